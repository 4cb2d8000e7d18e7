//! The closed pressure model (Matyka & Ollila 2003; the seed's eqs. 6–9): an ideal gas fills each closed body,
//! `P = nRT / V - P_ext`, and pushes every triangle along its normal.
//!
//! `V = 1/6 Σ_t (x0 - c)·((x1 - c) × (x2 - c))` (taken about an anchor particle `c` of the body to limit
//! round-off; for a closed surface `V` does not depend on `c`), and each corner of each triangle receives
//! `P (x1 - x0) × (x2 - x0) / 6 = P A n̂ / 3`: the seed's eq. (9) force, split equally. Summed over a vertex's
//! closed one-ring this equals `P ∂V/∂x_i` exactly, so the force is conservative with energy `-nRT ln V`, and its
//! sum over a closed surface is exactly zero. Openings of punctured bodies are capped (a fan from the loop's
//! centroid) for the volume, and the gas pushes on the caps too.
//!
//! One formula for the pressure, [`gas_pressure`], with its volume clamp [`MIN_VOLUME_FRACTION`], serves every
//! caller: the force pass, the implicit solver's Jacobian, the fracture load and leak, the energy and diagnostics.
//!
//! GPU twins: `gas_pressure`, `pressure_corner_force` and `MIN_VOLUME_FRACTION` in `shaders/common.wgsl`, used by
//! the kernels `surface_cross`, `surface_caps`, `surface_volume` and `surface_force` in `shaders/surface.wgsl`.

use super::ForceScratch;
use crate::model::Model;
use crate::real::{Real, Vector3};

/// A body's volume is clamped below at this fraction of its rest volume before `P = nRT / V` is taken: a
/// collapsed or inverted body keeps a finite (large) pressure that pushes it back out instead of dividing by
/// zero or changing sign.
pub const MIN_VOLUME_FRACTION: f64 = 1e-3;

/// `max(V, MIN_VOLUME_FRACTION · V0)` \[m^3\].
#[inline]
pub fn clamped_volume<R: Real>(volume: R, rest_volume: R) -> R {
    volume.max(rest_volume * R::from_f64(MIN_VOLUME_FRACTION))
}

/// Net gas pressure \[Pa\] of a body holding `gas = nRT` \[J\] at `volume` \[m^3\] (clamped, see
/// [`MIN_VOLUME_FRACTION`]), less the outside pressure `external` \[Pa\]; 0 for a body without gas.
#[inline]
pub fn gas_pressure<R: Real>(gas: R, volume: R, rest_volume: R, external: R) -> R {
    if gas > R::ZERO { gas / clamped_volume(volume, rest_volume) - external } else { R::ZERO }
}

/// The pressure force on each corner of a triangle with cross vector `cross = (x1 - x0) × (x2 - x0)` under net
/// pressure `p` \[Pa\]: `p · cross / 6` \[N\] (eq. 9, split equally over the corners).
#[inline(always)]
pub fn corner_force<R: Real>(cross: R::V, p: R) -> R::V {
    cross * (p * R::from_f64(1.0 / 6.0))
}

/// Energy of the gas and the outside pressure relative to the rest volume \[J\]: `-nRT ln(V / V0) + P_ext (V - V0)`.
pub fn gas_energy(gas: f64, volume: f64, rest_volume: f64, external: f64) -> f64 {
    -gas * (clamped_volume(volume, rest_volume) / rest_volume).ln() + external * (volume - rest_volume)
}

/// The caps over the openings of gas bodies: a fan `(x_j, x_i, c)` over each loop edge `i -> j` from the loop's
/// centroid `c`, closing the surface for the volume, and pushed on by the gas like any triangle (`c`'s share of
/// the gradient goes equally to the loop's particles). The plan (`loops`, `rim`, `touched`) is laid out once per
/// model by `ForceScratch::resize`; `g` and `terms` are formed each evaluation ([`CapPieces::run`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct Caps<R: Real> {
    /// `∂V/∂x` of the caps, per particle (empty without such openings) \[m^2\].
    pub g: Vec<R::V>,
    /// Particles with a nonzero entry in `g`: the loops' particles, each once, in index order.
    pub touched: Vec<u32>,
    /// The openings of gas bodies as `[body, start, end)` into `rim`, in the model's order.
    pub loops: Vec<[u32; 3]>,
    /// The loops' particles, one loop after another.
    pub rim: Vec<u32>,
    /// Each loop's term of its body's `6 V` (its cap's fan about the body's anchor), in `loops`' order.
    pub terms: Vec<R>,
}

impl<R: Real> Caps<R> {
    /// Lays out the plan for `m` (`g` sized and zero, only where `m` has openings of gas bodies). Entries an
    /// earlier model wrote are cleared first.
    pub(super) fn plan(&mut self, m: &Model<R>) {
        let caps = m.has_pressure() && m.openings.iter().any(|o| m.body_gas_amount[o.body as usize] > R::ZERO);
        for &i in &self.touched {
            if let Some(g) = self.g.get_mut(i as usize) {
                *g = R::V::ZERO;
            }
        }
        self.touched.clear();
        self.loops.clear();
        self.rim.clear();
        self.g.resize(if caps { m.particle_count() } else { 0 }, R::V::ZERO);
        if caps {
            // Laid out once per model: a split ball's 100 openings read through one flat list a step instead of a
            // vector each, and their particles listed once, not once per opening a step.
            for o in m.openings.iter().filter(|o| m.body_gas_amount[o.body as usize] > R::ZERO) {
                let start = self.rim.len() as u32;
                self.rim.extend_from_slice(&o.vertices);
                self.loops.push([o.body, start, self.rim.len() as u32]);
            }
            self.touched.extend_from_slice(&self.rim);
            self.touched.sort_unstable();
            self.touched.dedup();
        }
        self.terms.resize(self.loops.len(), R::ZERO);
    }
}

