//! Panels: several pictures tiled row by row into one image, each with a caption strip under it, an optional
//! title strip over the whole, and the layout rule that never leaves an empty cell.

use super::text::{draw_text, line_height, text_width, title_strip};
use image::{Rgb, RgbImage};

/// Height in pixels of the caption strip under each tile of [`panel`].
pub const CAPTION_HEIGHT: u32 = 26;
/// Caption text size (pixels).
pub const CAPTION_SIZE: f32 = 16.0;
/// Height in pixels of the title strip of [`with_title`].
pub const TITLE_HEIGHT: u32 = 34;
/// Title text size (pixels).
pub const TITLE_SIZE: f32 = 20.0;

/// How many of `n` pictures to show and in how many columns, so that every row is full: up to 5 in one row,
/// 6 or 7 as 3 × 2 (six of them), 8 or more as 4 × 2 (eight of them).
pub fn grid_layout(n: usize) -> (usize, usize) {
    match n {
        0..=5 => (n, n.max(1)),
        6 | 7 => (6, 3),
        _ => (8, 4),
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
            let mut strip = RgbImage::from_pixel(tw, CAPTION_HEIGHT - 1, Rgb([255, 255, 255]));
            let tx = (i64::from(tw) - i64::from(text_width(label, CAPTION_SIZE))).max(12) / 2;
            let ty = (i64::from(CAPTION_HEIGHT - 1) - i64::from(line_height(CAPTION_SIZE))) / 2;
            draw_text(&mut strip, tx, ty, label, CAPTION_SIZE, [30, 30, 30]);
            for (x, y, p) in strip.enumerate_pixels() {
                out.put_pixel(ox + x, oy + th + 1 + y, *p);
            }
        }
    }
    out
}

/// `img` with a [`TITLE_HEIGHT`] strip above it holding `title`, centred.
pub fn with_title(img: &RgbImage, title: &str) -> RgbImage {
    let strip = title_strip(img.width(), TITLE_HEIGHT, title, TITLE_SIZE);
    let mut out = RgbImage::from_pixel(img.width(), img.height() + TITLE_HEIGHT, Rgb([255, 255, 255]));
    for (x, y, p) in strip.enumerate_pixels() {
        out.put_pixel(x, y, *p);
    }
    for (x, y, p) in img.enumerate_pixels() {
        out.put_pixel(x, y + TITLE_HEIGHT, *p);
    }
    out
}

/// `img` below a white strip `height` pixels high (for text drawn over it afterwards).
pub fn pad_top(img: &RgbImage, height: u32) -> RgbImage {
    let mut out = RgbImage::from_pixel(img.width(), img.height() + height, Rgb([255, 255, 255]));
    image::imageops::replace(&mut out, img, 0, i64::from(height));
    out
}
