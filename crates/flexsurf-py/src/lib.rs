//! `flexsurf._flexsurf`: the Python extension module of flexsurf, built by maturin from `python/pyproject.toml`.
//! The Python package `flexsurf` (in `python/flexsurf`) re-exports it and adds what is plain Python (the
//! sweeps, the `run` wrapper). Scenes are read and checked by the library, so a dict given from Python is
//! validated, and its errors name the key, exactly as a TOML file's are.

mod convert;
mod layout;
mod simulation;

use convert::{dict_to_table, to_py, toml_to_py, Count, NotBool, Real};
use flexsurf::integrate::Method;
use flexsurf::lab::cantilever::{cantilever as run_cantilever, length_problem, Direction, Strip};
use flexsurf::lab::cusick::{cusick_specimen, default_grid, DISC};
use flexsurf::lab::kes::kes as run_kes;
use flexsurf::material::{Calibration, Fabric};
use flexsurf::runner::{output_steps, run_scene_with, RunOptions};
use flexsurf::scene::material::{load_material_file, material_from_toml, ResolvedMaterial};
use flexsurf::scene::{SceneError as LibSceneError, SceneSpec};
use numpy::ndarray::{Array2, ArrayD, IxDyn};
use numpy::IntoPyArray;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::Arc;

create_exception!(_flexsurf, FlexsurfError, PyException, "Base class of the errors flexsurf raises.");
create_exception!(
    _flexsurf,
    SceneError,
    FlexsurfError,
    "A scene or material that cannot be read or used; `key` is the dotted key it is about."
);
create_exception!(
    _flexsurf,
    SimulationError,
    FlexsurfError,
    "A run or a step that failed (divergence, a failed solve, an output that cannot be written)."
);

create_exception!(
    _flexsurf,
    FlexsurfWarning,
    pyo3::exceptions::PyUserWarning,
    "A value outside the usual range of fabrics (most often a unit slip: `density = 70` typed in g/m²) or a setting \
     that will not work well (the lagged scheme above its stability limit); the message names the file and the key, \
     as the command line's warnings do."
);

/// Issues each of `warnings` (a scene's, a material file's or a fit file's) as a [`FlexsurfWarning`], as the
/// command line prints them: a scene checked from Python said nothing of a unit slip.
fn warn_all(py: Python<'_>, warnings: &[flexsurf::scene::SceneWarning]) -> PyResult<()> {
    let category = py.get_type::<FlexsurfWarning>();
    for w in warnings {
        let message = std::ffi::CString::new(w.to_string().replace('\0', " "))?;
        PyErr::warn(py, &category, &message, 2)?;
    }
    Ok(())
}

create_exception!(
    _flexsurf,
    FolderError,
    FlexsurfError,
    "An output folder that cannot be used as it is: another run's outputs (pass `overwrite=True`), files flexsurf \
     did not write, a symbolic link inside it, or another run writing into it now."
);

/// A run's error as a Python exception: a folder problem as `FolderError` (in the words of the Python
/// call: `overwrite=True`, not a command-line flag), anything else as `SimulationError`.
fn run_err(e: &flexsurf::runner::RunError) -> PyErr {
    use flexsurf::runner::manifest::{OVERWRITE_HINT, RESUME_HINT};
    match e {
        flexsurf::runner::RunError::Folder { .. } => FolderError::new_err(
            e.to_string()
                .replace(OVERWRITE_HINT, "pass overwrite=True")
                .replace(RESUME_HINT, "resume it from the command line (flexsurf run SCENE --resume)"),
        ),
        _ => sim_err(with_causes(e)),
    }
}

/// A library scene error as a Python `SceneError` carrying `key` (the dotted key) and `file`.
fn scene_err(py: Python<'_>, e: &LibSceneError) -> PyErr {
    let err = SceneError::new_err(with_causes(e));
    let value = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail in practice; keep the message if it does.
    let _ = value.setattr("key", e.key());
    err
}

/// The message of `e` followed by those of its causes that it does not already contain (the operating system's
/// reason a file cannot be read), as the command line prints them.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !message.contains(&text) {
            message = format!("{message}: {text}");
        }
        cause = c.source();
    }
    message
}

/// Any other library error as a `SimulationError` with its message.
fn sim_err(e: impl std::fmt::Display) -> PyErr {
    SimulationError::new_err(e.to_string())
}

