//! # fissure
//!
//! Soft bodies that stretch, inflate, collide and tear: a mass-spring system built from a triangle surface mesh
//! (edges are springs, vertices are mass points), the closed pressure model (an ideal gas, `P = nRT / V`, pushing
//! each triangle along its normal), wind, colliders, and four integrators — after Zeng & Wu 2010, "Soft Body
//! Simulation with Multiple Local Fracturing Effects".
//!
//! This crate is the facade: it re-exports [`fissure_core`] and adds [`World`], which bundles a model, its state
//! and a solver for the common case, and [`scenes`], the scenes of the paper built in code.
//!
//! ```
//! use fissure::glam::DVec3;
//! use fissure::*;
//!
//! let mut b = ModelBuilder::new();
//! let ball = Mesh::icosphere(0.2, 2).translated(DVec3::new(0.0, 1.0, 0.0));
//! b.add_soft_body(&ball, &SoftBodyOptions { gas: Gas::Pressure(3000.0), ..Default::default() })?;
//! b.add_collider(Collider::ground(0.0));
//! let mut world: World<f32> = World::new(b.finalize()?, SolverConfig::default());
//! world.advance(0.5, 1e-4)?; // half a second in steps of 0.1 ms
//! assert!(world.model.center_of_mass(&world.state).y < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub use fissure_core::*;

#[cfg(feature = "render")]
pub mod output;
pub mod scene;
pub mod scenes;
#[cfg(feature = "viewer")]
pub mod viewer;

/// The wgpu compute backend (feature `gpu`): [`gpu::GpuSolver`], [`gpu::GpuContext`].
#[cfg(feature = "gpu")]
pub use fissure_gpu as gpu;

/// The README's code, compiled and run as a doctest so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// A model, its state, a CPU solver and the fracture pass, stepped together.
pub struct World<R: Real = f32> {
    /// The model (read-only during a step; parameters may be changed between steps).
    pub model: Model<R>,
    /// Positions, velocities and time.
    pub state: State<R>,
    /// The solver.
    pub solver: CpuSolver<R>,
    /// The fracture pass (does nothing unless the model has something breakable or a punctured gas body).
    pub fracture: Fracture<R>,
    /// Every fracture event so far, in order.
    pub events: Vec<FractureEvent>,
}

impl<R: Real> World<R> {
    /// A world at the model's initial state with the default fracture settings.
    pub fn new(model: Model<R>, config: SolverConfig) -> Self {
        let state = model.state();
        World { model, state, solver: CpuSolver::new(config), fracture: Fracture::default(), events: Vec::new() }
    }

    /// Replaces the fracture settings.
    pub fn with_fracture(mut self, config: FractureConfig) -> Self {
        self.fracture.config = config;
        self
    }

    /// One step of `dt` [s]: the solver's step, then the fracture pass (seed steps 4 and 5). Returns how many
    /// fracture events the step produced (they are appended to [`World::events`]).
    pub fn step(&mut self, dt: f64) -> Result<usize, StepError> {
        self.solver.step(&self.model, &mut self.state, dt)?;
        if !self.fracture.needed(&self.model) {
            return Ok(0);
        }
        let new = self.fracture.apply(&mut self.model, &mut self.state, dt);
        if !self.fracture.last_delta().is_empty() || !new.is_empty() {
            self.solver.notify_model_changed(&self.model);
        }
        let k = new.len();
        self.events.extend(new);
        Ok(k)
    }

    /// Advances by `duration` [s] in steps of at most `dt` [s] (the last one shortened to land exactly).
    pub fn advance(&mut self, duration: f64, dt: f64) -> Result<(), StepError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::BadTimeStep(dt));
        }
        let end = self.state.time + duration;
        while self.state.time < end - 1e-12 {
            let h = dt.min(end - self.state.time);
            self.step(h)?;
        }
        Ok(())
    }

    /// Per-stage timers of the solver and the fracture pass.
    pub fn timers(&self) -> StageTimers {
        let mut t = self.solver.timers().clone();
        t.merge_stages(self.fracture.timers());
        t
    }

    /// Clears the timers.
    pub fn reset_timers(&mut self) {
        self.solver.reset_timers();
        self.fracture.reset_timers();
    }
}