impl<R: Real> ForceScratch<R> {
    /// Adds the caps' volumes (their loops' terms of `6 V`, formed by [`CapPieces::run`]) to `body_volume`
    /// (still `6 V`, before the division), loop by loop in the model's order.
    pub(super) fn add_cap_volumes(&mut self, m: &Model<R>) {
        for (&[b, ..], &t) in self.caps.loops.iter().zip(&self.caps.terms) {
            let b = b as usize;
            if m.body_gas_amount[b] > R::ZERO {
                self.body_volume[b] += t;
            }
        }
    }
}

/// The caps, formed as one piece of a parallel pass (the surface pass's crosses, or the spring pass beside them):
/// on the team a helper forms them while the caller forms crosses. Serial after the crosses, a split ball's 100
/// caps cost its step ~2 µs of one thread while the other waited (2,562 vertices, 2026-11-25).
pub(crate) struct CapPieces<'a, R: Real> {
    loops: &'a [[u32; 3]],
    rim: &'a [u32],
    touched: &'a [u32],
    g: crate::par::Pieces<'a, R::V>,
    terms: crate::par::Pieces<'a, R>,
}

impl<'a, R: Real> CapPieces<'a, R> {
    pub(crate) fn new(caps: &'a mut Caps<R>) -> Self {
        let (ng, nt) = (caps.g.len(), caps.terms.len());
        CapPieces {
            loops: &caps.loops,
            rim: &caps.rim,
            touched: &caps.touched,
            g: crate::par::Pieces::new(&mut caps.g, ng),
            terms: crate::par::Pieces::new(&mut caps.terms, nt),
        }
    }

    /// Pieces of work: 1 with caps to form, else 0.
    pub(crate) fn count(&self) -> usize {
        usize::from(!self.loops.is_empty())
    }

    /// Zeroes `g` at the touched particles, then adds each cap's `∂(6V)/∂x / 6`, and writes each loop's term of
    /// its body's `6 V` (for [`ForceScratch::add_cap_volumes`]). Loops of bodies that leaked all their gas are
    /// skipped (their gradients stay 0).
    ///
    /// One cross product an edge: with `d_k = x_k - c` (`c` the loop's centroid), the fan triangle over the edge
    /// `i -> j` has `∂(6V)/∂x_i / 6 = ∂(6V)/∂x_j / 6 = e = (d_j × d_i) / 6` (what `(x_i - x_j) × (c - x_j) / 6`
    /// is, expanded), the centroid gets `Σ e` shared equally by the loop's particles, and the cap's `6 V` about
    /// the body's anchor `a` is `Σ (x_j - a)·((x_i - a) × (c - a)) = 6 (c - a)·Σ e` (the scalar triple product
    /// turned, and `Σ x_j × x_i` over a closed loop taken about `c`). With two crosses and a volume term an edge,
    /// the surface stage of a 2,562-vertex ball after 100 core splits (599 loop edges) cost 4.8 µs a step more
    /// than the intact ball's on one thread; with this form 2.6–2.7 (a probe stepping both in turn, 2026-11-27).
    ///
    /// # Safety
    /// Called once per pass (it writes the whole of `g` and `terms`), only when [`Self::count`] is 1.
    pub(crate) unsafe fn run(&self, m: &Model<R>, q: &[R::V]) {
        // SAFETY: one piece each, taken once (the caller's contract).
        let (g, terms) = unsafe { (self.g.get(0), self.terms.get(0)) };
        for &i in self.touched {
            g[i as usize] = R::V::ZERO;
        }
        let sixth = R::from_f64(1.0 / 6.0);
        // Each loop's edge gradients, then each particle's two edges and its share in one add (loops are short:
        // a core split's opening is a one-ring, ~6 particles).
        let mut edges = [R::V::ZERO; 32];
        let mut long = Vec::new();
        for (l, &[b, start, end]) in self.loops.iter().enumerate() {
            let b = b as usize;
            if m.body_gas_amount[b] <= R::ZERO {
                terms[l] = R::ZERO;
                continue;
            }
            let rim = &self.rim[start as usize..end as usize];
            let n = rim.len();
            let e = if n <= edges.len() {
                &mut edges[..n]
            } else {
                long.resize(n, R::V::ZERO);
                &mut long[..]
            };
            let inv_n = R::ONE / R::from_f64(n as f64);
            let centre = rim.iter().fold(R::V::ZERO, |acc, &i| acc + q[i as usize]) * inv_n;
            let first = q[rim[0] as usize] - centre;
            let mut di = first;
            let mut sum = R::V::ZERO;
            // Edge `k` runs from `rim[k]` to the next particle (the last closing onto the first).
            for k in 0..n {
                let dj = if k + 1 < n { q[rim[k + 1] as usize] - centre } else { first };
                let ek = dj.cross(di) * sixth;
                e[k] = ek;
                sum += ek;
                di = dj;
            }
            terms[l] = (centre - q[m.body_anchor[b] as usize]).dot(sum) * R::from_f64(6.0);
            let share = sum * inv_n;
            let mut prev = e[n - 1];
            for (&i, &ek) in rim.iter().zip(e.iter()) {
                g[i as usize] += (prev + ek) + share;
                prev = ek;
            }
        }
    }
}
