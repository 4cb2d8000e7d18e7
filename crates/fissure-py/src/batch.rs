//! Scenes and batches: `load_scene` (with overrides) and `run_many` (many scenes or worlds in parallel, threads
//! inside Rust, the GIL released), outcomes as numpy arrays.

use crate::*;
use fissure::scene::{Job, Outcome, Override, Scene, SceneError};
use numpy::PyArray1;
use pyo3::types::{PyList, PyTuple};

/// A Python value as a TOML value: bool, int, float, str, and lists, tuples and dicts of them; numpy scalars and
/// arrays go through `tolist()`.
fn toml_value(key: &str, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyString};
    if v.hasattr("ndim")? && v.hasattr("tolist")? {
        return toml_value(key, &v.call_method0("tolist")?);
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| PyValueError::new_err(format!("override `{key}`: {v} is too large")))?;
        return Ok(toml::Value::Integer(i));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract()?;
            let value = toml_value(&format!("{key}.{k}"), &x)?;
            t.insert(k, value);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.extract()?;
        return items.iter().map(|x| toml_value(key, x)).collect::<PyResult<Vec<_>>>().map(toml::Value::Array);
    }
    Err(PyTypeError::new_err(format!(
        "override `{key}`: a {} is not a scene value (want bool, int, float, str or a list of them)",
        type_name(v)
    )))
}

/// `{"body[0].pressure": 4000, ...}` as overrides (None: none).
pub(crate) fn read_overrides(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Override>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(Vec::new()) };
    let d = obj
        .cast::<PyDict>()
        .map_err(|_| PyTypeError::new_err(format!("overrides: want a dict of key: value, got {}", type_name(obj))))?;
    d.iter()
        .map(|(k, v)| {
            let key: String = k.extract().map_err(|_| PyTypeError::new_err("overrides: keys must be strings"))?;
            Ok(Override { value: toml_value(&key, &v)?, key })
        })
        .collect()
}

fn scene_err(e: SceneError) -> PyErr {
    match e {
        SceneError::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        e => value_err(e),
    }
}

/// Reads a scene file (TOML, see `scenes/` and `fissure::scene`): returns a dict with `world` (a `World` at the
/// scene's initial state, with its integrator and fracture settings), `dt` \[s\], `duration` \[s\] and `title`.
/// `overrides` sets scene keys without editing the file: `{"body[0].pressure": 4000, "solver.dt": 2e-5}`.
/// `precision`: "float32" (default) or "float64". Unknown keys and bad values raise `ValueError` naming the key; a
/// missing file raises `OSError`.
#[pyfunction]
#[pyo3(signature = (path, overrides = None, *, precision = "float32"))]
pub(crate) fn load_scene<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    overrides: Option<&Bound<'py, PyAny>>,
    precision: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let f64 = crate::precision::parse_precision(precision)?;
    let scene = Scene::load_with(&path, &read_overrides(overrides)?).map_err(scene_err)?;
    // The scene's own world (its solver and fracture settings): the front end only translates.
    let world = if f64 {
        World::from_world(py, scene.world::<f64>().map_err(value_err)?)?
    } else {
        World::from_world(py, scene.world::<f32>().map_err(value_err)?)?
    };
    let d = PyDict::new(py);
    d.set_item("world", Py::new(py, world)?)?;
    d.set_item("dt", scene.solver.dt)?;
    d.set_item("duration", scene.solver.duration)?;
    d.set_item("title", scene.title)?;
    Ok(d)
}

/// The outcomes as a dict of numpy arrays (one entry per run) and `error` (a list: None or the message).
fn outcome_table<'py>(py: Python<'py>, runs: &[Outcome]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let ints = |f: fn(&Outcome) -> usize| PyArray1::from_vec(py, runs.iter().map(|o| f(o) as i64).collect());
    let floats = |f: fn(&Outcome) -> f64| PyArray1::from_vec(py, runs.iter().map(f).collect());
    d.set_item("ok", PyArray1::from_vec(py, runs.iter().map(|o| o.error.is_none()).collect()))?;
    d.set_item("spring_events", ints(|o| o.spring_events))?;
    d.set_item("core_events", ints(|o| o.core_events))?;
    d.set_item("detach_events", ints(|o| o.detach_events))?;
    d.set_item("events", ints(|o| o.events()))?;
    d.set_item("pieces", ints(|o| o.pieces))?;
    d.set_item("bodies", ints(|o| o.bodies))?;
    d.set_item("particles", ints(|o| o.particles))?;
    d.set_item("triangles", ints(|o| o.triangles))?;
    d.set_item("steps", ints(|o| o.steps))?;
    d.set_item("simulated", floats(|o| o.simulated))?;
    d.set_item("initial_gas_volume", floats(|o| o.initial_gas_volume))?;
    d.set_item("gas_volume", floats(|o| o.gas_volume))?;
    d.set_item("wall", floats(|o| o.wall))?;
    d.set_item("error", runs.iter().map(|o| o.error.clone()).collect::<Vec<_>>())?;
    Ok(d)
}

