//! Annotations drawn over a rendered picture: a scale bar (a round length at the depth of the view's target)
//! and an axis triad (the world's x, y, z as the camera sees them), and lines and circles through world points.

use super::camera::{Camera, View};
use super::text::{draw_text, line_height, text_width};
use crate::math::Vec3;
use image::RgbImage;

/// Raster position of the world point `p` in a `w × h` picture of `view`, or `None` behind the camera.
pub fn project(view: &View, w: u32, h: u32, p: Vec3) -> Option<[f64; 2]> {
    let cam = Camera::new(view, w as usize, h as usize);
    let c = cam.to_camera(p);
    (c.z > cam.near).then(|| cam.to_screen(c))
}

/// Pixels per metre at the depth of the view's target in a picture `h` pixels high.
pub fn pixels_per_metre(view: &View, h: u32) -> f64 {
    let fov = if view.fov_y_deg.is_finite() { view.fov_y_deg.clamp(1.0, 170.0) } else { 30.0 };
    let focal = 0.5 * f64::from(h) / (0.5 * fov.to_radians()).tan();
    focal / (view.target - view.eye).length().max(1e-9)
}

/// A round length (1, 2 or 5 × 10ⁿ m) near `target` metres, and its label.
pub fn round_length(target: f64) -> (f64, String) {
    let target = if target.is_finite() && target > 0.0 { target } else { 1.0 };
    let e = target.log10().floor();
    let base = 10f64.powf(e);
    let m = [1.0, 2.0, 5.0, 10.0].into_iter().rfind(|m| m * base <= target * 1.0001).unwrap_or(1.0);
    let l = m * base;
    let label = if l >= 1.0 {
        format!("{} m", trim(l))
    } else if l >= 0.01 {
        format!("{} cm", trim(l * 100.0))
    } else {
        format!("{} mm", trim(l * 1000.0))
    };
    (l, label)
}

fn trim(v: f64) -> String {
    let s = format!("{v:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Blends `color` into pixel `(x, y)` with opacity `a`, if inside.
fn plot(img: &mut RgbImage, x: i64, y: i64, color: [u8; 3], a: f64) {
    if x < 0 || y < 0 || x >= i64::from(img.width()) || y >= i64::from(img.height()) {
        return;
    }
    let p = img.get_pixel_mut(x as u32, y as u32);
    for q in 0..3 {
        p.0[q] = (f64::from(p.0[q]) * (1.0 - a) + f64::from(color[q]) * a).round() as u8;
    }
}

/// A line from `a` to `b` (raster coordinates), `width` pixels wide.
pub fn draw_line(img: &mut RgbImage, a: [f64; 2], b: [f64; 2], width: f64, color: [u8; 3]) {
    if !(a.iter().chain(&b).all(|v| v.is_finite())) {
        return;
    }
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let r = 0.5 * width.max(1.0);
    let (x0, x1) = ((a[0].min(b[0]) - r).floor() as i64, (a[0].max(b[0]) + r).ceil() as i64);
    let (y0, y1) = ((a[1].min(b[1]) - r).floor() as i64, (a[1].max(b[1]) + r).ceil() as i64);
    let (x0, x1) = (x0.max(0), x1.min(i64::from(img.width())));
    let (y0, y1) = (y0.max(0), y1.min(i64::from(img.height())));
    for y in y0..y1 {
        for x in x0..x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let t = if len2 > 0.0 { (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let (qx, qy) = (a[0] + t * dx, a[1] + t * dy);
            let d = ((px - qx).powi(2) + (py - qy).powi(2)).sqrt();
            let cov = (r + 0.5 - d).clamp(0.0, 1.0);
            if cov > 0.0 {
                plot(img, x, y, color, cov);
            }
        }
    }
}

/// A polyline through world points, as `view` sees them in `img`.
pub fn draw_world_polyline(img: &mut RgbImage, view: &View, points: &[Vec3], width: f64, color: [u8; 3]) {
    let (w, h) = (img.width(), img.height());
    for s in points.windows(2) {
        if let (Some(a), Some(b)) = (project(view, w, h, s[0]), project(view, w, h, s[1])) {
            draw_line(img, a, b, width, color);
        }
    }
}

/// Draws a scale bar in the lower left corner: a round length about a fifth of the picture wide at the depth
/// of the view's target, with its label.
pub fn scale_bar(img: &mut RgbImage, view: &View) {
    let (w, h) = (img.width(), img.height());
    let ppm = pixels_per_metre(view, h);
    let (len, label) = round_length(0.2 * f64::from(w) / ppm);
    let px = len * ppm;
    let size = 14.0;
    let (x0, y) = (14.0, f64::from(h) - 14.0);
    let dark = [35, 35, 35];
    draw_line(img, [x0, y], [x0 + px, y], 3.0, dark);
    draw_line(img, [x0, y - 6.0], [x0, y + 1.0], 2.0, dark);
    draw_line(img, [x0 + px, y - 6.0], [x0 + px, y + 1.0], 2.0, dark);
    let tw = f64::from(text_width(&label, size));
    let ty = y as i64 - 8 - i64::from(line_height(size));
    draw_text(img, (x0 + 0.5 * (px - tw)) as i64, ty, &label, size, dark);
}

/// Draws the world axes x (red), y (green), z (blue) as the camera sees them, in the lower right corner.
pub fn axis_triad(img: &mut RgbImage, view: &View) {
    let (w, h) = (img.width(), img.height());
    let f = (view.target - view.eye).try_normalize().unwrap_or(Vec3::Y);
    let r = f.cross(view.up).try_normalize().unwrap_or(Vec3::X);
    let u = r.cross(f);
    let o = [f64::from(w) - 44.0, f64::from(h) - 40.0];
    let len = 26.0;
    for (axis, name, color) in
        [(Vec3::X, "x", [200, 40, 40]), (Vec3::Y, "y", [40, 150, 40]), (Vec3::Z, "z", [40, 70, 210])]
    {
        let d = [axis.dot(r), -axis.dot(u)];
        let tip = [o[0] + len * d[0], o[1] + len * d[1]];
        draw_line(img, o, tip, 2.0, color);
        let lx = o[0] + (len + 8.0) * d[0] - 4.0;
        let ly = o[1] + (len + 8.0) * d[1] - 8.0;
        draw_text(img, lx as i64, ly as i64, name, 13.0, color);
    }
}
