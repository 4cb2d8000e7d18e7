//! Springs: the seed's eqs. (1)–(2), Hooke's law along each edge of the mesh with damping, and the kernels that
//! evaluate them: per spring for irregular meshes (`ForceScratch::springs` → `spring_f`, gathered per particle),
//! and per block of particles over spring runs (cloth grids: contiguous slices, vectorised, AVX2 or AVX-512 when
//! present; the blocks and their walk are in `forces::runs`, the span maths, `span_forces`, here).
//!
//! One formula, [`force_components`], serves every caller: both kernels, the fracture load
//! ([`elastic_force`]), the implicit solver's Jacobian (`implicit_coefficients`) and the energy ([`potential`]).

use super::ForceScratch;
use crate::model::{DampingModel, Model};
use crate::par;
use crate::real::{Real, Vector3};

impl<R: Real> ForceScratch<R> {
    /// Spring forces: per particle into `particle_spring` (runs), else per spring into `spring_f`.
    pub fn springs(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        match (self.runs, m.damping_model) {
            (true, DampingModel::Projected) => {
                super::runs::run_pass::<R, true>(m, &self.run_blocks, q, qd, &mut self.particle_spring, None)
            }
            (true, DampingModel::Unprojected) => {
                super::runs::run_pass::<R, false>(m, &self.run_blocks, q, qd, &mut self.particle_spring, None)
            }
            (false, DampingModel::Projected) => spring_pass::<R, true>(m, q, qd, &mut self.spring_f),
            (false, DampingModel::Unprojected) => spring_pass::<R, false>(m, q, qd, &mut self.spring_f),
        }
    }

    /// Whether [`ForceScratch::springs_and_crosses`] serves this evaluation: on the team (`par::teamed`), the
    /// per-spring kernel, and gas (whose crosses the surface pass forms on its own otherwise).
    pub fn fuse_crosses(&self, m: &Model<R>) -> bool {
        par::teamed() && !self.runs && m.has_pressure() && self.tri_cross.len() == m.tri_count()
    }

    /// [`ForceScratch::springs`] (per-spring kernel) and the surface pass's crosses and volume partials
    /// (`forces::cross_chunk`) in one hand-over to the team. The triangle chunks and the spring pieces are taken
    /// in the order of where their middles lie in their arrays ([`region_order`]): the caller claims from the
    /// front and a helper from the end, so on a mesh numbered for locality (springs and triangles follow the
    /// particles: `Mesh::renumbered_for_locality`, which `Mesh::icosphere` applies) each core forms the crosses and
    /// spring forces of the particles whose gather it then takes, and the gather reads what its own core wrote.
    /// (Before, every triangle chunk came first, all on the caller's core; on a mesh without locality either way
    /// half of the gather's reads fall on the other core's lines.) By middles, not starts: a chunk of 2,048
    /// triangles spans two fifths of the 2,562-vertex ball, and ordered by its start the ball's middle chunk (its
    /// particles ~40-80 % of the way through, mostly the helper's) went to the caller, where it took 7.3-8.6 µs
    /// against 3.2-3.5 for the first chunk's same work (pieces timed, 2026-12-07, `benches/RESULTS.md` (59),
    /// (60)); by middles the ball's step went 27.9-28.9 → 25.6-26.2 µs on the Zen 4 development VM. A 642-vertex
    /// ball's 1,280 triangles are one chunk of the volume sum, taken first: the other thread runs springs
    /// meanwhile. The same pieces and chunks as the two passes apart: the same bits. The caps over a gas body's
    /// openings are one more piece, last (a helper takes it first).
    /// [`ForceScratch::surface`] is then told to skip them (`crosses_formed`).
    pub fn springs_and_crosses(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        match m.damping_model {
            DampingModel::Projected => self.springs_and_crosses_with::<true, false>(m, q, qd),
            DampingModel::Unprojected => self.springs_and_crosses_with::<false, false>(m, q, qd),
        }
    }

    /// [`ForceScratch::springs_measured`] and the surface pass's crosses in one hand-over, as
    /// [`ForceScratch::springs_and_crosses`] does without measuring: a model that can break measures at every
    /// step of symplectic Euler, and apart its surface pass's few triangle chunks (three on the 2,562-vertex ball)
    /// and the caps over its openings left one core idle while the other formed them.
    pub fn springs_measured_and_crosses(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        debug_assert!(self.measuring && !self.runs);
        match m.damping_model {
            DampingModel::Projected => self.springs_and_crosses_with::<true, true>(m, q, qd),
            DampingModel::Unprojected => self.springs_and_crosses_with::<false, true>(m, q, qd),
        }
    }

