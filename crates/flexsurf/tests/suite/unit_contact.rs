//! Unit tests of the library, contact area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `contact` (`src/contact/mod.rs`).
mod contact {
    use flexsurf::contact::*;
    use flexsurf::math::Vec3;

    #[test]
    fn first_hit_catches_a_segment_through_a_ball() {
        let s = [Obstacle::Sphere { center: Vec3::ZERO, radius: 0.3 }];
        let mut cache = ContactCache::new(1, 1);
        // Straight through the centre, from 1 m above to 1 m below: both ends are far outside.
        let (t, x, d, n) =
            first_hit(&s, &mut cache, 0, Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0), 0.005).unwrap();
        assert!((0.0025..0.005).contains(&d) && (x.z - 0.3 - d).abs() < 1e-12 && (n - Vec3::Z).length() < 1e-12);
        assert!((t - (1.0 - 0.3 - d) / 2.0).abs() < 1e-12);
        // Beside the ball: no hit.
        let far = first_hit(&s, &mut cache, 0, Vec3::new(0.4, 0.0, 1.0), Vec3::new(0.4, 0.0, -1.0), 0.005);
        assert!(far.is_none());
        // Through it, and grazing it from outside.
        assert!(passes_inside(&s, &mut cache, 0, Vec3::new(0.1, 0.0, 1.0), Vec3::new(0.1, 0.0, -1.0), 1e-6));
        let graze =
            passes_inside(&s, &mut cache, 0, Vec3::new(-1.0, 0.0, 0.3 + 1e-7), Vec3::new(1.0, 0.0, 0.3 + 1e-7), 1e-6);
        assert!(!graze);
    }

    /// A body's query asked again of a node (the same point, radius and warm start) is answered from the cache
    /// with what it would compute: the same distance, normal and warm start, to the bit, whatever the order of
    /// the queries; a changed radius or point is asked anew (2 cm out with a radius of 1 cm: nothing found).
    #[test]
    fn a_repeated_body_query_recalls_what_it_would_compute() {
        let body = std::sync::Arc::new(flexsurf::contact::mannequin::generate());
        let obstacles = [Obstacle::Nurbs(body.clone())];
        let mut cache = ContactCache::new(1, 2);
        let mut hints = [None, None];
        let bits = |a: Option<(f64, Vec3)>| a.map(|(d, n)| [d.to_bits(), n.x.to_bits(), n.y.to_bits(), n.z.to_bits()]);
        for (i, z) in [0.85, 0.95, 1.05].into_iter().enumerate() {
            let surface = body.closest(Vec3::new(0.0, 0.3, z), None);
            let out = |cm: f64| surface.point + surface.normal * (0.01 * cm);
            let (a, b) = (i % 2, 1 - i % 2);
            let queries = [
                (out(2.0), 0.03, a),
                (out(2.0), 0.03, a),
                (out(2.0), 0.03, b),
                (out(2.0), 0.01, a),
                (out(1.5), 0.03, a),
            ];
            for (q, (p, radius, k)) in queries.into_iter().enumerate() {
                let expected = obstacles[0].distance_hinted(p, &mut hints[k], radius);
                let got = closest_cached(&obstacles, &mut cache, k, p, radius);
                assert_eq!(bits(got), bits(expected), "query {q} at z = {z}");
                assert_eq!(expected.is_none(), radius < 0.02, "query {q} at z = {z}: {expected:?}");
            }
        }
    }

    /// A NURBS body told a lower bound of the signed distance answers as without it: a point 5 cm inside the
    /// mannequin is found (its unbounded query still runs) with any bound at or below the radius's depth, and a
    /// point 3 cm outside is farther than a 1 cm radius with or without the bound that skips that query.
    #[test]
    fn a_body_told_a_distance_bound_answers_as_without_it() {
        let body = flexsurf::contact::mannequin::generate();
        let surface = body.closest(Vec3::new(0.0, 0.3, 0.95), None);
        let (inside, outside) = (surface.point - surface.normal * 0.05, surface.point + surface.normal * 0.03);
        for floor in [f64::NEG_INFINITY, -0.06, -0.01] {
            let (d, n) = body.distance_within_above(inside, &mut None, 0.01, floor).expect("a point 5 cm inside");
            assert!((d + 0.05).abs() < 1e-6 && (n - surface.normal).length() < 1e-6, "floor {floor}: {d}, {n:?}");
        }
        for floor in [f64::NEG_INFINITY, 0.0, 0.02] {
            assert_eq!(body.distance_within_above(outside, &mut None, 0.01, floor), None, "floor {floor}");
        }
    }

    /// A node 5 cm outside the mannequin and 0.95 m above a floor plane: the mannequin, farther than the
    /// detection's reach, declines the query, the plane answers 0.95 m, and that distance was recorded as the
    /// node's lower bound for every obstacle, so after the node moved 6 cm, 1 cm into the mannequin, its
    /// detection was skipped (0.89 m of bound left) and the penetration went unseen. The bound kept is now at
    /// most the reach of the query that found it.
    #[test]
    fn regression_a_far_plane_hid_the_mannequin_from_detection() {
        use flexsurf::potential::contact::{detect_predicted, ContactParams};
        let body = std::sync::Arc::new(flexsurf::contact::mannequin::generate());
        let surface = body.closest(Vec3::new(0.0, 0.3, 0.95), None);
        let floor = Obstacle::Plane { point: Vec3::new(0.0, 0.0, surface.point.z - 0.95), normal: Vec3::Z };
        let obstacles = [Obstacle::Nurbs(body), floor];
        let params = ContactParams { stiffness: 1e4, offset: 0.01, ..ContactParams::default() };
        let mut cache = ContactCache::new(2, 1);
        let mut found = Vec::new();
        let outside = [surface.point + surface.normal * 0.05];
        detect_predicted(&obstacles, &params, &[1e-4], &outside, &outside, &mut cache, &mut found);
        assert!(found.is_empty(), "5 cm out: {found:?}");
        let inside = [surface.point - surface.normal * 0.01];
        detect_predicted(&obstacles, &params, &[1e-4], &inside, &inside, &mut cache, &mut found);
        assert_eq!(found.len(), 1, "1 cm inside the mannequin: no contact");
        assert!((found[0].distance + 0.01).abs() < 1e-6, "{:?}", found[0]);
    }

    /// Detection with a node's cache kept from step to step finds what a cold detection finds: the same
    /// contacts, at the same distances to the projection's tolerance, on nodes swinging in and out of the
    /// mannequin's layer, beside a ball and a floor and alone (planes and balls answer every query: alone, the
    /// queries that find nothing leave the bounds). The queries look past the step's reach and leave bounds
    /// that skip the next detections ("Contact queries that look ahead", docs/performance.md).
    #[test]
    fn a_warm_detection_finds_what_a_cold_one_finds() {
        let body = std::sync::Arc::new(flexsurf::contact::mannequin::generate());
        let hip = body.closest(Vec3::new(0.0, 0.3, 0.95), None);
        let ball = Obstacle::Sphere { center: hip.point + Vec3::new(0.0, 0.3, 0.0), radius: 0.1 };
        let floor = Obstacle::Plane { point: Vec3::new(0.0, 0.0, hip.point.z - 0.1), normal: Vec3::Z };
        let obstacles = [Obstacle::Nurbs(body), ball, floor];
        for obstacles in [&obstacles[..], &obstacles[..1]] {
            let touched = warm_and_cold(obstacles, hip.point, hip.normal);
            assert!(touched > 200, "{} obstacles: the nodes met the layers {touched} times", obstacles.len());
        }
    }

    /// Sixty nodes swung along `normal` from `point` for 200 steps, detected with a kept cache and a fresh
    /// one: asserts they find the same contacts; returns how many.
    fn warm_and_cold(obstacles: &[Obstacle], point: Vec3, normal: Vec3) -> usize {
        use flexsurf::potential::contact::{detect_predicted, Contact, ContactParams};
        use rand::{Rng, SeedableRng};
        let params = ContactParams { stiffness: 1e4, offset: 0.005, ..ContactParams::default() };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // Node k swings about 1.5 cm out, 3 cm either way, with its own phase, and jitters by up to 2 mm; the
        // row spreads 30 cm sideways, to the ball.
        let at = |k: usize, t: f64, jitter: Vec3| {
            let swing = 0.015 + 0.03 * (0.08 * t + 0.37 * k as f64).sin();
            point + normal * swing + Vec3::new(0.0, 0.005 * k as f64, 0.0) + jitter
        };
        let mut jitter = || Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0) * 0.002;
        let mut x: Vec<Vec3> = (0..60).map(|k| at(k, 0.0, Vec3::ZERO)).collect();
        let area = vec![1e-4; x.len()];
        let mut cache = ContactCache::new(obstacles.len(), x.len());
        let (mut warm, mut cold, mut touched) = (Vec::new(), Vec::new(), 0);
        for step in 1..=200 {
            let y: Vec<Vec3> = (0..x.len()).map(|k| at(k, step as f64, jitter())).collect();
            detect_predicted(obstacles, &params, &area, &x, &y, &mut cache, &mut warm);
            let mut fresh = ContactCache::new(obstacles.len(), x.len());
            detect_predicted(obstacles, &params, &area, &x, &y, &mut fresh, &mut cold);
            let key = |c: &Contact| (c.node(), c.distance);
            let (w, c): (Vec<_>, Vec<_>) = (warm.iter().map(key).collect(), cold.iter().map(key).collect());
            assert_eq!(w.len(), c.len(), "step {step}: {w:?} against {c:?}");
            for ((kw, dw), (kc, dc)) in w.iter().zip(&c) {
                assert!(kw == kc && (dw - dc).abs() < 1e-9, "step {step}: {w:?} against {c:?}");
            }
            touched += w.len();
            x = y;
        }
        touched
    }

    #[test]
    fn sphere_and_plane_distances() {
        let s = Obstacle::Sphere { center: Vec3::ZERO, radius: 0.3 };
        let (d, n) = s.distance(Vec3::new(0.0, 0.0, 0.5));
        assert!((d - 0.2).abs() < 1e-15 && (n - Vec3::Z).length() < 1e-15);
        let p = Obstacle::Plane { point: Vec3::new(0.0, 0.0, -1.0), normal: Vec3::Z };
        assert!((p.distance(Vec3::new(3.0, 1.0, -1.5)).0 + 0.5).abs() < 1e-15);
    }
}

