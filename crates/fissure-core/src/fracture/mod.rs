//! Multiple local fractures by virtual nodes (the seed's section 3, after Molino, Bao & Fedkiw 2004).
//!
//! [`Fracture::apply`] runs between steps: it checks every breakable spring and vertex, picks the ones past their
//! limits (at most [`FractureConfig::max_events_per_step`], the worst first, ties by index: a deterministic
//! order), splits them one after another on the live topology, and reports each split as a [`FractureEvent`].
//!
//! **Spring mode** (seed Fig. 2). A spring `a–b` stretched past its strain limit (set directly, or from the
//! body's tear strength in N/m: [`crate::Breakable::tear_strength`]) breaks. Two virtual nodes are made on the
//! segment, each 0.45 of its length from its parent: `n_a`, the part of the material on `a`'s side, and `n_b` on
//! `b`'s side (never at one point, and no node jumps: a jump could carry a face through a neighbour within the
//! contact distance). Each takes a share of its parent's mass (the share the new triangles' lumped areas give
//! it) and its parent's velocity, so mass is conserved exactly and momentum to rounding. Each triangle
//! `(a, b, c)` on the edge is cut from the edge towards `c` into `(a, n_a, c)` and `(n_b, b, c)`; the old spring
//! goes, and springs follow the new edges (`a–n_a`, `b–n_b` with half the rest length, `n_a–c`, `n_b–c` with the
//! rest triangle's median). The crack is the slit `c–n_a–d | c–n_b–d` across the broken spring, opening as its
//! two sides move apart; its tips are `c` and `d`. The springs of a crack's faces never break: born as
//! stretched as the material around them, with light nodes, they would pass the limit within steps and every
//! split would set off more along its own faces (the sheet shatters round the crack instead of tearing along
//! it); a crack runs through the material at its tips.
//!
//! **Cracks that run and stop.** A membrane under uniform tension has every spring along the load past its
//! limit within a step or two; splitting them all shatters it. Three rules make a crack start at one place,
//! run across the tension and stop when the load drops:
//! - at most [`FractureConfig::splits_per_body`] (default 1) triangle-edge splits per body per step: a crack
//!   advances up to an edge per step, faster than the membrane's waves at any stable step;
//! - a split whose spring touches no crack tip starts a new crack, and the body then waits
//!   [`FractureConfig::nucleation_interval`] (default: the time a stress wave takes to cross it) before the next
//!   one; a piece that comes off waits as long. A tip's springs may advance at once. So the first crack unloads
//!   the material before another can start, and a crack does not branch from its flanks;
//! - candidates are ranked by their ratio times `sin²` of the angle between the spring (the tension that
//!   stretched it) and the slit its split would open: a split can only cut a triangle from an edge to its
//!   opposite corner, and the weight makes a crack take the cut most nearly across the load, following the
//!   perpendicular to the principal stress as closely as the mesh allows (a notched sheet pulled uniaxially
//!   cracks within 2° of it, `tests/suite/tearing.rs`).
//!
//! A crack in a gas body is driven by the pressure; as the gas leaks through the slit the tips' springs fall
//! below their limit and the crack stops. With [`Trigger::Averaged`] a tip needs a sustained overload: the crack
//! advances about an edge per window, and dynamic spikes (an impact's ringing) start none.
//!
//! **Core mode** (seed Fig. 3). A vertex `v` whose *load* passes its limit breaks out. Load is the magnitude of
//! the net elastic force (springs and gas) on the vertex, in newtons: in a uniformly stretched or inflated
//! membrane it is near zero however high the tension (the vertex is pulled equally from all sides — tearing under
//! tension is the spring mode's job), and it is large exactly where the body is pressed or pulled locally, at a
//! contact with an obstacle or a sharp dent: where a chunk is punched out. The core block is `v`'s whole one-ring:
//! its fan triangles `(v, p_i, p_{i+1})` go to a new body with copies `c_i` of the ring vertices (each taking
//! the share of `p_i`'s mass its two fan triangles lumped on it, and `p_i`'s velocity: mass and momentum exact),
//! the spokes, each moving its end from `p_i` to `c_i` (the same spring, kept in its place in the model), and a
//! twin `c_i–c_{i+1}` of each rim spring; the surface keeps the ring `p_i` and its rim
//! springs around a hole the size of the block. Springs that crossed the fan or the rim (`v`'s bending springs,
//! and those between ring vertices that are not rim edges) break. The ring vertices become crack tips: the
//! stress at a hole's rim can start cracks. The fan triangles change body where they lie; once one in 64 of a
//! large model's triangles has, the pass orders the triangles by body again ([`Model::order_triangles_by_body`],
//! `delta.whole`), so the blocks' triangles follow the bodies they came from instead of lying among them.
//!
//! **Stiffness cap.** A split makes light nodes held by springs as stiff as the one that broke; each spring keeps
//! its own frequency, but a node held by two or three of them oscillates faster than any particle did. After
//! each step's splits, every touched particle whose `Σ k / m` passed the highest of the model as first seen has
//! its springs softened to it, so the explicit integrators stay stable at the step the model started with.
//!
//! **Separation.** After a split, a vertex whose triangles no longer form one fan (a crack reached it from two
//! sides) is duplicated, one copy per fan, its mass shared exactly; its springs go to the copy whose fan holds
//! the other end (others to the nearest fan). If the copies are no longer joined by any chain of springs, the
//! smaller side becomes its own body (a [`FractureKind::Detach`] event): found by a breadth-first search from
//! both copies at once that stops when either side is exhausted (the piece) or they meet, so its cost follows
//! the smaller piece, not the mesh.
//!
//! **Openings and gas.** The boundary loops of a gas body are its openings ([`crate::model::Opening`]); the
//! body's volume is taken with a virtual cap over each (and the gas pushes on the caps, so the pressure force
//! stays conservative and sums to zero). Unless the body is sealed, gas leaks out through the openings by the
//! orifice equation (after Mesit & Guha 2008, the seed's ref. \[6\]): the volume flow is
//! `Q = C_d A sqrt(2 ΔP / ρ)` with `A` the openings' area and `ΔP = nRT/V - P_ext`; gas leaving at the inside
//! pressure carries `nRT` away at `d(nRT)/dt = -(nRT / V) Q`, integrated exactly over a step as
//! `nRT <- nRT exp(-Q dt / V)`. No inflow is modelled.
//!
//! **Cost.** A split edits the arrays of the triangles, springs and particles it touches and the adjacency rows
//! of their particles ([`crate::csr::Csr`] rows with slack), and appends new items: its cost follows the size of
//! the change, not of the mesh. Broken springs keep their slot as [`SpringKind::Broken`] (zero stiffness, in no
//! adjacency row), so spring indices and the cloth kernel's spring runs stay valid.
//!
//! Mass is shared out exactly in floating point: each share is rounded down to a multiple of the parent mass's
//! unit in the last place, so `parent - n · share` and every sum involved are exact.

