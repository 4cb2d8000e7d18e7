//! The run kernel: spring forces summed per block of particles over a model's [`crate::model::SpringRun`]s (cloth
//! grids), on contiguous slices, vectorised ([`super::spring::span_forces`]).

use super::spring::{SPAN, SpanScratch, StrainSink, span_forces};
use crate::model::Model;
use crate::par;
use crate::real::{Real, Vector3};

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
        run_block_dispatch::<R, PROJECTED>(m, blocks.of(p0), q, qd, p0, block, strain)
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
#[derive(Clone, Debug, Default)]
pub(crate) struct RunBlocks {
    len: usize,
    /// `start[b]..start[b + 1]`: block `b`'s slice of `runs`.
    start: Vec<u32>,
    runs: Vec<u32>,
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
        let mut out = RunBlocks { len, start: vec![0], runs: Vec::new() };
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

/// [`run_block`] compiled for AVX-512 (F and VL) or AVX2 when the CPU has them (detected once, cached by std),
/// else for the baseline. Packed square roots and divisions are correctly rounded like the scalar ones and Rust
/// never fuses multiply-adds on its own, so every version gives the same bits. AVX-512 is chosen per kernel by
/// measurement (2026-11-24, AMD EPYC Zen 5, 2 threads): here the 128² cloth's step went 85–86 → 62 µs; the
/// per-spring kernel (`spring_chunk_dispatch`) stays on AVX2, where 512-bit gathers made it slower.
#[inline]
pub(crate) fn run_block_dispatch<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    runs: &[u32],
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::isa::avx512() {
            // SAFETY: the CPU supports AVX-512 F and VL, checked just above.
            unsafe { run_block_avx512::<R, PROJECTED>(m, runs, q, qd, p0, block, strain) };
            return;
        }
        if crate::isa::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { run_block_avx2::<R, PROJECTED>(m, runs, q, qd, p0, block, strain) };
            return;
        }
    }
    run_block::<R, PROJECTED>(m, runs, q, qd, p0, block, strain)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
fn run_block_avx512<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    runs: &[u32],
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
) {
    run_block::<R, PROJECTED>(m, runs, q, qd, p0, block, strain)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_block_avx2<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    runs: &[u32],
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    block: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
) {
    run_block::<R, PROJECTED>(m, runs, q, qd, p0, block, strain)
}

/// Spring-force sums of particles `p0 .. p0 + block.len()` into `block`; with `strain`, also the strains of the
/// springs whose end 0 is in the block.
#[inline(always)]
fn run_block<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    runs: &[u32],
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
    for &r in runs {
        let r = &m.spring_runs[r as usize];
        let (i0, j0, len, s0) = (r.i as usize, r.j as usize, r.len as usize, r.first as usize);
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
            while k0 < hi {
                let k1 = (k0 + SPAN).min(hi);
                let n = k1 - k0;
                let (qi, qj) = (&q[i0 + k0..i0 + k1], &q[j0 + k0..j0 + k1]);
                let (vi, vj) = (&qd[i0 + k0..i0 + k1], &qd[j0 + k0..j0 + k1]);
                let (rs, kss, kds) = (&rest[s0 + k0..], &ks[s0 + k0..], &kd[s0 + k0..]);
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
                );
                // End 0 of springs k in [max(k0, a0), min(k1, a1)) lies in the block: add.
                let (c0, c1) = (k0.max(a0), k1.min(a1));
                if let Some(out) = strain.filter(|_| c0 < c1) {
                    // SAFETY: these springs' end 0 lies in this block and in no other (see `StrainSink`).
                    unsafe { out.store(s0 + c0, &scratch.l[c0 - k0..c1 - k0], &rest[s0 + c0..s0 + c1]) };
                }
                if c0 < c1 {
                    let dst = &mut block[i0 + c0 - p0..i0 + c1 - p0];
                    for (d, f) in dst.iter_mut().zip(&buf[c0 - k0..c1 - k0]) {
                        *d += *f;
                    }
                }
                let (c0, c1) = (k0.max(b0), k1.min(b1));
                if c0 < c1 {
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
