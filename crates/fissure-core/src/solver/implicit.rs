//! Implicit Euler (Baraff & Witkin 1998): the linearised backward Euler system `(M + h C + h² K) Δv = h f + h² K v`
//! solved matrix-free by preconditioned conjugate gradients, springs by their exact stretched Jacobians
//! ([`crate::forces::spring::implicit_coefficients`]) and the gas by its rank-one Jacobian `nRT/V² g gᵀ`. The
//! preconditioner is block-Jacobi plus, by default (`SolverConfig::cg_coarse`), a coarse level on aggregates of
//! particles (`coarse.rs`: about half the iterations at large steps). CG starts from the last step's `Δv` when a
//! step continues the solver's last one. A grid cloth below `par::PAR_MIN` is solved in struct-of-arrays form over
//! its spring runs (`cg_runs.rs`, ~3× faster per iteration); any other model per spring here, its passes split
//! between the threads from `PAR_MIN` elements.

use super::*;

#[derive(Clone, Debug, Default)]
pub(super) struct ImplicitScratch<R: Real> {
    pub(super) r: Vec<R::V>,
    pub(super) z: Vec<R::V>,
    pub(super) p: Vec<R::V>,
    pub(super) ap: Vec<R::V>,
    pub(super) dv: Vec<R::V>,
    /// Rows of the inverse 3×3 diagonal block of each particle (the block-Jacobi preconditioner).
    pub(super) block: Vec<[R::V; 3]>,
    pub(super) g: Vec<R::V>,
    /// Unit direction of each spring.
    pub(super) u: Vec<R::V>,
    /// `[h² ks (1 - L0/l)+, h² ks, iso + damping, axial + damping]`: stiffness-only and system coefficients of the
    /// spring block `iso I + (axial - iso) u uᵀ`.
    pub(super) coef: Vec<[R; 4]>,
    /// `h² nRT / V²` per body.
    pub(super) body_c: Vec<R>,
    /// `g · p` per body.
    pub(super) body_dot: Vec<R>,
    pub(super) partials: Vec<R>,
    /// The struct-of-arrays CG of grid models (`cg_runs.rs`).
    pub(super) runs: super::cg_runs::RunsCg<R>,
    /// Chunk sums of the fused CG passes.
    pub(super) sums: Vec<[R; 2]>,
    /// `State::time` at the end of this solver's last implicit step, and that step's `h`: a step that starts
    /// there continues it, and its CG starts from that step's `Δv` (left in `dv`) scaled by the step ratio.
    /// `None` (a new or resized solver): CG starts from zero.
    pub(super) warm: Option<(f64, R)>,
    /// The preconditioner's coarse level (`coarse.rs`).
    pub(super) coarse: super::coarse::Coarse,
}

