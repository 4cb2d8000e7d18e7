//! Instruction sets chosen at run time for the hot kernels (x86-64).
//!
//! Each kernel that vectorises is compiled for the baseline and for the wider sets the CPU may have, and the
//! dispatcher picks the widest that was measured to pay *for that kernel*. Every version gives the same bits:
//! packed additions, multiplications, divisions and square roots round like the scalar ones, and Rust never
//! fuses a multiply and an add unless asked. See `benches/RESULTS.md` (issue 15, 2026-11-24 sixth session) for
//! the measurements behind each choice.
//!
//! Each version is a small wrapper function of its own carrying `#[target_feature]` and calling the
//! `#[inline(always)]` kernel, so the kernel is compiled inside it for those features. One generic helper taking
//! the kernel as a closure (`fn on_avx512(f: impl FnOnce() -> T)`) was tried instead: the 128² cloth's step took
//! 403–416 µs on one thread against 107–113 with the wrappers, since the kernel was no longer compiled for the
//! helper's features. So the wrappers stay, one per kernel and instruction set.

/// Whether the CPU has AVX-512 F and VL (detected once, cached by std).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}
