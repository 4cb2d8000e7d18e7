//! The CPU solver: `solver.step(&model, &mut state, dt)`.
//!
//! A step reads top to bottom like the seed's algorithm (step 4): forces of the springs (4.2), the surface
//! pass for volume, pressure and wind (4.3–4.4), the per-particle gather fused with the integrator's update
//! (4.5), then collisions with colliders and contact between surfaces ([`crate::contact`]). A stage the model does not need is skipped entirely (no gas: no volume pass; no
//! wind: no aerodynamics; no colliders: no collision pass; no body in contact: no contact pass; pinned particles are not integrated).
//!
//! | integrator | order | force evaluations / step | stability (undamped spring, `ω = √(k/m)`) |
//! |---|---|---|---|
//! | [`Integrator::SymplecticEuler`] (seed eqs. 3–5) | 1 | 1 | `dt < 2/ω` |
//! | [`Integrator::VelocityVerlet`] | 2 | 2 | `dt < 2/ω` |
//! | [`Integrator::Rk4`] | 4 | 4 | `dt < 2√2/ω` (slowly loses energy) |
//! | [`Integrator::ImplicitEuler`] (Baraff–Witkin) | 1 | 1 + CG | unconditional for the linearised system |
//!
//! For a mesh, `ω` is the largest natural frequency, and damping lowers the limits further: [`crate::stability`]
//! estimates both (power iteration on the fastest mode; Gershgorin's `ω² ≤ max_i Σ_s 2 k_s / m_i` caps it). With
//! [`SolverConfig::substep_safety`] set, `step` splits a too-large `dt` into substeps under that bound; a state
//! that blows up anyway is reported as [`StepError::NonFinite`] with the bound, so the message says whether the
//! step was too large or something else (pressure, a collision, a broken state) did it.

use crate::error::StepError;
use crate::forces::runs::run_block_dispatch;
use crate::forces::spring::{StrainSink, implicit_coefficients};
use crate::forces::{ForceScratch, add_corners, cap_force, particle_force, pressure, pressure_share};
use crate::fracture::TopologyDelta;
use crate::model::{DampingModel, Model, State};
use crate::par;
use crate::real::{Real, Vector3};
use crate::stability::StabilityBound;
use crate::timers::Instant;
use crate::timers::{Stage, StageTimers};
use crate::topology::NONE;
use std::sync::atomic::{AtomicBool, Ordering};

mod cg_runs;
mod coarse;
mod collide;
mod contact;
mod explicit;
mod implicit;

/// Steps between two estimates of the stability bound while the substep guard is on.
const BOUND_REFRESH: usize = 256;

pub use crate::integrator::Integrator;
pub use contact::ContactStats;
use explicit::Rk4Scratch;
use implicit::ImplicitScratch;

/// Solver settings.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct SolverConfig {
    /// The integrator. Default symplectic Euler.
    pub integrator: Integrator,
    /// Relative residual `|r| / |b|` at which CG stops (implicit only). Default 1e-5.
    pub cg_tolerance: f64,
    /// CG iteration cap (implicit only); the last iterate is used if reached. Default 200.
    pub cg_max_iterations: usize,
    /// A second level in CG's preconditioner (implicit only): besides each particle's 3×3 block, the system on
    /// aggregates of particles moving together (24 up to 1,024 particles, up to 96 for large models), solved
    /// exactly at every iteration (see `solver/coarse.rs`). The same stopping rule and so the same accuracy, in
    /// about half the iterations at large steps (the 32² benchmark cloth at 1/60 s: 107 → 57; 128²: 198 → 102).
    /// Default true; false gives block-Jacobi alone.
    pub cg_coarse: bool,
    /// Check every step for NaN/inf and return [`StepError::NonFinite`]. Default true (cost: a compare per
    /// particle inside the update pass).
    pub check_finite: bool,
    /// Stability guard: when set to `Some(s)` (0 < s ≤ 1), `step(dt)` advances in the fewest equal substeps of at
    /// most `s ×` the explicit stability bound of the model ([`crate::stability::StabilityBound`]). Default
    /// `None`: the caller's `dt` is used as given (on a model in contact, one above the bound is refused:
    /// [`crate::stability::ContactStepGuard`]). The bound is cached and recomputed when the model's counts
    /// change or after [`Solver::notify_model_changed`]; call that after editing stiffness or masses in place.
    /// Where springs stretch far (past ~50 %), take `s` ≤ 0.8 with symplectic Euler or velocity Verlet: they
    /// resonate below their linear limit there (the module docs of [`crate::stability`]).
    pub substep_safety: Option<f64>,
}

