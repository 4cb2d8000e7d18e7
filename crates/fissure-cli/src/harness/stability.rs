//! Stability: the largest stable step of each integrator, by bisection, against spring stiffness, next to the
//! bounds of [`fissure::stability`].
//!
//! A run lasts a fixed simulated time (N times the symplectic Euler bound) and is stable when every step succeeds
//! (no NaN) and the fastest particle stays below 2× the fastest of a reference run at 1/16 of the bound, plus
//! what gravity adds over any time the run lasts beyond the reference and 0.1 m/s; the state starts with a small
//! random velocity (1 cm/s, seeded) so every mode is excited.
//!
//! The criterion was 10× the reference's speed plus `g T` and 1 m/s until 2026-11-27. That counted as stable a run
//! whose fast modes had grown to ~8× the scene's own speeds and saturated there: on the soft hanging cloth
//! (k = 100 N/m, up to ~300 % strain) symplectic Euler resonates from ~0.84× its linear limit (the fastest particle
//! at 130–175 m/s against the reference's 16), and the old criterion read its limit at the blow-up instead
//! (0.98× the bound); RK4 runs whose fast modes had grown 3× passed too (the ball's RK4 cells read 1.07–1.13×
//! instead of 1.03–1.05×). `benches/RESULTS.md` (issue 15, (36)) has the measurements.
//!
//! Each cell is checked against a band that catches a wrong bound (0.9–1.15× the measured limit) and against
//! issue 15's target (1.0–1.1×). Cells whose reference run stretches some spring past [`NONLINEAR_STRAIN`] are
//! checked against a wider band (0.75–1.2×): there the limits are set by the motion, not the linearisation
//! (symplectic Euler's nonlinear resonances below its linear limit, RK4's damping of fast modes that are unstable
//! for a few steps at a time), which no bound from the frozen Jacobian can follow.

use super::{Report, sig3};
use crate::plot::{PALETTE, Plot, Series};
use fissure::glam::DVec3;
use fissure::*;
use std::fmt::Write as _;

/// The stability scenes: a Warp-layout cloth (0.1 m, 0.1 kg per particle, held along one edge, light damping
/// 0.01 N·s/m so the undamped bounds apply) and the pressurised ball (642 vertices, 0.4 kg, 2000 Pa, damping
/// ratio 0.05, 2k Pa), with every spring at `k`.
fn scene(name: &str, k: f64, quick: bool) -> ModelBuilder {
    let mut b = ModelBuilder::new();
    match name {
        "cloth" => {
            let n = if quick { 16 } else { 32 };
            let opts = ClothOptions {
                mass: Mass::PerParticle(0.1),
                stiffness: Stiffness::PerSpring(k),
                shear: Some(Stiffness::PerSpring(k)),
                bending: Some(Stiffness::PerSpring(k)),
                damping: Damping::PerSpring(0.01),
                pins: (0..n).map(|j| j * n).collect(),
                aero: Aero::NONE,
                fracture: None,
            };
            b.add_cloth_grid(n, n, 0.1, |p| DVec3::new(p.x, 4.0, p.y), &opts).expect("valid cloth");
        }
        _ => {
            let opts = SoftBodyOptions {
                mass: Mass::Total(0.4),
                stiffness: Stiffness::PerSpring(k),
                damping: Damping::Ratio(0.05),
                // Pressure in proportion to the springs (2000 Pa at 1000 N/m), so that every k holds its gas.
                gas: Gas::Pressure(2.0 * k),
                ..Default::default()
            };
            b.add_soft_body(&Mesh::icosphere(0.25, if quick { 2 } else { 3 }), &opts).expect("valid ball");
        }
    }
    b
}

