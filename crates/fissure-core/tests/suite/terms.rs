//! Wind physics, and "a scene pays only for what it uses": absent terms are never entered (stage timers).

use fissure_core::glam::DVec3;
use fissure_core::*;

fn sheet(wind: Option<WindField>, velocity: DVec3) -> (Model<f64>, State<f64>) {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).unwrap();
    let opts = ClothOptions { mass: Mass::PerParticle(1e-3), ..Default::default() };
    // A sheet in the XY plane: its normal is z.
    b.add_cloth_grid(8, 8, 0.05, |p| p, &opts).unwrap();
    if let Some(w) = wind {
        b.wind(w).unwrap();
    }
    let model: Model<f64> = b.finalize().unwrap();
    let mut s = model.state();
    s.particle_qd.iter_mut().for_each(|v| *v = velocity);
    (model, s)
}

fn net_force(model: &Model<f64>, s: &State<f64>) -> DVec3 {
    let mut f = vec![DVec3::ZERO; model.particle_count()];
    CpuSolver::<f64>::default().compute_forces(model, s, &mut f).unwrap();
    f.iter().copied().sum()
}

#[test]
fn face_on_wind_pushes_with_the_drag_formula() {
    // Steady 5 m/s face-on wind, sheet at rest: drag ½ ρ C_D A |n·v| v, no lift (n ∥ v).
    let u = 5.0;
    let (model, s) = sheet(Some(WindField::steady(DVec3::new(0.0, 0.0, u))), DVec3::ZERO);
    let f = net_force(&model, &s);
    let area = 0.35 * 0.35;
    let expected = 0.5 * 1.225 * 1.0 * area * u * u;
    assert!((f.z - expected).abs() < 1e-9 * expected, "drag {} N vs ½ρC_D A u² = {expected} N", f.z);
    assert!(f.x.abs() < 1e-12 && f.y.abs() < 1e-12, "no sideways force face-on: {f:?}");
}

#[test]
fn edge_on_wind_and_co_moving_sheet_feel_nothing() {
    let (model, s) = sheet(Some(WindField::steady(DVec3::new(4.0, 0.0, 0.0))), DVec3::ZERO);
    assert!(net_force(&model, &s).length() < 1e-12, "wind along the sheet's plane");
    let w = DVec3::new(1.0, -2.0, 3.0);
    let (model, s) = sheet(Some(WindField::steady(w)), w);
    assert!(net_force(&model, &s).length() < 1e-12, "sheet moving with the air");
}

#[test]
fn oblique_wind_gives_lift_across_the_flow() {
    // Wind at 45° to the sheet: the force has a component perpendicular to the flow (lift), magnitude
    // ½ ρ C_L A (n·v)|v| sin θ = ½ ρ C_L A u² / 2 at 45°.
    let u = 4.0;
    let dir = DVec3::new(1.0, 0.0, 1.0).normalize();
    let (model, s) = sheet(Some(WindField::steady(dir * u)), DVec3::ZERO);
    let f = net_force(&model, &s);
    let across = f - dir * f.dot(dir);
    let area = 0.35 * 0.35;
    let expected_lift = 0.5 * 1.225 * 0.5 * area * u * u * 0.5;
    assert!((across.length() - expected_lift).abs() < 1e-9, "lift {} N vs {expected_lift} N", across.length());
}

