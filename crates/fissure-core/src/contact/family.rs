//! Pieces born crossing their family, left out of contact with it until they part (see the [`crate::contact`]
//! module's docs). Both solvers keep an [`Excused`]: the CPU asks it at every pass, the GPU whenever the host holds
//! the current state (after every step that reads it back, and at the first step after a fracture pass).
//!
//! A body without self-contact may cross itself (the fracture scene's torn ball lies flattened on the floor in
//! layers), and a piece that breaks off where it does is born crossing the body it came from. The pass sees
//! distances, not sides: it held such a pair `h` apart and capped its moves at `GAMMA` of a gap that was already
//! nothing, and the gap shrank under the caps. On the fracture scene (2026-12-07) a core block born at
//! t = 1.0995 s where the ball lay folded, and the ball's particles it crossed, were held in place by bounds under
//! 1e-6 m (~1e-8 m at the end) at nearly every step to the end: 12,000 capped moves in 7 particles while their
//! springs pulled. Leaving out only the crossing pairs would not free them: the pairs beside the crossing are as
//! close and cap as hard. So the piece and the body it crosses take no contact with each other, as the body took
//! none with itself, until no triangle of the one comes within a thickness of the other
//! ([`crate::contact::bodies_within`], at each pass: the piece's few triangles against the boxes of the other's);
//! from then on they are held apart like any pair.

use crate::contact::bodies_within;
use crate::fracture::TopologyDelta;
use crate::model::Model;
use crate::real::Real;

/// The pairs of bodies left out of contact, and what finding them needs.
#[derive(Clone, Debug, Default)]
pub struct Excused {
    /// Each body's family: the body of the model as built that it broke from, through any pieces between
    /// (itself for such a body); grown as bodies appear.
    family: Vec<u32>,
    /// Pieces born since the last pass, each with the body it broke from.
    newborn: Vec<[u32; 2]>,
    /// The bodies left out of contact with each other, `[low, high]`.
    pairs: Vec<[u32; 2]>,
}

impl Excused {
    /// Notes the pieces a fracture created, to test at the next pass.
    pub fn born(&mut self, delta: &TopologyDelta) {
        self.newborn.extend(delta.events.iter().filter_map(|e| e.new_body.map(|b| [b, e.body])));
    }

    /// The pairs of bodies left out of contact with each other, `[low, high]`.
    pub fn pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// Whether bodies `a` and `b` are left out of contact with each other.
    #[inline]
    pub fn excuses(&self, a: u32, b: u32) -> bool {
        !self.pairs.is_empty() && self.pairs.contains(&[a.min(b), a.max(b)])
    }

    /// At a pass, with the positions `x` at the substep's start: excuses each piece born since the last pass
    /// from the members of its family it crosses, and forgets the pairs that have parted. True when the pairs
    /// changed (on the CPU a forgotten pair's element pairs are missing from the candidate lists, which must then
    /// be built again; the GPU uploads the pairs).
    pub fn update<R: Real>(&mut self, m: &Model<R>, x: &[R::V]) -> bool {
        let n = m.body_count();
        let known = self.family.len().min(n);
        self.family.truncate(known);
        self.family.extend(known as u32..n as u32);
        let newborn = std::mem::take(&mut self.newborn);
        for &[p, parent] in &newborn {
            if p as usize >= n || parent as usize >= n {
                continue;
            }
            self.family[p as usize] = self.family[parent as usize];
        }
        if newborn.is_empty() && self.pairs.is_empty() {
            return false;
        }
        let mut added = false;
        for &[p, _] in &newborn {
            if p as usize >= n || m.body_contact_thickness[p as usize] <= R::ZERO {
                continue;
            }
            for q in 0..n as u32 {
                if q != p && self.family[q as usize] == self.family[p as usize] && bodies_within(m, x, p, q, 0.0) {
                    let pair = [p.min(q), p.max(q)];
                    if !self.pairs.contains(&pair) {
                        self.pairs.push(pair);
                        added = true;
                    }
                }
            }
        }
        // Parted: no triangle of the one within a thickness of the other, so that contact takes the pair up
        // outside its thickness (inside it, the push-out would send the piece off at up to `RELAX h / PUSH_TIME`).
        let (h, before) = (|b: u32| m.body_contact_thickness[b as usize].to_f64(), self.pairs.len());
        self.pairs.retain(|&[a, b]| (b as usize) < n && bodies_within(m, x, a, b, h(a).max(h(b))));
        added || self.pairs.len() < before
    }
}
