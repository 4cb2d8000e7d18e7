//! The force terms, one module per equation: [`spring`] (seed eqs. 1–2), [`pressure`] (eqs. 6–9) and [`wind`]
//! (drag and lift), plus gravity. Each term is a flat pass over springs or triangles writing one value per
//! element; then a per-particle gather over the CSR lists sums them (`particle_force`). No locks, no atomics,
//! one summation order: bit-identical results on any number of threads.
//!
//! The surface pass fuses the two triangle terms: one sweep takes each triangle's cross vector, the bodies'
//! volumes, and then each corner's share of the pressure and wind forces. Cloth grids in wind without gas take
//! the grid wind pass instead (`forces/wind_grid.rs`): whole rows of quads, summed per particle without a gather.

#[cfg(target_arch = "x86_64")]
pub(crate) mod cross_avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod gather_avx2;
pub mod pressure;
pub(crate) mod runs;
#[cfg(target_arch = "x86_64")]
mod runs_avx2;
#[cfg(target_arch = "x86_64")]
mod runs_avx512;
#[cfg(all(test, target_arch = "x86_64"))]
mod span_check;
pub mod spring;
#[cfg(target_arch = "x86_64")]
mod spring_avx2;
pub mod wind;
#[cfg(target_arch = "x86_64")]
mod wind_avx2;
pub(crate) mod wind_grid;

use crate::model::Model;
use crate::par;
use crate::real::{Real, Vector3};

/// Reusable buffers of the force passes (allocated once per model size, never per step).
#[derive(Clone, Debug, Default)]
pub(crate) struct ForceScratch<R: Real> {
    /// Force on spring end 0 (end 1 gets the negative) \[N\] (irregular meshes).
    pub spring_f: Vec<R::V>,
    /// Sum of spring forces on each particle \[N\] (models made of spring runs).
    pub particle_spring: Vec<R::V>,
    /// Whether the run kernel is used (`particle_spring` holds the sums) or the gather (`spring_f`).
    pub runs: bool,
    /// The runs each block walks (run kernel).
    pub run_blocks: runs::RunBlocks,
    /// `(x1 - x0) × (x2 - x0)` of each triangle \[m^2\], padded in `f32` ([`Real::VA`]) for the gathers that sum
    /// them.
    pub tri_cross: Vec<R::VA>,
    /// Force on each corner of each triangle (pressure + wind share) \[N\], written only with wind: without it a
    /// particle's triangle forces are its pressure share, which [`pressure_share`] forms from the cross vectors
    /// where they are summed (one pass over the triangles fewer).
    pub tri_f: Vec<R::V>,
    /// Whether this evaluation's corner forces (wind) are in `tri_f`, or with a grid plan in `tri_sums`
    /// ([`ForceScratch::tri_summed`]); else see [`pressure_share`].
    pub tri_f_written: bool,
    /// The grid wind pass's plan (a model in wind whose triangles are mostly cloth grids: `wind_grid`).
    pub grid_plan: Option<wind_grid::GridPlan>,
    /// Each particle's sum of its triangles' wind forces \[N\] (the grid wind pass).
    pub tri_sums: Vec<R::V>,
    /// The grid plan's loose triangles' forces \[N\].
    pub loose_f: Vec<R::V>,
    /// Each particle's relative air `w(x) - v` \[m/s\] (the general wind pass: [`wind::relative_air`]).
    pub air_rel: Vec<R::V>,
    /// `P / 6` of each body \[Pa\]: a corner's pressure share is `cross · P / 6`.
    pub body_p6: Vec<R>,
    /// Per-chunk, per-body partial sums of `6 V`.
    pub vol_partials: Vec<R>,
    /// Volume of each body \[m^3\].
    pub body_volume: Vec<R>,
    /// Net pressure of each body \[Pa\].
    pub body_pressure: Vec<R>,
    /// The caps over the openings of gas bodies (see [`pressure::Caps`]).
    pub caps: pressure::Caps<R>,
    /// Each body with triangles as `(one past its last triangle, body)`, the greatest first ([`gas_tri_end`]).
    pub tri_ends: Vec<(u32, u32)>,
    /// The order the team takes [`ForceScratch::springs_and_crosses`]'s pieces in, and the triangle count, spring
    /// count and piece size it was laid out for (rebuilt only when they change, not at every call).
    pub fused_order: (Vec<u32>, [usize; 3]),
    /// The particles' rows blocked for the symplectic Euler update on AVX2 (`f32`, per-spring kernel: see
    /// [`gather_avx2`]); empty otherwise.
    #[cfg(target_arch = "x86_64")]
    pub ell: gather_avx2::Ell,
    /// Whether the spring pass measures the fracture trigger's inputs (see [`crate::fracture::Measures`]): a
    /// model that can break, on the per-spring kernel.
    pub measuring: bool,
    /// Strain of each spring (measuring only).
    pub strain: Vec<R>,
    /// Elastic pull of each spring on its end 0 \[N\] (measuring only).
    pub spring_el: Vec<R::V>,
    /// Load of each particle \[N\], 0 where it has no finite load limit (measuring only).
    pub load: Vec<R>,
    /// Some particle has a finite load limit: measuring evaluations write `spring_el` and sum `load` (else the
    /// strains alone, and `load` stays 0).
    pub loads: bool,
    /// Whether `strain`, `spring_el`, `load` hold the start of the last (sub)step.
    pub measured: bool,
    /// Measuring evaluations store strains sparsely (see `StrainSink`): the fracture trigger is instantaneous.
    pub sparse_strains: bool,
    /// `(1 + the smallest finite strain limit of a live spring)(1 - 1e-5)`: a spring longer than its rest length
    /// times this may pass its limit (infinite when none has a limit).
    pub strain_over: R,
    /// Whether the last measuring evaluation was sparse…
    pub strain_sparse: bool,
    /// …and then the ranges `[start, end)` of springs whose strains it stored, in order: every other spring's
    /// strain was within its limit.
    pub strain_spans: Vec<[u32; 2]>,
}

