//! Moving data between the host and the GPU: the state (upload, read-back), what the kernels found (fracture
//! candidates, net forces, volumes and pressures), the model after a fracture (re-packed and uploaded
//! block-wise), and the [`Solver`] implementation `World` drives.

use super::*;
use crate::layout::{GpuParticle, GpuSpring};
use crate::mapping::now;
use fissure_core::{LocalFuture, Solver, StepError, TopologyDelta};

/// Positions and velocities as the state buffers hold them: `[x, y, z, 0]` of the position, then of the velocity.
fn interleave(q: &[Vec3], qd: &[Vec3]) -> Vec<[f32; 4]> {
    q.iter().zip(qd).flat_map(|(x, v)| [[x.x, x.y, x.z, 0.0], [v.x, v.y, v.z, 0.0]]).collect()
}

impl GpuSolver {
    /// Writes `state` (positions, velocities, time) to the GPU.
    pub fn upload_state(&mut self, state: &State<f32>) -> Result<(), GpuError> {
        let n = self.particle_count();
        if state.particle_q.len() != n || state.particle_qd.len() != n {
            return Err(GpuError::StateMismatch { state: state.particle_q.len(), model: n });
        }
        let packed = interleave(&state.particle_q, &state.particle_qd);
        self.queue.write_buffer(&self.state[self.cur], 0, bytemuck::cast_slice(&packed));
        self.time = state.time;
        self.state_stale = false;
        self.state_valid = n;
        Ok(())
    }

    /// Writes the state of particles `from..` (new ones a fracture appended) to the GPU; everything when the
    /// state buffers were reallocated since the last upload.
    pub fn upload_new_particles(&mut self, state: &State<f32>, from: usize) -> Result<(), GpuError> {
        let n = self.particle_count();
        if state.particle_q.len() != n || state.particle_qd.len() != n {
            return Err(GpuError::StateMismatch { state: state.particle_q.len(), model: n });
        }
        let from = from.min(self.state_valid);
        if from == 0 {
            let before = self.last_upload;
            self.upload_state(state)?;
            self.last_upload = before + n * STATE_STRIDE as usize;
            return Ok(());
        }
        let packed = interleave(&state.particle_q[from..], &state.particle_qd[from..]);
        self.queue.write_buffer(&self.state[self.cur], from as u64 * STATE_STRIDE, bytemuck::cast_slice(&packed));
        self.last_upload += (n - from) * STATE_STRIDE as usize;
        self.state_stale = false;
        self.state_valid = n;
        Ok(())
    }

    /// Reads the current positions, velocities and time into `state` (a synchronous read-back; in a browser use
    /// [`GpuSolver::read_state_async`]).
    pub fn read_state(&mut self, state: &mut State<f32>) -> Result<(), GpuError> {
        now(self.read_state_async(state))
    }

    /// Reads the current positions, velocities and time into `state`, awaiting the read-back (in a browser the
    /// buffer is mapped only once control is back in the event loop).
    pub async fn read_state_async(&mut self, state: &mut State<f32>) -> Result<(), GpuError> {
        let n = self.particle_count();
        let both = self.read_vec4(&self.state[self.cur], 2 * n).await?;
        let v3 = |v: &[f32; 4]| Vec3::new(v[0], v[1], v[2]);
        state.particle_q.clear();
        state.particle_q.extend(both.iter().step_by(2).map(v3));
        state.particle_qd.clear();
        state.particle_qd.extend(both.iter().skip(1).step_by(2).map(v3));
        state.time = self.time;
        Ok(())
    }