impl<R: Real> CpuSolver<R> {
    pub(super) fn implicit_euler(
        &mut self,
        m: &Model<R>,
        s: &mut State<R>,
        dt: R,
        blown: &AtomicBool,
    ) -> Result<(), StepError> {
        let h = dt;
        let h2 = h * h;
        let surface = self.forces(m, &s.particle_q, &s.particle_qd, s.time);
        let t = Instant::now();
        let mut im = std::mem::take(&mut self.imp);
        let pressure = m.has_pressure();
        let (q, v0) = (&s.particle_q, &s.particle_qd);
        // Spring blocks.
        let projected = m.damping_model == DampingModel::Projected;
        {
            let coef = &mut im.coef;
            let u = &mut im.u;
            par::chunks2(u, coef, |start, us, cs| {
                for k in 0..us.len() {
                    let sidx = start + k;
                    let [i, j] = m.spring_indices[sidx];
                    let d = q[j as usize] - q[i as usize];
                    let (ks, kd, l0) = (m.spring_stiffness[sidx], m.spring_damping[sidx], m.spring_rest_length[sidx]);
                    (us[k], cs[k]) = implicit_coefficients(d, l0, ks, kd, h, projected);
                }
            });
        }
        // Pressure: g = ∂V/∂x per particle and c_b = h² nRT / V².
        if pressure {
            let tri_cross = &self.f.tri_cross;
            let sixth = R::from_f64(1.0 / 6.0);
            par::chunks(&mut im.g, |start, gs| {
                for k in 0..gs.len() {
                    let i = start + k;
                    let mut acc = R::VA::default();
                    for &tt in m.particle_tris.row(i) {
                        if m.body_gas_amount[m.tri_body[tt as usize] as usize] > R::ZERO {
                            acc += tri_cross[tt as usize];
                        }
                    }
                    gs[k] = acc.into() * sixth;
                }
            });
            for &i in &self.f.caps.touched {
                im.g[i as usize] += self.f.caps.g[i as usize];
            }
            for b in 0..m.body_count() {
                let gas = m.body_gas_amount[b];
                let v = pressure::clamped_volume(self.f.body_volume[b], m.body_rest_volume[b]);
                im.body_c[b] = if gas > R::ZERO { h2 * gas / (v * v) } else { R::ZERO };
            }
        }
        // Right-hand side b = h f0 + G(y_K(v0)) - Σ c_b g (g·v0), into r (the initial guess is 0).
        {
            let f = &self.f;
            par::chunks(&mut im.r, |start, rs| {
                for k in 0..rs.len() {
                    let i = start + k;
                    rs[k] = if m.particle_inv_mass[i] == R::ZERO {
                        R::V::ZERO
                    } else {
                        particle_force(m, f, surface, i) * h
                    };
                }
            });
        }
        // The spring buffer is free now: reuse it for y_K(v0).
        spring_apply(m, &im.u, &im.coef, 0, v0, &mut self.f.spring_f);
        if pressure {
            body_dots(m, &im.g, v0, &mut im.partials, &mut im.body_dot);
        }
        {
            let f = &self.f;
            let (g, bc, bd) = (&im.g, &im.body_c, &im.body_dot);
            par::chunks(&mut im.r, |start, rs| {
                for k in 0..rs.len() {
                    let i = start + k;
                    if m.particle_inv_mass[i] == R::ZERO {
                        continue;
                    }
                    rs[k] += spring_gather(m, &f.spring_f, i);
                    if pressure {
                        let body = m.particle_body[i];
                        if body != NONE && bc[body as usize] > R::ZERO {
                            rs[k] -= g[i] * (bc[body as usize] * bd[body as usize]);
                        }
                    }
                }
            });
        }
        // Block-Jacobi preconditioner: the inverse of A's 3×3 diagonal block of each particle (its mass, its
        // springs' blocks `iso I + (axial - iso) u uᵀ` and the gas's `c g gᵀ`), rows stored.
        {
            let (u, coef, g, bc) = (&im.u, &im.coef, &im.g, &im.body_c);
            par::chunks(&mut im.block, |start, ds| {
                for k in 0..ds.len() {
                    let i = start + k;
                    // Pinned particles are filtered out of the solve: a zero preconditioner keeps them at dv = 0
                    // (and avoids 0 · ∞ when a massless anchor has no stiffness in some direction).
                    if m.particle_inv_mass[i] == R::ZERO {
                        ds[k] = [R::V::ZERO; 3];
                        continue;
                    }
                    let mi = m.particle_mass[i];
                    // Symmetric: a[0][0], a[1][1], a[2][2], a[0][1], a[0][2], a[1][2].
                    let mut a = [mi, mi, mi, R::ZERO, R::ZERO, R::ZERO];
                    let mut add = |w: R::V, c: R, iso: R| {
                        let [x, y, z] = w.to_array();
                        a[0] += iso + c * x * x;
                        a[1] += iso + c * y * y;
                        a[2] += iso + c * z * z;
                        a[3] += c * x * y;
                        a[4] += c * x * z;
                        a[5] += c * y * z;
                    };
                    for &e in m.particle_springs.row(i) {
                        let sidx = (e >> 1) as usize;
                        let [_, _, iso, axial] = coef[sidx];
                        add(u[sidx], axial - iso, iso);
                    }
                    if pressure {
                        let body = m.particle_body[i];
                        if body != NONE {
                            add(g[i], bc[body as usize], R::ZERO);
                        }
                    }
                    ds[k] = inverse_sym3::<R>(a);
                    debug_assert!(ds[k].iter().all(|r| r.is_finite()), "free particle {i} has a singular block");
                }
            });
        }
        // The preconditioner's second level: the system on aggregates of particles moving together.
        if self.config.cg_coarse {
            let body_c: &[R] = if pressure { &im.body_c } else { &[] };
            im.coarse.build(m, &im.u, &im.coef, &im.g, body_c);
        } else {
            im.coarse.off();
        }
        self.timers.add(Stage::Integrate, t);
        let t = Instant::now();
        // The last step's Δv is the guess when this step continues it (the motion of one step predicts the next:
        // on the 32² benchmark cloth at 1/60 s, 115 → 107 iterations); anything else (a new state, another time, a
        // resized model) starts from zero.
        let guess = match im.warm {
            Some((time, h0)) if time == s.time && im.dv.len() == m.particle_count() => Some(h / h0),
            _ => None,
        };
        let result = if super::cg_runs::serves(m) {
            self.cg_solve_runs(m, &mut im, pressure, guess)
        } else {
            self.cg_solve(m, &mut im, pressure, guess)
        };
        self.timers.add(Stage::Solve, t);
        let t = Instant::now();
        let dv = &im.dv;
        par::chunks2(&mut s.particle_q, &mut s.particle_qd, |start, qs, vs| {
            let mut bad = false;
            for k in 0..qs.len() {
                let i = start + k;
                if m.particle_inv_mass[i] == R::ZERO {
                    continue;
                }
                vs[k] += dv[i];
                qs[k] += vs[k] * h;
                bad |= !(vs[k].is_finite() && qs[k].is_finite());
            }
            if bad {
                blown.store(true, Ordering::Relaxed);
            }
        });
        self.imp = im;
        self.timers.add(Stage::Integrate, t);
        result
    }

