//! Implicit Euler's coarse correction: the second level of its CG preconditioner.
//!
//! Block-Jacobi (each particle's 3×3 diagonal block inverted) sees one particle at a time, so it leaves the slow
//! modes of a large step's system `M + h C + h² K` alone: a patch of cloth moving as a whole against its
//! neighbours is stiff at its border but not inside, and CG needs ~√κ iterations to spread a correction across
//! the body (107 a step on the 32² benchmark cloth at 1/60 s, where `h² k / m` ≈ 280). The coarse level solves the
//! system restricted to patches moving rigidly in translation (unsmoothed aggregation, as in algebraic multigrid;
//! Tamstorf, Jones & McCormick 2015 used smoothed aggregation for cloth): particles are gathered into
//! aggregates along their springs, the aggregates' `3 n_c × 3 n_c` operator `Pᵀ A P` is formed and factored
//! at every step (dense Cholesky; `n_c` is 24 to [`MAX_AGGREGATES`], growing with the model: [`aggregates_for`]),
//! and each application of the preconditioner adds `P (Pᵀ A P)⁻¹ Pᵀ r` to block-Jacobi's `B r` (additive
//! two-level Schwarz: symmetric positive definite, so CG stays CG, and the stopping rule `|r| ≤ tol |b|` is
//! unchanged, so the solution's accuracy is).
//!
//! `Pᵀ A P` is cheap to form: a spring inside an aggregate moves both its ends alike under `P` and adds nothing;
//! a spring across two adds its block `B_s` to both diagonal blocks and `-B_s` to the two off-diagonal ones; a
//! spring to a pinned particle adds `B_s` to its free end's; the masses add to the diagonal; the gas's rank-one
//! term `c g gᵀ` adds `c G Gᵀ` with `G` the aggregates' sums of `g`. Everything is in `f64` and in a fixed order
//! (the particles', then the springs'): the same bits at any thread count.
//!
//! What it costs and saves, measured (`benches/probes/implicit_cloth.rs`, `benches/RESULTS.md` issue 15 (50), a
//! 2-vCPU Zen 3 host whose speed drifts ~2× from minute to minute): on the 32² benchmark cloth at 1/60 s, 107.3
//! → 56.8 CG iterations a step; the aggregation once (~2 µs), forming `Pᵀ A P`, its factor and inverse 60–120 µs a
//! step (the drift), an application ~3–3.5 µs (a third each: the restriction, the 72 × 72 product, the
//! prolongation) against ~8–13 µs for an iteration of block-Jacobi CG. A factor kept over four steps cost more
//! iterations than it saved set-up (56.7 → 72.9). 16, 24 and 32 aggregates were measured alternated in one
//! process: 24 was the fastest. Aggregates of consecutive particles instead of grown along the springs (strips, on
//! a grid numbered by rows) saved almost nothing (102.6 iterations).

use crate::model::Model;
use crate::real::{Real, Vector3};

/// The most aggregates a connected model is cut into: [`aggregates_for`] grows with the model up to this. Each piece
/// a body is broken into makes at least one of its own; past twice the count aimed at, the level is left off (the
/// pieces are then many and small, block-Jacobi's good case, and the factor's cost grows as the count's cube).
pub(super) const MAX_AGGREGATES: usize = 96;

/// The aggregates to cut `free` particles into: 24 up to 1,024 particles, then growing as `free^0.43` up to
/// [`MAX_AGGREGATES`]. A step costs about the factor (`∝ n_c³`) plus the iterations (`∝ √(N / n_c)` for aggregates
/// of `N / n_c` particles on a sheet) times `N` each; the sum is least for `n_c ∝ N^(3/7)`. Measured on the
/// benchmark cloths at 1/60 s (`benches/RESULTS.md` issue 15 (50)): 32² 16/24/32 aggregates alternated, 24 the
/// fastest; 64² 24 → 90.7 iterations, 48 → 73.3, 96 → 60.9, the time flat within the host's noise; 128² 24 →
/// 146.8 iterations (113.6 ms a step), 48 → 119.5 (76.8 ms), 64 → 112.0 (75.5 ms), 96 → 98.2 (61.3 ms), against
/// 197.6 with block-Jacobi alone (capped at 200 iterations: not converged).
pub(super) fn aggregates_for(free: usize) -> usize {
    let grown = 24.0 * (free as f64 / 1024.0).max(1.0).powf(3.0 / 7.0);
    (grown.round() as usize).clamp(24, MAX_AGGREGATES)
}
// The prolongation's table holds every slot: the aggregates and the pinned particles' one.
const _: () = assert!(2 * MAX_AGGREGATES < TABLE);
/// Slots of the prolongation's table (a power of two: an index masked by `TABLE - 1` needs no bounds check).
const TABLE: usize = 256;
/// Particles per aggregate below which a coarse level is not worth its passes: a model of fewer than
/// `2 × MIN_SIZE` free particles is solved with block-Jacobi alone.
pub(super) const MIN_SIZE: usize = 16;