    /// The first `bytes` of `src`, through a staging buffer.
    pub(super) async fn read_bytes(&self, src: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, GpuError> {
        let bytes = bytes.max(4).next_multiple_of(4);
        let staging = layout::create(
            &self.device,
            "readback",
            bytes as usize,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
        self.queue.submit([enc.finish()]);
        self.map_read(&staging, bytes).await
    }

    /// Maps `staging` and copies out its first `bytes` ([`crate::mapping::map_read`]).
    pub(super) async fn map_read(&self, staging: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, GpuError> {
        let out = crate::mapping::map_read(&self.device, staging, bytes).await?.to_vec();
        staging.unmap();
        Ok(out)
    }

    pub(super) async fn read_vec4(&self, src: &wgpu::Buffer, n: usize) -> Result<Vec<[f32; 4]>, GpuError> {
        let bytes = self.read_bytes(src, (n * 16) as u64).await?;
        Ok(bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(&bytes[..n * 16]))
    }

    /// The fracture candidates the last submission flagged.
    pub fn candidates(&self) -> Result<Candidates, GpuError> {
        let cap = self.config.candidate_capacity.max(1) as usize;
        let bytes = crate::mapping::now(self.read_bytes(&self.candidates, ((4 + 2 * cap) * 4) as u64))?;
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        let list = |kind: usize| {
            let n = (w[kind] as usize).min(cap);
            let mut v = w[4 + kind * cap..4 + kind * cap + n].to_vec();
            v.sort_unstable();
            v.dedup();
            v
        };
        Ok(Candidates { springs: list(0), vertices: list(1), overflow: w[0] as usize > cap || w[1] as usize > cap })
    }

    /// Volume \[m^3\] and net pressure \[Pa\] of each body as of the last surface pass (zeros for bodies without gas).
    pub fn body_volumes_pressures(&self, m: &Model<f32>) -> Result<Vec<(f32, f32)>, GpuError> {
        let nb = m.body_count();
        let v = crate::mapping::now(self.read_vec4(&self.scratch.body_state, nb))?;
        Ok(v.iter()
            .zip(&self.packed.bodies)
            .map(|(x, b)| if b.gas_slot == layout::NONE { (0.0, 0.0) } else { (x[0], x[1]) })
            .collect())
    }

    /// The net force on every particle at `state` \[N\] (gravity, springs, pressure, wind; not collisions): the
    /// kernels' twin of `CpuSolver::compute_forces`. Replaces the GPU state with `state`.
    pub fn compute_forces(&mut self, m: &Model<f32>, state: &State<f32>) -> Result<Vec<Vec3>, GpuError> {
        self.check_model(m)?;
        self.upload_state(state)?;
        self.write_clock(m, state.time, 1.0, 1);
        self.passes.clear();
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            let cur = self.cur;
            if m.has_pressure() || m.has_wind() {
                self.encode_surface(&mut pass, m, cur, 0, true);
            }
            self.dispatch(&mut pass, k!("net_forces"), cur, 0, groups(self.particle_count()));
        }
        self.queue.submit([enc.finish()]);
        let f = crate::mapping::now(self.read_vec4(&self.state[1 - self.cur], 2 * self.particle_count()))?;
        Ok(f.iter().step_by(2).map(|v| Vec3::new(v[0], v[1], v[2])).collect())
    }

    /// Re-packs `m` and uploads what differs from the GPU copy (block-wise; after a fracture event that is a few
    /// blocks per array). If particles were added, the state must be uploaded next ([`GpuSolver::upload_state`]).
    pub fn sync_model(&mut self, m: &Model<f32>) {
        let mut p = Packed::new(m, self.packed.tri_offset);
        p.contact.excuse(m.body_count(), self.excused.pairs());
        self.last_repacked = 2 * p.particles.len() + p.adj.len() + p.springs.len() + p.tris.len();
        let (d, q) = (&self.device, &self.queue);
        let mut realloc = false;
        let mut bytes = 0;
        let mut add = |(r, b): (bool, usize)| {
            realloc |= r;
            bytes += b;
        };
        add(self.particles.sync(d, q, &p.particles));
        add(self.adj.sync(d, q, &p.adj));
        add(self.springs.sync(d, q, &p.springs));
        add(self.tris.sync(d, q, &p.tris));
        add(self.bodies.sync(d, q, &p.bodies));
        add(self.openings.sync(d, q, &p.openings));
        add(self.spring_ends.sync(d, q, &p.spring_ends));
        add(self.caps.sync(d, q, &p.caps));
        add(self.c_part.sync(d, q, &p.contact.part));
        add(self.c_body.sync(d, q, &p.contact.body));
        add(self.c_edges.sync(d, q, &p.contact.edges));
        let old_count = self.particle_count();
        self.packed = p;
        self.finish_sync(m, old_count, realloc, bytes);
    }

    /// Re-packs and uploads what `delta` names (a fracture's change): the new and changed particles, their
    /// adjacency rows and items, the new and changed springs and triangles, and the bodies and openings when
    /// they changed. Host work and upload follow the size of the change, not of the model; a compaction of the
    /// adjacency lists, spring rows that outgrow their room, or a hand edit fall back to [`GpuSolver::sync_model`].
    pub fn sync_delta(&mut self, m: &Model<f32>, delta: &TopologyDelta) {
        let [n0, s0, t0, b0] = delta.old_counts;
        let sp_items = m.particle_springs.items.len();
        let whole = delta.whole
            || delta.rows_compacted
            || sp_items > self.packed.tri_offset
            || n0 != self.packed.particles.len()
            || s0 != self.packed.springs.len()
            || t0 != self.packed.tris.len();
        if whole {
            return self.sync_model(m);
        }
        let (n, ns, nt) = (m.particle_count(), m.spring_count(), m.tri_count());
        let merged = |changed: &[u32], old: usize, new: usize| {
            let mut v: Vec<u32> = changed.iter().copied().filter(|&i| (i as usize) < old).collect();
            v.extend(old as u32..new as u32);
            v.sort_unstable();
            v.dedup();
            v
        };
        let p = &mut self.packed;
        let off = p.tri_offset;
        // Particles and their adjacency headers.
        let mut pidx = merged(&delta.particles, n0, n);
        pidx.extend(delta.rows.iter().copied().filter(|&i| (i as usize) < n0));
        pidx.sort_unstable();
        pidx.dedup();
        p.particles.resize(n, GpuParticle::default());
        for &i in &pidx {
            p.particles[i as usize] = layout::pack_particle(m, i as usize, off);
            p.any_load_limit |= p.particles[i as usize].load_limit >= 0.0;
        }
        // The rows' items: spring rows at their start, triangle rows at `off` + their start.
        let (sp, tr) = (&m.particle_springs, &m.particle_tris);
        p.adj.resize(off + tr.items.len(), 0);
        let mut aidx = Vec::new();
        for &i in &delta.rows {
            let i = i as usize;
            for (csr, base) in [(sp, 0), (tr, off)] {
                let (s, l) = (csr.start[i] as usize, csr.len[i] as usize);
                p.adj[base + s..base + s + l].copy_from_slice(&csr.items[s..s + l]);
                aidx.extend((base + s..base + s + l).map(|k| k as u32));
            }
        }
        aidx.sort_unstable();
        aidx.dedup();
        // Springs and triangles.
        let sidx = merged(&delta.springs, s0, ns);
        p.springs.resize(ns, GpuSpring::default());
        p.spring_ends.resize(ns, [0; 2]);
        for &s in &sidx {
            p.springs[s as usize] = layout::pack_spring(m, s as usize);
            p.spring_ends[s as usize] = m.spring_indices[s as usize];
            p.any_strain_limit |= p.springs[s as usize].strain_limit >= 0.0;
        }
        let tidx = merged(&delta.triangles, t0, nt);
        p.tris.resize(nt, [0; 4]);
        for &t in &tidx {
            p.tris[t as usize] = layout::pack_tri(m, t as usize);
        }
        let bodies = m.body_count() != b0 || delta.openings || delta.gas;
        if bodies {
            p.pack_bodies(m);
        }
        self.last_repacked =
            2 * pidx.len() + aidx.len() + sidx.len() + tidx.len() + if bodies { m.body_count() } else { 0 };
        let (d, q) = (&self.device, &self.queue);
        let mut realloc = false;
        let mut bytes = 0;
        let mut add = |(r, b): (bool, usize)| {
            realloc |= r;
            bytes += b;
        };
        add(self.particles.write_items(d, q, &p.particles, &pidx));
        add(self.adj.write_items(d, q, &p.adj, &aidx));
        add(self.springs.write_items(d, q, &p.springs, &sidx));
        add(self.spring_ends.write_items(d, q, &p.spring_ends, &sidx));
        add(self.tris.write_items(d, q, &p.tris, &tidx));
        if bodies {
            add(self.bodies.sync(d, q, &p.bodies));
            add(self.openings.sync(d, q, &p.openings));
            add(self.caps.sync(d, q, &p.caps));
        }
        if m.has_contact() {
            // The contact elements follow the triangles, bodies and origins: re-packed whole (one pass over the
            // triangles), uploaded where they differ.
            p.contact = layout::ContactPack::new(m);
            p.contact.excuse(m.body_count(), self.excused.pairs());
            add(self.c_part.sync(d, q, &p.contact.part));
            add(self.c_body.sync(d, q, &p.contact.body));
            add(self.c_edges.sync(d, q, &p.contact.edges));
        }
        self.finish_sync(m, n0, realloc, bytes);
    }

    /// The end of every model sync: the state buffers for a grown particle count (from `old`), scratch buffers
    /// for the new sizes, the uniform, new bind groups if any buffer was reallocated, and the upload count.
    fn finish_sync(&mut self, m: &Model<f32>, old: usize, mut realloc: bool, mut bytes: usize) {
        realloc |= self.grow_state(old, m.particle_count());
        let capacity = self.config.contact_capacity;
        if (0..SCRATCH).any(|k| scratch_sizes(m, &self.packed, capacity)[k] > self.scratch.sized[k]) {
            self.scratch = scratch(&self.device, &self.queue, m, &self.packed, capacity);
            realloc = true;
        }
        self.write_params(m);
        bytes += size_of::<Params>();
        if realloc {
            self.rebind();
        }
        self.last_upload = bytes;
    }

    /// After the particle count went from `old` to `n`: the new particles' state must be uploaded before the next
    /// run; buffers too small are reallocated (their contents are lost: then the whole state). True if reallocated.
    fn grow_state(&mut self, old: usize, n: usize) -> bool {
        if n == old {
            return false;
        }
        self.state_stale = true;
        self.state_valid = self.state_valid.min(old);
        if n <= self.state_capacity {
            return false;
        }
        self.state_capacity = n + n / 4;
        let mk = |l| layout::create(&self.device, l, self.state_capacity * STATE_STRIDE as usize, STATE_USAGE);
        self.state = [mk("state 0"), mk("state 1")];
        self.state_valid = 0;
        true
    }

    /// Uploads the bodies' gas amounts after a leak (the state and topology unchanged). A body whose gas ran out
    /// changes the set of gas bodies, which the full [`GpuSolver::sync_model`] handles.
    fn sync_gas(&mut self, m: &Model<f32>) {
        let same_set =
            self.packed.bodies.iter().zip(&m.body_gas_amount).all(|(b, &g)| (b.gas_slot != layout::NONE) == (g > 0.0));
        if !same_set || self.packed.bodies.len() != m.body_count() {
            return self.sync_model(m);
        }
        for (b, &g) in self.packed.bodies.iter_mut().zip(&m.body_gas_amount) {
            b.gas = g;
        }
        self.last_upload = self.bodies.sync(&self.device, &self.queue, &self.packed.bodies).1;
    }
}

impl GpuSolver {
    /// Asks the pieces born crossing their family whether they have parted, at `state` (the current state: the
    /// host's copy must be), and uploads the pairs left out of contact when they changed (see
    /// [`fissure_core::contact::family`]: the CPU asks at every pass, the GPU only where the host holds the
    /// state, so a pair may stay left out a little longer here).
    fn update_excused(&mut self, model: &Model<f32>, state: &State<f32>) {
        if !model.has_contact() || !self.excused.update(model, &state.particle_q) {
            return;
        }
        self.packed.contact.excuse(model.body_count(), self.excused.pairs());
        if self.c_body.sync(&self.device, &self.queue, &self.packed.contact.body).0 {
            self.rebind();
        }
    }

    /// The CPU's refusal of an explicit step above the stability bound of a model in contact (see
    /// [`fissure_core::ContactStepGuard`]); the bound is the model's at rest, as [`GpuSolver::step_error`] names.
    fn check_contact_step(&mut self, model: &Model<f32>, dt: f64) -> Result<(), StepError> {
        let integrator = self.config.integrator;
        self.contact_guard.check(model, integrator, dt, || fissure_core::StabilityBound::of(model))
    }

    /// `GpuError::NonFinite` as the CPU's error, with the mesh's stability bound, so the message names the cause
    /// on either backend.
    fn step_error(&self, model: &Model<f32>, e: GpuError) -> StepError {
        match e {
            GpuError::NonFinite { to, dt, .. } => {
                let stable_dt = fissure_core::StabilityBound::of(model).max_dt(self.config.integrator);
                StepError::NonFinite { time: to, dt, particle: 0, what: "velocity", stable_dt }
            }
            e => e.into(),
        }
    }
}

/// `World` drives the GPU through this: [`Solver::advance`] encodes a batch of substeps in one submission and
/// leaves the state on the GPU; [`Solver::may_have_fracture_candidates`] answers from the kernels' counters, so
/// the state is read back only when a limit was passed or a body leaks.
impl Solver<f32> for GpuSolver {
    /// One step, as the CPU solver's: uploads `state`, runs one substep, reads it back. `World` uses
    /// [`Solver::advance`], which keeps the state on the GPU.
    fn step(&mut self, model: &Model<f32>, state: &mut State<f32>, dt: f64) -> Result<(), StepError> {
        self.check_contact_step(model, dt)?;
        self.update_excused(model, state);
        GpuSolver::upload_state(self, state)?;
        self.last_report = self.run(model, dt, 1).map_err(|e| self.step_error(model, e))?;
        self.read_state(state)?;
        Ok(())
    }

    fn advance(&mut self, model: &Model<f32>, state: &mut State<f32>, dt: f64, steps: usize) -> Result<(), StepError> {
        now(self.advance_async(model, state, dt, steps))
    }

    fn time(&self, _state: &State<f32>) -> f64 {
        self.time
    }

    fn may_have_fracture_candidates(&self) -> bool {
        self.last_report.spring_candidates > 0 || self.last_report.vertex_candidates > 0
    }

    fn sync_state(&mut self, state: &mut State<f32>) -> Result<(), StepError> {
        now(self.sync_state_async(state))
    }

    fn advance_async<'a>(
        &'a mut self,
        model: &'a Model<f32>,
        state: &'a mut State<f32>,
        dt: f64,
        steps: usize,
    ) -> LocalFuture<'a, Result<(), StepError>> {
        Box::pin(async move {
            self.check_contact_step(model, dt)?;
            if state.time == self.time && state.particle_q.len() == self.particle_count() {
                self.update_excused(model, state);
            }
            if self.state_stale {
                GpuSolver::upload_state(self, state)?;
            }
            let report = self.run_async(model, dt, steps).await;
            self.last_report = report.map_err(|e| self.step_error(model, e))?;
            Ok(())
        })
    }

