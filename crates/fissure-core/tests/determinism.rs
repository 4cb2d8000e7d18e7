//! Same input, bit-identical output, whatever the thread count, and with the `parallel` feature off (CI runs
//! this file with `--no-default-features` too: `inline_and_parallel_passes_give_the_recorded_bits`).

mod common;

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;

/// A scene using every term, large enough (more than `par::PAR_MIN` = 16,384 particles, springs and triangles)
/// for every pass and reduction to run in parallel.
fn scene() -> Model<f32> {
    let mut b = ModelBuilder::new();
    let ball = SoftBodyOptions {
        mass: Mass::Total(0.5),
        gas: Gas::Pressure(3000.0),
        bending: Some(Stiffness::PerSpring(10.0)),
        aero: Aero::default(),
        velocity: DVec3::new(0.5, -1.0, 0.2),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.3, 5).translated(DVec3::new(0.0, 0.5, 0.0)), &ball).unwrap();
    b.add_cloth_grid(
        96,
        96,
        0.01,
        |p| DVec3::new(p.x - 0.5, 1.2, p.y),
        &ClothOptions { pins: vec![0, 95], mass: Mass::PerParticle(1e-3), ..Default::default() },
    )
    .unwrap();
    b.wind(WindField::default()).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    b.add_collider(Collider::ball(Vec3::new(0.1, 0.1, 0.0), 0.15)).unwrap();
    b.finalize().unwrap()
}

fn fingerprint(s: &State<f32>) -> Vec<u32> {
    s.particle_q.iter().chain(&s.particle_qd).flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]).collect()
}

fn run(threads: usize, integrator: Integrator) -> Vec<u32> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let model = scene();
        let mut s = model.state();
        let mut solver = CpuSolver::<f32>::with_integrator(integrator);
        let dt = if integrator == Integrator::ImplicitEuler { 2e-3 } else { 1e-4 };
        for _ in 0..60 {
            solver.step(&model, &mut s, dt).unwrap();
        }
        fingerprint(&s)
    })
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    let m = scene();
    assert!(m.particle_count() > 16_384 && m.spring_count() > 16_384 && m.tri_count() > 16_384);
    for integrator in Integrator::ALL {
        let a = run(1, integrator);
        let b = run(2, integrator);
        let c = run(2, integrator);
        assert_eq!(b, c, "{}: two runs on 2 threads differ", integrator.name());
        let first = a.iter().zip(&b).position(|(x, y)| x != y);
        assert!(first.is_none(), "{}: 1 vs 2 threads differ at word {first:?}", integrator.name());
    }
}

/// The passes run inline (feature `parallel` off, as on wasm32) and on threads give the same bits: both builds
/// must reproduce this hash of 60 symplectic Euler steps of the scene. (Changes with the physics, like the
/// facade's state hashes: update it with the reason. Last: 2026-11-29, a gas volume summed in eight lanes
/// (`forces::VolumeSum`); before it the same day, `Mesh::icosphere` numbered for locality.)
#[test]
fn inline_and_parallel_passes_give_the_recorded_bits() {
    let bits = run(2, Integrator::SymplecticEuler);
    let hash = bits.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &w| {
        w.to_le_bytes().iter().fold(h, |h, &b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
    });
    eprintln!("hash {hash:#018x}");
    assert_eq!(hash, RECORDED, "parallel feature {}", cfg!(feature = "parallel"));
}

const RECORDED: u64 = 0xa3ec_66c0_5bd0_e6df;

#[test]
fn spring_run_kernel_matches_the_gather_kernel() {
    // With wind: the fused kernel's per-particle update with triangle terms.
    run_kernel_against_gather(64, 64, true);
}

#[test]
fn spring_run_kernel_matches_the_gather_kernel_on_wide_blocks_without_surface_terms() {
    // No surface term: the fused kernel's vectorised update. A grid 320 wide: its bending springs two rows apart
    // (offset 640) make the kernel's blocks 6,144 particles, more than a chunk, each walking only its own runs.
    run_kernel_against_gather(320, 24, false);
}

