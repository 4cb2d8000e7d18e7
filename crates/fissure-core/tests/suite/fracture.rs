//! Fracture: invariants after every split (property tests over random fracture sequences), exact mass,
//! momentum, cracks that open and detach pieces, core blocks, capped volumes, the gas leak, the averaged trigger,
//! determinism, and no fracture work when nothing can break.

use crate::common;

use common::Rng;
use fissure_core::glam::DVec3;
use fissure_core::*;
use proptest::prelude::*;

/// Exact sum of `f64` masses in fixed point (2^-100 kg units); panics if a mass is not a multiple of the unit.
fn exact_mass<R: Real>(m: &Model<R>) -> i128 {
    m.particle_mass
        .iter()
        .map(|&x| {
            let y = x.to_f64() * 2f64.powi(100);
            assert_eq!(y.fract(), 0.0, "mass {} below the fixed-point unit", x.to_f64());
            y as i128
        })
        .sum()
}

#[derive(Clone, Copy, Debug)]
enum Shape {
    Ball,
    Cloth,
    Torus,
}

fn model_of(shape: Shape) -> Model<f64> {
    let mut b = ModelBuilder::new();
    let brk = Some(Breakable { strain_limit: 0.5, load_limit: 10.0, sealed: false, ..Default::default() });
    match shape {
        Shape::Ball => {
            let opts = SoftBodyOptions {
                gas: Gas::Pressure(1000.0),
                bending: Some(Stiffness::Membrane(10.0)),
                fracture: brk,
                ..Default::default()
            };
            b.add_soft_body(&Mesh::icosphere(0.3, 2), &opts).unwrap();
        }
        Shape::Cloth => {
            let opts = ClothOptions { fracture: brk, pins: vec![0], ..Default::default() };
            b.add_cloth_grid(7, 6, 0.1, |p| p, &opts).unwrap();
        }
        Shape::Torus => {
            let text = include_str!("../data/torus.obj");
            let mesh = Mesh::parse_obj(text, Some(1e-6)).unwrap();
            assert!(mesh.is_closed(), "the seamed torus welds closed");
            let opts = SoftBodyOptions { gas: Gas::Pressure(500.0), fracture: brk, ..Default::default() };
            b.add_soft_body(&mesh, &opts).unwrap();
        }
    }
    b.finalize().unwrap()
}

/// Applies `ops` (`(core?, pick)`) to a fresh model of `shape`, checking every invariant after each split.
fn run_sequence(shape: Shape, ops: &[(bool, u64)], seed: u64) -> Result<(), TestCaseError> {
    let mut m = model_of(shape);
    let mut s = m.state();
    let mut rng = Rng(seed);
    for v in &mut s.particle_qd {
        *v = rng.vec();
    }
    let mass0 = exact_mass(&m);
    let p0 = m.momentum(&s);
    let scale: f64 = m.particle_mass.iter().sum::<f64>() * 2.0;
    let mut f = Fracture::<f64>::default();
    for &(core, pick) in ops {
        let before = m.clone();
        let delta = if core {
            let v = (pick % m.particle_count() as u64) as usize;
            f.break_core(&mut m, &mut s, v)
        } else {
            let sp = (pick % m.spring_count() as u64) as usize;
            f.break_spring(&mut m, &mut s, sp)
        };
        let events = &delta.events;
        if let Err(e) =
            check_invariants(&m).map_err(|e| e.to_string()).and_then(|_| delta_names_every_change(&before, &m, &delta))
        {
            return Err(TestCaseError::fail(format!("{shape:?} after {events:?}: {e}")));
        }
        prop_assert_eq!(s.particle_q.len(), m.particle_count());
        prop_assert_eq!(exact_mass(&m), mass0, "mass changed");
        let dp = (m.momentum(&s) - p0).length();
        prop_assert!(dp <= 1e-13 * scale, "momentum changed by {dp}");
        for (t, tri) in m.tri_indices.iter().enumerate() {
            let [a, b, c] = tri.map(|v| s.particle_q[v as usize]);
            prop_assert!((b - a).cross(c - a).length() > 0.0, "triangle {t} has zero area");
        }
        for e in events {
            prop_assert!(e.new_particles.iter().all(|&p| (p as usize) < m.particle_count()));
        }
    }
    Ok(())
}

