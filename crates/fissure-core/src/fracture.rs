//! Multiple local fractures by virtual nodes (the seed's section 3, after Molino, Bao & Fedkiw 2004).
//!
//! [`Fracture::apply`] runs between steps: it checks every breakable spring and vertex, picks the ones past their
//! limits (at most [`FractureConfig::max_events_per_step`], the worst first, ties by index: a deterministic
//! order), splits them one after another on the live topology, and reports each split as a [`FractureEvent`].
//!
//! **Spring mode** (seed Fig. 2). A spring `a–b` stretched past its strain limit breaks. Two virtual nodes are
//! made on the segment: `n_a`, the part of the material on `a`'s side, and `n_b` on `b`'s side. Each takes a
//! share of its parent's mass (the share the new triangles' lumped areas give it) and its parent's velocity,
//! so mass is conserved exactly and momentum to rounding. Each triangle `(a, b, c)` on the edge is cut from the
//! edge towards `c` into `(a, n_a, c)` and `(n_b, b, c)`; the old spring goes, and springs follow the new edges
//! (`a–n_a`, `b–n_b` with half the rest length, `n_a–c`, `n_b–c` with the rest triangle's median). The crack is
//! the slit `c–n_a–d | c–n_b–d` across the broken spring, opening as its two sides move apart: a crack runs
//! across the direction of the tension that made it. The halves of the broken spring snap back to their rest
//! length at once (the nodes are placed `L0/2` from their parents), so the broken spring's elastic energy is
//! released by the fracture instead of re-breaking its halves on the next step.
//!
//! **Core mode** (seed Fig. 3). A vertex `v` whose *load* passes its limit breaks out. Load is the magnitude of
//! the net elastic force (springs and gas) on the vertex, in newtons: in a uniformly stretched or inflated
//! membrane it is near zero however high the tension (the vertex is pulled equally from all sides — tearing under
//! tension is the spring mode's job), and it is large exactly where the body is pressed or pulled locally, at a
//! contact with an obstacle or a sharp dent: where a chunk is punched out. `v` splits into one copy per incident
//! triangle on each side of the break: `c_i` (the core) and `d_i` (the surface), placed halfway from `v` towards
//! the far edge of triangle `i`. The core block is `v` with the fan `(v, c_{i-1}, c_i)` and the ring of springs
//! `c_{i-1}–c_i`; it becomes its own body and breaks away. The surface keeps each triangle as `(d_i, p_i,
//! p_{i+1})` plus `(p_i, d_i, d_{i-1})` between neighbours: a valid surface with a hole where the core was. The
//! copies share `v`'s mass equally (exactly) and take its velocity. Rest lengths of all new springs come from the
//! rest shape (the one-ring unfolded flat from the springs' rest lengths).
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
//! orifice equation (after Mesit & Guha 2008, the seed's ref. [6]): the volume flow is
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

use crate::model::{BodyKind, Model, Opening, SpringKind, SpringRun, State};
use crate::real::{Real, Vector3};
use crate::timers::{Stage, StageTimers};
use glam::{DVec2, DVec3};
use std::collections::BTreeSet;
use std::time::Instant;

/// When a limit counts as passed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trigger {
    /// The current strain (or load) passes the limit.
    Instant,
    /// The strain (or load) averaged over a window passes it: an exponential moving average with time constant
    /// `window` [s] (after Bao, Hong, Teran & Fedkiw 2007). Raw thresholds fracture stiff materials arbitrarily,
    /// on single-step spikes; the average needs a sustained overload.
    Averaged {
        /// Time constant [s].
        window: f64,
    },
}

/// Settings of the fracture pass.
#[derive(Clone, Debug, PartialEq)]
pub struct FractureConfig {
    /// When a limit counts as passed. Default [`Trigger::Instant`].
    pub trigger: Trigger,
    /// Most splits per step (the worst first). Default 32.
    pub max_events_per_step: usize,
    /// Orifice discharge coefficient `C_d` of openings. Default 0.6 (a sharp-edged orifice).
    pub discharge_coefficient: f64,
    /// Density `ρ` of the gas [kg/m^3] in the orifice equation. Default 1.2 (air).
    pub gas_density: f64,
    /// Springs shorter than this at rest [m] do not split (a crack needs room). Default 1e-5.
    pub min_rest_length: f64,
    /// No split may leave a particle lighter than this fraction of the lightest breakable particle of the
    /// model as first seen. Each split shares masses out, and a fragment that keeps breaking would otherwise
    /// make ever lighter particles on the same springs (`ω = sqrt(k/m)` grows without bound) until the
    /// integrator goes unstable. Default 1/16 (a 4× higher frequency at most).
    pub min_mass_ratio: f64,
    /// Simulated time [s] before which nothing breaks (the gas leak still runs). A pressurised body starts out of
    /// equilibrium (its whole gas force unbalanced until the membrane stretches), and its load transient is not
    /// a fracture; let it settle. Default 0.
    pub start_time: f64,
}

