//! Work–precision: RMS position error at a fixed time against wall time, for every integrator, precision and
//! backend, over a sweep of step sizes; the reference is f64 RK4 with the step halved until halving changes the
//! answer by less than 1e-10 relative. Measured orders are least-squares slopes of log error against log dt over
//! the asymptotic points (relative error between 1e-11 and 1e-2: below is round-off, above is not yet
//! asymptotic).

use super::scenes::{self, Scene, positions, rms_diff};
use super::{GpuHandle, Report, sig3, time_best};
use crate::plot::{PALETTE, Plot, Series, pareto_front};
use fissure::glam::DVec3;
use fissure::*;
use std::fmt::Write as _;

/// One measured point.
#[derive(Clone, Debug)]
struct Point {
    backend: &'static str,
    integrator: Integrator,
    steps: usize,
    dt: f64,
    wall: f64,
    /// RMS error \[m\] (NaN: the run blew up).
    err: f64,
    rel: f64,
}

fn config(integrator: Integrator, f64_: bool) -> SolverConfig {
    let mut c = SolverConfig::with(integrator);
    if f64_ {
        // The CG residual would otherwise set an error floor near 1e-5 relative and hide the order.
        c.cg_tolerance = 1e-11;
        c.cg_max_iterations = 2000;
    }
    c
}

/// Runs `steps` CPU steps of the scene in precision `R`; the final positions, or the error.
fn cpu_run<R: Real>(sc: &Scene, integrator: Integrator, steps: usize) -> (Result<Vec<DVec3>, StepError>, f64) {
    let (model, s0) = sc.initial::<R>().expect("harness scenes are valid");
    let dt = sc.t_end / steps as f64;
    let mut solver = CpuSolver::<R>::new(config(integrator, R::EPSILON.to_f64() < 1e-10));
    let mut out = Err(StepError::BadTimeStep(dt));
    let wall = time_best(|| {
        let mut s = s0.clone();
        let mut res = Ok(());
        for _ in 0..steps {
            res = solver.step(&model, &mut s, dt);
            if res.is_err() {
                break;
            }
        }
        out = res.map(|_| positions(&s));
    });
    (out, wall)
}

fn gpu_run(sc: &Scene, g: &GpuHandle, integrator: Integrator, steps: usize) -> (Result<Vec<DVec3>, String>, f64) {
    let (model, s0) = sc.initial::<f32>().expect("harness scenes are valid");
    let dt = sc.t_end / steps as f64;
    let cfg = gpu::GpuConfig { integrator, ..Default::default() };
    let mut solver = match gpu::GpuSolver::new(g.ctx.device.clone(), g.ctx.queue.clone(), &model, cfg) {
        Ok(s) => s,
        Err(e) => return (Err(e.to_string()), f64::NAN),
    };
    let mut out = Err("not run".to_string());
    let wall = time_best(|| {
        let mut s = s0.clone();
        let res = solver.upload_state(&s).and_then(|_| {
            // Submissions of up to 256 substeps; the time includes the final read-back.
            let mut left = steps;
            while left > 0 {
                let k = left.min(256);
                solver.run(&model, dt, k)?;
                left -= k;
            }
            solver.read_state(&mut s)
        });
        out = res.map(|_| positions(&s)).map_err(|e| e.to_string());
    });
    (out, wall)
}

/// The f64 RK4 reference: final positions, the step count used and the relative change on the last halving.
fn reference(sc: &Scene) -> Result<(Vec<DVec3>, usize, f64), String> {
    let (model, s0) = sc.initial::<f64>()?;
    let x0 = positions(&s0);
    let run = |n: usize| -> Result<Vec<DVec3>, String> {
        let mut solver = CpuSolver::<f64>::with_integrator(Integrator::Rk4);
        let mut s = s0.clone();
        let dt = sc.t_end / n as f64;
        for _ in 0..n {
            solver.step(&model, &mut s, dt).map_err(|e| e.to_string())?;
        }
        Ok(positions(&s))
    };
    let mut n = 2 * sc.steps.iter().max().copied().unwrap_or(100);
    let mut coarse = run(n)?;
    for _ in 0..8 {
        let fine = run(2 * n)?;
        let disp = rms_diff(&fine, &x0).max(1e-300);
        let rel = rms_diff(&coarse, &fine) / disp;
        eprintln!("   reference {}: {} → {} steps, change {rel:.2e} relative", sc.name, n, 2 * n);
        if rel < 1e-10 {
            return Ok((fine, 2 * n, rel));
        }
        coarse = fine;
        n *= 2;
    }
    Err(format!("RK4 reference of {} did not converge to 1e-10 by {n} steps", sc.name))
}

