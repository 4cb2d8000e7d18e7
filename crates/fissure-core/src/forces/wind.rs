//! A wind field varying in space and time, and the per-triangle aerodynamic model it drives.
//!
//! The field is a mean wind whose speed is modulated by a gust wave travelling downwind, plus a crosswind
//! wobble: `w(x, t) = U (1 + a sin φ) + b |U| sin(φ') ê`, with `φ = 2π (f t - x·Û / λ)` and `φ'` the same at
//! 0.37 f (incommensurate, so the pattern never repeats exactly), `ê` horizontal and perpendicular to `U`.
//! It is smooth and deterministic: a given `(x, t)` always gives the same wind, on the CPU and on the GPU.
//!
//! Each triangle feels drag and lift on the air's velocity relative to it: the mean over its three corners of
//! `w(x_i) - v_i` (the field sampled at the corners, not at the centroid), with area `A` and unit normal `n` (sign
//! chosen so `n·v ≥ 0`):
//! - drag `½ ρ C_D A |n·v| v` (along the flow, largest face-on),
//! - lift `½ ρ C_L A (n·v) (n |v| - (n·v̂) v)` (across the flow, largest at 45°),
//!
//! split equally over the three corners. Both vanish on a sheet moving with the air.
//!
//! Why the corners: both the corner mean and the centroid sample are second-order quadratures of the field over
//! the triangle (exact for a field linear in `x`; for the gust's sine they differ by about `(kh)²/9` of it, with
//! `k = 2π/λ` and `h` the edge: ~3e-5 on a 1 cm cloth in the default 4 m gusts). A particle's sample is shared by
//! its six triangles, so the wind pass takes one sample (two polynomial sines) per particle instead of one per
//! triangle: half as many on a closed mesh or a cloth. Measured 2026-11-27 on the 128² cloth in wind (the grid pass, two threads, probe): the
//! wind's added cost 45–46 → 34–36 µs a step, on a spring pass of ~40 µs.

use crate::model::Model;
use crate::real::{Real, Vector3};
use glam::DVec3;

/// A spatially and temporally varying wind. Units: m/s, Hz, m, kg/m^3.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct WindField {
    /// Mean wind velocity `U` \[m/s\]. Default (3, 0, 0).
    pub velocity: DVec3,
    /// Gust amplitude `a` as a fraction of the mean speed. Default 0.5.
    pub gust_amplitude: f64,
    /// Gust frequency `f` \[Hz\]. Default 0.5.
    pub gust_frequency: f64,
    /// Gust wavelength `λ` along the wind \[m\]. Default 4.
    pub gust_wavelength: f64,
    /// Crosswind wobble `b` as a fraction of the mean speed. Default 0.2.
    pub crosswind: f64,
    /// Air density `ρ` \[kg/m^3\]. Default 1.225 (sea level, 15 °C).
    pub air_density: f64,
}

impl Default for WindField {
    fn default() -> Self {
        WindField {
            velocity: DVec3::new(3.0, 0.0, 0.0),
            gust_amplitude: 0.5,
            gust_frequency: 0.5,
            gust_wavelength: 4.0,
            crosswind: 0.2,
            air_density: 1.225,
        }
    }
}

impl WindField {
    /// A steady, uniform wind (no gusts, no crosswind).
    pub fn steady(velocity: DVec3) -> Self {
        WindField { velocity, gust_amplitude: 0.0, crosswind: 0.0, ..Default::default() }
    }

