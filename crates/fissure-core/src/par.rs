//! Deterministic data-parallel helpers.
//!
//! Work is cut into fixed-size chunks, independent of the number of threads. Element-wise passes are trivially
//! thread-count independent; reductions sum each fixed chunk, then the chunk sums in chunk order, so a sum has
//! the same bits on 1 thread or 64. Small inputs run inline: forking costs microseconds.
//!
//! Every pass goes through [`exec`], which hands its pieces to rayon's pool for large models, to the spinning
//! team ([`crate::team`]) for mid-sized ones stepped outside the pool, or runs them in order. On the team,
//! element-wise passes are cut finer ([`piece`]); reductions keep their fixed chunks.
//!
//! Without the `parallel` feature (on by default; off for targets without threads, such as `wasm32`) every pass
//! runs inline, over the same chunks: the same bits.

use crate::real::Real;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Chunk length of every parallel pass.
pub(crate) const CHUNK: usize = 2048;

/// Below this many elements a pass runs inline on the calling thread. Handing work to the pool costs a
/// wake-up of a sleeping worker (tens of microseconds on the development VM, more when the step's passes are
/// short and far apart), more than thousands of springs cost to compute. Chosen by measurement (2026-11-23, the
/// 2-core VM, `benches/ball.rs` and `benches/cloth.rs`): at 4 chunks (8,192) a 2,562-vertex ball after 100 core
/// splits (10,675 springs, its spring pass now parallel) took 296–300 µs per step, at 8 chunks 194–201 µs; the
/// 128² cloth 249 µs at both; at 16 chunks the cloth's 16,384-particle passes ran inline: 394 µs.
#[cfg_attr(not(feature = "parallel"), allow(dead_code))]
pub(crate) const PAR_MIN: usize = 8 * CHUNK;

/// Whether a pass over `n` elements goes to rayon's pool: from [`PAR_MIN`] elements, and only when the pool has
/// more than one thread. A pool of one (`RAYON_NUM_THREADS=1`, `ThreadPoolBuilder::num_threads(1)`) would only
/// hand the pass from the calling thread to its worker and back: two context switches per pass for nothing
/// (measured, 2026-11-24, 128² cloth on one thread: 10% of the step in the scheduler).
#[cfg(feature = "parallel")]
#[inline]
pub(crate) fn pooled(n: usize) -> bool {
    n >= PAR_MIN && pool_has_threads()
}

/// Whether the current rayon pool has more than one thread (see [`pooled`]; passes with their own size
/// threshold ask this too).
#[cfg(feature = "parallel")]
#[inline]
pub(crate) fn pool_has_threads() -> bool {
    rayon::current_num_threads() > 1
}

/// Whether work that calls rayon directly (the contact pass's searches) may use the pool: it has threads, and
/// this thread does not hold the team, whose helpers spin on the cores the pool's workers would need.
#[cfg(feature = "parallel")]
#[inline]
pub(crate) fn rayon_free() -> bool {
    pool_has_threads() && !teamed()
}

/// The threads a pass over `n` elements in `chunks` chunks runs on (to turn the summed time of its pieces into
/// an estimate of its wall time).
pub(crate) fn threads_for(n: usize, chunks: usize) -> usize {
    #[cfg(feature = "parallel")]
    if pooled(n) {
        return rayon::current_num_threads().min(chunks).max(1);
    }
    let _ = (n, chunks);
    1
}

/// Runs `f(0) … f(pieces - 1)`, each once: on the team when this thread holds it ([`crate::team`]; from two
/// pieces), else on rayon's pool if `pool`, else in order on this thread. The pieces' results must be their own
/// (each writes its own elements or partial sums): then the bits do not depend on where a piece ran.
#[inline]
pub(crate) fn exec(pool: bool, pieces: usize, f: &(dyn Fn(usize) + Sync)) {
    #[cfg(feature = "parallel")]
    {
        if pieces > 1
            && let Some(team) = crate::team::held()
        {
            return team.run(pieces, f);
        }
        if pool {
            (0..pieces).into_par_iter().for_each(f);
            return;
        }
    }
    let _ = pool;
    (0..pieces).for_each(f)
}

/// Whether this thread holds the team (its passes are cut finer: see [`piece`]).
#[inline]
pub(crate) fn teamed() -> bool {
    #[cfg(feature = "parallel")]
    return crate::team::held().is_some();
    #[cfg(not(feature = "parallel"))]
    false
}

/// Elements per piece of a pass on the team, for passes whose results are each element's own (any cut gives the
/// same bits): the 642-vertex ball's passes of 1,280 to 1,920 elements in pieces both threads share.
pub(crate) const TEAM_PIECE: usize = 256;

/// `size`, or [`TEAM_PIECE`] when this thread holds the team (for element-wise passes only: see [`TEAM_PIECE`]).
#[inline]
pub(crate) fn piece(size: usize) -> usize {
    if teamed() { TEAM_PIECE.min(size) } else { size }
}

