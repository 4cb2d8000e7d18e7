//! The candidate lists of the contact pass (a Verlet list, see the [`crate::contact`] module): built from the hash
//! grids over every element, or refreshed around the particles that drifted.

use super::sort::{merge_sorted, radix_sort};
use super::*;
use crate::csr::Csr;
use std::sync::Mutex;

/// Candidate searches per element cost a grid query (~0.2–1 µs): parallel from this many elements. Measured
/// (2026-11-23): from 1,024, the fracture scene's builds woke the pool for ~1,400 triangles and spent more in
/// wake-ups (`sched_yield` 5 % of its run) than they saved.
const PAR_BUILD: usize = 8 * TASK;
/// A hot vertex's search in a refresh costs a few microseconds: parallel from this many.
const PAR_HOT: usize = TASK;
/// The edge midpoints' cells, as a fraction of `radius + l_max`, where the grid takes its dense layout with them
/// (else `radius + l_max`, hashed: [`HashGrid::build_fine`]). Rows of small cells read in one run each read
/// less of the space around an edge that cannot hold a partner. `cargo bench --bench contact`, one thread, the
/// Zen 3 development VM, 2026-11-28, alternated with the build before (hashed cells of 1×: contact 12.9–16.5 ms
/// a substep): 0.5× **10.3–12.8 ms**, 0.4× 10.3, 0.35× 11.3–11.7, 1× (dense) 12.2; with vertex and centroid
/// cells at 0.5× or 0.7× as well, 11.5–12.2. (Before the dense layout, 0.5× and 0.7× were slower than 1×: a
/// hashed cell costs a hash and two loads from a large table.)
const EDGE_CELL: f64 = 0.5;

impl<R: Real> ContactScratch<R> {
    /// Finds every allowed pair closer than `radius` at `x0` (the Verlet list).
    pub(super) fn build(&mut self, m: &Model<R>, radius: f64) {
        self.xb.clone_from(&self.x0);
        self.drifts.iter_mut().for_each(|d| *d = 0.0);
        self.lists(m, radius, None);
        self.radius = radius;
        self.stats.builds += 1;
    }

    /// Refreshes the lists around the particles that drifted more than `slack` since their reference positions
    /// (`hot`): their references move to `x0`; the triangles with a hot corner and the edges with a hot end are
    /// searched again, and so is each hot vertex against the triangle centroids near it (measured on the folding
    /// 128² cloth, 2026-11-24: refreshes 12.9 → 11.2 ms per step against searching from every triangle near a
    /// hot vertex, the same lists); their pairs replace the old ones in the lists (merged in index order). Every
    /// allowed pair closer than `radius` at the reference positions is then listed, as after a build; a pair that
    /// no longer is may stay (the per-step distances drop it), so a refreshed list gives the same pairs within
    /// reach, in the same order, as a fresh one. False (nothing done) when more than a quarter of the particles
    /// are hot: a build is then cheaper (measured: with half, the 64² cloth_fold scene spent 12.7 s in contact
    /// against 10.2 s with builds alone; with a quarter, 7.9 s).
    pub(super) fn refresh(&mut self, m: &Model<R>, slack: f64) -> bool {
        let el = self.el.as_ref().expect("elements prepared");
        let (x0, xb) = (&self.x0, &self.xb);
        let hot: Vec<u32> = el
            .particles
            .iter()
            .copied()
            .filter(|&i| (x0[i as usize].to_dvec3() - xb[i as usize].to_dvec3()).length() > slack)
            .collect();
        if hot.len() * 4 > el.particles.len() {
            return false;
        }
        for &i in &hot {
            self.xb[i as usize] = self.x0[i as usize];
            self.drifts[i as usize] = 0.0;
        }
        self.lists(m, self.radius, Some(&hot));
        self.stats.refreshes += 1;
        if self.check_refreshes {
            let mut all = self.clone();
            all.lists(m, self.radius, None);
            for (kind, listed, found) in [("vertex–triangle", &self.vt, &all.vt), ("edge–edge", &self.ee, &all.ee)]
            {
                let listed: std::collections::HashSet<[u32; 2]> = listed.iter().map(|c| c.ids).collect();
                if let Some(c) = found.iter().find(|c| !listed.contains(&c.ids)) {
                    panic!("refresh {}: the {kind} pair {:?} is missing", self.stats.refreshes, c.ids);
                }
            }
        }
        true
    }