    /// Preconditioned conjugate gradients on `A dv = r` with pinned particles filtered out, to
    /// `|r| ≤ cg_tolerance |b|`. `guess`: start from `dv` (the last step's solution) times this factor; `None`:
    /// from zero. Each iteration is three passes over the particles (`A p` with `p·Ap`; the updates of `dv`
    /// and `r` with the preconditioner and `r·z`, `r·r`; the new direction) and one over the springs; the
    /// reductions are fused into the passes with the bits of [`par::sum`].
    pub(super) fn cg_solve(
        &mut self,
        m: &Model<R>,
        im: &mut ImplicitScratch<R>,
        pressure: bool,
        guess: Option<R>,
    ) -> Result<(), StepError> {
        let n = m.particle_count();
        let bnorm2 = par::sum(n, &mut im.partials, |i| im.r[i].dot(im.r[i]));
        self.cg = CgStats::default();
        if bnorm2 == R::ZERO {
            im.dv.iter_mut().for_each(|x| *x = R::V::ZERO);
            return Ok(());
        }
        let tol2 = R::from_f64(self.config.cg_tolerance * self.config.cg_tolerance) * bnorm2;
        match guess {
            Some(scale) => {
                // Zero on pinned particles: they are filtered out of the system.
                let w = &m.particle_inv_mass;
                par::chunks(&mut im.dv, |start, xs| {
                    for (k, x) in xs.iter_mut().enumerate() {
                        *x = if w[start + k] == R::ZERO { R::V::ZERO } else { *x * scale };
                    }
                });
                im.p.copy_from_slice(&im.dv);
                self.apply_a(m, im, pressure);
            }
            None => im.dv.iter_mut().for_each(|x| *x = R::V::ZERO),
        }
        // r = b - A dv (a warm start), z = P r, p = z.
        let [mut rz, mut rr] = {
            let (ap, block, warm) = (&im.ap, &im.block, guess.is_some());
            par::chunks3_sums(&mut im.r, &mut im.z, &mut im.p, &mut im.sums, |start, rs, zs, ps| {
                let (mut rz, mut rr) = (R::ZERO, R::ZERO);
                for k in 0..rs.len() {
                    if warm {
                        rs[k] -= ap[start + k];
                    }
                    zs[k] = precondition::<R>(&block[start + k], rs[k]);
                    ps[k] = zs[k];
                    rz += rs[k].dot(zs[k]);
                    rr += rs[k].dot(rs[k]);
                }
                [rz, rr]
            })
        };
        if im.coarse.active() {
            im.coarse.apply::<R>(&im.r, &mut im.z);
            im.p.copy_from_slice(&im.z);
            rz += R::from_f64(im.coarse.yx());
        }
        let mut it = 0;
        while it < self.config.cg_max_iterations && rr > tol2 {
            let pap = self.apply_a(m, im, pressure);
            if !pap.is_finite() || pap <= R::ZERO {
                // A is symmetric positive definite on the free particles by construction (clamped spring blocks,
                // positive masses, positive semidefinite pressure term): a non-positive or NaN curvature means
                // the state itself is broken.
                let residual = (rr / bnorm2).to_f64().sqrt();
                self.cg = CgStats { iterations: it, residual };
                return Err(StepError::NoConvergence { iterations: it, residual });
            }
            let alpha = rz / pap;
            let [mut rz_new, rr_new] = {
                let (p, ap, block) = (&im.p, &im.ap, &im.block);
                par::chunks3_sums(&mut im.dv, &mut im.r, &mut im.z, &mut im.sums, |start, xs, rs, zs| {
                    let (mut rz, mut rr) = (R::ZERO, R::ZERO);
                    for k in 0..xs.len() {
                        xs[k] += p[start + k] * alpha;
                        rs[k] -= ap[start + k] * alpha;
                        zs[k] = precondition::<R>(&block[start + k], rs[k]);
                        rz += rs[k].dot(zs[k]);
                        rr += rs[k].dot(rs[k]);
                    }
                    [rz, rr]
                })
            };
            if im.coarse.active() {
                im.coarse.apply::<R>(&im.r, &mut im.z);
                rz_new += R::from_f64(im.coarse.yx());
            }
            rr = rr_new;
            let beta = rz_new / rz;
            rz = rz_new;
            let z = &im.z;
            par::chunks(&mut im.p, |start, ps| {
                for k in 0..ps.len() {
                    ps[k] = z[start + k] + ps[k] * beta;
                }
            });
            it += 1;
        }
        let residual = (rr / bnorm2).to_f64().sqrt();
        self.cg = CgStats { iterations: it, residual };
        if !residual.is_finite() {
            return Err(StepError::NoConvergence { iterations: it, residual });
        }
        Ok(())
    }

