//! The per-spring kernel of irregular meshes (`spring::spring_chunk`, the forces alone) in `f32` on AVX2, eight
//! springs at a time, written with its intrinsics.
//!
//! Why by hand: the portable span code reads each spring's four 3-vectors (its ends' positions and velocities)
//! one component at a time into per-component arrays, runs the force maths over the arrays (vectorised), and
//! writes each force back from them: ~40 scalar loads and stores a spring around ~20 vector instructions of
//! maths, ~3 ns a spring on the 2,562-vertex ball (one thread, the Zen 4 development VM, 2026-11-29). Here each
//! 3-vector is one 16-byte load, the eight of a block are split into components with seven shuffles
//! (`cross_avx2::soa8`), and the eight forces are joined back with six and stored as eight overlapping 16-byte
//! stores (`store_xyz8`).
//!
//! The same bits as the portable code: each lane's maths is [`super::spring::force_parts`]'s, in its order, with
//! no fused multiply-adds (`sqrt` and division are correctly rounded in both). A block whose springs read the
//! last particle (whose 16-byte load would pass the end of the positions) goes the portable way.
//!
//! [`forces`] and [`measured`] drive it over a chunk of the spring pass (`spring::spring_chunk_dispatch` calls
//! them in `f32` on AVX2), forming what it leaves the portable way.

use std::arch::x86_64::*;

use super::cross_avx2::{dot8, soa8, sub8, xyzz8};
use super::spring::{SPAN, StrainSink, force_parts};
use crate::model::Model;
use crate::real::{Real, Vector3};

/// The forces of springs `start .. start + out.len()` in `f32` on AVX2: eight at a time by hand
/// (`super::spring_avx2`, the same bits), a block the kernel leaves (an end on the last particle) and the tail
/// the portable way. On the 2,562-vertex ball (one thread, the Zen 4 development VM, 2026-11-29) the spring
/// stage went 23.0–25.3 → 17.7–18.6 µs a step (`benches/RESULTS.md`, issue 15).
pub(super) fn forces<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    start: usize,
    out: &mut [R::V],
) {
    use crate::real::{as_f32, as_f32_mut};
    let end = start + out.len();
    let (idx, rest) = (&m.spring_indices[start..end], as_f32(&m.spring_rest_length[start..end]));
    let (ks, kd) = (as_f32(&m.spring_stiffness[start..end]), as_f32(&m.spring_damping[start..end]));
    let (xs, vs) = (as_f32(R::flat(q)), as_f32(R::flat(qd)));
    let mut k = 0;
    while k < out.len() {
        let o = as_f32_mut(R::flat_mut(&mut out[k..]));
        // SAFETY: the CPU has AVX2 (the caller's test).
        k += unsafe { springs::<PROJECTED>((xs, vs), &idx[k..], (&rest[k..], &ks[k..], &kd[k..]), o, None, None) };
        // The block it stopped at (or the tail), the portable way.
        let n = (out.len() - k).min(8);
        if n > 0 {
            // SAFETY: the CPU supports AVX2 (the caller's test).
            unsafe {
                super::spring::spring_chunk_avx2::<R, PROJECTED, false>(
                    m,
                    q,
                    qd,
                    start + k,
                    &mut out[k..k + n],
                    None,
                    &mut [],
                )
            };
            k += n;
        }
    }
}

