//! Cost of one fracture event against the size of the body: a pressurised icosphere of 2,562 vertices and one of
//! 40,962, each split in spring mode at springs spread over the surface and punctured in core mode. The cost of a
//! split follows the triangles it touches (incremental topology), so the two figures must be about equal.
//!
//! Run: `cargo bench --bench fracture`. `FISSURE_BENCH_QUICK=1` takes fewer samples so CI can run it fast.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use fissure::*;
use std::time::Instant;

/// Events per timed batch.
const EVENTS: usize = 16;

fn ball(subdivisions: u32) -> Model<f32> {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2000.0),
        fracture: Some(Breakable { strain_limit: 0.5, load_limit: 10.0, sealed: false, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.3, subdivisions), &opts).unwrap();
    b.finalize().unwrap()
}

/// `EVENTS` springs (spring mode) or vertices (core mode) spread evenly over the model.
fn targets(m: &Model<f32>, core: bool) -> Vec<usize> {
    let n = if core { m.particle_count() } else { m.spring_count() };
    (0..EVENTS).map(|k| k * n / EVENTS + 1).collect()
}

fn batch(m: &mut Model<f32>, s: &mut State<f32>, f: &mut Fracture<f32>, ts: &[usize], core: bool) -> usize {
    let mut events = 0;
    for &t in ts {
        events += if core { f.break_core(m, s, t) } else { f.break_spring(m, s, t) }.events.len();
    }
    events
}

fn bench(c: &mut Criterion) {
    let quick = std::env::var_os("FISSURE_BENCH_QUICK").is_some();
    let mut summary = Vec::new();
    // The plain timing sweeps four sizes (the largest only in a full run); criterion times 2,562 and 40,962.
    let sizes: &[u32] = if quick { &[4, 6] } else { &[4, 5, 6, 7] };
    for &sub in sizes {
        let model = ball(sub);
        let state = model.state();
        for core in [false, true] {
            let ts = targets(&model, core);
            // Each batch starts from a copy that has already broken once elsewhere, so it measures the steady
            // state: the first split of a simulation also pays for growing the model's arrays (amortised O(1)).
            let warm: Vec<usize> = ts.iter().map(|&t| t + 7).collect();
            let mut warmed = (model.clone(), state.clone(), Fracture::<f32>::default());
            batch(&mut warmed.0, &mut warmed.1, &mut warmed.2, &warm, core);
            let prepared = || {
                let (mut m, mut s, mut f) = warmed.clone();
                let (n, ns, nt) = (m.particle_count(), m.spring_count(), m.tri_count());
                m.reserve(n, ns, nt);
                s.particle_q.reserve(n);
                s.particle_qd.reserve(n);
                f.prepare(&m);
                (m, s, f)
            };
            // A plain timing for the summary line: the best of several fresh batches.
            let mut best = f64::INFINITY;
            let mut events = 0;
            for _ in 0..if quick { 3 } else { 20 } {
                let (mut m, mut s, mut f) = prepared();
                let t0 = Instant::now();
                events = batch(&mut m, &mut s, &mut f, &ts, core);
                best = best.min(t0.elapsed().as_secs_f64());
            }
            let per_event = best / events.max(1) as f64;
            let mode = if core { "core" } else { "spring" };
            summary.push(format!(
                "{mode:>6} mode, {:>6} vertices: {:>6.2} µs per event ({events} events per batch)",
                model.particle_count(),
                per_event * 1e6
            ));
            if sub != 4 && sub != 6 {
                continue;
            }
            let mut g = c.benchmark_group("fracture_event");
            if quick {
                g.sample_size(10);
            }
            g.bench_function(format!("{mode}_{}_vertices_x{EVENTS}", model.particle_count()), |b| {
                // By reference: dropping a 40k-vertex model (unmapping its arrays) is not part of a split.
                b.iter_batched_ref(prepared, |(m, s, f)| batch(m, s, f, &ts, core), BatchSize::LargeInput)
            });
            g.finish();
        }
    }
    println!("\ntime per fracture event (best of fresh batches):");
    for l in &summary {
        println!("  {l}");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