impl Default for SolverConfig {
    fn default() -> Self {
        SolverConfig {
            integrator: Integrator::SymplecticEuler,
            cg_tolerance: 1e-5,
            cg_max_iterations: 200,
            cg_coarse: true,
            check_finite: true,
            substep_safety: None,
        }
    }
}

impl SolverConfig {
    /// Default settings with `integrator`.
    pub fn with(integrator: Integrator) -> Self {
        SolverConfig { integrator, ..Default::default() }
    }

    /// Checks every value: `cg_tolerance` finite and > 0, `cg_max_iterations` ≥ 1, `substep_safety` in (0, 1].
    /// Every step checks it (a few compares), so a bad setting is an error naming it, never a silent default.
    pub fn validate(&self) -> Result<(), StepError> {
        if !(self.cg_tolerance.is_finite() && self.cg_tolerance > 0.0) {
            return Err(StepError::Config(format!("cg_tolerance must be finite and > 0, got {}", self.cg_tolerance)));
        }
        if self.cg_max_iterations == 0 {
            return Err(StepError::Config("cg_max_iterations must be at least 1, got 0".into()));
        }
        if let Some(s) = self.substep_safety
            && !(s > 0.0 && s <= 1.0)
        {
            return Err(StepError::Config(format!("substep_safety must be in (0, 1], got {s}")));
        }
        Ok(())
    }
}

/// A boxed future that need not be `Send` (a browser's GPU handles are not): what [`Solver::advance_async`] and
/// [`Solver::sync_state_async`] return.
pub type LocalFuture<'a, T> = std::pin::Pin<Box<dyn std::future::Future<Output = T> + 'a>>;

/// The output of `f` if it completes at its first poll, else `None`. What the synchronous twins of the async
/// stepping methods use: every backend that can wait for its device (the CPU, a GPU off the web) finishes their
/// futures at once; WebGPU in a browser does not, and the caller reports that instead of blocking.
pub fn ready_now<T>(f: impl std::future::Future<Output = T>) -> Option<T> {
    let mut f = std::pin::pin!(f);
    match f.as_mut().poll(&mut std::task::Context::from_waker(std::task::Waker::noop())) {
        std::task::Poll::Ready(out) => Some(out),
        std::task::Poll::Pending => None,
    }
}