impl<R: Real> ForceScratch<R> {
    /// Sizes the buffers for `m`. `spring_buffer`: the per-spring buffer is needed even with the run kernel
    /// (the implicit solver reuses it for its matrix products).
    pub fn resize(&mut self, m: &Model<R>, spring_buffer: bool) {
        self.runs = m.springs_are_runs();
        self.run_blocks = if self.runs { runs::RunBlocks::of_model(m) } else { runs::RunBlocks::default() };
        let ns = if spring_buffer || !self.runs { m.spring_count() } else { 0 };
        self.spring_f.resize(ns, R::V::ZERO);
        self.particle_spring.resize(if self.runs { m.particle_count() } else { 0 }, R::V::ZERO);
        let surface = m.has_pressure() || m.has_wind();
        let nt = if surface { m.tri_count() } else { 0 };
        // Kept only for the gas (without it the wind pass forms each cross in its lanes and keeps none).
        self.tri_cross.resize(if m.has_pressure() { nt } else { 0 }, R::VA::default());
        self.grid_plan = wind_grid::GridPlan::of_model(m);
        let planned = self.grid_plan.as_ref();
        self.tri_f.resize(if m.has_wind() && planned.is_none() { nt } else { 0 }, R::V::ZERO);
        self.air_rel.resize(if m.has_wind() && planned.is_none() { m.particle_count() } else { 0 }, R::V::ZERO);
        // Sums of particles without triangles are never written: zero from here on.
        self.tri_sums.clear();
        self.tri_sums.resize(if planned.is_some() { m.particle_count() } else { 0 }, R::V::ZERO);
        self.loose_f.resize(planned.map_or(0, |p| p.loose.len()), R::V::ZERO);
        self.body_p6.resize(m.body_count(), R::ZERO);
        self.body_volume.resize(m.body_count(), R::ZERO);
        self.body_pressure.resize(m.body_count(), R::ZERO);
        self.vol_partials.resize(nt.div_ceil(par::CHUNK).max(1) * m.body_count(), R::ZERO);
        self.caps.plan(m);
        self.tri_ends = if m.has_pressure() { tri_ends(m) } else { Vec::new() };
        #[cfg(target_arch = "x86_64")]
        {
            let f32_avx2 = std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx2();
            self.ell = if f32_avx2 && !self.runs { gather_avx2::Ell::of_model(m) } else { Default::default() };
        }
        // The trigger's inputs cost a write per spring and a gather per particle: only for a model that can break,
        // and the loads only for one that can break by load. The run kernel measures strains alone (each spring's
        // in the block of its end 0): a grid cloth with load limits is scanned by the fracture pass itself.
        self.loads = m.particle_load_limit.iter().any(|l| l.is_finite());
        self.measuring = m.has_fracture() && !(self.runs && self.loads);
        let (ns, np) = if self.measuring { (m.spring_count(), m.particle_count()) } else { (0, 0) };
        self.strain.resize(ns, R::ZERO);
        let floor = (m.spring_strain_limit.iter().zip(&m.spring_kind))
            .filter(|(l, k)| l.is_finite() && **k != crate::model::SpringKind::Broken)
            .fold(f64::INFINITY, |a, (l, _)| a.min(l.to_f64()));
        self.strain_over = R::from_f64((1.0 + floor) * (1.0 - 1e-5));
        self.strain_spans.clear();
        self.spring_el.resize(if self.loads { ns } else { 0 }, R::V::ZERO);
        self.load.resize(np, R::ZERO);
        if !self.loads {
            self.load.iter_mut().for_each(|l| *l = R::ZERO);
        }
        self.measured = false;
    }

