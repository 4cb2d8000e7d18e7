//! Colliders through parry3d: half-spaces (the ground, walls), balls, cuboids, capsules and triangle meshes,
//! static or moving with constant linear and angular velocity; restitution and Coulomb friction.
//!
//! Response is a projection after the integrator: a particle found inside a collider (or closer than its
//! `margin`) is moved to the surface (plus margin) and its velocity relative to the collider is corrected:
//! the approaching normal part is reversed and scaled by the restitution `e` (zeroed below
//! `restitution_threshold`, so resting contact does not jitter), and the tangential part loses up to
//! `μ |Δv_n|` (Coulomb's law for the normal impulse just applied). Up to three sweeps over the colliders run
//! so a particle pushed out of one into another (a ground-wall corner) ends outside both.
//!
//! parry3d works in `f32`; with an `f64` model the query point is rounded to `f32` and only contacts are
//! affected by that rounding. The accuracy references have no colliders.

pub(crate) mod lanes;

use crate::error::{MeshError, ModelError};
use crate::mesh::Mesh;
use glam::{Quat, Vec3};
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::{FeatureId, SharedShape, TriMeshFlags};

/// A static or kinematically moving collision shape.
#[derive(Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Collider {
    /// The shape, in its local frame.
    pub shape: SharedShape,
    /// Pose at time 0.
    pub pose: Pose,
    /// Linear velocity \[m/s\] (constant).
    pub linear_velocity: Vec3,
    /// Angular velocity \[rad/s\] about the pose's origin (constant).
    pub angular_velocity: Vec3,
    /// Restitution `e` in [0, 1] for normal impacts. Default 0.3.
    pub restitution: f32,
    /// Normal speed \[m/s\] below which restitution is 0. Default 0.05.
    pub restitution_threshold: f32,
    /// Coulomb friction coefficient `μ ≥ 0`. Default 0.4.
    pub friction: f32,
    /// Skin thickness \[m\] kept between particles and the surface. Default 0.
    pub margin: f32,
}

impl std::fmt::Debug for Collider {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Collider")
            .field("shape", &self.shape.shape_type())
            .field("pose", &self.pose)
            .field("linear_velocity", &self.linear_velocity)
            .field("angular_velocity", &self.angular_velocity)
            .field("restitution", &self.restitution)
            .field("friction", &self.friction)
            .field("margin", &self.margin)
            .finish()
    }
}

impl Collider {
    /// A collider from any parry3d shape at `pose`.
    pub fn new(shape: SharedShape, pose: Pose) -> Self {
        Collider {
            shape,
            pose,
            linear_velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
            restitution: 0.3,
            restitution_threshold: 0.05,
            friction: 0.4,
            margin: 0.0,
        }
    }

    /// The horizontal ground `y = height` (solid below).
    pub fn ground(height: f32) -> Self {
        Self::plane(Vec3::new(0.0, height, 0.0), Vec3::Y)
    }

    /// The half-space behind the plane through `point` with outward `normal` (a wall). A zero or non-finite
    /// normal gives a collider that [`Collider::validate`] (and so `ModelBuilder::add_collider`) rejects.
    pub fn plane(point: Vec3, normal: Vec3) -> Self {
        Self::new(SharedShape::halfspace(normal.normalize_or_zero()), Pose::from_translation(point))
    }

    /// A solid ball.
    pub fn ball(center: Vec3, radius: f32) -> Self {
        Self::new(SharedShape::ball(radius), Pose::from_translation(center))
    }

    /// A solid axis-aligned box (rotate it with [`Collider::with_rotation`]).
    pub fn cuboid(center: Vec3, half_extents: Vec3) -> Self {
        Self::new(SharedShape::cuboid(half_extents.x, half_extents.y, half_extents.z), Pose::from_translation(center))
    }

    /// A solid capsule between `a` and `b` with `radius`.
    pub fn capsule(a: Vec3, b: Vec3, radius: f32) -> Self {
        Self::new(SharedShape::capsule(a, b, radius), Pose::IDENTITY)
    }

    /// A solid triangle mesh (closed and outward-facing, so inside is defined).
    pub fn trimesh(mesh: &Mesh) -> Result<Self, MeshError> {
        if !mesh.is_closed() {
            let topo = mesh.topology();
            let e = topo.boundary_edges().next().map(|e| topo.edges[e]).unwrap_or([0, 0]);
            return Err(MeshError::Open { boundary_edges: topo.boundary_edges().count(), a: e[0], b: e[1] });
        }
        let mut m = mesh.clone();
        m.orient_outward();
        let verts = m.positions().iter().map(|p| p.as_vec3()).collect();
        let shape = SharedShape::trimesh_with_flags(verts, m.triangles().to_vec(), TriMeshFlags::ORIENTED)
            .map_err(|e| MeshError::Io { path: "<trimesh collider>".into(), message: format!("{e:?}") })?;
        Ok(Self::new(shape, Pose::IDENTITY))
    }

