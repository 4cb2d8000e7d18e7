//! The run kernel's spans in `f32` on AVX2 ([`span`]), written with its intrinsics: the AVX-512 spans'
//! (`super::runs_avx512`) scheme on 8 lanes. Each chunk of 8 springs reads its ends as 3-vectors, splits their
//! differences into components with five in-lane shuffles (each 128-bit half of the three registers holds 4 of
//! the 8 vectors: Intel's AoS-to-SoA transposition for AVX), forms the forces per component, joins them back with
//! six shuffles and three cross-lane permutes, and adds them into the block's sums in the same loop where the
//! order of additions allows it (the same rule as the AVX-512 spans').
//!
//! Why by hand (`perf annotate`, the 128² benchmark cloth on one thread, 2026-11-27, AMD EPYC Zen 3, which has
//! AVX2 and no AVX-512): the run kernel was ~92 % of a symplectic Euler step. LLVM's AVX2 version of the portable
//! pass (`super::spring::span_forces`) splits each span's differences into per-component arrays on the stack,
//! forms the forces from them, joins them into a buffer, then adds the buffer into the block in two more passes:
//! four round trips through memory per spring where this makes one.
//!
//! Measured against that portable pass, alternated, the same bits (`cargo bench --bench cloth --
//! cloth_128`, criterion, the 128² benchmark cloth, 2026-11-27, the Zen 3 host): one thread 335–417 → 299–345 µs a
//! step, two threads 200–207 → 175–187 µs. What is left is the chain through the square root and the division
//! (`perf annotate`: a third of the span's samples sit on the instructions waiting for them).
//! - One chunk at a time gave no gain (354–366 against 329–346 µs): each chunk's chain (~25 cycles of square root
//!   and division latency, then the products) left the out-of-order window idle. Two chunks are formed before
//!   either is stored, so their chains overlap; three and four were no better than two within this host's noise.
//! - The short last chunk went through zero-padded copies at first: its stack traffic was ~8 % of the span. Now
//!   masked loads and stores (`vmaskmovps`), for that chunk alone.
//! - Closures handed to `array::from_fn` and `map` are compiled without the caller's AVX2, so the intrinsics in
//!   them became calls: 10× slower. None here.
//!
//! The same bits as the portable loop: each lane's maths is [`super::spring::force_components`]' in its order (no
//! fused multiply-adds; packed square roots and divisions round correctly like the scalar ones), and each
//! particle's additions come in the portable pass's order (see [`span`]).

use std::arch::x86_64::*;

/// `_MM_SHUFFLE(z, y, x, w)`: `_mm256_shuffle_ps(a, b, ·)` takes `a[w], a[x], b[y], b[z]` in each 128-bit half.
pub(super) const fn shuf(z: i32, y: i32, x: i32, w: i32) -> i32 {
    (z << 6) | (y << 4) | (x << 2) | w
}