use crate::model::{Model, Opening, SpringKind, State};
use crate::real::{Real, Vector3};
use crate::timers::Instant;
use crate::timers::{Stage, StageTimers};
use glam::DVec3;
use std::collections::BTreeSet;

mod core_mode;
mod gas;
mod guards;
use guards::{crossing_times, stiffness_sum};
mod separate;
mod spring_mode;
mod trigger;

pub use crate::model::check_invariants;
pub use crate::model::edit::{Fan, boundary_next, fans, spring_between};

/// When a limit counts as passed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Trigger {
    /// The current strain (or load) passes the limit.
    Instant,
    /// The strain (or load) averaged over a window passes it: an exponential moving average with time constant
    /// `window` \[s\] (after Bao, Hong, Teran & Fedkiw 2007). Raw thresholds fracture stiff materials arbitrarily,
    /// on single-step spikes; the average needs a sustained overload.
    Averaged {
        /// Time constant \[s\].
        window: f64,
    },
}

/// Settings of the fracture pass.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FractureConfig {
    /// When a limit counts as passed. Default [`Trigger::Instant`].
    pub trigger: Trigger,
    /// Most splits per step (the worst first). Default 32.
    pub max_events_per_step: usize,
    /// Most spring-mode splits of triangle edges per body per step. Default 1. A membrane under uniform tension
    /// has every spring along the load past its limit within one step; splitting them all starts a crack at
    /// each and shatters the sheet. In a real sheet the first crack unloads the material around it and its
    /// tips, where the stress concentrates, take the load. One split per body per step keeps to that: the worst
    /// spring nucleates a crack, and on the next steps its tips (now the worst) carry it across while the load
    /// holds, at up to one edge per step (faster than the membrane's waves at any stable step). Springs on no
    /// triangle (bending, the second diagonal) are simply removed and do not count.
    pub splits_per_body: usize,
    /// Least time \[s\] between two new cracks in one body: a split whose springs touch no earlier crack starts a
    /// new one, and the body then waits this long before the next (the tips of the cracks it has may advance
    /// meanwhile). `None` (the default): the time a stress wave takes to cross the body, `extent / c` with
    /// `c = sqrt(k / ρ_A)` from its mean edge stiffness and area density. By then the first crack has unloaded
    /// the material, and a sheet that reaches its strength everywhere at once tears along one crack instead of
    /// shattering. `Some(0.0)`: no wait.
    pub nucleation_interval: Option<f64>,
    /// Orifice discharge coefficient `C_d` of openings. Default 0.6 (a sharp-edged orifice).
    pub discharge_coefficient: f64,
    /// Density `ρ` of the gas \[kg/m^3\] in the orifice equation. Default 1.2 (air).
    pub gas_density: f64,
    /// Springs shorter than this at rest \[m\] do not split (a crack needs room). Default 1e-5.
    pub min_rest_length: f64,
    /// No split may leave a particle lighter than this fraction of the lightest breakable particle of the
    /// model as first seen. Each split shares masses out, and a fragment that keeps breaking would otherwise
    /// make ever lighter particles on the same springs (`ω = sqrt(k/m)` grows without bound) until the
    /// integrator goes unstable. Default 1/16 (a 4× higher frequency at most).
    pub min_mass_ratio: f64,
    /// Simulated time \[s\] before which nothing breaks (the gas leak still runs). A pressurised body starts out of
    /// equilibrium (its whole gas force unbalanced until the membrane stretches), and its load transient is not
    /// a fracture; let it settle. Default 0.
    pub start_time: f64,
}

