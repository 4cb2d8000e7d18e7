//! Python bindings: `import fissure`.
//!
//! Every `#[pymethods]` wrapper only converts: arrays in (validated: shape, dtype, finiteness), a plain Rust call,
//! arrays out. Errors become `ValueError` (bad values, bad meshes, blown-up states) or `TypeError` (wrong types
//! or dtypes); nothing panics across the boundary. Stepping releases the GIL.
//!
//! Arrays: positions and velocities are float32 `(N, 3)`; meshes are float64 `(V, 3)` with integer `(F, 3)`
//! triangles. Any `(V, 3)` / `(F, 3)` array-like is accepted (lists, float32/float64, any integer dtype, any
//! memory layout), so meshes from trimesh or meshio go straight in. Inputs are read in place (no copy when they
//! are C-contiguous of the expected dtype) and copied once into the engine's own layout; outputs are new arrays
//! (the engine stores 3-vectors, which numpy cannot view without a copy), except `State.copy_positions_into`,
//! which fills a caller's preallocated array and allocates nothing.

use fissure::glam::{DVec3, Vec3};
use fissure::{
    Aero, Collider, Damping, DampingModel as RDampingModel, Gas, Integrator as RIntegrator, Mass, Mesh as RMesh,
    Model as RModel, ModelBuilder as RBuilder, SolverConfig, Stage, State as RState, Stiffness, WindField,
};
use numpy::{PyArray2, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyIndexError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn value_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `obj` as a numpy array (array-likes such as lists go through `numpy.asarray`).
fn as_ndarray<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return Ok(a.clone());
    }
    let np = obj.py().import("numpy")?;
    let arr = np.call_method1("asarray", (obj,)).map_err(|e| {
        PyTypeError::new_err(format!("expected an array-like of shape (N, 3), got {}: {e}", type_name(obj)))
    })?;
    let arr = arr.cast_into::<PyUntypedArray>()?;
    // Strings, bytes and objects make a numpy array too, but not a numeric one.
    if !matches!(arr.dtype().kind(), b'f' | b'i' | b'u' | b'c' | b'b') {
        return Err(PyTypeError::new_err(format!(
            "expected a numeric array-like of shape (N, 3), got {}",
            type_name(obj)
        )));
    }
    Ok(arr)
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

fn check_n3(name: &str, a: &Bound<'_, PyUntypedArray>) -> PyResult<usize> {
    let shape = a.shape();
    if a.ndim() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!("{name} must have shape (N, 3), got {shape:?}")));
    }
    Ok(shape[0])
}

/// Reads an `(N, 3)` float array (float32 or float64, any layout) as `f64` triples; rejects NaN/inf.
fn read_points(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<DVec3>> {
    let a = as_ndarray(obj)?;
    let n = check_n3(name, &a)?;
    let kind = a.dtype().kind();
    let out: Vec<DVec3> = if let Ok(f) = a.cast::<PyArray2<f64>>() {
        let r = f.readonly();
        r.as_array().rows().into_iter().map(|row| DVec3::new(row[0], row[1], row[2])).collect()
    } else if let Ok(f) = a.cast::<PyArray2<f32>>() {
        let r = f.readonly();
        r.as_array().rows().into_iter().map(|row| DVec3::new(row[0] as f64, row[1] as f64, row[2] as f64)).collect()
    } else if kind == b'i' || kind == b'u' {
        let f = a.call_method1("astype", ("float64",))?;
        return read_points(name, &f);
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a float32 or float64 array, got dtype {}",
            a.dtype().str().map(|s| s.to_string()).unwrap_or_default()
        )));
    };
    debug_assert_eq!(out.len(), n);
    if let Some((i, p)) = out.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(PyValueError::new_err(format!("{name}[{i}] = {:?} is not finite (NaN or infinite)", p.to_array())));
    }
    Ok(out)
}

/// Reads an `(F, 3)` integer array (any integer dtype) as triangles, checking sign and range.
fn read_triangles(obj: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
    let a = as_ndarray(obj)?;
    check_n3("triangles", &a)?;
    let kind = a.dtype().kind();
    if kind != b'i' && kind != b'u' {
        return Err(PyTypeError::new_err(format!(
            "triangles must be an integer array, got dtype {}",
            a.dtype().str().map(|s| s.to_string()).unwrap_or_default()
        )));
    }
    let a64 = a.call_method1("astype", ("int64",))?;
    let arr = a64.cast::<PyArray2<i64>>()?;
    let r = arr.readonly();
    let mut out = Vec::with_capacity(r.as_array().nrows());
    for (f, row) in r.as_array().rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for k in 0..3 {
            let i = row[k];
            if i < 0 || i as u64 >= vertex_count as u64 {
                return Err(PyValueError::new_err(format!(
                    "triangles[{f}] = {:?} refers to vertex {i}, but there are {vertex_count} vertices",
                    [row[0], row[1], row[2]]
                )));
            }
            t[k] = i as u32;
        }
        out.push(t);
    }
    Ok(out)
}

