//! `Simulation`: a scene stepped from Python, one step or many at a time with the GIL released; positions and
//! velocities as numpy arrays (`(M, N, 3)` over one sheet's grid, `(n, 3)` over several sheets' or a garment's
//! nodes: [`Layout`]), pinned nodes and spring targets moved between steps, energies, contacts and per-step
//! timings.

use crate::convert::{vec3, Count, NotBool};
use crate::layout::Layout;
use crate::{sim_err, PyScene, SimulationError};
use flexsurf::integrate::{max_penetration, Method, StepInfo, Stepper};
use flexsurf::model::Model;
use flexsurf::state::State;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyIndexError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

/// Per-step records kept for `timings`.
#[derive(Default)]
struct History {
    wall: Vec<f64>,
    assembly: Vec<f64>,
    contact: Vec<f64>,
    factorization: Vec<f64>,
    solve: Vec<f64>,
    solves: Vec<f64>,
    contacts: Vec<f64>,
}

impl History {
    fn push(&mut self, wall: f64, info: &StepInfo) {
        let t = &info.timings;
        self.wall.push(wall);
        self.assembly.push(t.assembly);
        self.contact.push(t.contact);
        self.factorization.push(t.factorization);
        self.solve.push(t.solve);
        self.solves.push(t.solves as f64);
        self.contacts.push(info.contacts as f64);
    }
}

/// The longest stretch of steps taken without checking for signals (Ctrl-C).
const SIGNAL_CHECK: std::time::Duration = std::time::Duration::from_millis(50);

/// A scene being stepped: its own model (spring targets may change), state and stepper.
#[pyclass(module = "flexsurf._flexsurf", name = "Simulation")]
pub struct PySimulation {
    model: Model,
    /// How the arrays lay the nodes out: `(M, N, 3)` over one sheet's grid, else `(n, 3)`.
    layout: Layout,
    state: State,
    /// In a mutex only to make the class `Sync` (the stepper's scratch is `Send` only); never locked, as the
    /// class's own borrow flag already gives `step` exclusive access.
    stepper: Mutex<Stepper>,
    dt: f64,
    /// The scene's moving pins (`[[pin]] motion`), placed before each step.
    motions: Vec<flexsurf::scene::motion::PinMotion>,
    last: Option<StepInfo>,
    history: History,
}

impl PySimulation {
    /// Node `(i, j)` of a one-sheet scene's grid.
    fn node(&self, i: usize, j: usize) -> PyResult<usize> {
        let g = self.layout.grid()?;
        if i >= g.m || j >= g.n {
            return Err(PyIndexError::new_err(format!("node ({i}, {j}) is outside the {}x{} grid", g.m, g.n)));
        }
        Ok(g.index(i, j))
    }

    /// Node `k` of the model's numbering.
    fn numbered(&self, k: usize) -> PyResult<usize> {
        let n = self.model.nodes();
        if k >= n {
            return Err(PyIndexError::new_err(format!("node {k} is outside the model's {n} nodes")));
        }
        Ok(k)
    }
}

#[pymethods]
impl PySimulation {
    /// A simulation of `scene` from its initial state (a dynamic scene; a static one is solved by `run`).
    #[new]
    fn new(scene: &PyScene) -> PyResult<Self> {
        let sc = &scene.scene;
        let params = match sc.method() {
            Method::Dynamic(p) => p,
            Method::Static(_) => {
                return Err(PyValueError::new_err(
                    "`integrator.kind`: a static scene is solved, not stepped: use flexsurf.run(scene)",
                ))
            }
        };
        let layout = Layout::of(&sc.model);
        let model = sc.model.clone();
        let stepper = Stepper::new(&model, &params).map_err(sim_err)?;
        Ok(Self {
            model,
            layout,
            motions: sc.motions.clone(),
            state: sc.state.clone(),
            stepper: Mutex::new(stepper),
            dt: sc.dt,
            last: None,
            history: History::default(),
        })
    }