/// What every solver (CPU, GPU) offers.
///
/// `World` (in the `fissure` facade) drives a solver through this trait and is the one place that sequences
/// step → fracture → notify; the methods past `step` exist so that a solver keeping the state elsewhere (the GPU)
/// can run many steps without copying it back.
pub trait Solver<R: Real>: Send + Sync {
    /// Advances `state` by `dt` \[s\] (the state in and out is `state`).
    fn step(&mut self, model: &Model<R>, state: &mut State<R>, dt: f64) -> Result<(), StepError>;
    /// `steps` steps of `dt` \[s\] as one batch from the solver's current state. Afterwards the solver's own copy
    /// is current and `state` may lag until [`Solver::sync_state`] (the CPU solver steps `state` itself; the GPU
    /// keeps it on the device). Default: `steps` calls of [`Solver::step`].
    fn advance(&mut self, model: &Model<R>, state: &mut State<R>, dt: f64, steps: usize) -> Result<(), StepError> {
        for _ in 0..steps {
            self.step(model, state, dt)?;
        }
        Ok(())
    }
    /// Simulation time of the solver's copy of the state \[s\] (the CPU: `state.time`).
    fn time(&self, state: &State<R>) -> f64 {
        state.time
    }
    /// False when the last batch certainly passed no fracture limit (a GPU's kernels flag candidates as they
    /// step; the CPU solver's sparse strains list none on a model without load limits); the fracture pass is
    /// then skipped unless a gas body leaks. Default: true.
    fn may_have_fracture_candidates(&self) -> bool {
        true
    }
    /// Whether the fracture pass's trigger is instantaneous ([`crate::fracture::Trigger::Instant`]): it then
    /// needs only the strains that may pass a limit, and the CPU solver stores just those spans (see
    /// [`crate::fracture::Measures::strain_spans`]). `World` says so before each batch. Default: nothing to do.
    fn set_instant_trigger(&mut self, _instant: bool) {}
    /// Brings `state` up to date with the solver's copy (a GPU reads it back). Default: nothing to do.
    fn sync_state(&mut self, _state: &mut State<R>) -> Result<(), StepError> {
        Ok(())
    }
    /// [`Solver::advance`] for a backend that cannot wait for its device: WebGPU in a browser, where a read-back
    /// completes only once control is back in the event loop. `World`'s stepping is written once, against these
    /// two; its synchronous methods poll it once and find it done on every backend that can wait. Default: the
    /// synchronous method, ready at once.
    fn advance_async<'a>(
        &'a mut self,
        model: &'a Model<R>,
        state: &'a mut State<R>,
        dt: f64,
        steps: usize,
    ) -> LocalFuture<'a, Result<(), StepError>> {
        Box::pin(std::future::ready(self.advance(model, state, dt, steps)))
    }
    /// [`Solver::sync_state`] for a backend that cannot wait for its device (see [`Solver::advance_async`]).
    fn sync_state_async<'a>(&'a mut self, state: &'a mut State<R>) -> LocalFuture<'a, Result<(), StepError>> {
        Box::pin(std::future::ready(self.sync_state(state)))
    }
    /// `state` was changed outside the solver (a fracture split particles, a user moved them): take it as the
    /// solver's copy (a GPU uploads it). Default: nothing to do.
    fn upload_state(&mut self, _state: &State<R>) -> Result<(), StepError> {
        Ok(())
    }
    /// Particles `from..` are new (a fracture split them off; the others' state is unchanged): take their
    /// state (a GPU uploads just them). Default: nothing to do.
    fn upload_new_particles(&mut self, _state: &State<R>, _from: usize) -> Result<(), StepError> {
        Ok(())
    }
    /// The fracture trigger's inputs, if the solver measured them during its last step (the CPU solver on a
    /// model that can break); `None` makes the fracture pass compute them from the state. Default `None`.
    fn fracture_measures(&self, _model: &Model<R>) -> Option<crate::fracture::Measures<'_, R>> {
        None
    }
    /// Tells the solver what changed in the model: after a fracture, the pass's [`TopologyDelta`]; after editing
    /// parameters by hand, [`TopologyDelta::whole`].
    fn notify_model_changed(&mut self, model: &Model<R>, delta: &TopologyDelta);
    /// The caller is done stepping for a while (a frame's advance ended; drawing or other work follows): a
    /// backend with threads that wait busily for the next step lets them sleep. Default: nothing to do.
    fn rest(&mut self) {}
    /// Per-stage time spent so far.
    fn timers(&self) -> &StageTimers;
    /// Clears the stage timers.
    fn reset_timers(&mut self);
    /// The solver as `Any`, to reach a backend's own methods (`downcast_ref::<CpuSolver<f32>>()`).
    fn as_any(&self) -> &dyn std::any::Any;
    /// The solver as `Any`, mutably.
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any;
    /// A short name: `cpu` or `gpu`.
    fn name(&self) -> &'static str;
}

/// Statistics of the last implicit solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CgStats {
    /// Iterations taken.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
}

