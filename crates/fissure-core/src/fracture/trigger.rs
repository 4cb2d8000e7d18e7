//! The trigger scan: which springs are past their strain limit and which vertices past their load limit,
//! instantaneous or averaged over a window (Bao et al. 2007), worst first.

use super::*;
use crate::forces::{pressure, spring};
use crate::par;

impl<R: Real> Fracture<R> {
    /// Candidates, sorted worst first: `(value / limit, 0 spring | 1 vertex, index)`.
    pub(super) fn scan(&mut self, m: &Model<R>, s: &State<R>, dt: f64) {
        self.candidates.clear();
        let alpha = alpha(self.config.trigger, dt);
        let q = &s.particle_q;
        let ns = m.spring_count();
        self.spring_avg.resize(ns, R::ZERO);
        // Every spring's strain in one data-parallel sweep (fixed chunks: the same bits on any thread count),
        // then, for the instantaneous trigger, the branch-free check whether any passes its limit at all.
        self.strain.resize(ns, R::ZERO);
        if m.spring_runs.is_empty() {
            par::chunks(&mut self.strain, |start, out| {
                for (k, e) in out.iter_mut().enumerate() {
                    let sp = start + k;
                    let [i, j] = m.spring_indices[sp];
                    *e = spring::strain((q[j as usize] - q[i as usize]).length(), m.spring_rest_length[sp]);
                }
            });
        } else {
            strains_by_runs(m, q, &mut self.strain);
        }
        spring_candidates(m, &self.strain, &mut self.spring_avg, alpha, &mut self.candidates);
        let n = m.particle_count();
        self.particle_avg.resize(n, R::ZERO);
        if m.particle_load_limit.iter().any(|l| l.is_finite()) {
            // The load: |net elastic force| on the particle, its springs' `ks (l - L0) d̂` and its share of the gas
            // pressure. Each spring's and each triangle's term once, then per particle the sum over its rows.
            // Element-wise passes over fixed chunks (par): the same bits on any thread count.
            self.spring_force.resize(m.spring_count(), DVec3::ZERO);
            par::chunks(&mut self.spring_force, |start, out| {
                for (k, f) in out.iter_mut().enumerate() {
                    let sp = start + k;
                    let [i, j] = m.spring_indices[sp];
                    let d = q[j as usize].to_dvec3() - q[i as usize].to_dvec3();
                    let (rest, ks) = (m.spring_rest_length[sp].to_f64(), m.spring_stiffness[sp].to_f64());
                    *f = spring::elastic_force::<f64>(d, rest, ks);
                }
            });
            self.tri_force.clear();
            if m.has_pressure() {
                let pressures = self.pressures(m, s);
                self.tri_force.resize(m.tri_count(), DVec3::ZERO);
                par::chunks(&mut self.tri_force, |start, out| {
                    for (k, f) in out.iter_mut().enumerate() {
                        let t = start + k;
                        let p = pressures[m.tri_body[t] as usize];
                        *f = if p == 0.0 {
                            DVec3::ZERO
                        } else {
                            let [a, b, c] = m.tri_indices[t].map(|v| q[v as usize].to_dvec3());
                            pressure::corner_force::<f64>((b - a).cross(c - a), p)
                        };
                    }
                });
            }
            let mut load = std::mem::take(&mut self.load);
            load.resize(n, R::ZERO);
            let (springs, tris) = (&self.spring_force, &self.tri_force);
            par::chunks(&mut load, |start, out| {
                for (k, l) in out.iter_mut().enumerate() {
                    let i = start + k;
                    if !m.particle_load_limit[i].is_finite() || m.particle_inv_mass[i] == R::ZERO {
                        *l = R::ZERO;
                        continue;
                    }
                    let mut f = crate::forces::spring_gather::<f64>(DVec3::ZERO, m.particle_springs.row(i), springs);
                    if !tris.is_empty() {
                        for &t in m.particle_tris.row(i) {
                            f += tris[t as usize];
                        }
                    }
                    *l = R::from_f64(f.length());
                }
            });
            particle_candidates(m, &load, &mut self.particle_avg, alpha, &mut self.candidates);
            self.load = load;
        }
        self.candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    }

    /// The scan on a solver's [`Measures`]: the same limits, averages and order as [`Fracture::scan`], with
    /// nothing recomputed.
    pub(super) fn scan_measured(&mut self, m: &Model<R>, x: &Measures<'_, R>, dt: f64) {
        self.candidates.clear();
        let alpha = alpha(self.config.trigger, dt);
        let ns = m.spring_count();
        self.spring_avg.resize(ns, R::ZERO);
        match x.strain_spans {
            // Instantaneous (`apply_measured` passes sparse measures for no other trigger): only the stored spans
            // can hold a strain past its limit.
            Some(spans) => {
                for &[a, b] in spans {
                    let (a, b) = (a as usize, b as usize);
                    let (strain, limits) = (&x.strain[a..b], &m.spring_strain_limit[a..b]);
                    for (k, (&v, &lim)) in strain.iter().zip(limits).enumerate() {
                        if lim.is_finite() && v > lim && m.spring_kind[a + k] != SpringKind::Broken {
                            self.candidates.push(((v / lim).to_f64(), 0, (a + k) as u32));
                        }
                    }
                }
            }
            None => spring_candidates(m, x.strain, &mut self.spring_avg, alpha, &mut self.candidates),
        }
        self.particle_avg.resize(m.particle_count(), R::ZERO);
        particle_candidates(m, x.load, &mut self.particle_avg, alpha, &mut self.candidates);
        self.candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    }