    /// Checks every value: shape sizes finite and positive (`radius`, `half_extents`), a unit `normal`, finite
    /// `position`, `rotation`, `velocity` and capsule ends (`a`, `b`), `restitution` in [0, 1], `friction` and
    /// `margin` finite and ≥ 0. The error's parameter name is the one a scene file or Python uses.
    pub fn validate(&self) -> Result<(), ModelError> {
        fn bad(name: &'static str, value: f32, expected: &'static str) -> Result<(), ModelError> {
            Err(ModelError::Parameter { name, value: value as f64, expected })
        }
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let s = &self.shape;
        if let Some(h) = s.as_halfspace() {
            let n = h.normal.length();
            if !(n.is_finite() && (n - 1.0).abs() < 1e-3) {
                return bad("normal", n, "a finite nonzero vector (its length is shown)");
            }
        } else if let Some(b) = s.as_ball() {
            if !pos(b.radius) {
                return bad("radius", b.radius, "finite and > 0 [m]");
            }
        } else if let Some(c) = s.as_cuboid() {
            if let Some(&x) = c.half_extents.to_array().iter().find(|x| !pos(**x)) {
                return bad("half_extents", x, "finite and > 0 [m]");
            }
        } else if let Some(c) = s.as_capsule() {
            if !pos(c.radius) {
                return bad("radius", c.radius, "finite and > 0 [m]");
            }
            if !c.segment.a.is_finite() {
                return bad("a", f32::NAN, "finite [m]");
            }
            if !c.segment.b.is_finite() {
                return bad("b", f32::NAN, "finite [m]");
            }
        }
        if !self.pose.translation.is_finite() {
            return bad("position", f32::NAN, "finite [m]");
        }
        if !self.pose.rotation.is_finite() || (self.pose.rotation.length() - 1.0).abs() > 1e-3 {
            return bad("rotation", self.pose.rotation.length(), "a finite unit quaternion");
        }
        if !self.linear_velocity.is_finite() || !self.angular_velocity.is_finite() {
            return bad("velocity", f32::NAN, "finite [m/s, rad/s]");
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return bad("restitution", self.restitution, "in [0, 1]");
        }
        for (name, v) in [
            ("friction", self.friction),
            ("margin", self.margin),
            ("restitution_threshold", self.restitution_threshold),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v, "finite and >= 0");
            }
        }
        Ok(())
    }

    /// Sets restitution.
    pub fn with_restitution(mut self, e: f32) -> Self {
        self.restitution = e;
        self
    }

    /// Sets Coulomb friction.
    pub fn with_friction(mut self, mu: f32) -> Self {
        self.friction = mu;
        self
    }

    /// Sets the skin margin \[m\].
    pub fn with_margin(mut self, margin: f32) -> Self {
        self.margin = margin;
        self
    }

    /// Sets the orientation at time 0.
    pub fn with_rotation(mut self, rotation: Quat) -> Self {
        self.pose.rotation = rotation;
        self
    }

    /// Sets a constant linear \[m/s\] and angular \[rad/s\] velocity.
    pub fn with_velocity(mut self, linear: Vec3, angular: Vec3) -> Self {
        self.linear_velocity = linear;
        self.angular_velocity = angular;
        self
    }

    /// Pose at time `t` \[s\].
    pub fn pose_at(&self, t: f64) -> Pose {
        let mut p = self.pose;
        p.translation += self.linear_velocity * t as f32;
        let angle = self.angular_velocity * t as f32;
        if angle != Vec3::ZERO {
            p.rotation = (Quat::from_scaled_axis(angle) * p.rotation).normalize();
        }
        p
    }

    /// Velocity \[m/s\] of the collider's material at world point `x` when its pose is `pose`.
    pub fn velocity_at(&self, pose: &Pose, x: Vec3) -> Vec3 {
        self.linear_velocity + self.angular_velocity.cross(x - pose.translation)
    }

    /// A bounding box at `pose`, grown by the margin.
    pub fn aabb(&self, pose: &Pose) -> Aabb {
        self.shape.compute_aabb(pose).loosened(self.margin.max(0.0) + 1e-6)
    }

    /// Everything a step needs to resolve particles against this collider at time `t`, computed once per step.
    pub fn prepare(&self, t: f64) -> PreparedCollider {
        let pose = self.pose_at(t);
        let shape = if let Some(h) = self.shape.as_halfspace() {
            Analytic::HalfSpace(h.normal)
        } else if let Some(b) = self.shape.as_ball() {
            Analytic::Ball(b.radius)
        } else if let Some(c) = self.shape.as_cuboid() {
            Analytic::Cuboid(c.half_extents)
        } else if let Some(c) = self.shape.as_capsule() {
            Analytic::Capsule(c.segment.a, c.segment.b, c.radius)
        } else {
            Analytic::General
        };
        // World-space distance tests for the fast reject (see `Quick`).
        let quick = match shape {
            Analytic::HalfSpace(n) => {
                let n_w = pose.rotation * n;
                Quick::Plane(n_w, n_w.dot(pose.translation), pose.translation.abs().max_element())
            }
            Analytic::Ball(r) => Quick::Sphere(pose.translation, r + self.margin, r),
            _ => Quick::None,
        };
        PreparedCollider { aabb: self.aabb(&pose), pose, shape, quick }
    }

    /// Resolves one particle at `x` with velocity `v` against this collider at time `t`: the corrected position
    /// and velocity if it was in contact, `None` otherwise. (Steps use [`Collider::prepare`] once instead.)
    pub fn resolve(&self, t: f64, x: Vec3, v: Vec3) -> Option<(Vec3, Vec3)> {
        self.prepare(t).resolve(self, x, v)
    }

    /// Outward normal of the surface feature nearest to the local point `local`.
    fn surface_normal(&self, local: Vec3) -> Vec3 {
        if let Some(tm) = self.shape.as_trimesh() {
            let (_, (tri, _)) = tm.project_local_point_and_get_location(local, false);
            return tm.triangle(tri).normal().unwrap_or(Vec3::Y);
        }
        let (p, feat) = self.shape.project_local_point_and_get_feature(local);
        if feat == FeatureId::Unknown {
            return Vec3::Y;
        }
        self.shape.feature_normal_at_point(0, feat, p.point).unwrap_or(Vec3::Y)
    }
}

