//! [`World`]: a model, its state, a solver (CPU, or GPU with the `gpu` feature) and the fracture pass, stepped
//! together. It is the one place that sequences the seed's step (forces, integration, collisions: the solver)
//! and fracture (the fracture pass), and tells the solver what the fracture changed. The viewer, `fissure run`,
//! the examples and the Python `World` all step through it; none keeps a loop of its own.
//!
//! **Time slicing, the same on every backend.** [`World::advance`] covers a duration in steps of `dt`, the last
//! one shortened to land exactly. The fracture pass runs every [`World::fracture_every`] steps (default 1: after
//! every step, as the seed's algorithm does) with the time those steps covered, on the CPU and on the GPU alike.
//! When the model has nothing that can break and no leaking opening, no fracture work is done and a GPU runs a
//! whole advance as one submission.
//!
//! **Synchronous and asynchronous, one path.** The stepping is written once, as `async` methods that await the
//! solver's read-backs ([`Solver::advance_async`], [`Solver::sync_state_async`]); [`World::advance`],
//! [`World::step`] and the cuts poll them once, which finishes at once on every backend that can wait for its
//! device. In a browser, where a GPU read-back completes only after control returns to the event loop, the page
//! awaits [`World::advance_async`] instead.
//!
//! **After a fracture** the pass's [`TopologyDelta`] goes to [`Solver::notify_model_changed`] (a GPU re-uploads
//! what it names) and, when particles were split off, [`Solver::upload_new_particles`] gives it their state (a
//! fracture never moves the others). A leak alone only changes the bodies' gas.

use fissure_core::*;

/// What one [`World::step`] or [`World::advance`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Advance {
    /// Steps taken.
    pub steps: usize,
    /// Fracture events, in order (also appended to [`World::events`]).
    pub events: Vec<FractureEvent>,
    /// Whether the topology (particles, springs, triangles, bodies or openings) changed: a renderer or exporter
    /// holding the mesh must re-read it.
    pub topology_changed: bool,
}

impl Advance {
    fn absorb(&mut self, delta: &TopologyDelta) {
        self.events.extend_from_slice(&delta.events);
        self.topology_changed |= !delta.is_empty();
    }
}

/// A model, its state, a solver and the fracture pass, stepped together. See the module docs.
pub struct World<R: Real = f32> {
    /// The model (read-only during a step; parameters may be changed between steps: then tell the solver with
    /// `world.solver.notify_model_changed(&world.model, &TopologyDelta::whole())`).
    pub model: Model<R>,
    /// Positions, velocities and time. Current after every [`World::step`] and [`World::advance`] on every
    /// backend.
    pub state: State<R>,
    /// The backend: a [`CpuSolver`], or a GPU solver with the `gpu` feature ([`World::with_solver`]).
    pub solver: Box<dyn Solver<R>>,
    /// The fracture pass (does nothing unless the model has something breakable or a punctured gas body).
    pub fracture: Fracture<R>,
    /// Every fracture event so far, in order.
    pub events: Vec<FractureEvent>,
    /// Steps between two fracture passes (default 1: after every step). A larger value trades when fractures are
    /// noticed for fewer state read-backs on a GPU; the pass then sees the time of all those steps at once.
    pub fracture_every: usize,
    /// Steps taken and time covered since the last fracture pass (the cadence, shared by `step` and `advance`).
    since_fracture: (usize, f64),
}

impl<R: Real> World<R> {
    /// A world at the model's initial state on the CPU solver with `config`, with the default fracture settings.
    pub fn new(model: Model<R>, config: SolverConfig) -> Self {
        Self::with_solver(model, Box::new(CpuSolver::<R>::new(config)))
    }

    /// A world at the model's initial state on `solver` (a GPU solver, say, built for this model).
    pub fn with_solver(model: Model<R>, solver: Box<dyn Solver<R>>) -> Self {
        let state = model.state();
        World {
            model,
            state,
            solver,
            fracture: Fracture::default(),
            events: Vec::new(),
            fracture_every: 1,
            since_fracture: (0, 0.0),
        }
    }

    /// Replaces the fracture settings.
    pub fn with_fracture(mut self, config: FractureConfig) -> Self {
        self.fracture.config = config;
        self
    }

    /// The CPU solver, if that is the backend (its stability bound, last substeps, forces).
    pub fn cpu_solver(&mut self) -> Option<&mut CpuSolver<R>> {
        self.solver.as_any_mut().downcast_mut::<CpuSolver<R>>()
    }

