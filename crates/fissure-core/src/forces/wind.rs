//! A wind field varying in space and time, and the per-triangle aerodynamic model it drives.
//!
//! The field is a mean wind whose speed is modulated by a gust wave travelling downwind, plus a crosswind
//! wobble: `w(x, t) = U (1 + a sin φ) + b |U| sin(φ') ê`, with `φ = 2π (f t - x·Û / λ)` and `φ'` the same at
//! 0.37 f (incommensurate, so the pattern never repeats exactly), `ê` horizontal and perpendicular to `U`.
//! It is smooth and deterministic: a given `(x, t)` always gives the same wind, on the CPU and on the GPU.
//!
//! Each triangle feels drag and lift on the air's velocity relative to it, `v = w(centroid) - v_triangle`,
//! with area `A` and unit normal `n` (sign chosen so `n·v ≥ 0`):
//! - drag `½ ρ C_D A |n·v| v` (along the flow, largest face-on),
//! - lift `½ ρ C_L A (n·v) (n |v| - (n·v̂) v)` (across the flow, largest at 45°),
//!
//! split equally over the three corners. Both vanish on a sheet moving with the air.

use crate::real::{Real, Vector3};
use glam::DVec3;

/// A spatially and temporally varying wind. Units: m/s, Hz, m, kg/m^3.
#[derive(Clone, Debug, PartialEq)]
pub struct WindField {
    /// Mean wind velocity `U` \[m/s\]. Default (3, 0, 0).
    pub velocity: DVec3,
    /// Gust amplitude `a` as a fraction of the mean speed. Default 0.5.
    pub gust_amplitude: f64,
    /// Gust frequency `f` \[Hz\]. Default 0.5.
    pub gust_frequency: f64,
    /// Gust wavelength `λ` along the wind \[m\]. Default 4.
    pub gust_wavelength: f64,
    /// Crosswind wobble `b` as a fraction of the mean speed. Default 0.2.
    pub crosswind: f64,
    /// Air density `ρ` \[kg/m^3\]. Default 1.225 (sea level, 15 °C).
    pub air_density: f64,
}

impl Default for WindField {
    fn default() -> Self {
        WindField {
            velocity: DVec3::new(3.0, 0.0, 0.0),
            gust_amplitude: 0.5,
            gust_frequency: 0.5,
            gust_wavelength: 4.0,
            crosswind: 0.2,
            air_density: 1.225,
        }
    }
}

impl WindField {
    /// A steady, uniform wind (no gusts, no crosswind).
    pub fn steady(velocity: DVec3) -> Self {
        WindField { velocity, gust_amplitude: 0.0, crosswind: 0.0, ..Default::default() }
    }

    /// Checks every value: a finite `velocity`; finite, non-negative `gust_amplitude`, `gust_frequency`,
    /// `crosswind`; a finite, positive `gust_wavelength` and `air_density`. Names as in a scene's `[wind]`.
    pub fn validate(&self) -> Result<(), crate::error::ModelError> {
        use crate::error::ModelError;
        if !self.velocity.is_finite() {
            let bad = self.velocity.to_array().into_iter().find(|x| !x.is_finite()).unwrap_or(f64::NAN);
            return Err(ModelError::Parameter { name: "velocity", value: bad, expected: "finite [m/s]" });
        }
        for (name, v) in [
            ("gust_amplitude", self.gust_amplitude),
            ("gust_frequency", self.gust_frequency),
            ("crosswind", self.crosswind),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and >= 0" });
            }
        }
        for (name, v) in [("gust_wavelength", self.gust_wavelength), ("air_density", self.air_density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and > 0" });
            }
        }
        Ok(())
    }

    /// Wind velocity at point `x` \[m\] and time `t` \[s\].
    pub fn sample(&self, x: DVec3, t: f64) -> DVec3 {
        let speed = self.velocity.length();
        if speed == 0.0 {
            return DVec3::ZERO;
        }
        let dir = self.velocity / speed;
        let tau = std::f64::consts::TAU;
        let along = x.dot(dir) / self.gust_wavelength.max(1e-9);
        let phase = tau * (self.gust_frequency * t - along);
        let phase2 = tau * (0.37 * self.gust_frequency * t - 0.61 * along);
        let mut side = dir.cross(DVec3::Y);
        if side.length_squared() < 1e-12 {
            side = DVec3::X;
        }
        let side = side.normalize();
        self.velocity * (1.0 + self.gust_amplitude * phase.sin()) + side * (self.crosswind * speed * phase2.sin())
    }
}

/// Aerodynamic coefficients of a surface. Zero for both switches the body's aerodynamics off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aero {
    /// Drag coefficient `C_D` (dimensionless). Default 1.0 (flat plate, face on ~1.2).
    pub drag: f64,
    /// Lift coefficient `C_L` (dimensionless). Default 0.5.
    pub lift: f64,
}

impl Default for Aero {
    fn default() -> Self {
        Aero { drag: 1.0, lift: 0.5 }
    }
}

impl Aero {
    /// No aerodynamic force.
    pub const NONE: Aero = Aero { drag: 0.0, lift: 0.0 };

    /// True when this surface feels the wind.
    pub fn is_active(&self) -> bool {
        self.drag != 0.0 || self.lift != 0.0
    }
}

/// Drag and lift on a triangle with cross vector `c = 2 A n̂`, in relative air velocity `v` (see the module docs).
///
/// GPU twin: `aero_force` in `shaders/surface.wgsl` (used by the kernel `surface_force`).
#[inline]
pub(crate) fn aero_force<R: Real>(c: R::V, v: R::V, cd: R, cl: R, rho_half: R) -> R::V {
    let c_len = c.length();
    let speed = v.length();
    if c_len <= R::ZERO || speed <= R::ZERO {
        return R::V::ZERO;
    }
    let area = c_len * R::from_f64(0.5);
    let mut n = c / c_len;
    let mut vn = n.dot(v);
    if vn < R::ZERO {
        n = -n;
        vn = -vn;
    }
    let drag = v * (rho_half * cd * area * vn);
    let lift = (n * speed - v * (vn / speed)) * (rho_half * cl * area * vn);
    drag + lift
}
