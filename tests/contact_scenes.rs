//! The contact scenes run to the end on the CPU, and at every frame (1/60 s) no two triangles that are not
//! neighbours cross (the exact test of `fissure::contact::crossings`), unless both are of one body that does not
//! ask for self-contact: balloons thrown at each other, a cloth folding over itself, and the fracture scene, whose
//! core blocks must stay out of the ball.

use fissure::scene::Scene;
use fissure::*;

/// Runs `name` to its end; returns the world and the contact pass's totals.
fn run_checked(name: &str) -> (World<f32>, ContactStats) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"));
    let scene = Scene::load(&path).unwrap();
    let mut w = scene.world::<f32>().unwrap();
    assert!(w.model.has_contact(), "{name}: the scene asks for contact");
    let frames = (scene.solver.duration * 60.0).round() as usize;
    for frame in 0..frames {
        w.advance(1.0 / 60.0, scene.solver.dt).unwrap();
        // Two surfaces may never cross; one surface may cross itself only where it does not ask for self-contact
        // (the fracture scene's torn ball folds its flaps into itself: contact keeps its pieces apart).
        let m = &w.model;
        let x: Vec<[u32; 2]> = fissure::contact::crossings(m, &w.state.particle_q)
            .into_iter()
            .filter(|&[t, u]| {
                let (a, b) = (m.tri_body[t as usize], m.tri_body[u as usize]);
                a != b || m.body_self_contact[a as usize]
            })
            .collect();
        assert!(x.is_empty(), "{name}: frame {frame}: {} crossing triangle pairs, first {:?}", x.len(), x[0]);
    }
    let stats = w.cpu_solver().unwrap().contact_stats();
    eprintln!("{name}: {stats:?}, timers\n{}", w.timers());
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
