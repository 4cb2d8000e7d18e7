//! `Model` (everything a step reads), `State` (positions, velocities, time) and the CPU `Solver`, each in
//! float32 or float64 (`precision` module).

use crate::precision::{Prec, each, pair};
use crate::*;

pub(crate) type AnyModel = Prec<RModel<f32>, RModel<f64>>;
pub(crate) type AnyState = Prec<RState<f32>, RState<f64>>;
pub(crate) type AnySolver = Prec<fissure::CpuSolver<f32>, fissure::CpuSolver<f64>>;

/// Everything a step reads: masses, springs, triangles, bodies, colliders (float32 or float64: `precision`).
#[pyclass(module = "fissure._fissure")]
pub struct Model {
    pub(crate) inner: AnyModel,
}

#[pymethods]
impl Model {
    /// The initial state.
    pub(crate) fn state(&self) -> State {
        State {
            inner: match &self.inner {
                Prec::F32(m) => Prec::F32(m.state()),
                Prec::F64(m) => Prec::F64(m.state()),
            },
        }
    }
    /// "float32" or "float64": the precision of the model and of every array it gives.
    #[getter]
    fn precision(&self) -> &'static str {
        self.inner.name()
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        each!(&self.inner, m => m.particle_count())
    }
    /// Number of springs.
    #[getter]
    fn spring_count(&self) -> usize {
        each!(&self.inner, m => m.spring_count())
    }
    /// Number of triangles.
    #[getter]
    fn tri_count(&self) -> usize {
        each!(&self.inner, m => m.tri_count())
    }
    /// Number of bodies.
    #[getter]
    fn body_count(&self) -> usize {
        each!(&self.inner, m => m.body_count())
    }
    /// Triangles, a new uint32 `(F, 3)` array: each body's from its `first_triangle`, ordered by their sorted
    /// corners (a grid's in the grid's order).
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let tris = each!(&self.inner, m => &m.tri_indices);
        let flat: Vec<u32> = tris.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([tris.len(), 3]).expect("F * 3 elements")
    }
    /// Springs, a new uint32 `(S, 2)` array.
    #[getter]
    fn springs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let springs = each!(&self.inner, m => &m.spring_indices);
        let flat: Vec<u32> = springs.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([springs.len(), 2]).expect("S * 2 elements")
    }
    /// Total mass \[kg\].
    fn total_mass(&self) -> f64 {
        each!(&self.inner, m => m.total_mass())
    }
    /// Enclosed volume of each body \[m^3\] (0 without gas).
    fn body_volumes(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        pair!(&self.inner, &state.inner, (m, s) => m.body_volumes(s))
    }
    /// Gas pressure of each body \[Pa\].
    fn body_pressures(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        pair!(&self.inner, &state.inner, (m, s) => m.body_pressures(s))
    }
    /// Linear momentum [kg·m/s].
    fn momentum(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        pair!(&self.inner, &state.inner, (m, s) => m.momentum(s).into())
    }
    /// Centre of mass \[m\].
    fn center_of_mass(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        pair!(&self.inner, &state.inner, (m, s) => m.center_of_mass(s).into())
    }
    /// Energies \[J\]: kinetic, spring, gas, gravity, total.
    fn energy<'py>(&self, py: Python<'py>, state: &State) -> PyResult<Bound<'py, PyDict>> {
        self.check(state)?;
        let e = pair!(&self.inner, &state.inner, (m, s) => m.energy(s))?;
        let d = PyDict::new(py);
        d.set_item("kinetic", e.kinetic)?;
        d.set_item("spring", e.spring)?;
        d.set_item("gas", e.gas)?;
        d.set_item("gravity", e.gravity)?;
        d.set_item("total", e.total())?;
        Ok(d)
    }
    /// Pickles as arrays (exact; see the `pickle` module).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        crate::pickle::reduce_model(py, self)
    }
    fn __repr__(&self) -> String {
        each!(&self.inner, m => format!(
            "Model(particles={}, springs={}, triangles={}, bodies={}, precision={})",
            m.particle_count(),
            m.spring_count(),
            m.tri_count(),
            m.body_count(),
            self.inner.name()
        ))
    }
}