/// The tests of `contact::nurbs::patch` (`src/contact/nurbs/patch.rs`).
mod nurbs_patch {
    use flexsurf::contact::nurbs::*;
    use flexsurf::math::Vec3;

    fn bilinear() -> NurbsPatch {
        let pts = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        NurbsPatch::new([1, 1], vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0], pts, None).unwrap()
    }

    #[test]
    fn bilinear_closed_form() {
        let p = bilinear();
        for (u, v) in [(0.0, 0.0), (0.3, 0.7), (1.0, 0.25), (0.5, 1.0)] {
            let d = p.derivatives(u, v);
            assert!((d.point - Vec3::new(u, v, u * v)).length() < 1e-15);
            assert!((d.du - Vec3::new(1.0, 0.0, v)).length() < 1e-15);
            assert!((d.dv - Vec3::new(0.0, 1.0, u)).length() < 1e-15);
            assert!(d.duu.length() < 1e-15 && d.dvv.length() < 1e-15);
            assert!((d.duv - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-15);
        }
    }

    #[test]
    fn validation_names_the_problem() {
        let pts = vec![Vec3::ZERO; 4];
        let e = NurbsPatch::new([1, 1], vec![0.0, 0.0, 1.0], vec![0.0, 0.0, 1.0, 1.0], pts.clone(), None);
        assert!(matches!(e, Err(NurbsError::TooFewKnots { dir: Direction::U, .. })));
        let e = NurbsPatch::new(
            [1, 1],
            vec![0.0, 0.0, 1.0, 1.0],
            vec![0.0, 0.0, 1.0, 1.0],
            pts,
            Some(vec![1.0, -1.0, 1.0, 1.0]),
        );
        assert_eq!(e.unwrap_err().to_string(), "weights[1] is -1; weights must be positive and finite");
    }
}

