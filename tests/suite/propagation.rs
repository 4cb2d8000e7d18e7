//! Property tests of fracture driven by its trigger, as a scene runs it: cracks start, run from their tips and
//! stop (`FractureConfig::splits_per_body`, nucleation, tips), pieces detach, gas leaks. Random strips pulled
//! apart by handles and random punctured pressurised balls; after every step that fractured anything the mesh
//! invariants hold (`check_invariants`: manifold, winding, adjacency), no triangle has zero area, the mass is
//! exactly the mass at the start (in fixed point), and every event names particles that exist. The explicit
//! fracture sequences of `crates/fissure-core/tests/suite/fracture.rs` check the same after each split one by one;
//! these check them along propagating cracks.

use crate::common;

use fissure::*;
use proptest::prelude::*;

/// Exact sum of `f64` masses in fixed point (2^-100 kg units).
fn exact_mass(m: &Model<f64>) -> i128 {
    m.particle_mass.iter().map(|&x| (x * 2f64.powi(100)) as i128).sum()
}

/// Steps `w` for `duration` \[s\] at `dt`, checking the invariants after every step with fracture events.
fn run_checked(
    w: &mut World<f64>,
    duration: f64,
    dt: f64,
    stop: impl Fn(&World<f64>) -> bool,
) -> Result<(), TestCaseError> {
    let mass0 = exact_mass(&w.model);
    while w.state.time < duration && !stop(w) {
        let events = w.step(dt).map_err(|e| TestCaseError::fail(format!("step failed: {e}")))?.events;
        if events.is_empty() {
            continue;
        }
        let m = &w.model;
        if let Err(e) = check_invariants(m) {
            return Err(TestCaseError::fail(format!("t = {:.4} s after {events:?}: {e}", w.state.time)));
        }
        prop_assert_eq!(exact_mass(m), mass0, "mass changed at t = {}", w.state.time);
        prop_assert_eq!(w.state.particle_q.len(), m.particle_count());
        for (t, tri) in m.tri_indices.iter().enumerate() {
            let [a, b, c] = tri.map(|v| w.state.particle_q[v as usize]);
            prop_assert!((b - a).cross(c - a).length() > 0.0, "triangle {} has zero area", t);
        }
        for e in &events {
            prop_assert!(e.new_particles.iter().all(|&p| (p as usize) < m.particle_count()));
        }
        prop_assert!(w.state.particle_q.iter().all(|q| q.is_finite()), "a position is not finite");
    }
    Ok(())
}

fn stable_dt(w: &mut World<f64>, fraction: f64) -> f64 {
    let cpu = w.solver.as_any_mut().downcast_mut::<CpuSolver<f64>>().expect("CPU world");
    fraction * cpu.stability_bound(&w.model).max_dt(Integrator::SymplecticEuler)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// A strip of random resolution and tear strength pulled apart at a random speed, with or without a notch:
    /// it tears through (at least two bodies) and every step on the way keeps the invariants.
    #[test]
    fn pulled_strips_tear_through_keeping_every_invariant(
        nx in 9usize..=21,
        tear in 10.0f64..40.0,
        speed in 0.05f64..0.2,
        notch in any::<bool>(),
    ) {
        let (width, height) = (0.2, 0.1);
        let ny = (height / (width / (nx - 1) as f64)).round() as usize + 1;
        let (mut w, _) = common::pulled_sheet(nx, width, height, speed, tear);
        if notch {
            // Cut the vertical edge spring at the middle of the top edge.
            let (i, j) = (nx / 2, nx / 2 + nx);
            let sp = fissure::fracture::spring_between(&w.model, i as u32, j as u32).unwrap() as usize;
            prop_assert!(!w.break_spring(sp).unwrap().is_empty());
        }
        let dt = stable_dt(&mut w, 0.8);
        // Stretched to 10x the tear strain by 0.5 s at the slowest pull: time enough to tear through.
        run_checked(&mut w, 0.5, dt, |w| w.model.body_count() >= 2)?;
        prop_assert!(w.model.body_count() >= 2, "the strip did not tear through by {:.3} s", w.state.time);
        prop_assert!(w.events.iter().filter(|e| e.kind == FractureKind::Spring).count() >= ny / 2);
    }

    /// A pressurised ball punctured at a random vertex, its tear strength a random fraction of the hoop load
    /// `P r / 2` (below 1 the skin may tear before the puncture): cracks may run from the hole while the pressure
    /// holds; the gas leaks; every step keeps the invariants.
    #[test]
    fn punctured_balls_leak_and_crack_keeping_every_invariant(
        pressure in 2000.0f64..4000.0,
        fraction in 0.6f64..1.1,
        puncture in 12usize..162, // where the search below starts (it passes over a vertex that cannot break out)
    ) {
        let r = 0.25;
        let mut w = common::breakable_ball(2, pressure, fraction * pressure * r / 2.0);
        let dt = stable_dt(&mut w, 0.5);
        run_checked(&mut w, 0.05, dt, |_| false)?;
        let v0 = w.model.body_volumes(&w.state)[0];
        // The puncture: the first vertex from `puncture` on that can break out (one next to a crack the
        // pressure opened on its own cannot).
        let n = w.model.particle_count();
        let hole = (puncture..puncture + n).map(|v| v % n).find_map(|v| {
            let e = w.break_core(v).unwrap();
            (!e.is_empty()).then_some(e)
        });
        prop_assert!(hole.is_some(), "no vertex could be punctured");
        check_invariants(&w.model).unwrap();
        run_checked(&mut w, 0.4, dt, |_| false)?;
        let v1 = w.model.body_volumes(&w.state)[0];
        let springs = w.events.iter().filter(|e| e.kind == FractureKind::Spring).count();
        eprintln!("P {pressure:.0} Pa, T {fraction:.2} P r / 2: {springs} spring splits, {} events", w.events.len());
        prop_assert!(v1 < 0.9 * v0, "the punctured ball kept {:.0} % of its volume", 100.0 * v1 / v0);
    }
}