    /// The load on each particle with a finite load limit: `|Σ elastic pulls of its springs + its triangles'
    /// pressure shares|` \[N\], the same sum the fracture pass's own scan takes (`fracture/trigger.rs`), from the
    /// spring pass's `spring_el` and the surface pass's crosses and pressures of this evaluation.
    pub fn loads(&mut self, m: &Model<R>, surface: bool) {
        let mut load = std::mem::take(&mut self.load);
        let this = &*self;
        let gas = surface && m.has_pressure();
        par::chunks(&mut load, |start, out| {
            for (k, l) in out.iter_mut().enumerate() {
                *l = load_of(m, this, gas, start + k);
            }
        });
        self.load = load;
    }

    /// Whether `tri_sums` holds this evaluation's wind forces, summed per particle (the grid wind pass ran).
    pub fn tri_summed(&self) -> bool {
        self.tri_f_written && self.grid_plan.is_some()
    }

    /// Triangle pass: crosses, body volumes and pressures (if any gas), wind (if any), into `tri_f`.
    /// `crosses_formed`: the crosses and volume partials of this evaluation are in place already (formed beside
    /// the spring pass: [`ForceScratch::springs_and_crosses`]).
    pub fn surface(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V], time: f64, crosses_formed: bool) {
        let nb = m.body_count();
        let pressure = m.has_pressure();
        // Pass A: crosses and per-chunk volume partials.
        let partial_rows = m.tri_count().div_ceil(par::CHUNK).max(1);
        let vp = &mut self.vol_partials[..partial_rows * nb];
        let end = if pressure { gas_tri_end(m, &self.tri_ends) } else { m.tri_count() };
        let cross_chunk =
            |start: usize, cross: &mut [R::VA], part: &mut [R]| cross_chunk(m, q, pressure, (start, end), cross, part);
        // Without gas the crosses are the wind pass's alone: it forms them itself (below), one pass over the
        // triangles instead of two.
        let fused_wind = !pressure && m.has_wind();
        if fused_wind {
            vp.iter_mut().for_each(|p| *p = R::ZERO);
        }
        if !fused_wind && !crosses_formed {
            let pool = par::is_pooled(m.tri_count());
            let (pc, pv) = (par::Pieces::new(&mut self.tri_cross, par::CHUNK), par::Pieces::new(vp, nb));
            let nc = pc.count();
            let caps = pressure::CapPieces::new(&mut self.caps);
            // The caps over a gas body's openings are one more piece (with `crosses_formed` they were formed beside
            // the springs; without gas there are none).
            // SAFETY (both): `exec` runs each piece index once; the caps (if any) are the piece after the chunks.
            // Without caps the closure has one kind of piece (see `ForceScratch::springs_and_crosses`).
            if caps.count() == 0 {
                par::exec(pool, nc, &|c| unsafe { cross_chunk(c * par::CHUNK, pc.get(c), pv.get(c)) });
            } else {
                par::exec(pool, nc + 1, &|c| unsafe {
                    if c < nc { cross_chunk(c * par::CHUNK, pc.get(c), pv.get(c)) } else { caps.run(m, q) }
                });
            }
        }
        // Each body's volume, pressure and `P / 6` in one visit (three loops over a split ball's 101 bodies
        // before; the team's surface stage 0.93–0.95 → 0.68–0.89 µs, within the host's noise). A body without gas has no volume terms (its volume
        // reads 0): its partials are neither written nor read. A split ball's 100 core blocks are such bodies;
        // zeroed and summed, their partials' lines went from the core that formed them to the one that summed
        // them, ~1.1 µs a step on the team (2,562 vertices, the Zen 4 development VM, 2026-11-29). The caps'
        // volume terms are added as each body's sum, formed where the terms were (`pressure::CapPieces::run`: read
        // edge by edge here, a split ball's 600 terms, 38 cache lines, came from the other core, ~1.1 µs a step);
        // a body without caps has `+0` there, which changes no sum (the partials' sum starts at `+0`, so it is
        // never `-0`).
        let (sixth, totals) = (R::from_f64(1.0 / 6.0), &self.caps.totals);
        for b in 0..nb {
            let gas = m.body_gas_amount[b];
            if gas > R::ZERO {
                let mut v6 = (0..partial_rows).fold(R::ZERO, |acc, r| acc + vp[r * nb + b]);
                if let Some(&t) = totals.get(b) {
                    v6 += t;
                }
                let v = v6 * sixth;
                self.body_volume[b] = v;
                self.body_pressure[b] =
                    pressure::gas_pressure(gas, v, m.body_rest_volume[b], m.body_pressure_external[b]);
            } else {
                (self.body_volume[b], self.body_pressure[b]) = (R::ZERO, R::ZERO);
            }
            // Pass B (wind only) forms per-corner forces; without wind the gathers form the pressure share.
            self.body_p6[b] = self.body_pressure[b] * sixth;
        }
        let wind = if m.has_wind() { m.wind.as_ref() } else { None };
        self.tri_f_written = wind.is_some();
        let Some(wind) = wind else { return };
        let rho_half = R::from_f64(0.5 * wind.air_density);
        let wind = wind.prepare::<R>(time);
        let body_pressure = &self.body_pressure;
        if let Some(plan) = &self.grid_plan {
            plan.run(m, q, qd, &wind, rho_half, body_pressure, &mut self.tri_sums, &mut self.loose_f);
            return;
        }
        // The wind sampled once per particle (a triangle's relative air is its corners' mean), then each
        // triangle's force, its own: on the team in finer pieces (`par::piece`), the same bits.
        let (pool, size) = (par::is_pooled(self.air_rel.len()), par::piece(par::CHUNK));
        par::chunks_pooled(pool, size, &mut self.air_rel, |start, out| wind::relative_air(q, qd, &wind, start, out));
        let air = wind::Air::Particles(&self.air_rel);
        let (pool, size) = (par::is_pooled(self.tri_f.len()), par::piece(par::CHUNK));
        if fused_wind {
            // No gas: the crosses are formed in the wind pass and kept by nothing else (not stored: on the
            // 10,242-vertex ball a 240 KB stream of writes fewer a step).
            par::chunks_pooled(pool, size, &mut self.tri_f, |start, out| {
                let tris = wind::Tris::Range { start, cross: None };
                wind::wind_chunk(m, q, air, tris, body_pressure, rho_half, &wind, out)
            });
        } else {
            par::chunks2_pooled(pool, size, &mut self.tri_f, &mut self.tri_cross, |start, out, cross| {
                let tris = wind::Tris::Range { start, cross: Some(&*cross) };
                wind::wind_chunk(m, q, air, tris, body_pressure, rho_half, &wind, out)
            });
        }
    }
}

