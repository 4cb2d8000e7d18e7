//! Tearing: a strip pulled apart by moving pins tears at the same force per unit width on three meshes and at
//! three time steps (the tear strength is a material property, not a mesh one); a sheet under uniaxial tension
//! cracks across the load; the pieces separate.

use fissure::glam::DVec3;
use fissure::*;

use crate::common;

use common::pulled_sheet;

/// Tear strength of the test sheet \[N/m\].
const TEAR: f64 = 20.0;

/// The pull on `handle` \[N\]: minus the x component of the net force its particles feel.
fn pull(w: &mut World<f64>, handle: &[usize], f: &mut Vec<DVec3>) -> f64 {
    f.resize(w.model.particle_count(), DVec3::ZERO);
    let cpu = w.solver.as_any_mut().downcast_mut::<CpuSolver<f64>>().unwrap();
    cpu.compute_forces(&w.model, &w.state, f).unwrap();
    // Virtual nodes split off a handle particle move with it: count every particle on the handle.
    let h = w.model.particle_handle[handle[0]];
    (0..w.model.particle_count()).filter(|&i| w.model.particle_handle[i] == h).map(|i| -f[i].x).sum()
}

/// Pulls a 0.2 × 0.1 m strip apart; returns the highest pull per unit width \[N/m\] and the world at the end.
fn tear_strip(nx: usize, dt_fraction: f64) -> (f64, World<f64>) {
    let (width, height) = (0.2, 0.1);
    let (mut w, right) = pulled_sheet(nx, width, height, 0.02, TEAR);
    let cpu = w.solver.as_any_mut().downcast_mut::<CpuSolver<f64>>().unwrap();
    let dt = dt_fraction * cpu.stability_bound(&w.model).max_dt(Integrator::SymplecticEuler);
    let mut f = Vec::new();
    let mut peak: f64 = 0.0;
    let steps = (0.25 / dt).ceil() as usize;
    let sample = (2e-4 / dt).ceil() as usize;
    for k in 0..steps {
        w.step(dt).unwrap();
        if k % sample == 0 {
            peak = peak.max(pull(&mut w, &right, &mut f) / height);
        }
    }
    (peak, w)
}

