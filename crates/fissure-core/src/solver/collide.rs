//! The collision pass: every particle against the prepared colliders, with a per-block broad test.

use super::*;
use crate::collision::lanes;

/// Particles per block of the collision pass's broad test (one bounding box per block), and of its lanes.
const COLLIDE_BLOCK: usize = lanes::LANES;
/// Colliders a block keeps in its near list on the stack; with more colliders in the scene every block tests all.
const COLLIDE_NEAR: usize = 64;
/// Pushes of one particle recorded for the far colliders' check; past it, the particle takes the full resolve.
const PUSHES: usize = 8;

/// Resolves a particle at `(x0, v0)` against the colliders `ids` (indices into `prepared`/`colliders`), in order,
/// sweeping until clear (a push out of one collider can land in another: a corner), at most 3 times; `None` if
/// none touched it. `pushed` receives the positions after each push, its flag cleared if they overflow it.
/// Inlined: most calls end at the plane's or the ball's first test (see `PreparedCollider::resolve`), and a
/// call of its own cost more than that test (the arguments stored and reloaded, the push list set up).
/// `TRACK`: record the pushes (only a block that tests a subset of the colliders checks them afterwards; a block
/// that tests them all skips the bookkeeping). Measured on the 2,562-vertex ball after 100 core splits, ~400 of
/// its particles resting on the ground, one thread, 2026-11-25: the collide stage 18.3 → 15.3 µs a step, and
/// 11.6 µs with the plane's and the ball's resolve inlined (`PreparedCollider::resolve`).
#[inline(always)]
fn sweeps<const TRACK: bool>(
    prepared: &[crate::collision::PreparedCollider],
    colliders: &[crate::collision::Collider],
    ids: &[u32],
    x0: glam::Vec3,
    v0: glam::Vec3,
    pushed: &mut ([glam::Vec3; PUSHES], usize, bool),
) -> Option<(glam::Vec3, glam::Vec3)> {
    let (mut x, mut v) = (x0, v0);
    let mut touched = false;
    for _sweep in 0..3 {
        let mut any = false;
        for &c in ids {
            let c = c as usize;
            if let Some((x2, v2)) = prepared[c].resolve(&colliders[c], x, v) {
                x = x2;
                v = v2;
                any = true;
                if TRACK && pushed.1 < PUSHES {
                    pushed.0[pushed.1] = x;
                    pushed.1 += 1;
                } else if TRACK {
                    pushed.2 = false;
                }
            }
        }
        touched |= any;
        if !any || colliders.len() == 1 {
            break;
        }
    }
    touched.then_some((x, v))
}

impl<R: Real> CpuSolver<R> {
    /// The colliders at time `t` \[s\], into `self.colliders` (and the list of all their indices).
    pub(super) fn prepare_colliders(&mut self, m: &Model<R>, t: f64) {
        self.colliders.clear();
        self.colliders.extend(m.colliders.iter().map(|c| c.prepare(t)));
        if self.collider_ids.len() != self.colliders.len() {
            self.collider_ids = (0..self.colliders.len() as u32).collect();
        }
    }

    /// Resolves contacts; flags `blown` if a contact produced a non-finite state (a particle flung to ±1e300 by
    /// an unstable step, whose distance to a collider overflows). Symplectic Euler on spring runs resolves them
    /// in its own pass instead (`collide_fused`), and this does nothing then.
    pub(super) fn collide(&mut self, m: &Model<R>, state: &mut State<R>, blown: &AtomicBool) {
        if !m.has_colliders() || std::mem::take(&mut self.collided) {
            return;
        }
        let t0 = Instant::now();
        self.prepare_colliders(m, state.time);
        let (prepared, every) = (&self.colliders[..], &self.collider_ids[..]);
        // Each particle's contact is its own: on the team in finer pieces (`par::piece`, a multiple of the block).
        let (pool, size) = (par::is_pooled(state.particle_q.len()), par::piece(par::CHUNK));
        par::chunks2_pooled(pool, size, &mut state.particle_q, &mut state.particle_qd, |start, qs, vs| {
            if collide_chunk(m, prepared, every, start, qs, vs) {
                blown.store(true, Ordering::Relaxed);
            }
        });
        self.timers.add(Stage::Collide, t0);
    }
}