/// A slice cut into pieces of `size` that several threads take, each piece once ([`exec`] hands out each index
/// once).
pub(crate) struct Pieces<'a, T> {
    ptr: *mut T,
    len: usize,
    size: usize,
    _slice: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the pieces are disjoint, and `get` is called once per piece (see there).
unsafe impl<T: Send> Send for Pieces<'_, T> {}
unsafe impl<T: Send> Sync for Pieces<'_, T> {}

impl<'a, T> Pieces<'a, T> {
    #[inline]
    pub(crate) fn new(data: &'a mut [T], size: usize) -> Self {
        Pieces { ptr: data.as_mut_ptr(), len: data.len(), size: size.max(1), _slice: std::marker::PhantomData }
    }

    #[inline]
    pub(crate) fn count(&self) -> usize {
        self.len.div_ceil(self.size)
    }

    /// Piece `c` (`c < count()`).
    ///
    /// # Safety
    /// No other reference to piece `c` may be alive: each index is taken once per pass.
    #[inline]
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn get(&self, c: usize) -> &'a mut [T] {
        let start = c * self.size;
        assert!(start < self.len);
        // SAFETY: in bounds (above), and disjoint from every other piece; exclusive by the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(start), self.size.min(self.len - start)) }
    }
}

/// Runs `f(start, chunk)` over `data` in fixed chunks, in parallel when there is more than one chunk.
#[inline]
pub(crate) fn chunks<T: Send>(data: &mut [T], f: impl Fn(usize, &mut [T]) + Sync + Send) {
    chunks_of(CHUNK, data, f)
}

/// [`chunks`] in chunks of `size` elements (the spring-run kernel's blocks, which grow with a grid's rows). The
/// parallel path and the inline one cut the same chunks: kernels whose order depends on the chunking (the
/// spring-run kernel) give the same bits either way.
#[inline]
pub(crate) fn chunks_of<T: Send>(size: usize, data: &mut [T], f: impl Fn(usize, &mut [T]) + Sync + Send) {
    let pool = is_pooled(data.len());
    chunks_pooled(pool, size, data, f)
}

/// [`pooled`], false without threads.
#[inline]
pub(crate) fn is_pooled(n: usize) -> bool {
    #[cfg(feature = "parallel")]
    return pooled(n);
    #[cfg(not(feature = "parallel"))]
    {
        let _ = n;
        false
    }
}

/// Like [`chunks`] over two slices of equal length walked together.
#[inline]
pub(crate) fn chunks2<A: Send, B: Send>(a: &mut [A], b: &mut [B], f: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send) {
    let pool = is_pooled(a.len());
    chunks2_pooled(pool, CHUNK, a, b, f)
}

/// [`chunks2`] on the pool if `pool`, in chunks of `size` (the same chunks either way). A per-particle gather
/// passes [`gather_pool`] of its work: its elements cost far more than a spring each, so the element count of
/// [`pooled`] misjudges it. Each element's result is its own, so the chunking changes no bits.
#[inline]
pub(crate) fn chunks2_pooled<A: Send, B: Send>(
    pool: bool,
    size: usize,
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send,
) {
    assert_eq!(a.len(), b.len());
    let (pa, pb) = (Pieces::new(a, size), Pieces::new(b, size));
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pa.count(), &|c| unsafe { f(c * size, pa.get(c), pb.get(c)) });
}

/// [`chunks2_pooled`] over one slice.
#[inline]
pub(crate) fn chunks_pooled<A: Send>(pool: bool, size: usize, a: &mut [A], f: impl Fn(usize, &mut [A]) + Sync + Send) {
    let pa = Pieces::new(a, size);
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pa.count(), &|c| unsafe { f(c * size, pa.get(c)) });
}

/// Whether a gather pass with `work` (in spring-sized units: a particle, a row entry) goes to the pool: from
/// [`GATHER_MIN`], and only when the pool has more than one thread (see [`pooled`]).
#[inline]
pub(crate) fn gather_pool(work: usize) -> bool {
    #[cfg(feature = "parallel")]
    return work >= GATHER_MIN && pool_has_threads();
    #[cfg(not(feature = "parallel"))]
    {
        let _ = work;
        false
    }
}

/// From this much work a gather pass goes to the pool ([`gather_pool`]). By its particle count alone (below
/// [`PAR_MIN`]) the 10,242-vertex ball's gather (12.7 ns a particle with pressure, a dozen row entries each) ran
/// inline: 130 µs of a 265 µs step on two threads; handed to the pool, 78 µs (2026-11-24, 2-core VM). The
/// 2,562-vertex ball's (33,282 units) lost: 33 µs inline, 38 handed over (the other thread's wake-up).
#[cfg_attr(not(feature = "parallel"), allow(dead_code))]
pub(crate) const GATHER_MIN: usize = 4 * PAR_MIN;

