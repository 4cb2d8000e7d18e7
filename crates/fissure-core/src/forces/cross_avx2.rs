//! The surface pass's crosses and gas volume terms ([`super::cross_chunk`]) in `f32` on AVX2, eight triangles at
//! a time, written with its intrinsics; and the same for the edges of the caps over a gas body's openings
//! ([`cap_edges`]).
//!
//! Each corner's eight positions are read as 16-byte loads (the 3-vector and one value past it, unused) and split
//! into components with seven shuffles (Intel's AoS-to-SoA transposition: each 128-bit half holds four of the
//! eight triangles); the two edges, the cross and the volume term are formed per component, and the crosses are
//! joined back into [`glam::Vec3A`]s (`x, y, z, z`: glam's own layout) with six shuffles. The block's eight volume
//! terms are then added to the body's eight partial sums in one instruction (`super::VolumeSum`: triangle `k` to
//! lane `k mod 8`, as the portable loop adds them).
//!
//! Why by hand: the portable loop is scalar (each triangle's positions come through its indices), ~30
//! instructions a triangle; this is ~12. The volume sum was one chain of additions (one a triangle, ~3 cycles
//! each), the kernel's floor, until it went to eight lanes.
//!
//! The same bits as the portable loop: each lane's maths is glam's `cross` and `dot` in their order (no fused
//! multiply-adds), and a block of eight is taken this way only when the triangles whose bodies hold gas are of one
//! body (the others add nothing to any sum) and none reads the last particle (whose 16-byte load would pass the
//! end of the positions); any other block, and the chunk's tail, go the portable way, triangle by triangle.

use std::arch::x86_64::*;

use glam::Vec3;

use super::VolumeSum;
use super::runs_avx2::shuf;

/// A chunk of the surface pass (see [`super::cross_chunk`]): triangles `tris` (corner indices), of bodies
/// `bodies`, at positions `q` (3-vectors as flat components, `3n` values); each triangle's cross into `cross` (4
/// values a triangle, the [`glam::Vec3A`] layout), and with `pressure` its volume term `(x0 − anchor) · cross`
/// summed into `part[body]` for the bodies whose `gas` is positive (`anchor`: each body's anchor particle).
///
/// # Safety
/// The CPU has AVX2 (the bounds are checked here).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn crosses(
    q: &[f32],
    tris: &[[u32; 3]],
    bodies: &[u32],
    (gas, anchors): (&[f32], &[u32]),
    pressure: bool,
    cross: &mut [f32],
    part: &mut [f32],
) {
    let n = q.len() / 3;
    // (Every other index is checked where it is used: the wide blocks' corners below, the rest by the slices.)
    assert!(bodies.len() == tris.len() && cross.len() == 4 * tris.len() && q.len() == 3 * n);
    let at = |i: u32| Vec3::from_slice(&q[3 * i as usize..3 * i as usize + 3]);
    // Only gas bodies' partials are written and read (see `ForceScratch::surface`).
    part.iter_mut().zip(gas).filter(|(_, g)| **g > 0.0).for_each(|(p, _)| *p = 0.0);
    let mut sum = VolumeSum::<f32>::new();
    // Triangle `k` the portable way.
    let one = |k: usize, sum: &mut VolumeSum<f32>, cross: &mut [f32], part: &mut [f32]| {
        let [a, b, d] = tris[k];
        let x0 = at(a);
        let c = (at(b) - x0).cross(at(d) - x0);
        cross[4 * k..4 * k + 4].copy_from_slice(&[c.x, c.y, c.z, c.z]);
        let body = bodies[k] as usize;
        if pressure && gas[body] > 0.0 {
            sum.switch(body, part, || at(anchors[body]));
            sum.add(k, (x0 - sum.anchor).dot(c));
        }
    };
    let mut k = 0;
    for (t8, b8) in tris.chunks_exact(8).zip(bodies.chunks_exact(8)) {
        // SAFETY: `t8` holds 24 indices and `b8` 8 bodies.
        let wide = if n >= 2 { unsafe { fits(t8.as_ptr().cast(), b8.as_ptr(), n - 2, gas, pressure) } } else { None };
        let Some((lanes, body)) = wide else {
            (k..k + 8).for_each(|k| one(k, &mut sum, cross, part));
            k += 8;
            continue;
        };
        let gassy = lanes != 0;
        if gassy {
            sum.switch(body as usize, part, || at(anchors[body as usize]));
        }
        // SAFETY: every index is below `n - 1` (tested above), so each 16-byte load stays in `q`; the block's
        // crosses are `cross[4k .. 4k + 32]`, inside `cross` (its length asserted above).
        let dots = unsafe { block(q.as_ptr(), t8, sum.anchor, cross.as_mut_ptr().add(4 * k), lanes) };
        if gassy {
            // Each term to its lane (`k` is a multiple of 8); the lanes without gas hold `-0`, which adds nothing
            // (`x + -0 = x` for every `x`, `-0` and NaN included): no branch a lane.
            // SAFETY: `lanes` holds 8 values.
            unsafe {
                let l = _mm256_add_ps(_mm256_loadu_ps(sum.lanes.as_ptr()), dots);
                _mm256_storeu_ps(sum.lanes.as_mut_ptr(), l);
            }
        }
        k += 8;
    }
    (k..tris.len()).for_each(|k| one(k, &mut sum, cross, part));
    sum.finish(part);
}

