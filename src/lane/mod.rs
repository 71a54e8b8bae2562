//! One kernel source for 1 and 8 lanes (issue 16, item 2).
//!
//! The hot-path maths is written once, generic over [`Lane`], and instantiated at two widths:
//! - `f32` (width 1, masks are `bool`): the scalar renderer's width, runs on any x86-64;
//! - [`F32x8`] (width 8, AVX2 `__m256`): reachable only through an [`Avx2`] token, which exists
//!   only when the CPU has AVX2 and FMA (runtime detection), so the binary still runs at width 1
//!   on a CPU without them.
//!
//! Bit-identity rule: every 8-wide function equals the 1-wide one bit for bit in every lane (NaN
//! compared as NaN: Rust does not specify NaN payloads). This holds because both widths use only
//! correctly rounded IEEE operations in the same order (`+ − × ÷ √`, no approximate reciprocal or
//! square root, FMA only through the explicit [`Lane::mul_add`], which both widths fuse), min/max
//! with x86 semantics (`if a < b { a } else { b }`), selects instead of branches, and no
//! horizontal operation feeding a lane's value. See `docs/design/lanes.md`.
//!
//! This module and `src/accel/embree.rs` are the only places with `unsafe` (here: `core::arch`
//! intrinsics, sound because an AVX2 value can only be built from an [`Avx2`] token or from
//! another AVX2 value).
//!
//! A third width, [`F32x16`] (AVX-512, behind an [`Avx512`] token), follows the same rule; the
//! stream renderer's shading kernels run at it where the CPU has AVX-512, through the
//! [`Wide`] token trait (see `docs/design/lanes.md`, "Width 16").
//!
//! Contents: the traits (this file), `scalar` (width 1), `avx2` (width 8), `avx512` (width 16,
//! experimental), [`math`] (polynomial
//! `sin cos acos atan2 exp log pow`), [`mod@vec`] (3- and 2-vectors), [`frame`], [`warp`],
//! [`microfacet`], [`fresnel`], [`mix`] (SplitMix64's finaliser per 64-bit lane), [`pcg`] (PCG32 per lane), [`batch`] (slice entry points), [`bits`] (masks'
//! bits as `[bool; W]`), [`wide`] (the tokens as one generic parameter over the width, for the
//! stream renderer).

use core::fmt::Debug;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
pub mod batch;
pub mod bits;
pub mod frame;
pub mod fresnel;
pub mod math;
pub mod microfacet;
pub mod mix;
pub mod pcg;
mod scalar;
pub mod vec;
pub mod warp;
pub mod wide;

#[cfg(target_arch = "x86_64")]
pub use avx2::{Avx2, F32x8, Hint, I128x4, I128x8, I32x8, U64x4, U64x8, Words8, M8, ROW_LANES};
#[cfg(target_arch = "x86_64")]
pub use avx512::{Avx512, F32x16, I32x16, U64x16, M16};
pub use wide::{ToArray, Wide};

/// A lane mask: per lane true or false (`bool` at width 1, all-ones/all-zeros lanes at width 8).
pub trait LaneMask:
    Copy
    + Debug
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
{
    /// Whether any lane is set. Horizontal: use it only for fast paths whose result equals the
    /// slow path's bit for bit.
    fn any(self) -> bool;
    /// Whether every lane is set (same caveat as [`LaneMask::any`]).
    fn all(self) -> bool;
}

