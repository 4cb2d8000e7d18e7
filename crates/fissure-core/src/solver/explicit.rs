//! The explicit integrators of [`CpuSolver`]: symplectic Euler (per-spring kernel, with the fracture loads fused
//! into its gather, and fused with the spring-run kernel on grids), velocity Verlet and RK4.

use super::*;
#[cfg(target_arch = "x86_64")]
use crate::forces::gather_avx2;

#[derive(Clone, Debug, Default)]
pub(super) struct Rk4Scratch<R: Real> {
    pub(super) xt: Vec<R::V>,
    pub(super) vt: Vec<R::V>,
    pub(super) ax: Vec<R::V>,
    pub(super) av: Vec<R::V>,
}

/// The fused symplectic Euler path's per-block force buffers (see `CpuSolver::block_f`): `count` buffers of `len`.
#[derive(Debug, Default)]
pub(super) struct BlockBuffers<R: Real>(Vec<std::sync::Mutex<Vec<R::V>>>);

impl<R: Real> BlockBuffers<R> {
    pub(super) fn new(count: usize, len: usize) -> Self {
        BlockBuffers((0..count).map(|_| std::sync::Mutex::new(vec![R::V::ZERO; len])).collect())
    }

    /// A buffer of `len` that no other thread holds: one of the kept buffers, or (more threads than were counted
    /// when they were made: a step inside a larger pool than the solver was sized in) a new one.
    fn take(&self, len: usize) -> Taken<'_, R> {
        match self.0.iter().find_map(|b| b.try_lock().ok()) {
            Some(b) if b.len() >= len => Taken::Kept(b),
            _ => Taken::New(vec![R::V::ZERO; len]),
        }
    }
}

/// A block's force buffer (see [`BlockBuffers::take`]).
enum Taken<'a, R: Real> {
    Kept(std::sync::MutexGuard<'a, Vec<R::V>>),
    New(Vec<R::V>),
}

impl<R: Real> std::ops::Deref for Taken<'_, R> {
    type Target = Vec<R::V>;
    fn deref(&self) -> &Vec<R::V> {
        match self {
            Taken::Kept(b) => b,
            Taken::New(b) => b,
        }
    }
}

impl<R: Real> std::ops::DerefMut for Taken<'_, R> {
    fn deref_mut(&mut self) -> &mut Vec<R::V> {
        match self {
            Taken::Kept(b) => b,
            Taken::New(b) => b,
        }
    }
}

impl<R: Real> Clone for BlockBuffers<R> {
    /// Buffers of the same shape (their contents are scratch).
    fn clone(&self) -> Self {
        let len = self.0.first().map_or(0, |b| b.lock().map_or(0, |v| v.len()));
        Self::new(self.0.len(), len)
    }
}

/// Particles per piece of a gather pass handed to the pool (see [`par::gather_pool`]): small enough that two
/// threads share a 10,242-vertex ball's 20 pieces evenly (at 2,048 they split its 5 pieces 3 to 2).
const GATHER_CHUNK: usize = 512;

/// What a gather over `m`'s particles costs, in spring-sized units: a particle, its spring entries and (with
/// triangle terms) its triangle entries.
fn gather_work<R: Real>(m: &Model<R>, surface: bool) -> usize {
    m.particle_count() + 2 * m.spring_count() + if surface { 3 * m.tri_count() } else { 0 }
}

