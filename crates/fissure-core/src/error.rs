//! Errors. Every fallible public function returns one of these; nothing on a user-reachable path panics.

use thiserror::Error;

/// A mesh that cannot be simulated, with what is wrong and where.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MeshError {
    /// No vertices or no triangles.
    #[error("mesh is empty: {vertices} vertices, {triangles} triangles")]
    Empty {
        /// Vertex count.
        vertices: usize,
        /// Triangle count.
        triangles: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value:?} (NaN or infinite)")]
    NonFinite {
        /// Vertex index.
        vertex: usize,
        /// The coordinates.
        value: [f64; 3],
    },
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The bad index.
        index: u64,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A triangle repeats a vertex or has (numerically) zero area.
    #[error("triangle {triangle} {vertices:?} is degenerate: {reason}")]
    Degenerate {
        /// Triangle index.
        triangle: usize,
        /// Its vertices.
        vertices: [u32; 3],
        /// Repeated vertex or zero area.
        reason: &'static str,
    },
    /// More than two triangles share an edge.
    #[error(
        "edge ({a}, {b}) is non-manifold: shared by {faces} triangles (at most 2 allowed), e.g. triangles {examples:?}"
    )]
    NonManifoldEdge {
        /// Edge end.
        a: u32,
        /// Edge end.
        b: u32,
        /// How many triangles share it.
        faces: usize,
        /// Up to three of them.
        examples: Vec<u32>,
    },
    /// Two triangles sharing an edge traverse it in the same direction (normals disagree).
    #[error(
        "inconsistent winding: triangles {t0} and {t1} both traverse edge ({a} -> {b}) in the same direction; flip one of them"
    )]
    InconsistentWinding {
        /// Edge start.
        a: u32,
        /// Edge end.
        b: u32,
        /// First triangle.
        t0: u32,
        /// Second triangle.
        t1: u32,
    },
    /// A closed surface is needed (a pressure model) but the mesh has boundary edges.
    #[error(
        "mesh is open ({boundary_edges} boundary edges, e.g. ({a}, {b})): a gas pressure model needs a closed surface; add it as cloth, or close the holes"
    )]
    Open {
        /// Count of boundary edges.
        boundary_edges: usize,
        /// One boundary edge end.
        a: u32,
        /// The other end.
        b: u32,
    },
    /// A closed mesh whose normals point inwards, and reorientation was not allowed.
    #[error("closed mesh faces inwards (signed volume {volume:.6e} m^3 < 0); enable reorientation or flip its winding")]
    InwardFacing {
        /// Signed volume.
        volume: f64,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What failed.
        message: String,
    },
}

/// A model that cannot be built from the given parameters.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ModelError {
    /// The mesh is unusable.
    #[error("mesh: {0}")]
    Mesh(#[from] MeshError),
    /// A parameter is out of its valid range.
    #[error("invalid parameter `{name}` = {value}: {expected}")]
    Parameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// A particle index (a pin, say) does not exist.
    #[error("`{name}` names particle {index}, but the body has only {count} particles")]
    ParticleOutOfRange {
        /// The parameter.
        name: &'static str,
        /// The index.
        index: usize,
        /// Particle count.
        count: usize,
    },
    /// Nothing was added.
    #[error("the model is empty: add a soft body, a cloth or particles first")]
    Empty,
}

impl ModelError {
    /// For a bad parameter: its name as a front end calls it (`rename` maps the core's names that differ there:
    /// a scene key, a Python keyword) and what is wrong, `must be …, got …`. `None` for other errors. The scene
    /// loader and the Python bindings build their messages from this, so they check nothing themselves.
    pub fn parameter(&self, rename: &[(&str, &'static str)]) -> Option<(&'static str, String)> {
        match *self {
            ModelError::Parameter { name, value, expected } => {
                let name = rename.iter().find(|(n, _)| *n == name).map_or(name, |(_, k)| *k);
                Some((name, format!("must be {expected}, got {value}")))
            }
            _ => None,
        }
    }
}

/// A step that could not be completed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StepError {
    /// The state became NaN or infinite.
    #[error("state blew up at t = {time:.6} s: particle {particle} has a non-finite {what}; {}", blow_up_cause(*.dt, *.stable_dt))]
    NonFinite {
        /// Simulation time.
        time: f64,
        /// The step size.
        dt: f64,
        /// First particle found non-finite.
        particle: usize,
        /// position or velocity.
        what: &'static str,
        /// The integrator's stability bound for the mesh \[s\] ([`crate::stability`]); infinite for
        /// the implicit integrator, NaN when the backend does not know it.
        stable_dt: f64,
    },
    /// An explicit step above the stability bound of a model in contact, refused before it is taken (see
    /// [`crate::stability::ContactStepGuard`]): contact's displacement bound would cap the instability's runaway
    /// moves, so that instead of blowing up into a [`StepError::NonFinite`] that names the cause, the run would
    /// go on jittering, wrong and many times slower.
    #[error(
        "the time step {dt:e} s is {:.3}× the springs' stability bound {stable_dt:.3e} s, and the model has contact, \
         which would hide the instability (its displacement bound caps the runaway moves: the run would go on, \
         jittering and slow, instead of failing): take substeps (the substep safety setting: \
         `solver.substep_safety` in a scene file, `substep_safety=` in Python, `SolverConfig::substep_safety` in \
         Rust), take a smaller step, or use the implicit integrator",
        dt / stable_dt
    )]
    AboveStabilityBound {
        /// The step asked for \[s\].
        dt: f64,
        /// The integrator's stability bound for the model \[s\] ([`crate::stability`]).
        stable_dt: f64,
    },
    /// The time step is not positive and finite.
    #[error("time step `dt` must be positive and finite, got {0}")]
    BadTimeStep(f64),
    /// The state does not belong to this model.
    #[error("state has {state} particles but the model has {model}")]
    StateMismatch {
        /// Particles in the state.
        state: usize,
        /// Particles in the model.
        model: usize,
    },
    /// The implicit solver's conjugate gradients did not converge.
    #[error("conjugate gradients did not converge in {iterations} iterations (relative residual {residual:e})")]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// Final relative residual.
        residual: f64,
    },
    /// A solver setting is out of range.
    #[error("invalid solver setting: {0}")]
    Config(String),
    /// A solver backend (the GPU) failed: device lost, read-back failed, model not supported.
    #[error("solver backend failed: {0}")]
    Backend(String),
}

/// Names the likely cause of a blow-up from the step and the mesh's stability bound.
fn blow_up_cause(dt: f64, stable_dt: f64) -> String {
    if stable_dt.is_nan() {
        format!(
            "the time step {dt:e} s is probably above the stability limit (try more substeps, the implicit integrator, or softer springs)"
        )
    } else if dt > stable_dt {
        format!(
            "the time step {dt:e} s is {:.3}× the springs' stability bound {stable_dt:e} s: take substeps (the substep safety setting: `solver.substep_safety` in a scene file, `substep_safety=` in Python, `SolverConfig::substep_safety` in Rust), use the implicit integrator, or soften the springs",
            dt / stable_dt
        )
    } else {
        format!(
            "the time step {dt:e} s is within the springs' stability bound {stable_dt:e} s, so something else drove it: extreme gas pressure, a collider moving through the body, wind, or a state that was already broken"
        )
    }
}