    fn springs_and_crosses_with<const PROJECTED: bool, const MEASURE: bool>(
        &mut self,
        m: &Model<R>,
        q: &[R::V],
        qd: &[R::V],
    ) {
        let (nb, size) = (m.body_count(), par::piece(par::CHUNK));
        let rows = m.tri_count().div_ceil(par::CHUNK).max(1);
        let end = super::gas_tri_end(m, &self.tri_ends);
        let (mut order, key) = std::mem::take(&mut self.fused_order);
        let want = [m.tri_count(), m.spring_count(), size];
        if key != want {
            region_order(&mut order, m.tri_count(), par::CHUNK, m.spring_count(), size);
        }
        let ps = par::Pieces::new(&mut self.spring_f, size);
        let pc = par::Pieces::new(&mut self.tri_cross, par::CHUNK);
        let pv = par::Pieces::new(&mut self.vol_partials[..rows * nb], nb);
        // Measuring: each spring's strain through the sink and (with load limits) its elastic pull into
        // `spring_el`, piece by piece (empty pieces without load limits).
        let over = self.sparse_strains.then_some(self.strain_over);
        let sink = MEASURE.then(|| StrainSink::new(&mut self.strain, over, std::mem::take(&mut self.strain_spans)));
        let el_len = if MEASURE { self.spring_el.len() } else { 0 };
        let pe = par::Pieces::new(&mut self.spring_el[..el_len], size);
        let (nc, np) = (pc.count(), ps.count());
        debug_assert_eq!(order.len(), nc + np);
        let caps = super::pressure::CapPieces::new(&mut self.caps);
        let (ord, sink_ref) = (&order, sink.as_ref());
        // Spring piece `p`'s pulls: its own piece of `spring_el`, or none.
        // SAFETY (for callers): each `p` once.
        let els = |p: usize| if el_len == 0 { &mut [][..] } else { unsafe { pe.get(p) } };
        // SAFETY (both): `exec` runs each piece index once and `order` is a permutation of `0 .. nc + np`;
        // triangle chunks, spring pieces and the caps (`nc + np`) are numbered apart.
        if caps.count() == 0 {
            // Without caps a closure of two kinds of piece: with a third branch in it the ball's pass (10,242
            // vertices, no openings) took 5 µs more a step (harness `terms`, 2026-11-25).
            par::exec(false, nc + np, &|k| unsafe {
                let k = *ord.get_unchecked(k) as usize;
                if k < nc {
                    super::cross_chunk(m, q, true, (k * par::CHUNK, end), pc.get(k), pv.get(k))
                } else {
                    let p = k - nc;
                    spring_chunk_dispatch::<R, PROJECTED, MEASURE>(m, q, qd, p * size, ps.get(p), sink_ref, els(p))
                }
            });
        } else {
            par::exec(false, nc + np + 1, &|k| unsafe {
                let k = if k < nc + np { *ord.get_unchecked(k) as usize } else { k };
                if k < nc {
                    super::cross_chunk(m, q, true, (k * par::CHUNK, end), pc.get(k), pv.get(k))
                } else if k < nc + np {
                    let p = k - nc;
                    spring_chunk_dispatch::<R, PROJECTED, MEASURE>(m, q, qd, p * size, ps.get(p), sink_ref, els(p))
                } else {
                    caps.run(m, q)
                }
            });
        }
        if let Some(sink) = sink {
            self.strain_spans = sink.finish();
            self.strain_sparse = over.is_some();
        }
        self.fused_order = (order, want);
    }

