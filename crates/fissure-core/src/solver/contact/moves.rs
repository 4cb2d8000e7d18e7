//! The contact pass's sweep over its particles at every step (how far each moved this step and drifted since the
//! candidates were found), and the test it feeds: may the Verlet list be kept?

use super::Scatter;
use crate::model::Model;
#[cfg(target_arch = "x86_64")]
use crate::real::v_as_f32;
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

/// The sweep's running maxima and the body run it is in: the body, its box and largest squared drift.
struct Acc {
    mv: Moves,
    d2_max: f64,
    r2_max: f64,
    run: usize,
    lo: DVec3,
    hi: DVec3,
    r2_run: f64,
}

impl Acc {
    fn new(boxes: usize) -> Self {
        let mv = Moves::new(boxes);
        let (lo, hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        Acc { mv, d2_max: 0.0, r2_max: 0.0, run: usize::MAX, lo, hi, r2_run: 0.0 }
    }

    /// Whether the bodies' boxes are measured.
    #[inline(always)]
    fn boxes(&self) -> bool {
        !self.mv.r2s.is_empty()
    }

    /// Makes body `b` the run's: a run of another body ends (folded into its body's) and an empty one starts.
    #[inline(always)]
    fn enter(&mut self, b: usize) {
        if b != self.run {
            if self.run != usize::MAX {
                self.mv.fold(self.run, self.lo, self.hi, self.r2_run);
            }
            (self.run, self.lo, self.hi, self.r2_run) = (b, DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0);
        }
    }

    /// Particle `i`, at `x` (start of the step), `q` (now) and `xb` (its reference; `None` unless fresh).
    ///
    /// # Safety
    /// `out` and `drifts` have an entry `i`, which no other thread reads or writes during the sweep.
    #[inline(always)]
    unsafe fn one(&mut self, i: usize, x: DVec3, q: DVec3, xb: Option<DVec3>, body: &[u32], sc: Sc) {
        let d2 = (q - x).length_squared();
        // SAFETY: the caller's.
        unsafe { sc.0.write(i, d2) };
        self.d2_max = self.d2_max.max(d2);
        if let Some(xb) = xb {
            let drift = x - xb;
            let r2 = drift.length_squared();
            self.r2_max = self.r2_max.max(r2);
            // SAFETY: the caller's.
            unsafe { sc.1.write(i, (r2 as f32).sqrt() * DRIFT_UP) };
            if self.boxes() {
                self.enter(body[i] as usize);
                (self.lo, self.hi, self.r2_run) = (self.lo.min(drift), self.hi.max(drift), self.r2_run.max(r2));
            }
        }
    }

    fn finish(mut self) -> Moves {
        if self.run != usize::MAX {
            self.mv.fold(self.run, self.lo, self.hi, self.r2_run);
        }
        (self.mv.d2, self.mv.r2) = (self.d2_max, self.r2_max);
        self.mv
    }
}

/// A drift's square root in `f32` times this is above the drift (see `ContactScratch::drifts`).
const DRIFT_UP: f32 = 1.0 + 4.0 * f32::EPSILON;

/// Where the sweep writes each particle's squared move and drift.
pub(super) type Sc = (Scatter<f64>, Scatter<f32>);

/// What a sweep reads: the particles' positions at the start of the step (`x0`), now (`q`) and at their
/// references (`xb`, read when `fresh`: the candidates have references), their bodies, and the model's body count
/// where each body's box of drifts is kept (else 0).
#[derive(Clone, Copy)]
pub(super) struct Reads<'a, V> {
    pub x0: &'a [V],
    pub q: &'a [V],
    pub xb: &'a [V],
    pub body: &'a [u32],
    pub fresh: bool,
    pub boxes: usize,
}