/// The forces of one span of `n` springs of a run into `out` where given (3-vectors as flat components, `3n`
/// values): lanes `k = 0 .. n` join particle `i + k` (end 0) and `j + k` (end 1). `rest`, `ks`, `kd`: per lane,
/// at least `n`. `q`, `qd`: 3-vectors as flat components. Each lane's force is also added into `add[k]` (the
/// block's sums at the span's ends 0) and subtracted from `sub[k]` (at its ends 1) where given, and its length
/// stored in `lens[k]` (a measuring pass's: the strains are formed from them, `StrainSink::store`).
///
/// The portable pass adds all of a span's forces at its ends 0, then subtracts them at its ends 1. The caller
/// gives `sub` only when the two ends lie at least a span apart (no particle is both), and `add` only when the
/// whole span's ends 0 lie in the block, so the additions per particle keep that order (as for
/// `super::runs_avx512::span`).
///
/// # Safety
/// The CPU has AVX2 (the bounds are checked here).
#[target_feature(enable = "avx2")]
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
    let base = |s: &mut Option<&mut [f32]>| s.as_deref_mut().map(|s| s.as_mut_ptr());
    let (o, l) = ([base(&mut out), base(&mut add), base(&mut sub)], base(&mut lens));
    let (q, qd) = (q.as_ptr(), qd.as_ptr());
    let p = [rest.as_ptr(), ks.as_ptr(), kd.as_ptr()];
    // Chunks of 8 lanes; the last may have fewer (a row of a 128² cloth is 127 springs): masked loads and stores
    // for it alone.
    // SAFETY (of each block below): lanes k .. k + m <= n, within the bounds asserted above; masked-off elements
    // are neither read nor written.
    let at = |s: Option<*mut f32>, e: usize| s.map(|s| s.wrapping_add(e));
    let ends = |k: usize| {
        let e = |s: *const f32, x: usize| s.wrapping_add(3 * (x + k));
        ([e(q, i), e(q, j)], [e(qd, i), e(qd, j)])
    };
    let params = |k: usize| [p[0].wrapping_add(k), p[1].wrapping_add(k), p[2].wrapping_add(k)];
    // Two chunks at a time: their chains (sqrt, then the division, ~25 cycles of latency) overlap, and each
    // chunk's additions touch particles the other's do not (the caller's contract), so the order is the same.
    let pairs = n / 16;
    for c in 0..pairs {
        let (k0, k1) = (16 * c, 16 * c + 8);
        unsafe {
            let (f0, l0) = forces::<PROJECTED>(ends(k0), params(k0), None);
            let (f1, l1) = forces::<PROJECTED>(ends(k1), params(k1), None);
            emit([at(o[0], 3 * k0), at(o[1], 3 * k0), at(o[2], 3 * k0)], at(l, k0), f0, l0, None);
            emit([at(o[0], 3 * k1), at(o[1], 3 * k1), at(o[2], 3 * k1)], at(l, k1), f1, l1, None);
        }
    }
    let mut k = 16 * pairs;
    while k < n {
        let m = (n - k).min(8);
        unsafe {
            let outs = [at(o[0], 3 * k), at(o[1], 3 * k), at(o[2], 3 * k)];
            // (Not `bool::then` with a closure: see the module's docs.)
            let tail = if m < 8 { Some(Tail::of(m)) } else { None };
            let (f, l0) = forces::<PROJECTED>(ends(k), params(k), tail.as_ref());
            emit(outs, at(l, k), f, l0, tail.as_ref());
        }
        k += m;
    }
}

/// The forces of a chunk of 8 lanes, or of the live lanes of a short last chunk (`tail`): ends `q[0]` and `q[1]`
/// (3-vectors, interleaved) and their velocities `v[0]`, `v[1]`; the parameters `p` (rest length, stiffness,
/// damping). Returns them joined into 3-vectors ([`join`]), and the lengths.
#[inline(always)]
unsafe fn forces<const PROJECTED: bool>(
    (q, v): ([*const f32; 2], [*const f32; 2]),
    p: [*const f32; 3],
    tail: Option<&Tail>,
) -> ([__m256; 3], __m256) {
    // SAFETY: the caller's bounds; masked-off elements are not read.
    unsafe {
        // (No `array::from_fn` or `map` here: see the module's docs.)
        let mask = tail.map(|t| &t.quarters);
        let d = split(sub3(load3(q[1], mask), load3(q[0], mask)));
        let w = split(sub3(load3(v[1], mask), load3(v[0], mask)));
        let (f, l) = match tail {
            None => force::<PROJECTED>(d, w, _mm256_loadu_ps(p[0]), _mm256_loadu_ps(p[1]), _mm256_loadu_ps(p[2])),
            Some(t) => {
                let lanes = t.lanes;
                let (r, s, k) =
                    (_mm256_maskload_ps(p[0], lanes), _mm256_maskload_ps(p[1], lanes), _mm256_maskload_ps(p[2], lanes));
                force::<PROJECTED>(d, w, r, s, k)
            }
        };
        (join(f), l)
    }
}

/// A chunk's forces `f` (joined) stored to `o[0]`, added into `o[1]`, subtracted from `o[2]` where given, and its
/// lengths `l` stored to `lens` where given; all 8 lanes, or the live ones of a short last chunk (`tail`).
#[inline(always)]
unsafe fn emit(o: [Option<*mut f32>; 3], lens: Option<*mut f32>, f: [__m256; 3], l: __m256, tail: Option<&Tail>) {
    // SAFETY: the caller's bounds; masked-off elements are not touched.
    unsafe {
        let (thirds, quarters) = (tail.map(|t| &t.thirds), tail.map(|t| &t.quarters));
        if let Some(lens) = lens {
            match tail {
                Some(t) => _mm256_maskstore_ps(lens, t.lanes, l),
                None => _mm256_storeu_ps(lens, l),
            }
        }
        if let Some(out) = o[0] {
            store3(out, f, thirds);
        }
        if let Some(add) = o[1] {
            let s = load3(add, quarters);
            store3(add, [_mm256_add_ps(s[0], f[0]), _mm256_add_ps(s[1], f[1]), _mm256_add_ps(s[2], f[2])], thirds);
        }
        if let Some(sub) = o[2] {
            store3(sub, sub3(load3(sub, quarters), f), thirds);
        }
    }
}