/// A built scene: model, initial state and run settings, read and checked by the library.
#[pyclass(module = "flexsurf._flexsurf", name = "Scene", frozen)]
pub struct PyScene {
    /// The library's scene (shared by the simulations made from it).
    pub scene: Arc<flexsurf::scene::Scene>,
}

#[pymethods]
impl PyScene {
    /// Reads, checks and builds the TOML scene at `path` (as `flexsurf run` does).
    #[staticmethod]
    fn from_toml(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let scene = flexsurf::scene::load(&path).map_err(|e| scene_err(py, &e))?;
        warn_all(py, &scene.warnings)?;
        Ok(Self { scene: Arc::new(scene) })
    }

    /// Checks and builds a scene given as a dict with the TOML's keys. `file` is the path the dict stands for:
    /// it names the scene when it has no `name`, relative paths in it are found from its folder, and errors
    /// name it (default `<dict>` in the current directory).
    #[staticmethod]
    #[pyo3(signature = (d, file = None))]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyDict>, file: Option<PathBuf>) -> PyResult<Self> {
        let file = file.unwrap_or_else(|| PathBuf::from("<dict>"));
        let table = dict_to_table(d, "")?;
        let text = toml::to_string(&table).map_err(|e| SceneError::new_err(format!("{}: {e}", file.display())))?;
        let spec = SceneSpec::from_toml(&text, &file).map_err(|e| scene_err(py, &e))?;
        let scene = spec.build(&file).map_err(|e| scene_err(py, &e))?;
        warn_all(py, &scene.warnings)?;
        Ok(Self { scene: Arc::new(scene) })
    }

    /// Scene name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// The scene's warnings (each also issued as a `FlexsurfWarning` when the scene was read), as the command
    /// line prints them: the file, the dotted key and what is unusual.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.iter().map(ToString::to_string).collect()
    }

    /// The file the scene was read from (or stands for).
    #[getter]
    fn file(&self) -> PathBuf {
        self.scene.file.clone()
    }

    /// Nodes `(M, N)` of a scene of one sheet (its position arrays are `(M, N, 3)`); a scene of several sheets
    /// or panels has no grid (its arrays are `(n, 3)`: `shape`).
    #[getter]
    fn grid(&self) -> PyResult<(usize, usize)> {
        let g = layout::Layout::of(&self.scene.model).grid()?;
        Ok((g.m, g.n))
    }

    /// The shape of the scene's position arrays: `(M, N, 3)` over one sheet's grid, else `(n, 3)` over its
    /// nodes (a node a seam joins once).
    #[getter]
    fn shape<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        pyo3::types::PyTuple::new(py, layout::Layout::of(&self.scene.model).shape())
    }

    /// Time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.scene.dt
    }

    /// Steps of a run.
    #[getter]
    fn steps(&self) -> usize {
        self.scene.steps
    }

    /// Frame cadence (steps).
    #[getter]
    fn output_every(&self) -> usize {
        self.scene.output_every
    }

    /// Material name.
    #[getter]
    fn material(&self) -> String {
        self.scene.material.clone()
    }

    /// The scene's fabric constants (SI) as a dict.
    #[getter]
    fn fabric<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.scene.model.fabric)
    }

    /// `True` for `integrator.kind = "static"` (a solve to equilibrium: use `flexsurf.run`).
    #[getter]
    fn is_static(&self) -> bool {
        matches!(self.scene.method(), Method::Static(_))
    }

    /// Total mass of the sheet (kg).
    #[getter]
    fn total_mass(&self) -> f64 {
        self.scene.model.total_mass()
    }

    /// The sheets or panels, in node order, each a dict: `shape` `(M, N)`, `nodes` (an `(M, N)` int64 array: the
    /// node of `(i, j)` in the `(n, 3)` arrays' numbering, a node a seam joins appearing in both its panels) and,
    /// for a sewn garment, the panel's `name`. `positions[panel["nodes"]]` is a panel's `(M, N, 3)` grid.
    #[getter]
    fn panels<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let names = self.scene.sewing.as_ref().map(|s| s.panels.clone()).unwrap_or_default();
        let mut out = Vec::new();
        for (k, p) in self.scene.model.panels.iter().enumerate() {
            let g = p.grid;
            let nodes: Vec<i64> = (0..g.m)
                .flat_map(|i| (0..g.n).map(move |j| (i, j)))
                .map(|(i, j)| p.nodes()[g.index(i, j)] as i64)
                .collect();
            let d = PyDict::new(py);
            d.set_item("shape", (g.m, g.n))?;
            d.set_item("nodes", Array2::from_shape_vec((g.m, g.n), nodes).map_err(sim_err)?.into_pyarray(py))?;
            if let Some(name) = names.get(k) {
                d.set_item("name", name)?;
            }
            out.push(d);
        }
        Ok(out)
    }

    fn __repr__(&self) -> String {
        let sheets: Vec<String> =
            self.scene.model.panels.iter().map(|p| format!("{}x{}", p.grid.m, p.grid.n)).collect();
        format!(
            "Scene({:?}, grid={}, dt={}, steps={})",
            self.scene.name,
            sheets.join("+"),
            self.scene.dt,
            self.scene.steps
        )
    }
}