/// In a gusty field each triangle feels the air relative to it as the mean of its corners' `w(x_i) - v_i` (the
/// field sampled once per particle: `forces::wind`'s docs), with the module's drag and lift: the net force on a
/// sheet equals that formula summed in `f64` from `WindField::sample`, and differs from the field sampled at the
/// centroids (so a pass sampling centroids fails this test). Short gusts (0.4 m on 5 cm cells) across the sheet.
#[test]
fn gusty_wind_acts_through_the_mean_of_the_corners_relative_air() {
    let wind = WindField { velocity: DVec3::new(3.0, 0.5, 2.0), gust_wavelength: 0.4, ..Default::default() };
    let (model, mut s) = sheet(Some(wind.clone()), DVec3::ZERO);
    s.time = 0.3;
    for (k, v) in s.particle_qd.iter_mut().enumerate() {
        *v = DVec3::new((k as f64 * 0.7).sin(), 0.2, (k as f64 * 0.3).cos()) * 0.4;
    }
    let f = net_force(&model, &s);
    let aero = |c: DVec3, v: DVec3| {
        let (s, vv) = (c.dot(v), v.dot(v));
        let root = (c.length_squared() * vv).sqrt();
        let quarter = 0.25 * 1.225;
        // A third on each corner: the whole force per triangle.
        v * (quarter * 1.0 * s.abs()) + (c * vv - v * s) * (quarter * 0.5 * s / root)
    };
    let (mut corners, mut centroids) = (DVec3::ZERO, DVec3::ZERO);
    for &[a, b, c] in &model.tri_indices {
        let [a, b, c] = [a, b, c].map(|i| i as usize);
        let (q, v) = (&s.particle_q, &s.particle_qd);
        let cross = (q[b] - q[a]).cross(q[c] - q[a]);
        let rel = [a, b, c].iter().map(|&i| wind.sample(q[i], s.time) - v[i]).sum::<DVec3>() / 3.0;
        corners += aero(cross, rel);
        let mid = (q[a] + q[b] + q[c]) / 3.0;
        centroids += aero(cross, wind.sample(mid, s.time) - (v[a] + v[b] + v[c]) / 3.0);
    }
    let scale = corners.length();
    assert!(scale > 0.1, "the gusts push the sheet ({scale} N)");
    assert!((f - corners).length() < 1e-9 * scale, "net {f:?} N vs the corners' formula {corners:?} N");
    assert!((corners - centroids).length() > 1e-4 * scale, "the two quadratures differ on short gusts");
}

#[test]
fn gusty_wind_varies_in_space_and_time() {
    let w = WindField::default();
    let a = w.sample(DVec3::ZERO, 0.0);
    assert_ne!(a, w.sample(DVec3::ZERO, 0.7));
    assert_ne!(a, w.sample(DVec3::new(1.3, 0.0, 0.0), 0.0));
    assert_eq!(w.sample(DVec3::new(0.2, 1.0, 0.3), 1.5), w.sample(DVec3::new(0.2, 1.0, 0.3), 1.5));
    // Mean over a long time is the mean wind.
    let mean: DVec3 = (0..20000).map(|k| w.sample(DVec3::ZERO, k as f64 * 0.01)).sum::<DVec3>() / 20000.0;
    assert!((mean - w.velocity).length() < 0.05 * w.velocity.length(), "mean wind {mean:?}");
}

/// The force pass samples the wind through `WindField::prepare` (phases reduced once per step, polynomial sines):
/// it agrees with the `f64` reference `WindField::sample` to f32 rounding in `f32` and to 1e-10 in `f64` (at
/// t = 1e5 s the reference's own phase, 3e5 rad, carries 6e-11 of rounding), and far from the origin; the sine
/// itself to 1e-6 / 1e-14.
#[test]
fn prepared_wind_matches_the_reference_field() {
    let w = WindField { velocity: DVec3::new(3.0, 0.5, 4.0), crosswind: 0.3, ..Default::default() };
    let mut worst = (0.0f64, 0.0f64);
    for (k, t) in [0.0, 0.013, 1.7, 33.3, 1e5 + 0.25].into_iter().enumerate() {
        let p32 = w.prepare::<f32>(t);
        let p64 = w.prepare::<f64>(t);
        for j in 0..200 {
            let x = DVec3::new(j as f64 * 0.37 - 30.0, (j % 7) as f64 * 0.5, (k * j % 11) as f64 - 5.0);
            let want = w.sample(x, t);
            let got32 = p32.sample(x.as_vec3()).as_dvec3();
            let got64 = p64.sample(x);
            worst.0 = worst.0.max((got32 - want).length() / w.velocity.length());
            worst.1 = worst.1.max((got64 - want).length() / w.velocity.length());
        }
    }
    assert!(worst.0 < 2e-5 && worst.1 < 1e-10, "relative wind error f32 {:e}, f64 {:e}", worst.0, worst.1);
    for k in -2000..2000 {
        let x = k as f64 * 0.01 + 0.003;
        assert!((fissure_core::wind::sin(x as f32) as f64 - x.sin()).abs() < 1e-6 * (1.0 + x.abs()), "sin {x}");
        assert!((fissure_core::wind::sin(x) - x.sin()).abs() < 1e-14, "sin {x} in f64");
    }
}

