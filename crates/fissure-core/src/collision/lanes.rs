//! Planes and balls against a block of particles at once: [`PreparedCollider::resolve`] lane by lane.
//!
//! A cloth resting on the ground keeps nearly every particle in contact, and the per-particle resolve (a plane's
//! push, the collider's velocity, the normal and friction response, then a second sweep that finds the particle
//! clear) cost ~15 ns a particle on one thread: on the harness's 128² cloth draped over the ground and a ball,
//! 2.2× the spring pass (2026-11-25). Here the same formulas run over 32 particles at a time in per-component
//! arrays, with selects where the scalar code branches: the compiler packs them. Each lane performs the scalar
//! code's operations in its order, so the bits are the same (the state-hash scenes with a ground check it);
//! sweeps repeat while any lane was pushed, which leaves the lanes that were not as they were (their next test
//! sees the same position). Colliders of other shapes go through the scalar path.

use super::{Collider, PreparedCollider, Quick};

/// Particles per block.
pub(crate) const LANES: usize = 32;

/// A block's positions and velocities per component, and which lanes a collider pushed.
pub(crate) struct Lanes {
    pub x: [[f32; LANES]; 3],
    pub v: [[f32; LANES]; 3],
    pub hit: [bool; LANES],
}

impl Lanes {
    pub(crate) fn new() -> Self {
        Lanes { x: [[0.0; LANES]; 3], v: [[0.0; LANES]; 3], hit: [false; LANES] }
    }
}

/// Whether [`resolve_lanes`] serves `prepared`: planes and balls only.
pub(crate) fn all_closed_form(prepared: &[PreparedCollider]) -> bool {
    prepared.iter().all(|p| !matches!(p.quick, Quick::None))
}

crate::isa::wide_kernel! {
    /// Every lane of `b` against `prepared` (prepared from `colliders`, all of them, in order), sweeping until no lane
    /// is pushed (at most 3 sweeps; one with a single collider), as the collision pass's `sweeps` does particle by
    /// particle; `b.hit` tells which lanes were pushed. Only for [`all_closed_form`] colliders. Compiled for AVX-512
    /// or AVX2 when the CPU has them (the same bits: see `crate::isa`).
    pub(crate) fn resolve_lanes[](prepared: &[PreparedCollider], colliders: &[Collider], b: &mut Lanes)
        => resolve_lanes_impl[]
}

#[inline(always)]
fn resolve_lanes_impl(prepared: &[PreparedCollider], colliders: &[Collider], b: &mut Lanes) {
    b.hit = [false; LANES];
    for _sweep in 0..3 {
        let mut any = false;
        for (p, c) in prepared.iter().zip(colliders) {
            any |= collider_lanes(p, c, b);
        }
        if !any || colliders.len() == 1 {
            break;
        }
    }
}