/// splitmix64, for the seeded velocity noise.
fn noise(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *seed;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// The largest particle speed over a run of `dt` steps lasting at least `t_end` and 50 steps, or `None` if a
/// step failed (NaN).
fn max_speed(model: &Model<f64>, integrator: Integrator, dt: f64, t_end: f64) -> Option<f64> {
    run_probe(model, integrator, dt, t_end, &mut |_| {})
}

/// [`max_speed`], calling `seen` with the positions after every step.
fn run_probe(
    model: &Model<f64>,
    integrator: Integrator,
    dt: f64,
    t_end: f64,
    seen: &mut dyn FnMut(&[DVec3]),
) -> Option<f64> {
    let mut s = model.state();
    let mut seed = 7u64;
    for v in &mut s.particle_qd {
        *v += DVec3::new(noise(&mut seed), noise(&mut seed), noise(&mut seed)) * 0.01;
    }
    let mut solver = CpuSolver::<f64>::with_integrator(integrator);
    let steps = ((t_end / dt).ceil() as usize).max(50);
    let mut vmax = 0.0f64;
    for _ in 0..steps {
        solver.step(model, &mut s, dt).ok()?;
        vmax = s.particle_qd.iter().map(|v| v.length()).fold(vmax, f64::max);
        seen(&s.particle_q);
    }
    Some(vmax)
}

/// The largest spring strain above which a scene's cells are checked against the wider band (see the module docs):
/// a spring stretched to 1.5× its rest length.
const NONLINEAR_STRAIN: f64 = 0.5;

/// Stability test at one scene and stiffness: a run is stable when no step fails and its fastest particle stays
/// below 2× the fastest of a reference run (symplectic Euler at 1/16 of its bound, same duration) plus what
/// gravity adds over the time the run lasts beyond the reference and 0.1 m/s. Judging speed against the scene's
/// own motion keeps physical motion (a ball inflating, a cloth falling) from reading as instability.
struct Probe<'a> {
    model: &'a Model<f64>,
    t_end: f64,
    v_ref: f64,
}

impl Probe<'_> {
    fn stable(&self, integrator: Integrator, dt: f64) -> bool {
        let t_run = (self.t_end / dt).ceil().max(50.0) * dt;
        max_speed(self.model, integrator, dt, self.t_end)
            .is_some_and(|v| v <= 2.0 * self.v_ref + 9.81 * (t_run - self.t_end).max(0.0) + 0.1)
    }
}