/// Pass A of the surface pass over triangles `start .. start + cross.len()` (`start` a multiple of `par::CHUNK`):
/// each triangle's cross `(x1 - x0) × (x2 - x0)` into `cross`, and (with gas, `pressure`) its body's volume terms
/// summed into `part` (the chunk's row of partials, one per body). A chunk's partial sums are adjacent to the next
/// chunk's: summed in a register and stored when the body changes (a store per triangle into a line another
/// thread writes cost the pass 2× its one-thread time on two threads). The additions are the same, in the same
/// order: the same bits. In `f32` on AVX2, eight triangles at a time (`cross_avx2`, the same bits): on the
/// 10,242-vertex ball, one thread, the Zen 4 development VM, 2026-11-28, the pass ~65 → 38 µs a step.
#[inline]
pub(crate) fn cross_chunk<R: Real>(
    m: &Model<R>,
    q: &[R::V],
    pressure: bool,
    (start, end): (usize, usize),
    cross: &mut [R::VA],
    part: &mut [R],
) {
    // Triangles from `end` on are not formed ([`gas_tri_end`]); the chunk's row of partials is still zeroed.
    let n = end.saturating_sub(start).min(cross.len());
    let cross = &mut cross[..n];
    // `f32` on AVX2: eight triangles at a time (`cross_avx2`), the same bits.
    #[cfg(target_arch = "x86_64")]
    if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx2() {
        use crate::real::{as_f32, as_f32_mut, va_as_f32_mut};
        let range = start..start + cross.len();
        let model = (&m.tri_indices[range.clone()], &m.tri_body[range]);
        let bodies = (as_f32(&m.body_gas_amount), &m.body_anchor[..]);
        let (q, cross, part) = (as_f32(R::flat(q)), va_as_f32_mut::<R>(cross), as_f32_mut(part));
        // SAFETY: the CPU has AVX2 (tested just above).
        return unsafe { cross_avx2::crosses(q, model.0, model.1, bodies, pressure, cross, part) };
    }
    // Only gas bodies' partials are written and read (see `ForceScratch::surface`).
    part.iter_mut().zip(&m.body_gas_amount).filter(|(_, g)| **g > R::ZERO).for_each(|(p, _)| *p = R::ZERO);
    let mut sum = VolumeSum::new();
    for (k, c) in cross.iter_mut().enumerate() {
        let t = start + k;
        let [a, b, d] = m.tri_indices[t];
        let (x0, x1, x2) = (q[a as usize], q[b as usize], q[d as usize]);
        let cr = (x1 - x0).cross(x2 - x0);
        *c = cr.into();
        if pressure {
            let body = m.tri_body[t] as usize;
            if m.body_gas_amount[body] > R::ZERO {
                sum.switch(body, part, || q[m.body_anchor[body] as usize]);
                sum.add(k, (x0 - sum.anchor).dot(cr));
            }
        }
    }
    sum.finish(part);
}

