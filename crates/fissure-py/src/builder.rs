//! `ModelBuilder`: bodies, cloths, colliders, gravity and wind, with keyword-only options.

use crate::*;

/// Collects bodies, colliders, gravity and wind; `finalize()` gives a `Model`.
#[pyclass(module = "fissure._fissure")]
pub struct ModelBuilder {
    pub(crate) inner: RBuilder,
}

pub(crate) fn mass_from(
    total: Option<f64>,
    area_density: Option<f64>,
    per_particle: Option<f64>,
    default: Mass,
) -> PyResult<Mass> {
    match (total, area_density, per_particle) {
        (None, None, None) => Ok(default),
        (Some(m), None, None) => Ok(Mass::Total(m)),
        (None, Some(d), None) => Ok(Mass::AreaDensity(d)),
        (None, None, Some(p)) => Ok(Mass::PerParticle(p)),
        _ => Err(PyValueError::new_err("give at most one of mass, area_density, particle_mass")),
    }
}

pub(crate) fn stiffness_from(
    membrane: Option<f64>,
    per_spring: Option<f64>,
    default: Stiffness,
) -> PyResult<Stiffness> {
    match (membrane, per_spring) {
        (None, None) => Ok(default),
        (Some(e), None) => Ok(Stiffness::Membrane(e)),
        (None, Some(k)) => Ok(Stiffness::PerSpring(k)),
        _ => Err(PyValueError::new_err("give at most one of stiffness (membrane E·h) and spring_stiffness")),
    }
}

pub(crate) fn damping_from(ratio: Option<f64>, per_spring: Option<f64>, default: Damping) -> PyResult<Damping> {
    match (ratio, per_spring) {
        (None, None) => Ok(default),
        (Some(z), None) => Ok(Damping::Ratio(z)),
        (None, Some(d)) => Ok(Damping::PerSpring(d)),
        _ => Err(PyValueError::new_err("give at most one of damping_ratio and spring_damping")),
    }
}

pub(crate) fn handle_dict<'py>(py: Python<'py>, h: fissure::BodyHandle) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("index", h.index)?;
    d.set_item("first_particle", h.first_particle)?;
    d.set_item("particle_count", h.particle_count)?;
    d.set_item("first_triangle", h.first_triangle)?;
    Ok(d)
}

/// Adds `c` with its material; the core checks every value, and its error names the keyword (`position` is
/// called `position_arg` here: `center`, `point` or `height`).
pub(crate) fn add_collider(
    b: &mut RBuilder,
    c: Collider,
    position_arg: &'static str,
    (restitution, friction, margin): (f32, f32, f32),
) -> PyResult<()> {
    let c = c.with_restitution(restitution).with_friction(friction).with_margin(margin);
    b.add_collider(c).map_err(|e| core_err(e, &[("position", position_arg)]))?;
    Ok(())
}

#[pymethods]
impl ModelBuilder {
    /// An empty builder with `gravity` \[m/s^2\].
    #[new]
    #[pyo3(signature = (*, gravity = (0.0, -9.81, 0.0), damping_model = DampingModel::PROJECTED))]
    fn new(gravity: (f64, f64, f64), damping_model: DampingModel) -> PyResult<Self> {
        let mut inner = RBuilder::new();
        inner.gravity(vec3("gravity", gravity)?).map_err(|e| core_err(e, &[]))?;
        inner.damping_model(match damping_model {
            DampingModel::PROJECTED => RDampingModel::Projected,
            DampingModel::UNPROJECTED => RDampingModel::Unprojected,
        });
        Ok(ModelBuilder { inner })
    }

    /// Adds one particle of `mass` \[kg\] (0 pins it); returns its index.
    #[pyo3(signature = (position, velocity = (0.0, 0.0, 0.0), *, mass))]
    fn add_particle(&mut self, position: (f64, f64, f64), velocity: (f64, f64, f64), mass: f64) -> PyResult<usize> {
        self.inner.add_particle(vec3("position", position)?, vec3("velocity", velocity)?, mass).map_err(value_err)
    }

    /// Adds a spring [N/m, N·s/m] between particles `i` and `j` at their current distance; returns its index.
    #[pyo3(signature = (i, j, *, stiffness, damping = 0.0))]
    fn add_spring(&mut self, i: usize, j: usize, stiffness: f64, damping: f64) -> PyResult<usize> {
        self.inner.add_spring(i, j, stiffness, damping).map_err(value_err)
    }