/// Reads a TOML file into a dict (the raw keys, unchecked; for building variants with `Scene.from_dict`).
#[pyfunction]
fn read_toml<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let text = std::fs::read_to_string(&path)
        .map_err(|e| SceneError::new_err(format!("{}: cannot read the file: {e}", path.display())))?;
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| SceneError::new_err(format!("{}: {}", path.display(), e.message().trim())))?;
    toml_to_py(py, &toml::Value::Table(table))
}

/// Runs `scene` into `out` (the files of `flexsurf run`, bit for bit), with the GIL released. Returns the
/// summary (a dict), the output steps and the node positions at those steps, shape `(F, M, N, 3)` (one sheet)
/// or `(F, n, 3)` (`Scene.shape` after `F`). With
/// `overwrite`, the outputs of another run in `out` are removed first (exactly the files its manifest lists).
#[pyfunction]
#[pyo3(signature = (scene, out, overwrite = false))]
fn run_into<'py>(
    py: Python<'py>,
    scene: &PyScene,
    out: PathBuf,
    overwrite: bool,
) -> PyResult<(Bound<'py, PyAny>, Vec<usize>, Bound<'py, PyAny>)> {
    let sc = Arc::clone(&scene.scene);
    let steps =
        if matches!(sc.method(), Method::Static(_)) { vec![0, 1] } else { output_steps(sc.steps, sc.output_every) };
    let layout = layout::Layout::of(&sc.model);
    let result = py.detach(|| {
        let mut frames: Vec<f64> = Vec::with_capacity(steps.len() * layout.len() * 3);
        let mut kept = Vec::with_capacity(steps.len());
        let mut keep = |state: &flexsurf::state::State| {
            if steps.binary_search(&state.step).is_ok() && kept.last() != Some(&state.step) {
                kept.push(state.step);
                layout.push(|k| state.x[k], &mut frames);
            }
        };
        keep(&sc.state);
        let options = RunOptions { overwrite, ..RunOptions::default() };
        run_scene_with(&sc, &out, &options, &mut keep).map(|o| (o, kept, frames))
    });
    let (output, kept, frames) = result.map_err(|e| run_err(&e))?;
    let count = kept.len();
    let shape: Vec<usize> = std::iter::once(count).chain(layout.shape()).collect();
    let frames = ArrayD::from_shape_vec(IxDyn(&shape), frames).map_err(sim_err)?.into_pyarray(py).into_any();
    Ok((to_py(py, &output.summary)?, kept, frames))
}

/// A fabric: SI constants and a display name.
#[pyclass(module = "flexsurf._flexsurf", name = "Material", frozen)]
#[derive(Clone)]
pub struct PyMaterial {
    material: ResolvedMaterial,
}

#[pymethods]
impl PyMaterial {
    /// A material from keyword arguments, with the keys of a scene's `[material]` table: `units` (`"si"`
    /// default, `"kes"` or `"fast"`), `preset`, `file`, `name`, `source` and the constants (in SI: `density`
    /// kg/m², `damping` kg/(m²·s), `tensile_warp`/`tensile_weft`/`shear` N/m, `bending_warp`/`bending_weft`/
    /// `twist` N·m, `poisson`, `bending_poisson`; in KES and FAST units as docs/scenes.md lists them).
    #[new]
    #[pyo3(signature = (**kwargs))]
    fn new(py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let table = match kwargs {
            Some(d) => dict_to_table(d, "")?,
            None => toml::Table::new(),
        };
        let file = Path::new("<material>");
        let text = toml::to_string(&table).map_err(|e| SceneError::new_err(format!("<material>: {e}")))?;
        let material = material_from_toml(&text, file).map_err(|e| scene_err(py, &e))?;
        warn_all(py, &material.warnings)?;
        Ok(Self { material })
    }

