//! The run kernel: spring forces summed per block of particles over a model's [`crate::model::SpringRun`]s (cloth
//! grids), on contiguous slices, vectorised ([`super::spring::span_forces`]; in `f32` on AVX-512 and on AVX2 by
//! hand, with the sums added in the same loop where the order allows: `super::runs_avx512`, `super::runs_avx2`).

use super::spring::{SPAN, SpanScratch, StrainSink, span_forces};
use crate::model::Model;
use crate::par;
use crate::real::{Real, Vector3};
#[cfg(target_arch = "x86_64")]
use crate::real::{as_f32, as_f32_mut};

/// Spring forces summed per particle, for models made of [`crate::model::SpringRun`]s. Each fixed block of
/// particles walks its runs ([`RunBlocks`]), computes the springs with an end in the block on contiguous slices
/// (up to [`SPAN`] at a time, vectorised), and adds them to the block's particles: `+f` on end 0, `-f` on end 1.
/// A spring with its ends in two blocks is computed by both. The order of additions per particle is fixed by the
/// run order and the block size (a function of the model), never by the thread count.
pub(super) fn run_pass<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    blocks: &RunBlocks,
    q: &[R::V],
    qd: &[R::V],
    out: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
) {
    par::chunks_of(blocks.len(), out, |p0, block| {
        run_block_dispatch::<R, PROJECTED>(m, blocks, q, qd, p0, block, strain)
    });
}

/// The run kernel's blocks: their length, and the runs each walks (those with a particle in it, in run order: the
/// order of additions, so the same bits as walking every run). Without the lists each block walked every run: a
/// 1024² cloth has ~3,000 row runs and 512 blocks, and that walk took a fifth of the kernel's time (measured
/// 2026-11-24, one thread).
///
/// A block is [`par::CHUNK`] particles, or more on a wide grid: at least 8 times the largest offset between a
/// run's two ends (8 rows of a cloth with bending springs two rows apart). A spring with its ends in two blocks is
/// computed by both, and with blocks of two rows (a 1024² cloth in chunks of 2,048) that was 40% of its springs
/// twice.
///
/// Each run's parameters: a spring whose rest length, stiffness and damping most of the run's springs share bit
/// for bit (see [`SharedParameters`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct RunBlocks {
    len: usize,
    /// `start[b]..start[b + 1]`: block `b`'s slice of `runs`.
    start: Vec<u32>,
    runs: Vec<u32>,
    shared: SharedParameters,
}

/// The parameters each spring run shares. A uniform cloth's runs have one rest length, stiffness and damping
/// (a membrane's or an area density's differ at its boundary rows and columns only), yet the kernel read them per
/// spring: 12 bytes a spring, more than half of what a 1024² cloth's step moved (6.3 M springs: 75 MB of 131).
/// A span of springs that all share their run's parameters reads them from one spring instead, broadcast over
/// the span's lanes (the same values, so the same bits). Measured on the 1024² benchmark cloth, two threads,
/// 2026-11-25: 5.9–6.4 → 4.8–5.2 ms a step.
#[derive(Clone, Debug, Default)]
pub(crate) struct SharedParameters {
    /// Per run: the spring whose parameters most of the run's springs share, or [`NONE`] (each spring its own).
    reference: Vec<u32>,
    /// Per run: its reference spring's rest length, stiffness and damping (as `f64`, exact for `f32` and `f64`
    /// alike), side by side in run order. Read from the model's per-spring arrays they were three cache misses
    /// a run in each block that walks it (the reference lies mid-run, in 25 MB arrays on the 1024² cloth):
    /// `perf` put a tenth of the run kernel's samples on those loads (2026-11-26, one thread).
    values: Vec<[f64; 3]>,
    /// `odd_start[r]..odd_start[r + 1]`: run `r`'s slice of `odd`.
    odd_start: Vec<u32>,
    /// The offsets in their run (ascending) of the springs whose parameters differ from the run's reference.
    odd: Vec<u32>,
}