    /// Adds a closed soft body with gas. Units: kg, kg/m^2, N/m, N·s/m, Pa, J, m/s.
    #[pyo3(signature = (mesh, *, mass = None, area_density = None, particle_mass = None, stiffness = None,
        spring_stiffness = None, damping_ratio = None, spring_damping = None, bending = None, pressure = None,
        gas_amount = None, external_pressure = 0.0, velocity = (0.0, 0.0, 0.0), drag = 0.0, lift = 0.0,
        reorient = true, strain_limit = None, load_limit = None, sealed = false, tear_strength = None,
        gas_inflow = 0.0))]
    #[allow(clippy::too_many_arguments)]
    fn add_soft_body<'py>(
        &mut self,
        py: Python<'py>,
        mesh: &Mesh,
        mass: Option<f64>,
        area_density: Option<f64>,
        particle_mass: Option<f64>,
        stiffness: Option<f64>,
        spring_stiffness: Option<f64>,
        damping_ratio: Option<f64>,
        spring_damping: Option<f64>,
        bending: Option<f64>,
        pressure: Option<f64>,
        gas_amount: Option<f64>,
        external_pressure: f64,
        velocity: (f64, f64, f64),
        drag: f64,
        lift: f64,
        reorient: bool,
        strain_limit: Option<f64>,
        load_limit: Option<f64>,
        sealed: bool,
        tear_strength: Option<f64>,
        gas_inflow: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = fissure::SoftBodyOptions::default();
        let gas = match (pressure, gas_amount) {
            (None, None) => d.gas,
            (Some(0.0), None) => Gas::None,
            (Some(p), None) => Gas::Pressure(p),
            (None, Some(0.0)) => Gas::None,
            (None, Some(a)) => Gas::Amount(a),
            _ => return Err(PyValueError::new_err("give at most one of pressure and gas_amount")),
        };
        let opts = fissure::SoftBodyOptions {
            mass: mass_from(mass, area_density, particle_mass, d.mass)?,
            stiffness: stiffness_from(stiffness, spring_stiffness, d.stiffness)?,
            damping: damping_from(damping_ratio, spring_damping, d.damping)?,
            bending: bending.map(Stiffness::Membrane),
            gas,
            gas_inflow,
            external_pressure,
            aero: Aero { drag, lift },
            reorient,
            velocity: vec3("velocity", velocity)?,
            fracture: breakable_from(strain_limit, load_limit, tear_strength, sealed),
        };
        let h = self.inner.add_soft_body(&mesh.inner, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// Adds a cloth from any mesh (edge springs, optional bending springs, pins by vertex index).
    #[pyo3(signature = (mesh, *, mass = None, area_density = None, particle_mass = None, stiffness = None,
        spring_stiffness = None, bending = None, damping_ratio = None, spring_damping = None, pins = vec![],
        drag = 1.0, lift = 0.5, strain_limit = None, load_limit = None, tear_strength = None))]
    #[allow(clippy::too_many_arguments)]
    fn add_cloth<'py>(
        &mut self,
        py: Python<'py>,
        mesh: &Mesh,
        mass: Option<f64>,
        area_density: Option<f64>,
        particle_mass: Option<f64>,
        stiffness: Option<f64>,
        spring_stiffness: Option<f64>,
        bending: Option<f64>,
        damping_ratio: Option<f64>,
        spring_damping: Option<f64>,
        pins: Vec<usize>,
        drag: f64,
        lift: f64,
        strain_limit: Option<f64>,
        load_limit: Option<f64>,
        tear_strength: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = fissure::ClothOptions::default();
        let opts = fissure::ClothOptions {
            mass: mass_from(mass, area_density, particle_mass, d.mass)?,
            stiffness: stiffness_from(stiffness, spring_stiffness, d.stiffness)?,
            shear: None,
            bending: bending.map(Stiffness::PerSpring).or(d.bending),
            damping: damping_from(damping_ratio, spring_damping, d.damping)?,
            pins,
            aero: Aero { drag, lift },
            fracture: breakable_from(strain_limit, load_limit, tear_strength, false),
        };
        let h = self.inner.add_cloth(&mesh.inner, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// Adds an `nx × ny` cloth grid with structural, shear and bending springs \[N/m\], placed with its top-left
    /// corner at `origin`, x to the right, rows along `down` (default -y), in the plane they span.
    #[pyo3(signature = (nx, ny, spacing, *, origin = (0.0, 0.0, 0.0), down = (0.0, -1.0, 0.0),
        mass = None, area_density = None, particle_mass = None, spring_stiffness = 1000.0, shear = 1000.0,
        bending = 1000.0, damping_ratio = None, spring_damping = None, pins = vec![], drag = 1.0, lift = 0.5,
        strain_limit = None, load_limit = None, tear_strength = None))]
    #[allow(clippy::too_many_arguments)]
    fn add_cloth_grid<'py>(
        &mut self,
        py: Python<'py>,
        nx: usize,
        ny: usize,
        spacing: f64,
        origin: (f64, f64, f64),
        down: (f64, f64, f64),
        mass: Option<f64>,
        area_density: Option<f64>,
        particle_mass: Option<f64>,
        spring_stiffness: f64,
        shear: f64,
        bending: f64,
        damping_ratio: Option<f64>,
        spring_damping: Option<f64>,
        pins: Vec<usize>,
        drag: f64,
        lift: f64,
        strain_limit: Option<f64>,
        load_limit: Option<f64>,
        tear_strength: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = fissure::ClothOptions::default();
        let o = vec3("origin", origin)?;
        let down = vec3("down", down)?;
        if down.length() == 0.0 || down.x.abs() > 1e-12 {
            return Err(PyValueError::new_err(format!("down must be a non-zero vector with x = 0, got {down:?}")));
        }
        let down = down.normalize();
        let opts = fissure::ClothOptions {
            mass: mass_from(mass, area_density, particle_mass, d.mass)?,
            stiffness: Stiffness::PerSpring(spring_stiffness),
            shear: (shear > 0.0).then_some(Stiffness::PerSpring(shear)),
            bending: (bending > 0.0).then_some(Stiffness::PerSpring(bending)),
            damping: damping_from(damping_ratio, spring_damping, d.damping)?,
            pins,
            aero: Aero { drag, lift },
            fracture: breakable_from(strain_limit, load_limit, tear_strength, false),
        };
        // Grid rows run along -y in the mesh generator: map (x, -row) to origin + x X + row down.
        let place = |p: DVec3| o + DVec3::X * p.x + down * (-p.y);
        let h = self.inner.add_cloth_grid(nx, ny, spacing, place, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// Moves `particles` (indices into the model) on a path: a moving pin. Either `velocity` \[m/s\] from
    /// `start` to `stop` \[s\] (still before and after), or `path`, a list of `(time, (x, y, z))` offsets \[s, m\]
    /// from the start position, linear between. The particles are pinned; returns the handle's index.
    #[pyo3(signature = (particles, *, velocity = None, start = 0.0, stop = None, path = None))]
    fn add_handle(
        &mut self,
        particles: Vec<usize>,
        velocity: Option<(f64, f64, f64)>,
        start: f64,
        stop: Option<f64>,
        path: Option<Vec<PathKey>>,
    ) -> PyResult<usize> {
        let handle = match (velocity, stop, path) {
            (Some(v), Some(stop), None) => {
                if !(start.is_finite() && stop.is_finite() && stop > start) {
                    return Err(PyValueError::new_err(format!("stop must be after start ({start} s), got {stop}")));
                }
                fissure::Handle::linear(vec3("velocity", v)?, start, stop)
            }
            (Some(_), None, None) => return Err(PyValueError::new_err("velocity needs stop [s]")),
            (None, None, Some(p)) => {
                let keys = p.into_iter().map(|(t, d)| Ok((t, vec3("path", d)?))).collect::<PyResult<Vec<_>>>()?;
                fissure::Handle { keys }
            }
            _ => return Err(PyValueError::new_err("give velocity (with stop) or path, not both")),
        };
        self.inner
            .add_handle(&particles, handle)
            .map_err(|e| core_err(e, &[("handle particle", "particles"), ("handle key time", "path")]))
    }

    /// Switches contact on for body `body` (the `index` of the dict an `add_*` call returned): its surface
    /// collides with every other body in contact and, with `self_collision`, with itself. `thickness` \[m\] is the
    /// gap kept (default 0.2 × the body's mean edge length); `friction` the Coulomb coefficient.
    #[pyo3(signature = (body, *, thickness = None, self_collision = false, friction = 0.3))]
    fn set_contact(
        &mut self,
        body: usize,
        thickness: Option<f64>,
        self_collision: bool,
        friction: f64,
    ) -> PyResult<()> {
        let c = fissure::Contact { thickness, self_collision, friction };
        self.inner.set_contact(body, c).map_err(|e| {
            core_err(
                e,
                &[("contact.thickness", "thickness"), ("contact.friction", "friction"), ("contact body", "body")],
            )
        })?;
        Ok(())
    }

    /// The ground `y = height`.
    #[pyo3(signature = (height = 0.0, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_ground(&mut self, height: f32, restitution: f32, friction: f32, margin: f32) -> PyResult<()> {
        add_collider(&mut self.inner, Collider::ground(height), "height", (restitution, friction, margin))
    }

    /// A wall: the half-space behind the plane through `point` with outward `normal`.
    #[pyo3(signature = (point, normal, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_plane(
        &mut self,
        point: (f64, f64, f64),
        normal: (f64, f64, f64),
        restitution: f32,
        friction: f32,
        margin: f32,
    ) -> PyResult<()> {
        let c = Collider::plane(f32x3("point", point)?, f32x3("normal", normal)?);
        add_collider(&mut self.inner, c, "point", (restitution, friction, margin))
    }

    /// A solid ball collider, optionally moving at `velocity` \[m/s\].
    #[pyo3(signature = (center, radius, *, velocity = (0.0, 0.0, 0.0), restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_ball(
        &mut self,
        center: (f64, f64, f64),
        radius: f32,
        velocity: (f64, f64, f64),
        restitution: f32,
        friction: f32,
        margin: f32,
    ) -> PyResult<()> {
        let c =
            Collider::ball(f32x3("center", center)?, radius).with_velocity(f32x3("velocity", velocity)?, Vec3::ZERO);
        add_collider(&mut self.inner, c, "center", (restitution, friction, margin))
    }

    /// A solid axis-aligned box collider.
    #[pyo3(signature = (center, half_extents, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_cuboid(
        &mut self,
        center: (f64, f64, f64),
        half_extents: (f64, f64, f64),
        restitution: f32,
        friction: f32,
        margin: f32,
    ) -> PyResult<()> {
        let c = Collider::cuboid(f32x3("center", center)?, f32x3("half_extents", half_extents)?);
        add_collider(&mut self.inner, c, "center", (restitution, friction, margin))
    }

    /// A solid capsule collider between `a` and `b`.
    #[pyo3(signature = (a, b, radius, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_capsule(
        &mut self,
        a: (f64, f64, f64),
        b: (f64, f64, f64),
        radius: f32,
        restitution: f32,
        friction: f32,
        margin: f32,
    ) -> PyResult<()> {
        let c = Collider::capsule(f32x3("a", a)?, f32x3("b", b)?, radius);
        add_collider(&mut self.inner, c, "a", (restitution, friction, margin))
    }

    /// A solid triangle-mesh collider (the mesh must be closed).
    #[pyo3(signature = (mesh, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_mesh_collider(&mut self, mesh: &Mesh, restitution: f32, friction: f32, margin: f32) -> PyResult<()> {
        let c = Collider::trimesh(&mesh.inner).map_err(value_err)?;
        add_collider(&mut self.inner, c, "mesh", (restitution, friction, margin))
    }

    /// A gusty wind [m/s, fraction, Hz, m, fraction, kg/m^3].
    #[pyo3(signature = (velocity, *, gust_amplitude = 0.5, gust_frequency = 0.5, gust_wavelength = 4.0,
        crosswind = 0.2, air_density = 1.225))]
    fn set_wind(
        &mut self,
        velocity: (f64, f64, f64),
        gust_amplitude: f64,
        gust_frequency: f64,
        gust_wavelength: f64,
        crosswind: f64,
        air_density: f64,
    ) -> PyResult<()> {
        let velocity = DVec3::new(velocity.0, velocity.1, velocity.2); // the core checks it (and names it)
        self.inner
            .wind(WindField { velocity, gust_amplitude, gust_frequency, gust_wavelength, crosswind, air_density })
            .map_err(|e| core_err(e, &[]))?;
        Ok(())
    }

    /// Number of particles so far.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_count()
    }

    /// The model: `precision="float32"` (the default: fast) or `"float64"` (the reference path: its state,
    /// solver and world, and every array they give, are float64).
    #[pyo3(signature = (*, precision = "float32"))]
    fn finalize(&self, precision: &str) -> PyResult<Model> {
        let inner = if crate::precision::parse_precision(precision)? {
            crate::precision::Prec::F64(self.inner.finalize().map_err(value_err)?)
        } else {
            crate::precision::Prec::F32(self.inner.finalize().map_err(value_err)?)
        };
        Ok(Model { inner })
    }
}

/// One key of a handle's path: `(time [s], (x, y, z) [m])`.
type PathKey = (f64, (f64, f64, f64));

/// Fracture options from keyword arguments: `None` when nothing can break and nothing is sealed.
pub(crate) fn breakable_from(
    strain_limit: Option<f64>,
    load_limit: Option<f64>,
    tear_strength: Option<f64>,
    sealed: bool,
) -> Option<fissure::Breakable> {
    if strain_limit.is_none() && load_limit.is_none() && tear_strength.is_none() && !sealed {
        return None;
    }
    Some(fissure::Breakable {
        strain_limit: strain_limit.unwrap_or(f64::INFINITY),
        load_limit: load_limit.unwrap_or(f64::INFINITY),
        sealed,
        tear_strength: tear_strength.unwrap_or(f64::INFINITY),
    })
}