impl Model {
    /// The state fits the model: the same precision and particle count.
    pub(crate) fn check(&self, s: &State) -> PyResult<()> {
        let (n, k) = pair!(&self.inner, &s.inner, (m, s) => (m.particle_count(), s.particle_q.len()))?;
        if n != k {
            return Err(PyValueError::new_err(format!("state has {k} particles but the model has {n}")));
        }
        Ok(())
    }
}

/// Positions \[m\], velocities \[m/s\] and time \[s\].
#[pyclass(module = "fissure._fissure")]
#[derive(Clone)]
pub struct State {
    pub(crate) inner: AnyState,
}

#[pymethods]
impl State {
    /// Positions: a new `(N, 3)` array of the state's precision, float32 or float64 (a copy; see
    /// `copy_positions_into`).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        each!(&self.inner, s => points_out(py, s.particle_q.iter().map(|v| v.to_array())).into_any())
    }
    /// Sets positions from an `(N, 3)` float array.
    #[setter]
    fn set_positions(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        each!(&mut self.inner, s => write_points("positions", &mut s.particle_q, value))
    }
    /// Velocities: a new `(N, 3)` array of the state's precision.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        each!(&self.inner, s => points_out(py, s.particle_qd.iter().map(|v| v.to_array())).into_any())
    }
    /// Sets velocities from an `(N, 3)` float array.
    #[setter]
    fn set_velocities(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        each!(&mut self.inner, s => write_points("velocities", &mut s.particle_qd, value))
    }
    /// Simulation time \[s\].
    #[getter]
    fn time(&self) -> f64 {
        each!(&self.inner, s => s.time)
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        each!(&self.inner, s => s.particle_q.len())
    }
    /// "float32" or "float64".
    #[getter]
    fn precision(&self) -> &'static str {
        self.inner.name()
    }
    /// Copies positions into `out`, a C-contiguous `(N, 3)` array of the state's precision, without allocating.
    fn copy_positions_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        each!(&self.inner, s => copy_into("out", &s.particle_q, out))
    }
    /// Copies velocities into `out`, a C-contiguous `(N, 3)` array of the state's precision, without allocating.
    fn copy_velocities_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        each!(&self.inner, s => copy_into("out", &s.particle_qd, out))
    }
    /// An independent copy.
    fn copy(&self) -> State {
        self.clone()
    }
    /// Pickles as arrays (exact).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        crate::pickle::reduce_state(py, self)
    }
}

/// The CPU solver (rayon threads, deterministic). It takes the precision of the model it steps (a float32 solver
/// given a float64 model becomes a float64 one, with the same settings, on its first step).
#[pyclass(module = "fissure._fissure")]
pub struct Solver {
    pub(crate) inner: AnySolver,
}

impl Solver {
    /// The settings.
    pub(crate) fn config(&self) -> SolverConfig {
        each!(&self.inner, s => s.config.clone())
    }

    /// Makes the solver the precision `f64` says (a new solver with the same settings if it is not).
    pub(crate) fn ensure(&mut self, f64: bool) {
        if self.inner.is_f64() != f64 {
            let c = self.config();
            self.inner =
                if f64 { Prec::F64(fissure::CpuSolver::new(c)) } else { Prec::F32(fissure::CpuSolver::new(c)) };
        }
    }
}

/// Solver settings from keywords; the core checks them (`SolverConfig::validate`, whose message names the keyword).
pub(crate) fn config(
    integrator: Integrator,
    cg_tolerance: f64,
    cg_max_iterations: usize,
    cg_coarse: bool,
    substep_safety: Option<f64>,
) -> PyResult<SolverConfig> {
    let c = SolverConfig {
        integrator: integrator.into(),
        cg_tolerance,
        cg_max_iterations,
        cg_coarse,
        check_finite: true,
        substep_safety,
    };
    c.validate().map_err(value_err)?;
    Ok(c)
}

