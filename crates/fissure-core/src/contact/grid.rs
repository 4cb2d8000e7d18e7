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
    keys: Vec<u32>,
    packed: Vec<u64>,
}

impl HashGrid {
    /// Rebuilds the grid with cells of side `cell` over the points `point(k)` for `k < n` (`None`: left out).
    pub fn build(&mut self, cell: f64, n: usize, point: impl Fn(usize) -> Option<DVec3>) {
        self.inv_cell = 1.0 / cell;
        let buckets = (2 * n).next_power_of_two().max(64);
        self.mask = buckets - 1;
        let (mut keys, mut packed) = (std::mem::take(&mut self.keys), std::mem::take(&mut self.packed));
        keys.clear();
        packed.clear();
        for k in 0..n {
            match point(k) {
                Some(p) => {
                    let c = self.cell(p);
                    keys.push(self.bucket(c) as u32);
                    packed.push(pack(c));
                }
                None => {
                    keys.push(u32::MAX);
                    packed.push(0);
                }
            }
        }
        self.keys = keys;
        self.packed = packed;
        self.start.clear();
        self.start.resize(buckets + 1, 0);
        for &b in &self.keys {
            if b != u32::MAX {
                self.start[b as usize + 1] += 1;
            }
        }
        for b in 0..buckets {
            self.start[b + 1] += self.start[b];
        }
        self.items.clear();
        self.items.resize(self.start[buckets] as usize, 0);
        self.cells.clear();
        self.cells.resize(self.start[buckets] as usize, 0);
        let mut fill = self.start[..buckets].to_vec();
        for (k, &b) in self.keys.iter().enumerate() {
            if b != u32::MAX {
                let slot = fill[b as usize] as usize;
                self.items[slot] = k as u32;
                self.cells[slot] = self.packed[k];
                fill[b as usize] += 1;
            }
        }
    }

    fn cell(&self, p: DVec3) -> [i64; 3] {
        (p * self.inv_cell).floor().to_array().map(|x| x as i64)
    }

    fn bucket(&self, c: [i64; 3]) -> usize {
        let h = (c[0] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (c[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ (c[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
        ((h ^ (h >> 29)) as usize) & self.mask
    }

    /// Calls `f` on every point whose cell meets the box `[lo, hi]`, each once, in cell order (all points when
    /// the box spans more cells than the grid has buckets).
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
                    let bk = self.bucket([x, y, z]);
                    let key = pack([x, y, z]);
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

/// A cell's key: 21 bits per axis (cells 2^21 apart share a key; a query never spans that many, see `query`).
fn pack(c: [i64; 3]) -> u64 {
    let m = (1u64 << 21) - 1;
    ((c[0] as u64 & m) << 42) | ((c[1] as u64 & m) << 21) | (c[2] as u64 & m)
}