fn vec3(name: &str, v: (f64, f64, f64)) -> PyResult<DVec3> {
    let d = DVec3::new(v.0, v.1, v.2);
    if !d.is_finite() {
        return Err(PyValueError::new_err(format!("{name} = {v:?} is not finite")));
    }
    Ok(d)
}

fn points_out<'py>(py: Python<'py>, p: impl ExactSizeIterator<Item = [f32; 3]>) -> Bound<'py, PyArray2<f32>> {
    let n = p.len();
    let flat: Vec<f32> = p.flatten().collect();
    numpy::PyArray1::from_vec(py, flat).reshape([n, 3]).expect("n * 3 elements")
}

/// The time integrators.
#[allow(non_camel_case_types)] // Python enum members are UPPER_CASE.
#[pyclass(eq, eq_int, module = "fissure._fissure", from_py_object)]
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Semi-implicit Euler (the seed's eqs. 3–5), order 1.
    SYMPLECTIC_EULER,
    /// Velocity Verlet, order 2.
    VELOCITY_VERLET,
    /// Classical Runge–Kutta, order 4.
    RK4,
    /// Linearised backward Euler with conjugate gradients, order 1, unconditionally stable.
    IMPLICIT_EULER,
}

impl From<Integrator> for RIntegrator {
    fn from(i: Integrator) -> Self {
        match i {
            Integrator::SYMPLECTIC_EULER => RIntegrator::SymplecticEuler,
            Integrator::VELOCITY_VERLET => RIntegrator::VelocityVerlet,
            Integrator::RK4 => RIntegrator::Rk4,
            Integrator::IMPLICIT_EULER => RIntegrator::ImplicitEuler,
        }
    }
}

#[pymethods]
impl Integrator {
    /// Global order of accuracy.
    #[getter]
    fn order(&self) -> u32 {
        RIntegrator::from(*self).order()
    }
}

/// The two damping forms of the seed's eq. (2).
#[allow(non_camel_case_types)] // Python enum members are UPPER_CASE.
#[pyclass(eq, eq_int, module = "fissure._fissure", from_py_object)]
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum DampingModel {
    /// Along the spring only (default): rigid rotation is not damped.
    PROJECTED,
    /// The paper's `kd (v_j - v_i)`.
    UNPROJECTED,
}

/// A validated triangle mesh (float64 positions in metres).
#[pyclass(module = "fissure._fissure", from_py_object)]
#[derive(Clone)]
pub struct Mesh {
    inner: RMesh,
}

#[pymethods]
impl Mesh {
    /// A mesh from a `(V, 3)` float array and an `(F, 3)` integer array, validated.
    #[new]
    fn new(positions: &Bound<'_, PyAny>, triangles: &Bound<'_, PyAny>) -> PyResult<Self> {
        let p = read_points("positions", positions)?;
        let t = read_triangles(triangles, p.len())?;
        Ok(Mesh { inner: RMesh::new(p, t).map_err(value_err)? })
    }