/// The inputs of the symplectic Euler update eight particles at a time (`forces::gather_avx2`) where it serves:
/// `f32` on AVX2 with the per-spring kernel (its blocks built: `ForceScratch::ell`); the surface's forces (if any)
/// the gas's crosses and caps, or with wind the wind pass's per-triangle corner forces (not a grid's per-particle
/// sums: a grid cloth steps on the run kernel anyway). `loads`: a measuring step's, which sums each particle's load
/// beside its force (never with wind: `fuse_loads`).
#[cfg(target_arch = "x86_64")]
fn wide_inputs<'a, R: Real>(
    m: &'a Model<R>,
    f: &'a crate::forces::ForceScratch<R>,
    surface: bool,
    dt: R,
    loads: bool,
) -> Option<gather_avx2::Inputs<'a>> {
    use crate::real::{as_f32, va_as_f32};
    let f32 = std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>();
    // With wind the triangles' corner forces (gas included) are the wind pass's `tri_f`, unless a grid's pass
    // summed them per particle.
    let wind = surface && f.tri_f_written;
    if !f32 || f.runs || !f.ell.fits(m) || (wind && (f.grid_plan.is_some() || !f.ell.has_wind())) {
        return None;
    }
    if surface && !wind && !m.has_pressure() {
        return None;
    }
    let g = m.gravity.to_vec3();
    Some(gather_avx2::Inputs {
        ell: &f.ell,
        spring_f: as_f32(R::flat(&f.spring_f)),
        cross: (surface && !wind).then(|| (va_as_f32::<R>(&f.tri_cross), as_f32(&f.body_p6))),
        wind: wind.then(|| as_f32(R::flat(&f.tri_f))),
        caps: (surface && !f.caps.g.is_empty()).then(|| (as_f32(R::flat(&f.caps.g)), as_f32(&f.body_pressure))),
        loads: loads.then(|| (as_f32(R::flat(&f.spring_el)), as_f32(&m.particle_load_limit))),
        body: &m.particle_body,
        mass: as_f32(&m.particle_mass),
        inv_mass: as_f32(&m.particle_inv_mass),
        gravity: [g.x, g.y, g.z],
        dt: as_f32(std::slice::from_ref(&dt))[0],
    })
}

/// Walks a gather's piece, particles `start .. start + len`: `f(k, true)` for each whole block of eight that `ell`
/// lets go wide (`k` its first particle, counted from `start`), `f(k, false)` for each other particle, in order.
#[cfg(target_arch = "x86_64")]
fn by_blocks(ell: &gather_avx2::Ell, start: usize, len: usize, mut f: impl FnMut(usize, bool)) {
    let mut k = 0;
    while k < len {
        let at = start + k;
        if at.is_multiple_of(8) && k + 8 <= len && ell.wide(at / 8) {
            f(k, true);
            k += 8;
        } else {
            let end = (k + 8 - at % 8).min(len);
            (k..end).for_each(|j| f(j, false));
            k = end;
        }
    }
}

impl<R: Real> CpuSolver<R> {
    pub(super) fn symplectic_euler(&mut self, m: &Model<R>, s: &mut State<R>, dt: R, blown: &AtomicBool) {
        if self.f.runs {
            return self.symplectic_euler_runs(m, s, dt, blown);
        }
        // Without wind a triangle's corner force is its pressure share alone, so a measuring step sums each
        // particle's fracture load in this gather (one walk of its rows for both sums, the same bits as the load
        // pass) instead of in a pass of its own.
        self.fuse_loads = !m.has_wind();
        let surface = self.forces(m, &s.particle_q, &s.particle_qd, s.time);
        if std::mem::take(&mut self.loads_pending) {
            return self.symplectic_euler_with_loads(m, s, dt, blown, surface);
        }
        let t = Instant::now();
        let f = &self.f;
        let pool = par::gather_pool(gather_work(m, surface));
        #[cfg(target_arch = "x86_64")]
        let wide = wide_inputs(m, f, surface, dt, false);
        par::chunks2_pooled(pool, par::piece(GATHER_CHUNK), &mut s.particle_q, &mut s.particle_qd, |start, qs, vs| {
            let mut bad = false;
            // Particle `start + k`, the portable way.
            let one = |k: usize, qs: &mut [R::V], vs: &mut [R::V], bad: &mut bool| {
                let i = start + k;
                let w = m.particle_inv_mass[i];
                if w == R::ZERO {
                    return;
                }
                vs[k] += particle_force(m, f, surface, i) * (w * dt);
                qs[k] += vs[k] * dt;
                *bad |= !(vs[k].is_finite() && qs[k].is_finite());
            };
            // Whole blocks of eight on AVX2 (`forces::gather_avx2`, the same bits), the others the portable way.
            #[cfg(target_arch = "x86_64")]
            if let Some(x) = &wide {
                use crate::real::as_f32_mut;
                by_blocks(x.ell, start, qs.len(), |k, whole| {
                    if !whole {
                        return one(k, qs, vs, &mut bad);
                    }
                    let q8 = as_f32_mut(R::flat_mut(&mut qs[k..k + 8])).as_mut_ptr();
                    let v8 = as_f32_mut(R::flat_mut(&mut vs[k..k + 8])).as_mut_ptr();
                    // SAFETY: the CPU has AVX2 and the blocks were built for this model (`wide_inputs`); the block
                    // is wide (`by_blocks`), and `q8`, `v8` hold its 24 values each.
                    bad |= unsafe { gather_avx2::block(x, (start + k) / 8, q8, v8, std::ptr::null_mut()) };
                });
                if bad {
                    blown.store(true, Ordering::Relaxed);
                }
                return;
            }
            (0..qs.len()).for_each(|k| one(k, qs, vs, &mut bad));
            if bad {
                blown.store(true, Ordering::Relaxed);
            }
        });
        self.timers.add(Stage::Integrate, t);
    }

