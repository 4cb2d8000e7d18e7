//! The contact pass's sweep over its particles at every step (how far each moved this step and drifted since the
//! candidates were found), and the test it feeds: may the Verlet list be kept?

use super::Scatter;
use crate::model::Model;
use crate::real::{Real, Vector3};
use glam::DVec3;

/// Bodies past which [`still_valid`] is not worth its pairwise loop (the global drift test decides alone).
pub(super) const CLOSING_BODIES: usize = 64;

/// What one sweep over the particles in contact measured (see `CpuSolver::contact`).
pub(super) struct Moves {
    /// Largest squared move this step.
    pub d2: f64,
    /// Largest squared drift since the candidates were found.
    pub r2: f64,
    /// Each body's box of drifts, and its largest squared drift (empty: not measured).
    lo: Vec<DVec3>,
    hi: Vec<DVec3>,
    r2s: Vec<f64>,
}

impl Moves {
    pub fn new(bodies: usize) -> Self {
        let (lo, hi) = (vec![DVec3::INFINITY; bodies], vec![DVec3::NEG_INFINITY; bodies]);
        Moves { d2: 0.0, r2: 0.0, lo, hi, r2s: vec![0.0; bodies] }
    }

    #[cfg(feature = "parallel")]
    pub fn merge(mut self, o: Moves) -> Moves {
        self.d2 = self.d2.max(o.d2);
        self.r2 = self.r2.max(o.r2);
        for (a, b) in self.lo.iter_mut().zip(o.lo) {
            *a = a.min(b);
        }
        for (a, b) in self.hi.iter_mut().zip(o.hi) {
            *a = a.max(b);
        }
        for (a, b) in self.r2s.iter_mut().zip(o.r2s) {
            *a = a.max(b);
        }
        self
    }

    /// Folds a run of one body's drifts (its box and largest squared drift) into that body's.
    fn fold(&mut self, b: usize, lo: DVec3, hi: DVec3, r2: f64) {
        self.lo[b] = self.lo[b].min(lo);
        self.hi[b] = self.hi[b].max(hi);
        self.r2s[b] = self.r2s[b].max(r2);
    }
}

/// Measures the particles `ps` (each listed once across all calls): writes each one's squared move `|q - x0|²`
/// to `out` and (`fresh`: the candidates have reference positions `xb`) its drift `|x0 - xb|`, rounded up to
/// `f32`, to `drifts`; returns the largest squares of both and (`boxes` > 0: the model's body count) each body's
/// box of drifts and largest drift. A body's box is kept in registers along a run of its particles (they come in
/// runs: read and written through memory, each particle's box waited on the last one's store; the sweep 40.5 → 35
/// ms of the fracture scene's run, timers inside the pass, 2026-11-29). Maxima and boxes are the same in any
/// grouping, so the result is.
#[allow(clippy::too_many_arguments)]
pub(super) fn sweep<R: Real>(
    ps: &[u32],
    x0: &[R::V],
    q: &[R::V],
    xb: &[R::V],
    body: &[u32],
    fresh: bool,
    boxes: usize,
    out: Scatter<f64>,
    drifts: Scatter<f32>,
) -> Moves {
    let mut mv = Moves::new(boxes);
    let (mut d2_max, mut r2_max) = (0.0f64, 0.0f64);
    // The body of the current run, its box and largest squared drift.
    let (mut run, mut lo, mut hi, mut r2_run) = (usize::MAX, DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64);
    for &i in ps {
        let i = i as usize;
        let x = x0[i].to_dvec3();
        let d2 = (q[i].to_dvec3() - x).length_squared();
        // SAFETY: `out` and `drifts` have an entry per particle, and each particle is in one call's `ps` once, so
        // no two calls (in parallel chunks) write the same entry; nothing reads them meanwhile.
        unsafe { out.write(i, d2) };
        d2_max = d2_max.max(d2);
        if fresh {
            let drift = x - xb[i].to_dvec3();
            let r2 = drift.length_squared();
            r2_max = r2_max.max(r2);
            // SAFETY: as for `out`.
            unsafe { drifts.write(i, (r2 as f32).sqrt() * (1.0 + 4.0 * f32::EPSILON)) };
            if boxes > 0 {
                let b = body[i] as usize;
                if b != run {
                    if run != usize::MAX {
                        mv.fold(run, lo, hi, r2_run);
                    }
                    (run, lo, hi, r2_run) = (b, DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0);
                }
                (lo, hi, r2_run) = (lo.min(drift), hi.max(drift), r2_run.max(r2));
            }
        }
    }
    if run != usize::MAX {
        mv.fold(run, lo, hi, r2_run);
    }
    (mv.d2, mv.r2) = (d2_max, r2_max);
    mv
}

/// True if no pair missing from the list (built with `radius`, body boxes `gaps` apart) can have come within
/// `r`. Over the pairs of bodies in contact that interact, a missing pair was at least `max(radius, gap)` apart
/// and has closed in by at most the largest relative drift of a point of one body and a point of the other. Two
/// bounds on that, the lesser taken: the bodies' boxes of drifts (`mv`; any point of an element drifts within its
/// body's box): a piece riding on the ball it came from, a cloth falling as a whole, or a piece lying far from
/// every other body does not force a rebuild; and the sum of the two bodies' largest drifts, where the boxes are
/// wide: on the fracture scene the torn ball's light rim particles whirl at 3–10 m/s, which spreads its box of
/// drifts in every axis (up to √3 × the sum) while the pieces lie still (refreshes 281 → 211, 2026-11-29). False
/// when the boxes were not measured (more than [`CLOSING_BODIES`] bodies).
pub(super) fn still_valid<R: Real>(m: &Model<R>, mv: &Moves, gaps: &[f64], radius: f64, r: f64) -> bool {
    let nb = m.body_count();
    if mv.lo.len() != nb || gaps.len() != nb * nb {
        return false;
    }
    let seen = |b: usize| mv.lo[b].x <= mv.hi[b].x;
    // Each body's largest drift, once (not once per pair of bodies).
    let largest: Vec<f64> = mv.r2s.iter().map(|r2| r2.sqrt()).collect();
    (0..nb).all(|a| {
        (a..nb).all(|b| {
            if !(seen(a) && seen(b) && (a != b || m.body_self_contact[a])) {
                return true;
            }
            let boxed = (mv.hi[a] - mv.lo[b]).abs().max((mv.hi[b] - mv.lo[a]).abs()).length();
            let closing = boxed.min(largest[a] + largest[b]);
            radius.max(gaps[a * nb + b]) - closing >= r
        })
    })
}
