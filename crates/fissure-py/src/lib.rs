//! Python bindings: `import fissure`.
//!
//! Every `#[pymethods]` wrapper only converts: arrays in (validated: shape, dtype, finiteness), a plain Rust call,
//! arrays out. Errors become `ValueError` (bad values, bad meshes, blown-up states) or `TypeError` (wrong types
//! or dtypes); nothing panics across the boundary. Stepping releases the GIL.
//!
//! Arrays: positions and velocities are float32 `(N, 3)` (float64 for a model finalized with
//! `precision="float64"`, the reference path: see the `precision` module); meshes are float64 `(V, 3)` with integer `(F, 3)`
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

mod batch;
mod builder;
mod convert;
mod model;
mod pickle;
mod precision;
mod types;
mod world;

pub use builder::ModelBuilder;
pub(crate) use convert::*;
pub use model::{Model, Solver, State};
pub use types::{DampingModel, Integrator, Mesh};
pub use world::World;

/// The compiled core of the `fissure` package.
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
    m.add_function(wrap_pyfunction!(batch::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(batch::run_many, m)?)?;
    m.add_function(wrap_pyfunction!(pickle::_model_from_pickle, m)?)?;
    m.add_function(wrap_pyfunction!(pickle::_state_from_pickle, m)?)?;
    m.add_function(wrap_pyfunction!(pickle::_world_from_pickle, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