    /// The lists' search at the reference positions `xb`: over every element (`hot` None), or around the hot
    /// particles (see [`ContactScratch::refresh`]).
    fn lists(&mut self, m: &Model<R>, radius: f64, hot: Option<&[u32]>) {
        let el = self.el.as_ref().expect("elements prepared");
        let x0 = &self.xb;
        let x = |i: u32| x0[i as usize].to_dvec3();
        // The edges' root mean square and longest length set the cells and the edge query's reach, from the
        // squares: the longest is the root of the largest square to the bit, and the cells' size does not change
        // the lists. (A root an edge at every list op, and every edge's box below, cost the fracture scene's run:
        // its contact stage 0.131–0.154 → 0.126–0.133 s without them, eight alternated runs, 2026-11-29.)
        let (mut l2_sum, mut l2_max) = (0.0, 0.0f64);
        for &[a, b] in &el.edges {
            let l2 = (x(b) - x(a)).length_squared();
            l2_sum += l2;
            l2_max = l2_max.max(l2);
        }
        let (l_rms, l_max) = ((l2_sum / el.edges.len().max(1) as f64).sqrt(), l2_max.sqrt());
        let cell = radius.max(l_rms).max(1e-9);
        let parts = &el.particles;
        let edges = &el.edges;
        let excused = &self.excused;
        let allowed = |a: u32, b: u32| (a != b || m.body_self_contact[a as usize]) && !excused.excuses(a, b);
        // Each body's box: an element of a body that does not collide with itself searches only where another
        // body's box reaches, and a body whose box meets no other (and that does not collide with itself) is
        // left out of the grids: away from contacts the build costs one pass over the particles.
        let mut boxes = vec![(DVec3::INFINITY, DVec3::NEG_INFINITY); m.body_count()];
        for &i in parts {
            let (b, p) = (m.particle_body[i as usize] as usize, x(i));
            boxes[b] = (boxes[b].0.min(p), boxes[b].1.max(p));
        }
        // The bodies' boxes (those with particles in contact) as `Box32`s with their bodies (rounded outward: a box
        // they meet may be kept that the `f64` boxes would not, never the reverse; the searches' exact tests decide
        // the pairs). Every element a list op visits takes this test, and most fail it (the fracture scene's grids
        // keep ~10 % of the ball's elements): one packed compare a box instead of six scalar ones. One list for all
        // the bodies, each skipping its own (a list of the others per body would cost bodies² a list op).
        let boxes32: Vec<(usize, Box32)> = (boxes.iter().enumerate())
            .filter(|(_, bx)| bx.0.is_finite())
            .map(|(b, &(lo, hi))| (b, Box32::new(lo, hi)))
            .collect();
        let worth = |body: u32, lo: DVec3, hi: DVec3| {
            m.body_self_contact[body as usize] || {
                let q = Box32::new(lo, hi);
                boxes32.iter().any(|&(b, ref o)| b != body as usize && !o.apart(&q))
            }
        };
        let nb = m.body_count();
        self.gaps.clear();
        if nb <= CLOSING_BODIES {
            self.gaps.extend((0..nb * nb).map(|k| {
                let ((alo, ahi), (blo, bhi)) = (boxes[k / nb], boxes[k % nb]);
                (alo - bhi).max(blo - ahi).max(DVec3::ZERO).length()
            }));
        }
        let pad = radius + l_max;
        let active: Vec<bool> = (0..m.body_count())
            .map(|b| boxes[b].0.is_finite() && worth(b as u32, boxes[b].0 - pad, boxes[b].1 + pad))
            .collect();
        // The body with the most contact edges, when it does not collide with itself: its elements go into grids
        // of their own, which only the other bodies' elements search (its own pairs are not allowed), so its
        // searches no longer visit its own elements. On the fracture scene, where the broken ball lies among
        // the blocks it lost, three quarters of the edge searches' visits were the ball's own edges. (The
        // bodies' edge counts are the elements', counted when they were formed.)
        let count = &el.edges_per_body;
        debug_assert_eq!(count.len(), nb, "elements formed for this model");
        let big =
            (0..count.len()).max_by_key(|&b| (count[b], std::cmp::Reverse(b))).filter(|&b| !m.body_self_contact[b]);
        let in_big = |b: u32| big == Some(b as usize);
        // Each grid's candidates, gathered in the passes below (ascending): the grids' builds then visit these
        // alone instead of every element twice (once for each of a kind's two grids). On the fracture scene a
        // list op's grids kept ~55 of ~1,500 elements they visited; the builds' visits were most of their ~55 µs.
        // The same lists; the scene's contact stage 0.220–0.268 → 0.200–0.252 s and `cloth_fold.toml`'s first 20
        // frames' 2.90 → 2.51 s (`fissure run … --no-png --no-gif`, three alternated runs and one, an Intel Ice
        // Lake host, 2026-12-06).
        let mut cands = std::mem::take(&mut self.grid_cands);
        cands.iter_mut().for_each(Vec::clear);
        // Each particle's test first, its box grown by the most an element's test box reaches past it (an
        // element's points lie within `l_max` of each of its corners; the edge searches reach `radius + l_max / 2`
        // past an edge's box): an element none of whose corners passes cannot pass its own test, which then runs
        // only where one does. Every element a list op visits took that test, ~4,900 of them against the eight
        // pieces' boxes on the fracture scene, and kept ~300 (a pass of the test over them: ~50 µs an op). The
        // same lists; the run's list work 66–72 → 62–69 ms (timers around the ops, not kept, five alternated
        // runs, 2026-11-29).
        let grow = DVec3::splat(radius + 1.5 * l_max);
        let mut near_parts = std::mem::take(&mut self.near_parts);
        near_parts.clear();
        near_parts.resize(m.particle_count(), false);
        for (k, &i) in parts.iter().enumerate() {
            let (b, p) = (m.particle_body[i as usize], x(i));
            let near = active[b as usize] && worth(b, p - grow, p + grow);
            near_parts[i as usize] = near;
            if near {
                cands[in_big(b) as usize].push(k as u32);
            }
        }
        let near = &near_parts;
        let any_near = |vs: &[u32]| vs.iter().any(|&v| near[v as usize]);
        // Only elements that can meet another body (or their own, if it collides with itself) go into the grids:
        // the ball a small piece broke from is not searched far from the piece.
        let pad = DVec3::splat(radius);
        let in_grid = |v: u32, p: DVec3| {
            let b = m.particle_body[v as usize];
            near[v as usize] && worth(b, p - pad, p + pad)
        };
        // (Only where an end passed its first test: no other edge's box is read.)
        self.eboxes.clear();
        self.eboxes.extend(edges.iter().enumerate().map(|(k, e)| {
            if !any_near(e) {
                return [DVec3::ZERO; 2];
            }
            cands[2 + in_big(m.particle_body[e[0] as usize]) as usize].push(k as u32);
            let (p, q) = (x(e[0]), x(e[1]));
            [p.min(q), p.max(q)]
        }));
        // A triangle's search box, and whether a build searches from it.
        let tri_box = |[a, b, c]: [DVec3; 3]| (a.min(b).min(c) - radius, a.max(b).max(c) + radius);
        let searched = |t: u32, (lo, hi): (DVec3, DVec3)| {
            let tb = m.tri_body[t as usize];
            any_near(&m.tri_indices[t as usize]) && worth(tb, lo, hi)
        };
        // A refresh's triangle centroids (of the searched triangles), and how far a triangle's points lie from
        // its centroid at most (a corner is the farthest: distance to a point is convex), over the searched ones:
        // the root of the largest square, which is the largest root to the bit.
        self.centroids.clear();
        let mut c_reach2 = 0.0f64;
        if hot.is_some() {
            self.centroids.extend(el.tris.iter().enumerate().map(|(k, &t)| {
                let corners = m.tri_indices[t as usize].map(x);
                let (lo, hi) = tri_box(corners);
                if !searched(t, (lo, hi)) {
                    return None;
                }
                cands[4 + in_big(m.tri_body[t as usize]) as usize].push(k as u32);
                let c = corners.iter().sum::<DVec3>() / 3.0;
                c_reach2 = corners.iter().fold(c_reach2, |r, &p| r.max((p - c).length_squared()));
                Some((c, Box32::new(lo, hi)))
            }));
        }
        let c_reach = c_reach2.sqrt();
        // The grids, each over its own elements, the big body's apart (in parallel: a build is a counting sort
        // in index order, the same whichever thread runs it). Edge midpoints go in cells of `EDGE_CELL ×
        // (radius + l_max)` where they are dense enough, else `radius + l_max`: an edge's query box (its box
        // grown by the reach below) spans at most 5 (or 3) cells a side.
        let (eboxes, centroids) = (&self.eboxes, &self.centroids);
        // Each kind's two grids (index 1: the big body's), each element in the one of its body: the candidates
        // gathered above are already split so and passed their first tests; the grids test the rest.
        let cand = &cands;
        let vertices = |gs: &mut [HashGrid<Box32>; 2]| {
            for (g, of_big) in gs.iter_mut().zip([false, true]) {
                let ks = cand[of_big as usize].iter().map(|&k| k as usize);
                g.build_fine_from(cell, cell, ks, |k| {
                    let (v, p) = (parts[k], x(parts[k]));
                    in_grid(v, p).then(|| (p, Box32::new(p, p)))
                });
            }
        };
        let midpoints = |gs: &mut [HashGrid<Box32>; 2]| {
            for (g, of_big) in gs.iter_mut().zip([false, true]) {
                let ks = cand[2 + of_big as usize].iter().map(|&k| k as usize);
                g.build_fine_from(EDGE_CELL * (radius + l_max), radius + l_max, ks, |k| {
                    let [lo, hi] = eboxes[k];
                    let b = m.particle_body[edges[k][0] as usize];
                    worth(b, lo - pad, hi + pad).then(|| (0.5 * (lo + hi), Box32::new(lo, hi)))
                });
            }
        };
        // Only a refresh searches from the vertices for triangles: its pieces below include this grid.
        let tri_centroids = |gs: &mut [HashGrid<Box32>; 2]| {
            for (g, of_big) in gs.iter_mut().zip([false, true]) {
                let ks = cand[4 + of_big as usize].iter().map(|&k| k as usize);
                g.build_fine_from(cell, cell, ks, |k| centroids[k]);
            }
        };
        // One grid a piece, the largest (the edges') first, each built whole by one thread, so the same grids
        // whichever way the pieces run (see [`pieces`]). On the team the other thread builds the vertices' and then
        // the centroids'. (Under `rayon::join`, taken only when the pool was free, the grids were built one after
        // another while the team spun: 2.4 of a refresh's 14.6 ms on the folding 128² cloth on two threads. With
        // the merges below run the same way, its contact 4.06–4.13 → 3.51–3.81 ms a substep: `cargo bench --bench
        // contact`, two threads, three alternated pairs, an AMD EPYC Zen 4 host, 2026-12-07.)
        let (grid, egrid, tgrid) =
            (Mutex::new(&mut self.grid), Mutex::new(&mut self.egrid), Mutex::new(&mut self.tgrid));
        pieces(parts.len() + edges.len() >= PAR_BUILD, if hot.is_some() { 3 } else { 2 }, &|k| match k {
            0 => midpoints(&mut egrid.lock().expect("one piece each")),
            1 => vertices(&mut grid.lock().expect("one piece each")),
            _ => tri_centroids(&mut tgrid.lock().expect("one piece each")),
        });
        // A refresh searches again from the triangles with a hot corner and the edges with a hot end, and from
        // each hot vertex the triangles (without a hot corner) whose centroids are within `radius + c_reach` of it
        // (every triangle with a point within `radius` of it): cheaper than searching from every triangle near a
        // hot vertex, since a hot vertex's query visits the triangles near it once.
        // Each hot particle's place in `hot` (`NOT_HOT` for the others).
        let (mut tmask, mut emask, mut rank) = (Vec::new(), Vec::new(), Vec::new());
        let mut groups = None;
        let is_hot = |rank: &[u32], i: u32| rank[i as usize] != NOT_HOT;
        if let Some(hot) = hot {
            rank = vec![NOT_HOT; m.particle_count()];
            hot.iter().enumerate().for_each(|(k, &i)| rank[i as usize] = k as u32);
            let is_hot = |i: u32| is_hot(&rank, i);
            tmask = vec![false; m.tri_count()];
            for &t in &el.tris {
                if m.tri_indices[t as usize].iter().any(|&i| is_hot(i)) {
                    tmask[t as usize] = true;
                }
            }
            emask = edges.iter().map(|&[i, j]| is_hot(i) || is_hot(j)).collect();
            groups = Some(Groups::new(m, el, &rank, hot.len(), &tmask, &emask));
        }
        let (grid, egrid) = (&self.grid, &self.egrid);
        let r2 = radius * radius;
        // Vertex `v` at `p` against triangle `t` (corners at `c`, normal `n`, search box `bx`), from either
        // side of a search: a pair if allowed and closer than `radius`. (That `v` shares no origin with a corner
        // is tested in the searches' index tests, inside the grid's loop, before this visit: a triangle's own
        // corners are in its box, and a vertex's own triangles around it. On the folding 128² cloth an edge's
        // search visited 13.3 edges past the box test, of which at least 5.9 were its neighbours: `cargo bench --bench
        // contact`, one thread, the Zen 4 development VM, 2026-11-29, five alternated runs, contact 6.87 → 6.62 ms
        // a substep, medians; the same pairs.)
        let normal = |c: [DVec3; 3]| (c[1] - c[0]).cross(c[2] - c[0]);
        // (Returns the gap: see `Candidate`.)
        let vt_near = |v: u32, p: DVec3, t: u32, c: [DVec3; 3], n: DVec3, (lo, hi): (DVec3, DVec3)| {
            // The box first (one load; most points a query visits are outside it), then the plane.
            if p.cmplt(lo).any() || p.cmpgt(hi).any() || plane_apart(p, c[0], n, radius) {
                return None;
            }
            if !allowed(m.particle_body[v as usize], m.tri_body[t as usize]) {
                return None;
            }
            let w = closest_on_triangle(p, c[0], c[1], c[2]);
            let d2 = (p - (w[0] * c[0] + w[1] * c[1] + w[2] * c[2])).length_squared();
            (d2 < r2).then(|| d2.sqrt())
        };
        // A triangle's search: its corners, normal, search box (and as a `Box32`) and its corners' origins, or None
        // where it is not searched.
        let tri_of = |t: u32| {
            let tv = m.tri_indices[t as usize];
            let c = tv.map(x);
            let bx = tri_box(c);
            searched(t, bx).then(|| TriSearch {
                t,
                c,
                n: normal(c),
                bx,
                bx32: Box32::new(bx.0, bx.1),
                origins: tv.map(|u| m.particle_origin[u as usize]),
            })
        };
        // Vertex `v` against a searched triangle: the origin test, then `vt_near`.
        let vt_pair = |s: &TriSearch, v: u32, p: DVec3, out: &mut Vec<Candidate>| {
            if !s.origins.contains(&m.particle_origin[v as usize])
                && let Some(d) = vt_near(v, p, s.t, s.c, s.n, s.bx)
            {
                out.push(Candidate::new([v, s.t], d));
            }
        };
        let mut vt = Vec::new();
        // A build searches from every triangle; a refresh from each hot particle once, for the triangles it owns
        // (see `Groups`).
        let from_big = |s: &TriSearch| in_big(m.tri_body[s.t as usize]);
        let pair = |s: &TriSearch, k: u32, out: &mut Vec<Candidate>| {
            let v = parts[k as usize];
            vt_pair(s, v, x(v), out)
        };
        match &groups {
            Some(groups) => grouped_searches(&mut vt, groups, Groups::tris, tri_of, grid, from_big, pair),
            None => searches(&mut vt, &el.tris, tri_of, grid, from_big, pair),
        }
        if let Some(hot) = hot {
            // From each hot vertex, the same tests as from a triangle (the vertex in the grid, the triangle in the
            // centroid grid, which holds the searched ones, then `vt_near`), so the same pairs. A triangle with a
            // point within `radius` of the vertex has its centroid within `radius + c_reach`.
            let (tgrid, tmask) = (&self.tgrid, &tmask);
            let reach = DVec3::splat(radius + c_reach);
            extend_chunks(&mut vt, &mut Vec::new(), hot, PAR_HOT, |hot, out| {
                for &v in hot {
                    let p = x(v);
                    if !in_grid(v, p) {
                        continue;
                    }
                    // (The grid's boxes are the triangles' search boxes: the point must be in one.)
                    let from_big = in_big(m.particle_body[v as usize]);
                    let fresh = |k: u32| {
                        let t = el.tris[k as usize] as usize;
                        !tmask[t] && !m.tri_indices[t].iter().any(|&u| same_origin(m, u, v))
                    };
                    search(tgrid, from_big, p - reach, p + reach, Box32::new(p, p), fresh, |k, _| {
                        let t = el.tris[k as usize];
                        let tv = m.tri_indices[t as usize];
                        let c = tv.map(x);
                        if let Some(d) = vt_near(v, p, t, c, normal(c), tri_box(c)) {
                            out.push(Candidate::new([v, t], d));
                        }
                    });
                }
            });
        }
        let reach = radius + 0.5 * l_max;
        // A pair of two searched edges is kept by the lower one's search alone (in a build every edge is
        // searched; in a refresh, those with a hot end).
        let emask = &emask;
        let searched_too = |f: usize| hot.is_none() || emask[f];
        // An edge's search: its ends, centre and half, query box, and the box its partners' boxes must meet; or
        // None where it is not searched.
        let edge_of = |e: u32| {
            let [a0, a1] = edges[e as usize];
            if !any_near(&[a0, a1]) {
                return None;
            }
            let [elo, ehi] = eboxes[e as usize];
            let (lo, hi) = (elo - reach, ehi + reach);
            let body = m.particle_body[a0 as usize];
            let (p, q) = (x(a0), x(a1));
            worth(body, lo, hi).then(|| EdgeSearch {
                e: e as usize,
                ends: [a0, a1],
                pq: [p, q],
                c: 0.5 * (p + q),
                h: 0.5 * (q - p),
                query: (lo, hi),
                near: Box32::new(elo - radius, ehi + radius),
                body,
            })
        };
        // Edge `f` (whose box met the searched edge's `near`) against a searched edge: the index and origin tests
        // (the same pair is kept by one search only), then the distance.
        let ee_pair = |s: &EdgeSearch, f: u32, out: &mut Vec<Candidate>| {
            let (e, f) = (s.e, f as usize);
            let [b0, b1] = edges[f];
            let [a0, a1] = s.ends;
            if !(f > e || (f < e && !searched_too(f)))
                || [a0, a1].iter().any(|&a| same_origin(m, a, b0) || same_origin(m, a, b1))
            {
                return;
            }
            let (r, t) = (x(b0), x(b1));
            if segments_apart(s.c, s.h, 0.5 * (r + t), 0.5 * (t - r), radius)
                || !allowed(s.body, m.particle_body[b0 as usize])
            {
                return;
            }
            let [p, q] = s.pq;
            let (u, v) = closest_on_segments(p, q, r, t);
            let d2 = ((p + u * (q - p)) - (r + v * (t - r))).length_squared();
            if d2 < r2 {
                out.push(Candidate::new([e.min(f) as u32, e.max(f) as u32], d2.sqrt()));
            }
        };
        let mut ee = Vec::new();
        let from_big = |s: &EdgeSearch| in_big(s.body);
        match &groups {
            Some(groups) => grouped_searches(&mut ee, groups, Groups::edges, edge_of, egrid, from_big, ee_pair),
            None => searches(&mut ee, &el.edge_ids, edge_of, egrid, from_big, ee_pair),
        }
        if hot.is_some() {
            // Old pairs of the searched elements out, their new pairs in, in index order: (t, v) and (e, f).
            // Each list's order as one integer: the new pairs sort ~2× faster by it than as arrays or tuples.
            // The two lists are independent: on the team, one a piece.
            let vt_key = |c: &Candidate| (c.ids[1] as u64) << 32 | c.ids[0] as u64;
            let ee_key = |c: &Candidate| (c.ids[0] as u64) << 32 | c.ids[1] as u64;
            let keep = |c: &Candidate| !tmask[c.ids[1] as usize] && !is_hot(&rank, c.ids[0]);
            let ee_keep = |c: &Candidate| !emask[c.ids[0] as usize] && !emask[c.ids[1] as usize];
            let merge_vt = |list: &mut Vec<Candidate>, mut new: Vec<Candidate>| {
                radix_sort(&mut new, vt_key);
                merge_sorted(list, new, keep, vt_key);
            };
            let merge_ee = |list: &mut Vec<Candidate>, mut new: Vec<Candidate>| {
                radix_sort(&mut new, ee_key);
                merge_sorted(list, new, ee_keep, ee_key);
            };
            let big = self.vt.len() + self.ee.len() >= PAR_BUILD;
            let work = [Mutex::new((&mut self.vt, vt)), Mutex::new((&mut self.ee, ee))];
            pieces(big, 2, &|k| {
                let mut w = work[k].lock().expect("one piece each");
                let (list, new) = &mut *w;
                let new = std::mem::take(new);
                if k == 0 { merge_vt(list, new) } else { merge_ee(list, new) }
            });
        } else {
            self.vt = vt;
            self.ee = ee;
        }
        self.near_parts = near_parts;
        self.grid_cands = cands;
    }
}

