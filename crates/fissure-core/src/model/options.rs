//! What a user says about a body: its mass, stiffness, damping, gas and how it breaks, in SI units.

use super::*;

/// How a body's mass is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mass {
    /// Total mass \[kg\], lumped onto vertices by area (each vertex takes a third of its triangles' area).
    Total(f64),
    /// Surface density [kg/m^2], lumped by area.
    AreaDensity(f64),
    /// The same mass \[kg\] on every vertex.
    PerParticle(f64),
}

/// How spring stiffness is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stiffness {
    /// Every spring gets this constant \[N/m\]. Depends on the mesh resolution: a finer mesh of the same
    /// springs is softer (more springs in series).
    PerSpring(f64),
    /// The membrane's stretching stiffness `E·h` \[N/m\] (2D Young's modulus, independent of resolution).
    /// Each edge spring gets `k = E·h Σ A_t / L²` over its one or two triangles (Van Gelder 1998): a regular
    /// triangle lattice of such springs has the 2D Young's modulus `E·h` (Poisson ratio 1/3) at any
    /// resolution. Bending springs get the same formula with their own length.
    Membrane(f64),
}

/// How spring damping is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// Every spring gets this coefficient \[N·s/m\].
    PerSpring(f64),
    /// A fraction ζ of each spring's critical damping `2 √(k m_red)`, `m_red` the reduced mass of its ends.
    Ratio(f64),
}

/// The seed's eq. (2) damping in two forms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum DampingModel {
    /// `kd ((v_j - v_i)·d̂) d̂`: damps stretching only. Rigid rotation is undamped (default).
    #[default]
    Projected,
    /// The paper's `kd (v_j - v_i)`: also damps rotation and shear of the spring.
    Unprojected,
}

/// Gas inside a closed body (the closed pressure model, seed eqs. 6–9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gas {
    /// No gas: a hollow membrane.
    None,
    /// The constant `nRT` \[J\] of `P V = nRT`.
    Amount(f64),
    /// The pressure \[Pa\] at the rest shape; `nRT = P0 · V0`.
    Pressure(f64),
}

/// What a spring represents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum SpringKind {
    /// A mesh edge (structural); the springs the fracture code splits.
    Edge,
    /// A shear spring across a quad (cloth grids).
    Shear,
    /// A bending spring: across two triangles, or skipping a vertex on a grid.
    Bend,
    /// A spring that broke: it keeps its slot (so indices and cloth spring runs stay valid) with zero stiffness
    /// and damping, and is in no particle's spring list.
    Broken,
}

/// How a body breaks (see the `fracture` module). Limits of `f64::INFINITY` switch a mode off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Breakable {
    /// Strain `(l - L0) / L0` past which a spring breaks (spring mode). Default infinity (off).
    pub strain_limit: f64,
    /// Load \[N\] past which a vertex breaks out as a core block (core mode): the magnitude of the net elastic
    /// force (springs and gas) on it. Default infinity (off).
    pub load_limit: f64,
    /// Keep the gas in when the body is punctured (its volume is still taken with caps over the openings).
    /// Default false: gas leaks through the openings.
    pub sealed: bool,
    /// Tear strength `T` \[N/m\]: the force per unit length of crack at which the membrane tears (spring mode).
    /// Default infinity (off). Unlike a strain limit on a spring of a given stiffness, it names a property of the
    /// material, so the same sheet tears at the same load whatever its mesh (the reason Houdini Vellum normalises
    /// stress). Each spring stands for a strip of membrane of width `w = A / L` (`A`: the area of the triangles it
    /// spans, `L` its rest length) and carries `k L ε` at strain `ε`; it breaks when that force per unit width
    /// passes `T`, at strain `T w / (k L)`. With [`Stiffness::Membrane`]`(E·h)` (`k = E·h A / L²`) that is the
    /// strain `T / (E·h)` on every spring: a sheet pulled uniaxially tears at `T / (E·h)` strain, at a pull of
    /// about `T` per unit width (more where shear and bending springs stiffen the lattice: a grid cloth with
    /// `shear = stiffness / 4` and light bending tears at 1.03 to 1.11 `T` on three meshes and three steps: the
    /// strip test of `tests/suite/tearing.rs`). The tighter of this and `strain_limit` holds.
    pub tear_strength: f64,
}