/// The coarse level: each particle's aggregate, the factor of `Pᵀ A P`, and scratch for an application.
#[derive(Clone, Debug, Default)]
pub(super) struct Coarse {
    /// Aggregate of each particle (a pinned particle, in none: one past the last aggregate).
    agg: Vec<u32>,
    /// Aggregates the shape has (0: the model is too small for a coarse level).
    aggregates: usize,
    /// Aggregates of the factor in use (0: no coarse level this step).
    n: usize,
    /// Each aggregate's mass.
    mass: Vec<f64>,
    /// `Pᵀ A P`, then (after [`factor`]) its inverse, row-major, `3n × 3n`; and scratch for the factor.
    l: Vec<f64>,
    xinv: Vec<f64>,
    /// Restricted residual and the coarse solution (each `3n + 3`: the last three, the pinned particles' slot),
    /// and a column of scratch for the factor.
    y: Vec<f64>,
    x: Vec<f64>,
    col: Vec<f64>,
    /// The runs of consecutive free particles in one aggregate: `(first, one past the last, aggregate)`.
    runs: Vec<(u32, u32, u32)>,
    /// The springs whose ends lie in different aggregates or on a pinned particle (the others add nothing),
    /// grouped by their pair of aggregates: pair `q` is `(a, b)` = `pairs[q].0, pairs[q].1` (`b` may be
    /// the pinned slot, past the aggregates) and its springs are `cross[pairs[q - 1].2..pairs[q].2]`.
    cross: Vec<u32>,
    pairs: Vec<(u32, u32, u32)>,
    /// What the aggregation was made for: particles, springs, free particles, a sum over the pinned ones.
    key: (usize, usize, usize, u64),
}

const NONE: u32 = u32::MAX;

impl Coarse {
    /// Turns the level off (block-Jacobi alone).
    pub fn off(&mut self) {
        self.n = 0;
    }

    /// Whether the coarse level is in use.
    pub fn active(&self) -> bool {
        self.n > 0
    }