/// [`forces`] for a measuring pass: each spring's length too, from which `sink` stores the strains span by
/// span ([`SPAN`] springs from the chunk's start, as `spring::spring_chunk` stores them: the same spans in sparse mode),
/// and where `els` is not empty (load limits) each spring's elastic pull into it. The springs the kernel leaves
/// are formed here one by one with [`force_parts`].
pub(super) fn measured<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    (q, qd): (&[R::V], &[R::V]),
    start: usize,
    out: &mut [R::V],
    sink: &StrainSink<'_, R>,
    els: &mut [R::V],
) {
    use crate::real::{as_f32, as_f32_mut};
    let (xs, vs) = (as_f32(R::flat(q)), as_f32(R::flat(qd)));
    let pulls = !els.is_empty();
    assert!(!pulls || els.len() == out.len());
    let mut l = [R::ZERO; SPAN];
    let mut k0 = 0;
    while k0 < out.len() {
        let n = (out.len() - k0).min(SPAN);
        let s0 = start + k0;
        let (idx, rest) = (&m.spring_indices[s0..s0 + n], &m.spring_rest_length[s0..s0 + n]);
        let (ks, kd) = (&m.spring_stiffness[s0..s0 + n], &m.spring_damping[s0..s0 + n]);
        let mut k = 0;
        while k < n {
            let o = as_f32_mut(R::flat_mut(&mut out[k0 + k..k0 + n]));
            let params = (as_f32(&rest[k..]), as_f32(&ks[k..]), as_f32(&kd[k..]));
            let e = pulls.then(|| as_f32_mut(R::flat_mut(&mut els[k0 + k..k0 + n])));
            // SAFETY: the CPU has AVX2 (the caller's test).
            k += unsafe { springs::<PROJECTED>((xs, vs), &idx[k..], params, o, Some(as_f32_mut(&mut l[k..n])), e) };
            // The block it stopped at (or the tail), one by one.
            let left = (n - k).min(8);
            for j in k..k + left {
                let [a, b] = idx[j].map(|v| v as usize);
                let (d, w) = ((q[b] - q[a]).to_array(), (qd[b] - qd[a]).to_array());
                let (f, el, len) = force_parts::<R, PROJECTED>(d, w, rest[j], ks[j], kd[j]);
                out[k0 + j] = R::V::new(f[0], f[1], f[2]);
                if pulls {
                    els[k0 + j] = R::V::new(el[0], el[1], el[2]);
                }
                l[j] = len;
            }
            k += left;
        }
        // SAFETY: springs `s0 .. s0 + n` are this chunk's alone (`par::chunks` partitions them).
        unsafe { sink.store(s0, &l[..n], rest) };
        k0 += n;
    }
}

/// Springs `idx` (end indices) with their rest lengths, stiffnesses and damping coefficients, at positions `q`
/// and velocities `qd` (3-vectors as flat components, `3n` values each): the force on each spring's end 0 into
/// `out` (3 values a spring), with `lens` each spring's length (the fracture trigger's strains are formed from
/// them: `spring::StrainSink::store`) and with `els` its elastic pull `ks (l − L0) d̂` (the loads'), eight springs
/// at a time from the first. Returns how many springs it formed: up to
/// the first block of eight with an end on the last particle, or the last whole block; the caller forms the
/// rest (and may call again past a block it formed itself).
///
/// # Safety
/// The CPU has AVX2 (the lengths and indices are checked here).
#[target_feature(enable = "avx2")]
pub(super) unsafe fn springs<const PROJECTED: bool>(
    (q, qd): (&[f32], &[f32]),
    idx: &[[u32; 2]],
    (rest, ks, kd): (&[f32], &[f32], &[f32]),
    out: &mut [f32],
    mut lens: Option<&mut [f32]>,
    mut els: Option<&mut [f32]>,
) -> usize {
    let ns = idx.len();
    assert!(q.len() == qd.len() && q.len().is_multiple_of(3));
    assert!(rest.len() == ns && ks.len() == ns && kd.len() == ns && out.len() == 3 * ns);
    assert!(lens.as_ref().is_none_or(|l| l.len() >= ns));
    assert!(els.as_ref().is_none_or(|e| e.len() >= 3 * ns));
    let n = q.len() / 3;
    if n < 2 {
        return 0;
    }
    // Every end of a wide block at most `n - 2`, so that `3 i + 4 <= 3 n`.
    let lim = _mm256_set1_epi32((n - 2).min(i32::MAX as usize) as i32);
    let mut k = 0;
    while k + 8 <= ns {
        // SAFETY: `idx[k .. k + 8]` holds 16 indices (`k + 8 <= ns`).
        let (e0, e1) = unsafe {
            let p = idx.as_ptr().add(k).cast::<__m256i>();
            (_mm256_loadu_si256(p), _mm256_loadu_si256(p.add(1)))
        };
        // `x <= lim` as `max(x, lim) == lim` (unsigned).
        let ok = _mm256_and_si256(
            _mm256_cmpeq_epi32(_mm256_max_epu32(e0, lim), lim),
            _mm256_cmpeq_epi32(_mm256_max_epu32(e1, lim), lim),
        );
        if _mm256_movemask_epi8(ok) != -1 {
            break;
        }
        let b = &idx[k..k + 8];
        let oi = [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * b[l][0] as usize);
        let oj = [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * b[l][1] as usize);
        // SAFETY: every end is at most `n - 2` (tested above): each 16-byte load stays in `q` and `qd`.
        let (xi, xj, vi, vj) =
            unsafe { (soa8(q.as_ptr(), oi), soa8(q.as_ptr(), oj), soa8(qd.as_ptr(), oi), soa8(qd.as_ptr(), oj)) };
        // SAFETY: `k + 8 <= ns`, the length of each parameter array.
        let (r, s, c) = unsafe {
            (
                _mm256_loadu_ps(rest.as_ptr().add(k)),
                _mm256_loadu_ps(ks.as_ptr().add(k)),
                _mm256_loadu_ps(kd.as_ptr().add(k)),
            )
        };
        let ((f0, f1, f2), l, (e0, e1, e2)) = force8::<PROJECTED>(sub8(xj, xi), sub8(vj, vi), r, s, c);
        // SAFETY: `out[3k .. 3k + 24]` is inside `out` (`3 ns` values), `lens[k .. k + 8]` inside `lens` and
        // `els[3k .. 3k + 24]` inside `els` (their lengths asserted above).
        unsafe {
            store_xyz8(out.as_mut_ptr().add(3 * k), f0, f1, f2);
            if let Some(lens) = lens.as_deref_mut() {
                _mm256_storeu_ps(lens.as_mut_ptr().add(k), l);
            }
            if let Some(els) = els.as_deref_mut() {
                store_xyz8(els.as_mut_ptr().add(3 * k), e0, e1, e2);
            }
        }
        k += 8;
    }
    k
}