    /// Lets the solver's helper threads sleep now rather than wait busily for the next step ([`Solver::rest`]):
    /// call it before other work that wants the cores between advances (drawing a frame). Not between back-to-back
    /// advances: waking a sleeping helper cost more than its spinning (on the development VM, `fissure run
    /// scenes/ball_drop.toml` without drawing went 9.4–10.1× → 7.8–8.4× real time when every advance ended
    /// with it, 2026-11-25), while in the viewer, whose drawing shares the cores, the simulation per frame went
    /// 4.5–4.9 → 4.4 ms and the drawing 8.5–8.7 → 7.9–8.0 ms.
    pub fn rest(&mut self) {
        self.solver.rest();
    }

    /// One step of `dt` \[s\], then the fracture pass when [`World::fracture_every`] steps have passed since the
    /// last one. Returns what happened (the events are also appended to [`World::events`]).
    pub fn step(&mut self, dt: f64) -> Result<Advance, StepError> {
        now(self.step_async(dt))
    }

    /// [`World::step`] on a backend that reads back asynchronously (the GPU in a browser); the same steps.
    pub async fn step_async(&mut self, dt: f64) -> Result<Advance, StepError> {
        check_dt(dt)?;
        let mut out = Advance::default();
        self.batch(dt, 1, &mut out).await?;
        self.solver.sync_state_async(&mut self.state).await?;
        Ok(out)
    }

    /// Advances by `duration` \[s\] in steps of `dt` \[s\], the last ones shortened to land exactly: never to less
    /// than half of `dt` when `duration` is at least that (a remainder under half a step is shared by the last two
    /// steps: a step of nanoseconds at the end of a frame made the contact pass's push, meant for a whole step,
    /// set pieces flying; that push is a rate now, `fissure_core::contact::PUSH_TIME`, and a step of nanoseconds
    /// would still be a whole step's work for nothing).
    pub fn advance(&mut self, duration: f64, dt: f64) -> Result<Advance, StepError> {
        now(self.advance_async(duration, dt))
    }

    /// [`World::advance`] on a backend that reads back asynchronously (the GPU in a browser, where a read-back
    /// completes only after control returns to the event loop): the same steps and fracture passes, awaiting the
    /// read-backs instead of waiting for them. [`World::advance`] is this, polled once.
    pub async fn advance_async(&mut self, duration: f64, dt: f64) -> Result<Advance, StepError> {
        check_dt(dt)?;
        if !(duration.is_finite() && duration >= 0.0) {
            return Err(StepError::Config(format!("duration must be finite and >= 0 s, got {duration}")));
        }
        let mut out = Advance::default();
        let end = self.solver.time(&self.state) + duration;
        loop {
            let t = self.solver.time(&self.state);
            if t >= end - 1e-12 {
                break;
            }
            let h = last_steps(end - t, dt);
            // Full steps of `dt` up to the next fracture pass (or to the end when nothing can break), counted
            // with the same additions the solver makes to its clock.
            let cap = if self.fracture_due() {
                self.fracture_every.max(1).saturating_sub(self.since_fracture.0).max(1)
            } else {
                usize::MAX
            };
            let (mut n, mut tt) = (1, t + h);
            if h == dt {
                while n < cap && tt < end - 1e-12 && last_steps(end - tt, dt) == dt {
                    tt += dt;
                    n += 1;
                }
            }
            self.batch(h, n, &mut out).await?;
        }
        self.solver.sync_state_async(&mut self.state).await?;
        Ok(out)
    }

    /// Breaks spring `sp` now, whatever its strain (a cut); the events (none if it cannot break).
    pub fn break_spring(&mut self, sp: usize) -> Result<Vec<FractureEvent>, StepError> {
        now(self.cut(sp, false))
    }

    /// Breaks particle `v` out as a core block now, whatever its load (a puncture); the events (none if it
    /// cannot: pinned, on or next to an opening, an odd valence).
    pub fn break_core(&mut self, v: usize) -> Result<Vec<FractureEvent>, StepError> {
        now(self.cut(v, true))
    }

    /// [`World::break_core`] on a backend that reads back asynchronously (a puncture in a browser).
    pub async fn break_core_async(&mut self, v: usize) -> Result<Vec<FractureEvent>, StepError> {
        self.cut(v, true).await
    }