/// A cloth grid uses the run kernel (fused with symplectic Euler); the same model with its runs cleared uses
/// the per-spring buffer and CSR gather. Same springs, different summation order: agreement to f32 rounding;
/// the pinned corners do not move.
fn run_kernel_against_gather(nx: usize, ny: usize, wind: bool) {
    let mut b = ModelBuilder::new();
    let pins = vec![0, nx - 1];
    let opts = ClothOptions { mass: Mass::PerParticle(1e-3), pins: pins.clone(), ..Default::default() };
    b.add_cloth_grid(nx, ny, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
    if wind {
        b.wind(WindField::default()).unwrap();
    }
    let runs: Model<f32> = b.finalize().unwrap();
    assert!(runs.springs_are_runs(), "{} runs for {} springs", runs.spring_runs.len(), runs.spring_count());
    let mut gather = runs.clone();
    gather.spring_runs.clear();
    assert!(!gather.springs_are_runs());
    let mut s = runs.state();
    for (k, q) in s.particle_q.iter_mut().enumerate() {
        *q += Vec3::new((k as f32 * 0.37).sin(), (k as f32 * 0.11).cos(), (k as f32 * 0.73).sin()) * 1e-3;
    }
    let (mut fa, mut fb) = (vec![Vec3::ZERO; runs.particle_count()], vec![Vec3::ZERO; runs.particle_count()]);
    CpuSolver::<f32>::default().compute_forces(&runs, &s, &mut fa).unwrap();
    CpuSolver::<f32>::default().compute_forces(&gather, &s, &mut fb).unwrap();
    let scale = fa.iter().map(|f| f.length()).fold(0.0f32, f32::max);
    let worst = fa.iter().zip(&fb).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    assert!(worst <= 1e-5 * scale, "forces differ by {worst} (max |f| {scale})");
    let (mut sa, mut sb) = (s.clone(), s.clone());
    let (mut va, mut vb) = (CpuSolver::<f32>::default(), CpuSolver::<f32>::default());
    for _ in 0..500 {
        va.step(&runs, &mut sa, 1e-4).unwrap();
        vb.step(&gather, &mut sb, 1e-4).unwrap();
    }
    let drift = sa.particle_q.iter().zip(&sb.particle_q).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    // 500 steps of a chaotic-free, damped sheet: rounding differences stay at the 1e-5 m level.
    assert!(drift < 1e-4, "trajectories drift apart by {drift} m");
    assert!(va.timers().calls(Stage::Integrate) == 0 && vb.timers().calls(Stage::Integrate) == 500);
    for &p in &pins {
        assert_eq!(sa.particle_q[p], s.particle_q[p], "pinned particle {p} moved");
    }
    let fell = sa.particle_q.iter().map(|q| q.y).fold(f32::INFINITY, f32::min);
    assert!(fell < 0.999, "the sheet did not fall under gravity: lowest y {fell} m");
}

/// Cloth grids in wind take the grid wind pass (`forces::wind_grid`: whole rows of quads, sums per particle);
/// the same model with its grids forgotten (`tri_grids` cleared) takes the general per-triangle pass and CSR
/// gather. Same triangles, another summation order: the forces agree to f64 rounding, including when some of
/// a grid's triangles no longer match its layout (here rotated corner orders, the same triangles: the grid pass
/// leaves them to the general kernel, as it does a torn cloth's). The grid is 300 wide (three tiles of a row)
/// and 23 rows, with gusts and crosswind on perturbed positions and velocities.
#[test]
fn grid_wind_matches_the_general_wind_pass() {
    let mut b = ModelBuilder::new();
    let opts = ClothOptions { mass: Mass::PerParticle(1e-3), pins: vec![0, 299], ..Default::default() };
    b.add_cloth_grid(300, 23, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
    let small = ClothOptions { pins: vec![], ..opts.clone() };
    b.add_cloth_grid(5, 4, 0.02, |p| DVec3::new(p.x, 1.5, p.y), &small).unwrap();
    b.wind(WindField { velocity: DVec3::new(2.0, 1.0, 4.0), ..Default::default() }).unwrap();
    let grid: Model<f64> = b.finalize().unwrap();
    let mut s = grid.state();
    for (k, (q, v)) in s.particle_q.iter_mut().zip(s.particle_qd.iter_mut()).enumerate() {
        let k = k as f64;
        *q += DVec3::new((k * 0.37).sin(), (k * 0.11).cos(), (k * 0.73).sin()) * 3e-3;
        *v = DVec3::new((k * 0.29).cos(), (k * 0.53).sin(), (k * 0.17).cos()) * 0.5;
    }
    let compare = |grid: &Model<f64>, what: &str| {
        let mut general = grid.clone();
        general.tri_grids.clear();
        let (mut fa, mut fb) = (vec![DVec3::ZERO; grid.particle_count()], vec![DVec3::ZERO; grid.particle_count()]);
        CpuSolver::<f64>::default().compute_forces(grid, &s, &mut fa).unwrap();
        CpuSolver::<f64>::default().compute_forces(&general, &s, &mut fb).unwrap();
        // Without gravity's share, which both add alike: the wind forces alone.
        let wind: Vec<DVec3> = fb.iter().zip(&grid.particle_mass).map(|(f, &m)| *f - grid.gravity * m).collect();
        let scale = wind.iter().map(|f| f.length()).fold(0.0, f64::max);
        assert!(scale > 1e-6, "{what}: the wind pushes ({scale} N)");
        let worst = fa.iter().zip(&fb).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(worst <= 1e-12 * scale, "{what}: forces differ by {worst} N (max wind force {scale} N)");
        // Not the same path twice: the two summation orders differ somewhere in the last bits.
        assert!(worst > 0.0, "{what}: bit-identical forces, so the grid pass did not run");
        let (mut sa, mut sb) = (s.clone(), s.clone());
        let (mut va, mut vb) = (CpuSolver::<f64>::default(), CpuSolver::<f64>::default());
        for _ in 0..200 {
            va.step(grid, &mut sa, 1e-4).unwrap();
            vb.step(&general, &mut sb, 1e-4).unwrap();
        }
        let drift = sa.particle_q.iter().zip(&sb.particle_q).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(drift < 1e-12, "{what}: trajectories drift apart by {drift} m");
    };
    compare(&grid, "intact grids");
    let mut changed = grid.clone();
    for t in [0usize, 1, 517, 4000, 12_000, 13_155, 13_170] {
        let [a, b, c] = changed.tri_indices[t];
        changed.tri_indices[t] = [b, c, a];
    }
    compare(&changed, "some triangles off the layout");
}

/// The grid wind pass gives the same bits on 1 and 2 threads (its rows are cut into pieces by the thread count;
/// each particle's sum does not depend on the cut): a 160 × 120 grid, above the parallel threshold, stepped by
/// symplectic Euler (the run kernel) and RK4 (the general gather).
#[test]
fn grid_wind_gives_the_same_bits_on_any_thread_count() {
    let run = |threads: usize, integrator: Integrator| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut b = ModelBuilder::new();
            let opts = ClothOptions { mass: Mass::PerParticle(1e-3), pins: vec![0, 159], ..Default::default() };
            b.add_cloth_grid(160, 120, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
            b.wind(WindField::default()).unwrap();
            let model: Model<f32> = b.finalize().unwrap();
            let mut s = model.state();
            let mut solver = CpuSolver::<f32>::with_integrator(integrator);
            for _ in 0..40 {
                solver.step(&model, &mut s, 1e-4).unwrap();
            }
            fingerprint(&s)
        })
    };
    for integrator in [Integrator::SymplecticEuler, Integrator::Rk4] {
        assert_eq!(run(1, integrator), run(2, integrator), "{}", integrator.name());
    }
}

