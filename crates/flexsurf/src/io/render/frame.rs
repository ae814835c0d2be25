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
