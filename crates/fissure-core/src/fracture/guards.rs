//! Guards that keep a model sound through a storm of splits: the stiffness cap (the explicit step the model
//! started with stays stable), new nodes moved out of colliders, and each body's wave-crossing time (how long a
//! body waits before it starts another crack).

use super::*;

impl<R: Real> Fracture<R> {
    /// Moves the particles this step's splits made out of the colliders: a node placed on the chord of a spring
    /// wrapped round a ball collider lies inside it (by up to `L² / 8R`).
    pub(super) fn clear_colliders(&self, m: &Model<R>, s: &mut State<R>) {
        if !m.has_colliders() {
            return;
        }
        for i in self.delta.old_counts[0]..m.particle_count() {
            for c in &m.colliders {
                let (x, v) = (s.particle_q[i].to_dvec3().as_vec3(), s.particle_qd[i].to_dvec3().as_vec3());
                if let Some((x, v)) = c.resolve(s.time, x, v) {
                    s.particle_q[i] = R::V::from_dvec3(x.as_dvec3());
                    s.particle_qd[i] = R::V::from_dvec3(v.as_dvec3());
                }
            }
        }
    }

    /// Caps the stiffness of every particle a split touched: where `Σ k / m` of its springs passed the highest
    /// of the model as first seen, all its springs are softened by the ratio (damping by its square root, so the
    /// damping ratio stays). A split makes light virtual nodes held by springs as stiff as the one that broke;
    /// each spring keeps its own frequency ([`crate::model::edit`]'s `add_spring`), but a node held by two or
    /// three of them oscillates faster than any particle did, and a crack of many splits would pull the stable
    /// time step down with it. With the cap, the explicit integrators stay stable at the step the model started
    /// with (the damaged material at a crack's edge is a little softer).
    pub(super) fn soften(&mut self, m: &mut Model<R>) {
        if self.stiff_cap <= 0.0 {
            return;
        }
        let old_springs = self.delta.old_counts[1] as u32;
        for k in 0..self.touched_list.len() {
            let v = self.touched_list[k] as usize;
            if m.particle_inv_mass[v] == R::ZERO {
                continue;
            }
            let w2 = stiffness_sum(m, v) / m.particle_mass[v].to_f64();
            if w2 <= self.stiff_cap {
                continue;
            }
            let scale = self.stiff_cap / w2;
            for j in 0..m.particle_springs.row(v).len() {
                let sp = (m.particle_springs.row(v)[j] >> 1) as usize;
                m.spring_stiffness[sp] *= R::from_f64(scale);
                m.spring_damping[sp] *= R::from_f64(scale.sqrt());
                if (sp as u32) < old_springs {
                    self.delta.springs.push(sp as u32);
                }
            }
        }
    }
}

/// `Σ k` \[N/m\] of particle `i`'s springs.
pub(super) fn stiffness_sum<R: Real>(m: &Model<R>, i: usize) -> f64 {
    m.particle_springs.row(i).iter().map(|&e| m.spring_stiffness[(e >> 1) as usize].to_f64()).sum()
}

/// Each body's wave-crossing time \[s\]: its rest extent (bounding-box diagonal) over `c = sqrt(k / ρ_A)`, `k`
/// the mean stiffness of its edge springs, `ρ_A` its mass over its rest area (0 for a body without either).
pub(super) fn crossing_times<R: Real>(m: &Model<R>) -> Vec<f64> {
    let nb = m.body_count();
    let (mut lo, mut hi) = (vec![DVec3::splat(f64::MAX); nb], vec![DVec3::splat(f64::MIN); nb]);
    let mut mass = vec![0.0; nb];
    for i in 0..m.particle_count() {
        let b = m.particle_body[i] as usize;
        if b < nb {
            let x = m.particle_q0[i].to_dvec3();
            lo[b] = lo[b].min(x);
            hi[b] = hi[b].max(x);
            mass[b] += m.particle_mass[i].to_f64();
        }
    }
    let mut area = vec![0.0; nb];
    for (t, tri) in m.tri_indices.iter().enumerate() {
        let [a, b, c] = tri.map(|v| m.particle_q0[v as usize].to_dvec3());
        area[m.tri_body[t] as usize] += 0.5 * (b - a).cross(c - a).length();
    }
    let mut k = vec![(0.0, 0usize); nb];
    for (sp, &[i, _]) in m.spring_indices.iter().enumerate() {
        let b = m.particle_body[i as usize] as usize;
        if b < nb && m.spring_kind[sp] == SpringKind::Edge {
            k[b].0 += m.spring_stiffness[sp].to_f64();
            k[b].1 += 1;
        }
    }
    (0..nb)
        .map(|b| {
            if k[b].1 == 0 || mass[b] <= 0.0 || area[b] <= 0.0 {
                return 0.0;
            }
            let c = (k[b].0 / k[b].1 as f64 / (mass[b] / area[b])).sqrt();
            (hi[b] - lo[b]).length() / c
        })
        .collect()
}