    /// Forms and factors `Pᵀ A P` for this step, with the springs' system blocks `iso I + (axial - iso) u uᵀ`
    /// (`coef[s][2]`, `coef[s][3]`) and the gas's term `c_b g gᵀ` (`body_c` empty: none); the aggregation is made
    /// again only when the model's shape changed ([`Coarse::aggregate`]). Leaves the level off when the model is
    /// too small, or when the factor fails (it cannot for positive masses, but a broken state is CG's to report,
    /// not this level's).
    pub fn build<R: Real>(&mut self, m: &Model<R>, u: &[R::V], coef: &[[R; 4]], g: &[R::V], body_c: &[R]) {
        self.aggregate(m);
        self.n = 0;
        let n = self.aggregates;
        if n == 0 {
            return;
        }
        let dim = 3 * n;
        self.l.clear();
        self.l.resize(dim * dim, 0.0);
        let a = &mut self.l;
        for (k, &mk) in self.mass.iter().enumerate() {
            (0..3).for_each(|r| a[(3 * k + r) * dim + 3 * k + r] = mk);
        }
        // Each pair's springs' blocks summed (the six entries of a symmetric 3×3), then added to the pair's four
        // blocks of `Pᵀ A P`: a spring across two aggregates moves them apart, one to a pinned particle its own.
        let mut start = 0;
        for &(pa, pb, end) in &self.pairs {
            let mut s = [0.0f64; 6];
            for &sp in &self.cross[start..end as usize] {
                let sp = sp as usize;
                let (iso, axial) = (coef[sp][2].to_f64(), coef[sp][3].to_f64());
                let d = u[sp].to_dvec3();
                let c = axial - iso;
                let (cx, cy, cz) = (c * d.x, c * d.y, c * d.z);
                s[0] += cx * d.x + iso;
                s[1] += cx * d.y;
                s[2] += cx * d.z;
                s[3] += cy * d.y + iso;
                s[4] += cy * d.z;
                s[5] += cz * d.z + iso;
            }
            start = end as usize;
            let blk = [[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]];
            let mut add = |p: usize, q: usize, sign: f64| {
                for (r, row) in blk.iter().enumerate() {
                    let at = (3 * p + r) * dim + 3 * q;
                    for (v, &b) in a[at..at + 3].iter_mut().zip(row) {
                        *v += sign * b;
                    }
                }
            };
            let pa = pa as usize;
            add(pa, pa, 1.0);
            if (pb as usize) < n {
                let pb = pb as usize;
                add(pb, pb, 1.0);
                add(pa, pb, -1.0);
                add(pb, pa, -1.0);
            }
        }
        for (b, &c) in body_c.iter().enumerate() {
            let c = c.to_f64();
            if c <= 0.0 {
                continue;
            }
            let sums = &mut self.x;
            sums.clear();
            sums.resize(dim, 0.0);
            for (i, &k) in self.agg.iter().enumerate() {
                if (k as usize) < n && m.particle_body[i] as usize == b {
                    let gi = g[i].to_dvec3();
                    let k = 3 * k as usize;
                    sums[k] += gi.x;
                    sums[k + 1] += gi.y;
                    sums[k + 2] += gi.z;
                }
            }
            for r in 0..dim {
                let cr = c * sums[r];
                for (v, &sq) in a[r * dim..(r + 1) * dim].iter_mut().zip(sums.iter()) {
                    *v += cr * sq;
                }
            }
        }
        self.xinv.resize(dim * dim, 0.0);
        self.col.resize(dim, 0.0);
        for v in [&mut self.y, &mut self.x] {
            v.resize(dim + 3, 0.0);
        }
        if factor(&mut self.l, dim, &mut self.col, &mut self.xinv) {
            self.n = n;
        }
    }