    /// [`ForceScratch::springs`] that also measures the fracture trigger's inputs: each spring's strain into
    /// `strain` and, when some particle has a finite load limit, its elastic pull into `spring_el` (per-spring
    /// kernel only: see `ForceScratch::resize`).
    pub fn springs_measured(&mut self, m: &Model<R>, q: &[R::V], qd: &[R::V]) {
        debug_assert!(self.measuring);
        let over = self.sparse_strains.then_some(self.strain_over);
        let sink = StrainSink::new(&mut self.strain, over, std::mem::take(&mut self.strain_spans));
        if self.runs {
            // The run kernel measures strains alone (a model with load limits is not measured on it).
            match m.damping_model {
                DampingModel::Projected => {
                    super::runs::run_pass::<R, true>(m, &self.run_blocks, q, qd, &mut self.particle_spring, Some(&sink))
                }
                DampingModel::Unprojected => super::runs::run_pass::<R, false>(
                    m,
                    &self.run_blocks,
                    q,
                    qd,
                    &mut self.particle_spring,
                    Some(&sink),
                ),
            }
        } else {
            // Empty without load limits: the strains alone.
            let (out, el) = (&mut self.spring_f, &mut self.spring_el);
            match m.damping_model {
                DampingModel::Projected => spring_pass_measured::<R, true>(m, q, qd, out, &sink, el),
                DampingModel::Unprojected => spring_pass_measured::<R, false>(m, q, qd, out, &sink, el),
            }
        }
        self.strain_spans = sink.finish();
        self.strain_sparse = over.is_some();
    }
}

/// The pieces of two passes run as one: `nt` triangles in chunks of `chunk` (numbered `0 .. nc`) and `ns` springs in
/// pieces of `size` (numbered `nc ..`), merged by where each one's middle lies as a fraction of its array (a
/// triangle chunk first on a tie; triangle chunks of half the triangles or more by their starts), into `order`.
/// On a mesh numbered for locality a fraction of the triangles and the same fraction of the springs touch about
/// the same particles.
fn region_order(order: &mut Vec<u32>, nt: usize, chunk: usize, ns: usize, size: usize) {
    let (nc, np) = (nt.div_ceil(chunk), ns.div_ceil(size));
    // Twice a piece's middle: its start plus its end (the last piece may be short).
    let mid2 = |k: usize, len: usize, n: usize| (2 * k * len + len.min(n - k * len)) as u128;
    // Where the chunks hold half the triangles or more (one or two chunks), they are placed by their starts: such
    // a chunk touches particles all over the mesh, and a large piece taken first (the 642-vertex ball's one
    // chunk) lets the other thread take the small ones.
    let tri2 = |c: usize| if 2 * chunk >= nt { (2 * c * chunk) as u128 } else { mid2(c, chunk, nt) };
    order.clear();
    let (mut c, mut p) = (0, 0);
    while c < nc || p < np {
        // `mid(c) / nt <= mid(p) / ns`, cross-multiplied (exact in u128).
        let tri_first = p == np || (c < nc && tri2(c) * ns as u128 <= mid2(p, size, ns) * nt as u128);
        if tri_first {
            order.push(c as u32);
            c += 1;
        } else {
            order.push((nc + p) as u32);
            p += 1;
        }
    }
}

/// The seed's eqs. (1)–(2) for one spring, on its end 0 (end 1 gets the negative), per component:
/// `F = ks (l - L0) d̂ + kd ((vj - vi)·d̂) d̂` (projected damping, the default) or `F = ks (l - L0) d̂ + kd (vj - vi)`
/// (the paper's unprojected form), with `d = xj - xi`, `l = |d|`, `d̂ = d / l`. Coincident ends have no
/// direction and no elastic force. Branch-free, so the span loops of the run kernel vectorise; every caller (the
/// per-spring and run kernels, the fracture load, diagnostics) goes through this one function.
///
/// GPU twin: `spring_force_of` in `shaders/common.wgsl` (through `spring_force` in the integrators of
/// `shaders/integrate.wgsl`, and `spring_elastic_force` in `load_check` of `shaders/fracture.wgsl`).
#[inline(always)]
pub fn force_components<R: Real, const PROJECTED: bool>(d: [R; 3], w: [R; 3], rest: R, ks: R, kd: R) -> [R; 3] {
    force_parts::<R, PROJECTED>(d, w, rest, ks, kd).0
}

/// [`force_components`] with its by-products: `(force, elastic part ks (l - L0) d̂, length l)`. The force pass
/// uses the last two as the fracture trigger's strain and load when the model can break.
#[inline(always)]
pub fn force_parts<R: Real, const PROJECTED: bool>(d: [R; 3], w: [R; 3], rest: R, ks: R, kd: R) -> ([R; 3], [R; 3], R) {
    let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let l = l2.sqrt();
    let inv = if l2 > R::ZERO { R::ONE / l } else { R::ZERO };
    let u = [d[0] * inv, d[1] * inv, d[2] * inv];
    let el = ks * (l - rest);
    let elastic = [u[0] * el, u[1] * el, u[2] * el];
    if PROJECTED {
        let mag = el + kd * (w[0] * u[0] + w[1] * u[1] + w[2] * u[2]);
        ([u[0] * mag, u[1] * mag, u[2] * mag], elastic, l)
    } else {
        ([elastic[0] + w[0] * kd, elastic[1] + w[1] * kd, elastic[2] + w[2] * kd], elastic, l)
    }
}