impl FractureConfig {
    /// Checks every value: an averaged trigger's `window` finite and > 0, `discharge_coefficient` and
    /// `gas_density` finite and > 0, `min_rest_length` and `min_mass_ratio` finite and >= 0, `start_time` finite.
    /// The error names the setting as a scene file's `[fracture]` and Python do (`averaged_window`, ...).
    pub fn validate(&self) -> Result<(), crate::ModelError> {
        use crate::ModelError;
        if let Trigger::Averaged { window } = self.trigger
            && !(window.is_finite() && window > 0.0)
        {
            return Err(ModelError::Parameter {
                name: "averaged_window",
                value: window,
                expected: "finite and > 0 [s]",
            });
        }
        if self.splits_per_body == 0 {
            return Err(ModelError::Parameter {
                name: "splits_per_body",
                value: 0.0,
                expected: ">= 1 (a strain limit of infinity switches spring mode off)",
            });
        }
        for (name, v) in [("discharge_coefficient", self.discharge_coefficient), ("gas_density", self.gas_density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and > 0" });
            }
        }
        if let Some(v) = self.nucleation_interval
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(ModelError::Parameter {
                name: "nucleation_interval",
                value: v,
                expected: "finite and >= 0 [s]",
            });
        }
        for (name, v) in [("min_rest_length", self.min_rest_length), ("min_mass_ratio", self.min_mass_ratio)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and >= 0" });
            }
        }
        if !self.start_time.is_finite() {
            return Err(ModelError::Parameter { name: "start_time", value: self.start_time, expected: "finite [s]" });
        }
        Ok(())
    }
}