/// `x - y`, per component register.
#[inline(always)]
unsafe fn sub3(x: [__m256; 3], y: [__m256; 3]) -> [__m256; 3] {
    // SAFETY: AVX (the caller's target features).
    unsafe { [_mm256_sub_ps(x[0], y[0]), _mm256_sub_ps(x[1], y[1]), _mm256_sub_ps(x[2], y[2])] }
}

/// The masks of a short last chunk of `m < 8` lanes, whose first `3m` elements (of 24) are live: of the six
/// 128-bit quarters [`load3`] reads, of the three 256-bit thirds [`store3`] writes, and of the lanes.
struct Tail {
    quarters: [__m128i; 6],
    thirds: [__m256i; 3],
    lanes: __m256i,
}

impl Tail {
    /// # Safety
    /// The CPU has AVX2.
    #[inline(always)]
    unsafe fn of(m: usize) -> Tail {
        // SAFETY: AVX2 (the caller's contract).
        unsafe {
            let idx = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let from = |at: usize| _mm256_cmpgt_epi32(_mm256_set1_epi32(3 * m as i32 - at as i32), idx);
            let mut quarters = [_mm_setzero_si128(); 6];
            for (r, q) in quarters.iter_mut().enumerate() {
                *q = _mm256_castsi256_si128(from(4 * r));
            }
            Tail {
                quarters,
                thirds: [from(0), from(8), from(16)],
                lanes: _mm256_cmpgt_epi32(_mm256_set1_epi32(m as i32), idx),
            }
        }
    }
}

/// 8 3-vectors at `p` (24 floats) as three registers whose 128-bit halves hold elements `[0..4 | 12..16]`,
/// `[4..8 | 16..20]`, `[8..12 | 20..24]`: vectors 0–3 in the low halves, 4–7 in the high, as [`split`] wants.
/// With `mask`, only the live elements of each quarter (the others zero).
#[inline(always)]
pub(super) unsafe fn load3(p: *const f32, mask: Option<&[__m128i; 6]>) -> [__m256; 3] {
    // SAFETY: the caller's bounds (24 floats at `p`, or the live ones); masked-off elements are not read.
    unsafe {
        let mut x = [_mm_setzero_ps(); 6];
        for (r, x) in x.iter_mut().enumerate() {
            *x = match mask {
                None => _mm_loadu_ps(p.add(4 * r)),
                Some(m) => _mm_maskload_ps(p.wrapping_add(4 * r), m[r]),
            };
        }
        [
            _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(x[0]), x[3]),
            _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(x[1]), x[4]),
            _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(x[2]), x[5]),
        ]
    }
}

/// Stores the three registers [`join`] gives (halves as [`load3`] reads them) as 24 interleaved floats at `p`;
/// with `mask`, only the live elements of each third.
#[inline(always)]
pub(super) unsafe fn store3(p: *mut f32, v: [__m256; 3], mask: Option<&[__m256i; 3]>) {
    // SAFETY: the caller's bounds (24 floats at `p`, or the live ones); masked-off elements are not written.
    unsafe {
        let thirds = [
            _mm256_permute2f128_ps::<0x20>(v[0], v[1]),
            _mm256_permute2f128_ps::<0x30>(v[2], v[0]),
            _mm256_permute2f128_ps::<0x31>(v[1], v[2]),
        ];
        for (r, t) in thirds.into_iter().enumerate() {
            match mask {
                None => _mm256_storeu_ps(p.add(8 * r), t),
                Some(m) => _mm256_maskstore_ps(p.wrapping_add(8 * r), m[r], t),
            }
        }
    }
}

