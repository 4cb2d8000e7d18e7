//! The contact pass (see the [`crate::contact`] module for the model): candidates from a hash grid kept as a
//! Verlet list (`lists.rs`), repulsion and friction impulses by projected Gauss–Seidel, then the displacement
//! bound.

mod lists;
mod moves;
mod sort;

use super::*;
use crate::contact::geometry::{Box32, closest_on_segments, closest_on_triangle, plane_apart, segments_apart};
use crate::contact::grid::HashGrid;
use crate::contact::{Elements, GAMMA, PUSH_TIME, RELAX, same_origin};
use glam::DVec3;
use moves::{CLOSING_BODIES, still_valid};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Gauss–Seidel sweeps over the pairs at most (each sweep stops early once the impulses settle). Layers of a
/// folded cloth converge slowly; whatever the sweeps leave, the displacement bound still rules out crossings.
const SWEEPS: usize = 8;
/// After the first sweep, a pair without impulse stays in the sweeps only if its slack (how much more its gap
/// could close this step before it needs one) is under this fraction of its thickness.
const HOT: f64 = 0.25;
/// The candidate search radius in units of the step's reach `r` (plus a thickness): the list stays valid while
/// no particle drifts `((SKIN - 1) r + h) / 2`. Measured (2026-11-23, `cargo bench --bench contact`): 1.5
/// against 2 rebuilds the folding 128² cloth's list 101 times in 600 substeps instead of 74, but its lists are a
/// third the size: contact 14.2–14.6 ms per step against 16.7–17.2; the fracture and balloons scenes within noise.
const SKIN: f64 = 1.5;
/// A kept list whose search radius exceeds this multiple of the one the step wants is built again. The search
/// radius follows the fastest particle of the step that built the list: on the folding 128² cloth (`cargo bench
/// --bench contact`, 2026-11-24) a list built while a corner whipped round at 16 m/s had a radius of 12.2 mm
/// and 855,074 candidates when the step wanted 6.9 mm; the cloth's own neighbours two rings away (7–10 mm at
/// rest) fill a list past ~7 mm. Contact per substep: never rebuilt for size 10.1–11.0 ms (69 refreshes in 600
/// substeps), 1.3× 7.2 ms (130,414 candidates), 1.15× 6.3 ms (27,268), 1.05× 6.8 ms (more builds).
const SHRINK: f64 = 1.15;
/// Elements per parallel task of the candidate search.
const TASK: usize = 512;

/// Appends to `out` what `f` makes of `items`, in order: in parallel chunks of [`TASK`] on rayon's pool when
/// there are at least `min` items, in pieces of [`TEAM_TASK`] on the team when this thread holds it (see
/// [`crate::team`]: its helpers spin while the contact pass runs; the pieces' outputs go through `bufs`, kept by
/// a caller that runs every step), else in one call on this thread straight into `out`. The same result each way:
/// `f` maps each item on its own, and the pieces' outputs are joined in order.
fn extend_chunks<T: Sync, U: Send>(
    out: &mut Vec<U>,
    bufs: &mut Vec<Vec<U>>,
    items: &[T],
    min: usize,
    f: impl Fn(&[T], &mut Vec<U>) + Sync,
) {
    #[cfg(feature = "parallel")]
    {
        if items.len() >= min && crate::par::rayon_free() {
            let parts: Vec<Vec<U>> = items
                .par_chunks(TASK)
                .map(|c| {
                    let mut v = Vec::new();
                    f(c, &mut v);
                    v
                })
                .collect();
            parts.into_iter().for_each(|p| out.extend(p));
            return;
        }
        if items.len() >= 2 * TEAM_TASK && crate::par::teamed() {
            let pieces = items.len().div_ceil(TEAM_TASK);
            if bufs.len() < pieces {
                bufs.resize_with(pieces, Vec::new);
            }
            let slots = crate::par::Pieces::new(&mut bufs[..pieces], 1);
            crate::par::exec(false, pieces, &|k| {
                // SAFETY: `exec` runs each piece index once.
                let buf = &mut unsafe { slots.get(k) }[0];
                buf.clear();
                f(&items[k * TEAM_TASK..((k + 1) * TEAM_TASK).min(items.len())], buf);
            });
            bufs[..pieces].iter_mut().for_each(|b| out.append(b));
            return;
        }
    }
    let _ = (min, bufs);
    f(items, out);
}