/// Whether a block of eight triangles (`t`: 24 corner indices, `b`: their 8 bodies) can go the wide way, and if
/// so its lanes that add to a gas volume (bit `l` for lane `l`) and their body: every corner index at most `last`,
/// every body one of `gas`'s, and (with `pressure`) every lane whose body holds gas of one body. Lanes of bodies
/// without gas add nothing, in the portable loop as here: a split ball's core blocks (no gas) leave 41 % of its
/// blocks with two bodies, which all went the portable way while every body had to be the same.
///
/// # Safety
/// AVX2; `t` holds 24 values and `b` 8.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn fits(t: *const u32, b: *const u32, last: usize, gas: &[f32], pressure: bool) -> Option<(u32, u32)> {
    let lim = _mm256_set1_epi32(u32::try_from(last).unwrap_or(u32::MAX) as i32);
    let nb = _mm256_set1_epi32(u32::try_from(gas.len().checked_sub(1)?).unwrap_or(u32::MAX) as i32);
    // SAFETY: the caller's bounds.
    let (t0, t1, t2, b) = unsafe {
        (
            _mm256_loadu_si256(t.cast()),
            _mm256_loadu_si256(t.add(8).cast()),
            _mm256_loadu_si256(t.add(16).cast()),
            _mm256_loadu_si256(b.cast()),
        )
    };
    // `x <= lim` as `max(x, lim) == lim` (unsigned; a macro, not a closure: see `block`).
    macro_rules! below {
        ($x:expr, $lim:expr) => {
            _mm256_cmpeq_epi32(_mm256_max_epu32($x, $lim), $lim)
        };
    }
    let ok = _mm256_and_si256(
        _mm256_and_si256(below!(t0, lim), below!(t1, lim)),
        _mm256_and_si256(below!(t2, lim), below!(b, nb)),
    );
    if _mm256_movemask_epi8(ok) != -1 {
        return None;
    }
    if !pressure {
        return Some((0, 0));
    }
    // One body (the usual block): its gas decides, without the gather.
    let b0 = _mm256_cvtsi256_si32(b) as u32;
    if _mm256_movemask_epi8(_mm256_cmpeq_epi32(b, _mm256_set1_epi32(b0 as i32))) == -1 {
        return Some((if gas[b0 as usize] > 0.0 { 0xff } else { 0 }, b0));
    }
    // SAFETY: every body is below `gas.len()` (tested just above).
    let g = unsafe { _mm256_i32gather_ps::<4>(gas.as_ptr(), b) };
    let lanes = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(g, _mm256_setzero_ps())) as u32;
    if lanes == 0 {
        return Some((0, 0));
    }
    let first = _mm256_permutevar8x32_epi32(b, _mm256_set1_epi32(lanes.trailing_zeros() as i32));
    let same = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(b, first))) as u32;
    (lanes & !same == 0).then(|| (lanes, _mm256_cvtsi256_si32(first) as u32))
}

