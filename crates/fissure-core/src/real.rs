//! One physics source for two precisions.
//!
//! Every force, integrator and collision routine is written once against [`Real`] (the scalar) and its
//! [`Real::V`] (a 3-vector of that scalar). `f32` with [`glam::Vec3`] is the fast path; `f64` with
//! [`glam::DVec3`] produces the reference solutions the accuracy tests and benchmarks compare against.
//! Meshes and builder parameters are always `f64`; [`crate::ModelBuilder::finalize`] rounds them once.

use glam::{DVec3, Vec3, Vec3A};
use std::fmt::{Debug, Display};
use std::iter::Sum;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar the simulation can run in (`f32` or `f64`).
pub trait Real:
    Copy
    + Send
    + Sync
    + Debug
    + Display
    + Default
    + PartialEq
    + PartialOrd
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Sum
{
    /// The 3-vector of this precision.
    type V: Vector3<Self>;
    /// [`Real::V`] as the gathers read it best: `f32`'s padded to 16 bytes ([`glam::Vec3A`]: one load and one
    /// packed add an entry where a 12-byte vector takes two of each), `f64`'s as it is. Component by component the
    /// same additions: the same bits.
    type VA: Copy + Debug + Default + Send + Sync + Add<Output = Self::VA> + AddAssign + From<Self::V> + Into<Self::V>;
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Converts (rounding) from `f64`.
    fn from_f64(x: f64) -> Self;
    /// Converts (exactly) to `f64`.
    fn to_f64(self) -> f64;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Larger of the two.
    fn max(self, o: Self) -> Self;
    /// Smaller of the two.
    fn min(self, o: Self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// Largest integer not above `self`.
    fn floor(self) -> Self;
    /// `self` where `keep`, else `+0`, formed by masking the bits: the same value as `if keep { self } else { 0 }`
    /// without a select, which LLVM's AVX2 code for the grid wind pass stored as masked stores (`vmaskmovps`,
    /// microcoded on AMD's cores).
    fn kept(self, keep: bool) -> Self;
    /// `x` if `c`, else `y`, formed by masking the bits (see [`Real::kept`]).
    fn pick(c: bool, x: Self, y: Self) -> Self;
    /// Unit in the last place of a positive finite `self`: the gap to the next larger number.
    fn ulp(self) -> Self;
    /// Positive infinity.
    fn infinity() -> Self;
    /// The components of `v`, `x y z x y z …` (a [`Real::V`] is three scalars in that order, `#[repr(C)]`).
    fn flat(v: &[Self::V]) -> &[Self];
    /// [`Real::flat`], mutable.
    fn flat_mut(v: &mut [Self::V]) -> &mut [Self];
}

/// A 3-vector over a [`Real`] scalar; implemented by [`Vec3`] and [`DVec3`].
pub trait Vector3<R>:
    Copy
    + Send
    + Sync
    + Debug
    + Default
    + PartialEq
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<R, Output = Self>
    + Div<R, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<R>
{
    /// (0, 0, 0).
    const ZERO: Self;
    /// Builds a vector.
    fn new(x: R, y: R, z: R) -> Self;
    /// Dot product.
    fn dot(self, o: Self) -> R;
    /// Cross product.
    fn cross(self, o: Self) -> Self;
    /// Euclidean length.
    fn length(self) -> R;
    /// Squared length.
    fn length_squared(self) -> R;
    /// Component-wise product.
    fn mul_elem(self, o: Self) -> Self;
    /// The components.
    fn to_array(self) -> [R; 3];
    /// Component-wise reciprocal.
    fn recip(self) -> Self;
    /// All components finite.
    fn is_finite(self) -> bool;
    /// From an `f64` vector (rounding).
    fn from_dvec3(v: DVec3) -> Self;
    /// To an `f64` vector (exact).
    fn to_dvec3(self) -> DVec3;
    /// To an `f32` vector (rounding), for parry3d queries and rendering.
    fn to_vec3(self) -> Vec3;
    /// From an `f32` vector (exact).
    fn from_vec3(v: Vec3) -> Self;
}

macro_rules! impl_real {
    ($t:ty, $v:ty, $va:ty, $bits:ty) => {
        impl Real for $t {
            type V = $v;
            type VA = $va;
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const EPSILON: Self = <$t>::EPSILON;
            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn kept(self, keep: bool) -> Self {
                <$t>::from_bits(self.to_bits() & (0 as $bits).wrapping_sub(keep as $bits))
            }
            #[inline(always)]
            fn pick(c: bool, x: Self, y: Self) -> Self {
                let m = (0 as $bits).wrapping_sub(c as $bits);
                <$t>::from_bits((x.to_bits() & m) | (y.to_bits() & !m))
            }
            #[inline(always)]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            fn ulp(self) -> Self {
                // Adjacent positive floats differ by one in their bit patterns; the difference is exact.
                <$t>::from_bits(self.to_bits() + 1) - self
            }
            fn infinity() -> Self {
                <$t>::INFINITY
            }
            #[inline(always)]
            fn flat(v: &[$v]) -> &[$t] {
                const { assert!(std::mem::size_of::<$v>() == 3 * std::mem::size_of::<$t>()) };
                // SAFETY: glam's vectors are `#[repr(C)]` structs of three scalars (size checked above): a slice of
                // n of them is 3n scalars, with the scalar's alignment.
                unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<$t>(), 3 * v.len()) }
            }
            #[inline(always)]
            fn flat_mut(v: &mut [$v]) -> &mut [$t] {
                const { assert!(std::mem::size_of::<$v>() == 3 * std::mem::size_of::<$t>()) };
                // SAFETY: as in `flat`; the borrow is the caller's unique one.
                unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<$t>(), 3 * v.len()) }
            }
        }

        impl Vector3<$t> for $v {
            const ZERO: Self = <$v>::ZERO;
            #[inline(always)]
            fn new(x: $t, y: $t, z: $t) -> Self {
                <$v>::new(x, y, z)
            }
            #[inline(always)]
            fn dot(self, o: Self) -> $t {
                <$v>::dot(self, o)
            }
            #[inline(always)]
            fn cross(self, o: Self) -> Self {
                <$v>::cross(self, o)
            }
            #[inline(always)]
            fn length(self) -> $t {
                <$v>::length(self)
            }
            #[inline(always)]
            fn length_squared(self) -> $t {
                <$v>::length_squared(self)
            }
            #[inline(always)]
            fn mul_elem(self, o: Self) -> Self {
                self * o
            }
            #[inline(always)]
            fn to_array(self) -> [$t; 3] {
                <$v>::to_array(&self)
            }
            #[inline(always)]
            fn recip(self) -> Self {
                <$v>::recip(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$v>::is_finite(self)
            }
            #[inline(always)]
            fn from_dvec3(v: DVec3) -> Self {
                <$v>::new(v.x as $t, v.y as $t, v.z as $t)
            }
            #[inline(always)]
            fn to_dvec3(self) -> DVec3 {
                DVec3::new(self.x as f64, self.y as f64, self.z as f64)
            }
            #[inline(always)]
            fn to_vec3(self) -> Vec3 {
                Vec3::new(self.x as f32, self.y as f32, self.z as f32)
            }
            #[inline(always)]
            fn from_vec3(v: Vec3) -> Self {
                <$v>::new(v.x as $t, v.y as $t, v.z as $t)
            }
        }
    };
}