/// The gas volume sum a chunk of the surface pass is adding to ([`cross_chunk`] and its `f32` kernel on AVX2):
/// its body's (`usize::MAX`: none yet), with the body's anchor. The terms go to eight partial sums, triangle `k`
/// of the chunk (counted from the chunk's start) to lane `k mod 8`, each lane starting at `-0` (which adds nothing:
/// `-0 + x = x` for every `x`); when the body changes (and at the chunk's end) the lanes are joined as
/// `((l0 + l1) + (l2 + l3)) + ((l4 + l5) + (l6 + l7))` and added to the body's partial. Eight chains instead of
/// one, so that the AVX2 kernel adds a block of eight terms in one instruction instead of eight dependent ones
/// (the chain, ~3 cycles a triangle, was the kernel's floor); the portable loop adds in the same lanes, so every
/// instruction set gives the same bits (`tests/isa.rs`). On the 10,242-vertex ball (harness `terms`, one thread,
/// the Zen 4 development VM, 2026-11-29) the surface stage went 38.1–39.5 → 31.6–32.3 µs a step.
pub(super) struct VolumeSum<R: Real> {
    body: usize,
    pub(super) lanes: [R; 8],
    pub(super) anchor: R::V,
}

impl<R: Real> VolumeSum<R> {
    pub(super) fn new() -> Self {
        VolumeSum { body: usize::MAX, lanes: [-R::ZERO; 8], anchor: R::V::ZERO }
    }

