//! Text: DejaVu Sans (a free font, its licence in `assets/fonts/LICENSE-DejaVu.txt`, carried in the binary)
//! rasterised by `ab_glyph` with anti-aliasing and kerning, blended into an image and clipped to it, for titles,
//! captions and labels. The same font is registered for the `plotters` charts ([`register_plot_font`]).

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use image::{Rgb, RgbImage};
use std::sync::OnceLock;

/// The font file (DejaVu Sans).
pub static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The parsed font (`None` only if the embedded file were corrupt, which the tests rule out).
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).ok()).as_ref()
}

/// Registers the font as `sans-serif` for `plotters` (once; later calls do nothing).
pub fn register_plot_font() -> bool {
    static DONE: OnceLock<bool> = OnceLock::new();
    *DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT_BYTES).is_ok()
    })
}

/// Width in pixels of `text` set at `size` pixels (the em height).
pub fn text_width(text: &str, size: f32) -> u32 {
    let Some(f) = font() else { return 0 };
    let sf = f.as_scaled(PxScale::from(size));
    let mut w = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let id = sf.glyph_id(c);
        if let Some(p) = prev {
            w += sf.kern(p, id);
        }
        w += sf.h_advance(id);
        prev = Some(id);
    }
    w.ceil().max(0.0) as u32
}

/// Height in pixels of a line of text at `size` (ascent + descent).
pub fn line_height(size: f32) -> u32 {
    font().map_or(0, |f| {
        let sf = f.as_scaled(PxScale::from(size));
        (sf.ascent() - sf.descent()).ceil() as u32
    })
}

/// Draws `text` at `size` pixels with its top-left corner (top of the ascent) at `(x, y)`, blended over the
/// image in `color`, clipped to the image.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, size: f32, color: [u8; 3]) {
    let Some(f) = font() else { return };
    let scale = PxScale::from(size);
    let sf = f.as_scaled(scale);
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    let mut caret = x as f32;
    let baseline = y as f32 + sf.ascent();
    let mut prev = None;
    for c in text.chars() {
        let id = sf.glyph_id(c);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        let glyph = id.with_scale_and_position(scale, point(caret, baseline));
        caret += sf.h_advance(id);
        prev = Some(id);
        let Some(outline) = f.outline_glyph(glyph) else { continue };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, cov| {
            let (px, py) = (b.min.x as i64 + i64::from(gx), b.min.y as i64 + i64::from(gy));
            if (0..w).contains(&px) && (0..h).contains(&py) && cov > 0.0 {
                let p = img.get_pixel_mut(px as u32, py as u32);
                let a = cov.clamp(0.0, 1.0);
                for q in 0..3 {
                    p.0[q] = (f32::from(p.0[q]) * (1.0 - a) + f32::from(color[q]) * a).round() as u8;
                }
            }
        });
    }
}

/// Draws `text` centred horizontally on `cx`, top at `y`.
pub fn draw_text_centered(img: &mut RgbImage, cx: i64, y: i64, text: &str, size: f32, color: [u8; 3]) {
    let w = i64::from(text_width(text, size));
    draw_text(img, cx - w / 2, y, text, size, color);
}

/// A white strip `width × height` with `text` centred in it.
pub fn title_strip(width: u32, height: u32, text: &str, size: f32) -> RgbImage {
    let mut strip = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let top = (i64::from(height) - i64::from(line_height(size))) / 2;
    draw_text_centered(&mut strip, i64::from(width) / 2, top, text, size, [25, 25, 25]);
    strip
}
