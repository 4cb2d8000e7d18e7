//! The check the contact scenes share on either backend: a scene run to its end in steps of its `dt`, and at every
//! frame (1/60 s) no two triangles that are not neighbours cross (the exact test of `fissure::contact::crossings`),
//! unless both are of one body that does not ask for self-contact.
//!
//! One more exception, which contact cannot avoid: a body without self-contact may cross itself (the fracture
//! scene's torn ball, flattened on the floor, lies in layers in one plane), and a piece that breaks off where it
//! does starts out crossing its parent. The solver then leaves the two bodies out of contact with each other
//! until no triangle of one comes within a thickness of the other (`fissure::contact::bodies_within`;
//! `fissure::contact::family`), and so does this check: the pairs of bodies that cross at the step a piece is born
//! (the piece and a body of its family: the body it broke from, pieces of that body born before or in the same
//! step) are recorded then, and their crossings are excused until the two are that far apart at a frame; from
//! then on the two are held like any other. A crossing between a piece and anything else (other bodies, a member
//! of its family it did not cross at birth) is not excused.

use fissure::glam::Vec3;
use fissure::scene::Scene;
use fissure::*;
use std::collections::HashSet;

/// The scene file `scenes/{name}.toml`.
pub fn scene(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"));
    Scene::load(&path).unwrap()
}

/// Pairs of triangles that cross at `q` and must not: of two bodies, or of one body with self-contact.
pub fn forbidden(m: &Model<f32>, q: &[fissure::glam::Vec3]) -> Vec<[u32; 2]> {
    fissure::contact::crossings(m, q)
        .into_iter()
        .filter(|&[t, u]| {
            let (a, b) = (m.tri_body[t as usize], m.tri_body[u as usize]);
            a != b || m.body_self_contact[a as usize]
        })
        .collect()
}

/// Runs `w`, the world of `scene` (`name`), to the scene's end in steps of its `dt`, one at a time (so a piece's
/// birth is seen at its step), checking every frame; returns the world.
pub fn run_checked(name: &str, mut w: World<f32>, scene: &Scene) -> World<f32> {
    assert!(w.model.has_contact(), "{name}: the scene asks for contact");
    let frames = (scene.solver.duration * 60.0).round() as usize;
    let mut inherited: HashSet<[u32; 2]> = HashSet::new();
    let mut excused = 0;
    for frame in 0..frames {
        let end = w.state.time + 1.0 / 60.0;
        while w.state.time < end - 1e-12 {
            let (bodies, events) = (w.model.body_count(), w.events.len());
            w.step(scene.solver.dt.min(end - w.state.time)).unwrap();
            if w.model.body_count() == bodies {
                continue;
            }
            // Pieces born this step: each joins the group of the body it broke from (whose own crossings are
            // allowed when it has no self-contact); a crossing between two members of one group, one of them
            // new, is the parent's own crossing inherited.
            let m = &w.model;
            let mut group: Vec<u32> = (0..m.body_count() as u32).collect();
            for e in &w.events[events..] {
                if let Some(b) = e.new_body {
                    group[b as usize] = group[e.body as usize];
                }
            }
            for [t, u] in forbidden(m, &w.state.particle_q) {
                let (a, b) = (m.tri_body[t as usize], m.tri_body[u as usize]);
                let root = group[a as usize] as usize;
                if group[b as usize] as usize == root && a.max(b) as usize >= bodies && !m.body_self_contact[root] {
                    inherited.insert([a.min(b), a.max(b)]);
                }
            }
        }
        let m = &w.model;
        let bodies_of = |[t, u]: [u32; 2]| {
            let (a, b) = (m.tri_body[t as usize], m.tri_body[u as usize]);
            [a.min(b), a.max(b)]
        };
        let x = forbidden(m, &w.state.particle_q);
        // A pair of bodies that parted is held from now on.
        let h = |b: u32| fissure::contact::thickness(m, b as usize);
        inherited.retain(|&[a, b]| fissure::contact::bodies_within(m, &w.state.particle_q, a, b, h(a).max(h(b))));
        excused = excused.max(inherited.len());
        let x: Vec<_> = x.into_iter().filter(|&tu| !inherited.contains(&bodies_of(tu))).collect();
        assert!(x.is_empty(), "{name}: frame {frame}: {} crossing triangle pairs, first {:?}", x.len(), x[0]);
    }
    eprintln!("{name}: at most {excused} pairs of bodies born crossing at once, timers\n{}", w.timers());
    w
}

/// Sheets of [`crossed_sheets`]: vertices a side, spacing \[m\].
const SHEET: (usize, f64) = (11, 0.02);