    /// Adds the term of the chunk's triangle `k` (to lane `k mod 8`).
    #[inline(always)]
    pub(super) fn add(&mut self, k: usize, term: R) {
        self.lanes[k % 8] += term;
    }

    /// Adds the current body's lanes to its partial in `part`.
    #[inline(always)]
    fn flush(&mut self, part: &mut [R]) {
        if self.body != usize::MAX {
            let l = self.lanes;
            part[self.body] += ((l[0] + l[1]) + (l[2] + l[3])) + ((l[4] + l[5]) + (l[6] + l[7]));
        }
    }

    /// Makes `body`'s sum the current one, adding the last body's into `part` (`anchor`: the new body's).
    #[inline(always)]
    pub(super) fn switch(&mut self, body: usize, part: &mut [R], anchor: impl FnOnce() -> R::V) {
        if body != self.body {
            self.flush(part);
            (self.body, self.lanes, self.anchor) = (body, [-R::ZERO; 8], anchor());
        }
    }

    /// Adds the current body's sum into `part`.
    #[inline(always)]
    pub(super) fn finish(mut self, part: &mut [R]) {
        self.flush(part);
    }
}

/// Particle `i`'s triangle forces added to `f` \[N\]: with wind its sum from the grid wind pass (`tri_sums`) or
/// each triangle's corner force (`tri_f`) in row order; else its [`pressure_share`].
#[inline(always)]
pub(crate) fn add_corners<R: Real>(f: R::V, m: &Model<R>, s: &ForceScratch<R>, i: usize) -> R::V {
    // One test on the gas's path (the usual one): a second in front of it cost the 642-vertex ball's gather a
    // third more (`fissure run scenes/ball_drop.toml`, one thread, 2026-11-25: integrate 0.27-0.32 -> 0.42 s).
    if s.tri_f_written {
        if s.grid_plan.is_some() {
            return f + s.tri_sums[i];
        }
        m.particle_tris.row(i).iter().fold(f, |f, &t| f + s.tri_f[t as usize])
    } else {
        f + pressure_share(m, s, i)
    }
}

/// The gas's push on particle `i` through its triangles \[N\]: `P/6 · Σ cross` over its row, one multiply by its
/// body's `P/6` (a triangle's body is its particles': a model invariant) instead of one per triangle with a look-up
/// of the triangle's body. On the 10,242-vertex ball with gas (a probe of the harness's `terms` model, two
/// threads, 2026-11-24) the gather went 84 → 69 µs a step, against 44 µs without gas. The per-corner form
/// `cross · P/6` ([`pressure::corner_force`]) differs from it by rounding only. The crosses are read as
/// [`Real::VA`] (one 16-byte load and one packed add an entry in `f32`): on the Zen 3 development VM the gas added
/// 1.16–1.38× the spring pass to the ball's step with 12-byte crosses, 1.06–1.21× with padded ones (harness
/// `terms`, six alternated pairs, 2026-11-28), the same bits.
///
/// A particle of a body without pressure (`P/6 = 0`: a body without gas, such as a core block broken off a ball)
/// takes none: `-0` in each component, which adds nothing (`x + −0 = x` for every `x`), and its triangles'
/// crosses are not read (the surface pass does not form the crosses of a model's last triangles that belong to
/// bodies without gas: [`gas_tri_end`]).
#[inline(always)]
pub(crate) fn pressure_share<R: Real>(m: &Model<R>, s: &ForceScratch<R>, i: usize) -> R::V {
    let p = s.body_p6[m.particle_body[i] as usize];
    if p == R::ZERO {
        let z = -R::ZERO;
        return R::V::new(z, z, z);
    }
    let c = m.particle_tris.row(i).iter().fold(R::VA::default(), |c, &t| c + s.tri_cross[t as usize]);
    c.into() * p
}

