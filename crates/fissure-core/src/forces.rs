//! Force kernels: springs (seed eqs. 1–2), the closed pressure model (eqs. 6–9 in the consistent `∂V/∂x` form)
//! and wind, each a flat pass over springs or triangles writing one value per element; then a per-particle
//! gather over the CSR lists sums them. No locks, no atomics, one summation order: bit-identical results on any
//! number of threads.
//!
//! Pressure: `V = 1/6 Σ_t (x0 - c)·((x1 - c) × (x2 - c))` (taken about an anchor particle `c` of the body to limit
//! round-off; for a closed surface `V` does not depend on `c`), `P = nRT / V - P_ext`, and each corner of each
//! triangle receives `P (x1 - x0) × (x2 - x0) / 6 = P A n̂ / 3`: the seed's eq. (9) force, split equally. Summed
//! over a vertex's closed one-ring this equals `P ∂V/∂x_i` exactly, so the pressure force is conservative with
//! energy `-nRT ln V`, and its sum over a closed surface is exactly zero.

use crate::model::{DampingModel, Model};
use crate::par;
use crate::real::{Real, Vector3};

/// Reusable buffers of the force passes (allocated once per model size, never per step).
#[derive(Clone, Debug, Default)]
pub(crate) struct ForceScratch<R: Real> {
    /// Force on spring end 0 (end 1 gets the negative) [N] (irregular meshes).
    pub spring_f: Vec<R::V>,
    /// Sum of spring forces on each particle [N] (models made of spring runs).
    pub particle_spring: Vec<R::V>,
    /// Whether the run kernel is used (`particle_spring` holds the sums) or the gather (`spring_f`).
    pub runs: bool,
    /// `(x1 - x0) × (x2 - x0)` of each triangle [m^2].
    pub tri_cross: Vec<R::V>,
    /// Force on each corner of each triangle (pressure + wind share) [N].
    pub tri_f: Vec<R::V>,
    /// Per-chunk, per-body partial sums of `6 V`.
    pub vol_partials: Vec<R>,
    /// Volume of each body [m^3].
    pub body_volume: Vec<R>,
    /// Net pressure of each body [Pa].
    pub body_pressure: Vec<R>,
    /// `∂V/∂x` of the caps over the openings of gas bodies, per particle (empty without such openings) [m^2].
    pub cap_g: Vec<R::V>,
    /// Pressure force through the caps, per particle [N].
    pub cap_f: Vec<R::V>,
    /// Particles with a nonzero entry in `cap_g` / `cap_f`.
    pub cap_touched: Vec<u32>,
}

impl<R: Real> ForceScratch<R> {
    /// Sizes the buffers for `m`. `spring_buffer`: the per-spring buffer is needed even with the run kernel
    /// (the implicit solver reuses it for its matrix products).
    pub fn resize(&mut self, m: &Model<R>, spring_buffer: bool) {
        self.runs = m.springs_are_runs();
        let ns = if spring_buffer || !self.runs { m.spring_count() } else { 0 };
        self.spring_f.resize(ns, R::V::ZERO);
        self.particle_spring.resize(if self.runs { m.particle_count() } else { 0 }, R::V::ZERO);
        let surface = m.has_pressure() || m.has_wind();
        let nt = if surface { m.tri_count() } else { 0 };
        self.tri_cross.resize(nt, R::V::ZERO);
        self.tri_f.resize(nt, R::V::ZERO);
        self.body_volume.resize(m.body_count(), R::ZERO);
        self.body_pressure.resize(m.body_count(), R::ZERO);
        self.vol_partials.resize(nt.div_ceil(par::CHUNK).max(1) * m.body_count(), R::ZERO);
        let caps = m.has_pressure() && m.openings.iter().any(|o| m.body_gas_amount[o.body as usize] > R::ZERO);
        let nc = if caps { m.particle_count() } else { 0 };
        // Entries from an earlier model may be stale: clear what was written, then size.
        for &i in &self.cap_touched {
            if let (Some(g), Some(f)) = (self.cap_g.get_mut(i as usize), self.cap_f.get_mut(i as usize)) {
                *g = R::V::ZERO;
                *f = R::V::ZERO;
            }
        }
        self.cap_touched.clear();
        self.cap_g.resize(nc, R::V::ZERO);
        self.cap_f.resize(nc, R::V::ZERO);
    }