/// The tests of `contact::proximity` (`src/contact/proximity.rs`).
mod proximity {
    use flexsurf::contact::proximity::internals::advance;
    use flexsurf::contact::proximity::*;
    use flexsurf::math::Vec3;

    fn square() -> (Faces, Vec<Vec3>) {
        // 3 × 3 nodes, 2 × 2 cells, spacing 1.
        let idx = |i: usize, j: usize| i + 3 * j;
        let cells =
            (0..2).flat_map(|j| (0..2).map(move |i| [idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)]));
        let x = (0..9).map(|k| Vec3::new((k % 3) as f64, (k / 3) as f64, 0.0)).collect();
        (Faces::new(9, cells), x)
    }

    #[test]
    fn a_flat_sheet_has_no_close_pairs_below_its_half_diagonal() {
        let (faces, x) = square();
        assert_eq!(faces.triangles.len(), 8);
        assert_eq!(faces.edges.len(), 16);
        assert!(faces.close(&x, 0.7).is_empty());
        let close = faces.close(&x, 1.5);
        assert!(!close.is_empty());
        assert!(close.iter().all(|c| c.distance() >= std::f64::consts::FRAC_1_SQRT_2 - 1e-12));
    }

    /// A step's candidates (swept from the start to a target, the radius grown by twice a slack) find the same
    /// close pairs and the same first touch as the whole broad phase, for any configuration within the slack.
    #[test]
    fn a_steps_candidates_find_what_the_broad_phase_finds() {
        let (faces, flat) = square();
        // Folded: the corner node 8 over the first cell, then moving through it.
        let mut start = flat.clone();
        start[8] = Vec3::new(0.4, 0.3, 0.3);
        let mut target = start.clone();
        target[8] = Vec3::new(0.5, 0.2, -0.2);
        let (radius, slack) = (0.2, 0.2);
        let candidates = faces.candidates(&start, Some(&target), radius + 2.0 * slack);
        for (k, z) in [0.25, 0.1, 0.0, -0.15, -0.35].iter().enumerate() {
            let mut x = target.clone();
            x[8] = Vec3::new(0.45, 0.25 + 0.01 * k as f64, *z);
            assert!(Faces::within(&x, &start, &target, slack));
            let pairs = |c: Vec<Closest>| c.into_iter().map(|c| c.pair).collect::<Vec<_>>();
            assert_eq!(
                pairs(faces.close_among(&candidates, &x, radius, true)),
                pairs(faces.close(&x, radius)),
                "z = {z}"
            );
            assert_eq!(
                faces.first_touch_among(&candidates, &start, &x, 1e-4),
                faces.first_touch(&start, &x, 1e-4),
                "z = {z}"
            );
        }
        let mut far = target.clone();
        far[8].z -= 0.5;
        assert!(!Faces::within(&far, &start, &target, slack));
    }

    #[test]
    fn a_node_above_a_face_is_close_and_crossing_is_caught() {
        let (faces, mut x) = square();
        // Fold node 8 (corner (2, 2)) over the first cell, 0.1 above it.
        x[8] = Vec3::new(0.4, 0.3, 0.1);
        let close = faces.close(&x, 0.2);
        assert!(close.iter().any(|c| c.pair == Pair::PointFace(8, 0) || c.pair == Pair::PointFace(8, 1)), "{close:?}");
        let c = close.iter().find(|c| matches!(c.pair, Pair::PointFace(8, _))).unwrap();
        assert!((c.distance() - 0.1).abs() < 1e-12);
        let mut to = x.clone();
        to[8] = Vec3::new(0.4, 0.3, -0.5);
        let (_, t) = faces.first_touch(&x, &to, 1e-4).expect("the node passes through the face");
        // The node reaches 1e-4 above the face at t = (0.1 − 1e-4) / 0.6 (its edges may meet others earlier).
        assert!(t < 0.1 / 0.6, "t = {t}");
        let node = advance(&faces, Pair::PointFace(8, 0), &x, &to, 1e-4).expect("the node meets the face");
        // Conservative advancement stops at or inside the tolerance, never past the face.
        assert!(((0.1 - 1e-4) / 0.6 - 1e-12..0.1 / 0.6).contains(&node), "t = {node}");
        to[8] = Vec3::new(0.4, 0.3, 0.05);
        assert!(faces.first_touch(&x, &to, 1e-4).is_none());
    }
}

