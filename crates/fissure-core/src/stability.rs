//! Stability limits of the explicit integrators, from the mesh.
//!
//! An explicit step of a mass-spring system is stable when `dt` times the stiffest mode's rate lies inside the
//! integrator's stability region. For a damped 1-DOF oscillator `a = -ω² x - γ v` the limit is found exactly:
//! [`max_stable_dt_1dof`] bisects on the spectral radius of the integrator's 2×2 update matrix (for symplectic
//! Euler it is `dt < (√(γ² + 4ω²) - γ) / ω²`, i.e. `2/ω` undamped; for RK4 `2√2/ω` undamped). For a mesh,
//! [`StabilityBound::of`] bounds the largest eigenvalue of `M⁻¹K` and of `M⁻¹C` by Gershgorin's theorem on the
//! 3×3 blocks: a spring `s` of stiffness `k_s` contributes a diagonal block of norm `k_s` and an off-diagonal one
//! of norm `k_s` to each end's row, so
//!
//! ```text
//! ω²_max ≤ max_i (2 / m_i) Σ_{s ∋ i} k_s,        γ_max ≤ max_i (2 / m_i) Σ_{s ∋ i} c_s
//! ```
//!
//! (pinned particles excluded). The limit uses both at once, which is exact when damping is proportional to
//! stiffness (the same mode is the stiffest and the most damped) and conservative otherwise. The bound is taken
//! at the rest shape: a stretched spring's transverse stiffness `k (1 - L0/l)` stays below `k`, so stretching does
//! not lower it; gas pressure (its stiffness `nRT/V² ∂V/∂x ∂V/∂xᵀ` is small beside a membrane's springs), wind and
//! collisions are not counted. Gershgorin overestimates `ω_max` for a regular grid, so measured limits lie at or
//! above the bound (the harness's stability section plots both).

use crate::integrator::Integrator;
use crate::model::Model;
use crate::real::Real;

/// Gershgorin bounds on a model's fastest mode, and the step sizes they allow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StabilityBound {
    /// Bound on the largest eigenvalue of `M⁻¹K` [1/s²].
    pub omega2: f64,
    /// Bound on the largest eigenvalue of `M⁻¹C` [1/s].
    pub damping_rate: f64,
    /// The free particle whose row gives `omega2` (`usize::MAX` without springs).
    pub stiffest_particle: usize,
}

impl StabilityBound {
    /// The bounds of `m` at its rest shape, O(springs).
    pub fn of<R: Real>(m: &Model<R>) -> Self {
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
