//! The scenes of the seed paper, built in code and shared by the examples, tests and benchmarks.

use crate::*;
use glam::{DVec3, Vec3};

/// Parameters of [`ball_drop`].
#[derive(Clone, Debug, PartialEq)]
pub struct BallDrop {
    /// Ball radius \[m\]. Default 0.25.
    pub radius: f64,
    /// Icosphere subdivisions (3: 642 vertices). Default 3.
    pub subdivisions: u32,
    /// Drop height of the ball's centre \[m\]. Default 1.6.
    pub height: f64,
    /// Initial gas pressure \[Pa\]. Default 2500.
    pub pressure: f64,
    /// Ball mass \[kg\]. Default 0.4.
    pub mass: f64,
    /// Half the width of the square room \[m\]. Default 1.2.
    pub room_half_width: f32,
}

impl Default for BallDrop {
    fn default() -> Self {
        BallDrop { radius: 0.25, subdivisions: 3, height: 1.6, pressure: 2500.0, mass: 0.4, room_half_width: 1.2 }
    }
}

/// The seed's Fig. 5: a pressurised ball dropped into a room with four walls and spherical obstacles, thrown
/// slightly sideways so it hits an obstacle, a wall and the floor.
pub fn ball_drop(p: &BallDrop) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(p.mass),
        stiffness: Stiffness::Membrane(2500.0),
        damping: Damping::Ratio(0.3),
        bending: Some(Stiffness::Membrane(50.0)),
        gas: Gas::Pressure(p.pressure),
        velocity: DVec3::new(0.8, 0.0, 0.3),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(p.radius, p.subdivisions).translated(DVec3::new(-0.3, p.height, -0.1)), &opts)?;
    room(&mut b, p.room_half_width)?;
    for (c, r) in
        [(Vec3::new(0.15, 0.3, 0.0), 0.3), (Vec3::new(-0.7, 0.2, 0.5), 0.2), (Vec3::new(0.6, 0.15, -0.6), 0.15)]
    {
        b.add_collider(Collider::ball(c, r).with_restitution(0.4).with_friction(0.3))?;
    }
    Ok(b)
}

/// A floor at y = 0 and four walls at `±half_width` in x and z.
pub fn room(b: &mut ModelBuilder, half_width: f32) -> Result<(), ModelError> {
    b.add_collider(Collider::ground(0.0).with_restitution(0.3).with_friction(0.5))?;
    for (p, n) in [
        (Vec3::new(half_width, 0.0, 0.0), Vec3::NEG_X),
        (Vec3::new(-half_width, 0.0, 0.0), Vec3::X),
        (Vec3::new(0.0, 0.0, half_width), Vec3::NEG_Z),
        (Vec3::new(0.0, 0.0, -half_width), Vec3::Z),
    ] {
        b.add_collider(Collider::plane(p, n).with_restitution(0.5).with_friction(0.2))?;
    }
    Ok(())
}

/// The seed's Fig. 4: a cloth hanging from two corners in a gusty wind. `n × n` particles, 1 m wide.
pub fn cloth_wind(n: usize) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    let spacing = 1.0 / (n - 1) as f64;
    let opts = ClothOptions {
        mass: Mass::AreaDensity(0.3),
        stiffness: Stiffness::Membrane(400.0),
        shear: Some(Stiffness::Membrane(100.0)),
        bending: Some(Stiffness::Membrane(20.0)),
        damping: Damping::Ratio(0.2),
        pins: vec![0, n - 1],
        aero: Aero::default(),
        fracture: None,
    };
    // Vertical sheet in the XY plane, top edge at y = 1.5, facing the wind along +z.
    b.add_cloth_grid(n, n, spacing, |q| DVec3::new(q.x - 0.5, 1.5 + q.y, 0.0), &opts)?;
    b.wind(WindField { velocity: DVec3::new(0.0, 0.0, 4.0), ..Default::default() })?;
    b.add_collider(Collider::ground(0.0))?;
    Ok(b)
}