/// Interleaved registers as [`load3`] reads them (per half: `x0 y0 z0 x1`, `y1 z1 x2 y2`, `z2 x3 y3 z3`) into one
/// register per component (lane `e`: vector `e`).
#[inline(always)]
pub(super) unsafe fn split([m03, m14, m25]: [__m256; 3]) -> [__m256; 3] {
    // SAFETY: AVX (the caller's target features).
    unsafe {
        let xy = _mm256_shuffle_ps::<{ shuf(2, 1, 3, 2) }>(m14, m25); // x2 y2 x3 y3
        let yz = _mm256_shuffle_ps::<{ shuf(1, 0, 2, 1) }>(m03, m14); // y0 z0 y1 z1
        [
            _mm256_shuffle_ps::<{ shuf(2, 0, 3, 0) }>(m03, xy), // x0 x1 x2 x3
            _mm256_shuffle_ps::<{ shuf(3, 1, 2, 0) }>(yz, xy),  // y0 y1 y2 y3
            _mm256_shuffle_ps::<{ shuf(3, 0, 3, 1) }>(yz, m25), // z0 z1 z2 z3
        ]
    }
}

/// [`split`]'s inverse.
#[inline(always)]
pub(super) unsafe fn join([x, y, z]: [__m256; 3]) -> [__m256; 3] {
    // SAFETY: AVX (the caller's target features).
    unsafe {
        let rxy = _mm256_shuffle_ps::<{ shuf(2, 0, 2, 0) }>(x, y); // x0 x2 y0 y2
        let ryz = _mm256_shuffle_ps::<{ shuf(3, 1, 3, 1) }>(y, z); // y1 y3 z1 z3
        let rzx = _mm256_shuffle_ps::<{ shuf(3, 1, 2, 0) }>(z, x); // z0 z2 x1 x3
        [
            _mm256_shuffle_ps::<{ shuf(2, 0, 2, 0) }>(rxy, rzx), // x0 y0 z0 x1
            _mm256_shuffle_ps::<{ shuf(3, 1, 2, 0) }>(ryz, rxy), // y1 z1 x2 y2
            _mm256_shuffle_ps::<{ shuf(3, 1, 3, 1) }>(rzx, ryz), // z2 x3 y3 z3
        ]
    }
}

/// [`super::spring::force_components`] on 8 lanes: the same operations in the same order; and the lengths.
#[inline(always)]
unsafe fn force<const PROJECTED: bool>(
    d: [__m256; 3],
    w: [__m256; 3],
    rest: __m256,
    ks: __m256,
    kd: __m256,
) -> ([__m256; 3], __m256) {
    // SAFETY: AVX (the caller's target features).
    unsafe {
        let l2 = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])),
            _mm256_mul_ps(d[2], d[2]),
        );
        let l = _mm256_sqrt_ps(l2);
        // 1 / l where l² > 0, else 0 (the comparison is false for NaN too, as the scalar `if` is).
        let inv =
            _mm256_and_ps(_mm256_div_ps(_mm256_set1_ps(1.0), l), _mm256_cmp_ps::<_CMP_GT_OQ>(l2, _mm256_setzero_ps()));
        let u = [_mm256_mul_ps(d[0], inv), _mm256_mul_ps(d[1], inv), _mm256_mul_ps(d[2], inv)];
        let el = _mm256_mul_ps(ks, _mm256_sub_ps(l, rest));
        if PROJECTED {
            let dot = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(w[0], u[0]), _mm256_mul_ps(w[1], u[1])),
                _mm256_mul_ps(w[2], u[2]),
            );
            let mag = _mm256_add_ps(el, _mm256_mul_ps(kd, dot));
            ([_mm256_mul_ps(u[0], mag), _mm256_mul_ps(u[1], mag), _mm256_mul_ps(u[2], mag)], l)
        } else {
            let f = |c: usize| _mm256_add_ps(_mm256_mul_ps(u[c], el), _mm256_mul_ps(w[c], kd));
            ([f(0), f(1), f(2)], l)
        }
    }
}

#[cfg(test)]
mod tests {
    /// [`super::span`] against the scalar force, as `super::super::runs_avx512`'s test checks its spans.
    #[test]
    fn spans_give_the_scalar_bits_and_touch_only_their_lanes() {
        if !crate::isa::avx2() {
            eprintln!("no AVX2 on this CPU: the by-hand spans are not used here (the portable loop is)");
            return;
        }
        // SAFETY: AVX2, checked above.
        unsafe { super::super::span_check::check(super::span::<true>, super::span::<false>) };
    }
}
