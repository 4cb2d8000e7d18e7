//! A uniform grid of points, built by a counting sort (the layout a GPU builds with u32 atomics). Two layouts, the
//! same queries:
//! - **dense**, when the points' cells fill a box of at most [`DENSE`] cells per point: every cell of that box has
//!   its slice of the points (in index order), laid out row by row with `z` the fastest axis, so a box query
//!   reads one contiguous run of points per `(x, y)` row of its cells, with no hashing and no test per point;
//! - **hashed** otherwise (points scattered over a large box, such as bodies far apart): each point goes to the
//!   bucket of its cell, buckets hold their points in index order with their cell's key, and a query visits each
//!   of its cells' buckets and keeps the points of that very cell.
//!
//! Either way a query visits every point in the box's cells once, in cell order (`x`, then `y`, then `z`) and in
//! index order within a cell, without sorting or deduplicating. Why the dense layout: on the folding 128² cloth
//! (`cargo bench --bench contact`) the contact pass's searches were bound by the hashed grid's cost per cell (a
//! hash and two loads from a table larger than the cache, then a key test per point), so they could only use
//! large cells, and an edge's query then read ~8× the volume that can hold a partner. Rows of small cells read
//! in one run each cut both (see `benches/RESULTS.md`, issue 16).

use glam::DVec3;

/// The dense layout is taken when the points' box of cells holds at most this many cells per point (and at least
/// 64 in all): its table of cell starts is then at most this many `u32`s a point.
pub const DENSE: usize = 32;

/// See the module docs. Each point carries a payload `P`, kept in the grid's own order beside its index, which a
/// query hands to its visit with the index: a search's first test (is the partner's box within reach?) then
/// reads its entries in one stream per row rather than one load per entry from an array in index order.
#[derive(Clone, Debug)]
pub struct HashGrid<P = ()> {
    inv_cell: f64,
    mask: usize,
    /// The dense layout's box of cells (its lowest cell and its cells per axis), or `None`: hashed.
    dense: Option<([i64; 3], [usize; 3])>,
    /// Dense: `start[c]..start[c + 1]` is cell `c`'s slice of `items`. Hashed: bucket `b`'s.
    start: Vec<u32>,
    items: Vec<u32>,
    /// Each entry's payload, in the order of `items`.
    payload: Vec<P>,
    /// The packed cell key of each entry of `items` (hashed only).
    cells: Vec<u64>,
    /// Build scratch: the kept points' indices, payloads and points, in index order.
    kept: Vec<u32>,
    kept_payload: Vec<P>,
    pts: Vec<DVec3>,
    /// Each kept point's slot (dense: its cell's index in the box; hashed: its bucket), and (hashed) its cell's key.
    slot: Vec<u32>,
    keys: Vec<u64>,
}

impl<P> Default for HashGrid<P> {
    fn default() -> Self {
        Self {
            inv_cell: 0.0,
            mask: 0,
            dense: None,
            start: Vec::new(),
            items: Vec::new(),
            payload: Vec::new(),
            cells: Vec::new(),
            kept: Vec::new(),
            kept_payload: Vec::new(),
            pts: Vec::new(),
            slot: Vec::new(),
            keys: Vec::new(),
        }
    }
}

impl<P: Copy + Default> HashGrid<P> {
    /// Rebuilds the grid with cells of side `cell` over the points `point(k)` for `k < n`, each with its payload
    /// (`None`: left out).
    /// The table is sized for the points kept, not for `n`: the contact pass keeps only the elements near
    /// another body, often a tenth of them, and a table sized for all cost it more to clear and sum than the
    /// points cost to sort. (The layout and the bucket count change no query's output: a query keeps the points
    /// of its very cells, in index order.)
    pub fn build(&mut self, cell: f64, n: usize, point: impl Fn(usize) -> Option<(DVec3, P)>) {
        self.build_fine(cell, cell, n, point);
    }

