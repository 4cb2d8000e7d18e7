//! The orbit camera and its uniform.

use super::*;

/// An orbit camera: it looks at `target` from `distance` away, at `yaw` about +y and `pitch` above the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The point looked at \[m\].
    pub target: Vec3,
    /// Angle about +y \[rad\]; 0 looks along -z.
    pub yaw: f32,
    /// Angle above the horizontal \[rad\], kept within ±1.5.
    pub pitch: f32,
    /// Distance from the target \[m\].
    pub distance: f32,
    /// Vertical field of view \[rad\].
    pub fov_y: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { target: Vec3::new(0.0, 0.6, 0.0), yaw: 0.5, pitch: 0.35, distance: 4.0, fov_y: 0.8 }
    }
}

impl Camera {
    /// A camera that frames the model's bodies and bounded colliders (and the room, if there are walls), seen
    /// from the front, a little from the side and above.
    pub fn framing(model: &Model<f32>, state: &State<f32>) -> Camera {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for q in state.particle_q.iter().filter(|q| q.is_finite()) {
            lo = lo.min(*q);
            hi = hi.max(*q);
        }
        let scene = SceneGeometry::extent(model, lo, hi);
        for c in &model.colliders {
            if c.shape.as_halfspace().is_none() {
                let aabb = c.shape.compute_aabb(&c.pose);
                lo = lo.min(aabb.mins);
                hi = hi.max(aabb.maxs);
            }
        }
        if scene.walls {
            lo = lo.min(Vec3::new(-scene.half_width, 0.0, -scene.half_width));
            hi = hi.max(Vec3::new(scene.half_width, lo.y.max(0.0), scene.half_width));
        }
        if !lo.is_finite() || !hi.is_finite() {
            return Camera::default();
        }
        let center = 0.5 * (lo + hi);
        // Without walls, bodies move out of their starting box (a cloth blows downwind): leave room.
        let radius = (0.5 * (hi - lo).length()).max(0.1) * if scene.walls { 1.0 } else { 1.5 };
        let fov_y = 0.8f32;
        Camera { target: center, yaw: 0.45, pitch: 0.42, distance: 0.9 * radius / (0.5 * fov_y).sin(), fov_y }
    }

    /// The camera's position \[m\].
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(sy * cp, sp, cy * cp)
    }

    /// World to clip space (wgpu's depth range 0..1) for a viewport of `aspect` = width / height.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let near = (self.distance * 0.01).max(1e-3);
        let far = self.distance * 20.0 + 10.0;
        use glam::camera::rh::{proj::directx::perspective, view::look_at_mat4};
        perspective(self.fov_y, aspect.max(1e-3), near, far) * look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// Turns the camera by `dyaw` and `dpitch` \[rad\].
    pub fn orbit(&mut self, dyaw: f32, dpitch: f32) {
        self.yaw += dyaw;
        self.pitch = (self.pitch + dpitch).clamp(-1.5, 1.5);
    }

    /// Moves the camera towards (`factor` < 1) or away from the target.
    pub fn zoom(&mut self, factor: f32) {
        self.distance = (self.distance * factor).clamp(0.05, 1e4);
    }

    /// The ray through pixel `(x, y)` of a `width × height` viewport (y down): origin and unit direction.
    pub fn ray(&self, x: f32, y: f32, width: f32, height: f32) -> (Vec3, Vec3) {
        let inv = self.view_proj(width / height).inverse();
        let ndc = Vec3::new(2.0 * x / width - 1.0, 1.0 - 2.0 * y / height, 0.0);
        let near = inv.project_point3(ndc);
        let far = inv.project_point3(Vec3::new(ndc.x, ndc.y, 1.0));
        (near, (far - near).normalize())
    }

    /// The pixel `(x, y)` (y down) and depth of world point `p`, or `None` behind the camera.
    pub fn project(&self, p: Vec3, width: f32, height: f32) -> Option<(f32, f32, f32)> {
        let c = self.view_proj(width / height) * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let n = c.truncate() / c.w;
        Some(((n.x + 1.0) * 0.5 * width, (1.0 - n.y) * 0.5 * height, n.z))
    }

    /// The mass point under pixel `(x, y)` of a `width` × `height` view: among those within 14 px on a body with
    /// triangles, the nearest to the camera (the viewer's and the web page's picking).
    pub fn pick(&self, model: &Model<f32>, q: &[Vec3], x: f32, y: f32, width: f32, height: f32) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for (i, p) in q.iter().enumerate() {
            if model.particle_tris.row(i).is_empty() {
                continue;
            }
            if let Some((px, py, depth)) = self.project(*p, width, height) {
                let d2 = (px - x).powi(2) + (py - y).powi(2);
                if d2 < 14.0 * 14.0 {
                    // Prefer the front: depth first, then closeness on screen.
                    let key = depth + d2 * 1e-7;
                    if best.is_none_or(|b| key < b.0) {
                        best = Some((key, i));
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Where pixel `(x, y)` of a `width` × `height` view points in the plane through `plane_point` facing the
    /// camera (where a grabbed point is dragged to).
    pub fn drag_target(&self, x: f32, y: f32, width: f32, height: f32, plane_point: Vec3) -> Vec3 {
        let (o, d) = self.ray(x, y, width, height);
        let n = (self.eye() - self.target).normalize();
        let denom = d.dot(n);
        if denom.abs() < 1e-6 {
            return plane_point;
        }
        o + d * ((plane_point - o).dot(n) / denom)
    }

    /// The pixel `(x, y)` of the centre of body `b` (the mean of its particles' positions `q`), or `None` when it
    /// has none or is behind the camera.
    pub fn body_pixel(&self, model: &Model<f32>, q: &[Vec3], b: u32, width: f32, height: f32) -> Option<(f32, f32)> {
        let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
        for (p, body) in q.iter().zip(&model.particle_body) {
            if *body == b {
                sum += *p;
                n += 1.0;
            }
        }
        if n == 0.0 {
            return None;
        }
        self.project(sum / n, width, height).map(|(x, y, _)| (x, y))
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct CameraUniform {
    pub(super) view_proj: [[f32; 4]; 4],
    pub(super) eye: [f32; 4],
    pub(super) viewport: [f32; 4],
    pub(super) light: [f32; 4],
}