/// Whether `d` names every existing particle, spring, triangle and adjacency row that differs between `before` and
/// `after` (a mirror that re-copies only what the delta names, the GPU's, then equals the model), and flags a
/// change of any existing body.
fn delta_names_every_change(before: &Model<f64>, after: &Model<f64>, d: &TopologyDelta) -> Result<(), String> {
    let [n0, s0, t0, b0] = d.old_counts;
    let counts = [before.particle_count(), before.spring_count(), before.tri_count(), before.body_count()];
    if counts != d.old_counts {
        return Err(format!("old counts {:?}, the model had {counts:?}", d.old_counts));
    }
    let named = |list: &[u32], k: usize| list.binary_search(&(k as u32)).is_ok();
    macro_rules! each_changed {
        ($n:expr, $list:expr, $what:literal, [$($f:ident),*]) => {
            for k in 0..$n {
                $( if before.$f[k] != after.$f[k] && !named($list, k) {
                    return Err(format!("{} {k}: {} changed and the delta does not name it", $what, stringify!($f)));
                } )*
            }
        };
    }
    each_changed!(n0, &d.particles, "particle", [particle_mass, particle_inv_mass, particle_body, particle_load_limit]);
    each_changed!(
        s0,
        &d.springs,
        "spring",
        [spring_indices, spring_rest_length, spring_stiffness, spring_damping, spring_kind, spring_strain_limit]
    );
    each_changed!(t0, &d.triangles, "triangle", [tri_indices, tri_body]);
    if !d.rows_compacted {
        for k in 0..n0 {
            let same = before.particle_springs.row(k) == after.particle_springs.row(k)
                && before.particle_tris.row(k) == after.particle_tris.row(k);
            if !same && !named(&d.rows, k) {
                return Err(format!("particle {k}: its adjacency rows changed and the delta does not name it"));
            }
        }
    }
    let bodies_changed = (0..b0).any(|b| {
        before.body_gas_amount[b] != after.body_gas_amount[b] || before.body_anchor[b] != after.body_anchor[b]
    });
    if bodies_changed && !(d.gas || d.openings || after.body_count() != b0) {
        return Err("a body changed and the delta flags no body change".into());
    }
    Ok(())
}

fn ops() -> impl Strategy<Value = Vec<(bool, u64)>> {
    prop::collection::vec((prop::bool::weighted(0.25), any::<u64>()), 1..40)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn random_fractures_keep_invariants_on_icospheres(ops in ops(), seed in any::<u64>()) {
        run_sequence(Shape::Ball, &ops, seed)?;
    }

    #[test]
    fn random_fractures_keep_invariants_on_grids(ops in ops(), seed in any::<u64>()) {
        run_sequence(Shape::Cloth, &ops, seed)?;
    }

    #[test]
    fn random_fractures_keep_invariants_on_an_imported_obj(ops in ops(), seed in any::<u64>()) {
        run_sequence(Shape::Torus, &ops, seed)?;
    }
}

/// A sheet pinned along its top row, its lower half thrown downwards: springs across the middle pass their limit,
/// the crack runs across the sheet, and the lower part comes off as its own body.
#[test]
fn a_torn_sheet_detaches_its_lower_half() {
    let n = 12;
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = ClothOptions {
        pins: (0..n).collect(),
        fracture: Some(Breakable { strain_limit: 0.3, ..Default::default() }),
        mass: Mass::PerParticle(1e-3),
        ..Default::default()
    };
    b.add_cloth_grid(n, n, 0.02, |p| p, &opts).unwrap();
    let mut m: Model<f64> = b.finalize().unwrap();
    let mut s = m.state();
    for i in n * n / 2..n * n {
        s.particle_qd[i] = DVec3::new(0.0, -20.0, 0.0);
    }
    let mass0 = exact_mass(&m);
    let mut solver = CpuSolver::with_integrator(Integrator::SymplecticEuler);
    let mut f = Fracture::<f64>::default();
    let mut events = Vec::new();
    for _ in 0..4000 {
        solver.step(&m, &mut s, 2e-5).unwrap();
        let e = f.apply(&mut m, &mut s, 2e-5).events;
        if !e.is_empty() {
            solver.notify_model_changed(&m, &TopologyDelta::whole());
        }
        check_invariants(&m).unwrap();
        events.extend(e);
    }
    assert_eq!(exact_mass(&m), mass0);
    let springs = events.iter().filter(|e| e.kind == FractureKind::Spring).count();
    let detach = events.iter().filter(|e| e.kind == FractureKind::Detach).count();
    assert!(springs >= n - 1, "{springs} springs broke");
    assert!(detach >= 1, "nothing detached: {events:?}");
    assert!(m.body_count() >= 2);
    assert!(m.components().0 >= 2);
    // The detached part moves away; the pinned row stays.
    let lowest = s.particle_q.iter().map(|x| x.y).fold(f64::INFINITY, f64::min);
    assert!(lowest < -0.5, "lowest point {lowest}");
    assert!(s.particle_q.iter().all(|x| x.is_finite()));
}