impl Default for FractureConfig {
    fn default() -> Self {
        FractureConfig {
            trigger: Trigger::Instant,
            max_events_per_step: 32,
            splits_per_body: 1,
            nucleation_interval: None,
            discharge_coefficient: 0.6,
            gas_density: 1.2,
            min_rest_length: 1e-5,
            min_mass_ratio: 1.0 / 16.0,
            start_time: 0.0,
        }
    }
}

/// What broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum FractureKind {
    /// A spring broke (spring mode). Without triangles on it, it is simply removed.
    Spring,
    /// A vertex broke out as a core block (core mode).
    Core,
    /// A piece came off and became its own body.
    Detach,
}

/// One fracture, as reported to the caller.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FractureEvent {
    /// What broke.
    pub kind: FractureKind,
    /// Simulation time \[s\].
    pub time: f64,
    /// Where \[m\]: the spring's midpoint, the core vertex, or the vertex where the piece came off.
    pub position: DVec3,
    /// The body it happened in.
    pub body: u32,
    /// The broken spring (spring mode).
    pub spring: Option<u32>,
    /// The core vertex (core mode) or the separated vertex (detach).
    pub vertex: Option<u32>,
    /// Particles created.
    pub new_particles: Vec<u32>,
    /// The body created (core block or detached piece).
    pub new_body: Option<u32>,
}

impl FractureEvent {
    /// A spring-mode event: spring `sp` of `body` broke at `position` (its virtual nodes, if any, in `new_particles`).
    fn spring(time: f64, position: DVec3, body: u32, sp: u32, new_particles: Vec<u32>) -> Self {
        FractureEvent {
            kind: FractureKind::Spring,
            time,
            position,
            body,
            spring: Some(sp),
            vertex: None,
            new_particles,
            new_body: None,
        }
    }
}

/// What a call of [`Fracture::apply`] (or a forced break) did: the events, and every item of the model it changed.
///
/// This is the contract between the fracture pass and the solvers: `World` hands it to
/// [`crate::Solver::notify_model_changed`], and a solver that mirrors the model (the GPU) re-packs and uploads only
/// the rows it names, so the work after a split follows the size of the change, not of the mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TopologyDelta {
    /// The fractures, in the order they happened.
    pub events: Vec<FractureEvent>,
    /// Particles, springs, triangles and bodies before the call; items from these indices on are new.
    pub old_counts: [usize; 4],
    /// Existing particles whose mass, body or load limit changed.
    pub particles: Vec<u32>,
    /// Particles whose spring or triangle rows (adjacency lists) changed, new particles included.
    pub rows: Vec<u32>,
    /// The adjacency lists were compacted: every row may have moved (a mirror re-copies them all).
    pub rows_compacted: bool,
    /// Existing springs that broke, moved an end, or had their stiffness or damping scaled (their end's mass
    /// changed).
    pub springs: Vec<u32>,
    /// Existing triangles that were rewritten.
    pub triangles: Vec<u32>,
    /// Whether the openings changed.
    pub openings: bool,
    /// Whether a body's gas amount changed (it leaked through an opening); nothing else need have changed.
    pub gas: bool,
    /// Anything may have changed (a hand edit of the model's arrays): a mirror re-derives everything.
    pub whole: bool,
}

impl TopologyDelta {
    /// True if the topology, masses and openings are unchanged (the gas may have leaked: see [`Self::gas`]).
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
            && self.particles.is_empty()
            && self.springs.is_empty()
            && self.triangles.is_empty()
            && self.rows.is_empty()
            && !self.rows_compacted
            && !self.openings
            && !self.whole
    }

    /// The delta for a model edited by hand: anything may have changed.
    pub fn whole() -> Self {
        TopologyDelta { whole: true, gas: true, ..Default::default() }
    }

    /// True if nothing at all changed, gas included.
    pub fn is_nothing(&self) -> bool {
        self.is_empty() && !self.gas
    }
}

