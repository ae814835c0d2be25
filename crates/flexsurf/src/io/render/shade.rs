//! Shading and colour: sRGB ↔ linear conversion, two-sided Lambert + ambient shading of a primitive (dimmed by
//! the shadow map), and the resolve of each pixel's supersamples (shaded once where one primitive covers the
//! whole pixel) into the sRGB image.

use super::camera::View;
use super::raster::{Prim, ZBuffer};
use super::shadow::ShadowMap;
use crate::math::Vec3;
use image::{Rgb, RgbImage};

/// sRGB byte to linear intensity.
fn srgb_to_linear(c: u8) -> f64 {
    let c = f64::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear intensity to sRGB byte.
fn linear_to_srgb(v: f64) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

pub(super) fn linear_rgb(c: [u8; 3]) -> [f64; 3] {
    c.map(srgb_to_linear)
}

/// Linear → sRGB byte lookup (fine enough that every byte value is reachable).
struct SrgbTable(Vec<u8>);

impl SrgbTable {
    const N: usize = 1 << 14;

    fn get_or_init() -> &'static Self {
        static TABLE: std::sync::OnceLock<SrgbTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(|| Self((0..=Self::N).map(|i| linear_to_srgb(i as f64 / Self::N as f64)).collect()))
    }

    fn get(&self, v: f64) -> u8 {
        let i = (v.clamp(0.0, 1.0) * Self::N as f64 + 0.5) as usize;
        self.0[i.min(Self::N)]
    }
}

/// Lights the primitives of a frame.
pub(super) struct Shader<'a> {
    prims: &'a [Prim],
    shadow: Option<&'a ShadowMap>,
    eye: Vec3,
    light: Vec3,
    /// Linear background colour, for samples without a primitive.
    bg: [f64; 3],
    ambient: f64,
    diffuse: f64,
}

impl<'a> Shader<'a> {
    /// The shading of `prims` for `view` with the unit direction to the light `light`.
    pub(super) fn new(view: &View, light: Vec3, prims: &'a [Prim], shadow: Option<&'a ShadowMap>) -> Self {
        let bg = linear_rgb(view.background);
        let (ambient, diffuse) = (view.ambient.clamp(0.0, 1.0), view.diffuse.clamp(0.0, 1.0));
        Self { prims, shadow, eye: view.eye, light, bg, ambient, diffuse }
    }

    /// Linear colour of primitive `id` at barycentric weights `b` (the background for an unknown id).
    fn shade(&self, id: u32, b: [f64; 3]) -> [f64; 3] {
        let Some(p) = self.prims.get(id as usize) else { return self.bg };
        let pos = p.world[0] * b[0] + p.world[1] * b[1] + p.world[2] * b[2];
        let mut n = (p.normal[0] * b[0] + p.normal[1] * b[1] + p.normal[2] * b[2]).try_normalize().unwrap_or(p.face);
        let mut face = p.face;
        // Two-sided lighting: light the side that faces the camera.
        if face.dot(self.eye - pos) < 0.0 {
            face = -face;
            n = -n;
        }
        if n.dot(face) < 0.0 {
            n = face;
        }
        let mut lambert = n.dot(self.light).max(0.0);
        if lambert > 0.0 {
            if let Some(sm) = self.shadow {
                lambert *= sm.visibility(pos + face * (1.5 * sm.texel()));
            }
        }
        let i = self.ambient + self.diffuse * lambert;
        p.color.map(|c| c * i)
    }
}

/// Fills every pixel of `img` with the mean colour of its `ss × ss` samples in `zbuf`.
pub(super) fn resolve(img: &mut RgbImage, ss: usize, zbuf: &ZBuffer, shader: &Shader<'_>) {
    let w = zbuf.width;
    let prim_id = &zbuf.prim_id;
    let norm = 1.0 / (ss * ss) as f64;
    let encode = SrgbTable::get_or_init();
    let mut samples = Vec::with_capacity(ss * ss);
    for (x, y, px) in img.enumerate_pixels_mut() {
        samples.clear();
        samples.extend((0..ss * ss).map(|s| (x as usize * ss + s % ss) + w * (y as usize * ss + s / ss)));
        let first = prim_id[samples[0]];
        let color = if first != u32::MAX && samples.iter().all(|&k| prim_id[k] == first) {
            // One surface covers the whole pixel: shade once at the mean sample position.
            let mut b = [0.0; 3];
            samples.iter().for_each(|&k| (0..3).for_each(|q| b[q] += zbuf.bary(k)[q] * norm));
            shader.shade(first, b)
        } else {
            let mut acc = [0.0; 3];
            for &k in &samples {
                let c = shader.shade(prim_id[k], zbuf.bary(k));
                (0..3).for_each(|q| acc[q] += c[q] * norm);
            }
            acc
        };
        *px = Rgb(color.map(|c| encode.get(c)));
    }
}
