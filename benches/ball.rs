//! The pressurised ball, the seed's central object, as issue 15's targets state it: an icosphere (r = 0.25 m,
//! 0.4 kg) of 642 or 2,562 vertices, springs of 1e3 N/m, gas nRT = 200 J, the ground, symplectic Euler,
//! dt = 1e-4 s, `f32`, all threads. Also the same ball built from shuffled meshes, and the 2,562-vertex ball after
//! 100 core splits (in six heap placements, the median of their ratios reported: see `split_ratios`). Two
//! shuffles: the triangles in a random order (so springs and triangles arrive shuffled and the particles keep the
//! mesh's numbering: the row, where `finalize` chooses the order of springs and triangles), and the
//! vertices renumbered at random as well (a mesh whose own numbering has no locality: the particle index is the
//! user's, so `finalize` keeps it), and that mesh renumbered for locality (`Mesh::renumbered_for_locality`,
//! reverse Cuthill–McKee).
//!
//! Run: `cargo bench --bench ball` (prints µs per step and the ratios, then criterion's figures).
//! `FISSURE_BENCH_QUICK=1` runs the 642-vertex ball only, briefly, as CI does.

use criterion::{Criterion, criterion_group, criterion_main};
use fissure::glam::DVec3;
use fissure::*;
use std::hint::black_box;
use std::time::Instant;

const DT: f64 = 1e-4;

/// splitmix64.
fn next(seed: &mut u64) -> u64 {
    *seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *seed;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// How a bench mesh is numbered.
#[derive(Clone, Copy, PartialEq)]
enum Order {
    /// The icosphere's own numbering.
    Original,
    /// The triangles reordered at random, the vertices kept.
    Triangles,
    /// The vertices renumbered at random and the triangles reordered.
    Everything,
    /// [`Order::Everything`], then `Mesh::renumbered_for_locality` (reverse Cuthill–McKee).
    Renumbered,
}

/// The icosphere of `subdivisions`, numbered as `order` says.
fn mesh(subdivisions: u32, order: Order) -> Mesh {
    let m = Mesh::icosphere(0.25, subdivisions).translated(DVec3::new(0.0, 0.3, 0.0));
    match order {
        Order::Original => return m,
        Order::Renumbered => return mesh(subdivisions, Order::Everything).renumbered_for_locality().0,
        _ => {}
    }
    let mut seed = 42;
    let n = m.vertex_count();
    let mut perm: Vec<u32> = (0..n as u32).collect();
    if order == Order::Everything {
        for i in (1..n).rev() {
            perm.swap(i, (next(&mut seed) % (i as u64 + 1)) as usize);
        }
    }
    let mut positions = vec![DVec3::ZERO; n];
    for (old, &new) in perm.iter().enumerate() {
        positions[new as usize] = m.positions()[old];
    }
    let mut tris: Vec<[u32; 3]> = m.triangles().iter().map(|t| t.map(|v| perm[v as usize])).collect();
    for i in (1..tris.len()).rev() {
        tris.swap(i, (next(&mut seed) % (i as u64 + 1)) as usize);
    }
    Mesh::new(positions, tris).expect("a renumbered icosphere is a valid mesh")
}

fn ball(subdivisions: u32, order: Order, breakable: bool) -> Model<f32> {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::PerSpring(1e3),
        gas: Gas::Amount(200.0),
        fracture: breakable.then_some(Breakable {
            strain_limit: f64::INFINITY,
            load_limit: 1e9,
            sealed: true,
            ..Default::default()
        }),
        ..Default::default()
    };
    b.add_soft_body(&mesh(subdivisions, order), &opts).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    b.finalize().unwrap()
}

/// µs per step over `steps` steps.
fn run(w: &mut World<f32>, steps: usize) -> f64 {
    let t0 = Instant::now();
    for _ in 0..steps {
        w.step(DT).unwrap();
    }
    t0.elapsed().as_secs_f64() / steps as f64 * 1e6
}

/// µs per step over `steps` steps after 200 warm-up steps.
fn time_world(w: &mut World<f32>, steps: usize) -> f64 {
    for _ in 0..200 {
        w.step(DT).unwrap();
    }
    w.reset_timers();
    run(w, steps)
}

/// `a` and `b` stepped in turn, `rounds` times `steps` steps each, both from the states they held on entry (so
/// each round times the same stretch of motion), the timers reset halfway. Returns the best µs per step of each
/// and the median of the rounds' ratios `b / a`. The VM's neighbours slow both alike within a round, so a round's
/// ratio is steadier than two bests taken minutes apart (those read 1.19–1.29 for the same build, 2026-11-27).
fn alternated(a: &mut World<f32>, b: &mut World<f32>, rounds: usize, steps: usize) -> (f64, f64, f64) {
    let (sa, sb) = (a.state.clone(), b.state.clone());
    let (mut best_a, mut best_b, mut ratios) = (f64::INFINITY, f64::INFINITY, Vec::new());
    for r in 0..rounds {
        a.state = sa.clone();
        b.state = sb.clone();
        if r == rounds / 2 {
            a.reset_timers();
            b.reset_timers();
        }
        let (ta, tb) = (run(a, steps), run(b, steps));
        best_a = best_a.min(ta);
        best_b = best_b.min(tb);
        ratios.push(tb / ta);
    }
    ratios.sort_by(f64::total_cmp);
    (best_a, best_b, ratios[ratios.len() / 2])
}