    async fn cut(&mut self, index: usize, core: bool) -> Result<Vec<FractureEvent>, StepError> {
        self.solver.sync_state_async(&mut self.state).await?;
        let (m, s) = (&mut self.model, &mut self.state);
        let delta = if core { self.fracture.break_core(m, s, index) } else { self.fracture.break_spring(m, s, index) };
        self.after_fracture(&delta)?;
        Ok(delta.events)
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

    /// Whether the fracture pass has work: something can break, or a gas body has an opening.
    fn fracture_due(&self) -> bool {
        self.fracture.needed(&self.model)
    }

    /// `n` steps of `h`, then the fracture pass once `fracture_every` steps have passed since the last one (the
    /// seed's steps 4 and 5), with the time they covered.
    async fn batch(&mut self, h: f64, n: usize, out: &mut Advance) -> Result<(), StepError> {
        self.solver.set_instant_trigger(matches!(self.fracture.config.trigger, crate::Trigger::Instant));
        self.solver.advance_async(&self.model, &mut self.state, h, n).await?;
        out.steps += n;
        if !self.fracture_due() {
            self.since_fracture = (0, 0.0);
            return Ok(());
        }
        self.since_fracture = (self.since_fracture.0 + n, self.since_fracture.1 + h * n as f64);
        let (steps, covered) = self.since_fracture;
        if steps < self.fracture_every.max(1) {
            return Ok(());
        }
        self.since_fracture = (0, 0.0);
        // A GPU knows whether a limit was passed; a body with openings leaks, and a pump pumps, whatever happened.
        let pumping = self.model.body_gas_inflow.iter().any(|&q| q > R::ZERO);
        if !self.solver.may_have_fracture_candidates() && self.model.openings.is_empty() && !pumping {
            return Ok(());
        }
        self.solver.sync_state_async(&mut self.state).await?;
        let measures = self.solver.fracture_measures(&self.model);
        let delta = self.fracture.apply_measured(&mut self.model, &mut self.state, covered, measures);
        self.after_fracture(&delta)?;
        out.absorb(&delta);
        Ok(())
    }

    /// Keeps the events and tells the solver what a fracture changed: the model's rows, and the state when
    /// particles were split off.
    fn after_fracture(&mut self, delta: &TopologyDelta) -> Result<(), StepError> {
        self.events.extend_from_slice(&delta.events);
        if delta.is_nothing() {
            return Ok(());
        }
        self.solver.notify_model_changed(&self.model, delta);
        // A fracture only appends particles (the others keep their state), so only the new ones are uploaded.
        if self.model.particle_count() > delta.old_counts[0] {
            self.solver.upload_new_particles(&self.state, delta.old_counts[0])?;
        }
        Ok(())
    }
}

/// The fastest a grabbed mass point follows its target \[m/s\] ([`World::steer_grab`]).
pub const GRAB_SPEED: f64 = 2.0;

/// Grabbing with the mouse (the viewer and the web page): a grabbed mass point is held as a moving pin, a
/// [`Handle`] of its own, steered towards a target each frame, so that a pull past a cloth's strength tears it;
/// fracture's copies of the grabbed point follow the same handle.
impl<R: Real> World<R> {
    /// Grabs particle `i`: it becomes a moving pin on a new handle, whose index is returned. `None` (nothing
    /// changes) for a particle out of range, pinned, or already on a handle.
    pub fn grab(&mut self, i: usize) -> Option<usize> {
        let m = &mut self.model;
        if i >= m.particle_count() || m.particle_inv_mass[i] == R::ZERO || m.particle_handle[i] != u32::MAX {
            return None;
        }
        let h = m.handles.len();
        m.handles.push(Handle { keys: vec![(self.state.time, glam::DVec3::ZERO)] });
        m.particle_handle[i] = h as u32;
        m.particle_inv_mass[i] = R::ZERO;
        self.solver.notify_model_changed(&self.model, &TopologyDelta::whole());
        Some(h)
    }

    /// Moves grab `handle`'s pin over the next `frame` seconds from `particle`'s position towards `target`, at
    /// most [`GRAB_SPEED`].
    pub fn steer_grab(&mut self, handle: usize, particle: usize, target: glam::DVec3, frame: f64) {
        if handle >= self.model.handles.len() || particle >= self.state.particle_q.len() {
            return;
        }
        let q = self.state.particle_q[particle].to_dvec3();
        let mut step = target - q;
        let max = GRAB_SPEED * frame;
        if step.length() > max {
            step = step.normalize() * max;
        }
        let t = self.state.time;
        let h = &mut self.model.handles[handle];
        let off = h.offset(t);
        h.keys = vec![(t, off), (t + frame, off + step)];
    }

