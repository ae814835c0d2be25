//! A small deterministic software renderer for figures: a z-buffered triangle rasteriser with Lambert + ambient
//! shading (two-sided, for cloth), optional shadow mapping, supersampled anti-aliasing and a perspective camera.
//! It draws cloth meshes and the analytic obstacles (a UV-tessellated sphere, a checkered ground plane), tiles
//! several views into a captioned panel with a built-in 5×7 bitmap font, and writes PNG through
//! [`super::atomic`]. Everything is single-threaded, so the same input gives the same bytes.

use super::atomic::write_atomic;
use crate::math::Vec3;
use crate::surface::mesh::{Aabb, TriMesh};
/// The picture type the renderer returns (re-exported so callers need not depend on `image`).
pub use image::RgbImage as Picture;
use image::{ImageEncoder, Rgb, RgbImage};
use std::borrow::Cow;
use std::io;
use std::path::Path;

/// Default cloth colour (sRGB).
pub const CLOTH_COLOR: [u8; 3] = [66, 118, 189];
/// Default sphere colour (sRGB).
pub const SPHERE_COLOR: [u8; 3] = [196, 96, 74];
/// Default ground colour (sRGB).
pub const GROUND_COLOR: [u8; 3] = [214, 210, 200];
/// Default background colour (sRGB).
pub const BACKGROUND_COLOR: [u8; 3] = [246, 247, 249];
/// Height in pixels of the caption strip under each tile of [`panel`].
pub const CAPTION_HEIGHT: u32 = 24;
/// Scale factor of caption text (glyphs are 5×7 font pixels, so captions are 10×14 image pixels).
pub const CAPTION_SCALE: u32 = 2;

/// Largest shadow map resolution (texels per side); the map is as fine as the supersampled image, up to this.
const SHADOW_MAX: usize = 1024;

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