/// [`force_components`] on vectors: the force on end 0 of a spring with `d = xj - xi`, `dv = vj - vi` \[N\].
#[inline(always)]
pub fn force<R: Real, const PROJECTED: bool>(d: R::V, dv: R::V, rest: R, ks: R, kd: R) -> R::V {
    let [x, y, z] = force_components::<R, PROJECTED>(d.to_array(), dv.to_array(), rest, ks, kd);
    R::V::new(x, y, z)
}

/// The elastic part alone, `ks (l - L0) d̂` \[N\] (the fracture load: the spring's pull on its end 0).
#[inline]
pub fn elastic_force<R: Real>(d: R::V, rest: R, ks: R) -> R::V {
    force::<R, true>(d, R::V::ZERO, rest, ks, R::ZERO)
}

/// Strain `(l - L0) / L0` of a spring of length `l` \[m\] and rest length `rest` \[m\].
#[inline]
pub fn strain<R: Real>(l: R, rest: R) -> R {
    (l - rest) / rest
}

/// Elastic energy `½ ks (l - L0)²` \[J\].
#[inline]
pub fn potential(l: f64, rest: f64, ks: f64) -> f64 {
    let d = l - rest;
    0.5 * ks * d * d
}

/// The spring's linearisation for implicit Euler (Baraff & Witkin 1998), scaled for the system
/// `(M + h C + h² K) Δv`: returns the unit direction `d̂` and `[iso, axial, damp_iso, damp_axial]`, the coefficients
/// of `I` and `d̂ d̂ᵀ` in `h² K + h C` (the stiffness block, then with damping). `K = ks (d̂ d̂ᵀ + (1 - L0/l)(I - d̂ d̂ᵀ))`,
/// exact when stretched; the transverse term is clamped at 0 when compressed (it is negative there and would make
/// the system indefinite; Choi & Ko 2002). `C = kd d̂ d̂ᵀ` (projected) or `kd I` (unprojected).
#[inline]
pub(crate) fn implicit_coefficients<R: Real>(d: R::V, rest: R, ks: R, kd: R, h: R, projected: bool) -> (R::V, [R; 4]) {
    let h2 = h * h;
    let l = d.length();
    if l > R::ZERO {
        let iso = h2 * ks * (R::ONE - rest / l).max(R::ZERO);
        let axial = h2 * ks;
        let hd = h * kd;
        (d * (R::ONE / l), if projected { [iso, axial, iso, axial + hd] } else { [iso, axial, iso + hd, axial + hd] })
    } else {
        let hd = if projected { R::ZERO } else { h * kd };
        (R::V::ZERO, [R::ZERO, R::ZERO, hd, hd])
    }
}

/// The per-spring kernel (irregular meshes): forces into `out`, and with `MEASURE` each spring's strain and
/// elastic pull too. Springs go a span of [`SPAN`] at a time: their ends' differences are gathered into
/// per-component arrays, [`force_parts`] runs on those as plain loops (packed square roots and divisions), and
/// the results are scattered back. Same maths lane by lane, same bits as one spring at a time.
fn spring_pass<R: Real, const PROJECTED: bool>(m: &Model<R>, q: &[R::V], qd: &[R::V], out: &mut [R::V]) {
    // Each spring's force is its own: on the team in finer pieces (`par::piece`), the same bits.
    par::chunks_of(par::piece(par::CHUNK), out, |start, chunk| {
        spring_chunk_dispatch::<R, PROJECTED, false>(m, q, qd, start, chunk, None, &mut [])
    });
}

fn spring_pass_measured<R: Real, const PROJECTED: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    out: &mut [R::V],
    strain: &StrainSink<'_, R>,
    el_out: &mut [R::V],
) {
    let n = out.len();
    // On the team in finer pieces, as the plain pass (each spring's results are its own: the same bits).
    let size = par::piece(par::CHUNK);
    if el_out.is_empty() {
        // No load limit: the strains alone.
        par::chunks_of(size, out, |start, chunk| {
            spring_chunk_dispatch::<R, PROJECTED, true>(m, q, qd, start, chunk, Some(strain), &mut [])
        });
        return;
    }
    par::chunks2_pooled(par::is_pooled(n), size, out, &mut el_out[..n], |start, chunk, els| {
        spring_chunk_dispatch::<R, PROJECTED, true>(m, q, qd, start, chunk, Some(strain), els)
    });
}

