//! The symplectic Euler update of irregular meshes (`solver::explicit`'s gather: each particle's spring forces
//! and gas push summed over its rows, then its velocity and position) in `f32` on AVX2, eight particles at a
//! time, written with its intrinsics.
//!
//! Why by hand: the portable gather walks one particle's row at a time, a 12-byte load, a well-predicted but
//! not free branch on the end bit and one add chain per spring, then the same for its triangles' crosses: ~15 ns a
//! particle on the 2,562-vertex ball (one thread, the Zen 4 development VM, 2026-11-29: 40 µs of a 76 µs step).
//! Here the eight particles of a block walk their rows side by side: entry `k` of the eight rows is one
//! column of [`Ell`] (the rows padded to the block's longest), its eight 3-vectors read as 16-byte loads and split
//! into components with shuffles (`cross_avx2::soa8`), the end bit turned into the sign (`a − b` is `a + (−b)`
//! bit for bit), and a padding entry into `−0`, which adds nothing (`x + −0 = x` for every `x`). The block's
//! positions and velocities are read and written as 24 contiguous values each (`runs_avx2::load3`, `store3`).
//!
//! The same bits as the portable gather: each lane adds its particle's entries in its row's order, with
//! `particle_force`'s and the update's operations in their order, no fused multiply-adds. Blocks whose rows
//! read the last spring (whose 16-byte load would pass the end of the forces), with wind the last triangle (the
//! same for its 12-byte corner forces), and the particles after the last whole block go the portable way.

use std::arch::x86_64::*;

use super::cross_avx2::soa8;
use super::runs_avx2::{join, load3, split, store3};
use crate::model::Model;
use crate::real::Real;

/// A padding entry of [`Ell`]'s columns.
const PAD: u32 = u32::MAX;

/// The particles' spring and triangle rows (`Model::particle_springs`, `particle_tris`) block by block, for
/// [`block`]: block `b` holds particles `8b .. 8b + 8` (whole blocks only); its rows padded with [`PAD`] to its
/// longest and stored column by column (entry `k` of lane `l` at `start + 8k + l`). Built once per model shape
/// (`ForceScratch::resize`), ~2 × 8 × 6 entries a block on a ball.
#[derive(Clone, Debug, Default)]
pub(crate) struct Ell {
    /// The counts it was built for: particles, springs, triangles.
    shape: (usize, usize, usize),
    /// Per block: where its spring columns start in `springs`, and how many.
    spring_cols: Vec<(u32, u32)>,
    /// Per block: where its triangle columns start in `tris`, and how many.
    tri_cols: Vec<(u32, u32)>,
    /// The spring entries (`Model::particle_springs`' encoding: `spring << 1 | end`), column by column.
    springs: Vec<u32>,
    /// Each spring entry's force as an offset into the forces' `f32`s (`3 spring`; 0 for padding), read as
    /// scalars: forming them from the entries in the vector registers and moving them out cost ~15 instructions a
    /// column.
    spring_at: Vec<u32>,
    /// The triangle entries, column by column.
    tris: Vec<u32>,
    /// Each triangle entry's cross as an offset into the crosses' `f32`s (`4 triangle`; 0 for padding).
    tri_at: Vec<u32>,
    /// With wind: each triangle entry's corner force as an offset into the forces' `f32`s (`3 triangle`, the
    /// 12-byte `ForceScratch::tri_f`; 0 for padding); empty without wind.
    tri_f_at: Vec<u32>,
    /// Per block: whether it may go wide (no entry is the last spring).
    wide: Vec<bool>,
}