/// A particle at `(x, v)` against every collider (`prepared`: this substep's, `every`: all their indices): a block
/// that every collider may reach, and the contact pass, which moves particles after this pass ran: a push from another body can press a particle
/// resting on a collider into it (the fracture scene's broken-off blocks, pressed by the ball against the ground,
/// were seen 0.12 mm deep at a frame's end, 2026-11-25). `None` if none touches it.
#[inline(always)]
pub(super) fn resolve_all(
    prepared: &[crate::collision::PreparedCollider],
    colliders: &[crate::collision::Collider],
    every: &[u32],
    x: glam::Vec3,
    v: glam::Vec3,
) -> Option<(glam::Vec3, glam::Vec3)> {
    let mut unused = ([glam::Vec3::ZERO; PUSHES], 0usize, true);
    sweeps::<false>(prepared, colliders, every, x, v, &mut unused)
}

/// Particles `start .. start + qs.len()` (`start` a multiple of [`COLLIDE_BLOCK`]) against the colliders
/// `prepared` (`every`: all their indices); true if a contact made a state non-finite.
#[inline]
pub(super) fn collide_chunk<R: Real>(
    m: &Model<R>,
    prepared: &[crate::collision::PreparedCollider],
    every: &[u32],
    start: usize,
    qs: &mut [R::V],
    vs: &mut [R::V],
) -> bool {
    let (inv_mass, colliders) = (&m.particle_inv_mass, &m.colliders);
    // Per block of particles, the colliders its bounding box can reach. A particle is resolved against
    // those alone, and the others are then checked at every position it was pushed to: when none of them
    // reaches any (the usual case), the full resolve against every collider would have made the same pushes
    // in the same order (a far collider's test depends on the position alone, and fails at all of them),
    // so the result is the same bit for bit; otherwise the particle takes the full resolve.
    let mut near = [0u32; COLLIDE_NEAR];
    let mut bad = false;
    // Planes and balls only: each block goes through them all at once, lane by lane (`collision::lanes`: the same
    // bits as the full resolve below, which the near list and far check reproduce).
    let closed = lanes::all_closed_form(prepared);
    // `f32` on AVX-512: whole blocks loaded and written back with permutes (`lanes::load_positions`, the same values).
    #[cfg(target_arch = "x86_64")]
    let by_hand = closed && crate::isa::avx512() && std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>();
    #[cfg(not(target_arch = "x86_64"))]
    let by_hand = false;
    let mut block = lanes::Lanes::new();
    for (b, (qb, vb)) in qs.chunks_mut(COLLIDE_BLOCK).zip(vs.chunks_mut(COLLIDE_BLOCK)).enumerate() {
        let p0 = start + b * COLLIDE_BLOCK;
        let whole = by_hand && qb.len() == COLLIDE_BLOCK;
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        #[cfg(target_arch = "x86_64")]
        if whole {
            use crate::real::as_f32;
            // SAFETY: AVX-512 (`by_hand`); a whole block. Its velocities only where a collider may reach it (below).
            let (l, h) = unsafe { lanes::load_positions(as_f32(R::flat(qb)), &mut block) };
            (lo, hi) = (glam::Vec3::new(l[0], l[1], l[2]), glam::Vec3::new(h[0], h[1], h[2]));
        }
        if !whole {
            for x in qb.iter() {
                let x = x.to_vec3();
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
        let mut count = 0;
        let mut all = !(lo.is_finite() && hi.is_finite()) || prepared.len() > COLLIDE_NEAR;
        if !all {
            for (k, (p, c)) in prepared.iter().zip(&m.colliders).enumerate() {
                if p.may_touch_box(c, lo, hi) {
                    near[count] = k as u32;
                    count += 1;
                }
            }
            if count == 0 {
                continue;
            }
            all = count == prepared.len();
        }
        #[cfg(target_arch = "x86_64")]
        if whole {
            use crate::real::{as_f32, as_f32_mut};
            // SAFETY: AVX-512 (`by_hand`); a whole block.
            unsafe { lanes::load_velocities(as_f32(R::flat(vb)), &mut block) };
            lanes::resolve_lanes(prepared, colliders, &mut block);
            let w = as_f32(&inv_mass[p0..p0 + COLLIDE_BLOCK]);
            // SAFETY: AVX-512 (`by_hand`); a whole block.
            bad |= unsafe { lanes::store_block(&block, w, as_f32_mut(R::flat_mut(qb)), as_f32_mut(R::flat_mut(vb))) };
            continue;
        }
        if closed {
            for (k, (x, v)) in qb.iter().zip(vb.iter()).enumerate() {
                let (x, v) = (x.to_vec3().to_array(), v.to_vec3().to_array());
                for e in 0..3 {
                    (block.x[e][k], block.v[e][k]) = (x[e], v[e]);
                }
            }
            lanes::resolve_lanes(prepared, colliders, &mut block);
            for k in 0..qb.len() {
                if !block.hit[k] || inv_mass[p0 + k] == R::ZERO {
                    continue;
                }
                let (x, v) = (&block.x, &block.v);
                qb[k] = R::V::from_vec3(glam::Vec3::new(x[0][k], x[1][k], x[2][k]));
                vb[k] = R::V::from_vec3(glam::Vec3::new(v[0][k], v[1][k], v[2][k]));
                bad |= !(qb[k].is_finite() && vb[k].is_finite());
            }
            continue;
        }
        if all {
            // Every collider is near: nothing to check afterwards.
            for k in 0..qb.len() {
                if inv_mass[p0 + k] == R::ZERO {
                    continue;
                }
                let Some(out) = resolve_all(prepared, colliders, every, qb[k].to_vec3(), vb[k].to_vec3()) else {
                    continue;
                };
                qb[k] = R::V::from_vec3(out.0);
                vb[k] = R::V::from_vec3(out.1);
                bad |= !(qb[k].is_finite() && vb[k].is_finite());
            }
            continue;
        }
        // The far colliders, listed once for the block (they were filtered out of all of them per particle).
        let mut far = [0u32; COLLIDE_NEAR];
        let mut nf = 0;
        for c in 0..prepared.len() as u32 {
            if !near[..count].contains(&c) {
                far[nf] = c;
                nf += 1;
            }
        }
        let (near, far) = (&near[..count], &far[..nf]);
        for k in 0..qb.len() {
            if inv_mass[p0 + k] == R::ZERO {
                continue;
            }
            let (x, v) = (qb[k].to_vec3(), vb[k].to_vec3());
            let mut pushed = ([glam::Vec3::ZERO; PUSHES], 0usize, true);
            let Some(mut out) = sweeps::<true>(prepared, colliders, near, x, v, &mut pushed) else { continue };
            let (list, n, complete) = pushed;
            let far_clear = complete
                && far.iter().all(|&c| {
                    let c = c as usize;
                    list[..n].iter().all(|&xp| prepared[c].resolve(&colliders[c], xp, v).is_none())
                });
            if !far_clear {
                out = sweeps::<true>(prepared, colliders, every, x, v, &mut pushed)
                    .expect("a particle a near collider touches is touched by the full resolve");
            }
            qb[k] = R::V::from_vec3(out.0);
            vb[k] = R::V::from_vec3(out.1);
            bad |= !(qb[k].is_finite() && vb[k].is_finite());
        }
    }
    bad
}