/// The shapes with closed-form projections; everything else goes through parry3d's point query.
#[derive(Clone, Copy, Debug)]
enum Analytic {
    HalfSpace(Vec3),
    Ball(f32),
    Cuboid(Vec3),
    Capsule(Vec3, Vec3, f32),
    General,
}

/// The plane and the ball in world space, where [`PreparedCollider::resolve`] tests and projects them in closed
/// form (no pose transforms; until 2026-11-24 they went through the local frame like the other shapes, with
/// this as a conservative quick reject before it). The block test [`PreparedCollider::may_touch_box`] keeps
/// tolerances far above rounding, so skipping a block never drops a contact.
#[derive(Clone, Copy, Debug)]
enum Quick {
    /// World normal `n`, offset `n·t`, and `|t|∞` for the tolerance.
    Plane(Vec3, f32, f32),
    /// World centre, radius plus margin, and radius.
    Sphere(Vec3, f32, f32),
    None,
}

/// A collider's pose, bounding box and shape kind evaluated for one step (owned, so a solver keeps a buffer of
/// them and a step allocates nothing).
#[derive(Clone, Debug)]
pub struct PreparedCollider {
    pose: Pose,
    aabb: Aabb,
    shape: Analytic,
    quick: Quick,
}

impl PreparedCollider {
    /// Closest boundary point, whether `p` (local) is inside, and the outward normal there.
    #[inline]
    fn closest(&self, c: &Collider, p: Vec3) -> (Vec3, bool, Vec3) {
        match self.shape {
            // The plane and the ball never come here: `resolve` projects them in world space (`Quick`).
            Analytic::Cuboid(h) => {
                let a = p.abs();
                if a.x <= h.x && a.y <= h.y && a.z <= h.z {
                    // Inside: leave through the nearest face.
                    let gap = h - a;
                    let axis = if gap.x <= gap.y && gap.x <= gap.z {
                        0
                    } else if gap.y <= gap.z {
                        1
                    } else {
                        2
                    };
                    let mut n = Vec3::ZERO;
                    n[axis] = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
                    let mut q = p;
                    q[axis] = n[axis] * h[axis];
                    (q, true, n)
                } else {
                    let q = p.clamp(-h, h);
                    let d = p - q;
                    (q, false, d / d.length())
                }
            }
            Analytic::Capsule(a, b, r) => {
                let ab = b - a;
                let len2 = ab.length_squared();
                let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
                let c = a + ab * t;
                let d = p - c;
                let l = d.length();
                let n = if l > 0.0 { d / l } else { ab.any_orthonormal_vector() };
                (c + n * r, l < r, n)
            }
            Analytic::HalfSpace(_) | Analytic::Ball(_) | Analytic::General => {
                // `solid = false`: interior points project onto the boundary (with `solid = true` parry projects
                // them onto themselves); `is_inside` still says which side they are on.
                let proj = c.shape.project_local_point(p, false);
                let delta = proj.point - p;
                let dist = delta.length();
                let n = if dist > 1e-6 {
                    if proj.is_inside { delta / dist } else { -delta / dist }
                } else {
                    // On (or within rounding of) the surface: the feature's normal is robust where `delta` is noise.
                    c.surface_normal(p)
                };
                (proj.point, proj.is_inside, n)
            }
        }
    }