    /// Checks every value: a finite `velocity`; finite, non-negative `gust_amplitude`, `gust_frequency`,
    /// `crosswind`; a finite, positive `gust_wavelength` and `air_density`. Names as in a scene's `[wind]`.
    pub fn validate(&self) -> Result<(), crate::error::ModelError> {
        use crate::error::ModelError;
        if !self.velocity.is_finite() {
            let bad = self.velocity.to_array().into_iter().find(|x| !x.is_finite()).unwrap_or(f64::NAN);
            return Err(ModelError::Parameter { name: "velocity", value: bad, expected: "finite [m/s]" });
        }
        for (name, v) in [
            ("gust_amplitude", self.gust_amplitude),
            ("gust_frequency", self.gust_frequency),
            ("crosswind", self.crosswind),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and >= 0" });
            }
        }
        for (name, v) in [("gust_wavelength", self.gust_wavelength), ("air_density", self.air_density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::Parameter { name, value: v, expected: "finite and > 0" });
            }
        }
        Ok(())
    }

    /// The field at time `t` \[s\] in the solver's precision, for sampling many points: the direction, the
    /// crosswind axis and the time part of both phases are taken once (the phases reduced modulo 2π in `f64`, so a
    /// long run keeps them exact), and each point costs a dot product and two polynomial sines. Agrees with
    /// [`WindField::sample`] to the precision `R` carries (tested).
    pub fn prepare<R: Real>(&self, t: f64) -> PreparedWind<R> {
        let speed = self.velocity.length();
        let tau = std::f64::consts::TAU;
        if speed == 0.0 {
            let z = R::V::ZERO;
            return PreparedWind { u: z, k: z, side: z, gust: R::ZERO, t1: R::ZERO, t2: R::ZERO };
        }
        let dir = self.velocity / speed;
        let side = self.side(dir);
        let f = self.gust_frequency;
        PreparedWind {
            u: R::V::from_dvec3(self.velocity),
            k: R::V::from_dvec3(dir * (tau / self.gust_wavelength.max(1e-9))),
            side: R::V::from_dvec3(side * (self.crosswind * speed)),
            gust: R::from_f64(self.gust_amplitude),
            t1: R::from_f64((f * t).rem_euclid(1.0) * tau),
            t2: R::from_f64((0.37 * f * t).rem_euclid(1.0) * tau),
        }
    }

    /// The horizontal unit vector across the wind direction `dir`.
    fn side(&self, dir: DVec3) -> DVec3 {
        let side = dir.cross(DVec3::Y);
        if side.length_squared() < 1e-12 { DVec3::X } else { side.normalize() }
    }

    /// Wind velocity at point `x` \[m\] and time `t` \[s\] (`f64`, the reference; the force pass samples a
    /// [`PreparedWind`]).
    pub fn sample(&self, x: DVec3, t: f64) -> DVec3 {
        let speed = self.velocity.length();
        if speed == 0.0 {
            return DVec3::ZERO;
        }
        let dir = self.velocity / speed;
        let tau = std::f64::consts::TAU;
        let along = x.dot(dir) / self.gust_wavelength.max(1e-9);
        let phase = tau * (self.gust_frequency * t - along);
        let phase2 = tau * (0.37 * self.gust_frequency * t - 0.61 * along);
        let side = self.side(dir);
        self.velocity * (1.0 + self.gust_amplitude * phase.sin()) + side * (self.crosswind * speed * phase2.sin())
    }
}

/// A [`WindField`] prepared for one time ([`WindField::prepare`]).
#[derive(Clone, Copy, Debug)]
pub struct PreparedWind<R: Real> {
    u: R::V,
    /// `2π Û / λ`: the gust phase per metre downwind.
    k: R::V,
    /// The crosswind axis times `b |U|`.
    side: R::V,
    gust: R,
    /// `2π f t` and `2π 0.37 f t`, reduced to `[0, 2π)`.
    t1: R,
    t2: R,
}

impl<R: Real> PreparedWind<R> {
    /// Wind velocity at `x` \[m\]: `U (1 + a sin φ) + b |U| sin(φ') ê`, as [`WindField::sample`].
    #[inline(always)]
    pub fn sample(&self, x: R::V) -> R::V {
        let [a, b, c] = self.sample_components(x.to_array());
        R::V::new(a, b, c)
    }