/// One collider against every lane; true if it pushed one. (The negated comparisons are the scalar code's early
/// returns turned around: a NaN distance counts as a contact there too.)
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn collider_lanes(p: &PreparedCollider, c: &Collider, b: &mut Lanes) -> bool {
    let z = [[0.0f32; LANES]; 3];
    let (mut xn, mut nrm) = (z, z);
    let mut contact = [false; LANES];
    match p.quick {
        Quick::Plane(n, d, _) => {
            let (n, margin) = (n.to_array(), c.margin);
            for k in 0..LANES {
                // `resolve`'s plane: the signed distance; at or past the margin no contact.
                let s = (n[0] * b.x[0][k] + n[1] * b.x[1][k]) + n[2] * b.x[2][k] - d;
                contact[k] = !(s >= margin);
                let t = margin - s;
                for e in 0..3 {
                    xn[e][k] = b.x[e][k] + n[e] * t;
                    nrm[e][k] = n[e];
                }
            }
        }
        Quick::Sphere(centre, reach, r) => {
            let centre = centre.to_array();
            let (lim, m2, out) = (reach * reach * (1.0 + 1e-4) + 1e-12, c.margin * c.margin, r + c.margin);
            // Each lane's offset from the centre (in `nrm` until the normal replaces it) and its square.
            let mut l2 = [0.0f32; LANES];
            for k in 0..LANES {
                for e in 0..3 {
                    nrm[e][k] = b.x[e][k] - centre[e];
                }
                l2[k] = (nrm[0][k] * nrm[0][k] + nrm[1][k] * nrm[1][k]) + nrm[2][k] * nrm[2][k];
            }
            // No lane within reach (most blocks of a cloth lying beside a ball): no contact, and none of the
            // square roots and divisions below (the 128² cloth draped over the ground and a ball, two threads,
            // 2026-11-27: the colliders' added cost 33–35 → 28 µs a step).
            if l2.iter().all(|&l2| l2 > lim) {
                return false;
            }
            for k in 0..LANES {
                let (d, l2) = ([nrm[0][k], nrm[1][k], nrm[2][k]], l2[k]);
                let l = l2.sqrt();
                let clear = (l >= r) & ((l - r) * (l - r) >= m2);
                contact[k] = !(l2 > lim) & !clear;
                let pos = l > 0.0;
                // `d / l`, or +y at the centre.
                let n = [
                    if pos { d[0] / l } else { 0.0 },
                    if pos { d[1] / l } else { 1.0 },
                    if pos { d[2] / l } else { 0.0 },
                ];
                for e in 0..3 {
                    xn[e][k] = centre[e] + n[e] * out;
                    nrm[e][k] = n[e];
                }
            }
        }
        Quick::None => unreachable!("resolve_lanes serves planes and balls only"),
    }
    // `resolve`'s response: the collider's velocity at the contact, the normal part reflected (or stopped below
    // the restitution threshold), the tangential part shortened by Coulomb friction; none when separating.
    let (lin, ang, t) = (c.linear_velocity.to_array(), c.angular_velocity.to_array(), p.pose.translation.to_array());
    // No lane touches (a block near a collider but clear of it): no response to form.
    if !contact.iter().any(|&c| c) {
        return false;
    }
    let (threshold, restitution, friction) = (c.restitution_threshold, c.restitution, c.friction);
    // One loop, each select a blend of bits (both values formed, as in a vector). Written with
    // `if`s over `bool`s, LLVM turned the selects between two arrays into a load through a selected pointer and
    // kept the update scalar, a quarter of the block's time (`perf annotate`, the 2,562-vertex ball after 100 core splits, its
    // blocks resting on the ground, one thread, 2026-11-29); with the blends it packs the one loop as it packed
    // the three it replaces (their arrays between them: the same samples). The same operations per lane, so the
    // same bits. What remains is the chain through the square root and the division (`vt_len`, `scale`).
    let touch: [u32; LANES] = std::array::from_fn(|k| mask(contact[k]));
    for k in 0..LANES {
        let xr = [xn[0][k] - t[0], xn[1][k] - t[1], xn[2][k] - t[2]];
        let vc = [
            lin[0] + (ang[1] * xr[2] - xr[1] * ang[2]),
            lin[1] + (ang[2] * xr[0] - xr[2] * ang[0]),
            lin[2] + (ang[0] * xr[1] - xr[0] * ang[1]),
        ];
        let n = [nrm[0][k], nrm[1][k], nrm[2][k]];
        let vr = [b.v[0][k] - vc[0], b.v[1][k] - vc[1], b.v[2][k] - vc[2]];
        let vn = (vr[0] * n[0] + vr[1] * n[1]) + vr[2] * n[2];
        let vn_new = blend(mask(-vn > threshold), -restitution * vn, 0.0);
        let vt = [vr[0] - n[0] * vn, vr[1] - n[1] * vn, vr[2] - n[2] * vn];
        let vt_len = ((vt[0] * vt[0] + vt[1] * vt[1]) + vt[2] * vt[2]).sqrt();
        let scale = blend(mask(vt_len > 0.0), (1.0 - friction * (vn_new - vn) / vt_len).max(0.0), 0.0);
        let keep = mask(vn >= 0.0) | !touch[k];
        for e in 0..3 {
            let v_out = (vc[e] + vt[e] * scale) + n[e] * vn_new;
            b.v[e][k] = blend(keep, b.v[e][k], v_out);
            b.x[e][k] = blend(touch[k], xn[e][k], b.x[e][k]);
        }
    }
    for k in 0..LANES {
        b.hit[k] |= contact[k];
    }
    // A lane touched: the blocks with none returned above.
    true
}