/// Eight triangles: their crosses stored at `out` (32 values), their volume terms about `anchor` returned in the
/// lanes set in `lanes` (bit `l` for lane `l`) and `-0` in the others (all `-0` when `lanes` is 0). Written
/// without closures or `map`: those are compiled without the caller's AVX2, and their intrinsics become calls
/// (`super::runs_avx2`).
///
/// # Safety
/// AVX2; each corner index `i` has `3i + 4 <= q`'s length, and `out` holds 32 values.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn block(q: *const f32, t: &[[u32; 3]], anchor: Vec3, out: *mut f32, lanes: u32) -> __m256 {
    // Corner `$c` of the eight triangles as three registers of components, lane `l` triangle `l`.
    macro_rules! corner {
        ($c:expr) => {
            // SAFETY: the caller's bounds.
            unsafe { soa8(q, [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * t[l][$c] as usize)) }
        };
    }
    let (p0, p1, p2) = (corner!(0), corner!(1), corner!(2));
    // glam's `cross` of `x1 − x0` and `x2 − x0`.
    let c = cross8(sub8(p1, p0), sub8(p2, p0));
    // SAFETY: `out` holds 32 values (the caller's bounds).
    unsafe { store_xyzz(out, c.0, c.1, c.2) };
    if lanes == 0 {
        return _mm256_set1_ps(-0.0);
    }
    {
        // glam's `dot` of `x0 − anchor` and the cross.
        let a = (_mm256_set1_ps(anchor.x), _mm256_set1_ps(anchor.y), _mm256_set1_ps(anchor.z));
        let s = dot8(sub8(p0, a), c);
        let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let keep = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(lanes as i32), bit), bit);
        _mm256_blendv_ps(_mm256_set1_ps(-0.0), s, _mm256_castsi256_ps(keep))
    }
}

/// Eight 3-vectors at `base + off[l]` (`f32` offsets) as three registers of components, lane `l` the vector at
/// `off[l]`: each read as a 16-byte load (the vector and one value past it, unused) and split with seven shuffles
/// (Intel's AoS-to-SoA transposition: each 128-bit half holds four of the eight).
///
/// # Safety
/// AVX2; `base + off[l] .. + 4` readable for every lane.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn soa8(base: *const f32, off: [usize; 8]) -> (__m256, __m256, __m256) {
    // (A macro, not a closure: see `block`.)
    macro_rules! pair {
        ($l:expr) => {
            // SAFETY: the caller's bounds.
            unsafe {
                _mm256_insertf128_ps::<1>(
                    _mm256_castps128_ps256(_mm_loadu_ps(base.add(off[$l]))),
                    _mm_loadu_ps(base.add(off[$l + 4])),
                )
            }
        };
    }
    let (r0, r1, r2, r3) = (pair!(0), pair!(1), pair!(2), pair!(3));
    let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
    let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
    (
        _mm256_shuffle_ps::<{ shuf(1, 0, 1, 0) }>(t0, t2),
        _mm256_shuffle_ps::<{ shuf(3, 2, 3, 2) }>(t0, t2),
        _mm256_shuffle_ps::<{ shuf(1, 0, 1, 0) }>(t1, t3),
    )
}

/// Eight 3-vectors given as components (lane `l` vector `l`) stored at `out` as `x, y, z, z` each (glam's
/// [`glam::Vec3A`] layout, 32 values), joined with six shuffles.
///
/// # Safety
/// AVX2; `out` holds 32 values.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_xyzz(out: *mut f32, cx: __m256, cy: __m256, cz: __m256) {
    let [o0, o1, o2, o3] = xyzz8(cx, cy, cz);
    // SAFETY: the caller's bounds.
    unsafe {
        _mm_storeu_ps(out, _mm256_castps256_ps128(o0));
        _mm_storeu_ps(out.add(4), _mm256_castps256_ps128(o1));
        _mm_storeu_ps(out.add(8), _mm256_castps256_ps128(o2));
        _mm_storeu_ps(out.add(12), _mm256_castps256_ps128(o3));
        _mm_storeu_ps(out.add(16), _mm256_extractf128_ps::<1>(o0));
        _mm_storeu_ps(out.add(20), _mm256_extractf128_ps::<1>(o1));
        _mm_storeu_ps(out.add(24), _mm256_extractf128_ps::<1>(o2));
        _mm_storeu_ps(out.add(28), _mm256_extractf128_ps::<1>(o3));
    }
}