/// One body of two sheets crossing at right angles (a flat one at y = 0, an upright one at z = 0 through it),
/// in contact but not with itself (so it may cross itself), without gravity: what a torn body lying folded
/// through itself looks like to contact.
pub fn crossed_sheets() -> Model<f32> {
    let (n, sp) = SHEET;
    let grid = Mesh::grid(n, n, sp);
    let mut pos = Vec::new();
    for j in 0..n {
        for i in 0..n {
            pos.push(fissure::glam::DVec3::new(-0.1 + sp * i as f64, 0.0, -0.09 + sp * j as f64));
        }
    }
    for j in 0..n {
        for i in 0..n {
            pos.push(fissure::glam::DVec3::new(-0.09 + sp * i as f64, -0.105 + sp * j as f64, 0.0));
        }
    }
    let nn = (n * n) as u32;
    let tris: Vec<[u32; 3]> =
        grid.triangles().iter().copied().chain(grid.triangles().iter().map(|t| t.map(|k| k + nn))).collect();
    let mut b = ModelBuilder::new();
    b.gravity(fissure::glam::DVec3::ZERO).unwrap();
    let sheets = b.add_cloth(&Mesh::new(pos, tris).unwrap(), &ClothOptions::default()).unwrap();
    b.set_contact(sheets.index, Contact::default()).unwrap();
    b.finalize().unwrap()
}

/// A piece born crossing the body it broke from (which does not collide with itself) is left out of contact with
/// it until no triangle of the one is within a thickness of the other, then held apart like any pair. On `w`, a
/// world of [`crossed_sheets`]: a core block broken out of the upright sheet where it passes through the flat one,
/// and sent down and out of its own sheet's plane at 0.5 m/s, moves as if free through the flat sheet (when its
/// pairs with the sheet were held, at gaps of nothing, the caps kept it where it was born: 6 mm in 80 ms instead
/// of 40), parts from it, and sent back is held below it, never crossing it again. `pushed`: the contact pass's
/// count of pushed pairs so far.
pub fn piece_born_crossing(mut w: World<f32>, pushed: impl Fn(&mut World<f32>) -> u64) {
    let n = SHEET.0;
    let dt = (0.5 * StabilityBound::of(&w.model).max_dt(Integrator::SymplecticEuler)).min(1e-4);
    // The upright sheet's vertex (5, 5), at y = -0.005: its one-ring reaches y = 0.015, through the flat sheet.
    let events = w.break_core(n * n + 5 * n + 5).unwrap();
    let piece = events.iter().find_map(|e| e.new_body).expect("a core block broke out");
    let crossing = |w: &World<f32>| {
        let m = &w.model;
        let body = |t: u32| m.tri_body[t as usize];
        let flat = |t: u32| m.tri_indices[t as usize].iter().all(|&i| (i as usize) < n * n);
        (fissure::contact::crossings(m, &w.state.particle_q).into_iter())
            .filter(|&[t, u]| (body(t) == piece && flat(u)) || (body(u) == piece && flat(t)))
            .count()
    };
    assert!(crossing(&w) > 0, "the block is not born crossing the flat sheet");
    let block: Vec<usize> = (0..w.model.particle_count()).filter(|&i| w.model.particle_body[i] == piece).collect();
    let centre = |w: &World<f32>| block.iter().map(|&i| w.state.particle_q[i]).sum::<Vec3>() / block.len() as f32;
    let send = |w: &mut World<f32>, v: Vec3| {
        block.iter().for_each(|&i| w.state.particle_qd[i] = v);
        w.solver.upload_state(&w.state).unwrap();
    };
    let (c0, v) = (centre(&w), Vec3::new(0.0, -0.5, -0.5) / 2f32.sqrt());
    send(&mut w, v);
    let steps = (0.08 / dt).ceil() as usize;
    for _ in 0..steps {
        w.step(dt).unwrap();
    }
    let moved = centre(&w) - c0;
    let free = v * (steps as f64 * dt) as f32;
    assert!((moved - free).length() < 0.05 * free.length(), "the block moved {moved} m, not freely ({free} m)");
    assert_eq!(crossing(&w), 0, "the block has not parted from the flat sheet");
    // Back up: held below the sheet from now on.
    let before = pushed(&mut w);
    send(&mut w, -v);
    for step in 0..2 * steps {
        w.step(dt).unwrap();
        assert_eq!(crossing(&w), 0, "step {step}: the block crossed the sheet again");
    }
    assert!(pushed(&mut w) > before, "the block never touched the sheet");
    assert!(centre(&w).y < 0.0, "the block is above the sheet");
}
