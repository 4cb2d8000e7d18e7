//! Instruction sets chosen at run time for the hot kernels (x86-64).
//!
//! Each kernel that vectorises is compiled for the baseline and for the wider sets the CPU may have, and the
//! dispatcher picks the widest that was measured to pay *for that kernel*: AVX-512 (F, VL) for the grid-run
//! spring kernel, symplectic Euler's update after it and the wind pass; AVX2 for those and for the per-spring
//! kernel (slower at 512 bits: the vectoriser's gathers) and the implicit solver's runs. Every version gives the
//! same bits: packed additions, multiplications, divisions and square roots round like the scalar ones, and Rust
//! never fuses a multiply and an add unless asked. `tests/isa.rs` checks that claim on every set the CPU has, and
//! `benches/RESULTS.md` (issue 15, 2026-11-24 sixth session) holds the measurements behind each choice.
//!
//! Each version is a small wrapper function of its own carrying `#[target_feature]` and calling the
//! `#[inline(always)]` kernel, so the kernel is compiled inside it for those features (`wide_kernel!` writes the
//! wrappers and the dispatcher for a kernel). One generic helper taking
//! the kernel as a closure (`fn on_avx512(f: impl FnOnce() -> T)`) was tried instead: the 128² cloth's step took
//! 403–416 µs on one thread against 107–113 with the wrappers, since the kernel was no longer compiled for the
//! helper's features. So the wrappers stay, one per kernel and instruction set.

use std::sync::atomic::{AtomicU8, Ordering};

#[cfg(target_arch = "x86_64")]
pub(crate) mod vec3x16;

/// An instruction set the kernels can be compiled for, narrowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64; the only one on other targets).
    Baseline = 0,
    /// AVX2 (x86-64).
    Avx2 = 1,
    /// AVX-512 F and VL (x86-64).
    Avx512 = 2,
}

impl Isa {
    fn from_u8(v: u8) -> Isa {
        match v {
            0 => Isa::Baseline,
            1 => Isa::Avx2,
            _ => Isa::Avx512,
        }
    }
}

/// The widest set the dispatchers may pick (see [`set_limit`]).
static LIMIT: AtomicU8 = AtomicU8::new(Isa::Avx512 as u8);

/// The sets this CPU has, narrowest first (always starting with [`Isa::Baseline`]).
pub fn available() -> Vec<Isa> {
    [Isa::Baseline, Isa::Avx2, Isa::Avx512].into_iter().filter(|&s| detected(s)).collect()
}

/// Whether the CPU has `isa` (detected once, cached by std).
fn detected(isa: Isa) -> bool {
    match isa {
        Isa::Baseline => true,
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => {
            std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
        }
        #[cfg(not(target_arch = "x86_64"))]
        _ => false,
    }
}

/// Caps the instruction sets the kernels may use, for the whole process, and returns the cap before (the default
/// is no cap: [`Isa::Avx512`]). Every set gives the same bits, so this changes only speed: it is for comparing
/// the versions (`tests/isa.rs`) and timing one against another. A cap wider than the CPU has changes nothing.
pub fn set_limit(isa: Isa) -> Isa {
    Isa::from_u8(LIMIT.swap(isa as u8, Ordering::Relaxed))
}

/// Whether the kernels may use AVX-512 F and VL: the CPU has them (detected once, cached by std) and the cap
/// allows them.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn avx512() -> bool {
    LIMIT.load(Ordering::Relaxed) >= Isa::Avx512 as u8 && detected(Isa::Avx512)
}

/// Whether the kernels may use AVX2 (see [`avx512`]).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn avx2() -> bool {
    LIMIT.load(Ordering::Relaxed) >= Isa::Avx2 as u8 && detected(Isa::Avx2)
}

/// Defines the dispatcher `$name`, which runs the `#[inline(always)]` kernel `$kernel` compiled for AVX-512 (F, VL)
/// or AVX2 when the CPU has them and [`set_limit`] allows them, else for the baseline: the wrappers of the module
/// docs, one per set, written once. `[$gen]`: the generic parameters; `[$targ]`: the kernel's generic arguments.
macro_rules! wide_kernel {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident[$($gen:tt)*]($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? => $kernel:ident[$($targ:tt)*]
    ) => {
        $(#[$meta])*
        #[inline]
        #[allow(clippy::too_many_arguments)]
        $vis fn $name<$($gen)*>($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512vl")]
                #[allow(clippy::too_many_arguments)]
                fn avx512<$($gen)*>($($arg: $ty),*) $(-> $ret)? {
                    $kernel::<$($targ)*>($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                fn avx2<$($gen)*>($($arg: $ty),*) $(-> $ret)? {
                    $kernel::<$($targ)*>($($arg),*)
                }
                if $crate::isa::avx512() {
                    // SAFETY: the CPU supports AVX-512 F and VL, checked just above.
                    return unsafe { avx512::<$($targ)*>($($arg),*) };
                }
                if $crate::isa::avx2() {
                    // SAFETY: the CPU supports AVX2, checked just above.
                    return unsafe { avx2::<$($targ)*>($($arg),*) };
                }
            }
            $kernel::<$($targ)*>($($arg),*)
        }
    };
}
pub(crate) use wide_kernel;
