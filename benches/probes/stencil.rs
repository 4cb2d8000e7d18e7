//! A stand-alone prototype of a grid stencil for issue 15's 1024² row (not built by cargo; `benches/RESULTS.md`,
//! entry 33, has what it measured and why it is not in the solver yet).
//!
//! One symplectic Euler step of an n × n cloth grid (structural springs, both diagonals, bending springs two
//! apart: the benchmark cloth's six families, 1000 N/m, 0.01 N·s/m, 1 g particles, 1 cm apart), `f32`, the state
//! in memory as interleaved 3-vectors like `State`'s. Each thread sweeps its half of the rows: row r + 2 read
//! once into a ring of four rows split into components (permutes), the springs based at row r formed once in
//! lanes of 16 columns, their forces summed into the ring's rows r, r + 1, r + 2 (the ends along a row by lane
//! shifts of the previous chunk's forces), and row r updated and written back as soon as it is complete.
//!
//! Run (x86-64 with AVX-512):
//!
//! ```text
//! rustc -C opt-level=3 -C target-cpu=native benches/probes/stencil.rs -o /tmp/stencil
//! PF=1 /tmp/stencil 1024 2     # n, threads; PF: prefetch row r + 3; NT: non-temporal stores
//! ```
//!
//! It prints the best step time over 47 steps (each step spawns its threads, ~30–60 µs).
use std::arch::x86_64::*;
use std::time::Instant;

const PAD: usize = 16;

#[inline(always)] unsafe fn ld(p: &[f32], at: usize) -> __m512 { unsafe { _mm512_loadu_ps(p.as_ptr().add(at)) } }

#[inline(always)]
unsafe fn force(d: [__m512; 3], w: [__m512; 3], rest: __m512, ks: __m512, kd: __m512) -> [__m512; 3] {
    unsafe {
        let l2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(d[0], d[0]), _mm512_mul_ps(d[1], d[1])), _mm512_mul_ps(d[2], d[2]));
        let l = _mm512_sqrt_ps(l2);
        let inv = _mm512_maskz_div_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(l2, _mm512_setzero_ps()), _mm512_set1_ps(1.0), l);
        let u = [_mm512_mul_ps(d[0], inv), _mm512_mul_ps(d[1], inv), _mm512_mul_ps(d[2], inv)];
        let el = _mm512_mul_ps(ks, _mm512_sub_ps(l, rest));
        let dot = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(w[0], u[0]), _mm512_mul_ps(w[1], u[1])), _mm512_mul_ps(w[2], u[2]));
        let mag = _mm512_add_ps(el, _mm512_mul_ps(kd, dot));
        [_mm512_mul_ps(u[0], mag), _mm512_mul_ps(u[1], mag), _mm512_mul_ps(u[2], mag)]
    }
}

