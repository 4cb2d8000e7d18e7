//! The scene's static geometry (ground, walls, obstacles) as triangle meshes for the renderer.

use super::*;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct StaticVertex {
    pub(super) p: [f32; 3],
    pub(super) n: [f32; 3],
    pub(super) color: [u8; 4],
}

/// One collider's triangles in the static buffers, and for a wall the plane that decides its visibility.
#[derive(Clone, Debug)]
pub(super) struct StaticDraw {
    pub(super) indices: std::ops::Range<u32>,
    /// A wall: drawn only when the camera is on the open side of (point, normal).
    pub(super) wall: Option<(Vec3, Vec3)>,
}

/// Extent of the drawn room and whether it has walls.
pub(super) struct SceneGeometry {
    pub(super) half_width: f32,
    pub(super) walls: bool,
}

impl SceneGeometry {
    pub(super) fn extent(model: &Model<f32>, lo: Vec3, hi: Vec3) -> SceneGeometry {
        let mut half_width: f32 = 0.0;
        let mut walls = false;
        for c in &model.colliders {
            if let Some(h) = c.shape.as_halfspace() {
                let n = c.pose.rotation * h.normal;
                if n.y.abs() < 0.5 {
                    walls = true;
                    half_width = half_width.max(c.pose.translation.dot(-n).abs());
                }
            }
        }
        if !walls {
            let span = if lo.is_finite() && hi.is_finite() { lo.abs().max(hi.abs()).max_element() } else { 1.0 };
            half_width = (2.0 * span).max(1.5);
        }
        SceneGeometry { half_width, walls }
    }
}

/// The triangles of a bounded collider shape in its local frame (balls and capsules tessellated finely enough to
/// look round at a few hundred pixels).
pub(super) fn collider_mesh(shape: &parry3d::shape::SharedShape) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    if let Some(b) = shape.as_ball() {
        b.to_trimesh(48, 24)
    } else if let Some(c) = shape.as_cuboid() {
        c.to_trimesh()
    } else if let Some(c) = shape.as_capsule() {
        c.to_trimesh(48, 12)
    } else if let Some(t) = shape.as_trimesh() {
        (t.vertices().to_vec(), t.indices().to_vec())
    } else {
        // Any other shape: its bounding box, so it is at least seen.
        let aabb = shape.compute_local_aabb();
        let (v, t) = parry3d::shape::Cuboid::new(aabb.half_extents()).to_trimesh();
        (v.into_iter().map(|p| p + aabb.center()).collect(), t)
    }
}

/// Area-weighted vertex normals.
pub(super) fn vertex_normals(p: &[Vec3], tris: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; p.len()];
    for t in tris {
        let [a, b, c] = t.map(|k| p[k as usize]);
        let f = (b - a).cross(c - a);
        for k in t {
            n[*k as usize] += f;
        }
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}
