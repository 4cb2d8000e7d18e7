//! The core's integration tests, one binary (each `tests/*.rs` file was a binary of its own, and each re-compiled
//! the solver's generic code and linked it again: ~10–60 s each of a release test build on 2 cores). Only tests
//! that need a process of their own stay apart: `alloc` (a counting global allocator), `team` (it sets the global
//! pool), and `determinism` (CI runs it alone without the `parallel` feature). Run one module's tests with
//! `cargo test -p fissure-core --release --test suite soft_contact::`.

#[path = "../common/mod.rs"]
mod common;

mod contact;
mod crack_edges;
mod fracture;
mod mesh;
mod physics;
mod soft_contact;
mod stress;
mod terms;
mod validation;