/// The multi-threaded CPU solver (rayon), generic over precision.
///
/// Threads: a pass over at least `par::PAR_MIN` (16,384) elements goes to rayon's pool, in fixed chunks (the same
/// bits on any number of threads); smaller passes, and every pass inside a pool of one thread, run on the calling
/// thread. A model with such passes steps inside the pool: [`Solver::advance`] hands a whole batch of steps over
/// once (what `World::advance` uses), [`Solver::step`] one step; run the stepping loop inside your own pool
/// (`ThreadPool::install`) and nothing is handed over at all.
///
/// A model stepped from outside rayon's pool while the pool has more than one thread runs its passes on a team
/// of spinning helper threads instead (`crate::team`: one per pool thread less one, at most 3, parked after 2 ms
/// without work, or at once on `World::rest`): a smaller model always, a large one when the team has as many
/// threads as the pool. Passes of a few microseconds are handed over in about 50 ns, where a rayon worker's
/// wake-up cost tens of microseconds on the development VM. The 2,562-vertex ball of `benches/ball.rs` went
/// 57.9–59.0 → 33.4–34.6 µs a step on two threads (2026-11-25, `benches/RESULTS.md`), where the VM's two vCPUs
/// answered each other in 45 ns; the 128² cloth 68.7–76.0 → 63.9–65.1 µs against the pool even where they took
/// ~440 ns (one step per call: 81–95 → 64–66). Where the team loses, the solver, which times both ways as it steps
/// (`crate::team::Pick`: against one thread for a smaller model, the pool for a large one), steps the other way.
/// The same bits as one thread (`tests/team.rs`).
#[derive(Clone, Debug, Default)]
pub struct CpuSolver<R: Real = f32> {
    /// Settings.
    pub config: SolverConfig,
    f: ForceScratch<R>,
    rk: Rk4Scratch<R>,
    imp: ImplicitScratch<R>,
    sized_for: Option<(usize, usize, usize, usize, Integrator)>,
    /// Second position/velocity buffers of the fused symplectic Euler path…
    q_next: Vec<R::V>,
    qd_next: Vec<R::V>,
    /// …and its blocks' force sums: one buffer of a block's length per thread that can run a block at once,
    /// taken by the block and given back, so the sums stay in the core's cache (a per-particle array went to
    /// memory and back: on the 1024² cloth 12 MB written, and read for ownership, a step).
    block_f: explicit::BlockBuffers<R>,
    /// Velocity Verlet's extrapolated end-of-step velocities.
    v_pred: Vec<R::V>,
    /// Colliders prepared for the current step (reused).
    colliders: Vec<crate::collision::PreparedCollider>,
    /// `0..colliders.len()`: the collision pass's list of every collider (kept, so a step allocates nothing).
    collider_ids: Vec<u32>,
    /// The contact pass's buffers (see the `contact` module).
    ct: contact::ContactScratch<R>,
    timers: StageTimers,
    /// Statistics of the last implicit solve.
    pub cg: CgStats,
    /// The model's stability bound, cached for the `sized_for` key.
    bound: Option<StabilityBound>,
    /// The stiffest mode found by the last bound estimate (the warm start of the next).
    mode: Vec<glam::DVec3>,
    /// Steps since the bound was estimated, and the stepping time (`timers.total`) then.
    bound_age: (usize, std::time::Duration),
    /// Time the last estimate took.
    bound_cost: std::time::Duration,
    /// Substeps the last `step` took.
    last_substeps: usize,
    /// The next force evaluation is the first of a substep: it measures the fracture trigger's inputs.
    measure_next: bool,
    /// The caller of the next force evaluation sums the loads in its own gather (symplectic Euler without wind)…
    fuse_loads: bool,
    /// …and must, because that evaluation measured.
    loads_pending: bool,
    /// The colliders' time \[s\] when this substep's integrator may resolve them in its own pass (symplectic
    /// Euler on spring runs, see `collide_chunk`)…
    collide_at: Option<f64>,
    /// …and whether it did (the collision pass is then skipped).
    collided: bool,
    /// Whether the spinning team pays on this machine, measured (see `crate::team::Pick`).
    #[cfg(feature = "parallel")]
    team_pick: crate::team::Pick,
}

impl<R: Real> CpuSolver<R> {
    /// A solver with `config`.
    pub fn new(config: SolverConfig) -> Self {
        CpuSolver { config, ..Default::default() }
    }

    /// A solver with default settings and `integrator`.
    pub fn with_integrator(integrator: Integrator) -> Self {
        Self::new(SolverConfig::with(integrator))
    }