/// Visits what an element of a body searches: the other bodies' grid (`rest`), and the big body's unless it is
/// the searcher's own, in the cells that meet `[lo, hi]`, and calls `f` on the elements whose boxes (the grids'
/// payloads) are not apart from `near` and whose indices `take` takes. Both tests are compiled into the grid's
/// query loop, `f` is called on what passes them (see [`HashGrid::query_where`]); generic over the visit (as a
/// `&mut dyn FnMut` it was an indirect call per point visited). On the folding 128² cloth (`cargo bench --bench
/// contact`, one thread, the Zen 3 development VM, 2026-11-28, timers inside a refresh, not kept, alternated with
/// the build before): the boxes read from arrays in index order and the whole visit called per point: edge
/// searches 11.6–13.6 ms a refresh, searches from triangles 4.4–4.7; the boxes in the grids (`f64`) and tested in
/// the loop: 10.3–10.4 and 3.5, with the grids' builds ~1 ms slower; as [`Box32`]: 9.2–9.4 and 3.4–3.6; contact
/// per substep 10.6 → 8.9–9.1 ms.
#[inline(always)]
fn search(
    grids: &[HashGrid<Box32>; 2],
    from_big: bool,
    lo: DVec3,
    hi: DVec3,
    near: Box32,
    take: impl Fn(u32) -> bool,
    mut f: impl FnMut(u32, &Box32),
) {
    let [rest, big] = grids;
    let keep = |i: u32, b: &Box32| !b.apart(&near) && take(i);
    rest.query_where(lo, hi, keep, &mut f);
    if !from_big {
        big.query_where(lo, hi, keep, f);
    }
}

