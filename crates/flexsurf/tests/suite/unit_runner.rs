//! Unit tests of the library, runner area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `runner::checkpoint` (`src/runner/checkpoint.rs`).
mod checkpoint {
    use flexsurf::integrate::linsolve::SolverWarm;
    use flexsurf::integrate::Counters;
    use flexsurf::potential::WarmState;
    use flexsurf::runner::checkpoint::*;
    use flexsurf::runner::outputs::OutputState;
    use flexsurf::sim::RunStats;
    use flexsurf::state::State;

    /// The checkpoint format's first bytes (`checkpoint::MAGIC`).
    const MAGIC: &[u8] = b"flexsurf-checkpoint\n";
    use flexsurf::math::Vec3;

    fn sample() -> Checkpoint {
        Checkpoint {
            fingerprint: "abc".into(),
            state: State::at_rest(vec![Vec3::new(1.0, f64::NEG_INFINITY, 0.1 + 0.2); 3]),
            warm: WarmState::empty(),
            counters: Counters::default().into(),
            solver: SolverWarm::default(),
            stats: RunStats { steps: 3, wall_seconds: 0.5, max_penetration_seen: 1e-3, max_contacts: 2 }.into(),
            outputs: vec![("energy".into(), OutputState::of(&99u64).unwrap())],
        }
    }

    #[test]
    fn round_trip_is_exact_and_damage_is_detected() {
        let ck = sample();
        let bytes = encode(&ck).unwrap();
        let back = decode(&bytes).unwrap();
        assert_eq!(back.state.x[0].to_array().map(f64::to_bits), ck.state.x[0].to_array().map(f64::to_bits));
        assert_eq!(back, Checkpoint { state: back.state.clone(), ..ck.clone() });
        let mut damaged = bytes.clone();
        let last = damaged.len() - 1;
        damaged[last] ^= 1;
        assert!(decode(&damaged).unwrap_err().contains("checksum"));
        let mut other = bytes.clone();
        other[MAGIC.len()] = 99;
        assert!(decode(&other).unwrap_err().contains("version 99"));
        assert!(decode(b"hello").unwrap_err().contains("not a flexsurf checkpoint"));
        assert!(decode(&bytes[..MAGIC.len() + 10]).unwrap_err().contains("truncated"));
    }
}

/// The tests of `runner::fields` (`src/runner/fields.rs`).
// Node loops index several arrays by node (the library allows the lint for the same reason, `src/lib.rs`).
#[allow(clippy::needless_range_loop)]
mod fields {
    use flexsurf::energy::frame::Warp;
    use flexsurf::grid::Grid;
    use flexsurf::grid::Topology;
    use flexsurf::math::Vec3;
    use flexsurf::model::Panel;
    use flexsurf::runner::fields::internals::{display_counts, panel_topology};
    use flexsurf::runner::fields::*;
    use flexsurf::surface::CoonsSurface;

    #[test]
    fn display_stencil_matches_the_tessellation() {
        for topology in [[Topology::Free, Topology::Free], [Topology::Periodic, Topology::Free]] {
            let g = Grid::new(5, 4, 0.1, 0.2, topology).unwrap();
            let x: Vec<Vec3> = (0..g.len())
                .map(|n| {
                    let (i, j) = g.coords(n);
                    Vec3::new(i as f64 * 0.1, j as f64 * 0.2, 0.05 * (i * j) as f64)
                })
                .collect();
            let k = 3;
            let mesh = CoonsSurface::new(&g, &x).tessellate(k);
            let panel = Panel::contiguous(g, 0, g.flat_positions(0.0));
            let topo = panel_topology(&panel, k);
            // Warp a quarter turn from u1: u along u2, v against u1.
            let turned = panel_topology(&panel.with_warp(Warp::Angle(std::f64::consts::FRAC_PI_2)), k);
            assert_eq!(turned.triangles, topo.triangles);
            for (t, u) in turned.uv.iter().zip(&topo.uv) {
                assert!((t[0] - u[1]).abs() < 1e-6 && (t[1] + u[0]).abs() < 1e-6, "{t:?} against {u:?}");
            }
            assert_eq!(topo.uv.len(), mesh.vertex_count());
            assert_eq!(topo.triangles, mesh.triangles);
            // Blending the node positions gives the display vertex at the grid nodes exactly.
            let blended = to_display(&g, k, &x);
            for n in 0..g.len() {
                let (i, j) = g.coords(n);
                let v = (i * k) + display_counts(&g, k).0 * (j * k);
                assert!((blended[v] - x[n]).length() < 1e-12);
                assert!((mesh.positions[v] - x[n]).length() < 1e-12);
                assert!((f64::from(topo.uv[v][0]) - i as f64 * 0.1).abs() < 1e-6);
                assert!((f64::from(topo.uv[v][1]) - j as f64 * 0.2).abs() < 1e-6);
            }
            // A third of the way along the first cell edge.
            assert!((f64::from(topo.uv[1][0]) - 0.1 / 3.0).abs() < 1e-6);
            assert!((blended[1] - (x[0] * (2.0 / 3.0) + x[1] * (1.0 / 3.0))).length() < 1e-12);
        }
    }

