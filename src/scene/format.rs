//! The scene file format: the TOML sections and the closed sets (integrators, shapes, ...) as serde types.
//! Values are checked by the core when the scene is built ([`super::Scene::builder`]); serde rejects unknown keys
//! and names.

use crate::*;
use serde::Deserialize;

/// `[solver] integrator`: the time integrator, by name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorName {
    /// Symplectic Euler (the seed's eqs. 3–5). The default.
    #[default]
    SymplecticEuler,
    /// Velocity Verlet.
    VelocityVerlet,
    /// Classical Runge–Kutta.
    Rk4,
    /// Implicit Euler (Baraff–Witkin).
    ImplicitEuler,
}

impl From<IntegratorName> for Integrator {
    fn from(n: IntegratorName) -> Integrator {
        match n {
            IntegratorName::SymplecticEuler => Integrator::SymplecticEuler,
            IntegratorName::VelocityVerlet => Integrator::VelocityVerlet,
            IntegratorName::Rk4 => Integrator::Rk4,
            IntegratorName::ImplicitEuler => Integrator::ImplicitEuler,
        }
    }
}

impl std::fmt::Display for IntegratorName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(Integrator::from(*self).name())
    }
}

/// `[solver] damping_model`: along the spring (`projected`) or the seed's eq. 2 (`unprojected`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DampingName {
    /// Along the spring. The default.
    #[default]
    Projected,
    /// The seed's eq. 2, which also damps shear and rotation of each spring.
    Unprojected,
}

/// `[[body]] shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyShape {
    /// A subdivided icosahedron (`radius`, `subdivisions`).
    Icosphere,
    /// A box (`half_extents`, `cells`).
    Cuboid,
    /// A mesh from an OBJ file (`file`).
    Obj,
    /// A rectangular cloth (`resolution`, `width`, `orientation`, `pin`, `shear`).
    Cloth,
}

/// `[[body]] orientation` of a cloth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Orientation {
    /// In the xy plane, hanging down from its top edge. The default.
    #[default]
    Vertical,
    /// In the xz plane.
    Horizontal,
}

/// `[[body]] pin` of a cloth: which particles are held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pin {
    /// The two top corners. The default.
    #[default]
    TopCorners,
    /// The whole top edge.
    TopEdge,
    /// The whole bottom edge.
    BottomEdge,
    /// The whole left edge (the first column).
    LeftEdge,
    /// The whole right edge (the last column).
    RightEdge,
    /// Nothing.
    None,
}

impl Pin {
    /// The particles of an `nx` × `ny` cloth grid (row 0 at the top) this names.
    pub fn particles(self, nx: usize, ny: usize) -> Vec<usize> {
        match self {
            Pin::TopCorners => vec![0, nx - 1],
            Pin::TopEdge => (0..nx).collect(),
            Pin::BottomEdge => ((ny - 1) * nx..ny * nx).collect(),
            Pin::LeftEdge => (0..ny).map(|j| j * nx).collect(),
            Pin::RightEdge => (0..ny).map(|j| j * nx + nx - 1).collect(),
            Pin::None => Vec::new(),
        }
    }
}

/// `[[body.handle]]`: particles of a body moved on a path (a moving pin; see [`fissure_core::Handle`]). Either
/// `velocity` (with `start` and `stop`) or `path`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandleSection {
    /// Cloth: which particles (`left_edge`, `right_edge`, `top_edge`, `bottom_edge`, `top_corners`).
    #[serde(default)]
    pub pin: Option<Pin>,
    /// Any body: the particles by vertex index (of the body's mesh).
    #[serde(default)]
    pub vertices: Option<Vec<usize>>,
    /// Velocity \[m/s\] from `start` to `stop`.
    #[serde(default)]
    pub velocity: Option<[f64; 3]>,
    /// When the handle starts moving \[s\]. Default 0.
    #[serde(default)]
    pub start: f64,
    /// When it stops \[s\]. Default: the scene's duration.
    #[serde(default)]
    pub stop: Option<f64>,
    /// Keys `[time, x, y, z]`: the offset \[m\] from the start position at each time \[s\], linear between.
    #[serde(default)]
    pub path: Option<Vec<[f64; 4]>>,
}

/// `[[collider]] shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColliderShape {
    /// The floor `y = height`.
    Ground,
    /// A wall: the half-space behind `point` with outward `normal`.
    Plane,
    /// A ball (`center`, `radius`).
    Ball,
    /// An axis-aligned box (`center`, `half_extents`).
    Cuboid,
    /// A capsule (`a`, `b`, `radius`).
    Capsule,
}