    /// Adds the caps over the openings of gas bodies: their volume to `body_volume` (as `6 V`, before the
    /// division) and their `∂V/∂x` to `cap_g`. A cap is the fan `(x_j, x_i, c)` over each loop edge `i -> j`
    /// from the loop's centroid `c`; `c`'s share of the gradient goes equally to the loop's particles.
    fn caps(&mut self, m: &Model<R>, q: &[R::V], vol6: &mut [R]) {
        for &i in &self.cap_touched {
            self.cap_g[i as usize] = R::V::ZERO;
        }
        self.cap_touched.clear();
        let sixth = R::from_f64(1.0 / 6.0);
        for o in &m.openings {
            let b = o.body as usize;
            if m.body_gas_amount[b] <= R::ZERO {
                continue;
            }
            let anchor = q[m.body_anchor[b] as usize];
            let n = o.vertices.len();
            let inv_n = R::ONE / R::from_f64(n as f64);
            let centre = o.vertices.iter().fold(R::V::ZERO, |acc, &i| acc + q[i as usize]) * inv_n;
            let mut centre_g = R::V::ZERO;
            for k in 0..n {
                let (i, j) = (o.vertices[k] as usize, o.vertices[(k + 1) % n] as usize);
                vol6[b] += (q[j] - anchor).dot((q[i] - anchor).cross(centre - anchor));
                let g = (q[i] - q[j]).cross(centre - q[j]) * sixth;
                self.cap_g[i] += g;
                self.cap_g[j] += g;
                centre_g += g;
            }
            for &i in &o.vertices {
                self.cap_g[i as usize] += centre_g * inv_n;
                self.cap_touched.push(i);
            }
        }
    }

    /// Spring forces: per particle into `particle_spring` (runs), else per spring into `spring_f`.
    pub fn springs(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        match (self.runs, m.damping_model) {
            (true, DampingModel::Projected) => run_pass::<R, true>(m, q, qd, &mut self.particle_spring),
            (true, DampingModel::Unprojected) => run_pass::<R, false>(m, q, qd, &mut self.particle_spring),
            (false, DampingModel::Projected) => spring_pass::<R, true>(m, q, qd, &mut self.spring_f),
            (false, DampingModel::Unprojected) => spring_pass::<R, false>(m, q, qd, &mut self.spring_f),
        }
    }

