//! Pickling: `Model`, `State` and `World` travel to worker processes (multiprocessing, Dask) as arrays, not
//! pointers: serde through postcard, a compact binary format that stores each float as its bytes, so a round trip
//! is exact. A pickle starts with a tag and a format version; anything else is a `ValueError`, and a model is
//! checked (`check_invariants`) before it is handed back, so a damaged pickle cannot reach the solver.
//!
//! A `World` pickles as its model, state, solver and fracture settings, `fracture_every` and its events. The
//! solver's warm-started estimates and the fracture pass's running averages are not kept: an unpickled world
//! goes on from that state as a new world would (bit-identical to one built from the same model and state).

use crate::model::{AnyModel, AnyState};
use crate::precision::{Prec, Precision, each};
use crate::*;
use pyo3::types::{PyBytes, PyTuple};
use serde::{Deserialize, Serialize};

const TAG: &[u8] = b"fissure-pickle\x01";

fn encode<T: Serialize>(what: &str, value: &T) -> PyResult<Vec<u8>> {
    let mut out = TAG.to_vec();
    out.extend(
        postcard::to_stdvec(value).map_err(|e| PyValueError::new_err(format!("cannot pickle the {what}: {e}")))?,
    );
    Ok(out)
}

fn decode<'a, T: Deserialize<'a>>(what: &str, bytes: &'a [u8]) -> PyResult<T> {
    let body = bytes.strip_prefix(TAG).ok_or_else(|| {
        PyValueError::new_err(format!("not a pickled fissure {what} (or one from an incompatible version)"))
    })?;
    postcard::from_bytes(body).map_err(|e| PyValueError::new_err(format!("damaged pickle of a fissure {what}: {e}")))
}

fn checked(m: AnyModel) -> PyResult<AnyModel> {
    each!(&m, m => fissure::check_invariants(m))
        .map_err(|e| PyValueError::new_err(format!("damaged pickle of a fissure model: {e}")))?;
    Ok(m)
}

/// `(constructor, (bytes,))`, what `__reduce__` returns.
fn reduce<'py>(py: Python<'py>, constructor: &str, bytes: Vec<u8>) -> PyResult<Bound<'py, PyTuple>> {
    let f = py.import("fissure._fissure")?.getattr(constructor)?;
    PyTuple::new(py, [f, PyTuple::new(py, [PyBytes::new(py, &bytes)])?.into_any()])
}

#[derive(Serialize, Deserialize)]
struct WorldPickle {
    model: AnyModel,
    state: AnyState,
    solver: fissure::SolverConfig,
    fracture: fissure::FractureConfig,
    fracture_every: usize,
    events: Vec<fissure::FractureEvent>,
}

/// `Model.__reduce__`.
pub(crate) fn reduce_model<'py>(py: Python<'py>, m: &Model) -> PyResult<Bound<'py, PyTuple>> {
    reduce(py, "_model_from_pickle", encode("model", &m.inner)?)
}

/// `State.__reduce__`.
pub(crate) fn reduce_state<'py>(py: Python<'py>, s: &State) -> PyResult<Bound<'py, PyTuple>> {
    reduce(py, "_state_from_pickle", encode("state", &s.inner)?)
}

/// `World.__reduce__`.
pub(crate) fn reduce_world<'py>(py: Python<'py>, w: &World) -> PyResult<Bound<'py, PyTuple>> {
    let p = WorldPickle {
        model: w.model.borrow(py).inner.clone(),
        state: w.state.borrow(py).inner.clone(),
        solver: w.solver.borrow(py).config(),
        fracture: each!(&w.world, w => w.fracture.config.clone()),
        fracture_every: each!(&w.world, w => w.fracture_every),
        events: each!(&w.world, w => w.events.clone()),
    };
    reduce(py, "_world_from_pickle", encode("world", &p)?)
}

/// Unpickles a `Model`.
#[pyfunction]
pub(crate) fn _model_from_pickle(bytes: &[u8]) -> PyResult<Model> {
    Ok(Model { inner: checked(decode("model", bytes)?)? })
}

/// Unpickles a `State`.
#[pyfunction]
pub(crate) fn _state_from_pickle(bytes: &[u8]) -> PyResult<State> {
    Ok(State { inner: decode("state", bytes)? })
}

fn rebuild<R: Precision>(
    py: Python<'_>,
    model: RModel<R>,
    state: RState<R>,
    p: (fissure::SolverConfig, fissure::FractureConfig, usize, Vec<fissure::FractureEvent>),
) -> PyResult<World> {
    let n = model.particle_count();
    if state.particle_q.len() != n || state.particle_qd.len() != n {
        return Err(PyValueError::new_err("damaged pickle of a fissure world: the state does not fit the model"));
    }
    let (solver, fracture, every, events) = p;
    let mut w = fissure::World::new(model, solver).with_fracture(fracture);
    w.state = state;
    w.fracture_every = every.max(1);
    w.events = events;
    World::from_world(py, w)
}

/// Unpickles a `World`.
#[pyfunction]
pub(crate) fn _world_from_pickle(py: Python<'_>, bytes: &[u8]) -> PyResult<World> {
    let p: WorldPickle = decode("world", bytes)?;
    let model = checked(p.model)?;
    p.solver.validate().map_err(value_err)?;
    p.fracture.validate().map_err(|e| core_err(e, &[]))?;
    let settings = (p.solver, p.fracture, p.fracture_every, p.events);
    match (model, p.state) {
        (Prec::F32(m), Prec::F32(s)) => rebuild(py, m, s, settings),
        (Prec::F64(m), Prec::F64(s)) => rebuild(py, m, s, settings),
        _ => Err(PyValueError::new_err("damaged pickle of a fissure world: model and state differ in precision")),
    }
}