    /// Icosphere of `radius` [m] with `subdivisions` (10·4^s + 2 vertices).
    #[staticmethod]
    fn icosphere(radius: f64, subdivisions: u32) -> PyResult<Self> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(PyValueError::new_err(format!("radius must be finite and > 0, got {radius}")));
        }
        if subdivisions > 8 {
            return Err(PyValueError::new_err(format!("subdivisions must be at most 8, got {subdivisions}")));
        }
        Ok(Mesh { inner: RMesh::icosphere(radius, subdivisions) })
    }

    /// An `nx × ny` grid with `spacing` [m] in the XY plane, row 0 at y = 0, rows going down.
    #[staticmethod]
    fn grid(nx: usize, ny: usize, spacing: f64) -> PyResult<Self> {
        if nx < 2 || ny < 2 || !(spacing.is_finite() && spacing > 0.0) {
            return Err(PyValueError::new_err(format!(
                "grid needs nx, ny >= 2 and spacing > 0, got {nx}, {ny}, {spacing}"
            )));
        }
        Ok(Mesh { inner: RMesh::grid(nx, ny, spacing) })
    }

    /// A closed box centred at the origin, each face split into `n × n` quads.
    #[staticmethod]
    #[pyo3(signature = (half_extents, n = 1))]
    fn cuboid(half_extents: (f64, f64, f64), n: usize) -> PyResult<Self> {
        let h = vec3("half_extents", half_extents)?;
        if h.min_element() <= 0.0 {
            return Err(PyValueError::new_err(format!("half_extents must be > 0, got {half_extents:?}")));
        }
        Ok(Mesh { inner: RMesh::cuboid(h, n) })
    }

    /// Loads an OBJ file, welding vertices split at seams (tolerance [m]; default 1e-6 of the box diagonal).
    #[staticmethod]
    #[pyo3(signature = (path, *, weld_tolerance = None))]
    fn load_obj(path: std::path::PathBuf, weld_tolerance: Option<f64>) -> PyResult<Self> {
        Ok(Mesh { inner: RMesh::load_obj(path, weld_tolerance).map_err(value_err)? })
    }

    /// Writes an OBJ file.
    fn save_obj(&self, path: std::path::PathBuf) -> PyResult<()> {
        self.inner.save_obj(path).map_err(value_err)
    }

    /// Writes an ASCII PLY file.
    fn save_ply(&self, path: std::path::PathBuf) -> PyResult<()> {
        self.inner.save_ply(path).map_err(value_err)
    }

    /// A copy moved by `offset` [m].
    fn translated(&self, offset: (f64, f64, f64)) -> PyResult<Self> {
        Ok(Mesh { inner: self.inner.translated(vec3("offset", offset)?) })
    }

    /// Positions, a new float64 `(V, 3)` array [m].
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self.inner.positions().iter().flat_map(|p| p.to_array()).collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.vertex_count(), 3]).expect("V * 3 elements")
    }

    /// Triangles, a new uint32 `(F, 3)` array.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.triangles().iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.triangle_count(), 3]).expect("F * 3 elements")
    }

    /// Number of vertices.
    #[getter]
    fn vertex_count(&self) -> usize {
        self.inner.vertex_count()
    }

    /// Number of triangles.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.inner.triangle_count()
    }

    /// True when every edge has two faces.
    fn is_closed(&self) -> bool {
        self.inner.is_closed()
    }

    /// Signed enclosed volume [m^3].
    fn signed_volume(&self) -> f64 {
        self.inner.signed_volume()
    }

    /// Surface area [m^2].
    fn area(&self) -> f64 {
        self.inner.area()
    }

    fn __repr__(&self) -> String {
        format!("Mesh(vertices={}, triangles={})", self.inner.vertex_count(), self.inner.triangle_count())
    }
}

/// Collects bodies, colliders, gravity and wind; `finalize()` gives a `Model`.
#[pyclass(module = "fissure._fissure")]
pub struct ModelBuilder {
    inner: RBuilder,
}

fn mass_from(
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

fn stiffness_from(membrane: Option<f64>, per_spring: Option<f64>, default: Stiffness) -> PyResult<Stiffness> {
    match (membrane, per_spring) {
        (None, None) => Ok(default),
        (Some(e), None) => Ok(Stiffness::Membrane(e)),
        (None, Some(k)) => Ok(Stiffness::PerSpring(k)),
        _ => Err(PyValueError::new_err("give at most one of stiffness (membrane E·h) and spring_stiffness")),
    }
}

fn damping_from(ratio: Option<f64>, per_spring: Option<f64>, default: Damping) -> PyResult<Damping> {
    match (ratio, per_spring) {
        (None, None) => Ok(default),
        (Some(z), None) => Ok(Damping::Ratio(z)),
        (None, Some(d)) => Ok(Damping::PerSpring(d)),
        _ => Err(PyValueError::new_err("give at most one of damping_ratio and spring_damping")),
    }
}

fn handle_dict<'py>(py: Python<'py>, h: fissure::BodyHandle) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("index", h.index)?;
    d.set_item("first_particle", h.first_particle)?;
    d.set_item("particle_count", h.particle_count)?;
    d.set_item("first_triangle", h.first_triangle)?;
    Ok(d)
}

fn collider_opts(c: Collider, restitution: f32, friction: f32, margin: f32) -> PyResult<Collider> {
    let ok = (0.0..=1.0).contains(&restitution)
        && friction.is_finite()
        && friction >= 0.0
        && margin.is_finite()
        && margin >= 0.0;
    if !ok {
        return Err(PyValueError::new_err(format!(
            "restitution must be in [0, 1], friction and margin finite and >= 0; got {restitution}, {friction}, {margin}"
        )));
    }
    Ok(c.with_restitution(restitution).with_friction(friction).with_margin(margin))
}

fn f32x3(name: &str, v: (f64, f64, f64)) -> PyResult<Vec3> {
    Ok(vec3(name, v)?.as_vec3())
}

#[pymethods]
impl ModelBuilder {
    /// An empty builder with `gravity` [m/s^2].
    #[new]
    #[pyo3(signature = (*, gravity = (0.0, -9.81, 0.0), damping_model = DampingModel::PROJECTED))]
    fn new(gravity: (f64, f64, f64), damping_model: DampingModel) -> PyResult<Self> {
        let mut inner = RBuilder::new();
        inner.gravity(vec3("gravity", gravity)?);
        inner.damping_model(match damping_model {
            DampingModel::PROJECTED => RDampingModel::Projected,
            DampingModel::UNPROJECTED => RDampingModel::Unprojected,
        });
        Ok(ModelBuilder { inner })
    }