fn balloon(sealed: bool) -> (Model<f64>, State<f64>) {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2000.0),
        stiffness: Stiffness::Membrane(500.0),
        damping: Damping::Ratio(0.3),
        fracture: Some(Breakable { sealed, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.2, 3), &opts).unwrap();
    let m: Model<f64> = b.finalize().unwrap();
    let s = m.state();
    (m, s)
}

/// A core block breaks out of a balloon: a new body, one opening, mass exact, the capped volume independent of
/// the origin, and the pressure force still summing to zero.
#[test]
fn a_core_block_breaks_out_and_leaves_a_capped_opening() {
    let (mut m, mut s) = balloon(false);
    let mass0 = exact_mass(&m);
    let v0 = m.body_volumes(&s)[0];
    let mut f = Fracture::<f64>::default();
    let ev = f.break_core(&mut m, &mut s, 7).events;
    assert_eq!(ev.len(), 1);
    assert_eq!(ev[0].kind, FractureKind::Core);
    check_invariants(&m).unwrap();
    assert_eq!(exact_mass(&m), mass0);
    assert_eq!(m.body_count(), 2);
    assert_eq!(m.components().0, 2);
    assert_eq!(m.openings.len(), 1);
    assert_eq!(m.openings[0].body, 0);
    // The hole is small and the cap closes it: the volume is about the sphere's.
    let v1 = m.body_volumes(&s)[0];
    assert!((v1 / v0 - 1.0).abs() < 0.01, "capped volume {v1} vs {v0}");
    // Independent of the origin.
    let mut shifted = s.clone();
    for x in &mut shifted.particle_q {
        *x += DVec3::new(50.0, -20.0, 7.0);
    }
    let v2 = m.body_volumes(&shifted)[0];
    assert!((v2 - v1).abs() < 1e-9 * v1, "{v2} vs {v1}");
    // Net internal force (no gravity) is zero: the caps take the gas's push on the hole.
    let mut solver = CpuSolver::<f64>::default();
    let mut out = vec![DVec3::ZERO; m.particle_count()];
    solver.compute_forces(&m, &s, &mut out).unwrap();
    let net: DVec3 = out.iter().sum();
    let scale: f64 = out.iter().map(|f| f.length()).sum();
    assert!(net.length() < 1e-10 * scale, "net force {net} (scale {scale})");
}

/// A punctured balloon loses gas through its opening and shrinks (the seed's Fig. 6, right); a sealed one keeps
/// its gas.
#[test]
fn a_punctured_balloon_leaks_and_shrinks_unless_sealed() {
    let mut results = Vec::new();
    for sealed in [false, true] {
        let (mut m, mut s) = balloon(sealed);
        let mut f = Fracture::<f64>::default();
        let mut solver = CpuSolver::with_integrator(Integrator::SymplecticEuler);
        // Inflate: the gas stretches the membrane well past its rest shape.
        for _ in 0..3000 {
            solver.step(&m, &mut s, 1e-4).unwrap();
        }
        let gas0 = m.body_gas_amount[0];
        let v0 = m.body_volumes(&s)[0];
        // Punctures at the icosahedron's twelve vertices (the ones with five springs), far apart.
        let corners: Vec<usize> = (0..m.particle_count()).filter(|&i| m.particle_springs.row(i).len() == 5).collect();
        assert_eq!(corners.len(), 12);
        for v in corners {
            assert!(!f.break_core(&mut m, &mut s, v).events.is_empty());
        }
        assert_eq!(m.openings.len(), 12);
        solver.notify_model_changed(&m, &TopologyDelta::whole());
        check_invariants(&m).unwrap();
        let mut vols = vec![v0];
        for k in 0..10000 {
            solver.step(&m, &mut s, 1e-4).unwrap();
            f.apply(&mut m, &mut s, 1e-4);
            if k % 2000 == 1999 {
                vols.push(m.body_volumes(&s)[0]);
            }
        }
        let gas1 = m.body_gas_amount[0];
        results.push((sealed, gas0, gas1, vols.clone()));
        if sealed {
            assert_eq!(gas1, gas0, "sealed: gas kept");
        } else {
            assert!(gas1 < 0.5 * gas0, "gas {gas0} -> {gas1}");
            assert!(vols.last().unwrap() < &(0.85 * v0), "volumes {vols:?}");
        }
    }
    let (_, _, _, open) = &results[0];
    let (_, _, _, sealed) = &results[1];
    assert!(open.last().unwrap() < &(0.85 * sealed.last().unwrap()), "open {open:?} sealed {sealed:?}");
}