/// The fracture trigger's inputs as a solver measured them during its last step (`Solver::fracture_measures`),
/// at the state that step started from: the pass then compares them with the limits instead of recomputing
/// every spring's force and every body's volume (the scan was half of the fracture scene's step). One step
/// of lag (`dt`, tens of microseconds) is far below any time scale the trigger resolves; the splits themselves
/// use the current state.
#[derive(Clone, Copy, Debug)]
pub struct Measures<'a, R: Real> {
    /// Strain `(l - L0) / L0` of each spring (with `strain_spans`, only of the springs listed there).
    pub strain: &'a [R],
    /// `None`: `strain` holds every spring's. `Some`: the solver stored only these ranges `[start, end)` of
    /// springs, the spans where some strain might pass its limit; every other spring's strain was within its
    /// limit. Enough for [`Trigger::Instant`]; [`Trigger::Averaged`] needs every strain and rescans the state.
    pub strain_spans: Option<&'a [[u32; 2]]>,
    /// Load of each particle with a finite load limit \[N\]: `|Σ elastic spring pulls + pressure shares|`, the
    /// sum [`Fracture::apply`] takes itself.
    pub load: &'a [R],
    /// Volume of each gas body, capped over its openings \[m^3\] (0 for bodies without gas).
    pub volume: &'a [R],
}

/// The fracture pass: its settings, the averaged triggers' history, scratch, and its timer.
#[derive(Clone, Debug, Default)]
pub struct Fracture<R: Real = f32> {
    /// Settings.
    pub config: FractureConfig,
    spring_avg: Vec<R>,
    particle_avg: Vec<R>,
    candidates: Vec<(f64, u8, u32)>,
    tri_force: Vec<DVec3>,
    /// Body volumes of the current call (empty: not yet computed, or stale after a split).
    volumes: Vec<f64>,
    spring_force: Vec<DVec3>,
    /// Each spring's strain and each particle's load (the scan without a solver's measures).
    strain: Vec<R>,
    load: Vec<R>,
    /// Per-particle stamp: `step_gen` if touched this step.
    touched: Vec<u32>,
    step_gen: u32,
    touched_list: Vec<u32>,
    /// BFS marks: `(gen << 2) | side`.
    mark: Vec<u64>,
    mark_gen: u64,
    /// Boundary vertices of each gas body.
    boundary: Vec<BTreeSet<u32>>,
    /// The lightest particle a split may make \[kg\] (set on first use from `min_mass_ratio`).
    mass_floor: Option<R>,
    /// Triangles given to a new body (a core block, a detached piece) since the triangles were last ordered by
    /// body (see [`Fracture::finish`]).
    rebodied: usize,
    /// The highest `Σ k / m` \[1/s²\] of any free particle as first seen: no split may raise a particle's above it.
    stiff_cap: f64,
    /// Per body: when it may start its next crack \[s\], and its wave-crossing time \[s\].
    quiet_until: Vec<f64>,
    crossing: Vec<f64>,
    /// Per particle: a crack tip (the far corner of a split triangle, or the rim of a core block's hole) made by
    /// an earlier step; `new_tips` those of this step.
    tip: Vec<bool>,
    new_tips: Vec<u32>,
    timers: StageTimers,
    delta: TopologyDelta,
}

fn split_mass<R: Real>(m: R, frac: f64, n: usize) -> Option<(R, R)> {
    // A share rounded down to a multiple of ulp(m): n shares and the remainder are then exact (all are integer
    // multiples of ulp(m) not above m).
    if !(m > R::ZERO && m.is_finite()) || frac * n as f64 > 1.0 {
        return None;
    }
    let u = m.ulp();
    let p = ((m * R::from_f64(frac)) / u).floor() * u;
    if p <= R::ZERO {
        return None;
    }
    Some((m - p * R::from_f64(n as f64), p))
}

fn inv<R: Real>(pinned: bool, m: R) -> R {
    if pinned { R::ZERO } else { R::ONE / m }
}