/// The 2,562-vertex breakable ball after 100 core splits against the same ball intact, both worlds built after a
/// block of `pad` bytes is allocated (a heap placement): the median ratio of alternated rounds right after the
/// splits and 0.8 s later, each printed with both worlds' stage timers.
fn split_ratios(sub: u32, n: usize, pad: usize, quick: bool) -> [f64; 2] {
    let block = black_box(vec![1u8; pad]);
    // 100 punctures spread over the surface (core mode; every vertex is breakable but none by load).
    let mut wa = World::new(ball(sub, Order::Original, true), SolverConfig::default());
    let mut wb = World::new(ball(sub, Order::Original, true), SolverConfig::default());
    // Both on the spinning team where there is one: each solver otherwise times the team against one thread as
    // it steps, and on a noisy host the two worlds may pick differently (a ratio of 0.94 in one placement).
    if rayon::current_num_threads() > 1 {
        for w in [&mut wa, &mut wb] {
            w.cpu_solver().expect("a CPU world").force_team(Some(true));
        }
    }
    for _ in 0..200 {
        wa.step(DT).unwrap();
        wb.step(DT).unwrap();
    }
    let size = |w: &World<f32>| [w.model.particle_count(), w.model.spring_count(), w.model.tri_count()];
    let before = size(&wb);
    let (mut done, mut v) = (0, 0);
    while done < 100 && v < n {
        done += (!wb.break_core(v).unwrap().is_empty()) as usize;
        v += 17;
    }
    let (rounds, round) = if quick { (2, 100) } else { (10, 500) };
    let mut out = [0.0; 2];
    // Right after the splits (0.02 s on, before the core blocks thrown out by the gas land), then 0.8 s on, where
    // the landed blocks rest on the ground and collide at every step.
    for (k, (what, after)) in
        [("right after the splits", 200), ("0.8 s after the splits", 8000)].into_iter().enumerate()
    {
        for _ in 0..(if quick { after.min(200) } else { after }) {
            wb.step(DT).unwrap();
        }
        let (intact, broken, ratio) = alternated(&mut wa, &mut wb, rounds, round);
        println!(
            "  placement {pad} B, breakable ball {what}: intact {intact:.1} µs/step, after {done} core splits \
             {broken:.1} µs/step: {ratio:.3}x (median of {rounds} alternated rounds of {round} steps)"
        );
        println!("intact:\n{}\nsplit:\n{}", wa.timers(), wb.timers());
        out[k] = ratio;
    }
    // The floor of that ratio: a step touches every particle, spring and triangle, so the work it must do grows
    // with the model, and the time per element is what the split body's layout decides.
    let after = size(&wb);
    let growth = [0, 1, 2].map(|k| after[k] as f64 / before[k] as f64);
    println!(
        "  the model grew {:.2}x in particles, {:.2}x in springs, {:.2}x in triangles",
        growth[0], growth[1], growth[2]
    );
    drop(block);
    out
}

fn bench(c: &mut Criterion) {
    let quick = std::env::var_os("FISSURE_BENCH_QUICK").is_some();
    let steps = if quick { 200 } else { 5000 };
    let threads = rayon::current_num_threads();
    let sizes: &[u32] = if quick { &[3] } else { &[3, 4] };
    for &sub in sizes {
        let mut w = World::new(ball(sub, Order::Original, false), SolverConfig::default());
        let n = w.model.particle_count();
        // Best of three runs: the VM's neighbours add noise, never speed.
        let plain = (0..3).map(|_| time_world(&mut w, steps)).fold(f64::INFINITY, f64::min);
        println!("ball {n} vertices, {threads} threads: {plain:.1} µs/step");
        println!("{}", w.timers());
        for (order, what) in [
            (Order::Triangles, "springs and triangles shuffled"),
            (Order::Everything, "vertices renumbered, springs and triangles shuffled"),
            (Order::Renumbered, "that mesh renumbered by Mesh::renumbered_for_locality"),
        ] {
            let mut ws = World::new(ball(sub, order, false), SolverConfig::default());
            let shuffled = (0..3).map(|_| time_world(&mut ws, steps)).fold(f64::INFINITY, f64::min);
            println!("  {what}: {shuffled:.1} µs/step ({:.2}x the original order)", shuffled / plain);
        }
        if sub == 4 || quick {
            // The split row in several heap placements: where the allocator puts the two worlds' arrays moves
            // each ball's time by up to ~10 % on the Zen 4 development VM (2026-12-07: the intact ball 36.9-43.3
            // µs a step and the split one 44.6-53.2 across placements and minutes), so one placement is one draw.
            // Each placement builds both worlds after a block of `pad` bytes (below glibc's mmap threshold, so
            // the block shifts the heap); the median of the placements' ratios is the row's figure.
            let pads: &[usize] = if quick { &[0] } else { &[0, 64, 1024, 4096, 20_000, 70_000] };
            let mut ratios = [Vec::new(), Vec::new()];
            for &pad in pads {
                for (k, r) in split_ratios(sub, n, pad, quick).into_iter().enumerate() {
                    ratios[k].push(r);
                }
            }
            for (what, mut r) in ["right after the splits", "0.8 s after the splits"].into_iter().zip(ratios) {
                r.sort_by(f64::total_cmp);
                let median = (r[(r.len() - 1) / 2] + r[r.len() / 2]) / 2.0;
                let (n, lo, hi) = (r.len(), r[0], r[r.len() - 1]);
                let s = if n == 1 { "" } else { "s" };
                println!(
                    "  breakable ball {what}: split / intact {median:.3}x, median of {n} placement{s} ({lo:.3}-{hi:.3})"
                );
            }
        }
        let model = ball(sub, Order::Original, false);
        let mut state = model.state();
        let mut solver = CpuSolver::<f32>::default();
        c.bench_function(&format!("ball_{n}_symplectic_euler_step"), |b| {
            b.iter(|| {
                solver.step(&model, &mut state, DT).unwrap();
                black_box(&state);
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