/// [`super::spring::force_parts`]'s force on eight lanes, in its order: `l2 = (dx dx + dy dy) + dz dz`, `l =
/// sqrt(l2)`, `inv = 1 / l` where `l2 > 0` (else `+0`), `u = d inv`, `el = ks (l − L0)`; projected `u (el + kd
/// ((wx ux + wy uy) + wz uz))`, else `u el + w kd`; and the lengths `l` and the elastic parts `u el`.
#[target_feature(enable = "avx2")]
#[inline]
fn force8<const PROJECTED: bool>(
    d: (__m256, __m256, __m256),
    w: (__m256, __m256, __m256),
    rest: __m256,
    ks: __m256,
    kd: __m256,
) -> ((__m256, __m256, __m256), __m256, (__m256, __m256, __m256)) {
    let l2 = dot8(d, d);
    let l = _mm256_sqrt_ps(l2);
    let positive = _mm256_cmp_ps::<_CMP_GT_OQ>(l2, _mm256_setzero_ps());
    let inv = _mm256_and_ps(_mm256_div_ps(_mm256_set1_ps(1.0), l), positive);
    let u = (_mm256_mul_ps(d.0, inv), _mm256_mul_ps(d.1, inv), _mm256_mul_ps(d.2, inv));
    let el = _mm256_mul_ps(ks, _mm256_sub_ps(l, rest));
    let elastic = (_mm256_mul_ps(u.0, el), _mm256_mul_ps(u.1, el), _mm256_mul_ps(u.2, el));
    let f = if PROJECTED {
        let mag = _mm256_add_ps(el, _mm256_mul_ps(kd, dot8(w, u)));
        (_mm256_mul_ps(u.0, mag), _mm256_mul_ps(u.1, mag), _mm256_mul_ps(u.2, mag))
    } else {
        (
            _mm256_add_ps(elastic.0, _mm256_mul_ps(w.0, kd)),
            _mm256_add_ps(elastic.1, _mm256_mul_ps(w.1, kd)),
            _mm256_add_ps(elastic.2, _mm256_mul_ps(w.2, kd)),
        )
    };
    (f, l, elastic)
}

/// Eight 3-vectors given as components (lane `l` vector `l`) stored at `out` as 24 consecutive values: each
/// lane's `x, y, z, z` as one 16-byte store at `out + 3 l`, in lane order, so that each store's fourth value is
/// overwritten by the next lane's `x`; the last lane's three values stored alone (nothing past `out + 24` is
/// written: the next spring may be another thread's).
///
/// # Safety
/// AVX2; `out` holds 24 values.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_xyz8(out: *mut f32, cx: __m256, cy: __m256, cz: __m256) {
    // Register `l` holds vector `l` in its low half, `l + 4` in its high.
    let [o0, o1, o2, o3] = xyzz8(cx, cy, cz);
    let last = _mm256_extractf128_ps::<1>(o3);
    // SAFETY: the caller's bounds: the seven 16-byte stores end at `out + 22`, the last lane's at `out + 24`.
    unsafe {
        _mm_storeu_ps(out, _mm256_castps256_ps128(o0));
        _mm_storeu_ps(out.add(3), _mm256_castps256_ps128(o1));
        _mm_storeu_ps(out.add(6), _mm256_castps256_ps128(o2));
        _mm_storeu_ps(out.add(9), _mm256_castps256_ps128(o3));
        _mm_storeu_ps(out.add(12), _mm256_extractf128_ps::<1>(o0));
        _mm_storeu_ps(out.add(15), _mm256_extractf128_ps::<1>(o1));
        _mm_storeu_ps(out.add(18), _mm256_extractf128_ps::<1>(o2));
        // `x, y` as one 8-byte store, then `z`.
        _mm_storel_epi64(out.add(21).cast(), _mm_castps_si128(last));
        _mm_store_ss(out.add(23), _mm_movehl_ps(last, last));
    }
}

