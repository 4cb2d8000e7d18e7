//! The closed pressure model (Matyka & Ollila 2003; the seed's eqs. 6–9): an ideal gas fills each closed body,
//! `P = nRT / V - P_ext`, and pushes every triangle along its normal.
//!
//! `V = 1/6 Σ_t (x0 - c)·((x1 - c) × (x2 - c))` (taken about an anchor particle `c` of the body to limit
//! round-off; for a closed surface `V` does not depend on `c`), and each corner of each triangle receives
//! `P (x1 - x0) × (x2 - x0) / 6 = P A n̂ / 3`: the seed's eq. (9) force, split equally. Summed over a vertex's
//! closed one-ring this equals `P ∂V/∂x_i` exactly, so the force is conservative with energy `-nRT ln V`, and its
//! sum over a closed surface is exactly zero. Openings of punctured bodies are capped (a fan from the loop's
//! centroid) for the volume, and the gas pushes on the caps too.
//!
//! One formula for the pressure, [`gas_pressure`], with its volume clamp [`MIN_VOLUME_FRACTION`], serves every
//! caller: the force pass, the implicit solver's Jacobian, the fracture load and leak, the energy and diagnostics.
//!
//! GPU twins: `gas_pressure`, `pressure_corner_force` and `MIN_VOLUME_FRACTION` in `shaders/common.wgsl`, used by
//! the kernels `surface_cross`, `surface_caps`, `surface_volume` and `surface_force` in `shaders/surface.wgsl`.

use super::ForceScratch;
use crate::model::Model;
use crate::real::{Real, Vector3};

/// A body's volume is clamped below at this fraction of its rest volume before `P = nRT / V` is taken: a
/// collapsed or inverted body keeps a finite (large) pressure that pushes it back out instead of dividing by
/// zero or changing sign.
pub const MIN_VOLUME_FRACTION: f64 = 1e-3;

/// `max(V, MIN_VOLUME_FRACTION · V0)` \[m^3\].
#[inline]
pub fn clamped_volume<R: Real>(volume: R, rest_volume: R) -> R {
    volume.max(rest_volume * R::from_f64(MIN_VOLUME_FRACTION))
}

/// Net gas pressure \[Pa\] of a body holding `gas = nRT` \[J\] at `volume` \[m^3\] (clamped, see
/// [`MIN_VOLUME_FRACTION`]), less the outside pressure `external` \[Pa\]; 0 for a body without gas.
#[inline]
pub fn gas_pressure<R: Real>(gas: R, volume: R, rest_volume: R, external: R) -> R {
    if gas > R::ZERO { gas / clamped_volume(volume, rest_volume) - external } else { R::ZERO }
}

/// The pressure force on each corner of a triangle with cross vector `cross = (x1 - x0) × (x2 - x0)` under net
/// pressure `p` \[Pa\]: `p · cross / 6` \[N\] (eq. 9, split equally over the corners).
#[inline(always)]
pub fn corner_force<R: Real>(cross: R::V, p: R) -> R::V {
    cross * (p * R::from_f64(1.0 / 6.0))
}

/// Energy of the gas and the outside pressure relative to the rest volume \[J\]: `-nRT ln(V / V0) + P_ext (V - V0)`.
pub fn gas_energy(gas: f64, volume: f64, rest_volume: f64, external: f64) -> f64 {
    -gas * (clamped_volume(volume, rest_volume) / rest_volume).ln() + external * (volume - rest_volume)
}

impl<R: Real> ForceScratch<R> {
    /// Adds the caps over the openings of gas bodies: their volume to `body_volume` (as `6 V`, before the
    /// division) and their `∂V/∂x` to `cap_g`. A cap is the fan `(x_j, x_i, c)` over each loop edge `i -> j`
    /// from the loop's centroid `c`; `c`'s share of the gradient goes equally to the loop's particles.
    pub(super) fn caps(&mut self, m: &Model<R>, q: &[R::V], vol6: &mut [R]) {
        for &i in &self.cap_touched {
            self.cap_g[i as usize] = R::V::ZERO;
        }
        self.cap_touched.clear();
        let sixth = R::from_f64(1.0 / 6.0);
        for o in &m.openings {
            let b = o.body as usize;
            if m.body_gas_amount[b] <= R::ZERO {
                continue;
            }
            let anchor = q[m.body_anchor[b] as usize];
            let n = o.vertices.len();
            let inv_n = R::ONE / R::from_f64(n as f64);
            let centre = o.vertices.iter().fold(R::V::ZERO, |acc, &i| acc + q[i as usize]) * inv_n;
            let mut centre_g = R::V::ZERO;
            for k in 0..n {
                let (i, j) = (o.vertices[k] as usize, o.vertices[(k + 1) % n] as usize);
                vol6[b] += (q[j] - anchor).dot((q[i] - anchor).cross(centre - anchor));
                let g = (q[i] - q[j]).cross(centre - q[j]) * sixth;
                self.cap_g[i] += g;
                self.cap_g[j] += g;
                centre_g += g;
            }
            for &i in &o.vertices {
                self.cap_g[i as usize] += centre_g * inv_n;
                self.cap_touched.push(i);
            }
        }
    }
}
