//! One contact record whatever the other side is (issue 18): a node against an obstacle is a stencil of one
//! node; a point of the sheet against a face of the sheet, or two edges, are stencils of four nodes with signed
//! weights whose off-diagonal blocks go into the step's extra pairs. Both through the shared finite-difference
//! checker, and action equals reaction for a stencil whose weights sum to zero.

use flexsurf::energy::{Operator, Sink};
use flexsurf::math::Vec3;
use flexsurf::potential::contact::{Contact, Other, Stencil};
use flexsurf::potential::{Context, Part, Scratch, Stage, Term, TermInfo};
use flexsurf::testing::{alone, check, value_gradient};

/// Penalty contacts of fixed stencils and normals, each linearised at the configuration it is evaluated at:
/// `½ c (δ − n·Σ wₖ xₖ)²` while positive.
#[derive(Debug, Clone)]
struct Records {
    stencils: Vec<(Stencil, Vec3)>,
    stiffness: f64,
    offset: f64,
}

impl Term for Records {
    fn info(&self) -> TermInfo {
        TermInfo::new("contact records", Stage::Contact, Part::Contact)
    }
    fn evaluate(&self, x: &[Vec3], cx: &Context, _s: &mut Scratch, sink: &mut Sink) -> f64 {
        let mut total = 0.0;
        for &(stencil, normal) in &self.stencils {
            let d = normal.dot(stencil.point(x));
            let force = self.stiffness * (self.offset - d);
            if force <= 0.0 {
                continue;
            }
            let c = Contact {
                stencil,
                other: Other::Sheet,
                normal,
                force,
                stiffness: self.stiffness,
                distance: d,
                reference: stencil.point(x),
            };
            let e = c.energy();
            sink.energy += e;
            total += e;
            c.add_to(cx, sink);
        }
        total
    }
}

/// Node 0 just above the triangle (1, 2, 3) in the plane z = 0 (barycentric (0.2, 0.3, 0.5)); nodes 4–7 two
/// crossing edges; node 8 alone above z = 0.
fn configuration() -> Vec<Vec3> {
    let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.1, 0.02), Vec3::new(0.1, 1.0, -0.01)];
    let b = [0.2, 0.3, 0.5];
    let inside = tri[0] * b[0] + tri[1] * b[1] + tri[2] * b[2];
    vec![
        inside + Vec3::new(0.0, 0.0, 0.003),
        tri[0],
        tri[1],
        tri[2],
        Vec3::new(-0.5, 0.0, 0.002),
        Vec3::new(0.5, 0.01, 0.001),
        Vec3::new(0.0, -0.5, -0.001),
        Vec3::new(0.02, 0.5, 0.0),
        Vec3::new(0.3, 0.3, 0.004),
    ]
}

fn records() -> Records {
    let up = Vec3::Z;
    Records {
        stencils: vec![
            (Stencil::of(&[0, 1, 2, 3], &[1.0, -0.2, -0.3, -0.5]), up),
            (Stencil::of(&[4, 5, 6, 7], &[0.5, 0.5, -0.5, -0.5]), up),
            (Stencil::node(8), up),
        ],
        stiffness: 300.0,
        offset: 0.01,
    }
}

#[test]
fn point_face_edge_edge_and_node_records_pass_the_checker() {
    let x = configuration();
    let potential = alone(x.len(), Box::new(records()));
    // The stencils couple nodes no pattern pair joins: their blocks are the step's extra pairs.
    assert_eq!(potential.pattern().blocks(), x.len());
    let report = check(&potential, &x, None, None, Operator::Exact);
    report.assert_below("contact records", 1e-6);
}

#[test]
fn a_record_whose_weights_sum_to_zero_pushes_both_sides_equally() {
    let x = configuration();
    let mut one = records();
    one.stencils.truncate(2);
    let potential = alone(x.len(), Box::new(one));
    let mut ws = flexsurf::potential::Workspace::new(&potential);
    let (energy, g) = value_gradient(&potential, &mut ws, &x, None, None);
    assert!(energy > 0.0, "the records touch");
    let net: Vec3 = g.iter().take(8).copied().sum();
    let scale = g.iter().map(|v| v.length()).fold(0.0, f64::max);
    assert!(scale > 0.1, "forces {scale} N");
    assert!(net.length() < 1e-12 * scale, "net force {net} of {scale} N");
    // The point is pushed up, the face down, in the barycentric shares.
    assert!(g[0].z < 0.0 && g[1].z > 0.0 && g[3].z > g[1].z);
}
