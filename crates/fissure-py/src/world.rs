//! `World`: the Rust `fissure::World` (the one stepping path: step, fracture, notify) behind a Python class.

use crate::model::timers_dict;
use crate::precision::{AnyWorld, Prec, Precision, each, mixed, pair};
use crate::*;

/// A model, its state, a solver and the fracture pass, stepped together.
///
/// The stepping is Rust's `fissure::World` (one stepping path for every front end). The Python objects `model`,
/// `state` and `solver` stay live and shared with the caller: for each call their contents are moved into the Rust
/// world (an O(1) swap of their arrays), stepped with the GIL released, and moved back.
#[pyclass(module = "fissure._fissure")]
pub struct World {
    pub(crate) model: Py<Model>,
    pub(crate) state: Py<State>,
    pub(crate) solver: Py<Solver>,
    /// The Rust world: holds the fracture pass and the events; its model, state and solver are the Python
    /// objects' only while a call runs (between calls it holds empty placeholders, swapped in and out in O(1)).
    pub(crate) world: AnyWorld,
}

pub(crate) fn event_dict<'py>(py: Python<'py>, e: &fissure::FractureEvent) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let kind = match e.kind {
        fissure::FractureKind::Spring => "spring",
        fissure::FractureKind::Core => "core",
        fissure::FractureKind::Detach => "detach",
    };
    d.set_item("kind", kind)?;
    d.set_item("time", e.time)?;
    d.set_item("position", (e.position.x, e.position.y, e.position.z))?;
    d.set_item("body", e.body)?;
    d.set_item("spring", e.spring)?;
    d.set_item("vertex", e.vertex)?;
    d.set_item("new_particles", e.new_particles.clone())?;
    d.set_item("new_body", e.new_body)?;
    Ok(d)
}

fn swap_one<R: fissure::Real>(
    w: &mut fissure::World<R>,
    m: &mut RModel<R>,
    s: &mut RState<R>,
    sv: &mut fissure::CpuSolver<R>,
) {
    std::mem::swap(&mut w.model, m);
    std::mem::swap(&mut w.state, s);
    if let Some(cpu) = w.cpu_solver() {
        std::mem::swap(cpu, sv);
    }
}

/// Moves the Python objects' model, state and solver into the Rust world, or back (an O(1) swap of arrays).
/// All four must have one precision (the solver takes the world's).
fn swap(w: &mut AnyWorld, m: &mut Model, s: &mut State, sv: &mut Solver) -> PyResult<()> {
    sv.ensure(w.is_f64());
    match (w, &mut m.inner, &mut s.inner, &mut sv.inner) {
        (Prec::F32(w), Prec::F32(m), Prec::F32(s), Prec::F32(sv)) => swap_one(w, m, s, sv),
        (Prec::F64(w), Prec::F64(m), Prec::F64(s), Prec::F64(sv)) => swap_one(w, m, s, sv),
        (w, m, s, _) => return Err(mixed(w.name(), if m.name() != w.name() { m.name() } else { s.name() })),
    }
    Ok(())
}

impl World {
    /// A Python world around a Rust one: its model, state and solver become the live Python objects.
    pub(crate) fn from_world<R: Precision>(py: Python<'_>, mut world: fissure::World<R>) -> PyResult<Self> {
        // Moved out, not copied: between calls the Rust world holds empty placeholders.
        let model = Model { inner: R::model(std::mem::take(&mut world.model)) };
        let state = State { inner: R::state(std::mem::take(&mut world.state)) };
        let cpu = world.cpu_solver().ok_or_else(|| PyValueError::new_err("the Python World steps on the CPU"))?;
        let solver = Solver { inner: R::solver(std::mem::take(cpu)) };
        Ok(World {
            model: Py::new(py, model)?,
            state: Py::new(py, state)?,
            solver: Py::new(py, solver)?,
            world: R::world(world),
        })
    }

    /// Runs `f` on the Rust world holding the Python objects' model, state and solver, with the GIL released.
    fn with_world<T: Send>(
        &mut self,
        py: Python<'_>,
        f: impl FnOnce(&mut AnyWorld) -> Result<T, fissure::StepError> + Send,
    ) -> PyResult<T> {
        let mut model = self.model.borrow_mut(py);
        let mut state = self.state.borrow_mut(py);
        let mut solver = self.solver.borrow_mut(py);
        model.check(&state)?;
        let w = &mut self.world;
        swap(w, &mut model, &mut state, &mut solver)?;
        let out = py.detach(|| f(w));
        swap(w, &mut model, &mut state, &mut solver)?;
        out.map_err(value_err)
    }

