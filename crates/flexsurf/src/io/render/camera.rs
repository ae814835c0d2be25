//! The camera: the [`View`] settings (eye, target, field of view, light, shading), a default view that frames
//! a bounding box, and the perspective projection of the supersampled image with the near-plane clip of the
//! triangles before [`super::raster`] fills them.

use super::scene::BACKGROUND_COLOR;
use crate::math::Vec3;
use crate::surface::mesh::Aabb;

/// Camera, light and image settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Camera position.
    pub eye: Vec3,
    /// Point looked at (the image centre).
    pub target: Vec3,
    /// Approximate up direction of the image.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f64,
    /// Direction from the scene towards the (directional) light.
    pub light_dir: Vec3,
    /// Background colour (sRGB).
    pub background: [u8; 3],
    /// Ambient light fraction, 0–1.
    pub ambient: f64,
    /// Diffuse light fraction, 0–1 (`ambient + diffuse` is the brightest lit shade).
    pub diffuse: f64,
    /// Cast shadows from cloth and spheres onto everything.
    pub shadows: bool,
    /// Supersampling factor per axis for anti-aliasing (1 = none; clamped to 1–4).
    pub supersample: u32,
}

impl View {
    /// A view from `eye` towards `target` with `+z` up and the default light and shading: the light comes from
    /// above, over the camera's left shoulder.
    pub fn look_at(eye: Vec3, target: Vec3) -> Self {
        let up = Vec3::Z;
        let (f, r, u) = camera_basis(eye, target, up);
        let light_dir = (-0.45 * r + 0.6 * u - 0.5 * f + 0.6 * up).try_normalize().unwrap_or(Vec3::Z);
        Self {
            eye,
            target,
            up,
            fov_y_deg: 30.0,
            light_dir,
            background: BACKGROUND_COLOR,
            ambient: 0.32,
            diffuse: 0.68,
            shadows: true,
            supersample: 2,
        }
    }
}

/// A view that frames `bbox` from a slightly elevated three-quarter angle (`+z` up, camera 25° above the
/// horizon, 60° round from the `−y` axis), like the figures of a cloth paper. The distance is chosen so that
/// the eight corners of the box fit, with a small margin, into an image of aspect ratio 4:3 or wider.
pub fn default_view_for(bbox: &Aabb) -> View {
    let ok = bbox.min.is_finite() && bbox.max.is_finite();
    let (lo, hi) = if ok { (bbox.min, bbox.max) } else { (Vec3::splat(-1.0), Vec3::splat(1.0)) };
    let target = 0.5 * (lo + hi);
    let (az, el) = ((-60.0f64).to_radians(), 25.0f64.to_radians());
    let dir = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let fov = 30.0f64;
    let (f, r, u) = camera_basis(target + dir, target, Vec3::Z);
    let tan_v = (0.5 * fov.to_radians()).tan() * 0.9;
    let tan_h = tan_v * 4.0 / 3.0;
    let radius = (0.5 * (hi - lo).length()).max(1e-6);
    let mut distance = 1e-3 * radius;
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        ) - target;
        let need = (corner.dot(u).abs() / tan_v).max(corner.dot(r).abs() / tan_h) - corner.dot(f);
        distance = distance.max(need);
    }
    // Never so close that the camera enters the box's bounding sphere.
    distance = distance.max(1.05 * radius);
    let mut view = View::look_at(target + dir * distance, target);
    view.fov_y_deg = fov;
    view
}

/// Camera forward, right and up vectors, with fallbacks for degenerate input.
fn camera_basis(eye: Vec3, target: Vec3, up: Vec3) -> (Vec3, Vec3, Vec3) {
    let f = (target - eye).try_normalize().unwrap_or(Vec3::Y);
    let r = f
        .cross(up)
        .try_normalize()
        .or_else(|| f.cross(Vec3::Z).try_normalize())
        .or_else(|| f.cross(Vec3::X).try_normalize())
        .unwrap_or(Vec3::X);
    (f, r, r.cross(f))
}

/// The perspective projection of a `w × h` (supersampled) image: camera basis, focal length in pixels, near
/// plane and image centre.
pub(super) struct Camera {
    eye: Vec3,
    f: Vec3,
    r: Vec3,
    u: Vec3,
    focal: f64,
    /// Distance of the near clipping plane.
    pub(super) near: f64,
    cx: f64,
    cy: f64,
}

impl Camera {
    /// The projection of `view` onto a `w × h` raster.
    pub(super) fn new(view: &View, w: usize, h: usize) -> Self {
        let (f, r, u) = camera_basis(view.eye, view.target, view.up);
        let fov = if view.fov_y_deg.is_finite() { view.fov_y_deg.clamp(1.0, 170.0) } else { 30.0 };
        let focal = 0.5 * h as f64 / (0.5 * fov.to_radians()).tan();
        let near = 1e-3 * (view.target - view.eye).length().max(1e-6);
        let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
        Self { eye: view.eye, f, r, u, focal, near, cx, cy }
    }

    /// Camera coordinates (right, up, forward) of the world point `p`.
    #[inline]
    pub(super) fn to_camera(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.r), d.dot(self.u), d.dot(self.f))
    }

    /// Raster coordinates of a camera-space point in front of the camera.
    #[inline]
    pub(super) fn to_screen(&self, c: Vec3) -> [f64; 2] {
        [self.cx + self.focal * c.x / c.z, self.cy - self.focal * c.y / c.z]
    }
}

/// Clipping vertex: camera coordinates, world position, normal.
#[derive(Clone, Copy)]
pub(super) struct ClipVert {
    pub(super) c: Vec3,
    pub(super) w: Vec3,
    pub(super) n: Vec3,
}

/// Sutherland–Hodgman clip of a triangle against `z ≥ near` in camera space: up to four vertices, and how many.
pub(super) fn clip_near(verts: &[ClipVert; 3], near: f64) -> ([ClipVert; 4], usize) {
    let mut out = [verts[0]; 4];
    let mut len = 0;
    for k in 0..3 {
        let (a, b) = (verts[k], verts[(k + 1) % 3]);
        let (ina, inb) = (a.c.z >= near, b.c.z >= near);
        if ina {
            out[len] = a;
            len += 1;
        }
        if ina != inb {
            let t = (near - a.c.z) / (b.c.z - a.c.z);
            let lerp = |p: Vec3, q: Vec3| p + (q - p) * t;
            let mut c = lerp(a.c, b.c);
            c.z = near;
            out[len] = ClipVert { c, w: lerp(a.w, b.w), n: lerp(a.n, b.n) };
            len += 1;
        }
    }
    (out, len)
}