/// The union of the bounding boxes of the drawables (planes, being infinite, are left out).
pub fn bbox_of(drawables: &[Drawable<'_>]) -> Option<Aabb> {
    drawables.iter().filter_map(Drawable::bbox).reduce(Aabb::union)
}

/// Something to draw.
#[derive(Debug, Clone)]
pub enum Drawable<'a> {
    /// A triangle mesh (cloth) with a base colour; drawn two-sided.
    Mesh {
        /// The mesh; its normals are used when it has one per vertex, face normals otherwise.
        mesh: Cow<'a, TriMesh>,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
    /// A sphere obstacle.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
    /// An infinite ground plane, drawn as a checkered square sized to the rest of the scene.
    Plane {
        /// A point on the plane.
        point: Vec3,
        /// Plane normal.
        normal: Vec3,
        /// Base colour (sRGB).
        color: [u8; 3],
    },
}

impl<'a> Drawable<'a> {
    /// A borrowed mesh.
    pub fn mesh(mesh: &'a TriMesh, color: [u8; 3]) -> Self {
        Self::Mesh { mesh: Cow::Borrowed(mesh), color }
    }

    /// An owned mesh.
    pub fn owned_mesh(mesh: TriMesh, color: [u8; 3]) -> Self {
        Self::Mesh { mesh: Cow::Owned(mesh), color }
    }

    /// A sphere.
    pub fn sphere(center: Vec3, radius: f64, color: [u8; 3]) -> Self {
        Self::Sphere { center, radius, color }
    }

    /// A ground plane.
    pub fn plane(point: Vec3, normal: Vec3, color: [u8; 3]) -> Self {
        Self::Plane { point, normal, color }
    }

    /// Bounding box, or `None` for a plane or empty or invalid geometry.
    pub fn bbox(&self) -> Option<Aabb> {
        match self {
            Self::Mesh { mesh, .. } => mesh.bbox(),
            Self::Sphere { center, radius, .. } => {
                let r = Vec3::splat(radius.abs());
                (center.is_finite() && radius.is_finite()).then(|| Aabb { min: *center - r, max: *center + r })
            }
            Self::Plane { .. } => None,
        }
    }
}

/// A UV sphere: `stacks` rings from pole to pole, `slices` segments round, outward normals, counter-clockwise
/// seen from outside.
pub fn uv_sphere(center: Vec3, radius: f64, stacks: usize, slices: usize) -> TriMesh {
    let (stacks, slices) = (stacks.max(2), slices.max(3));
    let mut mesh = TriMesh::new();
    for i in 0..=stacks {
        let th = std::f64::consts::PI * i as f64 / stacks as f64;
        for j in 0..=slices {
            let ph = std::f64::consts::TAU * j as f64 / slices as f64;
            let n = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            mesh.positions.push(center + n * radius);
            mesh.normals.push(n);
        }
    }
    let id = |i: usize, j: usize| (i * (slices + 1) + j) as u32;
    for i in 0..stacks {
        for j in 0..slices {
            let (v00, v10, v01, v11) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            if i + 1 < stacks {
                mesh.triangles.push([v00, v10, v11]);
            }
            if i > 0 {
                mesh.triangles.push([v00, v11, v01]);
            }
        }
    }
    mesh
}

/// A checkered square of `tiles × tiles` tiles (two triangles each) in the plane through `center` with normal
/// `normal`, side `2 half`; the second return value is the per-triangle shade factor (1 or 0.86).
pub fn checkered_square(center: Vec3, normal: Vec3, half: f64, tiles: usize) -> (TriMesh, Vec<f64>) {
    let n = normal.try_normalize().unwrap_or(Vec3::Z);
    let (e1, e2) = plane_basis(n);
    let tiles = tiles.max(1);
    let step = 2.0 * half / tiles as f64;
    let mut mesh = TriMesh::new();
    for b in 0..=tiles {
        for a in 0..=tiles {
            mesh.positions.push(center + e1 * (a as f64 * step - half) + e2 * (b as f64 * step - half));
            mesh.normals.push(n);
        }
    }
    let mut shade = Vec::with_capacity(2 * tiles * tiles);
    let id = |a: usize, b: usize| (a + (tiles + 1) * b) as u32;
    for b in 0..tiles {
        for a in 0..tiles {
            mesh.triangles.push([id(a, b), id(a + 1, b), id(a + 1, b + 1)]);
            mesh.triangles.push([id(a, b), id(a + 1, b + 1), id(a, b + 1)]);
            let s = if (a + b) % 2 == 0 { 1.0 } else { 0.86 };
            shade.extend([s, s]);
        }
    }
    (mesh, shade)
}

/// Orthonormal `(e1, e2)` with `e1 × e2 = n` for a unit `n`.
fn plane_basis(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let e1 = (a - n * a.dot(n)).normalize();
    (e1, n.cross(e1))
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

fn linear_rgb(c: [u8; 3]) -> [f64; 3] {
    c.map(srgb_to_linear)
}

/// A world-space triangle ready to draw.
struct Tri {
    p: [Vec3; 3],
    n: [Vec3; 3],
    color: [f64; 3],
    casts_shadow: bool,
}

/// Collects the triangles of all drawables.
fn gather(drawables: &[Drawable<'_>]) -> Vec<Tri> {
    let content = bbox_of(drawables);
    let capacity =
        drawables.iter().map(|d| if let Drawable::Mesh { mesh, .. } = d { mesh.triangle_count() } else { 4096 });
    let mut tris = Vec::with_capacity(capacity.sum());
    let mut push_mesh = |mesh: &TriMesh, color: [f64; 3], shade: Option<&[f64]>, casts: bool| {
        let normals: Cow<'_, [Vec3]> =
            if mesh.has_normals() { Cow::Borrowed(&mesh.normals) } else { Cow::Owned(mesh.face_averaged_normals()) };
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let Some(p) = mesh.triangle(t) else { continue };
            if !p.iter().all(|v| v.is_finite()) {
                continue;
            }
            let n = tri.map(|v| normals[v as usize]);
            let s = shade.and_then(|s| s.get(t)).copied().unwrap_or(1.0);
            tris.push(Tri { p, n, color: color.map(|c| c * s), casts_shadow: casts });
        }
    };
    for d in drawables {
        match d {
            Drawable::Mesh { mesh, color } => push_mesh(mesh, linear_rgb(*color), None, true),
            Drawable::Sphere { center, radius, color } => {
                if center.is_finite() && radius.is_finite() && *radius > 0.0 {
                    push_mesh(&uv_sphere(*center, *radius, 32, 64), linear_rgb(*color), None, true);
                }
            }
            Drawable::Plane { point, normal, color } => {
                let Some(n) = normal.try_normalize() else { continue };
                if !point.is_finite() {
                    continue;
                }
                let (c, half) = match content {
                    Some(b) => (b.center() - n * (b.center() - *point).dot(n), 6.0 * b.radius().max(1e-6)),
                    None => (*point, 1.0),
                };
                let (mesh, shade) = checkered_square(c, n, half, 24);
                push_mesh(&mesh, linear_rgb(*color), Some(&shade), false);
            }
        }
    }
    tris
}

/// Orthographic depth map seen from the light.
struct ShadowMap {
    ax: Vec3,
    ay: Vec3,
    az: Vec3,
    x0: f64,
    y0: f64,
    /// Texels per world unit.
    scale: f64,
    /// Texels per side.
    size: usize,
    depth: Vec<f32>,
}

impl ShadowMap {
    fn build(tris: &[Tri], light: Vec3, size: usize, mut depth: Vec<f32>) -> Option<Self> {
        let az = -light;
        let (ax, ay) = plane_basis(az);
        let pts =
            tris.iter().filter(|t| t.casts_shadow).flat_map(|t| t.p).map(|p| Vec3::new(p.dot(ax), p.dot(ay), 0.0));
        let b = Aabb::from_points(pts)?;
        let extent = b.size().x.max(b.size().y).max(1e-9) * 1.04;
        let (x0, y0) = (b.center().x - 0.5 * extent, b.center().y - 0.5 * extent);
        let scale = size as f64 / extent;
        depth.clear();
        depth.resize(size * size, f32::INFINITY);
        let mut sm = Self { ax, ay, az, x0, y0, scale, size, depth };
        for t in tris.iter().filter(|t| t.casts_shadow) {
            let s = t.p.map(|p| sm.project(p));
            raster_triangle([[s[0].x, s[0].y], [s[1].x, s[1].y], [s[2].x, s[2].y]], size, size, |k, w| {
                let d = (w[0] * s[0].z + w[1] * s[1].z + w[2] * s[2].z) as f32;
                if d < sm.depth[k] {
                    sm.depth[k] = d;
                }
            });
        }
        Some(sm)
    }

    /// Texel coordinates (x, y) and depth along the light (z).
    fn project(&self, p: Vec3) -> Vec3 {
        Vec3::new((p.dot(self.ax) - self.x0) * self.scale, (p.dot(self.ay) - self.y0) * self.scale, p.dot(self.az))
    }

    /// World size of a texel.
    fn texel(&self) -> f64 {
        1.0 / self.scale
    }

    /// Fraction of light reaching `p`: the four nearest texels' depth tests, bilinearly weighted.
    fn visibility(&self, p: Vec3) -> f64 {
        let q = self.project(p);
        let depth = q.z - 1.5 * self.texel();
        let (fx, fy) = (q.x - 0.5, q.y - 0.5);
        let (cx, cy) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - cx, fy - cy);
        let (cx, cy) = (cx as i64, cy as i64);
        let n = self.size as i64;
        let lit = |x: i64, y: i64| -> f64 {
            let inside = (0..n).contains(&x) && (0..n).contains(&y);
            if !inside || depth <= f64::from(self.depth[(y * n + x) as usize]) {
                1.0
            } else {
                0.0
            }
        };
        let top = lit(cx, cy) * (1.0 - tx) + lit(cx + 1, cy) * tx;
        let bottom = lit(cx, cy + 1) * (1.0 - tx) + lit(cx + 1, cy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}

/// Calls `pixel(index, barycentric weights)` for every pixel centre of a `w × h` raster inside the screen
/// triangle `s` (pixel `(x, y)` has centre `(x + ½, y + ½)`, index `x + w y`).
fn raster_triangle(s: [[f64; 2]; 3], w: usize, h: usize, mut pixel: impl FnMut(usize, [f64; 3])) {
    let area = (s[1][0] - s[0][0]) * (s[2][1] - s[0][1]) - (s[1][1] - s[0][1]) * (s[2][0] - s[0][0]);
    if !area.is_finite() || area.abs() <= 1e-12 {
        return;
    }
    let inv = 1.0 / area;
    // Normalised edge functions w_k(x, y) = a_k x + b_k y + c_k (weight of vertex k, opposite edge (k+1, k+2)).
    let coef: [[f64; 3]; 3] = std::array::from_fn(|k| {
        let (p, q) = (s[(k + 1) % 3], s[(k + 2) % 3]);
        let a = -(q[1] - p[1]) * inv;
        let b = (q[0] - p[0]) * inv;
        [a, b, -(a * p[0] + b * p[1])]
    });
    let lo = |c: usize| s[0][c].min(s[1][c]).min(s[2][c]);
    let hi = |c: usize| s[0][c].max(s[1][c]).max(s[2][c]);
    let clamp = |v: f64, n: usize| v.max(0.0).min(n as f64) as usize;
    let (x0, x1) = (clamp((lo(0) - 0.5).ceil(), w), clamp((hi(0) - 0.5).floor() + 1.0, w));
    let (y0, y1) = (clamp((lo(1) - 0.5).ceil(), h), clamp((hi(1) - 0.5).floor() + 1.0, h));
    if x0 >= x1 {
        return;
    }
    for y in y0..y1 {
        let py = y as f64 + 0.5;
        // The covered span of this row: the half-planes w_k ≥ 0 intersected along x, widened by a pixel against
        // rounding (the explicit test below decides coverage).
        let (mut xa, mut xb) = (x0 as f64 + 0.5, (x1 - 1) as f64 + 0.5);
        for c in &coef {
            let base = c[1] * py + c[2];
            if c[0] > 0.0 {
                xa = xa.max(-base / c[0] - 1.0);
            } else if c[0] < 0.0 {
                xb = xb.min(-base / c[0] + 1.0);
            } else if base < 0.0 {
                xb = f64::NEG_INFINITY;
            }
        }
        if xa.is_nan() || xb.is_nan() || xa > xb {
            continue;
        }
        let sa = ((xa - 0.5).ceil() as usize).max(x0);
        let sb = (((xb - 0.5).floor() + 1.0) as usize).min(x1);
        for x in sa..sb {
            let px = x as f64 + 0.5;
            let wk = coef.map(|c| c[0] * px + c[1] * py + c[2]);
            if wk[0] >= 0.0 && wk[1] >= 0.0 && wk[2] >= 0.0 {
                pixel(x + w * y, wk);
            }
        }
    }
}

/// A clipped, projected triangle.
struct Prim {
    world: [Vec3; 3],
    normal: [Vec3; 3],
    face: Vec3,
    color: [f64; 3],
}

/// Clipping vertex: camera coordinates, world position, normal.
#[derive(Clone, Copy)]
struct ClipVert {
    c: Vec3,
    w: Vec3,
    n: Vec3,
}

/// Per-thread buffers reused between renders (a fresh multi-megabyte buffer per frame costs more in page faults
/// than the rasterisation itself).
#[derive(Default)]
struct Scratch {
    inv_z: Vec<f64>,
    prim_id: Vec<u32>,
    weights: Vec<[f32; 2]>,
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

fn render_with(scratch: &mut Scratch, view: &View, drawables: &[Drawable<'_>], width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::from_pixel(width, height, Rgb(view.background));
    if width == 0 || height == 0 {
        return img;
    }
    let ss = view.supersample.clamp(1, 4) as usize;
    let (w, h) = (width as usize * ss, height as usize * ss);
    let tris = gather(drawables);
    let (f, r, u) = camera_basis(view.eye, view.target, view.up);
    let light = view.light_dir.try_normalize().unwrap_or(Vec3::Z);
    let fov = if view.fov_y_deg.is_finite() { view.fov_y_deg.clamp(1.0, 170.0) } else { 30.0 };
    let focal = 0.5 * h as f64 / (0.5 * fov.to_radians()).tan();
    let near = 1e-3 * (view.target - view.eye).length().max(1e-6);
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);

    let Scratch { inv_z, prim_id, weights, shadow: shadow_buf } = scratch;
    inv_z.clear();
    inv_z.resize(w * h, 0.0);
    prim_id.clear();
    prim_id.resize(w * h, u32::MAX);
    // Weights are only read where a primitive was written, so stale values need no clearing.
    weights.resize(w * h, [0.0; 2]);
    let mut prims: Vec<Prim> = Vec::with_capacity(tris.len());
    for t in &tris {
        let verts: [ClipVert; 3] = std::array::from_fn(|k| {
            let d = t.p[k] - view.eye;
            ClipVert { c: Vec3::new(d.dot(r), d.dot(u), d.dot(f)), w: t.p[k], n: t.n[k] }
        });
        let (poly, len) = clip_near(&verts, near);
        if len < 3 {
            continue;
        }
        let face = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).try_normalize().unwrap_or(Vec3::Z);
        for k in 1..len - 1 {
            let tri = [poly[0], poly[k], poly[k + 1]];
            let id = prims.len() as u32;
            let s = tri.map(|v| [cx + focal * v.c.x / v.c.z, cy - focal * v.c.y / v.c.z]);
            let iz = tri.map(|v| 1.0 / v.c.z);
            raster_triangle(s, w, h, |k, b| {
                let z = b[0] * iz[0] + b[1] * iz[1] + b[2] * iz[2];
                if z > inv_z[k] {
                    inv_z[k] = z;
                    prim_id[k] = id;
                    weights[k] = [(b[0] * iz[0] / z) as f32, (b[1] * iz[1] / z) as f32];
                }
            });
            prims.push(Prim { world: tri.map(|v| v.w), normal: tri.map(|v| v.n), face, color: t.color });
        }
    }

    let shadow = if view.shadows {
        ShadowMap::build(&tris, light, w.max(h).clamp(256, SHADOW_MAX), std::mem::take(shadow_buf))
    } else {
        None
    };
    let bg = linear_rgb(view.background);
    let (ambient, diffuse) = (view.ambient.clamp(0.0, 1.0), view.diffuse.clamp(0.0, 1.0));
    let shade = |id: u32, b: [f64; 3]| -> [f64; 3] {
        let Some(p) = prims.get(id as usize) else { return bg };
        let pos = p.world[0] * b[0] + p.world[1] * b[1] + p.world[2] * b[2];
        let mut n = (p.normal[0] * b[0] + p.normal[1] * b[1] + p.normal[2] * b[2]).try_normalize().unwrap_or(p.face);
        let mut face = p.face;
        // Two-sided lighting: light the side that faces the camera.
        if face.dot(view.eye - pos) < 0.0 {
            face = -face;
            n = -n;
        }
        if n.dot(face) < 0.0 {
            n = face;
        }
        let mut lambert = n.dot(light).max(0.0);
        if lambert > 0.0 {
            if let Some(sm) = &shadow {
                lambert *= sm.visibility(pos + face * (1.5 * sm.texel()));
            }
        }
        let i = ambient + diffuse * lambert;
        p.color.map(|c| c * i)
    };
    let norm = 1.0 / (ss * ss) as f64;
    let encode = SrgbTable::get_or_init();
    let mut samples = Vec::with_capacity(ss * ss);
    let bary = |k: usize| {
        let [b0, b1] = weights[k].map(f64::from);
        [b0, b1, 1.0 - b0 - b1]
    };
    for (x, y, px) in img.enumerate_pixels_mut() {
        samples.clear();
        samples.extend((0..ss * ss).map(|s| (x as usize * ss + s % ss) + w * (y as usize * ss + s / ss)));
        let first = prim_id[samples[0]];
        let color = if first != u32::MAX && samples.iter().all(|&k| prim_id[k] == first) {
            // One surface covers the whole pixel: shade once at the mean sample position.
            let mut b = [0.0; 3];
            samples.iter().for_each(|&k| (0..3).for_each(|q| b[q] += bary(k)[q] * norm));
            shade(first, b)
        } else {
            let mut acc = [0.0; 3];
            for &k in &samples {
                let c = shade(prim_id[k], bary(k));
                (0..3).for_each(|q| acc[q] += c[q] * norm);
            }
            acc
        };
        *px = Rgb(color.map(|c| encode.get(c)));
    }
    if let Some(sm) = shadow {
        *shadow_buf = sm.depth;
    }
    img
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

/// Sutherland–Hodgman clip of a triangle against `z ≥ near` in camera space: up to four vertices, and how many.
fn clip_near(verts: &[ClipVert; 3], near: f64) -> ([ClipVert; 4], usize) {
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

/// 5×7 glyph rows (bit 4 = leftmost column), or `None` for a character without a glyph.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        ' ' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00],
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E],
        'c' => [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'f' => [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D],
        'v' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'z' => [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        ';' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x04, 0x08],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '*' => [0x00, 0x04, 0x15, 0x0E, 0x15, 0x04, 0x00],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '[' => [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E],
        ']' => [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E],
        '<' => [0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02],
        '>' => [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '#' => [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A],
        '\'' => [0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00],
        '?' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
        '|' => [0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        _ => return None,
    })
}

/// Width in pixels of `text` drawn at `scale` (6 font columns per character, less the trailing gap).
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    (6 * n).saturating_sub(1) * scale
}

/// Draws `text` with its top-left corner at `(x, y)`, each font pixel a `scale × scale` block, clipped to the
/// image. Characters without a glyph are drawn as `?`.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, scale: u32, color: [u8; 3]) {
    let s = i64::from(scale.max(1));
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    for (ci, c) in text.chars().enumerate() {
        let rows = glyph(c).or_else(|| glyph('?')).unwrap_or([0; 7]);
        let gx = x + 6 * s * ci as i64;
        if gx >= w {
            break;
        }
        for (ry, row) in rows.iter().enumerate() {
            for col in 0..5 {
                if row & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..s {
                    for dx in 0..s {
                        let (px, py) = (gx + col * s + dx, y + ry as i64 * s + dy);
                        if (0..w).contains(&px) && (0..h).contains(&py) {
                            img.put_pixel(px as u32, py as u32, Rgb(color));
                        }
                    }
                }
            }
        }
    }
}

/// Tiles `images` row by row into `columns` columns (clamped to 1 ..= number of images), each tile as large as
/// the largest image plus a [`CAPTION_HEIGHT`] caption strip underneath holding `labels[k]` (missing labels
/// leave the strip blank). The result is `columns · tile_w` × `rows · (tile_h + CAPTION_HEIGHT)`; smaller images
/// are centred in their tile on white. No images give a 0 × 0 image.
pub fn panel(images: &[RgbImage], labels: &[String], columns: usize) -> RgbImage {
    if images.is_empty() {
        return RgbImage::new(0, 0);
    }
    let cols = columns.clamp(1, images.len());
    let rows = images.len().div_ceil(cols);
    let tw = images.iter().map(|i| i.width()).max().unwrap_or(0);
    let th = images.iter().map(|i| i.height()).max().unwrap_or(0);
    let cell_h = th + CAPTION_HEIGHT;
    let mut out = RgbImage::from_pixel(cols as u32 * tw, rows as u32 * cell_h, Rgb([255, 255, 255]));
    for (k, im) in images.iter().enumerate() {
        let (ox, oy) = ((k % cols) as u32 * tw, (k / cols) as u32 * cell_h);
        let (dx, dy) = ((tw - im.width()) / 2, (th - im.height()) / 2);
        for (x, y, p) in im.enumerate_pixels() {
            out.put_pixel(ox + dx + x, oy + dy + y, *p);
        }
        // A thin rule between picture and caption.
        for x in 0..tw {
            out.put_pixel(ox + x, oy + th, Rgb([200, 200, 200]));
        }
        if let Some(label) = labels.get(k) {
            let tx = i64::from(ox) + (i64::from(tw) - i64::from(text_width(label, CAPTION_SCALE))).max(12) / 2;
            let ty = i64::from(oy + th) + i64::from((CAPTION_HEIGHT - 7 * CAPTION_SCALE) / 2) + 1;
            let mut strip = RgbImage::from_pixel(tw, CAPTION_HEIGHT, Rgb([255, 255, 255]));
            draw_text(&mut strip, tx - i64::from(ox), ty - i64::from(oy + th), label, CAPTION_SCALE, [30, 30, 30]);
            for (x, y, p) in strip.enumerate_pixels() {
                if y > 0 {
                    out.put_pixel(ox + x, oy + th + y, *p);
                }
            }
        }
    }
    out
}

/// Encodes `img` as PNG in memory.
pub fn encode_png(img: &RgbImage) -> io::Result<Vec<u8>> {
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgb8)
        .map_err(io::Error::other)?;
    Ok(buf)
}

/// Writes `img` as a PNG file at `path`, atomically.
pub fn save_png(path: impl AsRef<Path>, img: &RgbImage) -> io::Result<()> {
    write_atomic(path, &encode_png(img)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;
    use crate::io::scratch_dir;
    use crate::surface::coons::CoonsSurface;

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

        let mut img = RgbImage::from_pixel(80, 20, Rgb([255, 255, 255]));
        draw_text(&mut img, 1, 1, "Ab9=.:-/", 1, [0, 0, 0]);
        let ink = img.pixels().filter(|p| p.0 == [0, 0, 0]).count();
        assert!(ink > 40, "{ink}");
        assert_eq!(text_width("abc", 2), 34);
        // Every required character has a glyph with ink (except space).
        for c in "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz=.:-/".chars() {
            assert!(glyph(c).unwrap().iter().any(|&r| r != 0), "{c}");
        }
        // Clipped drawing off the image does not panic.
        draw_text(&mut img, -7, 15, "xyz", 3, [0, 0, 0]);
    }
}