impl ColliderShape {
    pub(super) fn name(self) -> &'static str {
        match self {
            ColliderShape::Ground => "ground",
            ColliderShape::Plane => "plane",
            ColliderShape::Ball => "ball",
            ColliderShape::Cuboid => "cuboid",
            ColliderShape::Capsule => "capsule",
        }
    }
}

/// `[solver]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSection {
    /// Integrator: `symplectic_euler` (default), `velocity_verlet`, `rk4` or `implicit_euler`.
    pub integrator: IntegratorName,
    /// Step \[s\]. Default 1e-4.
    pub dt: f64,
    /// Simulated time of a run \[s\]. Default 2.
    pub duration: f64,
    /// Gravity \[m/s^2\]. Default (0, -9.81, 0).
    pub gravity: [f64; 3],
    /// Spring damping: `projected` (along the spring; default) or `unprojected` (the seed's eq. 2, which also
    /// damps shear and rotation of each spring).
    pub damping_model: DampingName,
    /// Stability guard: split a step that is too large for the mesh into substeps of at most this fraction of
    /// the stability bound, in (0, 1]. Default none (steps as given).
    pub substep_safety: Option<f64>,
}

impl Default for SolverSection {
    fn default() -> Self {
        SolverSection {
            integrator: IntegratorName::SymplecticEuler,
            dt: 1e-4,
            duration: 2.0,
            gravity: [0.0, -9.81, 0.0],
            damping_model: DampingName::Projected,
            substep_safety: None,
        }
    }
}

/// `[fracture]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FractureSection {
    /// Time constant of the averaged trigger \[s\]; none: instantaneous.
    pub averaged_window: Option<f64>,
    /// Most splits per step. Default 32.
    pub max_events_per_step: Option<usize>,
    /// Orifice discharge coefficient. Default 0.6.
    pub discharge_coefficient: Option<f64>,
    /// Gas density \[kg/m^3\]. Default 1.2.
    pub gas_density: Option<f64>,
    /// Simulated time before anything may break \[s\]. Default 0.
    pub start_time: Option<f64>,
    /// Most spring-mode splits per body per step. Default 1.
    pub splits_per_body: Option<usize>,
    /// Least time between new cracks in one body \[s\]. Default: its wave-crossing time.
    pub nucleation_interval: Option<f64>,
}

/// `[[body]]`: a soft body (closed, optionally with gas).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySection {
    /// `icosphere`, `cuboid`, `obj` or `cloth`.
    pub shape: BodyShape,
    /// Cloth: particles across and down.
    #[serde(default)]
    pub resolution: Option<[usize; 2]>,
    /// Cloth width \[m\]. Default 1.
    #[serde(default)]
    pub width: Option<f64>,
    /// Cloth: `vertical` (default) or `horizontal`.
    #[serde(default)]
    pub orientation: Option<Orientation>,
    /// Cloth: `top_corners` (default), `top_edge` or `none`.
    #[serde(default)]
    pub pin: Option<Pin>,
    /// Cloth shear springs, membrane stiffness \[N/m\]; none: no shear springs.
    #[serde(default)]
    pub shear: Option<f64>,
    /// Icosphere radius \[m\].
    #[serde(default)]
    pub radius: Option<f64>,
    /// Icosphere subdivisions. Default 3.
    #[serde(default)]
    pub subdivisions: Option<u32>,
    /// Cuboid half extents \[m\].
    #[serde(default)]
    pub half_extents: Option<[f64; 3]>,
    /// Cuboid cells per edge. Default 4.
    #[serde(default)]
    pub cells: Option<usize>,
    /// OBJ file, relative to the scene file.
    #[serde(default)]
    pub file: Option<String>,
    /// Translation \[m\].
    #[serde(default)]
    pub position: [f64; 3],
    /// Initial velocity \[m/s\].
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Total mass \[kg\]. Default 1.
    #[serde(default = "one")]
    pub mass: f64,
    /// Membrane stiffness E·h \[N/m\]. Default 2000.
    #[serde(default = "default_stiffness")]
    pub stiffness: f64,
    /// Damping ratio. Default 0.05.
    #[serde(default = "default_damping")]
    pub damping_ratio: f64,
    /// Bending membrane stiffness \[N/m\]; none: no bending springs.
    #[serde(default)]
    pub bending: Option<f64>,
    /// Gas pressure at rest \[Pa\]; 0: no gas. Default 2000 for closed bodies; a cloth has none.
    #[serde(default)]
    pub pressure: Option<f64>,
    /// A pump: gas added per second while the body is whole, as `nRT` \[Pa·m³/s\]. Default 0.
    #[serde(default)]
    pub inflow: Option<f64>,
    /// Strain limit of the springs (spring mode).
    #[serde(default)]
    pub strain_limit: Option<f64>,
    /// Load limit of the vertices \[N\] (core mode).
    #[serde(default)]
    pub load_limit: Option<f64>,
    /// Tear strength \[N/m\]: force per unit length of crack at which the membrane tears (spring mode).
    #[serde(default)]
    pub tear_strength: Option<f64>,
    /// Keep the gas when punctured.
    #[serde(default)]
    pub sealed: bool,
    /// Moving pins.
    #[serde(default)]
    pub handle: Vec<HandleSection>,
    /// Cuts made before the run: pairs of vertex indices (of the body's mesh) whose spring is split in spring
    /// mode, as a notch or a slit is cut into a specimen before it is loaded.
    #[serde(default)]
    pub cuts: Vec<[usize; 2]>,
    /// Collide with the other bodies in contact (and with pieces broken off this one). Default false.
    #[serde(default)]
    pub contact: bool,
    /// Also collide with itself; implies `contact`. Default false.
    #[serde(default)]
    pub self_collision: bool,
    /// Contact thickness \[m\]: the gap kept between surfaces. Default 0.2 × the mean edge length.
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Coulomb friction of contacts. Default 0.3.
    #[serde(default)]
    pub contact_friction: Option<f64>,
}