    /// Reads a material file (`materials/*.toml`; SI, KES or FAST units).
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let material = load_material_file(&path).map_err(|e| scene_err(py, &e))?;
        warn_all(py, &material.warnings)?;
        Ok(Self { material })
    }

    /// The paper's non-woven cotton.
    #[staticmethod]
    fn paper_cotton() -> Self {
        let (fabric, name) = (Fabric::paper_cotton(), "paper-cotton".into());
        Self { material: ResolvedMaterial { fabric, name, warnings: Vec::new(), laws: Default::default() } }
    }

    /// Display name.
    #[getter]
    fn name(&self) -> String {
        self.material.name.clone()
    }

    /// The SI constants as a dict (`twist` is `None` for Huber's default).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.material.fabric)
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        let d = to_py(py, &self.material.fabric)?;
        match d.get_item(name) {
            Ok(v) => Ok(v.unbind()),
            Err(_) => Err(pyo3::exceptions::PyAttributeError::new_err(format!("Material has no attribute `{name}`"))),
        }
    }

    fn __repr__(&self) -> String {
        let f = &self.material.fabric;
        format!(
            "Material({:?}, density={}, tensile_warp={}, tensile_weft={}, shear={}, bending_warp={}, bending_weft={})",
            self.material.name, f.density, f.tensile_warp, f.tensile_weft, f.shear, f.bending_warp, f.bending_weft
        )
    }
}

/// The fabric of an optional `material` argument: a `Material`, a path to a material file, or `None` (the
/// paper's non-woven cotton).
fn fabric_of(py: Python<'_>, material: Option<&Bound<'_, PyAny>>) -> PyResult<Fabric> {
    match material {
        None => Ok(Fabric::paper_cotton()),
        Some(m) => {
            if let Ok(mat) = m.cast::<PyMaterial>() {
                Ok(mat.get().material.fabric)
            } else if let Ok(d) = m.cast::<PyDict>() {
                Ok(PyMaterial::new(py, Some(d))?.material.fabric)
            } else {
                let path: PathBuf = m.extract().map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err("material: expected a Material, a dict or a path")
                })?;
                Ok(PyMaterial::from_file(py, path)?.material.fabric)
            }
        }
    }
}

fn calibration_of(name: &str) -> PyResult<Calibration> {
    match name {
        "kes" => Ok(Calibration::Kes),
        "paper" => Ok(Calibration::Paper),
        _ => Err(PyValueError::new_err(format!("calibration: {name:?} must be \"kes\" or \"paper\""))),
    }
}

/// The KES-F virtual tests (tension warp/weft/bias, shear, bending warp/weft) as a dict: `input`,
/// `recovered`, `relative_error`, `worst`.
#[pyfunction]
#[pyo3(signature = (material = None, calibration = "kes"))]
fn kes<'py>(py: Python<'py>, material: Option<&Bound<'py, PyAny>>, calibration: &str) -> PyResult<Bound<'py, PyAny>> {
    let fabric = fabric_of(py, material)?;
    let cal = calibration_of(calibration)?;
    let report = py.detach(|| run_kes(&fabric, cal)).map_err(sim_err)?;
    let d = to_py(py, &report)?;
    d.set_item("worst", report.worst())?;
    Ok(d)
}

/// The cantilever (Peirce / ASTM D1388) test as a dict. `direction` is `"warp"`, `"weft"` or `"bias"`,
/// `width` the strip width (m), `overhang` (m) default the Peirce length of the input.
#[pyfunction]
#[pyo3(signature = (material = None, direction = "warp", width = NotBool(Strip::WIDTH), overhang = None, calibration = "kes"))]
fn cantilever<'py>(
    py: Python<'py>,
    material: Option<&Bound<'py, PyAny>>,
    direction: &str,
    width: Real,
    overhang: Option<Real>,
    calibration: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let fabric = fabric_of(py, material)?;
    let cal = calibration_of(calibration)?;
    let direction = match direction {
        "warp" => Direction::Warp,
        "weft" => Direction::Weft,
        "bias" => Direction::Bias,
        _ => return Err(PyValueError::new_err(format!("direction: {direction:?} must be warp, weft or bias"))),
    };
    let (width, overhang) = (width.0, overhang.map(|o| o.0));
    for (name, value) in [("width", Some(width)), ("overhang", overhang)] {
        if let Some(p) = value.and_then(length_problem) {
            return Err(PyValueError::new_err(format!("{name}: {p}")));
        }
    }
    let strip = Strip { direction, width };
    let report = py.detach(|| run_cantilever(&fabric, cal, strip, overhang)).map_err(sim_err)?;
    to_py(py, &report)
}