/// The tests of `contact::shape` (`src/contact/shape.rs`).
mod shape {
    use flexsurf::contact::nurbs::Hint;
    use flexsurf::contact::shape::*;
    use flexsurf::contact::Obstacle;
    use flexsurf::grid::Grid;
    use flexsurf::integrate::{StepParams, Stepper};
    use flexsurf::material::{Calibration, Fabric, Stiffness};
    use flexsurf::math::Vec3;
    use flexsurf::model::{ModelBuilder, ModelKind};
    use flexsurf::potential::contact::ContactParams;
    use flexsurf::state::State;
    use std::sync::Arc;

    /// An axis-aligned box, written here as a user of the library would.
    #[derive(Debug)]
    struct Cuboid {
        min: Vec3,
        max: Vec3,
    }

    impl Shape for Cuboid {
        fn distance_within(&self, p: Vec3, _hint: &mut Option<Hint>, _radius: f64) -> Option<(f64, Vec3)> {
            let c = (self.min + self.max) * 0.5;
            let q = (p - c).abs() - (self.max - self.min) * 0.5;
            let outside = q.max(Vec3::ZERO);
            if outside.length() > 0.0 {
                let n = outside * (p - c).signum();
                return Some((outside.length(), n / n.length()));
            }
            // Inside: the nearest face.
            let a = (0..3).max_by(|&i, &j| q[i].total_cmp(&q[j])).unwrap_or(2);
            let mut n = Vec3::ZERO;
            n[a] = (p - c)[a].signum();
            Some((q[a], n))
        }
    }

