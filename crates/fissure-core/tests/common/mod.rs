//! Shared helpers of the core's integration tests.
#![allow(dead_code)]

use fissure_core::glam::DVec3;

/// A small deterministic PRNG (SplitMix64) so tests need no extra dependency and never vary.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    pub fn sym(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    pub fn vec(&mut self) -> DVec3 {
        DVec3::new(self.sym(), self.sym(), self.sym())
    }
}

/// The foundation benchmark's cloth options (`fissure::scenes::benchmark_cloth`, which this crate cannot reach):
/// 1 g per particle, structural, shear and bending springs of 1000 N/m, damping 0.01 N·s/m, no aerodynamics,
/// pins at grid indices `pins`, and `fracture`.
pub fn bench_cloth_options(pins: Vec<usize>, fracture: Option<fissure_core::Breakable>) -> fissure_core::ClothOptions {
    use fissure_core::{Aero, ClothOptions, Damping, Mass, Stiffness};
    ClothOptions {
        mass: Mass::PerParticle(1e-3),
        stiffness: Stiffness::PerSpring(1000.0),
        shear: Some(Stiffness::PerSpring(1000.0)),
        bending: Some(Stiffness::PerSpring(1000.0)),
        damping: Damping::PerSpring(0.01),
        pins,
        aero: Aero::NONE,
        fracture,
    }
}

/// `m` with its vertices renumbered at random (old vertex `i` becomes `perm[i]`) and, if `triangles`, its
/// triangles then reordered at random too: the same surface numbered without locality. Returns it and `perm`.
pub fn shuffled_mesh(m: &fissure_core::Mesh, seed: u64, triangles: bool) -> (fissure_core::Mesh, Vec<u32>) {
    let mut rng = Rng(seed);
    let n = m.vertex_count();
    let mut perm: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        perm.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
    }
    let mut positions = vec![DVec3::ZERO; n];
    for (old, &new) in perm.iter().enumerate() {
        positions[new as usize] = m.positions()[old];
    }
    let mut tris: Vec<[u32; 3]> = m.triangles().iter().map(|t| t.map(|v| perm[v as usize])).collect();
    if triangles {
        for i in (1..tris.len()).rev() {
            tris.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
    }
    (fissure_core::Mesh::new(positions, tris).expect("a renumbered mesh is valid"), perm)
}