impl<'a, V> Reads<'a, V> {
    /// The same reads with the positions as other arrays.
    #[cfg(target_arch = "x86_64")]
    fn with<W>(self, x0: &'a [W], q: &'a [W], xb: &'a [W]) -> Reads<'a, W> {
        Reads { x0, q, xb, body: self.body, fresh: self.fresh, boxes: self.boxes }
    }
}

/// Measures the particles `ps` (each listed once across all calls): writes each one's squared move `|q - x0|²`
/// to `sc.0` and (`fresh`) its drift `|x0 - xb|`, rounded up to `f32`, to `sc.1`; returns the largest squares of
/// both and (`boxes` > 0) each body's box of drifts and largest drift. A body's box is kept in registers along a run of its particles (they come in
/// runs: read and written through memory, each particle's box waited on the last one's store; the sweep 40.5 → 35
/// ms of the fracture scene's run, timers inside the pass, 2026-11-29). Maxima and boxes are the same in any
/// grouping, so the result is. In `f32` on AVX2, eight particles at a time ([`sweep_avx2`]).
pub(super) fn sweep<R: Real>(ps: &[u32], r: Reads<R::V>, sc: Sc) -> Moves {
    #[cfg(target_arch = "x86_64")]
    if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx2() {
        let r = r.with(v_as_f32::<R>(r.x0), v_as_f32::<R>(r.q), v_as_f32::<R>(r.xb));
        // SAFETY: AVX2 checked just above; the writes are as the caller promises (see `Acc::one`).
        return unsafe { sweep_avx2(ps, r, sc) };
    }
    sweep_scalar::<R>(ps, r, sc)
}

/// [`sweep`] one particle at a time.
fn sweep_scalar<R: Real>(ps: &[u32], r: Reads<R::V>, sc: Sc) -> Moves {
    let mut acc = Acc::new(r.boxes);
    for &i in ps {
        let i = i as usize;
        let xb = r.fresh.then(|| r.xb[i].to_dvec3());
        // SAFETY: the entries `i` of `sc` exist, and each particle is in one call's `ps` once, so no two calls (in
        // parallel chunks) write the same entry; nothing reads them meanwhile.
        unsafe { acc.one(i, r.x0[i].to_dvec3(), r.q[i].to_dvec3(), xb, r.body, sc) };
    }
    acc.finish()
}

/// [`sweep`] in `f32` on AVX2: eight particles at a time where they are of one body (with `boxes`) and are not the
/// last particle (their loads read one value past each vector): each array's eight 3-vectors split into
/// components by [`crate::forces::cross_avx2::soa8`], widened to `f64`, and the moves and drifts formed with the
/// scalar's operations in its order (the same bits: packed subtractions, products, sums and square roots round as
/// the scalar ones; the maxima take the scalar's operand that is not NaN); stored as two vectors where the eight
/// particles are consecutive, else lane by lane. The other particles go one at a time as in [`sweep`]. The
/// fracture scene's run (`fissure run scenes/fracture.toml`, 7,500 steps of ~850 particles): the contact pass up to
/// the end of the sweep 43.3–47.6 → 24.8–24.9 ms (timers, not kept, three alternated runs, the Zen 4 development
/// VM, 2026-11-29), ~5 → ~2.8 ns a particle.
///
/// # Safety
/// AVX2; `x0`, `q`, `xb` (when `fresh`) hold three values per particle of `ps`, and the writes are as in `Acc::one`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sweep_avx2(ps: &[u32], r: Reads<f32>, sc: Sc) -> Moves {
    let Reads { x0, q, xb, body, fresh, boxes } = r;
    use crate::forces::cross_avx2::soa8;
    use std::arch::x86_64::*;
    // (Macros and plain loops, not closures or `map`: those are compiled without this function's AVX2, and their
    // intrinsics become calls.)
    macro_rules! lanes {
        ($x:expr) => {{
            let mut a = [0.0f64; 4];
            // SAFETY: four values.
            unsafe { _mm256_storeu_pd(a.as_mut_ptr(), $x) };
            a
        }};
    }
    // `|x|²` of three component vectors, in the scalar's order.
    macro_rules! sq {
        ($x:expr, $y:expr, $z:expr) => {
            _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd($x, $x), _mm256_mul_pd($y, $y)), _mm256_mul_pd($z, $z))
        };
    }
    // Half `h` of eight `f32` lanes, widened.
    macro_rules! wide {
        ($x:expr, $h:expr) => {
            _mm256_cvtps_pd(if $h == 0 { _mm256_castps256_ps128($x) } else { _mm256_extractf128_ps::<1>($x) })
        };
    }
    let n = x0.len() / 3;
    let v = |a: &[f32], i: usize| DVec3::new(a[3 * i] as f64, a[3 * i + 1] as f64, a[3 * i + 2] as f64);
    let mut acc = Acc::new(boxes);
    // The block maxima, and the run's box and largest drift, lane by lane (folded into `acc` where a particle
    // goes alone, a run ends, or the sweep does).
    let (inf, ninf) = (_mm256_set1_pd(f64::INFINITY), _mm256_set1_pd(f64::NEG_INFINITY));
    let (mut vd2, mut vr2) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let (mut lx, mut ly, mut lz, mut hx, mut hy, mut hz) = (inf, inf, inf, ninf, ninf, ninf);
    let mut vrun = _mm256_setzero_pd();
    // Whether those lanes hold drifts not yet folded (a lone particle or a new run folds them only then).
    let mut pending = false;
    macro_rules! fold {
        () => {{
            let (a, b, c, d, e, f, r) =
                (lanes!(lx), lanes!(ly), lanes!(lz), lanes!(hx), lanes!(hy), lanes!(hz), lanes!(vrun));
            for l in 0..4 {
                let (lo, hi) = (DVec3::new(a[l], b[l], c[l]), DVec3::new(d[l], e[l], f[l]));
                (acc.lo, acc.hi, acc.r2_run) = (acc.lo.min(lo), acc.hi.max(hi), acc.r2_run.max(r[l]));
            }
        }};
    }
    macro_rules! flush {
        () => {{
            if pending {
                fold!();
                (lx, ly, lz, hx, hy, hz, vrun) = (inf, inf, inf, ninf, ninf, ninf, _mm256_setzero_pd());
                pending = false;
            }
        }};
    }
    let up = _mm_set1_ps(DRIFT_UP);
    let with_boxes = fresh && boxes > 0;
    let mut k = 0;
    while k < ps.len() {
        // Eight particles below the last, of one body where boxes are kept.
        let mut simd = k + 8 <= ps.len() && (ps[k + 7] as usize) + 1 < n;
        if simd && with_boxes {
            let b0 = body[ps[k] as usize];
            simd = ps[k + 1..k + 8].iter().all(|&i| body[i as usize] == b0);
        }
        if !simd {
            flush!();
            let i = ps[k] as usize;
            // SAFETY: the caller's.
            unsafe { acc.one(i, v(x0, i), v(q, i), fresh.then(|| v(xb, i)), body, sc) };
            k += 1;
            continue;
        }
        let idx = &ps[k..k + 8];
        if with_boxes {
            let b = body[idx[0] as usize] as usize;
            if b != acc.run {
                flush!();
                acc.enter(b);
            }
        }
        let mut off = [0usize; 8];
        for l in 0..8 {
            off[l] = 3 * idx[l] as usize;
        }
        let consecutive = idx[7] == idx[0] + 7;
        // SAFETY: every lane's particle is below the last, so its four values from `3 i` are in the arrays (`xb`
        // holds every particle when fresh).
        let (xs, qs) = unsafe { (soa8(x0.as_ptr(), off), soa8(q.as_ptr(), off)) };
        let bs = if fresh { unsafe { soa8(xb.as_ptr(), off) } } else { xs };
        for h in 0..2 {
            let (x, y, z) = (wide!(xs.0, h), wide!(xs.1, h), wide!(xs.2, h));
            let (dx, dy, dz) =
                (_mm256_sub_pd(wide!(qs.0, h), x), _mm256_sub_pd(wide!(qs.1, h), y), _mm256_sub_pd(wide!(qs.2, h), z));
            let d2 = sq!(dx, dy, dz);
            vd2 = _mm256_max_pd(d2, vd2);
            let at = idx[4 * h] as usize;
            if consecutive {
                // SAFETY: entries `at .. at + 4`, the caller's.
                unsafe { _mm256_storeu_pd(sc.0.0.add(at), d2) };
            } else {
                let d = lanes!(d2);
                for l in 0..4 {
                    // SAFETY: the caller's.
                    unsafe { sc.0.write(idx[4 * h + l] as usize, d[l]) };
                }
            }
            if !fresh {
                continue;
            }
            let (ex, ey, ez) =
                (_mm256_sub_pd(x, wide!(bs.0, h)), _mm256_sub_pd(y, wide!(bs.1, h)), _mm256_sub_pd(z, wide!(bs.2, h)));
            let r2 = sq!(ex, ey, ez);
            vr2 = _mm256_max_pd(r2, vr2);
            let root = _mm_mul_ps(_mm_sqrt_ps(_mm256_cvtpd_ps(r2)), up);
            if consecutive {
                // SAFETY: as above.
                unsafe { _mm_storeu_ps(sc.1.0.add(at), root) };
            } else {
                let mut r = [0.0f32; 4];
                // SAFETY: four values.
                unsafe { _mm_storeu_ps(r.as_mut_ptr(), root) };
                for l in 0..4 {
                    // SAFETY: the caller's.
                    unsafe { sc.1.write(idx[4 * h + l] as usize, r[l]) };
                }
            }
            if boxes > 0 {
                (lx, ly, lz) = (_mm256_min_pd(ex, lx), _mm256_min_pd(ey, ly), _mm256_min_pd(ez, lz));
                (hx, hy, hz) = (_mm256_max_pd(ex, hx), _mm256_max_pd(ey, hy), _mm256_max_pd(ez, hz));
                vrun = _mm256_max_pd(r2, vrun);
                pending = true;
            }
        }
        k += 8;
    }
    if pending {
        fold!();
    }
    let (d, r) = (lanes!(vd2), lanes!(vr2));
    for l in 0..4 {
        (acc.d2_max, acc.r2_max) = (acc.d2_max.max(d[l]), acc.r2_max.max(r[l]));
    }
    acc.finish()
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

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The AVX2 sweep against the scalar one, to the bit: moves, drifts, maxima and boxes, over particles in runs
    /// of a body with other bodies' among them, gaps in the indices (lanes stored one by one), the last particle
    /// (taken alone), with and without references and boxes, and a NaN position (the maxima skip it alike).
    #[test]
    fn avx2_sweep_gives_the_scalar_bits() {
        if !crate::isa::avx2() {
            return;
        }
        let n = 203;
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        // Components of unlike sizes: the squares' sums round (an order changed shows).
        let mut pts = |s: f32| {
            (0..n).map(|_| Vec3::new(rnd() as f32, 1e-4 * rnd() as f32, 3e-2 * rnd() as f32) * s).collect::<Vec<_>>()
        };
        let x0 = pts(2.0);
        let mut q: Vec<Vec3> = x0.iter().zip(pts(0.7)).map(|(a, b)| *a + b).collect();
        let xb: Vec<Vec3> = x0.iter().zip(pts(0.3)).map(|(a, b)| *a + b).collect();
        q[77].y = f32::NAN;
        let body: Vec<u32> = (0..n as u32).map(|i| if i % 37 == 5 { 3 } else { i / 64 }).collect();
        let every: Vec<u32> = (0..n as u32).collect();
        let gaps: Vec<u32> = (0..n as u32).filter(|i| i % 11 != 3).collect();
        for ps in [&every, &gaps] {
            for (fresh, boxes) in [(false, 0), (true, 0), (true, 5)] {
                let run = |avx: bool| {
                    let (mut out, mut drifts) = (vec![0.0f64; n], vec![0.0f32; n]);
                    let sc = (Scatter(out.as_mut_ptr()), Scatter(drifts.as_mut_ptr()));
                    let r = Reads { x0: &x0[..], q: &q[..], xb: &xb[..], body: &body[..], fresh, boxes };
                    let mv = if avx {
                        let flat = r.with(v_as_f32::<f32>(&x0), v_as_f32::<f32>(&q), v_as_f32::<f32>(&xb));
                        // SAFETY: AVX2 checked above; the arrays hold every particle.
                        unsafe { sweep_avx2(ps, flat, sc) }
                    } else {
                        sweep_scalar::<f32>(ps, r, sc)
                    };
                    let bits = |v: &[DVec3]| v.iter().map(|x| x.to_array().map(f64::to_bits)).collect::<Vec<_>>();
                    let r2s: Vec<u64> = mv.r2s.iter().map(|x| x.to_bits()).collect();
                    let out: Vec<u64> = out.iter().map(|x| x.to_bits()).collect();
                    let drifts: Vec<u32> = drifts.iter().map(|x| x.to_bits()).collect();
                    (out, drifts, mv.d2.to_bits(), mv.r2.to_bits(), bits(&mv.lo), bits(&mv.hi), r2s)
                };
                assert_eq!(run(true), run(false), "fresh {fresh}, boxes {boxes}, {} particles", ps.len());
            }
        }
    }
}