impl Ell {
    /// The rows of `m`, blocked.
    pub(crate) fn of_model<R: Real>(m: &Model<R>) -> Ell {
        let (n, ns, nt) = (m.particle_count(), m.spring_count(), m.tri_count());
        let blocks = n / 8;
        let mut e = Ell { shape: (n, ns, nt), ..Default::default() };
        for b in 0..blocks {
            let lanes = 8 * b..8 * b + 8;
            // (The offsets below fit in `u32`.)
            let mut wide = ns >= 2 && 3 * ns <= u32::MAX as usize && 4 * nt <= u32::MAX as usize;
            for (rows, cols, out) in [
                (&m.particle_springs, &mut e.spring_cols, &mut e.springs),
                (&m.particle_tris, &mut e.tri_cols, &mut e.tris),
            ] {
                let k = lanes.clone().map(|i| rows.row(i).len()).max().unwrap_or(0);
                cols.push((out.len() as u32, k as u32));
                for c in 0..k {
                    out.extend(lanes.clone().map(|i| rows.row(i).get(c).copied().unwrap_or(PAD)));
                }
            }
            let (s0, k) = e.spring_cols[b];
            let springs = &e.springs[s0 as usize..(s0 + 8 * k) as usize];
            e.spring_at.extend(springs.iter().map(|&x| if x == PAD { 0 } else { 3 * (x >> 1) }));
            let (t0, kt) = e.tri_cols[b];
            let tris = &e.tris[t0 as usize..(t0 + 8 * kt) as usize];
            e.tri_at.extend(tris.iter().map(|&x| if x == PAD { 0 } else { 4 * x }));
            if m.has_wind() {
                // A corner force's 16-byte load reads one value past it: not the last triangle's.
                e.tri_f_at.extend(tris.iter().map(|&x| if x == PAD { 0 } else { 3 * x }));
                wide &= tris.iter().all(|&x| x == PAD || x as usize + 1 < nt);
            }
            wide &=
                e.springs[s0 as usize..(s0 + 8 * k) as usize].iter().all(|&x| x == PAD || (x >> 1) as usize + 1 < ns);
            e.wide.push(wide);
        }
        e
    }

    /// Whether it was built for `m`'s counts.
    pub(crate) fn fits<R: Real>(&self, m: &Model<R>) -> bool {
        self.shape == (m.particle_count(), m.spring_count(), m.tri_count())
    }

    /// Whether it holds the corner forces' offsets (built for a model with wind).
    pub(crate) fn has_wind(&self) -> bool {
        self.tri_f_at.len() == self.tris.len()
    }

    /// Whether block `b` (particles `8b .. 8b + 8`) exists and may go wide.
    #[inline]
    pub(crate) fn wide(&self, b: usize) -> bool {
        self.wide.get(b).copied().unwrap_or(false)
    }
}

/// What [`block`] reads besides the block's own positions and velocities: the per-spring forces and (with
/// `cross`) the triangles' crosses and the bodies' `P / 6`, each as flat `f32`s, and the particles' masses,
/// inverse masses and bodies.
pub(crate) struct Inputs<'a> {
    pub ell: &'a Ell,
    pub spring_f: &'a [f32],
    /// With gas (and no wind): the crosses (4 values a triangle) and each body's `P / 6`.
    pub cross: Option<(&'a [f32], &'a [f32])>,
    /// With wind (the wind pass's per-triangle corner forces, gas included: `ForceScratch::tri_f`, 3 values a
    /// triangle): added in row order, as `forces::add_corners` does.
    pub wind: Option<&'a [f32]>,
    /// With caps over openings: each particle's cap gradient (`pressure::Caps::g`, 3 values a particle) and each
    /// body's pressure.
    pub caps: Option<(&'a [f32], &'a [f32])>,
    /// A measuring step with load limits: each spring's elastic pull (3 values a spring) and each particle's load
    /// limit; the loads are summed beside the forces (`solver::explicit`'s `symplectic_euler_with_loads`).
    pub loads: Option<(&'a [f32], &'a [f32])>,
    pub body: &'a [u32],
    pub mass: &'a [f32],
    pub inv_mass: &'a [f32],
    pub gravity: [f32; 3],
    pub dt: f32,
}