    /// [`CpuSolver::symplectic_euler`]'s update with the fracture loads summed in the same walk of each particle's
    /// rows (see there; the forces are `particle_force`'s, the loads `load_of`'s, bit for bit).
    fn symplectic_euler_with_loads(
        &mut self,
        m: &Model<R>,
        s: &mut State<R>,
        dt: R,
        blown: &AtomicBool,
        surface: bool,
    ) {
        let t = Instant::now();
        let mut load = std::mem::take(&mut self.f.load);
        let f = &self.f;
        let gas = surface && m.has_pressure();
        // Each spring entry is walked for two sums here.
        let pool = par::gather_pool(gather_work(m, surface) + 2 * m.spring_count());
        #[cfg(target_arch = "x86_64")]
        let wide = wide_inputs(m, f, surface, dt, true);
        par::chunks3_pooled(
            pool,
            par::piece(GATHER_CHUNK),
            &mut s.particle_q,
            &mut s.particle_qd,
            &mut load,
            |start, qs, vs, ls| {
                let mut bad = false;
                // Particle `start + k`, the portable way.
                let one = |k: usize, qs: &mut [R::V], vs: &mut [R::V], ls: &mut [R], bad: &mut bool| {
                    let i = start + k;
                    let mut ft = m.gravity * m.particle_mass[i];
                    let mut fe = R::V::ZERO;
                    for &e in m.particle_springs.row(i) {
                        let (sf, se) = (f.spring_f[(e >> 1) as usize], f.spring_el[(e >> 1) as usize]);
                        if e & 1 == 0 {
                            ft += sf;
                            fe += se;
                        } else {
                            ft -= sf;
                            fe -= se;
                        }
                    }
                    if surface {
                        // Reached without wind only (`fuse_loads`): the triangles' forces are the gas's.
                        debug_assert!(!f.tri_f_written);
                        let share = pressure_share(m, f, i);
                        ft += share;
                        if gas {
                            fe += share;
                        }
                        if !f.caps.g.is_empty() {
                            ft += cap_force(m, f, i);
                        }
                    }
                    ls[k] = if m.particle_load_limit[i].is_finite() { fe.length() } else { R::ZERO };
                    let w = m.particle_inv_mass[i];
                    if w == R::ZERO {
                        return;
                    }
                    vs[k] += ft * (w * dt);
                    qs[k] += vs[k] * dt;
                    *bad |= !(vs[k].is_finite() && qs[k].is_finite());
                };
                // Whole blocks of eight on AVX2 (`forces::gather_avx2`, the same bits), as in `symplectic_euler`.
                #[cfg(target_arch = "x86_64")]
                if let Some(x) = &wide {
                    use crate::real::as_f32_mut;
                    by_blocks(x.ell, start, qs.len(), |k, whole| {
                        if !whole {
                            return one(k, qs, vs, ls, &mut bad);
                        }
                        let q8 = as_f32_mut(R::flat_mut(&mut qs[k..k + 8])).as_mut_ptr();
                        let v8 = as_f32_mut(R::flat_mut(&mut vs[k..k + 8])).as_mut_ptr();
                        let l8 = as_f32_mut(&mut ls[k..k + 8]).as_mut_ptr();
                        // SAFETY: as in `symplectic_euler`; `l8` holds the block's 8 loads.
                        bad |= unsafe { gather_avx2::block(x, (start + k) / 8, q8, v8, l8) };
                    });
                    if bad {
                        blown.store(true, Ordering::Relaxed);
                    }
                    return;
                }
                (0..qs.len()).for_each(|k| one(k, qs, vs, ls, &mut bad));
                if bad {
                    blown.store(true, Ordering::Relaxed);
                }
            },
        );
        self.f.load = load;
        self.timers.add(Stage::Integrate, t);
    }

