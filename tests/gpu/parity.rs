//! CPU–GPU parity: every kernel of `fissure-gpu` against its CPU twin in `fissure-core` (f32 on both sides).
//!
//! Tolerances, and why:
//! - per-step forces: `|f_gpu - f_cpu| <= 2e-4 max_i |f_cpu|` per particle. Both sum in f32 over the same CSR
//!   rows, but the CPU sums spring runs blockwise and the GPU computes each spring at both ends, so terms of
//!   up to ~1e3 N that cancel to a few N differ by a few ulps of the terms;
//! - volumes and pressures: 1e-5 relative;
//! - trajectories over 500+ steps: RMS position difference below 1e-4 of the scene's size (the rounding differences
//!   above, propagated by a damped, non-chaotic motion);
//! - collisions in one step: 1e-5 m and 1e-4 m/s;
//! - fracture candidates: the same sets exactly (the test keeps every strain or load at least 5 % from its limit).
//!
//! Every test runs on a device with WebGPU's default limits (`wgpu::Limits::default()`: 8 storage buffers per
//! kernel, 128 MiB per binding), what a browser grants without asking, so the kernels are checked to fit in them.
//!
//! Contact between surfaces has its own file, `tests/gpu/contact.rs` (its trajectory tolerance is looser, and says
//! why).
//!
//! With `CI` set, a missing adapter fails these tests (CI installs lavapipe); elsewhere they are skipped loudly.

use fissure::glam::{DVec3, Vec3};
use fissure::scenes::{self, BallDrop};
use fissure::*;
use fissure_gpu::{GpuConfig, GpuContext, GpuError, GpuSolver, MAX_GPU_HANDLES};

use crate::gpu_support;
use gpu_support::{gpu, rms_difference, solver};

/// A deterministic pseudo-random number in [-1, 1).
fn noise(seed: &mut u64) -> f32 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
}

/// The model's initial state, shaken: positions by up to `dx` \[m\], velocities by up to `dv` \[m/s\].
fn shaken(m: &Model<f32>, dx: f32, dv: f32) -> State<f32> {
    let mut s = m.state();
    let mut seed = 7;
    for (q, v) in s.particle_q.iter_mut().zip(&mut s.particle_qd) {
        *q += Vec3::new(noise(&mut seed), noise(&mut seed), noise(&mut seed)) * dx;
        *v += Vec3::new(noise(&mut seed), noise(&mut seed), noise(&mut seed)) * dv;
    }
    s.time = 0.37;
    s
}

fn assert_forces_match(name: &str, ctx: &GpuContext, m: &Model<f32>, s: &State<f32>) {
    let mut cpu = CpuSolver::<f32>::default();
    let mut f_cpu = vec![Vec3::ZERO; m.particle_count()];
    cpu.compute_forces(m, s, &mut f_cpu).unwrap();
    let mut g = solver(ctx, m, Integrator::SymplecticEuler);
    let f_gpu = g.compute_forces(m, s).unwrap();
    let scale = f_cpu.iter().map(|f| f.length()).fold(0.0, f32::max);
    let worst = f_cpu.iter().zip(&f_gpu).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    eprintln!("{name}: max |f| = {scale:.3e} N, worst difference {worst:.3e} N ({:.2e} relative)", worst / scale);
    assert!(worst <= 2e-4 * scale, "{name}: forces differ by {worst} N (largest force {scale} N)");
}

#[test]
fn forces_match_the_cpu_springs_gravity_wind() {
    let Some(ctx) = gpu() else { return };
    let m: Model<f32> = scenes::cloth_wind(24).unwrap().finalize().unwrap();
    assert!(m.has_wind() && !m.has_pressure());
    assert_forces_match("cloth + wind", &ctx, &m, &shaken(&m, 0.004, 0.5));
    let m: Model<f32> = scenes::benchmark_cloth(16).unwrap().finalize().unwrap();
    assert_forces_match("cloth, springs only", &ctx, &m, &shaken(&m, 0.001, 0.2));
}

#[test]
fn forces_match_the_cpu_pressure_and_unprojected_damping() {
    let Some(ctx) = gpu() else { return };
    let m: Model<f32> = scenes::ball_drop(&BallDrop::default()).unwrap().finalize().unwrap();
    assert!(m.has_pressure());
    let s = shaken(&m, 0.01, 0.3);
    assert_forces_match("pressurised ball", &ctx, &m, &s);
    // Volumes and pressures of the reduction against the CPU's f64 sums.
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.compute_forces(&m, &s).unwrap();
    let vp = g.body_volumes_pressures(&m).unwrap();
    let (v, p) = (m.body_volumes(&s), m.body_pressures(&s));
    for b in 0..m.body_count() {
        assert!((vp[b].0 as f64 - v[b]).abs() <= 1e-5 * v[b], "volume {} vs {}", vp[b].0, v[b]);
        assert!((vp[b].1 as f64 - p[b]).abs() <= 1e-5 * p[b].abs(), "pressure {} vs {}", vp[b].1, p[b]);
    }
    let mut b = scenes::ball_drop(&BallDrop::default()).unwrap();
    b.damping_model(DampingModel::Unprojected);
    let m: Model<f32> = b.finalize().unwrap();
    assert_forces_match("unprojected damping", &ctx, &m, &shaken(&m, 0.01, 0.3));
}