    /// Adds one particle of `mass` [kg] (0 pins it); returns its index.
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
        reorient = true, strain_limit = None, load_limit = None, sealed = false))]
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
            external_pressure,
            aero: Aero { drag, lift },
            reorient,
            velocity: vec3("velocity", velocity)?,
            fracture: breakable_from(strain_limit, load_limit, sealed),
        };
        let h = self.inner.add_soft_body(&mesh.inner, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// Adds a cloth from any mesh (edge springs, optional bending springs, pins by vertex index).
    #[pyo3(signature = (mesh, *, mass = None, area_density = None, particle_mass = None, stiffness = None,
        spring_stiffness = None, bending = None, damping_ratio = None, spring_damping = None, pins = vec![],
        drag = 1.0, lift = 0.5, strain_limit = None, load_limit = None))]
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
            fracture: breakable_from(strain_limit, load_limit, false),
        };
        let h = self.inner.add_cloth(&mesh.inner, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// Adds an `nx × ny` cloth grid with structural, shear and bending springs [N/m], placed with its top-left
    /// corner at `origin`, x to the right, rows along `down` (default -y), in the plane they span.
    #[pyo3(signature = (nx, ny, spacing, *, origin = (0.0, 0.0, 0.0), down = (0.0, -1.0, 0.0),
        mass = None, area_density = None, particle_mass = None, spring_stiffness = 1000.0, shear = 1000.0,
        bending = 1000.0, damping_ratio = None, spring_damping = None, pins = vec![], drag = 1.0, lift = 0.5,
        strain_limit = None, load_limit = None))]
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
            fracture: breakable_from(strain_limit, load_limit, false),
        };
        // Grid rows run along -y in the mesh generator: map (x, -row) to origin + x X + row down.
        let place = |p: DVec3| o + DVec3::X * p.x + down * (-p.y);
        let h = self.inner.add_cloth_grid(nx, ny, spacing, place, &opts).map_err(value_err)?;
        handle_dict(py, h)
    }

    /// The ground `y = height`.
    #[pyo3(signature = (height = 0.0, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_ground(&mut self, height: f32, restitution: f32, friction: f32, margin: f32) -> PyResult<()> {
        self.inner.add_collider(collider_opts(Collider::ground(height), restitution, friction, margin)?);
        Ok(())
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
        let n = f32x3("normal", normal)?;
        if n.length() == 0.0 {
            return Err(PyValueError::new_err("normal must be non-zero"));
        }
        let c = Collider::plane(f32x3("point", point)?, n);
        self.inner.add_collider(collider_opts(c, restitution, friction, margin)?);
        Ok(())
    }

    /// A solid ball collider, optionally moving at `velocity` [m/s].
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
        if !(radius.is_finite() && radius > 0.0) {
            return Err(PyValueError::new_err(format!("radius must be finite and > 0, got {radius}")));
        }
        let c =
            Collider::ball(f32x3("center", center)?, radius).with_velocity(f32x3("velocity", velocity)?, Vec3::ZERO);
        self.inner.add_collider(collider_opts(c, restitution, friction, margin)?);
        Ok(())
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
        let h = f32x3("half_extents", half_extents)?;
        if h.min_element() <= 0.0 {
            return Err(PyValueError::new_err(format!("half_extents must be > 0, got {half_extents:?}")));
        }
        let c = Collider::cuboid(f32x3("center", center)?, h);
        self.inner.add_collider(collider_opts(c, restitution, friction, margin)?);
        Ok(())
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
        if !(radius.is_finite() && radius > 0.0) {
            return Err(PyValueError::new_err(format!("radius must be finite and > 0, got {radius}")));
        }
        let c = Collider::capsule(f32x3("a", a)?, f32x3("b", b)?, radius);
        self.inner.add_collider(collider_opts(c, restitution, friction, margin)?);
        Ok(())
    }

    /// A solid triangle-mesh collider (the mesh must be closed).
    #[pyo3(signature = (mesh, *, restitution = 0.3, friction = 0.4, margin = 0.0))]
    fn add_mesh_collider(&mut self, mesh: &Mesh, restitution: f32, friction: f32, margin: f32) -> PyResult<()> {
        let c = Collider::trimesh(&mesh.inner).map_err(value_err)?;
        self.inner.add_collider(collider_opts(c, restitution, friction, margin)?);
        Ok(())
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
        for (n, v) in [("gust_wavelength", gust_wavelength), ("air_density", air_density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(PyValueError::new_err(format!("{n} must be finite and > 0, got {v}")));
            }
        }
        self.inner.wind(WindField {
            velocity: vec3("velocity", velocity)?,
            gust_amplitude,
            gust_frequency,
            gust_wavelength,
            crosswind,
            air_density,
        });
        Ok(())
    }

    /// Number of particles so far.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_count()
    }

    /// The model (float32).
    fn finalize(&self) -> PyResult<Model> {
        Ok(Model { inner: self.inner.finalize().map_err(value_err)? })
    }
}

