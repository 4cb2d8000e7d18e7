//! Contact between surfaces on the GPU (`shaders/contact.wgsl`) against the CPU pass (`fissure_core::contact`),
//! on a device with WebGPU's default limits: the same pairs on fixed configurations, trajectories through contact
//! within a stated tolerance, contact after a fracture, a full pair buffer as an error, and the fracture scene
//! run to its end with no crossing at any frame.

use fissure::glam::{DVec3, Vec3};
use fissure::*;
use fissure_gpu::{GpuConfig, GpuError, GpuSolver};

use crate::gpu_support;
use crate::scene_check;
use gpu_support::{gpu, rms_difference, solver};

/// Two balls (icospheres of `sub` subdivisions: 162 vertices each at 2; no gas, no gravity, at rest) half their
/// contact thickness apart, the second also in contact with itself with a thickness of about its edge length (so
/// it has pairs with itself at rest); and the largest thickness.
fn touching_balls(sub: u32) -> (Model<f32>, f64) {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions::default();
    // Thicknesses in proportion to the edges (which halve with each subdivision).
    let f = 0.5f64.powi(sub as i32 - 2);
    let h = 0.02 * f;
    b.add_soft_body(&Mesh::icosphere(0.1, sub), &opts).unwrap();
    // Turned a little so that the two surfaces do not mirror each other (vertex on vertex).
    let turn = fissure::glam::DQuat::from_axis_angle(DVec3::new(0.3, 0.7, 0.2).normalize(), 0.4);
    let turned = Mesh::icosphere(0.1, sub).map_positions(|p| turn * p).unwrap();
    b.add_soft_body(&turned.translated(DVec3::new(0.2 + 0.5 * h, 0.0, 0.0)), &opts).unwrap();
    b.set_contact(0, Contact { thickness: Some(h), ..Default::default() }).unwrap();
    let h1 = 0.024 * f;
    b.set_contact(1, Contact { thickness: Some(h1), self_collision: true, ..Default::default() }).unwrap();
    (b.finalize().unwrap(), h1)
}

/// The GPU contact pass lists the CPU's pairs: on a fixed configuration (two balls at rest, one of them in contact
/// with itself), the same vertex–triangle and edge–edge pairs within reach, with the same gaps to f32 rounding, on
/// both GPU integrators. Pairs whose gap lies within 1e-3 of the reach are left out of the comparison (the reach
/// is the largest thickness plus the step's largest move over GAMMA: a few 1e-7 m here, where the springs' rest
/// lengths rounded to f32 move the balls, and not the same on both backends or integrators).
#[test]
fn contact_pairs_match_the_cpu_on_a_fixed_configuration() {
    let Some(ctx) = gpu() else { return };
    let (m, h) = touching_balls(2);
    assert_same_pairs(&ctx, &m, h);
}

/// The same on finer balls (2 × 2,562 vertices, 2 × 7,680 contact edges): grids of 2^15 buckets each, whose counts
/// the bucket scan takes in 64 blocks (`contact_scan_sums`, `contact_scan_spread`), against 4 at 162 vertices.
#[test]
fn contact_pairs_match_the_cpu_when_the_grids_span_many_scan_blocks() {
    let Some(ctx) = gpu() else { return };
    let (m, h) = touching_balls(4);
    assert_eq!(m.particle_count(), 2 * 2562);
    assert_same_pairs(&ctx, &m, h);
}