/// A refresh's rank of a particle that is not hot (see [`Groups::new`]).
const NOT_HOT: u32 = u32::MAX;

/// A refresh's searched elements by the hot particle that owns them: a triangle by its first hot corner, an edge
/// by its first hot end (so each group is of one body: a triangle's corners are of its body). Each particle's
/// triangles (and edges) are searched with one grid query over the union of their query boxes, each point it
/// visits tested against each of their boxes, instead of one query each: a particle's triangles and edges lie
/// within a centimetre or two of each other, so their queries had read mostly the same cells and points. The same
/// tests on every pair an element's own query would pass, so the same pairs (the refresh sorts its new pairs
/// before merging them). On the folding 128² cloth a hot particle owns 3.3 triangles and 4.1 edges on average
/// (hot particles come in clusters); a refresh's searches from the triangles 4.00–4.10 → 3.69–3.75 ms and from
/// the edges 10.43–10.79 → 9.59–9.83, contact 5.89–6.21 → 5.65–5.75 ms a substep (`cargo bench --bench contact`,
/// one thread, timers inside the refresh, not kept, four alternated pairs, an AMD EPYC Zen 4 host, 2026-12-07;
/// `benches/RESULTS.md` (62)).
/// The point's box tested against each element's before its other tests: against the union alone the
/// triangles' searches were slower than before (4.53–4.70 ms).
struct Groups {
    /// `0 ..` the number of hot particles (the searches' items).
    ranks: Vec<u32>,
    tris: Csr,
    edges: Csr,
}

