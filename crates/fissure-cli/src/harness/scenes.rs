//! The harness's scenes. All smooth (no collisions, no fracture) where accuracy is measured, so an integrator's
//! order shows.

use fissure::glam::DVec3;
use fissure::*;

/// A scene to integrate: its builder, how long to run, and its step sweep.
pub struct Scene {
    /// Name used in tables and file names.
    pub name: String,
    /// What it is, for the report.
    pub about: String,
    /// The model.
    pub builder: ModelBuilder,
    /// Simulated time \[s\].
    pub t_end: f64,
    /// A displacement \[m\] of one particle applied to the initial state (springs take their rest length from the
    /// builder's positions, so a stretched start is set on the state).
    pub displace: Option<(usize, DVec3)>,
    /// Steps to cover `t_end` in the work–precision sweep, coarse to fine.
    pub steps: Vec<usize>,
}

/// A 1 kg mass on a 100 N/m spring to a fixed anchor (ω = 10 rad/s), released 0.1 m from rest; no gravity,
/// no damping; 2 s (about 3 periods). The closed form is `x(t) = 0.1 cos(10 t)`.
pub fn oscillator(quick: bool) -> Scene {
    let mut b = ModelBuilder::new();
    b.gravity(DVec3::ZERO).expect("valid");
    let anchor = b.add_particle(DVec3::ZERO, DVec3::ZERO, 0.0).expect("valid");
    let mass = b.add_particle(DVec3::new(1.0, 0.0, 0.0), DVec3::ZERO, 1.0).expect("valid");
    b.add_spring(anchor, mass, 100.0, 0.0).expect("valid");
    // First-order methods need ωh ≲ 0.01 to be asymptotic here; the sweep is cheap (one particle).
    let steps = (0..if quick { 9 } else { 11 }).map(|k| 100usize << k).collect();
    Scene {
        name: "oscillator".into(),
        about: "1 kg on 100 N/m (ω = 10 rad/s), released 0.1 m from rest, 2 s".into(),
        builder: b,
        t_end: 2.0,
        displace: Some((mass, DVec3::new(0.1, 0.0, 0.0))),
        steps,
    }
}

impl Scene {
    /// The model in precision `R` and its initial state.
    pub fn initial<R: Real>(&self) -> Result<(Model<R>, State<R>), String> {
        let model: Model<R> = self.builder.finalize().map_err(|e| e.to_string())?;
        let mut s = model.state();
        if let Some((i, d)) = self.displace {
            s.particle_q[i] = R::V::from_dvec3(s.particle_q[i].to_dvec3() + d);
        }
        Ok((model, s))
    }
}

/// Warp's cloth benchmark layout: `n × n` particles at 0.1 m spacing, 0.1 kg each, structural, shear and bending
/// springs of 1000 N/m with 10 N·s/m damping, horizontal, held along one edge (Warp's `fix_left`), falling under
/// gravity. 0.25 s (15 frames at 60 fps); the sweep runs 16 to 256 substeps per 1/60 s frame.
pub fn warp_cloth(n: usize, quick: bool) -> Scene {
    let mut b = ModelBuilder::new();
    let opts = ClothOptions {
        mass: Mass::PerParticle(0.1),
        stiffness: Stiffness::PerSpring(1000.0),
        shear: Some(Stiffness::PerSpring(1000.0)),
        bending: Some(Stiffness::PerSpring(1000.0)),
        damping: Damping::PerSpring(10.0),
        pins: (0..n).map(|j| j * n).collect(),
        aero: Aero::NONE,
        fracture: None,
    };
    b.add_cloth_grid(n, n, 0.1, |p| DVec3::new(p.x, 4.0, p.y), &opts).expect("valid cloth");
    let frames = 15;
    let subs: &[usize] = if quick { &[16, 32, 64, 128] } else { &[16, 32, 64, 128, 256, 512] };
    Scene {
        name: format!("cloth{n}"),
        about: format!(
            "Warp cloth {n}² (0.1 m, 0.1 kg, k = 1000 N/m, c = 10 N·s/m), held along one edge, 0.25 s; 16–{} substeps per 1/60 s",
            subs.last().copied().unwrap_or(16)
        ),
        builder: b,
        t_end: frames as f64 / 60.0,
        displace: None,
        steps: subs.iter().map(|s| s * frames).collect(),
    }
}

/// A pressurised ball (icosphere, 642 vertices, r = 0.25 m, 0.4 kg, membrane springs 2500 N/m, damping ratio
/// 0.05, 2500 Pa) released in free fall with a spin, inflating from its rest shape; 0.1 s.
pub fn ball(quick: bool) -> Scene {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        mass: Mass::Total(0.4),
        stiffness: Stiffness::Membrane(2500.0),
        damping: Damping::Ratio(0.05),
        bending: None,
        gas: Gas::Pressure(2500.0),
        velocity: DVec3::new(0.5, 0.0, 0.0),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.25, 3), &opts).expect("valid ball");
    let steps = if quick { vec![400, 800, 1600, 3200] } else { vec![400, 800, 1600, 3200, 6400, 12800] };
    Scene {
        name: "ball".into(),
        about: "pressurised icosphere (642 vertices, 2500 Pa, membrane 2500 N/m, damping ratio 0.05), free fall, 0.1 s"
            .into(),
        builder: b,
        t_end: 0.1,
        displace: None,
        steps,
    }
}

/// A cloth held along two opposite edges (a sheet between two bars), `n × n` at 0.1 m, 0.02 kg per particle
/// (0.2 kg/m², the builder's default cloth density), structural, shear and bending springs of stiffness `k` with
/// 10 N·s/m damping in the seed's form (eq. 2, `kd (v_j - v_i)`, which damps all relative motion, so the sheet
/// settles within the 2 s the large-step check runs it; with damping along the springs only its sag still swings
/// by ±50% at 2 s, and the check would compare phases of an oscillation, not the sag), released flat.
pub fn sheet_between_bars(n: usize, k: f64) -> ModelBuilder {
    let mut b = ModelBuilder::new();
    b.damping_model(DampingModel::Unprojected);
    let opts = ClothOptions {
        mass: Mass::PerParticle(0.02),
        stiffness: Stiffness::PerSpring(k),
        shear: Some(Stiffness::PerSpring(k)),
        bending: Some(Stiffness::PerSpring(k)),
        damping: Damping::PerSpring(10.0),
        pins: (0..n).flat_map(|j| [j * n, j * n + n - 1]).collect(),
        aero: Aero::NONE,
        fracture: None,
    };
    b.add_cloth_grid(n, n, 0.1, |p| DVec3::new(p.x, 2.0, p.y), &opts).expect("valid cloth");
    b
}

/// Largest relative stretch `(l - L0) / L0` over the springs of `state`.
pub fn max_strain<R: Real>(m: &Model<R>, s: &State<R>) -> f64 {
    m.spring_indices
        .iter()
        .zip(&m.spring_rest_length)
        .map(|(&[i, j], &l0)| {
            let l = (s.particle_q[j as usize].to_dvec3() - s.particle_q[i as usize].to_dvec3()).length();
            l / l0.to_f64() - 1.0
        })
        .fold(0.0, f64::max)
}

/// RMS over particles of `|a - b|` \[m\].
pub fn rms_diff(a: &[DVec3], b: &[DVec3]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared()).sum();
    (s / a.len().max(1) as f64).sqrt()
}

/// Positions as f64 vectors.
pub fn positions<R: Real>(s: &State<R>) -> Vec<DVec3> {
    s.particle_q.iter().map(|q| q.to_dvec3()).collect()
}