    /// [`PreparedWind::sample`] per component (the form the span loop vectorises).
    #[inline(always)]
    pub fn sample_components(&self, x: [R; 3]) -> [R; 3] {
        let [kx, ky, kz] = self.k.to_array();
        let along = x[0] * kx + x[1] * ky + x[2] * kz;
        let g = R::ONE + self.gust * sin(self.t1 - along);
        let s = sin(self.t2 - along * R::from_f64(0.61));
        let (u, side) = (self.u.to_array(), self.side.to_array());
        [u[0] * g + side[0] * s, u[1] * g + side[1] * s, u[2] * g + side[2] * s]
    }

    /// The air's velocity relative to a point at `x` \[m\] moving at `v` \[m/s\], `w(x) - v`, per component: what
    /// each particle contributes to its triangles' relative air (the module docs). Its one home: the grid pass, the
    /// per-particle pass and the corners of listed triangles all form it here.
    #[inline(always)]
    pub(crate) fn relative_components(&self, x: [R; 3], v: [R; 3]) -> [R; 3] {
        let air = self.sample_components(x);
        [air[0] - v[0], air[1] - v[1], air[2] - v[2]]
    }
}

/// `sin x` by reduction to `[-π/2, π/2]` and an odd Taylor polynomial: degree 13 for `f32` (error below 1e-9,
/// beneath `f32`'s rounding), degree 21 for `f64` (below 1e-16). Branch-free (the precision switch is a constant),
/// so a loop of them vectorises: a fraction of a libm call.
#[inline(always)]
pub fn sin<R: Real>(x: R) -> R {
    let c = |v: f64| R::from_f64(v);
    let pi = c(std::f64::consts::PI);
    // x - 2π round(x / 2π) in [-π, π] (rounding by adding and subtracting 1.5·2^(mantissa bits), exact for
    // |x| < 2^20 rad: no libm call), then sin(x) = sin(π - x) folds [π/2, π] onto [0, π/2].
    let magic = if R::EPSILON.to_f64() < 1e-10 { c(1.5 * 2f64.powi(52)) } else { c(1.5 * 2f64.powi(23)) };
    let r = x - c(std::f64::consts::TAU) * ((x * c(1.0 / std::f64::consts::TAU) + magic) - magic);
    // Fold without branches: |r| in [0, π] to h - |h - |r|| in [0, π/2] (h = π/2), the sign of r outside.
    let h = pi * c(0.5);
    let sign = if r < R::ZERO { -R::ONE } else { R::ONE };
    let r = (h - (h - r.abs()).abs()) * sign;
    let r2 = r * r;
    // Horner from the highest term, written out (an inner loop would stop the caller's loop vectorising):
    // sin r = r (1 - r²/(2·3) (1 - r²/(4·5) (1 - …))).
    let t = |p: R, k: f64| R::ONE - r2 * c(1.0 / ((2.0 * k) * (2.0 * k + 1.0))) * p;
    let p = if R::EPSILON.to_f64() < 1e-10 {
        t(t(t(t(t(t(t(t(t(t(R::ONE, 10.0), 9.0), 8.0), 7.0), 6.0), 5.0), 4.0), 3.0), 2.0), 1.0)
    } else {
        t(t(t(t(t(t(R::ONE, 6.0), 5.0), 4.0), 3.0), 2.0), 1.0)
    };
    r * p
}

/// Aerodynamic coefficients of a surface. Zero for both switches the body's aerodynamics off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aero {
    /// Drag coefficient `C_D` (dimensionless). Default 1.0 (flat plate, face on ~1.2).
    pub drag: f64,
    /// Lift coefficient `C_L` (dimensionless). Default 0.5.
    pub lift: f64,
}

impl Default for Aero {
    fn default() -> Self {
        Aero { drag: 1.0, lift: 0.5 }
    }
}

impl Aero {
    /// No aerodynamic force.
    pub const NONE: Aero = Aero { drag: 0.0, lift: 0.0 };

    /// True when this surface feels the wind.
    pub fn is_active(&self) -> bool {
        self.drag != 0.0 || self.lift != 0.0
    }
}