impl_real!(f32, Vec3, Vec3A, u32);
impl_real!(f64, DVec3, DVec3, u64);

/// `x` as `f32` where `R` is `f32` (the caller checks; otherwise it panics).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn as_f32<R: Real>(x: &[R]) -> &[f32] {
    assert_eq!(std::any::TypeId::of::<R>(), std::any::TypeId::of::<f32>());
    // SAFETY: `R` is `f32` (asserted): the same type.
    unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<f32>(), x.len()) }
}

/// [`as_f32`], mutable.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn as_f32_mut<R: Real>(x: &mut [R]) -> &mut [f32] {
    assert_eq!(std::any::TypeId::of::<R>(), std::any::TypeId::of::<f32>());
    // SAFETY: `R` is `f32` (asserted): the same type.
    unsafe { std::slice::from_raw_parts_mut(x.as_mut_ptr().cast::<f32>(), x.len()) }
}

/// `x`'s padded vectors ([`Real::VA`]) as `f32` components, four a vector (glam's [`Vec3A`] layout), where `R` is
/// `f32` (the caller checks; otherwise it panics).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn va_as_f32<R: Real>(x: &[R::VA]) -> &[f32] {
    assert_eq!(std::any::TypeId::of::<R>(), std::any::TypeId::of::<f32>());
    const { assert!(std::mem::size_of::<Vec3A>() == 16) };
    // SAFETY: `R` is `f32` (asserted), so `R::VA` is `Vec3A`: 16 bytes of four `f32`s (size checked above).
    unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<f32>(), 4 * x.len()) }
}

/// `x`'s vectors ([`Real::V`]: glam's [`Vec3`], `#[repr(C)]`) as `f32` components, three a vector, where `R` is
/// `f32` (the caller checks; otherwise it panics).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn v_as_f32<R: Real>(x: &[R::V]) -> &[f32] {
    assert_eq!(std::any::TypeId::of::<R>(), std::any::TypeId::of::<f32>());
    const { assert!(std::mem::size_of::<Vec3>() == 12) };
    // SAFETY: `R` is `f32` (asserted), so `R::V` is `Vec3`: `#[repr(C)]`, three `f32`s (size checked above).
    unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<f32>(), 3 * x.len()) }
}

/// [`va_as_f32`], mutable.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn va_as_f32_mut<R: Real>(x: &mut [R::VA]) -> &mut [f32] {
    assert_eq!(std::any::TypeId::of::<R>(), std::any::TypeId::of::<f32>());
    const { assert!(std::mem::size_of::<Vec3A>() == 16) };
    // SAFETY: `R` is `f32` (asserted), so `R::VA` is `Vec3A`: 16 bytes of four `f32`s (size checked above).
    unsafe { std::slice::from_raw_parts_mut(x.as_mut_ptr().cast::<f32>(), 4 * x.len()) }
}
