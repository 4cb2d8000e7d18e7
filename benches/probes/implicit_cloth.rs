//! Issue 15's large-step row alone: the 32² benchmark cloth (1 cm, 1 g, k 1e3 N/m, two corners pinned) stepped by
//! implicit Euler at 1/60 s, the 120 steps of `cargo bench --bench cloth` repeated in rounds that alternate CG's
//! preconditioner (`SolverConfig::cg_coarse` on, then off: this host's speed drifts from minute to minute, so the
//! two are compared round against round); prints each round's time per step, its stages and CG iterations per
//! step, and the best round of each.
//!
//! Run: `cp benches/probes/implicit_cloth.rs examples/ && cargo run --release --example implicit_cloth -- 9`
//! (rounds of each; remove the copy afterwards). To compare two builds instead (copies of the binary run in
//! turn, `benches/RESULTS.md` issue 15 (51)): `PROBE_COARSE=1` (or `0`) keeps every round's preconditioner the
//! same, and `PROBE_TEAM=1` (or `0`) steps on the spinning team (or without it) instead of as the solver measures.
use fissure::*;
use std::time::Instant;

fn main() {
    let rounds: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(9);
    let model: Model<f32> = fissure::scenes::benchmark_cloth(32).unwrap().finalize().unwrap();
    let mut best = [f64::INFINITY; 2];
    for round in 0..2 * rounds {
        let coarse = std::env::var("PROBE_COARSE").map_or(round % 2 == 0, |v| v == "1");
        let mut state = model.state();
        let config = SolverConfig { cg_coarse: coarse, ..SolverConfig::with(Integrator::ImplicitEuler) };
        let mut solver = CpuSolver::<f32>::new(config);
        if let Ok(team) = std::env::var("PROBE_TEAM") {
            solver.force_team(Some(team == "1"));
        }
        let h = 1.0 / 60.0;
        let (mut iterations, steps) = (0, 120);
        let t0 = Instant::now();
        for _ in 0..steps {
            solver.step(&model, &mut state, h).unwrap();
            iterations += solver.cg.iterations;
        }
        let per = t0.elapsed().as_secs_f64() / steps as f64;
        best[!coarse as usize] = best[!coarse as usize].min(per);
        println!(
            "round {round} (coarse level {coarse}): {:.3} ms/step, {:.1} CG iterations per step\n{}",
            per * 1e3,
            iterations as f64 / steps as f64,
            solver.timers()
        );
    }
    println!("best: coarse level on {:.3} ms/step, off {:.3} ms/step", best[0] * 1e3, best[1] * 1e3);
}