#[test]
fn absent_terms_are_never_entered() {
    let cases: [(&str, bool, bool, bool); 4] = [
        ("bare cloth", false, false, false),
        ("wind", true, false, false),
        ("gas", false, true, false),
        ("colliders", false, false, true),
    ];
    for (name, wind, gas, colliders) in cases {
        let mut b = ModelBuilder::new();
        b.add_cloth_grid(8, 8, 0.05, |p| p, &ClothOptions { aero: Aero::default(), ..Default::default() }).unwrap();
        if wind {
            b.wind(WindField::default()).unwrap();
        }
        if gas {
            b.add_soft_body(
                &Mesh::icosphere(0.1, 1).translated(DVec3::new(0.0, 1.0, 0.0)),
                &SoftBodyOptions::default(),
            )
            .unwrap();
        } else {
            b.add_soft_body(
                &Mesh::icosphere(0.1, 1).translated(DVec3::new(0.0, 1.0, 0.0)),
                &SoftBodyOptions { gas: Gas::None, ..Default::default() },
            )
            .unwrap();
        }
        if colliders {
            b.add_collider(Collider::ground(-5.0)).unwrap();
        }
        let model: Model<f32> = b.finalize().unwrap();
        assert_eq!(model.has_wind(), wind, "{name}");
        assert_eq!(model.has_pressure(), gas, "{name}");
        let mut s = model.state();
        let mut solver = CpuSolver::<f32>::default();
        for _ in 0..10 {
            solver.step(&model, &mut s, 1e-4).unwrap();
        }
        let t = solver.timers();
        assert_eq!(t.calls(Stage::Surface) > 0, wind || gas, "{name}: surface pass");
        assert_eq!(t.calls(Stage::Collide) > 0, colliders, "{name}: collision pass");
        assert_eq!(t.calls(Stage::Solve), 0, "{name}: no linear solve under symplectic Euler");
        if !(wind || gas) {
            assert_eq!(t.time(Stage::Surface), std::time::Duration::ZERO);
        }
    }
}

/// Symplectic Euler on a grid cloth resolves the colliders inside its spring-run pass (each block right after
/// its update) instead of in a collision pass of its own: the same bits as stepping without colliders and then
/// resolving every particle against them in order, sweeping until clear (the collision pass's rule), on 1 and
/// on 3 threads (a 128² cloth's passes go to the pool). The stage timers still show the collision work.
#[test]
fn colliders_in_the_run_pass_give_the_collision_pass_bits() {
    use fissure_core::glam::Vec3;
    let build = |colliders: bool| -> Model<f32> {
        let mut b = ModelBuilder::new();
        let opts = ClothOptions { mass: Mass::PerParticle(1e-3), pins: vec![0, 127], ..Default::default() };
        b.add_cloth_grid(128, 128, 0.01, |p| DVec3::new(p.x, 1.0, p.y), &opts).unwrap();
        if colliders {
            b.add_collider(Collider::ground(0.9995)).unwrap();
            b.add_collider(Collider::ball(Vec3::new(0.3, 0.8, 0.3), 0.2)).unwrap();
        }
        b.finalize().unwrap()
    };
    let (with, without) = (build(true), build(false));
    assert!(!with.spring_runs.is_empty(), "a grid cloth is stepped by the run kernel");
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let (mut a, mut b) = (CpuSolver::<f32>::default(), CpuSolver::<f32>::default());
            let mut s = with.state();
            let mut touched = 0;
            for _ in 0..150 {
                let mut free = s.clone();
                a.step(&with, &mut s, 1e-4).unwrap();
                b.step(&without, &mut free, 1e-4).unwrap();
                for i in 0..free.particle_q.len() {
                    if with.particle_inv_mass[i] == 0.0 {
                        continue;
                    }
                    let (mut x, mut v) = (free.particle_q[i], free.particle_qd[i]);
                    for _ in 0..3 {
                        let mut any = false;
                        for c in &with.colliders {
                            if let Some((x2, v2)) = c.resolve(free.time, x, v) {
                                (x, v, any) = (x2, v2, true);
                            }
                        }
                        if !any {
                            break;
                        }
                        touched += 1;
                    }
                    (free.particle_q[i], free.particle_qd[i]) = (x, v);
                }
                assert_eq!(s.particle_q, free.particle_q);
                assert_eq!(s.particle_qd, free.particle_qd);
            }
            assert!(touched > 10_000, "the cloth lands on the ground and the ball ({touched} contacts)");
            assert_eq!(a.timers().calls(Stage::Collide), 150, "the collision work is timed");
            s
        })
    };
    assert_eq!(run(1).particle_q, run(3).particle_q);
}
