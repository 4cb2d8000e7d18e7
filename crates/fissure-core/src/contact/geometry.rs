//! Closest points between a point and a triangle and between two segments (Ericson, *Real-Time Collision
//! Detection*, 5.1.5 and 5.1.9), and an exact triangle–triangle crossing test on Shewchuk's adaptive `orient3d`.

use glam::{DVec3, Vec3A};

/// An axis-aligned box in `f32`, rounded outward: it contains the `f64` box it was made from, so two of them
/// apart means the boxes they came from are apart. The contact searches' first test: 32 bytes an entry in the
/// grids' payloads against 48 in `f64`, and the test is two packed compares and one branch.
#[derive(Clone, Copy, Debug, Default)]
pub struct Box32 {
    lo: Vec3A,
    hi: Vec3A,
}

impl Box32 {
    /// An `f32` box containing `[lo, hi]`: each bound rounded to nearest, then moved out by `|x| 2^-23` (at
    /// least an ulp, more than the half ulp rounding can have moved it in) and the smallest normal `f32` (for
    /// bounds near 0). Three packed operations a corner (`next_down`/`next_up` per component cost the grids'
    /// builds more than the compact payload saved the searches). A bound that is not finite in `f32` gives NaN
    /// or an infinite bound, and a box with NaN is apart from none: conservative.
    #[inline]
    pub fn new(lo: DVec3, hi: DVec3) -> Self {
        let (l, h) = (lo.as_vec3a(), hi.as_vec3a());
        let (e, tiny) = (Vec3A::splat(f32::EPSILON), Vec3A::splat(f32::MIN_POSITIVE));
        Self { lo: l - l.abs() * e - tiny, hi: h + h.abs() * e + tiny }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(&self, o: &Box32) -> Box32 {
        Box32 { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) }
    }

    /// Whether the boxes are apart along some axis (strictly: boxes that touch are not apart).
    #[inline(always)]
    pub fn apart(&self, o: &Box32) -> bool {
        (self.hi.cmplt(o.lo) | self.lo.cmpgt(o.hi)).any()
    }
}

/// Barycentric weights `[u, v, w]` (summing to 1) of the point of triangle `abc` closest to `p`.
pub fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// Whether two segments, given by their midpoints `c1`, `c2` and half-vectors `h1`, `h2`, are surely at least
/// `r` apart: their projections on the line through the midpoints leave a gap of at least `r` (with a relative
/// margin of 1e-9, so that rounding never rejects a pair [`closest_on_segments`] would find within `r`).
/// Projection on a unit vector shortens no distance, so the gap is a lower bound of the segments' distance.
/// A dozen flops against `closest_on_segments`'s thirty and its branches and divisions; it rejects what a box
/// test cannot: a flat cloth's edges one or two rings apart, whose boxes grown by the contact radius overlap
/// though the edges stay 7–10 mm apart (measured on the folding 128² cloth, 2026-11-26).
#[inline]
pub fn segments_apart(c1: DVec3, h1: DVec3, c2: DVec3, h2: DVec3, r: f64) -> bool {
    let d = c2 - c1;
    let l2 = d.length_squared();
    let l = l2.sqrt();
    // gap = l - (|h1·d| + |h2·d|) / l ≥ r (1 + 1e-9), multiplied through by l > 0.
    l2 - (h1.dot(d).abs() + h2.dot(d).abs()) >= r * (1.0 + 1e-9) * l && l > 0.0
}

/// Whether point `p` is surely at least `r` from the triangle with corner `a` and normal `n` (any length, not
/// zero): its distance to the triangle's plane, a lower bound of its distance to the triangle, is at least `r`
/// (with the margin of [`segments_apart`]). It rejects what a box test cannot on a folded cloth: the vertices of
/// the layer above or below a triangle, inside its box grown by the contact radius.
#[inline]
pub fn plane_apart(p: DVec3, a: DVec3, n: DVec3, r: f64) -> bool {
    let (d, n2) = (n.dot(p - a), n.length_squared());
    let rr = r * (1.0 + 1e-9);
    d * d >= rr * rr * n2 && n2 > 0.0
}

/// Parameters `(s, t)` in \[0, 1\] of the closest points `p1 + s (q1 - p1)` and `p2 + t (q2 - p2)` of two segments.
pub fn closest_on_segments(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> (f64, f64) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    let tiny = 1e-30;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > 0.0 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let p = |v: DVec3| robust::Coord3D { x: v.x, y: v.y, z: v.z };
    robust::orient3d(p(a), p(b), p(c), p(d))
}