/// Eight 3-vectors given as components (lane `l` vector `l`) joined into `x, y, z, z` quadruples with six
/// shuffles: register `l` holds vector `l` in its low half and `l + 4` in its high.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn xyzz8(cx: __m256, cy: __m256, cz: __m256) -> [__m256; 4] {
    let (u0, u1) = (_mm256_unpacklo_ps(cx, cy), _mm256_unpackhi_ps(cx, cy));
    let (v0, v1) = (_mm256_unpacklo_ps(cz, cz), _mm256_unpackhi_ps(cz, cz));
    [
        _mm256_shuffle_ps::<{ shuf(1, 0, 1, 0) }>(u0, v0),
        _mm256_shuffle_ps::<{ shuf(3, 2, 3, 2) }>(u0, v0),
        _mm256_shuffle_ps::<{ shuf(1, 0, 1, 0) }>(u1, v1),
        _mm256_shuffle_ps::<{ shuf(3, 2, 3, 2) }>(u1, v1),
    ]
}

/// glam's `cross` of `a` and `b` on eight lanes: `(ay bz − by az, az bx − bz ax, ax by − bx ay)`.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn cross8(a: (__m256, __m256, __m256), b: (__m256, __m256, __m256)) -> (__m256, __m256, __m256) {
    let ((ax, ay, az), (bx, by, bz)) = (a, b);
    (
        _mm256_sub_ps(_mm256_mul_ps(ay, bz), _mm256_mul_ps(by, az)),
        _mm256_sub_ps(_mm256_mul_ps(az, bx), _mm256_mul_ps(bz, ax)),
        _mm256_sub_ps(_mm256_mul_ps(ax, by), _mm256_mul_ps(bx, ay)),
    )
}

/// `a − b` on eight lanes of 3-vectors.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn sub8(a: (__m256, __m256, __m256), b: (__m256, __m256, __m256)) -> (__m256, __m256, __m256) {
    (_mm256_sub_ps(a.0, b.0), _mm256_sub_ps(a.1, b.1), _mm256_sub_ps(a.2, b.2))
}

/// glam's `dot` on eight lanes: `(ax bx + ay by) + az bz`.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn dot8(a: (__m256, __m256, __m256), b: (__m256, __m256, __m256)) -> __m256 {
    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a.0, b.0), _mm256_mul_ps(a.1, b.1)), _mm256_mul_ps(a.2, b.2))
}

