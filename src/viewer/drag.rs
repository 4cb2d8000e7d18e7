//! Dragging in the viewer: the grabbed mass point is held as a moving pin (a [`Handle`] of its own) that follows
//! the cursor, so a pull past a cloth's strength tears it.

use super::App;
use glam::Vec3;

/// A grabbed mass point: its index and the plane (through its grab position, facing the camera) it is dragged in.
pub(super) struct Drag {
    pub(super) particle: usize,
    pub(super) plane_point: Vec3,
    pub(super) target: Vec3,
    /// The moving pin ([`Handle`]) that holds the grabbed particle (and any copies fracture splits off it).
    pub(super) handle: usize,
}

impl App {
    pub(super) fn drag_target(&self, plane_point: Vec3) -> Vec3 {
        let (w, h) = self.size();
        self.camera.drag_target(self.cursor.0, self.cursor.1, w, h, plane_point)
    }

    /// Grabs particle `i` (not one already pinned or on a handle) through [`crate::World::grab`]; the pin is
    /// steered towards `target` each frame.
    pub(super) fn grab(&mut self, i: usize, target: Vec3) {
        let Some(handle) = self.world.grab(i) else { return };
        let p = self.world.state.particle_q[i];
        self.drag = Some(Drag { particle: i, plane_point: p, target, handle });
    }

    /// Lets go: the grabbed particle and its copies are free again, moving as the pin last moved them.
    pub(super) fn release(&mut self) {
        if let Some(d) = self.drag.take() {
            self.world.release_grab(d.handle);
        }
    }

    /// Moves the grabbed particle's pin towards the cursor over this frame's `span` \[s\]
    /// ([`crate::World::steer_grab`]).
    pub(super) fn move_pin(&mut self, span: f64) {
        if let Some(d) = &self.drag {
            let (h, i, target) = (d.handle, d.particle, d.target.as_dvec3());
            self.world.steer_grab(h, i, target, span);
        }
    }
}