/// True if segment `pq` meets triangle `abc` (exact: the signs of Shewchuk's adaptive `orient3d`). A segment
/// lying in the triangle's plane does not count (it cannot occur between moving surfaces except by accident).
pub fn segment_meets_triangle(p: DVec3, q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let (o1, o2) = (orient(a, b, c, p), orient(a, b, c, q));
    if (o1 > 0.0 && o2 > 0.0) || (o1 < 0.0 && o2 < 0.0) || (o1 == 0.0 && o2 == 0.0) {
        return false;
    }
    let s = [orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)];
    s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
}

/// True if triangles `t` and `u` intersect: an edge of one meets the other (exact; for triangles that share no
/// vertex, and up to coplanar overlaps, which the exact test leaves out).
pub fn triangles_cross(t: [DVec3; 3], u: [DVec3; 3]) -> bool {
    (0..3).any(|k| segment_meets_triangle(t[k], t[(k + 1) % 3], u[0], u[1], u[2]))
        || (0..3).any(|k| segment_meets_triangle(u[k], u[(k + 1) % 3], t[0], t[1], t[2]))
}

/// The distance between triangles `t` and `u` \[m\]: 0 where they cross, else the least of the distances from
/// each one's corners to the other and between their edges (where two triangles do not intersect, their closest
/// points include a corner of one or lie on an edge of each).
pub fn triangles_distance(t: [DVec3; 3], u: [DVec3; 3]) -> f64 {
    if triangles_cross(t, u) {
        return 0.0;
    }
    let point = |p: DVec3, c: [DVec3; 3]| {
        let w = closest_on_triangle(p, c[0], c[1], c[2]);
        (p - (w[0] * c[0] + w[1] * c[1] + w[2] * c[2])).length()
    };
    let corners = (0..3).map(|k| point(t[k], u).min(point(u[k], t)));
    let edges = (0..9).map(|k| {
        let (p1, q1, p2, q2) = (t[k / 3], t[(k / 3 + 1) % 3], u[k % 3], u[(k % 3 + 1) % 3]);
        let (a, b) = closest_on_segments(p1, q1, p2, q2);
        (p1 + a * (q1 - p1) - (p2 + b * (q2 - p2))).length()
    });
    corners.chain(edges).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in `[-1, 1)` from a linear congruential generator seeded with `seed`.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// The lower bounds never call a pair apart that the exact closest points put within `r`, and the segments'
    /// bound does reject over a quarter of the pairs at least `2 r` apart (so the test can fail both ways): random
    /// segments and point–triangle pairs in a box, including parallel and in-plane ones, against radii around
    /// their distances.
    #[test]
    fn lower_bounds_never_reject_a_pair_within_reach() {
        let mut rnd = uniform(11);
        let (mut rejected, mut far) = (0, 0);
        for k in 0..20_000 {
            let mut v = || DVec3::new(rnd(), rnd(), rnd());
            let (mut p1, mut q1, mut p2) = (v(), v(), v());
            // Every fourth pair parallel, every eighth in the plane z = 0 as well.
            let mut q2 = if k % 4 == 0 { p2 + (q1 - p1) * 0.7 } else { v() };
            if k % 8 == 0 {
                for x in [&mut p1, &mut q1, &mut p2, &mut q2] {
                    x.z = 0.0;
                }
            }
            let (s, t) = closest_on_segments(p1, q1, p2, q2);
            let d = ((p1 + s * (q1 - p1)) - (p2 + t * (q2 - p2))).length();
            let r = d * (0.25 + 1.75 * (rnd() * 0.5 + 0.5));
            let apart = segments_apart(0.5 * (p1 + q1), 0.5 * (q1 - p1), 0.5 * (p2 + q2), 0.5 * (q2 - p2), r);
            assert!(!apart || d >= r, "segments {d} apart rejected at r = {r}");
            far += (d >= 2.0 * r) as u32;
            rejected += (apart && d >= 2.0 * r) as u32;
            let (a, b, c, x) = (p1, q1, p2, q2 + DVec3::new(0.0, 0.0, rnd()));
            let w = closest_on_triangle(x, a, b, c);
            let dt = (x - (w[0] * a + w[1] * b + w[2] * c)).length();
            let r = dt * (0.5 + 1.5 * (rnd() * 0.5 + 0.5));
            assert!(!plane_apart(x, a, (b - a).cross(c - a), r) || dt >= r, "a point {dt} away rejected at r = {r}");
        }
        assert!(
            far > 1000 && rejected * 4 > far,
            "the segment bound rejected {rejected} of {far} pairs at least 2 r apart"
        );
    }

    /// A [`Box32`] contains the `f64` box it was made from, at every scale (tiny, around 0, huge, exactly
    /// representable in `f32` or not), so two of them are apart only where the exact boxes are; and it is
    /// tight (within a few ulps, or the smallest normal `f32` near 0), so boxes apart by a little more than that
    /// are seen apart.
    #[test]
    fn f32_boxes_contain_theirs_and_part_only_where_they_part() {
        let mut rnd = uniform(5);
        let (mut parted, mut apart) = (0, 0);
        for k in 0..20_000 {
            let scale = [1e-40, 1e-3, 1.0, 0.3, 1e6, 1e30][k % 6];
            let mut v = || DVec3::new(rnd(), rnd(), rnd()) * scale;
            let (a, b, c, d) = (v(), v(), v(), v());
            let (lo1, hi1, lo2, hi2) = (a.min(b), a.max(b), c.min(d), c.max(d));
            let (b1, b2) = (Box32::new(lo1, hi1), Box32::new(lo2, hi2));
            for (lo, hi, bx) in [(lo1, hi1, b1), (lo2, hi2, b2)] {
                assert!(bx.lo.as_dvec3().cmple(lo).all() && bx.hi.as_dvec3().cmpge(hi).all(), "{lo} {hi}: {bx:?}");
                let ulps = (hi.abs().max(lo.abs()).max_element() * 4.0 * f32::EPSILON as f64).max(1e-37);
                assert!((lo - bx.lo.as_dvec3()).max_element() <= ulps && (bx.hi.as_dvec3() - hi).max_element() <= ulps);
            }
            let exact = (hi1.cmplt(lo2) | lo1.cmpgt(hi2)).any();
            assert!(!b1.apart(&b2) || exact, "{lo1} {hi1} and {lo2} {hi2}: apart in f32 only");
            // (Below `f32`'s normal range every box is grown by its smallest normal number: not counted.)
            if scale > 1e-38 {
                apart += exact as u32;
                parted += b1.apart(&b2) as u32;
            }
            // A point is a box of one point.
            assert!(!Box32::new(a, a).apart(&Box32::new(a, a)));
        }
        assert!(apart > 5_000 && parted * 100 >= apart * 99, "{parted} of {apart} apart pairs seen apart");
    }

    #[test]
    fn closest_points_match_brute_force_sampling() {
        let (a, b, c) = (DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.2, 1.0, 0.3));
        let mut rnd = {
            let mut u = uniform(7);
            move || 1.5 * u()
        };
        for _ in 0..200 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let w = closest_on_triangle(p, a, b, c);
            let d = (p - (w[0] * a + w[1] * b + w[2] * c)).length();
            let mut best = f64::INFINITY;
            for i in 0..=100 {
                for j in 0..=100 - i {
                    let (u, v) = (i as f64 / 100.0, j as f64 / 100.0);
                    best = best.min((p - (a + u * (b - a) + v * (c - a))).length());
                }
            }
            assert!(d <= best + 1e-12 && d >= best - 0.02, "triangle: {d} vs sampled {best}");
            let (q, r) = (DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd()));
            let (s, t) = closest_on_segments(a, b, q, r);
            let d = ((a + s * (b - a)) - (q + t * (r - q))).length();
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=200 {
                    let (s, t) = (i as f64 / 200.0, j as f64 / 200.0);
                    best = best.min(((a + s * (b - a)) - (q + t * (r - q))).length());
                }
            }
            assert!(d <= best + 1e-12 && d >= best - 0.02, "segments: {d} vs sampled {best}");
        }
    }

    #[test]
    fn crossing_test_sees_a_pierce_and_not_a_near_miss() {
        let t = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        let pierce = [DVec3::new(0.2, 0.2, -1.0), DVec3::new(0.2, 0.2, 1.0), DVec3::new(3.0, 3.0, 0.5)];
        assert!(triangles_cross(t, pierce));
        let miss = [DVec3::new(0.6, 0.6, -1.0), DVec3::new(0.6, 0.6, 1.0), DVec3::new(3.0, 3.0, 0.5)];
        assert!(!triangles_cross(t, miss));
        let above = t.map(|x| x + DVec3::new(0.0, 0.0, 1e-12));
        assert!(!triangles_cross(t, above), "parallel, 1e-12 apart");
    }
}
