//! The collision pass: every particle against the prepared colliders, with a per-block broad test.

use super::*;

/// Particles per block of the collision pass's broad test (one bounding box per block).
const COLLIDE_BLOCK: usize = 32;
/// Colliders a block keeps in its near list on the stack; with more colliders in the scene every block tests all.
const COLLIDE_NEAR: usize = 64;

impl<R: Real> CpuSolver<R> {
    /// Resolves contacts; flags `blown` if a contact produced a non-finite state (a particle flung to ±1e300 by
    /// an unstable step, whose distance to a collider overflows).
    pub(super) fn collide(&mut self, m: &Model<R>, state: &mut State<R>, blown: &AtomicBool) {
        if !m.has_colliders() {
            return;
        }
        let t0 = Instant::now();
        self.colliders.clear();
        self.colliders.extend(m.colliders.iter().map(|c| c.prepare(state.time)));
        let prepared = &self.colliders;
        let inv_mass = &m.particle_inv_mass;
        // The full resolve of one particle: every collider in order, and since a push out of one collider can
        // land in another (a corner), sweep until clear, at most 3 times.
        let resolve_all = |x0: glam::Vec3, v0: glam::Vec3| -> Option<(glam::Vec3, glam::Vec3)> {
            let (mut x, mut v) = (x0, v0);
            let mut touched = false;
            for _sweep in 0..3 {
                let mut any = false;
                for (p, c) in prepared.iter().zip(&m.colliders) {
                    if let Some((x2, v2)) = p.resolve(c, x, v) {
                        x = x2;
                        v = v2;
                        any = true;
                    }
                }
                touched |= any;
                if !any || m.colliders.len() == 1 {
                    break;
                }
            }
            touched.then_some((x, v))
        };
        par::chunks2(&mut state.particle_q, &mut state.particle_qd, |start, qs, vs| {
            // Per block of particles, the colliders its bounding box can reach; a particle that none of them
            // touches is clear of all (the others reject its block), and one that is touched takes the full
            // resolve from its original state: the same result as testing every collider, bit for bit.
            let mut near = [0u32; COLLIDE_NEAR];
            let mut bad = false;
            for (b, (qb, vb)) in qs.chunks_mut(COLLIDE_BLOCK).zip(vs.chunks_mut(COLLIDE_BLOCK)).enumerate() {
                let p0 = start + b * COLLIDE_BLOCK;
                let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
                for x in qb.iter() {
                    let x = x.to_vec3();
                    lo = lo.min(x);
                    hi = hi.max(x);
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
                    // Every collider is near: the pre-test would only repeat the full resolve's first sweep.
                    all = count == prepared.len();
                }
                for k in 0..qb.len() {
                    if inv_mass[p0 + k] == R::ZERO {
                        continue;
                    }
                    let (x, v) = (qb[k].to_vec3(), vb[k].to_vec3());
                    if !all {
                        let hit = near[..count].iter().any(|&c| {
                            let c = c as usize;
                            prepared[c].resolve(&m.colliders[c], x, v).is_some()
                        });
                        if !hit {
                            continue;
                        }
                    }
                    if let Some((x, v)) = resolve_all(x, v) {
                        qb[k] = R::V::from_vec3(x);
                        vb[k] = R::V::from_vec3(v);
                        bad |= !(qb[k].is_finite() && vb[k].is_finite());
                    }
                }
            }
            if bad {
                blown.store(true, Ordering::Relaxed);
            }
        });
        self.timers.add(Stage::Collide, t0);
    }
}