#[test]
fn forces_match_the_cpu_through_the_caps_of_a_punctured_ball() {
    let Some(ctx) = gpu() else { return };
    let mut m: Model<f32> = scenes::ball_drop(&BallDrop::default()).unwrap().finalize().unwrap();
    let mut s = m.state();
    let mut f = Fracture::<f32>::default();
    assert!(!f.break_core(&mut m, &mut s, 5).is_empty());
    assert!(!f.break_core(&mut m, &mut s, 600).is_empty());
    assert!(m.openings.len() >= 2 && m.has_pressure());
    let mut s2 = shaken(&m, 0.005, 0.2);
    s2.time = s.time;
    assert_forces_match("punctured ball (caps)", &ctx, &m, &s2);
}

/// The same through the openings of the fracture scene's ball after 0.3 s, torn in many places: some openings'
/// loops are longer than a workgroup (the caps kernel shares a loop among 64 invocations and sums it in a tree).
#[test]
fn forces_match_the_cpu_through_the_long_openings_of_a_torn_ball() {
    let Some(ctx) = gpu() else { return };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/fracture.toml");
    let scene = fissure::scene::Scene::load(&path).unwrap();
    let mut w = scene.world::<f32>().unwrap();
    w.advance(0.3, scene.solver.dt).unwrap();
    let m = &w.model;
    let longest = m.openings.iter().map(|o| o.vertices.len()).max().unwrap_or(0);
    eprintln!("{} openings, the longest loop {longest} vertices", m.openings.len());
    assert!(m.has_pressure() && longest > 64, "no opening longer than a workgroup: {longest}");
    assert_forces_match("torn ball (long openings)", &ctx, m, &w.state);
}

fn assert_trajectories_match(
    name: &str,
    ctx: &GpuContext,
    m: &Model<f32>,
    integrator: Integrator,
    dt: f64,
    steps: usize,
    size: f64,
) {
    let mut cpu = CpuSolver::<f32>::with_integrator(integrator);
    let mut s_cpu = m.state();
    for _ in 0..steps {
        cpu.step(m, &mut s_cpu, dt).unwrap();
    }
    let mut g = solver(ctx, m, integrator);
    // Two submissions, to cover the clock of a second one.
    g.run(m, dt, steps / 2).unwrap();
    g.run(m, dt, steps - steps / 2).unwrap();
    let mut s_gpu = m.state();
    g.read_state(&mut s_gpu).unwrap();
    assert!((s_gpu.time - s_cpu.time).abs() < 1e-9);
    let moved = rms_difference(&s_cpu, &m.state());
    let rms = rms_difference(&s_cpu, &s_gpu);
    eprintln!("{name} ({}): moved {moved:.3e} m RMS, GPU-CPU {rms:.3e} m RMS", integrator.name());
    assert!(moved > 100.0 * rms.max(1e-9), "{name}: the scene barely moved ({moved} m)");
    assert!(rms <= 1e-4 * size, "{name}: trajectories differ by {rms} m RMS after {steps} steps");
}

#[test]
fn cloth_in_wind_trajectory_matches_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let m: Model<f32> = scenes::cloth_wind(16).unwrap().finalize().unwrap();
    for integrator in [Integrator::SymplecticEuler, Integrator::VelocityVerlet] {
        assert_trajectories_match("cloth in wind", &ctx, &m, integrator, 5e-4, 600, 1.0);
    }
}

/// Moving pins on the GPU: a sheet pulled apart by two handles (one on a path with a corner) follows the CPU
/// solver's trajectory, and the pinned particles sit exactly where their handles put them.
#[test]
fn moving_pins_match_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let n = 12;
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let opts = ClothOptions { pins: Vec::new(), ..Default::default() };
    let body = b.add_cloth_grid(n, n, 0.05, |p| DVec3::new(p.x, 1.0 - p.y, 0.0), &opts).unwrap();
    let left: Vec<usize> = (0..n).map(|j| body.first_particle + j * n).collect();
    let right: Vec<usize> = left.iter().map(|i| i + n - 1).collect();
    b.add_handle(&left, Handle::linear(DVec3::new(-0.1, 0.0, 0.0), 0.05, 0.4)).unwrap();
    let path = Handle {
        keys: vec![(0.0, DVec3::ZERO), (0.2, DVec3::new(0.05, 0.05, 0.0)), (0.4, DVec3::new(0.1, 0.0, 0.05))],
    };
    b.add_handle(&right, path.clone()).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    for integrator in [Integrator::SymplecticEuler, Integrator::VelocityVerlet] {
        assert_trajectories_match("pulled sheet", &ctx, &m, integrator, 2e-4, 1500, 0.6);
    }
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.run(&m, 2e-4, 1500).unwrap();
    let mut s = m.state();
    g.read_state(&mut s).unwrap();
    let want = path.offset(0.3).as_vec3();
    for &i in &right {
        let moved = s.particle_q[i] - m.particle_q0[i];
        assert!((moved - want).length() < 1e-4, "pin {i} moved {moved:?}, its path says {want:?}");
    }
}