/// One past the last triangle whose cross a pass reads: with wind every triangle's (its drag and lift read them),
/// else one past the last triangle of a body with gas (only gas bodies' particles read crosses: see
/// [`pressure_share`]). The core blocks broken off a ball are bodies without gas whose triangles the fracture
/// pass orders after the ball's (`Model::order_triangles_by_body`): their crosses were 12 % of the surface
/// pass's on the 2,562-vertex ball after 100 core splits, for nothing. `tri_ends`: each body with triangles as
/// `(one past its last triangle, body)`, the greatest first ([`ForceScratch::resize`]); gas amounts change
/// between steps (leaks, inflow), so the first body with gas is found at each evaluation (the first entry on an
/// intact ball). Walking back over the triangles instead cost the split ball's surface stage ~0.4 µs a step.
pub(crate) fn gas_tri_end<R: Real>(m: &Model<R>, tri_ends: &[(u32, u32)]) -> usize {
    if m.has_wind() {
        return m.tri_count();
    }
    tri_ends.iter().find(|&&(_, b)| m.body_gas_amount[b as usize] > R::ZERO).map_or(0, |&(end, _)| end as usize)
}

/// Each body with triangles as `(one past its last triangle, body)`, the greatest first (for [`gas_tri_end`]).
fn tri_ends<R: Real>(m: &Model<R>) -> Vec<(u32, u32)> {
    let mut end = vec![0u32; m.body_count()];
    for (t, &b) in m.tri_body.iter().enumerate() {
        end[b as usize] = t as u32 + 1;
    }
    let mut out: Vec<(u32, u32)> =
        end.iter().enumerate().filter(|(_, e)| **e > 0).map(|(b, &e)| (e, b as u32)).collect();
    out.sort_unstable_by(|a, b| b.cmp(a));
    out
}

/// The gas's push on particle `i` through the caps over its body's openings \[N\] (zero off their loops; only
/// where `caps.g` is sized). Formed in the gathers rather than stored per particle by a serial pass after the
/// volumes: on a split ball with 100 openings that pass ran on one thread while the other waited.
#[inline(always)]
pub(crate) fn cap_force<R: Real>(m: &Model<R>, s: &ForceScratch<R>, i: usize) -> R::V {
    s.caps.g[i] * s.body_pressure[m.particle_body[i] as usize]
}

/// The fracture load of particle `i` \[N\] (0 without a finite load limit): `|Σ ± spring_el + Σ pressure
/// shares|` from a measuring evaluation's buffers (see [`ForceScratch::loads`]); `gas`: the surface pass ran
/// and the model has pressure.
#[inline(always)]
pub(crate) fn load_of<R: Real>(m: &Model<R>, s: &ForceScratch<R>, gas: bool, i: usize) -> R {
    if !m.particle_load_limit[i].is_finite() {
        return R::ZERO;
    }
    let mut f = spring_gather::<R>(R::V::ZERO, m.particle_springs.row(i), &s.spring_el);
    if gas {
        f += pressure_share(m, s, i);
    }
    f.length()
}

/// Net force on particle `i` \[N\]: gravity, then its springs and triangles in CSR order.
#[inline(always)]
pub(crate) fn particle_force<R: Real>(m: &Model<R>, s: &ForceScratch<R>, surface: bool, i: usize) -> R::V {
    let mut f = m.gravity * m.particle_mass[i];
    if s.runs {
        f += s.particle_spring[i];
    } else {
        f = spring_gather::<R>(f, m.particle_springs.row(i), &s.spring_f);
    }
    if surface {
        f = add_corners(f, m, s, i);
        if !s.caps.g.is_empty() {
            f += cap_force(m, s, i);
        }
    }
    f
}

