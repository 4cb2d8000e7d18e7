//! Implicit Euler's conjugate gradients on a grid's spring runs, in struct-of-arrays form.
//!
//! The product `A p` is the solve's cost, and in the general solver it goes per spring through indices and
//! 3-vectors: ~3.4 ns per spring, scalar, on the development VM. On a model made of spring runs
//! ([`crate::model::SpringRun`]: springs `first + k` joining particles `i + k` and `j + k`) the ends of a span of
//! springs are contiguous, so with CG's vectors and the springs' coefficients stored per component each span's
//! products are plain loops over arrays that the compiler vectorises, and each particle's sum is added in place:
//! no index is read and no per-spring buffer is written and gathered again. The runs are joined across a grid's
//! row ends ([`join_runs`]) so the loops are long; each run's products are added to its two ends in one pass
//! ([`spring_product`]); the dot products keep eight partial sums (the additions pipeline); the per-particle
//! loops run over slices cut to one length (no bounds checks: they vectorise); and the solve is compiled for
//! AVX2 where the CPU has it. On the 32² benchmark cloth at 1/60 s (2026-11-24, the 2-core VM): 3.2–3.3 →
//! 0.98–1.16 ms per step at the same 107 iterations (~9.5 µs each, ~5.5 of them the product).
//!
//! It runs on the calling thread: it serves models below [`par::PAR_MIN`] springs (a model that size goes to the
//! pool in the general solver), so the choice depends on the model alone and the bits on nothing else. Each
//! particle's sum is added in the order of the runs, then of the spans' two ends; the dot products sum `x`, then
//! `y`, then `z` of each particle: bits of their own, the same on any machine and thread count.

use super::coarse::Coarse;
use super::implicit::ImplicitScratch;
use super::*;

/// A vector of 3-vectors stored per component.
#[derive(Clone, Debug, Default)]
pub(super) struct Soa<R> {
    pub(super) c: [Vec<R>; 3],
}

impl<R: Real> Soa<R> {
    fn resize(&mut self, n: usize) {
        self.c.iter_mut().for_each(|v| v.resize(n, R::ZERO));
    }

    fn fill(&mut self, v: &[R::V]) {
        self.resize(v.len());
        for (i, x) in v.iter().enumerate() {
            let [a, b, c] = x.to_array();
            (self.c[0][i], self.c[1][i], self.c[2][i]) = (a, b, c);
        }
    }

    fn get(&self, i: usize) -> R::V {
        R::V::new(self.c[0][i], self.c[1][i], self.c[2][i])
    }

    fn set(&mut self, i: usize, v: R::V) {
        let [a, b, c] = v.to_array();
        (self.c[0][i], self.c[1][i], self.c[2][i]) = (a, b, c);
    }
}

/// The struct-of-arrays CG's vectors and the springs' system coefficients per component.
#[derive(Clone, Debug, Default)]
pub(super) struct RunsCg<R> {
    r: Soa<R>,
    z: Soa<R>,
    p: Soa<R>,
    ap: Soa<R>,
    x: Soa<R>,
    /// Unit directions of the springs, per component, in the order of `vruns` (0 in holes).
    u: Soa<R>,
    /// `iso` and `axial - iso` of each spring's system block `iso I + (axial - iso) u uᵀ` (0 in holes).
    iso: Vec<R>,
    aniso: Vec<R>,
    /// The model's runs joined across short gaps ([`join_runs`]), and the spring of each of their slots.
    vruns: Vec<VRun>,
    slots: Vec<u32>,
    /// Each slot's product of one joined run, per component ([`spring_product`]).
    y: [Vec<R>; 3],
    /// `g · p` per body (the gas's rank-one term).
    gp: Vec<R>,
    /// The block-Jacobi preconditioner's symmetric inverse blocks per entry: `[b00, b01, b02, b11, b12, b22]`.
    block: [Vec<R>; 6],
}

