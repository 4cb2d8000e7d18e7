//! Encoding the contact pass (`shaders/contact.wgsl`) and reading what it did. The model is
//! `fissure_core::contact`'s; the kernels' docs say how the GPU solves it.

use super::scratch::PAIR_BYTES;
use super::*;

/// Invocations per element in the pair searches: `LANES` in `shaders/contact.wgsl`.
const SEARCH_LANES: usize = 8;

impl GpuSolver {
    /// The contact pass's first half, on the state at the start of the substep: positions saved, both grids built.
    pub(super) fn encode_contact_start(&mut self, pass: &mut wgpu::ComputePass<'_>, clock: usize) {
        let (n, ne) = (self.particle_count(), self.packed.contact.edges.len());
        let cur = self.cur;
        self.dispatch(pass, k!("contact_count"), cur, clock, groups(n + ne));
        let blocks = self.packed.contact.scan_blocks() as u32;
        self.dispatch(pass, k!("contact_scan_sums"), cur, clock, (blocks, 1));
        self.dispatch(pass, k!("contact_scan_spread"), cur, clock, (blocks, 1));
        self.dispatch(pass, k!("contact_scatter"), cur, clock, groups(n + ne));
    }

    /// The contact pass's second half, on the state after the integrator and the colliders (bound as the
    /// destination, which the kernels change in place): pairs, impulses, the displacement bound.
    pub(super) fn encode_contact_end(&mut self, pass: &mut wgpu::ComputePass<'_>, m: &Model<f32>, clock: usize) {
        let (n, ne) = (self.particle_count(), self.packed.contact.edges.len());
        let np = groups(n);
        let dst = 1 - self.cur;
        self.dispatch(pass, k!("contact_moves"), dst, clock, np);
        // `LANES` invocations per element (contact.wgsl).
        self.dispatch(pass, k!("contact_vt"), dst, clock, groups(SEARCH_LANES * m.tri_count()));
        self.dispatch(pass, k!("contact_ee"), dst, clock, groups(SEARCH_LANES * ne));
        self.dispatch(pass, k!("contact_args"), dst, clock, (1, 1));
        self.dispatch_pairs(pass, k!("contact_prep"), dst, clock);
        // An even count: the friction pass reads the totals the last (odd) iteration completed.
        let fused = self.config.contact_fused_pairs as usize;
        if fused > 0 && self.contact_stats.near <= fused {
            self.dispatch(pass, k!("contact_jacobi_fused"), dst, clock, (1, 1));
        } else {
            for it in 0..self.config.contact_iterations.next_multiple_of(2) {
                let k = if it % 2 == 0 { k!("contact_jacobi_even") } else { k!("contact_jacobi_odd") };
                self.dispatch_pairs(pass, k, dst, clock);
            }
        }
        self.dispatch_pairs(pass, k!("contact_friction"), dst, clock);
        self.dispatch(pass, k!("contact_apply"), dst, clock, np);
    }

    /// [`GpuSolver::dispatch`] with the workgroup counts read from the contact pass's `c_args` (one per pair this
    /// substep, written by `contact_args`).
    fn dispatch_pairs(&mut self, pass: &mut wgpu::ComputePass<'_>, k: usize, cur: usize, clock: usize) {
        self.bind_kernel(pass, k, cur, clock);
        pass.dispatch_workgroups_indirect(&self.scratch.c_args, 0);
        self.stamp(pass, k);
    }

    /// Takes the contact counters a submission copied into the status words (`c_ctl`'s first 8 words): the
    /// stats, and an error when a substep found more pairs than the buffer holds.
    pub(super) fn take_contact_status(&mut self, c: &[u32]) -> Result<(), GpuError> {
        let capacity = self.params_host.contact_n[2];
        let s = &mut self.contact_stats;
        s.near = c[0].min(capacity) as usize;
        s.steps += c[7] as u64;
        s.pushed_total += c[4] as u64;
        s.near_total += c[5] as u64;
        s.capped_total += c[6] as u64;
        if c[3] > 0 {
            return Err(GpuError::ContactCapacity { wanted: c[3], capacity });
        }
        Ok(())
    }

    /// What the contact pass did: `near` is the pairs within reach in the last substep of the last submission;
    /// the totals and `steps` sum over every substep run. The GPU keeps no candidate list (its grids are built at
    /// every substep), so `candidates`, `builds` and `refreshes` stay 0, and so does `pushed` (counted in total
    /// only). Zeros without contact.
    pub fn contact_stats(&self) -> fissure_core::ContactStats {
        self.contact_stats
    }

    /// The contact pairs within reach in the last substep, in no particular order (the kernels list them as they
    /// find them): each pair's four particles (a vertex then its triangle's corners, or one edge's ends then the
    /// other's) and its gap at the start of the substep \[m\].
    pub fn contact_pairs(&self) -> Result<Vec<([u32; 4], f32)>, GpuError> {
        if !self.packed.contact.on() {
            return Ok(Vec::new());
        }
        let ctl: Vec<u32> =
            bytemuck::pod_collect_to_vec(&crate::mapping::now(self.read_bytes(&self.scratch.c_ctl, 32))?);
        let n = (ctl[0] as usize).min(self.scratch.sized[7]);
        let bytes = crate::mapping::now(self.read_bytes(&self.scratch.c_pairs, (n * PAIR_BYTES) as u64))?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[..n * PAIR_BYTES]);
        Ok(words.chunks_exact(PAIR_BYTES / 4).map(|w| ([w[0], w[1], w[2], w[3]], f32::from_bits(w[11]))).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::SEARCH_LANES;

    /// The dispatch sizes follow the shader's lane count: with fewer here than there, elements would go unsearched.
    #[test]
    fn search_lanes_are_the_shaders() {
        let (_, src) = crate::SHADERS.iter().find(|(n, _)| *n == "contact.wgsl").unwrap();
        assert!(
            src.contains(&format!("const LANES: u32 = {SEARCH_LANES}u;")),
            "contact.wgsl's LANES is not {SEARCH_LANES}"
        );
    }
}
