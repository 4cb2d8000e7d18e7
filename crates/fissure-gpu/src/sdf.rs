//! Signed-distance grids: how the GPU collides with triangle meshes (and any other parry3d shape without a
//! closed-form projection). The grid is baked once on the CPU with parry3d's exact point projection (negative
//! inside); the `collide` kernel samples it trilinearly and takes the normal from its gradient. Its error is
//! second order in the cell size away from sharp features; at edges and corners the surface is rounded off by about
//! a cell. [`SdfGrid::closest`] is the CPU twin of the kernel's lookup.

use glam::Vec3;
use parry3d::shape::Shape;

/// A signed-distance field on a regular grid in the shape's local frame [m].
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
        let d = self.sample(p);
        let e = 0.5 * self.cell;
        let g = Vec3::new(
            self.sample(p + Vec3::X * e) - self.sample(p - Vec3::X * e),
            self.sample(p + Vec3::Y * e) - self.sample(p - Vec3::Y * e),
            self.sample(p + Vec3::Z * e) - self.sample(p - Vec3::Z * e),
        );
        let gl = g.length();
        if gl <= 0.0 {
            return None;
        }
        let n = g / gl;
        Some((p - n * d, d < 0.0, n))
    }
}
