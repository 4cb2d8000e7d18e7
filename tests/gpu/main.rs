//! The GPU tests, one binary (the `gpu` feature): every kernel against its CPU twin (`parity`), and contact between
//! surfaces against the CPU pass (`contact`). With `CI` set, a missing adapter fails them (CI installs lavapipe);
//! elsewhere they are skipped loudly.

#[path = "../gpu_support/mod.rs"]
mod gpu_support;
#[path = "../scene_check/mod.rs"]
mod scene_check;

mod contact;
mod parity;