/// Drag and lift on a triangle with cross vector `c = 2 A n̂`, in relative air velocity `v` (see the module docs),
/// per component and branch-free (selects only), so the span loop of the wind pass vectorises.
///
/// The module's formulas with `n·v` and the area written through `s = c·v = 2 A (n̂·v)`: the drag
/// `½ ρ C_D A |n·v| v` is `¼ ρ C_D |s| v`, and the lift `½ ρ C_L A (n·v) (n |v| - (n·v̂) v)` (with `n` facing the
/// flow) is `¼ ρ C_L s (c |v|² - s v) / (|c| |v|)`: one square root and one division instead of two of each and
/// no sign flip (the wind pass's lanes, 2026-11-25). A degenerate triangle (`c = 0`) or still air (`v = 0`) gives
/// `s = 0` and a zero reciprocal: no force.
///
/// GPU twin: `aero_force` in `shaders/surface.wgsl` (used by the kernel `surface_force`).
#[inline(always)]
pub(crate) fn aero_components<R: Real>(c: [R; 3], v: [R; 3], cd: R, cl: R, rho_half: R) -> [R; 3] {
    let cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let s = c[0] * v[0] + c[1] * v[1] + c[2] * v[2];
    let root = (cc * vv).sqrt();
    let inv = if root > R::ZERO { R::ONE / root } else { R::ZERO };
    let quarter = rho_half * R::from_f64(0.5);
    let (kd, kl) = (quarter * cd * s.abs(), quarter * cl * s * inv);
    [
        v[0] * kd + (c[0] * vv - v[0] * s) * kl,
        v[1] * kd + (c[1] * vv - v[1] * s) * kl,
        v[2] * kd + (c[2] * vv - v[2] * s) * kl,
    ]
}

/// Triangles per span of the wind pass.
const SPAN: usize = 64;