/// Everything a step reads: masses, springs, triangles, bodies, colliders (float32).
#[pyclass(module = "fissure._fissure")]
pub struct Model {
    inner: RModel<f32>,
}

#[pymethods]
impl Model {
    /// The initial state.
    fn state(&self) -> State {
        State { inner: self.inner.state() }
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_count()
    }
    /// Number of springs.
    #[getter]
    fn spring_count(&self) -> usize {
        self.inner.spring_count()
    }
    /// Number of triangles.
    #[getter]
    fn tri_count(&self) -> usize {
        self.inner.tri_count()
    }
    /// Number of bodies.
    #[getter]
    fn body_count(&self) -> usize {
        self.inner.body_count()
    }
    /// Triangles, a new uint32 `(F, 3)` array.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.tri_indices.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.tri_count(), 3]).expect("F * 3 elements")
    }
    /// Springs, a new uint32 `(S, 2)` array.
    #[getter]
    fn springs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let flat: Vec<u32> = self.inner.spring_indices.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([self.inner.spring_count(), 2]).expect("S * 2 elements")
    }
    /// Total mass [kg].
    fn total_mass(&self) -> f64 {
        self.inner.total_mass()
    }
    /// Enclosed volume of each body [m^3] (0 without gas).
    fn body_volumes(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        Ok(self.inner.body_volumes(&state.inner))
    }
    /// Gas pressure of each body [Pa].
    fn body_pressures(&self, state: &State) -> PyResult<Vec<f64>> {
        self.check(state)?;
        Ok(self.inner.body_pressures(&state.inner))
    }
    /// Linear momentum [kg·m/s].
    fn momentum(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        Ok(self.inner.momentum(&state.inner).into())
    }
    /// Centre of mass [m].
    fn center_of_mass(&self, state: &State) -> PyResult<(f64, f64, f64)> {
        self.check(state)?;
        Ok(self.inner.center_of_mass(&state.inner).into())
    }
    /// Energies [J]: kinetic, spring, gas, gravity, total.
    fn energy<'py>(&self, py: Python<'py>, state: &State) -> PyResult<Bound<'py, PyDict>> {
        self.check(state)?;
        let e = self.inner.energy(&state.inner);
        let d = PyDict::new(py);
        d.set_item("kinetic", e.kinetic)?;
        d.set_item("spring", e.spring)?;
        d.set_item("gas", e.gas)?;
        d.set_item("gravity", e.gravity)?;
        d.set_item("total", e.total())?;
        Ok(d)
    }
    fn __repr__(&self) -> String {
        format!(
            "Model(particles={}, springs={}, triangles={}, bodies={})",
            self.inner.particle_count(),
            self.inner.spring_count(),
            self.inner.tri_count(),
            self.inner.body_count()
        )
    }
}

impl Model {
    fn check(&self, s: &State) -> PyResult<()> {
        if s.inner.particle_q.len() != self.inner.particle_count() {
            return Err(PyValueError::new_err(format!(
                "state has {} particles but the model has {}",
                s.inner.particle_q.len(),
                self.inner.particle_count()
            )));
        }
        Ok(())
    }
}

/// Positions [m], velocities [m/s] and time [s].
#[pyclass(module = "fissure._fissure")]
#[derive(Clone)]
pub struct State {
    inner: RState<f32>,
}

fn write_points(name: &str, dst: &mut [Vec3], src: &Bound<'_, PyAny>) -> PyResult<()> {
    let pts = read_points(name, src)?;
    if pts.len() != dst.len() {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({}, 3), got ({}, 3)",
            dst.len(),
            pts.len()
        )));
    }
    for (d, p) in dst.iter_mut().zip(pts) {
        *d = p.as_vec3();
    }
    Ok(())
}