impl<R: Real> Fracture<R> {
    /// A pass with `config`.
    pub fn new(config: FractureConfig) -> Self {
        Fracture { config, ..Default::default() }
    }

    /// Time spent (stage `Fracture` only).
    pub fn timers(&self) -> &StageTimers {
        &self.timers
    }

    /// Clears the timer.
    pub fn reset_timers(&mut self) {
        self.timers.reset();
    }

    /// True if the pass has anything to do for `m`: something can break, or a gas body has an opening.
    pub fn needed(&self, m: &Model<R>) -> bool {
        m.has_fracture() || !m.openings.is_empty() || m.body_gas_inflow.iter().any(|&q| q > R::ZERO)
    }

    /// Checks every breakable spring and vertex after a step of `dt` \[s\], splits those past their limits, lets
    /// gas leak through the openings, and returns what it did: the events and what changed, which the solver
    /// must be told (`Solver::notify_model_changed`). `World` does both; call this directly only to drive a
    /// solver of your own.
    pub fn apply(&mut self, m: &mut Model<R>, s: &mut State<R>, dt: f64) -> TopologyDelta {
        self.apply_measured(m, s, dt, None)
    }

    /// [`Fracture::apply`] with the trigger's inputs as the solver measured them during the step (`World` passes
    /// `Solver::fracture_measures`); `None`, or measures of another model size, computes them from `s`.
    pub fn apply_measured(
        &mut self,
        m: &mut Model<R>,
        s: &mut State<R>,
        dt: f64,
        measures: Option<Measures<'_, R>>,
    ) -> TopologyDelta {
        let mut events = Vec::new();
        self.begin(m);
        self.volumes.clear();
        if !self.needed(m) {
            return std::mem::take(&mut self.delta);
        }
        let t0 = Instant::now();
        let instant = matches!(self.config.trigger, Trigger::Instant);
        let measures = measures.filter(|x| {
            x.strain.len() == m.spring_count()
                && x.load.len() == m.particle_count()
                && x.volume.len() == m.body_count()
                && (instant || x.strain_spans.is_none())
        });
        if let Some(x) = &measures {
            self.volumes.extend(x.volume.iter().map(|v| v.to_f64()));
        }
        if m.has_fracture() && s.time >= self.config.start_time {
            match &measures {
                Some(x) => self.scan_measured(m, x, dt),
                None => self.scan(m, s, dt),
            }
            let budget = self.config.max_events_per_step;
            let mut cands = std::mem::take(&mut self.candidates);
            self.rank_cracks(m, s, &mut cands);
            let mut done = 0;
            // Bodies and their triangle-edge splits this step.
            let mut splits: Vec<(u32, usize)> = Vec::new();
            for &(_, kind, idx) in &cands {
                if done >= budget {
                    break;
                }
                let first = events.len();
                let ok = if kind == 0 {
                    let [a, b] = m.spring_indices[idx as usize];
                    let body = m.particle_body[a as usize];
                    let on_tri = m.particle_tris.row(a as usize).iter().any(|&t| crate::model::edit::tri_has(m, t, b));
                    let k = splits.iter().position(|&(bd, _)| bd == body);
                    if on_tri && k.is_some_and(|k| splits[k].1 >= self.config.splits_per_body) {
                        continue;
                    }
                    let new_crack = on_tri && !self.near_crack(m, a, b);
                    let bu = body as usize;
                    if new_crack && self.quiet_until.get(bu).is_some_and(|&t| s.time < t) {
                        continue;
                    }
                    let ok = self.split_spring(m, s, idx, false, &mut events);
                    if ok && on_tri {
                        match k {
                            Some(k) => splits[k].1 += 1,
                            None => splits.push((body, 1)),
                        }
                    }
                    if ok && new_crack && bu < self.quiet_until.len() {
                        let wait = self.config.nucleation_interval.unwrap_or(self.crossing[bu]);
                        self.quiet_until[bu] = s.time + wait;
                    }
                    ok
                } else {
                    self.split_core(m, s, idx, &mut events)
                };
                done += ok as usize;
                // Pieces that came off wait as their body would after a new crack: the unloading wave of the crack
                // that freed them is still crossing them.
                for e in &events[first..] {
                    if let Some(nb) = e.new_body {
                        let (p, nb) = (e.body as usize, nb as usize);
                        if p < self.quiet_until.len() && nb >= self.quiet_until.len() {
                            self.quiet_until.resize(nb + 1, f64::NEG_INFINITY);
                            self.crossing.resize(nb + 1, 0.0);
                            let wait = self.config.nucleation_interval.unwrap_or(self.crossing[p]);
                            self.quiet_until[nb] = self.quiet_until[p].max(s.time + wait);
                            self.crossing[nb] = self.crossing[p];
                        }
                    }
                }
            }
            self.candidates = cands;
            if !events.is_empty() {
                self.volumes.clear();
                self.clear_colliders(m, s);
            }
            self.finish(m);
        }
        self.pump(m, dt);
        self.leak(m, s, dt);
        self.timers.add(Stage::Fracture, t0);
        self.timers.steps += 1;
        self.delta.events = events;
        std::mem::take(&mut self.delta)
    }

