//! Compressed sparse rows: the adjacency lists the force gathers walk (vertex -> springs, vertex -> faces).
//!
//! Rows may be edited in place (fracture adds and removes springs and faces at a few vertices per event). Each row
//! owns a slot of `cap[i] >= len[i]` items; a row that outgrows its slot moves to the end of `items` with twice the
//! room, leaving its old slot unused. An edit therefore costs O(row length), never O(all rows); the unused slots are
//! reclaimed by [`Csr::compact`] once they outweigh the live items, which keeps the amortised cost per edit constant.

/// Row `i` holds `items[start[i]..start[i] + len[i]]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Csr {
    /// Row starts.
    pub start: Vec<u32>,
    /// Row lengths.
    pub len: Vec<u32>,
    /// Room reserved for each row (`>= len`).
    pub cap: Vec<u32>,
    /// Row contents, with unused slots.
    pub items: Vec<u32>,
    /// Items in slots that no row owns any more.
    pub garbage: usize,
    /// Items in rows (the sum of `len`).
    pub live: usize,
    /// What changed since the log was last taken ([`Csr::take_edits`]): a mirror of the rows (the GPU's copy)
    /// re-copies only the rows it names.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub edits: EditLog,
}

/// The rows a [`Csr`] edited since the log was last taken, and whether it was compacted (every row moved).
/// Not part of the rows' content: two `Csr`s with the same rows are equal whatever their logs.
#[derive(Clone, Debug, Default)]
pub struct EditLog {
    /// Rows pushed, or with an item pushed, removed or replaced (with repeats, in edit order).
    pub rows: Vec<u32>,
    /// [`Csr::compact`] ran: every row may have moved.
    pub compacted: bool,
}

impl PartialEq for EditLog {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Eq for EditLog {}

impl Csr {
    /// Builds from `(row, item)` pairs by a stable counting sort: within a row, items keep the order of `pairs`,
    /// so the gather's summation order (and hence every result bit) is fixed by the input, never by threads.
    pub fn from_pairs(rows: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Self {
        let mut len = vec![0u32; rows];
        for (r, _) in pairs.clone() {
            len[r as usize] += 1;
        }
        let mut start = vec![0u32; rows];
        let mut acc = 0u32;
        for i in 0..rows {
            start[i] = acc;
            acc += len[i];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; acc as usize];
        for (r, it) in pairs {
            let slot = &mut fill[r as usize];
            items[*slot as usize] = it;
            *slot += 1;
        }
        Csr { start, cap: len.clone(), len, live: acc as usize, items, garbage: 0, edits: EditLog::default() }
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.start.len()
    }

    /// The items of row `i`.
    #[inline(always)]
    pub fn row(&self, i: usize) -> &[u32] {
        let s = self.start[i] as usize;
        &self.items[s..s + self.len[i] as usize]
    }

    /// Appends an empty row; returns its index.
    pub fn push_row(&mut self) -> usize {
        self.start.push(self.items.len() as u32);
        self.len.push(0);
        self.cap.push(0);
        self.edits.rows.push(self.rows() as u32 - 1);
        self.rows() - 1
    }

    /// The edit log so far, leaving an empty one.
    pub fn take_edits(&mut self) -> EditLog {
        std::mem::take(&mut self.edits)
    }

    /// Appends `item` to row `i` (after its existing items).
    pub fn push(&mut self, i: usize, item: u32) {
        if self.len[i] == self.cap[i] {
            let (s, l) = (self.start[i] as usize, self.len[i] as usize);
            let new_cap = (2 * l).max(4);
            let new_start = self.items.len();
            self.items.extend_from_within(s..s + l);
            self.items.resize(new_start + new_cap, u32::MAX);
            self.garbage += self.cap[i] as usize;
            self.start[i] = new_start as u32;
            self.cap[i] = new_cap as u32;
        }
        let at = (self.start[i] + self.len[i]) as usize;
        self.items[at] = item;
        self.len[i] += 1;
        self.live += 1;
        self.edits.rows.push(i as u32);
    }

    /// Removes the first occurrence of `item` from row `i`, keeping the order of the others; false if absent.
    pub fn remove(&mut self, i: usize, item: u32) -> bool {
        let (s, l) = (self.start[i] as usize, self.len[i] as usize);
        match self.items[s..s + l].iter().position(|&x| x == item) {
            Some(k) => {
                self.items.copy_within(s + k + 1..s + l, s + k);
                self.len[i] -= 1;
                self.live -= 1;
                self.edits.rows.push(i as u32);
                true
            }
            None => false,
        }
    }

    /// Replaces the first occurrence of `old` in row `i` by `new` in place; false if absent.
    pub fn replace(&mut self, i: usize, old: u32, new: u32) -> bool {
        let (s, l) = (self.start[i] as usize, self.len[i] as usize);
        match self.items[s..s + l].iter().position(|&x| x == old) {
            Some(k) => {
                self.items[s + k] = new;
                self.edits.rows.push(i as u32);
                true
            }
            None => false,
        }
    }

    /// Packs the rows back to back (row order and item order kept) if unused slots outweigh the live items.
    pub fn compact_if_sparse(&mut self) {
        if self.garbage > self.live.max(1024) {
            self.compact();
        }
    }

    /// Packs the rows back to back, row order and item order kept.
    pub fn compact(&mut self) {
        let mut items = Vec::with_capacity(self.len.iter().map(|&l| l as usize).sum());
        for i in 0..self.rows() {
            let s = self.start[i] as usize;
            self.start[i] = items.len() as u32;
            items.extend_from_slice(&self.items[s..s + self.len[i] as usize]);
            self.cap[i] = self.len[i];
        }
        self.items = items;
        self.garbage = 0;
        self.edits.compacted = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_keep_rows_and_order() {
        let mut c = Csr::from_pairs(3, [(0, 10), (2, 20), (0, 11), (2, 21)].into_iter());
        assert_eq!(c.row(0), &[10, 11]);
        assert_eq!(c.row(1), &[] as &[u32]);
        for k in 0..9 {
            c.push(1, 100 + k);
        }
        c.push(0, 12);
        assert!(c.remove(0, 10));
        assert!(!c.remove(0, 10));
        assert!(c.replace(2, 21, 22));
        let r = c.push_row();
        c.push(r, 7);
        let expect: [&[u32]; 4] = [&[11, 12], &[100, 101, 102, 103, 104, 105, 106, 107, 108], &[20, 22], &[7]];
        for (i, e) in expect.iter().enumerate() {
            assert_eq!(c.row(i), *e);
        }
        c.compact();
        assert_eq!(c.garbage, 0);
        for (i, e) in expect.iter().enumerate() {
            assert_eq!(c.row(i), *e);
        }
        assert_eq!(c.items.len(), 14);
    }
}
