//! Unit tests of the library, surface area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `surface::coons` (`src/surface/coons.rs`).
mod coons {
    use flexsurf::grid::Grid;
    use flexsurf::grid::Topology;
    use flexsurf::math::Vec3;
    use flexsurf::surface::coons::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random smooth map of the parameter plane (periodic in u1 with period `l1` when `wrap1`).
    fn deformed(grid: &Grid, seed: u64) -> Vec<Vec3> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let coef: Vec<f64> = (0..12).map(|_| rng.random_range(-1.0..1.0)).collect();
        let l1 = grid.h1 * grid.spans(0) as f64;
        let wrap1 = grid.periodic(0);
        (0..grid.len())
            .map(|k| {
                let (i, j) = grid.coords(k);
                let (u, v) = (i as f64 * grid.h1, j as f64 * grid.h2);
                if wrap1 {
                    let th = std::f64::consts::TAU * u / l1;
                    let r = 1.0 + 0.2 * coef[0] * (2.0 * th).sin() + 0.1 * coef[1] * v;
                    Vec3::new(r * th.cos(), r * th.sin(), v + 0.1 * coef[2] * (th + v).sin())
                } else {
                    Vec3::new(
                        u + 0.3 * coef[3] * (1.7 * v).sin() + 0.2 * coef[4] * u * v,
                        v + 0.3 * coef[5] * (1.3 * u + coef[6]).cos(),
                        0.5 * coef[7] * (u * u - v) + 0.4 * coef[8] * (2.0 * u + 3.0 * v * coef[9]).sin(),
                    )
                }
            })
            .collect()
    }

    fn close(a: Vec3, b: Vec3, scale: f64) -> bool {
        (a - b).length() <= 1e-12 * scale.max(1.0)
    }

    #[test]
    fn interpolates_nodes() {
        for topo in [[Topology::Free; 2], [Topology::Periodic, Topology::Free]] {
            let g = Grid::new(7, 5, 0.3, 0.2, topo).unwrap();
            let x = deformed(&g, 1);
            let s = CoonsSurface::new(&g, &x);
            let (s1, s2) = s.cells();
            for cj in 0..s2 {
                for ci in 0..s1 {
                    let nodes = g.cell(ci, cj);
                    for (c, &(t1, t2)) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)].iter().enumerate() {
                        assert!(close(s.eval(ci, cj, t1, t2).point, x[nodes[c]], 0.0));
                    }
                }
            }
        }
    }

    #[test]
    fn c1_across_cell_edges() {
        let topologies = [
            [Topology::Free, Topology::Free],
            [Topology::Periodic, Topology::Free],
            [Topology::Free, Topology::Periodic],
            [Topology::Periodic, Topology::Periodic],
        ];
        for (seed, topo) in topologies.into_iter().enumerate() {
            let g = Grid::new(8, 6, 0.25, 0.3, topo).unwrap();
            let x = deformed(&g, 10 + seed as u64);
            let s = CoonsSurface::new(&g, &x);
            let scale = x.iter().map(|p| p.length()).fold(0.0, f64::max);
            let (s1, s2) = s.cells();
            let ts = [0.0, 0.17, 0.5, 0.83, 1.0];
            for cj in 0..s2 {
                for ci in 0..s1 {
                    // Right neighbour (wrapping when periodic).
                    if ci + 1 < s1 || g.periodic(0) {
                        let cn = (ci + 1) % s1;
                        for &t in &ts {
                            let (p, q) = (s.eval(ci, cj, 1.0, t), s.eval(cn, cj, 0.0, t));
                            assert!(close(p.point, q.point, scale));
                            assert!(close(p.d1, q.d1, scale));
                            assert!(close(p.d2, q.d2, scale));
                        }
                    }
                    if cj + 1 < s2 || g.periodic(1) {
                        let cn = (cj + 1) % s2;
                        for &t in &ts {
                            let (p, q) = (s.eval(ci, cj, t, 1.0), s.eval(ci, cn, t, 0.0));
                            assert!(close(p.point, q.point, scale));
                            assert!(close(p.d1, q.d1, scale));
                            assert!(close(p.d2, q.d2, scale));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let g = Grid::new(5, 5, 0.3, 0.4, [Topology::Free; 2]).unwrap();
        let x = deformed(&g, 3);
        let s = CoonsSurface::new(&g, &x);
        let (t1, t2, e) = (0.37, 0.61, 1e-6);
        let sp = s.eval(1, 2, t1, t2);
        let fd1 = (s.eval(1, 2, t1 + e, t2).point - s.eval(1, 2, t1 - e, t2).point) / (2.0 * e);
        let fd2 = (s.eval(1, 2, t1, t2 + e).point - s.eval(1, 2, t1, t2 - e).point) / (2.0 * e);
        assert!((sp.d1 - fd1).length() < 1e-8);
        assert!((sp.d2 - fd2).length() < 1e-8);
    }

    #[test]
    fn flat_grid_tessellates_flat() {
        let g = Grid::sheet(6, 4, 1.0, 0.6).unwrap();
        let x = g.flat_positions(0.25);
        let s = CoonsSurface::new(&g, &x);
        for k in [1, 3] {
            let m = s.tessellate(k);
            assert_eq!(m.triangle_count(), 2 * k * k * 5 * 3);
            assert_eq!(m.vertex_count(), (5 * k + 1) * (3 * k + 1));
            assert!(m.validate().is_ok());
            assert!(m.positions.iter().all(|p| (p.z - 0.25).abs() < 1e-14));
            assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-12));
            assert!((m.area() - 0.6).abs() < 1e-12);
            // Every triangle faces +z (counter-clockwise seen from the normal side).
            for t in 0..m.triangle_count() {
                let [a, b, c] = m.triangle(t).unwrap();
                assert!((b - a).cross(c - a).z > 0.0);
            }
        }
    }

    #[test]
    fn periodic_tessellation_wraps() {
        let g = Grid::new(12, 4, 0.5, 0.3, [Topology::Periodic, Topology::Free]).unwrap();
        let x = deformed(&g, 7);
        let s = CoonsSurface::new(&g, &x);
        let k = 4;
        let m = s.tessellate(k);
        assert_eq!(m.triangle_count(), 2 * k * k * g.cells().count());
        assert_eq!(m.vertex_count(), (12 * k) * (3 * k + 1));
        assert!(m.validate().is_ok());
        // Each vertex is used, so no seam duplicates dangle.
        let mut used = vec![false; m.vertex_count()];
        m.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
        assert!(used.iter().all(|&u| u));
        assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
        assert_eq!(
            CoonsSurface::try_new(&g, &x[1..]).unwrap_err(),
            SurfaceError::PositionCount { expected: 48, got: 47 }
        );
    }
}

/// The tests of `surface::footprint` (`src/surface/footprint.rs`).
mod footprint {
    use flexsurf::surface::footprint::*;
    use flexsurf::surface::CoonsSurface;

    #[test]
    fn footprint_of_a_flat_square() {
        let g = flexsurf::grid::Grid::sheet(5, 5, 1.0, 0.5).unwrap();
        let mesh = CoonsSurface::new(&g, &g.flat_positions(0.3)).tessellate(2);
        let a = projected_area_xy(&mesh, 512);
        assert!((a - 0.5).abs() < 1e-9, "{a}");
    }
}

/// The tests of `surface::mesh` (`src/surface/mesh.rs`).
mod mesh {
    use flexsurf::math::Vec3;
    use flexsurf::surface::mesh::*;

    fn quad() -> TriMesh {
        TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: vec![],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn bbox_area_normals() {
        let mut m = quad();
        let b = m.bbox().unwrap();
        assert_eq!(b.min, Vec3::ZERO);
        assert_eq!(b.max, Vec3::new(1.0, 1.0, 0.0));
        assert!((m.area() - 1.0).abs() < 1e-15);
        assert!(m.validate().is_ok());
        m.recompute_normals();
        assert!(m.normals.iter().all(|&n| (n - Vec3::Z).length() < 1e-15));
        let other = quad();
        m.append(&other);
        assert_eq!(m.vertex_count(), 8);
        assert_eq!(m.triangles[3], [4, 6, 7]);
        assert!(m.has_normals());
        assert!(TriMesh::new().bbox().is_none());
    }

    #[test]
    fn validation_errors() {
        let mut m = quad();
        m.triangles.push([0, 1, 9]);
        assert!(matches!(m.validate(), Err(MeshError::IndexOutOfRange { triangle: 2, index: 9, .. })));
        assert!(m.triangle(2).is_none());
        let mut m = quad();
        m.normals = vec![Vec3::Z];
        assert!(matches!(m.validate(), Err(MeshError::NormalCount { .. })));
    }
}
