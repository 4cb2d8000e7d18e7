//! The wind on cloth grids ([`TriGrid`]) without gathers: a row of quads at a time, from contiguous rows of
//! particles, summed per particle in place.
//!
//! The general wind pass ([`super::wind::wind_chunk`]) reads each triangle's three corners through its indices
//! and writes one force per triangle, which each particle then gathers from its six triangles: on the 128²
//! cloth those loads, not the aerodynamics, were most of the pass (one thread, 2026-11-25: 170 µs for the
//! triangles of which ~60 µs the drag and lift, and ~95 µs of per-particle gathers and scalar updates, against
//! 105 µs for the whole spring pass). On a grid every triangle's corners are known from its place: quad `(i, j)`
//! has particles `i, i + 1` of rows `j` and `j + 1`. So a tile of up to 128 quads loads the two rows' positions
//! and velocities once, transposed into per-component arrays; forms both triangles of every quad in packed loops
//! (the diagonal's parity chosen by a select); and adds each triangle's corner force into per-component row sums
//! at lane offsets `0` and `+1`, again packed. A row's sums are complete once the quad rows above and below it
//! are done, and symplectic Euler's run blocks add them in one packed pass (`solver/explicit.rs`).
//!
//! Each particle's sum is `0 + (quad row j - 1: its own quad's share, then its left neighbour's) + (quad row j:
//! the same)`, whatever the rows' split into pieces (each piece starts one quad row early and keeps only its
//! own particle rows): the same bits on any number of threads. The order differs from the per-particle gather of
//! the general pass (by rounding only: `grid_wind_matches_the_general_wind_pass` in `tests/determinism.rs`).
//!
//! Fracture changes some triangles of a grid (a split corner, a piece detached as its own body): those, and any
//! triangle outside the grids (appended by fracture), are *loose*: computed by the general kernel and added to
//! their corners' sums afterwards, in triangle order, so a tearing cloth stays on this pass (a 33 × 17 strip
//! torn through into five bodies had 18 % of its triangles loose: `a_tearing_cloth_in_wind_keeps_the_grid_wind_pass`
//! in `tests/suite/tearing.rs`). A model with over a quarter of its triangles loose uses the general pass instead (the
//! grid kernel still computes its masked triangles, and the loose ones are summed on one thread), as does a model
//! with gas (its pressure shares ride in the general pass's per-triangle forces).

use super::wind::{self, PreparedWind};
use crate::model::{Model, TriGrid};
use crate::par;
use crate::real::{Real, Vector3};

/// Quads per tile of a quad row: a row's first tile takes its first `QUADS` particles (a 128-particle row in one
/// tile), each later one `QUADS - 1` and the quad left of them.
const QUADS: usize = 128;
/// Lanes of a tile's row arrays: the quads' corners.
const LANES: usize = QUADS + 1;