/// Items per piece of a contact search or pair evaluation on the team: a triangle's or an edge's search costs
/// ~0.3–1 µs, a pair's evaluation ~20 ns.
#[cfg(feature = "parallel")]
const TEAM_TASK: usize = 32;

/// Pair evaluations cost a box test and at most a closest-point computation: parallel from this many.
const PAR_NEAR: usize = 32 * TASK;

/// A pair within reach this step: four particles with weights (`Σ w x` is the vector between the closest
/// points, from the second element to the first), `Σ w² / m` (the inverse of its effective mass; 0: all pinned),
/// its normal, gap, thickness, friction, accumulated impulse.
#[derive(Clone, Copy, Debug)]
struct Pair {
    p: [u32; 4],
    w: [f64; 4],
    wsum: f64,
    n: DVec3,
    d: f64,
    h: f64,
    mu: f64,
    j: f64,
}

/// A candidate pair of the Verlet list: its two elements (a vertex and a triangle, or two edges), and its gap at
/// the reference positions `xb` when it was found, rounded down to `f32` (its elements' particles have not moved
/// their references since: a particle that does is hot, and every pair of its elements is found again).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    ids: [u32; 2],
    gap: f32,
}

impl Candidate {
    fn new(ids: [u32; 2], gap: f64) -> Self {
        Candidate { ids, gap: down32(gap) }
    }
}

/// The least `f32` at or above `x`.
fn up32(x: f64) -> f32 {
    match x as f32 {
        f if (f as f64) < x => f.next_up(),
        f => f,
    }
}

/// The greatest `f32` at or below `x`.
fn down32(x: f64) -> f32 {
    match x as f32 {
        f if (f as f64) > x => f.next_down(),
        f => f,
    }
}

/// What the contact pass did in the last step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Candidate pairs in the Verlet list (vertex–triangle + edge–edge).
    pub candidates: usize,
    /// Pairs within their reach this step (see `near`).
    pub near: usize,
    /// Pairs that took an impulse.
    pub pushed: usize,
    /// Particles whose move the displacement bound capped.
    pub capped: usize,
    /// Candidate lists built since the solver started.
    pub builds: u64,
    /// Candidate lists refreshed around the particles that drifted (instead of built) since the solver started.
    pub refreshes: u64,
    /// Steps the pass ran since the solver started.
    pub steps: u64,
    /// Sums over those steps of `near`, `pushed` and `capped`.
    pub near_total: u64,
    /// See `near_total`.
    pub pushed_total: u64,
    /// See `near_total`.
    pub capped_total: u64,
}