    #[test]
    fn a_custom_shape_pushes_the_cloth_out() {
        let fabric = Fabric::paper_cotton();
        let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
        let g = Grid::sheet(5, 5, 0.4, 0.4).unwrap();
        let rest = g.flat_positions(0.0);
        let mut b = ModelBuilder::new(g, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::ZERO);
        let cuboid = Cuboid { min: Vec3::new(-0.1, -0.1, -0.5), max: Vec3::new(0.1, 0.1, 0.001) };
        b.obstacles.push(Obstacle::Custom(Arc::new(cuboid)));
        b.contact = ContactParams { stiffness: 1e4, offset: 0.005, friction: 0.0, ..ContactParams::default() };
        let model = b.build().unwrap();
        let centre = (0..rest.len()).min_by(|&i, &j| rest[i].length().total_cmp(&rest[j].length())).unwrap();
        let before = model.obstacles()[0].distance(rest[centre]).0;
        assert!(before < 0.0, "the centre node starts inside the box");
        let mut state = State::at_rest(rest);
        let mut stepper = Stepper::new(&model, &StepParams::with_dt(0.01)).unwrap();
        let info = stepper.step(&model, &mut state).unwrap();
        assert!(info.contacts > 0);
        let after = model.obstacles()[0].distance(state.x[centre]).0;
        assert!(after > before && state.x[centre].z > 0.0, "pushed out: {before} -> {after}");
        assert!(model.obstacles()[0].scaled(2.0).is_none() && model.obstacles()[0].look().is_none());
    }
}

