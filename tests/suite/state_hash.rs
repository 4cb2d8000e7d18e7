//! Bit-exact regression hashes of the final CPU state of each scene file and of a fracture run.
//!
//! Recorded on `main` before the architecture refactor of issue 14 (one stepping path, one home per equation,
//! files split by role) and required to hold after it: a refactor changes where code lives, not one bit of what
//! it computes. A change that alters the physics on purpose (a bug fix) updates the hash in the same commit and
//! says why in its message.
//!
//! Changed on purpose since: issue 15 (the fracture trigger reads the strains, loads and volumes the solver
//! measured at the start of the step instead of recomputing them in `f64` after it; the fracture scene's step
//! went from 5e-5 s to 2e-4 s, under its stability bound as now estimated): the fracture scene and the punctured ball.
//! Then the wind sampled in the solver's precision with polynomial sines (`WindField::prepare`) and the scenes'
//! steps set to 0.75–0.79× their estimated stability bounds (cloth in wind 1e-4 → 2e-4 s, ball drop 1e-4 → 1.6e-4 s).
//! Then issue 16: the fracture scene has contact on (its core blocks collide with the ball they came from); its
//! hash also moves when the contact candidate lists are rebuilt at other steps (the impulses are solved in the
//! lists' order).
//! Then issue 17: grid cloths' second diagonals and bending springs get the stiffness of one cell's area under
//! `Stiffness::Membrane` (they had none: an area of 0 in Van Gelder's formula), which moves the cloth in wind;
//! core blocks are a vertex's whole one-ring and spring-mode nodes sit on the spring (the punctured ball, whose
//! second puncture moved from vertex 300 to 600: 300 is now on the rim of the first hole); the fracture scene
//! tears by a tear strength with an averaged trigger and cracks that run from tips.
//! Then issue 15 again: the spring-run kernel takes spans of 128 springs instead of 64, and the order in which a
//! particle's spring forces are added follows the spans (end 0 and end 1 of a run in one span or in two), which
//! moves the cloth in wind (a grid cloth) and nothing else.
//! Then issue 15/16's contact speed-up: the candidate lists are rebuilt at other steps (bodies whose boxes were
//! far apart may drift further before a rebuild) and each element's partners are listed in index order rather
//! than the grid's cell order (the pairs' Gauss–Seidel order no longer depends on the cell size): the fracture
//! scene.
//! Then issue 15's gather: a particle's pressure push is its body's `P/6` times the sum of its triangles' cross
//! vectors (one multiply) instead of the sum of `cross · P/6` per triangle (`forces::pressure_share`): the ball
//! drop, the punctured ball and the fracture scene, by rounding.
//! Then (2026-11-25) the contact pass resolves the particles it moved against the colliders again, within each
//! particle's displacement bound (a block pressed into the ground by the ball stayed up to 0.12 mm inside): the
//! fracture scene.
//! Then (2026-11-25) the wind on cloth grids is summed per particle a row of quads at a time (`forces::wind_grid`)
//! instead of gathered from per-triangle forces, and the drag and lift are written through `c·v` (one square root
//! and one division fewer: `forces::wind::aero_components`): the cloth in wind, by rounding.
//! Then (2026-11-27) a triangle's relative air is the mean of its corners' `w(x) - v`, the field sampled once per
//! particle, instead of the field at its centroid minus its corners' mean velocity (both second-order quadratures
//! of the same field; half the sines: `forces::wind`'s docs): the cloth in wind.
//! Then (2026-11-27) each contact pair's reach is its own (the thickness plus its four particles' largest move over
//! `GAMMA`, not the fastest particle's anywhere) and each particle's displacement bound starts at `GAMMA h + d_i`
//! (`solver::contact`'s `near`): fewer pairs within reach, the same guarantee: the fracture scene.
//! Then (2026-11-29) `Mesh::icosphere` numbers its vertices for locality (reverse Cuthill–McKee, triangles in
//! their corners' order): the same surfaces, other particle, spring and triangle orders, so other orders of
//! addition, and the punctured ball's vertices 5 and 600 and spring 100 are other places on it: the ball drop,
//! the fracture scene and the punctured ball.
//! Then (2026-11-29) a gas volume's sum over a chunk of triangles goes to eight partial sums (triangle `k` to lane
//! `k mod 8`, joined pairwise: `forces::VolumeSum`) instead of one chain: the ball drop, the fracture scene and the
//! punctured ball, by rounding.
//! Then (2026-11-29, thirtieth session) a core split moves each spoke's end from the ring vertex to its copy
//! instead of breaking it and adding a new spring (the same spring in another place of the model: other orders of
//! addition; no broken springs left in the spring pass), and a body's caps' volume terms are summed loop by loop
//! where they are formed (`forces::pressure::Caps::totals`) before being added to its volume: the fracture scene
//! and the punctured ball.
//! Then (2026-12-07, forty-fourth session) a piece born crossing a body of its family takes no contact with it
//! until they are a thickness apart (`solver::contact::family`): the fracture scene, whose core block born at
//! t = 1.0995 s where the collapsed ball lay folded had been held in place by its pairs with the ball.
//!
//! The hash covers positions, velocities and time (their bits), the counts of particles, springs, triangles and
//! bodies, every body's gas, and the fracture events (kind, time bits, index). The CPU engine is deterministic
//! for any thread count, so one value holds on every machine with the same floating-point semantics (x86-64
//! SSE2, AVX2 and AVX-512 give the same bits here: the vector kernels never fuse multiply-adds; `tests/isa.rs`
//! compares them on every set the CPU has, and these hashes, recorded on an AVX2 host, hold on an AVX-512 one).