/// Block `b` of [`Ell`] (particles `8b .. 8b + 8`): each particle's force (gravity, its springs in row order,
/// then with wind its triangles' corner forces in row order, or its gas push `P/6 Σ cross` where `P` is not 0, then
/// its caps' `P g`), then `v += f (w dt)`, `x += v dt` where its inverse
/// mass `w` is not 0. `q` and `v`: the block's 24 position and velocity values. With `x.loads`, each particle's
/// load (`|Σ ± pull + P/6 Σ cross|` where its limit is finite, else 0) into `load` (8 values). Returns whether a
/// value it wrote is not finite.
///
/// # Safety
/// AVX2; `x.ell.wide(b)`, built for the model the inputs come from ([`Ell::fits`]); `q` and `v` hold 24 values,
/// and `load` 8 where `x.loads` is given.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn block(x: &Inputs<'_>, b: usize, q: *mut f32, v: *mut f32, load: *mut f32) -> bool {
    let i0 = 8 * b;
    let e = x.ell;
    debug_assert!(e.wide(b) && i0 + 8 <= x.mass.len());
    // SAFETY: particles `i0 .. i0 + 8` exist (block `b` is whole).
    let (mass, w, bodies) = unsafe {
        (
            _mm256_loadu_ps(x.mass.as_ptr().add(i0)),
            _mm256_loadu_ps(x.inv_mass.as_ptr().add(i0)),
            _mm256_loadu_si256(x.body.as_ptr().add(i0).cast()),
        )
    };
    let g = x.gravity;
    // `gravity * mass`.
    let mut f = (
        _mm256_mul_ps(_mm256_set1_ps(g[0]), mass),
        _mm256_mul_ps(_mm256_set1_ps(g[1]), mass),
        _mm256_mul_ps(_mm256_set1_ps(g[2]), mass),
    );
    let pad = _mm256_set1_epi32(PAD as i32);
    let neg0 = _mm256_set1_ps(-0.0);
    // Column `k` of a block's entries (at `$at`): their eight 3-vectors at `base + offset` (the offsets read as
    // scalars from `$offs`), and the entries with the padding lanes' mask.
    macro_rules! column {
        ($entries:expr, $offs:expr, $at:expr, $base:expr) => {{
            // SAFETY: `$at + 8 <= entries.len() == offs.len()` (the block's columns, asserted by the caller); every
            // offset is in range and its 16-byte load inside `$base` (the block is wide: see `Ell::of_model`).
            unsafe {
                let c = _mm256_loadu_si256($entries.as_ptr().add($at).cast());
                let is_pad = _mm256_castsi256_ps(_mm256_cmpeq_epi32(c, pad));
                let p = $offs.as_ptr().add($at);
                let o = [
                    *p as usize,
                    *p.add(1) as usize,
                    *p.add(2) as usize,
                    *p.add(3) as usize,
                    *p.add(4) as usize,
                    *p.add(5) as usize,
                    *p.add(6) as usize,
                    *p.add(7) as usize,
                ];
                (c, is_pad, soa8($base.as_ptr(), o))
            }
        }};
    }
    let (s0, ks) = e.spring_cols[b];
    assert!(x.spring_f.len() == 3 * e.shape.1 && (s0 + 8 * ks) as usize <= e.springs.len().min(e.spring_at.len()));
    // The elastic pulls' sum `fe` (from `+0`, as `R::V::ZERO`), in the same walk of the rows.
    let z = _mm256_setzero_ps();
    let mut fe = (z, z, z);
    if let Some((pulls, _)) = x.loads {
        assert!(pulls.len() == x.spring_f.len());
        for k in 0..ks {
            let at = (s0 + 8 * k) as usize;
            let (c, is_pad, (vx, vy, vz)) = column!(e.springs, e.spring_at, at, x.spring_f);
            let (_, _, (ex, ey, ez)) = column!(e.springs, e.spring_at, at, pulls);
            let sign = _mm256_castsi256_ps(_mm256_slli_epi32::<31>(c));
            macro_rules! term {
                ($a:expr) => {
                    _mm256_blendv_ps(_mm256_xor_ps($a, sign), neg0, is_pad)
                };
            }
            f = (_mm256_add_ps(f.0, term!(vx)), _mm256_add_ps(f.1, term!(vy)), _mm256_add_ps(f.2, term!(vz)));
            fe = (_mm256_add_ps(fe.0, term!(ex)), _mm256_add_ps(fe.1, term!(ey)), _mm256_add_ps(fe.2, term!(ez)));
        }
    }
    for k in 0..if x.loads.is_some() { 0 } else { ks } {
        let (c, is_pad, (vx, vy, vz)) = column!(e.springs, e.spring_at, (s0 + 8 * k) as usize, x.spring_f);
        // End 1's force enters with its sign flipped; a padding entry as `-0`.
        // (Macros, not closures: a closure is compiled without this function's AVX2, its intrinsics as calls.)
        let sign = _mm256_castsi256_ps(_mm256_slli_epi32::<31>(c));
        macro_rules! term {
            ($a:expr) => {
                _mm256_blendv_ps(_mm256_xor_ps($a, sign), neg0, is_pad)
            };
        }
        f = (_mm256_add_ps(f.0, term!(vx)), _mm256_add_ps(f.1, term!(vy)), _mm256_add_ps(f.2, term!(vz)));
    }
    // `$acc` plus the block's triangle columns of `$base` (each entry read at its offset in `$offs`), each lane in
    // its row's order, a padding entry as `-0`: the wind's corner forces into the force, or the gas's crosses
    // into their sum.
    let (t0, kt) = e.tri_cols[b];
    macro_rules! plus_tri_columns {
        ($acc:expr, $offs:expr, $base:expr) => {{
            let mut a = $acc;
            for k in 0..kt {
                let (_, is_pad, (cx, cy, cz)) = column!(e.tris, $offs, (t0 + 8 * k) as usize, $base);
                macro_rules! term {
                    ($v:expr) => {
                        _mm256_blendv_ps($v, neg0, is_pad)
                    };
                }
                a = (_mm256_add_ps(a.0, term!(cx)), _mm256_add_ps(a.1, term!(cy)), _mm256_add_ps(a.2, term!(cz)));
            }
            a
        }};
    }
    if let Some(tf) = x.wind {
        assert!(
            tf.len() == 3 * e.shape.2 && e.has_wind() && (t0 + 8 * kt) as usize <= e.tris.len().min(e.tri_f_at.len())
        );
        f = plus_tri_columns!(f, e.tri_f_at, tf);
    }
    if let Some((cross, p6)) = x.cross {
        assert!(cross.len() == 4 * e.shape.2 && (t0 + 8 * kt) as usize <= e.tris.len().min(e.tri_at.len()));
        assert!(x.body[i0..i0 + 8].iter().all(|&b| (b as usize) < p6.len()), "a particle's body out of range");
        // SAFETY: every body is below `p6.len()` (asserted just above).
        let p = unsafe { _mm256_i32gather_ps::<4>(p6.as_ptr(), bodies) };
        // A lane whose body has no pressure takes `-0` (`forces::pressure_share`), and a block of such lanes (the
        // core blocks broken off a ball) reads no crosses: theirs are not formed (`forces::gas_tri_end`).
        let pushed = _mm256_cmp_ps::<_CMP_NEQ_UQ>(p, z);
        if _mm256_movemask_ps(pushed) != 0 {
            let s = plus_tri_columns!((z, z, z), e.tri_at, cross);
            let share = (
                _mm256_blendv_ps(neg0, _mm256_mul_ps(s.0, p), pushed),
                _mm256_blendv_ps(neg0, _mm256_mul_ps(s.1, p), pushed),
                _mm256_blendv_ps(neg0, _mm256_mul_ps(s.2, p), pushed),
            );
            f = (_mm256_add_ps(f.0, share.0), _mm256_add_ps(f.1, share.1), _mm256_add_ps(f.2, share.2));
            fe = (_mm256_add_ps(fe.0, share.0), _mm256_add_ps(fe.1, share.1), _mm256_add_ps(fe.2, share.2));
        }
    }
    if let Some((g, pressure)) = x.caps {
        assert!(g.len() == 3 * x.mass.len());
        assert!(x.body[i0..i0 + 8].iter().all(|&b| (b as usize) < pressure.len()), "a particle's body out of range");
        // SAFETY: `g[3 i0 .. 3 i0 + 24]` is the block's (asserted length); every body is below `pressure.len()`.
        let (c, p) = unsafe {
            (split(load3(g.as_ptr().add(3 * i0), None)), _mm256_i32gather_ps::<4>(pressure.as_ptr(), bodies))
        };
        f = (
            _mm256_add_ps(f.0, _mm256_mul_ps(c[0], p)),
            _mm256_add_ps(f.1, _mm256_mul_ps(c[1], p)),
            _mm256_add_ps(f.2, _mm256_mul_ps(c[2], p)),
        );
    }
    // The loads: `|fe|` as glam's `length` (`sqrt((x x + y y) + z z)`) where the limit is finite, else `+0`.
    if let Some((_, limit)) = x.loads {
        assert!(limit.len() == x.mass.len());
        // SAFETY: particles `i0 .. i0 + 8` exist; `load` holds 8 values (the caller's bounds).
        unsafe {
            let lim = _mm256_loadu_ps(limit.as_ptr().add(i0));
            let abs = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
            let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_and_ps(lim, abs), _mm256_set1_ps(f32::INFINITY));
            let len = _mm256_sqrt_ps(_mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(fe.0, fe.0), _mm256_mul_ps(fe.1, fe.1)),
                _mm256_mul_ps(fe.2, fe.2),
            ));
            _mm256_storeu_ps(load, _mm256_and_ps(len, finite));
        }
    }
    let dt = _mm256_set1_ps(x.dt);
    let wdt = _mm256_mul_ps(w, dt);
    // SAFETY: `q` and `v` hold 24 values (the caller's bounds).
    let (q0, v0) = unsafe { (split(load3(q, None)), split(load3(v, None))) };
    let nv = [
        _mm256_add_ps(v0[0], _mm256_mul_ps(f.0, wdt)),
        _mm256_add_ps(v0[1], _mm256_mul_ps(f.1, wdt)),
        _mm256_add_ps(v0[2], _mm256_mul_ps(f.2, wdt)),
    ];
    let nq = [
        _mm256_add_ps(q0[0], _mm256_mul_ps(nv[0], dt)),
        _mm256_add_ps(q0[1], _mm256_mul_ps(nv[1], dt)),
        _mm256_add_ps(q0[2], _mm256_mul_ps(nv[2], dt)),
    ];
    // A particle whose inverse mass is 0 keeps its state (`!(w == 0)`: a NaN `w` moves, as in the portable loop).
    let live = _mm256_cmp_ps::<_CMP_NEQ_UQ>(w, _mm256_setzero_ps());
    macro_rules! keep {
        ($new:expr, $old:expr) => {
            [
                _mm256_blendv_ps($old[0], $new[0], live),
                _mm256_blendv_ps($old[1], $new[1], live),
                _mm256_blendv_ps($old[2], $new[2], live),
            ]
        };
    }
    let (v1, q1) = (keep!(nv, v0), keep!(nq, q0));
    // Not finite: `|x| < inf` fails (NaN included), on a live lane.
    let abs = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
    let inf = _mm256_set1_ps(f32::INFINITY);
    let mut finite = live;
    for a in [nv[0], nv[1], nv[2], nq[0], nq[1], nq[2]] {
        finite = _mm256_and_ps(finite, _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_and_ps(a, abs), inf));
    }
    let bad = _mm256_movemask_ps(_mm256_xor_ps(finite, live)) != 0;
    // SAFETY: as for the loads.
    unsafe {
        store3(v, join(v1), None);
        store3(q, join(q1), None);
    }
    bad
}