    /// Symplectic Euler fused with the spring-run kernel: each block of particles sums its spring forces and
    /// immediately updates its own particles, writing into the second position/velocity buffers (other blocks
    /// still read the old positions of their neighbours), which are then swapped with the state's. One pass over
    /// the particles instead of two.
    fn symplectic_euler_runs(&mut self, m: &Model<R>, s: &mut State<R>, dt: R, blown: &AtomicBool) {
        let surface = m.has_pressure() || m.has_wind();
        if surface {
            let t = Instant::now();
            self.f.surface(m, &s.particle_q, &s.particle_qd, s.time, false);
            self.timers.add(Stage::Surface, t);
        }
        let t = Instant::now();
        // A model that can break by strain gets its springs' strains from the kernel (see `StrainSink`).
        let measure = std::mem::take(&mut self.measure_next) && self.f.measuring;
        let mut strain = std::mem::take(&mut self.f.strain);
        let over = self.f.sparse_strains.then_some(self.f.strain_over);
        let spans = std::mem::take(&mut self.f.strain_spans);
        let sink = measure.then(|| StrainSink::new(&mut strain, over, spans));
        let sink_ref = sink.as_ref();
        // The colliders resolved by each block right after its update, while its particles are in cache: the
        // collision pass's work without a pass of its own. On two threads a pass handed to the pool costs a
        // wake-up. On the 128² cloth on the ground and a ball (harness `terms`, 2026-11-24), the colliders added
        // 0.08–0.69× the spring pass with a pass of their own (7 of 8 runs over 0.3), and −0.20…0.35× fused (6
        // of 7 runs at or under 0.3). Each block starts at a multiple of `par::CHUNK`, so the collision blocks
        // and their near lists are the pass's: the same bits. The collide stage gets the pieces' summed time over
        // the pass's threads.
        let fused = self.collide_at.take();
        if let Some(time) = fused {
            self.prepare_colliders(m, time);
        }
        let (prepared, every) = (&self.colliders[..], &self.collider_ids[..]);
        let collide_ns = std::sync::atomic::AtomicU64::new(0);
        // Buffers sized by `ensure_sized`.
        let (q, qd) = (&s.particle_q, &s.particle_qd);
        let f = &self.f;
        let projected = m.damping_model == DampingModel::Projected;
        let collide = |p0: usize, qs: &mut [R::V], vs: &mut [R::V]| {
            if fused.is_some() {
                let t = Instant::now();
                if super::collide::collide_chunk(m, prepared, every, p0, qs, vs) {
                    blown.store(true, Ordering::Relaxed);
                }
                collide_ns.fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
            }
        };
        let block_f = &self.block_f;
        let pool = par::is_pooled(s.particle_q.len());
        par::chunks2_pooled(pool, f.run_blocks.len(), &mut self.q_next, &mut self.qd_next, |p0, qs, vs| {
            {
                // A free buffer: as many as threads can run blocks at once (see `CpuSolver::block_f`).
                let mut fs = block_f.take(qs.len());
                let fs = &mut fs[..qs.len()];
                if projected {
                    run_block_dispatch::<R, true>(m, &f.run_blocks, q, qd, p0, fs, sink_ref);
                } else {
                    run_block_dispatch::<R, false>(m, &f.run_blocks, q, qd, p0, fs, sink_ref);
                }
                let summed = f.tri_summed();
                if summed {
                    // The grid wind pass summed each particle's triangles: one add a particle, over the components.
                    let sums = R::flat(&f.tri_sums[p0..p0 + fs.len()]);
                    for (a, &b) in R::flat_mut(fs).iter_mut().zip(sums) {
                        *a += b;
                    }
                }
                if !surface || summed {
                    // No triangle terms left: the update over the components, without branches.
                    if update_dispatch(m, q, qd, p0, fs, qs, vs, dt) {
                        blown.store(true, Ordering::Relaxed);
                    }
                    collide(p0, qs, vs);
                    return;
                }
                let mut bad = false;
                for k in 0..fs.len() {
                    let i = p0 + k;
                    let w = m.particle_inv_mass[i];
                    if w == R::ZERO {
                        qs[k] = q[i];
                        vs[k] = qd[i];
                        continue;
                    }
                    // With triangle terms (the case without them returned above).
                    let mut force = add_corners(m.gravity * m.particle_mass[i] + fs[k], m, f, i);
                    if !f.caps.g.is_empty() {
                        force += cap_force(m, f, i);
                    }
                    let v = qd[i] + force * (w * dt);
                    vs[k] = v;
                    qs[k] = q[i] + v * dt;
                    bad |= !(v.is_finite() && qs[k].is_finite());
                }
                if bad {
                    blown.store(true, Ordering::Relaxed);
                }
                collide(p0, qs, vs);
            }
        });
        // The collision work's share of the pass's wall time: its pieces' summed time over the threads.
        let pass = t.elapsed();
        let collided = if fused.is_some() {
            let blocks = s.particle_q.len().div_ceil(self.f.run_blocks.len());
            let threads = par::threads_for(s.particle_q.len(), blocks) as u32;
            let c = (std::time::Duration::from_nanos(collide_ns.into_inner()) / threads).min(pass);
            self.timers.add_time(Stage::Collide, c);
            self.collided = true;
            c
        } else {
            std::time::Duration::ZERO
        };
        if let Some(sink) = sink {
            self.f.strain_spans = sink.finish();
            self.f.strain_sparse = over.is_some();
        }
        self.f.strain = strain;
        self.f.measured = measure;
        std::mem::swap(&mut s.particle_q, &mut self.q_next);
        std::mem::swap(&mut s.particle_qd, &mut self.qd_next);
        self.timers.add_time(Stage::Springs, t.elapsed().saturating_sub(collided));
    }