    /// Net gas pressure of each body \[Pa\] (capped volumes, volumes computed at most once per call of
    /// [`Fracture::apply`]).
    pub(super) fn pressures(&mut self, m: &Model<R>, s: &State<R>) -> Vec<f64> {
        if self.volumes.len() != m.body_count() {
            self.volumes = m.body_volumes(s);
        }
        (0..m.body_count())
            .map(|b| {
                let (gas, v0, ext) = (m.body_gas_amount[b], m.body_rest_volume[b], m.body_pressure_external[b]);
                pressure::gas_pressure(gas.to_f64(), self.volumes[b], v0.to_f64(), ext.to_f64())
            })
            .collect()
    }
}

/// Every spring's strain, walking a model's runs (grid cloths the solver did not measure: with load limits, or
/// stepped by another solver):
/// both ends of a run's springs are contiguous slices, so no index is read and the spans' lengths, square roots
/// and divisions vectorise. The same bits as the per-spring loop: `d = qj - qi`, `|d| = √(dx² + dy² + dz²)` summed
/// in that order (as `length`), then [`spring::strain`]. On the 128² cloth (harness `terms`, 2026-11-24): the fracture
/// stage 177 → 98–101 µs per step.
fn strains_by_runs<R: Real>(m: &Model<R>, q: &[R::V], out: &mut [R]) {
    const SPAN: usize = 64;
    let runs = &m.spring_runs;
    par::chunks(out, |start, out| {
        let end = start + out.len();
        let mut d = [[R::ZERO; SPAN]; 3];
        let mut r = runs.partition_point(|r| (r.first + r.len) as usize <= start);
        while r < runs.len() && (runs[r].first as usize) < end {
            let run = runs[r];
            let (first, i0, j0) = (run.first as usize, run.i as usize, run.j as usize);
            let (mut s0, hi) = (start.max(first), end.min(first + run.len as usize));
            while s0 < hi {
                let n = (hi - s0).min(SPAN);
                let k0 = s0 - first;
                let (qi, qj) = (&q[i0 + k0..i0 + k0 + n], &q[j0 + k0..j0 + k0 + n]);
                for k in 0..n {
                    [d[0][k], d[1][k], d[2][k]] = (qj[k] - qi[k]).to_array();
                }
                let (rest, o) = (&m.spring_rest_length[s0..s0 + n], &mut out[s0 - start..s0 - start + n]);
                let [dx, dy, dz] = &d;
                for k in 0..n {
                    let l = (dx[k] * dx[k] + dy[k] * dy[k] + dz[k] * dz[k]).sqrt();
                    o[k] = spring::strain(l, rest[k]);
                }
                s0 += n;
            }
            r += 1;
        }
    });
}

/// Appends `(strain / limit, 0, spring)` for every unbroken spring whose (averaged) strain passes its limit.
fn spring_candidates<R: Real>(m: &Model<R>, strain: &[R], avg: &mut [R], alpha: f64, out: &mut Vec<(f64, u8, u32)>) {
    let skip = |sp: usize| m.spring_kind[sp] == SpringKind::Broken;
    candidates(strain, &m.spring_strain_limit, avg, alpha, 0, skip, out);
}

/// Appends `(load / limit, 1, particle)` for every free particle whose (averaged) load passes its limit.
fn particle_candidates<R: Real>(m: &Model<R>, load: &[R], avg: &mut [R], alpha: f64, out: &mut Vec<(f64, u8, u32)>) {
    let skip = |i: usize| m.particle_inv_mass[i] == R::ZERO;
    candidates(load, &m.particle_load_limit, avg, alpha, 1, skip, out);
}

/// Appends `(value / limit, kind, k)` for every `k` with a finite limit, not skipped, whose (averaged) value passes
/// it. One branch-free sweep (it vectorises) first finds whether any value passes at all, the usual answer being
/// no; the averaged trigger's sweep also updates every average (all of them, at every step).
fn candidates<R: Real>(
    values: &[R],
    limits: &[R],
    avg: &mut [R],
    alpha: f64,
    kind: u8,
    skip: impl Fn(usize) -> bool,
    out: &mut Vec<(f64, u8, u32)>,
) {
    let listed: &[R] = if alpha >= 1.0 {
        if !any_over(values, limits) {
            return;
        }
        values
    } else {
        let a = R::from_f64(alpha);
        let mut any = false;
        for (k, (g, (&x, &lim))) in avg.iter_mut().zip(values.iter().zip(limits)).enumerate() {
            let live = lim.is_finite() & !skip(k);
            let next = *g + (x - *g) * a;
            *g = if live { next } else { *g };
            any |= live & (next > lim);
        }
        if !any {
            return;
        }
        avg
    };
    for (k, &v) in listed.iter().enumerate() {
        let lim = limits[k];
        if lim.is_finite() && !skip(k) && v > lim {
            out.push(((v / lim).to_f64(), kind, k as u32));
        }
    }
}

/// Whether `values[k] > limits[k]` for any `k` (an infinite limit is never passed).
fn any_over<R: Real>(values: &[R], limits: &[R]) -> bool {
    values.chunks(256).zip(limits.chunks(256)).any(|(v, l)| v.iter().zip(l).fold(false, |acc, (v, l)| acc | (*v > *l)))
}

/// The moving average's weight of a new sample after `dt` \[s\] (1: instantaneous).
fn alpha(trigger: Trigger, dt: f64) -> f64 {
    match trigger {
        Trigger::Instant => 1.0,
        Trigger::Averaged { window } => 1.0 - (-dt / window.max(1e-12)).exp(),
    }
}