    /// Takes `n` steps (default 1) with the GIL released; returns the step count reached. A failed step raises
    /// `SimulationError` and leaves the state at the last good step. Signals are checked between steps (at
    /// least every [`SIGNAL_CHECK`]): Ctrl-C raises `KeyboardInterrupt`, the state at the last step taken.
    #[pyo3(signature = (n = NotBool(1)))]
    fn step(&mut self, py: Python<'_>, n: Count) -> PyResult<usize> {
        let n = n.0;
        let Self { model, state, stepper, last, history, motions, dt, .. } = self;
        let stepper = stepper.get_mut().unwrap_or_else(PoisonError::into_inner);
        let mut done = 0;
        while done < n {
            let result = py.detach(|| {
                let start = Instant::now();
                let mut taken = 0;
                while done + taken < n && (taken == 0 || start.elapsed() < SIGNAL_CHECK) {
                    let before = state.clone();
                    let t0 = Instant::now();
                    // The scene's moving pins are placed before each step.
                    let stepped = flexsurf::scene::motion::drive(motions, model, state, *dt)
                        .map_err(|e| e.to_string())
                        .and_then(|()| stepper.step(model, state).map_err(|e| e.to_string()));
                    match stepped {
                        Ok(info) => {
                            history.push(t0.elapsed().as_secs_f64(), &info);
                            *last = Some(info);
                        }
                        Err(e) => {
                            *state = before;
                            return Err(e);
                        }
                    }
                    taken += 1;
                }
                Ok(taken)
            });
            done += result.map_err(SimulationError::new_err)?;
            py.check_signals()?;
        }
        Ok(self.state.step)
    }

    /// Node positions (m), a new array of the scene's shape (`(M, N, 3)` for one sheet, else `(n, 3)`).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let x = &self.state.x;
        self.layout.array(py, |k| x[k])
    }

    /// Writes the node positions into `out`, a C-contiguous float64 array of the scene's shape (no allocation).
    fn positions_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        let shape = self.layout.shape();
        let out = float64_array(out, &shape)?;
        if out.shape() != shape.as_slice() {
            return Err(PyValueError::new_err(format!("out: shape {} must be {}", tuple(out.shape()), tuple(&shape))));
        }
        if !out.is_c_contiguous() {
            return Err(PyValueError::new_err("out: must be C-contiguous"));
        }
        // numpy's reasons ("The given array is not writeable", "… is already borrowed") after the argument's name.
        let mut rw = out.try_readwrite().map_err(|e| PyValueError::new_err(format!("out: {}", lower_first(&e))))?;
        let slice = rw.as_slice_mut().map_err(|_| PyValueError::new_err("out: must be C-contiguous"))?;
        for (place, o) in slice.chunks_exact_mut(3).enumerate() {
            let p = self.state.x[self.layout.node(place)];
            o.copy_from_slice(&[p.x, p.y, p.z]);
        }
        Ok(())
    }

    /// Node velocities (m/s), the scheme's second-order estimate, a new array of the scene's shape.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let s = &self.state;
        self.layout.array(py, |k| s.velocity(k))
    }

    /// Nodes `(M, N)` of a one-sheet scene.
    #[getter]
    fn grid(&self) -> PyResult<(usize, usize)> {
        let g = self.layout.grid()?;
        Ok((g.m, g.n))
    }

    /// Steps taken.
    #[getter]
    fn step_count(&self) -> usize {
        self.state.step
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.state.time
    }

    /// Time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.dt
    }

    /// The pinned nodes, in the arrays' order: `(i, j)` pairs on one sheet, node numbers otherwise.
    #[getter]
    fn pinned(&self, py: Python<'_>) -> PyResult<Vec<Py<PyAny>>> {
        let pinned = self.model.pinned();
        let nodes = (0..self.layout.len()).map(|p| self.layout.node(p)).filter(|&k| pinned[k]);
        nodes.map(|k| self.layout.name(py, k)).collect()
    }

    /// Moves a pinned node to `position` (m) before the next step: the step holds it there, and the sheet sees
    /// it moving at `(position − previous)/Δt`. `move_pin(i, j, position)` names node `(i, j)` of a one-sheet
    /// scene's grid, `move_pin(k, position)` node `k` of any scene (the `(n, 3)` arrays' numbering).
    #[pyo3(signature = (first, second, third = None))]
    fn move_pin(&mut self, first: Count, second: &Bound<'_, PyAny>, third: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let first = first.0;
        let (k, position) = match third {
            Some(position) => (self.node(first, second.extract::<Count>()?.0)?, position),
            None => (self.numbered(first)?, second),
        };
        let p = vec3(position, "position")?;
        self.model.move_pin(&mut self.state, k, p).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The springs' nodes (`(i, j)` on one sheet, node numbers otherwise), in the order `set_spring_target`
    /// numbers them.
    #[getter]
    fn spring_nodes(&self, py: Python<'_>) -> PyResult<Vec<Py<PyAny>>> {
        self.model.springs().iter().map(|s| self.layout.name(py, s.node)).collect()
    }

    /// The spring targets (m), an `(S, 3)` array.
    #[getter]
    fn spring_targets<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        let springs = self.model.springs();
        let v: Vec<f64> = springs.iter().flat_map(|s| [s.target.x, s.target.y, s.target.z]).collect();
        Array2::from_shape_vec((springs.len(), 3), v).expect("three per spring").into_pyarray(py)
    }

    /// Moves the target of spring `index` to `target` (m) before the next step.
    fn set_spring_target(&mut self, index: Count, target: &Bound<'_, PyAny>) -> PyResult<()> {
        let t = vec3(target, "target")?;
        self.model.set_spring_target(index.0, t).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Energies of the current state (J): `kinetic`, `membrane`, `bending`, `potential` (gravity and loads),
    /// and `contact` (the penalty energy at the start of the last step; 0 before the first).
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let e = flexsurf::sim::energies(&self.model, &self.state);
        let d = PyDict::new(py);
        d.set_item("step", e.step)?;
        d.set_item("time", e.time)?;
        d.set_item("kinetic", e.kinetic)?;
        d.set_item("membrane", e.energies.membrane)?;
        d.set_item("bending", e.energies.bending)?;
        d.set_item("potential", e.potential)?;
        d.set_item("contact", self.last.map_or(0.0, |l| l.contact_energy))?;
        Ok(d)
    }

    /// Active contacts at the start of the last step (0 before the first).
    #[getter]
    fn contacts(&self) -> usize {
        self.last.map_or(0, |l| l.contacts)
    }

    /// Deepest penetration into an obstacle now (m).
    #[getter]
    fn max_penetration(&self) -> f64 {
        max_penetration(&self.model, &self.state.x)
    }

    /// Per-step records since the start, a dict of 1-D arrays: `wall` (s, the whole step), `assembly`,
    /// `contact`, `factorization`, `solve` (s per stage), `solves` and `contacts`.
    fn timings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.history;
        let d = PyDict::new(py);
        for (name, v) in [
            ("wall", &h.wall),
            ("assembly", &h.assembly),
            ("contact", &h.contact),
            ("factorization", &h.factorization),
            ("solve", &h.solve),
            ("solves", &h.solves),
            ("contacts", &h.contacts),
        ] {
            d.set_item(name, Array1::from_vec(v.clone()).into_pyarray(py))?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let nodes = match self.layout {
            Layout::Sheet(g) => format!("grid={}x{}", g.m, g.n),
            Layout::Nodes(n) => format!("nodes={n}"),
        };
        format!("Simulation({nodes}, step={}, t={})", self.state.step, self.state.time)
    }
}