/// All ones where `c`, else zero: a lane's mask for [`blend`].
#[inline(always)]
fn mask(c: bool) -> u32 {
    (c as u32).wrapping_neg()
}

/// `a` where `m` is all ones, `b` where it is zero, bit for bit: `Real::pick` with its mask formed by the caller,
/// so that the contact flags become masks once per block (`Real::pick`, forming the mask from a `bool` at each
/// select, made `resolve_lanes` ~20 % slower on the split ball's resting blocks: 237–259 → 290–311 samples,
/// 2026-11-29).
#[inline(always)]
fn blend(m: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// A whole block's positions (`q`: `LANES` 3-vectors as flat `f32` components) into `b.x` per component with
/// two-source permutes (`isa::vec3x16`), and the box of its positions: per component the least and greatest value,
/// NaN ignored as `f32::min` and `f32::max` ignore it (`+∞`/`-∞` if every value is NaN), so the same box as the
/// scalar loop's. The transposition and box were a third of the collision pass's time (`perf`, the 128² cloth
/// draped over the ground and a ball, 2026-11-27). The velocities are transposed apart ([`load_velocities`]), only
/// for the blocks a collider may reach (most blocks of a ball above the ground reach none), and the box is reduced
/// with the three components side by side and returned as one 16-byte value: reduced one component at a time and
/// returned as six scalars, it made the caller's first read of it wait for the reductions and a failed
/// store-to-load forwarding, ~37 % of the collision pass's own samples (`perf annotate`, the 2,562-vertex ball
/// after 100 core splits, one thread, 2026-11-29).
///
/// # Safety
/// The CPU has AVX-512 F and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
pub(crate) unsafe fn load_positions(q: &[f32], b: &mut Lanes) -> ([f32; 4], [f32; 4]) {
    use std::arch::x86_64::*;
    // SAFETY: AVX-512 F and VL (the target features).
    let halves = unsafe { transpose(q, &mut b.x) };
    let (mut lo, mut hi) = ([_mm512_set1_ps(f32::INFINITY); 3], [_mm512_set1_ps(f32::NEG_INFINITY); 3]);
    for x in halves {
        for e in 0..3 {
            // `min(x, lo)` is `lo` where `x` is NaN: NaN is ignored.
            lo[e] = _mm512_min_ps(x[e], lo[e]);
            hi[e] = _mm512_max_ps(x[e], hi[e]);
        }
    }
    // No lane of `lo` or `hi` is NaN, so the order of the reduction does not change the least and greatest value.
    let (mut l, mut h) = ([0.0f32; 4], [0.0f32; 4]);
    // SAFETY: 16 bytes each; AVX-512 F (the target features).
    unsafe {
        _mm_storeu_ps(l.as_mut_ptr(), reduce3::<true>(lo));
        _mm_storeu_ps(h.as_mut_ptr(), reduce3::<false>(hi));
    }
    (l, h)
}

/// The least (`MIN`) or greatest value of each of three registers, as lanes 0, 1, 2 of one (lane 3: lane 2's).
/// Written without closures: a closure does not take the caller's target features, and the intrinsics in one
/// were calls (the collision stage ~10× slower, 2 → 21 µs on the breakable 2,562-vertex ball).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn reduce3<const MIN: bool>(v: [std::arch::x86_64::__m512; 3]) -> std::arch::x86_64::__m128 {
    use std::arch::x86_64::*;
    // SAFETY: AVX-512 F (the caller's target features).
    unsafe {
        let mut q = [_mm_setzero_ps(); 3];
        for e in 0..3 {
            let (a, b) =
                (_mm512_castps512_ps256(v[e]), _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(v[e]))));
            let h = if MIN { _mm256_min_ps(a, b) } else { _mm256_max_ps(a, b) };
            let (a, b) = (_mm256_castps256_ps128(h), _mm256_extractf128_ps::<1>(h));
            q[e] = if MIN { _mm_min_ps(a, b) } else { _mm_max_ps(a, b) };
        }
        // Four lanes of x, y, z each → (x, y, z, z) per lane, then the four lanes' values against each other.
        let (xy_lo, xy_hi) = (_mm_unpacklo_ps(q[0], q[1]), _mm_unpackhi_ps(q[0], q[1]));
        let (zz_lo, zz_hi) = (_mm_unpacklo_ps(q[2], q[2]), _mm_unpackhi_ps(q[2], q[2]));
        let (c0, c1) = (_mm_movelh_ps(xy_lo, zz_lo), _mm_movehl_ps(zz_lo, xy_lo));
        let (c2, c3) = (_mm_movelh_ps(xy_hi, zz_hi), _mm_movehl_ps(zz_hi, xy_hi));
        if MIN {
            _mm_min_ps(_mm_min_ps(c0, c1), _mm_min_ps(c2, c3))
        } else {
            _mm_max_ps(_mm_max_ps(c0, c1), _mm_max_ps(c2, c3))
        }
    }
}

