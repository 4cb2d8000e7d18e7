//! Contact between surfaces: every body that asks for it ([`crate::ModelBuilder::set_contact`]) against every
//! other such body, against the pieces fracture breaks off it, and (with [`Contact::self_collision`]) against
//! itself.
//!
//! # The model
//! Vertex–triangle and edge–edge pairs closer than the pair's thickness `h` (the larger of the two bodies') are
//! kept `h` apart. Elements that share a vertex are never a pair; neither are elements that share a vertex's
//! *origin* (the particle it was split from), so the virtual nodes of one fracture, which coincide when they are
//! created, do not push each other apart.
//!
//! Each substep, after the integrator and the colliders (`solver/contact/`):
//! 1. **Candidates** (broad phase): a uniform grid ([`grid::HashGrid`], counting sort, as the GPU builds it; dense
//!    where the points fill their box of cells, hashed where they are scattered) of vertices for vertex–triangle
//!    pairs and of edge midpoints for edge–edge pairs, each entry carrying its element's box in `f32` rounded
//!    outward (the searches' first test, read in the grid's own order), gives every pair closer than a search
//!    radius `R` at the step's start, each element's partners in index order. The list is kept between steps (a
//!    Verlet list) while no missed pair can have come within reach, judged per pair of bodies from how far apart
//!    their boxes were and how far their points drifted since: cost grows with the surface, not its square, and a
//!    resting scene rebuilds rarely. A list built at a passing peak of speed (its radius follows the fastest
//!    particle) is built again once it is well past the radius the step wants. Since the pairs within reach are
//!    listed in index order whenever the list was built, a kept list gives the same bits as one rebuilt at every
//!    step.
//! 2. **Repulsion with friction**: for each pair within reach, an impulse along the normal between the closest
//!    points makes the predicted gap at the end of the step at least `h` (a pair already inside `h` is eased out
//!    by [`RELAX`] of its overlap per step instead, so resting contact does not jitter; per [`PUSH_TIME`] when the
//!    step is shorter, so that a tiny step does not turn the overlap into a large velocity), applied to the four
//!    particles with their barycentric weights. Equal and opposite by construction: momentum is conserved. The
//!    impulses are solved by projected Gauss–Seidel in the pairs' fixed order (deterministic at any thread count),
//!    then Coulomb friction removes tangential relative velocity up to `μ` times the normal impulse. Inelastic:
//!    kinetic energy never grows; bodies bounce by their own springs and gas.
//! 3. **A displacement bound** guarantees no crossing: every particle's move in the step is capped at
//!    [`GAMMA`] (< 1/2) times the distance from each element it belongs to to the nearest element it could meet.
//!    Two elements `d` apart then close in by less than `2 × GAMMA × d < d`: they cannot touch during the step,
//!    whatever the impulses did. This is the bound of Offset Geometric Contact (Chen et al. 2025), chosen over
//!    continuous collision detection because it is exact without root finding (a CCD cubic on a steep
//!    trajectory is where robust implementations spend their care), costs one distance per candidate pair,
//!    is the same on the GPU, and guarantees the invariant the tests check (no two triangles ever cross). It
//!    rarely binds: a pair is *within reach* when it is closer than its own reach `h + d_P / GAMMA` (`d_P`
//!    the largest move this step of its four particles), so a particle with nothing within reach moves freely,
//!    and a particle's bound starts at `GAMMA h + d_i`, which keeps it within `GAMMA` of the gap of every pair it
//!    is in but not within reach; the impulses keep pairs at `h`, where the cap is `GAMMA h` per step (metres
//!    per second of sliding at the scenes' steps). A capped particle's velocity is scaled down with its move
//!    (energy only decreases). The reach is the pair's own, not the fastest particle's anywhere (as it was until
//!    2026-11-27): on the folding 128² cloth one corner moves 20× the median particle, and with one reach for all
//!    the pairs within it were 8,145 a step where their own reaches keep 1,333 (`cargo bench --bench contact`).
//! 4. **The colliders again**, for the particles the pass moved (their pass ran before this one): a push from
//!    another body can press a particle resting on the ground into it. The collider's push is taken when the
//!    particle's whole move stays within its bound, so the no-crossing guarantee holds; otherwise the particle
//!    keeps the contact's position. (Added 2026-11-25: a block pressed by the ball into the ground stayed up to
//!    0.12 mm inside at a frame's end.) The GPU does the same (`contact_apply`).
//!
//! The guarantee is that no step makes a crossing; it cannot undo one a fracture makes. A body without
//! self-contact may cross itself (the fracture scene's torn ball, flattened on the floor, lies in layers in one
//! plane), and a piece that breaks off where it does is born crossing its parent: no contact acted between them
//! before. The pass sees distances, not sides: it held such a pair `h` apart and capped its moves at `GAMMA` of a
//! gap that was already nothing, so the piece and the parent's particles it crossed stayed where they were (on
//! the fracture scene, 2026-12-07, seven particles capped at nearly every step for the last 0.4 s). So a piece
//! born crossing a body of its family (the body it broke from, or other pieces of it) takes no contact with that
//! body, as the body took none with itself, until no triangle of the one comes within a thickness of the other
//! ([`bodies_within`]); from then on the two are held apart like any pair ([`family`]).
//! `tests/scene_check` excuses the same pairs of bodies over the same span, and no others. The GPU leaves out the
//! same pairs (listed after the bodies in its `c_body`), but asks whether they have parted only where the host
//! holds the current state (every step that reads it back, the first after a fracture pass), so a pair may stay
//! left out there a little longer.
//!
//! On the GPU (`fissure-gpu`, `shaders/contact.wgsl`) the same model runs with two differences, both for a machine
//! of thousands of threads: the grids are built at every substep (a counting sort with u32 atomics, no Verlet
//! list to keep valid), and the impulses are solved by Jacobi iterations (each pair's update scaled by one over the
//! most pairs any of its particles is in) instead of Gauss–Seidel, their velocity changes summed in fixed point with
//! integer atomics (WGSL has no float atomics, and integer sums do not depend on the order the racing threads add
//! them in, so a GPU run is deterministic). The pairs are the CPU's (tested exactly on a fixed configuration);
//! the displacement bound is the same, so the no-crossing guarantee holds there too.
//!
//! With implicit Euler the same pass runs after the solve (contact is not in the linear system): stable at any
//! step, since it only removes relative velocity and caps moves.
//!
//! An explicit step above the springs' stability bound is refused on a model in contact
//! ([`crate::stability::ContactStepGuard`], both solvers): the displacement bound would cap the instability's
//! runaway moves, and the run would go on jittering, many times slower, instead of blowing up with an error
//! that names the step.