/// The time-averaged trigger (Bao et al. 2007) ignores a one-step spike that breaks at once under the
/// instantaneous trigger, and breaks under a sustained overload.
#[test]
fn the_averaged_trigger_needs_a_sustained_overload() {
    let build = || {
        let mut b = ModelBuilder::new();
        b.gravity(DVec3::ZERO).unwrap();
        let opts = ClothOptions {
            fracture: Some(Breakable { strain_limit: 0.2, ..Default::default() }),
            shear: None,
            bending: None,
            ..Default::default()
        };
        b.add_cloth_grid(3, 3, 0.1, |p| p, &opts).unwrap();
        b.finalize::<f64>().unwrap()
    };
    let stretch = |s: &mut State<f64>, k: f64| {
        for i in 0..9 {
            s.particle_q[i].x = (i % 3) as f64 * 0.1 * k;
        }
    };
    let dt = 1e-3;
    // Instant: one stretched step breaks.
    let mut m = build();
    let mut s = m.state();
    let mut f = Fracture::<f64>::default();
    stretch(&mut s, 1.5);
    assert!(!f.apply(&mut m, &mut s, dt).events.is_empty());
    // Averaged over 20 ms: one stretched step does not, twenty back-to-back do.
    let cfg = FractureConfig { trigger: Trigger::Averaged { window: 0.02 }, ..Default::default() };
    let mut m = build();
    let mut s = m.state();
    let mut f = Fracture::<f64>::new(cfg);
    stretch(&mut s, 1.5);
    assert!(f.apply(&mut m, &mut s, dt).events.is_empty());
    stretch(&mut s, 1.0);
    for _ in 0..50 {
        assert!(f.apply(&mut m, &mut s, dt).events.is_empty());
    }
    stretch(&mut s, 1.5);
    let mut broke_at = None;
    for k in 0..100 {
        if !f.apply(&mut m, &mut s, dt).events.is_empty() {
            broke_at = Some(k);
            break;
        }
    }
    let k = broke_at.expect("a sustained overload breaks");
    // 1 - exp(-t/τ) > 0.2/0.5 = 0.4 needs t > τ ln(1/0.6) ≈ 10 ms.
    assert!((8..=12).contains(&k), "broke after {k} steps");
}

/// Fracture runs are bit-identical on 1 and 4 threads.
#[test]
fn fracture_is_deterministic_across_thread_counts() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut b = ModelBuilder::new();
            let opts = SoftBodyOptions {
                gas: Gas::Pressure(4000.0),
                velocity: DVec3::new(0.0, -6.0, 0.0),
                fracture: Some(Breakable { strain_limit: 0.15, load_limit: 2.0, sealed: false, ..Default::default() }),
                ..Default::default()
            };
            b.add_soft_body(&Mesh::icosphere(0.2, 3).translated(DVec3::new(0.0, 0.25, 0.0)), &opts).unwrap();
            b.add_collider(Collider::ground(0.0)).unwrap();
            b.add_collider(Collider::ball(fissure_core::glam::Vec3::new(0.05, 0.0, 0.0), 0.06)).unwrap();
            let m: Model<f32> = b.finalize().unwrap();
            let mut w_model = m;
            let mut s = w_model.state();
            let mut solver = CpuSolver::with_integrator(Integrator::SymplecticEuler);
            let mut f = Fracture::<f32>::default();
            let mut events = Vec::new();
            for _ in 0..1500 {
                solver.step(&w_model, &mut s, 5e-5).unwrap();
                let e = f.apply(&mut w_model, &mut s, 5e-5).events;
                if !e.is_empty() {
                    solver.notify_model_changed(&w_model, &TopologyDelta::whole());
                }
                events.extend(e);
            }
            let bits: Vec<u32> = s.particle_q.iter().flat_map(|x| x.to_array()).map(f32::to_bits).collect();
            (bits, events.len(), w_model.tri_indices.clone())
        })
    };
    let (a, na, ta) = run(1);
    let (b, nb, tb) = run(4);
    assert!(na > 0, "the scene must break for this test to mean anything");
    assert_eq!(na, nb);
    assert_eq!(ta, tb);
    assert!(a == b, "positions differ between 1 and 4 threads");
}

