//! Closed-form and conservation checks of the CPU engine, each with its tolerance and the reason for it.

use crate::common;

use common::Rng;
use fissure_core::glam::DVec3;
use fissure_core::*;

/// A mass `m` on a spring `k` to a pinned anchor, displaced by `amp` along x; no gravity, no damping.
fn oscillator(m: f64, k: f64, amp: f64) -> (Model<f64>, State<f64>, f64) {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let l0 = 1.0;
    let anchor = b.add_particle(DVec3::ZERO, DVec3::ZERO, 0.0).unwrap();
    let mass = b.add_particle(DVec3::new(l0, 0.0, 0.0), DVec3::ZERO, m).unwrap();
    b.add_spring(anchor, mass, k, 0.0).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    s.particle_q[mass].x += amp;
    (model, s, l0)
}

fn solver(integrator: Integrator) -> CpuSolver<f64> {
    CpuSolver::new(SolverConfig {
        integrator,
        cg_tolerance: 1e-14,
        cg_max_iterations: 50,
        check_finite: true,
        substep_safety: None,
        cg_coarse: true,
    })
}

#[test]
fn oscillator_period_is_two_pi_sqrt_m_over_k() {
    let (m, k, amp) = (0.3, 50.0, 0.05);
    let (model, mut s, l0) = oscillator(m, k, amp);
    let period = 2.0 * std::f64::consts::PI * (m / k).sqrt();
    let dt = period / 2000.0;
    let mut solver = solver(Integrator::Rk4);
    let mut crossings = Vec::new();
    let mut prev = s.particle_q[1].x - l0;
    while s.time < 5.2 * period {
        solver.step(&model, &mut s, dt).unwrap();
        let cur = s.particle_q[1].x - l0;
        if prev > 0.0 && cur <= 0.0 {
            // Linear interpolation of the downward zero crossing.
            crossings.push(s.time - dt * cur / (cur - prev));
        }
        prev = cur;
    }
    assert!(crossings.len() >= 5, "{crossings:?}");
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    // RK4 at 2000 steps per period: phase error ~1e-13; interpolation error ~ (ω dt)² amp: 1e-6 relative.
    let rel = (measured - period).abs() / period;
    assert!(rel < 1e-6, "period {measured} vs 2π√(m/k) = {period}: relative error {rel:e}");
}

/// Phase-space error `|x - x*| + |v - v*|/ω` after 0.3 periods.
fn oscillator_error(integrator: Integrator, steps: usize) -> f64 {
    let (m, k, amp) = (0.3, 50.0, 0.05);
    let (model, mut s, l0) = oscillator(m, k, amp);
    let w = (k / m).sqrt();
    // 0.3 of a period: at whole periods symplectic Euler's first-order phase errors cancel (it is conjugate
    // to a second-order method for the harmonic oscillator), which would hide its true order.
    let t_end = 0.3 * 2.0 * std::f64::consts::PI / w;
    let dt = t_end / steps as f64;
    let mut solver = solver(integrator);
    for _ in 0..steps {
        solver.step(&model, &mut s, dt).unwrap();
    }
    let (x, v) = (s.particle_q[1].x - l0, s.particle_qd[1].x);
    let (xe, ve) = (amp * (w * s.time).cos(), -amp * w * (w * s.time).sin());
    (x - xe).abs() + (v - ve).abs() / w
}

#[test]
fn each_integrator_converges_at_its_order() {
    for integrator in Integrator::ALL {
        let base = if integrator == Integrator::Rk4 { 16 } else { 200 };
        let errs: Vec<f64> = (0..4).map(|i| oscillator_error(integrator, base << i)).collect();
        let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        let mean = orders.iter().sum::<f64>() / orders.len() as f64;
        // Tolerance 0.2 on the order, as the accuracy harness uses.
        assert!(
            (mean - integrator.order() as f64).abs() < 0.2,
            "{}: errors {errs:?}, observed orders {orders:?}, expected {}",
            integrator.name(),
            integrator.order()
        );
    }
}