    /// Triangle pass: crosses, body volumes and pressures (if any gas), wind (if any), into `tri_f`.
    pub fn surface(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V], time: f64) {
        let nb = m.body_count();
        let pressure = m.has_pressure();
        // Pass A: crosses and per-chunk volume partials.
        let partial_rows = m.tri_count().div_ceil(par::CHUNK).max(1);
        let vp = &mut self.vol_partials[..partial_rows * nb];
        let body_anchor_q: &[u32] = &m.body_anchor;
        let cross_chunk = |start: usize, cross: &mut [R::V], part: &mut [R]| {
            part.iter_mut().for_each(|p| *p = R::ZERO);
            for (k, c) in cross.iter_mut().enumerate() {
                let t = start + k;
                let [a, b, d] = m.tri_indices[t];
                let (x0, x1, x2) = (q[a as usize], q[b as usize], q[d as usize]);
                *c = (x1 - x0).cross(x2 - x0);
                if pressure {
                    let body = m.tri_body[t] as usize;
                    if m.body_gas_amount[body] > R::ZERO {
                        let anchor = q[body_anchor_q[body] as usize];
                        part[body] += (x0 - anchor).dot(*c);
                    }
                }
            }
        };
        if m.tri_count() < par::PAR_MIN {
            for (c, (cross, part)) in self.tri_cross.chunks_mut(par::CHUNK).zip(vp.chunks_mut(nb)).enumerate() {
                cross_chunk(c * par::CHUNK, cross, part);
            }
        } else {
            use rayon::prelude::*;
            self.tri_cross
                .par_chunks_mut(par::CHUNK)
                .zip(vp.par_chunks_mut(nb))
                .enumerate()
                .for_each(|(c, (cross, part))| cross_chunk(c * par::CHUNK, cross, part));
        }
        let sixth = R::from_f64(1.0 / 6.0);
        for b in 0..nb {
            self.body_volume[b] = (0..partial_rows).fold(R::ZERO, |acc, r| acc + vp[r * nb + b]);
        }
        if !self.cap_g.is_empty() {
            let mut vol6 = std::mem::take(&mut self.body_volume);
            self.caps(m, q, &mut vol6);
            self.body_volume = vol6;
        }
        for b in 0..nb {
            let v = self.body_volume[b] * sixth;
            self.body_volume[b] = v;
            let gas = m.body_gas_amount[b];
            self.body_pressure[b] = if gas > R::ZERO {
                let vmin = m.body_rest_volume[b] * R::from_f64(1e-3);
                gas / v.max(vmin) - m.body_pressure_external[b]
            } else {
                R::ZERO
            };
        }
        for &i in &self.cap_touched {
            let i = i as usize;
            self.cap_f[i] = self.cap_g[i] * self.body_pressure[m.particle_body[i] as usize];
        }
        // Pass B: per-corner force of each triangle.
        let wind = if m.has_wind() { m.wind.as_ref() } else { None };
        let rho_half = R::from_f64(0.5 * wind.map_or(0.0, |w| w.air_density));
        let third = R::from_f64(1.0 / 3.0);
        let body_pressure = &self.body_pressure;
        let tri_cross = &self.tri_cross;
        par::chunks(&mut self.tri_f, |start, out| {
            for (k, f) in out.iter_mut().enumerate() {
                let t = start + k;
                let body = m.tri_body[t] as usize;
                let c = tri_cross[t];
                let mut force = c * (body_pressure[body] * sixth);
                if let Some(w) = wind {
                    let (cd, cl) = (m.body_drag[body], m.body_lift[body]);
                    if cd != R::ZERO || cl != R::ZERO {
                        let [a, b, d] = m.tri_indices[t];
                        let centroid = (q[a as usize] + q[b as usize] + q[d as usize]) * third;
                        let vel = (qd[a as usize] + qd[b as usize] + qd[d as usize]) * third;
                        let air = R::V::from_dvec3(w.sample(centroid.to_dvec3(), time));
                        force += aero_force(c, air - vel, cd, cl, rho_half) * third;
                    }
                }
                *f = force;
            }
        });
    }
}

/// Drag and lift on a triangle with cross vector `c = 2 A n̂`, in relative air velocity `v`.
#[inline]
pub(crate) fn aero_force<R: Real>(c: R::V, v: R::V, cd: R, cl: R, rho_half: R) -> R::V {
    let c_len = c.length();
    let speed = v.length();
    if c_len <= R::ZERO || speed <= R::ZERO {
        return R::V::ZERO;
    }
    let area = c_len * R::from_f64(0.5);
    let mut n = c / c_len;
    let mut vn = n.dot(v);
    if vn < R::ZERO {
        n = -n;
        vn = -vn;
    }
    let drag = v * (rho_half * cd * area * vn);
    let lift = (n * speed - v * (vn / speed)) * (rho_half * cl * area * vn);
    drag + lift
}

/// One spring's force on its end 0 (branch-free, so span loops vectorise).
#[inline(always)]
fn spring_force<R: Real, const PROJECTED: bool>(d: R::V, dv: R::V, rest: R, ks: R, kd: R) -> R::V {
    let l2 = d.length_squared();
    let l = l2.sqrt();
    // Coincident ends have no direction and no elastic force.
    let inv = if l2 > R::ZERO { R::ONE / l } else { R::ZERO };
    let u = d * inv;
    if PROJECTED { u * (ks * (l - rest) + kd * dv.dot(u)) } else { u * (ks * (l - rest)) + dv * kd }
}

fn spring_pass<R: Real, const PROJECTED: bool>(m: &Model<R>, q: &[R::V], qd: &[R::V], out: &mut [R::V]) {
    let n = out.len();
    let (idx, rest, ks, kd) =
        (&m.spring_indices[..n], &m.spring_rest_length[..n], &m.spring_stiffness[..n], &m.spring_damping[..n]);
    par::chunks(out, |start, chunk| {
        let end = start + chunk.len();
        let (idx, rest, ks, kd) = (&idx[start..end], &rest[start..end], &ks[start..end], &kd[start..end]);
        for (k, f) in chunk.iter_mut().enumerate() {
            let [i, j] = idx[k];
            let (i, j) = (i as usize, j as usize);
            *f = spring_force::<R, PROJECTED>(q[j] - q[i], qd[j] - qd[i], rest[k], ks[k], kd[k]);
        }
    });
}