/// `Σ f(i)` over `0..n`, deterministic: chunk sums in `partials` (resized, reused), then summed in order.
#[inline]
pub(crate) fn sum<R: Real>(n: usize, partials: &mut Vec<R>, f: impl Fn(usize) -> R + Sync + Send) -> R {
    let nc = n.div_ceil(CHUNK);
    partials.resize(nc, R::ZERO);
    // The same chunks on the pool or not: the bits do not depend on the size threshold either.
    let pp = Pieces::new(partials, 1);
    // SAFETY: `exec` runs each piece index once.
    exec(is_pooled(n), nc, &|c| {
        let end = ((c + 1) * CHUNK).min(n);
        let total = (c * CHUNK..end).map(&f).fold(R::ZERO, |a, b| a + b);
        unsafe { pp.get(c)[0] = total };
    });
    partials.iter().fold(R::ZERO, |a, &b| a + b)
}

/// Like [`chunks`], each chunk also returning two partial sums, which are summed in chunk order (`partials`:
/// resized, reused): each total has the bits [`sum`] gives for the same terms, on any thread count, when `f`
/// folds its chunk's terms in element order from zero. Fuses a pass and the reductions over its results.
#[inline]
pub(crate) fn chunks_sums<T: Send, R: Real>(
    data: &mut [T],
    partials: &mut Vec<[R; 2]>,
    f: impl Fn(usize, &mut [T]) -> [R; 2] + Sync + Send,
) -> [R; 2] {
    partials.resize(data.len().div_ceil(CHUNK), [R::ZERO; 2]);
    let pool = is_pooled(data.len());
    let (pd, pp) = (Pieces::new(data, CHUNK), Pieces::new(partials, 1));
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pd.count(), &|c| unsafe { pp.get(c)[0] = f(c * CHUNK, pd.get(c)) });
    total2(partials)
}

/// [`chunks_sums`] over three slices of equal length walked together.
#[inline]
#[allow(clippy::type_complexity)]
pub(crate) fn chunks3_sums<A: Send, B: Send, C: Send, R: Real>(
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    partials: &mut Vec<[R; 2]>,
    f: impl Fn(usize, &mut [A], &mut [B], &mut [C]) -> [R; 2] + Sync + Send,
) -> [R; 2] {
    assert!(a.len() == b.len() && a.len() == c.len());
    partials.resize(a.len().div_ceil(CHUNK), [R::ZERO; 2]);
    let pool = is_pooled(a.len());
    let (pa, pb, pc) = (Pieces::new(a, CHUNK), Pieces::new(b, CHUNK), Pieces::new(c, CHUNK));
    let pp = Pieces::new(partials, 1);
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pa.count(), &|i| unsafe { pp.get(i)[0] = f(i * CHUNK, pa.get(i), pb.get(i), pc.get(i)) });
    total2(partials)
}

/// The chunk sums of [`chunks_sums`], in chunk order.
fn total2<R: Real>(partials: &[[R; 2]]) -> [R; 2] {
    partials.iter().fold([R::ZERO; 2], |[a, b], &[x, y]| [a + x, b + y])
}

/// [`chunks2_pooled`] over four slices (the RK4 stages' gathers).
#[inline]
#[allow(clippy::type_complexity)]
pub(crate) fn chunks4_pooled<A: Send, B: Send, C: Send, D: Send>(
    pool: bool,
    size: usize,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    d: &mut [D],
    f: impl Fn(usize, &mut [A], &mut [B], &mut [C], &mut [D]) + Sync + Send,
) {
    assert!(a.len() == b.len() && a.len() == c.len() && a.len() == d.len());
    let (pa, pb) = (Pieces::new(a, size), Pieces::new(b, size));
    let (pc, pd) = (Pieces::new(c, size), Pieces::new(d, size));
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pa.count(), &|i| unsafe { f(i * size, pa.get(i), pb.get(i), pc.get(i), pd.get(i)) });
}

/// Like [`chunks`] over three slices of equal length walked together, in chunks of `size` elements, on the pool if
/// `pool` (see [`chunks2_pooled`]).
#[inline]
pub(crate) fn chunks3_pooled<A: Send, B: Send, C: Send>(
    pool: bool,
    size: usize,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    f: impl Fn(usize, &mut [A], &mut [B], &mut [C]) + Sync + Send,
) {
    assert!(a.len() == b.len() && a.len() == c.len());
    let (pa, pb, pc) = (Pieces::new(a, size), Pieces::new(b, size), Pieces::new(c, size));
    // SAFETY: `exec` runs each piece index once.
    exec(pool, pa.count(), &|i| unsafe { f(i * size, pa.get(i), pb.get(i), pc.get(i)) });
}
