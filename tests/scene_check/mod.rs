//! The check the contact scenes share on either backend: a scene run to its end in steps of its `dt`, and at every
//! frame (1/60 s) no two triangles that are not neighbours cross (the exact test of `fissure::contact::crossings`),
//! unless both are of one body that does not ask for self-contact.
//!
//! One more exception, which contact cannot avoid: a body without self-contact may cross itself (the fracture
//! scene's torn ball, flattened on the floor, lies in layers in one plane), and a piece that breaks off where it
//! does starts out crossing its parent. The solver then leaves the two bodies out of contact with each other
//! until no triangle of one comes within a thickness of the other (`fissure::contact::bodies_within`; the core's
//! `solver::contact::family`), and so does this check: the pairs of bodies that cross at the step a piece is born
//! (the piece and a body of its family: the body it broke from, pieces of that body born before or in the same
//! step) are recorded then, and their crossings are excused until the two are that far apart at a frame; from
//! then on the two are held like any other. A crossing between a piece and anything else (other bodies, a member
//! of its family it did not cross at birth) is not excused.

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