/// [`spring_chunk`] compiled for AVX2 when the CPU has it, else for the baseline (same bits: see
/// [`super::runs::run_block_dispatch`]).
#[inline]
fn spring_chunk_dispatch<R: Real, const PROJECTED: bool, const MEASURE: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    start: usize,
    out: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
    els: &mut [R::V],
) {
    #[cfg(target_arch = "x86_64")]
    {
        let f32_avx2 = std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>() && crate::isa::avx2();
        if !MEASURE && f32_avx2 {
            return super::spring_avx2::forces::<R, PROJECTED>(m, q, qd, start, out);
        }
        if let (true, Some(sink)) = (MEASURE && f32_avx2, strain) {
            return super::spring_avx2::measured::<R, PROJECTED>(m, (q, qd), start, out, sink, els);
        }
        if crate::isa::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { spring_chunk_avx2::<R, PROJECTED, MEASURE>(m, q, qd, start, out, strain, els) };
            return;
        }
    }
    spring_chunk::<R, PROJECTED, MEASURE>(m, q, qd, start, out, strain, els)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) fn spring_chunk_avx2<R: Real, const PROJECTED: bool, const MEASURE: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    start: usize,
    out: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
    els: &mut [R::V],
) {
    spring_chunk::<R, PROJECTED, MEASURE>(m, q, qd, start, out, strain, els)
}

/// Springs `start .. start + out.len()`, a span at a time (see [`spring_pass`]).
#[inline(always)]
fn spring_chunk<R: Real, const PROJECTED: bool, const MEASURE: bool>(
    m: &Model<R>,
    q: &[R::V],
    qd: &[R::V],
    start: usize,
    out: &mut [R::V],
    strain: Option<&StrainSink<'_, R>>,
    els: &mut [R::V],
) {
    let mut t = SpanScratch::<R>::new();
    let mut e = [[R::ZERO; SPAN]; 3];
    let mut l = [R::ZERO; SPAN];
    let mut k0 = 0;
    while k0 < out.len() {
        let n = (out.len() - k0).min(SPAN);
        let s0 = start + k0;
        let (idx, rest, ks, kd) = (
            &m.spring_indices[s0..s0 + n],
            &m.spring_rest_length[s0..s0 + n],
            &m.spring_stiffness[s0..s0 + n],
            &m.spring_damping[s0..s0 + n],
        );
        // The span's ends checked once (a vectorised maximum), then read without a check each: on the 642-vertex
        // ball (`cargo bench --bench ball`, 2026-11-24) the spring stage went 5.5–5.7 → 4.6–4.8 µs a step.
        let top = idx.iter().fold(0u32, |a, &[i, j]| a.max(i).max(j)) as usize;
        assert!(top < q.len() && top < qd.len(), "spring end out of range");
        for k in 0..n {
            let [i, j] = idx[k];
            let (i, j) = (i as usize, j as usize);
            // SAFETY: i, j <= top < q.len(), qd.len() (asserted above).
            let (qi, qj, vi, vj) =
                unsafe { (q.get_unchecked(i), q.get_unchecked(j), qd.get_unchecked(i), qd.get_unchecked(j)) };
            let [a, b, c] = (*qj - *qi).to_array();
            let [x, y, z] = (*vj - *vi).to_array();
            (t.d[0][k], t.d[1][k], t.d[2][k]) = (a, b, c);
            (t.w[0][k], t.w[1][k], t.w[2][k]) = (x, y, z);
            (t.p[0][k], t.p[1][k], t.p[2][k]) = (rest[k], ks[k], kd[k]);
        }
        {
            let ([dx, dy, dz], [wx, wy, wz], [r, s, d]) = (&t.d, &t.w, &t.p);
            let [fx, fy, fz] = &mut t.f;
            let [ex, ey, ez] = &mut e;
            // Three loops, each without a branch: the elastic pulls only for a model with load limits.
            if MEASURE && !els.is_empty() {
                for k in 0..SPAN {
                    let (f, el, len) =
                        force_parts::<R, PROJECTED>([dx[k], dy[k], dz[k]], [wx[k], wy[k], wz[k]], r[k], s[k], d[k]);
                    [fx[k], fy[k], fz[k]] = f;
                    [ex[k], ey[k], ez[k]] = el;
                    l[k] = len;
                }
            } else if MEASURE {
                for k in 0..SPAN {
                    let (f, _, len) =
                        force_parts::<R, PROJECTED>([dx[k], dy[k], dz[k]], [wx[k], wy[k], wz[k]], r[k], s[k], d[k]);
                    [fx[k], fy[k], fz[k]] = f;
                    l[k] = len;
                }
            } else {
                for k in 0..SPAN {
                    [fx[k], fy[k], fz[k]] = force_components::<R, PROJECTED>(
                        [dx[k], dy[k], dz[k]],
                        [wx[k], wy[k], wz[k]],
                        r[k],
                        s[k],
                        d[k],
                    );
                }
            }
        }
        for k in 0..n {
            out[k0 + k] = R::V::new(t.f[0][k], t.f[1][k], t.f[2][k]);
        }
        if MEASURE {
            if let Some(sink) = strain {
                // SAFETY: springs `s0 .. s0 + n` are this chunk's alone (`par::chunks` partitions them).
                unsafe { sink.store(s0, &l[..n], rest) };
            }
            if !els.is_empty() {
                for k in 0..n {
                    els[k0 + k] = R::V::new(e[0][k], e[1][k], e[2][k]);
                }
            }
        }
        k0 += n;
    }
}