/// Runs many scenes, or many worlds, in parallel (threads inside Rust, the GIL released), one run per thread,
/// so each outcome is bit-identical to running it alone. Returns a dict of numpy arrays, one entry per run:
/// `ok`, `spring_events`, `core_events`, `detach_events`, `events`, `pieces`, `bodies`, `particles`,
/// `triangles`, `steps`, `simulated` \[s\], `initial_gas_volume` and `gas_volume` \[m^3\], `wall` \[s\], and `error`
/// (a list: None, or why that run failed; a failed run never stops the others).
///
/// - Scenes: `runs` is a list of scene paths, or of `(path, overrides)` pairs; `overrides` (a dict) applies to
///   every run without its own. Each runs for `duration` \[s\] (default: its file's) in steps of its `dt`.
/// - Worlds: `runs` is a list of `World`s, advanced in place by `duration` \[s\] in steps of `dt` \[s\] (both
///   required).
///
/// `threads`: runs at a time (default: one per core). `precision`: of the scenes' worlds, "float32" (default) or
/// "float64" (worlds keep their own).
#[pyfunction]
#[pyo3(signature = (runs, overrides = None, *, duration = None, dt = None, threads = None, precision = "float32"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_many<'py>(
    py: Python<'py>,
    runs: &Bound<'py, PyAny>,
    overrides: Option<&Bound<'py, PyAny>>,
    duration: Option<f64>,
    dt: Option<f64>,
    threads: Option<usize>,
    precision: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let f64 = crate::precision::parse_precision(precision)?;
    let items: Vec<Bound<'py, PyAny>> =
        runs.extract().map_err(|_| PyTypeError::new_err("run_many: `runs` must be a list of scenes or worlds"))?;
    if threads == Some(0) {
        return Err(PyValueError::new_err("run_many: `threads` must be at least 1"));
    }
    if let Some(d) = duration
        && !(d.is_finite() && d >= 0.0)
    {
        return Err(PyValueError::new_err(format!("run_many: `duration` must be >= 0 s, got {d}")));
    }
    if !items.is_empty() && items.iter().all(|w| w.is_instance_of::<World>()) {
        let (Some(duration), Some(dt)) = (duration, dt) else {
            return Err(PyValueError::new_err("run_many: worlds need `duration` and `dt` [s]"));
        };
        if !(dt.is_finite() && dt > 0.0) {
            return Err(PyValueError::new_err(format!("run_many: `dt` must be > 0 s, got {dt}")));
        }
        let worlds: Vec<Bound<'py, World>> =
            items.iter().map(|w| w.cast::<World>().cloned()).collect::<Result<_, _>>()?;
        let outcomes = World::advance_many(py, &worlds, duration, dt, threads)?;
        return outcome_table(py, &outcomes);
    }
    if items.iter().any(|w| w.is_instance_of::<World>()) {
        return Err(PyTypeError::new_err("run_many: give either scenes or worlds, not both"));
    }
    let common = read_overrides(overrides)?;
    let jobs = items
        .iter()
        .map(|item| {
            let (path, own) = match item.extract::<(std::path::PathBuf, Bound<'py, PyAny>)>() {
                Ok((p, o)) => (p, Some(read_overrides(Some(&o))?)),
                Err(_) => (
                    item.extract::<std::path::PathBuf>().map_err(|_| {
                        PyTypeError::new_err(format!(
                            "run_many: a run is a scene path, a (path, overrides) pair or a World, got {}",
                            type_name(item)
                        ))
                    })?,
                    None,
                ),
            };
            Ok(Job { scene: path, overrides: own.unwrap_or_else(|| common.clone()), duration })
        })
        .collect::<PyResult<Vec<Job>>>()?;
    let outcomes = py.detach(|| {
        if f64 {
            fissure::scene::run_all::<f64>(&jobs, threads)
        } else {
            fissure::scene::run_all::<f32>(&jobs, threads)
        }
    });
    outcome_table(py, &outcomes)
}
