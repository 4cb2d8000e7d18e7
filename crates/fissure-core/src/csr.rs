//! Compressed sparse rows: the adjacency lists the force gathers walk (vertex -> springs, vertex -> faces).

/// Row `i` holds `items[offsets[i]..offsets[i + 1]]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Csr {
    /// Row starts; `rows + 1` entries.
    pub offsets: Vec<u32>,
    /// Row contents.
    pub items: Vec<u32>,
}

impl Csr {
    /// Builds from `(row, item)` pairs by a stable counting sort: within a row, items keep the order of `pairs`,
    /// so the gather's summation order (and hence every result bit) is fixed by the input, never by threads.
    pub fn from_pairs(rows: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Self {
        let mut offsets = vec![0u32; rows + 1];
        for (r, _) in pairs.clone() {
            offsets[r as usize + 1] += 1;
        }
        for i in 0..rows {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[rows] as usize];
        for (r, it) in pairs {
            let slot = &mut fill[r as usize];
            items[*slot as usize] = it;
            *slot += 1;
        }
        Csr { offsets, items }
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The items of row `i`.
    #[inline(always)]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}