/// The body of the two tests above: the pairs of one substep on both backends.
fn assert_same_pairs(ctx: &fissure_gpu::GpuContext, m: &Model<f32>, h: f64) {
    let m = m.clone();
    let dt = 1e-4;
    // (h: the largest thickness, which is the reach at rest.)
    let mut cpu = CpuSolver::<f32>::new(SolverConfig::default());
    let mut s = m.state();
    cpu.step(&m, &mut s, dt).unwrap();
    let config = GpuConfig { contact_capacity: 1 << 16, ..Default::default() };
    let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m, config).unwrap();
    g.run(&m, dt, 1).unwrap();
    let clear = |d: f64| (d - h).abs() > 1e-3 * h;
    let mut c: Vec<([u32; 4], f64)> = cpu.contact_pairs().into_iter().filter(|p| clear(p.1)).collect();
    let mut gp: Vec<([u32; 4], f64)> =
        g.contact_pairs().unwrap().into_iter().map(|(p, d)| (p, d as f64)).filter(|p| clear(p.1)).collect();
    c.sort_by_key(|p| p.0);
    gp.sort_by_key(|p| p.0);
    eprintln!("{} pairs within reach on the CPU, {} on the GPU", c.len(), gp.len());
    assert!(c.len() >= 20, "the configuration should have pairs: {}", c.len());
    let ids = |v: &[([u32; 4], f64)]| v.iter().map(|p| p.0).collect::<Vec<_>>();
    assert_eq!(ids(&c), ids(&gp), "the same pairs");
    // Both kinds are there: vertex–triangle (the first particle alone on its element) and edge–edge.
    let tri_of =
        |p: [u32; 4]| m.tri_indices.iter().any(|t| t.contains(&p[1]) && t.contains(&p[2]) && t.contains(&p[3]));
    assert!(c.iter().any(|p| tri_of(p.0)) && c.iter().any(|p| !tri_of(p.0)), "both pair kinds");
    for (a, b) in c.iter().zip(&gp) {
        assert!((a.1 - b.1).abs() <= 1e-6 * 0.2 + 1e-3 * a.1, "gap of {:?}: cpu {} gpu {}", a.0, a.1, b.1);
    }
    // Velocity Verlet saves the start of the substep and changes its end state the same way: the same pairs.
    let config = GpuConfig { contact_capacity: 1 << 16, integrator: Integrator::VelocityVerlet, ..Default::default() };
    let mut vv = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m, config).unwrap();
    vv.run(&m, dt, 1).unwrap();
    let mut vp: Vec<[u32; 4]> =
        vv.contact_pairs().unwrap().into_iter().filter(|p| clear(p.1 as f64)).map(|p| p.0).collect();
    vp.sort();
    let g_ids = ids(&gp);
    let only_vv: Vec<_> = vp.iter().filter(|p| !g_ids.contains(p)).collect();
    let only_se: Vec<_> = g_ids.iter().filter(|p| !vp.contains(p)).collect();
    assert!(only_vv.is_empty() && only_se.is_empty(), "velocity Verlet: {only_vv:?} more, {only_se:?} fewer");
    // Pairs between the balls, and of the second ball with itself; none of the first with itself.
    let body = |i: u32| m.particle_body[i as usize];
    let kinds = |b0, b1| c.iter().filter(|p| body(p.0[0]) == b0 && body(p.0[3]) == b1).count();
    eprintln!("pairs: {} between the balls, {} of the second with itself", kinds(0, 1) + kinds(1, 0), kinds(1, 1));
    assert!(kinds(0, 1) + kinds(1, 0) > 0 && kinds(1, 1) > 0 && kinds(0, 0) == 0);
}