/// The physics does not depend on how a mesh is numbered: the pressurised ball built from its icosphere with the
/// vertices renumbered and the triangles reordered at random (its particles, springs and triangles all come in
/// another order, so every sum runs in another order), and that mesh renumbered for locality, follow the same
/// trajectory onto the ground, positions and velocities mapped back through the renumberings, within f64
/// rounding.
#[test]
fn a_renumbered_mesh_gives_the_same_physics() {
    let mesh = Mesh::icosphere(0.25, 3).translated(DVec3::new(0.0, 0.27, 0.0));
    // A fixed permutation of the vertices and a fixed shuffle of the triangles.
    let (shuffled, perm) = common::shuffled_mesh(&mesh, 42, true);
    let build = |m: &Mesh| -> Model<f64> {
        let mut b = ModelBuilder::new();
        let opts = SoftBodyOptions {
            mass: Mass::Total(0.4),
            stiffness: Stiffness::PerSpring(1e3),
            gas: Gas::Amount(200.0),
            velocity: DVec3::new(0.3, -1.0, 0.1),
            ..Default::default()
        };
        b.add_soft_body(m, &opts).unwrap();
        b.add_collider(Collider::ground(0.0)).unwrap();
        b.finalize().unwrap()
    };
    // And the shuffled mesh renumbered back into a local order (`Mesh::renumbered_for_locality`): the shuffled
    // vertex `p` is its particle `back[p]`.
    let (local, map) = shuffled.renumbered_for_locality();
    let back = map.vertex;
    let (a, b, c) = (build(&mesh), build(&shuffled), build(&local));
    assert_eq!((a.spring_count(), a.tri_count()), (b.spring_count(), b.tri_count()));
    assert_eq!((a.spring_count(), a.tri_count()), (c.spring_count(), c.tri_count()));
    let (mut sa, mut sb, mut sc) = (a.state(), b.state(), c.state());
    let mut v = [(); 3].map(|_| CpuSolver::<f64>::default());
    let mut touched = false;
    for _ in 0..1500 {
        v[0].step(&a, &mut sa, 1e-4).unwrap();
        v[1].step(&b, &mut sb, 1e-4).unwrap();
        v[2].step(&c, &mut sc, 1e-4).unwrap();
        touched |= sa.particle_q.iter().any(|q| q.y < 1e-3);
    }
    assert!(touched, "the ball never reached the ground");
    let (mut dq, mut dv, mut moved) = ([0.0f64; 2], [0.0f64; 2], 0.0f64);
    for (k, &p) in perm.iter().enumerate() {
        let p = p as usize;
        for (j, (s, i)) in [(&sb, p), (&sc, back[p] as usize)].into_iter().enumerate() {
            dq[j] = dq[j].max((sa.particle_q[k] - s.particle_q[i]).length());
            dv[j] = dv[j].max((sa.particle_qd[k] - s.particle_qd[i]).length());
        }
        moved = moved.max((sa.particle_q[k] - a.particle_q0[k]).length());
    }
    assert!(moved > 0.05, "the ball hardly moved: {moved} m");
    for j in 0..2 {
        assert!(dq[j] < 1e-10 && dv[j] < 1e-8, "renumbering {j} departs by {} m, {} m/s after 0.15 s", dq[j], dv[j]);
    }
}

