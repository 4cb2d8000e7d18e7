//! A hashed uniform grid of points, built by a counting sort (the layout a GPU builds with u32 atomics): each
//! point goes to the bucket of its cell, buckets hold their points in index order with their cell's key, and a
//! box query visits each of its cells' buckets and keeps the points of that very cell: every point in the box's
//! cells once, without sorting or deduplicating buckets.

use glam::DVec3;

/// See the module docs.
#[derive(Clone, Debug, Default)]
pub struct HashGrid {
    inv_cell: f64,
    mask: usize,
    /// `start[b]..start[b + 1]`: bucket `b`'s slice of `items`.
    start: Vec<u32>,
    items: Vec<u32>,
    /// The packed cell key of each entry of `items`.
    cells: Vec<u64>,
    /// Build scratch: the kept points' indices and packed cells, in index order.
    kept: Vec<u32>,
    packed: Vec<u64>,
}

impl HashGrid {
    /// Rebuilds the grid with cells of side `cell` over the points `point(k)` for `k < n` (`None`: left out).
    /// The buckets are sized for the points kept, not for `n`: the contact pass keeps only the elements near
    /// another body, often a tenth of them, and a table sized for all cost it more to clear and sum than the
    /// points cost to sort. (The bucket count changes no query's output: a query keeps the points of its very
    /// cells, in index order.)
    pub fn build(&mut self, cell: f64, n: usize, point: impl Fn(usize) -> Option<DVec3>) {
        self.inv_cell = 1.0 / cell;
        let (mut kept, mut packed) = (std::mem::take(&mut self.kept), std::mem::take(&mut self.packed));
        kept.clear();
        packed.clear();
        // (index, packed cell) of each point kept, in index order; the bucket comes once their count is known.
        for k in 0..n {
            if let Some(p) = point(k) {
                kept.push(k as u32);
                packed.push(pack(self.cell(p)));
            }
        }
        let count = kept.len();
        let buckets = (2 * count).next_power_of_two().max(64);
        self.mask = buckets - 1;
        self.start.clear();
        self.start.resize(buckets + 2, 0);
        self.cells.clear();
        self.cells.resize(count, 0);
        self.items.clear();
        self.items.resize(count, 0);
        // Count into `start[b + 2]`, sum so that `start[b + 1]` is bucket b's first slot, then fill by
        // advancing `start[b + 1]`: afterwards `start[b]..start[b + 1]` is bucket b (a stable counting sort in
        // index order, with no second table).
        let mask = self.mask;
        for &c in &packed {
            self.start[bucket_of(c, mask) + 2] += 1;
        }
        for b in 2..buckets + 2 {
            self.start[b] += self.start[b - 1];
        }
        for (&k, &c) in kept.iter().zip(&packed) {
            let slot = &mut self.start[bucket_of(c, mask) + 1];
            self.items[*slot as usize] = k;
            self.cells[*slot as usize] = c;
            *slot += 1;
        }
        self.start.pop();
        self.kept = kept;
        self.packed = packed;
    }

    /// The cell of `p`: `floor(p / cell)` per axis. The floor is taken on the integer (truncate, then one down
    /// below zero): `f64::floor` is a call into libm on the x86-64 baseline (no SSE4.1), and a build takes a
    /// cell per point. The same cells for every finite coordinate (and `x as i64` saturates as before).
    #[inline]
    fn cell(&self, p: DVec3) -> [i64; 3] {
        (p * self.inv_cell).to_array().map(|x| {
            let t = x as i64;
            t.saturating_sub(((t as f64) > x) as i64)
        })
    }

    /// Calls `f` on every point whose cell meets the box `[lo, hi]`, each once, in cell order (all points when
    /// the box spans more cells than the grid has buckets). Inlined into each search, so that the search's visit
    /// is compiled into the loop over the bucket's points rather than called through a pointer per point.
    #[inline(always)]
    pub fn query(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(u32)) {
        let (a, b) = (self.cell(lo), self.cell(hi));
        let span = |k: usize| (b[k] - a[k] + 1).max(0) as u128;
        let cells = span(0) * span(1) * span(2);
        if cells > self.mask as u128 || !(lo.is_finite() && hi.is_finite()) {
            self.items.iter().for_each(|&i| f(i));
            return;
        }
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    let key = pack([x, y, z]);
                    let bk = bucket_of(key, self.mask);
                    let range = self.start[bk] as usize..self.start[bk + 1] as usize;
                    for (&i, &c) in self.items[range.clone()].iter().zip(&self.cells[range]) {
                        if c == key {
                            f(i);
                        }
                    }
                }
            }
        }
    }
}

/// The bucket of a packed cell key: splitmix64's finaliser, so that every axis reaches the low bits the mask
/// keeps (a single multiply left `x`, packed highest, out of tables under 2^13 buckets).
#[inline]
fn bucket_of(key: u64, mask: usize) -> usize {
    let mut h = key;
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((h ^ (h >> 31)) as usize) & mask
}

/// A cell's key: 21 bits per axis (cells 2^21 apart share a key; a query never spans that many, see `query`).
fn pack(c: [i64; 3]) -> u64 {
    let m = (1u64 << 21) - 1;
    ((c[0] as u64 & m) << 42) | ((c[1] as u64 & m) << 21) | (c[2] as u64 & m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer floor agrees with `f64::floor` (then `as i64`) at integers, just below and above them, on
    /// both sides of zero, and where the conversion saturates.
    #[test]
    fn cells_are_floors() {
        let g = HashGrid { inv_cell: 1.0, ..Default::default() };
        for x in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.0 - 1e-16,
            -1.0 + 1e-16,
            -1e-300,
            3.0e9,
            -3.0e9 - 0.5,
            1e30,
            -1e30,
            f64::NAN,
        ] {
            assert_eq!(g.cell(DVec3::splat(x)), [x.floor() as i64; 3], "{x}");
        }
    }

    /// A query visits exactly the kept points whose cells meet its box, each once, in cell order and in index
    /// order within a cell, whatever the bucket count (a grid keeping few of many points has few buckets, so
    /// many cells share one).
    #[test]
    fn a_query_visits_the_kept_points_of_its_cells_once() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let pts: Vec<DVec3> = (0..2000).map(|_| DVec3::new(next(), next(), next()) * 2.0 - 1.0).collect();
        let cell = 0.13;
        let c = |p: DVec3| (p / cell).floor();
        for keep_every in [1, 10, 97] {
            let mut g = HashGrid::default();
            g.build(cell, pts.len(), |k| (k % keep_every == 0).then_some(pts[k]));
            assert_eq!(g.mask + 1, (2 * pts.len().div_ceil(keep_every)).next_power_of_two().max(64));
            for q in 0..50 {
                let lo = pts[q * 7] - 0.2;
                let hi = lo + DVec3::new(0.3, 0.15, 0.45);
                let mut got = Vec::new();
                g.query(lo, hi, |i| got.push(i));
                let (a, b) = (c(lo), c(hi));
                let mut want: Vec<(DVec3, u32)> = (0..pts.len())
                    .filter(|&k| k % keep_every == 0 && c(pts[k]).cmpge(a).all() && c(pts[k]).cmple(b).all())
                    .map(|k| (c(pts[k]), k as u32))
                    .collect();
                // Cell order: x, then y, then z, as the query loops.
                want.sort_by(|(p, i), (r, j)| (p.x, p.y, p.z, i).partial_cmp(&(r.x, r.y, r.z, j)).unwrap());
                assert_eq!(got, want.iter().map(|&(_, k)| k).collect::<Vec<_>>(), "keep 1 in {keep_every}, query {q}");
            }
        }
    }
}
