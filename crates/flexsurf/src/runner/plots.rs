//! Charts a person would rather look at than read, drawn with `plotters` (bitmap backend, the embedded DejaVu
//! Sans registered as its font, so no system fonts are needed) and written as PNG through
//! [`crate::io::atomic`]: the line charts of a run's `energy.png` ([`super::outputs::energy`]) and of the virtual
//! tests' sweeps ([`line_chart`]).

use super::summary::Summary;
use crate::io::render::{self, register_plot_font};
use crate::scene::Scene;
use plotters::prelude::*;
use std::path::Path;

/// How pictures name the models.
pub fn model_label(kind: &str) -> &'static str {
    match kind {
        "tfs" => "TFS",
        "terzopoulos" => "Terzopoulos",
        _ => "flexsurf",
    }
}

/// What `animation.glb` records about the run besides the frames.
pub fn run_info(scene: &Scene, summary: &Summary) -> serde_json::Value {
    // The viewer's warp and weft lines, one a grid spacing apart (the UVs are metres along the grain).
    let panels = &scene.model.panels;
    let mean =
        |h: fn(&crate::grid::Grid) -> f64| panels.iter().map(|p| h(&p.grid)).sum::<f64>() / panels.len().max(1) as f64;
    serde_json::json!({
        "line_spacing": [mean(|g| g.h1), mean(|g| g.h2)],
        "scene": scene.name,
        "model": summary.model,
        "integrator": summary.integrator,
        "grid": summary.grid,
        "dt": summary.dt,
        "steps": summary.steps,
        "output_every": summary.output_every,
        "animation_every": summary.animation_every,
        "simulated_seconds": summary.simulated_seconds,
    })
}

/// One line of a chart: its name, colour and points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Line colour (sRGB).
    pub color: [u8; 3],
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Mark every point with a dot (for sweeps of a few values).
    pub dots: bool,
}

/// Axis range of `values` with a margin; a flat or empty range is widened so the chart has an extent.
fn range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) =
        values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    // At least 2 % of the values' magnitude, so that rounding noise does not fill the chart.
    let span = (hi - lo).max(0.02 * lo.abs().max(hi.abs())).max(1e-12);
    let (lo, hi) = if hi - lo < span { (lo - 0.5 * span, hi + 0.5 * span) } else { (lo, hi) };
    (lo - pad * (hi - lo), hi + pad * (hi - lo))
}

/// Tick labels for an axis spanning `span`: as many decimals as its size needs (no "-0.0"), or an exponent
/// form for very large or very small values.
fn tick_format(span: f64) -> impl Fn(&f64) -> String {
    let exp = !(1e-4..1e6).contains(&span.abs());
    let decimals = if exp { 0 } else { (2.0 - span.abs().log10().floor()).clamp(0.0, 6.0) as usize };
    move |v: &f64| {
        let v = if v.abs() < span.abs() * 1e-9 { 0.0 } else { *v };
        if exp {
            format!("{v:.2e}")
        } else {
            format!("{v:.decimals$}")
        }
    }
}

/// Draws a line chart of `series` into an RGB buffer of `w × h` pixels.
fn chart_pixels(
    w: u32,
    h: u32,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<Vec<u8>, String> {
    register_plot_font();
    let mut buf = vec![255u8; 3 * w as usize * h as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (x0, x1) = range(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)), 0.0);
        let (y0, y1) = range(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)), 0.05);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(74)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?;
        let (fx, fy) = (tick_format(x1 - x0), tick_format(y1 - y0));
        chart
            .configure_mesh()
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| e.to_string())?;
        for s in series {
            let color = RGBColor(s.color[0], s.color[1], s.color[2]);
            let pts: Vec<(f64, f64)> =
                s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            if s.dots {
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled()))).map_err(|e| e.to_string())?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .label_font(("sans-serif", 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(buf)
}

/// Writes a line chart of `series` as a PNG at `path` (`w × h` pixels), atomically.
pub fn line_chart(
    path: &Path,
    size: (u32, u32),
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> std::io::Result<()> {
    let (w, h) = size;
    let buf = chart_pixels(w, h, title, x_label, y_label, series)
        .map_err(|e| std::io::Error::other(format!("chart: {e}")))?;
    let img = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| std::io::Error::other("chart buffer size"))?;
    render::save_png(path, &img)
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `tick_format`.
    pub fn tick_format(span: f64) -> impl Fn(&f64) -> String {
        super::tick_format(span)
    }
}
