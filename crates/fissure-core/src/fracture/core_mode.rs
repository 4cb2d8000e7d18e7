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
        // Each p_i gives the block the share of its mass its two fan triangles lumped on it, and keeps a
        // triangle of its own outside the fan (else the surface would lose it).
        let area = |t: u32| tri_area_now(m, s, t);
        let mut shares = Vec::with_capacity(k);
        for (i, &pi) in p.iter().enumerate() {
            let piu = pi as usize;
            if self.was_touched(pi) || m.particle_inv_mass[piu] == R::ZERO || m.particle_tris.row(piu).len() <= 2 {
                return false;
            }
            let all: f64 = m.particle_tris.row(piu).iter().map(|&t| area(t)).sum();
            let fan = area(ring[i].0) + area(ring[(i + k - 1) % k].0);
            let frac = if all > 0.0 { (fan / all).clamp(1.0 / 16.0, 0.5) } else { 0.25 };
            match split_mass(m.particle_mass[piu], frac, 1) {
                Some((rest, part)) if self.heavy_enough(rest) && self.heavy_enough(part) => shares.push((rest, part)),
                _ => return false,
            }
        }
        let body = m.particle_body[vu];
        let core_body = new_body(m, body, v);
        // The block's copies of the ring, where the ring is and moving with it (momentum is kept exactly).
        let c: Vec<u32> = (0..k)
            .map(|i| {
                let (x, u, part) = (s.particle_q[p[i] as usize], s.particle_qd[p[i] as usize], shares[i].1);
                let ci = add_particle(m, s, x, u, part, R::ONE / part, core_body, p[i] as usize);
                m.particle_load_limit[ci as usize] = R::infinity();
                ci
            })
            .collect();
        m.particle_body[vu] = core_body;
        m.particle_load_limit[vu] = R::infinity();
        m.body_anchor[core_body as usize] = v;
        if m.body_anchor[body as usize] == v {
            m.body_anchor[body as usize] = p[0];
        }
        self.delta.particles.push(v);
        // The springs of the fan go with the block: the spokes v–p_i become v–c_i (each moves its end, keeping its
        // place in the model: a broken spring left behind would still cost the spring pass its work every step),
        // each ring edge p_i–p_{i+1} (the rim of the hole, kept by the surface) gets a twin c_i–c_{i+1}. Springs
        // that cross the fan or the rim (v's bending springs, and those between ring vertices that are not rim
        // edges) break.
        let params = |m: &Model<R>, sp: u32| {
            let u = sp as usize;
            let [a, b] = m.spring_indices[u];
            let red = reduced(m.particle_mass[a as usize], m.particle_mass[b as usize]);
            (m.spring_rest_length[u], m.spring_stiffness[u], (m.spring_damping[u], red), m.spring_strain_limit[u])
        };
        let spokes: Vec<_> = sv.iter().map(|&sp| params(m, sp)).collect();
        let mut rims = Vec::with_capacity(k);
        for i in 0..k {
            match spring_between(m, p[i], p[(i + 1) % k]) {
                Some(sp) => rims.push(params(m, sp)),
                None => rims.push(spokes[i]),
            }
        }
        let mut doomed: Vec<u32> =
            m.particle_springs.row(vu).iter().map(|&e| e >> 1).filter(|sp| !sv.contains(sp)).collect();
        for (i, &pi) in p.iter().enumerate() {
            let (prev, next) = (p[(i + k - 1) % k], p[(i + 1) % k]);
            for &e in m.particle_springs.row(pi as usize) {
                let [a, b] = m.spring_indices[(e >> 1) as usize];
                let w = if a == pi { b } else { a };
                if p.contains(&w) && w != prev && w != next {
                    doomed.push(e >> 1);
                }
            }
        }
        for sp in doomed {
            if m.spring_kind[sp as usize] != SpringKind::Broken {
                break_spring(m, sp);
                self.delta.springs.push(sp);
            }
        }
        // Each spoke's end moves from p_i to c_i before p_i's mass changes (which would scale the springs still
        // on it), its stiffness and damping scaled as a new spring's would be (`add_spring`).
        for (i, &sp) in sv.iter().enumerate() {
            let u = sp as usize;
            move_spring_end(m, sp, usize::from(m.spring_indices[u][0] != p[i]), c[i]);
            let (_, ks, (kd, red), _) = spokes[i];
            let ratio = (reduced(m.particle_mass[vu], m.particle_mass[c[i] as usize]) / red).min(R::ONE);
            (m.spring_stiffness[u], m.spring_damping[u], m.spring_kind[u]) = (ks * ratio, kd * ratio, SpringKind::Edge);
            self.delta.springs.push(sp);
        }
        for (i, &(rest, _)) in shares.iter().enumerate() {
            self.set_mass(m, p[i] as usize, rest);
        }
        for (i, &(t, _, _)) in ring.iter().enumerate() {
            set_tri(m, t, [v, c[i], c[(i + 1) % k]]);
            m.tri_body[t as usize] = core_body;
            self.rebodied += 1;
            self.delta.triangles.push(t);
            let (l0, ks, kd, lim) = rims[i];
            add_spring(m, c[i], c[(i + 1) % k], l0, ks, kd, lim);
        }
        for &x in [v].iter().chain(&p).chain(&c) {
            self.touch(x);
        }
        self.new_tips.extend(&p);
        events.push(FractureEvent {
            kind: FractureKind::Core,
            time: s.time,
            position: s.particle_q[vu].to_dvec3(),
            body,
            spring: None,
            vertex: Some(v),
            new_particles: c.clone(),
            new_body: Some(core_body),
        });
        for &pi in &p {
            self.separate(m, s, pi, events);
        }
        true
    }
}
