//! The check of the by-hand spans (`super::runs_avx512`, `super::runs_avx2`): each must give the scalar force's
//! bits and touch only its own lanes.

use crate::forces::spring::force_parts;

/// A by-hand span (`super::runs_avx512::span`'s signature).
pub(super) type Span = unsafe fn(
    &[f32],
    &[f32],
    (usize, usize),
    (&[f32], &[f32], &[f32]),
    usize,
    [Option<&mut [f32]>; 3],
    Option<&mut [f32]>,
);

/// Every span length from 1 to 70 (whole chunks, a short last chunk, both), ends 1, 2 and 75 apart, both damping
/// models (`projected_span`, `plain_span`): each lane's force and length are [`force_parts`]' bit for bit, added
/// and subtracted exactly where asked, and nothing outside the span's lanes is written.
///
/// # Safety
/// The CPU has the instruction set the spans are compiled for.
pub(super) unsafe fn check(projected_span: Span, plain_span: Span) {
    let mut seed = 11u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    };
    let len = 160;
    let q: Vec<f32> = (0..3 * len).map(|_| next()).collect();
    let qd: Vec<f32> = (0..3 * len).map(|_| 10.0 * next()).collect();
    let p: Vec<[f32; 3]> = (0..len).map(|_| [0.3 + next().abs(), 100.0 + next(), 0.1 + next().abs()]).collect();
    let (rest, ks, kd): (Vec<f32>, Vec<f32>, Vec<f32>) =
        (p.iter().map(|x| x[0]).collect(), p.iter().map(|x| x[1]).collect(), p.iter().map(|x| x[2]).collect());
    let check = |projected: bool, n: usize, off: usize| {
        let (i, j) = (3, 3 + off);
        let guard = 5;
        let mut out = vec![f32::NAN; 3 * (n + guard)];
        let base: Vec<f32> = (0..3 * (n + guard)).map(|k| k as f32 * 0.25).collect();
        let (mut add, mut sub) = (base.clone(), base.clone());
        let mut lens = vec![f32::NAN; n + guard];
        let args = (&q[..], &qd[..], (i, j), (&rest[..], &ks[..], &kd[..]));
        let o = [Some(&mut out[..3 * n]), Some(&mut add[..3 * n]), Some(&mut sub[..3 * n])];
        let span = if projected { projected_span } else { plain_span };
        // SAFETY: the caller's instruction set is there (its contract).
        unsafe { span(args.0, args.1, args.2, args.3, n, o, Some(&mut lens[..n])) };
        for k in 0..n {
            let e = |v: &[f32], p: usize| [v[3 * p], v[3 * p + 1], v[3 * p + 2]];
            let (qi, qj, vi, vj) = (e(&q, i + k), e(&q, j + k), e(&qd, i + k), e(&qd, j + k));
            let d = [qj[0] - qi[0], qj[1] - qi[1], qj[2] - qi[2]];
            let w = [vj[0] - vi[0], vj[1] - vi[1], vj[2] - vi[2]];
            let (f, _, l) = if projected {
                force_parts::<f32, true>(d, w, rest[k], ks[k], kd[k])
            } else {
                force_parts::<f32, false>(d, w, rest[k], ks[k], kd[k])
            };
            assert_eq!(lens[k].to_bits(), l.to_bits(), "length: n {n}, lane {k}");
            for c in 0..3 {
                let at = 3 * k + c;
                assert_eq!(out[at].to_bits(), f[c].to_bits(), "n {n}, offset {off}, lane {k}, component {c}");
                assert_eq!(add[at].to_bits(), (base[at] + f[c]).to_bits(), "add: n {n}, lane {k}");
                assert_eq!(sub[at].to_bits(), (base[at] - f[c]).to_bits(), "sub: n {n}, lane {k}");
            }
        }
        assert!(out[3 * n..].iter().all(|x| x.is_nan()), "written past the span (n {n})");
        assert!(lens[n..].iter().all(|x| x.is_nan()), "lengths past the span (n {n})");
        assert_eq!(&add[3 * n..], &base[3 * n..], "added past the span (n {n})");
        assert_eq!(&sub[3 * n..], &base[3 * n..], "subtracted past the span (n {n})");
        assert!(out[..3 * n].iter().any(|x| *x != 0.0), "forces formed (n {n})");
    };
    for projected in [true, false] {
        for n in 1..=70 {
            for off in [1, 2, 75] {
                check(projected, n, off);
            }
        }
    }
}