impl Groups {
    /// The groups of the `n` hot particles, each at its `rank` (see [`NOT_HOT`]), of the triangles and edges that
    /// `tmask` and `emask` mark (those with a hot corner or end).
    fn new<R: Real>(m: &Model<R>, el: &Elements, rank: &[u32], n: usize, tmask: &[bool], emask: &[bool]) -> Self {
        let owner = |vs: &[u32]| vs.iter().map(|&v| rank[v as usize]).find(|&r| r != NOT_HOT).expect("a hot corner");
        let tris = el.tris.iter().filter(|&&t| tmask[t as usize]).map(|&t| (owner(&m.tri_indices[t as usize]), t));
        let edges = el.edge_ids.iter().filter(|&&e| emask[e as usize]).map(|&e| (owner(&el.edges[e as usize]), e));
        Groups { ranks: (0..n as u32).collect(), tris: Csr::from_pairs(n, tris), edges: Csr::from_pairs(n, edges) }
    }

    fn tris(&self, r: u32) -> &[u32] {
        self.tris.row(r as usize)
    }

    fn edges(&self, r: u32) -> &[u32] {
        self.edges.row(r as usize)
    }
}

/// An element's search: the grid query's box, and the box a partner's box must meet.
trait Searched {
    fn query(&self) -> (DVec3, DVec3);
    fn near(&self) -> Box32;
}