/// Springs computed per span of a run at a time. A grid cloth's row runs hold `n - 1` or `n - 2` springs: 128
/// takes a 128² cloth's rows in one span each instead of two (measured 2026-11-24, one thread: 272–279 µs per
/// step against 289–297 with 64; the per-particle order of additions follows the spans, so the bits differ
/// between the two, each the same at any thread count).
pub(super) const SPAN: usize = 128;

/// Per-component stack arrays of [`span_forces`], created once per block and reused by every span.
pub(super) struct SpanScratch<R: Real> {
    d: [[R; SPAN]; 3],
    w: [[R; SPAN]; 3],
    p: [[R; SPAN]; 3],
    f: [[R; SPAN]; 3],
    /// Each lane's length (measuring spans only).
    pub(super) l: [R; SPAN],
}

impl<R: Real> SpanScratch<R> {
    pub(super) fn new() -> Self {
        let z = [[R::ZERO; SPAN]; 3];
        SpanScratch { d: z, w: z, p: z, f: z, l: [R::ZERO; SPAN] }
    }
}

/// Forces of a span of springs with contiguous ends. The positions arrive as 3-vectors (array of structs). On
/// AVX-512 (`one_loop`) one loop forms each lane from them and stores its force, which LLVM packs with strided
/// loads and stores; elsewhere that loop packs poorly, and they are transposed into per-component arrays, the
/// maths runs on those (plain loops over `[R; SPAN]` that LLVM turns into packed code, square roots and
/// divisions included), and the result is transposed back. Lanes past `out.len()` up to a multiple of
/// [`LANES`] hold stale values from an earlier span: computed, never used. The maths is [`force_components`],
/// lane by lane; `measure`: also each lane's length, into `t.l` (from [`force_parts`]: the strain is formed from
/// it only where it is stored, see [`StrainSink::store`]). On AVX-512 and AVX2 the run kernel's `f32` spans go by
/// hand instead (`super::runs_avx512`, `super::runs_avx2`: the same bits).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn span_forces<R: Real, const PROJECTED: bool>(
    t: &mut SpanScratch<R>,
    qi: &[R::V],
    qj: &[R::V],
    vi: &[R::V],
    vj: &[R::V],
    rest: &[R],
    ks: &[R],
    kd: &[R],
    out: &mut [R::V],
    measure: bool,
    one_loop: bool,
) {
    let n = out.len();
    let (qi, qj, vi, vj) = (&qi[..n], &qj[..n], &vi[..n], &vj[..n]);
    if one_loop && !measure && rest.len() >= n {
        // `one_loop` (the caller runs on AVX-512): the span's lanes in one loop, from the ends' 3-vectors to the
        // force's (LLVM packs its strided loads and stores with AVX-512's two-source permutes): no round trip
        // through the per-component arrays below. The same operations on the same values, so the same bits.
        // Measured 2026-11-26 on one thread (AMD EPYC, Zen 5), the 1024² cloth's step 8.8–9.3 → 7.9–8.4 ms
        // and the 128² 107–108 → 100–105 µs on AVX-512; on AVX2 the same loop was slower (10.8–11.0 →
        // 12.3–12.6 ms, 155–158 → 181–186 µs), so AVX2 and the baseline keep the arrays. Measuring spans keep
        // them too (they store lengths), and so do spans whose parameters must be copied. Adding the lanes'
        // forces into the block inside this loop (rather than from `out` afterwards) was tried: LLVM no longer
        // packed it, 4× slower.
        let (r, s, d) = (&rest[..n], &ks[..n], &kd[..n]);
        for k in 0..n {
            let f = force_components::<R, PROJECTED>(
                (qj[k] - qi[k]).to_array(),
                (vj[k] - vi[k]).to_array(),
                r[k],
                s[k],
                d[k],
            );
            out[k] = R::V::new(f[0], f[1], f[2]);
        }
        return;
    }
    for k in 0..n {
        let [a, b, c] = (qj[k] - qi[k]).to_array();
        let [e, f, g] = (vj[k] - vi[k]).to_array();
        (t.d[0][k], t.d[1][k], t.d[2][k]) = (a, b, c);
        (t.w[0][k], t.w[1][k], t.w[2][k]) = (e, f, g);
    }
    // Whole vectors of lanes, not the whole span: a 32² cloth's rows are spans of 31 springs. The parameters are
    // read in place where the arrays extend that far (they are contiguous along a run), else copied.
    let lanes = n.next_multiple_of(LANES).min(SPAN);
    let (r, s, d) = if rest.len() >= lanes {
        (&rest[..lanes], &ks[..lanes], &kd[..lanes])
    } else {
        t.p[0][..n].copy_from_slice(&rest[..n]);
        t.p[1][..n].copy_from_slice(&ks[..n]);
        t.p[2][..n].copy_from_slice(&kd[..n]);
        (&t.p[0][..lanes], &t.p[1][..lanes], &t.p[2][..lanes])
    };
    let ([dx, dy, dz], [wx, wy, wz]) = (&t.d, &t.w);
    let [fx, fy, fz] = &mut t.f;
    if measure {
        let l = &mut t.l;
        for k in 0..lanes {
            let (f, _, len) =
                force_parts::<R, PROJECTED>([dx[k], dy[k], dz[k]], [wx[k], wy[k], wz[k]], r[k], s[k], d[k]);
            [fx[k], fy[k], fz[k]] = f;
            l[k] = len;
        }
    } else {
        for k in 0..lanes {
            [fx[k], fy[k], fz[k]] =
                force_components::<R, PROJECTED>([dx[k], dy[k], dz[k]], [wx[k], wy[k], wz[k]], r[k], s[k], d[k]);
        }
    }
    for k in 0..n {
        out[k] = R::V::new(fx[k], fy[k], fz[k]);
    }
}

