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
    /// Force on spring end 0 (end 1 gets the negative) [N].
    pub spring_f: Vec<R::V>,
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
}

impl<R: Real> ForceScratch<R> {
    pub fn resize(&mut self, m: &Model<R>) {
        self.spring_f.resize(m.spring_count(), R::V::ZERO);
        let surface = m.has_pressure() || m.has_wind();
        let nt = if surface { m.tri_count() } else { 0 };
        self.tri_cross.resize(nt, R::V::ZERO);
        self.tri_f.resize(nt, R::V::ZERO);
        self.body_volume.resize(m.body_count(), R::ZERO);
        self.body_pressure.resize(m.body_count(), R::ZERO);
        self.vol_partials.resize(nt.div_ceil(par::CHUNK).max(1) * m.body_count(), R::ZERO);
    }

    /// Spring forces into `spring_f`.
    pub fn springs(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        match m.damping_model {
            DampingModel::Projected => spring_pass::<R, true>(m, q, qd, &mut self.spring_f),
            DampingModel::Unprojected => spring_pass::<R, false>(m, q, qd, &mut self.spring_f),
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
            let v = (0..partial_rows).fold(R::ZERO, |acc, r| acc + vp[r * nb + b]) * sixth;
            self.body_volume[b] = v;
            let gas = m.body_gas_amount[b];
            self.body_pressure[b] = if gas > R::ZERO {
                let vmin = m.body_rest_volume[b] * R::from_f64(1e-3);
                gas / v.max(vmin) - m.body_pressure_external[b]
            } else {
                R::ZERO
            };
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

fn spring_pass<R: Real, const PROJECTED: bool>(m: &Model<R>, q: &[R::V], qd: &[R::V], out: &mut [R::V]) {
    let idx = &m.spring_indices[..out.len()];
    let rest = &m.spring_rest_length[..out.len()];
    let ks = &m.spring_stiffness[..out.len()];
    let kd = &m.spring_damping[..out.len()];
    par::chunks(out, |start, chunk| {
        let end = start + chunk.len();
        let (idx, rest, ks, kd) = (&idx[start..end], &rest[start..end], &ks[start..end], &kd[start..end]);
        for (k, f) in chunk.iter_mut().enumerate() {
            let [i, j] = idx[k];
            let (i, j) = (i as usize, j as usize);
            let d = q[j] - q[i];
            let dv = qd[j] - qd[i];
            let l2 = d.length_squared();
            if l2 > R::ZERO {
                let l = l2.sqrt();
                let u = d * (R::ONE / l);
                *f = if PROJECTED {
                    u * (ks[k] * (l - rest[k]) + kd[k] * dv.dot(u))
                } else {
                    u * (ks[k] * (l - rest[k])) + dv * kd[k]
                };
            } else {
                // Coincident ends: no direction, no elastic force.
                *f = if PROJECTED { R::V::ZERO } else { dv * kd[k] };
            }
        }
    });
}

/// Net force on particle `i` [N]: gravity, then its springs and triangles in CSR order.
#[inline(always)]
pub(crate) fn particle_force<R: Real>(m: &Model<R>, s: &ForceScratch<R>, surface: bool, i: usize) -> R::V {
    let mut f = m.gravity * m.particle_mass[i];
    for &e in m.particle_springs.row(i) {
        let v = s.spring_f[(e >> 1) as usize];
        if e & 1 == 0 {
            f += v;
        } else {
            f -= v;
        }
    }
    if surface {
        for &t in m.particle_tris.row(i) {
            f += s.tri_f[t as usize];
        }
    }
    f
}
