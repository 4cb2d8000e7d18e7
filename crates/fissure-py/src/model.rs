//! `Model` (everything a step reads), `State` (positions, velocities, time) and the CPU `Solver`.

use crate::*;

/// Everything a step reads: masses, springs, triangles, bodies, colliders (float32).
#[pyclass(module = "fissure._fissure")]
pub struct Model {
    pub(crate) inner: RModel<f32>,
}

#[pymethods]
impl Model {
    /// The initial state.
    pub(crate) fn state(&self) -> State {
        State { inner: self.inner.state() }
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_count()
    }
    /// Number of springs.
    #[getter]
    fn spring_count(&self) -> usize {
        self.inner.spring_count()
    }
    /// Number of triangles.
    #[getter]
    fn tri_count(&self) -> usize {
        self.inner.tri_count()
    }
    /// Number of bodies.
    #[getter]
    fn body_count(&self) -> usize {
        self.inner.body_count()
    }
    /// Triangles, a new uint32 `(F, 3)` array.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.tri_indices.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.tri_count(), 3]).expect("F * 3 elements")
    }
    /// Springs, a new uint32 `(S, 2)` array.
    #[getter]
    fn springs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.spring_indices.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.spring_count(), 2]).expect("S * 2 elements")
    }
    /// Total mass \[kg\].
    fn total_mass(&self) -> f64 {
        self.inner.total_mass()
    }
    /// Enclosed volume of each body \[m^3\] (0 without gas).
    fn body_volumes(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        Ok(self.inner.body_volumes(&state.inner))
    }
    /// Gas pressure of each body \[Pa\].
    fn body_pressures(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        Ok(self.inner.body_pressures(&state.inner))
    }
    /// Linear momentum [kg·m/s].
    fn momentum(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        Ok(self.inner.momentum(&state.inner).into())
    }
    /// Centre of mass \[m\].
    fn center_of_mass(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        Ok(self.inner.center_of_mass(&state.inner).into())
    }
    /// Energies \[J\]: kinetic, spring, gas, gravity, total.
    fn energy<'py>(&self, py: Python<'py>, state: &State) -> PyResult<Bound<'py, PyDict>> {
        self.check(state)?;
        let e = self.inner.energy(&state.inner);
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
        format!(
            "Model(particles={}, springs={}, triangles={}, bodies={})",
            self.inner.particle_count(),
            self.inner.spring_count(),
            self.inner.tri_count(),
            self.inner.body_count()
        )
    }
}

impl Model {
    pub(crate) fn check(&self, s: &State) -> PyResult<()> {
        if s.inner.particle_q.len() != self.inner.particle_count() {
            return Err(PyValueError::new_err(format!(
                "state has {} particles but the model has {}",
                s.inner.particle_q.len(),
                self.inner.particle_count()
            )));
        }
        Ok(())
    }
}

/// Positions \[m\], velocities \[m/s\] and time \[s\].
#[pyclass(module = "fissure._fissure")]
#[derive(Clone)]
pub struct State {
    pub(crate) inner: RState<f32>,
}

#[pymethods]
impl State {
    /// Positions: a new float32 `(N, 3)` array (a copy; see `copy_positions_into`).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        points_out(py, self.inner.particle_q.iter().map(|v| v.to_array()))
    }
    /// Sets positions from an `(N, 3)` float array.
    #[setter]
    fn set_positions(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        write_points("positions", &mut self.inner.particle_q, value)
    }
    /// Velocities: a new float32 `(N, 3)` array.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        points_out(py, self.inner.particle_qd.iter().map(|v| v.to_array()))
    }
    /// Sets velocities from an `(N, 3)` float array.
    #[setter]
    fn set_velocities(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        write_points("velocities", &mut self.inner.particle_qd, value)
    }
    /// Simulation time \[s\].
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_q.len()
    }
    /// Copies positions into `out`, a C-contiguous float32 `(N, 3)` array, without allocating.
    fn copy_positions_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        copy_into("out", &self.inner.particle_q, out)
    }
    /// Copies velocities into `out`, a C-contiguous float32 `(N, 3)` array, without allocating.
    fn copy_velocities_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        copy_into("out", &self.inner.particle_qd, out)
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

/// The CPU solver (rayon threads, deterministic).
#[pyclass(module = "fissure._fissure")]
pub struct Solver {
    pub(crate) inner: fissure::CpuSolver<f32>,
}

/// Solver settings from keywords; the core checks them (`SolverConfig::validate`, whose message names the keyword).
pub(crate) fn config(
    integrator: Integrator,
    cg_tolerance: f64,
    cg_max_iterations: usize,
    substep_safety: Option<f64>,
) -> PyResult<SolverConfig> {
    let c = SolverConfig {
        integrator: integrator.into(),
        cg_tolerance,
        cg_max_iterations,
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
    /// A solver; options are keyword-only.
    #[new]
    #[pyo3(signature = (*, integrator = Integrator::SYMPLECTIC_EULER, cg_tolerance = 1e-5, cg_max_iterations = 200,
        substep_safety = None))]
    pub(crate) fn new(
        integrator: Integrator,
        cg_tolerance: f64,
        cg_max_iterations: usize,
        substep_safety: Option<f64>,
    ) -> PyResult<Self> {
        let c = config(integrator, cg_tolerance, cg_max_iterations, substep_safety)?;
        Ok(Solver { inner: fissure::CpuSolver::new(c) })
    }

    /// Advances `state` by `steps` steps of `dt` \[s\], with the GIL released.
    #[pyo3(signature = (model, state, dt, steps = 1))]
    fn step(&mut self, py: Python<'_>, model: &Model, state: &mut State, dt: f64, steps: usize) -> PyResult<()> {
        model.check(state)?;
        let (solver, m, s) = (&mut self.inner, &model.inner, &mut state.inner);
        py.detach(|| {
            for _ in 0..steps {
                fissure::Solver::step(solver, m, s, dt)?;
            }
            Ok::<(), fissure::StepError>(())
        })
        .map_err(value_err)
    }

    /// Seconds spent per stage so far, with `total` and `steps`.
    fn timers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        timers_dict(py, fissure::Solver::timers(&self.inner))
    }

    /// What the contact pass did: the last step's `candidates`, `near`, `pushed` and `capped` pairs/particles,
    /// and totals since the solver started (`steps`, `builds`, `near_total`, `pushed_total`, `capped_total`).
    fn contact_stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.contact_stats();
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