#[pymethods]
impl State {
    /// Positions: a new float32 `(N, 3)` array (a copy; see `copy_positions_into`).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        points_out(py, self.inner.particle_q.iter().map(|v| v.to_array()))
    }
    /// Sets positions from an `(N, 3)` float array.
    #[setter]
    fn set_positions(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        write_points("positions", &mut self.inner.particle_q, value)
    }
    /// Velocities: a new float32 `(N, 3)` array.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        points_out(py, self.inner.particle_qd.iter().map(|v| v.to_array()))
    }
    /// Sets velocities from an `(N, 3)` float array.
    #[setter]
    fn set_velocities(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        write_points("velocities", &mut self.inner.particle_qd, value)
    }
    /// Simulation time [s].
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time
    }
    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.inner.particle_q.len()
    }
    /// Copies positions into `out`, a C-contiguous float32 `(N, 3)` array, without allocating.
    fn copy_positions_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        copy_into("out", &self.inner.particle_q, out)
    }
    /// Copies velocities into `out`, a C-contiguous float32 `(N, 3)` array, without allocating.
    fn copy_velocities_into(&self, out: &Bound<'_, PyAny>) -> PyResult<()> {
        copy_into("out", &self.inner.particle_qd, out)
    }
    /// An independent copy.
    fn copy(&self) -> State {
        self.clone()
    }
}

fn copy_into(name: &str, src: &[Vec3], out: &Bound<'_, PyAny>) -> PyResult<()> {
    let arr = out.cast::<PyArray2<f32>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a float32 numpy array of shape ({}, 3), got {}",
            src.len(),
            type_name(out)
        ))
    })?;
    if !arr.is_c_contiguous() {
        return Err(PyValueError::new_err(format!("{name} must be C-contiguous (np.ascontiguousarray)")));
    }
    if arr.shape() != [src.len(), 3] {
        return Err(PyValueError::new_err(format!("{name} must have shape ({}, 3), got {:?}", src.len(), arr.shape())));
    }
    let mut rw = arr.try_readwrite().map_err(|e| PyValueError::new_err(format!("{name} is not writable: {e}")))?;
    let dst = rw.as_slice_mut().map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))?;
    for (d, s) in dst.chunks_exact_mut(3).zip(src) {
        d.copy_from_slice(&s.to_array());
    }
    Ok(())
}

/// The CPU solver (rayon threads, deterministic).
#[pyclass(module = "fissure._fissure")]
pub struct Solver {
    inner: fissure::CpuSolver<f32>,
}

fn config(integrator: Integrator, cg_tolerance: f64, cg_max_iterations: usize) -> PyResult<SolverConfig> {
    if !(cg_tolerance.is_finite() && cg_tolerance > 0.0) || cg_max_iterations == 0 {
        return Err(PyValueError::new_err("cg_tolerance must be > 0 and cg_max_iterations >= 1"));
    }
    Ok(SolverConfig {
        integrator: integrator.into(),
        cg_tolerance,
        cg_max_iterations,
        check_finite: true,
        substep_safety: None,
    })
}

fn timers_dict<'py>(py: Python<'py>, t: &fissure::StageTimers) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for s in Stage::ALL {
        d.set_item(s.name(), t.time(s).as_secs_f64())?;
    }
    d.set_item("total", t.total.as_secs_f64())?;
    d.set_item("steps", t.steps)?;
    Ok(d)
}

#[pymethods]
impl Solver {
    /// A solver; options are keyword-only.
    #[new]
    #[pyo3(signature = (*, integrator = Integrator::SYMPLECTIC_EULER, cg_tolerance = 1e-5, cg_max_iterations = 200))]
    fn new(integrator: Integrator, cg_tolerance: f64, cg_max_iterations: usize) -> PyResult<Self> {
        Ok(Solver { inner: fissure::CpuSolver::new(config(integrator, cg_tolerance, cg_max_iterations)?) })
    }

    /// Advances `state` by `steps` steps of `dt` [s], with the GIL released.
    #[pyo3(signature = (model, state, dt, steps = 1))]
    fn step(&mut self, py: Python<'_>, model: &Model, state: &mut State, dt: f64, steps: usize) -> PyResult<()> {
        model.check(state)?;
        let (solver, m, s) = (&mut self.inner, &model.inner, &mut state.inner);
        py.detach(|| {
            for _ in 0..steps {
                fissure::Solver::step(solver, m, s, dt)?;
            }
            Ok::<(), fissure::StepError>(())
        })
        .map_err(value_err)
    }

    /// Seconds spent per stage so far, with `total` and `steps`.
    fn timers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        timers_dict(py, fissure::Solver::timers(&self.inner))
    }
}

/// A model, its state, a solver and the fracture pass, stepped together.
#[pyclass(module = "fissure._fissure")]
pub struct World {
    model: Py<Model>,
    state: Py<State>,
    solver: Py<Solver>,
    fracture: fissure::Fracture<f32>,
    events: Vec<fissure::FractureEvent>,
}

fn event_dict<'py>(py: Python<'py>, e: &fissure::FractureEvent) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let kind = match e.kind {
        fissure::FractureKind::Spring => "spring",
        fissure::FractureKind::Core => "core",
        fissure::FractureKind::Detach => "detach",
    };
    d.set_item("kind", kind)?;
    d.set_item("time", e.time)?;
    d.set_item("position", (e.position.x, e.position.y, e.position.z))?;
    d.set_item("body", e.body)?;
    d.set_item("spring", e.spring)?;
    d.set_item("vertex", e.vertex)?;
    d.set_item("new_particles", e.new_particles.clone())?;
    d.set_item("new_body", e.new_body)?;
    Ok(d)
}