fn idx_in(j: usize) -> ([i32; 16], [i32; 16]) {
    let (mut a, mut b) = ([0i32; 16], [0i32; 16]);
    for k in 0..16 { let p = 3 * k + j; if p < 32 { a[k] = p as i32; b[k] = k as i32; } else { a[k] = 0; b[k] = 16 + (p - 32) as i32; } }
    (a, b)
}
fn idx_out(o: usize) -> ([i32; 16], [i32; 16]) {
    let (mut a, mut b) = ([0i32; 16], [0i32; 16]);
    for t in 0..16 { let p = 16 * o + t; let (j, k) = (p % 3, p / 3); a[t] = match j { 0 => k as i32, 1 => 16 + k as i32, _ => 0 }; b[t] = if j == 2 { 16 + k as i32 } else { t as i32 }; }
    (a, b)
}
#[target_feature(enable = "avx512f")]
unsafe fn load_row_v(q: &[f32], qd: &[f32], n: usize, r: usize, dst: &mut [Vec<f32>; 6]) {
    unsafe {
    let ids: [([i32; 16], [i32; 16]); 3] = std::array::from_fn(idx_in);
    let ii: [(__m512i, __m512i); 3] = std::array::from_fn(|j| (_mm512_loadu_si512(ids[j].0.as_ptr() as *const _), _mm512_loadu_si512(ids[j].1.as_ptr() as *const _)));
    let base = 3 * r * n;
    let mut c = 0;
    while c < n {
        for (src, off) in [(q, 0usize), (qd, 3usize)] {
            let p = src.as_ptr().add(base + 3 * c);
            let (a, b, cc) = (_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16)), _mm512_loadu_ps(p.add(32)));
            for j in 0..3 {
                let t = _mm512_permutex2var_ps(a, ii[j].0, b);
                let x = _mm512_permutex2var_ps(t, ii[j].1, cc);
                _mm512_storeu_ps(dst[off + j].as_mut_ptr().add(PAD + c), x);
            }
        }
        c += 16;
    }
    }
}
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn sweep(n: usize, r0: usize, r1: usize, q: &[f32], qd: &[f32], qn: &mut [f32], qdn: &mut [f32], p: [f32; 9], dt: f32, w_inv: &[f32], mass: &[f32], rows: &mut Vec<[Vec<f32>; 6]>, acc: &mut Vec<[Vec<f32>; 3]>) {
    unsafe {
    let nt = std::env::var_os("NT").is_some();
    let pf = std::env::var_os("PF").is_some();
    let start = r0.saturating_sub(2);
    // rows start, start+1 loaded; loop loads r+2
    for r in start..(start + 2).min(n) { load_row_v(q, qd, n, r, &mut rows[r % 4]); for k in 0..3 { acc[r % 4][k].fill(0.0); } }
    let (rs_s, ks_s, kd_s) = (_mm512_set1_ps(p[0]), _mm512_set1_ps(p[1]), _mm512_set1_ps(p[2]));
    let rs_d = _mm512_set1_ps(p[3]);
    let rs_b = _mm512_set1_ps(p[6]);
    let g = [_mm512_setzero_ps(), _mm512_set1_ps(-9.81), _mm512_setzero_ps()];
    let dtv = _mm512_set1_ps(dt);
    let zero = _mm512_setzero_ps();
    let ido: [([i32; 16], [i32; 16]); 3] = std::array::from_fn(idx_out);
    let io: [(__m512i, __m512i); 3] = std::array::from_fn(|j| (_mm512_loadu_si512(ido[j].0.as_ptr() as *const _), _mm512_loadu_si512(ido[j].1.as_ptr() as *const _)));
    for r in start..r1 {
        if pf && r + 3 < n { let o = 3 * (r + 3) * n; let mut k = 0; while k < 3 * n { _mm_prefetch::<_MM_HINT_T0>(q.as_ptr().add(o + k) as *const i8); _mm_prefetch::<_MM_HINT_T0>(qd.as_ptr().add(o + k) as *const i8); k += 16; } }
        if r + 2 < n { let (a, b) = (r + 2, &mut rows[(r + 2) % 4]); load_row_v(q, qd, n, a, b); for k in 0..3 { acc[(r + 2) % 4][k].fill(0.0); } }
        let has1 = r + 1 < n; let has2 = r + 2 < n;
        // raw pointers to rows
        let (i0, i1, i2) = (r % 4, (r + 1) % 4, (r + 2) % 4);
        let row0: [&[f32]; 6] = std::array::from_fn(|k| &rows[i0][k][..]);
        let row1: [&[f32]; 6] = std::array::from_fn(|k| &rows[i1][k][..]);
        let row2: [&[f32]; 6] = std::array::from_fn(|k| &rows[i2][k][..]);
        let a0: [*mut f32; 3] = std::array::from_fn(|k| acc[i0][k].as_mut_ptr());
        let a1: [*mut f32; 3] = std::array::from_fn(|k| acc[i1][k].as_mut_ptr());
        let a2: [*mut f32; 3] = std::array::from_fn(|k| acc[i2][k].as_mut_ptr());
        let mut prev_h = [zero; 3]; let mut prev_b = [zero; 3]; let mut prev_dg = [zero; 3]; let mut prev_an = [zero; 3];
        let mut c = 0;
        while c < n {
            let at = PAD + c;
            let lanes_h: u16 = if c + 16 < n { 0xffff } else { 0x7fff };
            let lanes_b: u16 = if c + 16 < n { 0xffff } else { 0x3fff };
            let x0: [__m512; 6] = std::array::from_fn(|k| ld(row0[k], at));
            let x0p1: [__m512; 6] = std::array::from_fn(|k| ld(row0[k], at + 1));
            let x0p2: [__m512; 6] = std::array::from_fn(|k| ld(row0[k], at + 2));
            let dif = |a: &[__m512; 6], b: &[__m512; 6]| -> ([__m512; 3], [__m512; 3]) {
                (std::array::from_fn(|k| _mm512_sub_ps(b[k], a[k])), std::array::from_fn(|k| _mm512_sub_ps(b[3 + k], a[3 + k])))
            };
            let mz = |m: u16, f: [__m512; 3]| -> [__m512; 3] { std::array::from_fn(|k| _mm512_maskz_mov_ps(m, f[k])) };
            // horizontal (c+k, c+k+1) and bend (c+k, c+k+2)
            let (d, w) = dif(&x0, &x0p1); let fh = mz(lanes_h, force(d, w, rs_s, ks_s, kd_s));
            let (d, w) = dif(&x0, &x0p2); let fb = mz(lanes_b, force(d, w, rs_b, ks_s, kd_s));
            let mut s0 = [zero; 3];
            for k in 0..3 {
                let sh = _mm512_castsi512_ps(_mm512_alignr_epi32(_mm512_castps_si512(fh[k]), _mm512_castps_si512(prev_h[k]), 15));
                let sb = _mm512_castsi512_ps(_mm512_alignr_epi32(_mm512_castps_si512(fb[k]), _mm512_castps_si512(prev_b[k]), 14));
                s0[k] = _mm512_sub_ps(_mm512_add_ps(fh[k], fb[k]), _mm512_add_ps(sh, sb));
            }
            prev_h = fh; prev_b = fb;
            let mut s1 = [zero; 3]; let mut s2 = [zero; 3];
            if has1 {
                let x1: [__m512; 6] = std::array::from_fn(|k| ld(row1[k], at));
                let x1p1: [__m512; 6] = std::array::from_fn(|k| ld(row1[k], at + 1));
                // down (r,c)->(r+1,c)
                let (d, w) = dif(&x0, &x1); let fd = force(d, w, rs_s, ks_s, kd_s);
                // diag (r,c)->(r+1,c+1)
                let (d, w) = dif(&x0, &x1p1); let fdg = mz(lanes_h, force(d, w, rs_d, ks_s, kd_s));
                // anti (r,c+1)->(r+1,c)
                let (d, w) = dif(&x0p1, &x1); let fan = mz(lanes_h, force(d, w, rs_d, ks_s, kd_s));
                for k in 0..3 {
                    let sdg = _mm512_castsi512_ps(_mm512_alignr_epi32(_mm512_castps_si512(fdg[k]), _mm512_castps_si512(prev_dg[k]), 15));
                    let san = _mm512_castsi512_ps(_mm512_alignr_epi32(_mm512_castps_si512(fan[k]), _mm512_castps_si512(prev_an[k]), 15));
                    s0[k] = _mm512_add_ps(s0[k], _mm512_add_ps(_mm512_add_ps(fd[k], fdg[k]), san));
                    s1[k] = _mm512_add_ps(_mm512_add_ps(fd[k], sdg), fan[k]);
                }
                prev_dg = fdg; prev_an = fan;
                if has2 {
                    let x2: [__m512; 6] = std::array::from_fn(|k| ld(row2[k], at));
                    let (d, w) = dif(&x0, &x2); let fbd = force(d, w, rs_b, ks_s, kd_s);
                    for k in 0..3 { s0[k] = _mm512_add_ps(s0[k], fbd[k]); s2[k] = fbd[k]; }
                }
            }
            for k in 0..3 {
                let p0 = a0[k].add(at); _mm512_storeu_ps(p0, _mm512_add_ps(_mm512_loadu_ps(p0), s0[k]));
                if has1 { let p1 = a1[k].add(at); _mm512_storeu_ps(p1, _mm512_sub_ps(_mm512_loadu_ps(p1), s1[k])); }
                if has2 { let p2 = a2[k].add(at); _mm512_storeu_ps(p2, _mm512_sub_ps(_mm512_loadu_ps(p2), s2[k])); }
            }
            c += 16;
        }
        // row r complete: update, write AoS
        if r >= r0 {
            let base = r * n;
            let mut c = 0;
            while c < n {
                let at = PAD + c;
                let wv = _mm512_loadu_ps(w_inv.as_ptr().add(base + c));
                let mv = _mm512_loadu_ps(mass.as_ptr().add(base + c));
                let mut xs = [zero; 3]; let mut vs = [zero; 3];
                for k in 0..3 {
                    let f = _mm512_add_ps(_mm512_mul_ps(g[k], mv), _mm512_loadu_ps(a0[k].add(at)));
                    let v = _mm512_add_ps(ld(row0[3 + k], at), _mm512_mul_ps(f, _mm512_mul_ps(wv, dtv)));
                    vs[k] = v;
                    xs[k] = _mm512_add_ps(ld(row0[k], at), _mm512_mul_ps(v, dtv));
                }
                let o = 3 * (base + c);
                for (src, dst) in [(xs, qn.as_mut_ptr()), (vs, qdn.as_mut_ptr())] {
                    for oo in 0..3 {
                        let t = _mm512_permutex2var_ps(src[0], io[oo].0, src[1]);
                        let x = _mm512_permutex2var_ps(t, io[oo].1, src[2]);
                        if nt { _mm512_stream_ps(dst.add(o + 16 * oo), x) } else { _mm512_storeu_ps(dst.add(o + 16 * oo), x) }
                    }
                }
                c += 16;
            }
        }
    }
    }
}

