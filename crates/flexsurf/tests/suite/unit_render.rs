//! Unit tests of the library, render area: moved from `#[cfg(test)]` modules beside the code (docs/testing.md).

/// The tests of `io::render::annotate` (`src/io/render/annotate.rs`).
mod annotate {
    use flexsurf::io::render::annotate::*;
    use flexsurf::io::render::View;
    use flexsurf::math::Vec3;
    use image::Rgb;
    use image::RgbImage;

    #[test]
    fn round_lengths_and_projection() {
        assert_eq!(round_length(0.27), (0.2, "20 cm".to_string()));
        assert_eq!(round_length(0.6).1, "50 cm");
        assert_eq!(round_length(3.0).1, "2 m");
        assert_eq!(round_length(0.0042).1, "2 mm");
        let view = View::look_at(Vec3::new(0.0, -3.0, 0.0), Vec3::ZERO);
        let c = project(&view, 200, 100, Vec3::ZERO).unwrap();
        assert!((c[0] - 100.0).abs() < 1e-9 && (c[1] - 50.0).abs() < 1e-9);
        // One metre to the right at the target's depth is pixels_per_metre to the right.
        let p = project(&view, 200, 100, Vec3::X).unwrap();
        assert!((p[0] - 100.0 - pixels_per_metre(&view, 100)).abs() < 1e-6);
        assert!(project(&view, 200, 100, Vec3::new(0.0, -5.0, 0.0)).is_none());
        let mut img = RgbImage::from_pixel(200, 100, Rgb([255, 255, 255]));
        scale_bar(&mut img, &view);
        axis_triad(&mut img, &view);
        let dark = img.pixels().filter(|p| p.0[0] < 100 && p.0[1] < 100).count();
        assert!(dark > 50, "{dark}");
    }
}

/// The tests of `io::render::frame` (`src/io/render/frame.rs`).
mod frame {
    use crate::scratch_dir;
    use flexsurf::grid::Grid;
    use flexsurf::io::render::*;
    use flexsurf::math::Vec3;
    use flexsurf::surface::coons::CoonsSurface;
    use flexsurf::surface::mesh::TriMesh;
    use image::{Rgb, RgbImage};

    fn is_bg(p: &Rgb<u8>, bg: [u8; 3]) -> bool {
        p.0 == bg
    }

    #[test]
    fn sphere_centre_is_foreground_corner_is_background() {
        let c = Vec3::new(0.3, -0.2, 1.0);
        let scene = [Drawable::sphere(c, 0.5, SPHERE_COLOR)];
        let view = default_view_for(&bbox_of(&scene).unwrap());
        let img = render(&view, &scene, 160, 120);
        assert_eq!((img.width(), img.height()), (160, 120));
        assert!(!is_bg(img.get_pixel(80, 60), view.background));
        assert!(is_bg(img.get_pixel(0, 0), view.background));
        assert!(is_bg(img.get_pixel(159, 119), view.background));
        // Reddish: the sphere's colour dominates.
        let p = img.get_pixel(80, 60).0;
        assert!(p[0] > p[2]);
        // Deterministic.
        assert_eq!(render(&view, &scene, 160, 120), img);
    }