/// `scenes/cloth_tear.toml` on the GPU path (kernels step, the CPU fracture pass splits, new particles on a
/// handle follow it): the cloth tears in two along the pull, as on the CPU.
#[test]
fn cloth_tear_tears_on_the_gpu_path() {
    let Some(ctx) = gpu() else { return };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cloth_tear.toml");
    let scene = fissure::scene::Scene::load(&path).unwrap();
    let mut w: World<f32> = scene.world().unwrap();
    let config = GpuConfig { integrator: scene.integrator().unwrap(), ..Default::default() };
    w.solver = Box::new(GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &w.model, config).unwrap());
    w.advance(1.0, scene.solver.dt).unwrap();
    let springs = w.events.iter().filter(|e| e.kind == FractureKind::Spring).count();
    let (pieces, label) = w.model.components();
    eprintln!("cloth_tear on the GPU: {springs} spring splits, {} bodies, {pieces} pieces", w.model.body_count());
    assert!(springs >= 20 && w.model.body_count() >= 2, "{springs} splits, {} bodies", w.model.body_count());
    // The two largest pieces hold one side handle each: the tear ran between them.
    let (l, r) = (
        w.model.particle_handle.iter().position(|&h| h == 0).unwrap(),
        w.model.particle_handle.iter().position(|&h| h == 1).unwrap(),
    );
    assert_ne!(label[l], label[r], "the handles still hold one piece");
    check_invariants(&w.model).unwrap();
}

/// The ball drop from 0.4 m, 162 vertices: it meets the ground and the first obstacle within 0.12 s.
fn low_ball() -> Model<f32> {
    scenes::ball_drop(&BallDrop { height: 0.4, subdivisions: 2, ..Default::default() }).unwrap().finalize().unwrap()
}

#[test]
fn ball_drop_trajectory_matches_the_cpu() {
    let Some(ctx) = gpu() else { return };
    // Low, so the ball meets the ground and the first obstacle within the 0.12 s compared.
    let m = low_ball();
    for integrator in [Integrator::SymplecticEuler, Integrator::VelocityVerlet] {
        assert_trajectories_match("ball drop", &ctx, &m, integrator, 2e-4, 600, 0.5);
    }
}

/// The kernel timers (`GpuConfig::kernel_timers`): every kernel a submission encodes is timed once per dispatch,
/// the times land in the stage timers, within the wall time of the submissions, and timing changes no bit.
#[test]
fn kernel_timers_time_every_dispatch_and_change_nothing() {
    let Some(ctx) = gpu() else { return };
    let m = low_ball();
    let timed = GpuConfig { kernel_timers: true, ..Default::default() };
    let mut g = match GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m, timed) {
        Ok(g) => g,
        Err(e @ fissure_gpu::GpuError::NoKernelTimers) if !fissure_gpu::adapter_required() => {
            eprintln!("SKIPPED: {e}");
            return;
        }
        Err(e) => panic!("{e}"),
    };
    let mut plain = solver(&ctx, &m, Integrator::SymplecticEuler);
    // A first submission, then the timers reset: they count what follows only.
    g.run(&m, 2e-4, 40).unwrap();
    plain.run(&m, 2e-4, 40).unwrap();
    g.reset_timers();
    assert!(g.kernel_times().is_empty() && g.timers().total.is_zero());
    for _ in 0..3 {
        g.run(&m, 2e-4, 40).unwrap();
        plain.run(&m, 2e-4, 40).unwrap();
    }
    let (mut a, mut b) = (m.state(), m.state());
    g.read_state(&mut a).unwrap();
    plain.read_state(&mut b).unwrap();
    let bits = |s: &State<f32>| s.particle_q.iter().flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert!(bits(&a) == bits(&b), "the timed solver's positions differ from the plain one's");
    // Each kernel of the last submission, as many times as it was dispatched per submission (times 3).
    let times = g.kernel_times();
    eprintln!("{times:?}");
    for name in g.passes() {
        let per = g.passes().iter().filter(|&p| p == name).count() as u64;
        let (_, t, calls) = times.iter().find(|(n, ..)| n == name).expect("every kernel encoded is timed");
        assert_eq!(*calls, 3 * per, "{name}");
        assert!(*t > std::time::Duration::ZERO, "{name}: no time");
    }
    assert_eq!(times.len(), {
        let mut p = g.passes().to_vec();
        p.sort();
        p.dedup();
        p.len()
    });
    let timers = g.timers();
    let sum: std::time::Duration = times.iter().map(|(_, t, _)| *t).sum();
    let staged: std::time::Duration = Stage::ALL.iter().map(|&s| timers.time(s)).sum();
    assert!(staged == sum, "stage timers {staged:?} against the kernels' {sum:?}");
    assert!(
        timers.time(Stage::Integrate) > std::time::Duration::ZERO && timers.time(Stage::Surface) > Default::default()
    );
    assert!(sum <= timers.total, "the kernels' {sum:?} exceed the submissions' wall time {:?}", timers.total);
    eprintln!("{timers}");
}

