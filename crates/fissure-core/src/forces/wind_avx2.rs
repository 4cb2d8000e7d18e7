//! The wind pass's triangles in `f32` on AVX2, eight at a time ([`blocks`], [`block8`]): each triangle's cross
//! vector and the mean of its corners' relative air, read through its corner indices and split into components,
//! then its drag and lift (`wind::aero_components`) and pressure share, its corner force stored as a 3-vector.
//!
//! Why by hand: the portable loop ([`super::wind::wind_chunk`]) reads each triangle's three corners and three
//! relative airs one by one and stores them component by component into the span's arrays, then packs only the
//! drag and lift: `perf annotate` of the 10,242-vertex ball in wind (one thread, the Zen 4 development VM,
//! 2026-11-29) put most of its samples on those scalar loads, `vextractps` and `vmovss`. Here each corner's eight
//! 3-vectors are read as 16-byte loads and split with seven shuffles (`cross_avx2::soa8`), everything is formed
//! per component in registers, and the forces are joined back (`cross_avx2::xyzz8`) and stored as overlapping
//! 16-byte stores. Measured on that ball (one thread, the surface stage, three alternated runs each): 131.8–133.3
//! µs a step before, 111.1–112.8 with the blocks, 102.5–105.7 with one call a span instead of one a block.
//!
//! The same bits as the portable loop: glam's `cross` of `x1 − x0` and `x2 − x0` (or the gas pass's cross, as it
//! stored it), `((a0 + a1) + a2) · ⅓`, and `aero_components`' and the pressure share's operations, each lane in
//! their order, without fused multiply-adds (the tests below; `tests/isa.rs`).

use std::arch::x86_64::*;

use super::cross_avx2::{cross8, dot8, soa8, sub8, xyzz8};

/// The coefficients [`block8`] applies, each as the portable loop holds it in `f32`: one body's drag and lift
/// coefficients and pressure (a block of one body), and `½ ρ`.
#[derive(Clone, Copy)]
pub(super) struct Coefficients {
    pub cd: f32,
    pub cl: f32,
    pub pressure: f32,
    pub rho_half: f32,
}

/// ⅓ and ⅙ as the portable loop rounds them (`R::from_f64(1.0 / 3.0)` and `R::from_f64(1.0 / 6.0)` in `f32`).
const THIRD: f32 = (1.0f64 / 3.0) as f32;
const SIXTH: f32 = (1.0f64 / 6.0) as f32;

/// [`block8`] over the whole blocks of eight of `t` (one body's triangles; their crosses, with `cross`, 4 values a
/// triangle from its start), their corner forces into `out` (3 values a triangle); returns how many triangles it
/// formed (a multiple of eight; the caller forms the rest). `room`: `out` may be written one value past its
/// `3 t.len()` (the next triangle's, written after this). One call a span: a call a block cost its arguments'
/// slicing and checks each time (the wind pass's own samples 417 against the blocks' 1,782 on the 10,242-vertex
/// ball, one thread, 2026-11-29).
///
/// # Safety
/// AVX2; every corner index `i` has `3i + 4` within `air`, and within `q` without `cross`.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn blocks(
    q: &[f32],
    air: &[f32],
    t: &[[u32; 3]],
    cross: Option<&[f32]>,
    k: Coefficients,
    out: &mut [f32],
    room: bool,
) -> usize {
    let n = t.len() / 8 * 8;
    assert!(out.len() >= 3 * t.len() + usize::from(room) && cross.is_none_or(|c| c.len() >= 4 * n));
    for b in (0..n).step_by(8) {
        let c = cross.map(|c| c[4 * b..].as_ptr());
        let room = room || b + 8 < t.len();
        // SAFETY: the corner indices as the caller guarantees; `c` holds the block's 32 values and `out` from `3b`
        // its 24, and one more where a triangle of `t` follows or with the caller's `room` (asserted above).
        unsafe { block8(q.as_ptr(), air.as_ptr(), &t[b..b + 8], c, k, out[3 * b..].as_mut_ptr(), room) };
    }
    n
}