    fn ensure_sized(&mut self, m: &Model<R>) {
        let key = (m.particle_count(), m.spring_count(), m.tri_count(), m.body_count(), self.config.integrator);
        if Some(key) == self.sized_for {
            return;
        }
        self.sized_for = Some(key);
        self.bound = None;
        self.ct.invalidate();
        self.f.resize(m, self.config.integrator == Integrator::ImplicitEuler);
        let n = m.particle_count();
        let fused = self.f.runs && self.config.integrator == Integrator::SymplecticEuler;
        for v in [&mut self.q_next, &mut self.qd_next] {
            v.resize(if fused { n } else { 0 }, R::V::ZERO);
        }
        #[cfg(feature = "parallel")]
        let threads = rayon::current_num_threads() + 1;
        #[cfg(not(feature = "parallel"))]
        let threads = 1;
        let len = if fused { self.f.run_blocks.len().min(n) } else { 0 };
        self.block_f = explicit::BlockBuffers::new(if fused { threads } else { 0 }, len);
        let z = R::V::ZERO;
        self.v_pred.resize(if self.config.integrator == Integrator::VelocityVerlet { n } else { 0 }, z);
        let rk = if self.config.integrator == Integrator::Rk4 { n } else { 0 };
        for v in [&mut self.rk.xt, &mut self.rk.vt, &mut self.rk.ax, &mut self.rk.av] {
            v.resize(rk, z);
        }
        let imp = self.config.integrator == Integrator::ImplicitEuler;
        let ni = if imp { n } else { 0 };
        let i = &mut self.imp;
        for v in [&mut i.r, &mut i.z, &mut i.p, &mut i.ap, &mut i.dv] {
            v.resize(ni, z);
        }
        i.block.resize(ni, [z; 3]);
        i.g.resize(if imp && m.has_pressure() { n } else { 0 }, z);
        i.u.resize(if imp { m.spring_count() } else { 0 }, z);
        i.coef.resize(if imp { m.spring_count() } else { 0 }, [R::ZERO; 4]);
        i.body_c.resize(m.body_count(), R::ZERO);
        i.body_dot.resize(m.body_count(), R::ZERO);
        i.warm = None;
    }

