//! Panels: several pictures tiled row by row into one image, each with a caption strip under it.

use super::text::{draw_text, text_width};
use image::{Rgb, RgbImage};

/// Height in pixels of the caption strip under each tile of [`panel`].
pub const CAPTION_HEIGHT: u32 = 24;
/// Scale factor of caption text (glyphs are 5×7 font pixels, so captions are 10×14 image pixels).
pub const CAPTION_SCALE: u32 = 2;

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

#[cfg(test)]
mod tests {
    use super::super::text::glyph;
    use super::*;

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
