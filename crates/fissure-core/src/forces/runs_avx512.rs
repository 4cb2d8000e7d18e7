//! The run kernel's spans in `f32` on AVX-512 ([`span`]), written with its intrinsics: each chunk of 16 springs
//! reads its ends as 3-vectors, splits their differences into components with two-source permutes, forms the
//! forces per component, joins them back into 3-vectors, and adds them into the block's sums in the same loop
//! where the order of additions allows it (see [`span`]).
//!
//! Why by hand (`perf annotate`, the 1024² benchmark cloth on one thread, 2026-11-26, AMD EPYC Zen 5):
//! - LLVM's packing of the portable loop (`super::spring::span_forces`) took ~30 permutes per 16 springs: it split
//!   the squares of the differences again instead of reusing the split differences. Here: 18.
//! - An add into the block inside the portable loop stopped LLVM packing it (4× slower), so every force went
//!   through a buffer and two more passes (+f at end 0, -f at end 1). Here most go straight into the block.
//! - A span's last chunk of fewer than 16 lanes (every row of a 128² cloth has 127 springs) runs with masked loads
//!   and stores, not lane by lane.
//!
//! Measured against the portable loop, alternated, the same bits (a probe stepping the benchmark cloth, `f32`):
//! 1024² one thread 7.9–8.3 → 6.5–6.7 ms a step, two threads 4.0–4.1 → 3.35 ms; 128² 52 → 42 µs; 32² 10.1 → 8.8 µs.
//! With only the kernel's maths rewritten (forces through the buffer as before) the 1024² step did not change:
//! its permutes were not what bound it.
//!
//! The same bits as the portable loop: each lane's maths is [`super::spring::force_components`]' in its order (no
//! fused multiply-adds; packed square roots and divisions round correctly like the scalar ones), and each
//! particle's additions come in the portable pass's order (see [`span`]).
//!
//! Tried and not kept (2026-11-26): every chunk masked (masked stores are slow on these cores: the 1024² step
//! 1.3× slower); both ends added in the loop for every span, walking the chunks backwards where the order needs it
//! (each chunk's loads of the block overlapped the previous chunk's stores a particle apart, and the
//! store-to-load forwarding failed at every one: 1.3× slower); the block's window transposed into per-component
//! arrays first, spans reading it as contiguous lanes (the same bits; 1.15× slower: the transposition's ~20 % of
//! the kernel and the per-component adds' ~28 % cost more than the permutes they saved).

use crate::isa::vec3x16::{join, load3, split, store3};
use std::arch::x86_64::*;

/// The forces of one span of `n` springs of a run into `out` where given (3-vectors as flat components, `3n`
/// values): lanes `k = 0 .. n` join particle `i + k` (end 0) and `j + k` (end 1). `rest`, `ks`, `kd`: per lane,
/// at least `n`. `q`, `qd`: 3-vectors as flat components. Each lane's force is also added into `add[k]` (the
/// block's sums at the span's ends 0) and subtracted from `sub[k]` (at its ends 1) where given, and its length
/// stored in `lens[k]` (a measuring pass's: the strains are formed from them, `StrainSink::store`).
///
/// The portable pass adds all of a span's forces at its ends 0, then subtracts them at its ends 1. A particle
/// that is end 0 of one of the span's springs and end 1 of another gets its add first; the caller gives `sub`
/// only when the two ends lie at least a span apart (no particle is both), and `add` only when the whole span's
/// ends 0 lie in the block, so the additions per particle keep that order.
///
/// # Safety
/// The CPU has AVX-512 F and VL (the bounds are checked here).
#[target_feature(enable = "avx512f,avx512vl")]
pub(super) unsafe fn span<const PROJECTED: bool>(
    q: &[f32],
    qd: &[f32],
    (i, j): (usize, usize),
    (rest, ks, kd): (&[f32], &[f32], &[f32]),
    n: usize,
    [out, add, sub]: [Option<&mut [f32]>; 3],
    lens: Option<&mut [f32]>,
) {
    let (mut out, mut add, mut sub, mut lens) = (out, add, sub, lens);
    assert!([&out, &add, &sub].iter().all(|a| a.as_ref().is_none_or(|a| a.len() == 3 * n)));
    assert!(lens.as_ref().is_none_or(|l| l.len() == n));
    assert!(3 * (i.max(j) + n) <= q.len().min(qd.len()) && rest.len().min(ks.len()).min(kd.len()) >= n);
    // Chunks of 16 lanes; the last may have fewer (a row of a 128² cloth is 127 springs): masked loads and stores
    // for it alone (masked stores are slow on AMD's cores: masking every chunk made the 1024² cloth's step 1.3×
    // slower, 2026-11-26).
    let whole = n / 16;
    for c in 0..whole {
        // SAFETY: lanes 16c .. 16c + 16 <= n, within the bounds asserted above.
        unsafe {
            chunk::<PROJECTED, true>(
                q,
                qd,
                (i, j),
                (rest, ks, kd),
                [out.as_deref_mut(), add.as_deref_mut(), sub.as_deref_mut()],
                lens.as_deref_mut(),
                16 * c,
                16,
            )
        };
    }
    if n > 16 * whole {
        // SAFETY: lanes 16 whole .. n, within the bounds asserted above.
        unsafe {
            chunk::<PROJECTED, false>(q, qd, (i, j), (rest, ks, kd), [out, add, sub], lens, 16 * whole, n - 16 * whole)
        };
    }
}

