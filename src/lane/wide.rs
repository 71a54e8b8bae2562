//! The SIMD tokens as one generic parameter: [`Wide<W>`] is implemented by [`Avx2`] (`W = 8`)
//! and [`Avx512`] (`W = 16`), so that the stream renderer's drivers are written once over the
//! chunk width `W` and instantiated at whichever width the CPU has (issue 18; see
//! `docs/design/lanes.md`, "Width 16").
//!
//! The width is a const generic, not an associated constant, because an array type `[f32; W]`
//! can only be named from a const parameter on stable Rust. Everything else — the lane types,
//! loads, stores, the `#[target_feature]` entry point — comes from the token.

#[cfg(target_arch = "x86_64")]
use super::{Avx2, Avx512, F32x16, F32x8, I32x16, I32x8, U64x16, U64x8, M16, M8};
use super::{Lane, LaneI32, LaneMask, LaneU64};

/// A lane value's lanes as an array of `W` elements (a store).
pub trait ToArray<E, const W: usize>: Copy {
    fn to_array(self) -> [E; W];
}

/// A token proving the CPU runs `W`-wide lanes, with their types, loads and entry point.
pub trait Wide<const W: usize>: Copy + core::fmt::Debug {
    /// `W` float lanes.
    type F: Lane<Mask = Self::M, I32 = Self::I, U64 = Self::U> + ToArray<f32, W>;
    /// `W` lane masks.
    type M: LaneMask + ToArray<bool, W>;
    /// `W` 32-bit integer lanes.
    type I: LaneI32<F = Self::F, Mask = Self::M> + ToArray<i32, W>;
    /// `W` 64-bit integer lanes.
    type U: LaneU64<I32 = Self::I> + ToArray<u64, W>;

    /// Run `f` inside a function compiled for this width's target features (put whole loops
    /// inside; closures passed here should be `#[inline(always)]`).
    fn run<R>(self, f: impl FnOnce() -> R) -> R;
    fn splat(self, c: f32) -> Self::F;
    fn load(self, a: &[f32; W]) -> Self::F;
    fn load_i32(self, a: &[i32; W]) -> Self::I;
    fn load_u64(self, a: &[u64; W]) -> Self::U;
    /// A mask from `W` booleans.
    fn mask(self, a: &[bool; W]) -> Self::M;
    /// A mask from the low `W` bits of `bits` (lane `k` set when bit `k` is; higher bits
    /// ignored): flags kept as bits become masks without `[bool; W]` stores and loads.
    fn mask_bits(self, bits: u32) -> Self::M;
    /// The lanes of `m` as the low `W` bits of a number (bit `k` for lane `k`; the inverse of
    /// [`Wide::mask_bits`]).
    fn bits(m: Self::M) -> u32;
    /// Per lane `k`, from the last lane to the first, `table[idx[k]] = new[k]` where `on`,
    /// else `old[k]` (where an index repeats, the lowest lane's value is left): a write-back of
    /// values gathered from `table` and updated where `on`, without a branch or a bounds test
    /// per lane (`Avx2::store_u64_at`, `Avx512::store_u64_at`).
    ///
    /// # Panics
    /// If an index (as `u32`) is not below `table.len()`, before any store.
    fn store_u64_at(self, table: &mut [u64], idx: Self::I, on: Self::M, new: Self::U, old: Self::U);
}

#[cfg(target_arch = "x86_64")]
macro_rules! to_array {
    ($w:literal: $($t:ty => $e:ty),*) => {$(
        impl ToArray<$e, $w> for $t {
            #[inline(always)]
            fn to_array(self) -> [$e; $w] {
                <$t>::to_array(self)
            }
        }
    )*};
}

#[cfg(target_arch = "x86_64")]
to_array!(8: F32x8 => f32, M8 => bool, I32x8 => i32, U64x8 => u64);
#[cfg(target_arch = "x86_64")]
to_array!(16: F32x16 => f32, M16 => bool, I32x16 => i32, U64x16 => u64);

#[cfg(target_arch = "x86_64")]
macro_rules! wide {
    ($tok:ty, $w:literal, $f:ty, $m:ty, $i:ty, $u:ty) => {
        impl Wide<$w> for $tok {
            type F = $f;
            type M = $m;
            type I = $i;
            type U = $u;
            #[inline(always)]
            fn run<R>(self, f: impl FnOnce() -> R) -> R {
                <$tok>::run(self, f)
            }
            #[inline(always)]
            fn splat(self, c: f32) -> $f {
                <$tok>::splat(self, c)
            }
            #[inline(always)]
            fn load(self, a: &[f32; $w]) -> $f {
                <$tok>::load(self, a)
            }
            #[inline(always)]
            fn load_i32(self, a: &[i32; $w]) -> $i {
                <$tok>::load_i32(self, a)
            }
            #[inline(always)]
            fn load_u64(self, a: &[u64; $w]) -> $u {
                <$tok>::load_u64(self, a)
            }
            #[inline(always)]
            fn mask(self, a: &[bool; $w]) -> $m {
                <$tok>::mask(self, a)
            }
            #[inline(always)]
            fn mask_bits(self, bits: u32) -> $m {
                <$tok>::mask_bits(self, bits)
            }
            #[inline(always)]
            fn bits(m: $m) -> u32 {
                m.bits()
            }
            #[inline(always)]
            fn store_u64_at(self, table: &mut [u64], idx: $i, on: $m, new: $u, old: $u) {
                <$tok>::store_u64_at(self, table, idx, on, new, old)
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
wide!(Avx2, 8, F32x8, M8, I32x8, U64x8);
#[cfg(target_arch = "x86_64")]
wide!(Avx512, 16, F32x16, M16, I32x16, U64x16);

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::lane::{Lane, LaneMask};

    /// Loads, a lane operation and stores through the trait at width `W` equal width 1.
    fn round_trip<T: Wide<W>, const W: usize>(t: T) {
        t.run(|| {
            let a: [f32; W] = core::array::from_fn(|k| k as f32 * 0.37 - 2.0);
            let m: [bool; W] = core::array::from_fn(|k| k % 3 == 1);
            let x = t.load(&a);
            let y = T::F::select(t.mask(&m), x.sqrt(), x * t.splat(3.0));
            let want: [f32; W] =
                core::array::from_fn(|k| if m[k] { a[k].sqrt() } else { a[k] * 3.0 });
            let got = y.to_array();
            for k in 0..W {
                assert_eq!(got[k].to_bits(), want[k].to_bits(), "lane {k} of {W}");
            }
            assert_eq!(t.mask(&m).to_array(), m);
            assert_eq!(t.mask(&m).any(), m.iter().any(|&b| b));
            let i: [i32; W] = core::array::from_fn(|k| k as i32 * 7 - 3);
            assert_eq!(t.load_i32(&i).to_array(), i);
            let u: [u64; W] = core::array::from_fn(|k| (k as u64) << 40 | 5);
            assert_eq!(t.load_u64(&u).to_array(), u);
        });
    }

    #[test]
    fn both_tokens_load_and_store_their_width() {
        match Avx2::detect() {
            Some(t) => round_trip(t),
            None => eprintln!("note: no AVX2, width 8 not checked"),
        }
        match Avx512::detect() {
            Some(t) => round_trip(t),
            None => eprintln!("note: no AVX-512, width 16 not checked"),
        }
    }
}