#[cfg(test)]
mod tests {
    use super::springs;
    use crate::forces::cross_avx2::tests::xorshift;
    use crate::forces::spring::force_parts;

    /// The kernel gives the portable maths' bits for every spring it forms (coincident ends included), stops at a
    /// block with an end on the last particle, and writes nothing past the springs it formed.
    #[test]
    fn eight_springs_at_a_time_give_the_portable_bits() {
        if !crate::isa::avx2() {
            return;
        }
        let mut rng = xorshift(0x9E37_79B9_7F4A_7C15);
        let mut unit = move || (rng() >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
        let n = 50;
        let q: Vec<f32> = (0..3 * n).map(|_| unit()).collect();
        let qd: Vec<f32> = (0..3 * n).map(|_| 4.0 * unit()).collect();
        let mut pick = xorshift(12345);
        for ns in [0, 7, 8, 9, 16, 40, 41] {
            // Ends below `n - 1`, one spring with coincident ends, then (when there are 24 springs) one with an end
            // on the last particle in the third block.
            let mut idx: Vec<[u32; 2]> =
                (0..ns).map(|_| [(pick() % (n as u64 - 1)) as u32, (pick() % (n as u64 - 1)) as u32]).collect();
            if ns > 3 {
                idx[3] = [5, 5];
            }
            if ns >= 24 {
                idx[20][1] = n as u32 - 1;
            }
            let rest: Vec<f32> = (0..ns).map(|_| 0.5 + unit()).collect();
            let ks: Vec<f32> = (0..ns).map(|_| 1e3 * (1.0 + unit())).collect();
            let kd: Vec<f32> = (0..ns).map(|_| 2.0 + unit()).collect();
            for projected in [true, false] {
                let (mut out, mut lens, mut els) = (vec![f32::NAN; 3 * ns], vec![f32::NAN; ns], vec![f32::NAN; 3 * ns]);
                let (params, l, e) = ((&rest[..], &ks[..], &kd[..]), Some(&mut lens[..]), Some(&mut els[..]));
                // SAFETY: the CPU has AVX2 (tested above).
                let done = unsafe {
                    if projected {
                        springs::<true>((&q, &qd), &idx, params, &mut out, l, e)
                    } else {
                        springs::<false>((&q, &qd), &idx, params, &mut out, l, e)
                    }
                };
                let want = if ns >= 24 { 16 } else { ns / 8 * 8 };
                assert_eq!(done, want, "{ns} springs");
                for (k, &[i, j]) in idx.iter().enumerate() {
                    let at = |v: &[f32], p: u32| [0, 1, 2].map(|c| v[3 * p as usize + c]);
                    let (xi, xj, vi, vj) = (at(&q, i), at(&q, j), at(&qd, i), at(&qd, j));
                    let d = [0, 1, 2].map(|c| xj[c] - xi[c]);
                    let w = [0, 1, 2].map(|c| vj[c] - vi[c]);
                    let (f, el, l) = if projected {
                        force_parts::<f32, true>(d, w, rest[k], ks[k], kd[k])
                    } else {
                        force_parts::<f32, false>(d, w, rest[k], ks[k], kd[k])
                    };
                    let got = &out[3 * k..3 * k + 3];
                    if k < done {
                        let got = [got[0], got[1], got[2]].map(f32::to_bits);
                        assert_eq!(got, f.map(f32::to_bits), "spring {k} of {ns}, {projected}");
                        assert_eq!(lens[k].to_bits(), l.to_bits(), "length of spring {k} of {ns}");
                        let e = [els[3 * k], els[3 * k + 1], els[3 * k + 2]].map(f32::to_bits);
                        assert_eq!(e, el.map(f32::to_bits), "elastic pull of spring {k} of {ns}");
                    } else {
                        assert!(got.iter().all(|x| x.is_nan()), "spring {k} of {ns} written past the blocks");
                        assert!(lens[k].is_nan(), "length {k} of {ns} written past the blocks");
                        assert!(els[3 * k..3 * k + 3].iter().all(|x| x.is_nan()), "pull {k} of {ns} written past");
                    }
                }
            }
        }
    }
}