/// The triangles a call of the wind kernel computes, and what it does with their cross vectors.
pub(crate) enum Tris<'a, R: Real> {
    /// Triangles `start .. start + out.len()` (the surface pass): their crosses read from `cross` (formed by the
    /// gas's pass), or without it formed here from the positions the kernel loads anyway (a model without gas: no
    /// pass of its own for them; 128² cloth in wind, harness `terms`, 2026-11-24: the surface stage 149–150 →
    /// 140–142 µs a step).
    Range { start: usize, cross: Option<&'a [R::VA]> },
    /// The listed triangles (the loose ones of a grid model, `forces::wind_grid`): their crosses formed here and
    /// not kept.
    List(&'a [u32]),
}

crate::isa::wide_kernel! {
    /// Each particle's air velocity relative to it, `w(x) - v` \[m/s\], for particles `start .. start +
    /// out.len()` into `out`: the wind sampled once per particle, a span at a time (positions and velocities
    /// transposed into per-component arrays, the sample run as a plain loop over them: packed polynomial sines).
    /// The triangles then take the mean of their corners' ([`wind_chunk`], `forces::wind_grid`).
    pub(crate) fn relative_air[R: Real](
        q: &[R::V],
        qd: &[R::V],
        w: &PreparedWind<R>,
        start: usize,
        out: &mut [R::V],
    ) => relative_air_impl[R]
}

#[inline(always)]
fn relative_air_impl<R: Real>(q: &[R::V], qd: &[R::V], w: &PreparedWind<R>, start: usize, out: &mut [R::V]) {
    let z = [[R::ZERO; SPAN]; 3];
    let (mut x, mut v) = (z, z);
    for (c, out) in out.chunks_mut(SPAN).enumerate() {
        let p0 = start + c * SPAN;
        let n = out.len();
        let (fq, fv) = (R::flat(&q[p0..p0 + n]), R::flat(&qd[p0..p0 + n]));
        // `f32` on AVX-512: whole blocks of 16 split into components with permutes (`isa::vec3x16`) and joined back,
        // not value by value (scalar copies LLVM did not pack: the 10,242-vertex ball in wind, one thread, the Zen 4
        // development VM, 2026-11-29, surface stage 102.5–105.7 → 95.7–98.7 µs a step). The same values.
        #[cfg(target_arch = "x86_64")]
        let wide = if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx512() {
            n / 16 * 16
        } else {
            0
        };
        #[cfg(not(target_arch = "x86_64"))]
        let wide = 0;
        #[cfg(target_arch = "x86_64")]
        for k in (0..wide).step_by(16) {
            use crate::isa::vec3x16::split_into;
            use crate::real::{as_f32, as_f32_mut};
            let ([x0, x1, x2], [v0, v1, v2]) = (&mut x, &mut v);
            let xs = [as_f32_mut(&mut x0[k..]), as_f32_mut(&mut x1[k..]), as_f32_mut(&mut x2[k..])];
            let vs = [as_f32_mut(&mut v0[k..]), as_f32_mut(&mut v1[k..]), as_f32_mut(&mut v2[k..])];
            // SAFETY: AVX-512 (tested above); 48 values from `3k` in each (`k + 16 <= n`).
            unsafe {
                split_into(as_f32(fq), 3 * k, xs);
                split_into(as_f32(fv), 3 * k, vs);
            }
        }
        for k in wide..n {
            for e in 0..3 {
                (x[e][k], v[e][k]) = (fq[3 * k + e], fv[3 * k + e]);
            }
        }
        for k in 0..SPAN {
            let rel = w.relative_components([x[0][k], x[1][k], x[2][k]], [v[0][k], v[1][k], v[2][k]]);
            for e in 0..3 {
                v[e][k] = rel[e];
            }
        }
        #[cfg(target_arch = "x86_64")]
        for k in (0..wide).step_by(16) {
            use crate::isa::vec3x16::{join, store3};
            use crate::real::{as_f32, as_f32_mut};
            // SAFETY: AVX-512 (tested above); 16 values from each array, 48 into `out` from `3k` (`k + 16 <= n`).
            unsafe {
                // (No closure: one is compiled without the caller's AVX-512, its intrinsics as calls.)
                let at = |e: usize| as_f32(&v[e][k..k + 16]).as_ptr();
                let (r0, r1, r2) = (at(0), at(1), at(2));
                use std::arch::x86_64::_mm512_loadu_ps as load;
                let r = [load(r0), load(r1), load(r2)];
                store3(as_f32_mut(R::flat_mut(out)), 3 * k, join(r), None);
            }
        }
        for (k, o) in out.iter_mut().enumerate().skip(wide) {
            *o = R::V::new(v[0][k], v[1][k], v[2][k]);
        }
    }
}

/// Where the wind kernel finds its corners' relative air (`w(x) - v`).
#[derive(Clone, Copy)]
pub(crate) enum Air<'a, R: Real> {
    /// Per particle, from [`relative_air`].
    Particles(&'a [R::V]),
    /// Sampled at each corner here from the particles' velocities (a few listed triangles: no pass over the
    /// particles for them). The same formula in the same order as [`relative_air`]: the same bits.
    Corners(&'a [R::V]),
}

crate::isa::wide_kernel! {
    /// Corner forces (pressure share + a third of drag and lift) of the triangles `tris` names into `out` (one per
    /// triangle), a span at a time: per-lane inputs gathered into per-component arrays, [`aero_components`] run as
    /// a plain loop over them (packed square roots and divisions), results scattered back. A triangle's relative
    /// air is the mean of its corners' (`air`). Compiled for AVX-512 or AVX2 when the CPU has them (same bits: see
    /// `crate::isa`; AVX-512 measured on the 128² cloth in wind, harness `terms`, 2026-11-24: the surface stage
    /// 141–144 → 130–131 µs). In `f32` on AVX2, a span of one body with the air per particle goes eight triangles
    /// at a time by hand instead (`forces::wind_avx2`, the same bits; the 10,242-vertex ball in wind, harness
    /// `terms`, 2026-11-29: the surface stage 73–75 → 57 µs a step on two threads).
    pub(crate) fn wind_chunk[R: Real](
        m: &Model<R>,
        q: &[R::V],
        air: Air<'_, R>,
        tris: Tris<'_, R>,
        pressure: &[R],
        rho_half: R,
        w: &PreparedWind<R>,
        out: &mut [R::V],
    ) => wind_chunk_impl[R]
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn wind_chunk_impl<R: Real>(
    m: &Model<R>,
    q: &[R::V],
    air: Air<'_, R>,
    tris: Tris<'_, R>,
    pressure: &[R],
    rho_half: R,
    w: &PreparedWind<R>,
    out: &mut [R::V],
) {
    let (third, sixth) = (R::from_f64(1.0 / 3.0), R::from_f64(1.0 / 6.0));
    let z = [[R::ZERO; SPAN]; 3];
    let (mut c, mut rel, mut f) = (z, z, z);
    // Corners' positions and velocities (`Air::Corners` only).
    let (mut xs, mut vs) = ([z; 3], [z; 3]);
    let (mut cd, mut cl, mut p) = ([R::ZERO; SPAN], [R::ZERO; SPAN], [R::ZERO; SPAN]);
    let mut corners = [[0u32; 3]; SPAN];
    let mut bodies = [0u32; SPAN];
    let mut k0 = 0;
    while k0 < out.len() {
        let n = (out.len() - k0).min(SPAN);
        // The span's corners and bodies, copied (a slice of the model's, or gathered through the list).
        let (idx, body) = match &tris {
            Tris::Range { start, .. } => {
                let t0 = start + k0;
                (&m.tri_indices[t0..t0 + n], &m.tri_body[t0..t0 + n])
            }
            Tris::List(ids) => {
                for (k, &t) in ids[k0..k0 + n].iter().enumerate() {
                    (corners[k], bodies[k]) = (m.tri_indices[t as usize], m.tri_body[t as usize]);
                }
                (&corners[..n], &bodies[..n])
            }
        };
        // The span's corners checked once (a vectorised maximum), then read without a check each, as in the
        // per-spring kernel; a span of one body (the usual case) reads its coefficients once. One thread,
        // 2026-11-25: the surface stage 246 → 170 µs a step on the 128² cloth in wind, 160 → 107 µs on the
        // 10,242-vertex ball. (The maximum over the flat indices: over the triangles' triples it was not packed,
        // ~3 % of the surface stage on that ball, one thread, 2026-11-29: 99.8–100.8 → 97.1–97.5 µs.)
        let top = idx.as_flattened().iter().copied().max().unwrap_or(0) as usize;
        let air_len = match air {
            Air::Particles(a) => a.len(),
            Air::Corners(qd) => qd.len(),
        };
        assert!(top < q.len() && top < air_len, "triangle corner out of range");
        let b0 = body[0] as usize;
        // (As the bodies' least and greatest, which pack; `all` stops early and did not: ~3 % of the surface
        // stage on the 10,242-vertex ball in wind, one thread, 2026-11-29.)
        let (least, most) = body.iter().fold((u32::MAX, 0), |(l, h), &b| (l.min(b), h.max(b)));
        let one_body = least == most;
        // `f32` on AVX2, the air per particle, a span of one body: whole blocks of eight by hand (`wind_avx2`, the
        // same bits), where every corner's 16-byte load stays inside the positions and the air.
        #[allow(unused_mut)]
        let mut first = 0;
        #[cfg(target_arch = "x86_64")]
        if let (Air::Particles(a), Tris::Range { cross, .. }) = (air, &tris)
            && std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>()
            && crate::isa::avx2()
            && one_body
            && top + 1 < q.len().min(a.len())
        {
            use crate::real::{as_f32, as_f32_mut, va_as_f32};
            // (`R` is `f32` here: exact.)
            let one = |x: R| x.to_f64() as f32;
            let coefficients = super::wind_avx2::Coefficients {
                cd: one(m.body_drag[b0]),
                cl: one(m.body_lift[b0]),
                pressure: one(pressure[b0]),
                rho_half: one(rho_half),
            };
            let (qf, af) = (as_f32(R::flat(q)), as_f32(R::flat(a)));
            let crosses = cross.map(|x| &va_as_f32::<R>(x)[4 * k0..4 * (k0 + n)]);
            let room = k0 + n < out.len();
            let dst = as_f32_mut(R::flat_mut(&mut out[k0..k0 + n + usize::from(room)]));
            let dst = &mut dst[..3 * n + usize::from(room)];
            // SAFETY: AVX2 (tested above); every corner index is at most `top`, below `q.len() - 1` and the air's
            // length less one (tested above), so each 16-byte load stays inside them; with `room`, `dst` holds a
            // value past the span's, the next triangle's (written after this).
            first = unsafe { super::wind_avx2::blocks(qf, af, idx, crosses, coefficients, dst, room) };
        }
        if first == n {
            k0 += n;
            continue;
        }
        if one_body {
            cd.fill(m.body_drag[b0]);
            cl.fill(m.body_lift[b0]);
            p.fill(pressure[b0]);
        } else {
            for k in 0..n {
                let b = body[k] as usize;
                (cd[k], cl[k], p[k]) = (m.body_drag[b], m.body_lift[b], pressure[b]);
            }
        }
        for k in first..n {
            let [a, b, d] = idx[k].map(|i| i as usize);
            // SAFETY: a, b, d <= top < q.len() and the relative air's length (asserted above).
            let (qa, qb, qc) = unsafe { (*q.get_unchecked(a), *q.get_unchecked(b), *q.get_unchecked(d)) };
            match air {
                Air::Particles(air) => {
                    let (ra, rb, rc) = unsafe { (*air.get_unchecked(a), *air.get_unchecked(b), *air.get_unchecked(d)) };
                    let r = ((ra + rb + rc) * third).to_array();
                    for e in 0..3 {
                        rel[e][k] = r[e];
                    }
                }
                Air::Corners(qd) => {
                    let (va, vb, vc) = unsafe { (*qd.get_unchecked(a), *qd.get_unchecked(b), *qd.get_unchecked(d)) };
                    for (j, (x, v)) in [(qa, va), (qb, vb), (qc, vc)].into_iter().enumerate() {
                        let (x, v) = (x.to_array(), v.to_array());
                        for e in 0..3 {
                            (xs[j][e][k], vs[j][e][k]) = (x[e], v[e]);
                        }
                    }
                }
            }
            // The surface pass's formula (`forces::cross_chunk`): the same bits.
            let cr = match &tris {
                Tris::Range { cross: Some(cross), .. } => cross[k0 + k].into(),
                Tris::Range { cross: None, .. } | Tris::List(_) => (qb - qa).cross(qc - qa),
            }
            .to_array();
            for e in 0..3 {
                c[e][k] = cr[e];
            }
        }
        if let Air::Corners(_) = air {
            // Each corner's relative air as `relative_air` forms it, then their mean in corner order.
            for j in 0..3 {
                for k in 0..SPAN {
                    let (x, v) = (&xs[j], &vs[j]);
                    let rel = w.relative_components([x[0][k], x[1][k], x[2][k]], [v[0][k], v[1][k], v[2][k]]);
                    for e in 0..3 {
                        vs[j][e][k] = rel[e];
                    }
                }
            }
            for e in 0..3 {
                for k in 0..SPAN {
                    rel[e][k] = (vs[0][e][k] + vs[1][e][k] + vs[2][e][k]) * third;
                }
            }
        }
        for k in first..SPAN {
            let cr = [c[0][k], c[1][k], c[2][k]];
            let a = aero_components(cr, [rel[0][k], rel[1][k], rel[2][k]], cd[k], cl[k], rho_half);
            let ps = p[k] * sixth;
            for e in 0..3 {
                // `pressure::corner_force` (c · p/6) plus a third of the aerodynamic force.
                f[e][k] = cr[e] * ps + a[e] * third;
            }
        }
        for k in first..n {
            out[k0 + k] = R::V::new(f[0][k], f[1][k], f[2][k]);
        }
        k0 += n;
    }
}