    /// Gathers `m`'s free particles into aggregates along its springs (breadth first from the lowest unassigned
    /// particle, up to the size that makes [`aggregates_for`] of them in a connected model), with each aggregate's
    /// mass, its runs of consecutive particles and the springs that cross between aggregates; kept while the
    /// model's counts and pins are the same.
    fn aggregate<R: Real>(&mut self, m: &Model<R>) {
        let np = m.particle_count();
        let w = &m.particle_inv_mass;
        // The pinned particles by count and a sum of their indices' squares: an aggregate must hold no pinned
        // particle (the level would move it), and a pin moved to another particle changes the sum.
        let (mut pinned, mut sum) = (0usize, 0u64);
        for (i, wi) in w.iter().enumerate() {
            if *wi == R::ZERO {
                pinned += 1;
                sum = sum.wrapping_add((i as u64 + 1).wrapping_mul(i as u64 + 1));
            }
        }
        let free = np - pinned;
        let key = (np, m.spring_count(), free, sum);
        if key == self.key && self.agg.len() == np {
            return;
        }
        self.key = key;
        self.aggregates = 0;
        self.agg.clear();
        self.agg.resize(np, NONE);
        if free < 2 * MIN_SIZE {
            return;
        }
        let target = aggregates_for(free);
        let size = free.div_ceil(target).max(MIN_SIZE);
        let mut members = Vec::with_capacity(free);
        let mut n = 0u32;
        for seed in 0..np {
            if w[seed] == R::ZERO || self.agg[seed] != NONE {
                continue;
            }
            let mut head = members.len();
            members.push(seed as u32);
            self.agg[seed] = n;
            let mut count = 1;
            'grow: while head < members.len() {
                let i = members[head] as usize;
                head += 1;
                for &e in m.particle_springs.row(i) {
                    let [a, b] = m.spring_indices[(e >> 1) as usize];
                    let j = if a as usize == i { b } else { a } as usize;
                    if w[j] != R::ZERO && self.agg[j] == NONE {
                        self.agg[j] = n;
                        members.push(j as u32);
                        count += 1;
                        if count == size {
                            break 'grow;
                        }
                    }
                }
            }
            n += 1;
        }
        if n as usize > 2 * target {
            return;
        }
        // The pinned particles' slot: one past the aggregates (a residual summed there is never read).
        self.agg.iter_mut().filter(|k| **k == NONE).for_each(|k| *k = n);
        self.runs.clear();
        for (i, &k) in self.agg.iter().enumerate() {
            match self.runs.last_mut() {
                Some(run) if run.2 == k && run.1 as usize == i => run.1 += 1,
                _ if k < n => self.runs.push((i as u32, i as u32 + 1, k)),
                _ => {}
            }
        }
        self.mass.clear();
        self.mass.resize(n as usize, 0.0);
        for (i, &k) in self.agg.iter().enumerate() {
            if k < n {
                self.mass[k as usize] += m.particle_mass[i].to_f64();
            }
        }
        // The crossing springs by pair of aggregates (the lower first; a pinned end, slot `n`, sorts last), each
        // pair's in spring order: a fixed order of sums.
        let agg = &self.agg;
        let pair = |s: u32| {
            let [i, j] = m.spring_indices[s as usize];
            let (a, b) = (agg[i as usize], agg[j as usize]);
            (a.min(b), a.max(b))
        };
        self.cross.clear();
        self.cross.extend((0..m.spring_count() as u32).filter(|&s| {
            let (a, b) = pair(s);
            a != b
        }));
        self.cross.sort_by_key(|&s| pair(s));
        self.pairs.clear();
        for (at, &s) in self.cross.iter().enumerate() {
            let (a, b) = pair(s);
            match self.pairs.last_mut() {
                Some(last) if (last.0, last.1) == (a, b) => last.2 = at as u32 + 1,
                _ => self.pairs.push((a, b, at as u32 + 1)),
            }
        }
        self.aggregates = n as usize;
    }

    /// `z += P (Pᵀ A P)⁻¹ Pᵀ r` on vectors stored per component (`cg_runs.rs`): the residual summed over each
    /// run of consecutive particles of one aggregate (in the model's type, a short contiguous sum), the runs' sums
    /// added per aggregate in particle order, the coarse solve, and each particle's aggregate's correction added.
    /// Measured against a pass over the particles one by one, each looking up its aggregate (~20 instructions a
    /// particle and direction, 2.6 µs both ways): runs 2.2 µs; runs cut to windows of 8 lanes summed branch-free,
    /// slower (3.4 µs for the restriction alone). The prolongation reads a table whose masked index needs no bounds
    /// check. Inlined into the runs' CG, so compiled for its instruction set.
    #[inline(always)]
    pub fn apply_soa<R: Real>(&mut self, r: &[Vec<R>; 3], z: &mut [Vec<R>; 3]) {
        let np = self.agg.len();
        let (rx, ry, rz) = (&r[0][..np], &r[1][..np], &r[2][..np]);
        for v in self.y.iter_mut() {
            *v = 0.0;
        }
        let y = &mut self.y[..];
        for &(start, end, k) in &self.runs {
            let (start, end, k) = (start as usize, end as usize, 3 * k as usize);
            let (mut sx, mut sy, mut sz) = (R::ZERO, R::ZERO, R::ZERO);
            for i in start..end {
                sx += rx[i];
                sy += ry[i];
                sz += rz[i];
            }
            let yk = &mut y[k..k + 3];
            yk[0] += sx.to_f64();
            yk[1] += sy.to_f64();
            yk[2] += sz.to_f64();
        }
        self.solve();
        // Each particle's correction looked up in a table of 64 entries per component, its index masked so that
        // the lookup needs no bounds check (at most 2 × MAX_AGGREGATES + 1 slots are used: see below).
        let mut table = [[R::ZERO; TABLE]; 3];
        for (k, xk) in self.x.chunks_exact(3).enumerate() {
            for c in 0..3 {
                table[c][k] = R::from_f64(xk[c]);
            }
        }
        let [tx, ty, tz] = &table;
        let agg = &self.agg[..np];
        let [zx, zy, zz] = z;
        let (zx, zy, zz) = (&mut zx[..np], &mut zy[..np], &mut zz[..np]);
        for i in 0..np {
            let k = agg[i] as usize & (TABLE - 1);
            zx[i] += tx[k];
            zy[i] += ty[k];
            zz[i] += tz[k];
        }
    }

    /// `z += P (Pᵀ A P)⁻¹ Pᵀ r` on vectors of 3-vectors (`implicit.rs`), as [`Coarse::apply_soa`].
    pub fn apply<R: Real>(&mut self, r: &[R::V], z: &mut [R::V]) {
        let np = self.agg.len();
        let r = &r[..np];
        for v in self.y.iter_mut() {
            *v = 0.0;
        }
        for &(start, end, k) in &self.runs {
            let k = 3 * k as usize;
            let s = r[start as usize..end as usize].iter().fold(R::V::ZERO, |a, &b| a + b).to_dvec3();
            let yk = &mut self.y[k..k + 3];
            yk[0] += s.x;
            yk[1] += s.y;
            yk[2] += s.z;
        }
        self.solve();
        let mut table = [R::V::ZERO; TABLE];
        for (t, xk) in table.iter_mut().zip(self.x.chunks_exact(3)) {
            *t = R::V::from_dvec3(glam::DVec3::from_slice(xk));
        }
        for (&k, zi) in self.agg.iter().zip(&mut z[..np]) {
            *zi += table[k as usize & (TABLE - 1)];
        }
    }

    /// `yᵀ x` of the last application: what its correction adds to `rᵀ z` (`rᵀ P x = (Pᵀ r)ᵀ x`), so that CG need
    /// not take the dot product again.
    pub fn yx(&self) -> f64 {
        let dim = 3 * self.n;
        self.y[..dim].iter().zip(&self.x[..dim]).map(|(a, b)| a * b).sum()
    }

    /// `x = (Pᵀ A P)⁻¹ y` as a sum of the inverse's columns scaled, which are its rows (it is symmetric): each a
    /// contiguous `x += s a` of full length, so it vectorises (a fixed order: fixed bits). Measured on the
    /// benchmark cloth's 72 unknowns: the same product as rows' dot products, which LLVM packed poorly, 2.1 µs an
    /// application; `Xᵀ (X y)` with `X = L⁻¹` as two such sums over triangles (no `Xᵀ X` to form), 1.7× this one,
    /// which outweighed the set-up it saved. The slot of the pinned particles (the last three entries) gets zero.
    #[inline(always)]
    fn solve(&mut self) {
        let dim = 3 * self.n;
        let (inv, y, x) = (&self.l[..dim * dim], &self.y[..dim], &mut self.x[..]);
        for v in x.iter_mut() {
            *v = 0.0;
        }
        let xd = &mut x[..dim];
        for (row, &s) in inv.chunks_exact(dim).zip(y) {
            for (v, &a) in xd.iter_mut().zip(row) {
                *v += s * a;
            }
        }
    }
}