/// The contact pass's buffers, kept between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct ContactScratch<R: Real> {
    el: Option<Elements>,
    /// Positions at the start of the substep.
    pub x0: Vec<R::V>,
    /// Each contact particle's squared move this step \[m²\] (`|q - x0|²`; the others' entries are stale): a
    /// pair's reach is the thickness plus its particles' largest move over `GAMMA`. Squared: the square root is
    /// taken where a move is used (`sqrt` of the largest square is the largest root, to the bit: the root is
    /// monotonic and correctly rounded), for the particles of the pairs, not in the sweep over every particle.
    moved: Vec<f64>,
    /// Each contact particle's drift since its reference position `xb` \[m\], rounded up (see `near`): in
    /// `f32` from the squared drift (rounded twice, each time by at most half an ulp: `4 f32::EPSILON` of it more
    /// is above the drift; `f64`'s square root cost the sweep over the particles twice its time).
    drifts: Vec<f32>,
    /// Positions when the candidates were found, and their search radius (0: none yet).
    xb: Vec<R::V>,
    radius: f64,
    /// `gaps[a * nb + b]`: how far apart the boxes of bodies `a` and `b` were when the candidates were found
    /// (0 where they met; empty with more than [`CLOSING_BODIES`] bodies).
    gaps: Vec<f64>,
    /// The candidates: (vertex, triangle) pairs sorted by triangle then vertex, (edge, edge) pairs sorted.
    vt: Vec<Candidate>,
    ee: Vec<Candidate>,
    pairs: Vec<Pair>,
    /// The pieces of `pairs` when the team evaluates them (kept: the pass runs every step).
    pair_pieces: Vec<Vec<Pair>>,
    dv: Vec<DVec3>,
    bound: Vec<f64>,
    touched: Vec<u32>,
    hot: Vec<u32>,
    /// Vertices, edge midpoints and triangle centroids (refreshes only), each of the bodies but the largest,
    /// then of the largest (see `lists`).
    /// Their payloads: a vertex's position, an edge's box, a triangle's box grown by the search radius, each as
    /// a [`Box32`] (a search's first test).
    grid: [HashGrid<Box32>; 2],
    egrid: [HashGrid<Box32>; 2],
    tgrid: [HashGrid<Box32>; 2],
    /// Each particle's first test in a list op (see `lists`; kept: the ops run often).
    near_parts: Vec<bool>,
    /// The elements each grid of a list op may keep (see `lists`; kept: the ops run often): vertices, edges and
    /// triangle centroids, each of the bodies but the largest, then of the largest.
    grid_cands: [Vec<u32>; 6],
    /// The searched triangles' centroids and search boxes (refreshes only; `None`: not searched).
    centroids: Vec<Option<(DVec3, Box32)>>,
    /// Each edge's box at `x0` when the candidates were found (the searcher's own box, and the source of the edge
    /// grid's payloads).
    eboxes: Vec<[DVec3; 2]>,
    pub stats: ContactStats,
    /// Rebuild the candidate lists at every step (a check of the Verlet list: see
    /// `CpuSolver::rebuild_contact_lists_every_step`).
    rebuild_always: bool,
    /// After every refresh, search every element again and panic on a pair the refreshed lists miss (a check of
    /// the refreshes: see `CpuSolver::check_contact_refreshes`).
    check_refreshes: bool,
    /// Refuses explicit steps above the stability bound (kept through fractures: see its docs).
    guard: crate::stability::ContactStepGuard,
    /// Pieces born crossing their family, left out of contact with it until they part (see `family`).
    excused: crate::contact::family::Excused,
}

impl<R: Real> ContactScratch<R> {
    /// Forgets everything derived from the model (after a fracture or an edit).
    pub fn invalidate(&mut self) {
        self.el = None;
        self.radius = 0.0;
    }

    /// After a fracture: forgets what the model's change made stale, and notes the pieces it created.
    pub fn changed(&mut self, delta: &crate::fracture::TopologyDelta) {
        self.invalidate();
        self.excused.born(delta);
    }

