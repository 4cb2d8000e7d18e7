//! The facade's integration tests, one binary (each `tests/*.rs` file was a binary of its own, and each
//! re-compiled the solver's generic code and linked it again: ~20–45 s each of a release test build on 2 cores).
//! Apart: `isa` (the instruction-set cap it sets holds for its whole process), `examples` (the `viewer` feature)
//! and the GPU tests (`tests/gpu/`, the `gpu` feature). Run one module's tests with
//! `cargo test --release --test suite state_hash::`.

#[path = "../common/mod.rs"]
mod common;
#[path = "../scene_check/mod.rs"]
mod scene_check;

mod advance;
mod contact_scenes;
mod propagation;
mod python_reference;
mod state_hash;
mod tearing;
mod validation;