#[test]
fn free_fall_matches_closed_form() {
    let g = DVec3::new(0.0, -9.81, 0.0);
    let (x0, v0) = (DVec3::new(0.0, 10.0, 0.0), DVec3::new(1.0, 2.0, -0.5));
    for integrator in Integrator::ALL {
        let mut b = ModelBuilder::new();
        b.gravity(g).unwrap();
        b.add_particle(x0, v0, 0.2).unwrap();
        let model: Model<f64> = b.finalize().unwrap();
        let mut s = model.state();
        let dt = 1e-3;
        let mut solver = solver(integrator);
        for _ in 0..1000 {
            solver.step(&model, &mut s, dt).unwrap();
        }
        let t = s.time;
        let exact = x0 + v0 * t + g * (0.5 * t * t);
        // Verlet and RK4 are exact for a constant force; the two Euler variants (v updated first) carry the
        // known first-order bias g·dt·t/2.
        let expected = match integrator {
            Integrator::VelocityVerlet | Integrator::Rk4 => exact,
            Integrator::SymplecticEuler | Integrator::ImplicitEuler => exact + g * (0.5 * dt * t),
        };
        let err = (s.particle_q[0] - expected).length();
        assert!(err < 1e-10, "{}: x = {:?}, expected {:?}", integrator.name(), s.particle_q[0], expected);
        assert!((s.particle_qd[0] - (v0 + g * t)).length() < 1e-10, "{}", integrator.name());
    }
}

/// A perturbed, moving, pressurised icosphere in f64 without gravity.
fn free_ball(subdiv: u32, seed: u64) -> (Model<f64>, State<f64>) {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.5),
        stiffness: Stiffness::Membrane(500.0),
        damping: Damping::Ratio(0.1),
        bending: Some(Stiffness::PerSpring(20.0)),
        gas: Gas::Pressure(3000.0),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.2, subdiv).translated(DVec3::new(0.3, 1.0, -0.2)), &opts).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    let mut rng = Rng(seed);
    for (q, v) in s.particle_q.iter_mut().zip(&mut s.particle_qd) {
        *q += rng.vec() * 0.01;
        *v = rng.vec() * 0.5;
    }
    (model, s)
}

#[test]
fn internal_forces_sum_to_zero_and_momentum_is_conserved() {
    let (model, s) = free_ball(2, 7);
    let mut f = vec![DVec3::ZERO; model.particle_count()];
    solver(Integrator::SymplecticEuler).compute_forces(&model, &s, &mut f).unwrap();
    let net: DVec3 = f.iter().copied().sum();
    let scale: f64 = f.iter().map(|v| v.length()).sum();
    // Pairwise-opposite spring forces and a closed surface's pressure cancel to rounding: 1e-13 of Σ|f|.
    assert!(net.length() < 1e-13 * scale, "net internal force {net:?} (Σ|f| = {scale})");
    let p0 = model.momentum(&s);
    for integrator in Integrator::ALL {
        let mut s2 = s.clone();
        let mut sv = solver(integrator);
        for _ in 0..500 {
            sv.step(&model, &mut s2, 1e-4).unwrap();
        }
        let dp = (model.momentum(&s2) - p0).length();
        let pscale: f64 =
            (0..model.particle_count()).map(|i| model.particle_mass[i] * s2.particle_qd[i].length()).sum();
        assert!(dp < 1e-12 * pscale.max(1.0), "{}: momentum drift {dp:e}", integrator.name());
    }
}

#[test]
fn net_pressure_force_on_a_closed_surface_is_zero() {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions {
        stiffness: Stiffness::PerSpring(0.0),
        damping: Damping::PerSpring(0.0),
        gas: Gas::Pressure(1e5),
        ..Default::default()
    };
    // A lumpy closed surface far from the origin: the sum must vanish there too.
    let mesh = Mesh::icosphere(0.5, 3).map_positions(|p| p * (1.0 + 0.2 * bumps(p)) + DVec3::splat(100.0)).unwrap();
    b.add_soft_body(&mesh, &opts).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let s = model.state();
    let mut f = vec![DVec3::ZERO; model.particle_count()];
    CpuSolver::<f64>::default().compute_forces(&model, &s, &mut f).unwrap();
    let net: DVec3 = f.iter().copied().sum();
    let scale: f64 = f.iter().map(|v| v.length()).sum();
    assert!(scale > 1.0, "pressure forces present");
    assert!(net.length() < 1e-12 * scale, "net pressure force {net:?} vs Σ|f| {scale}");
}