/// The caps' loop edges (`pressure::CapPieces::edges`), eight at a time across loops: edge `k` from particle
/// `rim[k]` to `next[k]` on loop `loop_of[k]`, whose centroid `c` and anchor `a` are `spots[8 l ..]` and
/// `spots[8 l + 4 ..]` (padded 3-vectors); its volume term `(xj − a) · ((xi − a) × (c − a))` into `terms[k]` and
/// its gradient `((xi − xj) × (c − xj)) / 6` into `e[4 k ..]` (padded), each lane glam's maths in its order (the
/// same bits as the portable loop). Returns how many edges it formed: the blocks of eight from the first, up to
/// the first block with an end on the last particle (whose 16-byte load would pass the end of the positions); the
/// caller forms the rest.
///
/// # Safety
/// The CPU has AVX2 (the bounds are checked here).
#[target_feature(enable = "avx2")]
pub(super) unsafe fn cap_edges(
    q: &[f32],
    (rim, next, loop_of): (&[u32], &[u32], &[u32]),
    spots: &[f32],
    terms: &mut [f32],
    e: &mut [f32],
) -> usize {
    let (n, ne, nl) = (q.len() / 3, rim.len(), spots.len() / 8);
    assert!(next.len() == ne && loop_of.len() == ne && terms.len() == ne && e.len() == 4 * ne);
    assert!(q.len() == 3 * n && spots.len() == 8 * nl);
    let sixth = _mm256_set1_ps((1.0f64 / 6.0) as f32);
    let mut k = 0;
    while k + 8 <= ne {
        let (ri, nj, lo) = (&rim[k..k + 8], &next[k..k + 8], &loop_of[k..k + 8]);
        if n < 2 || ri.iter().chain(nj).any(|&i| i as usize > n - 2) || lo.iter().any(|&l| l as usize >= nl) {
            break;
        }
        // SAFETY: every particle index is below `n - 1` and every loop below `nl` (tested above), so each 16-byte
        // load stays in `q` or `spots`; `terms[k..k + 8]` and `e[4k..4k + 32]` are in bounds (`k + 8 <= ne`).
        unsafe {
            let xi = soa8(q.as_ptr(), [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * ri[l] as usize));
            let xj = soa8(q.as_ptr(), [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * nj[l] as usize));
            let c = soa8(spots.as_ptr(), [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 8 * lo[l] as usize));
            let a = soa8(spots.as_ptr(), [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 8 * lo[l] as usize + 4));
            let t = dot8(sub8(xj, a), cross8(sub8(xi, a), sub8(c, a)));
            _mm256_storeu_ps(terms.as_mut_ptr().add(k), t);
            let (gx, gy, gz) = cross8(sub8(xi, xj), sub8(c, xj));
            let (gx, gy, gz) = (_mm256_mul_ps(gx, sixth), _mm256_mul_ps(gy, sixth), _mm256_mul_ps(gz, sixth));
            store_xyzz(e.as_mut_ptr().add(4 * k), gx, gy, gz);
        }
        k += 8;
    }
    k
}

#[cfg(test)]
pub(super) mod tests {
    use crate::real::Real;
    use glam::{Vec3, Vec3A};

