//! # fissure
//!
//! Soft bodies that stretch, inflate, collide and tear: a mass-spring system built from a triangle surface mesh
//! (edges are springs, vertices are mass points), the closed pressure model (an ideal gas, `P = nRT / V`, pushing
//! each triangle along its normal), wind, colliders, and four integrators — after Zeng & Wu 2010, "Soft Body
//! Simulation with Multiple Local Fracturing Effects".
//!
//! This crate is the facade: it re-exports [`fissure_core`] and adds [`World`], which bundles a model, its state,
//! a solver (CPU or GPU) and the fracture pass, and is the one stepping path, and [`scenes`], the scenes of the paper built in code.
//!
//! ```
//! use fissure::glam::DVec3;
//! use fissure::*;
//!
//! let mut b = ModelBuilder::new();
//! let ball = Mesh::icosphere(0.2, 2).translated(DVec3::new(0.0, 1.0, 0.0));
//! b.add_soft_body(&ball, &SoftBodyOptions { gas: Gas::Pressure(3000.0), ..Default::default() })?;
//! b.add_collider(Collider::ground(0.0))?;
//! let mut world: World<f32> = World::new(b.finalize()?, SolverConfig::default());
//! world.advance(0.5, 1e-4)?; // half a second in steps of 0.1 ms
//! assert!(world.model.center_of_mass(&world.state).y < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub use fissure_core::*;

#[cfg(feature = "render")]
pub mod output;
pub mod scene;
pub mod scenes;
pub mod vtk;
mod world;
pub use world::{Advance, GRAB_SPEED, World};
#[cfg(feature = "viewer")]
pub mod viewer;

/// The wgpu compute backend (feature `gpu`): [`gpu::GpuSolver`], [`gpu::GpuContext`].
#[cfg(feature = "gpu")]
pub use fissure_gpu as gpu;

/// The README's code, compiled and run as a doctest so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