/// Springs computed per span of a run at a time.
const SPAN: usize = 64;

/// Per-component stack arrays of [`span_forces`], created once per block and reused by every span.
struct SpanScratch<R: Real> {
    d: [[R; SPAN]; 3],
    w: [[R; SPAN]; 3],
    p: [[R; SPAN]; 3],
    f: [[R; SPAN]; 3],
}

impl<R: Real> SpanScratch<R> {
    fn new() -> Self {
        let z = [[R::ZERO; SPAN]; 3];
        SpanScratch { d: z, w: z, p: z, f: z }
    }
}

/// Forces of a span of springs with contiguous ends. The positions arrive as 3-vectors (array of structs), which
/// no compiler vectorises well; they are transposed into per-component arrays, the maths runs on those (plain
/// loops over `[R; SPAN]` that LLVM turns into packed code, square roots and divisions included), and the
/// result is transposed back. Lanes past `out.len()` hold stale values from an earlier span: computed, never
/// used. Same operations in the same order as [`spring_force`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn span_forces<R: Real, const PROJECTED: bool>(
    t: &mut SpanScratch<R>,
    qi: &[R::V],
    qj: &[R::V],
    vi: &[R::V],
    vj: &[R::V],
    rest: &[R],
    ks: &[R],
    kd: &[R],
    out: &mut [R::V],
) {
    let n = out.len();
    let (qi, qj, vi, vj, rest, ks, kd) = (&qi[..n], &qj[..n], &vi[..n], &vj[..n], &rest[..n], &ks[..n], &kd[..n]);
    for k in 0..n {
        let [a, b, c] = (qj[k] - qi[k]).to_array();
        let [e, f, g] = (vj[k] - vi[k]).to_array();
        (t.d[0][k], t.d[1][k], t.d[2][k]) = (a, b, c);
        (t.w[0][k], t.w[1][k], t.w[2][k]) = (e, f, g);
        (t.p[0][k], t.p[1][k], t.p[2][k]) = (rest[k], ks[k], kd[k]);
    }
    let z = R::ZERO;
    let ([dx, dy, dz], [wx, wy, wz], [r, s, d]) = (&t.d, &t.w, &t.p);
    let [fx, fy, fz] = &mut t.f;
    for k in 0..SPAN {
        let l2 = dx[k] * dx[k] + dy[k] * dy[k] + dz[k] * dz[k];
        let l = l2.sqrt();
        let inv = if l2 > z { R::ONE / l } else { z };
        let (ux, uy, uz) = (dx[k] * inv, dy[k] * inv, dz[k] * inv);
        if PROJECTED {
            let mag = s[k] * (l - r[k]) + d[k] * (wx[k] * ux + wy[k] * uy + wz[k] * uz);
            fx[k] = ux * mag;
            fy[k] = uy * mag;
            fz[k] = uz * mag;
        } else {
            let mag = s[k] * (l - r[k]);
            fx[k] = ux * mag + wx[k] * d[k];
            fy[k] = uy * mag + wy[k] * d[k];
            fz[k] = uz * mag + wz[k] * d[k];
        }
    }
    for k in 0..n {
        out[k] = R::V::new(fx[k], fy[k], fz[k]);
    }
}

/// Spring forces summed per particle, for models made of [`crate::model::SpringRun`]s. Each fixed block of
/// particles walks every run, computes the springs with an end in the block on contiguous slices (a span of up to
/// 64 at a time, vectorised), and adds them to the block's particles: `+f` on end 0, `-f` on end 1. A spring
/// with its ends in two blocks is computed by both. The order of additions per particle is fixed by the run order
/// and the fixed block size, never by the thread count.
fn run_pass<R: Real, const PROJECTED: bool>(m: &Model<R>, q: &[R::V], qd: &[R::V], out: &mut [R::V]) {
    par::chunks(out, |p0, block| run_block_dispatch::<R, PROJECTED>(m, q, qd, p0, block));
}

