//! Dragging in the viewer: the grabbed mass point is held as a moving pin (a [`Handle`] of its own) that follows
//! the cursor, so a pull past a cloth's strength tears it.

use super::App;
use crate::{Handle, TopologyDelta};
use glam::Vec3;

/// A grabbed mass point: its index and the plane (through its grab position, facing the camera) it is dragged in.
pub(super) struct Drag {
    pub(super) particle: usize,
    pub(super) plane_point: Vec3,
    pub(super) target: Vec3,
    /// The moving pin ([`Handle`]) that holds the grabbed particle (and any copies fracture splits off it).
    pub(super) handle: usize,
}

/// The fastest a grabbed mass point follows the cursor \[m/s\].
const DRAG_SPEED: f32 = 2.0;

impl App {
    pub(super) fn drag_target(&self, plane_point: Vec3) -> Vec3 {
        let (w, h) = self.size();
        let (o, d) = self.camera.ray(self.cursor.0, self.cursor.1, w, h);
        let n = (self.camera.eye() - self.camera.target).normalize();
        let denom = d.dot(n);
        if denom.abs() < 1e-6 {
            return plane_point;
        }
        o + d * ((plane_point - o).dot(n) / denom)
    }

    /// Grabs particle `i` (not one already pinned or on a handle): it becomes a moving pin, a [`Handle`] of its
    /// own, that [`App::simulate`] moves towards `target`; fracture's copies of it follow the same handle.
    pub(super) fn grab(&mut self, i: usize, target: Vec3) {
        let m = &mut self.world.model;
        if m.particle_inv_mass[i] == 0.0 || m.particle_handle[i] != u32::MAX {
            return;
        }
        let h = m.handles.len();
        m.handles.push(Handle { keys: vec![(self.world.state.time, glam::DVec3::ZERO)] });
        m.particle_handle[i] = h as u32;
        m.particle_inv_mass[i] = 0.0;
        self.world.solver.notify_model_changed(&self.world.model, &TopologyDelta::whole());
        let p = self.world.state.particle_q[i];
        self.drag = Some(Drag { particle: i, plane_point: p, target, handle: h });
    }

    /// Lets go: the grabbed particle and its copies are free again, moving as the pin last moved them.
    pub(super) fn release(&mut self) {
        let Some(d) = self.drag.take() else { return };
        let m = &mut self.world.model;
        if d.handle >= m.handles.len() {
            return;
        }
        for i in 0..m.particle_count() {
            if m.particle_handle[i] == d.handle as u32 {
                m.particle_handle[i] = u32::MAX;
                let mass = m.particle_mass[i];
                m.particle_inv_mass[i] = if mass > 0.0 { 1.0 / mass } else { 0.0 };
            }
        }
        // The drag's handle is the last one: nothing else adds handles while it is held.
        m.handles.truncate(d.handle);
        self.world.solver.notify_model_changed(&self.world.model, &TopologyDelta::whole());
    }

    /// Moves the grabbed particle's pin towards the cursor over this frame, at most [`DRAG_SPEED`].
    pub(super) fn move_pin(&mut self) {
        if let Some(d) = &self.drag
            && d.handle < self.world.model.handles.len()
        {
            let frame = self.options.frame_time;
            let q = self.world.state.particle_q[d.particle];
            let max = DRAG_SPEED * frame as f32;
            let mut step = d.target - q;
            if step.length() > max {
                step = step.normalize() * max;
            }
            let t = self.world.state.time;
            let h = &mut self.world.model.handles[d.handle];
            let off = h.offset(t);
            h.keys = vec![(t, off), (t + frame, off + step.as_dvec3())];
        }
    }
}