    /// Breaks spring `sp` now (spring mode, or removal if it is on no triangle), whatever its strain: for
    /// cutting tools and tests. No events if it cannot break (already broken, shorter than the minimum).
    pub fn break_spring(&mut self, m: &mut Model<R>, s: &mut State<R>, sp: usize) -> TopologyDelta {
        self.break_now(m, s, sp, false)
    }

    /// Breaks particle `v` out as a core block now, whatever its load: a puncture. Empty if it cannot (pinned,
    /// on or next to a boundary, valence outside 3..=64, a spoke that is not a spring): no events then.
    pub fn break_core(&mut self, m: &mut Model<R>, s: &mut State<R>, v: usize) -> TopologyDelta {
        self.break_now(m, s, v, true)
    }

    fn break_now(&mut self, m: &mut Model<R>, s: &mut State<R>, index: usize, core: bool) -> TopologyDelta {
        self.begin(m);
        let mut events = Vec::new();
        if core && index < m.particle_count() {
            self.split_core(m, s, index as u32, &mut events);
        } else if !core && index < m.spring_count() {
            self.split_spring(m, s, index as u32, true, &mut events);
        }
        self.finish(m);
        self.delta.events = events;
        std::mem::take(&mut self.delta)
    }

    /// Sizes the pass for `m` and fixes the mass floor (`min_mass_ratio` times the lightest particle with
    /// triangles). Done on first use; call it ahead to keep that O(model) work out of the first split.
    pub fn prepare(&mut self, m: &Model<R>) {
        if self.mass_floor.is_none() {
            let lightest = (0..m.particle_count())
                .filter(|&i| !m.particle_tris.row(i).is_empty())
                .map(|i| m.particle_mass[i])
                .fold(R::infinity(), |a, b| a.min(b));
            self.mass_floor = Some(lightest * R::from_f64(self.config.min_mass_ratio));
            self.stiff_cap = (0..m.particle_count())
                .filter(|&i| m.particle_inv_mass[i] != R::ZERO)
                .map(|i| stiffness_sum(m, i) / m.particle_mass[i].to_f64())
                .fold(0.0, f64::max);
            self.crossing = crossing_times(m);
            self.quiet_until = vec![f64::NEG_INFINITY; m.body_count()];
        }
        let n = m.particle_count();
        if self.touched.len() < n {
            self.touched.resize(n + n / 4, self.step_gen.wrapping_sub(1));
        }
        if self.mark.len() < n {
            self.mark.resize(n + n / 4, 0);
        }
    }

    fn begin(&mut self, m: &mut Model<R>) {
        if self.mass_floor.is_none() {
            self.prepare(m);
        }
        self.delta = TopologyDelta {
            old_counts: [m.particle_count(), m.spring_count(), m.tri_count(), m.body_count()],
            ..Default::default()
        };
        self.step_gen = self.step_gen.wrapping_add(1);
        self.touched_list.clear();
        m.particle_springs.take_edits();
        m.particle_tris.take_edits();
    }

