//! How often a leaf pair's own validity would fail on the fold bench (issue 16; not built by cargo:
//! `benches/RESULTS.md`, issue 16's section and entry (58), has what it counted).
//!
//! The design costed in RESULTS (56) keeps, instead of one Verlet list valid while no particle drifts past a global
//! slack, a front of leaf pairs, each valid while its own particles' relative drift stays within its slack: parts of
//! the cloth that move together are then not searched again. This probe counts what that would cost on the fold
//! bench's motion. It steps the bench's model (`fissure::scenes::folding_cloth(n, true)`, 2e-4 s steps, the substep
//! guard at 0.8: two substeps a step) for `warm` steps, then groups the particles into leaves of `leaf` × `leaf`
//! grid particles (a triangle belongs to the leaf of its lowest corner; a leaf's particles are its triangles'
//! corners), takes as the front every pair of leaves (and each leaf with itself) whose boxes lie within the
//! search radius `R = 1.5 r + h` of the pass (`r = h + d_max / GAMMA`), and then over `steps` steps:
//! - a front pair fails when the box of its particles' drift vectors since its own reference (the step it was
//!   formed or last failed) is wider (its diagonal) than `R − r`: its element pairs would be tested again (counted:
//!   vertex–triangle and edge–edge tests, from the leaves' triangle and particle counts) and its reference reset;
//! - every `scan` steps the leaf pairs whose boxes are now within `R` are found by brute force over a hash of
//!   leaf centres, and those missing from the front are counted (and added): the front's growth, which a
//!   hierarchy above the leaves would have to find.
//!
//! Prints the front's size, failures and element-pair tests per substep, and the growth per substep, beside the
//! Verlet list's own figures for the same steps (`ContactStats`: refreshes, builds).
//!
//! Run: `cp benches/probes/leaf_drift.rs examples/ && cargo run --release --example leaf_drift -- 128 2500 300 2`
//! (arguments: n, warm, steps, leaf; about a minute; remove the copy afterwards).
use fissure::glam::DVec3;
use fissure::*;
use std::collections::{HashMap, HashSet};

