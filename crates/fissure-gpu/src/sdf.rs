//! Signed-distance grids: how the GPU collides with triangle meshes (and any other parry3d shape without a
//! closed-form projection). The grid is baked once on the CPU with parry3d's exact point projection (negative
//! inside); the `collide` kernel samples it trilinearly and takes the normal from its gradient. Its error is
//! second order in the cell size away from sharp features; at edges and corners the surface is rounded off by about
//! a cell. [`SdfGrid::closest`] is the CPU twin of the kernel's lookup.

use glam::Vec3;
use parry3d::shape::Shape;

/// A signed-distance field on a regular grid in the shape's local frame \[m\].
#[derive(Clone, Debug, PartialEq)]
pub struct SdfGrid {
    /// Position of node (0, 0, 0).
    pub origin: Vec3,
    /// Cell size.
    pub cell: f32,
    /// Nodes along x, y, z (each ≥ 2).
    pub dims: [u32; 3],
    /// Signed distance at each node, x fastest.
    pub values: Vec<f32>,
}

/// Newton steps of the closest-point query (the kernel's `SDF_ITERATIONS`).
pub const SDF_ITERATIONS: usize = 4;

/// Most nodes along one axis (a 256³ grid is 64 MiB).
pub const MAX_CELLS: u32 = 256;

impl SdfGrid {
    /// Bakes `shape` with `cells` cells along the longest side of its bounding box, padded by two cells plus
    /// `margin` on every side.
    pub fn bake(shape: &dyn Shape, cells: u32, margin: f32) -> Result<SdfGrid, String> {
        if !(4..=MAX_CELLS).contains(&cells) {
            return Err(format!("grid resolution {cells} is outside 4..={MAX_CELLS} cells"));
        }
        let aabb = shape.compute_local_aabb();
        let (lo, hi) = (aabb.mins, aabb.maxs);
        let extent = (hi - lo).max_element();
        if !(extent.is_finite() && extent > 0.0) {
            return Err("the shape is unbounded or empty; only bounded shapes can be baked".into());
        }
        let cell = extent / cells as f32;
        let pad = 2.0 * cell + margin.max(0.0);
        let origin = lo - Vec3::splat(pad);
        let size = hi - lo + Vec3::splat(2.0 * pad);
        let dims = (size / cell).ceil().as_uvec3() + glam::UVec3::ONE;
        let dims = [dims.x.max(2), dims.y.max(2), dims.z.max(2)];
        let mut values = Vec::with_capacity((dims[0] * dims[1] * dims[2]) as usize);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = origin + Vec3::new(i as f32, j as f32, k as f32) * cell;
                    let proj = shape.project_local_point(p, false);
                    let d = (proj.point - p).length();
                    values.push(if proj.is_inside { -d } else { d });
                }
            }
        }
        Ok(SdfGrid { origin, cell, dims, values })
    }

    fn at(&self, i: [u32; 3]) -> f32 {
        let [nx, ny, _] = self.dims;
        self.values[(i[0] + nx * (i[1] + ny * i[2])) as usize]
    }

    /// Trilinear sample at local point `p` (clamped to the grid); same operations as the kernel's `sdf_sample`.
    pub fn sample(&self, p: Vec3) -> f32 {
        let dims = Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32);
        let u = ((p - self.origin) / self.cell).clamp(Vec3::ZERO, dims - Vec3::ONE);
        let fl = u.floor();
        let i0 = [0, 1, 2].map(|a| (fl[a] as u32).min(self.dims[a] - 2));
        let f = u - Vec3::new(i0[0] as f32, i0[1] as f32, i0[2] as f32);
        let at = |dx: u32, dy: u32, dz: u32| self.at([i0[0] + dx, i0[1] + dy, i0[2] + dz]);
        let mix = |a: f32, b: f32, t: f32| a * (1.0 - t) + b * t;
        let c00 = mix(at(0, 0, 0), at(1, 0, 0), f.x);
        let c10 = mix(at(0, 1, 0), at(1, 1, 0), f.x);
        let c01 = mix(at(0, 0, 1), at(1, 0, 1), f.x);
        let c11 = mix(at(0, 1, 1), at(1, 1, 1), f.x);
        mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z)
    }

    /// The kernel's closest-point query: `(surface point, inside, outward normal)`, or `None` outside the grid.
    pub fn closest(&self, p: Vec3) -> Option<(Vec3, bool, Vec3)> {
        let hi = self.origin
            + Vec3::new(self.dims[0] as f32 - 1.0, self.dims[1] as f32 - 1.0, self.dims[2] as f32 - 1.0) * self.cell;
        if p.cmplt(self.origin).any() || p.cmpgt(hi).any() {
            return None;
        }
        let inside = self.sample(p) < 0.0;
        // Newton steps onto the zero level: one suffices near the surface; deep inside, near the medial axis, the
        // gradient blends two faces and later steps correct the first.
        let mut q = p;
        let mut n = Vec3::ZERO;
        for _ in 0..SDF_ITERATIONS {
            let d = self.sample(q);
            n = self.normal(q)?;
            q -= n * d;
            if d.abs() <= 1e-4 * self.cell {
                break;
            }
        }
        Some((q, inside, n))
    }

    /// Unit gradient at `p` by central differences over half a cell, `None` where it vanishes.
    fn normal(&self, p: Vec3) -> Option<Vec3> {
        let e = 0.5 * self.cell;
        let g = Vec3::new(
            self.sample(p + Vec3::X * e) - self.sample(p - Vec3::X * e),
            self.sample(p + Vec3::Y * e) - self.sample(p - Vec3::Y * e),
            self.sample(p + Vec3::Z * e) - self.sample(p - Vec3::Z * e),
        );
        let gl = g.length();
        (gl > 0.0).then(|| g / gl)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fissure_core::Collider;
    use fissure_core::Mesh;
    use glam::DVec3;

    /// The grid's distance is within a cell of parry's exact distance, and its closest point within half a cell of
    /// the surface, at points inside and around a box mesh (faces, edges and corners included).
    #[test]
    fn baked_box_matches_the_exact_distance() {
        let c = Collider::trimesh(&Mesh::cuboid(DVec3::new(0.5, 0.3, 0.4), 4)).unwrap();
        let g = SdfGrid::bake(c.shape.as_ref(), 64, 0.0).unwrap();
        let mut seed = 5u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let p = Vec3::new(rnd() * 0.52, rnd() * 0.32, rnd() * 0.42);
            let exact = c.shape.project_local_point(p, false);
            let d = (exact.point - p).length() * if exact.is_inside { -1.0 } else { 1.0 };
            let s = g.sample(p);
            assert!((s - d).abs() <= g.cell, "at {p}: grid {s}, exact {d}");
            let (q, inside, _) = g.closest(p).unwrap();
            if d < -8.0 * g.cell {
                // Deep inside, near the medial axis, the closest point is ambiguous; contacts never get there.
                continue;
            }
            assert_eq!(inside, s < 0.0);
            let e = c.shape.project_local_point(q, false);
            assert!((e.point - q).length() <= 0.5 * g.cell, "closest point {q} of {p} is off the surface");
        }
    }
}