    fn finish(&mut self, m: &mut Model<R>) {
        if self.touched_list.is_empty() {
            return;
        }
        self.soften(m);
        for v in std::mem::take(&mut self.new_tips) {
            let v = v as usize;
            if self.tip.len() <= v {
                self.tip.resize(v + 1 + v / 4, false);
            }
            self.tip[v] = true;
        }
        self.update_openings(m);
        // The triangles grouped by body again once enough of them went to new bodies in place: a core block's
        // fan triangles are rewritten where they were, among the body's own, with corners at its new particles at
        // the end of the numbering, so each core's triangle chunks read particles the other core updated. On the
        // 2,562-vertex ball after 100 core splits, two threads, the Zen 4 development VM, 2026-11-29 (a probe):
        // its step ÷ the intact ball's 1.39 → 1.25 with its blocks' triangles at the end. O(T log T) each time,
        // once every T/64 triangles moved (a split's few: amortised), only past one chunk of the surface pass
        // (one core forms a smaller model's crosses whatever their order), not for grid cloths (their wind pass
        // walks the grid's own triangle layout); a mirror re-derives everything (`delta.whole`).
        if self.rebodied * 64 >= m.tri_count() && m.tri_count() > crate::par::CHUNK {
            self.rebodied = 0;
            if m.tri_grids.is_empty() && m.order_triangles_by_body() {
                self.delta.whole = true;
            }
        }
        m.particle_springs.compact_if_sparse();
        m.particle_tris.compact_if_sparse();
        for log in [m.particle_springs.take_edits(), m.particle_tris.take_edits()] {
            self.delta.rows.extend(log.rows);
            self.delta.rows_compacted |= log.compacted;
        }
        for list in
            [&mut self.delta.particles, &mut self.delta.springs, &mut self.delta.triangles, &mut self.delta.rows]
        {
            list.sort_unstable();
            list.dedup();
        }
    }

    fn heavy_enough(&self, mass: R) -> bool {
        self.mass_floor.is_none_or(|f| mass >= f)
    }

    fn touch(&mut self, v: u32) {
        let v = v as usize;
        if self.touched.len() <= v {
            self.touched.resize(v + 1, self.step_gen.wrapping_sub(1));
        }
        if self.touched[v] != self.step_gen {
            self.touched[v] = self.step_gen;
            self.touched_list.push(v as u32);
        }
    }

    /// Sets particle `i`'s mass (its springs' stiffness and damping scale down with it, see
    /// `model::edit::set_mass`) and names the particle and all of those springs in the delta: a mirror of the
    /// model (the GPU's) must re-copy them, or it steps the split's neighbours on their old stiffness.
    fn set_mass(&mut self, m: &mut Model<R>, i: usize, mass: R) {
        crate::model::edit::set_mass(m, i, mass);
        self.delta.particles.push(i as u32);
        self.delta.springs.extend(m.particle_springs.row(i).iter().map(|&e| e >> 1));
    }

    fn was_touched(&self, v: u32) -> bool {
        self.touched.get(v as usize).is_some_and(|&g| g == self.step_gen)
    }
}

#[cfg(test)]
mod tests {
    use super::split_mass;

    #[test]
    fn mass_shares_are_exact() {
        for &m in &[1.0f64, 0.1, 1.0 / 3.0, 7.3e-4, 123.456] {
            for n in 1..9 {
                let (rest, part) = split_mass(m, 1.0 / (n + 1) as f64, n).unwrap();
                assert!(part > 0.0 && rest > 0.0);
                let mut acc = rest;
                for _ in 0..n {
                    acc += part; // each partial sum is a multiple of ulp(m) not above m: exact
                }
                assert_eq!(acc, m);
                assert!((part / (m / (n + 1) as f64) - 1.0).abs() < 1e-12);
            }
        }
        let (rest, part) = split_mass(0.3f32, 0.25, 1).unwrap();
        assert_eq!(rest + part, 0.3f32);
    }
}
