//! Small dense 3×3 algebra shared by the virtual tests: the determinant and Cramer's rule, used by the
//! cantilever (the bias strip's compliance, the Kirchhoff rod's Newton shooting) and the KES bending fit (the
//! least-squares parabola's normal equations).

/// A 3×3 matrix, by rows.
pub type Mat3 = [[f64; 3]; 3];

/// Determinant of a 3×3 matrix (rows).
pub fn det3(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// `m` with its column `j` replaced by `col` (the numerator matrix of Cramer's rule for unknown `j`).
pub fn with_column(m: &Mat3, j: usize, col: [f64; 3]) -> Mat3 {
    let mut mj = *m;
    for i in 0..3 {
        mj[i][j] = col[i];
    }
    mj
}