    /// Springs and surface passes at `(q, qd)`, timed. Returns whether triangle forces exist.
    ///
    /// The first evaluation of a substep (`measure_next`) of a model that can break also measures the fracture
    /// trigger's inputs (strains, elastic pulls, loads; see [`crate::fracture::Measures`]), so that the fracture
    /// pass reads them instead of recomputing every spring and triangle.
    /// (The load pass is its own sweep: fused into symplectic Euler's gather it cost more than apart, measured
    /// on the fracture scene.)
    fn forces(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V], time: f64) -> bool {
        let measure = std::mem::take(&mut self.measure_next) && self.f.measuring;
        let fuse = std::mem::take(&mut self.fuse_loads) && self.f.load.len() == q.len();
        // On the team the surface pass's crosses run beside the springs (timed with them), measuring or not.
        let crosses_formed = m.spring_count() > 0 && self.f.fuse_crosses(m);
        if m.spring_count() > 0 {
            let t = Instant::now();
            match (measure, crosses_formed) {
                (true, true) => self.f.springs_measured_and_crosses(m, q, qd),
                (true, false) => self.f.springs_measured(m, q, qd),
                (false, true) => self.f.springs_and_crosses(m, q, qd),
                (false, false) => self.f.springs(m, q, qd),
            }
            self.timers.add(Stage::Springs, t);
        }
        let surface = m.has_pressure() || m.has_wind();
        if surface {
            let t = Instant::now();
            self.f.surface(m, q, qd, time, crosses_formed);
            self.timers.add(Stage::Surface, t);
        }
        if measure {
            let t = Instant::now();
            if m.spring_count() == 0 {
                self.f.strain.iter_mut().for_each(|s| *s = R::ZERO);
            }
            // A model that breaks by strain alone leaves its loads at 0 (the trigger reads none without a limit).
            if self.f.loads {
                if fuse {
                    self.loads_pending = true;
                } else {
                    self.f.loads(m, surface);
                }
            }
            self.f.measured = true;
            self.timers.add(Stage::Fracture, t);
        }
        surface
    }

    /// The fracture trigger's inputs measured at the start of the last substep, if this model's last step
    /// measured them (a model that can break; on the run kernel, one without load limits) and nothing changed since.
    pub fn measures(&self, m: &Model<R>) -> Option<crate::fracture::Measures<'_, R>> {
        let f = &self.f;
        (f.measured
            && f.strain.len() == m.spring_count()
            && f.load.len() == m.particle_count()
            && f.body_volume.len() == m.body_count())
        .then_some(crate::fracture::Measures {
            strain: &f.strain,
            strain_spans: f.strain_sparse.then_some(&f.strain_spans[..]),
            load: &f.load,
            volume: &f.body_volume,
        })
    }

    /// The net force on every particle at `state` \[N\] (gravity, springs, pressure, wind; not collisions) into
    /// `out`, which must have one entry per particle. Pinned particles get their force too.
    pub fn compute_forces(&mut self, m: &Model<R>, state: &State<R>, out: &mut [R::V]) -> Result<(), StepError> {
        if state.particle_q.len() != m.particle_count() || out.len() != m.particle_count() {
            return Err(StepError::StateMismatch {
                state: state.particle_q.len().min(out.len()),
                model: m.particle_count(),
            });
        }
        self.ensure_sized(m);
        self.measure_next = false;
        self.f.measured = false;
        let surface = self.forces(m, &state.particle_q, &state.particle_qd, state.time);
        let f = &self.f;
        par::chunks(out, |start, os| {
            for (k, o) in os.iter_mut().enumerate() {
                *o = particle_force(m, f, surface, start + k);
            }
        });
        Ok(())
    }

    /// Volumes of the gas bodies \[m^3\] as of the last force evaluation (0 for bodies without gas).
    pub fn body_volumes(&self) -> &[R] {
        &self.f.body_volume
    }

    /// The explicit stability bound of `m` at its initial positions (cached; see
    /// [`SolverConfig::substep_safety`]).
    pub fn stability_bound(&mut self, m: &Model<R>) -> StabilityBound {
        self.bound_at(m, &m.particle_q0)
    }

    /// The bound at positions `q`, cached until the model changes; re-estimated from the last stiffest mode (a
    /// warm start: a fracture changes the mode only near the break).
    fn bound_at(&mut self, m: &Model<R>, q: &[R::V]) -> StabilityBound {
        self.ensure_sized(m);
        if let Some(b) = self.bound {
            return b;
        }
        let t = Instant::now();
        let q: Vec<glam::DVec3> = q.iter().map(|x| x.to_dvec3()).collect();
        let b = StabilityBound::estimate(m, &q, &mut self.mode);
        self.bound = Some(b);
        self.bound_cost = t.elapsed();
        self.bound_age = (0, self.timers.total);
        b
    }

    /// Steps on the spinning team (`Some(true)`), without it (`Some(false)`: one thread for a model below the
    /// pool's size, the pool above it), or as measured (`None`, the default: see `crate::team::Pick`). For
    /// benchmarks that compare several models in one process: each solver measures for itself, and on a host
    /// where the two ways cost about the same, two solvers may pick differently and their difference then
    /// measures the pick, not the models (the harness's cost-per-term section, 2026-11-27: a ball with colliders
    /// read 1.46× its spring pass in one run and 0.10–0.13× in three). The choice changes no bits.
    #[doc(hidden)]
    pub fn force_team(&mut self, team: Option<bool>) {
        #[cfg(feature = "parallel")]
        self.team_pick.force(team);
        #[cfg(not(feature = "parallel"))]
        let _ = team;
    }

    /// Whether this solver's measurements favour the team, once it has timed both ways (`None` before that,
    /// when forced, or where there is no team). See [`CpuSolver::force_team`].
    #[doc(hidden)]
    pub fn team_chosen(&self) -> Option<bool> {
        #[cfg(feature = "parallel")]
        return self.team_pick.chosen();
        #[cfg(not(feature = "parallel"))]
        None
    }

    /// Substeps the last [`Solver::step`] took (1 unless the stability guard split it).
    pub fn last_substeps(&self) -> usize {
        self.last_substeps
    }

    fn step_inner(&mut self, m: &Model<R>, s: &mut State<R>, dt: f64) -> Result<(), StepError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::BadTimeStep(dt));
        }
        if s.particle_q.len() != m.particle_count() || s.particle_qd.len() != m.particle_count() {
            return Err(StepError::StateMismatch { state: s.particle_q.len(), model: m.particle_count() });
        }
        self.config.validate()?;
        self.ensure_sized(m);
        self.check_contact_step(m, s, dt)?;
        let mut substeps = 1;
        if let Some(safety) = self.config.substep_safety {
            // The fastest mode follows the deformation (a stretched spring stiffens transversally): re-estimated
            // from the last mode (a warm start converges in a few sweeps) every BOUND_REFRESH steps, and no more
            // often than keeps the estimates under 5% of the stepping time.
            self.bound_age.0 += 1;
            if self.bound_age.0 > BOUND_REFRESH
                && self.timers.total.saturating_sub(self.bound_age.1) > 20 * self.bound_cost
            {
                self.bound = None;
            }
            let limit = safety * self.bound_at(m, &s.particle_q).max_dt(self.config.integrator);
            if dt > limit {
                // Cap the count so a zero-mass or absurd bound cannot hang the caller.
                // (1 - 1e-12): a ratio that is an integer up to round-off takes that many substeps, not one more.
                substeps = ((dt / limit * (1.0 - 1e-12)).ceil() as usize).clamp(1, 1 << 20);
            }
        }
        self.last_substeps = substeps;
        let h = dt / substeps as f64;
        for _ in 0..substeps {
            self.substep(m, s, h)?;
        }
        Ok(())
    }

    fn substep(&mut self, m: &Model<R>, s: &mut State<R>, dt: f64) -> Result<(), StepError> {
        let t0 = Instant::now();
        let blown = AtomicBool::new(false);
        let h = R::from_f64(dt);
        self.measure_next = true;
        self.f.measured = false;
        if m.has_contact() {
            self.ct.x0.clone_from(&s.particle_q);
        }
        // Handles move after the integrator and before the collision pass: with handles the pass stays apart.
        self.collide_at = (m.has_colliders() && !m.has_handles()).then_some(s.time + dt);
        self.collided = false;
        match self.config.integrator {
            Integrator::SymplecticEuler => self.symplectic_euler(m, s, h, &blown),
            Integrator::VelocityVerlet => self.velocity_verlet(m, s, h, &blown),
            Integrator::Rk4 => self.rk4(m, s, h, &blown),
            Integrator::ImplicitEuler => self.implicit_euler(m, s, h, &blown)?,
        }
        let t = s.time;
        s.time += dt;
        if self.config.integrator == Integrator::ImplicitEuler {
            self.imp.warm = Some((s.time, h));
        }
        if m.has_handles() {
            move_handles(m, s, t, s.time);
        }
        self.collide(m, s, &blown);
        self.contact(m, s, dt, &blown);
        self.timers.steps += 1;
        self.timers.total += t0.elapsed();
        if self.config.check_finite && blown.load(Ordering::Relaxed) {
            let (particle, what) = (0..m.particle_count())
                .find_map(|i| {
                    if !s.particle_qd[i].is_finite() {
                        Some((i, "velocity"))
                    } else if !s.particle_q[i].is_finite() {
                        Some((i, "position"))
                    } else {
                        None
                    }
                })
                .unwrap_or((0, "velocity"));
            // The cached bound, else the one at the initial positions (the blown state has none).
            let stable_dt = self.stability_bound(m).max_dt(self.config.integrator);
            return Err(StepError::NonFinite { time: s.time, dt, particle, what, stable_dt });
        }
        Ok(())
    }
}