    /// Advances every world by `duration` in steps of `dt` in parallel, the GIL released (`run_many`).
    pub(crate) fn advance_many(
        py: Python<'_>,
        worlds: &[Bound<'_, World>],
        duration: f64,
        dt: f64,
        threads: Option<usize>,
    ) -> PyResult<Vec<fissure::scene::Outcome>> {
        let busy = |what: &str| {
            PyValueError::new_err(format!("run_many: a {what} appears twice in the batch (each world needs its own)"))
        };
        let mut ws = Vec::with_capacity(worlds.len());
        for w in worlds {
            ws.push(w.try_borrow_mut().map_err(|_| busy("world"))?);
        }
        let mut parts = Vec::with_capacity(ws.len());
        for w in &ws {
            let m = w.model.bind(py).try_borrow_mut().map_err(|_| busy("model"))?;
            let s = w.state.bind(py).try_borrow_mut().map_err(|_| busy("state"))?;
            let sv = w.solver.bind(py).try_borrow_mut().map_err(|_| busy("solver"))?;
            m.check(&s)?;
            parts.push((m, s, sv));
        }
        if ws.iter().any(|w| w.world.is_f64() != ws[0].world.is_f64()) {
            return Err(mixed("float32", "float64"));
        }
        for (w, (m, s, sv)) in ws.iter_mut().zip(parts.iter_mut()) {
            swap(&mut w.world, m, s, sv)?;
        }
        let (mut single, mut double) = (Vec::new(), Vec::new());
        for w in ws.iter_mut() {
            match &mut w.world {
                Prec::F32(w) => single.push(w),
                Prec::F64(w) => double.push(w),
            }
        }
        let out = py.detach(|| {
            if double.is_empty() {
                fissure::scene::advance_all(&mut single, duration, dt, threads)
            } else {
                fissure::scene::advance_all(&mut double, duration, dt, threads)
            }
        });
        for (w, (m, s, sv)) in ws.iter_mut().zip(parts.iter_mut()) {
            swap(&mut w.world, m, s, sv)?;
        }
        Ok(out)
    }

    fn cut<'py>(&mut self, py: Python<'py>, index: usize, core: bool) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let count = each!(&self.model.borrow(py).inner, m => if core { m.particle_count() } else { m.spring_count() });
        if index >= count {
            let what = if core { "particle" } else { "spring" };
            return Err(PyIndexError::new_err(format!("{what} {index} out of range (model has {count})")));
        }
        let new =
            self.with_world(py, |w| each!(w, w => if core { w.break_core(index) } else { w.break_spring(index) }))?;
        new.iter().map(|e| event_dict(py, e)).collect()
    }
}