/// The tests of `contact::trimesh` (`src/contact/trimesh.rs`).
mod trimesh {
    use flexsurf::contact::trimesh::*;
    use flexsurf::math::Vec3;

    #[test]
    fn display_mesh_keeps_the_body() {
        // A unit cube, quads fan-triangulated.
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                   f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        let body = TriMeshBody::from_obj_str(obj, "cube.obj").unwrap();
        let m = body.to_mesh();
        assert_eq!((m.vertex_count(), m.triangle_count()), (8, 12));
        assert!((m.area() - 6.0).abs() < 1e-12);
        assert!(body.distance(Vec3::new(0.5, 0.5, 2.0)).0 > 0.99);
    }

    /// Issue 22: one far-off vertex of a closed cube was reported as "inside out".
    #[test]
    fn regression_a_far_off_vertex_was_called_inside_out() {
        let faces = "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        let cube = |v7: &str| format!("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n{v7}\nv 0 1 1\n{faces}");
        for far in ["v -1e9 -1e9 -1e9", "v -1e5 -2e5 -1e5"] {
            let e = TriMeshBody::from_obj_str(&cube(far), "cube.obj").err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains("vertex, 7 ") && e.contains("stray vertex") && !e.contains("inside out"), "{far}: {e}");
        }
        // A cube wound the other way round is still inside out.
        let flipped: String = cube("v 1 1 1")
            .lines()
            .map(|l| match l.strip_prefix("f ") {
                Some(f) => format!("f {}\n", f.split(' ').rev().collect::<Vec<_>>().join(" ")),
                None => format!("{l}\n"),
            })
            .collect();
        let e = TriMeshBody::from_obj_str(&flipped, "cube.obj").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("inside out"), "{e}");
        assert!(TriMeshBody::from_obj_str(&cube("v 1 1 1"), "cube.obj").is_ok());
    }
}

/// The tests of `potential::contact` (`src/potential/contact.rs`).
mod potential_contact {
    use flexsurf::contact::Obstacle;
    use flexsurf::math::Vec3;
    use flexsurf::potential::contact::*;

    #[test]
    fn penalty_force() {
        let s = Obstacle::Sphere { center: Vec3::ZERO, radius: 1.0 };
        let params = ContactParams { stiffness: 100.0, offset: 0.01, friction: 0.5, slip_speed: 1e-4 };
        let mut out = Vec::new();
        detect(&[s], &params, &[0.5, 0.5], &[Vec3::new(0.0, 0.0, 0.995), Vec3::new(0.0, 0.0, 2.0)], &mut out);
        assert_eq!(out.len(), 1);
        // c a (δ − d) = 100 · 0.5 · (0.01 + 0.005).
        assert!((out[0].force - 0.75).abs() < 1e-12);
    }
}

/// The tests of `potential::friction` (`src/potential/friction.rs`).
mod friction {
    use flexsurf::math::{outer, Mat3, Vec3};
    use flexsurf::potential::friction::*;

    #[test]
    fn law_is_continuous_with_coulomb_limit_and_psd() {
        let law = FrictionLaw { limit: 2.0, eps: 1e-3 };
        // Continuity of value and force at s = ε, the Coulomb magnitude beyond it, zero force at rest.
        assert!((law.energy(1e-3 * (1.0 - 1e-12)) - law.energy(1e-3)).abs() < 1e-12);
        assert!((law.force(1e-3 * (1.0 - 1e-9)) - 2.0).abs() < 1e-8);
        assert_eq!(law.force(0.5), 2.0);
        assert_eq!(law.force(0.0), 0.0);
        let p = Mat3::IDENTITY - outer(Vec3::Z, Vec3::Z);
        for &s in &[0.0, 2e-4, 9e-4, 1e-3, 3e-3, 1.0] {
            let u = Vec3::new(0.6, 0.8, 0.0) * s;
            let h = law.hessian(u, p);
            // The three eigen-directions: along u, across u in the plane, the normal.
            for d in [Vec3::new(0.6, 0.8, 0.0), Vec3::new(-0.8, 0.6, 0.0), Vec3::Z] {
                assert!(d.dot(h * d) >= -1e-12, "s = {s}: {}", d.dot(h * d));
            }
            assert!((h * Vec3::Z).length() < 1e-12);
        }
    }

