pub use fissure_core::*;