/// Largest stable dt by bisection in log space, between `bound / 16` and `cap`; `None` if even the lower end
/// fails. The second value says the search hit `cap` (stable there).
fn largest_stable(p: &Probe, integrator: Integrator, bound: f64, cap: f64) -> (Option<f64>, bool) {
    let mut lo = if bound.is_finite() { bound / 16.0 } else { 1e-4 };
    if !p.stable(integrator, lo) {
        return (None, false);
    }
    let mut hi = if bound.is_finite() { (bound * 16.0).min(cap) } else { cap };
    if p.stable(integrator, hi) {
        return (Some(hi), true);
    }
    for _ in 0..14 {
        let mid = (lo * hi).sqrt();
        if p.stable(integrator, mid) {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi / lo < 1.01 {
            break;
        }
    }
    (Some(lo), false)
}

/// Runs the section.
pub fn run(r: &mut Report) -> Result<(), String> {
    let quick = r.quick;
    let ks: Vec<f64> = if quick { vec![1e2, 1e4, 1e6] } else { vec![1e2, 1e3, 1e4, 1e5, 1e6] };
    let steps = if quick { 200 } else { 400 };
    let cap = 0.05;
    let _ = writeln!(
        r.md,
        "\n### Stability\n\nLargest stable step (bisection to 1%, f64) against spring stiffness. Each run lasts {steps}× \
         the symplectic Euler bound (at least 50 steps), from a state with 1 cm/s of seeded velocity noise; stable = \
         no NaN and speeds below 2× those of a run at 1/16 of the bound (plus what gravity adds in any time beyond that \
         run's, and 0.1 m/s); largest strain: the most any spring stretches in that run. Bounds: the 1-DOF `2/ω` with \
         `ω = √(k/m)` of one spring on one particle, the solver's bound (`fissure::stability`: power iteration, \
         damping included, the tightest of the initial shape and 64 shapes along the reference run), and Gershgorin's; velocity Verlet has the same as symplectic Euler undamped, RK4 2√2/ω). The implicit \
         integrator is searched up to {cap} s. Cloth: {} Warp-layout cloth, held along one edge, damping 0.01 N·s/m. \
         Ball: pressurised icosphere ({} vertices, gas at 2k Pa so that each stiffness holds it, damping ratio 0.05). CSV: `stability.csv`.\n",
        if quick { "16²" } else { "32²" },
        if quick { 162 } else { 642 },
    );
    let mut rows = Vec::new();
    let mut ratios = Vec::new();
    for name in ["cloth", "ball"] {
        let _ = writeln!(
            r.md,
            "| {name}: k [N/m] | largest strain | bound SE / RK4 [s] | Gershgorin SE [s] | 2/ω 1-DOF [s] | symplectic_euler | velocity_verlet | rk4 | implicit_euler |\n|---|---|---|---|---|---|---|---|---|"
        );
        let mut measured: Vec<Vec<(f64, f64)>> = vec![Vec::new(); 4];
        let (mut b_se, mut b_rk, mut b_g, mut one) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for &k in &ks {
            let model: Model<f64> = scene(name, k, quick).finalize().map_err(|e| e.to_string())?;
            // The bound as the solver's guard takes it: estimated at the initial shape, then re-estimated along
            // the run (a hanging soft cloth stretches and stiffens); the tightest one counts. The run is the
            // reference run at 1/16 of the initial bound, sampled at 64 evenly spaced steps.
            let initial = StabilityBound::of(&model);
            let gersh = StabilityBound::gershgorin(&model);
            let se0 = initial.max_dt(Integrator::SymplecticEuler);
            let t_end = steps as f64 * se0;
            let mut bounds = vec![initial];
            let mut mode = Vec::new();
            let (mut step, every) = (0usize, ((t_end / (se0 / 16.0)).ceil() as usize).max(50) / 64);
            let mut strain = 0.0f64;
            let v_ref = run_probe(&model, Integrator::SymplecticEuler, se0 / 16.0, t_end, &mut |q| {
                step += 1;
                if step % every.max(1) == 0 {
                    bounds.push(StabilityBound::estimate(&model, q, &mut mode));
                }
                for (&[i, j], &l0) in model.spring_indices.iter().zip(&model.spring_rest_length) {
                    strain = strain.max((q[j as usize] - q[i as usize]).length() / l0 - 1.0);
                }
            })
            .ok_or_else(|| format!("{name} k = {k}: the reference run at 1/16 of the bound failed"))?;
            let bound = bounds
                .iter()
                .copied()
                .reduce(|a, b| StabilityBound {
                    omega2: a.omega2.max(b.omega2),
                    damping_rate: a.damping_rate.max(b.damping_rate),
                    stiffest_particle: a.stiffest_particle,
                })
                .unwrap_or(initial);
            let m_min = model
                .particle_mass
                .iter()
                .zip(&model.particle_inv_mass)
                .filter(|(_, w)| **w > 0.0)
                .map(|(m, _)| *m)
                .fold(f64::INFINITY, f64::min);
            let k_min = model.spring_stiffness.iter().copied().fold(f64::INFINITY, f64::min);
            let one_dof = 2.0 / (k_min / m_min).sqrt();
            let se_bound = bound.max_dt(Integrator::SymplecticEuler);
            let probe = Probe { model: &model, t_end, v_ref };
            b_se.push((k, se_bound));
            b_rk.push((k, bound.max_dt(Integrator::Rk4)));
            b_g.push((k, gersh.max_dt(Integrator::SymplecticEuler)));
            one.push((k, one_dof));
            let _ = write!(
                r.md,
                "| {} | {:.0}% | {} / {} | {} | {} |",
                sig3(k),
                strain * 100.0,
                sig3(bound.max_dt(Integrator::SymplecticEuler)),
                sig3(bound.max_dt(Integrator::Rk4)),
                sig3(gersh.max_dt(Integrator::SymplecticEuler)),
                sig3(one_dof)
            );
            for (n, integrator) in Integrator::ALL.iter().enumerate() {
                let b = bound.max_dt(*integrator);
                let (dt, at_cap) = largest_stable(&probe, *integrator, b, cap);
                let ratio = dt.map_or(f64::NAN, |d| d / b);
                if b.is_finite() && !at_cap {
                    ratios.push((ratio, strain > NONLINEAR_STRAIN));
                }
                let cell = match (dt, at_cap) {
                    (None, _) => "unstable at bound/16".to_string(),
                    (Some(d), true) => format!("≥ {} (search cap)", sig3(d)),
                    (Some(d), false) if b.is_finite() => format!("{} ({:.2}× bound)", sig3(d), ratio),
                    (Some(d), false) => sig3(d),
                };
                let _ = write!(r.md, " {cell} |");
                if let Some(d) = dt {
                    measured[n].push((k, d));
                }
                rows.push(format!(
                    "{name},{k:e},{},{:e},{:e},{},{}",
                    integrator.name(),
                    b,
                    dt.unwrap_or(f64::NAN),
                    at_cap,
                    if b.is_finite() { format!("{ratio:e}") } else { String::new() }
                ));
                if *integrator == Integrator::ImplicitEuler {
                    r.check(
                        format!("{name} k={}: implicit Euler stable at the largest step tried", sig3(k)),
                        dt.is_some(),
                        dt.map_or("unstable".into(), |d| format!("stable up to {} s", sig3(d))),
                    );
                } else {
                    let detail =
                        format!("measured {} s, bound {} s ({ratio:.2}×)", sig3(dt.unwrap_or(f64::NAN)), sig3(b));
                    // The check: the bound is the right estimate (a regression in it moves a ratio out of this
                    // band). The target (issue 15): within 10% and never above the measured limit.
                    // Past NONLINEAR_STRAIN the band is wider (the motion sets the limits there), still narrow
                    // enough that a bound off by a quarter fails.
                    let (lo, hi) = if strain <= NONLINEAR_STRAIN { (0.9, 1.15) } else { (0.75, 1.2) };
                    r.check(
                        format!("{name} k={}: {} stable dt at {lo}–{hi}× its bound", sig3(k), integrator.name()),
                        (lo..=hi).contains(&ratio),
                        detail.clone(),
                    );
                    r.target(
                        format!("{name} k={}: {} stable dt at 1.0–1.1× its bound", sig3(k), integrator.name()),
                        (1.0..=1.1).contains(&ratio),
                        detail,
                    );
                }
            }
            let _ = writeln!(r.md);
        }
        let mut plot = Plot::new(format!("largest stable step: {name}"), "spring stiffness k [N/m]", "dt [s]");
        for (n, integrator) in Integrator::ALL.iter().enumerate() {
            plot.series.push(Series::new(format!("{} measured", integrator.name()), measured[n].clone(), PALETTE[n]));
        }
        plot.series.push(Series::dashed("bound SE/VV", b_se, PALETTE[0]));
        plot.series.push(Series::dashed("bound RK4", b_rk, PALETTE[2]));
        plot.series.push(Series::dashed("Gershgorin SE/VV", b_g, [120, 120, 120]));
        plot.series.push(Series::dashed("1-DOF 2/w", one, [0, 0, 0]));
        r.plot(&format!("stability-{name}.png"), &plot).map_err(|e| e.to_string())?;
    }
    let span = |nonlinear: bool| {
        ratios.iter().filter(|r| r.1 == nonlinear).fold((f64::INFINITY, 0.0f64), |(a, b), &(x, _)| (a.min(x), b.max(x)))
    };
    let ((lo, hi), (nlo, nhi)) = (span(false), span(true));
    let _ = writeln!(
        r.md,
        "Reading it: where no spring stretches past {:.0}% the measured limits of the explicit integrators lie at \
         {lo:.2}–{hi:.2}× the solver's bound. The bound is the power-iteration estimate of the fastest mode (plus 3%) \
         at the initial shape and along the run, as `SolverConfig::substep_safety` re-estimates it every 256 steps \
         (a soft hanging cloth stretches and stiffens transversally: at the initial shape alone its bound would be \
         too large); Gershgorin's bound, the solver's before, lies 1.3–1.6× below the measured limits. The 1-DOF line \
         `2/ω` of a single spring lies above all: a particle held by a dozen springs is stiffer than one spring.{}\n",
        NONLINEAR_STRAIN * 100.0,
        if nlo.is_finite() {
            format!(
                " Where springs stretch further (the softest cloth) the limits lie at {nlo:.2}–{nhi:.2}× the bound: \
                 symplectic Euler and velocity Verlet resonate below their linear limits, RK4 damps fast modes that \
                 are unstable for a few steps at a time (the module docs of `harness::stability`); substeps there \
                 want `substep_safety` ≤ 0.8."
            )
        } else {
            String::new()
        }
    );
    r.csv("stability.csv", "scene,k_n_per_m,integrator,bound_s,measured_s,at_search_cap,measured_over_bound", &rows)
        .map_err(|e| e.to_string())?;
    Ok(())
}