impl Default for FractureConfig {
    fn default() -> Self {
        FractureConfig {
            trigger: Trigger::Instant,
            max_events_per_step: 32,
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
pub struct FractureEvent {
    /// What broke.
    pub kind: FractureKind,
    /// Simulation time [s].
    pub time: f64,
    /// Where [m]: the spring's midpoint, the core vertex, or the vertex where the piece came off.
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

/// What a call of [`Fracture::apply`] changed, for solvers that mirror the model (a GPU re-uploads only this).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TopologyDelta {
    /// Particles, springs, triangles and bodies before the call; items from these indices on are new.
    pub old_counts: [usize; 4],
    /// Existing particles whose mass, body or load limit changed.
    pub particles: Vec<u32>,
    /// Existing springs that broke or moved an end.
    pub springs: Vec<u32>,
    /// Existing triangles that were rewritten.
    pub triangles: Vec<u32>,
    /// Whether the openings changed.
    pub openings: bool,
}

impl TopologyDelta {
    /// True if nothing changed.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty() && self.springs.is_empty() && self.triangles.is_empty() && !self.openings
    }
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
    /// Per-particle stamp: `step_gen` if touched this step.
    touched: Vec<u32>,
    step_gen: u32,
    touched_list: Vec<u32>,
    /// BFS marks: `(gen << 2) | side`.
    mark: Vec<u64>,
    mark_gen: u64,
    /// Boundary vertices of each gas body.
    boundary: Vec<BTreeSet<u32>>,
    /// The lightest particle a split may make [kg] (set on first use from `min_mass_ratio`).
    mass_floor: Option<R>,
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
        m.has_fracture() || !m.openings.is_empty()
    }

    /// Checks every breakable spring and vertex after a step of `dt` [s], splits those past their limits, lets
    /// gas leak through the openings, and returns the events (empty if nothing broke). When the model changed,
    /// [`Fracture::last_delta`] says what, and the solver must be told (`Solver::notify_model_changed`).
    pub fn apply(&mut self, m: &mut Model<R>, s: &mut State<R>, dt: f64) -> Vec<FractureEvent> {
        let mut events = Vec::new();
        self.begin(m);
        self.volumes.clear();
        if !self.needed(m) {
            return events;
        }
        let t0 = Instant::now();
        if m.has_fracture() && s.time >= self.config.start_time {
            self.scan(m, s, dt);
            let budget = self.config.max_events_per_step;
            let cands = std::mem::take(&mut self.candidates);
            let mut done = 0;
            for &(_, kind, idx) in &cands {
                if done >= budget {
                    break;
                }
                let ok = if kind == 0 {
                    self.split_spring(m, s, idx, &mut events)
                } else {
                    self.split_core(m, s, idx, &mut events)
                };
                done += ok as usize;
            }
            self.candidates = cands;
            if !events.is_empty() {
                self.volumes.clear();
            }
            self.finish(m);
        }
        self.leak(m, s, dt);
        self.timers.add(Stage::Fracture, t0);
        self.timers.steps += 1;
        events
    }

    /// Breaks spring `sp` now (spring mode, or removal if it is on no triangle), whatever its strain: for
    /// cutting tools and tests. Empty if it cannot break (already broken, shorter than the minimum).
    pub fn break_spring(&mut self, m: &mut Model<R>, s: &mut State<R>, sp: usize) -> Vec<FractureEvent> {
        self.break_now(m, s, sp, false)
    }

    /// Breaks particle `v` out as a core block now, whatever its load: a puncture. Empty if it cannot (pinned,
    /// on or next to a boundary, valence outside 3..=64, a spoke that is not a spring).
    pub fn break_core(&mut self, m: &mut Model<R>, s: &mut State<R>, v: usize) -> Vec<FractureEvent> {
        self.break_now(m, s, v, true)
    }

    fn break_now(&mut self, m: &mut Model<R>, s: &mut State<R>, index: usize, core: bool) -> Vec<FractureEvent> {
        self.begin(m);
        let mut events = Vec::new();
        if core && index < m.particle_count() {
            self.split_core(m, s, index as u32, &mut events);
        } else if !core && index < m.spring_count() {
            self.split_spring(m, s, index as u32, &mut events);
        }
        self.finish(m);
        events
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
        }
        let n = m.particle_count();
        if self.touched.len() < n {
            self.touched.resize(n + n / 4, self.step_gen.wrapping_sub(1));
        }
        if self.mark.len() < n {
            self.mark.resize(n + n / 4, 0);
        }
    }

    fn begin(&mut self, m: &Model<R>) {
        if self.mass_floor.is_none() {
            self.prepare(m);
        }
        self.delta = TopologyDelta {
            old_counts: [m.particle_count(), m.spring_count(), m.tri_count(), m.body_count()],
            ..Default::default()
        };
        self.step_gen = self.step_gen.wrapping_add(1);
        self.touched_list.clear();
    }

    fn finish(&mut self, m: &mut Model<R>) {
        if self.touched_list.is_empty() {
            return;
        }
        self.update_openings(m);
        m.particle_springs.compact_if_sparse();
        m.particle_tris.compact_if_sparse();
        for list in [&mut self.delta.particles, &mut self.delta.springs, &mut self.delta.triangles] {
            list.sort_unstable();
            list.dedup();
        }
    }

    /// What the last [`Fracture::apply`] changed.
    pub fn last_delta(&self) -> &TopologyDelta {
        &self.delta
    }

    /// Candidates, sorted worst first: `(value / limit, 0 spring | 1 vertex, index)`.
    fn scan(&mut self, m: &Model<R>, s: &State<R>, dt: f64) {
        self.candidates.clear();
        let alpha = match self.config.trigger {
            Trigger::Instant => 1.0,
            Trigger::Averaged { window } => 1.0 - (-dt / window.max(1e-12)).exp(),
        };
        let q = &s.particle_q;
        let ns = m.spring_count();
        self.spring_avg.resize(ns, R::ZERO);
        for sp in 0..ns {
            let lim = m.spring_strain_limit[sp];
            if !lim.is_finite() || m.spring_kind[sp] == SpringKind::Broken {
                continue;
            }
            let [i, j] = m.spring_indices[sp];
            let l0 = m.spring_rest_length[sp];
            let strain = ((q[j as usize] - q[i as usize]).length() - l0) / l0;
            let v = triggered(&mut self.spring_avg[sp], strain, alpha);
            if v > lim {
                self.candidates.push(((v / lim).to_f64(), 0, sp as u32));
            }
        }
        let n = m.particle_count();
        self.particle_avg.resize(n, R::ZERO);
        if m.particle_load_limit.iter().any(|l| l.is_finite()) {
            // The load: |net elastic force| on the particle, its springs' `ks (l - L0) d̂` and its share of the gas
            // pressure. Each spring's and each triangle's term once, then per particle the sum over its rows.
            self.spring_force.clear();
            self.spring_force.extend(m.spring_indices.iter().enumerate().map(|(sp, &[i, j])| {
                let d = q[j as usize].to_dvec3() - q[i as usize].to_dvec3();
                let l = d.length();
                let ks = m.spring_stiffness[sp].to_f64();
                if l > 0.0 && ks != 0.0 { d * (ks * (l - m.spring_rest_length[sp].to_f64()) / l) } else { DVec3::ZERO }
            }));
            self.tri_force.clear();
            if m.has_pressure() {
                let pressures = self.pressures(m, s);
                self.tri_force.extend(m.tri_indices.iter().zip(&m.tri_body).map(|(tri, &b)| {
                    let p = pressures[b as usize];
                    if p == 0.0 {
                        return DVec3::ZERO;
                    }
                    let [a, b, c] = tri.map(|v| q[v as usize].to_dvec3());
                    (b - a).cross(c - a) * (p / 6.0)
                }));
            }
            for i in 0..n {
                let lim = m.particle_load_limit[i];
                if !lim.is_finite() || m.particle_inv_mass[i] == R::ZERO {
                    continue;
                }
                let mut f = DVec3::ZERO;
                for &e in m.particle_springs.row(i) {
                    let v = self.spring_force[(e >> 1) as usize];
                    if e & 1 == 0 {
                        f += v;
                    } else {
                        f -= v;
                    }
                }
                if !self.tri_force.is_empty() {
                    for &t in m.particle_tris.row(i) {
                        f += self.tri_force[t as usize];
                    }
                }
                let v = triggered(&mut self.particle_avg[i], R::from_f64(f.length()), alpha);
                if v > lim {
                    self.candidates.push(((v / lim).to_f64(), 1, i as u32));
                }
            }
        }
        self.candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    }