/// Runs joined across gaps: slots `start + k` for `k < len` join particles `i + k` and `j + k`; a slot holds a
/// spring or, where the joined runs skip a few particles, a hole (coefficients 0).
#[derive(Clone, Copy, Debug)]
struct VRun {
    i: usize,
    j: usize,
    len: usize,
    start: usize,
}

/// Slots of a hole in [`RunsCg::slots`].
const HOLE: u32 = u32::MAX;

/// Joins `m`'s runs where the next one continues the last after a gap of at most two particles at both ends (a
/// grid's rows: the last particle of a row has no spring to the right). A 32² cloth's 128 runs of ~45 springs
/// become a handful of long ones, so the products run in whole vectors instead of paying each short run's loop
/// overheads; a hole's product is 0.
fn join_runs<R: Real>(m: &Model<R>, vruns: &mut Vec<VRun>, slots: &mut Vec<u32>) {
    vruns.clear();
    slots.clear();
    for r in &m.spring_runs {
        let (i, j, len, first) = (r.i as usize, r.j as usize, r.len as usize, r.first);
        if let Some(last) = vruns.last_mut() {
            let (ei, ej) = (last.i + last.len, last.j + last.len);
            if i >= ei && i - ei <= 2 && j >= ej && j - ej == i - ei {
                slots.extend(std::iter::repeat_n(HOLE, i - ei));
                slots.extend(first..first + len as u32);
                last.len += i - ei + len;
                continue;
            }
        }
        vruns.push(VRun { i, j, len, start: slots.len() });
        slots.extend(first..first + len as u32);
    }
}

/// Whether [`CpuSolver::cg_solve_runs`] serves `m`: a model of spring runs whose passes run on one thread.
pub(super) fn serves<R: Real>(m: &Model<R>) -> bool {
    m.springs_are_runs() && m.spring_count() < par::PAR_MIN && m.particle_count() < par::PAR_MIN
}

/// `ap = Σ_runs ±B_s (p_j - p_i)` (the springs' part of `-A p`'s off-mass terms, as the general solver's
/// `spring_gather` of `spring_apply`): `+` on end 0, `-` on end 1. Per joined run, every slot's `y_k` into `y`,
/// then one pass over the particles it reaches adds `y_t - y_{t - off}` (`off = j - i`, the run's ends' offset):
/// adding `y` at `i + k` and subtracting it at `j + k` in two passes made the second pass's loads overlap the
/// first's stores a particle or two away, which stalls their forwarding.
#[inline(always)]
fn spring_product<R: Real>(cg: &RunsCg<R>, out: &mut Soa<R>, y: &mut [Vec<R>; 3]) {
    out.c.iter_mut().for_each(|v| v.iter_mut().for_each(|x| *x = R::ZERO));
    let (p, u) = (&cg.p.c, &cg.u.c);
    for r in &cg.vruns {
        let (i0, j0, s0, len) = (r.i, r.j, r.start, r.len);
        y.iter_mut().for_each(|v| v.resize(len, R::ZERO));
        {
            let (iso, an) = (&cg.iso[s0..s0 + len], &cg.aniso[s0..s0 + len]);
            let (ux, uy, uz) = (&u[0][s0..s0 + len], &u[1][s0..s0 + len], &u[2][s0..s0 + len]);
            let (pix, piy, piz) = (&p[0][i0..i0 + len], &p[1][i0..i0 + len], &p[2][i0..i0 + len]);
            let (pjx, pjy, pjz) = (&p[0][j0..j0 + len], &p[1][j0..j0 + len], &p[2][j0..j0 + len]);
            let [yx, yy, yz] = y;
            let (yx, yy, yz) = (&mut yx[..len], &mut yy[..len], &mut yz[..len]);
            for k in 0..len {
                let (dx, dy, dz) = (pjx[k] - pix[k], pjy[k] - piy[k], pjz[k] - piz[k]);
                let t = an[k] * (ux[k] * dx + uy[k] * dy + uz[k] * dz);
                yx[k] = dx * iso[k] + ux[k] * t;
                yy[k] = dy * iso[k] + uy[k] * t;
                yz[k] = dz * iso[k] + uz[k] * t;
            }
        }
        for (c, yc) in y.iter().enumerate() {
            let o = &mut out.c[c];
            if j0 > i0 {
                let off = j0 - i0;
                let head = off.min(len);
                for (o, v) in o[i0..i0 + head].iter_mut().zip(&yc[..head]) {
                    *o += *v;
                }
                if off < len {
                    let body = &mut o[i0 + off..i0 + len];
                    for (k, o) in body.iter_mut().enumerate() {
                        *o += yc[off + k] - yc[k];
                    }
                }
                let tail0 = off.max(len);
                for (o, v) in o[i0 + tail0..j0 + len].iter_mut().zip(&yc[tail0 - off..len]) {
                    *o -= *v;
                }
            } else {
                for (o, v) in o[i0..i0 + len].iter_mut().zip(&yc[..len]) {
                    *o += *v;
                }
                for (o, v) in o[j0..j0 + len].iter_mut().zip(&yc[..len]) {
                    *o -= *v;
                }
            }
        }
    }
}