    /// Marsaglia's xorshift generator from `seed` (not 0): the tests' positions and indices (here and in
    /// `super::super::spring_avx2`'s).
    pub(in crate::forces) fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        }
    }

    /// The portable loop (`super::super::cross_chunk`'s), written out over plain slices.
    fn portable(q: &[Vec3], tris: &[[u32; 3]], bodies: &[u32], gas: &[f32], anchors: &[u32]) -> (Vec<f32>, Vec<f32>) {
        let (mut cross, mut part) = (Vec::new(), vec![0.0f32; gas.len()]);
        let (mut cur, mut lanes, mut anchor) = (usize::MAX, [-0.0f32; 8], Vec3::ZERO);
        let join = |l: [f32; 8]| ((l[0] + l[1]) + (l[2] + l[3])) + ((l[4] + l[5]) + (l[6] + l[7]));
        for (k, (&[a, b, d], &body)) in tris.iter().zip(bodies).enumerate() {
            let (x0, x1, x2) = (q[a as usize], q[b as usize], q[d as usize]);
            let cr = (x1 - x0).cross(x2 - x0);
            // glam's own padded layout (`x, y, z, z`).
            let padded = Vec3A::from(cr);
            // SAFETY: a `Vec3A` is four `f32`s.
            cross.extend(unsafe { std::mem::transmute::<Vec3A, [f32; 4]>(padded) });
            let body = body as usize;
            if gas[body] > 0.0 {
                if body != cur {
                    if cur != usize::MAX {
                        part[cur] += join(lanes);
                    }
                    (cur, lanes, anchor) = (body, [-0.0; 8], q[anchors[body] as usize]);
                }
                lanes[k % 8] += (x0 - anchor).dot(cr);
            }
        }
        if cur != usize::MAX {
            part[cur] += join(lanes);
        }
        (cross, part)
    }

    /// Every block kind (one body, a body with gas beside bodies without, two bodies with gas, a body without gas,
    /// a corner on the last particle) and every tail length 0–7 give the portable loop's bits.
    #[test]
    fn crosses_match_the_portable_loop() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let n = 97u32;
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let q: Vec<Vec3> =
            (0..n).map(|_| Vec3::from_array([0; 3].map(|_| (next() % 20_000) as f32 * 1e-4 - 1.0))).collect();
        let (gas, anchors) = (vec![2.0f32, 0.0, 1.5], vec![5u32, 17, 40]);
        for len in 64..72 {
            let tris: Vec<[u32; 3]> = (0..len)
                .map(|k| if k == 9 { [n - 1, 3, 4] } else { [0; 3].map(|_| (next() % n as u64) as u32) })
                .collect();
            // Runs of one body, a block of a body with gas and one without, a body without gas, the two
            // interleaved, a block of two bodies with gas (the portable way), then back to a body seen before.
            let bodies: Vec<u32> = (0..len)
                .map(|k| match k {
                    0..24 => 0,
                    24..29 => 2,
                    29..40 => 1,
                    40..48 => [2, 1, 2, 1, 1, 2, 1, 1][k - 40],
                    48..56 => [2, 2, 0, 0, 2, 1, 0, 2][k - 48],
                    _ => 2,
                })
                .collect();
            let (want_cross, want_part) = portable(&q, &tris, &bodies, &gas, &anchors);
            let (mut cross, mut part) = (vec![f32::NAN; 4 * len], vec![f32::NAN; 3]);
            // SAFETY: AVX2, tested above.
            unsafe { super::crosses(f32::flat(&q), &tris, &bodies, (&gas, &anchors), true, &mut cross, &mut part) };
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&cross), bits(&want_cross), "crosses, {len} triangles");
            // Bodies without gas have no partials (neither written nor read).
            let gassy =
                |v: &[f32]| v.iter().zip(&gas).filter(|(_, g)| **g > 0.0).map(|(x, _)| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(gassy(&part), gassy(&want_part), "volume partials, {len} triangles");
        }
    }

    /// The caps' edges eight at a time give glam's bits, edge by edge, for every count of edges 0–27 (blocks and
    /// the tail the caller forms), and stop at the first block with an end on the last particle.
    #[test]
    fn cap_edges_match_glam() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let n = 61u32;
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut coord = || (next() % 20_000) as f32 * 1e-4 - 1.0;
        let q: Vec<Vec3> = (0..n).map(|_| Vec3::new(coord(), coord(), coord())).collect();
        let loops = 5;
        let spots: Vec<f32> = (0..8 * loops).map(|k| if k % 4 == 3 { 0.0 } else { coord() }).collect();
        let spot = |l: u32, s: usize| Vec3::from_slice(&spots[8 * l as usize + 4 * s..]);
        for ne in 0..28usize {
            for last_at in [None, Some(11)] {
                let mut pick = |k: usize| if Some(k) == last_at { n - 1 } else { (next() % (n as u64 - 1)) as u32 };
                let rim: Vec<u32> = (0..ne).map(&mut pick).collect();
                let ends: Vec<u32> = (0..ne).map(|k| rim[(k + 1) % ne]).collect();
                let loop_of: Vec<u32> = (0..ne).map(|k| (k * loops / ne.max(1)) as u32).collect();
                let (mut terms, mut e) = (vec![f32::NAN; ne], vec![f32::NAN; 4 * ne]);
                // SAFETY: AVX2, tested above.
                let done =
                    unsafe { super::cap_edges(f32::flat(&q), (&rim, &ends, &loop_of), &spots, &mut terms, &mut e) };
                let blocks = ne / 8 * 8;
                let want_done = match last_at {
                    Some(k) if k < blocks => k / 8 * 8,
                    _ => blocks,
                };
                assert_eq!(done, want_done, "{ne} edges, last particle at {last_at:?}");
                for k in 0..done {
                    let (xi, xj) = (q[rim[k] as usize], q[ends[k] as usize]);
                    let (c, a) = (spot(loop_of[k], 0), spot(loop_of[k], 1));
                    let t = (xj - a).dot((xi - a).cross(c - a));
                    let g = (xi - xj).cross(c - xj) * (1.0f64 / 6.0) as f32;
                    assert_eq!(terms[k].to_bits(), t.to_bits(), "term of edge {k} of {ne}");
                    let got = Vec3::from_slice(&e[4 * k..]);
                    assert_eq!(got.to_array().map(f32::to_bits), g.to_array().map(f32::to_bits), "edge {k} of {ne}");
                }
            }
        }
    }
}
