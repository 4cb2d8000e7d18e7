//! Arrays and values in and out: validated numpy reads (shape, dtype, finiteness), copies out, error mapping.

use crate::*;

/// A core error as `ValueError`; a bad parameter is named by its Python keyword (`rename` maps the core's name
/// where the keyword differs): "`radius` must be finite and > 0 \[m\], got -1".
pub(crate) fn core_err(e: fissure::ModelError, rename: &[(&str, &'static str)]) -> PyErr {
    match e.parameter(rename) {
        Some((arg, message)) => PyValueError::new_err(format!("`{arg}` {message}")),
        None => value_err(e),
    }
}

pub(crate) fn value_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `obj` as a numpy array (array-likes such as lists go through `numpy.asarray`).
pub(crate) fn as_ndarray<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyUntypedArray>> {
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

pub(crate) fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

pub(crate) fn check_n3(name: &str, a: &Bound<'_, PyUntypedArray>) -> PyResult<usize> {
    let shape = a.shape();
    if a.ndim() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!("{name} must have shape (N, 3), got {shape:?}")));
    }
    Ok(shape[0])
}

/// Reads an `(N, 3)` float array (float32 or float64, any layout) as `f64` triples; rejects NaN/inf.
pub(crate) fn read_points(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<DVec3>> {
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
pub(crate) fn read_triangles(obj: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
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

pub(crate) fn vec3(name: &str, v: (f64, f64, f64)) -> PyResult<DVec3> {
    let d = DVec3::new(v.0, v.1, v.2);
    if !d.is_finite() {
        return Err(PyValueError::new_err(format!("{name} = {v:?} is not finite")));
    }
    Ok(d)
}

pub(crate) fn points_out<'py, R: numpy::Element>(
    py: Python<'py>,
    p: impl ExactSizeIterator<Item = [R; 3]>,
) -> Bound<'py, PyArray2<R>> {
    let n = p.len();
    let flat: Vec<R> = p.flatten().collect();
    numpy::PyArray1::from_vec(py, flat).reshape([n, 3]).expect("n * 3 elements")
}

pub(crate) fn f32x3(name: &str, v: (f64, f64, f64)) -> PyResult<Vec3> {
    Ok(vec3(name, v)?.as_vec3())
}

pub(crate) fn write_points<V: fissure::Vector3<R>, R: fissure::Real>(
    name: &str,
    dst: &mut [V],
    src: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let pts = read_points(name, src)?;
    if pts.len() != dst.len() {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({}, 3), got ({}, 3)",
            dst.len(),
            pts.len()
        )));
    }
    for (d, p) in dst.iter_mut().zip(pts) {
        *d = V::from_dvec3(p);
    }
    Ok(())
}

pub(crate) fn copy_into<V: fissure::Vector3<R>, R: fissure::Real + numpy::Element>(
    name: &str,
    src: &[V],
    out: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let arr = out.cast::<PyArray2<R>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a {} numpy array of shape ({}, 3), got {}",
            if std::mem::size_of::<R>() == 4 { "float32" } else { "float64" },
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