#[test]
fn collisions_match_the_cpu_for_every_analytic_shape() {
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    b.add_collider(Collider::ground(0.0).with_restitution(0.5).with_friction(0.3)).unwrap();
    b.add_collider(Collider::ball(Vec3::new(2.0, 0.5, 0.0), 0.4).with_margin(0.01)).unwrap();
    b.add_collider(
        Collider::cuboid(Vec3::new(-2.0, 0.5, 0.0), Vec3::new(0.3, 0.4, 0.5))
            .with_rotation(fissure::glam::Quat::from_rotation_y(0.4))
            .with_velocity(Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)),
    )
    .unwrap();
    b.add_collider(Collider::capsule(Vec3::new(0.0, 0.5, 2.0), Vec3::new(0.5, 0.8, 2.0), 0.25).with_friction(0.8))
        .unwrap();
    let mut seed = 3;
    let centres =
        [DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 0.5, 0.0), DVec3::new(-2.0, 0.5, 0.0), DVec3::new(0.25, 0.65, 2.0)];
    for c in centres {
        for _ in 0..200 {
            let p = c + DVec3::new(noise(&mut seed) as f64, noise(&mut seed) as f64, noise(&mut seed) as f64) * 0.5;
            let v = DVec3::new(noise(&mut seed) as f64, noise(&mut seed) as f64, noise(&mut seed) as f64) * 2.0;
            b.add_particle(p, v, 0.01).unwrap();
        }
    }
    let m: Model<f32> = b.finalize().unwrap();
    let dt = 1e-3;
    let mut s_cpu = m.state();
    s_cpu.time = 0.5;
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.upload_state(&s_cpu).unwrap();
    CpuSolver::<f32>::default().step(&m, &mut s_cpu, dt).unwrap();
    g.run(&m, dt, 1).unwrap();
    let mut s_gpu = m.state();
    g.read_state(&mut s_gpu).unwrap();
    let mut contacts = 0;
    for i in 0..m.particle_count() {
        let (dx, dv) = (
            (s_cpu.particle_q[i] - s_gpu.particle_q[i]).length(),
            (s_cpu.particle_qd[i] - s_gpu.particle_qd[i]).length(),
        );
        assert!(dx <= 1e-5 && dv <= 1e-4, "particle {i}: dx {dx}, dv {dv}");
        let free = m.state().particle_q[i] + m.state().particle_qd[i] * dt as f32;
        contacts += ((s_cpu.particle_q[i] - free).length() > 1e-3) as usize;
    }
    assert!(contacts > 200, "only {contacts} particles touched a collider");
}

#[test]
fn triangle_mesh_colliders_work_through_a_signed_distance_grid() {
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    let boxm = Mesh::cuboid(DVec3::new(0.5, 0.3, 0.4), 4);
    let col = Collider::trimesh(&boxm).unwrap().with_restitution(0.0);
    b.add_collider(col.clone()).unwrap();
    let mut seed = 11;
    let half = DVec3::new(0.5, 0.3, 0.4);
    for k in 0..300 {
        // Inside, up to 3 cm below a face.
        let mut p = DVec3::new(noise(&mut seed) as f64, noise(&mut seed) as f64, noise(&mut seed) as f64) * half * 0.9;
        let axis = k % 3;
        let depth = 0.03 * (noise(&mut seed) as f64 * 0.5 + 0.5);
        p[axis] = (half[axis] - depth) * if noise(&mut seed) > 0.0 { 1.0 } else { -1.0 };
        b.add_particle(p, DVec3::ZERO, 0.01).unwrap();
    }
    let mut bb = b.clone();
    bb.gravity(DVec3::ZERO).unwrap();
    let m: Model<f32> = bb.finalize().unwrap();
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.run(&m, 1e-4, 1).unwrap();
    let mut s = m.state();
    g.read_state(&mut s).unwrap();
    // Every particle was inside; each must now be on the surface, to within the grid's resolution (cell = 1/64 of
    // the longest side), and outside or on it per parry's exact query.
    let cell = 1.0 / 64.0;
    let start = m.state();
    let mut checked = 0;
    for (i, x) in s.particle_q.iter().enumerate() {
        // Deep inside, near the medial axis, "the" closest point is ambiguous; contacts start near the surface.
        let x0 = start.particle_q[i];
        if (col.shape.project_local_point(x0, false).point - x0).length() > 4.0 * cell {
            continue;
        }
        checked += 1;
        let p = col.shape.project_local_point(*x, false);
        let d = (p.point - *x).length();
        assert!(d <= 0.5 * cell, "particle {i} at {x} is {d} m from the surface");
        assert!(!p.is_inside || d <= 0.5 * cell, "particle {i} still inside by {d}");
    }
    assert!(checked > 250, "{checked}");
}