    #[test]
    fn panels_are_merged_in_order_and_one_panel_is_its_own_tessellation() {
        let (a, b) = (Grid::sheet(3, 3, 0.5, 0.5).unwrap(), Grid::sheet(4, 3, 0.2, 0.3).unwrap());
        let panels = [Panel::contiguous(a, 0, a.flat_positions(0.0)), Panel::contiguous(b, 9, b.flat_positions(0.0))];
        let x: Vec<Vec3> = (0..21).map(|n| Vec3::new(0.1 * n as f64, (n % 3) as f64, 0.01 * (n * n) as f64)).collect();
        let k = 2;
        // 2 × 2 cells × 2 subdivisions: 5 × 5 display vertices; 3 × 2 cells: 7 × 5.
        let (na, nb) = (25, 35);
        let mesh = coons_mesh(&panels, &x, k);
        assert_eq!(mesh.vertex_count(), na + nb);
        assert_eq!(mesh.triangles.len(), 2 * (4 * 4) + 2 * (6 * 4));
        let first = CoonsSurface::new(&a, &x[..9]).tessellate(k);
        let second = CoonsSurface::new(&b, &x[9..]).tessellate(k);
        assert_eq!(coons_mesh(&panels[..1], &x[..9], k), first);
        assert_eq!(mesh.positions[na..], second.positions[..]);
        assert_eq!(mesh.triangles[first.triangles.len()], second.triangles[0].map(|v| v + na as u32));
        let topo = display_topology(&panels, k);
        assert_eq!((topo.uv.len(), &topo.triangles), (na + nb, &mesh.triangles));
        // The second panel's pattern coordinates start at its own origin; a 0.2 m × 0.3 m sheet, its far corner at (0.2, 0.3) m.
        assert_eq!(topo.uv[na], [0.0, 0.0]);
        assert!((f64::from(topo.uv[na + nb - 1][0]) - 0.2).abs() < 1e-6);
        assert!((f64::from(topo.uv[na + nb - 1][1]) - 0.3).abs() < 1e-6);
        // Node values reach the display vertices panel by panel: the corner nodes keep theirs.
        let blended = panels_to_display(&panels, k, &x);
        assert!((blended[na] - x[9]).length() < 1e-12 && (blended[na + nb - 1] - x[20]).length() < 1e-12);
    }
}

/// The tests of `runner::manifest` (`src/runner/manifest.rs`).
mod manifest {
    use flexsurf::runner::manifest::internals::{frame_name, plain_relative, stale_temp};

    #[test]
    fn temporary_and_frame_names() {
        let owned = |n: &str| n == "energy.csv" || frame_name(n);
        assert!(stale_temp(".energy.csv.tmp.123.0", &owned));
        assert!(stale_temp(".frame_00010.obj.tmp.9.12", &owned));
        assert!(!stale_temp(".energy.csv.tmp.123.x", &owned));
        assert!(!stale_temp(".notes.txt.tmp.1.2", &owned));
        assert!(!stale_temp("energy.csv", &owned));
        assert!(frame_name("frame_00001.ply") && !frame_name("frame_.obj") && !frame_name("frame_01"));
        assert!(plain_relative("frames/a.obj").is_some());
        assert!(
            plain_relative("../x").is_none() && plain_relative("/etc/passwd").is_none() && plain_relative("").is_none()
        );
    }
}

/// The tests of `runner::outputs` (`src/runner/outputs/mod.rs`).
mod outputs {
    use flexsurf::runner::outputs::*;

