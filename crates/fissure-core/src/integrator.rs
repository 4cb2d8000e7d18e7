//! The time integrators and their orders. Their stability limits are in [`crate::stability`], their steps in
//! [`crate::solver`].

/// The time integrators.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Integrator {
    /// Semi-implicit (symplectic) Euler, the seed's eqs. (3)–(5): `v += dt a(x, v); x += dt v`. Order 1.
    #[default]
    SymplecticEuler,
    /// Velocity Verlet (kick–drift–kick). Order 2, damping included: the second kick evaluates the
    /// velocity-dependent forces (damping, drag) at `v_n + dt a_n`, the linear extrapolation of the velocity to
    /// the step's end, instead of the half-step velocity (which would make it first order in those terms; the
    /// harness measured 1.45 on a lightly damped ball before this). The price: on heavily damped springs the
    /// stability limit is that of symplectic Euler (`dt γ ≤ 2` for pure damping) instead of `dt γ ≤ 4`.
    VelocityVerlet,
    /// Classical fourth-order Runge–Kutta. Order 4.
    Rk4,
    /// Linearised backward Euler (Baraff & Witkin 1998) solved matrix-free by preconditioned conjugate
    /// gradients. Order 1, unconditionally stable for the linearised system. Spring Jacobians are exact when
    /// stretched; for compressed springs the transverse term `(1 - L0/l)` is clamped at 0 (it is negative, would
    /// make the system indefinite and CG fail; Choi & Ko 2002). Pressure enters with its rank-one Jacobian
    /// `nRT/V² g gᵀ` (`g = ∂V/∂x`), which is what keeps a stiff balloon stable at large steps.
    ImplicitEuler,
}

impl Integrator {
    /// All integrators.
    pub const ALL: [Integrator; 4] =
        [Integrator::SymplecticEuler, Integrator::VelocityVerlet, Integrator::Rk4, Integrator::ImplicitEuler];

    /// Global order of accuracy.
    pub fn order(self) -> u32 {
        match self {
            Integrator::SymplecticEuler | Integrator::ImplicitEuler => 1,
            Integrator::VelocityVerlet => 2,
            Integrator::Rk4 => 4,
        }
    }

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::SymplecticEuler => "symplectic_euler",
            Integrator::VelocityVerlet => "velocity_verlet",
            Integrator::Rk4 => "rk4",
            Integrator::ImplicitEuler => "implicit_euler",
        }
    }
}