    /// The candidates closer than their reach at `x0`, as pairs with weights and normals. A pair's reach is
    /// `h + d_P / GAMMA`, `h` the largest thickness and `d_P` the largest move this step of its four particles:
    /// a pair farther apart is not closed in by its particles' moves (each at most `GAMMA (reach - h)`) nor by
    /// the bound's start (`GAMMA h + d_i`, see `CpuSolver::contact`), by more than `2 GAMMA` of its gap.
    ///
    /// Candidates that cannot be within reach are dropped before their positions are read. A candidate's gap has
    /// closed since it was found by at most its elements' drifts since the references (the larger of each
    /// element's particles'). So a candidate whose gap then is at least `far`, the step's largest reach `r_all`
    /// plus twice the largest drift (see `CpuSolver::contact`), is dropped on the list's entry alone; one whose gap
    /// less its elements' drifts is at least `r_all`, on the particles' drifts. On the folding 128² cloth most
    /// candidates are the cloth's own neighbours two rings away, which the list keeps and which do not come
    /// within reach: `cargo bench --bench contact`, one thread, the Zen 3 development VM, 2026-11-28, timers
    /// inside the pass (not kept): `near` 2.30–2.52 → 0.97–1.02 ms a substep, the sweep over the particles that
    /// measures the drifts 135 → 156 µs.
    fn near(&mut self, m: &Model<R>, h_max: f64, r_all: f64, far: f64) {
        // `far` and `r_all` rounded up to `f32`: a gap (rounded down) at or above one is at or above the `f64`.
        let (far, r_all64, r_all) = (up32(far), r_all, up32(r_all));
        let el = self.el.as_ref().expect("elements prepared");
        let (x0, moved, drifts) = (&self.x0, &self.moved, &self.drifts);
        let drift = |i: u32| drifts[i as usize] as f64;
        let x = |i: u32| x0[i as usize].to_dvec3();
        let reach = |p: [u32; 4]| h_max + p.iter().fold(0.0f64, |a, &i| a.max(moved[i as usize])).sqrt() / GAMMA;
        let pair = |p: [u32; 4], w: [f64; 4], fallback: DVec3, b: [u32; 2], r: f64| {
            let diff: DVec3 = (0..4).map(|k| w[k] * x(p[k])).sum();
            let d = diff.length();
            if d >= r {
                return None;
            }
            let n = if d > 1e-12 { diff / d } else { fallback.normalize_or(DVec3::Y) };
            let [ba, bb] = b.map(|b| b as usize);
            let h = m.body_contact_thickness[ba].to_f64().max(m.body_contact_thickness[bb].to_f64());
            let mu = 0.5 * (m.body_contact_friction[ba].to_f64() + m.body_contact_friction[bb].to_f64());
            let wsum = (0..4).map(|k| w[k] * w[k] * m.particle_inv_mass[p[k] as usize].to_f64()).sum();
            Some(Pair { p, w, wsum, n, d, h, mu, j: 0.0 })
        };
        let edges = &el.edges;
        // Boxes first: most candidates are not within `r` this step, and a box test is cheaper than closest points.
        let apart = |lo: DVec3, hi: DVec3, lo2: DVec3, hi2: DVec3, r: f64| (lo2 - hi).max(lo - hi2).max_element() >= r;
        let vt_pair = |&Candidate { ids: [v, t], gap }: &Candidate| {
            let tv = m.tri_indices[t as usize];
            if gap >= r_all && gap as f64 - (drift(v) + tv.iter().fold(0.0f64, |a, &i| a.max(drift(i)))) >= r_all64 {
                return None;
            }
            let r = reach([v, tv[0], tv[1], tv[2]]);
            let [a, b, cc] = tv.map(x);
            let (p, n) = (x(v), (b - a).cross(cc - a));
            if apart(p, p, a.min(b).min(cc), a.max(b).max(cc), r) || plane_apart(p, a, n, r) {
                return None;
            }
            let w = closest_on_triangle(p, a, b, cc);
            let b2 = [m.particle_body[v as usize], m.tri_body[t as usize]];
            pair([v, tv[0], tv[1], tv[2]], [1.0, -w[0], -w[1], -w[2]], n, b2, r)
        };
        let ee_pair = |&Candidate { ids: [e, f], gap }: &Candidate| {
            let ([a0, a1], [b0, b1]) = (edges[e as usize], edges[f as usize]);
            if gap >= r_all && gap as f64 - (drift(a0).max(drift(a1)) + drift(b0).max(drift(b1))) >= r_all64 {
                return None;
            }
            let r = reach([a0, a1, b0, b1]);
            let (p, q, u, w) = (x(a0), x(a1), x(b0), x(b1));
            if apart(p.min(q), p.max(q), u.min(w), u.max(w), r)
                || segments_apart(0.5 * (p + q), 0.5 * (q - p), 0.5 * (u + w), 0.5 * (w - u), r)
            {
                return None;
            }
            let (s, t) = closest_on_segments(p, q, u, w);
            let b2 = [m.particle_body[a0 as usize], m.particle_body[b0 as usize]];
            pair([a0, a1, b0, b1], [1.0 - s, s, t - 1.0, -t], (q - p).cross(w - u), b2, r)
        };
        // Vertex–triangle pairs, then edge–edge pairs, each in their list's order.
        self.pairs.clear();
        let bufs = &mut self.pair_pieces;
        // The entry's test in the loop over the list, the rest in `vt_pair` and `ee_pair`: those are compiled as
        // functions, and with the test inside them every candidate cost a call (on the folding 128² cloth ~80,000 a
        // substep, two thirds failing the entry's test; `near` 1.56–1.91 → 1.33–1.69 ms a substep, timers not
        // kept, two alternated runs of `cargo bench --bench contact` on one thread, a Zen 4 host, 2026-12-08).
        let entry = |c: &&Candidate| c.gap < far;
        extend_chunks(&mut self.pairs, bufs, &self.vt, PAR_NEAR, |c, o| {
            o.extend(c.iter().filter(entry).filter_map(vt_pair))
        });
        extend_chunks(&mut self.pairs, bufs, &self.ee, PAR_NEAR, |c, o| {
            o.extend(c.iter().filter(entry).filter_map(ee_pair))
        });
    }
}

