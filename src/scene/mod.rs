//! Scene files: TOML descriptions of bodies, colliders, wind, solver and fracture settings, read by one loader
//! shared by the examples, the tests and (later) the command line. Unknown keys and bad values are errors that
//! name the key. Units are SI throughout.
//!
//! ```toml
//! [solver]
//! integrator = "symplectic_euler"   # symplectic_euler | velocity_verlet | rk4 | implicit_euler
//! dt = 5e-5                         # \[s\]
//! duration = 2.0                    # \[s\]
//! gravity = [0.0, -9.81, 0.0]       # \[m/s^2\]
//! damping_model = "projected"       # projected (along springs) | unprojected (the seed's eq. 2)
//!
//! [fracture]                        # optional: the fracture pass's settings
//! averaged_window = 0.002           # \[s\]; omit for the instantaneous trigger
//! max_events_per_step = 8
//! splits_per_body = 1               # spring-mode splits per body per step: a crack advances an edge a step
//! nucleation_interval = 0.005       # \[s\] between new cracks in a body (default: its wave-crossing time)
//!
//! [[body]]
//! shape = "icosphere"               # icosphere | cuboid | obj | cloth
//! radius = 0.25                     # \[m\]
//! subdivisions = 3
//! position = [0.0, 1.5, 0.0]        # \[m\]
//! velocity = [0.5, 0.0, 0.0]        # \[m/s\]
//! mass = 0.5                        # \[kg\]
//! stiffness = 2500.0                # membrane E·h \[N/m\]
//! pressure = 3000.0                 # \[Pa\]; 0: no gas
//! strain_limit = 0.3                # optional: spring mode
//! load_limit = 4.0                  # optional: core mode \[N\]
//! tear_strength = 450.0             # optional: spring mode, force per unit length of crack \[N/m\]
//! inflow = 60.0                     # optional: a pump, nRT added per second while whole \[Pa·m³/s\]
//! contact = true                    # optional: collide with the other bodies in contact (default false)
//! self_collision = false            # optional: and with itself (implies contact)
//! thickness = 0.01                  # optional \[m\]: gap kept (default 0.2 × mean edge length)
//! contact_friction = 0.3            # optional: Coulomb coefficient
//!
//! [[body]]                          # an open sheet: no gas
//! shape = "cloth"
//! resolution = [32, 32]             # particles across and down
//! width = 1.0                       # \[m\]; the particles are width / (across - 1) apart
//! orientation = "vertical"          # vertical (in the xy plane, facing +z) | horizontal (in the xz plane)
//! position = [0.0, 1.6, 0.0]        # \[m\] the middle of the top edge (vertical) or of the sheet (horizontal)
//! pin = "top_corners"               # top_corners | top_edge | bottom_edge | left_edge | right_edge | none
//! cuts = [[15, 16]]                 # optional: springs (vertex pairs) cut before the run, a notch
//!
//! [[body.handle]]                   # optional, any number: a moving pin
//! pin = "left_edge"                 # cloth edges as for `pin`, or `vertices = [0, 1, ...]`
//! velocity = [-0.05, 0.0, 0.0]      # \[m/s\] from `start` to `stop` \[s\]; or `path = [[t, x, y, z], ...]`
//! start = 0.2
//! stop = 2.0
//! mass = 0.3                        # \[kg\]
//! stiffness = 400.0                 # structural springs, membrane E·h \[N/m\]
//! shear = 100.0                     # optional: shear springs \[N/m\]
//! bending = 20.0                    # optional: bending springs \[N/m\]
//!
//! [wind]
//! velocity = [0.0, 0.0, 4.0]        # \[m/s\] mean wind
//! gust_amplitude = 0.5              # optional: fraction of the mean speed (default 0.5)
//! gust_frequency = 0.5              # optional \[Hz\] (default 0.5)
//! gust_wavelength = 4.0             # optional \[m\] (default 4)
//! crosswind = 0.2                   # optional: fraction of the mean speed (default 0.2)
//! air_density = 1.225               # optional \[kg/m^3\]
//!
//! [[collider]]
//! shape = "ball"                    # ground | plane | ball | cuboid | capsule
//! center = [0.0, 0.3, 0.0]
//! radius = 0.3
//! ```
//!
//! Any key can be overridden without editing the file ([`Override`], [`Scene::load_with`]), and a scene run
//! headless comes to an [`Outcome`] ([`Scene::run_headless`]; many at once in parallel with [`run_all`]).