/// [`run_block`] compiled for AVX2 when the CPU has it (detected once, cached by std), else for the baseline.
/// Packed square roots and divisions are correctly rounded like the scalar ones and Rust never fuses
/// multiply-adds on its own, so both versions give the same bits.
#[inline]
pub(crate) fn run_block_dispatch<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { run_block_avx2::<R, PROJECTED>(m, q, qd, p0, block) };
            return;
        }
    }
    run_block::<R, PROJECTED>(m, q, qd, p0, block)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_block_avx2<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
) {
    run_block::<R, PROJECTED>(m, q, qd, p0, block)
}

/// Spring-force sums of particles `p0 .. p0 + block.len()` into `block`.
#[inline(always)]
fn run_block<R: Real, const PROJECTED: bool>(m: &Model<R>, q: &[R::V], qd: &[R::V], p0: usize, block: &mut [R::V]) {
    let (rest, ks, kd) = (&m.spring_rest_length[..], &m.spring_stiffness[..], &m.spring_damping[..]);
    let p1 = p0 + block.len();
    block.iter_mut().for_each(|f| *f = R::V::ZERO);
    let mut buf = [R::V::ZERO; SPAN];
    let mut scratch = SpanScratch::<R>::new();
    for r in &m.spring_runs {
        let (i0, j0, len, s0) = (r.i as usize, r.j as usize, r.len as usize, r.first as usize);
        // Spring indices k of this run with end 0 (a) or end 1 (b) in the block.
        let (a0, a1) = (p0.saturating_sub(i0).min(len), p1.saturating_sub(i0).min(len));
        let (b0, b1) = (p0.saturating_sub(j0).min(len), p1.saturating_sub(j0).min(len));
        let ranges: [(usize, usize); 2] = if a0 < a1 && b0 < b1 && a0.max(b0) <= a1.min(b1) {
            [(a0.min(b0), a1.max(b1)), (0, 0)]
        } else {
            [(a0, a1), (b0, b1)]
        };
        for (lo, hi) in ranges {
            let mut k0 = lo;
            while k0 < hi {
                let k1 = (k0 + SPAN).min(hi);
                let n = k1 - k0;
                let (qi, qj) = (&q[i0 + k0..i0 + k1], &q[j0 + k0..j0 + k1]);
                let (vi, vj) = (&qd[i0 + k0..i0 + k1], &qd[j0 + k0..j0 + k1]);
                let (rs, kss, kds) = (&rest[s0 + k0..s0 + k1], &ks[s0 + k0..s0 + k1], &kd[s0 + k0..s0 + k1]);
                span_forces::<R, PROJECTED>(&mut scratch, qi, qj, vi, vj, rs, kss, kds, &mut buf[..n]);
                // End 0 of springs k in [max(k0, a0), min(k1, a1)) lies in the block: add.
                let (c0, c1) = (k0.max(a0), k1.min(a1));
                if c0 < c1 {
                    let dst = &mut block[i0 + c0 - p0..i0 + c1 - p0];
                    for (d, f) in dst.iter_mut().zip(&buf[c0 - k0..c1 - k0]) {
                        *d += *f;
                    }
                }
                let (c0, c1) = (k0.max(b0), k1.min(b1));
                if c0 < c1 {
                    let dst = &mut block[j0 + c0 - p0..j0 + c1 - p0];
                    for (d, f) in dst.iter_mut().zip(&buf[c0 - k0..c1 - k0]) {
                        *d -= *f;
                    }
                }
                k0 = k1;
            }
        }
    }
}

/// Net force on particle `i` [N]: gravity, then its springs and triangles in CSR order.
#[inline(always)]
pub(crate) fn particle_force<R: Real>(m: &Model<R>, s: &ForceScratch<R>, surface: bool, i: usize) -> R::V {
    let mut f = m.gravity * m.particle_mass[i];
    if s.runs {
        f += s.particle_spring[i];
    } else {
        for &e in m.particle_springs.row(i) {
            let v = s.spring_f[(e >> 1) as usize];
            if e & 1 == 0 {
                f += v;
            } else {
                f -= v;
            }
        }
    }
    if surface {
        for &t in m.particle_tris.row(i) {
            f += s.tri_f[t as usize];
        }
        if !s.cap_f.is_empty() {
            f += s.cap_f[i];
        }
    }
    f
}