/// Which triangles the grid wind pass computes: built by [`GridPlan::of_model`] when the model changes.
#[derive(Clone, Debug, Default)]
pub(crate) struct GridPlan {
    grids: Vec<PlanGrid>,
    /// 1 for each grid triangle laid out as its grid says (computed by the grid kernel), 0 for a changed one; the
    /// grids' triangles one after the other.
    regular: Vec<u8>,
    /// Triangles the general kernel computes, in order: changed grid triangles and triangles outside the grids.
    pub loose: Vec<u32>,
    /// Particles outside the grids that loose triangles touch (their sums are cleared before the loose forces
    /// are added).
    loose_particles: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct PlanGrid {
    grid: TriGrid,
    body: u32,
    /// Offset of the grid's triangles in `regular`.
    mask: usize,
}

impl GridPlan {
    /// The plan for `m`: some for a model in wind without gas whose triangles lie mostly in its recorded grids.
    pub fn of_model<R: Real>(m: &Model<R>) -> Option<Self> {
        if !m.has_wind() || m.has_pressure() || m.tri_grids.is_empty() {
            return None;
        }
        let (nt, np) = (m.tri_count(), m.particle_count());
        let mut grids: Vec<TriGrid> = m.tri_grids.clone();
        grids.sort_by_key(|g| g.first);
        // Grids in range and apart (their triangles and their particles).
        let mut spans: Vec<(usize, usize)> = Vec::new();
        for g in &grids {
            let (nx, ny) = (g.nx as usize, g.ny as usize);
            let (t0, v0) = (g.first as usize, g.base as usize);
            if nx < 2 || ny < 2 || t0 + g.tri_count() > nt || v0 + nx * ny > np {
                return None;
            }
            spans.push((v0, v0 + nx * ny));
        }
        spans.sort_unstable();
        let tris_apart = grids.windows(2).all(|w| w[0].first as usize + w[0].tri_count() <= w[1].first as usize);
        if !tris_apart || spans.windows(2).any(|w| w[0].1 > w[1].0) {
            return None;
        }
        let mut plan = GridPlan::default();
        let mut in_grid = vec![false; nt];
        let mut votes = vec![0u32; m.body_count()];
        for g in grids {
            // The grid's body: the one most of its triangles have (pieces that fracture detached become bodies of
            // their own, perhaps the piece holding the first triangle).
            let range = g.first as usize..g.first as usize + g.tri_count();
            votes.iter_mut().for_each(|v| *v = 0);
            for &b in &m.tri_body[range] {
                votes[b as usize] += 1;
            }
            let body = (0..votes.len()).max_by_key(|&b| (votes[b], std::cmp::Reverse(b))).unwrap_or(0) as u32;
            plan.grids.push(PlanGrid { grid: g, body, mask: plan.regular.len() });
            for j in 0..g.ny - 1 {
                for i in 0..g.nx - 1 {
                    let t = g.first as usize + 2 * (j * (g.nx - 1) + i) as usize;
                    for (k, want) in g.quad(i, j).into_iter().enumerate() {
                        let ok = m.tri_indices[t + k] == want && m.tri_body[t + k] == body;
                        plan.regular.push(ok as u8);
                        in_grid[t + k] = ok;
                    }
                }
            }
        }
        plan.loose = (0..nt as u32).filter(|&t| !in_grid[t as usize]).collect();
        if plan.loose.len() * 4 > nt {
            return None;
        }
        let mut outside = vec![true; np];
        for &(a, b) in &spans {
            outside[a..b].iter_mut().for_each(|o| *o = false);
        }
        let mut touched: Vec<u32> =
            (plan.loose.iter()).flat_map(|&t| m.tri_indices[t as usize]).filter(|&v| outside[v as usize]).collect();
        touched.sort_unstable();
        touched.dedup();
        plan.loose_particles = touched;
        Some(plan)
    }

