//! The enums (integrators, damping forms) and the mesh.

use crate::*;

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
    pub(crate) inner: RMesh,
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

    /// Icosphere of `radius` \[m\] with `subdivisions` (10·4^s + 2 vertices).
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

    /// An `nx × ny` grid with `spacing` \[m\] in the XY plane, row 0 at y = 0, rows going down.
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

    /// Loads an OBJ file, welding vertices split at seams (tolerance \[m\]; default 1e-6 of the box diagonal).
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

    /// A copy moved by `offset` \[m\].
    fn translated(&self, offset: (f64, f64, f64)) -> PyResult<Self> {
        Ok(Mesh { inner: self.inner.translated(vec3("offset", offset)?) })
    }

    /// The same surface with its vertices renumbered for locality (reverse Cuthill–McKee) and its triangles in
    /// their order: `(mesh, vertex_map, triangle_map)`, the maps uint32 arrays of each old vertex's and
    /// triangle's new index. For a mesh whose own numbering has no locality: a model keeps the numbering it is
    /// given, and stepping it is slower when neighbours lie far apart in it.
    fn renumbered_for_locality<'py>(
        &self,
        py: Python<'py>,
    ) -> (Self, Bound<'py, numpy::PyArray1<u32>>, Bound<'py, numpy::PyArray1<u32>>) {
        let (mesh, map) = self.inner.renumbered_for_locality();
        (Mesh { inner: mesh }, numpy::PyArray1::from_vec(py, map.vertex), numpy::PyArray1::from_vec(py, map.triangle))
    }

    /// Positions, a new float64 `(V, 3)` array \[m\].
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

    /// Signed enclosed volume \[m^3\].
    fn signed_volume(&self) -> f64 {
        self.inner.signed_volume()
    }

    /// Surface area \[m^2\].
    fn area(&self) -> f64 {
        self.inner.area()
    }

    fn __repr__(&self) -> String {
        format!("Mesh(vertices={}, triangles={})", self.inner.vertex_count(), self.inner.triangle_count())
    }
}
