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

mod builder;
mod convert;
mod model;
mod types;
mod world;

pub use builder::ModelBuilder;
pub(crate) use convert::*;
pub use model::{Model, Solver, State};
pub use types::{DampingModel, Integrator, Mesh};
pub use world::World;

/// The compiled core of the `fissure` package.
/// Reads a scene file (TOML, see `scenes/` and `fissure::scene`): returns a dict with `world` (a `World` at the
/// scene's initial state, with its integrator and fracture settings), `dt` \[s\], `duration` \[s\] and `title`.
/// Unknown keys and bad values raise `ValueError` naming the key; a missing file raises `OSError`.
#[pyfunction]
fn load_scene<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    use fissure::scene::{Scene, SceneError};
    let scene = Scene::load(&path).map_err(|e| match e {
        SceneError::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        e => value_err(e),
    })?;
    // The scene's own world (its solver and fracture settings): the front end only translates.
    let rust = scene.world::<f32>().map_err(value_err)?;
    let world = World::from_world(py, rust)?;
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