crate::isa::wide_kernel! {
    /// Inverts the symmetric positive definite `dim × dim` matrix `a` (row-major, lower triangle read) in place,
    /// through its Cholesky factor `L` and `X = L⁻¹` (in `x`, scratch of `dim²`): `a⁻¹ = Xᵀ X`; `col` is scratch
    /// of `dim`. False if `a` is not positive definite. Compiled for AVX-512 or AVX2 when the CPU has them (the
    /// same bits: see `crate::isa`).
    fn factor[](a: &mut [f64], dim: usize, col: &mut [f64], x: &mut [f64]) -> bool => factor_kernel[]
}

/// [`factor`]'s body: Cholesky right-looking, with column `j` copied into `col` so that each row's update is a
/// contiguous `a -= s b`; then `L⁻¹` by forward elimination on the identity, row operations again; then `Xᵀ X` as
/// a sum of `X`'s rows' outer products (lower triangle, mirrored). Every inner loop is a contiguous `a += s b` (no
/// chain of dependent additions), so it vectorises.
#[inline(always)]
fn factor_kernel(a: &mut [f64], dim: usize, col: &mut [f64], x: &mut [f64]) -> bool {
    let (a, col, x) = (&mut a[..dim * dim], &mut col[..dim], &mut x[..dim * dim]);
    for j in 0..dim {
        let d = a[j * dim + j];
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j * dim + j] = d;
        for i in j + 1..dim {
            a[i * dim + j] /= d;
            col[i] = a[i * dim + j];
        }
        for i in j + 1..dim {
            let s = col[i];
            for (v, &b) in a[i * dim + j + 1..i * dim + i + 1].iter_mut().zip(&col[j + 1..i + 1]) {
                *v -= s * b;
            }
        }
    }
    for v in x.iter_mut() {
        *v = 0.0;
    }
    for k in 0..dim {
        x[k * dim + k] = 1.0;
    }
    for q in 0..dim {
        let d = a[q * dim + q];
        for v in &mut x[q * dim..q * dim + q + 1] {
            *v /= d;
        }
        let (done, rest) = x.split_at_mut((q + 1) * dim);
        let xq = &done[q * dim..q * dim + q + 1];
        for r in q + 1..dim {
            let s = a[r * dim + q];
            for (v, &b) in rest[(r - q - 1) * dim..(r - q - 1) * dim + q + 1].iter_mut().zip(xq) {
                *v -= s * b;
            }
        }
    }
    for v in a.iter_mut() {
        *v = 0.0;
    }
    for r in 0..dim {
        let xr = &x[r * dim..r * dim + r + 1];
        for (p, &s) in xr.iter().enumerate() {
            for (v, &b) in a[p * dim..p * dim + p + 1].iter_mut().zip(xr) {
                *v += s * b;
            }
        }
    }
    for p in 0..dim {
        for q in 0..p {
            a[q * dim + p] = a[p * dim + q];
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 9 × 9 symmetric positive definite matrix (`B Bᵀ + I` for a fixed `B`).
    fn spd() -> Vec<f64> {
        let b = |r: usize, c: usize| ((r * 7 + c * 3) % 5) as f64 - 2.0;
        let mut a = vec![0.0; 81];
        for r in 0..9 {
            for c in 0..9 {
                a[r * 9 + c] = (0..9).map(|k| b(r, k) * b(c, k)).sum::<f64>() + if r == c { 1.0 } else { 0.0 };
            }
        }
        a
    }

    #[test]
    fn aggregates_grow_with_the_model_within_bounds() {
        assert_eq!(aggregates_for(500), 24);
        assert_eq!(aggregates_for(1024), 24);
        assert_eq!(aggregates_for(4096), 43);
        assert_eq!(aggregates_for(16384), 79);
        assert_eq!(aggregates_for(1 << 20), MAX_AGGREGATES);
    }

    #[test]
    fn factor_and_solve_invert_a_small_spd_system() {
        let a = spd();
        let mut c = Coarse { n: 3, l: a.clone(), xinv: vec![0.0; 81], col: vec![0.0; 9], ..Coarse::default() };
        assert!(factor(&mut c.l, 9, &mut c.col, &mut c.xinv));
        // A A⁻¹ = I, and A⁻¹ symmetric.
        for r in 0..9 {
            for q in 0..9 {
                let v: f64 = (0..9).map(|k| a[r * 9 + k] * c.l[k * 9 + q]).sum();
                assert!((v - if r == q { 1.0 } else { 0.0 }).abs() < 1e-9, "A A⁻¹[{r}][{q}] = {v}");
                assert_eq!(c.l[r * 9 + q], c.l[q * 9 + r]);
            }
        }
        // x = A⁻¹ y for y = e_j and a dense y; the pinned slot's entries are ignored and come back zero.
        for j in 0..10 {
            c.y = (0..12)
                .map(|i| {
                    if j == 9 {
                        i as f64 - 4.5
                    } else if i == j {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            c.y[9..].iter_mut().for_each(|v| *v = 7.0);
            c.x = vec![0.0; 12];
            c.solve();
            for r in 0..9 {
                let v: f64 = (0..9).map(|k| a[r * 9 + k] * c.x[k]).sum();
                assert!((v - c.y[r]).abs() < 1e-9, "(A x)[{r}] = {v}, want {} (case {j})", c.y[r]);
            }
            assert_eq!(&c.x[9..], &[0.0; 3]);
        }
        let mut b = vec![1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 2.0];
        assert!(!factor(&mut b, 3, &mut [0.0; 3], &mut [0.0; 9]), "an indefinite matrix is refused");
    }
}