/// Lanes `k .. k + m` (`m <= 16`; `WHOLE`: `m = 16`, unmasked) of [`span`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn chunk<const PROJECTED: bool, const WHOLE: bool>(
    q: &[f32],
    qd: &[f32],
    (i, j): (usize, usize),
    (rest, ks, kd): (&[f32], &[f32], &[f32]),
    [out, add, sub]: [Option<&mut [f32]>; 3],
    lens: Option<&mut [f32]>,
    k: usize,
    m: usize,
) {
    let lanes = (((1u32 << m) - 1) & 0xffff) as u16;
    let thirds: [u16; 3] = std::array::from_fn(|r| {
        let e = (3 * m).saturating_sub(16 * r).min(16);
        (((1u32 << e) - 1) & 0xffff) as u16
    });
    let mask = (!WHOLE).then_some(thirds);
    // SAFETY: the caller's bounds; masked-off elements are not read or written.
    unsafe {
        let d = split(sub3(load3(q, 3 * (j + k), mask), load3(q, 3 * (i + k), mask)));
        let w = split(sub3(load3(qd, 3 * (j + k), mask), load3(qd, 3 * (i + k), mask)));
        let p = |s: &[f32]| {
            if WHOLE { _mm512_loadu_ps(s.as_ptr().add(k)) } else { _mm512_maskz_loadu_ps(lanes, s.as_ptr().add(k)) }
        };
        let (f, l) = force::<PROJECTED>(d, w, p(rest), p(ks), p(kd));
        if let Some(lens) = lens {
            let at = lens.as_mut_ptr().add(k);
            if WHOLE { _mm512_storeu_ps(at, l) } else { _mm512_mask_storeu_ps(at, lanes, l) }
        }
        let f = join(f);
        if let Some(out) = out {
            store3(out, 3 * k, f, mask);
        }
        if let Some(add) = add {
            let s = load3(add, 3 * k, mask);
            let sum = [_mm512_add_ps(s[0], f[0]), _mm512_add_ps(s[1], f[1]), _mm512_add_ps(s[2], f[2])];
            store3(add, 3 * k, sum, mask);
        }
        if let Some(sub) = sub {
            store3(sub, 3 * k, sub3(load3(sub, 3 * k, mask), f), mask);
        }
    }
}

#[inline(always)]
unsafe fn sub3(x: [__m512; 3], y: [__m512; 3]) -> [__m512; 3] {
    // SAFETY: AVX-512 F (the caller's target features).
    unsafe { [_mm512_sub_ps(x[0], y[0]), _mm512_sub_ps(x[1], y[1]), _mm512_sub_ps(x[2], y[2])] }
}

/// [`super::spring::force_components`] on 16 lanes: the same operations in the same order; and the lengths.
#[inline(always)]
unsafe fn force<const PROJECTED: bool>(
    d: [__m512; 3],
    w: [__m512; 3],
    rest: __m512,
    ks: __m512,
    kd: __m512,
) -> ([__m512; 3], __m512) {
    // SAFETY: AVX-512 F (the caller's target features).
    unsafe {
        let l2 = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(d[0], d[0]), _mm512_mul_ps(d[1], d[1])),
            _mm512_mul_ps(d[2], d[2]),
        );
        let l = _mm512_sqrt_ps(l2);
        let inv =
            _mm512_maskz_div_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(l2, _mm512_setzero_ps()), _mm512_set1_ps(1.0), l);
        let u = [_mm512_mul_ps(d[0], inv), _mm512_mul_ps(d[1], inv), _mm512_mul_ps(d[2], inv)];
        let el = _mm512_mul_ps(ks, _mm512_sub_ps(l, rest));
        if PROJECTED {
            let dot = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(w[0], u[0]), _mm512_mul_ps(w[1], u[1])),
                _mm512_mul_ps(w[2], u[2]),
            );
            let mag = _mm512_add_ps(el, _mm512_mul_ps(kd, dot));
            ([_mm512_mul_ps(u[0], mag), _mm512_mul_ps(u[1], mag), _mm512_mul_ps(u[2], mag)], l)
        } else {
            (std::array::from_fn(|c| _mm512_add_ps(_mm512_mul_ps(u[c], el), _mm512_mul_ps(w[c], kd))), l)
        }
    }
}

#[cfg(test)]
mod tests {
    /// [`super::span`] against the scalar force (`super::super::span_check`).
    #[test]
    fn spans_give_the_scalar_bits_and_touch_only_their_lanes() {
        if !crate::isa::avx512() {
            eprintln!("no AVX-512 on this CPU: the by-hand spans are not used here (the portable loop is)");
            return;
        }
        // SAFETY: AVX-512, checked above.
        unsafe { super::super::span_check::check(super::span::<true>, super::span::<false>) };
    }
}