pub(crate) fn timers_dict<'py>(py: Python<'py>, t: &fissure::StageTimers) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for s in Stage::ALL {
        d.set_item(s.name(), t.time(s).as_secs_f64())?;
    }
    d.set_item("total", t.total.as_secs_f64())?;
    d.set_item("steps", t.steps)?;
    Ok(d)
}

#[pymethods]
impl Solver {
    /// A solver; options are keyword-only. `cg_coarse` (implicit Euler only): the coarse level in CG's
    /// preconditioner (about half the iterations at large steps; False: block-Jacobi alone).
    #[new]
    #[pyo3(signature = (*, integrator = Integrator::SYMPLECTIC_EULER, cg_tolerance = 1e-5, cg_max_iterations = 200,
        cg_coarse = true, substep_safety = None))]
    pub(crate) fn new(
        integrator: Integrator,
        cg_tolerance: f64,
        cg_max_iterations: usize,
        cg_coarse: bool,
        substep_safety: Option<f64>,
    ) -> PyResult<Self> {
        let c = config(integrator, cg_tolerance, cg_max_iterations, cg_coarse, substep_safety)?;
        Ok(Solver { inner: Prec::F32(fissure::CpuSolver::new(c)) })
    }

    /// Advances `state` by `steps` steps of `dt` \[s\], with the GIL released. Raises `ValueError` when a step
    /// fails (a blow-up, named with the springs' stability bound) or is refused before it is taken: on a model
    /// with contact, an explicit `dt` above that bound (contact would hide the instability; pass
    /// `substep_safety`).
    #[pyo3(signature = (model, state, dt, steps = 1))]
    fn step(&mut self, py: Python<'_>, model: &Model, state: &mut State, dt: f64, steps: usize) -> PyResult<()> {
        model.check(state)?;
        self.ensure(model.inner.is_f64());
        let (solver, m, s) = (&mut self.inner, &model.inner, &mut state.inner);
        fn run<R: fissure::Real>(
            solver: &mut fissure::CpuSolver<R>,
            m: &RModel<R>,
            s: &mut RState<R>,
            dt: f64,
            steps: usize,
        ) -> Result<(), fissure::StepError> {
            for _ in 0..steps {
                fissure::Solver::step(solver, m, s, dt)?;
            }
            Ok(())
        }
        let out = py.detach(|| match (solver, m, s) {
            (Prec::F32(sv), Prec::F32(m), Prec::F32(s)) => Ok(run(sv, m, s, dt, steps)),
            (Prec::F64(sv), Prec::F64(m), Prec::F64(s)) => Ok(run(sv, m, s, dt, steps)),
            (_, m, s) => Err((m.name(), s.name())),
        });
        match out {
            Ok(r) => r.map_err(value_err),
            Err((a, b)) => Err(crate::precision::mixed(a, b)),
        }
    }

    /// Seconds spent per stage so far, with `total` and `steps`.
    fn timers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        each!(&self.inner, s => timers_dict(py, fissure::Solver::timers(s)))
    }

    /// What the contact pass did: the last step's `candidates`, `near`, `pushed` and `capped` pairs/particles,
    /// and totals since the solver started (`steps`, `builds`, `near_total`, `pushed_total`, `capped_total`).
    fn contact_stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = each!(&self.inner, s => s.contact_stats());
        let d = PyDict::new(py);
        for (k, v) in [
            ("candidates", c.candidates as u64),
            ("near", c.near as u64),
            ("pushed", c.pushed as u64),
            ("capped", c.capped as u64),
            ("steps", c.steps),
            ("builds", c.builds),
            ("near_total", c.near_total),
            ("pushed_total", c.pushed_total),
            ("capped_total", c.capped_total),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }
}
