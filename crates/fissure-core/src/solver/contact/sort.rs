//! The contact lists' sorts and merges: a refresh's new pairs sorted by their indices and merged into the pairs it
//! keeps (see `lists.rs`).

/// Sorts `v` by `key` (an index pair, high and low 32 bits) as `sort_unstable_by_key` does where the keys all
/// differ (a list's pairs): a stable radix sort, least significant digit first, on the pair packed into as few
/// bits as its largest low half needs, 11 bits a pass. On the folding 128² cloth a refresh's sorts and merges of
/// its ~13,000 new vertex-triangle and ~30,000 edge-edge pairs took 1.53 ms with `sort_unstable_by_key`, 0.92–0.94
/// with this (`cargo bench --bench contact`, one thread, a timer around them, not kept, two alternated pairs, an
/// AMD EPYC Zen 4 host, 2026-12-07; `benches/RESULTS.md` (62)).
pub(super) fn radix_sort<T: Copy>(v: &mut Vec<T>, key: impl Fn(&T) -> u64) {
    const BITS: u32 = 11;
    let low = 64 - v.iter().fold(0, |a, x| a | (key(x) & 0xffff_ffff)).leading_zeros();
    let packed = |x: &T| (key(x) >> 32) << low | (key(x) & 0xffff_ffff);
    let passes = (64 - v.iter().fold(0, |a, x| a | packed(x)).leading_zeros()).div_ceil(BITS);
    if v.len() < 256 || passes > 4 {
        v.sort_unstable_by_key(key);
        return;
    }
    let mut to = v.clone();
    for pass in 0..passes {
        let digit = |x: &T| ((packed(x) >> (BITS * pass)) & ((1 << BITS) - 1)) as usize;
        let mut start = [0usize; 1 << BITS];
        v.iter().for_each(|x| start[digit(x)] += 1);
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for x in v.iter() {
            let d = digit(x);
            to[start[d]] = *x;
            start[d] += 1;
        }
        std::mem::swap(v, &mut to);
    }
}

/// Merges `new` into the entries of `list` that `keep` keeps, both sorted by `key` (one pass instead of a
/// `retain` and then a merge).
pub(super) fn merge_sorted<T: Copy, K: Ord>(
    list: &mut Vec<T>,
    new: Vec<T>,
    keep: impl Fn(&T) -> bool,
    key: impl Fn(&T) -> K,
) {
    let mut out = Vec::with_capacity(list.len() + new.len());
    let mut new = new.into_iter().peekable();
    for &old in list.iter().filter(|p| keep(p)) {
        while let Some(n) = new.next_if(|n| key(n) < key(&old)) {
            out.push(n);
        }
        out.push(old);
    }
    out.extend(new);
    *list = out;
}

#[cfg(test)]
mod tests {
    use super::radix_sort;

    /// The radix sort orders distinct index pairs as the comparison sort does, for low halves of every width up to
    /// 32 bits, at lengths on both sides of its threshold.
    #[test]
    fn radix_sort_orders_distinct_pairs_as_the_comparison_sort() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for (len, hi_bits, lo_bits) in
            [(100, 15, 15), (5_000, 15, 15), (20_000, 16, 16), (3_000, 1, 32), (3_000, 20, 3)]
        {
            let mut set = std::collections::BTreeSet::new();
            while set.len() < len {
                let (hi, lo) = (next() >> (64 - hi_bits), next() >> (64 - lo_bits));
                set.insert([hi as u32, lo as u32]);
            }
            let mut v: Vec<[u32; 2]> = set.into_iter().collect();
            v.reverse();
            v.rotate_left(len / 3);
            let key = |p: &[u32; 2]| (p[0] as u64) << 32 | p[1] as u64;
            let mut want = v.clone();
            want.sort_unstable_by_key(key);
            radix_sort(&mut v, key);
            assert_eq!(v, want, "{len} pairs of {hi_bits} and {lo_bits} bits");
        }
    }
}