/// No breakable spring or vertex: the fracture pass does nothing, and its timer shows no call.
#[test]
fn no_fracture_work_without_breakable_springs() {
    let mut b = ModelBuilder::new();
    b.add_soft_body(&Mesh::icosphere(0.2, 2), &SoftBodyOptions::default()).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    assert!(!m.has_fracture());
    let mut s = m.state();
    let mut f = Fracture::<f32>::default();
    for _ in 0..10 {
        assert!(f.apply(&mut m, &mut s, 1e-4).events.is_empty());
    }
    assert_eq!(f.timers().calls(Stage::Fracture), 0);
    // Breakable but unbroken: the checks run (and are timed).
    let mut b = ModelBuilder::new();
    let opts =
        SoftBodyOptions { fracture: Some(Breakable { strain_limit: 1.0, ..Default::default() }), ..Default::default() };
    b.add_soft_body(&Mesh::icosphere(0.2, 2), &opts).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    for _ in 0..10 {
        assert!(f.apply(&mut m, &mut s, 1e-4).events.is_empty());
    }
    assert_eq!(f.timers().calls(Stage::Fracture), 10);
}

/// The trigger's inputs as the CPU solver measures them during a step (`CpuSolver::measures`, which the fracture
/// pass reads instead of recomputing) agree with the same quantities computed independently in `f64` from the
/// state the step started from: each spring's strain, each particle's load `|Σ elastic pulls + pressure shares|`
/// and each gas body's capped volume (a punctured ball, so the caps over the opening count).
#[test]
fn solver_measures_match_an_independent_f64_computation() {
    use fissure_core::forces::{pressure, spring};
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(2000.0),
        fracture: Some(Breakable { strain_limit: 0.4, load_limit: 50.0, sealed: false, ..Default::default() }),
        velocity: DVec3::new(0.3, -1.0, 0.0),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 3), &opts).unwrap();
    let mut m: Model<f32> = b.finalize().unwrap();
    let mut s = m.state();
    let mut f = Fracture::<f32>::default();
    assert!(!f.break_core(&mut m, &mut s, 7).events.is_empty(), "the puncture breaks");
    assert!(!m.openings.is_empty(), "the puncture opens the ball");
    let mut solver = CpuSolver::<f32>::default();
    for _ in 0..20 {
        solver.step(&m, &mut s, 1e-5).unwrap();
    }
    let s0 = s.clone();
    solver.step(&m, &mut s, 1e-5).unwrap();
    let x = solver.measures(&m).expect("a breakable model on the per-spring kernel is measured");
    let q = |i: u32| s0.particle_q[i as usize].to_dvec3();

    let mut worst_strain = 0.0f64;
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        let want = spring::strain((q(j) - q(i)).length(), m.spring_rest_length[sp] as f64);
        worst_strain = worst_strain.max((x.strain[sp] as f64 - want).abs());
    }
    assert!(worst_strain < 1e-5, "strain differs by {worst_strain:e}");

    let volumes = m.body_volumes(&s0);
    let p: Vec<f64> = (0..m.body_count())
        .map(|b| {
            let (gas, v0, ext) = (m.body_gas_amount[b], m.body_rest_volume[b], m.body_pressure_external[b]);
            pressure::gas_pressure(gas as f64, volumes[b], v0 as f64, ext as f64)
        })
        .collect();
    for (b, (&got, &want)) in x.volume.iter().zip(&volumes).enumerate() {
        if m.body_gas_amount[b] > 0.0 {
            let rel = (got as f64 - want).abs() / want;
            assert!(rel < 1e-5, "body {b}: volume {got} against {want} (relative {rel:e})");
        }
    }
    let mut checked = 0;
    for i in 0..m.particle_count() {
        if !m.particle_load_limit[i].is_finite() {
            assert_eq!(x.load[i], 0.0, "particle {i} cannot break: no load measured");
            continue;
        }
        let mut f = DVec3::ZERO;
        let mut scale = 0.0;
        for &e in m.particle_springs.row(i) {
            let sp = (e >> 1) as usize;
            let [a, c] = m.spring_indices[sp];
            let el = spring::elastic_force::<f64>(
                q(c) - q(a),
                m.spring_rest_length[sp] as f64,
                m.spring_stiffness[sp] as f64,
            );
            f += if e & 1 == 0 { el } else { -el };
            scale += el.length();
        }
        for &t in m.particle_tris.row(i) {
            let [a, c, d] = m.tri_indices[t as usize];
            let corner =
                pressure::corner_force::<f64>((q(c) - q(a)).cross(q(d) - q(a)), p[m.tri_body[t as usize] as usize]);
            f += corner;
            scale += corner.length();
        }
        let err = (x.load[i] as f64 - f.length()).abs();
        assert!(err <= 1e-5 * scale + 1e-9, "particle {i}: load {} against {} (terms {scale})", x.load[i], f.length());
        checked += 1;
    }
    assert!(checked > 600);
}