/// A fracture pass that breaks every candidate at once: no limit per body, no wait between cracks.
fn every_candidate() -> FractureConfig {
    FractureConfig {
        max_events_per_step: 1000,
        splits_per_body: usize::MAX,
        nucleation_interval: Some(0.0),
        ..Default::default()
    }
}

#[test]
fn fracture_candidates_match_the_cpu() {
    let Some(ctx) = gpu() else { return };
    // Spring mode: a breakable sheet with three vertices pulled sideways.
    let mut b = ModelBuilder::new();
    let opts = ClothOptions {
        fracture: Some(Breakable { strain_limit: 0.2, ..Default::default() }),
        pins: vec![],
        ..Default::default()
    };
    let h = b.add_cloth_grid(20, 20, 0.05, |p| p, &opts).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    for (k, v) in [45usize, 210, 333].into_iter().enumerate() {
        let i = h.first_particle + v;
        s.particle_q[i] += Vec3::new(0.015 + 0.006 * k as f32, 0.004, 0.0);
    }
    let dt = 1e-7;
    // Expected: every spring past its limit after one tiny step, from the CPU state (strains kept away from 0.2).
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.upload_state(&s).unwrap();
    let report = g.run(&m, dt, 1).unwrap();
    let cand = g.candidates().unwrap();
    CpuSolver::<f32>::default().step(&m, &mut s, dt).unwrap();
    let (mut expected, mut borderline) = (Vec::new(), Vec::new());
    for sp in 0..m.spring_count() {
        let [i, j] = m.spring_indices[sp];
        let l0 = m.spring_rest_length[sp] as f64;
        let strain = ((s.particle_q[j as usize] - s.particle_q[i as usize]).length() as f64 - l0) / l0;
        // Within f32 rounding of the limit either answer is right.
        if (strain - 0.2).abs() < 1e-4 {
            borderline.push(sp as u32);
        } else if strain > 0.2 {
            expected.push(sp as u32);
        }
    }
    assert!(expected.len() >= 3 && borderline.is_empty(), "{expected:?} {borderline:?}");
    assert_eq!(cand.springs, expected);
    assert_eq!(report.spring_candidates as usize, expected.len());
    // And the springs the CPU fracture pass breaks are those.
    let mut f = Fracture::<f32>::new(every_candidate());
    let events = f.apply(&mut m, &mut s, dt);
    let mut broken: Vec<u32> = events.events.iter().filter_map(|e| e.spring).collect();
    broken.sort_unstable();
    assert_eq!(broken, expected);
}

#[test]
fn load_candidates_match_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2000.0),
        stiffness: Stiffness::Membrane(2000.0),
        fracture: Some(Breakable { load_limit: 8.0, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 3), &opts).unwrap();
    b.gravity(DVec3::ZERO).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    // Dent three far-apart vertices inwards: their springs pull them back hard.
    let dents = [0u32, 200, 500];
    for &v in &dents {
        let x = s.particle_q[v as usize];
        s.particle_q[v as usize] = x * 0.9;
    }
    let dt = 1e-7;
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.upload_state(&s).unwrap();
    g.run(&m, dt, 1).unwrap();
    let cand = g.candidates().unwrap();
    CpuSolver::<f32>::default().step(&m, &mut s, dt).unwrap();
    // The load as the fracture pass defines it, in f64: |springs' ks (l - L0) d̂ + the gas pressure's share|.
    let p = m.body_pressures(&s)[0];
    let x = |i: u32| s.particle_q[i as usize].as_dvec3();
    let mut load = vec![DVec3::ZERO; m.particle_count()];
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        let d = x(j) - x(i);
        let f = d * (m.spring_stiffness[sp] as f64 * (d.length() - m.spring_rest_length[sp] as f64) / d.length());
        load[i as usize] += f;
        load[j as usize] -= f;
    }
    for t in &m.tri_indices {
        let f = (x(t[1]) - x(t[0])).cross(x(t[2]) - x(t[0])) * (p / 6.0);
        for &v in t {
            load[v as usize] += f;
        }
    }
    let limit = 8.0;
    let expected: Vec<u32> = (0..m.particle_count() as u32).filter(|&i| load[i as usize].length() > limit).collect();
    assert!(load.iter().all(|l| (l.length() - limit).abs() > 1e-3 * limit), "a load is too close to the limit");
    assert!(dents.iter().all(|d| expected.contains(d)), "{expected:?}");
    assert_eq!(cand.vertices, expected, "GPU load candidates");
    // The CPU fracture pass breaks the dents (their neighbours, now next to a hole, may not break in the same step).
    let mut f = Fracture::<f32>::new(every_candidate());
    let events = f.apply(&mut m, &mut s, dt);
    let cores: Vec<u32> =
        events.events.iter().filter(|e| e.kind == FractureKind::Core).filter_map(|e| e.vertex).collect();
    assert!(dents.iter().all(|d| cores.contains(d)), "CPU core events {cores:?}");
    assert!(cores.iter().all(|c| expected.contains(c)));
}