/// A build's searches: for each element, the search `of` makes of it (None: not searched), its query of `grids`,
/// and `pair` on each point whose box meets its `near` box. Each element's partners in index order, whatever the
/// grid's cells: the pairs' order (and so the impulses' Gauss–Seidel order) does not depend on the cell size.
fn searches<S: Searched>(
    out: &mut Vec<Candidate>,
    elements: &[u32],
    of: impl Fn(u32) -> Option<S> + Sync,
    grids: &[HashGrid<Box32>; 2],
    from_big: impl Fn(&S) -> bool + Sync,
    pair: impl Fn(&S, u32, &mut Vec<Candidate>) + Sync,
) {
    extend_chunks(out, &mut Vec::new(), elements, PAR_BUILD, |ks, out| {
        for &k in ks {
            let Some(s) = of(k) else { continue };
            let (from, (lo, hi)) = (out.len(), s.query());
            search(grids, from_big(&s), lo, hi, s.near(), |_| true, |j, _| pair(&s, j, out));
            out[from..].sort_unstable_by_key(|c| c.ids);
        }
    });
}

/// A refresh's searches by [`Groups`]: for each hot particle, the searches `of` makes of its elements (`row`),
/// one query of `grids` over the union of their boxes, and `pair` on each of them whose `near` box the box of a
/// point the query visits meets.
fn grouped_searches<S: Searched>(
    out: &mut Vec<Candidate>,
    groups: &Groups,
    row: fn(&Groups, u32) -> &[u32],
    of: impl Fn(u32) -> Option<S> + Sync,
    grids: &[HashGrid<Box32>; 2],
    from_big: impl Fn(&S) -> bool + Sync,
    pair: impl Fn(&S, u32, &mut Vec<Candidate>) + Sync,
) {
    extend_chunks(out, &mut Vec::new(), &groups.ranks, PAR_HOT, |rs, out| {
        let mut group: Vec<S> = Vec::new();
        for &r in rs {
            group.clear();
            group.extend(row(groups, r).iter().filter_map(|&k| of(k)));
            let Some(first) = group.first() else { continue };
            let (lo, hi) = group.iter().map(S::query).fold(first.query(), |(lo, hi), q| (lo.min(q.0), hi.max(q.1)));
            let near = group.iter().skip(1).fold(first.near(), |a, s| a.union(&s.near()));
            search(
                grids,
                from_big(first),
                lo,
                hi,
                near,
                |_| true,
                |k, b| {
                    group.iter().filter(|s| !b.apart(&s.near())).for_each(|s| pair(s, k, out));
                },
            );
        }
    });
}