/// The Cusick drape test (18 cm disc) as a dict: `drape_coefficient` (%), `nodes`, `shadow_area` (m²), ….
/// `specimen` is the diameter (m), `level` the grid (0 coarse, 1 default, 2 fine), `index` which specimen
/// (each starts from a different small wobble of the hem; 0 is the CLI's first).
#[pyfunction]
#[pyo3(signature = (material = None, specimen = NotBool(0.30), level = NotBool(1), index = NotBool(0), calibration = "kes"))]
fn cusick<'py>(
    py: Python<'py>,
    material: Option<&Bound<'py, PyAny>>,
    specimen: Real,
    level: Count,
    index: Count,
    calibration: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let (specimen, level, index) = (specimen.0, level.0, index.0);
    let fabric = fabric_of(py, material)?;
    let cal = calibration_of(calibration)?;
    if !(specimen.is_finite() && specimen > DISC) {
        return Err(PyValueError::new_err(format!("specimen: {specimen} m must be larger than the {DISC} m disc")));
    }
    if level > 2 {
        return Err(PyValueError::new_err(format!("level: {level} must be 0, 1 or 2")));
    }
    let (radial, angular) = default_grid(specimen, level);
    let drape = py.detach(|| cusick_specimen(&fabric, cal, specimen, radial, angular, index)).map_err(sim_err)?;
    to_py(py, &drape.report)
}

/// `flexsurf fit` from Python: the material constants that explain measured targets. `problem` is the path of a
/// fit file or a dict with its keys (`material`, `units`, `free`, `target`, …; docs/materials.md, "Fitting"),
/// `file` the path a dict stands for (its material is found relative to it; default `<dict>` in the current
/// directory). Returns a dict: `problem` (as read, SI) and `report` (`constants` with `value`,
/// `standard_error`, `identifiable`; `residuals`; `not_identifiable`; `null_directions`; `iterations`, …).
#[pyfunction]
#[pyo3(signature = (problem, file = None))]
fn fit<'py>(py: Python<'py>, problem: &Bound<'py, PyAny>, file: Option<PathBuf>) -> PyResult<Bound<'py, PyAny>> {
    use flexsurf::lab::fit::input::{load_fit_file, problem_from_toml};
    let p = if let Ok(d) = problem.cast::<PyDict>() {
        let file = file.unwrap_or_else(|| PathBuf::from("<dict>"));
        let table = dict_to_table(d, "")?;
        let text = toml::to_string(&table).map_err(|e| SceneError::new_err(format!("{}: {e}", file.display())))?;
        problem_from_toml(&text, &file).map_err(|e| scene_err(py, &e))?
    } else {
        let path: PathBuf = problem
            .extract()
            .map_err(|_| pyo3::exceptions::PyTypeError::new_err("problem: expected a fit file's path or a dict"))?;
        load_fit_file(&path).map_err(|e| scene_err(py, &e))?
    };
    warn_all(py, &p.warnings)?;
    let report = py.detach(|| flexsurf::lab::fit::fit(&p)).map_err(sim_err)?;
    let d = PyDict::new(py);
    d.set_item("problem", to_py(py, &p)?)?;
    d.set_item("report", to_py(py, &report)?)?;
    Ok(d.into_any())
}

/// The extension module.
#[pymodule]
fn _flexsurf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FlexsurfError", py.get_type::<FlexsurfError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("FolderError", py.get_type::<FolderError>())?;
    m.add("FlexsurfWarning", py.get_type::<FlexsurfWarning>())?;
    m.add_class::<PyScene>()?;
    m.add_class::<PyMaterial>()?;
    m.add_class::<simulation::PySimulation>()?;
    m.add_function(wrap_pyfunction!(read_toml, m)?)?;
    m.add_function(wrap_pyfunction!(run_into, m)?)?;
    m.add_function(wrap_pyfunction!(kes, m)?)?;
    m.add_function(wrap_pyfunction!(cantilever, m)?)?;
    m.add_function(wrap_pyfunction!(cusick, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