impl<R: Real> Solver<R> for CpuSolver<R> {
    fn step(&mut self, model: &Model<R>, state: &mut State<R>, dt: f64) -> Result<(), StepError> {
        self.advance(model, state, dt, 1)
    }

    fn advance(&mut self, model: &Model<R>, state: &mut State<R>, dt: f64, steps: usize) -> Result<(), StepError> {
        // A model whose passes go to rayon's pool steps inside the pool: one hand-over per batch instead of one per
        // pass (a thread outside the pool waits for each pass it hands over, with a wake-up each way; measured
        // on the 128² cloth, 2 threads, 2026-11-24: 177–202 µs per step handing over each pass, 152–161 each
        // step).
        #[cfg(feature = "parallel")]
        if rayon::current_thread_index().is_none() && par::pool_has_threads() {
            let big = par::pooled(model.particle_count().max(model.spring_count()));
            // The model's passes go to the spinning team (`crate::team`), when no other thread holds it: a
            // smaller model's always, a large one's when the team has as many threads as the pool (its helpers
            // are capped; on the 2-core VM, 2026-11-25, the team stepped the 128² cloth in 57.7 µs against 66–68
            // in the pool, 512² in 1.24 ms against 1.85, the 10,242-vertex ball with gas in 136 µs against 148).
            // The contact pass's searches then run on the team's pieces or on this thread (`par::rayon_free`).
            // Whether it pays is measured as the steps run (`crate::team::Pick`), against one thread for a smaller
            // model and against the pool for a large one.
            let lease = if !big || crate::team::covers_pool() { crate::team::lease() } else { None };
            if let Some(lease) = lease {
                let mut left = steps;
                while left > 0 {
                    let (team, most) = self.team_pick.choose();
                    let n = most.min(left).max(1);
                    let t0 = Instant::now();
                    let mut run = |this: &mut Self| (0..n).try_for_each(|_| this.step_inner(model, state, dt));
                    let r = if team {
                        run(self)
                    } else if big {
                        // The pool's workers need both cores: the helpers park rather than spin beside them.
                        crate::team::rest();
                        lease.without(|| rayon::scope(|_| run(self)))
                    } else {
                        lease.without(|| run(self))
                    };
                    self.team_pick.record(team, n, t0.elapsed().as_secs_f64());
                    r?;
                    left -= n;
                }
                return Ok(());
            }
            if big {
                return rayon::scope(|_| (0..steps).try_for_each(|_| self.step_inner(model, state, dt)));
            }
        }
        (0..steps).try_for_each(|_| self.step_inner(model, state, dt))
    }

