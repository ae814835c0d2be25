//! PNG output of the rendered pictures, in memory or written atomically through [`crate::io::atomic`].

use crate::io::atomic::write_atomic;
use image::{ImageEncoder, RgbImage};
use std::io;
use std::path::Path;

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
