//! The contact scenes run to the end on the CPU, checked at every frame by `scene_check` (no two triangles that
//! are not neighbours cross): balloons thrown at each other, a cloth folding over itself, and the fracture scene,
//! whose core blocks must stay out of the ball. `tests/gpu/contact.rs` runs the fracture scene on the GPU with the
//! same check.

use fissure::glam::DVec3;
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

/// A piece born crossing the body it broke from (which does not collide with itself, so it may cross itself) is
/// left out of contact with it until no triangle of the one crosses the other, then held apart like any pair.
/// One body of two sheets crossing at right angles; a core block broken out of the upright sheet where it passes
/// through the flat one, and sent down and out of its own sheet's plane at 0.5 m/s: it moves freely through the
/// flat sheet (when its pairs with the sheet were held, at gaps of nothing, the caps kept it where it was born:
/// the fracture scene's lock), parts from it, and sent back is held below it, never crossing it again.
#[test]
fn a_piece_born_crossing_its_parent_moves_through_it_until_parted_then_is_held_apart() {
    let (n, sp) = (11usize, 0.02);
    let grid = Mesh::grid(n, n, sp);
    let mut pos = Vec::new();
    for j in 0..n {
        for i in 0..n {
            pos.push(DVec3::new(-0.1 + sp * i as f64, 0.0, -0.09 + sp * j as f64));
        }
    }
    for j in 0..n {
        for i in 0..n {
            pos.push(DVec3::new(-0.09 + sp * i as f64, -0.105 + sp * j as f64, 0.0));
        }
    }
    let nn = (n * n) as u32;
    let tris: Vec<[u32; 3]> =
        grid.triangles().iter().copied().chain(grid.triangles().iter().map(|t| t.map(|k| k + nn))).collect();
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let sheets = b.add_cloth(&Mesh::new(pos, tris).unwrap(), &ClothOptions::default()).unwrap();
    b.set_contact(sheets.index, Contact::default()).unwrap();
    let m: Model<f64> = b.finalize().unwrap();
    let dt = (0.5 * StabilityBound::of(&m).max_dt(Integrator::SymplecticEuler)).min(1e-4);
    let mut w = World::new(m, SolverConfig::default());
    // The upright sheet's vertex (5, 5), at y = -0.005: its one-ring reaches y = 0.015, through the flat sheet.
    let events = w.break_core(nn as usize + 5 * n + 5).unwrap();
    let piece = events.iter().find_map(|e| e.new_body).expect("a core block broke out");
    let crossing = |w: &World<f64>| {
        let m = &w.model;
        let body = |t: u32| m.tri_body[t as usize];
        let flat = |t: u32| m.tri_indices[t as usize].iter().all(|&i| (i as usize) < n * n);
        (fissure::contact::crossings(m, &w.state.particle_q).into_iter())
            .filter(|&[t, u]| (body(t) == piece && flat(u)) || (body(u) == piece && flat(t)))
            .count()
    };
    assert!(crossing(&w) > 0, "the block is not born crossing the flat sheet");
    let block: Vec<usize> = (0..w.model.particle_count()).filter(|&i| w.model.particle_body[i] == piece).collect();
    let centre = |w: &World<f64>| block.iter().map(|&i| w.state.particle_q[i]).sum::<DVec3>() / block.len() as f64;
    let send = |w: &mut World<f64>, v: DVec3| block.iter().for_each(|&i| w.state.particle_qd[i] = v);
    let (c0, v) = (centre(&w), DVec3::new(0.0, -0.5, -0.5) / 2f64.sqrt());
    send(&mut w, v);
    let steps = (0.08 / dt).ceil() as usize;
    for _ in 0..steps {
        w.step(dt).unwrap();
    }
    let moved = centre(&w) - c0;
    let free = v * (steps as f64 * dt);
    assert!((moved - free).length() < 0.05 * free.length(), "the block moved {moved} m, not freely ({free} m)");
    assert_eq!(crossing(&w), 0, "the block has not parted from the flat sheet");
    // Back up: held below the sheet from now on.
    let pushed = w.cpu_solver().unwrap().contact_stats().pushed_total;
    send(&mut w, -v);
    for step in 0..2 * steps {
        w.step(dt).unwrap();
        assert_eq!(crossing(&w), 0, "step {step}: the block crossed the sheet again");
    }
    assert!(w.cpu_solver().unwrap().contact_stats().pushed_total > pushed, "the block never touched the sheet");
    assert!(centre(&w).y < 0.0, "the block is above the sheet");
}
