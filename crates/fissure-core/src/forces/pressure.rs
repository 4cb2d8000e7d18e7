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
    /// Each loop edge's term of its body's `6 V` (the edge from `rim[k]` to the loop's next particle).
    pub terms: Vec<R>,
    /// Per body, its caps' terms of `6 V` summed (each loop's edge by edge from `+0`, then the loops' sums in the
    /// model's order), formed by [`CapPieces::run`] on the core that formed the terms: 0 for bodies without caps.
    pub totals: Vec<R>,
    /// No particle is on two loops, nor twice on one: each entry of `g` at a loop's particle is then formed in
    /// registers and written once from the edges' gradients (see [`CapPieces::run`]).
    pub once: bool,
    /// Each loop edge's end: `rim[k]`'s next particle on its loop.
    pub next: Vec<u32>,
    /// Each loop edge's loop (an index into `loops`).
    pub loop_of: Vec<u32>,
    /// Formed each evaluation: each loop edge's `∂(6V)/∂x / 6` (`rim.len()` of them), then each loop's centroid
    /// and its body's anchor position (two a loop).
    pub work: Vec<R::VA>,
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
        self.once = self.touched.len() == self.rim.len();
        self.next.clear();
        self.loop_of.clear();
        for (l, &[_, start, end]) in self.loops.iter().enumerate() {
            let rim = &self.rim[start as usize..end as usize];
            self.next.extend(rim.iter().skip(1).chain(rim.first()));
            self.loop_of.extend(std::iter::repeat_n(l as u32, rim.len()));
        }
        self.work.resize(self.rim.len() + 2 * self.loops.len(), R::VA::default());
        self.terms.resize(self.rim.len(), R::ZERO);
        self.totals.clear();
        self.totals.resize(if self.loops.is_empty() { 0 } else { m.body_count() }, R::ZERO);
    }
}

/// The caps, formed as one piece of a parallel pass (the surface pass's crosses, or the spring pass beside them):
/// on the team a helper forms them while the caller forms crosses. Serial after the crosses, a split ball's 100
/// caps cost its step ~2 µs of one thread while the other waited (2,562 vertices, 2026-11-25).
pub(crate) struct CapPieces<'a, R: Real> {
    loops: &'a [[u32; 3]],
    rim: &'a [u32],
    touched: &'a [u32],
    once: bool,
    next: &'a [u32],
    loop_of: &'a [u32],
    g: crate::par::Pieces<'a, R::V>,
    terms: crate::par::Pieces<'a, R>,
    totals: crate::par::Pieces<'a, R>,
    work: crate::par::Pieces<'a, R::VA>,
}

impl<'a, R: Real> CapPieces<'a, R> {
    pub(crate) fn new(caps: &'a mut Caps<R>) -> Self {
        let (ng, nt, nw, nb) = (caps.g.len(), caps.terms.len(), caps.work.len(), caps.totals.len());
        CapPieces {
            loops: &caps.loops,
            rim: &caps.rim,
            touched: &caps.touched,
            once: caps.once,
            next: &caps.next,
            loop_of: &caps.loop_of,
            g: crate::par::Pieces::new(&mut caps.g, ng),
            terms: crate::par::Pieces::new(&mut caps.terms, nt),
            totals: crate::par::Pieces::new(&mut caps.totals, nb),
            work: crate::par::Pieces::new(&mut caps.work, nw),
        }
    }

    /// Pieces of work: 1 with caps to form, else 0.
    pub(crate) fn count(&self) -> usize {
        usize::from(!self.loops.is_empty())
    }

    /// Zeroes `g` at the touched particles, then adds each cap's `∂(6V)/∂x / 6`, and writes each loop
    /// edge's volume term and each body's total of them (which `ForceScratch::surface` adds to its volume).
    /// Loops of bodies that leaked all their gas are skipped (their gradients stay 0).
    ///
    /// # Safety
    /// Called once per pass (it writes the whole of `g` and `terms`), only when [`Self::count`] is 1.
    pub(crate) unsafe fn run(&self, m: &Model<R>, q: &[R::V]) {
        // SAFETY: one piece each, taken once (the caller's contract).
        let (g, terms) = unsafe { (self.g.get(0), self.terms.get(0)) };
        // SAFETY: as for `g` and `terms`.
        let e = self.edges(m, q, terms, unsafe { self.work.get(0) });
        // SAFETY: as for `g` and `terms`.
        let totals = unsafe { self.totals.get(0) };
        for &[b, ..] in self.loops {
            totals[b as usize] = R::ZERO;
        }
        if self.once {
            return self.assemble_once(m, g, e, terms, totals);
        }
        for &[b, start, end] in self.loops {
            if m.body_gas_amount[b as usize] > R::ZERO {
                totals[b as usize] += loop_sum(&terms[start as usize..end as usize]);
            }
        }
        // A particle on two loops (or twice on one): its entry summed in `g` edge by edge, loop by loop.
        for &i in self.touched {
            g[i as usize] = R::V::ZERO;
        }
        for &[b, start, end] in self.loops {
            if m.body_gas_amount[b as usize] <= R::ZERO {
                continue;
            }
            let (rim, next) = (&self.rim[start as usize..end as usize], &self.next[start as usize..end as usize]);
            let mut centre_g = R::V::ZERO;
            for ((&i, &j), &e) in rim.iter().zip(next).zip(&e[start as usize..end as usize]) {
                let e: R::V = e.into();
                g[i as usize] += e;
                g[j as usize] += e;
                centre_g += e;
            }
            let share = centre_g * (R::ONE / R::from_f64(rim.len() as f64));
            for &i in rim {
                g[i as usize] += share;
            }
        }
    }