#[test]
fn only_the_kernels_a_model_needs_are_encoded() {
    let Some(ctx) = gpu() else { return };
    // With `check_finite` (the default) a submission ends with one finite check of its last state.
    let run = |m: &Model<f32>, integrator| {
        let mut g = solver(&ctx, m, integrator);
        g.run(m, 1e-5, 2).unwrap();
        let mut p = g.passes().to_vec();
        assert_eq!(p.pop(), Some("finite_check"));
        assert!(!p.contains(&"finite_check"));
        p
    };
    // Plain cloth: springs and gravity only.
    let m: Model<f32> = scenes::benchmark_cloth(8).unwrap().finalize().unwrap();
    assert_eq!(run(&m, Integrator::SymplecticEuler), vec!["integrate_symplectic_euler"; 2]);
    assert_eq!(run(&m, Integrator::VelocityVerlet), ["integrate_verlet_first", "integrate_verlet_second"].repeat(2));
    // Wind and the ground: the surface pass without the volume reduction, and collisions.
    let m: Model<f32> = scenes::cloth_wind(8).unwrap().finalize().unwrap();
    assert_eq!(
        run(&m, Integrator::SymplecticEuler),
        ["surface_cross", "surface_force", "integrate_symplectic_euler", "collide"].repeat(2)
    );
    // Gas: the volume reduction too.
    let m: Model<f32> = scenes::ball_drop(&BallDrop::default()).unwrap().finalize().unwrap();
    let p = run(&m, Integrator::SymplecticEuler);
    assert_eq!(&p[..5], ["surface_cross", "surface_volume", "surface_force", "integrate_symplectic_euler", "collide"]);
    assert!(!p.iter().any(|k| k.contains("check") || *k == "surface_caps"));
    // Breakable springs: the strain check, nothing else added.
    let mut b = ModelBuilder::new();
    let opts =
        ClothOptions { fracture: Some(Breakable { strain_limit: 0.5, ..Default::default() }), ..Default::default() };
    b.add_cloth_grid(8, 8, 0.05, |p| p, &opts).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    assert_eq!(run(&m, Integrator::SymplecticEuler), ["integrate_symplectic_euler", "strain_check"].repeat(2));
    // A punctured gas body: the caps' geometry before the volumes, their forces after them.
    let mut m: Model<f32> = scenes::ball_drop(&BallDrop::default()).unwrap().finalize().unwrap();
    let mut s = m.state();
    assert!(!Fracture::<f32>::default().break_core(&mut m, &mut s, 5).is_empty());
    let p = run(&m, Integrator::SymplecticEuler);
    let surface = ["surface_cross", "surface_caps", "surface_volume", "surface_force", "cap_force"];
    assert_eq!(&p[..6], [&surface[..], &["integrate_symplectic_euler"]].concat());
    // Breakable vertices of a gas body: after the step, the pressure shares alone for the load check.
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2000.0),
        fracture: Some(Breakable { load_limit: 1e6, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 1), &opts).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    let p = run(&m, Integrator::SymplecticEuler);
    let step = ["surface_cross", "surface_volume", "surface_force", "integrate_symplectic_euler"];
    let check = ["surface_cross", "surface_volume", "surface_pressure", "load_check"];
    assert_eq!(p, [&step[..], &check[..]].concat().repeat(2));
    // Contact: the grids before the step, the pairs, the Jacobi iterations (few pairs: all in one dispatch; else
    // 16, one dispatch each), friction and the bound after it.
    let mut b = scenes::benchmark_cloth(8).unwrap();
    b.set_contact(0, Contact { self_collision: true, ..Default::default() }).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    let start =
        ["contact_count", "contact_scan_sums", "contact_scan_spread", "contact_scatter", "integrate_symplectic_euler"];
    let pairs = ["contact_moves", "contact_vt", "contact_ee", "contact_args", "contact_prep"];
    let end = ["contact_friction", "contact_apply"];
    let with = |jacobi: &[&'static str]| [&start[..], &pairs[..], jacobi, &end[..]].concat().repeat(2);
    assert_eq!(run(&m, Integrator::SymplecticEuler), with(&["contact_jacobi_fused"]));
    let config = GpuConfig { contact_fused_pairs: 0, ..Default::default() };
    let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m, config).unwrap();
    g.run(&m, 1e-5, 2).unwrap();
    let mut p = g.passes().to_vec();
    p.pop();
    assert_eq!(p, with(&["contact_jacobi_even", "contact_jacobi_odd"].repeat(8)));
    // A state that blew up is reported (the finite check of the last state).
    let m: Model<f32> = scenes::benchmark_cloth(8).unwrap().finalize().unwrap();
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    let mut s = m.state();
    s.particle_qd[3].x = f32::NAN;
    g.upload_state(&s).unwrap();
    assert!(matches!(g.run(&m, 1e-5, 5), Err(GpuError::NonFinite { .. })));
}