    fn notify_model_changed(&mut self, _model: &Model<R>, delta: &TopologyDelta) {
        // Buffers (and the stability bound) are sized lazily from the model's counts on the next step. A leak
        // alone changes only gas amounts, which every step reads anyway.
        if !delta.is_empty() {
            self.sized_for = None;
            self.bound = None;
            self.f.measured = false;
            self.ct.changed(delta);
        }
    }

    fn fracture_measures(&self, model: &Model<R>) -> Option<crate::fracture::Measures<'_, R>> {
        self.measures(model)
    }

    fn may_have_fracture_candidates(&self) -> bool {
        let f = &self.f;
        !(f.measured && f.strain_sparse && f.strain_spans.is_empty() && !f.loads)
    }

    fn set_instant_trigger(&mut self, instant: bool) {
        self.f.sparse_strains = instant;
    }

    fn timers(&self) -> &StageTimers {
        &self.timers
    }

    fn reset_timers(&mut self) {
        self.timers.reset();
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    fn name(&self) -> &'static str {
        "cpu"
    }

    fn rest(&mut self) {
        #[cfg(feature = "parallel")]
        crate::team::rest();
    }
}

/// Moves the particles of every [`crate::model::Handle`] by its path's change from `t0` to `t1` \[s\] and gives
/// them the path's mean velocity over the step. Runs after the integrator (which leaves pinned particles alone)
/// and before collisions, so forces of step `t0 -> t1` saw the handles where they were at `t0`: first order in
/// the handle's motion, as a kinematic boundary is in a symplectic Euler step. One pass over the particles'
/// handle marks, only in a model that has handles.
fn move_handles<R: Real>(m: &Model<R>, s: &mut State<R>, t0: f64, t1: f64) {
    let moves: Vec<(R::V, R::V)> = m
        .handles
        .iter()
        .map(|h| {
            let d = h.offset(t1) - h.offset(t0);
            (R::V::from_dvec3(d), R::V::from_dvec3(d / (t1 - t0)))
        })
        .collect();
    for (i, &h) in m.particle_handle.iter().enumerate() {
        if let Some(&(d, v)) = moves.get(h as usize) {
            s.particle_q[i] += d;
            s.particle_qd[i] = v;
        }
    }
}
