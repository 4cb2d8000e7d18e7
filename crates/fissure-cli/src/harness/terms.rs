//! Cost per term: the same body with and without each force term, per stage. A scene pays only for what it uses:
//! the rows without a term show no time (and no calls) in that term's stage.

use super::{Report, sig3};
use fissure::glam::{DVec3, Vec3};
use fissure::*;
use std::fmt::Write as _;
use std::time::Instant;

#[derive(Clone, Copy, PartialEq)]
enum Term {
    Plain,
    Pressure,
    Wind,
    Colliders,
    Fracture,
}

impl Term {
    fn name(self) -> &'static str {
        match self {
            Term::Plain => "springs + gravity only",
            Term::Pressure => "+ pressure",
            Term::Wind => "+ wind",
            Term::Colliders => "+ colliders (ground and a ball, touching)",
            Term::Fracture => "+ fracture (breakable, nothing breaks)",
        }
    }
}

fn build(body: &str, term: Term, quick: bool) -> Result<ModelBuilder, ModelError> {
    let mut b = ModelBuilder::new();
    let breakable = (term == Term::Fracture).then(|| Breakable { strain_limit: 10.0, ..Default::default() });
    if body == "cloth" {
        let n = if quick { 32 } else { 128 };
        let opts = ClothOptions {
            aero: Aero::default(),
            pins: vec![0, n - 1],
            fracture: breakable,
            damping: Damping::PerSpring(0.1),
            mass: Mass::PerParticle(1e-3),
            ..Default::default()
        };
        b.add_cloth_grid(n, n, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts)?;
    } else {
        let opts = SoftBodyOptions {
            mass: Mass::Total(0.4),
            stiffness: Stiffness::Membrane(2500.0),
            gas: if term == Term::Pressure { Gas::Pressure(2500.0) } else { Gas::None },
            fracture: breakable,
            aero: Aero::default(),
            ..Default::default()
        };
        b.add_soft_body(
            &Mesh::icosphere(0.25, if quick { 3 } else { 5 }).translated(DVec3::new(0.0, 0.26, 0.0)),
            &opts,
        )?;
    }
    match term {
        Term::Wind => {
            b.wind(WindField { velocity: DVec3::new(0.0, 0.0, 4.0), ..Default::default() })?;
        }
        Term::Colliders => {
            b.add_collider(Collider::ground(if body == "cloth" { 0.9995 } else { 0.0 }))?;
            b.add_collider(Collider::ball(Vec3::new(0.3, 0.8, 0.3), 0.2))?;
        }
        _ => {}
    }
    Ok(b)
}