/// A smooth deterministic bump field, for lumpy test surfaces.
fn bumps(p: DVec3) -> f64 {
    (p.x * 12.9898 + p.y * 78.233 + p.z * 37.719).sin()
}

#[test]
fn spring_and_pressure_forces_are_minus_energy_gradients() {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions {
        stiffness: Stiffness::Membrane(300.0),
        damping: Damping::PerSpring(0.0),
        bending: Some(Stiffness::PerSpring(5.0)),
        gas: Gas::Pressure(2500.0),
        external_pressure: 800.0,
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.3, 1), &opts).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    let mut rng = Rng(11);
    for q in &mut s.particle_q {
        *q += rng.vec() * 0.03;
    }
    let mut f = vec![DVec3::ZERO; model.particle_count()];
    CpuSolver::<f64>::default().compute_forces(&model, &s, &mut f).unwrap();
    let energy = |s: &State<f64>| {
        let e = model.energy(s);
        e.spring + e.gas
    };
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for (i, fi) in f.iter().enumerate() {
        for axis in 0..3 {
            let mut sp = s.clone();
            let mut sm = s.clone();
            sp.particle_q[i][axis] += h;
            sm.particle_q[i][axis] -= h;
            let grad = (energy(&sp) - energy(&sm)) / (2.0 * h);
            let err = (fi[axis] + grad).abs() / (1.0 + fi.length());
            worst = worst.max(err);
        }
    }
    // Central differences in f64 with h = 1e-6: truncation ~h², round-off ~1e-16 E / h ~ 1e-9.
    assert!(worst < 1e-6, "force differs from -∇E by {worst:e} (relative)");
}

#[test]
fn slowly_compressed_ball_follows_boyle() {
    // A nearly slack membrane (tension < 0.3% of the pressure) inflated beyond its rest size, then compressed
    // quasi-statically by raising the outside pressure in stages. At each equilibrium the gas pressure nRT/V
    // must balance the outside pressure, i.e. P_ext · V = nRT.
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let r0 = 0.1;
    let v0 = Mesh::icosphere(r0, 2).signed_volume();
    let nrt = 1000.0 * 3.0 * v0;
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.05),
        stiffness: Stiffness::PerSpring(0.2),
        damping: Damping::PerSpring(0.5),
        gas: Gas::Amount(nrt),
        external_pressure: 1000.0,
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(r0, 2), &opts).unwrap();
    let mut model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    let mut solver = solver(Integrator::SymplecticEuler);
    for p_ext in [1000.0, 1250.0, 1500.0, 1750.0, 2000.0] {
        // Ramp to the new outside pressure over 0.2 s, then settle for 1.3 s.
        let p_start = model.body_pressure_external[0];
        for k in 0..15000 {
            let a = (k as f64 / 2000.0).min(1.0);
            model.body_pressure_external[0] = p_start + a * (p_ext - p_start);
            solver.step(&model, &mut s, 1e-4).unwrap();
        }
        let v = model.body_volumes(&s)[0];
        let ratio = p_ext * v / nrt;
        assert!((ratio - 1.0).abs() < 0.01, "P_ext = {p_ext} Pa: P·V/nRT = {ratio}");
        let ke = model.energy(&s).kinetic;
        assert!(ke < 1e-6, "not settled: kinetic energy {ke}");
    }
}

