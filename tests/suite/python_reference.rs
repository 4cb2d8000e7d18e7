//! The reference the Python float64 path is checked against: the 32² cloth in wind (`scenes/cloth_wind.toml`)
//! integrated by RK4 in `Model<f64>` for 500 steps of its `dt`, positions written as little-endian f64 to
//! `crates/fissure-py/tests/data/cloth_wind_rk4_f64.bin` (committed). This test recomputes them and requires the
//! file to match within 1e-12 m; pytest (`test_float64.py`) runs the same scene through
//! `load_scene(..., precision="float64")` and requires the same. `FISSURE_BLESS=1 cargo test --release --test
//! python_reference` rewrites the file after a change to the physics on purpose (say why in the commit).

use fissure::scene::{Override, Scene};
use std::path::Path;

const STEPS: usize = 500;

fn reference_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/fissure-py/tests/data/cloth_wind_rk4_f64.bin")
}

#[test]
fn float64_rk4_cloth_matches_the_reference_python_checks() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cloth_wind.toml");
    let scene = Scene::load_with(&path, &[Override::new("solver.integrator", "rk4")]).expect("scene loads");
    let mut world = scene.world::<f64>().expect("world builds");
    for _ in 0..STEPS {
        world.step(scene.solver.dt).expect("RK4 steps");
    }
    let q: Vec<f64> = world.state.particle_q.iter().flat_map(|p| p.to_array()).collect();
    assert_eq!(q.len(), 32 * 32 * 3);
    assert!(q.iter().all(|x| x.is_finite()));
    let bytes: Vec<u8> = q.iter().flat_map(|x| x.to_le_bytes()).collect();
    if std::env::var("FISSURE_BLESS").is_ok_and(|v| v == "1") {
        std::fs::write(reference_path(), &bytes).expect("write the reference");
        return;
    }
    let stored = std::fs::read(reference_path()).expect("the committed reference (FISSURE_BLESS=1 writes it)");
    assert_eq!(stored.len(), bytes.len());
    let worst = stored
        .chunks_exact(8)
        .zip(&q)
        .map(|(b, x)| (f64::from_le_bytes(b.try_into().unwrap()) - x).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-12, "the f64 RK4 cloth moved {worst:e} m from the committed reference");
    // The run did something: the wind blew the cloth downwind (+z) by centimetres.
    let dz: f64 = q.chunks_exact(3).map(|p| p[2]).sum::<f64>() / 1024.0;
    assert!(dz > 1e-3, "mean z {dz}");
}