    /// Each particle's sum of its triangles' wind forces into `sums` (one per particle; entries of particles
    /// without triangles are left as they are: zero, see [`super::ForceScratch::resize`]). `loose_f`: room for
    /// the loose triangles' forces.
    #[allow(clippy::too_many_arguments)]
    pub fn run<R: Real>(
        &self,
        m: &Model<R>,
        q: &[R::V],
        qd: &[R::V],
        w: &PreparedWind<R>,
        rho_half: R,
        pressure: &[R],
        sums: &mut [R::V],
        loose_f: &mut [R::V],
    ) {
        let third = R::from_f64(1.0 / 3.0);
        for g in &self.grids {
            let (nx, ny) = (g.grid.nx as usize, g.grid.ny as usize);
            let base = g.grid.base as usize;
            let out = &mut sums[base..base + nx * ny];
            // Two pieces a thread, of at least 8 rows (each piece computes the quad row above it again: the 128²
            // cloth's 16 pieces of 8 rows on the team did 12% more quad rows than the cloth has).
            let threads = par::threads_for(nx * ny, usize::MAX);
            let rows = (ny / (2 * threads)).max(8).min(ny);
            let pieces = par::Pieces::new(out, rows * nx);
            let (cd, cl) = (m.body_drag[g.body as usize], m.body_lift[g.body as usize]);
            let coef = Coef { cd, cl, rho_half, third };
            let mask = &self.regular[g.mask..g.mask + g.grid.tri_count()];
            let pool = par::is_pooled(nx * ny);
            // SAFETY: `exec` runs each piece index once.
            par::exec(pool, pieces.count(), &|c| unsafe {
                rows_dispatch(&g.grid, q, qd, mask, w, &coef, c * rows, pieces.get(c))
            });
        }
        if self.loose.is_empty() {
            return;
        }
        // The loose triangles' forces in parallel (each its own), then added to their corners in order.
        let loose_f = &mut loose_f[..self.loose.len()];
        let (pool, size) = (par::is_pooled(self.loose.len()), par::piece(par::CHUNK));
        par::chunks_pooled(pool, size, loose_f, |start, out| {
            let ids = &self.loose[start..start + out.len()];
            wind::wind_chunk(m, q, wind::Air::Corners(qd), wind::Tris::List(ids), pressure, rho_half, w, out)
        });
        for &v in &self.loose_particles {
            sums[v as usize] = R::V::ZERO;
        }
        for (&t, &f) in self.loose.iter().zip(loose_f.iter()) {
            for v in m.tri_indices[t as usize] {
                sums[v as usize] += f;
            }
        }
    }
}

/// A grid's aerodynamic coefficients `C_D`, `C_L`, `ρ / 2`, and `1/3`.
struct Coef<R> {
    cd: R,
    cl: R,
    rho_half: R,
    third: R,
}

crate::isa::wide_kernel! {
    /// [`rows`] compiled for AVX-512 or AVX2 when the CPU has them (the same bits: see `crate::isa`).
    fn rows_dispatch[R: Real](
        g: &TriGrid,
        q: &[R::V],
        qd: &[R::V],
        mask: &[u8],
        w: &PreparedWind<R>,
        c: &Coef<R>,
        j0: usize,
        out: &mut [R::V],
    ) => rows[R]
}

/// Positions of a row's particles in a tile and the air relative to each, per component.
#[derive(Clone, Copy)]
struct Row<R> {
    x: [[R; LANES]; 3],
    /// `w(x) - v`: the air velocity relative to the particle, as [`wind::relative_air`] forms it.
    rel: [[R; LANES]; 3],
}

impl<R: Real> Row<R> {
    fn new() -> Self {
        let z = [[R::ZERO; LANES]; 3];
        Row { x: z, rel: z }
    }