    #[test]
    fn majorant_touches_and_bounds_the_potential() {
        let law = FrictionLaw { limit: 1.5, eps: 1e-3 };
        let p = Mat3::IDENTITY - outer(Vec3::Z, Vec3::Z);
        let dir = Vec3::new(0.6, -0.8, 0.0);
        for &sl in &[1e-5, 5e-4, 1e-3, 2e-3, 0.1] {
            let (v, g, _) = law.majorant(sl, dir * sl, p);
            assert!((v - law.energy(sl)).abs() < 1e-12 * (1.0 + v.abs()));
            assert!((g - law.gradient(dir * sl)).length() < 1e-9);
            for &s in &[0.0, 1e-4, 8e-4, 1.5e-3, 0.05, 1.0] {
                assert!(law.majorant(sl, dir * s, p).0 >= law.energy(s) - 1e-12, "s_l = {sl}, s = {s}");
            }
        }
    }

    /// A step's first model (`Lagged::predict`): a node that stuck keeps its last slip and the majorant; one that
    /// slid steadily the tangent model about `(1.5 v − 0.5 v⁻) Δt`; one whose slip reversed over the last step
    /// the majorant about that slip, whose force at any slip resists it (the tangent model about a slip that
    /// reverses again pushes the node along its motion: the 21² drop's zig-zag, tests/suite/continuity.rs).
    #[test]
    fn a_steps_first_model_resists_a_reversing_node() {
        let (dt, eps) = (0.01, 1e-6);
        let law = FrictionLaw { limit: 1.0, eps };
        let fresh = || Lagged { node: 0, limit: 1.0, normal: Vec3::Z, at: Vec3::ZERO, majorant: false };
        let (x, tilt) = (Vec3::X, Vec3::new(0.0, 0.0, 3.0));
        let mut stuck = fresh();
        stuck.predict(x * 4e-7 + tilt * 1e-7, x * 4e-5, x * 4e-5, dt, eps);
        assert!(stuck.majorant && (stuck.at - x * 4e-7).length() < 1e-18, "{stuck:?}");
        let mut steady = fresh();
        steady.predict(x * 1e-4, x * 0.012 + tilt, x * 0.010, dt, eps);
        assert!(!steady.majorant && (steady.at - x * 1.3e-4).length() < 1e-15, "{steady:?}");
        let mut reversing = fresh();
        reversing.predict(x * -1e-4, x * -0.01, x * 0.01 + tilt, dt, eps);
        assert!(reversing.majorant && (reversing.at - x * -2e-4).length() < 1e-15, "{reversing:?}");
        // The slip reverses again in the step: the tangent model's force would push along it, the majorant's resists.
        let back = x * 5e-5;
        let along = |l: &Lagged| -l.model(&law, back).1.dot(back);
        let mut tangent = reversing;
        tangent.majorant = false;
        assert!(along(&tangent) > 0.0 && along(&reversing) < 0.0, "{} {}", along(&tangent), along(&reversing));
    }
}

/// Held records of the obstacle contact (`potential/contact.rs`, `ActiveSet::hold`).
mod penalty_hold {
    use flexsurf::contact::Obstacle;
    use flexsurf::math::Vec3;
    use flexsurf::potential::contact::{ContactParams, PenaltyContact};
    use flexsurf::potential::{Pins, Potential, Want, Workspace};