    /// Lets go of grab `handle` (the last handle added): the grabbed particle and its copies are free again,
    /// moving as the pin last moved them.
    pub fn release_grab(&mut self, handle: usize) {
        let m = &mut self.model;
        if handle >= m.handles.len() {
            return;
        }
        for i in 0..m.particle_count() {
            if m.particle_handle[i] == handle as u32 {
                m.particle_handle[i] = u32::MAX;
                let mass = m.particle_mass[i];
                m.particle_inv_mass[i] = if mass > R::ZERO { R::ONE / mass } else { R::ZERO };
            }
        }
        m.handles.truncate(handle);
        self.solver.notify_model_changed(&self.model, &TopologyDelta::whole());
    }
}

#[cfg(feature = "gpu")]
impl World<f32> {
    /// A world on the GPU: a [`crate::gpu::GpuSolver`] for `model` on `ctx`'s device, with `config`'s
    /// integrator (symplectic Euler or velocity Verlet; the others have no kernels and are an error).
    pub fn gpu(
        model: Model<f32>,
        config: &SolverConfig,
        ctx: &crate::gpu::GpuContext,
    ) -> Result<Self, crate::gpu::GpuError> {
        let gpu_config = crate::gpu::GpuConfig { integrator: config.integrator, ..Default::default() };
        let solver = crate::gpu::GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &model, gpu_config)?;
        Ok(Self::with_solver(model, Box::new(solver)))
    }

    /// The GPU solver, if that is the backend (its position buffer for drawing, its passes, upload counters).
    pub fn gpu_solver(&self) -> Option<&crate::gpu::GpuSolver> {
        self.solver.as_any().downcast_ref::<crate::gpu::GpuSolver>()
    }
}

/// The result of `f` on every backend that can wait for its device ([`ready_now`]); on one that must await a
/// read-back (WebGPU in a browser) an error naming the async methods.
fn now<T>(f: impl std::future::Future<Output = Result<T, StepError>>) -> Result<T, StepError> {
    ready_now(f).unwrap_or_else(|| {
        Err(StepError::Backend(
            "this backend reads back asynchronously (WebGPU in a browser): use World::advance_async, step_async or break_core_async".into(),
        ))
    })
}

/// The next step of an advance with `rest` \[s\] left, in steps of `dt`: `dt` while that leaves half of one or
/// more (or nothing), else half of what is left, so the last two steps share the remainder: no step of an advance
/// is shorter than `dt / 2` unless the whole advance is. A frame time that is not a multiple of the step (1/30 s
/// in steps of 2.2222e-4 s leaves 3.3e-8 s) made a step of a few nanoseconds at every frame, and the contact
/// pass, which pushes a penetrating pair apart within the step it is given, then set velocities of ~1 km/s: on
/// `scenes/fracture.toml` at that step the pieces lying on the torn ball jumped at every frame, the candidate
/// lists grew to 0.9 m and `fissure run` slowed from ~4× real time to 1.8× (2026-11-29).
pub(crate) fn last_steps(rest: f64, dt: f64) -> f64 {
    if rest >= 1.5 * dt || (rest >= dt && rest - dt <= 1e-12) {
        dt
    } else if rest > dt {
        0.5 * rest
    } else {
        rest
    }
}

fn check_dt(dt: f64) -> Result<(), StepError> {
    if dt.is_finite() && dt > 0.0 { Ok(()) } else { Err(StepError::BadTimeStep(dt)) }
}

#[cfg(test)]
mod tests {
    use super::last_steps;

    /// The steps of an advance as its loop takes them: none shorter than half of `dt` (unless the advance is), the
    /// remainder of half a step or more one step, and the end reached.
    #[test]
    fn last_steps_share_a_short_remainder() {
        let dt = 2.2222e-4;
        for k in 0..2000 {
            let duration = dt * (0.3 + k as f64 * 0.01237);
            let (mut t, mut steps) = (0.0, Vec::new());
            while t < duration - 1e-12 {
                let h = last_steps(duration - t, dt);
                steps.push(h);
                t += h;
            }
            assert!((t - duration).abs() < 1e-12, "{duration}: lands at {t}");
            let least = steps.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(least >= (0.5 * dt).min(duration) - 1e-15, "{duration}: a step of {least} s");
            assert!(steps.iter().all(|&h| h <= dt), "{duration}: a step longer than dt");
            let rem = duration / dt - (duration / dt).floor();
            if duration >= dt && rem >= 0.5 + 1e-9 {
                // As before the change: whole steps, then the remainder in one.
                assert!(steps[..steps.len() - 1].iter().all(|&h| h == dt), "{duration}");
            }
        }
    }
}