/// No reference spring.
const NONE: u32 = u32::MAX;

impl SharedParameters {
    /// Each run of `m`: its middle spring's parameters, or its first's, are the reference if at most a quarter of
    /// the run's springs differ from them (bit for bit); otherwise the run has none.
    pub(crate) fn of_model<R: Real>(m: &Model<R>) -> Self {
        let (rest, ks, kd) = (&m.spring_rest_length, &m.spring_stiffness, &m.spring_damping);
        let key = |s: usize| [rest[s], ks[s], kd[s]].map(|x| x.to_f64().to_bits());
        let mut out =
            SharedParameters { reference: Vec::new(), values: Vec::new(), odd_start: vec![0], odd: Vec::new() };
        for r in &m.spring_runs {
            let (first, len) = (r.first as usize, r.len as usize);
            let mut reference = NONE;
            for candidate in [first + len / 2, first] {
                if len == 0 {
                    break;
                }
                let want = key(candidate);
                let from = out.odd.len();
                out.odd.extend((0..len as u32).filter(|&k| key(first + k as usize) != want));
                if (out.odd.len() - from) * 4 <= len {
                    reference = candidate as u32;
                    break;
                }
                out.odd.truncate(from);
            }
            out.reference.push(reference);
            out.values.push(if reference == NONE {
                [0.0; 3]
            } else {
                let r = reference as usize;
                [rest[r], ks[r], kd[r]].map(|x| x.to_f64())
            });
            out.odd_start.push(out.odd.len() as u32);
        }
        out
    }

    /// How many springs of `m`'s runs the kernel reads the parameters of one by one (the others share their run's).
    pub(crate) fn own_count<R: Real>(&self, m: &Model<R>) -> usize {
        m.spring_runs
            .iter()
            .zip(&self.reference)
            .enumerate()
            .map(|(r, (run, &reference))| {
                if reference == NONE { run.len as usize } else { (self.odd_start[r + 1] - self.odd_start[r]) as usize }
            })
            .sum()
    }
}

impl RunBlocks {
    /// The blocks of `m`'s runs.
    pub fn of_model<R: Real>(m: &Model<R>) -> Self {
        let offset = m.spring_runs.iter().map(|r| r.i.abs_diff(r.j) as usize).max().unwrap_or(0);
        let len = par::CHUNK.max((8 * offset).next_multiple_of(par::CHUNK));
        let blocks = m.particle_count().div_ceil(len);
        let mut lists = vec![Vec::new(); blocks];
        for (k, r) in m.spring_runs.iter().enumerate() {
            if r.len == 0 {
                continue;
            }
            let (lo, hi) = (r.i.min(r.j) as usize, (r.i.max(r.j) + r.len) as usize);
            for list in &mut lists[lo / len..(hi - 1) / len + 1] {
                list.push(k as u32);
            }
        }
        let mut out = RunBlocks { len, start: vec![0], runs: Vec::new(), shared: SharedParameters::of_model(m) };
        for l in lists {
            out.runs.extend(l);
            out.start.push(out.runs.len() as u32);
        }
        out
    }

    /// Particles per block.
    pub fn len(&self) -> usize {
        self.len
    }

    /// The runs of the block starting at particle `p0` (a multiple of [`RunBlocks::len`]).
    pub fn of(&self, p0: usize) -> &[u32] {
        debug_assert_eq!(p0 % self.len, 0);
        let b = p0 / self.len;
        &self.runs[self.start[b] as usize..self.start[b + 1] as usize]
    }
}