pub mod family;
pub mod geometry;
pub mod grid;

use crate::error::ModelError;
use crate::model::Model;
use crate::real::{Real, Vector3};
use glam::DVec3;
use grid::HashGrid;

/// The displacement bound's fraction of the distance to the nearest element that could be met (< 1/2).
pub const GAMMA: f64 = 0.45;
/// Fraction of a pair's overlap into its thickness recovered per step (per [`PUSH_TIME`] when the step is shorter).
pub const RELAX: f64 = 0.1;
/// The shortest time, in seconds, over which [`RELAX`] of a pair's overlap is recovered. The push-out is a rate:
/// its speed is at most `RELAX × overlap / PUSH_TIME`, whatever the step. Without it a step of `dt` pushed at
/// `RELAX × overlap / dt`: a step of 1e-8 s (a caller's `World::step`, or an advance's remainder before
/// `World::advance` kept its steps ≥ dt/2) turned a millimetre of overlap into 10 km/s, which the displacement bound
/// kept from crossing but which stayed in the velocities. At the scenes' steps (≥ 1.4e-4 s) nothing changes.
pub const PUSH_TIME: f64 = 1e-4;
/// Default thickness as a fraction of the body's mean edge length.
pub const THICKNESS_PER_EDGE: f64 = 0.2;