use crate::*;
use glam::{DVec3, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod format;
mod outcome;
mod overrides;

pub use format::*;
pub use outcome::{Job, Outcome, advance_all, run_all, run_all_reporting};
pub use overrides::{Override, parse_value};

/// Core parameter names that differ from a body's scene keys.
const BODY_KEYS: &[(&str, &str)] = &[
    ("damping", "damping_ratio"),
    ("fracture.strain_limit", "strain_limit"),
    ("fracture.load_limit", "load_limit"),
    ("fracture.tear_strength", "tear_strength"),
    ("spacing", "width"),
    ("gas_inflow", "inflow"),
];

/// A scene that could not be read or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read scene {path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The TOML is malformed, has an unknown key, or a value of the wrong type (the message names the key).
    #[error("scene {path}: {message}")]
    Parse {
        /// The path.
        path: PathBuf,
        /// What and where.
        message: String,
    },
    /// A value is out of range.
    #[error("scene {path}: `{key}` {message}")]
    Value {
        /// The path.
        path: PathBuf,
        /// The offending key.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A mesh could not be loaded or the model could not be built.
    #[error("scene {path}: {source}")]
    Model {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// A parsed scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// A title for output.
    #[serde(default)]
    pub title: String,
    /// Solver settings.
    #[serde(default)]
    pub solver: SolverSection,
    /// Fracture pass settings.
    #[serde(default)]
    pub fracture: FractureSection,
    /// Bodies.
    #[serde(default, rename = "body")]
    pub bodies: Vec<BodySection>,
    /// Colliders.
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderSection>,
    /// A walled room: a floor at y = 0 and four walls at ± this half width \[m\].
    #[serde(default)]
    pub room_half_width: Option<f32>,
    /// Wind.
    #[serde(default)]
    pub wind: Option<WindSection>,
    /// Where the file was read from (set by [`Scene::load`]).
    #[serde(skip)]
    pub path: PathBuf,
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}
fn f3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

impl Scene {
    /// Reads and parses a scene file (nothing is built yet).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref().to_path_buf();
        let text = std::fs::read_to_string(&path).map_err(|source| SceneError::Io { path: path.clone(), source })?;
        let mut scene = Scene::parse(&text, &path)?;
        scene.path = path;
        Ok(scene)
    }

    /// Parses scene text; `path` only names it in errors and resolves relative mesh files.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        let mut scene: Scene =
            toml::from_str(text).map_err(|e| SceneError::Parse { path: path.into(), message: e.to_string() })?;
        scene.path = path.into();
        scene.validate()?;
        Ok(scene)
    }

    fn bad(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Value { path: self.path.clone(), key: key.into(), message: message.into() }
    }

    fn validate(&self) -> Result<(), SceneError> {
        if !(self.solver.dt.is_finite() && self.solver.dt > 0.0) {
            return Err(self.bad("solver.dt", format!("must be > 0, got {}", self.solver.dt)));
        }
        if !(self.solver.duration.is_finite() && self.solver.duration >= 0.0) {
            return Err(self.bad("solver.duration", format!("must be >= 0, got {}", self.solver.duration)));
        }
        if let Err(StepError::Config(m)) = self.solver_config().validate() {
            return Err(self.bad("solver", m));
        }
        self.fracture_config().validate().map_err(|e| self.core_error("fracture", e, &[]))?;
        Ok(())
    }

    /// The integrator named in `[solver]`.
    pub fn integrator(&self) -> Result<Integrator, SceneError> {
        Ok(self.solver.integrator.into())
    }

    /// The solver settings of `[solver]` (checked by the core on the first step).
    pub fn solver_config(&self) -> SolverConfig {
        SolverConfig { substep_safety: self.solver.substep_safety, ..SolverConfig::with(self.solver.integrator.into()) }
    }

    /// A core error as a scene error naming the key: `prefix.name`, with the core's parameter names that differ
    /// from the scene's keys renamed.
    fn core_error(&self, prefix: &str, e: ModelError, rename: &[(&str, &'static str)]) -> SceneError {
        match e.parameter(rename) {
            Some((key, message)) => self.bad(format!("{prefix}.{key}"), message),
            None => self.bad(prefix, e.to_string()),
        }
    }

    /// The fracture settings.
    pub fn fracture_config(&self) -> FractureConfig {
        let d = FractureConfig::default();
        let f = &self.fracture;
        FractureConfig {
            trigger: f.averaged_window.map_or(Trigger::Instant, |window| Trigger::Averaged { window }),
            max_events_per_step: f.max_events_per_step.unwrap_or(d.max_events_per_step),
            discharge_coefficient: f.discharge_coefficient.unwrap_or(d.discharge_coefficient),
            gas_density: f.gas_density.unwrap_or(d.gas_density),
            start_time: f.start_time.unwrap_or(d.start_time),
            splits_per_body: f.splits_per_body.unwrap_or(d.splits_per_body),
            nucleation_interval: f.nucleation_interval.or(d.nucleation_interval),
            ..d
        }
    }

    /// The model builder of this scene.
    pub fn builder(&self) -> Result<ModelBuilder, SceneError> {
        let model_err =
            |e: Box<dyn std::error::Error + Send + Sync>| SceneError::Model { path: self.path.clone(), source: e };
        let mut b = ModelBuilder::new();
        b.gravity(v3(self.solver.gravity)).map_err(|e| self.core_error("solver", e, &[]))?;
        b.damping_model(match self.solver.damping_model {
            DampingName::Projected => DampingModel::Projected,
            DampingName::Unprojected => DampingModel::Unprojected,
        });
        for (k, body) in self.bodies.iter().enumerate() {
            let key = |f: &str| format!("body[{k}].{f}");
            if body.shape == BodyShape::Cloth {
                self.add_cloth(&mut b, k, body)?;
                continue;
            }
            for (f, v) in [
                ("resolution", body.resolution.is_some()),
                ("width", body.width.is_some()),
                ("orientation", body.orientation.is_some()),
                ("pin", body.pin.is_some()),
                ("shear", body.shear.is_some()),
            ] {
                if v {
                    return Err(self.bad(key(f), format!("applies to a cloth only, not a {:?}", body.shape)));
                }
            }
            let given = [
                ("radius", body.radius.is_some()),
                ("subdivisions", body.subdivisions.is_some()),
                ("half_extents", body.half_extents.is_some()),
                ("cells", body.cells.is_some()),
                ("file", body.file.is_some()),
            ];
            let keys: &[&str] = match body.shape {
                BodyShape::Icosphere => &["radius", "subdivisions"],
                BodyShape::Cuboid => &["half_extents", "cells"],
                BodyShape::Obj | BodyShape::Cloth => &["file"],
            };
            if let Some((f, _)) = given.iter().find(|(f, g)| *g && !keys.contains(f)) {
                return Err(self.bad(key(f), format!("does not apply to a {:?} body; remove the key", body.shape)));
            }
            let mesh = match body.shape {
                BodyShape::Icosphere => {
                    let r = body.radius.ok_or_else(|| self.bad(key("radius"), "is required for an icosphere"))?;
                    if !(r.is_finite() && r > 0.0) {
                        return Err(self.bad(key("radius"), format!("must be > 0, got {r}")));
                    }
                    let sub = body.subdivisions.unwrap_or(3);
                    if sub > 7 {
                        return Err(self.bad(key("subdivisions"), format!("at most 7, got {sub}")));
                    }
                    Mesh::icosphere(r, sub)
                }
                BodyShape::Cuboid => {
                    let h =
                        body.half_extents.ok_or_else(|| self.bad(key("half_extents"), "is required for a cuboid"))?;
                    Mesh::cuboid(v3(h), body.cells.unwrap_or(4).max(1))
                }
                BodyShape::Obj => {
                    let f = body.file.as_ref().ok_or_else(|| self.bad(key("file"), "is required for an obj"))?;
                    let p = self.path.parent().unwrap_or(Path::new(".")).join(f);
                    Mesh::load_obj(&p, Some(1e-6)).map_err(|e| model_err(Box::new(e)))?
                }
                BodyShape::Cloth => unreachable!("cloths are built above"),
            };
            let fracture = body.breakable();
            let opts = SoftBodyOptions {
                mass: Mass::Total(body.mass),
                stiffness: Stiffness::Membrane(body.stiffness),
                damping: Damping::Ratio(body.damping_ratio),
                bending: body.bending.map(Stiffness::Membrane),
                // 0: no gas; anything else goes to the core, which rejects NaN and negative pressures.
                gas: match body.pressure.unwrap_or(2000.0) {
                    0.0 => Gas::None,
                    p => Gas::Pressure(p),
                },
                gas_inflow: body.inflow.unwrap_or(0.0),
                velocity: v3(body.velocity),
                fracture,
                ..Default::default()
            };
            let h = b
                .add_soft_body(&mesh.translated(v3(body.position)), &opts)
                .map_err(|e| self.core_error(&format!("body[{k}]"), e, BODY_KEYS))?;
            self.set_contact(&mut b, k, body, h.index)?;
            self.add_handles(&mut b, k, body, h, None)?;
        }
        if let Some(h) = self.room_half_width {
            if !(h.is_finite() && h > 0.0) {
                return Err(self.bad("room_half_width", format!("must be > 0, got {h}")));
            }
            crate::scenes::room(&mut b, h).map_err(|e| self.core_error("room_half_width", e, &[]))?;
        }
        for (k, c) in self.colliders.iter().enumerate() {
            let prefix = format!("collider[{k}]");
            let key = |f: &str| format!("{prefix}.{f}");
            let given = [
                ("height", c.height.is_some()),
                ("point", c.point.is_some()),
                ("normal", c.normal.is_some()),
                ("center", c.center.is_some()),
                ("radius", c.radius.is_some()),
                ("half_extents", c.half_extents.is_some()),
                ("a", c.a.is_some()),
                ("b", c.b.is_some()),
            ];
            let (keys, position): (&[&str], &str) = match c.shape {
                ColliderShape::Ground => (&["height"], "height"),
                ColliderShape::Plane => (&["point", "normal"], "point"),
                ColliderShape::Ball => (&["center", "radius"], "center"),
                ColliderShape::Cuboid => (&["center", "half_extents"], "center"),
                ColliderShape::Capsule => (&["a", "b", "radius"], "a"),
            };
            if let Some((f, _)) = given.iter().find(|(f, g)| *g && !keys.contains(f)) {
                return Err(self.bad(key(f), format!("does not apply to a {}; remove the key", c.shape.name())));
            }
            let need3 = |v: Option<[f32; 3]>, f: &str| {
                v.map(f3).ok_or_else(|| self.bad(key(f), format!("is required for a {}", c.shape.name())))
            };
            let need = |v: Option<f32>, f: &str| {
                v.ok_or_else(|| self.bad(key(f), format!("is required for a {}", c.shape.name())))
            };
            let col = match c.shape {
                ColliderShape::Ground => Collider::ground(c.height.unwrap_or(0.0)),
                ColliderShape::Plane => Collider::plane(need3(c.point, "point")?, need3(c.normal, "normal")?),
                ColliderShape::Ball => Collider::ball(need3(c.center, "center")?, need(c.radius, "radius")?),
                ColliderShape::Cuboid => {
                    Collider::cuboid(need3(c.center, "center")?, need3(c.half_extents, "half_extents")?)
                }
                ColliderShape::Capsule => {
                    Collider::capsule(need3(c.a, "a")?, need3(c.b, "b")?, need(c.radius, "radius")?)
                }
            };
            b.add_collider(col.with_restitution(c.restitution).with_friction(c.friction))
                .map_err(|e| self.core_error(&prefix, e, &[("position", position)]))?;
        }
        if let Some(w) = &self.wind {
            let d = WindField::default();
            let wind = WindField {
                velocity: v3(w.velocity),
                gust_amplitude: w.gust_amplitude.unwrap_or(d.gust_amplitude),
                gust_frequency: w.gust_frequency.unwrap_or(d.gust_frequency),
                gust_wavelength: w.gust_wavelength.unwrap_or(d.gust_wavelength),
                crosswind: w.crosswind.unwrap_or(d.crosswind),
                air_density: w.air_density.unwrap_or(d.air_density),
            };
            b.wind(wind).map_err(|e| self.core_error("wind", e, &[]))?;
        }
        Ok(b)
    }

    fn add_cloth(&self, b: &mut ModelBuilder, k: usize, body: &BodySection) -> Result<(), SceneError> {
        let key = |f: &str| format!("body[{k}].{f}");
        let [nx, ny] = body.resolution.ok_or_else(|| self.bad(key("resolution"), "is required for a cloth"))?;
        if nx < 2 || ny < 2 || nx * ny > 4 << 20 {
            return Err(self.bad(key("resolution"), format!("needs 2..=2048 each way, got [{nx}, {ny}]")));
        }
        let width = body.width.unwrap_or(1.0); // the core checks the spacing it gives (reported as `width`)
        if body.pressure.is_some_and(|p| p != 0.0) {
            return Err(self.bad(key("pressure"), "an open cloth holds no gas; remove the key"));
        }
        for (f, set) in [
            ("radius", body.radius.is_some()),
            ("subdivisions", body.subdivisions.is_some()),
            ("half_extents", body.half_extents.is_some()),
            ("cells", body.cells.is_some()),
            ("file", body.file.is_some()),
            ("sealed", body.sealed),
            ("inflow", body.inflow.is_some()),
        ] {
            if set {
                return Err(self.bad(key(f), "does not apply to a cloth"));
            }
        }
        let spacing = width / (nx - 1) as f64;
        let o = v3(body.position);
        let vertical = body.orientation.unwrap_or_default() == Orientation::Vertical;
        let height = spacing * (ny - 1) as f64;
        let place = move |q: DVec3| {
            if vertical {
                o + DVec3::new(q.x - 0.5 * width, q.y, 0.0)
            } else {
                o + DVec3::new(q.x - 0.5 * width, 0.0, -q.y - 0.5 * height)
            }
        };
        let pins = body.pin.unwrap_or_default().particles(nx, ny);
        let opts = ClothOptions {
            mass: Mass::Total(body.mass),
            stiffness: Stiffness::Membrane(body.stiffness),
            shear: body.shear.map(Stiffness::Membrane),
            bending: body.bending.map(Stiffness::Membrane),
            damping: Damping::Ratio(body.damping_ratio),
            pins,
            aero: Aero::default(),
            fracture: body.breakable(),
        };
        if body.velocity != [0.0; 3] {
            return Err(self.bad(key("velocity"), "a cloth starts at rest; remove the key"));
        }
        let h = b
            .add_cloth_grid(nx, ny, spacing, place, &opts)
            .map_err(|e| self.core_error(&format!("body[{k}]"), e, BODY_KEYS))?;
        self.set_contact(b, k, body, h.index)?;
        self.add_handles(b, k, body, h, Some([nx, ny]))
    }

    /// The body's `[[body.handle]]` tables (moving pins). `grid`: a cloth's resolution, for `pin`.
    fn add_handles(
        &self,
        b: &mut ModelBuilder,
        k: usize,
        body: &BodySection,
        h: BodyHandle,
        grid: Option<[usize; 2]>,
    ) -> Result<(), SceneError> {
        for (j, hs) in body.handle.iter().enumerate() {
            let key = |f: &str| format!("body[{k}].handle[{j}].{f}");
            let mut particles = match (hs.pin, &hs.vertices, grid) {
                (Some(_), Some(_), _) => return Err(self.bad(key("pin"), "give `pin` or `vertices`, not both")),
                (Some(p), None, Some([nx, ny])) => p.particles(nx, ny),
                (Some(_), None, None) => {
                    return Err(self.bad(key("pin"), "names cloth edges; give `vertices` for this body"));
                }
                (None, Some(v), _) => v.clone(),
                (None, None, _) => return Err(self.bad(key("pin"), "is required (or `vertices`)")),
            };
            if let Some(&bad) = particles.iter().find(|&&i| i >= h.particle_count) {
                return Err(
                    self.bad(key("vertices"), format!("{bad} is past the body's {} vertices", h.particle_count))
                );
            }
            particles.iter_mut().for_each(|i| *i += h.first_particle);
            let handle = match (hs.velocity, &hs.path) {
                (Some(_), Some(_)) => return Err(self.bad(key("path"), "give `velocity` or `path`, not both")),
                (Some(v), None) => {
                    let stop = hs.stop.unwrap_or(self.solver.duration);
                    if !(hs.start.is_finite() && stop.is_finite() && stop > hs.start) {
                        return Err(self.bad(key("stop"), format!("must be after `start` ({}), got {stop}", hs.start)));
                    }
                    Handle::linear(v3(v), hs.start, stop)
                }
                (None, Some(p)) => Handle { keys: p.iter().map(|&[t, x, y, z]| (t, DVec3::new(x, y, z))).collect() },
                (None, None) => return Err(self.bad(key("velocity"), "is required (or `path`)")),
            };
            b.add_handle(&particles, handle)
                .map_err(|e| self.core_error(&format!("body[{k}].handle[{j}]"), e, &[("handle key time", "path")]))?;
        }
        Ok(())
    }

    /// The body's `contact`, `self_collision`, `thickness` and `contact_friction` keys.
    fn set_contact(&self, b: &mut ModelBuilder, k: usize, body: &BodySection, index: usize) -> Result<(), SceneError> {
        let Some(c) = body.contact() else {
            for (f, set) in
                [("thickness", body.thickness.is_some()), ("contact_friction", body.contact_friction.is_some())]
            {
                if set {
                    return Err(
                        self.bad(format!("body[{k}].{f}"), "needs `contact = true` (or `self_collision = true`)")
                    );
                }
            }
            return Ok(());
        };
        b.set_contact(index, c).map_err(|e| {
            self.core_error(
                &format!("body[{k}]"),
                e,
                &[("contact.thickness", "thickness"), ("contact.friction", "contact_friction")],
            )
        })?;
        Ok(())
    }

    /// Builds the world: model, state, solver and fracture pass.
    pub fn world<R: Real>(&self) -> Result<World<R>, SceneError> {
        let model = self
            .builder()?
            .finalize::<R>()
            .map_err(|e| SceneError::Model { path: self.path.clone(), source: Box::new(e) })?;
        let mut world = World::new(model, self.solver_config()).with_fracture(self.fracture_config());
        for (k, body) in self.bodies.iter().enumerate() {
            let key = || format!("body[{k}].cuts");
            if body.cuts.is_empty() {
                continue;
            }
            let owner = &world.model.particle_body;
            let first = owner.iter().position(|&b| b == k as u32).unwrap_or(0);
            let count = owner.iter().filter(|&&b| b == k as u32).count();
            for &[i, j] in &body.cuts {
                if i.max(j) >= count {
                    return Err(self.bad(key(), format!("[{i}, {j}]: the body has {count} vertices")));
                }
                let sp = fissure_core::fracture::spring_between(&world.model, (first + i) as u32, (first + j) as u32);
                let Some(sp) = sp else {
                    return Err(self.bad(key(), format!("[{i}, {j}]: no spring joins these vertices")));
                };
                let broken = world.break_spring(sp as usize).map_err(|e| self.bad(key(), e.to_string()))?;
                if broken.is_empty() {
                    return Err(self.bad(key(), format!("[{i}, {j}]: the spring cannot be cut (too short?)")));
                }
            }
            world.events.clear();
        }
        Ok(world)
    }
}