impl<R: Real> CpuSolver<R> {
    /// [`CpuSolver::cg_solve`] for a model [`serves`] accepts: the same system, preconditioner, start and
    /// stopping rule (`|r| ≤ cg_tolerance |b|`), in struct-of-arrays form on one thread (module docs). `b` in
    /// `im.r`; the solution into `im.dv`. Compiled for AVX2 when the CPU has it (the same bits: see
    /// `run_block_dispatch`).
    pub(super) fn cg_solve_runs(
        &mut self,
        m: &Model<R>,
        im: &mut ImplicitScratch<R>,
        pressure: bool,
        guess: Option<R>,
    ) -> Result<(), StepError> {
        let (tol, max) = (self.config.cg_tolerance, self.config.cg_max_iterations);
        #[cfg(target_arch = "x86_64")]
        {
            if crate::isa::avx2() {
                // SAFETY: the CPU supports AVX2, checked just above.
                let (result, stats) = unsafe { solve_avx2(m, im, pressure, guess, tol, max) };
                self.cg = stats;
                return result;
            }
        }
        let (result, stats) = solve(m, im, pressure, guess, tol, max);
        self.cg = stats;
        result
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve_avx2<R: Real>(
    m: &Model<R>,
    im: &mut ImplicitScratch<R>,
    pressure: bool,
    guess: Option<R>,
    tol: f64,
    max: usize,
) -> (Result<(), StepError>, CgStats) {
    solve(m, im, pressure, guess, tol, max)
}

/// The body of [`CpuSolver::cg_solve_runs`]: the result and the iterations and final relative residual.
#[inline(always)]
fn solve<R: Real>(
    m: &Model<R>,
    im: &mut ImplicitScratch<R>,
    pressure: bool,
    guess: Option<R>,
    tol: f64,
    max: usize,
) -> (Result<(), StepError>, CgStats) {
    let n = m.particle_count();
    let mut cg = std::mem::take(&mut im.runs);
    let w = &m.particle_inv_mass;
    cg.r.fill(&im.r);
    let bnorm2 = dot(&cg.r, &cg.r);
    if bnorm2 == R::ZERO {
        im.dv.iter_mut().for_each(|x| *x = R::V::ZERO);
        im.runs = cg;
        return (Ok(()), CgStats::default());
    }
    let tol2 = R::from_f64(tol * tol) * bnorm2;
    // The springs' system coefficients per component, in the joined runs' slots.
    let (mut vruns, mut slots) = (std::mem::take(&mut cg.vruns), std::mem::take(&mut cg.slots));
    join_runs(m, &mut vruns, &mut slots);
    cg.u.resize(slots.len());
    cg.iso.clear();
    cg.aniso.clear();
    for (k, &sp) in slots.iter().enumerate() {
        let (u, c) = if sp == HOLE { (R::V::ZERO, [R::ZERO; 4]) } else { (im.u[sp as usize], im.coef[sp as usize]) };
        cg.u.set(k, u);
        cg.iso.push(c[2]);
        cg.aniso.push(c[3] - c[2]);
    }
    (cg.vruns, cg.slots) = (vruns, slots);
    for v in [&mut cg.z, &mut cg.p, &mut cg.ap, &mut cg.x] {
        v.resize(n);
    }
    match guess {
        Some(scale) => {
            for i in 0..n {
                let v = if w[i] == R::ZERO { R::V::ZERO } else { im.dv[i] * scale };
                cg.x.set(i, v);
            }
            cg.p.c.clone_from(&cg.x.c);
            apply(m, &mut cg, im, pressure);
            for c in 0..3 {
                for (r, a) in cg.r.c[c].iter_mut().zip(&cg.ap.c[c]) {
                    *r -= *a;
                }
            }
        }
        None => cg.x.c.iter_mut().for_each(|v| v.iter_mut().for_each(|x| *x = R::ZERO)),
    }
    // The inverse blocks are symmetric: six entries, as rows `(b00 b01 b02) (b01 b11 b12) (b02 b12 b22)`.
    for (e, v) in cg.block.iter_mut().enumerate() {
        v.clear();
        let (row, col) = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)][e];
        v.extend(im.block.iter().map(|b| b[row].to_array()[col]));
    }
    precondition(&mut cg, &mut im.coarse);
    cg.p.c.clone_from(&cg.z.c);
    let (mut rz, mut rr) = (dot(&cg.r, &cg.z), dot(&cg.r, &cg.r));
    let mut it = 0;
    let mut result = Ok(());
    let mut stats = CgStats::default();
    while it < max && rr > tol2 {
        let pap = apply(m, &mut cg, im, pressure);
        if !pap.is_finite() || pap <= R::ZERO {
            // Positive definite by construction (see `cg_solve`): the state itself is broken.
            let residual = (rr / bnorm2).to_f64().sqrt();
            stats = CgStats { iterations: it, residual };
            result = Err(StepError::NoConvergence { iterations: it, residual });
            break;
        }
        let alpha = rz / pap;
        for c in 0..3 {
            for ((x, r), (p, a)) in
                cg.x.c[c].iter_mut().zip(cg.r.c[c].iter_mut()).zip(cg.p.c[c].iter().zip(&cg.ap.c[c]))
            {
                *x += *p * alpha;
                *r -= *a * alpha;
            }
        }
        precondition(&mut cg, &mut im.coarse);
        let rz_new = dot(&cg.r, &cg.z);
        rr = dot(&cg.r, &cg.r);
        let beta = rz_new / rz;
        rz = rz_new;
        for c in 0..3 {
            for (p, z) in cg.p.c[c].iter_mut().zip(&cg.z.c[c]) {
                *p = *z + *p * beta;
            }
        }
        it += 1;
    }
    for (i, d) in im.dv.iter_mut().enumerate() {
        *d = cg.x.get(i);
    }
    im.runs = cg;
    if result.is_ok() {
        let residual = (rr / bnorm2).to_f64().sqrt();
        stats = CgStats { iterations: it, residual };
        if !residual.is_finite() {
            result = Err(StepError::NoConvergence { iterations: it, residual });
        }
    }
    (result, stats)
}