    /// False when no point of the box `lo..=hi` (world) can pass this collider's fast reject in
    /// [`PreparedCollider::resolve`]: the solver then skips the collider for a whole block of particles. Every
    /// test here is looser than the per-point one (the box's nearest point, tolerances widened for rounding), so
    /// skipping never drops a contact.
    #[inline]
    pub fn may_touch_box(&self, c: &Collider, lo: Vec3, hi: Vec3) -> bool {
        match self.quick {
            Quick::Plane(n, d, t) => {
                let far = lo.abs().max(hi.abs()).max_element();
                let nearest = (n * lo).min(n * hi).element_sum();
                let tol = 1e-5 * (far + t + 1.0) + 1e-6 * (far + d.abs() + 1.0);
                nearest - d <= c.margin + tol
            }
            Quick::Sphere(centre, reach, _) => {
                let gap = centre.clamp(lo, hi) - centre;
                gap.length_squared() <= reach * reach * (1.0 + 1e-3) + 1e-10
            }
            Quick::None => {
                let pad = 1e-5 * (1.0 + lo.abs().max(hi.abs()).max_element());
                self.aabb.mins.cmple(hi + pad).all() && self.aabb.maxs.cmpge(lo - pad).all()
            }
        }
    }

    /// The contact point and normal of a shape without a closed form (through the local frame and parry3d), or
    /// `None` when `x` is clear of it. Out of line: it would make every caller's frame large for the plane's and
    /// the ball's few instructions.
    #[inline(never)]
    fn contact_general(&self, c: &Collider, x: Vec3) -> Option<(Vec3, Vec3)> {
        if !self.aabb.contains_local_point(x) {
            return None;
        }
        let local = self.pose.inverse_transform_point(x);
        let (proj, inside, n_local) = self.closest(c, local);
        if !inside && (local - proj).length_squared() >= c.margin * c.margin {
            return None;
        }
        Some((self.pose.transform_point(proj + n_local * c.margin), self.pose.rotation * n_local))
    }

    /// See [`Collider::resolve`]; `c` is the collider this was prepared from. Inlined into the collision pass:
    /// a call cost more than the plane's test (measured 2026-11-25 on resting contacts, see `solver/collide.rs`).
    #[inline(always)]
    pub fn resolve(&self, c: &Collider, x: Vec3, v: Vec3) -> Option<(Vec3, Vec3)> {
        // The plane and the ball in world space: the same formulas as `closest` in the local frame, without the
        // two pose transforms. Measured on the harness's `terms` cloth (128², resting on the ground and a ball),
        // 2026-11-24: a contact 33.7 → 15.3 ns; with `sweeps` inlined, the collide stage 60 → 26 µs per step
        // over the harness's window, 351 → 227 µs once half the cloth rests on them.
        let (x_new, n) = match self.quick {
            Quick::Plane(n, d, _) => {
                // Signed distance; at or past the margin (≥ 0) no contact.
                let s = n.dot(x) - d;
                if s >= c.margin {
                    return None;
                }
                (x + n * (c.margin - s), n)
            }
            Quick::Sphere(centre, reach, r) => {
                let d = x - centre;
                let l2 = d.length_squared();
                if l2 > reach * reach * (1.0 + 1e-4) + 1e-12 {
                    return None;
                }
                let l = l2.sqrt();
                if l >= r && (l - r) * (l - r) >= c.margin * c.margin {
                    return None;
                }
                let n = if l > 0.0 { d / l } else { Vec3::Y };
                (centre + n * (r + c.margin), n)
            }
            Quick::None => self.contact_general(c, x)?,
        };
        let v_col = c.velocity_at(&self.pose, x_new);
        let v_rel = v - v_col;
        let vn = v_rel.dot(n);
        if vn >= 0.0 {
            return Some((x_new, v));
        }
        let vn_new = if -vn > c.restitution_threshold { -c.restitution * vn } else { 0.0 };
        let vt = v_rel - n * vn;
        let vt_len = vt.length();
        let scale = if vt_len > 0.0 { (1.0 - c.friction * (vn_new - vn) / vt_len).max(0.0) } else { 0.0 };
        Some((x_new, v_col + vt * scale + n * vn_new))
    }
}
