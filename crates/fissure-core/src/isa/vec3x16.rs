//! 16 3-vectors in three AVX-512 registers: loaded and stored as interleaved `f32` components (`x0 y0 z0 x1 …`,
//! the layout of a slice of `Vec3`), split into one register per component and joined back with two two-source
//! permutes per register (the run kernel's spans, `forces::runs_avx512`; the collision pass's blocks,
//! `collision::lanes`).

use std::arch::x86_64::*;

/// 16 3-vectors from `s[at ..]`, as three registers of interleaved components; with `mask`, only the elements it
/// selects in each register (the others zero).
#[inline(always)]
pub(crate) unsafe fn load3(s: &[f32], at: usize, mask: Option<[u16; 3]>) -> [__m512; 3] {
    // SAFETY: the caller's bounds; masked-off elements are not read (`wrapping_add`: a pointer past the slice is
    // never dereferenced).
    unsafe {
        let p = s.as_ptr().add(at);
        match mask {
            None => [_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16)), _mm512_loadu_ps(p.add(32))],
            Some(m) => [
                _mm512_maskz_loadu_ps(m[0], p),
                _mm512_maskz_loadu_ps(m[1], p.wrapping_add(16)),
                _mm512_maskz_loadu_ps(m[2], p.wrapping_add(32)),
            ],
        }
    }
}

/// Stores three registers of interleaved 3-vectors at `s[at ..]`; with `mask`, only the elements it selects.
#[inline(always)]
pub(crate) unsafe fn store3(s: &mut [f32], at: usize, v: [__m512; 3], mask: Option<[u16; 3]>) {
    // SAFETY: the caller's bounds; masked-off elements are not written.
    unsafe {
        let p = s.as_mut_ptr().add(at);
        match mask {
            None => {
                _mm512_storeu_ps(p, v[0]);
                _mm512_storeu_ps(p.add(16), v[1]);
                _mm512_storeu_ps(p.add(32), v[2]);
            }
            Some(m) => {
                _mm512_mask_storeu_ps(p, m[0], v[0]);
                _mm512_mask_storeu_ps(p.wrapping_add(16), m[1], v[1]);
                _mm512_mask_storeu_ps(p.wrapping_add(32), m[2], v[2]);
            }
        }
    }
}

/// The permutes' index tables: for component (or register) `c`, the first and the second permute's.
const SPLIT: [[[i32; 16]; 2]; 3] = split_tables();
const JOIN: [[[i32; 16]; 2]; 3] = join_tables();

/// [`split`]'s: component `c` of vector `e` is element `3e + c` of the 48, taken from the first two registers
/// while under 32 (first permute), then from the third (second permute, which keeps the first's elements).
const fn split_tables() -> [[[i32; 16]; 2]; 3] {
    let mut t = [[[0; 16]; 2]; 3];
    let mut c = 0;
    while c < 3 {
        let mut e = 0;
        while e < 16 {
            let g = 3 * e + c as i32;
            if g < 32 {
                t[c][0][e as usize] = g;
                t[c][1][e as usize] = e;
            } else {
                t[c][1][e as usize] = 16 + g - 32;
            }
            e += 1;
        }
        c += 1;
    }
    t
}

/// [`join`]'s: element `e` of register `r` is element `g = 16r + e` of the 48, component `g % 3` of vector `g / 3`:
/// the first permute takes components 0 and 1, the second component 2 (keeping the first's elements).
const fn join_tables() -> [[[i32; 16]; 2]; 3] {
    let mut t = [[[0; 16]; 2]; 3];
    let mut r = 0;
    while r < 3 {
        let mut e = 0;
        while e < 16 {
            let g = 16 * r as i32 + e;
            let (comp, vec) = (g % 3, g / 3);
            t[r][0][e as usize] = if comp == 0 { vec } else { 16 + vec };
            t[r][1][e as usize] = if comp == 2 { 16 + vec } else { e };
            e += 1;
        }
        r += 1;
    }
    t
}

/// An index table as a register.
#[inline(always)]
unsafe fn index(t: &[i32; 16]) -> __m512i {
    // SAFETY: 16 values.
    unsafe { _mm512_loadu_si512(t.as_ptr().cast()) }
}

/// Interleaved 3-vectors (element `e` of the 48 is component `e % 3` of vector `e / 3`) → one register a component.
#[inline(always)]
pub(crate) unsafe fn split(v: [__m512; 3]) -> [__m512; 3] {
    // SAFETY: AVX-512 F (the caller's target features).
    unsafe { permute3(v, &SPLIT) }
}

/// 16 3-vectors from `s[at ..]` (interleaved) into `out[0..3]`, one component a slice (16 values each), and the
/// three registers it stored (the collision pass's blocks, the wind's relative air).
#[inline(always)]
pub(crate) unsafe fn split_into(s: &[f32], at: usize, out: [&mut [f32]; 3]) -> [__m512; 3] {
    assert!(out.iter().all(|o| o.len() >= 16));
    // SAFETY: the caller's bounds for `s`, 16 values in each `out` (asserted); AVX-512 F (the caller's target
    // features).
    unsafe {
        let c = split(load3(s, at, None));
        for (o, &r) in out.into_iter().zip(&c) {
            _mm512_storeu_ps(o.as_mut_ptr(), r);
        }
        c
    }
}

/// The inverse of [`split`].
#[inline(always)]
pub(crate) unsafe fn join(f: [__m512; 3]) -> [__m512; 3] {
    // SAFETY: AVX-512 F (the caller's target features).
    unsafe { permute3(f, &JOIN) }
}

/// Output register `r` of three: the first two inputs through `t[r][0]`, then that and the third through `t[r][1]`.
#[inline(always)]
unsafe fn permute3(v: [__m512; 3], t: &[[[i32; 16]; 2]; 3]) -> [__m512; 3] {
    // SAFETY: AVX-512 F (the caller's target features). Written out, without closures: a closure here does not
    // take the caller's target features, and the intrinsics in it were calls in some callers (`lanes::load_positions`).
    unsafe {
        let (a, b, c) = (
            _mm512_permutex2var_ps(v[0], index(&t[0][0]), v[1]),
            _mm512_permutex2var_ps(v[0], index(&t[1][0]), v[1]),
            _mm512_permutex2var_ps(v[0], index(&t[2][0]), v[1]),
        );
        [
            _mm512_permutex2var_ps(a, index(&t[0][1]), v[2]),
            _mm512_permutex2var_ps(b, index(&t[1][1]), v[2]),
            _mm512_permutex2var_ps(c, index(&t[2][1]), v[2]),
        ]
    }
}