/// Writes to a slice's entries from several threads, each entry from at most one (see its use).
#[derive(Clone, Copy)]
struct Scatter<T>(*mut T);

// SAFETY: `Scatter` is used only where each entry is written by one thread and not read during the writes.
unsafe impl<T> Send for Scatter<T> {}
unsafe impl<T> Sync for Scatter<T> {}

impl<T> Scatter<T> {
    /// # Safety
    /// `i` is in bounds and no other thread reads or writes entry `i` during the call.
    unsafe fn write(self, i: usize, v: T) {
        // SAFETY: as the caller promises.
        unsafe { *self.0.add(i) = v };
    }
}

impl<R: Real> CpuSolver<R> {
    /// Refuses an explicit step above the stability bound of a model in contact when no substep guard would split
    /// it (see [`crate::stability::ContactStepGuard`]); the bound is estimated at `s`'s positions.
    pub(super) fn check_contact_step(&mut self, m: &Model<R>, s: &State<R>, dt: f64) -> Result<(), StepError> {
        if self.config.substep_safety.is_some() {
            return Ok(());
        }
        let mut guard = self.ct.guard;
        let checked = guard.check(m, self.config.integrator, dt, || self.bound_at(m, &s.particle_q));
        self.ct.guard = guard;
        checked
    }

