//! Test models shared by the tearing tests and the property tests of propagating cracks.

use fissure::glam::DVec3;
use fissure::*;

/// Membrane stiffness `E·h` of the test sheet \[N/m\].
pub const EH: f64 = 1000.0;

/// A `width` × `height` sheet in the xy plane, `nx` particles across, its left and right columns pulled apart
/// at `speed` \[m/s\] each; returns the world and the particle indices of the right column.
pub fn pulled_sheet(nx: usize, width: f64, height: f64, speed: f64, tear: f64) -> (World<f64>, Vec<usize>) {
    let h = width / (nx - 1) as f64;
    let ny = (height / h).round() as usize + 1;
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = ClothOptions {
        mass: Mass::AreaDensity(0.5),
        stiffness: Stiffness::Membrane(EH),
        shear: Some(Stiffness::Membrane(EH / 4.0)),
        bending: Some(Stiffness::Membrane(EH / 100.0)),
        damping: Damping::Ratio(0.3),
        pins: Vec::new(),
        aero: Aero::NONE,
        fracture: Some(Breakable { tear_strength: tear, ..Default::default() }),
    };
    let body = b.add_cloth_grid(nx, ny, h, |p| p, &opts).unwrap();
    let left: Vec<usize> = (0..ny).map(|j| body.first_particle + j * nx).collect();
    let right: Vec<usize> = left.iter().map(|i| i + nx - 1).collect();
    b.add_handle(&left, Handle::linear(DVec3::new(-speed, 0.0, 0.0), 0.0, 10.0)).unwrap();
    b.add_handle(&right, Handle::linear(DVec3::new(speed, 0.0, 0.0), 0.0, 10.0)).unwrap();
    let model = b.finalize::<f64>().unwrap();
    (World::new(model, SolverConfig::default()).with_fracture(FractureConfig::default()), right)
}

/// A gas-filled ball of radius 0.25 m (`Mesh::icosphere` of `subdivisions`), no gravity, whose membrane (2500 N/m,
/// bending 50 N/m, 0.4 kg, damping ratio 0.3) tears at `tear_strength` \[N/m\] under `pressure` \[Pa\], with
/// fracture on (averaged over 5 ms), in `f64`.
pub fn breakable_ball(subdivisions: u32, pressure: f64, tear_strength: f64) -> World<f64> {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::Membrane(2500.0),
        damping: Damping::Ratio(0.3),
        bending: Some(Stiffness::Membrane(50.0)),
        gas: Gas::Pressure(pressure),
        fracture: Some(Breakable { tear_strength, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, subdivisions), &opts).unwrap();
    let config = FractureConfig { trigger: Trigger::Averaged { window: 0.005 }, ..Default::default() };
    World::new(b.finalize::<f64>().unwrap(), SolverConfig::default()).with_fracture(config)
}