/// `f + Σ ±buf[spring]` over a particle's spring row, summed in row order (`+` where it is end 0, `-` where
/// end 1: the force sign convention). Measured against a branch-free `± 1 ×` multiply: the branch is faster
/// (the end bit is well predicted enough, the multiply lengthens the chain). So it was against flipping the sign
/// bits by an exclusive or (`a + (-b)` is `a - b` bit for bit): the 2,562-vertex breakable ball's gather took
/// 22.6 µs a step against 19.8 with the branch (two threads, 2026-11-25).
#[inline(always)]
pub(crate) fn spring_gather<R: Real>(mut f: R::V, row: &[u32], buf: &[R::V]) -> R::V {
    for &e in row {
        let v = buf[(e >> 1) as usize];
        if e & 1 == 0 {
            f += v;
        } else {
            f -= v;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Gas, ModelBuilder, SoftBodyOptions};
    use glam::DVec3;

    /// A body without gas after a ball with gas (as a split ball's core blocks follow it): its triangles' crosses
    /// are neither formed nor read (poisoned with NaN, they stay NaN and no force is NaN), and its particles'
    /// forces are gravity's and their springs' bit for bit, in `f32` and `f64`.
    fn a_body_without_gas_reads_no_crosses<R: Real>() {
        let mut b = ModelBuilder::new();
        let gas = SoftBodyOptions { gas: Gas::Amount(50.0), ..Default::default() };
        b.add_soft_body(&crate::Mesh::icosphere(0.2, 2), &gas).unwrap();
        let mesh = crate::Mesh::icosphere(0.1, 1).translated(DVec3::new(1.0, 0.0, 0.0));
        b.add_soft_body(&mesh, &SoftBodyOptions { gas: Gas::None, ..Default::default() }).unwrap();
        let m: Model<R> = b.finalize().unwrap();
        let mut state = m.state();
        // Stretched a little so that the springs pull.
        state.particle_q.iter_mut().for_each(|x| *x *= R::from_f64(1.05));
        let (q, qd) = (&state.particle_q, &state.particle_qd);
        let mut s = ForceScratch::<R>::default();
        s.resize(&m, false);
        let first_gasless = m.tri_body.iter().position(|&b| b == 1).unwrap();
        assert_eq!(gas_tri_end(&m, &s.tri_ends), first_gasless, "the crosses end with the ball's triangles");
        // Gas amounts change between steps (inflow, leaks): the end follows them.
        let mut other = m.clone();
        other.body_gas_amount[1] = R::ONE;
        assert_eq!(gas_tri_end(&other, &s.tri_ends), m.tri_count());
        other.body_gas_amount = vec![R::ZERO; 2];
        assert_eq!(gas_tri_end(&other, &s.tri_ends), 0);
        let nan = R::from_f64(f64::NAN);
        s.tri_cross.iter_mut().for_each(|c| *c = R::V::new(nan, nan, nan).into());
        s.springs(&m, q, qd);
        s.surface(&m, q, qd, 0.0, false);
        assert!(s.body_pressure[0] > R::ZERO && s.body_pressure[1] == R::ZERO);
        assert!(s.tri_cross[first_gasless..].iter().all(|&c| !c.into().is_finite()), "not formed");
        assert!(s.tri_cross[..first_gasless].iter().all(|&c| c.into().is_finite()), "formed");
        for i in 0..m.particle_count() {
            let (with, without) = (particle_force(&m, &s, true, i), particle_force(&m, &s, false, i));
            assert!(with.is_finite(), "particle {i}: {with:?}");
            if m.particle_body[i] == 1 {
                assert_eq!(
                    with.to_array().map(|x| x.to_f64().to_bits()),
                    without.to_array().map(|x| x.to_f64().to_bits())
                );
            } else {
                assert!((with - without).length() > R::ZERO, "particle {i}: the gas pushes");
            }
        }
    }

    #[test]
    fn a_body_without_gas_reads_no_crosses_f32_and_f64() {
        a_body_without_gas_reads_no_crosses::<f32>();
        a_body_without_gas_reads_no_crosses::<f64>();
    }
}