    /// Net gas pressure of each body [Pa] (capped volumes, volumes computed at most once per call of
    /// [`Fracture::apply`]).
    fn pressures(&mut self, m: &Model<R>, s: &State<R>) -> Vec<f64> {
        if self.volumes.len() != m.body_count() {
            self.volumes = m.body_volumes(s);
        }
        (0..m.body_count()).map(|b| m.gas_pressure(b, self.volumes[b]) - m.body_pressure_external[b].to_f64()).collect()
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

    fn was_touched(&self, v: u32) -> bool {
        self.touched.get(v as usize).is_some_and(|&g| g == self.step_gen)
    }

    /// Spring mode on spring `sp`; false if it cannot split (already broken, too short, no mass to share).
    fn split_spring(&mut self, m: &mut Model<R>, s: &mut State<R>, sp: u32, events: &mut Vec<FractureEvent>) -> bool {
        let spu = sp as usize;
        if m.spring_kind[spu] == SpringKind::Broken {
            return false;
        }
        let [a, b] = m.spring_indices[spu];
        let (au, bu) = (a as usize, b as usize);
        let (xa, xb) = (s.particle_q[au], s.particle_q[bu]);
        let l0 = m.spring_rest_length[spu];
        let l = (xb - xa).length();
        // Re-check: an earlier split this step may have relieved it.
        if self.was_touched(a) || self.was_touched(b) {
            let lim = m.spring_strain_limit[spu];
            if matches!(self.config.trigger, Trigger::Instant) && (l - l0) / l0 <= lim {
                return false;
            }
        }
        let faces: Vec<u32> = m.particle_tris.row(au).iter().copied().filter(|&t| tri_has(m, t, b)).collect();
        let body = m.particle_body[au];
        let mid = ((xa + xb) * R::from_f64(0.5)).to_dvec3();
        if faces.is_empty() {
            // Not a triangle edge (shear, bending, or a free spring): it is simply removed.
            break_spring(m, sp);
            self.delta.springs.push(sp);
            self.touch(a);
            self.touch(b);
            events.push(FractureEvent::spring(s.time, mid, body, sp, Vec::new()));
            return true;
        }
        if l0.to_f64() < self.config.min_rest_length {
            return false;
        }
        // Mass shares: what the new triangles' lumped areas give the nodes (a third of half of each cut
        // triangle, from each end), as a fraction of the end's lumped area.
        let area = |t: u32| tri_area_now(m, s, t);
        let shared: f64 = faces.iter().map(|&t| area(t)).sum();
        let frac = |v: usize| {
            let all: f64 = m.particle_tris.row(v).iter().map(|&t| area(t)).sum();
            if all > 0.0 && shared > 0.0 { (0.5 * shared / all).clamp(1.0 / 16.0, 0.5) } else { 0.25 }
        };
        let (fa, fb) = (frac(au), frac(bu));
        let (Some((rest_a, part_a)), Some((rest_b, part_b))) =
            (split_mass(m.particle_mass[au], fa, 1), split_mass(m.particle_mass[bu], fb, 1))
        else {
            return false;
        };
        if [rest_a, part_a, rest_b, part_b].iter().any(|&x| !self.heavy_enough(x)) {
            return false;
        }
        // Nodes at half the rest length from their parents (the halves snap back), or at the midpoint if the
        // spring is not longer than its rest length.
        let half = R::from_f64(0.5);
        let (xna, xnb) = if l > l0 {
            let d = (xb - xa) * (R::ONE / l);
            (xa + d * (l0 * half), xb - d * (l0 * half))
        } else {
            let mid = (xa + xb) * half;
            (mid, mid)
        };
        let (pa, pb) = (m.particle_inv_mass[au] == R::ZERO, m.particle_inv_mass[bu] == R::ZERO);
        let na = add_particle(m, s, xna, s.particle_qd[au], part_a, inv(pa, part_a), m.particle_body[au], au);
        let nb = add_particle(m, s, xnb, s.particle_qd[bu], part_b, inv(pb, part_b), m.particle_body[bu], bu);
        let (ks, kd, lim) = (m.spring_stiffness[spu], m.spring_damping[spu], m.spring_strain_limit[spu]);
        let red = reduced(m.particle_mass[au], m.particle_mass[bu]);
        break_spring(m, sp);
        set_mass(m, au, rest_a);
        set_mass(m, bu, rest_b);
        self.delta.particles.extend([a, b]);
        self.delta.springs.push(sp);
        add_spring(m, a, na, l0 * half, ks, (kd, red), lim);
        add_spring(m, b, nb, l0 * half, ks, (kd, red), lim);
        let mut thirds = Vec::with_capacity(2);
        for &t in &faces {
            let tri = m.tri_indices[t as usize];
            let k = (0..3).find(|&k| [a, b].contains(&tri[k]) && [a, b].contains(&tri[(k + 1) % 3])).expect("edge");
            let (p, qv, r) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let node = |v: u32| if v == a { na } else { nb };
            set_tri(m, t, [p, node(p), r]);
            self.delta.triangles.push(t);
            let tb = m.tri_body[t as usize];
            add_tri(m, [node(qv), qv, r], tb);
            // The rest triangle's median from r to the edge's midpoint.
            let (lpr, lqr) = (rest_between(m, s, p, r), rest_between(m, s, qv, r));
            let l0f = l0.to_f64();
            let med = (0.25 * (2.0 * lpr * lpr + 2.0 * lqr * lqr - l0f * l0f)).max(1e-6 * l0f * l0f).sqrt();
            add_spring(m, na, r, R::from_f64(med), ks, (kd, red), lim);
            add_spring(m, nb, r, R::from_f64(med), ks, (kd, red), lim);
            thirds.push(r);
        }
        for v in [a, b, na, nb].into_iter().chain(thirds.iter().copied()) {
            self.touch(v);
        }
        events.push(FractureEvent::spring(s.time, mid, body, sp, vec![na, nb]));
        for v in [a, b].into_iter().chain(thirds) {
            self.separate(m, s, v, events);
        }
        true
    }

    /// Core mode on vertex `v`; false if it cannot (touched this step, on a boundary, pinned, odd valence).
    fn split_core(&mut self, m: &mut Model<R>, s: &mut State<R>, v: u32, events: &mut Vec<FractureEvent>) -> bool {
        let vu = v as usize;
        if self.was_touched(v) || m.particle_inv_mass[vu] == R::ZERO {
            return false;
        }
        let fans = fans(m, v);
        if fans.len() != 1 || !fans[0].1 {
            return false;
        }
        let ring = &fans[0].0;
        let k = ring.len();
        if !(3..=64).contains(&k) {
            return false;
        }
        // A vertex next to an opening is a crack tip: it tears in spring mode. Its load is dominated by the
        // opening's rim (the cap's push, the missing hoop tension), and breaking it out as a core would eat the
        // surface hole by hole.
        if ring.iter().any(|&(_, x, _)| boundary_next(m, x).is_some()) {
            return false;
        }
        // p_i and the springs v–p_i.
        let p: Vec<u32> = ring.iter().map(|&(_, x, _)| x).collect();
        let mut sv = Vec::with_capacity(k);
        for &pi in &p {
            match spring_between(m, v, pi) {
                Some(sp) => sv.push(sp),
                None => return false,
            }
        }
        let Some((rest_v, part)) = split_mass(m.particle_mass[vu], 1.0 / (2 * k + 1) as f64, 2 * k) else {
            return false;
        };
        if !self.heavy_enough(part) || !self.heavy_enough(rest_v) {
            return false;
        }
        // The rest one-ring unfolded flat: P_i at angle phi_i, distance L_i; Q_i halfway to face i's far edge.
        let li: Vec<f64> = sv.iter().map(|&sp| m.spring_rest_length[sp as usize].to_f64()).collect();
        let mut phi = vec![0.0f64; k + 1];
        for i in 0..k {
            let (l1, l2) = (li[i], li[(i + 1) % k]);
            let e = rest_between(m, s, p[i], p[(i + 1) % k]);
            let c = ((l1 * l1 + l2 * l2 - e * e) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
            phi[i + 1] = phi[i] + c.acos();
        }
        let pt = |i: usize| DVec2::from_angle(phi[i]) * li[i % k];
        let qs: Vec<DVec2> = (0..k).map(|i| (pt(i) + pt(i + 1)) * 0.25).collect();
        // Q_{i-1} in face i's frame: face k-1 is rotated by -phi_k to meet face 0 across v–p_0.
        let prev_q = |i: usize| if i == 0 { DVec2::from_angle(-phi[k]).rotate(qs[k - 1]) } else { qs[i - 1] };
        let ks = sv.iter().fold(R::ZERO, |acc, &sp| acc + m.spring_stiffness[sp as usize]) / R::from_f64(k as f64);
        let kd = sv.iter().fold(R::ZERO, |acc, &sp| acc + m.spring_damping[sp as usize]) / R::from_f64(k as f64);
        let lim = m.spring_strain_limit[sv[0] as usize];
        let red = reduced(m.particle_mass[vu], m.particle_mass[p[0] as usize]);
        let kd = (kd, red);
        let xv = s.particle_q[vu];
        let vv = s.particle_qd[vu];
        let body = m.particle_body[vu];
        let half = R::from_f64(0.5);
        let mut d = Vec::with_capacity(k);
        let mut c = Vec::with_capacity(k);
        for i in 0..k {
            let far = (s.particle_q[p[i] as usize] + s.particle_q[p[(i + 1) % k] as usize]) * half;
            let x = xv + (far - xv) * half;
            d.push(add_particle(m, s, x, vv, part, R::ONE / part, body, vu));
        }
        let core_body = new_body(m, body, v);
        for i in 0..k {
            let x = s.particle_q[d[i] as usize];
            let ci = add_particle(m, s, x, vv, part, R::ONE / part, core_body, vu);
            m.particle_load_limit[ci as usize] = R::infinity();
            c.push(ci);
        }
        m.particle_body[vu] = core_body;
        m.particle_load_limit[vu] = R::infinity();
        m.body_anchor[core_body as usize] = v;
        if m.body_anchor[body as usize] == v {
            m.body_anchor[body as usize] = d[0];
        }
        self.delta.particles.push(v);
        // The old spokes and any other spring of v (bending springs across its edges) go: the core is free.
        let spokes: Vec<u32> = m.particle_springs.row(vu).iter().map(|&e| e >> 1).collect();
        for sp in spokes {
            break_spring(m, sp);
            self.delta.springs.push(sp);
        }
        set_mass(m, vu, rest_v);
        for (i, &(t, _, _)) in ring.iter().enumerate() {
            let (pi, pn, dp) = (p[i], p[(i + 1) % k], d[(i + k - 1) % k]);
            set_tri(m, t, [d[i], pi, pn]);
            self.delta.triangles.push(t);
            add_tri(m, [pi, d[i], dp], body);
            add_tri(m, [v, c[(i + k - 1) % k], c[i]], core_body);
            let r = |x: f64| R::from_f64(x);
            let ring_len = (qs[i] - prev_q(i)).length();
            add_spring(m, d[i], pi, r((qs[i] - pt(i)).length()), ks, kd, lim);
            add_spring(m, d[i], pn, r((qs[i] - pt(i + 1)).length()), ks, kd, lim);
            add_spring(m, d[i], dp, r(ring_len), ks, kd, lim);
            add_spring(m, v, c[i], r(qs[i].length()), ks, kd, lim);
            add_spring(m, c[i], c[(i + k - 1) % k], r(ring_len), ks, kd, lim);
        }
        for &x in [v].iter().chain(&p).chain(&d).chain(&c) {
            self.touch(x);
        }
        events.push(FractureEvent {
            kind: FractureKind::Core,
            time: s.time,
            position: xv.to_dvec3(),
            body,
            spring: None,
            vertex: Some(v),
            new_particles: d.iter().chain(&c).copied().collect(),
            new_body: Some(core_body),
        });
        true
    }

    /// Splits `v` into one particle per fan of its triangles; detaches pieces that lost their last link.
    fn separate(&mut self, m: &mut Model<R>, s: &mut State<R>, v: u32, events: &mut Vec<FractureEvent>) {
        let fans = fans(m, v);
        if fans.len() <= 1 {
            return;
        }
        let vu = v as usize;
        let k = fans.len();
        let Some((rest, part)) = split_mass(m.particle_mass[vu], 1.0 / k as f64, k - 1) else {
            return;
        };
        let pinned = m.particle_inv_mass[vu] == R::ZERO;
        let fan_verts: Vec<Vec<u32>> =
            fans.iter().map(|(f, _)| f.iter().flat_map(|&(_, x, y)| [x, y]).collect()).collect();
        let mut copies = vec![v];
        for (fan, _) in fans.iter().skip(1) {
            let body = m.particle_body[vu];
            let cp = add_particle(m, s, s.particle_q[vu], s.particle_qd[vu], part, inv(pinned, part), body, vu);
            for &(t, x, y) in fan {
                set_tri(m, t, [cp, x, y]);
                self.delta.triangles.push(t);
            }
            copies.push(cp);
        }
        set_mass(m, vu, rest);
        self.delta.particles.push(v);
        // Springs follow the fan holding their other end, else the nearest fan.
        let centres: Vec<DVec3> = fan_verts
            .iter()
            .map(|vs| vs.iter().map(|&x| s.particle_q[x as usize].to_dvec3()).sum::<DVec3>() / vs.len() as f64)
            .collect();
        let entries: Vec<u32> = m.particle_springs.row(vu).to_vec();
        for e in entries {
            let (sp, end) = ((e >> 1) as usize, (e & 1) as usize);
            let w = m.spring_indices[sp][1 - end];
            let j = fan_verts.iter().position(|vs| vs.contains(&w)).unwrap_or_else(|| {
                let xw = s.particle_q[w as usize].to_dvec3();
                (0..k).min_by(|&x, &y| centres[x].distance(xw).total_cmp(&centres[y].distance(xw))).unwrap_or(0)
            });
            if j != 0 {
                m.spring_indices[sp][end] = copies[j];
                m.particle_springs.remove(vu, e);
                m.particle_springs.push(copies[j] as usize, e);
                split_run(m, sp as u32);
                self.delta.springs.push(sp as u32);
            }
        }
        for &cp in &copies {
            self.touch(cp);
        }
        for &cp in &copies[1..] {
            if let Some(piece) = self.disconnected(m, v, cp) {
                let parent = m.particle_body[vu];
                let nb = new_body(m, parent, piece[0]);
                for &x in &piece {
                    m.particle_body[x as usize] = nb;
                    for &t in m.particle_tris.row(x as usize) {
                        m.tri_body[t as usize] = nb;
                    }
                    self.delta.particles.push(x);
                }
                if piece.contains(&m.body_anchor[parent as usize]) {
                    m.body_anchor[parent as usize] = if piece.contains(&v) { cp } else { v };
                }
                events.push(FractureEvent {
                    kind: FractureKind::Detach,
                    time: s.time,
                    position: s.particle_q[vu].to_dvec3(),
                    body: parent,
                    spring: None,
                    vertex: Some(v),
                    new_particles: copies[1..].to_vec(),
                    new_body: Some(nb),
                });
            }
        }
    }

    /// Breadth-first search from `a` and `b` at once over live springs: the particles of the side exhausted first
    /// if they are not connected, `None` as soon as the searches meet.
    fn disconnected(&mut self, m: &Model<R>, a: u32, b: u32) -> Option<Vec<u32>> {
        let n = m.particle_count();
        if self.mark.len() < n {
            self.mark.resize(n, 0);
        }
        self.mark_gen += 1;
        let tag = |side: u64| (self.mark_gen << 2) | side;
        let mut queues = [vec![a], vec![b]];
        let mut heads = [0usize; 2];
        self.mark[a as usize] = tag(1);
        self.mark[b as usize] = tag(2);
        loop {
            for side in 0..2 {
                if heads[side] == queues[side].len() {
                    return Some(std::mem::take(&mut queues[side]));
                }
                let u = queues[side][heads[side]] as usize;
                heads[side] += 1;
                for &e in m.particle_springs.row(u) {
                    let w = m.spring_indices[(e >> 1) as usize][1 - (e & 1) as usize];
                    let mk = self.mark[w as usize];
                    if mk == tag(2 - side as u64) {
                        return None;
                    }
                    if mk >> 2 != self.mark_gen {
                        self.mark[w as usize] = tag(1 + side as u64);
                        queues[side].push(w);
                    }
                }
            }
        }
    }

    /// Rebuilds the openings of the gas bodies touched this step, walking only their boundaries.
    fn update_openings(&mut self, m: &mut Model<R>) {
        if self.boundary.len() < m.body_count() {
            self.boundary.resize(m.body_count(), BTreeSet::new());
        }
        let mut dirty = BTreeSet::new();
        // A body whose gas has all leaked out keeps its openings, and they must follow its later splits too
        // (the stress test's fracture storms found stale loops otherwise).
        let with_openings: BTreeSet<u32> = m.openings.iter().map(|o| o.body).collect();
        for &v in &self.touched_list {
            let b = m.particle_body[v as usize];
            if (b as usize) < m.body_count() && (m.body_gas_amount[b as usize] > R::ZERO || with_openings.contains(&b))
            {
                self.boundary[b as usize].insert(v);
                dirty.insert(b);
            }
        }
        for b in dirty {
            let cands = std::mem::take(&mut self.boundary[b as usize]);
            let mut left: BTreeSet<u32> = cands
                .into_iter()
                .filter(|&v| m.particle_body[v as usize] == b && boundary_next(m, v).is_some())
                .collect();
            self.boundary[b as usize] = left.clone();
            m.openings.retain(|o| o.body != b);
            while let Some(start) = left.pop_first() {
                let mut lp = vec![start];
                let mut v = start;
                while let Some(nx) = boundary_next(m, v) {
                    if nx == start {
                        if lp.len() >= 3 {
                            m.openings.push(Opening { body: b, vertices: std::mem::take(&mut lp) });
                        }
                        break;
                    }
                    if !left.remove(&nx) {
                        break;
                    }
                    lp.push(nx);
                    v = nx;
                }
            }
            self.delta.openings = true;
        }
    }

    /// Orifice leak of every unsealed gas body with openings.
    fn leak(&mut self, m: &mut Model<R>, s: &State<R>, dt: f64) {
        if m.openings.is_empty() || !m.has_pressure() {
            return;
        }
        let mut bodies: Vec<u32> = m.openings.iter().map(|o| o.body).collect();
        bodies.sort_unstable();
        bodies.dedup();
        if self.volumes.len() != m.body_count() {
            self.volumes = m.body_volumes(s);
        }
        for b in bodies {
            let bu = b as usize;
            let gas = m.body_gas_amount[bu].to_f64();
            if gas <= 0.0 || m.body_sealed[bu] {
                continue;
            }
            // The volume as the force pass clamps it, and the pressure difference across the openings.
            let v = self.volumes[bu].max(1e-3 * m.body_rest_volume[bu].to_f64());
            let dp = m.gas_pressure(bu, v) - m.body_pressure_external[bu].to_f64();
            if dp <= 0.0 {
                continue;
            }
            let area = m.opening_area(s, bu);
            let flow = self.config.discharge_coefficient * area * (2.0 * dp / self.config.gas_density).sqrt();
            m.body_gas_amount[bu] = R::from_f64(gas * (-flow * dt / v).exp());
        }
    }
}

/// The trigger's value for a new sample `x`: `x` itself (instantaneous, `alpha = 1`), or the exponential moving
/// average `avg` updated by `alpha`.
fn triggered<R: Real>(avg: &mut R, x: R, alpha: f64) -> R {
    if alpha >= 1.0 {
        return x;
    }
    *avg += (x - *avg) * R::from_f64(alpha);
    *avg
}

fn tri_has<R: Real>(m: &Model<R>, t: u32, v: u32) -> bool {
    m.tri_indices[t as usize].contains(&v)
}

fn tri_area_now<R: Real>(m: &Model<R>, s: &State<R>, t: u32) -> f64 {
    let [a, b, c] = m.tri_indices[t as usize].map(|v| s.particle_q[v as usize].to_dvec3());
    0.5 * (b - a).cross(c - a).length()
}

/// The live spring between `i` and `j`, if any.
pub fn spring_between<R: Real>(m: &Model<R>, i: u32, j: u32) -> Option<u32> {
    m.particle_springs.row(i as usize).iter().map(|&e| e >> 1).find(|&sp| {
        let [a, b] = m.spring_indices[sp as usize];
        (a == i && b == j) || (a == j && b == i)
    })
}

fn rest_between<R: Real>(m: &Model<R>, s: &State<R>, i: u32, j: u32) -> f64 {
    match spring_between(m, i, j) {
        Some(sp) => m.spring_rest_length[sp as usize].to_f64(),
        None => (s.particle_q[j as usize] - s.particle_q[i as usize]).length().to_f64(),
    }
}

/// A fan of triangles around a vertex `v`: `(triangle, x, y)` for each triangle `(v, x, y)`.
pub type Fan = Vec<(u32, u32, u32)>;

/// The triangles around `v` grouped into fans, each as `(triangle, x, y)` with the triangle `(v, x, y)`,
/// ordered so that each one's `y` is the next one's `x`; with whether the fan closes on itself.
pub fn fans<R: Real>(m: &Model<R>, v: u32) -> Vec<(Fan, bool)> {
    let corners: Vec<(u32, u32, u32)> = m
        .particle_tris
        .row(v as usize)
        .iter()
        .map(|&t| {
            let tri = m.tri_indices[t as usize];
            let k = tri.iter().position(|&x| x == v).expect("row lists the triangle");
            (t, tri[(k + 1) % 3], tri[(k + 2) % 3])
        })
        .collect();
    let mut used = vec![false; corners.len()];
    let mut out = Vec::new();
    let next_of = |f: &(u32, u32, u32)| corners.iter().position(|g| g.1 == f.2);
    for start in 0..corners.len() {
        if used[start] {
            continue;
        }
        // Walk back to the start of an open fan (or once around a closed one).
        let mut first = start;
        let mut steps = 0;
        while let Some(p) = corners.iter().position(|g| g.2 == corners[first].1) {
            if p == start || used[p] || steps > corners.len() {
                break;
            }
            first = p;
            steps += 1;
        }
        let mut fan = Vec::new();
        let mut cur = first;
        let mut closed = false;
        loop {
            used[cur] = true;
            fan.push(corners[cur]);
            match next_of(&corners[cur]) {
                Some(nx) if nx == first => {
                    closed = true;
                    break;
                }
                Some(nx) if !used[nx] => cur = nx,
                _ => break,
            }
        }
        out.push((fan, closed));
    }
    out
}

/// The particle after `v` along the boundary (the edge `v -> w` of a triangle with no triangle on `w -> v`).
pub fn boundary_next<R: Real>(m: &Model<R>, v: u32) -> Option<u32> {
    let row = m.particle_tris.row(v as usize);
    let corner = |t: u32| {
        let tri = m.tri_indices[t as usize];
        let k = tri.iter().position(|&x| x == v).expect("row lists the triangle");
        (tri[(k + 1) % 3], tri[(k + 2) % 3])
    };
    row.iter().map(|&t| corner(t).0).find(|&x| !row.iter().any(|&t| corner(t).1 == x))
}

#[allow(clippy::too_many_arguments)]
fn add_particle<R: Real>(
    m: &mut Model<R>,
    s: &mut State<R>,
    x: R::V,
    v: R::V,
    mass: R,
    inv_mass: R,
    body: u32,
    like: usize,
) -> u32 {
    let load = m.particle_load_limit[like];
    m.particle_q0.push(x);
    m.particle_qd0.push(v);
    m.particle_mass.push(mass);
    m.particle_inv_mass.push(inv_mass);
    m.particle_body.push(body);
    m.particle_load_limit.push(load);
    m.particle_springs.push_row();
    m.particle_tris.push_row();
    s.particle_q.push(x);
    s.particle_qd.push(v);
    (m.particle_count() - 1) as u32
}

/// `m_i m_j / (m_i + m_j)` [kg].
fn reduced<R: Real>(a: R, b: R) -> R {
    a * b / (a + b)
}

/// Sets particle `i`'s mass, keeping the frequency and damping ratio of its springs: each one's `ks` and `kd`
/// scale with its reduced mass (see [`add_spring`]).
fn set_mass<R: Real>(m: &mut Model<R>, i: usize, mass: R) {
    let old = m.particle_mass[i];
    for k in 0..m.particle_springs.row(i).len() {
        let e = m.particle_springs.row(i)[k];
        let sp = (e >> 1) as usize;
        let w = m.spring_indices[sp][1 - (e & 1) as usize] as usize;
        let mw = m.particle_mass[w];
        let ratio = (reduced(mass, mw) / reduced(old, mw)).min(R::ONE);
        m.spring_stiffness[sp] *= ratio;
        m.spring_damping[sp] *= ratio;
    }
    m.particle_mass[i] = mass;
    if m.particle_inv_mass[i] != R::ZERO {
        m.particle_inv_mass[i] = R::ONE / mass;
    }
}

/// Adds a spring with the stiffness `ks` and damping `kd` of the spring it replaces, both scaled (down only) by
/// the ratio of its ends' reduced mass to `red`, the replaced spring's: every spring keeps its frequency
/// `sqrt(ks / m_red)` and damping ratio through a split. Splits share masses out, so without this a crack would
/// make ever lighter particles on equally stiff springs and raise the highest frequency of the model — and
/// with it the explicit integrators' stability limit `dt < 2 / ω` — at every split: a fracture storm would end
/// in a blow-up. The material around a crack is a little softer instead (a damaged zone), and a model stays
/// stable at the time step it started with.
fn add_spring<R: Real>(m: &mut Model<R>, i: u32, j: u32, rest: R, ks: R, (kd, red): (R, R), limit: R) -> u32 {
    let sp = m.spring_count() as u32;
    let red_new = reduced(m.particle_mass[i as usize], m.particle_mass[j as usize]);
    let ratio = (red_new / red).min(R::ONE);
    let (ks, kd) = (ks * ratio, kd * ratio);
    m.spring_indices.push([i, j]);
    m.spring_rest_length.push(rest);
    m.spring_stiffness.push(ks);
    m.spring_damping.push(kd);
    m.spring_kind.push(SpringKind::Edge);
    m.spring_strain_limit.push(limit);
    m.particle_springs.push(i as usize, sp << 1);
    m.particle_springs.push(j as usize, (sp << 1) | 1);
    // Spring runs are kept only while the model uses them (empty otherwise).
    if !m.spring_runs.is_empty() {
        match m.spring_runs.last_mut() {
            Some(r) if r.first + r.len == sp && r.i.wrapping_add(r.len) == i && r.j.wrapping_add(r.len) == j => {
                r.len += 1
            }
            _ => m.spring_runs.push(SpringRun { first: sp, i, j, len: 1 }),
        }
    }
    sp
}

/// Spring `sp` moved an end: its run (if runs are in use) splits around it. O(runs); the model falls back to
/// the gather kernel when runs get short.
fn split_run<R: Real>(m: &mut Model<R>, sp: u32) {
    if m.spring_runs.is_empty() {
        return;
    }
    let k = m.spring_runs.partition_point(|r| r.first + r.len <= sp);
    let r = m.spring_runs[k];
    let off = sp - r.first;
    let [i, j] = m.spring_indices[sp as usize];
    let mut parts = Vec::with_capacity(3);
    if off > 0 {
        parts.push(SpringRun { len: off, ..r });
    }
    parts.push(SpringRun { first: sp, i, j, len: 1 });
    if off + 1 < r.len {
        parts.push(SpringRun { first: sp + 1, i: r.i + off + 1, j: r.j + off + 1, len: r.len - off - 1 });
    }
    m.spring_runs.splice(k..k + 1, parts);
    if !m.springs_are_runs() {
        m.spring_runs.clear();
    }
}

fn break_spring<R: Real>(m: &mut Model<R>, sp: u32) {
    let s = sp as usize;
    if m.spring_kind[s] == SpringKind::Broken {
        return;
    }
    let [i, j] = m.spring_indices[s];
    m.particle_springs.remove(i as usize, sp << 1);
    m.particle_springs.remove(j as usize, (sp << 1) | 1);
    m.spring_kind[s] = SpringKind::Broken;
    m.spring_stiffness[s] = R::ZERO;
    m.spring_damping[s] = R::ZERO;
    m.spring_strain_limit[s] = R::infinity();
}

fn set_tri<R: Real>(m: &mut Model<R>, t: u32, new: [u32; 3]) {
    let old = m.tri_indices[t as usize];
    for v in old {
        if !new.contains(&v) {
            m.particle_tris.remove(v as usize, t);
        }
    }
    for v in new {
        if !old.contains(&v) {
            m.particle_tris.push(v as usize, t);
        }
    }
    m.tri_indices[t as usize] = new;
}

fn add_tri<R: Real>(m: &mut Model<R>, tri: [u32; 3], body: u32) -> u32 {
    let t = m.tri_count() as u32;
    m.tri_indices.push(tri);
    m.tri_body.push(body);
    for v in tri {
        m.particle_tris.push(v as usize, t);
    }
    t
}

/// A new open body (no gas) with `parent`'s other parameters.
fn new_body<R: Real>(m: &mut Model<R>, parent: u32, anchor: u32) -> u32 {
    let p = parent as usize;
    m.body_kind.push(BodyKind::Cloth);
    m.body_gas_amount.push(R::ZERO);
    m.body_pressure_external.push(m.body_pressure_external[p]);
    m.body_rest_volume.push(R::ZERO);
    m.body_drag.push(m.body_drag[p]);
    m.body_lift.push(m.body_lift[p]);
    m.body_anchor.push(anchor);
    m.body_sealed.push(m.body_sealed[p]);
    (m.body_count() - 1) as u32
}

/// Checks the invariants every split keeps; the first one broken, in words. Every index valid; every edge with
/// at most two triangles and a consistent winding (each directed edge used once); every triangle edge carried by
/// exactly one live spring and every live `Edge` spring between particles with triangles on a triangle edge;
/// triangles with three distinct corners and positive rest edges; a triangle's corners and a spring's ends in
/// its body; adjacency rows equal to the arrays; positive masses with matching inverse masses; openings walking
/// boundary edges. Cost: O(model), for tests and debugging.
pub fn check_invariants<R: Real>(m: &Model<R>) -> Result<(), String> {
    use std::collections::HashMap;
    let n = m.particle_count();
    let lens = [
        m.particle_q0.len(),
        m.particle_qd0.len(),
        m.particle_mass.len(),
        m.particle_inv_mass.len(),
        m.particle_body.len(),
        m.particle_load_limit.len(),
        m.particle_springs.rows(),
        m.particle_tris.rows(),
    ];
    if lens.iter().any(|&l| l != n) {
        return Err(format!("particle arrays disagree in length: {lens:?}"));
    }
    let ns = m.spring_count();
    let slens = [m.spring_rest_length.len(), m.spring_stiffness.len(), m.spring_damping.len(), m.spring_kind.len()];
    if slens.iter().any(|&l| l != ns) || m.spring_strain_limit.len() != ns {
        return Err(format!("spring arrays disagree in length: {ns} vs {slens:?}"));
    }
    if m.tri_body.len() != m.tri_count() {
        return Err("tri_body length".into());
    }
    let nb = m.body_count();
    for i in 0..n {
        let (mass, w) = (m.particle_mass[i], m.particle_inv_mass[i]);
        if mass.partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) || !(w == R::ZERO || w == R::ONE / mass) {
            return Err(format!("particle {i}: mass {:?}, inverse mass {:?}", mass.to_f64(), w.to_f64()));
        }
    }
    // Directed edges of triangles.
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in m.tri_indices.iter().enumerate() {
        if tri.iter().any(|&v| v as usize >= n) {
            return Err(format!("triangle {t} {tri:?}: index out of range"));
        }
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(format!("triangle {t} {tri:?}: repeated corner"));
        }
        let b = m.tri_body[t];
        if b as usize >= nb || tri.iter().any(|&v| m.particle_body[v as usize] != b) {
            return Err(format!("triangle {t} {tri:?}: corners not all in its body {b}"));
        }
        for k in 0..3 {
            let e = (tri[k], tri[(k + 1) % 3]);
            if let Some(other) = directed.insert(e, t as u32) {
                return Err(format!("edge {e:?} used in the same direction by triangles {other} and {t}"));
            }
        }
    }
    // Springs against edges.
    let mut pair_springs: HashMap<(u32, u32), u32> = HashMap::new();
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        if m.spring_kind[sp] == SpringKind::Broken {
            continue;
        }
        if i as usize >= n || j as usize >= n || i == j {
            return Err(format!("spring {sp} [{i}, {j}]: bad ends"));
        }
        if m.particle_body[i as usize] != m.particle_body[j as usize] {
            return Err(format!("spring {sp} [{i}, {j}] joins two bodies"));
        }
        if m.spring_rest_length[sp].partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) {
            return Err(format!("spring {sp}: rest length {:?}", m.spring_rest_length[sp].to_f64()));
        }
        let key = (i.min(j), i.max(j));
        *pair_springs.entry(key).or_insert(0) += 1;
        let has_tris = |v: u32| !m.particle_tris.row(v as usize).is_empty();
        let is_edge = directed.contains_key(&(i, j)) || directed.contains_key(&(j, i));
        if m.spring_kind[sp] == SpringKind::Edge && has_tris(i) && has_tris(j) && !is_edge {
            return Err(format!("edge spring {sp} [{i}, {j}] is on no triangle edge"));
        }
    }
    for &(a, b) in directed.keys() {
        let c = pair_springs.get(&(a.min(b), a.max(b))).copied().unwrap_or(0);
        if c != 1 {
            return Err(format!("triangle edge ({a}, {b}) carried by {c} live springs"));
        }
    }
    // Adjacency rows.
    let mut want_s: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        if m.spring_kind[sp] != SpringKind::Broken {
            want_s[i as usize].push((sp as u32) << 1);
            want_s[j as usize].push(((sp as u32) << 1) | 1);
        }
    }
    let mut want_t: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in m.tri_indices.iter().enumerate() {
        for &v in tri {
            want_t[v as usize].push(t as u32);
        }
    }
    for i in 0..n {
        let mut got = m.particle_springs.row(i).to_vec();
        got.sort_unstable();
        if got != want_s[i] {
            return Err(format!("particle {i}: spring row {got:?}, springs say {:?}", want_s[i]));
        }
        let mut got = m.particle_tris.row(i).to_vec();
        got.sort_unstable();
        if got != want_t[i] {
            return Err(format!("particle {i}: triangle row {got:?}, triangles say {:?}", want_t[i]));
        }
    }
    // Rest edges of triangles.
    for (t, tri) in m.tri_indices.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if let Some(sp) = spring_between(m, a, b)
                && m.spring_rest_length[sp as usize].partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater)
            {
                return Err(format!("triangle {t}: edge ({a}, {b}) has rest length 0"));
            }
        }
    }
    // Runs, when used, cover the springs in order.
    if !m.spring_runs.is_empty() {
        let mut next = 0u32;
        for r in &m.spring_runs {
            if r.first != next {
                return Err(format!("spring runs skip from {next} to {}", r.first));
            }
            for k in 0..r.len {
                if m.spring_indices[(r.first + k) as usize] != [r.i + k, r.j + k] {
                    return Err(format!("spring {} does not match its run", r.first + k));
                }
            }
            next += r.len;
        }
        if next as usize != ns {
            return Err(format!("spring runs cover {next} of {ns} springs"));
        }
    }
    for o in &m.openings {
        let k = o.vertices.len();
        for x in 0..k {
            let (a, b) = (o.vertices[x], o.vertices[(x + 1) % k]);
            if !directed.contains_key(&(a, b)) || directed.contains_key(&(b, a)) {
                return Err(format!("opening of body {}: ({a}, {b}) is not a boundary edge", o.body));
            }
        }
    }
    Ok(())
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