    /// Particles `start .. start + n` (lanes past `n` keep what they held: computed, never used), and the wind
    /// sampled once at each: a row is loaded once per tile, so every particle's sample is shared by its six
    /// triangles.
    #[inline(always)]
    fn load(&mut self, q: &[R::V], qd: &[R::V], start: usize, n: usize, w: &PreparedWind<R>) {
        let (fq, fv) = (R::flat(&q[start..start + n]), R::flat(&qd[start..start + n]));
        for k in 0..n {
            for e in 0..3 {
                self.x[e][k] = fq[3 * k + e];
                self.rel[e][k] = fv[3 * k + e];
            }
        }
        for k in 0..n.next_multiple_of(16).min(LANES) {
            let (x, v) = (&self.x, &self.rel);
            let rel = w.relative_components([x[0][k], x[1][k], x[2][k]], [v[0][k], v[1][k], v[2][k]]);
            for e in 0..3 {
                self.rel[e][k] = rel[e];
            }
        }
    }
}

/// Per-component arrays over a tile's quads.
type Lanes<R> = [[R; QUADS]; 3];

/// What a tile's quads give their corners: quad `k`'s share to its particle `k` (`l`) and `k + 1` (`r`) of the
/// lower row (`0`) and the upper one (`1`).
struct Shares<R> {
    l0: Lanes<R>,
    r0: Lanes<R>,
    l1: Lanes<R>,
    r1: Lanes<R>,
}

/// The sums of particle rows `j0 .. j0 + out.len() / nx` of grid `g` into `out` (those rows, row-major).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn rows<R: Real>(
    g: &TriGrid,
    q: &[R::V],
    qd: &[R::V],
    mask: &[u8],
    w: &PreparedWind<R>,
    c: &Coef<R>,
    j0: usize,
    out: &mut [R::V],
) {
    let (nx, ny, base) = (g.nx as usize, g.ny as usize, g.base as usize);
    let j1 = j0 + out.len() / nx;
    // Quad rows `rlo .. rhi`: the one above the first particle row too (its lower share), none below the last.
    let (rlo, rhi) = (j0.saturating_sub(1), j1.min(ny - 1));
    let z = [[R::ZERO; QUADS]; 3];
    let mut rows = [Row::<R>::new(), Row::<R>::new()];
    let mut s = Shares { l0: z, r0: z, l1: z, r1: z };
    let mut i0 = 0;
    while i0 < nx {
        let i1 = (i0 + if i0 == 0 { QUADS } else { QUADS - 1 }).min(nx);
        // Quads `qlo .. qhi` (the one left of the tile too, for its right share), particles `qlo ..= qhi`.
        let (qlo, qhi) = (i0.saturating_sub(1), i1.min(nx - 1));
        let nq = qhi - qlo;
        rows[rlo % 2].load(q, qd, base + rlo * nx + qlo, nq + 1, w);
        // Sums of particle rows `r` and `r + 1` (tile lanes: particle `i0 + k`).
        let mut acc = [z, z];
        let (ka, kb) = (i0 - qlo, (i1 - qlo - 1).min(nq));
        for r in rlo..rhi {
            rows[(r + 1) % 2].load(q, qd, base + (r + 1) * nx + qlo, nq + 1, w);
            let quads = &mask[2 * (r * (nx - 1) + qlo)..2 * (r * (nx - 1) + qhi)];
            let (lo, hi) = (&rows[r % 2], &rows[(r + 1) % 2]);
            quad_row(lo, hi, quads, (qlo + r) % 2 == 0, nq, c, &mut s);
            let [a0, a1] = &mut acc;
            let (now, next) = if r % 2 == 0 { (a0, a1) } else { (a1, a0) };
            // Particle `v` of row r takes `l0` of quad `v` and `r0` of quad `v - 1`; of row r + 1, `l1` and `r1`
            // the same way. Lane k of the shares is quad `qlo + k`.
            add_shares(now, &s.l0, &s.r0, ka, kb, nq);
            if r >= j0 {
                store(now, &mut out[(r - j0) * nx + i0..(r - j0) * nx + i1]);
            }
            *now = z;
            add_shares(next, &s.l1, &s.r1, ka, kb, nq);
        }
        // The last particle row has no quad row below it.
        if rhi == ny - 1 && rhi >= j0 && rhi < j1 {
            store(&acc[rhi % 2], &mut out[(rhi - j0) * nx + i0..(rhi - j0) * nx + i1]);
        }
        i0 = i1;
    }
}

/// `acc[v] += l[v + ka]` for the tile's particles `v` right of a quad of the tile, then `acc[v] += r[v + ka - 1]`.
#[inline(always)]
fn add_shares<R: Real>(acc: &mut Lanes<R>, l: &Lanes<R>, r: &Lanes<R>, ka: usize, kb: usize, nq: usize) {
    // Slices zipped (not indices with offsets): the adds vectorise (with indices they did not, and cost the pass
    // as much as its geometry).
    for e in 0..3 {
        for (d, &x) in acc[e][..nq - ka].iter_mut().zip(&l[e][ka..nq]) {
            *d += x;
        }
        for (d, &x) in acc[e][1 - ka..kb + 1 - ka].iter_mut().zip(&r[e][..kb]) {
            *d += x;
        }
    }
}

#[inline(always)]
fn store<R: Real>(acc: &Lanes<R>, out: &mut [R::V]) {
    for (k, o) in out.iter_mut().enumerate() {
        *o = R::V::new(acc[0][k], acc[1][k], acc[2][k]);
    }
}