#[test]
fn fracture_runs_on_the_gpu_path_and_uploads_only_what_changed() {
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::Membrane(2500.0),
        damping: Damping::Ratio(0.3),
        gas: Gas::Pressure(3000.0),
        velocity: DVec3::new(0.0, -4.0, 0.0),
        fracture: Some(Breakable { load_limit: 3.0, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 4).translated(DVec3::new(0.0, 0.4, 0.0)), &opts).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    m.reserve(2000, 8000, 4000);
    let fracture = FractureConfig { max_events_per_step: 4, start_time: 0.01, ..Default::default() };
    let g = solver(&ctx, &m, Integrator::SymplecticEuler);
    let model_bytes =
        m.particle_count() * 16 + m.spring_count() * 32 + m.tri_count() * 16 + m.particle_springs.items.len() * 4;
    // The one stepping path, on the GPU: fracture every 10 steps (read back only when the kernels flag a limit).
    let mut w = World::with_solver(m, Box::new(g)).with_fracture(fracture);
    w.fracture_every = 10;
    let mut uploads = Vec::new();
    let mut v0 = None;
    for _ in 0..300 {
        let adv = w.advance(10.0 * 5e-5, 5e-5).unwrap();
        assert_eq!(adv.steps, 10);
        if !adv.events.is_empty() {
            uploads.push(w.gpu_solver().unwrap().last_upload_bytes());
            check_invariants(&w.model).unwrap();
            // Volume right after the first puncture.
            v0.get_or_insert(w.model.body_volumes(&w.state)[0]);
        }
    }
    let v0 = v0.expect("a puncture");
    let (m, s, events) = (&w.model, &w.state, &w.events);
    assert!(!events.is_empty(), "nothing broke");
    assert!(s.particle_q.iter().all(|q| q.is_finite()));
    assert!(s.particle_q.iter().all(|q| q.y > -1e-3), "a particle went through the ground");
    let first = uploads[0];
    eprintln!("{} events; first upload {first} bytes of a {model_bytes}-byte model", events.len());
    assert!(first * 10 < model_bytes, "an event uploaded {first} of {model_bytes} bytes");
    let v1 = m.body_volumes(s)[0];
    assert!(v1 < v0, "the punctured ball should shrink: {v0} -> {v1}");
}

#[test]
fn bad_input_gets_clear_errors() {
    let Some(ctx) = gpu() else { return };
    let m: Model<f32> = scenes::benchmark_cloth(8).unwrap().finalize().unwrap();
    let e = GpuSolver::new(
        ctx.device.clone(),
        ctx.queue.clone(),
        &m,
        GpuConfig { integrator: Integrator::Rk4, ..Default::default() },
    );
    assert!(matches!(e, Err(GpuError::UnsupportedIntegrator("rk4"))));
    let mut b = scenes::benchmark_cloth(8).unwrap();
    for k in 0..=MAX_GPU_HANDLES {
        b.add_handle(&[k], Handle::linear(DVec3::X, 0.0, 1.0)).unwrap();
    }
    let with_handles: Model<f32> = b.finalize().unwrap();
    let e = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &with_handles, GpuConfig::default());
    assert!(matches!(e, Err(GpuError::UnsupportedHandles)), "more pins than the clock holds must be refused");
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    assert!(matches!(g.run(&m, -1.0, 1), Err(GpuError::BadTimeStep(_))));
    let other: Model<f32> = scenes::benchmark_cloth(9).unwrap().finalize().unwrap();
    assert!(matches!(g.upload_state(&other.state()), Err(GpuError::StateMismatch { .. })));
    // A step far past the stability limit blows up; the error says so instead of returning NaN.
    let e = g.run(&m, 1.0, 50).unwrap_err();
    assert!(matches!(e, GpuError::NonFinite { .. }), "{e}");
    assert!(e.to_string().contains("stability limit"));
    // Through the Solver trait too.
    let mut s = m.state();
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    let e = Solver::step(&mut g, &m, &mut s, 1e9).and_then(|_| Solver::step(&mut g, &m, &mut s, 1e9));
    assert!(matches!(e, Err(StepError::NonFinite { .. })), "{e:?}");
}

