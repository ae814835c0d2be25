//! `energy.csv`: one row per step (step, time, kinetic, membrane, bending and gravitational potential energy,
//! then a column for each further term without an active set, such as `springs`),
//! appended and flushed to the system row by row as the run goes (a kill keeps every row written; a resumed
//! run truncates it to its length at the checkpoint), and `energy.png`, its chart, at the end.

use super::{Context, Frame, Output, OutputState};
use crate::runner::plots::{line_chart, model_label, Series};
use crate::runner::{io_err, RunError, Summary};
use crate::scene::Scene;
use crate::sim;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The energy table, relative to the output folder.
pub const ENERGY_CSV: &str = "energy.csv";
/// Its chart.
pub const ENERGY_PNG: &str = "energy.png";
const HEADER: &str = "step,time,kinetic,membrane,bending,potential\n";

/// The energy output.
pub struct Energy<'a> {
    scene: &'a Scene,
    /// The terms beyond the elastic energy and the loads (springs, ...), a column each after the standard ones.
    extra: Vec<&'static str>,
    out: PathBuf,
    file: Option<std::fs::File>,
    /// Bytes written to `energy.csv` so far.
    bytes: u64,
}

impl<'a> Energy<'a> {
    /// The energy table of the run `cx`.
    pub fn new(cx: &Context<'a>) -> Self {
        let extra = cx.scene.model.potential.extra_energy_names();
        Self { scene: cx.scene, out: cx.out.clone(), extra, file: None, bytes: 0 }
    }

    fn append(&mut self, text: &str) -> Result<(), RunError> {
        let path = self.out.join(ENERGY_CSV);
        let file = self.file.as_mut().ok_or_else(|| io_err(&path)(std::io::Error::other("not started")))?;
        file.write_all(text.as_bytes()).map_err(io_err(&path))?;
        self.bytes += text.len() as u64;
        Ok(())
    }
}

/// Opens `path` to continue after its first `bytes` bytes (the rest, written after the checkpoint, cut).
fn reopen(path: &Path, bytes: u64) -> Result<std::fs::File, RunError> {
    let file = std::fs::OpenOptions::new().append(true).open(path).map_err(io_err(path))?;
    let len = file.metadata().map_err(io_err(path))?.len();
    if len < bytes {
        let message = format!("is {len} bytes, shorter than the {bytes} it had at the checkpoint");
        return Err(RunError::Io { path: path.to_path_buf(), source: std::io::Error::other(message) });
    }
    file.set_len(bytes).map_err(io_err(path))?;
    Ok(file)
}

impl Output for Energy<'_> {
    fn name(&self) -> &'static str {
        "energy"
    }

    fn files(&self) -> Vec<String> {
        vec![ENERGY_CSV.to_string(), ENERGY_PNG.to_string()]
    }

    fn start(&mut self, saved: Option<&OutputState>) -> Result<(), RunError> {
        let path = self.out.join(ENERGY_CSV);
        match saved {
            None => {
                self.file = Some(std::fs::File::create(&path).map_err(io_err(&path))?);
                self.bytes = 0;
                let mut header = HEADER.trim_end().to_string();
                self.extra.iter().for_each(|name| header += &format!(",{}", name.replace(' ', "_")));
                self.append(&(header + "\n"))
            }
            Some(s) => {
                self.bytes = s.get(self.name())?;
                self.file = Some(reopen(&path, self.bytes)?);
                Ok(())
            }
        }
    }

    fn record(&mut self, frame: &Frame<'_>) -> Result<(), RunError> {
        // Only the energies: penetration and strain of every step are not written, so not computed here.
        let d = sim::energies(&self.scene.model, frame.state);
        let mut row = format!(
            "{},{},{:.9e},{:.9e},{:.9e},{:.9e}",
            d.step, d.time, d.kinetic, d.energies.membrane, d.energies.bending, d.potential
        );
        if !self.extra.is_empty() {
            let extra = &self.extra;
            let values = self.scene.model.potential.energies_where(&frame.state.x, false, |i| extra.contains(&i.name));
            values.iter().for_each(|(_, e)| row += &format!(",{e:.9e}"));
        }
        self.append(&(row + "\n"))
    }

    fn save(&self) -> Result<OutputState, RunError> {
        OutputState::of(&self.bytes)
    }

    fn finish(&mut self, _summary: &Summary) -> Result<(), RunError> {
        write_energy_png(&self.out, self.scene)
    }
}

/// The columns of `energy.csv` (time, kinetic, membrane, bending, potential), parsed.
fn energy_rows(text: &str) -> Vec<[f64; 5]> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let v: Vec<f64> = l.split(',').filter_map(|c| c.trim().parse().ok()).collect();
            (v.len() >= 6).then(|| [v[1], v[2], v[3], v[4], v[5]])
        })
        .collect()
}

/// Writes `energy.png` into `out` from its `energy.csv`: kinetic, membrane and bending energy, the change of
/// the gravitational potential energy from the start, and the total of the four, against simulated time.
pub fn write_energy_png(out: &Path, scene: &Scene) -> Result<(), RunError> {
    let csv = out.join(ENERGY_CSV);
    let text = std::fs::read_to_string(&csv).map_err(io_err(&csv))?;
    let rows = energy_rows(&text);
    let Some(first) = rows.first().copied() else { return Ok(()) };
    // A static solve's rows are the start and the equilibrium, both at t = 0: plotted against the state.
    let stat = matches!(scene.method(), crate::integrate::Method::Static(_));
    let x = |k: usize, r: &[f64; 5]| if stat { k as f64 } else { r[0] };
    let line = |name: &str, color: [u8; 3], f: &dyn Fn(&[f64; 5]) -> f64| Series {
        name: name.to_string(),
        color,
        points: rows.iter().enumerate().map(|(k, r)| (x(k, r), f(r))).collect(),
        dots: rows.len() <= 2,
    };
    let series = [
        line("kinetic", [214, 39, 40], &|r| r[1]),
        line("membrane", [31, 119, 180], &|r| r[2]),
        line("bending", [44, 160, 44], &|r| r[3]),
        line("gravity (change from t = 0)", [148, 103, 189], &|r| r[4] - first[4]),
        line("total (change from t = 0)", [40, 40, 40], &|r| {
            r[1] + r[2] + r[3] + r[4] - (first[1] + first[2] + first[3] + first[4])
        }),
    ];
    let title = format!("{}  ·  {} model  ·  energy", scene.name, model_label(scene.model.kind.name()));
    let png = out.join(ENERGY_PNG);
    let axis = if stat { "state (0: start, 1: equilibrium of the static solve)" } else { "simulated time (s)" };
    line_chart(&png, (800, 480), &title, axis, "energy (J)", &series).map_err(io_err(&png))
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    /// `energy_rows`.
    pub fn energy_rows(text: &str) -> Vec<[f64; 5]> {
        super::energy_rows(text)
    }
}
