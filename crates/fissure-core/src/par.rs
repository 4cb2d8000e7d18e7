//! Deterministic data-parallel helpers.
//!
//! Work is cut into fixed-size chunks, independent of the number of threads. Element-wise passes are trivially
//! thread-count independent; reductions sum each fixed chunk, then the chunk sums in chunk order, so a sum has
//! the same bits on 1 thread or 64. Small inputs run inline: forking costs microseconds.
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

/// Runs `f(start, chunk)` over `data` in fixed chunks, in parallel when there is more than one chunk.
#[inline]
pub(crate) fn chunks<T: Send>(data: &mut [T], f: impl Fn(usize, &mut [T]) + Sync + Send) {
    chunks_of(CHUNK, data, f)
}

/// [`chunks`] in chunks of `size` elements (the spring-run kernel's blocks, which grow with a grid's rows).
#[inline]
pub(crate) fn chunks_of<T: Send>(size: usize, data: &mut [T], f: impl Fn(usize, &mut [T]) + Sync + Send) {
    #[cfg(feature = "parallel")]
    if pooled(data.len()) {
        data.par_chunks_mut(size).enumerate().for_each(|(c, s)| f(c * size, s));
        return;
    }
    // The same fixed chunks as the parallel path: kernels whose order depends on the chunking (the spring-run
    // kernel) give the same bits either way.
    data.chunks_mut(size).enumerate().for_each(|(c, s)| f(c * size, s));
}

/// Like [`chunks`] over two slices of equal length walked together.
#[inline]
pub(crate) fn chunks2<A: Send, B: Send>(a: &mut [A], b: &mut [B], f: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send) {
    debug_assert_eq!(a.len(), b.len());
    #[cfg(feature = "parallel")]
    if pooled(a.len()) {
        a.par_chunks_mut(CHUNK).zip(b.par_chunks_mut(CHUNK)).enumerate().for_each(|(c, (x, y))| f(c * CHUNK, x, y));
        return;
    }
    a.chunks_mut(CHUNK).zip(b.chunks_mut(CHUNK)).enumerate().for_each(|(i, (x, y))| f(i * CHUNK, x, y));
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
    debug_assert_eq!(a.len(), b.len());
    #[cfg(feature = "parallel")]
    if pool {
        a.par_chunks_mut(size).zip(b.par_chunks_mut(size)).enumerate().for_each(|(c, (x, y))| f(c * size, x, y));
        return;
    }
    let _ = pool;
    a.chunks_mut(size).zip(b.chunks_mut(size)).enumerate().for_each(|(i, (x, y))| f(i * size, x, y));
}

/// [`chunks2_pooled`] over one slice.
#[inline]
pub(crate) fn chunks_pooled<A: Send>(pool: bool, size: usize, a: &mut [A], f: impl Fn(usize, &mut [A]) + Sync + Send) {
    #[cfg(feature = "parallel")]
    if pool {
        a.par_chunks_mut(size).enumerate().for_each(|(c, x)| f(c * size, x));
        return;
    }
    let _ = pool;
    a.chunks_mut(size).enumerate().for_each(|(i, x)| f(i * size, x));
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
    #[cfg(feature = "parallel")]
    if pooled(n) {
        partials.par_iter_mut().enumerate().for_each(|(c, p)| {
            let end = ((c + 1) * CHUNK).min(n);
            *p = (c * CHUNK..end).map(&f).fold(R::ZERO, |a, b| a + b);
        });
        return partials.iter().fold(R::ZERO, |a, &b| a + b);
    }
    // Same chunked order as the parallel path, so the bits do not depend on the size threshold either.
    for (c, p) in partials.iter_mut().enumerate() {
        *p = (c * CHUNK..((c + 1) * CHUNK).min(n)).map(&f).fold(R::ZERO, |a, b| a + b);
    }
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
    #[cfg(feature = "parallel")]
    if pooled(data.len()) {
        data.par_chunks_mut(CHUNK)
            .zip(partials.par_iter_mut())
            .enumerate()
            .for_each(|(c, (x, p))| *p = f(c * CHUNK, x));
        return total2(partials);
    }
    data.chunks_mut(CHUNK).zip(partials.iter_mut()).enumerate().for_each(|(c, (x, p))| *p = f(c * CHUNK, x));
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
    debug_assert!(a.len() == b.len() && a.len() == c.len());
    partials.resize(a.len().div_ceil(CHUNK), [R::ZERO; 2]);
    #[cfg(feature = "parallel")]
    if pooled(a.len()) {
        a.par_chunks_mut(CHUNK)
            .zip(b.par_chunks_mut(CHUNK))
            .zip(c.par_chunks_mut(CHUNK).zip(partials.par_iter_mut()))
            .enumerate()
            .for_each(|(i, ((x, y), (z, p)))| *p = f(i * CHUNK, x, y, z));
        return total2(partials);
    }
    a.chunks_mut(CHUNK)
        .zip(b.chunks_mut(CHUNK))
        .zip(c.chunks_mut(CHUNK).zip(partials.iter_mut()))
        .enumerate()
        .for_each(|(i, ((x, y), (z, p)))| *p = f(i * CHUNK, x, y, z));
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
    #[cfg(feature = "parallel")]
    if pool {
        a.par_chunks_mut(size)
            .zip(b.par_chunks_mut(size))
            .zip(c.par_chunks_mut(size).zip(d.par_chunks_mut(size)))
            .enumerate()
            .for_each(|(i, ((w, x), (y, z)))| f(i * size, w, x, y, z));
        return;
    }
    let _ = pool;
    a.chunks_mut(size)
        .zip(b.chunks_mut(size))
        .zip(c.chunks_mut(size).zip(d.chunks_mut(size)))
        .enumerate()
        .for_each(|(i, ((w, x), (y, z)))| f(i * size, w, x, y, z));
}

/// Like [`chunks`] over three slices of equal length walked together, in chunks of `size` elements (see
/// [`chunks_of`]).
#[inline]
pub(crate) fn chunks3_of<A: Send, B: Send, C: Send>(
    size: usize,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    f: impl Fn(usize, &mut [A], &mut [B], &mut [C]) + Sync + Send,
) {
    #[cfg(feature = "parallel")]
    let pool = pooled(a.len());
    #[cfg(not(feature = "parallel"))]
    let pool = false;
    chunks3_pooled(pool, size, a, b, c, f)
}

/// [`chunks3_of`]'s walk, on the pool if `pool` (see [`chunks2_pooled`]).
#[inline]
pub(crate) fn chunks3_pooled<A: Send, B: Send, C: Send>(
    pool: bool,
    size: usize,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    f: impl Fn(usize, &mut [A], &mut [B], &mut [C]) + Sync + Send,
) {
    #[cfg(feature = "parallel")]
    if pool {
        a.par_chunks_mut(size)
            .zip(b.par_chunks_mut(size))
            .zip(c.par_chunks_mut(size))
            .enumerate()
            .for_each(|(i, ((x, y), z))| f(i * size, x, y, z));
        return;
    }
    let _ = pool;
    a.chunks_mut(size)
        .zip(b.chunks_mut(size))
        .zip(c.chunks_mut(size))
        .enumerate()
        .for_each(|(i, ((x, y), z))| f(i * size, x, y, z));
}