#[test]
fn strip_tears_at_one_force_per_width_on_any_mesh_and_step() {
    let mut peaks = Vec::new();
    for (nx, frac) in [(17, 0.8), (33, 0.8), (65, 0.8), (33, 0.4), (33, 0.2)] {
        let (peak, w) = tear_strip(nx, frac);
        let springs = w.events.iter().filter(|e| e.kind == FractureKind::Spring).count();
        eprintln!(
            "nx {nx} dt {frac} x bound: peak pull {peak:.3} N/m, {springs} spring events, {} bodies",
            w.model.body_count()
        );
        assert!(w.model.body_count() >= 2, "nx {nx}, dt {frac}: the strip did not tear through");
        check_invariants(&w.model).unwrap();
        // The tear strength is the load per unit width at which it tears (the lattice's shear and bending
        // springs carry a little more than the membrane: up to about 1.1 T).
        assert!((0.95 * TEAR..1.2 * TEAR).contains(&peak), "nx {nx}, dt {frac}: tore at {peak} N/m, strength {TEAR}");
        peaks.push(peak);
    }
    let (lo, hi) = peaks.iter().fold((f64::MAX, 0.0f64), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    assert!(hi / lo < 1.1, "tear force per width varies by {:.1} %: {peaks:?}", (hi / lo - 1.0) * 100.0);
}

/// A grid cloth in wind keeps the grid wind pass as it tears (`forces::wind_grid`: the triangles fracture
/// changed or added are computed by the general kernel and added to their corners): on the torn strip the forces
/// agree with the general pass (the same model with its grids forgotten) to f64 rounding, and are not bit for bit
/// the same (so the grid pass ran).
#[test]
fn a_tearing_cloth_in_wind_keeps_the_grid_wind_pass() {
    let (mut w, _) = pulled_sheet(33, 0.2, 0.1, 0.02, TEAR);
    w.model.wind = Some(WindField { velocity: DVec3::new(0.5, 1.0, 3.0), ..Default::default() });
    w.model.body_drag.iter_mut().for_each(|d| *d = 1.0);
    w.model.body_lift.iter_mut().for_each(|l| *l = 0.5);
    w.solver.notify_model_changed(&w.model, &TopologyDelta::whole());
    let (particles, triangles) = (w.model.particle_count(), w.model.tri_count());
    let cpu = w.solver.as_any_mut().downcast_mut::<CpuSolver<f64>>().unwrap();
    let dt = 0.8 * cpu.stability_bound(&w.model).max_dt(Integrator::SymplecticEuler);
    for _ in 0..(0.25 / dt).ceil() as usize {
        w.step(dt).unwrap();
    }
    assert!(w.model.body_count() >= 2, "the strip tore through in the wind");
    // Triangles whose corners fracture moved: off their grid's layout.
    let moved = w.model.tri_indices.iter().filter(|t| t.iter().any(|&v| v as usize >= particles)).count();
    assert!(moved > 0 && w.model.tri_count() >= triangles, "{moved} triangles on split particles");
    // Over a tenth of the triangles off their grid's layout: split corners, detached pieces, new triangles.
    let g = w.model.tri_grids[0];
    let mut off = w.model.tri_count() - g.tri_count();
    for j in 0..g.ny - 1 {
        for i in 0..g.nx - 1 {
            let t = g.first as usize + 2 * (j * (g.nx - 1) + i) as usize;
            for (k, want) in g.quad(i, j).into_iter().enumerate() {
                off += (w.model.tri_indices[t + k] != want || w.model.tri_body[t + k] != 0) as usize;
            }
        }
    }
    assert!(off * 10 > w.model.tri_count(), "{off} of {} triangles off the layout", w.model.tri_count());
    let mut general = w.model.clone();
    general.tri_grids.clear();
    let n = w.model.particle_count();
    let (mut fa, mut fb) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
    CpuSolver::<f64>::default().compute_forces(&w.model, &w.state, &mut fa).unwrap();
    CpuSolver::<f64>::default().compute_forces(&general, &w.state, &mut fb).unwrap();
    let scale = fb.iter().map(|f| f.length()).fold(0.0, f64::max);
    let worst = fa.iter().zip(&fb).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    assert!(worst <= 1e-12 * scale, "forces differ by {worst} N (max {scale} N)");
    assert!(worst > 0.0, "bit-identical forces: the grid pass did not run on the torn cloth");
}

/// Direction of the crack: the principal axis of the spring-event positions; returns its angle from the y axis
/// (the perpendicular to the load) in degrees, and the number of events.
fn crack_angle(w: &World<f64>) -> (f64, usize) {
    let p: Vec<DVec3> = w.events.iter().filter(|e| e.kind == FractureKind::Spring).map(|e| e.position).collect();
    let n = p.len() as f64;
    let c = p.iter().copied().sum::<DVec3>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for q in &p {
        let d = *q - c;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    // The major axis of the 2x2 covariance.
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = DVec3::new(theta.cos(), theta.sin(), 0.0);
    (axis.x.abs().asin().to_degrees(), p.len())
}

#[test]
fn notched_sheet_cracks_across_the_load() {
    for nx in [17, 33] {
        let (mut w, _) = pulled_sheet(nx, 0.2, 0.2, 0.02, TEAR);
        // A notch: the horizontal springs at the middle of the bottom edge cut, two rows deep.
        let ny = nx;
        for row in [ny - 1, ny - 2] {
            let (a, b) = (row * nx + nx / 2 - 1, row * nx + nx / 2);
            let sp = fissure::fracture::spring_between(&w.model, a as u32, b as u32).unwrap() as usize;
            w.break_spring(sp).unwrap();
        }
        let cpu = w.solver.as_any_mut().downcast_mut::<CpuSolver<f64>>().unwrap();
        let dt = 0.5 * cpu.stability_bound(&w.model).max_dt(Integrator::SymplecticEuler);
        for _ in 0..(0.2 / dt) as usize {
            w.step(dt).unwrap();
        }
        let (angle, n) = crack_angle(&w);
        eprintln!("nx {nx}: {n} spring events, crack {angle:.1} deg from the perpendicular");
        check_invariants(&w.model).unwrap();
        assert!(n >= 8, "nx {nx}: the crack did not run ({n} spring events)");
        assert!(angle < 15.0, "nx {nx}: the crack runs {angle:.1} deg off the perpendicular to the load");
        // It ran from the notch: its events lie on the middle of the sheet.
        let off = w.events.iter().filter(|e| e.kind == FractureKind::Spring).map(|e| (e.position.x - 0.1).abs());
        let off = off.fold(0.0, f64::max);
        assert!(off < 0.05, "nx {nx}: a crack opened {off} m from the notch's line");
    }
}

/// Loads `scenes/{name}.toml` in f32.
fn scene_world(name: &str) -> (fissure::scene::Scene, World<f32>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"));
    let scene = fissure::scene::Scene::load(&path).unwrap();
    let w = scene.world::<f32>().unwrap();
    (scene, w)
}

/// Spring-mode events that split a triangle edge (not the removal of a bending spring).
fn splits(w: &World<f32>) -> Vec<&FractureEvent> {
    w.events.iter().filter(|e| e.kind == FractureKind::Spring && !e.new_particles.is_empty()).collect()
}

#[test]
fn cloth_tear_scene_tears_in_two_halves_along_the_pull() {
    let (scene, mut w) = scene_world("cloth_tear");
    w.advance(scene.solver.duration, scene.solver.dt).unwrap();
    check_invariants(&w.model).unwrap();
    // The two halves, each on its handle: the particles of each handle belong to one body, not the same one.
    let body_of = |h: u32| {
        let i = w.model.particle_handle.iter().position(|&x| x == h).unwrap();
        w.model.particle_body[i]
    };
    let (left, right) = (body_of(0), body_of(1));
    assert_ne!(left, right, "the cloth did not tear in two ({} events)", w.events.len());
    // Each half is a large piece: the split ran between them, across the pull (x).
    let count = |b: u32| w.model.particle_body.iter().filter(|&&x| x == b).count();
    let n = w.model.particle_count();
    assert!(count(left) > n / 4 && count(right) > n / 4, "halves of {} and {} of {n}", count(left), count(right));
    let mean_x = |b: u32| {
        let xs: Vec<f32> = (0..n).filter(|&i| w.model.particle_body[i] == b).map(|i| w.state.particle_q[i].x).collect();
        xs.iter().sum::<f32>() / xs.len() as f32
    };
    assert!(mean_x(left) < -0.1 && mean_x(right) > 0.1, "halves at x = {} and {}", mean_x(left), mean_x(right));
    let s = splits(&w);
    assert!(s.len() >= 10, "{} splits", s.len());
}

#[test]
fn burst_scene_balloon_loses_its_volume_once_it_bursts() {
    let (scene, mut w) = scene_world("burst");
    let frame = 1.0 / 120.0;
    let mut before = 0.0;
    let mut burst = None;
    while w.state.time < scene.solver.duration - 1e-9 {
        let v = w.model.body_volumes(&w.state)[0];
        w.advance(frame, scene.solver.dt).unwrap();
        if burst.is_none() && !w.events.is_empty() {
            burst = Some(w.state.time);
            before = v;
        }
        if let Some(t) = burst
            && w.state.time >= t + 0.5
        {
            break;
        }
    }
    let t = burst.expect("the balloon never burst");
    let v0 = w.model.body_rest_volume[0] as f64;
    assert!(before > 4.0 * v0, "it burst at {:.1} times its rest volume: not inflated past its strength", before / v0);
    let after = w.model.body_volumes(&w.state)[0];
    eprintln!("burst at {t:.3} s at {before:.2e} m^3; {after:.2e} m^3 0.5 s later; {} events", w.events.len());
    assert!(after <= 0.1 * before, "kept {:.0} % of its volume 0.5 s after bursting", 100.0 * after / before);
    assert!(w.model.body_gas_amount[0] < 0.01 * 60.0, "its gas did not escape");
    check_invariants(&w.model).unwrap();
}

#[test]
fn fracture_scene_shows_cracks_and_chunks_and_collapses() {
    let (scene, mut w) = scene_world("fracture");
    let area = |m: &Model<f32>, s: &State<f32>, b: u32| -> f64 {
        (0..m.tri_count())
            .filter(|&t| m.tri_body[t] == b)
            .map(|t| {
                let [a, b, c] = m.tri_indices[t].map(|v| s.particle_q[v as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    };
    let tri0 = area(&w.model, &w.state, 0) / w.model.tri_count() as f64;
    let mut v_start = 0.0f64;
    while w.state.time < scene.solver.duration - 1e-9 {
        w.advance(1.0 / 60.0, scene.solver.dt).unwrap();
        if w.events.is_empty() {
            v_start = v_start.max(w.model.body_volumes(&w.state)[0]);
        }
    }
    check_invariants(&w.model).unwrap();
    let s = splits(&w);
    let core: Vec<_> = w.events.iter().filter(|e| e.kind == FractureKind::Core).collect();
    assert!(s.len() >= 3 && core.len() >= 3, "{} splits, {} core events", s.len(), core.len());
    // In >= 3 places (events more than 0.1 m apart).
    let mut places: Vec<DVec3> = Vec::new();
    for e in s.iter().chain(&core) {
        if places.iter().all(|p| p.distance(e.position) > 0.1) {
            places.push(e.position);
        }
    }
    assert!(places.len() >= 3, "events in {} places", places.len());
    // A crack longer than 3 edges: a chain of >= 4 splits, each within 1.5 edge lengths of the next.
    let edge = (4.0 * tri0 / 3f64.sqrt()).sqrt();
    let mut longest = 0;
    let mut seen = vec![false; s.len()];
    for i in 0..s.len() {
        if seen[i] {
            continue;
        }
        let (mut stack, mut size) = (vec![i], 0);
        seen[i] = true;
        while let Some(k) = stack.pop() {
            size += 1;
            for j in 0..s.len() {
                if !seen[j] && s[j].position.distance(s[k].position) < 1.5 * edge {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
        longest = longest.max(size);
    }
    assert!(longest >= 4, "the longest crack has {longest} splits");
    // Core blocks are a whole one-ring: >= 5 triangles of the ball's size.
    for e in &core {
        let b = e.new_body.unwrap();
        let tris = (0..w.model.tri_count()).filter(|&t| w.model.tri_body[t] == b).count();
        let a0: f64 = tris as f64 * tri0;
        assert!(tris >= 5, "core block {b} has {tris} triangles");
        assert!(area(&w.model, &w.state, b) > 0.5 * a0, "core block {b} is a speck");
    }
    let v_end = w.model.body_volumes(&w.state)[0];
    eprintln!(
        "{} splits, {} core, {} places, longest crack {longest}, volume {v_start:.4} -> {v_end:.4}",
        s.len(),
        core.len(),
        places.len()
    );
    assert!(v_end <= 0.6 * v_start, "the ball kept {:.0} % of its volume", 100.0 * v_end / v_start);
}

/// A punctured ball whose gas pulls its membrane at 0.9 of its tear strength: cracks start at the hole's rim
/// (where the stress concentrates), run while the pressure drives them, and stop as the gas leaks out.
#[test]
fn a_crack_in_a_leaking_ball_stops_when_the_pressure_falls() {
    let mut w = common::breakable_ball(3, 3000.0, 360.0);
    let dt = 2e-4;
    w.advance(0.1, dt).unwrap();
    assert!(w.events.is_empty(), "the inflated ball broke on its own");
    let pressure = |w: &World<f64>| {
        let v = w.model.body_volumes(&w.state)[0];
        w.model.body_gas_amount[0] / v
    };
    let p0 = pressure(&w);
    w.break_core(0).unwrap();
    let mut last = (0.0, p0);
    while w.state.time < 1.0 {
        let n = w.events.len();
        w.step(dt).unwrap();
        if w.events[n..].iter().any(|e| e.kind == FractureKind::Spring) {
            last = (w.state.time, pressure(&w));
        }
    }
    let s = w.events.iter().filter(|e| e.kind == FractureKind::Spring && !e.new_particles.is_empty()).count();
    let p_end = pressure(&w);
    eprintln!("{s} splits; the last at {:.3} s at {:.0} Pa (from {p0:.0}); {p_end:.0} Pa at the end", last.0, last.1);
    assert!(s >= 3, "the puncture did not start a crack ({s} splits)");
    assert!(last.0 < 0.7, "the crack still grew at {:.3} s", last.0);
    assert!(last.1 < 0.9 * p0, "the crack stopped before the pressure fell ({:.0} of {p0:.0} Pa)", last.1);
    // By then the gas pulls the membrane (hoop tension p r / 2, r about 0.27 m) far below its tear strength.
    assert!(last.1 * 0.27 / 2.0 < 0.5 * 360.0, "the crack stopped at {:.0} Pa, still driven", last.1);
    assert!(p_end < last.1, "the gas did not keep leaking after the crack stopped");
    check_invariants(&w.model).unwrap();
}