/// The renderer draws where the camera projects: the ball's centre pixel is in the body colour, a corner pixel
/// is background, the floor below the ball is lit grey; drawing the GPU solver's position buffer in place gives
/// the same image as uploading the same state from the CPU.
#[test]
fn renderer_draws_where_the_camera_projects_and_both_position_sources_agree() {
    use fissure_gpu::render::{Camera, Offscreen, PALETTE, Positions, Renderer, View};
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    let ball = Mesh::icosphere(0.3, 3).translated(DVec3::new(0.0, 0.5, 0.0));
    b.add_soft_body(&ball, &SoftBodyOptions::default()).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    let model: Model<f32> = b.finalize().unwrap();
    let state = model.state();
    let mut r = Renderer::new(&ctx.device, &ctx.queue, Offscreen::FORMAT);
    r.set_model(&model, 0.0);
    r.upload_positions(&state);
    let camera = Camera { target: Vec3::new(0.0, 0.4, 0.0), yaw: 0.3, pitch: 0.35, distance: 2.5, fov_y: 0.8 };
    let mut target = Offscreen::new(&ctx.device, 320, 200);
    let view = View::default();
    let cpu = target.render(&ctx.device, &ctx.queue, &mut r, &camera, &view, Positions::Uploaded).unwrap();
    let (x, y, _) = camera.project(Vec3::new(0.0, 0.5, 0.0), 320.0, 200.0).unwrap();
    let c = cpu.pixel(x as u32, y as u32);
    let hue = |p: [u8; 4], q: [u8; 3]| {
        let (a, b) = (p.map(|v| v as f64), q.map(|v| v as f64));
        let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        dot / ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt())
    };
    assert!(hue(c, PALETTE[0]) > 0.98, "centre pixel {c:?} is not the body's colour");
    let corner = cpu.pixel(2, 2);
    assert!(corner[0] < 40 && corner[1] < 40 && corner[2] < 50, "corner {corner:?} is not background");
    let (fx, fy, _) = camera.project(Vec3::new(0.0, 0.0, 0.6), 320.0, 200.0).unwrap();
    let floor = cpu.pixel(fx as u32, fy as u32);
    assert!(floor[0] > 110 && floor[0].abs_diff(floor[2]) < 40, "floor pixel {floor:?}");
    let mut gpu = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &model, GpuConfig::default()).unwrap();
    gpu.upload_state(&state).unwrap();
    let on_gpu = target
        .render(&ctx.device, &ctx.queue, &mut r, &camera, &view, Positions::Buffer(gpu.position_buffer()))
        .unwrap();
    assert_eq!(on_gpu, cpu, "the GPU buffer and the uploaded state draw differently");
}

/// Issue 14's contract: `Fracture::apply` (here a forced core split) returns a `TopologyDelta`, and the GPU
/// re-packs and uploads only the rows it names. One split on a 2,562- and on a 40,962-vertex ball re-packs the
/// same number of elements and uploads the same bytes (the 16× larger mesh adds nothing); and the delta-updated
/// GPU model steps like the CPU's.
#[test]
fn a_core_split_uploads_and_repacks_the_change_not_the_mesh() {
    let Some(ctx) = gpu() else { return };
    // `gas`: a pressurised ball, whose springs are stretched, so that a stiffness the upload missed shows.
    let ball = |sub: u32, gas: Gas| {
        let mut b = ModelBuilder::new();
        let opts = SoftBodyOptions {
            gas,
            fracture: Some(Breakable { load_limit: 1e9, ..Default::default() }),
            ..Default::default()
        };
        b.add_soft_body(&Mesh::icosphere(0.25, sub).translated(DVec3::new(0.0, 1.0, 0.0)), &opts).unwrap();
        b.finalize::<f32>().unwrap()
    };
    let mut figures = Vec::new();
    for sub in [4, 6] {
        let m = ball(sub, Gas::None);
        let n = m.particle_count();
        let model_bytes = n * 16 + m.spring_count() * 32 + m.tri_count() * 16;
        let g = solver(&ctx, &m, Integrator::SymplecticEuler);
        let mut w = World::with_solver(m, Box::new(g));
        let events = w.break_core(n / 2).unwrap();
        assert!(events.iter().any(|e| e.kind == FractureKind::Core), "vertex {} breaks out", n / 2);
        check_invariants(&w.model).unwrap();
        let gpu = w.gpu_solver().unwrap();
        let (bytes, repacked) = (gpu.last_upload_bytes(), gpu.last_repacked());
        eprintln!(
            "{n} vertices: one core split re-packed {repacked} elements, uploaded {bytes} of {model_bytes} bytes"
        );
        figures.push((n, bytes, repacked, model_bytes));
    }
    let ((n0, b0, r0, _), (n1, b1, r1, mb1)) = (figures[0], figures[1]);
    assert!(n1 > 15 * n0);
    assert!(b1 <= b0 + b0 / 10 && r1 <= r0 + r0 / 10, "upload {b0} -> {b1} bytes, re-packed {r0} -> {r1}");
    assert!(b1 * 100 < mb1, "{b1} bytes uploaded of a {mb1}-byte model");

    // The delta-updated GPU model steps as the CPU's does after the same split, through the leak that follows
    // (the split lightens the ring, whose springs soften with it: the delta must carry them).
    let inflated = || ball(4, Gas::Pressure(2000.0));
    let (mut cpu, mut gpu_world) = (World::new(inflated(), SolverConfig::default()), {
        let m = inflated();
        let g = solver(&ctx, &m, Integrator::SymplecticEuler);
        World::with_solver(m, Box::new(g))
    });
    for w in [&mut cpu, &mut gpu_world] {
        w.advance(0.01, 1e-4).unwrap();
        let v = w.model.particle_count() / 3;
        assert!(!w.break_core(v).unwrap().is_empty());
        w.advance(0.03, 1e-4).unwrap();
    }
    assert_eq!(cpu.model.particle_count(), gpu_world.model.particle_count());
    let moved = rms_difference(&cpu.state, &inflated().state());
    let rms = rms_difference(&cpu.state, &gpu_world.state);
    eprintln!("after the split: moved {moved:.3e} m RMS, GPU-CPU {rms:.3e} m RMS");
    assert!(moved > 100.0 * rms && rms < 1e-4 * 0.5, "GPU and CPU differ by {rms} m after a split");
}
