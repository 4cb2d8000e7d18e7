//! [`State`] (positions, velocities, time) and the energies of a state.

use super::*;
use crate::forces::{pressure, spring};

/// Positions and velocities: the only data a step changes.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(bound(
        serialize = "R: serde::Serialize, R::V: serde::Serialize",
        deserialize = "R: serde::Deserialize<'de>, R::V: serde::Deserialize<'de>"
    ))
)]
pub struct State<R: Real = f32> {
    /// Positions \[m\].
    pub particle_q: Vec<R::V>,
    /// Velocities \[m/s\].
    pub particle_qd: Vec<R::V>,
    /// Simulation time \[s\].
    pub time: f64,
}

/// Energies of a state \[J\], each summed in `f64`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `Σ ½ m v²` of free particles.
    pub kinetic: f64,
    /// `Σ ½ ks (l - L0)²`.
    pub spring: f64,
    /// `Σ -nRT ln(V / V0)` (0 at rest volume) plus `P_ext (V - V0)`.
    pub gas: f64,
    /// `-Σ m g·x` of free particles.
    pub gravity: f64,
}

impl Energy {
    /// Sum of all terms.
    pub fn total(&self) -> f64 {
        self.kinetic + self.spring + self.gas + self.gravity
    }
}

impl<R: Real> Model<R> {
    /// The energies of `state` (wind and colliders do work and are not included).
    pub fn energy(&self, state: &State<R>) -> Energy {
        let mut e = Energy::default();
        let g = self.gravity.to_dvec3();
        for i in 0..self.particle_count() {
            if self.particle_inv_mass[i] > R::ZERO {
                let m = self.particle_mass[i].to_f64();
                e.kinetic += 0.5 * m * state.particle_qd[i].to_dvec3().length_squared();
                e.gravity -= m * g.dot(state.particle_q[i].to_dvec3());
            }
        }
        for (s, &[i, j]) in self.spring_indices.iter().enumerate() {
            let l = (state.particle_q[j as usize].to_dvec3() - state.particle_q[i as usize].to_dvec3()).length();
            e.spring += spring::potential(l, self.spring_rest_length[s].to_f64(), self.spring_stiffness[s].to_f64());
        }
        for (b, v) in self.body_volumes(state).into_iter().enumerate() {
            let gas = self.body_gas_amount[b].to_f64();
            let v0 = self.body_rest_volume[b].to_f64();
            if gas > 0.0 {
                e.gas += pressure::gas_energy(gas, v, v0, self.body_pressure_external[b].to_f64());
            }
        }
        e
    }

    /// Per particle, the largest strain `(l - L0) / L0` of its edge springs at positions `q` (0 for a particle on
    /// none), and that strain as a fraction of the spring's strain limit, or of `full_scale` for a spring that
    /// cannot break: 1 is where it tears. What the renderer's strain colours and the VTK export's `strain` and
    /// `damage` fields show.
    pub fn particle_strain(&self, q: &[R::V], full_scale: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.particle_count().min(q.len());
        let (mut strain, mut ratio) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let (mut s_max, mut r_max) = (f64::NEG_INFINITY, 0.0f64);
            for &e in self.particle_springs.row(i) {
                let sp = (e >> 1) as usize;
                if self.spring_kind[sp] != SpringKind::Edge {
                    continue;
                }
                let [a, b] = self.spring_indices[sp];
                let (a, b) = (a as usize, b as usize);
                if a >= q.len() || b >= q.len() {
                    continue;
                }
                let l0 = self.spring_rest_length[sp].to_f64();
                let s = ((q[b] - q[a]).length().to_f64() - l0) / l0;
                let lim = self.spring_strain_limit[sp].to_f64();
                s_max = s_max.max(s);
                r_max = r_max.max(s / if lim.is_finite() { lim } else { full_scale });
            }
            if s_max.is_finite() {
                (strain[i], ratio[i]) = (s_max, r_max);
            }
        }
        (strain, ratio)
    }
}