/// How a body takes part in contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Gap kept between two surfaces \[m\] (the larger of the two bodies' values). `None`: 0.2 × the body's mean
    /// edge length at rest.
    ///
    /// The pass's cost grows quickly once it passes about half an edge length: every element within a few
    /// thicknesses of another is a candidate tested at every step. The four balloons of `scenes/balloons.toml`
    /// (edges ~3.3 cm, the default ~6.6 mm) spent 0.26 s of contact over their first 0.4 s with the default or 1.5 cm,
    /// 0.53 s at 3 cm, 1.16 s at 6 cm and 5.44 s at 12 cm (`fissure run scenes/balloons.toml --frames 12 --set
    /// 'body[0].thickness=…'` for each body, 2026-11-29, a 2-core AMD EPYC Zen 3 VM). A thick shell on a coarse
    /// mesh is better given by a finer mesh.
    pub thickness: Option<f64>,
    /// Also against itself (a cloth folding, a ball squashed flat). Default false: only against other bodies
    /// (including pieces broken off it).
    pub self_collision: bool,
    /// Coulomb friction coefficient (the mean of the two bodies'). Default 0.3.
    pub friction: f64,
}

impl Default for Contact {
    fn default() -> Self {
        Contact { thickness: None, self_collision: false, friction: 0.3 }
    }
}

impl Contact {
    pub(crate) fn check(&self) -> Result<(), ModelError> {
        if let Some(h) = self.thickness
            && !(h.is_finite() && h > 0.0)
        {
            return Err(ModelError::Parameter { name: "contact.thickness", value: h, expected: "finite and > 0 [m]" });
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(ModelError::Parameter { name: "contact.friction", value: self.friction, expected: ">= 0" });
        }
        Ok(())
    }
}

/// The elements of a model that take part in contact: triangles, their unique edges, their particles.
#[derive(Clone, Debug, Default)]
pub(crate) struct Elements {
    pub tris: Vec<u32>,
    pub edges: Vec<[u32; 2]>,
    /// `0..edges.len()`.
    pub edge_ids: Vec<u32>,
    pub particles: Vec<u32>,
    /// Largest thickness of any body in contact \[m\].
    pub h_max: f64,
    /// How many of `edges` each body has (by its lower end's body), indexed by body.
    pub edges_per_body: Vec<u32>,
}

impl Elements {
    /// The elements of `m` in index order: edges sorted by (lower end, upper end), particles ascending. Built
    /// after every fracture event, so in linear time: the edges bucketed by their lower end (a counting sort),
    /// each bucket's few upper ends sorted and deduplicated, the particles marked (sorting the 3 × triangles
    /// half-edges took the fracture scene ~140 µs an event).
    pub fn of<R: Real>(m: &Model<R>) -> Self {
        let on = |b: u32| m.body_contact_thickness.get(b as usize).is_some_and(|&h| h > R::ZERO);
        let tris: Vec<u32> = (0..m.tri_count() as u32).filter(|&t| on(m.tri_body[t as usize])).collect();
        let n = m.particle_count();
        let half = |t: u32| {
            let [a, b, c] = m.tri_indices[t as usize];
            [[a, b], [b, c], [c, a]].map(|[i, j]| [i.min(j), i.max(j)])
        };
        let mut start = vec![0u32; n + 2];
        let mut used = vec![false; n];
        for &t in &tris {
            for [i, j] in half(t) {
                start[i as usize + 2] += 1;
                used[i as usize] = true;
                used[j as usize] = true;
            }
        }
        for i in 2..n + 2 {
            start[i] += start[i - 1];
        }
        let mut upper = vec![0u32; start[n + 1] as usize];
        for &t in &tris {
            for [i, j] in half(t) {
                let slot = &mut start[i as usize + 1];
                upper[*slot as usize] = j;
                *slot += 1;
            }
        }
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(upper.len() / 2 + 1);
        for i in 0..n {
            let ends = &mut upper[start[i] as usize..start[i + 1] as usize];
            ends.sort_unstable();
            let mut last = None;
            for &j in ends.iter() {
                if last != Some(j) {
                    edges.push([i as u32, j]);
                    last = Some(j);
                }
            }
        }
        let particles: Vec<u32> = (0..n as u32).filter(|&i| used[i as usize]).collect();
        let h_max = m.body_contact_thickness.iter().map(|h| h.to_f64()).fold(0.0, f64::max);
        let edge_ids = (0..edges.len() as u32).collect();
        let mut edges_per_body = vec![0u32; m.body_count()];
        edges.iter().for_each(|e| edges_per_body[m.particle_body[e[0] as usize] as usize] += 1);
        Elements { tris, edges, edge_ids, particles, h_max, edges_per_body }
    }
}