/// `cg.ap = A cg.p` (zero on pinned particles), returning `p · ap`.
#[inline(always)]
fn apply<R: Real>(m: &Model<R>, cg: &mut RunsCg<R>, im: &ImplicitScratch<R>, pressure: bool) -> R {
    let (n, w) = (m.particle_count(), &m.particle_inv_mass);
    let (mut ap, mut y) = (std::mem::take(&mut cg.ap), std::mem::take(&mut cg.y));
    spring_product_dispatch(cg, &mut ap, &mut y);
    cg.y = y;
    let (mass, w) = (&m.particle_mass[..n], &w[..n]);
    for c in 0..3 {
        for ((a, &p), (&mi, &wi)) in ap.c[c][..n].iter_mut().zip(&cg.p.c[c][..n]).zip(mass.iter().zip(w)) {
            let y = p * mi - *a;
            *a = if wi == R::ZERO { R::ZERO } else { y };
        }
    }
    if pressure {
        let mut gp = std::mem::take(&mut cg.gp);
        body_dots_soa(m, &im.g, &cg.p, &mut gp);
        for i in 0..n {
            let body = m.particle_body[i];
            if w[i] != R::ZERO && body != NONE {
                ap.set(i, ap.get(i) + im.g[i] * (im.body_c[body as usize] * gp[body as usize]));
            }
        }
        cg.gp = gp;
    }
    cg.ap = ap;
    dot(&cg.p, &cg.ap)
}