    /// One free node (area 0.01 m²) 2 cm over a ball of radius 0.3 m; a solve proposes it 2 mm under the
    /// surface, tilted off the pole, and the refinement gives it a contact linearised there. Held, an assembly
    /// 5 cm along the tangent plane keeps that record, its push the penalty of the linearised gap
    /// `c a (δ − d(q) − n·(p − q))` along `n` at the proposal `q`; released, the assembly finds the contact at
    /// `p` itself, `c a (δ − (|p| − R))` along `p/|p|`.
    #[test]
    fn a_held_record_keeps_its_linear_gap_where_detection_would_not() {
        let (radius, offset, c, area) = (0.3, 0.005, 1e4, 0.01);
        let ball = Obstacle::Sphere { center: Vec3::ZERO, radius };
        let params = ContactParams { stiffness: c, offset, friction: 0.0, ..ContactParams::default() };
        let potential =
            Potential::new(1, vec![Box::new(PenaltyContact::new(vec![ball], params, vec![area]))], Pins::none(1));
        let mut ws = Workspace::new(&potential);
        let cx = potential.context(None);
        let start = [Vec3::new(0.0, 0.0, radius + 0.02)];
        potential.assemble(&start, &cx, None, Want::GRADIENT, &mut ws);
        assert!(!potential.engaged(&ws), "2 cm over the ball is outside the 5 mm layer");
        let n = Vec3::new(0.1, 0.0, 1.0).normalize();
        let q = n * (radius - 0.002);
        let delta = [q - start[0]];
        assert!(potential.refine(&start, &delta, &cx, Want::GRADIENT, &mut ws), "the proposal entered the layer");
        assert!(potential.can_hold(&[q], &ws), "2 mm under the surface is within the offset");
        potential.hold(&mut ws, true);
        let p = q + Vec3::new(n.z, 0.0, -n.x) * 0.05;
        potential.assemble(&[p], &cx, None, Want::GRADIENT, &mut ws);
        let held = n * (c * area * (offset + 0.002 - n.dot(p - q)));
        assert!((-ws.grad[0] - held).length() < 1e-9 * held.length(), "held: {:?} against {held:?}", -ws.grad[0]);
        potential.hold(&mut ws, false);
        potential.assemble(&[p], &cx, None, Want::GRADIENT, &mut ws);
        let found = p.normalize() * (c * area * (offset - (p.length() - radius)));
        assert!((-ws.grad[0] - found).length() < 1e-9 * found.length(), "found: {:?} against {found:?}", -ws.grad[0]);
        assert!((held - found).length() > 0.05 * found.length(), "the two should differ on the curved ball");
        // Deeper than the offset under the surface, the proposal's record is not held.
        assert!(!potential.can_hold(&[n * (radius - 0.006)], &ws));
    }
}

mod friction_misfit {
    use flexsurf::potential::friction::Misfit;

    /// The converge rule's measure of friction's model error (the root mean square over the records) and the
    /// violent rule's (the largest record), by hand: records off by 0.3 and 0.4 of the largest limit, and a
    /// term without records.
    #[test]
    fn the_misfit_keeps_the_largest_record_and_the_root_mean_square() {
        let mut a = Misfit::default();
        assert_eq!((a.largest, a.rms()), (0.0, 0.0));
        a.add(0.3);
        a.add(0.4);
        assert_eq!(a.largest, 0.4);
        assert!((a.rms() - 0.125f64.sqrt()).abs() < 1e-15);
        let mut many = Misfit::default();
        (0..198).for_each(|_| many.add(0.0));
        let all = many.merge(a).merge(Misfit::default());
        assert_eq!((all.largest, all.count), (0.4, 200));
        // Two flickering records among two hundred: 3.5 % in the mean square, under the 5 % the rule iterates on.
        assert!((all.rms() - 0.00125f64.sqrt()).abs() < 1e-15);
    }
}