    pub(super) fn velocity_verlet(&mut self, m: &Model<R>, s: &mut State<R>, dt: R, blown: &AtomicBool) {
        let half = dt * R::from_f64(0.5);
        // Kick half a step, drift a whole step; keep `v_n + dt a_n` for the velocity-dependent forces of the second
        // kick (see `Integrator::VelocityVerlet`).
        let surface = self.forces(m, &s.particle_q, &s.particle_qd, s.time);
        let t = Instant::now();
        let f = &self.f;
        let mut v_pred = std::mem::take(&mut self.v_pred);
        let pool = par::gather_pool(gather_work(m, surface));
        par::chunks3_pooled(
            pool,
            par::piece(GATHER_CHUNK),
            &mut s.particle_q,
            &mut s.particle_qd,
            &mut v_pred,
            |start, qs, vs, ps| {
                let mut bad = false;
                for k in 0..qs.len() {
                    let i = start + k;
                    let w = m.particle_inv_mass[i];
                    if w != R::ZERO {
                        let a = particle_force(m, f, surface, i) * w;
                        ps[k] = vs[k] + a * dt;
                        vs[k] += a * half;
                        qs[k] += vs[k] * dt;
                        bad |= !qs[k].is_finite();
                    } else {
                        ps[k] = vs[k];
                    }
                }
                if bad {
                    blown.store(true, Ordering::Relaxed);
                }
            },
        );
        self.timers.add(Stage::Integrate, t);
        // Kick the second half with the forces at the new positions and the extrapolated velocities.
        let surface = self.forces(m, &s.particle_q, &v_pred, s.time + dt.to_f64());
        self.v_pred = v_pred;
        let t = Instant::now();
        let f = &self.f;
        par::chunks_pooled(
            par::gather_pool(gather_work(m, surface)),
            par::piece(GATHER_CHUNK),
            &mut s.particle_qd,
            |start, vs| {
                let mut bad = false;
                for k in 0..vs.len() {
                    let i = start + k;
                    let w = m.particle_inv_mass[i];
                    if w != R::ZERO {
                        vs[k] += particle_force(m, f, surface, i) * (w * half);
                        bad |= !vs[k].is_finite();
                    }
                }
                if bad {
                    blown.store(true, Ordering::Relaxed);
                }
            },
        );
        self.timers.add(Stage::Integrate, t);
    }