/// A body's triangles are ordered by their corners whatever order its mesh lists them in: the icosphere with
/// its triangles reversed and then swapped about builds the same model (the same triangles, springs and
/// particles) and so the same bits step after step.
#[test]
fn a_mesh_with_its_triangles_reordered_builds_the_same_model() {
    let mesh = Mesh::icosphere(0.25, 2).translated(DVec3::new(0.0, 0.27, 0.0));
    let mut tris: Vec<[u32; 3]> = mesh.triangles().iter().rev().copied().collect();
    let n = tris.len();
    for i in 0..n / 2 {
        tris.swap(i, (i * 7 + 3) % n);
    }
    assert_ne!(tris, mesh.triangles());
    let reordered = Mesh::new(mesh.positions().to_vec(), tris).unwrap();
    let build = |m: &Mesh| -> Model<f32> {
        let mut b = ModelBuilder::new();
        let opts = SoftBodyOptions { mass: Mass::Total(0.4), gas: Gas::Amount(200.0), ..Default::default() };
        b.add_soft_body(m, &opts).unwrap();
        b.add_collider(Collider::ground(0.0)).unwrap();
        b.finalize().unwrap()
    };
    let (a, b) = (build(&mesh), build(&reordered));
    assert_eq!(a.tri_indices, b.tri_indices);
    assert_eq!(a.spring_indices, b.spring_indices);
    let (mut sa, mut sb) = (a.state(), b.state());
    let (mut va, mut vb) = (CpuSolver::<f32>::default(), CpuSolver::<f32>::default());
    for _ in 0..300 {
        va.step(&a, &mut sa, 1e-4).unwrap();
        vb.step(&b, &mut sb, 1e-4).unwrap();
    }
    assert_eq!(fingerprint(&sa), fingerprint(&sb));
}

/// A solver first stepped in a pool of one thread, then in a pool of four: the run kernel's per-thread block
/// buffers were counted in the first (two), so some of the larger pool's blocks take new ones. The bits stay one
/// thread's, and nothing panics.
#[test]
fn a_solver_sized_in_a_small_pool_steps_in_a_larger_one() {
    let mut b = ModelBuilder::new();
    let opts = ClothOptions { pins: vec![0, 139], mass: Mass::PerParticle(1e-3), ..Default::default() };
    b.add_cloth_grid(140, 140, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
    let model: Model<f32> = b.finalize().unwrap();
    assert!(model.springs_are_runs() && model.particle_count() > 16_384);
    let steps = |pools: [usize; 2]| {
        let mut s = model.state();
        let mut solver = CpuSolver::<f32>::default();
        for threads in pools {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| (0..10).for_each(|_| solver.step(&model, &mut s, 2e-4).unwrap()));
        }
        fingerprint(&s)
    };
    assert_eq!(steps([1, 4]), steps([1, 1]));
}
