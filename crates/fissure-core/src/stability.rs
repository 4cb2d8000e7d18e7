//! Stability limits of the explicit integrators, from the mesh.
//!
//! An explicit step of a mass-spring system is stable when `dt` times the stiffest mode's rate lies inside the
//! integrator's stability region. For a damped 1-DOF oscillator `a = -ω² x - γ v` the limit is found exactly:
//! [`max_stable_dt_1dof`] bisects on the spectral radius of the integrator's 2×2 update matrix (for symplectic
//! Euler it is `dt < (√(γ² + 4ω²) - γ) / ω²`, i.e. `2/ω` undamped; for RK4 `2√2/ω` undamped). For a mesh,
//! [`StabilityBound::gershgorin`] bounds the largest eigenvalue of `M⁻¹K` and of `M⁻¹C` by Gershgorin's theorem on
//! the 3×3 blocks: a spring `s` of stiffness `k_s` contributes a diagonal block of norm `k_s` and an off-diagonal one
//! of norm `k_s` to each end's row, so
//!
//! ```text
//! ω²_max ≤ max_i (2 / m_i) Σ_{s ∋ i} k_s,        γ_max ≤ max_i (2 / m_i) Σ_{s ∋ i} c_s
//! ```
//!
//! (pinned particles excluded). Gershgorin overestimates `ω_max` (by 1.3–1.6× in `dt` on the harness's cloth and
//! ball), so automatic substepping under it took up to 1.6× more steps than needed.
//!
//! [`StabilityBound::of`] therefore *estimates* the largest eigenvalues instead: power iteration on the symmetric
//! `M^{-1/2} K M^{-1/2}` (and on `M^{-1/2} C M^{-1/2}`), with `K` the springs' Jacobian at the given positions
//! (`k (d̂d̂ᵀ + max(0, 1 - L0/l)(I - d̂d̂ᵀ))`, as the implicit solver linearises it), from a fixed pseudo-random start
//! (or a warm start after a fracture), until the Rayleigh quotient settles to 1e-4. The quotient approaches the
//! top eigenvalue from below, so it is raised by [`EIGEN_MARGIN`] and capped by Gershgorin (a true upper bound);
//! the measured limits then lie at 1.01–1.08× the bound on the harness's scenes wherever no spring stretches past
//! 50 % (`fissure bench --only stability`; a harness check holds them to 0.9–1.15).
//!
//! A linear bound cannot follow strongly nonlinear motion. On the harness's softest cloth (k = 100 N/m, springs
//! stretched up to ~300 % under its weight) symplectic Euler and velocity Verlet go into a nonlinear resonance
//! from ~0.83–0.86× the bound (`h ω` ≈ 1.65, between the third- and fourth-order resonances `√3` and `√2` that
//! Schlick, Mandziuk, Skeel and Srinivas (1998) found for Verlet in molecular dynamics): the fast modes grow to
//! ~8× the scene's own speeds and stay there, and the run blows up at ~0.98×. RK4 instead runs clean to 1.13×,
//! through states whose frozen Jacobian gives it a growth of 1.2–1.8 a step: the unstable mode is localised at the
//! most stretched particles and moves with them, and RK4 damps what it leaves behind (`|R(iy)|` ≈ 0.5 at `y` =
//! 2.5). So for large strains take [`crate::SolverConfig::substep_safety`] ≤ 0.8 with the symplectic integrators.
//! Gas pressure (its stiffness `nRT/V² ∂V/∂x ∂V/∂xᵀ` is small beside a membrane's springs), wind and collisions are
//! not counted. [`StabilityBound::gershgorin`] keeps the O(springs) bound.

use crate::error::StepError;
use crate::integrator::Integrator;
use crate::model::Model;
use crate::real::{Real, Vector3};
use glam::DVec3;

/// Relative margin added to the power-iteration estimate of the fastest mode's `ω²` (the Rayleigh quotient lies
/// at or below the top eigenvalue).
pub const EIGEN_MARGIN: f64 = 0.03;

/// Bounds on a model's fastest mode, and the step sizes they allow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StabilityBound {
    /// Largest eigenvalue of `M⁻¹K` \[1/s²\] (estimated plus margin, or Gershgorin's bound).
    pub omega2: f64,
    /// Largest eigenvalue of `M⁻¹C` \[1/s\] (estimated plus margin, or Gershgorin's bound).
    pub damping_rate: f64,
    /// The free particle whose Gershgorin row is the stiffest (`usize::MAX` without springs).
    pub stiffest_particle: usize,
}