/// A model that breaks by strain alone measures strains, not loads: the strains match an independent `f64`
/// computation, every load reads 0, and the step is the same as the measured one of a model that also has
/// (unreachable) load limits, bit for bit: measuring does not change the physics.
#[test]
fn strain_only_models_measure_strains_and_skip_loads() {
    use fissure_core::forces::spring;
    let ball = |load_limit: f64| {
        let mut b = ModelBuilder::new();
        let opts = SoftBodyOptions {
            gas: Gas::Pressure(2000.0),
            fracture: Some(Breakable { strain_limit: 0.4, load_limit, ..Default::default() }),
            velocity: DVec3::new(0.3, -1.0, 0.0),
            ..Default::default()
        };
        b.add_soft_body(&Mesh::icosphere(0.25, 2), &opts).unwrap();
        b.finalize().unwrap()
    };
    let (m, loaded): (Model<f32>, Model<f32>) = (ball(f64::INFINITY), ball(1e9));
    let (mut s, mut s2) = (m.state(), loaded.state());
    let (mut solver, mut solver2) = (CpuSolver::<f32>::default(), CpuSolver::<f32>::default());
    for _ in 0..20 {
        solver.step(&m, &mut s, 1e-5).unwrap();
        solver2.step(&loaded, &mut s2, 1e-5).unwrap();
    }
    assert_eq!(s.particle_q, s2.particle_q);
    assert_eq!(s.particle_qd, s2.particle_qd);
    let s0 = s.clone();
    solver.step(&m, &mut s, 1e-5).unwrap();
    let x = solver.measures(&m).expect("a breakable model on the per-spring kernel is measured");
    let q = |i: u32| s0.particle_q[i as usize].to_dvec3();
    let mut worst = 0.0f64;
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        let want = spring::strain((q(j) - q(i)).length(), m.spring_rest_length[sp] as f64);
        worst = worst.max((x.strain[sp] as f64 - want).abs());
    }
    assert!(worst < 1e-5, "strain differs by {worst:e}");
    assert!(x.load.iter().all(|&l| l == 0.0), "no particle can break by load: no load measured");
    solver2.step(&loaded, &mut s2, 1e-5).unwrap();
    let y = solver2.measures(&loaded).unwrap();
    assert!(y.load.iter().any(|&l| l > 0.0), "the model with load limits measures its loads");
    assert_eq!(x.strain, y.strain);
}

/// A grid cloth (the run kernel) that breaks by strain gets its strains from the step itself: each spring's from
/// the block holding its end 0, written in parallel. They are the strains of the positions at the start of the
/// step, the same bits as the per-spring formula, on 1 thread and on 3 (the 128² cloth's passes are split
/// between the threads).
#[test]
fn run_kernel_measures_every_strain_once_on_any_thread_count() {
    let n = 128;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            // The benchmark cloth (1 g, 1000 N/m), stable at 2e-4 s.
            let breakable = Breakable { strain_limit: 10.0, ..Default::default() };
            let opts = common::bench_cloth_options(vec![0, n - 1], Some(breakable));
            let mut b = ModelBuilder::new();
            b.add_cloth_grid(n, n, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
            let m: Model<f32> = b.finalize().unwrap();
            assert!(!m.spring_runs.is_empty(), "a grid cloth is stepped by the run kernel");
            let mut s = m.state();
            let mut solver = CpuSolver::<f32>::default();
            for _ in 0..100 {
                solver.step(&m, &mut s, 2e-4).unwrap();
            }
            let s0 = s.clone();
            solver.step(&m, &mut s, 2e-4).unwrap();
            let strain = solver.measures(&m).expect("a breakable grid cloth is measured").strain.to_vec();
            for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
                let want = fissure_core::forces::spring::strain(
                    (s0.particle_q[j as usize] - s0.particle_q[i as usize]).length(),
                    m.spring_rest_length[sp],
                );
                assert_eq!(strain[sp].to_bits(), want.to_bits(), "spring {sp}: {} against {want}", strain[sp]);
            }
            assert!(strain.iter().any(|&e| e > 1e-5), "the cloth sags: its springs stretch");
            (strain, s.particle_q)
        })
    };
    let (one, three) = (run(1), run(3));
    assert_eq!(one, three);
}

