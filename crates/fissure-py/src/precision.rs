//! The two precisions behind one set of Python classes: a `Model`, `State`, `Solver` or `World` holds either the
//! engine's `f32` objects (the default: fast) or its `f64` ones (the reference path the harness uses), chosen by
//! `ModelBuilder.finalize(precision=...)`. Arrays come out as float32 or float64 to match; mixing the two in one
//! call is a `TypeError`.

use crate::*;
use serde::{Deserialize, Serialize};

/// One value of either precision.
#[derive(Clone, Serialize, Deserialize)]
pub(crate) enum Prec<A, B> {
    F32(A),
    F64(B),
}

impl<A: Default, B> Default for Prec<A, B> {
    fn default() -> Self {
        Prec::F32(A::default())
    }
}

impl<A, B> Prec<A, B> {
    /// "float32" or "float64".
    pub(crate) fn name(&self) -> &'static str {
        match self {
            Prec::F32(_) => "float32",
            Prec::F64(_) => "float64",
        }
    }
    pub(crate) fn is_f64(&self) -> bool {
        matches!(self, Prec::F64(_))
    }
}

/// The error of a call that mixes precisions.
pub(crate) fn mixed(a: &'static str, b: &'static str) -> PyErr {
    PyTypeError::new_err(format!("a {a} object with a {b} one: use one precision throughout (finalize(precision=...))"))
}

/// `precision=` as a flag: true for float64.
pub(crate) fn parse_precision(p: &str) -> PyResult<bool> {
    match p {
        "float32" | "f32" | "single" => Ok(false),
        "float64" | "f64" | "double" => Ok(true),
        other => Err(PyValueError::new_err(format!("precision must be \"float32\" or \"float64\", got {other:?}"))),
    }
}

/// Runs `$body` with `$x` bound to the inner value, whichever precision it is (the body is compiled for both).
macro_rules! each {
    ($e:expr, $x:ident => $body:expr) => {
        match $e {
            $crate::precision::Prec::F32($x) => $body,
            $crate::precision::Prec::F64($x) => $body,
        }
    };
}

/// Runs `$body` with both values bound when they have the same precision; a `TypeError` otherwise.
macro_rules! pair {
    ($a:expr, $b:expr, ($x:ident, $y:ident) => $body:expr) => {
        match ($a, $b) {
            ($crate::precision::Prec::F32($x), $crate::precision::Prec::F32($y)) => Ok($body),
            ($crate::precision::Prec::F64($x), $crate::precision::Prec::F64($y)) => Ok($body),
            (a, b) => Err($crate::precision::mixed(a.name(), b.name())),
        }
    };
}

pub(crate) use {each, pair};

pub(crate) type AnyWorld = Prec<fissure::World<f32>, fissure::World<f64>>;

/// The engine's two float types, and how each is wrapped.
pub(crate) trait Precision: fissure::Real + numpy::Element {
    fn model(m: RModel<Self>) -> crate::model::AnyModel;
    fn state(s: RState<Self>) -> crate::model::AnyState;
    fn solver(s: fissure::CpuSolver<Self>) -> crate::model::AnySolver;
    fn world(w: fissure::World<Self>) -> AnyWorld;
}

macro_rules! precision {
    ($t:ty, $v:ident) => {
        impl Precision for $t {
            fn model(m: RModel<Self>) -> crate::model::AnyModel {
                Prec::$v(m)
            }
            fn state(s: RState<Self>) -> crate::model::AnyState {
                Prec::$v(s)
            }
            fn solver(s: fissure::CpuSolver<Self>) -> crate::model::AnySolver {
                Prec::$v(s)
            }
            fn world(w: fissure::World<Self>) -> AnyWorld {
                Prec::$v(w)
            }
        }
    };
}
precision!(f32, F32);
precision!(f64, F64);