impl Default for Breakable {
    fn default() -> Self {
        Breakable {
            strain_limit: f64::INFINITY,
            load_limit: f64::INFINITY,
            sealed: false,
            tear_strength: f64::INFINITY,
        }
    }
}

impl Breakable {
    /// Strain limit of a spring of stiffness `k` \[N/m\] and rest length `l` \[m\] standing for a strip of membrane
    /// `width` \[m\] wide: the tighter of `strain_limit` and the tear strength's (see
    /// [`Breakable::tear_strength`]; a spring that stands for no membrane or has no stiffness gets the strain
    /// limit alone).
    pub fn spring_strain_limit(&self, k: f64, l: f64, width: f64) -> f64 {
        let tear = if self.tear_strength.is_finite() && width > 0.0 && k > 0.0 {
            self.tear_strength * width / (k * l)
        } else {
            f64::INFINITY
        };
        self.strain_limit.min(tear)
    }

    pub(super) fn check(&self) -> Result<(), ModelError> {
        for (name, v) in [
            ("fracture.strain_limit", self.strain_limit),
            ("fracture.load_limit", self.load_limit),
            ("fracture.tear_strength", self.tear_strength),
        ] {
            if v.is_nan() || v <= 0.0 {
                return Err(ModelError::Parameter { name, value: v, expected: "> 0 (infinity: off)" });
            }
        }
        Ok(())
    }
}

/// An opening of a gas body: a boundary loop of its surface, in the direction its faces traverse it. The body's
/// volume is taken with a virtual cap over it (a fan from the loop's centroid), so the volume does not depend on
/// the origin, and its gas leaks out through it (see the `fracture` module).
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Opening {
    /// The body.
    pub body: u32,
    /// The loop's particles.
    pub vertices: Vec<u32>,
}

/// What a body is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum BodyKind {
    /// A closed surface, possibly with gas.
    SoftBody,
    /// An open (or closed) sheet without gas.
    Cloth,
}

/// Options of [`ModelBuilder::add_soft_body`].
#[derive(Clone, Debug, PartialEq)]
pub struct SoftBodyOptions {
    /// Mass. Default `Total(1.0)` kg.
    pub mass: Mass,
    /// Edge spring stiffness. Default `Membrane(2000.0)` N/m.
    pub stiffness: Stiffness,
    /// Spring damping. Default `Ratio(0.05)`.
    pub damping: Damping,
    /// Bending springs across each interior edge, if any. Default `None`.
    pub bending: Option<Stiffness>,
    /// Gas. Default `Pressure(2000.0)` Pa.
    pub gas: Gas,
    /// A pump: gas added per second while the body is whole, as `nRT` \[J/s = Pa·m³/s\] (a litre per second of
    /// air at 1 bar is 100). It stops at the first opening (a burst balloon is off its pump). Default 0.
    pub gas_inflow: f64,
    /// Pressure outside \[Pa\], subtracted from the gas pressure. Default 0 (the seed's model).
    pub external_pressure: f64,
    /// Aerodynamic coefficients (only used if the model has wind). Default none.
    pub aero: Aero,
    /// Flip an inward-facing closed mesh instead of failing. Default true.
    pub reorient: bool,
    /// Initial velocity \[m/s\]. Default 0.
    pub velocity: DVec3,
    /// How the body breaks. Default `None`: it never does.
    pub fracture: Option<Breakable>,
}

impl Default for SoftBodyOptions {
    fn default() -> Self {
        SoftBodyOptions {
            mass: Mass::Total(1.0),
            stiffness: Stiffness::Membrane(2000.0),
            damping: Damping::Ratio(0.05),
            bending: None,
            gas: Gas::Pressure(2000.0),
            gas_inflow: 0.0,
            external_pressure: 0.0,
            aero: Aero::NONE,
            reorient: true,
            velocity: DVec3::ZERO,
            fracture: None,
        }
    }
}