fn main() {
    let arg = |k: usize, d: usize| std::env::args().nth(k).map_or(d, |s| s.parse().unwrap());
    let (n, warm, steps, leaf, scan) = (arg(1, 128), arg(2, 2500), arg(3, 300), arg(4, 2), arg(5, 10));
    let m: Model<f32> = fissure::scenes::folding_cloth(n, true).unwrap().finalize().unwrap();
    let mut s = m.state();
    let mut solver = CpuSolver::<f32>::new(SolverConfig { substep_safety: Some(0.8), ..Default::default() });
    let dt = 2e-4;
    for _ in 0..warm {
        solver.step(&m, &mut s, dt).unwrap();
    }
    let np = m.particle_count();
    let lx = n.div_ceil(leaf);
    let leaf_of = |p: u32| (p as usize / n / leaf) * lx + (p as usize % n) / leaf;
    let nl = lx * lx;
    let mut ltris = vec![Vec::new(); nl];
    let mut lparts: Vec<Vec<u32>> = vec![Vec::new(); nl];
    for (t, tv) in m.tri_indices.iter().enumerate() {
        let l = leaf_of(*tv.iter().min().unwrap());
        ltris[l].push(t);
        lparts[l].extend(tv);
    }
    for p in lparts.iter_mut() {
        p.sort_unstable();
        p.dedup();
    }
    let h = m.body_contact_thickness[0] as f64;
    let pos = |s: &State<f32>| s.particle_q.iter().map(|x| x.as_dvec3()).collect::<Vec<DVec3>>();
    let boxes = |x: &[DVec3]| {
        lparts
            .iter()
            .map(|ps| {
                ps.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                    (lo.min(x[p as usize]), hi.max(x[p as usize]))
                })
            })
            .collect::<Vec<_>>()
    };
    let apart = |a: (DVec3, DVec3), b: (DVec3, DVec3)| (a.0 - b.1).max(b.0 - a.1).max(DVec3::ZERO).length();
    // Leaf pairs within `radius` (brute force over a hash of leaf centres; leaves are at most `span` wide).
    let near_pairs = |bx: &[(DVec3, DVec3)], radius: f64| {
        let span = bx.iter().map(|b| (b.1 - b.0).max_element()).fold(0.0, f64::max);
        let cell = span + radius;
        let key = |p: DVec3| (p / cell).floor().as_ivec3();
        let mut grid: HashMap<_, Vec<usize>> = HashMap::new();
        for (l, b) in bx.iter().enumerate() {
            if b.0.is_finite() {
                grid.entry(key(0.5 * (b.0 + b.1))).or_default().push(l);
            }
        }
        let mut out = HashSet::new();
        for (l, b) in bx.iter().enumerate() {
            if !b.0.is_finite() {
                continue;
            }
            let k = key(0.5 * (b.0 + b.1));
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for &o in grid.get(&(k + fissure::glam::IVec3::new(dx, dy, dz))).into_iter().flatten() {
                            if o >= l && apart(*b, bx[o]) < radius {
                                out.insert((l, o));
                            }
                        }
                    }
                }
            }
        }
        out
    };
    let mut hist: Vec<Vec<DVec3>> = vec![pos(&s)];
    let gamma = fissure::contact::GAMMA;
    // The pass's reach and radius at the start (the fastest particle's move a substep).
    let reach_of = |a: &[DVec3], b: &[DVec3]| {
        let dmax = a.iter().zip(b).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max) / 2.0;
        h + dmax / gamma
    };
    let before = solver.contact_stats();
    solver.step(&m, &mut s, dt).unwrap();
    hist.push(pos(&s));
    let r0 = reach_of(&hist[1], &hist[0]);
    let radius = 1.5 * r0 + h;
    let bx = boxes(&hist[1]);
    let mut front: HashMap<(usize, usize), usize> = near_pairs(&bx, radius).into_iter().map(|p| (p, 1)).collect();
    let size0 = front.len();
    let (mut fails, mut tests, mut grown, mut r_sum) = (0usize, 0usize, 0usize, 0.0);
    for k in 2..=steps + 1 {
        solver.step(&m, &mut s, dt).unwrap();
        hist.push(pos(&s));
        let r = reach_of(&hist[k], &hist[k - 1]);
        r_sum += r;
        let x = &hist[k];
        for (&(a, b), k0) in front.iter_mut() {
            let x0 = &hist[*k0];
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for &p in lparts[a].iter().chain(if a == b { &[][..] } else { &lparts[b][..] }) {
                let d = x[p as usize] - x0[p as usize];
                (lo, hi) = (lo.min(d), hi.max(d));
            }
            if (hi - lo).length() > radius - r {
                fails += 1;
                // Vertex–triangle tests both ways and edge–edge tests (~1.5 edges a triangle).
                let (ta, tb) = (ltris[a].len(), ltris[b].len());
                let (pa, pb) = (lparts[a].len(), lparts[b].len());
                tests += pa * tb + pb * ta + (3 * ta / 2) * (3 * tb / 2);
                *k0 = k;
            }
        }
        if k % scan == 0 {
            for p in near_pairs(&boxes(x), radius) {
                if let std::collections::hash_map::Entry::Vacant(e) = front.entry(p) {
                    e.insert(k);
                    grown += 1;
                }
            }
        }
    }
    let after = solver.contact_stats();
    let substeps = 2.0 * steps as f64;
    println!(
        "{np} particles, {nl} leaves of {leaf}x{leaf}; h {:.2} mm, r {:.2} mm (mean {:.2}), R {:.2} mm; front {size0} \
         leaf pairs at the start, {} at the end",
        h * 1e3,
        r0 * 1e3,
        r_sum / steps as f64 * 1e3,
        radius * 1e3,
        front.len()
    );
    println!(
        "per substep: {:.1} front pairs fail ({:.3} % of the front), {:.0} element-pair tests again; the front grows \
         by {:.1} pairs (checked every {scan} steps)",
        fails as f64 / substeps,
        100.0 * fails as f64 / substeps / size0 as f64,
        tests as f64 / substeps,
        grown as f64 / substeps
    );
    println!(
        "the Verlet list over the same steps: {} builds, {} refreshes",
        after.builds - before.builds,
        after.refreshes - before.refreshes
    );
}