    /// Each loop edge's volume term into `terms` and its gradient `e = ((xi − xj) × (c − xj)) / 6` into the
    /// returned slice of `work` (after each loop's centroid `c` and anchor, formed first): in `f32` on AVX2 eight
    /// edges at a time, across loops (`cross_avx2::cap_edges`, the same bits), the rest one by one. On the
    /// 2,562-vertex ball after 100 core splits (100 openings, ~600 loop edges), one thread, the Zen 4 development
    /// VM, 2026-11-29 (`perf`): the caps 4.0 → 2.8 µs a step, the surface stage 16.8–17.0 → 15.0–15.2 µs.
    fn edges<'w>(&self, m: &Model<R>, q: &[R::V], terms: &mut [R], work: &'w mut [R::VA]) -> &'w [R::VA] {
        let sixth = R::from_f64(1.0 / 6.0);
        let (e, spots) = work.split_at_mut(self.rim.len());
        for (&[b, start, end], spot) in self.loops.iter().zip(spots.chunks_exact_mut(2)) {
            let rim = &self.rim[start as usize..end as usize];
            let inv_n = R::ONE / R::from_f64(rim.len() as f64);
            let centre = rim.iter().fold(R::V::ZERO, |acc, &i| acc + q[i as usize]) * inv_n;
            spot[0] = centre.into();
            spot[1] = q[m.body_anchor[b as usize] as usize].into();
        }
        let spots = &*spots;
        // The edges formed eight at a time (`f32` on AVX2), then the rest one by one.
        #[cfg(target_arch = "x86_64")]
        let from = if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx2() {
            use crate::real::{as_f32, as_f32_mut, va_as_f32, va_as_f32_mut};
            let (q, spots) = (as_f32(R::flat(q)), va_as_f32::<R>(spots));
            let edges = (self.rim, self.next, self.loop_of);
            // SAFETY: the CPU has AVX2 (tested just above).
            unsafe { super::cross_avx2::cap_edges(q, edges, spots, as_f32_mut(terms), va_as_f32_mut::<R>(e)) }
        } else {
            0
        };
        #[cfg(not(target_arch = "x86_64"))]
        let from = 0;
        for k in from..self.rim.len() {
            let l = self.loop_of[k] as usize;
            let (centre, anchor): (R::V, R::V) = (spots[2 * l].into(), spots[2 * l + 1].into());
            let (xi, xj) = (q[self.rim[k] as usize], q[self.next[k] as usize]);
            terms[k] = (xj - anchor).dot((xi - anchor).cross(centre - anchor));
            e[k] = ((xi - xj).cross(centre - xj) * sixth).into();
        }
        e
    }

    /// Where no particle is on two loops or twice on one ([`Caps::once`]): particle `rim[k]`'s entry
    /// `((0 + e[k - 1]) + e[k]) + share` (`rim[0]`'s `((0 + e[0]) + e[n - 1]) + share`), the sums the general
    /// path forms in `g` edge by edge, here formed in registers and written once (no pass zeroing `g` first):
    /// the same bits. Each loop in one visit: its terms' sum into its body's total, its share `Σ e / n` (the edges'
    /// sum from `0 + e[0]`, as the general path's), then each entry, written once (before, the entries were written
    /// and the share added in a second pass, and the totals summed in a pass of their own).
    fn assemble_once(&self, m: &Model<R>, g: &mut [R::V], e: &[R::VA], terms: &[R], totals: &mut [R]) {
        for &[b, start, end] in self.loops {
            let (rim, e) = (&self.rim[start as usize..end as usize], &e[start as usize..end as usize]);
            if m.body_gas_amount[b as usize] <= R::ZERO {
                rim.iter().for_each(|&i| g[i as usize] = R::V::ZERO);
                continue;
            }
            totals[b as usize] += loop_sum(&terms[start as usize..end as usize]);
            let (Some(&first), Some(&e0), Some(&last)) = (rim.first(), e.first(), e.last()) else { continue };
            let (e0, last): (R::V, R::V) = (e0.into(), last.into());
            let centre_g = e[1..].iter().fold(R::V::ZERO + e0, |c, &ek| c + ek.into());
            let share = centre_g * (R::ONE / R::from_f64(rim.len() as f64));
            g[first as usize] = ((R::V::ZERO + e0) + last) + share;
            let mut prev = e0;
            for (&i, &ek) in rim.iter().zip(e).skip(1) {
                let ek: R::V = ek.into();
                g[i as usize] = ((R::V::ZERO + prev) + ek) + share;
                prev = ek;
            }
        }
    }
}

/// A loop's volume terms summed from `+0` in order (each loop's sum apart, then added to its body's: the loops'
/// short chains overlap).
#[inline(always)]
fn loop_sum<R: Real>(terms: &[R]) -> R {
    terms.iter().fold(R::ZERO, |v, &x| v + x)
}