impl World {
    /// Steps with the GIL released; returns the number of new fracture events.
    fn run(&mut self, py: Python<'_>, mut dts: impl FnMut(f64) -> Option<f64> + Send) -> PyResult<usize> {
        let mut model = self.model.borrow_mut(py);
        let mut state = self.state.borrow_mut(py);
        let mut solver = self.solver.borrow_mut(py);
        model.check(&state)?;
        let (m, s, sv) = (&mut model.inner, &mut state.inner, &mut solver.inner);
        let (fr, events) = (&mut self.fracture, &mut self.events);
        let before = events.len();
        py.detach(|| {
            while let Some(dt) = dts(s.time) {
                fissure::Solver::step(sv, m, s, dt)?;
                if fr.needed(m) {
                    let new = fr.apply(m, s, dt);
                    if !new.is_empty() || !fr.last_delta().is_empty() {
                        fissure::Solver::notify_model_changed(sv, m);
                    }
                    events.extend(new);
                }
            }
            Ok::<(), fissure::StepError>(())
        })
        .map_err(value_err)?;
        Ok(self.events.len() - before)
    }

    fn cut<'py>(&mut self, py: Python<'py>, index: usize, core: bool) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let mut model = self.model.borrow_mut(py);
        let mut state = self.state.borrow_mut(py);
        model.check(&state)?;
        let (m, s) = (&mut model.inner, &mut state.inner);
        let count = if core { m.particle_count() } else { m.spring_count() };
        if index >= count {
            let what = if core { "particle" } else { "spring" };
            return Err(PyIndexError::new_err(format!("{what} {index} out of range (model has {count})")));
        }
        let new = if core { self.fracture.break_core(m, s, index) } else { self.fracture.break_spring(m, s, index) };
        if !new.is_empty() {
            fissure::Solver::notify_model_changed(&mut self.solver.borrow_mut(py).inner, m);
        }
        let out = new.iter().map(|e| event_dict(py, e)).collect::<PyResult<Vec<_>>>()?;
        self.events.extend(new);
        Ok(out)
    }
}

#[pymethods]
impl World {
    /// A world at the model's initial state. Fracture settings (used when the model has breakable bodies):
    /// `max_events_per_step`, `averaged_window` [s] (None: instantaneous trigger), `discharge_coefficient`,
    /// `gas_density` [kg/m^3], `start_time` [s].
    #[new]
    #[pyo3(signature = (model, *, integrator = Integrator::SYMPLECTIC_EULER, cg_tolerance = 1e-5, cg_max_iterations = 200,
        max_events_per_step = 32, averaged_window = None, discharge_coefficient = 0.6, gas_density = 1.2,
        start_time = 0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: Py<Model>,
        integrator: Integrator,
        cg_tolerance: f64,
        cg_max_iterations: usize,
        max_events_per_step: usize,
        averaged_window: Option<f64>,
        discharge_coefficient: f64,
        gas_density: f64,
        start_time: f64,
    ) -> PyResult<Self> {
        if let Some(w) = averaged_window
            && !(w.is_finite() && w > 0.0)
        {
            return Err(PyValueError::new_err(format!("averaged_window must be > 0, got {w}")));
        }
        for (name, v) in [("discharge_coefficient", discharge_coefficient), ("gas_density", gas_density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(PyValueError::new_err(format!("{name} must be > 0, got {v}")));
            }
        }
        if !start_time.is_finite() {
            return Err(PyValueError::new_err(format!("start_time must be finite, got {start_time}")));
        }
        let state = model.borrow(py).state();
        let solver = Solver::new(integrator, cg_tolerance, cg_max_iterations)?;
        let config = fissure::FractureConfig {
            trigger: averaged_window.map_or(fissure::Trigger::Instant, |window| fissure::Trigger::Averaged { window }),
            max_events_per_step,
            discharge_coefficient,
            gas_density,
            start_time,
            ..Default::default()
        };
        Ok(World {
            model,
            state: Py::new(py, state)?,
            solver: Py::new(py, solver)?,
            fracture: fissure::Fracture::new(config),
            events: Vec::new(),
        })
    }

    /// The model.
    #[getter]
    fn model(&self, py: Python<'_>) -> Py<Model> {
        self.model.clone_ref(py)
    }
    /// The state (live: stepping the world changes it).
    #[getter]
    fn state(&self, py: Python<'_>) -> Py<State> {
        self.state.clone_ref(py)
    }
    /// The solver.
    #[getter]
    fn solver(&self, py: Python<'_>) -> Py<Solver> {
        self.solver.clone_ref(py)
    }
    /// Simulation time [s].
    #[getter]
    fn time(&self, py: Python<'_>) -> f64 {
        self.state.borrow(py).inner.time
    }
    /// Every fracture event so far, as dicts: `kind` ("spring", "core" or "detach"), `time` [s], `position` [m],
    /// `body`, `spring`, `vertex`, `new_particles`, `new_body`.
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.events.iter().map(|e| event_dict(py, e)).collect()
    }

    /// `steps` steps of `dt` [s] (each followed by the fracture pass), GIL released. Returns the number of new
    /// fracture events.
    #[pyo3(signature = (dt, steps = 1))]
    fn step(&mut self, py: Python<'_>, dt: f64, steps: usize) -> PyResult<usize> {
        let mut left = steps;
        self.run(py, move |_| {
            if left == 0 {
                return None;
            }
            left -= 1;
            Some(dt)
        })
    }

    /// Advances by `duration` [s] in steps of at most `dt` [s], GIL released. Returns the number of new fracture
    /// events.
    fn advance(&mut self, py: Python<'_>, duration: f64, dt: f64) -> PyResult<usize> {
        if !(dt.is_finite() && dt > 0.0 && duration.is_finite() && duration >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "need dt > 0 and duration >= 0, got dt = {dt}, duration = {duration}"
            )));
        }
        let end = self.state.borrow(py).inner.time + duration;
        self.run(py, move |t| (t < end - 1e-12).then(|| dt.min(end - t)))
    }

    /// Breaks spring `index` now (a cut), whatever its strain; returns the events (empty if it could not break).
    fn break_spring<'py>(&mut self, py: Python<'py>, index: usize) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cut(py, index, false)
    }

    /// Breaks particle `index` out as a core block now (a puncture); returns the events (empty if it could not:
    /// pinned, on or next to an opening, or an odd valence).
    fn break_core<'py>(&mut self, py: Python<'py>, index: usize) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cut(py, index, true)
    }

    /// Seconds spent per stage (solver stages and `fracture`), with `total` and `steps`.
    fn timers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut t = fissure::Solver::timers(&self.solver.borrow(py).inner).clone();
        t.merge_stages(self.fracture.timers());
        timers_dict(py, &t)
    }
}

