//! Separation: a vertex whose triangles no longer form one fan is duplicated per fan, and a piece that lost its
//! last spring to the rest becomes its own body.

use super::*;
use crate::model::edit::*;

impl<R: Real> Fracture<R> {
    /// Splits `v` into one particle per fan of its triangles; detaches pieces that lost their last link.
    pub(super) fn separate(&mut self, m: &mut Model<R>, s: &mut State<R>, v: u32, events: &mut Vec<FractureEvent>) {
        let fans = fans(m, v);
        if fans.len() <= 1 {
            return;
        }
        let vu = v as usize;
        let k = fans.len();
        let Some((rest, part)) = split_mass(m.particle_mass[vu], 1.0 / k as f64, k - 1) else {
            return;
        };
        let pinned = m.particle_inv_mass[vu] == R::ZERO;
        let fan_verts: Vec<Vec<u32>> =
            fans.iter().map(|(f, _)| f.iter().flat_map(|&(_, x, y)| [x, y]).collect()).collect();
        let mut copies = vec![v];
        for (fan, _) in fans.iter().skip(1) {
            let body = m.particle_body[vu];
            let cp = add_particle(m, s, s.particle_q[vu], s.particle_qd[vu], part, inv(pinned, part), body, vu);
            for &(t, x, y) in fan {
                set_tri(m, t, [cp, x, y]);
                self.delta.triangles.push(t);
            }
            copies.push(cp);
        }
        self.set_mass(m, vu, rest);
        // Springs follow the fan holding their other end, else the nearest fan.
        let centres: Vec<DVec3> = fan_verts
            .iter()
            .map(|vs| vs.iter().map(|&x| s.particle_q[x as usize].to_dvec3()).sum::<DVec3>() / vs.len() as f64)
            .collect();
        let entries: Vec<u32> = m.particle_springs.row(vu).to_vec();
        for e in entries {
            let (sp, end) = ((e >> 1) as usize, (e & 1) as usize);
            let w = m.spring_indices[sp][1 - end];
            let j = fan_verts.iter().position(|vs| vs.contains(&w)).unwrap_or_else(|| {
                let xw = s.particle_q[w as usize].to_dvec3();
                (0..k).min_by(|&x, &y| centres[x].distance(xw).total_cmp(&centres[y].distance(xw))).unwrap_or(0)
            });
            if j != 0 {
                move_spring_end(m, sp as u32, end, copies[j]);
                self.delta.springs.push(sp as u32);
            }
        }
        for &cp in &copies {
            self.touch(cp);
        }
        for &cp in &copies[1..] {
            if let Some(piece) = self.disconnected(m, v, cp) {
                self.detach(m, s, piece, [v, cp], copies[1..].to_vec(), events);
            }
        }
    }

    /// Makes `piece` (the particles on one side of a cut between `ends`, as [`Fracture::disconnected`] found
    /// them) its own body, and reports it.
    pub(super) fn detach(
        &mut self,
        m: &mut Model<R>,
        s: &State<R>,
        piece: Vec<u32>,
        ends: [u32; 2],
        new_particles: Vec<u32>,
        events: &mut Vec<FractureEvent>,
    ) {
        let [v, w] = ends;
        let parent = m.particle_body[v as usize];
        let nb = new_body(m, parent, piece[0]);
        for &x in &piece {
            m.particle_body[x as usize] = nb;
            for &t in m.particle_tris.row(x as usize) {
                m.tri_body[t as usize] = nb;
                self.rebodied += 1;
                self.delta.triangles.push(t);
            }
            self.delta.particles.push(x);
        }
        if piece.contains(&m.body_anchor[parent as usize]) {
            m.body_anchor[parent as usize] = if piece.contains(&v) { w } else { v };
        }
        events.push(FractureEvent {
            kind: FractureKind::Detach,
            time: s.time,
            position: s.particle_q[v as usize].to_dvec3(),
            body: parent,
            spring: None,
            vertex: Some(v),
            new_particles,
            new_body: Some(nb),
        });
    }

    /// Breadth-first search from `a` and `b` at once over live springs: the particles of the side exhausted first
    /// if they are not connected, `None` as soon as the searches meet.
    pub(super) fn disconnected(&mut self, m: &Model<R>, a: u32, b: u32) -> Option<Vec<u32>> {
        let n = m.particle_count();
        if self.mark.len() < n {
            self.mark.resize(n, 0);
        }
        self.mark_gen += 1;
        let tag = |side: u64| (self.mark_gen << 2) | side;
        let mut queues = [vec![a], vec![b]];
        let mut heads = [0usize; 2];
        self.mark[a as usize] = tag(1);
        self.mark[b as usize] = tag(2);
        loop {
            for side in 0..2 {
                if heads[side] == queues[side].len() {
                    return Some(std::mem::take(&mut queues[side]));
                }
                let u = queues[side][heads[side]] as usize;
                heads[side] += 1;
                for &e in m.particle_springs.row(u) {
                    let w = m.spring_indices[(e >> 1) as usize][1 - (e & 1) as usize];
                    let mk = self.mark[w as usize];
                    if mk == tag(2 - side as u64) {
                        return None;
                    }
                    if mk >> 2 != self.mark_gen {
                        self.mark[w as usize] = tag(1 + side as u64);
                        queues[side].push(w);
                    }
                }
            }
        }
    }
}