    /// `ap = A p = M p - G(y_A(p)) + Σ c_b g (g·p)`, zero on pinned particles; returns `p·Ap`.
    pub(super) fn apply_a(&mut self, m: &Model<R>, im: &mut ImplicitScratch<R>, pressure: bool) -> R {
        spring_apply(m, &im.u, &im.coef, 2, &im.p, &mut self.f.spring_f);
        if pressure {
            body_dots(m, &im.g, &im.p, &mut im.partials, &mut im.body_dot);
        }
        let f = &self.f;
        let (p, g, bc, bd) = (&im.p, &im.g, &im.body_c, &im.body_dot);
        let [pap, _] = par::chunks_sums(&mut im.ap, &mut im.sums, |start, aps| {
            let mut pap = R::ZERO;
            for k in 0..aps.len() {
                let i = start + k;
                aps[k] = if m.particle_inv_mass[i] == R::ZERO {
                    R::V::ZERO
                } else {
                    let mut y = p[i] * m.particle_mass[i] - spring_gather(m, &f.spring_f, i);
                    if pressure {
                        let body = m.particle_body[i];
                        if body != NONE {
                            y += g[i] * (bc[body as usize] * bd[body as usize]);
                        }
                    }
                    y
                };
                pap += p[i].dot(aps[k]);
            }
            [pap, R::ZERO]
        });
        pap
    }
}

/// `Σ` spring buffer entries of particle `i` with the force sign convention (+ on end 0, - on end 1).
#[inline(always)]
fn spring_gather<R: Real>(m: &Model<R>, buf: &[R::V], i: usize) -> R::V {
    crate::forces::spring_gather::<R>(R::V::ZERO, m.particle_springs.row(i), buf)
}

/// `out_s = B_s (p_j - p_i)` with `B_s = c[o] I + (c[o+1] - c[o]) u uᵀ` (o = 0: stiffness only, 2: system).
fn spring_apply<R: Real>(m: &Model<R>, u: &[R::V], coef: &[[R; 4]], o: usize, p: &[R::V], out: &mut [R::V]) {
    par::chunks(out, |start, ys| {
        for k in 0..ys.len() {
            let s = start + k;
            let [i, j] = m.spring_indices[s];
            let d = p[j as usize] - p[i as usize];
            let (iso, axial) = (coef[s][o], coef[s][o + 1]);
            ys[k] = d * iso + u[s] * ((axial - iso) * u[s].dot(d));
        }
    });
}

/// `out_b = Σ_{i in body b} g_i · p_i`, deterministic.
fn body_dots<R: Real>(m: &Model<R>, g: &[R::V], p: &[R::V], partials: &mut Vec<R>, out: &mut [R]) {
    for (b, o) in out.iter_mut().enumerate() {
        if m.body_gas_amount[b] > R::ZERO {
            *o = par::sum(m.particle_count(), partials, |i| {
                if m.particle_body[i] as usize == b { g[i].dot(p[i]) } else { R::ZERO }
            });
        } else {
            *o = R::ZERO;
        }
    }
}

/// `z = B r` with `B` a particle's inverse diagonal block (rows).
#[inline(always)]
fn precondition<R: Real>(b: &[R::V; 3], r: R::V) -> R::V {
    R::V::new(b[0].dot(r), b[1].dot(r), b[2].dot(r))
}

/// The inverse of the symmetric 3×3 matrix `[a00, a11, a22, a01, a02, a12]`, as rows (adjugate over determinant).
fn inverse_sym3<R: Real>(a: [R; 6]) -> [R::V; 3] {
    let [a00, a11, a22, a01, a02, a12] = a;
    let c00 = a11 * a22 - a12 * a12;
    let c01 = a02 * a12 - a01 * a22;
    let c02 = a01 * a12 - a02 * a11;
    let c11 = a00 * a22 - a02 * a02;
    let c12 = a01 * a02 - a00 * a12;
    let c22 = a00 * a11 - a01 * a01;
    let inv = R::ONE / (a00 * c00 + a01 * c01 + a02 * c02);
    [
        R::V::new(c00 * inv, c01 * inv, c02 * inv),
        R::V::new(c01 * inv, c11 * inv, c12 * inv),
        R::V::new(c02 * inv, c12 * inv, c22 * inv),
    ]
}