/// A whole block's velocities (`qd`, as [`load_positions`] reads `q`) into `b.v` per component.
///
/// # Safety
/// The CPU has AVX-512 F and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
pub(crate) unsafe fn load_velocities(qd: &[f32], b: &mut Lanes) {
    // SAFETY: AVX-512 F and VL (the target features).
    unsafe { transpose(qd, &mut b.v) };
}

/// `LANES` 3-vectors (flat components) into `out` per component with two-source permutes (`isa::vec3x16`), for
/// [`load_positions`] and [`load_velocities`]; returns the registers of each half of 16 lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn transpose(s: &[f32], out: &mut [[f32; LANES]; 3]) -> [[std::arch::x86_64::__m512; 3]; LANES / 16] {
    use crate::isa::vec3x16::split_into;
    use std::arch::x86_64::*;
    assert!(s.len() == 3 * LANES);
    // SAFETY: AVX-512 F (the caller's target features).
    let mut halves = [[unsafe { _mm512_setzero_ps() }; 3]; LANES / 16];
    for (h, half) in halves.iter_mut().enumerate() {
        let [x, y, z] = &mut *out;
        let at = 16 * h;
        // SAFETY: 48 values from 48 h, within the asserted length; AVX-512 F (the caller's target features).
        *half = unsafe { split_into(s, 48 * h, [&mut x[at..], &mut y[at..], &mut z[at..]]) };
    }
    halves
}