/// The foundation benchmark's cloth: `n × n` particles, spacing 1 cm, 1 g each, structural + shear + bend springs
/// of 1000 N/m (97,026 for n = 128), damping 0.01 N·s/m, two corners pinned, horizontal at y = 1, no wind.
pub fn benchmark_cloth(n: usize) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    let opts = ClothOptions {
        mass: Mass::PerParticle(1e-3),
        stiffness: Stiffness::PerSpring(1000.0),
        shear: Some(Stiffness::PerSpring(1000.0)),
        bending: Some(Stiffness::PerSpring(1000.0)),
        damping: Damping::PerSpring(0.01),
        pins: vec![0, n - 1],
        aero: Aero::NONE,
        fracture: None,
    };
    b.add_cloth_grid(n, n, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts)?;
    Ok(b)
}

/// Issue 16's contact benchmark (`benches/contact.rs`): an `n × n` cloth 1.27 m wide (1 cm spacing at n = 128),
/// 0.25 kg/m², at y = 0.75 above a ball collider (radius 0.3 m) and the floor, which it falls onto and folds
/// over; `self_collision` switches its contact with itself on (friction 0.4, the default thickness).
pub fn folding_cloth(n: usize, self_collision: bool) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    b.add_collider(Collider::ball(Vec3::new(0.0, 0.3, 0.0), 0.3).with_friction(0.5).with_restitution(0.0))?;
    b.add_collider(Collider::ground(0.0).with_restitution(0.0))?;
    let spacing = 0.01 * 128.0 / n as f64;
    let w = spacing * (n - 1) as f64;
    let opts = ClothOptions {
        mass: Mass::AreaDensity(0.25),
        stiffness: Stiffness::Membrane(400.0),
        shear: Some(Stiffness::Membrane(100.0)),
        bending: Some(Stiffness::Membrane(1.0)),
        damping: Damping::Ratio(0.2),
        ..Default::default()
    };
    let place = |q: DVec3| DVec3::new(q.x - w / 2.0 + 0.05, 0.75, q.y + w / 2.0);
    let h = b.add_cloth_grid(n, n, spacing, place, &opts)?;
    if self_collision {
        b.set_contact(h.index, Contact { self_collision: true, friction: 0.4, ..Default::default() })?;
    }
    Ok(b)
}

/// Eight coarse balls (5 cm radius, 42 vertices, gas at 500 Pa, each in contact with itself and the others) on the
/// corners of a 13 cm cube, no gravity, thrown into the middle: the even-numbered ones at `fast` to `2 fast` m/s,
/// the others at 5 cm/s, their aims jittered by a fixed sequence. A check of contact with slow bodies beside fast
/// ones (each pair's reach is its own: `fissure_core::contact`'s docs); `tests/suite/contact_scenes.rs` and
/// `tests/gpu/contact.rs` step it at `fast` = 100 m/s.
pub fn crowd(fast: f64) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO)?;
    // xorshift64, a fixed sequence in [-1, 1).
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for k in 0..8 {
        let at = DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64) * 0.13 - DVec3::splat(0.065);
        let aim = (-at).normalize() + 0.3 * DVec3::new(unit(), unit(), unit());
        let speed = if k % 2 == 0 { fast * (1.0 + unit().abs()) } else { 0.05 };
        let opts = SoftBodyOptions {
            mass: Mass::Total(0.05),
            stiffness: Stiffness::Membrane(800.0),
            damping: Damping::Ratio(0.1),
            gas: Gas::Pressure(500.0),
            velocity: speed * aim.normalize(),
            ..Default::default()
        };
        let h = b.add_soft_body(&Mesh::icosphere(0.05, 1).translated(at), &opts)?;
        b.set_contact(h.index, Contact { self_collision: true, ..Default::default() })?;
    }
    Ok(b)
}