/// True if particles `a` and `b` are, or were split from, the same particle.
#[inline]
pub(crate) fn same_origin<R: Real>(m: &Model<R>, a: u32, b: u32) -> bool {
    m.particle_origin[a as usize] == m.particle_origin[b as usize]
}

/// Whether a triangle of body `a` crosses one of body `b`, or comes within `gap` \[m\] of it, at positions `q`.
/// Triangles that share a vertex's origin (neighbours across a split) are not tested. The smaller body's
/// triangles are tested against the boxes of the larger's: a piece of a few triangles against a ball costs a pass
/// over the ball's triangles. What decides when a piece born crossing its family has parted from it (see the
/// module docs); `gap = 0` asks only whether they cross.
pub fn bodies_within<R: Real>(m: &Model<R>, q: &[R::V], a: u32, b: u32, gap: f64) -> bool {
    let (mut of_a, mut of_b) = (Vec::new(), Vec::new());
    for (t, &body) in m.tri_body.iter().enumerate() {
        if body == a {
            of_a.push(t as u32);
        } else if body == b {
            of_b.push(t as u32);
        }
    }
    let (small, large) = if of_a.len() <= of_b.len() { (of_a, of_b) } else { (of_b, of_a) };
    let corners = |t: u32| m.tri_indices[t as usize].map(|i| q[i as usize].to_dvec3());
    let bounds = |c: [DVec3; 3]| (c[0].min(c[1]).min(c[2]) - gap, c[0].max(c[1]).max(c[2]) + gap);
    let small: Vec<(u32, [DVec3; 3], (DVec3, DVec3))> =
        small.into_iter().map(|t| (t, corners(t), bounds(corners(t)))).collect();
    let Some(all) = small.iter().map(|s| s.2).reduce(|p, r| (p.0.min(r.0), p.1.max(r.1))) else {
        return false;
    };
    large.into_iter().any(|u| {
        let d = corners(u);
        let (lo, hi) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
        if lo.cmpgt(all.1).any() || hi.cmplt(all.0).any() {
            return false;
        }
        small.iter().any(|&(t, c, (clo, chi))| {
            lo.cmple(chi).all()
                && clo.cmple(hi).all()
                && !neighbours(m, t, u)
                && (if gap > 0.0 { geometry::triangles_distance(c, d) <= gap } else { geometry::triangles_cross(c, d) })
        })
    })
}

/// True if triangles `t` and `u` share a vertex or a vertex's origin (neighbours, or neighbours across a split):
/// never a crossing.
fn neighbours<R: Real>(m: &Model<R>, t: u32, u: u32) -> bool {
    let uv = m.tri_indices[u as usize];
    m.tri_indices[t as usize].iter().any(|&a| uv.iter().any(|&b| same_origin(m, a, b)))
}