use fissure::scene::Scene;
use fissure::*;
use std::path::Path;

/// FNV-1a, 64 bit: a fixed, dependency-free hash (std's `DefaultHasher` may change between Rust releases).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
}

fn hash_world<R: Real>(w: &World<R>) -> u64 {
    let mut h = Fnv::new();
    let m = &w.model;
    for c in [m.particle_count(), m.spring_count(), m.tri_count(), m.body_count()] {
        h.u64(c as u64);
    }
    h.u64(w.state.time.to_bits());
    for (x, v) in w.state.particle_q.iter().zip(&w.state.particle_qd) {
        for c in x.to_dvec3().to_array().into_iter().chain(v.to_dvec3().to_array()) {
            h.u64(c.to_bits());
        }
    }
    for &g in &m.body_gas_amount {
        h.u64(g.to_f64().to_bits());
    }
    for e in &w.events {
        h.u64(e.kind as u64);
        h.u64(e.time.to_bits());
        h.u64(e.spring.or(e.vertex).map_or(u64::MAX, |i| i as u64));
    }
    h.0
}

fn scene_hash(file: &str) -> (u64, World<f32>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(file);
    let scene = Scene::load(&path).expect("scene loads");
    let mut world: World<f32> = scene.world().expect("scene builds");
    world.advance(scene.solver.duration, scene.solver.dt).expect("scene runs");
    (hash_world(&world), world)
}

fn check(name: &str, got: u64, want: u64) {
    assert_eq!(got, want, "{name}: final-state hash {got:#018x}, recorded {want:#018x}: the physics changed");
}

#[test]
fn fracture_scene_final_state_is_bit_identical() {
    let (h, w) = scene_hash("fracture.toml");
    assert!(!w.events.is_empty(), "the fracture scene breaks");
    check("fracture.toml", h, 0x6df3_f458_f707_5c4e);
}

#[test]
fn ball_drop_scene_final_state_is_bit_identical() {
    let (h, _) = scene_hash("ball_drop.toml");
    check("ball_drop.toml", h, 0xac13_1e4f_7336_ed79);
}

#[test]
fn cloth_wind_scene_final_state_is_bit_identical() {
    let (h, _) = scene_hash("cloth_wind.toml");
    check("cloth_wind.toml", h, 0xdf4a_d1ca_7aec_4702);
}

/// A punctured, pressurised f64 ball under velocity Verlet: two core splits and a spring split by hand, then the
/// gas leaks and spring triggers run for 0.2 s.
#[test]
fn punctured_ball_f64_run_is_bit_identical() {
    let mut b = ModelBuilder::new();
    let ball = Mesh::icosphere(0.2, 3).translated(glam::DVec3::new(0.0, 0.5, 0.0));
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2500.0),
        fracture: Some(Breakable {
            strain_limit: 0.25,
            load_limit: f64::INFINITY,
            sealed: false,
            ..Default::default()
        }),
        ..Default::default()
    };
    b.add_soft_body(&ball, &opts).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let mut w = World::new(model, SolverConfig::with(Integrator::VelocityVerlet));
    w.advance(0.02, 1e-4).unwrap();
    for v in [5, 600] {
        assert!(!w.break_core(v).unwrap().is_empty(), "vertex {v} breaks");
    }
    w.break_spring(100).unwrap();
    w.advance(0.2, 1e-4).unwrap();
    let h = hash_world(&w);
    check("punctured ball", h, 0x34e8_e3a8_3bd4_8f44);
}
