//! One frame: [`render`] gathers the scene's triangles, z-buffers them through the camera at the supersampled
//! resolution, builds the shadow map, and shades and resolves the samples into the picture, reusing per-thread
//! buffers between frames.

use super::camera::{Camera, View};
use super::raster::{rasterise, ZBuffer};
use super::scene::{gather, Drawable};
use super::shade::{resolve, Shader};
use super::shadow::{ShadowMap, SHADOW_MAX};
use crate::math::Vec3;
use image::{Rgb, RgbImage};

/// Per-thread buffers reused between renders (a fresh multi-megabyte buffer per frame costs more in page faults
/// than the rasterisation itself).
#[derive(Default)]
struct Scratch {
    zbuf: ZBuffer,
    shadow: Vec<f32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// Renders the drawables as a `width × height` image.
pub fn render(view: &View, drawables: &[Drawable<'_>], width: u32, height: u32) -> RgbImage {
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut scratch) => render_with(&mut scratch, view, drawables, width, height),
        Err(_) => render_with(&mut Scratch::default(), view, drawables, width, height),
    })
}

/// [`render`] with the buffers of `scratch`.
fn render_with(scratch: &mut Scratch, view: &View, drawables: &[Drawable<'_>], width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::from_pixel(width, height, Rgb(view.background));
    if width == 0 || height == 0 {
        return img;
    }
    let ss = view.supersample.clamp(1, 4) as usize;
    let (w, h) = (width as usize * ss, height as usize * ss);
    let tris = gather(drawables);
    let camera = Camera::new(view, w, h);
    let light = view.light_dir.try_normalize().unwrap_or(Vec3::Z);

    let Scratch { zbuf, shadow: shadow_buf } = scratch;
    zbuf.reset(w, h);
    let prims = rasterise(&tris, &camera, zbuf);

    let shadow = if view.shadows {
        ShadowMap::build(&tris, light, w.max(h).clamp(256, SHADOW_MAX), std::mem::take(shadow_buf))
    } else {
        None
    };
    resolve(&mut img, ss, zbuf, &Shader::new(view, light, &prims, shadow.as_ref()));
    if let Some(sm) = shadow {
        *shadow_buf = sm.depth;
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;
    use crate::io::render::{bbox_of, default_view_for, panel, save_png, CLOTH_COLOR, GROUND_COLOR, SPHERE_COLOR};
    use crate::io::scratch_dir;
    use crate::surface::coons::CoonsSurface;
    use crate::surface::mesh::TriMesh;

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

    /// Timing and a look at a typical figure: `cargo test --release -p flexsurf --lib render_speed -- --ignored
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
