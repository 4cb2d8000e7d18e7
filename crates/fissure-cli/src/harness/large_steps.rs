//! Large steps that are stable and right: implicit Euler at dt = 1/60 s on a 32² cloth held between two bars,
//! k from 1e3 to 1e5 N/m, 2 s. Checks: no blow-up, springs stretch < 10% at every step, and the sag (drop of the
//! centre particle) at 2 s within 10% of the converged small-step answer (f64 RK4 at half its stability bound,
//! shown converged by halving the step). The explicit integrators at the same step are run too, to show why a
//! large step needs the implicit one.

use super::scenes::{max_strain, sheet_between_bars};
use super::{Report, sig3};
use fissure::*;
use std::fmt::Write as _;

struct Outcome {
    sag: f64,
    strain: f64,
    error: Option<String>,
    cg_max: usize,
}

fn simulate(model: &Model<f64>, integrator: Integrator, dt: f64, t_end: f64, centre: usize) -> Outcome {
    let mut solver = CpuSolver::<f64>::with_integrator(integrator);
    let mut s = model.state();
    let y0 = s.particle_q[centre].y;
    let steps = (t_end / dt).round() as usize;
    let (mut strain, mut cg_max) = (0.0f64, 0);
    for _ in 0..steps {
        if let Err(e) = solver.step(model, &mut s, dt) {
            return Outcome { sag: f64::NAN, strain, error: Some(e.to_string()), cg_max };
        }
        strain = strain.max(max_strain(model, &s));
        cg_max = cg_max.max(solver.cg.iterations);
    }
    Outcome { sag: y0 - s.particle_q[centre].y, strain, error: None, cg_max }
}

/// A run that failed or left the scene (a sag beyond 100 m on a 3 m sheet).
fn blew_up(o: &Outcome) -> bool {
    o.error.is_some() || !o.sag.is_finite() || o.sag.abs() >= 100.0
}

/// Runs the section.
pub fn run(r: &mut Report) -> Result<(), String> {
    let n = 32;
    let t_end = 2.0;
    let ks: Vec<f64> = if r.quick { vec![1e3, 1e5] } else { vec![1e3, 1e4, 1e5] };
    let centre = (n / 2) * n + n / 2;
    let dt = 1.0 / 60.0;
    let _ = writeln!(
        r.md,
        "\n### Large steps: implicit Euler at dt = 1/60 s\n\n32² cloth at 0.1 m, 0.02 kg per particle (0.2 kg/m²), \
         structural, shear and bending springs of stiffness k, damping 10 N·s/m in the seed's form (eq. 2, which \
         damps all relative motion, so the sheet settles), held along two opposite edges, released flat under gravity; {t_end} s. Sag: drop of the centre particle at the end. Reference: f64 RK4 at \
         half its stability bound, converged by halving. Max strain: the largest spring stretch over every step.\n\n\
         | k [N/m] | reference sag [m] | implicit sag [m] | sag error | implicit max strain | reference max strain | CG iterations (max) | symplectic Euler at 1/60 | velocity Verlet at 1/60 |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    let mut rows = Vec::new();
    for &k in &ks {
        let model: Model<f64> = sheet_between_bars(n, k).finalize().map_err(|e| e.to_string())?;
        let bound = StabilityBound::of(&model).max_dt(Integrator::Rk4);
        let steps = (t_end / (0.5 * bound)).ceil();
        let reference = simulate(&model, Integrator::Rk4, t_end / steps, t_end, centre);
        let finer = simulate(&model, Integrator::Rk4, t_end / (2.0 * steps), t_end, centre);
        if let Some(e) = reference.error.as_ref().or(finer.error.as_ref()) {
            return Err(format!("reference at k = {k}: {e}"));
        }
        let ref_change = (reference.sag - finer.sag).abs() / finer.sag.abs();
        let imp = simulate(&model, Integrator::ImplicitEuler, dt, t_end, centre);
        let se = simulate(&model, Integrator::SymplecticEuler, dt, t_end, centre);
        let vv = simulate(&model, Integrator::VelocityVerlet, dt, t_end, centre);
        let sag_err = (imp.sag - finer.sag).abs() / finer.sag.abs();
        let explicit = |o: &Outcome| if blew_up(o) { "blows up".to_string() } else { format!("sag {} m", sig3(o.sag)) };
        let _ = writeln!(
            r.md,
            "| {} | {} | {} | {:.2}% | {:.2}% | {:.2}% | {} | {} | {} |",
            sig3(k),
            sig3(finer.sag),
            sig3(imp.sag),
            100.0 * sag_err,
            100.0 * imp.strain,
            100.0 * finer.strain,
            imp.cg_max,
            explicit(&se),
            explicit(&vv)
        );
        r.check(
            format!("k={}: reference sag converged", sig3(k)),
            ref_change < 1e-3,
            format!("RK4 {} steps vs {}: sag changed {:.1e} relative", steps, 2.0 * steps, ref_change),
        );
        r.check(
            format!("k={}: implicit Euler at 1/60 s stays finite", sig3(k)),
            imp.error.is_none(),
            imp.error.clone().unwrap_or_else(|| "no blow-up".into()),
        );
        r.check(
            format!("k={}: implicit Euler springs stretch < 10%", sig3(k)),
            imp.strain < 0.1,
            format!("max strain {:.2}% (reference {:.2}%)", 100.0 * imp.strain, 100.0 * finer.strain),
        );
        r.check(
            format!("k={}: implicit Euler sag within 10% of converged", sig3(k)),
            sag_err < 0.1,
            format!("{} m vs {} m ({:.1}%)", sig3(imp.sag), sig3(finer.sag), 100.0 * sag_err),
        );
        rows.push(format!(
            "{k:e},{:e},{:e},{:e},{:e},{:e},{},{},{}",
            finer.sag,
            imp.sag,
            sag_err,
            imp.strain,
            finer.strain,
            imp.cg_max,
            !blew_up(&se),
            !blew_up(&vv)
        ));
    }
    r.csv(
        "large_steps.csv",
        "k_n_per_m,reference_sag_m,implicit_sag_m,sag_rel_error,implicit_max_strain,reference_max_strain,cg_iterations_max,symplectic_euler_stable,velocity_verlet_stable",
        &rows,
    )
    .map_err(|e| e.to_string())?;
    Ok(())
}