    #[test]
    fn cloth_over_sphere_on_ground_with_shadow() {
        let g = Grid::sheet(30, 30, 2.0, 2.0).unwrap();
        let x: Vec<Vec3> = g
            .flat_positions(0.0)
            .into_iter()
            .map(|p| p + Vec3::Z * (1.2 - 0.5 * (p.x * p.x + p.y * p.y).min(1.0)))
            .collect();
        let cloth = CoonsSurface::new(&g, &x).tessellate(2);
        let scene = [
            Drawable::mesh(&cloth, CLOTH_COLOR),
            Drawable::sphere(Vec3::new(0.0, 0.0, 0.4), 0.4, SPHERE_COLOR),
            Drawable::plane(Vec3::ZERO, Vec3::Z, GROUND_COLOR),
        ];
        let view = default_view_for(&bbox_of(&scene).unwrap());
        let a = render(&view, &scene, 200, 150);
        let mut no_shadow = view;
        no_shadow.shadows = false;
        let b = render(&no_shadow, &scene, 200, 150);
        assert_ne!(a, b, "the cloth casts a shadow on the ground");
        // The centre shows the cloth (bluish).
        let p = a.get_pixel(100, 75).0;
        assert!(p[2] > p[0], "{p:?}");
        let d = scratch_dir("render");
        save_png(d.join("scene.png"), &a).unwrap();
        let back = image::open(d.join("scene.png")).unwrap().to_rgb8();
        assert_eq!(back, a);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn camera_inside_plane_range_and_degenerate_input_do_not_panic() {
        let mut bad = TriMesh::new();
        bad.positions = vec![Vec3::ZERO, Vec3::splat(f64::NAN), Vec3::X];
        bad.triangles = vec![[0, 1, 2], [0, 2, 7]];
        let scene = [Drawable::mesh(&bad, CLOTH_COLOR), Drawable::plane(Vec3::ZERO, Vec3::Z, GROUND_COLOR)];
        let view = View::look_at(Vec3::new(0.0, -1.0, 0.2), Vec3::new(0.0, 0.0, 0.2));
        let img = render(&view, &scene, 64, 48);
        // The ground fills the lower half, the sky the upper.
        assert!(!is_bg(img.get_pixel(32, 47), view.background));
        assert!(is_bg(img.get_pixel(32, 0), view.background));
        assert_eq!(render(&view, &[], 0, 10).width(), 0);
        let same = View::look_at(Vec3::ONE, Vec3::ONE);
        let _ = render(&same, &scene, 8, 8);
    }

    /// Timing and a look at a typical figure: `cargo test --release -p flexsurf --test suite render_speed -- --ignored
    /// --nocapture` writes `flexsurf-render-demo.png` to the temp dir.
    #[test]
    #[ignore]
    fn render_speed() {
        let g = Grid::sheet(71, 71, 2.0, 2.0).unwrap();
        let x: Vec<Vec3> = g
            .flat_positions(0.0)
            .into_iter()
            .map(|p| {
                let r2 = p.x * p.x + p.y * p.y;
                p + Vec3::Z * (1.0 - 0.6 * r2.min(1.2) + 0.05 * (9.0 * p.x).sin() * r2)
            })
            .collect();
        let cloth = CoonsSurface::new(&g, &x).tessellate(1);
        assert!(cloth.triangle_count() >= 9800);
        let cloth2 = CoonsSurface::new(&g, &x).tessellate(2);
        let scene = [
            Drawable::mesh(&cloth, CLOTH_COLOR),
            Drawable::sphere(Vec3::new(0.0, 0.0, 0.5), 0.45, SPHERE_COLOR),
            Drawable::plane(Vec3::ZERO, Vec3::Z, GROUND_COLOR),
        ];
        let view = default_view_for(&bbox_of(&scene).unwrap());
        let g20 = Grid::sheet(101, 101, 2.0, 2.0).unwrap();
        let x20: Vec<Vec3> =
            g20.flat_positions(0.0).into_iter().map(|p| p + Vec3::Z * (1.0 - 0.5 * p.x * p.x)).collect();
        let cloth20 = CoonsSurface::new(&g20, &x20).tessellate(1);
        for (name, s) in [("10k scene", &scene[..]), ("20k cloth only", &[Drawable::mesh(&cloth20, CLOTH_COLOR)][..])] {
            let mut best = f64::INFINITY;
            for _ in 0..5 {
                let t = std::time::Instant::now();
                let _ = render(&view, s, 400, 300);
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            eprintln!("{name}: best of 5 {best:.1} ms");
        }
        let scene2 = [
            Drawable::mesh(&cloth2, CLOTH_COLOR),
            Drawable::sphere(Vec3::new(0.0, 0.0, 0.5), 0.45, SPHERE_COLOR),
            Drawable::plane(Vec3::ZERO, Vec3::Z, GROUND_COLOR),
        ];
        let mut best = f64::INFINITY;
        let mut img = RgbImage::new(1, 1);
        for _ in 0..7 {
            let t = std::time::Instant::now();
            img = render(&view, &scene2, 400, 300);
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        let mut fast = view;
        fast.shadows = false;
        fast.supersample = 1;
        let t = std::time::Instant::now();
        let _ = render(&fast, &scene2, 400, 300);
        let plain = t.elapsed().as_secs_f64() * 1e3;
        eprintln!("{} tris full scene: best {best:.1} ms; no shadow, no AA {plain:.1} ms", cloth2.triangle_count());
        let labels = vec!["t = 0.00 s".to_string(), "t = 1.25 s  E/E0 = 0.31".to_string()];
        let p = panel(&[img.clone(), img], &labels, 2);
        save_png(std::env::temp_dir().join("flexsurf-render-demo.png"), &p).unwrap();
    }

    /// 20 renders of a 20k-triangle cloth at 400×300 (for `perf stat` CPU-time measurements).
    #[test]
    #[ignore]
    fn render_20k_x20() {
        let g = Grid::sheet(101, 101, 2.0, 2.0).unwrap();
        let x: Vec<Vec3> = g.flat_positions(0.0).into_iter().map(|p| p + Vec3::Z * (1.0 - 0.5 * p.x * p.x)).collect();
        let cloth = CoonsSurface::new(&g, &x).tessellate(1);
        assert_eq!(cloth.triangle_count(), 20_000);
        let scene = [Drawable::mesh(&cloth, CLOTH_COLOR), Drawable::plane(Vec3::ZERO, Vec3::Z, GROUND_COLOR)];
        let view = default_view_for(&bbox_of(&scene).unwrap());
        for _ in 0..20 {
            let _ = render(&view, &scene, 400, 300);
        }
    }
}

/// The tests of `io::render::panel` (`src/io/render/panel.rs`).
mod panel {
    use flexsurf::io::render::*;
    use image::{Rgb, RgbImage};

    #[test]
    fn panel_size_and_text() {
        let a = RgbImage::from_pixel(40, 30, Rgb([10, 10, 10]));
        let b = RgbImage::from_pixel(50, 20, Rgb([10, 10, 10]));
        let imgs = vec![a.clone(), b, a.clone()];
        let labels = vec!["t = 0.5 s".to_string(), "E/E0: -1.25".to_string()];
        let p = panel(&imgs, &labels, 2);
        assert_eq!((p.width(), p.height()), (2 * 50, 2 * (30 + CAPTION_HEIGHT)));
        let p1 = panel(&imgs, &labels, 5);
        assert_eq!((p1.width(), p1.height()), (3 * 50, 30 + CAPTION_HEIGHT));
        let p0 = panel(&imgs, &labels, 0);
        assert_eq!((p0.width(), p0.height()), (50, 3 * (30 + CAPTION_HEIGHT)));
        assert_eq!(panel(&[], &[], 3).width(), 0);
        // The first caption strip has dark text pixels; the third (no label) has none below its rule.
        let dark = |img: &RgbImage, x0: u32, y0: u32, w: u32, h: u32| {
            (y0..y0 + h)
                .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
                .filter(|&(x, y)| img.get_pixel(x, y).0[0] < 100)
                .count()
        };
        assert!(dark(&p, 0, 31, 50, CAPTION_HEIGHT - 1) > 20);
        assert_eq!(dark(&p, 0, 30 + CAPTION_HEIGHT + 30 + 1, 50, CAPTION_HEIGHT - 1), 0);
        let t = with_title(&p, "ball_drop");
        assert_eq!((t.width(), t.height()), (p.width(), p.height() + TITLE_HEIGHT));
        assert!(dark(&t, 0, 0, t.width(), TITLE_HEIGHT) > 20);
    }

    #[test]
    fn layouts_have_no_empty_cells() {
        for n in 1..=40 {
            let (count, cols) = grid_layout(n);
            assert!(count >= 1 && count <= n, "{n}");
            assert_eq!(count % cols, 0, "{n} pictures: {count} in {cols} columns leave an empty cell");
            assert!(cols <= 5);
        }
        assert_eq!(grid_layout(5), (5, 5));
        assert_eq!(grid_layout(4), (4, 4));
    }
}

/// The tests of `io::render::scene` (`src/io/render/scene.rs`).
mod scene {
    use flexsurf::io::render::*;
    use flexsurf::math::Vec3;

    #[test]
    fn uv_sphere_is_closed_and_outward() {
        let m = uv_sphere(Vec3::ZERO, 2.0, 8, 16);
        assert!(m.validate().is_ok());
        assert_eq!(m.triangle_count(), 2 * 8 * 16 - 2 * 16);
        let area = m.area();
        assert!(area < 4.0 * std::f64::consts::PI * 4.0 && area > 0.9 * 4.0 * std::f64::consts::PI * 4.0);
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t).unwrap();
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }
}

/// The tests of `io::render::text` (`src/io/render/text.rs`).
mod text {
    use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
    use flexsurf::io::render::*;
    use image::{Rgb, RgbImage};

    fn ink(img: &RgbImage) -> usize {
        img.pixels().filter(|p| p.0[0] < 128).count()
    }

    #[test]
    fn the_font_draws_distinct_glyphs_with_descenders() {
        // The embedded font parses (the renderer's own parse of `FONT_BYTES`).
        let font = FontRef::try_from_slice(FONT_BYTES).ok();
        assert!(font.is_some());
        assert!(register_plot_font());
        let draw = |s: &str| {
            let mut img = RgbImage::from_pixel(60, 40, Rgb([255, 255, 255]));
            draw_text(&mut img, 2, 2, s, 24.0, [0, 0, 0]);
            img
        };
        // "p" and "P" differ (the old bitmap font drew them alike), and "g" reaches below the baseline.
        let (p, cap_p, g) = (draw("p"), draw("P"), draw("g"));
        assert_ne!(p, cap_p);
        let baseline = 2 + font.unwrap().as_scaled(PxScale::from(24.0)).ascent().round() as u32;
        let below = |img: &RgbImage| {
            (baseline + 1..40)
                .flat_map(|y| (0..60).map(move |x| (x, y)))
                .filter(|&(x, y)| img.get_pixel(x, y).0[0] < 128)
                .count()
        };
        assert!(below(&g) > 5 && below(&p) > 5 && below(&cap_p) == 0);
        assert!(ink(&draw("m")) > ink(&draw(".")));
        assert!(text_width("mmmm", 20.0) > text_width("iiii", 20.0));
        assert_eq!(text_width("", 20.0), 0);
        // Clipped drawing off the image does not panic.
        let mut img = RgbImage::new(10, 10);
        draw_text(&mut img, -30, -5, "xyz", 40.0, [255, 0, 0]);
    }
}