/// Lanes of the widest vectors the span loops use (8 `f32` in AVX2).
const LANES: usize = 8;

/// Where a measuring spring pass puts the springs' strains. Its kernels run in parallel, each on springs no
/// other touches: the run kernel's blocks store the springs whose end 0 they hold (blocks partition the
/// particles), the per-spring kernel's chunks their own. A grid cloth's fracture trigger then reads the strains
/// its step computed instead of a pass of its own (128² cloth, harness `terms`, 2026-11-24: the fracture stage
/// 98–101 → 10.4–10.5 µs per step, the spring pass 18–24 µs dearer).
///
/// Sparse (`over`: an instantaneous trigger, which reads only the strains past a limit): a span of springs is
/// stored only where some spring's length passes `L0 · over` (`over` = `(1 + the smallest limit)(1 - 1e-5)`,
/// a margin far above the rounding of the strain `(l - L0) / L0`, so no spring that passes its limit is
/// missed), and its range is listed. Storing every strain was what fracture added to a step that breaks
/// nothing: 0.50× the spring pass on the 128² cloth, 0.80× on the ball (97,026 strains, 388 KB a step, and a
/// division each; harness `terms`, 2026-11-24).
pub(crate) struct StrainSink<'a, R> {
    ptr: *mut R,
    len: usize,
    over: Option<R>,
    spans: std::sync::Mutex<Vec<[u32; 2]>>,
    _out: std::marker::PhantomData<&'a mut [R]>,
}

// SAFETY: the sink only writes, through `store`, to ranges its callers keep disjoint across threads (above); the
// span list is behind a mutex.
unsafe impl<R: Send> Send for StrainSink<'_, R> {}
// SAFETY: as for `Send`.
unsafe impl<R: Send> Sync for StrainSink<'_, R> {}

