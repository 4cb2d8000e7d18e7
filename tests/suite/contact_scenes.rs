//! The contact scenes run to the end on the CPU, checked at every frame by `scene_check` (no two triangles that
//! are not neighbours cross): balloons thrown at each other, a cloth folding over itself, and the fracture scene,
//! whose core blocks must stay out of the ball. `tests/gpu/contact.rs` runs the fracture scene on the GPU with the
//! same check.

use fissure::*;

use crate::scene_check;

/// Runs `name` on the CPU to its end, checked at every frame; returns the world and the contact pass's totals.
fn run_checked(name: &str) -> (World<f32>, ContactStats) {
    let scene = scene_check::scene(name);
    let mut w = scene_check::run_checked(name, scene.world::<f32>().unwrap(), &scene);
    let stats = w.cpu_solver().unwrap().contact_stats();
    eprintln!("{name}: {stats:?}");
    (w, stats)
}

#[test]
fn balloons_collide_and_never_cross() {
    let (w, c) = run_checked("balloons");
    assert!(c.pushed_total > 1000, "the balloons hardly touched: {c:?}");
    // Every balloon keeps its gas volume near its rest volume: none was squashed through another.
    for (b, v) in w.model.body_volumes(&w.state).iter().enumerate() {
        let v0 = w.model.body_rest_volume[b] as f64;
        assert!((v / v0 - 1.0).abs() < 0.2, "balloon {b}: volume {v} vs rest {v0}");
    }
}

#[test]
fn cloth_fold_folds_over_itself_and_never_crosses() {
    let (w, c) = run_checked("cloth_fold");
    assert!(c.pushed_total > 10_000, "the cloth hardly touched itself: {c:?}");
    let top = w.state.particle_q.iter().map(|x| x.y).fold(f32::MIN, f32::max);
    assert!(top < 0.7, "the cloth did not settle onto the ball (highest point {top} m)");
}

#[test]
fn fracture_scene_with_contact_keeps_pieces_out_of_the_ball() {
    let (w, c) = run_checked("fracture");
    let core = w.events.iter().filter(|e| e.kind == FractureKind::Core).count();
    assert!(core >= 3, "only {core} core events");
    assert!(w.model.body_count() > 3, "no pieces broke away");
    assert!(c.pushed_total > 0, "the pieces never touched the ball: {c:?}");
}

/// Each pair's reach is its own (`h + d_P / GAMMA`, its four particles' largest move) and each particle's bound
/// starts at `GAMMA h + d_i`: slow bodies beside fast ones must still never cross. `fissure::scenes::crowd`:
/// eight coarse balls (5 cm, thickness ~6 mm), four thrown at 100–200 m/s (20–40 mm a step, several thicknesses)
/// and four nearly at rest, each colliding with itself too: no two triangles cross after any step, the pass
/// pushed pairs, and its bound capped moves. (With the reach cut to a tenth, 24 pairs cross at the first step.)
#[test]
fn slow_and_fast_bodies_in_a_crowd_never_cross() {
    let m: Model<f32> = fissure::scenes::crowd(100.0).unwrap().finalize().unwrap();
    let mut s = m.state();
    let mut solver = CpuSolver::<f32>::new(SolverConfig { substep_safety: Some(0.8), ..Default::default() });
    for step in 0..300 {
        solver.step(&m, &mut s, 2e-4).unwrap();
        let crossed = fissure::contact::crossings(&m, &s.particle_q);
        assert!(crossed.is_empty(), "step {step}: {} pairs of triangles cross", crossed.len());
    }
    let st = solver.contact_stats();
    eprintln!(
        "pushed {} capped {} within reach {} over {} substeps",
        st.pushed_total, st.capped_total, st.near_total, st.steps
    );
    assert!(st.pushed_total > 0, "the balls never touched");
    assert!(st.capped_total > 0, "the bound never bound");
}

/// A piece born crossing the body it broke from moves through it until they part, then is held apart
/// (`scene_check::piece_born_crossing`; the GPU runs the same check).
#[test]
fn a_piece_born_crossing_its_parent_moves_through_it_until_parted_then_is_held_apart() {
    let m = scene_check::crossed_sheets();
    let w = World::new(m, SolverConfig::default());
    scene_check::piece_born_crossing(w, |w| w.cpu_solver().unwrap().contact_stats().pushed_total);
}