/// `n` zeroed `f32`s in a 64-byte aligned buffer (non-temporal stores need the alignment), owned as blocks of 16
/// and seen as a slice: freed with the layout it was allocated with.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
struct A([f32; 16]);
struct Aligned(Vec<A>, usize);
impl std::ops::Deref for Aligned {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        // SAFETY: `self.1 <= 16 * self.0.len()` initialised `f32`s, contiguous in the blocks.
        unsafe { std::slice::from_raw_parts(self.0.as_ptr() as *const f32, self.1) }
    }
}
impl std::ops::DerefMut for Aligned {
    fn deref_mut(&mut self) -> &mut [f32] {
        // SAFETY: as in `deref`, uniquely borrowed.
        unsafe { std::slice::from_raw_parts_mut(self.0.as_mut_ptr() as *mut f32, self.1) }
    }
}
fn avec(n: usize) -> Aligned {
    Aligned(vec![A([0.0; 16]); n.div_ceil(16)], n)
}
fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let threads: usize = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(2);
    let steps = 50;
    let h = 0.01f32;
    let mut q = avec(3 * n * n); let mut qd = avec(3 * n * n);
    let mut s = 1u64;
    let mut rnd = || { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5 };
    for r in 0..n { for c in 0..n { let i = r * n + c; q[3 * i] = c as f32 * h; q[3 * i + 1] = 1.0 + 1e-4 * rnd(); q[3 * i + 2] = r as f32 * h; qd[3*i+1] = 0.01 * rnd(); } }
    let mut qn = avec(3 * n * n); let mut qdn = avec(3 * n * n);
    let w_inv = vec![1000f32; n * n]; let mass = vec![1e-3f32; n * n];
    let p = [h, 1000.0, 0.01, h * 2f32.sqrt(), 1000.0, 0.01, 2.0 * h, 1000.0, 0.01];
    let mut best = f64::INFINITY;
    let wlen = n + 2 * PAD;
    let mut scratch: Vec<(Vec<[Vec<f32>; 6]>, Vec<[Vec<f32>; 3]>)> = (0..threads).map(|_| ((0..4).map(|_| std::array::from_fn(|_| vec![0.0f32; wlen])).collect(), (0..4).map(|_| std::array::from_fn(|_| vec![0.0f32; wlen])).collect())).collect();
    for it in 0..steps {
        let t = Instant::now();
        let rows_per = n.div_ceil(threads);
        let (qr, qdr) = (&q[..], &qd[..]);
        let chunks: Vec<(&mut [f32], &mut [f32])> = qn.chunks_mut(3 * n * rows_per).zip(qdn.chunks_mut(3 * n * rows_per)).collect();
        std::thread::scope(|sc| {
            for ((k, (a, b)), sc_) in chunks.into_iter().enumerate().zip(scratch.iter_mut()) {
                let (w_inv, mass) = (&w_inv, &mass);
                sc.spawn(move || {
                    // each thread writes its own rows: give it full-size views by offsetting
                    let r0 = k * rows_per; let r1 = ((k + 1) * rows_per).min(n);
                    
                    // SAFETY: the thread writes rows r0..r1 only: index into its chunk with an offset.
                    let off = 3 * n * r0;
                    let qn_full = unsafe { std::slice::from_raw_parts_mut(a.as_mut_ptr().sub(off), 3 * n * n) };
                    let qdn_full = unsafe { std::slice::from_raw_parts_mut(b.as_mut_ptr().sub(off), 3 * n * n) };
                    unsafe { sweep(n, r0, r1, qr, qdr, qn_full, qdn_full, p, 1e-4, w_inv, mass, &mut sc_.0, &mut sc_.1) };
                });
            }
        });
        let e = t.elapsed().as_secs_f64();
        if it > 2 { best = best.min(e); }
        std::mem::swap(&mut q, &mut qn); std::mem::swap(&mut qd, &mut qdn);
    }
    let ke: f64 = qd.iter().map(|&v| (v as f64) * (v as f64)).sum();
    println!("n {n} threads {threads}: best {:.3} ms per step (incl. thread spawn) ke {ke:.3e}", best * 1e3);
}