crate::isa::wide_kernel! {
    /// [`run_block`] compiled for AVX-512 (F and VL) or AVX2 when the CPU has them (detected once, cached by std),
    /// else for the baseline. Packed square roots and divisions are correctly rounded like the scalar ones and Rust
    /// never fuses multiply-adds on its own, so every version gives the same bits. AVX-512 is chosen per kernel by
    /// measurement (2026-11-24, AMD EPYC Zen 5, 2 threads): here the 128² cloth's step went 85–86 → 62 µs; the
    /// per-spring kernel (`spring_chunk_dispatch`) stays on AVX2, where 512-bit gathers made it slower.
    pub(crate) fn run_block_dispatch[R: Real, const PROJECTED: bool](
        m: &Model<R>,
        blocks: &RunBlocks,
        q: &[R::V],
        qd: &[R::V],
        p0: usize,
        block: &mut [R::V],
        strain: Option<&StrainSink<'_, R>>,
    ) => run_block[R, PROJECTED]
}

/// Spring-force sums of particles `p0 .. p0 + block.len()` into `block`; with `strain`, also the strains of the
/// springs whose end 0 is in the block.
#[inline(always)]
fn run_block<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    blocks: &RunBlocks,
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
) {
    let (rest, ks, kd) = (&m.spring_rest_length[..], &m.spring_stiffness[..], &m.spring_damping[..]);
    let p1 = p0 + block.len();
    block.iter_mut().for_each(|f| *f = R::V::ZERO);
    let mut buf = [R::V::ZERO; SPAN];
    let mut scratch = SpanScratch::<R>::new();
    // The run's shared parameters broadcast over a span's lanes (filled once per run).
    let mut shared = [[R::ZERO; SPAN]; 3];
    let sp = &blocks.shared;
    // Whether this block runs on AVX-512 (the dispatcher's own test): the spans' one-loop form (`span_forces`).
    #[cfg(target_arch = "x86_64")]
    let one_loop = crate::isa::avx512();
    #[cfg(not(target_arch = "x86_64"))]
    let one_loop = false;
    // `f32` on AVX-512 or AVX2: the spans by hand (`super::runs_avx512`, `super::runs_avx2`), adding into the block
    // as they go.
    #[cfg(target_arch = "x86_64")]
    let wide = one_loop || crate::isa::avx2();
    #[cfg(not(target_arch = "x86_64"))]
    let wide = false;
    let by_hand = wide && std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>();
    for &ri in blocks.of(p0) {
        let r = &m.spring_runs[ri as usize];
        let (i0, j0, len, s0) = (r.i as usize, r.j as usize, r.len as usize, r.first as usize);
        let reference = sp.reference[ri as usize] as usize;
        let odd = &sp.odd[sp.odd_start[ri as usize] as usize..sp.odd_start[ri as usize + 1] as usize];
        if reference != NONE as usize {
            for (lanes, &v) in shared.iter_mut().zip(&sp.values[ri as usize]) {
                lanes.fill(R::from_f64(v));
            }
        }
        // Spring indices k of this run with end 0 (a) or end 1 (b) in the block.
        let (a0, a1) = (p0.saturating_sub(i0).min(len), p1.saturating_sub(i0).min(len));
        let (b0, b1) = (p0.saturating_sub(j0).min(len), p1.saturating_sub(j0).min(len));
        let ranges: [(usize, usize); 2] = if a0 < a1 && b0 < b1 && a0.max(b0) <= a1.min(b1) {
            [(a0.min(b0), a1.max(b1)), (0, 0)]
        } else {
            [(a0, a1), (b0, b1)]
        };
        for (lo, hi) in ranges {
            let mut k0 = lo;
            // The first odd spring at or after `k0`.
            let mut o = odd.partition_point(|&k| (k as usize) < k0);
            while k0 < hi {
                let k1 = (k0 + SPAN).min(hi);
                let n = k1 - k0;
                let (qi, qj) = (&q[i0 + k0..i0 + k1], &q[j0 + k0..j0 + k1]);
                let (vi, vj) = (&qd[i0 + k0..i0 + k1], &qd[j0 + k0..j0 + k1]);
                while o < odd.len() && (odd[o] as usize) < k0 {
                    o += 1;
                }
                let (rs, kss, kds) = if reference != NONE as usize && odd.get(o).is_none_or(|&k| k as usize >= k1) {
                    (&shared[0][..], &shared[1][..], &shared[2][..])
                } else {
                    (&rest[s0 + k0..], &ks[s0 + k0..], &kd[s0 + k0..])
                };
                // The span's end 0 all in the block: its forces added as they are formed (`by_hand`).
                let added = by_hand && a0 <= k0 && k1 <= a1;
                // And its end 1 subtracted likewise where each particle meets only one of the span's springs (the
                // ends a span apart or more): the same order of additions per particle as the passes below.
                let subtracted = added && b0 <= k0 && k1 <= b1 && i0.abs_diff(j0) >= n;
                #[cfg(target_arch = "x86_64")]
                let by_hand = by_hand && {
                    let (at, bt) = (i0 + k0 - p0, j0 + k0 - p0);
                    let (add, sub) = if subtracted {
                        let (x, y) = block.split_at_mut(at.max(bt));
                        let (low, high) = (&mut x[at.min(bt)..at.min(bt) + n], &mut y[..n]);
                        if at < bt { (Some(low), Some(high)) } else { (Some(high), Some(low)) }
                    } else {
                        (added.then(|| &mut block[at..at + n]), None)
                    };
                    let (add, sub) = (add.map(|b| as_f32_mut(R::flat_mut(b))), sub.map(|b| as_f32_mut(R::flat_mut(b))));
                    let ends = (as_f32(R::flat(q)), as_f32(R::flat(qd)), (i0 + k0, j0 + k0));
                    let params = (as_f32(rs), as_f32(kss), as_f32(kds));
                    // The buffer only for the passes below.
                    let outs = [(!subtracted).then(|| as_f32_mut(R::flat_mut(&mut buf[..n]))), add, sub];
                    let lens = strain.is_some().then(|| as_f32_mut(&mut scratch.l[..n]));
                    // SAFETY: AVX-512 (`one_loop`) or else AVX2 (`wide`); `span` checks the bounds.
                    unsafe {
                        if one_loop {
                            super::runs_avx512::span::<PROJECTED>(ends.0, ends.1, ends.2, params, n, outs, lens)
                        } else {
                            super::runs_avx2::span::<PROJECTED>(ends.0, ends.1, ends.2, params, n, outs, lens)
                        }
                    };
                    true
                };
                if !by_hand {
                    span_forces::<R, PROJECTED>(
                        &mut scratch,
                        qi,
                        qj,
                        vi,
                        vj,
                        rs,
                        kss,
                        kds,
                        &mut buf[..n],
                        strain.is_some(),
                        one_loop,
                    );
                }
                // End 0 of springs k in [max(k0, a0), min(k1, a1)) lies in the block: add.
                let (c0, c1) = (k0.max(a0), k1.min(a1));
                if let Some(out) = strain.filter(|_| c0 < c1) {
                    // SAFETY: these springs' end 0 lies in this block and in no other (see `StrainSink`).
                    unsafe { out.store(s0 + c0, &scratch.l[c0 - k0..c1 - k0], &rest[s0 + c0..s0 + c1]) };
                }
                if c0 < c1 && !added {
                    let dst = &mut block[i0 + c0 - p0..i0 + c1 - p0];
                    for (d, f) in dst.iter_mut().zip(&buf[c0 - k0..c1 - k0]) {
                        *d += *f;
                    }
                }
                let (c0, c1) = (k0.max(b0), k1.min(b1));
                if c0 < c1 && !subtracted {
                    let dst = &mut block[j0 + c0 - p0..j0 + c1 - p0];
                    for (d, f) in dst.iter_mut().zip(&buf[c0 - k0..c1 - k0]) {
                        *d -= *f;
                    }
                }
                k0 = k1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ClothOptions, Damping, Mass, ModelBuilder, Stiffness};
    use glam::DVec3;

    /// A cloth with `opts`, one spring in the middle of its longest run edited by hand, and positions and
    /// velocities jittered.
    fn cloth<R: Real>(opts: &ClothOptions) -> (Model<R>, Vec<R::V>, Vec<R::V>) {
        let mut b = ModelBuilder::new();
        b.add_cloth_grid(40, 24, 0.01, |p| DVec3::new(p.x, 0.0, p.y), opts).unwrap();
        let mut m: Model<R> = b.finalize().unwrap();
        assert!(m.springs_are_runs());
        let r = m.spring_runs.iter().max_by_key(|r| r.len).copied().unwrap();
        m.spring_stiffness[(r.first + r.len / 3) as usize] *= R::from_f64(1.5);
        let mut seed = 3u64;
        let mut jitter = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2e-3
        };
        let mut noise = |scale: f64| R::V::from_dvec3(DVec3::new(jitter(), jitter(), jitter()) * scale);
        let q = m.particle_q0.iter().map(|&x| x + noise(1.0)).collect();
        let v = (0..m.particle_count()).map(|_| noise(100.0)).collect();
        (m, q, v)
    }

    /// The springs listed as differing from their run's reference are exactly those that do, and the kernel
    /// reading the shared parameters gives the bits of the kernel reading each spring's own.
    fn shared_parameters_check<R: Real>(m: &Model<R>, q: &[R::V], v: &[R::V]) -> usize {
        let blocks = RunBlocks::of_model(m);
        let shared = &blocks.shared;
        for (r, run) in m.spring_runs.iter().enumerate() {
            let reference = shared.reference[r] as usize;
            if shared.reference[r] == NONE {
                continue;
            }
            let odd = &shared.odd[shared.odd_start[r] as usize..shared.odd_start[r + 1] as usize];
            let key = |s: usize| {
                [m.spring_rest_length[s], m.spring_stiffness[s], m.spring_damping[s]].map(|x| x.to_f64().to_bits())
            };
            for k in 0..run.len {
                let same = key((run.first + k) as usize) == key(reference);
                assert_eq!(odd.binary_search(&k).is_err(), same, "run {r}, spring {k}");
            }
        }
        let mut apart = blocks.clone();
        apart.shared.reference.iter_mut().for_each(|r| *r = NONE);
        let (mut f, mut g) = (vec![R::V::ZERO; m.particle_count()], vec![R::V::ZERO; m.particle_count()]);
        run_pass::<R, true>(m, &blocks, q, v, &mut f, None);
        run_pass::<R, true>(m, &apart, q, v, &mut g, None);
        assert!(f.iter().any(|x| x.length() > R::ZERO));
        let bits = |f: &[R::V]| f.iter().flat_map(|x| x.to_array().map(|c| c.to_f64().to_bits())).collect::<Vec<_>>();
        assert_eq!(bits(&f), bits(&g));
        shared.own_count(m)
    }

    /// A cloth of the default options in `f32`: every run shares its parameters but for the edited spring and a
    /// few rest lengths rounded apart; the same forces, bit for bit, as each spring's own.
    #[test]
    fn shared_parameters_give_the_bits_of_each_springs_own() {
        let (m, q, v) = cloth::<f32>(&ClothOptions::default());
        let own = shared_parameters_check(&m, &q, &v);
        let blocks = RunBlocks::of_model(&m);
        assert!(blocks.shared.reference.iter().all(|&r| r != NONE), "every run has a reference");
        assert!((1..m.spring_count() / 20).contains(&own), "{own} of {} springs read their own", m.spring_count());
        assert_eq!(m.springs_with_own_parameters(), own);
        // A membrane with area-density masses and damping ratios, in f64: its parameters differ at the
        // boundary and in their last bits (rest lengths from rounded positions); some runs have no reference.
        let opts = ClothOptions {
            mass: Mass::AreaDensity(0.2),
            stiffness: Stiffness::Membrane(300.0),
            shear: Some(Stiffness::Membrane(80.0)),
            bending: Some(Stiffness::Membrane(2.0)),
            damping: Damping::Ratio(0.1),
            ..Default::default()
        };
        let (m, q, v) = cloth::<f64>(&opts);
        shared_parameters_check(&m, &q, &v);
    }
}