impl StabilityBound {
    /// The estimated bound of `m` at its initial positions (see the module docs): power iteration, capped by
    /// Gershgorin.
    pub fn of<R: Real>(m: &Model<R>) -> Self {
        let q: Vec<DVec3> = m.particle_q0.iter().map(|x| x.to_dvec3()).collect();
        Self::estimate(m, &q, &mut Vec::new())
    }

    /// The estimated bound of `m` at positions `q` \[m\]. `warm` holds the fastest modes (stiffness, then damping)
    /// of an earlier call, reused as the start (extended for new particles; empty: a cold start), and receives
    /// this call's.
    pub fn estimate<R: Real>(m: &Model<R>, q: &[DVec3], warm: &mut Vec<DVec3>) -> Self {
        let g = Self::gershgorin(m);
        if g.omega2 == 0.0 && g.damping_rate == 0.0 {
            return g;
        }
        let n = m.particle_count();
        let sw: Vec<f64> = m.particle_inv_mass.iter().map(|w| w.to_f64().sqrt()).collect();
        let ks = |s: usize| {
            let [i, j] = m.spring_indices[s];
            let l = (q[j as usize] - q[i as usize]).length();
            let t = if l > 0.0 { (1.0 - m.spring_rest_length[s].to_f64() / l).max(0.0) } else { 0.0 };
            (m.spring_stiffness[s].to_f64(), m.spring_stiffness[s].to_f64() * t)
        };
        // `warm` holds the stiffness mode, then the damping mode.
        let half = warm.len() / 2;
        let mut damping_mode = if half <= n { warm.split_off(half) } else { Vec::new() };
        if half > n {
            warm.clear();
        }
        let omega2 = if g.omega2 > 0.0 { top_eigenvalue(m, q, &sw, ks, warm) } else { 0.0 };
        let projected = m.damping_model == crate::model::DampingModel::Projected;
        let cs = |s: usize| {
            let c = m.spring_damping[s].to_f64();
            (c, if projected { 0.0 } else { c })
        };
        let damping_rate = if g.damping_rate > 0.0 { top_eigenvalue(m, q, &sw, cs, &mut damping_mode) } else { 0.0 };
        if warm.len() == n && damping_mode.len() == n {
            warm.append(&mut damping_mode);
        }
        StabilityBound {
            omega2: (omega2 * (1.0 + EIGEN_MARGIN)).min(g.omega2),
            damping_rate: (damping_rate * (1.0 + EIGEN_MARGIN)).min(g.damping_rate),
            stiffest_particle: g.stiffest_particle,
        }
    }

    /// Gershgorin's bounds of `m` at its rest shape, O(springs): safe, and 1.3–1.6× loose in `dt` on meshes.
    pub fn gershgorin<R: Real>(m: &Model<R>) -> Self {
        let n = m.particle_count();
        let mut k_sum = vec![0.0f64; n];
        let mut c_sum = vec![0.0f64; n];
        for (s, &[i, j]) in m.spring_indices.iter().enumerate() {
            let (k, c) = (m.spring_stiffness[s].to_f64(), m.spring_damping[s].to_f64());
            if k == 0.0 && c == 0.0 {
                continue; // broken springs keep their slot with zero coefficients
            }
            for p in [i as usize, j as usize] {
                k_sum[p] += k;
                c_sum[p] += c;
            }
        }
        let mut b = StabilityBound { omega2: 0.0, damping_rate: 0.0, stiffest_particle: usize::MAX };
        for i in 0..n {
            let w = m.particle_inv_mass[i].to_f64();
            if w == 0.0 {
                continue;
            }
            let o2 = 2.0 * w * k_sum[i];
            if o2 > b.omega2 {
                b.omega2 = o2;
                b.stiffest_particle = i;
            }
            b.damping_rate = b.damping_rate.max(2.0 * w * c_sum[i]);
        }
        b
    }

    /// The largest stable step \[s\] of `integrator` for this bound; infinite for the implicit integrator or a
    /// model without springs.
    pub fn max_dt(&self, integrator: Integrator) -> f64 {
        max_stable_dt_1dof(integrator, self.omega2, self.damping_rate)
    }
}

