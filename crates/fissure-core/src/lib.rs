#![doc = include_str!("../README.md")]
#![warn(missing_docs)]
// Kernels walk several parallel arrays with one global index (`start + k`), as their WGSL twins do with
// `global_invocation_id`; iterator chains over four or five zipped slices would hide that.
#![allow(clippy::needless_range_loop)]

pub mod collision;
pub mod contact;
pub mod csr;
pub mod error;
pub mod forces;
pub mod fracture;
pub mod integrator;
pub mod isa;
pub mod mesh;
pub mod model;
mod par;
pub mod real;
pub mod solver;
pub mod stability;
#[cfg(feature = "parallel")]
mod team;
pub mod timers;
pub mod topology;
pub use forces::wind;

pub use collision::Collider;
pub use contact::Contact;
pub use error::{MeshError, ModelError, StepError};
pub use fracture::{
    Fracture, FractureConfig, FractureEvent, FractureKind, Measures, TopologyDelta, Trigger, check_invariants,
};
pub use glam;
pub use mesh::{Mesh, Renumbering};
pub use model::{
    BodyHandle, BodyKind, BodyRow, Breakable, ClothOptions, Damping, DampingModel, Energy, Gas, Handle, Mass, Model,
    ModelBuilder, Opening, ParticleRow, SoftBodyOptions, SpringKind, SpringRow, SpringRun, State, Stiffness, TriGrid,
    TriRow,
};
pub use parry3d;
pub use real::{Real, Vector3};
pub use solver::{CgStats, ContactStats, CpuSolver, Integrator, LocalFuture, Solver, SolverConfig, ready_now};
pub use stability::{ContactStepGuard, StabilityBound, max_stable_dt_1dof};
pub use timers::{Stage, StageTimers};
pub use wind::{Aero, WindField};
