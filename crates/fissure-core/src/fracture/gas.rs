//! Openings and gas: the boundary loops of gas bodies, and the orifice leak through them (Mesit & Guha 2008).

use super::*;
use crate::forces::pressure;
use crate::model::edit::*;

impl<R: Real> Fracture<R> {
    /// Rebuilds the openings of the gas bodies touched this step, walking only their boundaries.
    pub(super) fn update_openings(&mut self, m: &mut Model<R>) {
        if self.boundary.len() < m.body_count() {
            self.boundary.resize(m.body_count(), BTreeSet::new());
        }
        let mut dirty = BTreeSet::new();
        // A body whose gas has all leaked out keeps its openings, and they must follow its later splits too
        // (the stress test's fracture storms found stale loops otherwise).
        let with_openings: BTreeSet<u32> = m.openings.iter().map(|o| o.body).collect();
        for &v in &self.touched_list {
            let b = m.particle_body[v as usize];
            if (b as usize) < m.body_count() && (m.body_gas_amount[b as usize] > R::ZERO || with_openings.contains(&b))
            {
                self.boundary[b as usize].insert(v);
                dirty.insert(b);
            }
        }
        for b in dirty {
            let cands = std::mem::take(&mut self.boundary[b as usize]);
            let mut left: BTreeSet<u32> = cands
                .into_iter()
                .filter(|&v| m.particle_body[v as usize] == b && boundary_next(m, v).is_some())
                .collect();
            self.boundary[b as usize] = left.clone();
            m.openings.retain(|o| o.body != b);
            while let Some(start) = left.pop_first() {
                let mut lp = vec![start];
                let mut v = start;
                while let Some(nx) = boundary_next(m, v) {
                    if nx == start {
                        if lp.len() >= 3 {
                            m.openings.push(Opening { body: b, vertices: std::mem::take(&mut lp) });
                        }
                        break;
                    }
                    if !left.remove(&nx) {
                        break;
                    }
                    lp.push(nx);
                    v = nx;
                }
            }
            self.delta.openings = true;
        }
    }

    /// The pumps: each whole body with an inflow gains `inflow · dt` of `nRT`.
    pub(super) fn pump(&mut self, m: &mut Model<R>, dt: f64) {
        for b in 0..m.body_count() {
            let q = m.body_gas_inflow[b];
            if q > R::ZERO && !m.openings.iter().any(|o| o.body as usize == b) {
                m.body_gas_amount[b] += q * R::from_f64(dt);
                self.delta.gas = true;
            }
        }
    }

    /// Orifice leak of every unsealed gas body with openings.
    pub(super) fn leak(&mut self, m: &mut Model<R>, s: &State<R>, dt: f64) {
        if m.openings.is_empty() || !m.has_pressure() {
            return;
        }
        let mut bodies: Vec<u32> = m.openings.iter().map(|o| o.body).collect();
        bodies.sort_unstable();
        bodies.dedup();
        if self.volumes.len() != m.body_count() {
            self.volumes = m.body_volumes(s);
        }
        for b in bodies {
            let bu = b as usize;
            let gas = m.body_gas_amount[bu].to_f64();
            if gas <= 0.0 || m.body_sealed[bu] {
                continue;
            }
            // The volume as the force pass clamps it, and the pressure difference across the openings.
            let (v0, ext) = (m.body_rest_volume[bu].to_f64(), m.body_pressure_external[bu].to_f64());
            let v = pressure::clamped_volume(self.volumes[bu], v0);
            let dp = pressure::gas_pressure(gas, v, v0, ext);
            if dp <= 0.0 {
                continue;
            }
            let area = m.opening_area(s, bu);
            let flow = self.config.discharge_coefficient * area * (2.0 * dp / self.config.gas_density).sqrt();
            m.body_gas_amount[bu] = R::from_f64(gas * (-flow * dt / v).exp());
            self.delta.gas = true;
        }
    }
}