/// The balloons scene from just before the first collision, 600 steps on both backends: the balloons touch (the
/// GPU pushed pairs apart), no two triangles cross on the GPU at the end, and the trajectories agree within 2e-3
/// of the scene's size, RMS (measured on lavapipe, 2026-11-24: 8.9e-4). The tolerance is looser than the 1e-4 of
/// the other trajectories because the GPU
/// solves the contact impulses by Jacobi iterations and the CPU by Gauss–Seidel: the same constraints, solved to
/// a different residual, for the few hundred particles in contact.
#[test]
fn contact_trajectories_match_the_cpu_on_the_balloons_scene() {
    let Some(ctx) = gpu() else { return };
    let scene = scene_check::scene("balloons");
    let mut w = scene.world::<f32>().unwrap();
    let dt = scene.solver.dt;
    for _ in 0..560 {
        w.step(dt).unwrap();
    }
    let start = w.state.clone();
    let steps0 = w.cpu_solver().unwrap().contact_stats().steps;
    let pushed0 = w.cpu_solver().unwrap().contact_stats().pushed_total;
    for _ in 0..600 {
        w.step(dt).unwrap();
    }
    let cpu = w.cpu_solver().unwrap().contact_stats();
    assert_eq!(cpu.steps - steps0, 600, "one substep per step on the CPU");
    assert!(cpu.pushed_total > pushed0, "the balloons should touch within the 600 steps");
    let m = &w.model;
    let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), m, GpuConfig::default()).unwrap();
    g.upload_state(&start).unwrap();
    g.run(m, dt, 600).unwrap();
    let mut s = start.clone();
    g.read_state(&mut s).unwrap();
    let gs = g.contact_stats();
    eprintln!("CPU contact {cpu:?}\nGPU contact {gs:?}");
    assert_eq!(gs.steps, 600);
    assert!(gs.pushed_total > 0, "the GPU pass pushed no pair apart");
    let crossings = fissure::contact::crossings(m, &s.particle_q);
    assert!(crossings.is_empty(), "{} triangle pairs cross on the GPU", crossings.len());
    let (lo, hi) = s.particle_q.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let size = (hi - lo).length();
    let rms = (s.particle_q.iter().zip(&w.state.particle_q).map(|(a, b)| (*a - *b).length_squared()).sum::<f32>()
        / s.particle_q.len() as f32)
        .sqrt();
    eprintln!("balloons, 600 steps through contact: RMS {rms:e} m of a {size} m scene");
    assert!(rms <= 2e-3 * size, "RMS {rms} m against a {size} m scene");
    // Deterministic: the pairs are listed in a racy order, but the impulses are summed in integers.
    let mut again = start.clone();
    g.upload_state(&start).unwrap();
    g.run(m, dt, 600).unwrap();
    g.read_state(&mut again).unwrap();
    let bits = |s: &State<f32>| {
        s.particle_q.iter().chain(&s.particle_qd).map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert!(bits(&again) == bits(&s), "two GPU runs from one state differ");
    // One dispatch per Jacobi iteration gives the same bits as all of them in one workgroup (the default here).
    let config = GpuConfig { contact_fused_pairs: 0, ..Default::default() };
    let mut per = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), m, config).unwrap();
    per.upload_state(&start).unwrap();
    per.run(m, dt, 600).unwrap();
    let mut split = start.clone();
    per.read_state(&mut split).unwrap();
    assert!(bits(&split) == bits(&s), "one dispatch per Jacobi iteration and one for all differ");
}

/// Contact after a fracture on the GPU path: a breakable ball in contact falls onto another resting on the ground
/// and a core block breaks out of it (the model's contact elements re-packed with the delta); the balls then
/// touch and never cross, and the positions follow the CPU's within the tolerance of the balloons test.
#[test]
fn contact_follows_a_core_split_on_the_gpu_path() {
    let Some(ctx) = gpu() else { return };
    let balls = || {
        let mut b = ModelBuilder::new();
        let top = SoftBodyOptions {
            gas: Gas::Pressure(1500.0),
            velocity: DVec3::new(0.0, -1.0, 0.0),
            fracture: Some(Breakable { load_limit: 1e9, ..Default::default() }),
            ..Default::default()
        };
        let bottom = SoftBodyOptions { gas: Gas::Pressure(1500.0), ..Default::default() };
        b.add_soft_body(&Mesh::icosphere(0.25, 3).translated(DVec3::new(0.05, 0.77, 0.0)), &top).unwrap();
        b.add_soft_body(&Mesh::icosphere(0.25, 3).translated(DVec3::new(0.0, 0.25, 0.0)), &bottom).unwrap();
        b.set_contact(0, Contact::default()).unwrap();
        b.set_contact(1, Contact::default()).unwrap();
        b.add_collider(Collider::ground(0.0)).unwrap();
        b.finalize::<f32>().unwrap()
    };
    let mut cpu = World::new(balls(), SolverConfig::default());
    let m = balls();
    let g = solver(&ctx, &m, Integrator::SymplecticEuler);
    let mut gpu_world = World::with_solver(m, Box::new(g));
    for w in [&mut cpu, &mut gpu_world] {
        w.advance(0.02, 1e-4).unwrap();
        assert!(!w.break_core(0).unwrap().is_empty(), "vertex 0 breaks out");
        w.advance(0.05, 1e-4).unwrap();
        let m = &w.model;
        let x: Vec<_> = fissure::contact::crossings(m, &w.state.particle_q)
            .into_iter()
            .filter(|&[t, u]| m.tri_body[t as usize] != m.tri_body[u as usize])
            .collect();
        assert!(x.is_empty(), "{}: {} crossings between bodies", w.solver.name(), x.len());
    }
    let gs = gpu_world.gpu_solver().unwrap().contact_stats();
    let cs = cpu.cpu_solver().unwrap().contact_stats();
    eprintln!("after a core split: CPU {cs:?}\nGPU {gs:?}");
    assert!(gs.pushed_total > 0 && cs.pushed_total > 0, "the balls should touch");
    assert_eq!(cpu.model.particle_count(), gpu_world.model.particle_count());
    let rms = rms_difference(&cpu.state, &gpu_world.state);
    eprintln!("GPU-CPU {rms:.3e} m RMS");
    assert!(rms < 2e-3 * 1.0, "GPU and CPU differ by {rms} m after a split with contact");
}