/// `out` as a float64 array of `shape`'s dimensions, or a `TypeError` that says what it is instead and what
/// [`PySimulation::positions_into`] needs (numpy's own cast error names neither the type nor the shape).
fn float64_array<'a, 'py>(out: &'a Bound<'py, PyAny>, shape: &[usize]) -> PyResult<&'a Bound<'py, PyArrayDyn<f64>>> {
    if let Some(array) = out.cast::<PyArrayDyn<f64>>().ok().filter(|a| a.ndim() == shape.len()) {
        return Ok(array);
    }
    let what = match out.cast::<numpy::PyUntypedArray>() {
        Ok(a) => format!("{} array of shape {}", article(&a.dtype().to_string()), tuple(a.shape())),
        Err(_) => article(&out.get_type().name().map_or_else(|_| "value".to_string(), |n| n.to_string())),
    };
    Err(PyTypeError::new_err(format!("out: expected a float64 array of shape {}, got {what}", tuple(shape))))
}

/// `shape` as Python writes a tuple: `(7, 7, 3)`, `(147,)`.
fn tuple(shape: &[usize]) -> String {
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    }
}

/// `word` after its indefinite article: `a float32`, `an int64`.
fn article(word: &str) -> String {
    let an = word.starts_with(['a', 'e', 'i', 'o', 'u']);
    format!("{} {word}", if an { "an" } else { "a" })
}

/// `e`'s message with its first letter in lower case, to follow an argument's name.
fn lower_first(e: &impl std::fmt::Display) -> String {
    let text = e.to_string();
    let mut chars = text.chars();
    chars.next().map_or_else(String::new, |c| c.to_lowercase().chain(chars).collect())
}