    pub(super) fn rk4(&mut self, m: &Model<R>, s: &mut State<R>, dt: R, blown: &AtomicBool) {
        let mut rk = std::mem::take(&mut self.rk);
        rk.xt.copy_from_slice(&s.particle_q);
        rk.vt.copy_from_slice(&s.particle_qd);
        let weight = [1.0 / 6.0, 2.0 / 6.0, 2.0 / 6.0, 1.0 / 6.0].map(R::from_f64);
        let c_next = [0.5, 0.5, 1.0].map(|c| R::from_f64(c) * dt);
        let c_time = [0.0, 0.5, 0.5, 1.0];
        for stage in 0..4 {
            let surface = self.forces(m, &rk.xt, &rk.vt, s.time + c_time[stage] * dt.to_f64());
            let t = Instant::now();
            let f = &self.f;
            let ws = weight[stage];
            let first = stage == 0;
            let pool = par::gather_pool(gather_work(m, surface));
            // Slopes of this stage: kx = stage velocity, kv = acceleration. Accumulate, then either set up the next
            // stage or (last stage) apply the weighted sum to the state.
            let slope = |i: usize, vt: R::V| -> (R::V, R::V) {
                let w = m.particle_inv_mass[i];
                if w == R::ZERO { (R::V::ZERO, R::V::ZERO) } else { (vt, particle_force(m, f, surface, i) * w) }
            };
            if stage < 3 {
                let cn = c_next[stage];
                let (x0, v0) = (&s.particle_q, &s.particle_qd);
                par::chunks4_pooled(
                    pool,
                    par::piece(GATHER_CHUNK),
                    &mut rk.xt,
                    &mut rk.vt,
                    &mut rk.ax,
                    &mut rk.av,
                    |start, xs, vs, axs, avs| {
                        for k in 0..xs.len() {
                            let i = start + k;
                            let (kx, kv) = slope(i, vs[k]);
                            if first {
                                axs[k] = kx * ws;
                                avs[k] = kv * ws;
                            } else {
                                axs[k] += kx * ws;
                                avs[k] += kv * ws;
                            }
                            xs[k] = x0[i] + kx * cn;
                            vs[k] = v0[i] + kv * cn;
                        }
                    },
                );
            } else {
                let vt = &rk.vt;
                par::chunks4_pooled(
                    pool,
                    par::piece(GATHER_CHUNK),
                    &mut s.particle_q,
                    &mut s.particle_qd,
                    &mut rk.ax,
                    &mut rk.av,
                    |start, xs, vs, axs, avs| {
                        let mut bad = false;
                        for k in 0..xs.len() {
                            let i = start + k;
                            let (kx, kv) = slope(i, vt[i]);
                            xs[k] += (axs[k] + kx * ws) * dt;
                            vs[k] += (avs[k] + kv * ws) * dt;
                            bad |= !(vs[k].is_finite() && xs[k].is_finite());
                        }
                        if bad {
                            blown.store(true, Ordering::Relaxed);
                        }
                    },
                );
            }
            self.timers.add(Stage::Integrate, t);
        }
        self.rk = rk;
    }
}