/// Eight triangles of one body (`t`: their corner indices): each one's corner force, its pressure share plus a
/// third of drag and lift (`wind::aero_components`), stored at `out` as 3-vectors (24 values). The cross is
/// `(x1 − x0) × (x2 − x0)` from the positions `q` (3-vectors as flat components), or with `cross` the one stored
/// there (4 values a triangle, glam's `Vec3A` layout, the block's first at `cross`); the relative air is the mean of
/// the corners' in `air` (3-vectors as flat components). Each lane is the portable loop's maths in its order.
/// `room`: `out` may be written one value past its 24 (the next triangle's, written after this): each vector is
/// then one 16-byte store, else the last is written as 12 bytes.
///
/// # Safety
/// AVX2; every corner index `i` has `3i + 4` within `air`, and within `q` without `cross`; `cross` (when given)
/// holds 32 values, and `out` 24 (25 with `room`).
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn block8(
    q: *const f32,
    air: *const f32,
    t: &[[u32; 3]],
    cross: Option<*const f32>,
    k: Coefficients,
    out: *mut f32,
    room: bool,
) {
    debug_assert!(t.len() == 8);
    // Corner `$j` of the eight triangles at `$base`, as three registers of components.
    macro_rules! corner {
        ($base:expr, $j:expr) => {
            // SAFETY: the caller's bounds.
            unsafe { soa8($base, [0, 1, 2, 3, 4, 5, 6, 7].map(|l| 3 * t[l][$j] as usize)) }
        };
    }
    let c = match cross {
        // SAFETY: 32 values at `cross` (the caller's bounds).
        Some(cross) => unsafe { soa8(cross, [0, 4, 8, 12, 16, 20, 24, 28]) },
        None => {
            let (p0, p1, p2) = (corner!(q, 0), corner!(q, 1), corner!(q, 2));
            cross8(sub8(p1, p0), sub8(p2, p0))
        }
    };
    let (a0, a1, a2) = (corner!(air, 0), corner!(air, 1), corner!(air, 2));
    let third = _mm256_set1_ps(THIRD);
    // (Macros, not closures: a closure is compiled without this function's AVX2, its intrinsics as calls.)
    macro_rules! mean {
        ($a:expr, $b:expr, $d:expr) => {
            _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps($a, $b), $d), third)
        };
    }
    let v = (mean!(a0.0, a1.0, a2.0), mean!(a0.1, a1.1, a2.1), mean!(a0.2, a1.2, a2.2));
    // `aero_components`, term by term.
    let (cc, vv, s) = (dot8(c, c), dot8(v, v), dot8(c, v));
    let root = _mm256_sqrt_ps(_mm256_mul_ps(cc, vv));
    let zero = _mm256_setzero_ps();
    let inv = _mm256_and_ps(_mm256_div_ps(_mm256_set1_ps(1.0), root), _mm256_cmp_ps::<_CMP_GT_OQ>(root, zero));
    let quarter = _mm256_set1_ps(k.rho_half * 0.5);
    let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), s);
    let kd = _mm256_mul_ps(_mm256_mul_ps(quarter, _mm256_set1_ps(k.cd)), abs);
    let kl = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(quarter, _mm256_set1_ps(k.cl)), s), inv);
    let ps = _mm256_set1_ps(k.pressure * SIXTH);
    macro_rules! force {
        ($c:expr, $v:expr) => {{
            let a = _mm256_add_ps(
                _mm256_mul_ps($v, kd),
                _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps($c, vv), _mm256_mul_ps($v, s)), kl),
            );
            _mm256_add_ps(_mm256_mul_ps($c, ps), _mm256_mul_ps(a, third))
        }};
    }
    let f = xyzz8(force!(c.0, v.0), force!(c.1, v.1), force!(c.2, v.2));
    // Register `l` holds triangle `l` in its low half and `l + 4` in its high: stored in the triangles' order, each
    // 16-byte store's last value overwritten by the next.
    let quads = [
        _mm256_castps256_ps128(f[0]),
        _mm256_castps256_ps128(f[1]),
        _mm256_castps256_ps128(f[2]),
        _mm256_castps256_ps128(f[3]),
        _mm256_extractf128_ps::<1>(f[0]),
        _mm256_extractf128_ps::<1>(f[1]),
        _mm256_extractf128_ps::<1>(f[2]),
        _mm256_extractf128_ps::<1>(f[3]),
    ];
    // SAFETY: `out` holds 24 values, 25 with `room` (the caller's bounds): the first seven stores end at value
    // 3 l + 4 <= 22 + 1, the last at 25 with `room`, else it writes 8 bytes and then 4.
    unsafe {
        for (l, &x) in quads.iter().enumerate().take(7) {
            _mm_storeu_ps(out.add(3 * l), x);
        }
        if room {
            _mm_storeu_ps(out.add(21), quads[7]);
        } else {
            _mm_storel_pd(out.add(21).cast(), _mm_castps_pd(quads[7]));
            _mm_store_ss(out.add(23), _mm_movehl_ps(quads[7], quads[7]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::cross_avx2::tests::xorshift;
    use super::super::wind::aero_components;
    use super::*;
    use crate::real::Real;
    use glam::Vec3;

    /// [`blocks`] gives the portable loop's corner forces bit for bit (its cross or the given one, the mean air,
    /// `aero_components`, the pressure share), for every count of triangles 0–26, with and without given crosses,
    /// with and without room past the end: it forms the whole blocks of eight and writes nothing past their values
    /// but the one `room` allows. Degenerate triangles (a repeated corner) and still air (corners whose relative
    /// air is zero) are among them.
    #[test]
    fn blocks_give_the_portable_bits() {
        if !crate::isa::avx2() {
            return;
        }
        let n = 40u32;
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let mut coord = |scale: f32| ((next() % 20_000) as f32 * 1e-4 - 1.0) * scale;
        let q: Vec<f32> = (0..3 * n).map(|_| coord(0.3)).collect();
        // Particles 0–4 in still air.
        let air: Vec<f32> = (0..3 * n).map(|k| if k < 15 { 0.0 } else { coord(5.0) }).collect();
        let at = |s: &[f32], i: u32| Vec3::from_slice(&s[3 * i as usize..]);
        let k = Coefficients { cd: 1.1, cl: 0.45, pressure: 1234.5, rho_half: 0.6125 };
        // The portable loop's constants, formed as it forms them.
        let (third, sixth) = (f32::from_f64(1.0 / 3.0), f32::from_f64(1.0 / 6.0));
        let mut pick = xorshift(0x9e37_79b9_7f4a_7c15);
        for nt in 0..27usize {
            let t: Vec<[u32; 3]> = (0..nt)
                .map(|l| {
                    let mut c = [0; 3].map(|_| (pick() % (n as u64 - 1)) as u32);
                    if l % 5 == 1 {
                        c[2] = c[0];
                    }
                    if l % 7 == 3 {
                        c = [1, 2, 3];
                    }
                    c
                })
                .collect();
            let given: Vec<f32> = (0..4 * nt).map(|_| coord(0.01)).collect();
            for with_cross in [false, true] {
                for room in [false, true] {
                    let mut out = vec![f32::NAN; 3 * nt + 1];
                    let len = 3 * nt + usize::from(room);
                    let cross = with_cross.then_some(&given[..]);
                    // SAFETY: AVX2 (tested above); every corner index is below `n - 1`.
                    let done = unsafe { blocks(&q, &air, &t, cross, k, &mut out[..len], room) };
                    assert_eq!(done, nt / 8 * 8, "{nt} triangles");
                    for (l, &[a, b, d]) in t.iter().enumerate().take(done) {
                        let c = if with_cross {
                            Vec3::from_slice(&given[4 * l..])
                        } else {
                            (at(&q, b) - at(&q, a)).cross(at(&q, d) - at(&q, a))
                        };
                        let r = (at(&air, a) + at(&air, b) + at(&air, d)) * third;
                        let f = aero_components(c.to_array(), r.to_array(), k.cd, k.cl, k.rho_half);
                        let ps = k.pressure * sixth;
                        let want = [0, 1, 2].map(|e| c[e] * ps + f[e] * third);
                        let got = [0, 1, 2].map(|e| out[3 * l + e].to_bits());
                        assert_eq!(got, want.map(f32::to_bits), "{nt} triangles, triangle {l}");
                    }
                    // Past the blocks: untouched, but for the one value after them (the tail's first, or past the end
                    // with `room`).
                    let spill = usize::from(done > 0 && (room || done < nt));
                    assert!(
                        out[3 * done + spill..].iter().all(|x| x.is_nan()),
                        "{nt} triangles: wrote past the blocks"
                    );
                }
            }
        }
    }
}