/// Sparse strains (an instantaneous trigger: `Solver::set_instant_trigger`): the solver stores only the spans
/// of springs where a strain may pass the smallest limit, on both kernels (a ball: per spring; a grid cloth: the
/// run kernel). The spans hold the same bits as storing every strain, every spring past its limit lies in one,
/// they are the same on 1 and 3 threads, and the fracture pass breaks the same springs from them as from every
/// strain. With every strain far from its limit nothing is stored and the solver rules out candidates (`World`
/// then skips the fracture pass).
#[test]
fn sparse_strains_find_what_every_strain_finds() {
    type Run = (Vec<f32>, Option<Vec<[u32; 2]>>, bool, Model<f32>, State<f32>);
    for grid in [false, true] {
        let dt = if grid { 2e-4 } else { 1e-4 };
        let run = |threads: usize, limit: f64, sparse: bool| -> Run {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let breakable = Some(Breakable { strain_limit: limit, ..Default::default() });
                let mut b = ModelBuilder::new();
                if grid {
                    let opts = common::bench_cloth_options(vec![0, 127], breakable);
                    b.add_cloth_grid(128, 128, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
                } else {
                    let opts =
                        SoftBodyOptions { gas: Gas::Pressure(2000.0), fracture: breakable, ..Default::default() };
                    b.add_soft_body(&Mesh::icosphere(0.25, 4), &opts).unwrap();
                }
                let m: Model<f32> = b.finalize().unwrap();
                assert_eq!(m.spring_runs.is_empty(), !grid);
                let mut s = m.state();
                let mut solver = CpuSolver::<f32>::default();
                solver.set_instant_trigger(sparse);
                // The cloth sags under gravity over 40 ms; the ball's gas stretches it at once.
                for _ in 0..if grid { 200 } else { 60 } {
                    solver.step(&m, &mut s, dt).unwrap();
                }
                let x = solver.measures(&m).expect("a breakable model is measured");
                let out = (x.strain.to_vec(), x.strain_spans.map(<[_]>::to_vec));
                (out.0, out.1, solver.may_have_fracture_candidates(), m, s)
            })
        };
        // Every strain, far from the limit: the strains' spread picks a limit that some 0.5% of springs pass.
        let (all, none, may, _, _) = run(1, 10.0, false);
        assert!(none.is_none() && may);
        let mut sorted: Vec<f32> = all.clone();
        sorted.sort_by(f32::total_cmp);
        let limit = sorted[sorted.len() * 995 / 1000] as f64;
        assert!(limit > 1e-4, "grid {grid}: the body stretches (limit {limit})");
        let (far, spans, may, _, _) = run(1, 10.0, true);
        assert_eq!(spans.as_deref(), Some(&[][..]), "grid {grid}: nothing near the limit, nothing stored");
        assert!(!may, "grid {grid}: no candidate possible");
        assert_eq!(far.len(), all.len());

        let (full, _, _, mut m_full, mut s_full) = run(1, limit, false);
        let (sparse, spans, may, mut m_sparse, mut s_sparse) = run(1, limit, true);
        assert_eq!(s_full.particle_q, s_sparse.particle_q, "measuring does not change the physics");
        let spans = spans.expect("sparse");
        assert!(may);
        assert!(spans.windows(2).all(|w| w[0][1] <= w[1][0]), "spans in order, disjoint");
        let stored: usize = spans.iter().map(|[a, b]| (b - a) as usize).sum();
        // A span of the kernel stores all its strains when one is near the limit: on the ball, whose ~0.5 % of
        // springs near it lie spread over its (locality-ordered) numbering, ~27 % are stored.
        assert!(stored < full.len() / 3, "grid {grid}: {stored} of {} strains stored", full.len());
        let inside = |k: usize| spans.iter().any(|&[a, b]| (a as usize..b as usize).contains(&k));
        let mut passed = 0;
        for (k, &e) in full.iter().enumerate() {
            if inside(k) {
                assert_eq!(sparse[k].to_bits(), e.to_bits(), "grid {grid}: spring {k}");
            }
            if e as f64 > limit {
                assert!(inside(k), "grid {grid}: spring {k} passes its limit outside every span");
                passed += 1;
            }
        }
        assert!(passed > 0);
        assert_eq!(run(3, limit, true).1, Some(spans.clone()), "grid {grid}: the same spans on 3 threads");

        // The fracture pass on each solver's measures breaks the same springs.
        let deltas =
            [(&mut m_full, &mut s_full, &full, None), (&mut m_sparse, &mut s_sparse, &sparse, Some(&spans[..]))].map(
                |(m, s, strain, strain_spans)| {
                    let load = vec![0.0; m.particle_count()];
                    let volume = m.body_volumes(s).iter().map(|&v| v as f32).collect::<Vec<_>>();
                    let x = Measures { strain, strain_spans, load: &load, volume: &volume };
                    Fracture::<f32>::default().apply_measured(m, s, dt, Some(x))
                },
            );
        assert!(!deltas[0].events.is_empty(), "grid {grid}: springs break");
        assert_eq!(deltas[0], deltas[1], "grid {grid}");
    }
}