/// The same pairs when the reach is so long that a triangle's search box spans more cells than the grid has
/// buckets, and the kernels visit every item instead of the box's cells: two coarse balls (12 vertices, 128
/// buckets) closing at 2,000 m/s, one step of 1e-4 s (a move of 10 cm, a reach of 24 cm, over cells of 10 cm: a
/// triangle's box spans 6 or more cells a side).
#[test]
fn contact_pairs_match_the_cpu_when_the_reach_spans_the_grid() {
    let Some(ctx) = gpu() else { return };
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let (h, v, dt) = (0.02, 1000.0, 1e-4);
    for (x, vx) in [(0.0, v), (0.3, -v)] {
        let opts = SoftBodyOptions { velocity: DVec3::new(vx, 0.0, 0.0), ..Default::default() };
        b.add_soft_body(&Mesh::icosphere(0.1, 0).translated(DVec3::new(x, 0.0, 0.0)), &opts).unwrap();
    }
    for body in 0..2 {
        b.set_contact(body, Contact { thickness: Some(h), ..Default::default() }).unwrap();
    }
    let m: Model<f32> = b.finalize().unwrap();
    let mut cpu = CpuSolver::<f32>::new(SolverConfig::default());
    let mut s = m.state();
    cpu.step(&m, &mut s, dt).unwrap();
    let mut g = solver(&ctx, &m, Integrator::SymplecticEuler);
    g.run(&m, dt, 1).unwrap();
    let reach = h + v * dt / fissure::contact::GAMMA;
    let clear = |d: f64| (d - reach).abs() > 1e-3 * reach;
    let mut c: Vec<[u32; 4]> = cpu.contact_pairs().into_iter().filter(|p| clear(p.1)).map(|p| p.0).collect();
    let mut gp: Vec<[u32; 4]> =
        g.contact_pairs().unwrap().into_iter().filter(|p| clear(p.1 as f64)).map(|p| p.0).collect();
    c.sort();
    gp.sort();
    eprintln!("{} pairs within a reach of {reach} m", c.len());
    assert!(c.len() >= 10, "{} pairs", c.len());
    assert_eq!(c, gp);
}

/// More contact pairs than the buffer holds: the run fails instead of missing them.
#[test]
fn more_contact_pairs_than_the_buffer_holds_is_an_error() {
    let Some(ctx) = gpu() else { return };
    let (m2, _) = touching_balls(2);
    let config = GpuConfig { contact_capacity: 2, ..Default::default() };
    let mut g2 = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m2, config).unwrap();
    let e = g2.run(&m2, 1e-4, 1).unwrap_err();
    assert!(matches!(e, GpuError::ContactCapacity { capacity: 2, .. }), "{e}");
    assert!(e.to_string().contains("contact_capacity"), "{e}");
}