    #[test]
    fn output_steps_end_at_the_last_step() {
        assert_eq!(output_steps(300, 100), vec![0, 100, 200, 300]);
        assert_eq!(output_steps(250, 100), vec![0, 100, 200, 250]);
        assert_eq!(output_steps(5, 0), vec![0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn animation_steps_hold_every_output_step() {
        assert_eq!(animation_steps(12, 5, 4), vec![0, 4, 5, 8, 10, 12]);
        assert_eq!(animation_steps(300, 100, 5).len(), 61);
        assert_eq!(animation_steps(7, 7, 100), vec![0, 7]);
    }
}

/// The tests of `runner::outputs::energy` (`src/runner/outputs/energy.rs`).
mod outputs_energy {
    use flexsurf::runner::outputs::energy::internals::energy_rows;

    #[test]
    fn rows_are_parsed_and_bad_lines_skipped() {
        assert_eq!(energy_rows("step,time,k,m,b,p\n0,0,1,2,3,4\nbad\n"), vec![[0.0, 1.0, 2.0, 3.0, 4.0]]);
    }
}

/// The tests of `runner::outputs::frames` (`src/runner/outputs/frames.rs`).
mod outputs_frames {
    use flexsurf::runner::outputs::frames::*;
    use flexsurf::scene::FrameFormat;

    #[test]
    fn every_frame_format_writes_a_file_named_after_it() {
        let dir = crate::scratch_dir("frame-formats");
        let mesh = flexsurf::testing::test_mesh();
        for format in [FrameFormat::Obj, FrameFormat::Ply, FrameFormat::Gltf] {
            let path = dir.join(format!("mesh.{}", format.extension()));
            write_mesh(&path, &mesh, format).unwrap();
            assert!(std::fs::metadata(&path).unwrap().len() > 0);
            assert_eq!(serde_json::to_value(format).unwrap().as_str(), Some(format.extension()));
        }
        assert_eq!(frame_file(42, FrameFormat::Ply), "frames/frame_00042.ply");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The tests of `runner::outputs::snapshots` (`src/runner/outputs/snapshots.rs`).
mod outputs_snapshots {
    use flexsurf::runner::outputs::snapshots::internals::spread;

    #[test]
    fn pictured_steps_are_spread_evenly() {
        assert_eq!(spread(&(0..=20).collect::<Vec<_>>(), 5), vec![0, 5, 10, 15, 20]);
        assert_eq!(spread(&[0, 1, 2], 8), vec![0, 1, 2]);
    }
}

/// The tests of `runner::plots` (`src/runner/plots.rs`).
mod plots {
    use flexsurf::runner::plots::internals::tick_format;
    use flexsurf::runner::plots::*;

    #[test]
    fn a_chart_draws_its_lines() {
        let d = crate::scratch_dir("chart");
        let p = d.join("c.png");
        let s = Series {
            name: "a".into(),
            color: [214, 39, 40],
            points: vec![(0.0, 0.0), (1.0, 2.0), (2.0, 1.0)],
            dots: true,
        };
        line_chart(&p, (400, 300), "a chart", "x (s)", "y (J)", &[s]).unwrap();
        let img = image::open(&p).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (400, 300));
        let red = img.pixels().filter(|p| p.0[0] > 180 && p.0[1] < 90 && p.0[2] < 90).count();
        let text = img.pixels().filter(|p| p.0.iter().all(|&c| c < 90)).count();
        assert!(red > 200, "{red} line pixels");
        assert!(text > 100, "{text} text pixels");
        // No points at all still gives a chart (empty axes), not an error.
        line_chart(&p, (300, 200), "empty", "x", "y", &[]).unwrap();
        let f = tick_format(0.25);
        assert_eq!((f(&-0.05), f(&1e-12), f(&0.1)), ("-0.050".to_string(), "0.000".to_string(), "0.100".to_string()));
        assert_eq!(tick_format(2e-6)(&1e-6), "1.00e-6");
        std::fs::remove_dir_all(&d).unwrap();
    }
}

/// The tests of `runner::viewer` (`src/runner/viewer/mod.rs`).
mod viewer {
    use flexsurf::runner::outputs::glb::GLB_FILE;
    use flexsurf::runner::viewer::*;

    /// The page template (`viewer::TEMPLATE`) and its one data slot (`viewer::SLOT`).
    const TEMPLATE: &str = include_str!("../../src/runner/viewer/view.html");
    const SLOT: &str = "__FLEXSURF_DATA__";

    #[test]
    fn missing_or_wrong_inputs_are_named() {
        let d = crate::scratch_dir("viewer");
        let e = write_view(&d).unwrap_err();
        assert!(matches!(e, ViewError::NoAnimation(_)), "{e}");
        assert!(e.to_string().contains("animation.glb"), "{e}");
        std::fs::write(d.join(GLB_FILE), b"not a glb at all").unwrap();
        let e = write_view(&d).unwrap_err().to_string();
        assert!(e.contains("animation.glb") && e.contains("magic"), "{e}");
        assert!(!d.join(VIEW_FILE).exists());
        // The template has exactly one data slot, and no address outside the page.
        assert_eq!(TEMPLATE.matches(SLOT).count(), 1);
        assert!(!TEMPLATE.contains("http://") && !TEMPLATE.contains("https://"));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
