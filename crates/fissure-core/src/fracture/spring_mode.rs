//! Spring mode (seed Fig. 2): an over-stretched spring splits into two virtual nodes and a crack opens across it.

use super::*;
use crate::model::edit::*;

impl<R: Real> Fracture<R> {
    /// Spring mode on spring `sp`; false if it cannot split (already broken, too short, no mass to share).
    pub(super) fn split_spring(
        &mut self,
        m: &mut Model<R>,
        s: &mut State<R>,
        sp: u32,
        events: &mut Vec<FractureEvent>,
    ) -> bool {
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
}
