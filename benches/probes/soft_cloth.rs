//! The harness's softest cloth (k = 100 N/m, 0.1 kg a particle, held along one edge: springs stretched up to
//! ~300 %) stepped at one integrator and `dt`, printing at 12 times of the run the fastest mode's `ω²` at the
//! state of the moment (`StabilityBound::estimate`, without its margin), the growth a step that the frozen
//! Jacobian there gives this integrator at this `dt` (power iteration on the linearised step map), and the fastest
//! particle's speed; then the run's largest speed. `benches/RESULTS.md`, issue 15, (36), has what it showed: RK4
//! at 0.0279 s runs clean through states whose frozen growth is 1.2–1.8 a step, symplectic Euler resonates from
//! 0.0145 s (its largest speed 130–175 m/s against the 16 m/s of a run at 1/16 of the bound).
//!
//! Run: `cp benches/probes/soft_cloth.rs examples/ && cargo run --release --example soft_cloth -- rk 0.0279`
//! (`se` for symplectic Euler; about 10 s on the development VM; remove the copy afterwards).
use fissure::glam::DVec3;
use fissure::*;

struct Lin {
    sp: Vec<(usize, usize, f64, f64, f64, DVec3)>,
    w: Vec<f64>,
}
impl Lin {
    fn new(m: &Model<f64>, q: &[DVec3]) -> Self {
        let sp = m
            .spring_indices
            .iter()
            .enumerate()
            .map(|(s, &[i, j])| {
                let (i, j) = (i as usize, j as usize);
                let d = q[j] - q[i];
                let l = d.length();
                let k = m.spring_stiffness[s];
                let t = k * (1.0 - m.spring_rest_length[s] / l).max(0.0);
                (i, j, k, t, m.spring_damping[s], d / l)
            })
            .collect();
        Lin { sp, w: m.particle_inv_mass.clone() }
    }
    fn acc(&self, x: &[DVec3], v: &[DVec3], out: &mut [DVec3]) {
        out.iter_mut().for_each(|o| *o = DVec3::ZERO);
        for &(i, j, k, t, c, u) in &self.sp {
            let d = x[i] - x[j];
            let al = u * u.dot(d);
            let dv = v[i] - v[j];
            let p = al * k + (d - al) * t + u * (u.dot(dv) * c);
            out[i] -= p;
            out[j] += p;
        }
        for (o, w) in out.iter_mut().zip(&self.w) {
            *o *= *w;
        }
    }
    fn step(&self, rk: bool, h: f64, x: &mut Vec<DVec3>, v: &mut Vec<DVec3>) {
        let n = x.len();
        let mut a = vec![DVec3::ZERO; n];
        if !rk {
            self.acc(x, v, &mut a);
            for i in 0..n {
                v[i] += a[i] * h;
                x[i] += v[i] * h;
            }
            return;
        }
        let (x0, v0) = (x.clone(), v.clone());
        let mut kx = vec![vec![DVec3::ZERO; n]; 4];
        let mut kv = kx.clone();
        let (mut xs, mut vs) = (x0.clone(), v0.clone());
        for s in 0..4 {
            self.acc(&xs, &vs, &mut a);
            kx[s].copy_from_slice(&vs);
            kv[s].copy_from_slice(&a);
            let f = if s < 2 { 0.5 * h } else { h };
            if s < 3 {
                for i in 0..n {
                    xs[i] = x0[i] + kx[s][i] * f;
                    vs[i] = v0[i] + kv[s][i] * f;
                }
            }
        }
        for i in 0..n {
            x[i] = x0[i] + (kx[0][i] + kx[1][i] * 2.0 + kx[2][i] * 2.0 + kx[3][i]) * (h / 6.0);
            v[i] = v0[i] + (kv[0][i] + kv[1][i] * 2.0 + kv[2][i] * 2.0 + kv[3][i]) * (h / 6.0);
        }
    }
    fn growth(&self, rk: bool, h: f64, its: usize) -> f64 {
        let n = self.w.len();
        let mut s = 1u64;
        let mut r = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut x: Vec<DVec3> =
            (0..n).map(|i| if self.w[i] > 0.0 { DVec3::new(r(), r(), r()) } else { DVec3::ZERO }).collect();
        let mut v: Vec<DVec3> = vec![DVec3::ZERO; n];
        let norm = |x: &[DVec3], v: &[DVec3]| (x.iter().chain(v).map(|a| a.length_squared()).sum::<f64>()).sqrt();
        let mut lg = 0.0;
        for it in 0..2 * its {
            self.step(rk, h, &mut x, &mut v);
            let nn = norm(&x, &v);
            if it >= its {
                lg += nn.ln();
            }
            x.iter_mut().for_each(|a| *a /= nn);
            v.iter_mut().for_each(|a| *a /= nn);
        }
        (lg / its as f64).exp()
    }
}

fn main() {
    let k: f64 = 100.0;
    let integ = if std::env::args().nth(1).unwrap() == "se" { Integrator::SymplecticEuler } else { Integrator::Rk4 };
    let dt: f64 = std::env::args().nth(2).unwrap().parse().unwrap();
    let n = 32;
    let mut b = ModelBuilder::new();
    let opts = ClothOptions {
        mass: Mass::PerParticle(0.1),
        stiffness: Stiffness::PerSpring(k),
        shear: Some(Stiffness::PerSpring(k)),
        bending: Some(Stiffness::PerSpring(k)),
        damping: Damping::PerSpring(0.01),
        pins: (0..n).map(|j| j * n).collect(),
        aero: Aero::NONE,
        fracture: None,
    };
    b.add_cloth_grid(n, n, 0.1, |p| DVec3::new(p.x, 4.0, p.y), &opts).unwrap();
    let m: Model<f64> = b.finalize().unwrap();
    let mut s = m.state();
    let mut solver = CpuSolver::<f64>::with_integrator(integ);
    let mut mode = Vec::new();
    let steps = (7.8 / dt) as usize;
    let mut fastest = 0.0f64;
    for st in 0..steps {
        if solver.step(&m, &mut s, dt).is_err() {
            println!("t {:.2}: the step failed (non-finite state)", st as f64 * dt);
            return;
        }
        fastest = s.particle_qd.iter().map(|v| v.length()).fold(fastest, f64::max);
        if st % (steps / 12) == 0 {
            let bd = StabilityBound::estimate(&m, &s.particle_q, &mut mode);
            let lin = Lin::new(&m, &s.particle_q);
            let g = lin.growth(integ == Integrator::Rk4, dt, 400);
            let vmax = s.particle_qd.iter().map(|v| v.length()).fold(0.0, f64::max);
            println!(
                "t {:.2}: w2 {:.0} (h w {:.3}) frozen growth per step at dt {dt}: {g:.4}  vmax {vmax:.2}",
                st as f64 * dt,
                bd.omega2 / 1.03,
                dt * (bd.omega2 / 1.03).sqrt()
            );
        }
    }
    println!("largest speed over the run: {fastest:.2} m/s");
}