#[test]
fn undamped_symplectic_integrators_keep_energy_bounded_for_1e5_steps() {
    for integrator in [Integrator::SymplecticEuler, Integrator::VelocityVerlet] {
        let mut b = ModelBuilder::new();
        b.gravity(DVec3::ZERO).unwrap();
        let opts = SoftBodyOptions {
            mass: Mass::Total(0.2),
            stiffness: Stiffness::Membrane(200.0),
            damping: Damping::PerSpring(0.0),
            gas: Gas::Pressure(1500.0),
            ..Default::default()
        };
        b.add_soft_body(&Mesh::icosphere(0.2, 1), &opts).unwrap();
        let model: Model<f64> = b.finalize().unwrap();
        let mut s = model.state();
        let mut rng = Rng(5);
        for v in &mut s.particle_qd {
            *v = rng.vec() * 0.3;
        }
        let e0 = model.energy(&s).total();
        let mut solver = solver(integrator);
        let (mut lo, mut hi) = (e0, e0);
        let mut late_max: f64 = 0.0;
        let mut early_max: f64 = 0.0;
        let mut ke_max: f64 = 0.0;
        let n = 100_000;
        for k in 0..n {
            solver.step(&model, &mut s, 2e-4).unwrap();
            if k % 50 == 0 {
                let en = model.energy(&s);
                let e = en.total();
                ke_max = ke_max.max(en.kinetic);
                lo = lo.min(e);
                hi = hi.max(e);
                let dev = (e - e0).abs();
                if k < n / 10 {
                    early_max = early_max.max(dev);
                }
                if k > n - n / 10 {
                    late_max = late_max.max(dev);
                }
            }
        }
        // Symplectic: the energy oscillates in a band of O(dt) (Euler) or O(dt²) (Verlet) and does not drift.
        // The band is O(ω dt) of the exchanged energy for Euler (ω dt ≈ 0.2 here), O((ω dt)²) for Verlet.
        let band = if integrator == Integrator::SymplecticEuler { 0.08 } else { 0.01 };
        assert!(
            (hi - lo) < band * ke_max,
            "{}: energy band [{lo}, {hi}] vs peak kinetic energy {ke_max}",
            integrator.name()
        );
        assert!(late_max < 1.5 * early_max, "{}: energy drifts ({early_max:e} -> {late_max:e})", integrator.name());
    }
}

/// Implicit Euler's conjugate gradients start from the last step's `Δv` when a step continues the solver's last
/// one. The start changes the path, not the answer: each warm step lands within the CG tolerance of a cold solve
/// of the same step (f64, tolerance 1e-9 relative to `|b|`; the positions then agree to ~1e-9 of a step's motion,
/// bounded here by 1e-9 m), in fewer iterations over the run. A state the solver did not just step (another
/// time) starts cold: the same bits as a fresh solver.
#[test]
fn implicit_warm_start_changes_iterations_not_the_solution() {
    let n = 16;
    let model = hanging_cloth(n);
    let config = SolverConfig {
        integrator: Integrator::ImplicitEuler,
        cg_tolerance: 1e-9,
        cg_max_iterations: 2000,
        check_finite: true,
        substep_safety: None,
        // Block-Jacobi alone: the coarse level already removes the smooth part of the error that a warm start
        // would (with it, this run took 2,671 iterations warm and 2,667 cold).
        cg_coarse: false,
    };
    let h = 1.0 / 60.0;
    let mut warm = CpuSolver::<f64>::new(config.clone());
    let mut s = model.state();
    let (mut warm_its, mut cold_its) = (0, 0);
    for step in 0..40 {
        let mut c = s.clone();
        let mut cold = CpuSolver::<f64>::new(config.clone());
        cold.step(&model, &mut c, h).unwrap();
        warm.step(&model, &mut s, h).unwrap();
        cold_its += cold.cg.iterations;
        warm_its += warm.cg.iterations;
        let worst = s.particle_q.iter().zip(&c.particle_q).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "step {step}: warm and cold solves differ by {worst:e} m");
        // Continue from the cold result: both solvers see the same state at every step.
        s = c;
    }
    assert!(warm_its < cold_its, "warm start took {warm_its} CG iterations over the run, cold {cold_its}");
    // Another time: a cold start, bit for bit.
    let mut other = s.clone();
    other.time += 1.0;
    let mut fresh_state = other.clone();
    warm.step(&model, &mut other, h).unwrap();
    CpuSolver::<f64>::new(config).step(&model, &mut fresh_state, h).unwrap();
    assert_eq!(other.particle_q, fresh_state.particle_q);
}