/// Least-squares slope of `ln err` against `ln dt` over the finest `max_points` asymptotic points.
fn order(points: &[&Point], max_points: usize) -> Option<(f64, usize)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.rel.is_finite() && p.rel > 1e-11 && p.rel < 1e-2)
        .map(|p| (p.dt.ln(), p.err.ln()))
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    p.truncate(max_points);
    if p.len() < 3 {
        return None;
    }
    let n = p.len() as f64;
    let (mx, my) = (p.iter().map(|q| q.0).sum::<f64>() / n, p.iter().map(|q| q.1).sum::<f64>() / n);
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    Some((sxy / sxx, p.len()))
}

/// The most steps a reduced run (CI) gives the GPU arm of a sweep. On a software adapter (lavapipe, as CI has)
/// a substep costs ~2.6 ms of dispatch overhead whatever the model's size: the oscillator's GPU runs up to 25,600
/// steps took 4.5 of the reduced harness's 6 minutes (2026-11-27, the Zen 3 development VM). Its check (the GPU
/// as accurate as the CPU in `f32` at the same step) holds or fails at the coarse steps as at the fine ones;
/// the full run sweeps every step count.
const QUICK_GPU_STEPS: usize = 1_000;

/// The order an integrator should show on a scene.
fn expected_order(integrator: Integrator) -> u32 {
    integrator.order()
}