/// A float lane type: `f32` or [`F32x8`]. Every method is per lane and correctly rounded.
pub trait Lane:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The mask type of comparisons.
    type Mask: LaneMask;
    /// 32-bit integer lanes of the same width (bit views, exponents, PCG outputs).
    type I32: LaneI32<F = Self, Mask = Self::Mask> + LaneLookup<Self>;
    /// 64-bit unsigned integer lanes of the same width (PCG state).
    type U64: LaneU64<I32 = Self::I32> + pcg::PcgOps<Self::I32>;
    /// Number of lanes.
    const WIDTH: usize;

    /// `c` in every lane, with the width of `self` (a constant is made from a value so that a
    /// width-8 value can only come from a width-8 value or an [`Avx2`] token).
    fn splat(self, c: f32) -> Self;
    /// Correctly rounded square root (`sqrtss`/`vsqrtps`; NaN below zero).
    fn sqrt(self) -> Self;
    /// Fused multiply-add `self · a + b`, rounded once. Only where written explicitly.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// x86 minimum: `if self < o { self } else { o }` (so NaN in `self` gives `o`).
    fn min(self, o: Self) -> Self;
    /// x86 maximum: `if self > o { self } else { o }` (so NaN in `self` gives `o`).
    fn max(self, o: Self) -> Self;
    fn eq(self, o: Self) -> Self::Mask;
    /// Unordered not-equal (true when either is NaN), as Rust's `!=`.
    fn ne(self, o: Self) -> Self::Mask;
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    /// Per lane `if m { a } else { b }`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// The IEEE bit pattern.
    fn to_bits(self) -> Self::I32;
    /// The float of an IEEE bit pattern.
    fn from_bits(b: Self::I32) -> Self;
    /// Round to the nearest integer, ties to even (the MXCSR default); `i32::MIN` when out of
    /// range or NaN (x86 `cvtps2dq` semantics).
    fn round_i32(self) -> Self::I32;
    /// Truncate toward zero; `i32::MIN` when out of range or NaN (x86 `cvttps2dq`).
    fn trunc_i32(self) -> Self::I32;
    /// Lane `i` as a scalar (tests, tails).
    fn lane(self, i: usize) -> f32;
    /// `table[idx]` per lane (a table lookup: `vgatherdps` at width 8), each index first
    /// clamped to `N − 1` as an unsigned number (so a negative index reads the last entry):
    /// always in bounds, the same entry at both widths. `N` must be in 1..=i32::MAX.
    fn gather<const N: usize>(table: &[f32; N], idx: Self::I32) -> Self;
    /// The components of `table[idx]` per lane (three `vgatherdps` at width 8; a bitmap
    /// texture's RGB texels), each index first clamped to `table.len() − 1` as an unsigned
    /// number: always in bounds, the same vector at both widths.
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX / 3` vectors.
    fn gather3(table: &[glam::Vec3], idx: Self::I32) -> [Self; 3];
    /// `table[idx]` per lane from a table of any length (`vgatherdps` at width 8; a mesh's
    /// triangle CDF), each index first clamped to `table.len() − 1` as an unsigned number.
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX` entries.
    fn gather_slice(table: &[f32], idx: Self::I32) -> Self;
    /// `f()` in a function of its own, compiled for this lane type's instructions and never
    /// inlined (give it an `#[inline(always)]` closure). For a large piece that a kernel would
    /// otherwise inline several times (a whole BSDF evaluation), so that the optimiser works on
    /// pieces of bounded size: LLVM's SROA pass grows faster than linearly with a function's
    /// size, and the blend kernel as one function took half of the library's build time.
    /// The numbers are the same as inlined.
    fn outlined<R>(self, f: impl FnOnce() -> R) -> R;

    /// |self| (clears the sign bit; NaN stays NaN).
    #[inline(always)]
    fn abs(self) -> Self {
        let b = self.to_bits();
        Self::from_bits(b.and(b.splat(0x7fff_ffff)))
    }
    /// The magnitude of `self` with the sign bit of `s`.
    #[inline(always)]
    fn copysign(self, s: Self) -> Self {
        let b = self.to_bits();
        let m = b.splat(i32::MIN);
        Self::from_bits(b.andnot(m).or(s.to_bits().and(m)))
    }
    /// `self` with its sign flipped where `s` has its sign bit set.
    #[inline(always)]
    fn mulsign(self, s: Self) -> Self {
        let sb = s.to_bits();
        Self::from_bits(self.to_bits().xor(sb.and(sb.splat(i32::MIN))))
    }
    /// The sign bit is set (also for −0 and negative NaN).
    #[inline(always)]
    fn sign_bit(self) -> Self::Mask {
        let b = self.to_bits();
        b.lt(b.splat(0))
    }
    #[inline(always)]
    fn is_nan(self) -> Self::Mask {
        self.ne(self)
    }
    /// Neither infinite nor NaN.
    #[inline(always)]
    fn is_finite(self) -> Self::Mask {
        self.abs().lt(self.splat(f32::INFINITY))
    }
}

/// 32-bit integer lanes (two's complement, wrapping). Shifts take their count as a constant.
pub trait LaneI32: Copy + Debug {
    type F: Lane<I32 = Self, Mask = Self::Mask>;
    type Mask: LaneMask;
    /// `c` in every lane, with the width of `self`.
    fn splat(self, c: i32) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn and(self, o: Self) -> Self;
    /// `self & !o`.
    fn andnot(self, o: Self) -> Self;
    fn or(self, o: Self) -> Self;
    fn xor(self, o: Self) -> Self;
    fn shl<const N: i32>(self) -> Self;
    /// Logical (unsigned) right shift.
    fn shr<const N: i32>(self) -> Self;
    /// Arithmetic (signed) right shift.
    fn sar<const N: i32>(self) -> Self;
    /// As unsigned, rotate right by `r & 31` lane by lane.
    fn rotate_right(self, r: Self) -> Self;
    fn eq(self, o: Self) -> Self::Mask;
    /// Signed greater-than.
    fn gt(self, o: Self) -> Self::Mask;
    /// Signed less-than.
    #[inline(always)]
    fn lt(self, o: Self) -> Self::Mask {
        o.gt(self)
    }
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `table[idx]` as a little-endian `i32` per lane (`vpgatherdd` at width 8; a bitmap
    /// texture's 8-bit RGB codes), each index clamped as in [`Lane::gather3`].
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX` entries.
    fn gather_bytes4(table: &[[u8; 4]], idx: Self) -> Self;
    /// `table[idx]` (its bits as an `i32`) per lane (`vpgatherdd` at width 8; a mesh's vertex
    /// indices), each index clamped as in [`Lane::gather3`].
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX` entries.
    fn gather_u32(table: &[u32], idx: Self) -> Self;
    /// Signed integer to float, correctly rounded (exact below 2²⁴ in magnitude).
    fn to_f32(self) -> Self::F;
    /// Lane `i` (tests).
    fn lane(self, i: usize) -> i32;
}

/// 64-bit unsigned integer lanes (wrapping), as much as PCG32 needs.
pub trait LaneU64: Copy + Debug {
    type I32: LaneI32;
    /// `c` in every lane, with the width of `self`.
    fn splat(self, c: u64) -> Self;
    fn add(self, o: Self) -> Self;
    /// Low 64 bits of the product.
    fn mul(self, o: Self) -> Self;
    fn xor(self, o: Self) -> Self;
    fn or(self, o: Self) -> Self;
    fn shl<const N: i32>(self) -> Self;
    fn shr<const N: i32>(self) -> Self;
    /// The low 32 bits of each lane.
    fn low_u32(self) -> Self::I32;
    /// Lane `i` (tests).
    fn lane(self, i: usize) -> u64;
}

/// Lookups in a table of 8 floats by a lane index (`vpermps`: one instruction per table where a
/// gather loads every lane), for the small tables of the light stage.
pub trait LaneLookup<F> {
    /// `table[min(idx as u32, 7)]` per lane (the index clamped as in [`Lane::gather`]).
    fn lookup8(table: &[f32; 8], idx: Self) -> F;
}