/// Both triangles of a tile's quads (`even`: whether its first quad's `i + j` is even), their corner forces, and
/// what each corner gets, into `s`. Quad `(i, j)` with corners `p00, p10` (row j) and `p01, p11` (row j + 1):
/// for even `i + j` triangles `A = (p00, p01, p11)`, `B = (p00, p11, p10)`, else `A = (p00, p01, p10)`,
/// `B = (p10, p01, p11)` ([`TriGrid::quad`]). The maths of [`wind::aero_components`], lane by lane; a changed
/// triangle (`quads[2k + s] == 0`) gives nothing. The `nq` quads are computed in whole vectors of 16 lanes;
/// those past `nq` are never used.
///
/// The choices are made on the bits ([`Real::kept`], [`Real::pick`]), not by selects: from `if` selects LLVM's
/// AVX2 code wrote the shares as pairs of masked stores (`vmaskmovps`, microcoded on AMD's cores): on the Zen 3
/// development VM the wind added 228–328 µs to the 128² cloth's step, against 117–133 µs now (the same bits;
/// `benches/RESULTS.md`, issue 15's (38)).
#[inline(always)]
fn quad_row<R: Real>(lo: &Row<R>, hi: &Row<R>, quads: &[u8], even: bool, nq: usize, c: &Coef<R>, s: &mut Shares<R>) {
    let (mut ok_a, mut ok_b) = ([false; QUADS], [false; QUADS]);
    for (k, t) in quads.chunks_exact(2).enumerate() {
        (ok_a[k], ok_b[k]) = (t[0] != 0, t[1] != 0);
    }
    for k in 0..nq.next_multiple_of(16).min(QUADS) {
        let ev = (k % 2 == 0) == even;
        let p = |r: &Row<R>, o: usize| [r.x[0][k + o], r.x[1][k + o], r.x[2][k + o]];
        let u = |r: &Row<R>, o: usize| [r.rel[0][k + o], r.rel[1][k + o], r.rel[2][k + o]];
        let sel = |e: bool, a: [R; 3], b: [R; 3]| if e { a } else { b };
        let (p00, p10, p01, p11) = (p(lo, 0), p(lo, 1), p(hi, 0), p(hi, 1));
        let (u00, u10, u01, u11) = (u(lo, 0), u(lo, 1), u(hi, 0), u(hi, 1));
        let a = triangle_force([p00, p01, sel(ev, p11, p10)], [u00, u01, sel(ev, u11, u10)], c);
        let b = triangle_force(
            [sel(ev, p00, p10), sel(ev, p11, p01), sel(ev, p10, p11)],
            [sel(ev, u00, u10), sel(ev, u11, u01), sel(ev, u10, u11)],
            c,
        );
        // Even quads: p00 and p11 in both triangles, p01 in A, p10 in B; odd: p01 and p10 in both, p00 in A, p11
        // in B.
        for e in 0..3 {
            let (a, b) = (a[e].kept(ok_a[k]), b[e].kept(ok_b[k]));
            let both = a + b;
            s.l0[e][k] = R::pick(ev, both, a);
            s.r0[e][k] = R::pick(ev, b, both);
            s.l1[e][k] = R::pick(ev, a, both);
            s.r1[e][k] = R::pick(ev, both, b);
        }
    }
}