/// Writes back the lanes of `b` that a collider pushed (`b.hit`) and whose particle moves (`inv_mass` not zero)
/// into `q`, `qd` (as [`load_positions`] and [`load_velocities`] read them), the others left as they are; true if a written lane is not
/// finite. The scalar write-back's values and its test, lane for lane.
///
/// # Safety
/// The CPU has AVX-512 F and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
pub(crate) unsafe fn store_block(b: &Lanes, inv_mass: &[f32], q: &mut [f32], qd: &mut [f32]) -> bool {
    use crate::isa::vec3x16::{join, load3, split, store3};
    use std::arch::x86_64::*;
    assert!(q.len() == 3 * LANES && qd.len() == 3 * LANES && inv_mass.len() == LANES);
    let mut bad = false;
    for h in 0..LANES / 16 {
        let mut hit = 0u16;
        for k in 0..16 {
            hit |= (b.hit[16 * h + k] as u16) << k;
        }
        // SAFETY: 16 values from 16 h, within the asserted length.
        let w = unsafe { _mm512_loadu_ps(inv_mass.as_ptr().add(16 * h)) };
        // `w == 0` skips a lane (NaN is written, as the scalar test `w == 0` lets it through).
        let write = hit & _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(w, _mm512_setzero_ps());
        if write == 0 {
            continue;
        }
        // SAFETY: as in `load_positions`.
        unsafe {
            let (x0, v0) = (split(load3(q, 48 * h, None)), split(load3(qd, 48 * h, None)));
            let (mut x, mut v) = (x0, v0);
            // Finite where `a - a` is 0 (NaN for ±∞ and NaN).
            let mut all = 0xffffu16;
            for e in 0..3 {
                x[e] = _mm512_mask_blend_ps(write, x0[e], _mm512_loadu_ps(b.x[e].as_ptr().add(16 * h)));
                v[e] = _mm512_mask_blend_ps(write, v0[e], _mm512_loadu_ps(b.v[e].as_ptr().add(16 * h)));
                all &= _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(_mm512_sub_ps(x[e], x[e]), _mm512_setzero_ps());
                all &= _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(_mm512_sub_ps(v[e], v[e]), _mm512_setzero_ps());
            }
            bad |= write & !all != 0;
            store3(q, 48 * h, join(x), None);
            store3(qd, 48 * h, join(v), None);
        }
    }
    bad
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The scalar rule the collision pass applies to one particle (`solver/collide.rs`, `sweeps`).
    fn scalar(prepared: &[PreparedCollider], colliders: &[Collider], x: Vec3, v: Vec3) -> Option<(Vec3, Vec3)> {
        let (mut x, mut v, mut touched) = (x, v, false);
        for _ in 0..3 {
            let mut any = false;
            for (p, c) in prepared.iter().zip(colliders) {
                if let Some((x2, v2)) = p.resolve(c, x, v) {
                    (x, v, any) = (x2, v2, true);
                }
            }
            touched |= any;
            if !any || colliders.len() == 1 {
                break;
            }
        }
        touched.then_some((x, v))
    }

    /// The AVX-512 block load and write-back give the scalar loops' values: the same arrays and box (a NaN and an
    /// infinite coordinate among them), and only the pushed lanes of moving particles written, with the
    /// non-finite test of the written ones.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx512_block_load_and_store_match_the_scalar_loops() {
        if !crate::isa::avx512() {
            return;
        }
        let mut q: Vec<f32> = (0..3 * LANES).map(|i| ((i as f32) * 0.37).sin()).collect();
        let qd: Vec<f32> = (0..3 * LANES).map(|i| ((i as f32) * 0.91).cos()).collect();
        (q[7], q[20], q[43]) = (f32::NAN, f32::INFINITY, f32::NEG_INFINITY);
        let mut b = Lanes::new();
        // SAFETY: AVX-512 (checked above).
        let (lo, hi) = unsafe { load_positions(&q, &mut b) };
        // SAFETY: as above.
        unsafe { load_velocities(&qd, &mut b) };
        let (mut slo, mut shi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for k in 0..LANES {
            let x = Vec3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2]);
            (slo, shi) = (slo.min(x), shi.max(x));
            for e in 0..3 {
                assert_eq!(b.x[e][k].to_bits(), q[3 * k + e].to_bits());
                assert_eq!(b.v[e][k].to_bits(), qd[3 * k + e].to_bits());
            }
        }
        assert_eq!((&lo[..3], &hi[..3]), (&slo.to_array()[..], &shi.to_array()[..]));
        let mut inv_mass = vec![1.0f32; LANES];
        inv_mass[3] = 0.0;
        for k in 0..LANES {
            b.hit[k] = k % 3 != 1;
            for e in 0..3 {
                b.x[e][k] += 1.0;
                b.v[e][k] -= 2.0;
            }
        }
        let (mut q2, mut qd2) = (q.clone(), qd.clone());
        // SAFETY: as above.
        let bad = unsafe { store_block(&b, &inv_mass, &mut q2, &mut qd2) };
        for k in 0..LANES {
            let written = b.hit[k] && inv_mass[k] != 0.0;
            for e in 0..3 {
                let (want_q, want_v) = if written { (b.x[e][k], b.v[e][k]) } else { (q[3 * k + e], qd[3 * k + e]) };
                assert_eq!(q2[3 * k + e].to_bits(), want_q.to_bits(), "lane {k}");
                assert_eq!(qd2[3 * k + e].to_bits(), want_v.to_bits(), "lane {k}");
            }
        }
        assert!(bad, "lane 2 (pushed, moving) holds the NaN");
        (b.hit[2], b.hit[6], b.hit[14]) = (false, false, false); // the NaN's lane and the infinities'
        // SAFETY: as above.
        assert!(!unsafe { store_block(&b, &inv_mass, &mut q.clone(), &mut qd.clone()) }, "no written lane is NaN");
    }

    /// Lanes give the scalar resolve's bits: a tilted moving plane and a spinning ball with restitution and
    /// friction, particles inside, on and outside both (one at the ball's centre, one with a NaN coordinate), a
    /// single collider and both.
    #[test]
    fn lanes_give_the_scalar_bits() {
        let plane = Collider::plane(Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.1, 1.0, -0.2))
            .with_velocity(Vec3::new(0.3, 0.1, 0.0), Vec3::ZERO)
            .with_restitution(0.5)
            .with_friction(0.3)
            .with_margin(1e-3);
        let ball = Collider::ball(Vec3::new(0.2, 0.15, 0.1), 0.12)
            .with_velocity(Vec3::new(0.0, -0.2, 0.1), Vec3::new(0.5, 2.0, -1.0))
            .with_friction(0.8);
        for colliders in [vec![plane.clone()], vec![plane, ball.clone()], vec![ball]] {
            let prepared: Vec<PreparedCollider> = colliders.iter().map(|c| c.prepare(0.25)).collect();
            assert!(all_closed_form(&prepared));
            let mut b = Lanes::new();
            let mut want = Vec::new();
            for k in 0..LANES {
                let f = k as f32;
                let x = match k {
                    0 => Vec3::new(0.2, 0.15, 0.1),
                    1 => Vec3::new(f32::NAN, 0.0, 0.0),
                    _ => Vec3::new((f * 0.37).sin() * 0.3, (f * 0.53).cos() * 0.2 + 0.1, (f * 0.71).sin() * 0.2),
                };
                let v = Vec3::new((f * 0.9).cos(), (f * 1.3).sin() - 0.5, (f * 0.4).cos()) * 2.0;
                for e in 0..3 {
                    (b.x[e][k], b.v[e][k]) = (x[e], v[e]);
                }
                want.push(scalar(&prepared, &colliders, x, v));
            }
            resolve_lanes(&prepared, &colliders, &mut b);
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            let mut pushed = 0;
            for (k, w) in want.iter().enumerate() {
                let got = (Vec3::new(b.x[0][k], b.x[1][k], b.x[2][k]), Vec3::new(b.v[0][k], b.v[1][k], b.v[2][k]));
                assert_eq!(b.hit[k], w.is_some(), "lane {k}: pushed or not");
                if let Some((x, v)) = w {
                    assert_eq!((bits(got.0), bits(got.1)), (bits(*x), bits(*v)), "lane {k}");
                    pushed += 1;
                }
            }
            assert!(pushed > 3 && pushed < LANES - 3, "{pushed} of {LANES} lanes pushed: both cases tested");
        }
    }
}