impl BodySection {
    /// Contact settings: `None` unless `contact` or `self_collision` is set.
    pub(super) fn contact(&self) -> Option<Contact> {
        (self.contact || self.self_collision).then(|| Contact {
            thickness: self.thickness,
            self_collision: self.self_collision,
            friction: self.contact_friction.unwrap_or(Contact::default().friction),
        })
    }

    /// How the body breaks: `None` unless a limit (or `sealed`) is given; a missing limit is infinite (off).
    pub(super) fn breakable(&self) -> Option<Breakable> {
        let any = self.strain_limit.is_some() || self.load_limit.is_some() || self.tear_strength.is_some();
        (any || self.sealed).then(|| Breakable {
            strain_limit: self.strain_limit.unwrap_or(f64::INFINITY),
            load_limit: self.load_limit.unwrap_or(f64::INFINITY),
            sealed: self.sealed,
            tear_strength: self.tear_strength.unwrap_or(f64::INFINITY),
        })
    }
}

fn one() -> f64 {
    1.0
}
fn default_stiffness() -> f64 {
    2000.0
}
fn default_damping() -> f64 {
    0.05
}
fn default_restitution() -> f32 {
    0.3
}
fn default_friction() -> f32 {
    0.4
}

/// `[[collider]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderSection {
    /// `ground`, `plane`, `ball`, `cuboid` or `capsule`.
    pub shape: ColliderShape,
    /// Ground height \[m\].
    #[serde(default)]
    pub height: Option<f32>,
    /// Plane point \[m\].
    #[serde(default)]
    pub point: Option<[f32; 3]>,
    /// Plane normal.
    #[serde(default)]
    pub normal: Option<[f32; 3]>,
    /// Ball or cuboid centre \[m\].
    #[serde(default)]
    pub center: Option<[f32; 3]>,
    /// Ball or capsule radius \[m\].
    #[serde(default)]
    pub radius: Option<f32>,
    /// Cuboid half extents \[m\].
    #[serde(default)]
    pub half_extents: Option<[f32; 3]>,
    /// Capsule ends \[m\].
    #[serde(default)]
    pub a: Option<[f32; 3]>,
    /// Capsule ends \[m\].
    #[serde(default)]
    pub b: Option<[f32; 3]>,
    /// Restitution. Default 0.3.
    #[serde(default = "default_restitution")]
    pub restitution: f32,
    /// Coulomb friction. Default 0.4.
    #[serde(default = "default_friction")]
    pub friction: f32,
}

/// `[wind]`: see [`WindField`] for the model.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindSection {
    /// Mean wind velocity \[m/s\].
    pub velocity: [f64; 3],
    /// Gust amplitude as a fraction of the mean speed. Default 0.5.
    #[serde(default)]
    pub gust_amplitude: Option<f64>,
    /// Gust frequency \[Hz\]. Default 0.5.
    #[serde(default)]
    pub gust_frequency: Option<f64>,
    /// Gust wavelength \[m\]. Default 4.
    #[serde(default)]
    pub gust_wavelength: Option<f64>,
    /// Crosswind wobble as a fraction of the mean speed. Default 0.2.
    #[serde(default)]
    pub crosswind: Option<f64>,
    /// Air density \[kg/m^3\]. Default 1.225.
    #[serde(default)]
    pub air_density: Option<f64>,
}