/// One triangle's corner force (a third of its drag and lift) from its corners' positions and relative airs: the
/// general kernel's formulas (the corners' mean relative air, the cross vector, [`wind::aero_components`]).
#[inline(always)]
fn triangle_force<R: Real>(x: [[R; 3]; 3], rel: [[R; 3]; 3], c: &Coef<R>) -> [R; 3] {
    let t = c.third;
    let air = [0, 1, 2].map(|e| (rel[0][e] + rel[1][e] + rel[2][e]) * t);
    let d1 = [0, 1, 2].map(|e| x[1][e] - x[0][e]);
    let d2 = [0, 1, 2].map(|e| x[2][e] - x[0][e]);
    let cross = [d1[1] * d2[2] - d2[1] * d1[2], d1[2] * d2[0] - d2[2] * d1[0], d1[0] * d2[1] - d2[0] * d1[1]];
    let f = wind::aero_components(cross, air, c.cd, c.cl, c.rho_half);
    [f[0] * t, f[1] * t, f[2] * t]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ClothOptions, Gas, ModelBuilder, SoftBodyOptions};
    use crate::{Mesh, WindField};
    use glam::DVec3;

    fn cloth(wind: bool, gas_ball: bool) -> Model<f64> {
        let mut b = ModelBuilder::new();
        b.add_cloth_grid(12, 9, 0.01, |p| p, &ClothOptions::default()).unwrap();
        if gas_ball {
            let opts = SoftBodyOptions { gas: Gas::Pressure(100.0), ..Default::default() };
            b.add_soft_body(&Mesh::icosphere(0.1, 1).translated(DVec3::new(0.0, 1.0, 0.0)), &opts).unwrap();
        }
        if wind {
            b.wind(WindField::default()).unwrap();
        }
        b.finalize().unwrap()
    }

    #[test]
    fn a_plan_for_grids_in_wind_without_gas() {
        let m = cloth(true, false);
        let plan = GridPlan::of_model(&m).expect("a grid cloth in wind has a plan");
        assert!(plan.loose.is_empty() && plan.regular.iter().all(|&r| r == 1));
        assert_eq!(plan.regular.len(), m.tri_count());
        assert!(GridPlan::of_model(&cloth(false, false)).is_none(), "no wind, no plan");
        assert!(GridPlan::of_model(&cloth(true, true)).is_none(), "gas takes the general pass");
        let mut other = m.clone();
        other.tri_grids.clear();
        assert!(GridPlan::of_model(&other).is_none(), "no grid recorded, no plan");
    }

    #[test]
    fn triangles_off_the_layout_are_loose_and_a_mostly_loose_model_has_no_plan() {
        let mut m = cloth(true, false);
        for t in [3usize, 40, 41] {
            let [a, b, c] = m.tri_indices[t];
            m.tri_indices[t] = [b, c, a];
        }
        let plan = GridPlan::of_model(&m).unwrap();
        assert_eq!(plan.loose, vec![3, 40, 41]);
        assert_eq!(plan.regular.iter().filter(|&&r| r == 0).count(), 3);
        for t in 0..m.tri_count() / 4 + 1 {
            let [a, b, c] = m.tri_indices[t];
            m.tri_indices[t] = [b, c, a];
        }
        assert!(GridPlan::of_model(&m).is_none(), "over a quarter loose: the general pass");
        // A grid recorded out of range is refused, not trusted.
        let mut bad = cloth(true, false);
        bad.tri_grids[0].ny += 1;
        assert!(GridPlan::of_model(&bad).is_none());
    }

    /// Each particle's sum is the same whatever the cut of the rows into pieces (the bits on any thread count).
    #[test]
    fn the_sums_do_not_depend_on_the_pieces() {
        let mut b = ModelBuilder::new();
        b.add_cloth_grid(140, 21, 0.01, |p| p, &ClothOptions::default()).unwrap();
        b.wind(WindField { velocity: DVec3::new(1.0, 2.0, 3.0), ..Default::default() }).unwrap();
        let m: Model<f64> = b.finalize().unwrap();
        let plan = GridPlan::of_model(&m).unwrap();
        let g = plan.grids[0].grid;
        let (q, qd) = (m.particle_q0.clone(), vec![DVec3::new(0.1, -0.2, 0.3); m.particle_count()]);
        let w = m.wind.as_ref().unwrap().prepare::<f64>(0.3);
        let c = Coef { cd: 1.0, cl: 0.5, rho_half: 0.6125, third: 1.0 / 3.0 };
        let rows_of = |cut: &[usize]| {
            let mut out = vec![DVec3::ZERO; m.particle_count()];
            for win in cut.windows(2) {
                let (j0, j1) = (win[0], win[1]);
                rows(&g, &q, &qd, &plan.regular, &w, &c, j0, &mut out[j0 * 140..j1 * 140]);
            }
            out
        };
        let whole = rows_of(&[0, 21]);
        assert!(whole.iter().all(|f| f.length() > 0.0), "every particle has a triangle in the wind");
        assert_eq!(whole, rows_of(&[0, 1, 8, 9, 20, 21]));
        assert_eq!(whole, rows_of(&[0, 10, 21]));
    }
}