/// Core splits give a ball's fan triangles to new bodies where they lie; once enough have moved (one in 64 of the
/// triangles) on a model past one chunk of the surface pass, the fracture pass orders the triangles by body again
/// (the blocks' after the ball's) and says so (`delta.whole`). The reorder keeps every triangle and its body, the
/// invariants, and the forces (f64: the same sums in another order, to rounding).
#[test]
fn core_blocks_triangles_are_ordered_after_the_ball() {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        gas: Gas::Amount(200.0),
        fracture: Some(Breakable { strain_limit: f64::INFINITY, load_limit: 1e9, sealed: true, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 4), &opts).unwrap();
    let mut m: Model<f64> = b.finalize().unwrap();
    let (mut s, mut f) = (m.state(), Fracture::<f64>::default());
    let nt = m.tri_count();
    assert!(nt > 2048);
    let sorted_blocks = |m: &Model<f64>| m.tri_body.is_sorted();
    let (mut splits, mut wholes, mut v, mut last_whole) = (0, 0, 0, false);
    while splits < 40 {
        let d = f.break_core(&mut m, &mut s, v);
        v += 17;
        if d.events.is_empty() {
            continue;
        }
        splits += 1;
        check_invariants(&m).unwrap();
        last_whole = d.whole;
        if d.whole {
            wholes += 1;
            assert!(sorted_blocks(&m), "split {splits}: reordered, yet some block's triangles lie among the ball's");
        }
    }
    // 40 splits of five or six triangles each (~235), one reorder per 80 (5,120 / 64) moved: two or three.
    assert!((2..=3).contains(&wholes), "{wholes} reorders in 40 core splits");
    if !last_whole {
        assert!(!sorted_blocks(&m), "the last splits' triangles wait for the next reorder");
    }
    // The reorder by hand: the same triangles with the same bodies, grouped, and the same forces.
    let mut r = m.clone();
    assert!(r.order_triangles_by_body());
    assert!(sorted_blocks(&r) && !r.order_triangles_by_body(), "ordered once, then nothing to move");
    check_invariants(&r).unwrap();
    let tris = |m: &Model<f64>| {
        let mut t: Vec<([u32; 3], u32)> = m.tri_indices.iter().copied().zip(m.tri_body.iter().copied()).collect();
        t.sort_unstable();
        t
    };
    assert_eq!(tris(&m), tris(&r));
    assert_ne!(m.tri_indices, r.tri_indices);
    let (mut fm, mut fr) = (vec![DVec3::ZERO; m.particle_count()], vec![DVec3::ZERO; m.particle_count()]);
    CpuSolver::<f64>::default().compute_forces(&m, &s, &mut fm).unwrap();
    CpuSolver::<f64>::default().compute_forces(&r, &s, &mut fr).unwrap();
    let scale = fm.iter().map(|x| x.length()).fold(0.0, f64::max);
    let worst = fm.iter().zip(&fr).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    assert!(scale > 0.0 && worst <= 1e-12 * scale, "forces differ by {worst} N (largest {scale} N)");
}