    /// Keeps surfaces in contact apart (see the [`crate::contact`] module): from the positions `ct.x0` at the
    /// start of the substep to those in `s`, over `dt` \[s\].
    pub(super) fn contact(&mut self, m: &Model<R>, s: &mut State<R>, dt: f64, blown: &AtomicBool) {
        if !m.has_contact() {
            return;
        }
        let t0 = Instant::now();
        let c = &mut self.ct;
        if c.el.is_none() {
            c.el = Some(Elements::of(m));
            c.radius = 0.0;
        }
        // Pieces born crossing their family are left out of contact with it until they part; a pair that parted
        // is missing from the lists, which are then built again.
        if c.excused.update(m, &c.x0) {
            c.radius = 0.0;
        }
        let el = c.el.as_ref().expect("just set");
        let h_max = el.h_max;
        // The largest move this step, and the largest drift since the candidates were found.
        let (x0, xb, q) = (&c.x0, &c.xb, &s.particle_q);
        let fresh = c.radius > 0.0 && xb.len() == x0.len();
        // One sweep: the largest move this step, the largest drift since the candidates were found, and each
        // body's box of drifts (with few bodies).
        let boxes = if fresh && m.body_count() <= CLOSING_BODIES { m.body_count() } else { 0 };
        c.moved.resize(m.particle_count(), 0.0);
        c.drifts.resize(m.particle_count(), 0.0);
        let (out, drifts) = (Scatter(c.moved.as_mut_ptr()), Scatter(c.drifts.as_mut_ptr()));
        let reads = moves::Reads { x0, q, xb, body: &m.particle_body, fresh, boxes };
        let moves = |ps: &[u32]| moves::sweep::<R>(ps, reads, (out, drifts));
        // (Maxima and boxes: the same in any grouping.)
        #[cfg(feature = "parallel")]
        let mv = if !(crate::par::pooled(el.particles.len()) && crate::par::rayon_free()) {
            moves(&el.particles)
        } else {
            el.particles.par_chunks(TASK).map(moves).reduce(|| moves::Moves::new(boxes), moves::Moves::merge)
        };
        #[cfg(not(feature = "parallel"))]
        let mv = moves(&el.particles);
        let (d_max, drift) = (mv.d2.sqrt(), mv.r2.sqrt());
        if !(d_max.is_finite() && drift.is_finite()) {
            blown.store(true, Ordering::Relaxed);
            return;
        }
        // The step's largest reach: no pair farther apart is within its own reach (see `near`).
        let r = h_max + d_max / GAMMA;
        // Pairs missing from the list were `radius` apart when it was built and have closed in by at most
        // 2 drift since; when that is not enough, by at most what their bodies moved relative to each other
        // (a piece riding on the ball it came from, a cloth falling as a whole, does not force a rebuild).
        // A list built at a passing peak of speed (a corner whipping round) is kept no longer than it is needed:
        // past SHRINK times the radius this step wants, it is built again at that radius.
        let oversize = c.radius > SHRINK * (SKIN * r + h_max);
        let valid = !c.rebuild_always
            && fresh
            && !oversize
            && (c.radius - 2.0 * drift >= r || still_valid(m, &mv, &c.gaps, c.radius, r));
        // Slack `(radius - r) / 4`: after a refresh no particle has drifted more, and the list stays valid until
        // one drifts `(radius - r) / 2`. Measured on the folding 128² cloth (`cargo bench --bench contact`,
        // 2026-11-23): slack 0.25 × → contact 10.0–10.9 ms per step (96 refreshes, no build, in 600 substeps);
        // 0.15 × → 10.5–12.3 ms; 0.4 × → 14.6–15.4 ms (259 refreshes); builds alone 11.9–12.7 ms.
        let slack = 0.25 * (c.radius - r);
        let refreshed = !valid && !oversize && fresh && !c.rebuild_always && c.radius > r && c.refresh(m, slack);
        // The largest drift since the references now: a refresh moved those of the particles that drifted more
        // than `slack`, a build all of them.
        let drift = if valid {
            drift
        } else if refreshed {
            drift.min(slack)
        } else {
            c.build(m, SKIN * r + h_max);
            0.0
        };
        // A candidate's gap has closed by at most twice the largest drift since it was found (its elements' points
        // each drift within it); the `1e-9` covers the rounding of the gaps (`f64`, then down to `f32`), so every
        // candidate the test skips is one the exact tests would drop: the pairs and their order are unchanged.
        c.near(m, h_max, r * (1.0 + 1e-9), (r + 2.0 * drift) * (1.0 + 1e-9));
        let n = m.particle_count();
        if c.dv.len() != n {
            c.dv = vec![DVec3::ZERO; n];
            c.bound = vec![f64::INFINITY; n];
        }
        let ContactScratch { pairs, dv, bound, touched, x0, hot, moved, .. } = c;
        touched.clear();
        // Each particle's bound starts at `GAMMA h + d_i`: every pair it is in but not within reach is at least
        // `h + d_i / GAMMA` apart (its reach), so the cap keeps the particle within `GAMMA` of that pair's gap.
        for p in pairs.iter() {
            for &i in &p.p {
                if bound[i as usize] == f64::INFINITY {
                    touched.push(i);
                    bound[i as usize] = GAMMA * h_max + moved[i as usize].sqrt();
                }
                bound[i as usize] = bound[i as usize].min(GAMMA * p.d);
            }
        }
        // Projected Gauss–Seidel on the normal impulses, in the pairs' order.
        let inv_m = |i: u32| m.particle_inv_mass[i as usize].to_f64();
        let qd = &s.particle_qd;
        let vel = |dv: &[DVec3], i: u32| qd[i as usize].to_dvec3() + dv[i as usize];
        let mut pushed = 0;
        // A pair inside its thickness is eased out at RELAX of its overlap per step, or per PUSH_TIME when the step
        // is shorter (the push-out's speed does not grow as the step shrinks).
        let ease = dt.max(PUSH_TIME);
        // The first sweep visits every pair; later sweeps only those that took an impulse or came within HOT
        // thicknesses of needing one (the others are far from binding; the displacement bound covers them anyway).
        hot.clear();
        hot.extend(0..pairs.len() as u32);
        for sweep in 0..SWEEPS {
            let mut change = 0.0f64;
            let mut keep = 0;
            for k in 0..hot.len() {
                let p = &mut pairs[hot[k] as usize];
                let wsum = p.wsum;
                if wsum <= 0.0 {
                    continue;
                }
                let un: f64 = (0..4).map(|k| p.w[k] * vel(dv, p.p[k]).dot(p.n)).sum();
                let target = if p.d >= p.h { (p.h - p.d) / dt } else { RELAX * (p.h - p.d) / ease };
                let j = (p.j + (target - un) / wsum).max(0.0);
                let dj = j - p.j;
                if sweep > 0 || j > 0.0 || (un - target) * dt < HOT * p.h {
                    hot[keep] = hot[k];
                    keep += 1;
                }
                if dj != 0.0 {
                    p.j = j;
                    for k in 0..4 {
                        dv[p.p[k] as usize] += (p.w[k] * inv_m(p.p[k]) * dj) * p.n;
                    }
                    change = change.max((dj * wsum).abs());
                }
            }
            hot.truncate(keep);
            // Converged to 1e-4 of the velocity that closes a thickness in a step, or in PUSH_TIME (momentum is
            // exact anyway: every impulse is equal and opposite).
            if change <= 1e-4 * (h_max / ease) {
                break;
            }
        }
        // Coulomb friction, up to mu times each pair's normal impulse.
        for p in pairs.iter() {
            if p.j <= 0.0 {
                continue;
            }
            pushed += 1;
            let wsum = p.wsum;
            let u: DVec3 = (0..4).map(|k| p.w[k] * vel(dv, p.p[k])).sum();
            let ut = u - u.dot(p.n) * p.n;
            let speed = ut.length();
            if speed > 0.0 && wsum > 0.0 {
                let jt = (speed / wsum).min(p.mu * p.j);
                let dir = ut / speed;
                for k in 0..4 {
                    dv[p.p[k] as usize] -= (p.w[k] * inv_m(p.p[k]) * jt) * dir;
                }
            }
        }
        // Apply, then cap each move at its bound.
        let mut capped = 0;
        let (prepared, every) = (&self.colliders[..], &self.collider_ids[..]);
        let has_colliders = m.has_colliders() && !prepared.is_empty();
        for &i in touched.iter() {
            let i = i as usize;
            let d = std::mem::take(&mut dv[i]);
            let b = std::mem::replace(&mut bound[i], f64::INFINITY);
            if m.particle_inv_mass[i] == R::ZERO {
                continue;
            }
            let (x0i, mut x, mut v) = (x0[i].to_dvec3(), s.particle_q[i].to_dvec3(), s.particle_qd[i].to_dvec3());
            x += dt * d;
            v += d;
            let step = x - x0i;
            let len = step.length();
            if len > b {
                let k = b / len;
                x = x0i + k * step;
                v *= k;
                capped += 1;
            }
            // The colliders again (their pass ran before this one), within the same bound: a push out of the
            // ground that would carry the particle farther than `b` could cross another surface, and crossing is
            // what the bound rules out, so there the particle keeps the contact's position.
            if has_colliders
                && let Some((xc, vc)) = collide::resolve_all(prepared, &m.colliders, every, x.as_vec3(), v.as_vec3())
                && (xc.as_dvec3() - x0i).length() <= b
            {
                x = xc.as_dvec3();
                v = vc.as_dvec3();
            }
            s.particle_q[i] = R::V::from_dvec3(x);
            s.particle_qd[i] = R::V::from_dvec3(v);
        }
        let c = &mut self.ct;
        c.stats.candidates = c.vt.len() + c.ee.len();
        c.stats.near = c.pairs.len();
        c.stats.pushed = pushed;
        c.stats.capped = capped;
        c.stats.steps += 1;
        c.stats.near_total += c.pairs.len() as u64;
        c.stats.pushed_total += pushed as u64;
        c.stats.capped_total += capped as u64;
        self.timers.add(Stage::Contact, t0);
    }

