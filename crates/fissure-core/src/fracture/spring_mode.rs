//! Spring mode (seed Fig. 2): an over-stretched spring splits into two virtual nodes and a crack opens across it.

use super::*;
use crate::model::edit::*;

impl<R: Real> Fracture<R> {
    /// Spring mode on spring `sp`; false if it cannot split (already broken, too short, no mass to share, or
    /// not stretched now unless `cut`: a crack opens only under tension, and an averaged trigger may fire on a
    /// spring an impact has since compressed).
    pub(super) fn split_spring(
        &mut self,
        m: &mut Model<R>,
        s: &mut State<R>,
        sp: u32,
        cut: bool,
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
            // It may have been the last link between two parts (a crack's sides held by a bending spring).
            if (body as usize) < m.body_count()
                && let Some(piece) = self.disconnected(m, a, b)
            {
                self.detach(m, s, piece, [a, b], Vec::new(), events);
            }
            return true;
        }
        if l0.to_f64() < self.config.min_rest_length || (l <= l0 && !cut) {
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
        // Nodes 0.45 of the spring's length from their parents, on the spring: a gap of a tenth of it between them,
        // so the slit's sides never start at one point, and no node jumps (a jump could carry a face through a
        // neighbour within the contact distance). The halves keep their stretch and pull their nodes back over
        // the next steps; they cannot break (see below).
        let half = R::from_f64(0.5);
        if l.to_f64() <= 1e-9 * l0.to_f64() || !l.is_finite() {
            return false;
        }
        let d = (xb - xa) * (R::ONE / l);
        let reach = l * R::from_f64(0.45);
        let (xna, xnb) = (xa + d * reach, xb - d * reach);
        let (pa, pb) = (m.particle_inv_mass[au] == R::ZERO, m.particle_inv_mass[bu] == R::ZERO);
        let na = add_particle(m, s, xna, s.particle_qd[au], part_a, inv(pa, part_a), m.particle_body[au], au);
        let nb = add_particle(m, s, xnb, s.particle_qd[bu], part_b, inv(pb, part_b), m.particle_body[bu], bu);
        let (ks, kd) = (m.spring_stiffness[spu], m.spring_damping[spu]);
        let red = reduced(m.particle_mass[au], m.particle_mass[bu]);
        break_spring(m, sp);
        self.set_mass(m, au, rest_a);
        self.set_mass(m, bu, rest_b);
        self.delta.springs.push(sp);
        // The springs of a crack's faces (the halves of the broken spring and the slit's sides) do not break: a
        // crack runs through the material at its tips, where the stress concentrates. Breakable, the faces --
        // born as stretched as the material around them, their nodes light -- pass the limit within steps of
        // their birth, and every split sets off more along its own faces: the sheet shatters around the crack
        // instead of tearing along it.
        add_spring(m, a, na, l0 * half, ks, (kd, red), R::infinity());
        add_spring(m, b, nb, l0 * half, ks, (kd, red), R::infinity());
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
            add_spring(m, na, r, R::from_f64(med), ks, (kd, red), R::infinity());
            add_spring(m, nb, r, R::from_f64(med), ks, (kd, red), R::infinity());
            thirds.push(r);
        }
        for v in [a, b, na, nb].into_iter().chain(thirds.iter().copied()) {
            self.touch(v);
        }
        self.new_tips.extend(&thirds);
        events.push(FractureEvent::spring(s.time, mid, body, sp, vec![na, nb]));
        for v in [a, b].into_iter().chain(thirds) {
            self.separate(m, s, v, events);
        }
        true
    }

    /// Orders spring candidates for cracks that run across the tension: each triangle-edge spring's ratio is
    /// weighted by `sin²` of the angle between it (the tension that stretched it) and the slit its split would
    /// open (from the opposite vertex of one triangle to that of the other). A split can only cut a triangle from
    /// an edge to its opposite corner, so on a mesh a crack chooses among a few directions at each step; the
    /// weight makes it take the one most nearly across the load, and a crack then follows the perpendicular to
    /// the principal stress as closely as the mesh allows (instead of the mesh's diagonals). Stable sort: equal
    /// weights keep the scan's order (worst first, ties by index).
    pub(super) fn rank_cracks(&self, m: &Model<R>, s: &State<R>, cands: &mut [(f64, u8, u32)]) {
        let mut weighted = false;
        for c in cands.iter_mut().filter(|c| c.1 == 0) {
            let [a, b] = m.spring_indices[c.2 as usize];
            let (xa, xb) = (s.particle_q[a as usize].to_dvec3(), s.particle_q[b as usize].to_dvec3());
            let opposite: Vec<DVec3> = m
                .particle_tris
                .row(a as usize)
                .iter()
                .filter(|&&t| tri_has(m, t, b))
                .filter_map(|&t| m.tri_indices[t as usize].into_iter().find(|&v| v != a && v != b))
                .map(|v| s.particle_q[v as usize].to_dvec3())
                .collect();
            let slit = match opposite.as_slice() {
                [c, d] => *c - *d,
                [c] => *c - 0.5 * (xa + xb),
                _ => continue,
            };
            let u = (xb - xa).normalize_or_zero();
            let sin2 = u.cross(slit).length_squared() / slit.length_squared().max(f64::MIN_POSITIVE);
            c.0 *= sin2;
            weighted = true;
        }
        if weighted {
            cands.sort_by(|x, y| y.0.total_cmp(&x.0));
        }
    }

    /// Whether spring `a–b` is at a crack's tip: an end, or the opposite corner of one of its triangles, is a tip
    /// (the far corner of a triangle an earlier split cut, or the rim of a core block's hole). Only there may a
    /// crack advance without waiting: a crack runs on at its tips and does not branch from its flanks.
    pub(super) fn near_crack(&self, m: &Model<R>, a: u32, b: u32) -> bool {
        let cracked = |v: u32| self.tip.get(v as usize).copied().unwrap_or(false);
        cracked(a)
            || cracked(b)
            || m.particle_tris
                .row(a as usize)
                .iter()
                .filter(|&&t| tri_has(m, t, b))
                .any(|&t| m.tri_indices[t as usize].iter().any(|&v| cracked(v)))
    }
}