/// The crowd of `fissure::scenes::crowd` on the GPU: fast balls (100–200 m/s) beside slow ones, each pair
/// filtered by its own reach (`pair_reach` in `shaders/contact.wgsl`) and each bound started at `GAMMA h + d_i`,
/// as on the CPU: no two triangles cross at any of 30 read-backs over 300 steps, and pairs were pushed and moves
/// capped.
#[test]
fn slow_and_fast_bodies_in_a_crowd_never_cross_on_the_gpu() {
    let Some(ctx) = gpu() else { return };
    let m: Model<f32> = fissure::scenes::crowd(100.0).unwrap().finalize().unwrap();
    // A fast ball's reach is ~9 cm (40 mm a step over GAMMA): at the densest moment ~45,000 pairs are within it.
    let config = GpuConfig { contact_capacity: 1 << 17, ..Default::default() };
    let mut g = GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &m, config).unwrap();
    let mut s = m.state();
    for k in 0..30 {
        g.run(&m, 2e-4, 10).unwrap();
        g.read_state(&mut s).unwrap();
        let crossed = fissure::contact::crossings(&m, &s.particle_q);
        assert!(crossed.is_empty(), "after {} steps: {} pairs of triangles cross", 10 * (k + 1), crossed.len());
    }
    let st = g.contact_stats();
    eprintln!("GPU crowd: {st:?}");
    assert!(st.pushed_total > 0 && st.capped_total > 0, "pushed {} capped {}", st.pushed_total, st.capped_total);
}

/// The fracture scene on the GPU (its leak and fracture passes on the CPU, the state read back every step), run
/// with `tests/suite/contact_scenes.rs`'s check at every frame: pieces break away, touch the ball and never cross it or
/// each other. It runs the scene's first 0.75 s of 1.5: all but 5 of its ~200 fracture events come before 0.3 s,
/// and by 0.75 s the pieces lie on the floor and the obstacles. `tests/suite/contact_scenes.rs` runs the whole scene on
/// the CPU; here on lavapipe the whole scene took 3 minutes, a third of CI's test time (2026-11-27). (On an H200,
/// `fissure run scenes/fracture.toml --backend gpu`, whose frames are 1/30 s, capped 29,530 moves over the run
/// against ~140 on lavapipe and on the CPU; this test run to the scene's end, whose frames are 1/60 s, capped 142
/// there and found no crossing at any frame.)
#[test]
fn fracture_scene_with_contact_keeps_pieces_out_of_the_ball_on_the_gpu() {
    let Some(ctx) = gpu() else { return };
    let mut scene = scene_check::scene("fracture");
    scene.solver.duration = 0.75;
    let mut w = scene.world::<f32>().unwrap();
    let config = GpuConfig { integrator: scene.integrator().unwrap(), ..Default::default() };
    w.solver = Box::new(GpuSolver::new(ctx.device.clone(), ctx.queue.clone(), &w.model, config).unwrap());
    let w = scene_check::run_checked("fracture", w, &scene);
    let c = w.gpu_solver().unwrap().contact_stats();
    eprintln!("fracture on the GPU: {} events, {} bodies, {c:?}", w.events.len(), w.model.body_count());
    let core = w.events.iter().filter(|e| e.kind == FractureKind::Core).count();
    assert!(core >= 3, "only {core} core events");
    assert!(w.model.body_count() > 3, "no pieces broke away");
    assert!(c.pushed_total > 0, "the pieces never touched the ball: {c:?}");
}

/// A piece born crossing the body it broke from moves through it until they part, then is held apart: the CPU's
/// check (`scene_check::piece_born_crossing`), on the GPU path (the pairs left out listed after the bodies in
/// `c_body`, asked whether they parted at every step here, since every step reads the state back).
#[test]
fn a_piece_born_crossing_its_parent_moves_through_it_until_parted_on_the_gpu() {
    let Some(ctx) = gpu() else { return };
    let m = scene_check::crossed_sheets();
    let g = solver(&ctx, &m, Integrator::SymplecticEuler);
    let w = World::with_solver(m, Box::new(g));
    scene_check::piece_born_crossing(w, |w| w.gpu_solver().unwrap().contact_stats().pushed_total);
}