/// A triangle searched for the vertices near it.
struct TriSearch {
    t: u32,
    /// Corners, normal (unnormalised) and search box (the triangle's box grown by the lists' radius).
    c: [DVec3; 3],
    n: DVec3,
    bx: (DVec3, DVec3),
    bx32: Box32,
    /// The corners' origins: a vertex of one of them is not its partner.
    origins: [u32; 3],
}

impl Searched for TriSearch {
    fn query(&self) -> (DVec3, DVec3) {
        self.bx
    }
    fn near(&self) -> Box32 {
        self.bx32
    }
}

/// An edge searched for the edges near it.
struct EdgeSearch {
    e: usize,
    ends: [u32; 2],
    pq: [DVec3; 2],
    /// Centre and half of the segment.
    c: DVec3,
    h: DVec3,
    /// The grid query's box (its box grown by the reach of a partner's midpoint), and the box a partner's box
    /// must meet (its box grown by the lists' radius).
    query: (DVec3, DVec3),
    near: Box32,
    body: u32,
}

/// Runs `f(0)` … `f(n - 1)`, each once: when `big`, on the team if this thread holds it, else on rayon's pool if it
/// is free (see [`crate::par::exec`]); otherwise here, in order. For pieces whose results are each their own.
fn pieces(big: bool, n: usize, f: &(dyn Fn(usize) + Sync)) {
    #[cfg(feature = "parallel")]
    let pool = crate::par::rayon_free();
    #[cfg(not(feature = "parallel"))]
    let pool = false;
    if big { crate::par::exec(pool, n, f) } else { (0..n).for_each(f) }
}

impl Searched for EdgeSearch {
    fn query(&self) -> (DVec3, DVec3) {
        self.query
    }
    fn near(&self) -> Box32 {
        self.near
    }
}
