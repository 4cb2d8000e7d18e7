//! Core mode (seed Fig. 3): an over-loaded vertex splits and a core block breaks away, leaving a hole.

use super::*;
use crate::model::edit::*;

impl<R: Real> Fracture<R> {
    /// Core mode on vertex `v`; false if it cannot (touched this step, on a boundary, pinned, odd valence).
    pub(super) fn split_core(
        &mut self,
        m: &mut Model<R>,
        s: &mut State<R>,
        v: u32,
        events: &mut Vec<FractureEvent>,
    ) -> bool {
        let vu = v as usize;
        if self.was_touched(v) || m.particle_inv_mass[vu] == R::ZERO {
            return false;
        }
        let fans = fans(m, v);
        if fans.len() != 1 || !fans[0].1 {
            return false;
        }
        let ring = &fans[0].0;
        let k = ring.len();
        if !(3..=64).contains(&k) {
            return false;
        }
        // A vertex next to an opening is a crack tip: it tears in spring mode. Its load is dominated by the
        // opening's rim (the cap's push, the missing hoop tension), and breaking it out as a core would eat the
        // surface hole by hole.
        if ring.iter().any(|&(_, x, _)| boundary_next(m, x).is_some()) {
            return false;
        }
        // p_i and the springs v–p_i.
        let p: Vec<u32> = ring.iter().map(|&(_, x, _)| x).collect();
        let mut sv = Vec::with_capacity(k);
        for &pi in &p {
            match spring_between(m, v, pi) {
                Some(sp) => sv.push(sp),
                None => return false,
            }
        }
        let Some((rest_v, part)) = split_mass(m.particle_mass[vu], 1.0 / (2 * k + 1) as f64, 2 * k) else {
            return false;
        };
        if !self.heavy_enough(part) || !self.heavy_enough(rest_v) {
            return false;
        }
        // The rest one-ring unfolded flat: P_i at angle phi_i, distance L_i; Q_i halfway to face i's far edge.
        let li: Vec<f64> = sv.iter().map(|&sp| m.spring_rest_length[sp as usize].to_f64()).collect();
        let mut phi = vec![0.0f64; k + 1];
        for i in 0..k {
            let (l1, l2) = (li[i], li[(i + 1) % k]);
            let e = rest_between(m, s, p[i], p[(i + 1) % k]);
            let c = ((l1 * l1 + l2 * l2 - e * e) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
            phi[i + 1] = phi[i] + c.acos();
        }
        let pt = |i: usize| DVec2::from_angle(phi[i]) * li[i % k];
        let qs: Vec<DVec2> = (0..k).map(|i| (pt(i) + pt(i + 1)) * 0.25).collect();
        // Q_{i-1} in face i's frame: face k-1 is rotated by -phi_k to meet face 0 across v–p_0.
        let prev_q = |i: usize| if i == 0 { DVec2::from_angle(-phi[k]).rotate(qs[k - 1]) } else { qs[i - 1] };
        let ks = sv.iter().fold(R::ZERO, |acc, &sp| acc + m.spring_stiffness[sp as usize]) / R::from_f64(k as f64);
        let kd = sv.iter().fold(R::ZERO, |acc, &sp| acc + m.spring_damping[sp as usize]) / R::from_f64(k as f64);
        let lim = m.spring_strain_limit[sv[0] as usize];
        let red = reduced(m.particle_mass[vu], m.particle_mass[p[0] as usize]);
        let kd = (kd, red);
        let xv = s.particle_q[vu];
        let vv = s.particle_qd[vu];
        let body = m.particle_body[vu];
        let half = R::from_f64(0.5);
        let mut d = Vec::with_capacity(k);
        let mut c = Vec::with_capacity(k);
        for i in 0..k {
            let far = (s.particle_q[p[i] as usize] + s.particle_q[p[(i + 1) % k] as usize]) * half;
            let x = xv + (far - xv) * half;
            d.push(add_particle(m, s, x, vv, part, R::ONE / part, body, vu));
        }
        let core_body = new_body(m, body, v);
        for i in 0..k {
            let x = s.particle_q[d[i] as usize];
            let ci = add_particle(m, s, x, vv, part, R::ONE / part, core_body, vu);
            m.particle_load_limit[ci as usize] = R::infinity();
            c.push(ci);
        }
        m.particle_body[vu] = core_body;
        m.particle_load_limit[vu] = R::infinity();
        m.body_anchor[core_body as usize] = v;
        if m.body_anchor[body as usize] == v {
            m.body_anchor[body as usize] = d[0];
        }
        self.delta.particles.push(v);
        // The old spokes and any other spring of v (bending springs across its edges) go: the core is free.
        let spokes: Vec<u32> = m.particle_springs.row(vu).iter().map(|&e| e >> 1).collect();
        for sp in spokes {
            break_spring(m, sp);
            self.delta.springs.push(sp);
        }
        set_mass(m, vu, rest_v);
        for (i, &(t, _, _)) in ring.iter().enumerate() {
            let (pi, pn, dp) = (p[i], p[(i + 1) % k], d[(i + k - 1) % k]);
            set_tri(m, t, [d[i], pi, pn]);
            self.delta.triangles.push(t);
            add_tri(m, [pi, d[i], dp], body);
            add_tri(m, [v, c[(i + k - 1) % k], c[i]], core_body);
            let r = |x: f64| R::from_f64(x);
            let ring_len = (qs[i] - prev_q(i)).length();
            add_spring(m, d[i], pi, r((qs[i] - pt(i)).length()), ks, kd, lim);
            add_spring(m, d[i], pn, r((qs[i] - pt(i + 1)).length()), ks, kd, lim);
            add_spring(m, d[i], dp, r(ring_len), ks, kd, lim);
            add_spring(m, v, c[i], r(qs[i].length()), ks, kd, lim);
            add_spring(m, c[i], c[(i + k - 1) % k], r(ring_len), ks, kd, lim);
        }
        for &x in [v].iter().chain(&p).chain(&d).chain(&c) {
            self.touch(x);
        }
        events.push(FractureEvent {
            kind: FractureKind::Core,
            time: s.time,
            position: xv.to_dvec3(),
            body,
            spring: None,
            vertex: Some(v),
            new_particles: d.iter().chain(&c).copied().collect(),
            new_body: Some(core_body),
        });
        true
    }
}