/// Fracture options from keyword arguments: `None` when nothing can break and nothing is sealed.
fn breakable_from(strain_limit: Option<f64>, load_limit: Option<f64>, sealed: bool) -> Option<fissure::Breakable> {
    if strain_limit.is_none() && load_limit.is_none() && !sealed {
        return None;
    }
    Some(fissure::Breakable {
        strain_limit: strain_limit.unwrap_or(f64::INFINITY),
        load_limit: load_limit.unwrap_or(f64::INFINITY),
        sealed,
    })
}

/// The compiled core of the `fissure` package.
/// Reads a scene file (TOML, see `scenes/` and `fissure::scene`): returns a dict with `world` (a `World` at the
/// scene's initial state, with its integrator and fracture settings), `dt` [s], `duration` [s] and `title`.
/// Unknown keys and bad values raise `ValueError` naming the key; a missing file raises `OSError`.
#[pyfunction]
fn load_scene<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    use fissure::scene::{Scene, SceneError};
    let scene = Scene::load(&path).map_err(|e| match e {
        SceneError::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        e => value_err(e),
    })?;
    let model = scene.builder().map_err(value_err)?.finalize::<f32>().map_err(value_err)?;
    let integrator = match scene.integrator().map_err(value_err)? {
        RIntegrator::SymplecticEuler => Integrator::SYMPLECTIC_EULER,
        RIntegrator::VelocityVerlet => Integrator::VELOCITY_VERLET,
        RIntegrator::Rk4 => Integrator::RK4,
        RIntegrator::ImplicitEuler => Integrator::IMPLICIT_EULER,
    };
    let state = model.state();
    let world = World {
        model: Py::new(py, Model { inner: model })?,
        state: Py::new(py, State { inner: state })?,
        solver: Py::new(py, Solver::new(integrator, 1e-5, 200)?)?,
        fracture: fissure::Fracture::new(scene.fracture_config()),
        events: Vec::new(),
    };
    let d = PyDict::new(py);
    d.set_item("world", Py::new(py, world)?)?;
    d.set_item("dt", scene.solver.dt)?;
    d.set_item("duration", scene.solver.duration)?;
    d.set_item("title", scene.title)?;
    Ok(d)
}

#[pymodule]
fn _fissure(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Integrator>()?;
    m.add_class::<DampingModel>()?;
    m.add_class::<Mesh>()?;
    m.add_class::<ModelBuilder>()?;
    m.add_class::<Model>()?;
    m.add_class::<State>()?;
    m.add_class::<Solver>()?;
    m.add_class::<World>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