/// Implicit Euler solves a grid's system in struct-of-arrays form over its spring runs (`cg_runs.rs`), any other
/// mesh per spring: the same cloth built with its springs in reverse order (no runs) follows the same motion to
/// the CG tolerance (f64, 1e-12): 1e-9 m after 30 steps of 1/60 s.
#[test]
fn implicit_solves_on_runs_and_per_spring_agree() {
    let n = 32;
    let grid = hanging_cloth(n);
    assert!(grid.springs_are_runs());
    let mesh = reversed_springs(&grid);
    assert!(!mesh.springs_are_runs());
    let config = SolverConfig {
        integrator: Integrator::ImplicitEuler,
        cg_tolerance: 1e-12,
        cg_max_iterations: 5000,
        check_finite: true,
        substep_safety: None,
        cg_coarse: true,
    };
    let (mut a, mut c) = (grid.state(), mesh.state());
    let (mut sa, mut sc) = (CpuSolver::<f64>::new(config.clone()), CpuSolver::<f64>::new(config));
    for _ in 0..30 {
        sa.step(&grid, &mut a, 1.0 / 60.0).unwrap();
        sc.step(&mesh, &mut c, 1.0 / 60.0).unwrap();
    }
    let worst = a.particle_q.iter().zip(&c.particle_q).map(|(x, y)| (*x - *y).length()).fold(0.0, f64::max);
    let sag = grid.particle_q0[n * n / 2].y - a.particle_q[n * n / 2].y;
    assert!(sag > 0.01, "the cloth falls and sags: {sag} m");
    assert!(worst < 1e-9, "the two solves differ by {worst:e} m");
}

/// The benchmark cloth's `n × n` grid at 1 cm, held at two corners, in `f64` (the implicit solver's tests).
fn hanging_cloth(n: usize) -> Model<f64> {
    let opts = common::bench_cloth_options(vec![0, n - 1], None);
    let mut b = ModelBuilder::new();
    b.add_cloth_grid(n, n, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
    b.finalize().unwrap()
}

/// `grid`'s particles with its springs added in reverse order: no runs, so implicit Euler takes the per-spring path.
fn reversed_springs(grid: &Model<f64>) -> Model<f64> {
    let mut b = ModelBuilder::new();
    for i in 0..grid.particle_count() {
        let pinned = grid.particle_inv_mass[i] == 0.0;
        b.add_particle(grid.particle_q0[i], DVec3::ZERO, if pinned { 0.0 } else { grid.particle_mass[i] }).unwrap();
    }
    for s in (0..grid.spring_count()).rev() {
        let [i, j] = grid.spring_indices[s];
        b.add_spring(i as usize, j as usize, grid.spring_stiffness[s], grid.spring_damping[s]).unwrap();
    }
    b.finalize().unwrap()
}

/// Implicit Euler's coarse level (`SolverConfig::cg_coarse`, `solver/coarse.rs`) is a preconditioner: it changes
/// how many CG iterations a step takes, not where the step lands. The 32² cloth at 1/60 s, on the runs and on the
/// per-spring path: the same positions as block-Jacobi alone to 1e-8 m over 20 steps (CG tolerance 1e-10), in at
/// most 0.8× the iterations (measured 0.68 on the runs, 0.73 per spring, whose aggregates differ: their search
/// follows the springs' order; at the default tolerance 1e-5, 0.53).
#[test]
fn implicit_coarse_level_changes_iterations_not_the_solution() {
    let n = 32;
    let grid = hanging_cloth(n);
    let mesh = reversed_springs(&grid);
    for model in [&grid, &mesh] {
        let config = |cg_coarse| SolverConfig {
            cg_tolerance: 1e-10,
            cg_max_iterations: 5000,
            cg_coarse,
            ..SolverConfig::with(Integrator::ImplicitEuler)
        };
        let (mut a, mut c) = (model.state(), model.state());
        let (mut sa, mut sc) = (CpuSolver::<f64>::new(config(true)), CpuSolver::<f64>::new(config(false)));
        let (mut its_a, mut its_c) = (0, 0);
        for _ in 0..20 {
            sa.step(model, &mut a, 1.0 / 60.0).unwrap();
            sc.step(model, &mut c, 1.0 / 60.0).unwrap();
            its_a += sa.cg.iterations;
            its_c += sc.cg.iterations;
        }
        let runs = model.springs_are_runs();
        let worst = a.particle_q.iter().zip(&c.particle_q).map(|(x, y)| (*x - *y).length()).fold(0.0, f64::max);
        assert!(worst < 1e-8, "runs {runs}: with and without the coarse level the cloth differs by {worst:e} m");
        assert!(
            (its_a as f64) < 0.8 * its_c as f64,
            "runs {runs}: {its_a} CG iterations with the coarse level, {its_c} without"
        );
    }
}