/// Runs the section.
pub fn run(r: &mut Report, gpu: Option<&GpuHandle>) -> Result<(), String> {
    let quick = r.quick;
    let mut list = vec![scenes::oscillator(quick), scenes::warp_cloth(32, quick), scenes::ball(quick)];
    if !quick {
        list.push(scenes::warp_cloth(64, false));
        let mut c128 = scenes::warp_cloth(128, false);
        c128.steps.truncate(4); // 16–128 substeps: the finer ones cost minutes and add nothing to the picture
        list.push(c128);
    }
    let _ = writeln!(
        r.md,
        "### Work–precision\n\nRMS position error at the end time against the wall time of the run, for each integrator \
         (CPU in f64 and f32{}), over a sweep of steps. Reference: f64 RK4, step halved until the answer changes \
         by < 1e-10 relative (relative to the RMS displacement). Measured order: slope of log error against log dt \
         over the finest points with relative error in (1e-11, 1e-2). Implicit Euler runs CG to 1e-11 in f64 (to \
         1e-5, the default, in f32).Velocity Verlet is second order with damping: its second kick \
         takes the velocity-dependent forces at the extrapolated end-of-step velocity (at the half-step velocity, as \
         before, the lightly damped ball measured 1.45). CSV: `precision.csv`.\n",
        if gpu.is_some() { "; GPU in f32 for the explicit integrators it runs" } else { "" }
    );
    let mut rows = Vec::new();
    for sc in &list {
        eprintln!("-- {}", sc.name);
        let (reference, n_ref, change) = reference(sc)?;
        let (_, s0) = sc.initial::<f64>()?;
        let disp = rms_diff(&reference, &positions(&s0));
        let _ = writeln!(r.md, "#### {} — {}\n", sc.name, sc.about);
        r.check(
            format!("{}: reference converged", sc.name),
            change < 1e-10,
            format!(
                "RK4 f64 with {n_ref} steps; halving changed it by {change:.1e} relative (RMS displacement {} m)",
                sig3(disp)
            ),
        );
        let mut pts: Vec<Point> = Vec::new();
        for integrator in Integrator::ALL {
            for &steps in &sc.steps {
                let dt = sc.t_end / steps as f64;
                let mut add = |backend: &'static str, res: Result<Vec<DVec3>, String>, wall: f64| {
                    let err = res.map(|x| rms_diff(&x, &reference)).unwrap_or(f64::NAN);
                    pts.push(Point { backend, integrator, steps, dt, wall, err, rel: err / disp });
                };
                let (x, w) = cpu_run::<f64>(sc, integrator, steps);
                add("cpu-f64", x.map_err(|e| e.to_string()), w);
                let (x, w) = cpu_run::<f32>(sc, integrator, steps);
                add("cpu-f32", x.map_err(|e| e.to_string()), w);
                if let Some(g) = gpu {
                    let gpu_ok = matches!(integrator, Integrator::SymplecticEuler | Integrator::VelocityVerlet);
                    let small = sc.name == "oscillator" || sc.name == "cloth32" || !quick;
                    if gpu_ok && small && (!quick || steps <= QUICK_GPU_STEPS) {
                        let (x, w) = gpu_run(sc, g, integrator, steps);
                        add("gpu-f32", x, w);
                    }
                }
            }
        }
        // Table: one row per (backend, integrator); columns: steps.
        let _ = write!(r.md, "| integrator | backend | order (expected) |");
        for s in &sc.steps {
            let _ = write!(r.md, " dt = {} s |", sig3(sc.t_end / *s as f64));
        }
        let _ = write!(r.md, "\n|---|---|---|");
        for _ in &sc.steps {
            let _ = write!(r.md, "---|");
        }
        let _ = writeln!(r.md);
        let mut plot = Plot::new(format!("work-precision: {}", sc.name), "wall time [s]", "RMS position error [m]");
        for backend in ["cpu-f64", "cpu-f32", "gpu-f32"] {
            for (k, integrator) in Integrator::ALL.iter().enumerate() {
                let mine: Vec<&Point> =
                    pts.iter().filter(|p| p.backend == backend && p.integrator == *integrator).collect();
                if mine.is_empty() {
                    continue;
                }
                let expected = expected_order(*integrator);
                let ord = order(&mine, 4);
                let ord_txt = match ord {
                    Some((o, n)) => format!("{o:.2} ({expected}, {n} pts)"),
                    None => format!("— ({expected})"),
                };
                let _ = write!(r.md, "| {} | {backend} | {ord_txt} |", integrator.name());
                for p in &mine {
                    if p.err.is_finite() {
                        let _ = write!(r.md, " {} m, {} ms |", sig3(p.err), sig3(p.wall * 1e3));
                    } else {
                        let _ = write!(r.md, " unstable |");
                    }
                }
                let _ = writeln!(r.md);
                if backend == "cpu-f64" {
                    match ord {
                        Some((o, _)) => r.check(
                            format!("{}: {} converges at order {expected}", sc.name, integrator.name()),
                            (o - expected as f64).abs() <= 0.2,
                            format!("measured {o:.2}"),
                        ),
                        None => {
                            eprintln!("   {} {}: too few asymptotic points for an order", sc.name, integrator.name())
                        }
                    }
                }
                let pts_xy: Vec<(f64, f64)> = mine.iter().map(|p| (p.wall, p.err)).collect();
                let name = format!("{} {backend}", integrator.name());
                // One colour per integrator; the GPU's in a second set of colours so it stands apart from CPU f32.
                let colour = if backend == "gpu-f32" { PALETTE[(k + 4) % PALETTE.len()] } else { PALETTE[k] };
                let mut s = Series::new(name, pts_xy, colour);
                s.dashed = backend != "cpu-f64";
                plot.series.push(s);
            }
        }
        // The GPU (f32) must be as accurate as the CPU in f32: its error within 2× the CPU's plus 1e-5 of the
        // displacement (f32 round-off differs between the two; the truncation error must not).
        for g in pts.iter().filter(|p| p.backend == "gpu-f32") {
            if let Some(c) =
                pts.iter().find(|c| c.backend == "cpu-f32" && c.integrator == g.integrator && c.steps == g.steps)
                && c.err.is_finite()
            {
                r.check(
                    format!("{}: GPU {} at {} steps as accurate as CPU f32", sc.name, g.integrator.name(), g.steps),
                    g.err <= 2.0 * c.err + 1e-5 * disp,
                    format!("GPU {} m, CPU f32 {} m", sig3(g.err), sig3(c.err)),
                );
            }
        }
        let all: Vec<(f64, f64)> = pts.iter().map(|p| (p.wall, p.err)).collect();
        plot.series.push(Series::dashed("Pareto front", pareto_front(&all), [0, 0, 0]));
        r.plot(&format!("precision-{}.png", sc.name), &plot).map_err(|e| e.to_string())?;
        for p in &pts {
            rows.push(format!(
                "{},{},{},{},{:e},{:e},{:e},{:e}",
                sc.name,
                p.backend,
                p.integrator.name(),
                p.steps,
                p.dt,
                p.wall,
                p.err,
                p.rel
            ));
        }
    }
    r.csv("precision.csv", "scene,backend,integrator,steps,dt_s,wall_s,rms_error_m,relative_error", &rows)
        .map_err(|e| e.to_string())?;
    Ok(())
}