/// Runs the section.
pub fn run(r: &mut Report) -> Result<(), String> {
    let steps = if r.quick { 50 } else { 300 };
    let _ = writeln!(
        r.md,
        "\n### Cost per term\n\nThe same body with one term added at a time: symplectic Euler, f32, all threads, \
         {steps} steps after 10 warm-up steps, best of 3 runs (the terms' runs interleaved, each body's runs stepping one way: below the table), µs per step in total and per stage (`StageTimers`; \
         fracture is the fracture pass and the solver's load sums outside the gather); `added` is what the term adds \
         to the whole step ÷ the plain body's spring pass (issue 15's goals: wind, pressure ≤ 1, colliders ≤ 0.3, \
         fracture ≤ 0.2). Cloth: {0}² particles at 1 cm, 1 g each, default cloth springs. Ball: icosphere \
         of {1} vertices, membrane 2500 N/m. CSV: `terms.csv`.\n\n\
         | body | terms | µs/step | springs | surface | integrate | collide | fracture | added |\n|---|---|---|---|---|---|---|---|---|",
        if r.quick { 32 } else { 128 },
        if r.quick { 642 } else { 10242 },
    );
    let mut rows = Vec::new();
    let mut modes = Vec::new();
    for body in ["cloth", "ball"] {
        let mut plain = (0.0, 1.0);
        let terms: Vec<Term> = [Term::Plain, Term::Pressure, Term::Wind, Term::Colliders, Term::Fracture]
            .into_iter()
            .filter(|&t| !(body == "cloth" && t == Term::Pressure)) // an open sheet holds no gas
            .collect();
        let dt = 5e-5;
        let mut worlds = Vec::new();
        for &term in &terms {
            let model: Model<f32> =
                build(body, term, r.quick).map_err(|e| e.to_string())?.finalize().map_err(|e| e.to_string())?;
            let mut world = World::new(model, SolverConfig::default());
            for _ in 0..10 {
                world.step(dt).map_err(|e| e.to_string())?;
            }
            worlds.push(world);
        }
        // Every world of the body steps the way the plain body's solver chose. Each solver measures for itself
        // whether the spinning team pays (`team::Pick`: both ways timed over its first ~100 steps), and on a host
        // where the two cost about the same, two worlds may step different ways, which their difference would
        // then measure (2026-11-27: a ball with colliders read 1.46× its spring pass in one run of this section
        // and 0.10–0.13× in three).
        let plain_world = &mut worlds[0];
        for _ in 0..120 {
            plain_world.step(dt).map_err(|e| e.to_string())?;
        }
        let team = plain_world.cpu_solver().and_then(|s| s.team_chosen());
        for world in &mut worlds {
            if let Some(s) = world.cpu_solver() {
                s.force_team(team);
            }
        }
        modes.push(format!(
            "{body}: {}",
            match team {
                Some(true) => "every run on the spinning team, as the plain body's solver chose",
                Some(false) => "every run without the spinning team, as the plain body's solver chose",
                None => "each solver stepping as it measured (no team, or no choice made)",
            }
        ));
        // Best of three runs, the terms' runs interleaved (plain, pressure, …, plain, …): the machine's neighbours
        // add time, never remove it, and a drift over the section then falls on every term alike instead of on
        // the ones measured last.
        let mut best: Vec<(f64, StageTimers)> = vec![(f64::INFINITY, StageTimers::default()); terms.len()];
        for _ in 0..3 {
            for (world, best) in worlds.iter_mut().zip(&mut best) {
                world.reset_timers();
                let t = Instant::now();
                for _ in 0..steps {
                    world.step(dt).map_err(|e| e.to_string())?;
                }
                let run = t.elapsed().as_secs_f64() / steps as f64 * 1e6;
                if run < best.0 {
                    *best = (run, world.timers());
                }
            }
        }
        for ((&term, world), (total, tm)) in terms.iter().zip(&worlds).zip(best) {
            let per = |st: Stage| tm.time(st).as_secs_f64() / steps as f64 * 1e6;
            let frac = per(Stage::Fracture);
            if term == Term::Plain {
                plain = (total, per(Stage::Springs));
            }
            // What the term adds to the whole step (its own stage, and any work it puts into the others: the
            // fracture measures ride in the spring and integrate passes, the pressure shares in the gather).
            let added = (total - plain.0) / plain.1.max(1e-9);
            let _ = writeln!(
                r.md,
                "| {body} | {} | {} | {} | {} | {} | {} | {} | {} |",
                term.name(),
                sig3(total),
                sig3(per(Stage::Springs)),
                sig3(per(Stage::Surface)),
                sig3(per(Stage::Integrate)),
                sig3(per(Stage::Collide)),
                sig3(frac),
                if term == Term::Plain { "—".to_string() } else { format!("{added:.2}") }
            );
            rows.push(format!(
                "{body},{},{total:e},{:e},{:e},{:e},{:e},{frac:e}",
                term.name(),
                per(Stage::Springs),
                per(Stage::Surface),
                per(Stage::Integrate),
                per(Stage::Collide)
            ));
            let fracture_calls = world.fracture.timers().calls(Stage::Fracture);
            if term != Term::Pressure && term != Term::Wind {
                r.check(
                    format!("{body} {}: no surface pass", term.name()),
                    tm.calls(Stage::Surface) == 0,
                    format!("{} surface calls", tm.calls(Stage::Surface)),
                );
            }
            if term != Term::Colliders {
                r.check(
                    format!("{body} {}: no collision pass", term.name()),
                    tm.calls(Stage::Collide) == 0,
                    format!("{} collide calls", tm.calls(Stage::Collide)),
                );
            }
            if term != Term::Fracture {
                r.check(
                    format!("{body} {}: no fracture work", term.name()),
                    fracture_calls == 0,
                    format!("{fracture_calls} fracture calls"),
                );
            }
            // Issue 15's goals: what each present term adds to the step, at most a fraction of the spring pass.
            let goal = match term {
                Term::Plain => None,
                Term::Pressure | Term::Wind => Some(1.0),
                Term::Colliders => Some(0.3),
                Term::Fracture => Some(0.2),
            };
            if let Some(limit) = goal {
                r.target(
                    format!("{body} {}: adds ≤ {limit}× the spring pass", term.name()),
                    added <= limit,
                    format!("{added:.2}× ({} µs on {} µs of springs)", sig3(total - plain.0), sig3(plain.1)),
                );
            }
        }
    }
    let _ = writeln!(r.md, "\nThreads: {}.", modes.join("; "));
    r.csv("terms.csv", "body,terms,us_per_step,springs_us,surface_us,integrate_us,collide_us,fracture_us", &rows)
        .map_err(|e| e.to_string())?;
    Ok(())
}