crate::isa::wide_kernel! {
    /// [`update`] compiled for AVX-512 or AVX2 when the CPU has them (the same bits; see `crate::isa`).
    fn update_dispatch[R: Real](
        m: &Model<R>,
        q: &[R::V],
        qd: &[R::V],
        p0: usize,
        fs: &[R::V],
        qs: &mut [R::V],
        vs: &mut [R::V],
        dt: R,
    ) -> bool => update[R]
}

/// Symplectic Euler's update of particles `p0 .. p0 + fs.len()` from their spring forces `fs` (no other force but
/// gravity) into `qs`, `vs`: `v = v0 + (g m + f) w dt`, `x = x0 + v dt`, a pinned particle (`w = 0`) kept as it
/// was. The per-particle update's operations in its order (the same bits), over the components with selects
/// instead of branches.
/// True if a moving particle's state is not finite.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn update<R: Real>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    p0: usize,
    fs: &[R::V],
    qs: &mut [R::V],
    vs: &mut [R::V],
    dt: R,
) -> bool {
    const SPAN: usize = 64;
    let n = fs.len();
    let (x0, v0, f) = (R::flat(&q[p0..p0 + n]), R::flat(&qd[p0..p0 + n]), R::flat(fs));
    let (x1, v1) = (R::flat_mut(&mut qs[..n]), R::flat_mut(&mut vs[..n]));
    let (w, mass) = (&m.particle_inv_mass[p0..p0 + n], &m.particle_mass[p0..p0 + n]);
    let g = m.gravity.to_array();
    let mut bad = false;
    // Per span of particles, their factors spread over their components (`g m` and `w dt` per component), then
    // one loop over the components: flat, so the compiler vectorises it.
    let (mut gm, mut s, mut keep) = ([R::ZERO; 3 * SPAN], [R::ZERO; 3 * SPAN], [false; 3 * SPAN]);
    // A span whose particles share one mass and inverse mass (a uniform cloth's, but for its pins) has the same
    // factors for every particle: spread once, for every span after it that shares them too. Spreading per
    // particle was 44 % of this update on the 1024² cloth (2026-11-25). The same values: the same bits.
    let mut spread: Option<(R, R)> = None;
    let mut k0 = 0;
    while k0 < n {
        let len = (n - k0).min(SPAN);
        let (wk, mk) = (&w[k0..k0 + len], &mass[k0..k0 + len]);
        let (w0, m0) = (wk[0], mk[0]);
        let shared = wk.iter().zip(mk).fold(true, |same, (&a, &b)| same & (a == w0) & (b == m0));
        if shared {
            if spread != Some((m0, w0)) {
                let (sk, kk) = (w0 * dt, w0 == R::ZERO);
                for k in 0..SPAN {
                    for c in 0..3 {
                        gm[3 * k + c] = g[c] * m0;
                        s[3 * k + c] = sk;
                        keep[3 * k + c] = kk;
                    }
                }
                spread = Some((m0, w0));
            }
        } else {
            spread = None;
            for k in 0..len {
                let (mk, sk, kk) = (mk[k], wk[k] * dt, wk[k] == R::ZERO);
                for c in 0..3 {
                    gm[3 * k + c] = g[c] * mk;
                    s[3 * k + c] = sk;
                    keep[3 * k + c] = kk;
                }
            }
        }
        let r = 3 * k0..3 * (k0 + len);
        let (x0, v0, f, x1, v1) = (&x0[r.clone()], &v0[r.clone()], &f[r.clone()], &mut x1[r.clone()], &mut v1[r]);
        for j in 0..3 * len {
            let v = v0[j] + (gm[j] + f[j]) * s[j];
            let x = x0[j] + v * dt;
            v1[j] = if keep[j] { v0[j] } else { v };
            x1[j] = if keep[j] { x0[j] } else { x };
            bad |= !keep[j] & !(v.is_finite() & x.is_finite());
        }
        k0 += len;
    }
    bad
}