    /// What the contact pass did in the last step.
    pub fn contact_stats(&self) -> ContactStats {
        self.ct.stats
    }

    /// The contact pairs within reach in the last step, in the pass's order: each pair's four particles (a vertex
    /// then its triangle's corners, or one edge's ends then the other's) and its gap at the start of the step
    /// \[m\]. For comparisons with the GPU pass (`fissure_gpu::GpuSolver::contact_pairs`).
    pub fn contact_pairs(&self) -> Vec<([u32; 4], f64)> {
        self.ct.pairs.iter().map(|p| (p.p, p.d)).collect()
    }

    /// Rebuilds the contact candidate lists at every step instead of keeping them while they are valid. The
    /// result is the same to the bit (the pairs within reach are listed in index order whenever the list was
    /// built, so a valid list and a fresh one give the same pairs in the same order); only the cost differs. For
    /// tests of that claim.
    #[doc(hidden)]
    pub fn rebuild_contact_lists_every_step(&mut self, on: bool) {
        self.ct.rebuild_always = on;
    }

    /// After every refresh of the contact candidate lists, searches every element again at the same reference
    /// positions and panics if the refreshed lists miss a pair that search finds (a refreshed list may hold
    /// more: pairs that drifted apart). For tests of the refreshes; slow.
    #[doc(hidden)]
    pub fn check_contact_refreshes(&mut self, on: bool) {
        self.ct.check_refreshes = on;
    }
}