/// The largest eigenvalue of `M^{-1/2} A M^{-1/2}`, `A = Σ_s (e_i - e_j)(e_i - e_j)ᵀ ⊗ (a d̂d̂ᵀ + t (I - d̂d̂ᵀ))` with
/// `(a, t) = coef(s)`, by power iteration (serial, fixed order: the same bits every run). `sw`: `√(1/m)` per
/// particle (0 pins a particle). `x`: the start (see [`StabilityBound::estimate`]); left holding the mode.
fn top_eigenvalue<R: Real>(
    m: &Model<R>,
    q: &[DVec3],
    sw: &[f64],
    coef: impl Fn(usize) -> (f64, f64),
    x: &mut Vec<DVec3>,
) -> f64 {
    let n = m.particle_count();
    // Start: the warm mode where it fits, a fixed pseudo-random vector elsewhere (never an eigenvector by chance).
    let fresh = |i: usize| {
        let h = |k: u64| {
            let mut z =
                (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(k.wrapping_mul(0xD1B5_4A32_D192_ED03));
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        DVec3::new(h(1), h(2), h(3))
    };
    let warm = x.len().min(n);
    x.truncate(warm);
    x.extend((warm..n).map(fresh));
    let coefs: Vec<(f64, f64, DVec3)> = m
        .spring_indices
        .iter()
        .enumerate()
        .map(|(s, &[i, j])| {
            let (a, t) = coef(s);
            let d = q[j as usize] - q[i as usize];
            let l = d.length();
            (a, t, if l > 0.0 { d / l } else { DVec3::ZERO })
        })
        .collect();
    let mut y = vec![DVec3::ZERO; n];
    let (mut rho, mut history) = (0.0, [0.0f64; 8]);
    let cold = warm == 0;
    let max_iterations = if cold { 1000 } else { 100 };
    for it in 0..max_iterations {
        let norm = x.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            x.iter_mut().enumerate().for_each(|(i, v)| *v = fresh(i));
            continue;
        }
        x.iter_mut().for_each(|v| *v /= norm);
        y.iter_mut().for_each(|v| *v = DVec3::ZERO);
        for (s, &[i, j]) in m.spring_indices.iter().enumerate() {
            let (i, j) = (i as usize, j as usize);
            let (a, t, u) = coefs[s];
            if a == 0.0 && t == 0.0 {
                continue;
            }
            let d = x[i] * sw[i] - x[j] * sw[j];
            let along = u * u.dot(d);
            let p = along * a + (d - along) * t;
            y[i] += p * sw[i];
            y[j] -= p * sw[j];
        }
        rho = x.iter().zip(&y).map(|(a, b)| a.dot(*b)).sum::<f64>();
        std::mem::swap(x, &mut y);
        // Settled: the quotient moved less than 1e-4 over the last 8 iterations (well inside EIGEN_MARGIN).
        let old = history[it % 8];
        history[it % 8] = rho;
        if it >= 8 && (rho - old).abs() <= 1e-4 * rho {
            break;
        }
    }
    let norm = x.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
    if norm > 0.0 {
        x.iter_mut().for_each(|v| *v /= norm);
    }
    rho.max(0.0)
}

/// Refuses an explicit step above the stability bound of a model in contact, before it is taken
/// ([`StepError::AboveStabilityBound`]). Both solvers keep one and ask it before every step that takes no
/// substeps of its own.
///
/// Why: without contact an unstable step ends in a [`StepError::NonFinite`] within tens of steps, and its
/// message names the step and the bound. With contact it does not end: the contact pass caps every particle's
/// move at a fraction of the gap to the nearest element it could meet, and the instability's runaway moves are
/// exactly such moves. The run goes on, its cloth jittering within the caps, wrong and many times slower.
/// Measured on `scenes/cloth_fold.toml` at twice its step (4e-4 s, 1.31× the bound; `fissure run … --set
/// solver.dt=4e-4 --frames 6`, 2026-12-07, a 2-core AMD EPYC Zen 4 VM): 0.2 s of simulation took 30 s of wall
/// time (0.007× real time, where its own step runs at 0.5×), 200,000 pairs within reach and 1,600 capped moves
/// a step against 88 and none; without contact the same step blew up at t = 19 ms with the message.
///
/// The bound is estimated once, at the first step's positions, and kept for the solver's life (a fracture
/// changes it by a few percent: 0.79–0.81× the step over the fracture scene's 130 changes, while an estimate
/// costs 1–12 ms). Above it the step is refused, though the measured limits lie at 1.01–1.13× it on the
/// harness's scenes: the bound is what the substep guard keeps under, and a step a little above it that happens
/// to run is not worth a run that silently does not.
#[derive(Clone, Copy, Debug, Default)]
pub struct ContactStepGuard {
    /// The integrator and its limit \[s\], once estimated.
    limit: Option<(Integrator, f64)>,
}

impl ContactStepGuard {
    /// `Ok` unless `m` has contact and `dt` \[s\] is above the limit of the explicit `integrator`; `bound` gives
    /// the model's bound the first time it is needed (or after the integrator changed).
    pub fn check<R: Real>(
        &mut self,
        m: &Model<R>,
        integrator: Integrator,
        dt: f64,
        bound: impl FnOnce() -> StabilityBound,
    ) -> Result<(), StepError> {
        if !m.has_contact() || integrator == Integrator::ImplicitEuler {
            return Ok(());
        }
        let limit = match self.limit {
            Some((i, limit)) if i == integrator => limit,
            _ => {
                let limit = bound().max_dt(integrator);
                self.limit = Some((integrator, limit));
                limit
            }
        };
        if dt > limit { Err(StepError::AboveStabilityBound { dt, stable_dt: limit }) } else { Ok(()) }
    }
}

/// The largest step \[s\] for which `integrator` is stable on `a = -omega2 x - gamma v` (spectral radius of its
/// update matrix ≤ 1), by bisection to 1e-12 relative. Infinite for [`Integrator::ImplicitEuler`] (A-stable) and
/// when both rates are zero.
pub fn max_stable_dt_1dof(integrator: Integrator, omega2: f64, gamma: f64) -> f64 {
    if integrator == Integrator::ImplicitEuler || (omega2 <= 0.0 && gamma <= 0.0) {
        return f64::INFINITY;
    }
    let stable = |h: f64| spectral_radius(update_matrix(integrator, omega2, gamma, h)) <= 1.0 + 1e-12;
    // The stable set of these schemes is an interval [0, h*]: grow past it, then bisect.
    let mut hi = 1.0 / (omega2.sqrt() + gamma);
    while stable(hi) {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    while hi - lo > 1e-12 * hi {
        let mid = 0.5 * (lo + hi);
        if stable(mid) { lo = mid } else { hi = mid }
    }
    lo
}

/// The map `(x, v) → (x', v')` of one step of `integrator` on the linear oscillator, as a 2×2 matrix (columns are
/// the images of `(1, 0)` and `(0, 1)`). Written the way the solver steps, so the bound is the solver's.
fn update_matrix(integrator: Integrator, omega2: f64, gamma: f64, h: f64) -> [[f64; 2]; 2] {
    let a = |x: f64, v: f64| -omega2 * x - gamma * v;
    let step = |x: f64, v: f64| -> (f64, f64) {
        match integrator {
            Integrator::SymplecticEuler => {
                let v1 = v + h * a(x, v);
                (x + h * v1, v1)
            }
            Integrator::VelocityVerlet => {
                let vh = v + 0.5 * h * a(x, v);
                let x1 = x + h * vh;
                (x1, vh + 0.5 * h * a(x1, 2.0 * vh - v))
            }
            Integrator::Rk4 => {
                let (k1x, k1v) = (v, a(x, v));
                let (k2x, k2v) = (v + 0.5 * h * k1v, a(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
                let (k3x, k3v) = (v + 0.5 * h * k2v, a(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
                let (k4x, k4v) = (v + h * k3v, a(x + h * k3x, v + h * k3v));
                (x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x), v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))
            }
            Integrator::ImplicitEuler => {
                // (1 + hγ + h²ω²) v' = v + h a(x, 0); x' = x + h v'.
                let v1 = (v + h * a(x, 0.0)) / (1.0 + h * gamma + h * h * omega2);
                (x + h * v1, v1)
            }
        }
    };
    let (c0, c1) = (step(1.0, 0.0), step(0.0, 1.0));
    [[c0.0, c1.0], [c0.1, c1.1]]
}

fn spectral_radius(m: [[f64; 2]; 2]) -> f64 {
    let tr = m[0][0] + m[1][1];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let disc = tr * tr / 4.0 - det;
    if disc >= 0.0 {
        let r = disc.sqrt();
        (tr / 2.0 + r).abs().max((tr / 2.0 - r).abs())
    } else {
        det.abs().sqrt() // complex pair: |λ|² = det
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_limits_are_the_textbook_ones() {
        let w = 10.0f64;
        let se = max_stable_dt_1dof(Integrator::SymplecticEuler, w * w, 0.0);
        let vv = max_stable_dt_1dof(Integrator::VelocityVerlet, w * w, 0.0);
        let rk = max_stable_dt_1dof(Integrator::Rk4, w * w, 0.0);
        assert!((se - 2.0 / w).abs() < 1e-9, "{se}");
        assert!((vv - 2.0 / w).abs() < 1e-9, "{vv}");
        assert!((rk - 8f64.sqrt() / w).abs() < 1e-6, "{rk}");
        assert_eq!(max_stable_dt_1dof(Integrator::ImplicitEuler, w * w, 0.0), f64::INFINITY);
    }

    #[test]
    fn damped_symplectic_euler_matches_its_closed_form() {
        for (w2, g) in [(1e4, 10.0), (1e4, 1e3), (1.0, 1e2)] {
            let closed = ((g * g + 4.0 * w2).sqrt() - g) / w2;
            let h = max_stable_dt_1dof(Integrator::SymplecticEuler, w2, g);
            assert!((h - closed).abs() < 1e-9 * closed, "{w2} {g}: {h} vs {closed}");
        }
    }
}