    /// [`HashGrid::build`] with cells of side `fine` where the points then fill a box of cells densely enough
    /// for the dense layout, else of side `coarse` (small cells pay with rows read in one run each, and cost
    /// more than they save as hashed cells: see the module docs).
    pub fn build_fine(&mut self, fine: f64, coarse: f64, n: usize, point: impl Fn(usize) -> Option<(DVec3, P)>) {
        self.build_fine_from(fine, coarse, 0..n, point);
    }

    /// [`HashGrid::build_fine`] over the points `ks` only (ascending; `point` is not called for the others, which
    /// are left out). The same grid as `build_fine` with a `point` that leaves out every point not in `ks`: a
    /// caller that knows most points are left out (the contact pass's list ops, on a scene whose bodies lie
    /// mostly apart) skips their tests.
    pub fn build_fine_from(
        &mut self,
        fine: f64,
        coarse: f64,
        ks: impl IntoIterator<Item = usize>,
        point: impl Fn(usize) -> Option<(DVec3, P)>,
    ) {
        let (mut kept, mut slot, mut pts) =
            (std::mem::take(&mut self.kept), std::mem::take(&mut self.slot), std::mem::take(&mut self.pts));
        let mut kept_payload = std::mem::take(&mut self.kept_payload);
        kept.clear();
        slot.clear();
        pts.clear();
        kept_payload.clear();
        // The points kept, in index order, and their box.
        let (mut plo, mut phi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for k in ks {
            if let Some((p, pay)) = point(k) {
                (plo, phi) = (plo.min(p), phi.max(p));
                kept.push(k as u32);
                pts.push(p);
                kept_payload.push(pay);
            }
        }
        let fits = |cell: f64| {
            let cells = ((phi - plo) / cell).to_array().iter().fold(1.0, |n, &d| n * (d + 2.0));
            cells <= (DENSE * kept.len()).max(64) as f64
        };
        self.inv_cell = 1.0 / if fine != coarse && fits(fine) { fine } else { coarse };
        // The box of the points' cells: the cells of the points' box's corners (a cell is monotonic in its point).
        let (lo, hi) = (self.cell(plo), self.cell(phi));
        let count = kept.len();
        let dims = [0, 1, 2].map(|a| (hi[a] as i128 - lo[a] as i128 + 1).max(0) as u128);
        let total = dims[0] * dims[1] * dims[2];
        self.items.clear();
        self.items.resize(count, 0);
        self.payload.clear();
        self.payload.resize(count, P::default());
        self.start.clear();
        if count > 0 && total <= (DENSE * count).max(64) as u128 {
            let dims = dims.map(|d| d as usize);
            self.dense = Some((lo, dims));
            self.cells.clear();
            let index = |c: &[i64; 3]| {
                (((c[0] - lo[0]) as usize * dims[1]) + (c[1] - lo[1]) as usize) * dims[2] + (c[2] - lo[2]) as usize
            };
            slot.extend(pts.iter().map(|&p| index(&self.cell(p)) as u32));
            self.counting_sort(total as usize, &kept, &kept_payload, &slot, false);
        } else {
            self.dense = None;
            let buckets = (2 * count).next_power_of_two().max(64);
            self.mask = buckets - 1;
            let mask = self.mask;
            self.cells.clear();
            self.cells.resize(count, 0);
            let mut keys = std::mem::take(&mut self.keys);
            keys.clear();
            keys.extend(pts.iter().map(|&p| pack(self.cell(p))));
            slot.extend(keys.iter().map(|&k| bucket_of(k, mask) as u32));
            self.keys = keys;
            self.counting_sort(buckets, &kept, &kept_payload, &slot, true);
        }
        self.kept = kept;
        self.kept_payload = kept_payload;
        self.slot = slot;
        self.pts = pts;
    }

    /// Sorts the kept points into `slots` slots (`slot` each point's), stably, into `items` and their payloads into
    /// `payload` (and with `keyed`, each entry's cell key from `keys` into `cells`): afterwards
    /// `start[s]..start[s + 1]` is slot `s`.
    /// Counts go into `start[s + 2]`, are summed so that `start[s + 1]` is slot s's first entry, and the fill
    /// advances `start[s + 1]` (no second table).
    fn counting_sort(&mut self, slots: usize, kept: &[u32], kept_payload: &[P], slot: &[u32], keyed: bool) {
        self.start.resize(slots + 2, 0);
        for &s in slot {
            self.start[s as usize + 2] += 1;
        }
        // The running sum in a register: summed in place (`start[s] += start[s - 1]`), each cell waited on the
        // store of the one before (a store-to-load forwarding, ~5 cycles), half of the sort's time on the
        // folding 128² cloth's dense tables of ~250,000 cells.
        let mut sum = 0u32;
        for c in &mut self.start[2..] {
            sum += *c;
            *c = sum;
        }
        for (j, ((&k, &pay), &s)) in kept.iter().zip(kept_payload).zip(slot).enumerate() {
            let at = &mut self.start[s as usize + 1];
            self.items[*at as usize] = k;
            self.payload[*at as usize] = pay;
            if keyed {
                self.cells[*at as usize] = self.keys[j];
            }
            *at += 1;
        }
        self.start.pop();
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

    /// Whether the grid took the dense layout (see the module docs).
    pub fn is_dense(&self) -> bool {
        self.dense.is_some()
    }

    /// Calls `f` with the index and the payload of every point whose cell meets the box `[lo, hi]`, each once, in
    /// cell order (all points when the box is not finite, or, hashed, spans more cells than the grid has
    /// buckets). Inlined into each search, so that the search's visit is compiled into the loop over the cells'
    /// points rather than called through a pointer per point.
    #[inline(always)]
    pub fn query(&self, lo: DVec3, hi: DVec3, f: impl FnMut(u32, &P)) {
        self.query_where(lo, hi, |_, _| true, f);
    }

    /// [`HashGrid::query`], calling `f` only on the points (index and payload) that `keep` keeps. `keep` (a
    /// search's first, cheap tests: a box, an index) is compiled into the loop over the cells' points, and `f`,
    /// the rest of the search's test, is called on the few it keeps: measured on the folding 128² cloth
    /// (2026-11-28), a search's whole visit as one closure was compiled as a function called per point (a stack
    /// frame of ~200 bytes set up and torn down for each), and three quarters of the points a search visits fail
    /// its box.
    #[inline(always)]
    pub fn query_where(&self, lo: DVec3, hi: DVec3, keep: impl Fn(u32, &P) -> bool, mut f: impl FnMut(u32, &P)) {
        let mut f = |i: u32, p: &P| {
            if keep(i, p) {
                f(i, p)
            }
        };
        let all = |f: &mut dyn FnMut(u32, &P)| self.items.iter().zip(&self.payload).for_each(|(&i, p)| f(i, p));
        // (An empty grid, such as the big body's where there is none, is not walked cell by cell.)
        if self.items.is_empty() {
            return;
        }
        if !(lo.is_finite() && hi.is_finite()) {
            all(&mut f);
            return;
        }
        let (a, b) = (self.cell(lo), self.cell(hi));
        if let Some((base, dims)) = self.dense {
            // The query's cells clipped to the grid's box, as offsets into it; then one run per `(x, y)` row.
            let mut r = [(0usize, 0usize); 3];
            for k in 0..3 {
                let (from, to) = (a[k].max(base[k]), b[k].min(base[k] + dims[k] as i64 - 1));
                if from > to {
                    return;
                }
                r[k] = ((from - base[k]) as usize, (to - base[k]) as usize);
            }
            for x in r[0].0..=r[0].1 {
                for y in r[1].0..=r[1].1 {
                    let row = (x * dims[1] + y) * dims[2];
                    let run = self.start[row + r[2].0] as usize..self.start[row + r[2].1 + 1] as usize;
                    self.items[run.clone()].iter().zip(&self.payload[run]).for_each(|(&i, p)| f(i, p));
                }
            }
            return;
        }
        let span = |k: usize| (b[k] - a[k] + 1).max(0) as u128;
        let cells = span(0) * span(1) * span(2);
        if cells > self.mask as u128 {
            all(&mut f);
            return;
        }
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    let key = pack([x, y, z]);
                    let bk = bucket_of(key, self.mask);
                    let range = self.start[bk] as usize..self.start[bk + 1] as usize;
                    for (k, &c) in range.clone().zip(&self.cells[range]) {
                        if c == key {
                            f(self.items[k], &self.payload[k]);
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

    /// `n` points uniform in the cube `[-1, 1]³`, from a linear congruential generator seeded with `seed`.
    fn random_points(mut seed: u64, n: usize) -> Vec<DVec3> {
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| DVec3::new(next(), next(), next()) * 2.0 - 1.0).collect()
    }

    /// A grid built over a list of the points is the grid built over all of them with the others left out: the
    /// same visits, in the same order, in either layout.
    #[test]
    fn a_grid_over_listed_points_is_the_grid_that_leaves_the_others_out() {
        let pts = random_points(5, 1200);
        for every in [2, 3, 61] {
            let listed: Vec<usize> = (0..pts.len()).filter(|k| k % every == 1).collect();
            let (mut all, mut from) = (HashGrid::<u32>::default(), HashGrid::<u32>::default());
            all.build_fine(0.07, 0.2, pts.len(), |k| (k % every == 1).then_some((pts[k], k as u32)));
            from.build_fine_from(0.07, 0.2, listed.iter().copied(), |k| Some((pts[k], k as u32)));
            assert_eq!(all.is_dense(), from.is_dense());
            for q in 0..40 {
                let (lo, hi) = (pts[q * 29] - 0.25, pts[q * 29] + DVec3::new(0.1, 0.3, 0.2));
                let (mut a, mut b) = (Vec::new(), Vec::new());
                all.query(lo, hi, |i, &p| a.push((i, p)));
                from.query(lo, hi, |i, &p| b.push((i, p)));
                assert_eq!(a, b, "one in {every}, query {q}");
            }
        }
    }

    /// The integer floor agrees with `f64::floor` (then `as i64`) at integers, just below and above them, on
    /// both sides of zero, and where the conversion saturates.
    #[test]
    fn cells_are_floors() {
        let g = HashGrid::<()> { inv_cell: 1.0, ..Default::default() };
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
    /// order within a cell, in either layout and whatever the bucket count (a grid keeping few of many points has
    /// few buckets, so many cells share one), including boxes that reach past the points' cells.
    #[test]
    fn a_query_visits_the_kept_points_of_its_cells_once() {
        let pts = random_points(7, 2000);
        let cell = 0.13;
        let c = |p: DVec3| (p / cell).floor();
        for keep_every in [1, 10, 97] {
            let mut g = HashGrid::<u32>::default();
            // The payload travels with its point: each point's is its index times 3.
            g.build(cell, pts.len(), |k| (k % keep_every == 0).then_some((pts[k], 3 * k as u32)));
            // ~16^3 cells: dense for all the points, hashed for a 97th (and both ways tested).
            if keep_every != 10 {
                assert_eq!(g.is_dense(), keep_every == 1, "keep 1 in {keep_every}");
            }
            if !g.is_dense() {
                assert_eq!(g.mask + 1, (2 * pts.len().div_ceil(keep_every)).next_power_of_two().max(64));
            }
            for q in 0..60 {
                // The last ten boxes reach out of the points' cube on some side (or miss it).
                let lo = if q < 50 { pts[q * 7] - 0.2 } else { pts[q * 7] * 1.5 - 0.2 };
                let hi = lo + DVec3::new(0.3, 0.15, 0.45);
                let mut got = Vec::new();
                g.query(lo, hi, |i, &p| {
                    assert_eq!(p, 3 * i);
                    got.push(i)
                });
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