/// `cg.z = B cg.r`, each row `b · r` summed x, y, z (the bits of `implicit::precondition`), plus the coarse
/// level's correction where it is active (`coarse.rs`).
#[inline(always)]
fn precondition<R: Real>(cg: &mut RunsCg<R>, coarse: &mut Coarse) {
    let n = cg.r.c[0].len();
    let [b00, b01, b02, b11, b12, b22] = &cg.block;
    let (b00, b01, b02, b11, b12, b22) = (&b00[..n], &b01[..n], &b02[..n], &b11[..n], &b12[..n], &b22[..n]);
    let [rx, ry, rz] = &cg.r.c;
    let (rx, ry, rz) = (&rx[..n], &ry[..n], &rz[..n]);
    let [zx, zy, zz] = &mut cg.z.c;
    let (zx, zy, zz) = (&mut zx[..n], &mut zy[..n], &mut zz[..n]);
    for i in 0..n {
        let (x, y, z) = (rx[i], ry[i], rz[i]);
        zx[i] = b00[i] * x + b01[i] * y + b02[i] * z;
        zy[i] = b01[i] * x + b11[i] * y + b12[i] * z;
        zz[i] = b02[i] * x + b12[i] * y + b22[i] * z;
    }
    if coarse.active() {
        coarse.apply_soa(&cg.r.c, &mut cg.z.c);
    }
}

/// `a · b`, in eight interleaved partial sums (so that the additions pipeline and vectorise) added in a fixed
/// order at the end: the same bits on every run.
#[inline(always)]
fn dot<R: Real>(a: &Soa<R>, b: &Soa<R>) -> R {
    let mut acc = [R::ZERO; 8];
    for c in 0..3 {
        let (x, y) = (&a.c[c], &b.c[c]);
        let whole = x.len() / 8 * 8;
        for (xs, ys) in x[..whole].chunks_exact(8).zip(y[..whole].chunks_exact(8)) {
            for l in 0..8 {
                acc[l] += xs[l] * ys[l];
            }
        }
        for (l, (xv, yv)) in x[whole..].iter().zip(&y[whole..]).enumerate() {
            acc[l] += *xv * *yv;
        }
    }
    acc.iter().fold(R::ZERO, |s, &v| s + v)
}

/// [`spring_product`] compiled for AVX2 when the CPU has it (the same bits: see `run_block_dispatch`).
fn spring_product_dispatch<R: Real>(cg: &RunsCg<R>, out: &mut Soa<R>, y: &mut [Vec<R>; 3]) {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::isa::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { spring_product_avx2(cg, out, y) };
            return;
        }
    }
    spring_product(cg, out, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn spring_product_avx2<R: Real>(cg: &RunsCg<R>, out: &mut Soa<R>, y: &mut [Vec<R>; 3]) {
    spring_product(cg, out, y)
}

/// `Σ_{i in body b} g_i · p_i` per body (the gas's rank-one term), in particle order.
fn body_dots_soa<R: Real>(m: &Model<R>, g: &[R::V], p: &Soa<R>, out: &mut Vec<R>) {
    out.clear();
    out.resize(m.body_count(), R::ZERO);
    for (i, gi) in g.iter().enumerate() {
        let b = m.particle_body[i];
        if b != NONE && m.body_gas_amount[b as usize] > R::ZERO {
            out[b as usize] += gi.dot(p.get(i));
        }
    }
}