/// Options of [`ModelBuilder::add_cloth`] and [`ModelBuilder::add_cloth_grid`].
#[derive(Clone, Debug, PartialEq)]
pub struct ClothOptions {
    /// Mass. Default `AreaDensity(0.2)` kg/m^2.
    pub mass: Mass,
    /// Edge (structural) stiffness. Default `PerSpring(1000.0)` N/m.
    pub stiffness: Stiffness,
    /// Shear springs (grids: both quad diagonals). Default `Some(PerSpring(1000.0))`. Ignored for general meshes.
    pub shear: Option<Stiffness>,
    /// Bending springs. Default `Some(PerSpring(1000.0))`.
    pub bending: Option<Stiffness>,
    /// Spring damping. Default `PerSpring(0.1)` N·s/m.
    pub damping: Damping,
    /// Vertex indices (of this mesh) held fixed. Default none.
    pub pins: Vec<usize>,
    /// Aerodynamic coefficients. Default `Aero::default()`.
    pub aero: Aero,
    /// How the cloth tears. Default `None`: it never does.
    pub fracture: Option<Breakable>,
}

impl Default for ClothOptions {
    fn default() -> Self {
        ClothOptions {
            mass: Mass::AreaDensity(0.2),
            stiffness: Stiffness::PerSpring(1000.0),
            shear: Some(Stiffness::PerSpring(1000.0)),
            bending: Some(Stiffness::PerSpring(1000.0)),
            damping: Damping::PerSpring(0.1),
            pins: Vec::new(),
            aero: Aero::default(),
            fracture: None,
        }
    }
}

/// A moving pin: particles held on a prescribed path (a clamp that pulls a cloth apart, a hand that drags a
/// body). The path is a list of keys `(time [s], offset [m])`, the offset from where the particles were at the
/// start, linear between keys and held at the first key's offset before it and at the last key's after it. The
/// particles are pinned (no force moves them); each step the solver moves them by the path's change over the
/// step and gives them its velocity, which their springs' damping and contact see. Particles that fracture
/// splits off a handle particle belong to the same handle.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Handle {
    /// Keys `(time [s], offset [m])`, times strictly increasing.
    pub keys: Vec<(f64, DVec3)>,
}

impl Handle {
    /// A handle that moves at `velocity` \[m/s\] from `start` to `stop` \[s\] and holds still before and after.
    pub fn linear(velocity: DVec3, start: f64, stop: f64) -> Handle {
        Handle { keys: vec![(start, DVec3::ZERO), (stop, velocity * (stop - start))] }
    }

    /// The offset \[m\] at time `t` \[s\].
    pub fn offset(&self, t: f64) -> DVec3 {
        let k = &self.keys;
        let i = k.partition_point(|&(tk, _)| tk <= t);
        if i == 0 {
            return k[0].1;
        }
        if i == k.len() {
            return k[i - 1].1;
        }
        let ((t0, a), (t1, b)) = (k[i - 1], k[i]);
        a + (b - a) * ((t - t0) / (t1 - t0))
    }

    /// Checks the keys: at least one, finite, times strictly increasing.
    pub(super) fn check(&self) -> Result<(), ModelError> {
        if self.keys.is_empty() {
            return Err(ModelError::Parameter { name: "handle keys", value: 0.0, expected: "at least one key" });
        }
        for (k, &(t, d)) in self.keys.iter().enumerate() {
            if !t.is_finite() || !d.is_finite() {
                return Err(ModelError::Parameter { name: "handle key", value: k as f64, expected: "finite" });
            }
            if k > 0 && t <= self.keys[k - 1].0 {
                return Err(ModelError::Parameter {
                    name: "handle key time",
                    value: t,
                    expected: "strictly increasing times [s]",
                });
            }
        }
        Ok(())
    }
}

/// A handle to a body added to a builder: its index and the range of its particles and triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BodyHandle {
    /// Body index.
    pub index: usize,
    /// First particle.
    pub first_particle: usize,
    /// Number of particles.
    pub particle_count: usize,
    /// First triangle. The body's triangles follow, ordered by their sorted corners (a grid's in the grid's
    /// order), not necessarily in the order its mesh listed them.
    pub first_triangle: usize,
}

impl BodyHandle {
    /// The range of this body's particles.
    pub fn particles(&self) -> std::ops::Range<usize> {
        self.first_particle..self.first_particle + self.particle_count
    }
}
