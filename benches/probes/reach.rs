//! How many contact pairs a per-pair reach would keep (issue 16's fold bench; not built by cargo:
//! `benches/RESULTS.md`, issue 16's section, "How much a per-pair reach would remove", has what it counted).
//!
//! Steps the fold bench's model (`fissure::scenes::folding_cloth`, as `benches/contact.rs` builds it: a 128² cloth with self-collision dropped onto a ball and
//! the floor) for `warm` steps of 2e-4 s, takes each particle's move over the next step (halved: the bench's
//! substep guard makes two substeps a step), and counts by brute force over a hash grid every vertex–triangle and
//! edge–edge pair without a shared vertex that lies within the pass's global reach `r = h + d_max / GAMMA` and its
//! search radius `1.5 r + h`, and within a per-pair reach `r_P = h + max_{k in P} d_k / GAMMA` (and `1.5 r_P + h`).
//!
//! Run: `cp benches/probes/reach.rs examples/ && cargo run --release --example reach -- 128 2500` (about a
//! minute on the development VM; remove the copy afterwards).
use fissure::contact::geometry::{closest_on_segments, closest_on_triangle};
use fissure::contact::grid::HashGrid;
use fissure::glam::DVec3;
use fissure::*;
use std::collections::BTreeSet;

fn main() {
    let n: usize = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(128);
    let warm: usize = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(2500);
    let m: Model<f32> = fissure::scenes::folding_cloth(n, true).unwrap().finalize().unwrap();
    let mut s = m.state();
    let mut solver = CpuSolver::<f32>::new(SolverConfig { substep_safety: Some(0.8), ..Default::default() });
    let dt = 2e-4;
    for _ in 0..warm {
        solver.step(&m, &mut s, dt).unwrap();
    }
    let q0: Vec<DVec3> = s.particle_q.iter().map(|x| x.as_dvec3()).collect();
    solver.step(&m, &mut s, dt).unwrap();
    let q1: Vec<DVec3> = s.particle_q.iter().map(|x| x.as_dvec3()).collect();
    let np = q0.len();
    // Per-substep moves (two substeps a step).
    let d: Vec<f64> = (0..np).map(|i| (q1[i] - q0[i]).length() / 2.0).collect();
    let h = m.body_contact_thickness[0] as f64;
    let gamma = fissure::contact::GAMMA;
    let skin = 1.5;
    let dmax = d.iter().cloned().fold(0.0, f64::max);
    let r = h + dmax / gamma;
    let big = skin * r + h;
    let mut ds = d.clone();
    ds.sort_by(f64::total_cmp);
    println!(
        "{np} particles; h {:.2} mm; moves per substep: median {:.4} mm, p90 {:.4}, p99 {:.4}, max {:.4}; \
         global reach r {:.2} mm, search {:.2} mm",
        h * 1e3,
        ds[np / 2] * 1e3,
        ds[np * 9 / 10] * 1e3,
        ds[np * 99 / 100] * 1e3,
        dmax * 1e3,
        r * 1e3,
        big * 1e3
    );
    let x = &q0;
    let tris: Vec<[u32; 3]> = m.tri_indices.clone();
    let mut edges = BTreeSet::new();
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.insert([a.min(b), a.max(b)]);
        }
    }
    let edges: Vec<[u32; 2]> = edges.into_iter().collect();
    let lmax = edges.iter().map(|e| (x[e[0] as usize] - x[e[1] as usize]).length()).fold(0.0, f64::max);
    // Counts: [global near, global candidates, per-pair near, per-pair candidates]
    let mut vt = [0usize; 4];
    let mut ee = [0usize; 4];
    let reach = |ps: &[u32]| h + ps.iter().map(|&p| d[p as usize]).fold(0.0, f64::max) / gamma;
    let mut g = HashGrid::default();
    g.build(big, np, |i| Some(x[i]));
    for t in &tris {
        let [a, b, c] = t.map(|i| x[i as usize]);
        let (lo, hi) = (a.min(b).min(c) - DVec3::splat(big), a.max(b).max(c) + DVec3::splat(big));
        g.query(lo, hi, |v| {
            if t.contains(&v) {
                return;
            }
            let p = x[v as usize];
            let w = closest_on_triangle(p, a, b, c);
            let dist = (p - (w[0] * a + w[1] * b + w[2] * c)).length();
            let rp = reach(&[v, t[0], t[1], t[2]]);
            let c4 = [dist < r, dist < big, dist < rp, dist < skin * rp + h];
            for k in 0..4 {
                vt[k] += c4[k] as usize;
            }
        });
    }
    let mid = |e: &[u32; 2]| 0.5 * (x[e[0] as usize] + x[e[1] as usize]);
    g.build(big + lmax, edges.len(), |k| Some(mid(&edges[k])));
    for (k, e) in edges.iter().enumerate() {
        let c = mid(e);
        let ext = DVec3::splat(big + lmax);
        g.query(c - ext, c + ext, |f| {
            let f = f as usize;
            if f <= k {
                return;
            }
            let o = &edges[f];
            if e.iter().any(|a| o.contains(a)) {
                return;
            }
            let (p, q, u, w) = (x[e[0] as usize], x[e[1] as usize], x[o[0] as usize], x[o[1] as usize]);
            let (s_, t_) = closest_on_segments(p, q, u, w);
            let dist = ((p + s_ * (q - p)) - (u + t_ * (w - u))).length();
            let rp = reach(&[e[0], e[1], o[0], o[1]]);
            let c4 = [dist < r, dist < big, dist < rp, dist < skin * rp + h];
            for j in 0..4 {
                ee[j] += c4[j] as usize;
            }
        });
    }
    println!(
        "vertex-triangle pairs: global near {}, global candidates {}; per-pair near {}, per-pair candidates {}",
        vt[0], vt[1], vt[2], vt[3]
    );
    println!(
        "edge-edge pairs:       global near {}, global candidates {}; per-pair near {}, per-pair candidates {}",
        ee[0], ee[1], ee[2], ee[3]
    );
}