#[pymethods]
impl World {
    /// A world at the model's initial state. Fracture settings (used when the model has breakable bodies):
    /// `max_events_per_step`, `averaged_window` \[s\] (None: instantaneous trigger), `discharge_coefficient`,
    /// `gas_density` \[kg/m^3\], `start_time` \[s\], `splits_per_body` (spring-mode splits per body per step),
    /// `nucleation_interval` \[s\] (least time between new cracks in a body; None: its wave-crossing time).
    #[new]
    #[pyo3(signature = (model, *, integrator = Integrator::SYMPLECTIC_EULER, cg_tolerance = 1e-5,
        cg_max_iterations = 200, cg_coarse = true, substep_safety = None,
        max_events_per_step = 32, averaged_window = None, discharge_coefficient = 0.6, gas_density = 1.2,
        start_time = 0.0, splits_per_body = 1, nucleation_interval = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: Py<Model>,
        integrator: Integrator,
        cg_tolerance: f64,
        cg_max_iterations: usize,
        cg_coarse: bool,
        substep_safety: Option<f64>,
        max_events_per_step: usize,
        averaged_window: Option<f64>,
        discharge_coefficient: f64,
        gas_density: f64,
        start_time: f64,
        splits_per_body: usize,
        nucleation_interval: Option<f64>,
    ) -> PyResult<Self> {
        let config = fissure::FractureConfig {
            trigger: averaged_window.map_or(fissure::Trigger::Instant, |window| fissure::Trigger::Averaged { window }),
            max_events_per_step,
            discharge_coefficient,
            gas_density,
            start_time,
            splits_per_body,
            nucleation_interval,
            ..Default::default()
        };
        config.validate().map_err(|e| core_err(e, &[]))?;
        let solver = Solver::new(integrator, cg_tolerance, cg_max_iterations, cg_coarse, substep_safety)?;
        // An empty placeholder model: the Python objects' contents are swapped in for each call.
        let f64 = model.borrow(py).inner.is_f64();
        let c = solver.config();
        let rust = if f64 {
            Prec::F64(fissure::World::new(fissure::Model::default(), c).with_fracture(config))
        } else {
            Prec::F32(fissure::World::new(fissure::Model::default(), c).with_fracture(config))
        };
        let state = model.borrow(py).state();
        Ok(World { model, state: Py::new(py, state)?, solver: Py::new(py, solver)?, world: rust })
    }

    /// The model.
    #[getter]
    fn model(&self, py: Python<'_>) -> Py<Model> {
        self.model.clone_ref(py)
    }
    /// The state (live: stepping the world changes it).
    #[getter]
    fn state(&self, py: Python<'_>) -> Py<State> {
        self.state.clone_ref(py)
    }
    /// The solver.
    #[getter]
    fn solver(&self, py: Python<'_>) -> Py<Solver> {
        self.solver.clone_ref(py)
    }
    /// Simulation time \[s\].
    #[getter]
    fn time(&self, py: Python<'_>) -> f64 {
        each!(&self.state.borrow(py).inner, s => s.time)
    }
    /// Every fracture event so far, as dicts: `kind` ("spring", "core" or "detach"), `time` \[s\], `position` \[m\],
    /// `body`, `spring`, `vertex`, `new_particles`, `new_body`.
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        each!(&self.world, w => w.events.iter().map(|e| event_dict(py, e)).collect())
    }

    /// `steps` steps of `dt` \[s\] (each followed by the fracture pass), GIL released. Returns the number of new
    /// fracture events.
    #[pyo3(signature = (dt, steps = 1))]
    fn step(&mut self, py: Python<'_>, dt: f64, steps: usize) -> PyResult<usize> {
        self.with_world(py, |w| {
            let mut events = 0;
            for _ in 0..steps {
                events += each!(&mut *w, w => w.step(dt)?.events.len());
            }
            Ok(events)
        })
    }

    /// Advances by `duration` \[s\] in steps of at most `dt` \[s\], GIL released. Returns the number of new fracture
    /// events.
    fn advance(&mut self, py: Python<'_>, duration: f64, dt: f64) -> PyResult<usize> {
        if !(dt.is_finite() && dt > 0.0 && duration.is_finite() && duration >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "need dt > 0 and duration >= 0, got dt = {dt}, duration = {duration}"
            )));
        }
        self.with_world(py, |w| Ok(each!(w, w => w.advance(duration, dt)?.events.len())))
    }

    /// Lets the solver's helper threads sleep now rather than wait busily for the next step: call it before
    /// other CPU work between advances (drawing a frame). Not between back-to-back advances, where waking them
    /// costs more than their waiting. Changes no result.
    fn rest(&mut self, py: Python<'_>) -> PyResult<()> {
        self.with_world(py, |w| {
            each!(w, w => w.rest());
            Ok(())
        })
    }

    /// Breaks spring `index` now (a cut), whatever its strain; returns the events (empty if it could not break).
    fn break_spring<'py>(&mut self, py: Python<'py>, index: usize) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cut(py, index, false)
    }

    /// Breaks particle `index` out as a core block now (a puncture); returns the events (empty if it could not:
    /// pinned, on or next to an opening, or an odd valence).
    fn break_core<'py>(&mut self, py: Python<'py>, index: usize) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cut(py, index, true)
    }

    /// Writes the surface now as VTK XML: PolyData for a `.vtp` path (ParaView, PyVista), UnstructuredGrid for
    /// `.vtu` (also meshio). Points, triangles, point data `velocity` \[m/s\], `strain` and `body`, cell data `body`
    /// and `damage` (1 on a crack). Another extension raises `ValueError`.
    fn save_vtk(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        if fissure::vtk::VtkKind::from_path(&path).is_none() {
            return Err(PyValueError::new_err(format!("save_vtk: want a .vtp or .vtu path, got {}", path.display())));
        }
        let m = self.model.borrow(py);
        let s = self.state.borrow(py);
        m.check(&s)?;
        pair!(&m.inner, &s.inner, (m, s) => fissure::vtk::write_vtk(&path, m, s))?
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", path.display())))
    }

    /// Pickles as its model, state, settings and events (the solver's warm starts and the fracture pass's
    /// running averages start afresh when unpickled).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        crate::pickle::reduce_world(py, self)
    }

    /// Seconds spent per stage (solver stages and `fracture`), with `total` and `steps`.
    fn timers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut t = each!(&self.solver.borrow(py).inner, s => fissure::Solver::timers(s).clone());
        t.merge_stages(each!(&self.world, w => w.fracture.timers()));
        timers_dict(py, &t)
    }
}