/// Default thickness of a body with these triangles \[m\]: [`THICKNESS_PER_EDGE`] × mean edge length.
pub(crate) fn default_thickness(q: &[DVec3], tris: impl Iterator<Item = [u32; 3]>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for [a, b, c] in tris {
        for (i, j) in [(a, b), (b, c), (c, a)] {
            sum += (q[j as usize] - q[i as usize]).length();
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { THICKNESS_PER_EDGE * sum / n as f64 }
}

/// Pairs of triangles `[t, u]` (`t < u`) that intersect at positions `q`, found with the exact test of
/// [`geometry::triangles_cross`]. Triangles that share a vertex, or a vertex's origin (virtual nodes of one
/// split), are neighbours and are not tested. Every triangle of the model takes part, in contact or not. A
/// diagnostic for tests and users (a hash grid, about a microsecond per triangle), not part of a step.
pub fn crossings<R: Real>(m: &Model<R>, q: &[R::V]) -> Vec<[u32; 2]> {
    let x = |i: u32| q[i as usize].to_dvec3();
    let nt = m.tri_count();
    let corners = |t: usize| m.tri_indices[t].map(x);
    let mut l_max: f64 = 0.0;
    for t in 0..nt {
        let c = corners(t);
        l_max = l_max.max((c[1] - c[0]).length()).max((c[2] - c[1]).length()).max((c[0] - c[2]).length());
    }
    if nt < 2 || !(l_max.is_finite() && l_max > 0.0) {
        return Vec::new();
    }
    let mut grid = HashGrid::<()>::default();
    let centroid = |t: usize| corners(t).iter().sum::<DVec3>() / 3.0;
    grid.build(l_max, nt, |t| Some((centroid(t), ())));
    let mut out = Vec::new();
    for t in 0..nt {
        let c = corners(t);
        let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
        grid.query(lo - l_max, hi + l_max, |u, _| {
            let u = u as usize;
            if u <= t {
                return;
            }
            if neighbours(m, t as u32, u as u32) {
                return;
            }
            let d = corners(u);
            let (lo2, hi2) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
            if lo.cmple(hi2).all() && lo2.cmple(hi).all() && geometry::triangles_cross(c, d) {
                out.push([t as u32, u as u32]);
            }
        });
    }
    out
}

/// The contact thickness of body `b` \[m\] (0: no contact), as `f64`.
pub fn thickness<R: Real>(m: &Model<R>, b: usize) -> f64 {
    m.body_contact_thickness[b].to_f64()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::model::{ClothOptions, ModelBuilder, SoftBodyOptions};
    use glam::DVec3;

    /// The linear-time build lists what sorting the half-edges lists: a closed ball (each edge twice), an open
    /// cloth (boundary edges once) and a body without contact (left out), renumbered so that lower ends vary.
    #[test]
    fn elements_are_the_sorted_unique_edges_of_the_contact_triangles() {
        let mut b = ModelBuilder::new();
        let off = b.add_soft_body(&Mesh::icosphere(0.2, 2), &SoftBodyOptions::default()).unwrap();
        let ball = b.add_soft_body(&Mesh::icosphere(0.2, 2).translated(DVec3::X), &SoftBodyOptions::default()).unwrap();
        let cloth = b.add_cloth(&Mesh::grid(7, 5, 0.05), &ClothOptions::default()).unwrap();
        b.set_contact(ball.index, Contact::default()).unwrap();
        b.set_contact(cloth.index, Contact::default()).unwrap();
        let m = b.finalize::<f64>().unwrap();
        let el = Elements::of(&m);
        let tris: Vec<u32> =
            (0..m.tri_count() as u32).filter(|&t| m.tri_body[t as usize] as usize != off.index).collect();
        let mut edges: Vec<[u32; 2]> = tris
            .iter()
            .flat_map(|&t| {
                let [a, b, c] = m.tri_indices[t as usize];
                [[a, b], [b, c], [c, a]].map(|[i, j]| [i.min(j), i.max(j)])
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let mut particles: Vec<u32> = tris.iter().flat_map(|&t| m.tri_indices[t as usize]).collect();
        particles.sort_unstable();
        particles.dedup();
        assert_eq!(el.tris, tris);
        assert_eq!(el.edges, edges);
        assert_eq!(el.particles, particles);
        assert_eq!(el.edge_ids, (0..edges.len() as u32).collect::<Vec<_>>());
        // The ball's 3 × 320 / 2 edges; the 7 × 5 grid's 6 × 5 + 7 × 4 on its lines and 6 × 4 diagonals.
        assert_eq!(edges.len(), 480 + 30 + 28 + 24);
    }
}
