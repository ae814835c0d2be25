//! A small deterministic software renderer for figures: a z-buffered triangle rasteriser with Lambert + ambient
//! shading (two-sided, for cloth), optional shadow mapping, supersampled anti-aliasing and a perspective camera.
//! It draws cloth meshes and the analytic obstacles (a UV-tessellated sphere, a checkered ground plane), tiles
//! several views into a captioned panel with a real font (DejaVu Sans), and writes PNG through
//! [`super::atomic`]. Everything is single-threaded, so the same input gives the same bytes.
//!
//! The pipeline of [`render`], one file a stage:
//!
//! * `scene`: the [`Drawable`]s, their default colours and bounding boxes, and their triangles (meshes as
//!   given, spheres as [`uv_sphere`]s, planes as [`checkered_square`]s sized to the rest of the scene).
//! * `camera`: the [`View`] (camera, light, shading settings), [`default_view_for`] a bounding box, the
//!   perspective projection and the near-plane clip.
//! * `raster`: the triangle rasteriser (pixel centres inside a screen triangle, with barycentric weights) and
//!   the z-buffer of the supersampled image.
//! * `shadow`: the shadow map seen from the light.
//! * `shade`: Lambert + ambient shading, sRGB conversion and the resolve of the supersamples into pixels.
//! * `frame`: [`render`] itself, with the per-thread buffers it reuses.
//! * `text`, `panel`, `png`: text in DejaVu Sans through `ab_glyph` ([`draw_text`]), the captioned
//!   [`panel()`] of several pictures (with [`with_title`] and the [`grid_layout`] without empty cells) and PNG
//!   output ([`save_png`]).
//! * [`annotate`]: scale bar, axis triad and world-space lines over a rendered picture.

pub mod annotate;
mod camera;
mod frame;
mod panel;
mod png;
mod raster;
mod scene;
mod shade;
mod shadow;
mod text;

pub use camera::{default_view_for, View};
pub use frame::render;
/// The picture type the renderer returns (re-exported so callers need not depend on `image`).
pub use image::RgbImage as Picture;
pub use panel::{grid_layout, pad_top, panel, with_title, CAPTION_HEIGHT, CAPTION_SIZE, TITLE_HEIGHT};
pub use png::{encode_png, save_png};
pub use scene::{
    bbox_of, checkered_square, uv_sphere, Drawable, BACKGROUND_COLOR, CLOTH_COLOR, GROUND_COLOR, SPHERE_COLOR,
};
pub use text::{draw_text, draw_text_centered, line_height, register_plot_font, text_width, FONT_BYTES};