    fn sync_state_async<'a>(&'a mut self, state: &'a mut State<f32>) -> LocalFuture<'a, Result<(), StepError>> {
        Box::pin(async move {
            if state.time != self.time || state.particle_q.len() != self.particle_count() {
                self.read_state_async(state).await?;
            }
            Ok(())
        })
    }

    fn upload_state(&mut self, state: &State<f32>) -> Result<(), StepError> {
        Ok(GpuSolver::upload_state(self, state)?)
    }

    /// A leak alone uploads the bodies' gas; a fracture re-packs and uploads what its delta names
    /// ([`GpuSolver::sync_delta`]).
    fn notify_model_changed(&mut self, model: &Model<f32>, delta: &TopologyDelta) {
        if delta.is_empty() {
            if delta.gas {
                self.sync_gas(model);
            }
        } else {
            self.excused.born(delta);
            self.sync_delta(model, delta);
        }
    }

    fn upload_new_particles(&mut self, state: &State<f32>, from: usize) -> Result<(), StepError> {
        Ok(GpuSolver::upload_new_particles(self, state, from)?)
    }

    fn timers(&self) -> &StageTimers {
        &self.timers
    }

    fn reset_timers(&mut self) {
        self.timers.reset();
        self.reset_kernel_times();
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    fn name(&self) -> &'static str {
        "gpu"
    }
}