impl<'a, R: Real> StrainSink<'a, R> {
    /// A sink over `out`, borrowed for the sink's life; `over`: sparse (above), listing into `spans` (cleared).
    pub(crate) fn new(out: &'a mut [R], over: Option<R>, mut spans: Vec<[u32; 2]>) -> Self {
        spans.clear();
        StrainSink {
            ptr: out.as_mut_ptr(),
            len: out.len(),
            over,
            spans: std::sync::Mutex::new(spans),
            _out: std::marker::PhantomData,
        }
    }

    /// The ranges of springs stored in sparse mode, in spring order (the same list on any thread count).
    pub(crate) fn finish(self) -> Vec<[u32; 2]> {
        let mut spans = self.spans.into_inner().unwrap_or_else(|e| e.into_inner());
        spans.sort_unstable();
        spans
    }

    /// The strains of springs `at .. at + len.len()` from their lengths `len` and rest lengths `rest` (at least as
    /// long): all of them, or in sparse mode only where one may pass a limit.
    ///
    /// # Safety
    /// No other thread writes or reads that range during the sink's life.
    #[inline(always)]
    pub(super) unsafe fn store(&self, at: usize, len: &[R], rest: &[R]) {
        let n = len.len();
        let rest = &rest[..n];
        if let Some(c) = self.over {
            if !len.iter().zip(rest).fold(false, |any, (&l, &r)| any | (l > r * c)) {
                return;
            }
            self.spans.lock().unwrap_or_else(|e| e.into_inner()).push([at as u32, (at + n) as u32]);
        }
        assert!(at + n <= self.len, "strain write out of range");
        // SAFETY: in bounds (asserted); exclusive by the caller's contract.
        let out = unsafe { std::slice::from_raw_parts_mut(self.ptr.add(at), n) };
        for ((o, &l), &r) in out.iter_mut().zip(len).zip(rest) {
            *o = strain(l, r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::region_order;

    /// The merged order is a permutation of the pieces, each kind in its own order, and every piece follows the
    /// pieces of the other kind that start before it (as fractions of their arrays).
    #[test]
    fn region_order_merges_the_two_passes_by_where_their_pieces_lie() {
        let mut order = Vec::new();
        for (nt, chunk, ns, size) in [(1280, 2048, 1920, 256), (5120, 2048, 7680, 256), (20480, 2048, 30720, 256)]
            .into_iter()
            .chain([(0, 2048, 100, 256), (100, 2048, 0, 256), (7, 3, 5, 2)])
        {
            region_order(&mut order, nt, chunk, ns, size);
            let (nc, np) = (nt.div_ceil(chunk), ns.div_ceil(size));
            let mut seen = order.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..(nc + np) as u32).collect::<Vec<_>>(), "{nt} {ns}: a permutation");
            // Each piece's middle as a fraction of its array; where chunks hold half the triangles or more, starts.
            let mid = |k: u32| {
                let k = k as usize;
                let whole = k < nc && 2 * chunk >= nt;
                let (k, len, n) = if k < nc { (k, chunk, nt) } else { (k - nc, size, ns) };
                (k * len) as f64 / n as f64 + if whole { 0.0 } else { (len.min(n - k * len)) as f64 / n as f64 / 2.0 }
            };
            assert!(order.windows(2).all(|w| mid(w[0]) <= mid(w[1])), "{nt} {ns}: by middle: {order:?}");
            let tris: Vec<u32> = order.iter().copied().filter(|&k| (k as usize) < nc).collect();
            assert_eq!(tris, (0..nc as u32).collect::<Vec<_>>());
        }
        // The 2,562-vertex ball's three triangle chunks sit among the spring pieces of their middles: the first
        // after six pieces (its middle at 1/5 of the triangles), the second past the middle of the order (3/5).
        region_order(&mut order, 5120, 2048, 7680, 256);
        assert_eq!(&order[..7], &[3, 4, 5, 6, 7, 8, 0]);
        assert_eq!(order.iter().position(|&k| k == 1), Some(18 + 1));
        assert!(order.iter().position(|&k| k == 1).unwrap() > order.len() / 2);
        // The 642-vertex ball's one chunk (all its triangles) comes first.
        region_order(&mut order, 1280, 2048, 1920, 256);
        assert_eq!(order[0], 0);
    }
}
