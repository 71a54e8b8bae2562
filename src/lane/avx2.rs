//! Width 8: thin wrappers over `core::arch::x86_64` AVX2 (`__m256`, `__m256i`).
//!
//! Soundness: executing an AVX2 instruction on a CPU without AVX2 is undefined behaviour, so a
//! value of these types can only be built from an [`Avx2`] token (which [`Avx2::detect`] returns
//! only when the CPU has AVX2 and FMA) or computed from another such value; their fields are
//! private. Every operation is `#[inline(always)]`: inside [`Avx2::run`] (a
//! `#[target_feature(enable = "avx2,fma")]` entry point) it compiles to one instruction or a
//! short sequence; elsewhere it is still correct, only slower (an out-of-line intrinsic call).
//!
//! The semantics match `scalar.rs` lane by lane: ordered comparisons (`!=` unordered), minps/
//! maxps (second operand on NaN or equal), `cvtps2dq`/`cvttps2dq` (`i32::MIN` when out of range).

use super::{Lane, LaneI32, LaneMask, LaneU64};
use core::arch::x86_64::*;
use core::fmt;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

#[path = "avx2_i128.rs"]
mod i128_sums;
pub use i128_sums::{I128x4, I128x8, Words8, ROW_LANES};
#[path = "avx2_prefetch.rs"]
mod prefetch;
pub use prefetch::Hint;

/// Proof that the CPU has AVX2 and FMA: the only way to make 8-wide values.
#[derive(Clone, Copy, Debug)]
pub struct Avx2(());

/// Eight `f32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x8(__m256);

/// Eight lane masks (each lane all ones or all zeros).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M8(__m256);

/// Eight `i32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x8(__m256i);

/// Eight `u64` lanes: lanes 0–3 in the first register, 4–7 in the second.
#[derive(Clone, Copy)]
pub struct U64x8([__m256i; 2]);

impl Avx2 {
    /// The token, when this CPU has AVX2 and FMA.
    pub fn detect() -> Option<Avx2> {
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            Some(Avx2(()))
        } else {
            None
        }
    }

    /// Run `f` inside a function compiled for AVX2 and FMA, so that the 8-wide operations
    /// inlined into it become single instructions. Put whole loops inside.
    #[inline(always)]
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        // SAFETY: the token exists only when the CPU has AVX2 and FMA.
        unsafe { run_avx2(f) }
    }

    #[inline(always)]
    pub fn splat(self, c: f32) -> F32x8 {
        // SAFETY: the token proves AVX (here and below).
        F32x8(unsafe { _mm256_set1_ps(c) })
    }
    #[inline(always)]
    pub fn load(self, a: &[f32; 8]) -> F32x8 {
        F32x8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    pub fn load_i32(self, a: &[i32; 8]) -> I32x8 {
        I32x8(unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
    }
    /// Eight `u32`s (path ids, indices) as `i32` lanes, bit for bit what `x as i32` gives for
    /// each (one load, not eight conversions through the stack).
    #[inline(always)]
    pub fn load_u32(self, a: &[u32; 8]) -> I32x8 {
        // SAFETY: the token proves AVX; `a` is 32 bytes of initialised `u32`s.
        I32x8(unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
    }
    #[inline(always)]
    pub fn load_u64(self, a: &[u64; 8]) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_loadu_si256(a.as_ptr().cast()),
                _mm256_loadu_si256(a[4..].as_ptr().cast()),
            ])
        }
    }
    /// `b` in every lane of a mask (a chunk-wide flag).
    #[inline(always)]
    pub fn mask_splat(self, b: bool) -> M8 {
        M8(unsafe { _mm256_castsi256_ps(_mm256_set1_epi32(-(b as i32))) })
    }
    /// The three indices of `table[idx]` per lane (three `vpgatherdd`; a mesh's triangles),
    /// each index first clamped to `table.len() − 1` as an unsigned number (as
    /// [`crate::lane::Lane::gather3`]): always in bounds.
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX / 3` rows.
    #[inline(always)]
    pub fn gather3_u32(self, table: &[[u32; 3]], idx: I32x8) -> [I32x8; 3] {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize / 3);
        // SAFETY: the token proves AVX2. `[u32; 3]` is three consecutive u32s (12 bytes), so
        // row r's entry c is u32 3r + c from the start; after the clamp r < len and
        // 3r + 2 < 3·len ≤ i32::MAX, so each load reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            let i3 = _mm256_add_epi32(_mm256_add_epi32(i, i), i);
            let base = table.as_ptr().cast::<i32>();
            [
                I32x8(_mm256_i32gather_epi32::<4>(base, i3)),
                I32x8(_mm256_i32gather_epi32::<4>(base.add(1), i3)),
                I32x8(_mm256_i32gather_epi32::<4>(base.add(2), i3)),
            ]
        }
    }
    /// The components of `table[idx]` per lane (two `vgatherdps`; a mesh's uvs), each index
    /// clamped as in [`Avx2::gather3_u32`].
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX / 2` vectors.
    #[inline(always)]
    pub fn gather2(self, table: &[glam::Vec2], idx: I32x8) -> [F32x8; 2] {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize / 2);
        // SAFETY: the token proves AVX2. `glam::Vec2` is `#[repr(C)]` with two f32 fields x, y
        // (8 bytes, asserted below), so vector r's component c is float 2r + c; after the clamp
        // r < len and 2r + 1 < 2·len ≤ i32::MAX, so each load reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            let i2 = _mm256_add_epi32(i, i);
            let base = table.as_ptr().cast::<f32>();
            [
                F32x8(_mm256_i32gather_ps::<4>(base, i2)),
                F32x8(_mm256_i32gather_ps::<4>(base.add(1), i2)),
            ]
        }
    }
    /// The rays `rays[ids[k]]` in lanes, field by field: o.x, o.y, o.z, d.x, d.y, d.z, tmin,
    /// tmax (one row per ray, [`Self::ray_row`], then [`F32x8::transpose8`]; the gather
    /// stage's rays).
    ///
    /// # Panics
    /// If an id is out of range (before any row is read).
    #[inline(always)]
    pub fn ray_fields(self, rays: &[crate::geometry::Ray], ids: &[u32; 8]) -> [F32x8; 8] {
        // One bounds check for the 8 ids ([`Self::ids_below`]), not one per row.
        assert!(
            self.ids_below(ids, rays.len()),
            "a ray's id past its column"
        );
        // Row by row, not `ids.map(…)`: LLVM left that closure out of line (`array::try_map`,
        // without the target features) once the gather stage had more call sites (the
        // forty-second session's pipeline).
        let mut rows = [self.splat(0.0); 8];
        for (r, &i) in rows.iter_mut().zip(ids) {
            // SAFETY: every id is below `rays.len()` (the assertion).
            *r = self.ray_row(unsafe { rays.get_unchecked(i as usize) });
        }
        F32x8::transpose8(rows)
    }
    /// A mask from eight booleans: one 8-byte load, widened to 32-bit lanes (`vpmovzxbd`) and
    /// negated (0 or 1 to 0 or −1), not eight booleans widened, negated and stored one by one
    /// (~20 instructions where the kernels hand `Gather::add_x8` or the draws their lanes).
    #[inline(always)]
    pub fn mask(self, a: &[bool; 8]) -> M8 {
        // SAFETY: the token proves AVX2; the load reads the 8 bytes of `a` (unaligned loads
        // are allowed), each 0 or 1 (a `bool`), so lane k is −1 exactly where `a[k]`.
        M8(unsafe {
            let b = _mm256_cvtepu8_epi32(_mm_loadl_epi64(a.as_ptr().cast()));
            _mm256_castsi256_ps(_mm256_sub_epi32(_mm256_setzero_si256(), b))
        })
    }
    /// A mask from the low eight bits of `bits` (lane `k` set when bit `k` is; the inverse of
    /// [`M8::bits`]): a broadcast, an and and a compare, no per-lane stores.
    #[inline(always)]
    pub fn mask_bits(self, bits: u32) -> M8 {
        // SAFETY: the token proves AVX2.
        unsafe {
            let lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let b = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bit);
            M8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(b, lane_bit)))
        }
    }
}

#[target_feature(enable = "avx2,fma")]
fn run_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`Lane::outlined`] at width 8: as [`run_avx2`], never inlined.
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
fn outlined_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

impl F32x8 {
    #[inline(always)]
    pub fn to_array(self) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        // SAFETY: an F32x8 exists only with AVX (module doc); `a` holds 8 floats.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    pub fn store(self, out: &mut [f32; 8]) {
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
    }
    /// [`Self::store`] of the lanes' bits as words (rows whose words are not all floats: the
    /// accelerators' hit rows), one store.
    #[inline(always)]
    pub fn store_bits(self, out: &mut [u32; 8]) {
        // SAFETY: an F32x8 exists only with AVX (module doc); `out` holds 8 four-byte words.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr().cast(), self.0) };
    }

    /// The 8×8 transpose: lane `k` of output `j` is lane `j` of input `k` (moves only, no
    /// arithmetic; 24 shuffles). Turns 8 fields of 8 lanes into 8 lanes' rows of 8 fields, for
    /// row stores (`stream::kernels::surface`).
    #[inline(always)]
    pub fn transpose8(v: [F32x8; 8]) -> [F32x8; 8] {
        // SAFETY: the inputs prove AVX (module doc).
        unsafe {
            let t0 = _mm256_unpacklo_ps(v[0].0, v[1].0);
            let t1 = _mm256_unpackhi_ps(v[0].0, v[1].0);
            let t2 = _mm256_unpacklo_ps(v[2].0, v[3].0);
            let t3 = _mm256_unpackhi_ps(v[2].0, v[3].0);
            let t4 = _mm256_unpacklo_ps(v[4].0, v[5].0);
            let t5 = _mm256_unpackhi_ps(v[4].0, v[5].0);
            let t6 = _mm256_unpacklo_ps(v[6].0, v[7].0);
            let t7 = _mm256_unpackhi_ps(v[6].0, v[7].0);
            let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
            let u1 = _mm256_shuffle_ps::<0xee>(t0, t2);
            let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
            let u3 = _mm256_shuffle_ps::<0xee>(t1, t3);
            let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
            let u5 = _mm256_shuffle_ps::<0xee>(t4, t6);
            let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
            let u7 = _mm256_shuffle_ps::<0xee>(t5, t7);
            [
                F32x8(_mm256_permute2f128_ps::<0x20>(u0, u4)),
                F32x8(_mm256_permute2f128_ps::<0x20>(u1, u5)),
                F32x8(_mm256_permute2f128_ps::<0x20>(u2, u6)),
                F32x8(_mm256_permute2f128_ps::<0x20>(u3, u7)),
                F32x8(_mm256_permute2f128_ps::<0x31>(u0, u4)),
                F32x8(_mm256_permute2f128_ps::<0x31>(u1, u5)),
                F32x8(_mm256_permute2f128_ps::<0x31>(u2, u6)),
                F32x8(_mm256_permute2f128_ps::<0x31>(u3, u7)),
            ]
        }
    }
}

impl I32x8 {
    #[inline(always)]
    pub fn to_array(self) -> [i32; 8] {
        let mut a = [0i32; 8];
        unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), self.0) };
        a
    }
}

impl U64x8 {
    /// The eight `i32` lanes of `x` sign-extended to 64 bits (`vpmovsxdq`).
    #[inline(always)]
    pub fn from_i32(x: I32x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_cvtepi32_epi64(_mm256_castsi256_si128(x.0)),
                _mm256_cvtepi32_epi64(_mm256_extracti128_si256::<1>(x.0)),
            ])
        }
    }
    /// Per lane `self << n` (`vpsllvq`): 0 where `n` ≥ 64 as an unsigned number.
    #[inline(always)]
    pub fn shl_var(self, n: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_sllv_epi64(self.0[0], n.0[0]),
                _mm256_sllv_epi64(self.0[1], n.0[1]),
            ])
        }
    }
    /// Per lane logical `self >> n` (`vpsrlvq`): 0 where `n` ≥ 64 as an unsigned number.
    #[inline(always)]
    pub fn shr_var(self, n: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_srlv_epi64(self.0[0], n.0[0]),
                _mm256_srlv_epi64(self.0[1], n.0[1]),
            ])
        }
    }
    #[inline(always)]
    pub fn and(self, o: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_and_si256(self.0[0], o.0[0]),
                _mm256_and_si256(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    pub fn to_array(self) -> [u64; 8] {
        let mut a = [0u64; 8];
        unsafe {
            _mm256_storeu_si256(a.as_mut_ptr().cast(), self.0[0]);
            _mm256_storeu_si256(a[4..].as_mut_ptr().cast(), self.0[1]);
        }
        a
    }
}

impl M8 {
    #[inline(always)]
    pub fn to_array(self) -> [bool; 8] {
        let m = unsafe { _mm256_movemask_ps(self.0) };
        super::bits::bools8(m as u32)
    }
    /// The mask as 8 bits (movemask): bit `k` for lane `k`.
    #[inline(always)]
    pub fn bits(self) -> u32 {
        // SAFETY: an M8 exists only with AVX (module doc).
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
}

impl fmt::Debug for F32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x8{:?}", self.to_array())
    }
}
impl fmt::Debug for I32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x8{:?}", self.to_array())
    }
}
impl fmt::Debug for U64x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "U64x8{:?}", self.to_array())
    }
}
impl fmt::Debug for M8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M8{:?}", self.to_array())
    }
}

macro_rules! binop {
    ($t:ty, $tr:ident, $f:ident, $intr:ident) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, o: $t) -> $t {
                // SAFETY: a value of this type exists only with AVX (module doc).
                Self(unsafe { $intr(self.0, o.0) })
            }
        }
    };
}
binop!(F32x8, Add, add, _mm256_add_ps);
binop!(F32x8, Sub, sub, _mm256_sub_ps);
binop!(F32x8, Mul, mul, _mm256_mul_ps);
binop!(F32x8, Div, div, _mm256_div_ps);
binop!(M8, BitAnd, bitand, _mm256_and_ps);
binop!(M8, BitOr, bitor, _mm256_or_ps);
binop!(M8, BitXor, bitxor, _mm256_xor_ps);

impl Neg for F32x8 {
    type Output = F32x8;
    #[inline(always)]
    fn neg(self) -> F32x8 {
        F32x8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        M8(unsafe { _mm256_xor_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) })
    }
}

impl LaneMask for M8 {
    #[inline(always)]
    fn any(self) -> bool {
        unsafe { _mm256_movemask_ps(self.0) != 0 }
    }
    #[inline(always)]
    fn all(self) -> bool {
        unsafe { _mm256_movemask_ps(self.0) == 0xff }
    }
}

macro_rules! cmp {
    ($f:ident, $imm:ident) => {
        #[inline(always)]
        fn $f(self, o: F32x8) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<$imm>(self.0, o.0) })
        }
    };
}

impl Lane for F32x8 {
    type Mask = M8;
    type I32 = I32x8;
    type U64 = U64x8;
    const WIDTH: usize = 8;

    #[inline(always)]
    fn outlined<R>(self, f: impl FnOnce() -> R) -> R {
        // SAFETY: an F32x8 exists only where AVX2 and FMA are on (module doc).
        unsafe { outlined_avx2(f) }
    }

    #[inline(always)]
    fn splat(self, c: f32) -> F32x8 {
        F32x8(unsafe { _mm256_set1_ps(c) })
    }
    #[inline(always)]
    fn sqrt(self) -> F32x8 {
        F32x8(unsafe { _mm256_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn mul_add(self, a: F32x8, b: F32x8) -> F32x8 {
        // SAFETY: the token also proves FMA.
        F32x8(unsafe { _mm256_fmadd_ps(self.0, a.0, b.0) })
    }
    #[inline(always)]
    fn min(self, o: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_max_ps(self.0, o.0) })
    }
    cmp!(eq, _CMP_EQ_OQ);
    cmp!(ne, _CMP_NEQ_UQ);
    cmp!(lt, _CMP_LT_OQ);
    cmp!(le, _CMP_LE_OQ);
    cmp!(gt, _CMP_GT_OQ);
    cmp!(ge, _CMP_GE_OQ);
    #[inline(always)]
    fn select(m: M8, a: F32x8, b: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
    }
    #[inline(always)]
    fn to_bits(self) -> I32x8 {
        I32x8(unsafe { _mm256_castps_si256(self.0) })
    }
    #[inline(always)]
    fn from_bits(b: I32x8) -> F32x8 {
        F32x8(unsafe { _mm256_castsi256_ps(b.0) })
    }
    #[inline(always)]
    fn round_i32(self) -> I32x8 {
        I32x8(unsafe { _mm256_cvtps_epi32(self.0) })
    }
    #[inline(always)]
    fn trunc_i32(self) -> I32x8 {
        I32x8(unsafe { _mm256_cvttps_epi32(self.0) })
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[f32; N], idx: I32x8) -> F32x8 {
        const { assert!(N >= 1 && N <= i32::MAX as usize) };
        // SAFETY: an I32x8 exists only with AVX2; after the unsigned clamp every index is
        // below N, so each of the 8 loads reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(N as i32 - 1));
            F32x8(_mm256_i32gather_ps::<4>(table.as_ptr(), i))
        }
    }
    #[inline(always)]
    fn gather_slice(table: &[f32], idx: I32x8) -> F32x8 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x8 exists only with AVX2; after the unsigned clamp every index is
        // below len, so each of the 8 loads reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            F32x8(_mm256_i32gather_ps::<4>(table.as_ptr(), i))
        }
    }
    #[inline(always)]
    fn gather3(table: &[glam::Vec3], idx: I32x8) -> [F32x8; 3] {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize / 3);
        // SAFETY: an I32x8 exists only with AVX2. `glam::Vec3` is `#[repr(C)]` with three f32
        // fields x, y, z (12 bytes, no padding), so vector r's component c is float 3r + c from
        // the start; after the unsigned clamp r < len and 3r + 2 < 3·len ≤ i32::MAX, so each
        // load reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            let i3 = _mm256_add_epi32(_mm256_add_epi32(i, i), i);
            let base = table.as_ptr().cast::<f32>();
            [
                F32x8(_mm256_i32gather_ps::<4>(base, i3)),
                F32x8(_mm256_i32gather_ps::<4>(base.add(1), i3)),
                F32x8(_mm256_i32gather_ps::<4>(base.add(2), i3)),
            ]
        }
    }
}

// `Avx2::gather2` reads a `glam::Vec2` as two consecutive f32s, `gather3_u32` a `[u32; 3]` as
// three consecutive u32s.
const _: () = assert!(
    core::mem::size_of::<glam::Vec2>() == 8
        && core::mem::align_of::<glam::Vec2>() == 4
        && core::mem::size_of::<[u32; 3]>() == 12
);

// `Avx2::ray_fields` and `Avx2::ray_row` read a `Ray` as eight consecutive f32s in this order.
const _: () = {
    use crate::geometry::Ray;
    use core::mem::{offset_of, size_of};
    assert!(
        size_of::<Ray>() == 32
            && offset_of!(Ray, o) == 0
            && offset_of!(Ray, d) == 12
            && offset_of!(Ray, tmin) == 24
            && offset_of!(Ray, tmax) == 28
    );
};

// `Lane::gather3` reads a `glam::Vec3` as three consecutive f32s.
const _: () =
    assert!(core::mem::size_of::<glam::Vec3>() == 12 && core::mem::align_of::<glam::Vec3>() == 4);

impl LaneI32 for I32x8 {
    type F = F32x8;
    type Mask = M8;
    #[inline(always)]
    fn gather_u32(table: &[u32], idx: I32x8) -> I32x8 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x8 exists only with AVX2; after the unsigned clamp every index is
        // below len, so each 4-byte load reads one entry of `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            I32x8(_mm256_i32gather_epi32::<4>(table.as_ptr().cast::<i32>(), i))
        }
    }
    #[inline(always)]
    fn gather_bytes4(table: &[[u8; 4]], idx: I32x8) -> I32x8 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x8 exists only with AVX2; after the unsigned clamp every index is below
        // len, so each 4-byte load reads one entry of `table` (gathers need no alignment; x86
        // loads are little-endian, as the width-1 `from_le_bytes`).
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            I32x8(_mm256_i32gather_epi32::<4>(table.as_ptr().cast::<i32>(), i))
        }
    }
    #[inline(always)]
    fn splat(self, c: i32) -> I32x8 {
        I32x8(unsafe { _mm256_set1_epi32(c) })
    }
    #[inline(always)]
    fn add(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_add_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn sub(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_sub_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn and(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_and_si256(self.0, o.0) })
    }
    #[inline(always)]
    fn andnot(self, o: I32x8) -> I32x8 {
        // vpandn computes !first & second.
        I32x8(unsafe { _mm256_andnot_si256(o.0, self.0) })
    }
    #[inline(always)]
    fn or(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_or_si256(self.0, o.0) })
    }
    #[inline(always)]
    fn xor(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_xor_si256(self.0, o.0) })
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> I32x8 {
        I32x8(unsafe { _mm256_slli_epi32::<N>(self.0) })
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> I32x8 {
        I32x8(unsafe { _mm256_srli_epi32::<N>(self.0) })
    }
    #[inline(always)]
    fn sar<const N: i32>(self) -> I32x8 {
        I32x8(unsafe { _mm256_srai_epi32::<N>(self.0) })
    }
    #[inline(always)]
    fn rotate_right(self, r: I32x8) -> I32x8 {
        unsafe {
            let r = _mm256_and_si256(r.0, _mm256_set1_epi32(31));
            let l = _mm256_sub_epi32(_mm256_set1_epi32(32), r);
            // vpsllvd gives 0 for a count of 32 (r = 0), as the rotation needs.
            I32x8(_mm256_or_si256(
                _mm256_srlv_epi32(self.0, r),
                _mm256_sllv_epi32(self.0, l),
            ))
        }
    }
    #[inline(always)]
    fn eq(self, o: I32x8) -> M8 {
        M8(unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, o.0)) })
    }
    #[inline(always)]
    fn gt(self, o: I32x8) -> M8 {
        M8(unsafe { _mm256_castsi256_ps(_mm256_cmpgt_epi32(self.0, o.0)) })
    }
    #[inline(always)]
    fn select(m: M8, a: I32x8, b: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_blendv_epi8(b.0, a.0, _mm256_castps_si256(m.0)) })
    }
    #[inline(always)]
    fn to_f32(self) -> F32x8 {
        F32x8(unsafe { _mm256_cvtepi32_ps(self.0) })
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.to_array()[i]
    }
}

impl LaneU64 for U64x8 {
    type I32 = I32x8;
    #[inline(always)]
    fn splat(self, c: u64) -> U64x8 {
        let v = unsafe { _mm256_set1_epi64x(c as i64) };
        U64x8([v, v])
    }
    #[inline(always)]
    fn add(self, o: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_add_epi64(self.0[0], o.0[0]),
                _mm256_add_epi64(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn mul(self, o: U64x8) -> U64x8 {
        U64x8([mul64(self.0[0], o.0[0]), mul64(self.0[1], o.0[1])])
    }
    #[inline(always)]
    fn xor(self, o: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_xor_si256(self.0[0], o.0[0]),
                _mm256_xor_si256(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn or(self, o: U64x8) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_or_si256(self.0[0], o.0[0]),
                _mm256_or_si256(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_slli_epi64::<N>(self.0[0]),
                _mm256_slli_epi64::<N>(self.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> U64x8 {
        unsafe {
            U64x8([
                _mm256_srli_epi64::<N>(self.0[0]),
                _mm256_srli_epi64::<N>(self.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn low_u32(self) -> I32x8 {
        unsafe {
            // Gather the even 32-bit words of each register into its low half, then join.
            let idx = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
            let a = _mm256_permutevar8x32_epi32(self.0[0], idx);
            let b = _mm256_permutevar8x32_epi32(self.0[1], idx);
            I32x8(_mm256_permute2x128_si256::<0x20>(a, b))
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> u64 {
        self.to_array()[i]
    }
}

/// Four `u64` lanes in one register: the stream keys of a chunk's pixels when its eight paths
/// are two or four samples of each of four or two pixels (the stream renderer's batch fill at 2
/// or 4 samples a pixel, `sampler::for_whole_pixels_x8`): `sampler::stream_key` on the four
/// pixels costs half the 64-bit multiplies of the eight lanes of a [`U64x8`], and
/// [`U64x4::spread`] copies each pixel's key to its paths' lanes.
#[derive(Clone, Copy)]
pub struct U64x4(__m256i);

impl fmt::Debug for U64x4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "U64x4{:?}", self.to_array())
    }
}

impl U64x4 {
    /// The four values of `a`.
    #[inline(always)]
    pub fn load(_avx: Avx2, a: &[u64; 4]) -> U64x4 {
        // SAFETY: the token proves AVX; one 32-byte load of `a`'s 32 bytes.
        U64x4(unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
    }
    /// The four lanes.
    #[inline(always)]
    pub fn to_array(self) -> [u64; 4] {
        let mut a = [0u64; 4];
        // SAFETY: a U64x4 exists only with AVX2; one 32-byte store into `a`.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), self.0) };
        a
    }
    /// Eight lanes from these four: lane j of the result is lane `words[j / 4][2 (j mod 4)] / 2`
    /// of `self`, where `words` holds each result register's 32-bit word indices (`vpermd`
    /// twice; lane i's words are 2i and 2i + 1, so `words[h]` is
    /// `[2i₀, 2i₀ + 1, 2i₁, 2i₁ + 1, …]` for the lanes i₀ to i₃ of result lanes 4h to 4h + 3).
    #[inline(always)]
    pub fn spread(self, avx: Avx2, words: &[[i32; 8]; 2]) -> U64x8 {
        let (a, b) = (avx.load_i32(&words[0]), avx.load_i32(&words[1]));
        // SAFETY: a U64x4 exists only with AVX2.
        unsafe {
            U64x8([
                _mm256_permutevar8x32_epi32(self.0, a.0),
                _mm256_permutevar8x32_epi32(self.0, b.0),
            ])
        }
    }
}

impl LaneU64 for U64x4 {
    /// Eight `i32` lanes: [`LaneU64::low_u32`] gives the four low words in lanes 0–3 and again
    /// in lanes 4–7 (the trait's PCG32 output is not drawn at this width; only `mix64` and the
    /// stream keys run on it).
    type I32 = I32x8;
    #[inline(always)]
    fn splat(self, c: u64) -> U64x4 {
        U64x4(unsafe { _mm256_set1_epi64x(c as i64) })
    }
    #[inline(always)]
    fn add(self, o: U64x4) -> U64x4 {
        U64x4(unsafe { _mm256_add_epi64(self.0, o.0) })
    }
    #[inline(always)]
    fn mul(self, o: U64x4) -> U64x4 {
        U64x4(mul64(self.0, o.0))
    }
    #[inline(always)]
    fn xor(self, o: U64x4) -> U64x4 {
        U64x4(unsafe { _mm256_xor_si256(self.0, o.0) })
    }
    #[inline(always)]
    fn or(self, o: U64x4) -> U64x4 {
        U64x4(unsafe { _mm256_or_si256(self.0, o.0) })
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> U64x4 {
        U64x4(unsafe { _mm256_slli_epi64::<N>(self.0) })
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> U64x4 {
        U64x4(unsafe { _mm256_srli_epi64::<N>(self.0) })
    }
    #[inline(always)]
    fn low_u32(self) -> I32x8 {
        unsafe {
            let idx = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
            I32x8(_mm256_permutevar8x32_epi32(self.0, idx))
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> u64 {
        self.to_array()[i]
    }
}

impl U64x8 {
    /// The eight `u32` lanes of `x`, zero-extended (`vpmovzxdq` of each half).
    #[inline(always)]
    pub fn from_u32(x: I32x8) -> U64x8 {
        // SAFETY: an I32x8 exists only with AVX2.
        unsafe {
            U64x8([
                _mm256_cvtepu32_epi64(_mm256_castsi256_si128(x.0)),
                _mm256_cvtepu32_epi64(_mm256_extracti128_si256::<1>(x.0)),
            ])
        }
    }
}

/// Low 64 bits of a 64×64 product per lane from 32×32→64 multiplies (AVX2 has no 64-bit
/// `mullo`): a·b mod 2⁶⁴ = lo·lo + ((hi_a·lo_b + lo_a·hi_b) << 32).
#[inline(always)]
fn mul64(a: __m256i, b: __m256i) -> __m256i {
    // SAFETY: called only on values of U64x8, which exist only with AVX2.
    unsafe {
        let ll = _mm256_mul_epu32(a, b);
        let hl = _mm256_mul_epu32(_mm256_srli_epi64::<32>(a), b);
        let lh = _mm256_mul_epu32(a, _mm256_srli_epi64::<32>(b));
        _mm256_add_epi64(ll, _mm256_slli_epi64::<32>(_mm256_add_epi64(hl, lh)))
    }
}

impl Avx2 {
    /// Eight rays from their fields in lanes (o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax): the
    /// inverse of [`Avx2::ray_fields`], [`F32x8::transpose8`] then one 32-byte store per ray
    /// (moves only: each ray's fields are its lane's bits). The stream kernels' next rays,
    /// written whole into the batch's rows instead of six scalar stores per ray.
    #[inline(always)]
    pub fn ray_rows(self, f: [F32x8; 8]) -> [crate::geometry::Ray; 8] {
        let rows = F32x8::transpose8(f);
        let mut out = core::mem::MaybeUninit::<[crate::geometry::Ray; 8]>::uninit();
        let p = out.as_mut_ptr().cast::<f32>();
        // SAFETY: the token proves AVX. A `Ray` is eight f32s, o.x … tmax, without padding
        // (asserted above `impl LaneI32 for I32x8`), so the 8 stores of 8 floats at 8k
        // initialise every ray of `out`, all of whose bit patterns are valid `f32`s.
        unsafe {
            for (k, r) in rows.iter().enumerate() {
                _mm256_storeu_ps(p.add(8 * k), r.0);
            }
            out.assume_init()
        }
    }

    /// One ray's fields as Embree's single-ray `RTCRay` holds them, as the bits of 12 floats:
    /// o.x, o.y, o.z, tmin, d.x, d.y, d.z, time 0; then tmax, all ones (the mask), tmax's bits
    /// again (the id groove gives a query) and 0 (the flags). One row load, two permutes, two
    /// blends and two stores, where the fields one by one took ~25 instructions a ray of an
    /// Embree stream.
    #[inline(always)]
    pub fn embree_ray(self, ray: &crate::geometry::Ray, out: &mut [f32; 12]) {
        let row = self.ray_row(ray).0;
        // SAFETY: the token proves AVX2; the stores write floats 0–7 and 8–11 of `out`.
        unsafe {
            let first = _mm256_permutevar8x32_ps(row, _mm256_setr_epi32(0, 1, 2, 6, 3, 4, 5, 7));
            let first = _mm256_blend_ps::<0x80>(first, _mm256_setzero_ps());
            _mm256_storeu_ps(out.as_mut_ptr(), first);
            let tmax = _mm256_castps256_ps128(_mm256_permutevar8x32_ps(row, _mm256_set1_epi32(7)));
            let rest = _mm_setr_ps(0.0, f32::from_bits(u32::MAX), 0.0, 0.0);
            _mm_storeu_ps(out.as_mut_ptr().add(8), _mm_blend_ps::<0b1010>(tmax, rest));
        }
    }

    /// Stores in `out` the hit row (`crate::accel::HitRow`'s words: geom, prim, `tfar`'s
    /// bits, u, v, inst, 0, 0) of an Embree ray-hit whose ray hit something: `hit` is its
    /// `RTCHit`'s eight words in Embree's order (Ng.x, Ng.y, Ng.z, u, v, primID, geomID,
    /// instID) and `tfar` its ray's. `tfar` and a zero word replace Ng.x and Ng.y (one
    /// blend), one permute puts the words in the row's order, one store writes them: where
    /// the words one by one, from the ray-hit's scattered fields, took ~25 instructions a ray
    /// of an Embree stream. (Returned by value instead, the row was taken apart again by the
    /// compiler into scalar words and stored as six.)
    #[inline(always)]
    pub fn embree_hit_row(self, hit: &[u32; 8], tfar: f32, out: &mut [u32; 8]) {
        // SAFETY: the token proves AVX2; the load reads `hit`'s 8 words, the store writes
        // `out`'s 8.
        unsafe {
            let h = _mm256_loadu_si256(hit.as_ptr().cast());
            let t = _mm256_setr_epi32(tfar.to_bits() as i32, 0, 0, 0, 0, 0, 0, 0);
            // tfar, 0, Ng.z, u, v, primID, geomID, instID.
            let h = _mm256_blend_epi32::<0b11>(h, t);
            let w = _mm256_permutevar8x32_epi32(h, _mm256_setr_epi32(6, 5, 0, 3, 4, 7, 1, 1));
            _mm256_storeu_si256(out.as_mut_ptr().cast(), w);
        }
    }

    /// Eight lanes' rows of 8 floats from 8 fields in lanes: row `k` is lane `k` of each field,
    /// in order ([`F32x8::transpose8`], then one store per row; moves only). For rows of other
    /// structures than rays (the stream kernels' path states).
    #[inline(always)]
    pub fn rows8(self, f: [F32x8; 8]) -> [[f32; 8]; 8] {
        let rows = F32x8::transpose8(f);
        let mut out = [[0.0f32; 8]; 8];
        for (o, r) in out.iter_mut().zip(rows) {
            r.store(o);
        }
        out
    }
}

impl super::pcg::PcgOps<I32x8> for U64x8 {
    #[inline(always)]
    fn gather_u64(table: &[u64], idx: I32x8) -> U64x8 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x8 exists only with AVX2; after the unsigned clamp every index is
        // below len, so each of the 8 loads (`vpgatherdq`, four per half) reads inside `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(table.len() as i32 - 1));
            let p = table.as_ptr().cast::<i64>();
            U64x8([
                _mm256_i32gather_epi64::<8>(p, _mm256_castsi256_si128(i)),
                _mm256_i32gather_epi64::<8>(p, _mm256_extracti128_si256::<1>(i)),
            ])
        }
    }
    #[inline(always)]
    fn xsh_rr(self) -> I32x8 {
        // SAFETY: a U64x8 exists only with AVX2.
        unsafe {
            // x = ((s >> 18) ^ s) >> 27 per 64-bit lane: its low word is the xorshifted
            // output and its high word is s >> 59, the rotation (bits 46..63 of s pass the xor
            // unchanged, and x has 37 bits).
            let a = self.0[0];
            let a = _mm256_srli_epi64::<27>(_mm256_xor_si256(_mm256_srli_epi64::<18>(a), a));
            let b = self.0[1];
            let b = _mm256_srli_epi64::<27>(_mm256_xor_si256(_mm256_srli_epi64::<18>(b), b));
            // vshufps takes the low (0x88) or the high (0xDD) words of both registers in one
            // instruction, both in the lane order 0 1 4 5 2 3 6 7.
            let (fa, fb) = (_mm256_castsi256_ps(a), _mm256_castsi256_ps(b));
            let lo = _mm256_castps_si256(_mm256_shuffle_ps::<0x88>(fa, fb));
            let rot = _mm256_castps_si256(_mm256_shuffle_ps::<0xDD>(fa, fb));
            // Rotate right by rot < 32: vpsllvd gives 0 for a count of 32 (rot = 0).
            let r = _mm256_or_si256(
                _mm256_srlv_epi32(lo, rot),
                _mm256_sllv_epi32(lo, _mm256_sub_epi32(_mm256_set1_epi32(32), rot)),
            );
            // Back to the lane order: the 64-bit pieces 0 2 1 3.
            I32x8(_mm256_permute4x64_epi64::<0xD8>(r))
        }
    }
}

impl super::LaneLookup<F32x8> for I32x8 {
    #[inline(always)]
    fn lookup8(table: &[f32; 8], idx: I32x8) -> F32x8 {
        // SAFETY: an I32x8 exists only with AVX2; the load reads the 8 floats of `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(7));
            F32x8(_mm256_permutevar8x32_ps(_mm256_loadu_ps(table.as_ptr()), i))
        }
    }
}

impl Avx2 {
    /// Eight rows of 4 floats as 4 fields in lanes: lane `k` of field `j` is `rows[k][j]`
    /// (moves only). Rows `k` and `k + 4` share a register (one 16-byte load each), then the
    /// 4×4 transposes of [`F32x8::transpose8`] within each 128-bit half. For structures read a
    /// row of 4 per path (the stream renderer's path states: radiance and depth).
    #[inline(always)]
    pub fn fields4(self, rows: &[[f32; 4]; 8]) -> [F32x8; 4] {
        // SAFETY: the token proves AVX; each load reads the 4 floats of one row of `rows`.
        unsafe {
            // (Written out: a closure or `array::from_fn` may be compiled out of line, without
            // the target features.)
            let r = |k: usize| rows[k].as_ptr();
            let v = [
                _mm256_set_m128(_mm_loadu_ps(r(4)), _mm_loadu_ps(r(0))),
                _mm256_set_m128(_mm_loadu_ps(r(5)), _mm_loadu_ps(r(1))),
                _mm256_set_m128(_mm_loadu_ps(r(6)), _mm_loadu_ps(r(2))),
                _mm256_set_m128(_mm_loadu_ps(r(7)), _mm_loadu_ps(r(3))),
            ];
            let t0 = _mm256_unpacklo_ps(v[0], v[1]);
            let t1 = _mm256_unpackhi_ps(v[0], v[1]);
            let t2 = _mm256_unpacklo_ps(v[2], v[3]);
            let t3 = _mm256_unpackhi_ps(v[2], v[3]);
            [
                F32x8(_mm256_shuffle_ps::<0x44>(t0, t2)),
                F32x8(_mm256_shuffle_ps::<0xee>(t0, t2)),
                F32x8(_mm256_shuffle_ps::<0x44>(t1, t3)),
                F32x8(_mm256_shuffle_ps::<0xee>(t1, t3)),
            ]
        }
    }

    /// The inverse of [`Avx2::fields4`]: eight lanes' rows of the 4 fields `f` (row `k` is
    /// lane `k` of `f[0]`, …, `f[3]`; moves only, one 16-byte store per row).
    #[inline(always)]
    pub fn rows4(self, f: [F32x8; 4]) -> [[f32; 4]; 8] {
        let mut out = [[0.0f32; 4]; 8];
        // SAFETY: the token proves AVX; each store writes the 4 floats of one row of `out`.
        unsafe {
            let t0 = _mm256_unpacklo_ps(f[0].0, f[1].0);
            let t1 = _mm256_unpackhi_ps(f[0].0, f[1].0);
            let t2 = _mm256_unpacklo_ps(f[2].0, f[3].0);
            let t3 = _mm256_unpackhi_ps(f[2].0, f[3].0);
            // Rows m (low half) and m + 4 (high half) in u[m].
            let u = [
                _mm256_shuffle_ps::<0x44>(t0, t2),
                _mm256_shuffle_ps::<0xee>(t0, t2),
                _mm256_shuffle_ps::<0x44>(t1, t3),
                _mm256_shuffle_ps::<0xee>(t1, t3),
            ];
            for (m, r) in u.iter().enumerate() {
                _mm_storeu_ps(out[m].as_mut_ptr(), _mm256_castps256_ps128(*r));
                _mm_storeu_ps(out[m + 4].as_mut_ptr(), _mm256_extractf128_ps::<1>(*r));
            }
        }
        out
    }

    // The twenty-sixth session's h1: a lookup in a table of 16 floats.

    /// `table[min(idx as u32, 15)]` per lane: two `vpermps` (the table's halves, by the index's
    /// low three bits) and one `vblendvps` on the index's bit 3 (moved to the sign bit). For the
    /// surface gather's tables of meshes of 9 to 16 triangles (the Cornell boxes' 12), where
    /// [`super::LaneLookup::lookup8`] serves 8. The clamp and the shift depend on `idx` only, so
    /// a run of lookups by one index shares them.
    #[inline(always)]
    pub fn lookup16(self, table: &[f32; 16], idx: I32x8) -> F32x8 {
        // SAFETY: the token proves AVX2; the loads read the 16 floats of `table`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(15));
            let lo = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table.as_ptr()), i);
            let hi = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table.as_ptr().add(8)), i);
            let high = _mm256_castsi256_ps(_mm256_slli_epi32::<28>(i));
            F32x8(_mm256_blendv_ps(lo, hi, high))
        }
    }

    // Added in the twenty-sixth session (h2).

    /// Per lane `k`, from the last lane to the first, `table[idx[k]] = new[k]` where `on`,
    /// else `old[k]`: where an index repeats, the lowest lane's value is the one left. For
    /// writing back values gathered from `table` (`old`, e.g. by `PcgOps::gather_u64`) and
    /// updated where `on` (the stream kernels' PCG32 states, `kernels::draws`): a store per
    /// lane, without a branch or a bounds test per lane.
    ///
    /// # Panics
    /// If an index (as `u32`) is not below `table.len()`, before any store.
    #[inline(always)]
    pub fn store_u64_at(self, table: &mut [u64], idx: I32x8, on: M8, new: U64x8, old: U64x8) {
        assert!(!table.is_empty(), "store_u64_at: an empty table");
        let last = table.len().min(u32::MAX as usize) as u32 - 1;
        let mut ix = [0u32; 8];
        let mut v = [0u64; 8];
        // SAFETY: the token proves AVX2. The stores write the locals `ix` and `v`.
        let fits = unsafe {
            let i = idx.0;
            let fits = _mm256_cmpeq_epi32(_mm256_min_epu32(i, _mm256_set1_epi32(last as i32)), i);
            // The 32-bit lane masks widened to the 64-bit lanes of each half.
            let m = _mm256_castps_si256(on.0);
            let lo = _mm256_cvtepi32_epi64(_mm256_castsi256_si128(m));
            let hi = _mm256_cvtepi32_epi64(_mm256_extracti128_si256::<1>(m));
            let v0 = _mm256_blendv_epi8(old.0[0], new.0[0], lo);
            let v1 = _mm256_blendv_epi8(old.0[1], new.0[1], hi);
            _mm256_storeu_si256(ix.as_mut_ptr().cast(), i);
            _mm256_storeu_si256(v.as_mut_ptr().cast(), v0);
            _mm256_storeu_si256(v.as_mut_ptr().add(4).cast(), v1);
            _mm256_movemask_ps(_mm256_castsi256_ps(fits))
        };
        assert!(fits == 0xff, "store_u64_at: an index out of range");
        let p = table.as_mut_ptr();
        // SAFETY: every index is at most `last` < `table.len()` (tested above).
        unsafe {
            *p.add(ix[7] as usize) = v[7];
            *p.add(ix[6] as usize) = v[6];
            *p.add(ix[5] as usize) = v[5];
            *p.add(ix[4] as usize) = v[4];
            *p.add(ix[3] as usize) = v[3];
            *p.add(ix[2] as usize) = v[2];
            *p.add(ix[1] as usize) = v[1];
            *p.add(ix[0] as usize) = v[0];
        }
    }

    // Added in the twenty-eighth session (h1).

    /// A compress: the lanes of `ids` where `keep`, in lane order, appended to a list at
    /// `out[at..]`; returns `at` plus the number kept. All eight lanes are written to
    /// `out[at..at + 8]`, the kept ones first and the others after them in lane order (slots
    /// past the list's new end, which the next append overwrites). One permute chosen by the
    /// mask from a table of the 256 masks' permutations as 8 bytes ([`COMPRESS_ROWS`]), one
    /// store: the stream renderer's lists of path ids filtered 8 at a time without a branch
    /// per path (the emission stage's first pass, `stream::emission`, the compaction and the
    /// light split, `stream::batch`).
    ///
    /// # Panics
    /// If `at + 8 > out.len()`, before any store.
    #[inline(always)]
    pub fn compress_store(self, ids: I32x8, keep: M8, out: &mut [u32], at: usize) -> usize {
        let dst: &mut [u32; 8] = (&mut out[at..][..8]).try_into().expect("8 slots");
        let m = (keep.bits() & 0xff) as usize;
        // SAFETY: the token proves AVX2; the row is 8 bytes, so the 8-byte load (unaligned, as
        // `vmovq` allows) reads exactly it; `dst` holds 8 u32s, so the 32-byte store writes
        // exactly `dst`.
        unsafe {
            let perm = _mm256_cvtepu8_epi32(_mm_loadl_epi64(COMPRESS_ROWS.0[m].as_ptr().cast()));
            let v = _mm256_permutevar8x32_epi32(ids.0, perm);
            _mm256_storeu_si256(dst.as_mut_ptr().cast(), v);
        }
        at + super::bits::BYTE_COUNTS[m] as usize
    }

    /// The `depth` of the path states `state[idx[k]]` in lanes (one `vpgatherdd` at the
    /// field's offset in each state), each index first clamped to `state.len() − 1` as an
    /// unsigned number (as [`LaneI32::gather_u32`]): always in bounds. A typed gather (not a
    /// generic "field of `&[T]`": the field is a `u32` of a `repr(C)` struct, initialised in
    /// every element, which the compiler checks here through `offset_of!`): the emission
    /// stage's first pass reads 8 paths' depths with it.
    ///
    /// # Panics
    /// If `state` is empty or larger than `i32::MAX` bytes.
    #[inline(always)]
    pub fn gather_depth(self, state: &[crate::integrator::path::PathState], idx: I32x8) -> I32x8 {
        const AT: usize = core::mem::offset_of!(crate::integrator::path::PathState, depth);
        I32x8(self.gather_state_word::<AT>(state, idx))
    }

    /// The x and y columns of eight 2-D points: lane `k` of the first is `v[k].x`, of the
    /// second `v[k].y` (moves only). Two 32-byte loads, two shuffles and two 64-bit permutes,
    /// not 16 scalar moves through the stack: the film positions of the stream renderer's
    /// camera rays and splat.
    #[inline(always)]
    pub fn vec2_columns(self, v: &[glam::Vec2; 8]) -> [F32x8; 2] {
        // SAFETY: the token proves AVX2. A `glam::Vec2` is two f32s, x then y, 8 bytes
        // (asserted below `impl Lane for F32x8`), so `v` is 16 consecutive floats and each load
        // reads 8 of them.
        unsafe {
            let p = v.as_ptr().cast::<f32>();
            // x0 y0 x1 y1 | x2 y2 x3 y3 and x4 y4 x5 y5 | x6 y6 x7 y7.
            let (a, b) = (_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8)));
            // Per 128-bit half: x0 x1 x4 x5 | x2 x3 x6 x7 (and the y's), then the 64-bit
            // pairs in the order 0, 2, 1, 3.
            let xs = _mm256_castps_pd(_mm256_shuffle_ps::<0x88>(a, b));
            let ys = _mm256_castps_pd(_mm256_shuffle_ps::<0xDD>(a, b));
            [
                F32x8(_mm256_castpd_ps(_mm256_permute4x64_pd::<0xD8>(xs))),
                F32x8(_mm256_castpd_ps(_mm256_permute4x64_pd::<0xD8>(ys))),
            ]
        }
    }

    // Added in the twenty-eighth session (h2).

    /// Per 64-bit lane `k`, `a[k]` where lane `k` of `on` is set, else `b[k]` (each 32-bit
    /// mask lane widened to its 64-bit lane; its sign bit decides, as in `F32x8::select`): a
    /// masked PCG32 step keeps the state of the lanes that do not draw (the compensated
    /// sampler's draws, `bsdf::mnm::compensated::lanes`).
    #[inline(always)]
    pub fn select_u64(self, on: M8, a: U64x8, b: U64x8) -> U64x8 {
        // SAFETY: the token proves AVX2.
        unsafe {
            let m = _mm256_castps_si256(on.0);
            let lo = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(m)));
            let hi = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256::<1>(m)));
            // (Written out, not a closure: a closure may be compiled out of the SIMD
            // function, its intrinsics then calls.)
            let v0 = _mm256_blendv_pd(_mm256_castsi256_pd(b.0[0]), _mm256_castsi256_pd(a.0[0]), lo);
            let v1 = _mm256_blendv_pd(_mm256_castsi256_pd(b.0[1]), _mm256_castsi256_pd(a.0[1]), hi);
            U64x8([_mm256_castpd_si256(v0), _mm256_castpd_si256(v1)])
        }
    }

    // Added in the twenty-ninth session (h1).

    /// The 4-byte word at byte `AT` of the path states `state[idx[k]]` in lanes (one
    /// `vpgatherdd`), each index first clamped to `state.len() − 1` as an unsigned number (as
    /// [`Self::gather_depth`]): always in bounds. Private: its typed callers name the field
    /// through `offset_of!`, so `AT` is always a whole 4-byte field (`f32` or `u32`) of the
    /// `repr(C)` struct.
    ///
    /// # Panics
    /// If `state` is empty or larger than `i32::MAX` bytes.
    #[inline(always)]
    fn gather_state_word<const AT: usize>(
        self,
        state: &[crate::integrator::path::PathState],
        idx: I32x8,
    ) -> __m256i {
        const SIZE: usize = core::mem::size_of::<crate::integrator::path::PathState>();
        const { assert!(AT.is_multiple_of(4) && SIZE.is_multiple_of(4) && AT + 4 <= SIZE) };
        assert!(!state.is_empty() && state.len() <= i32::MAX as usize / SIZE);
        // SAFETY: the token proves AVX2. After the unsigned clamp every index r is below
        // len, so the byte offset r·SIZE fits an i32 (asserted above) and the 4-byte load at
        // r·SIZE + AT reads a field of `state[r]` (the callers pass a field's offset), always
        // initialised.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(state.len() as i32 - 1));
            let off = _mm256_mullo_epi32(i, _mm256_set1_epi32(SIZE as i32));
            let base = state.as_ptr().cast::<u8>().add(AT).cast::<i32>();
            _mm256_i32gather_epi32::<1>(base, off)
        }
    }

    /// The `eta` of the path states `state[idx[k]]` in lanes (one gather, every bit moved),
    /// each index clamped as [`Self::gather_depth`]: the stream renderer's vertex end reads 8
    /// paths' index products with it (`stream::kernels::vertex::x8::advance`), not 8 scalar
    /// loads and inserts.
    ///
    /// # Panics
    /// If `state` is empty or larger than `i32::MAX` bytes.
    #[inline(always)]
    pub fn gather_eta(self, state: &[crate::integrator::path::PathState], idx: I32x8) -> F32x8 {
        const AT: usize = core::mem::offset_of!(crate::integrator::path::PathState, eta);
        // SAFETY: the token proves AVX2 (a bit cast).
        F32x8(unsafe { _mm256_castsi256_ps(self.gather_state_word::<AT>(state, idx)) })
    }

    /// The `throughput` (x, y, z) of the path states `state[idx[k]]` in lanes (three gathers,
    /// every bit moved), each index clamped as [`Self::gather_depth`]: the wrapper-chain
    /// kernels' throughputs of 8 paths (`stream::kernels::vertex::x8::shade`), not 24 scalar
    /// copies through the stack.
    ///
    /// # Panics
    /// If `state` is empty or larger than `i32::MAX` bytes.
    #[inline(always)]
    pub fn gather_throughput(
        self,
        state: &[crate::integrator::path::PathState],
        idx: I32x8,
    ) -> [F32x8; 3] {
        use crate::integrator::path::PathState;
        const X: usize = core::mem::offset_of!(PathState, throughput);
        // glam's `Vec3` is three `f32`s, x, y, z (`repr(C)`).
        const { assert!(core::mem::size_of::<glam::Vec3>() == 12) };
        // SAFETY: the token proves AVX2 (bit casts).
        unsafe {
            [
                F32x8(_mm256_castsi256_ps(self.gather_state_word::<X>(state, idx))),
                F32x8(_mm256_castsi256_ps(
                    self.gather_state_word::<{ X + 4 }>(state, idx),
                )),
                F32x8(_mm256_castsi256_ps(
                    self.gather_state_word::<{ X + 8 }>(state, idx),
                )),
            ]
        }
    }

    // Added in the twenty-ninth session (h2).

    /// A window gather of `glam::Vec3` rows: for each offset `o` of `offsets`, lane k of
    /// entry r holds row `table[i + o]` by component (x, y, z), where `i` is `idx[k]` clamped
    /// once, as an unsigned number, to `len − 1 − max(offsets)` (every row of the window
    /// inside the table). Where `idx[k] + max(offsets)` is below the table's length, lane k
    /// reads exactly the rows that [`Lane::gather3`] reads at `idx[k] + o` (whose clamp, index
    /// by index, then changes nothing); elsewhere the window of the clamped index. The
    /// compensated model's table lookups read the 8 corner nodes of a cell this way
    /// (`bsdf::mnm::ms_table`: one clamp and scaling per lookup instead of one per corner).
    ///
    /// Without gathers (thirty-eighth session, h2): the 8 lanes' first float indices are moved
    /// to scalar registers once for all the rows; each row is then 8 unaligned 16-byte loads
    /// (one per lane: the row and the next row's x for offset 0, the previous row's z and the
    /// row otherwise, so no load leaves the table) and a 4 × 4 transpose in each 128-bit half
    /// (4 inserts, 7 unpacks). On this project's Zen 3 host an 8-lane `vgatherdps` is ~39
    /// micro-ops (published tables) and measured 10–13 cycles of throughput, so the 24 gathers
    /// of an 8-row window cost far more than the 8 loads and 11 shuffles a row that replace
    /// them (`docs/bench/README.md`, the thirty-eighth session's h2 section). Every value is
    /// moved, never computed, so the rows are the gathers' bit for bit (NaN payloads too).
    ///
    /// # Panics
    /// If the table has `max(offsets)` rows or fewer, or more than `i32::MAX / 3`.
    #[inline(always)]
    pub fn gather3_window<const K: usize>(
        self,
        table: &[glam::Vec3],
        idx: I32x8,
        offsets: &[usize; K],
    ) -> [[F32x8; 3]; K] {
        let mut span = 0;
        for &o in offsets {
            span = span.max(o);
        }
        assert!(table.len() > span && table.len() <= i32::MAX as usize / 3);
        // SAFETY: the token proves AVX2. `glam::Vec3` is three f32s without padding (the
        // assertion after `impl Lane for F32x8`), so row r's component c is float 3r + c from
        // the start, and the table holds 3·len floats. After the clamp i ≤ len − 1 − span, so
        // for each offset o ≤ span the row i + o is below len and 3(i + o) + 2 < 3·len ≤
        // i32::MAX. A row at offset 0 is read as floats 3i … 3i + 3: when span ≥ 1 the row
        // i + 1 ≤ i + span exists, so float 3i + 3 (its x) is inside; when span = 0 the rows
        // are `Lane::gather3`'s instead (its clamp to len − 1 is this one). A row at offset o ≥ 1 is read as floats
        // 3(i + o) − 1 … 3(i + o) + 2, from the z of row i + o − 1 ≥ 0: inside.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32((table.len() - 1 - span) as i32));
            let i3 = _mm256_add_epi32(_mm256_add_epi32(i, i), i);
            let first: [i32; 8] = core::mem::transmute(i3);
            let base = table.as_ptr().cast::<f32>();
            let mut out = [[F32x8(_mm256_setzero_ps()); 3]; K];
            for (row, &o) in out.iter_mut().zip(offsets) {
                // Plain statements and macros, not closures (a closure would be compiled
                // outside `Avx2::run`'s target features).
                if span == 0 {
                    // Every row is `table[min(idx, len − 1)]`: the lane gather's own clamp.
                    *row = <F32x8 as Lane>::gather3(table, idx);
                    continue;
                }
                // The row's x in the loaded floats: float 0 at offset 0, float 1 otherwise.
                let from = if o == 0 { base } else { base.add(3 * o - 1) };
                macro_rules! pair {
                    ($lo:expr) => {
                        _mm256_insertf128_ps::<1>(
                            _mm256_castps128_ps256(_mm_loadu_ps(from.add(first[$lo] as usize))),
                            _mm_loadu_ps(from.add(first[$lo + 4] as usize)),
                        )
                    };
                }
                let (r0, r1, r2, r3) = (pair!(0), pair!(1), pair!(2), pair!(3));
                // Lanes k and k + 4 are the 128-bit halves of r_k; the unpacks transpose each
                // half: a holds float 0 of lanes 0–3 | 4–7, b float 1, c float 2, d float 3.
                let t0 = _mm256_castps_pd(_mm256_unpacklo_ps(r0, r1));
                let t1 = _mm256_castps_pd(_mm256_unpackhi_ps(r0, r1));
                let t2 = _mm256_castps_pd(_mm256_unpacklo_ps(r2, r3));
                let t3 = _mm256_castps_pd(_mm256_unpackhi_ps(r2, r3));
                let a = F32x8(_mm256_castpd_ps(_mm256_unpacklo_pd(t0, t2)));
                let b = F32x8(_mm256_castpd_ps(_mm256_unpackhi_pd(t0, t2)));
                let c = F32x8(_mm256_castpd_ps(_mm256_unpacklo_pd(t1, t3)));
                let d = F32x8(_mm256_castpd_ps(_mm256_unpackhi_pd(t1, t3)));
                *row = if o == 0 { [a, b, c] } else { [b, c, d] };
            }
            out
        }
    }

    // The thirtieth session's h1 block.

    /// One ray as a row of 8 floats: o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax (one 32-byte
    /// load, as each row of [`Self::ray_fields`]): tier A's packets read the stream renderer's
    /// rays where they lie, through a reference, instead of copying them into a packet first.
    #[inline(always)]
    pub fn ray_row(self, ray: &crate::geometry::Ray) -> F32x8 {
        let r: *const crate::geometry::Ray = ray;
        // SAFETY: the token proves AVX. A `Ray` is eight f32s, o.x … tmax, without padding
        // (asserted below), all initialised, so the 32-byte load reads exactly `*ray`.
        F32x8(unsafe { _mm256_loadu_ps(r.cast::<f32>()) })
    }

    // Added in the thirtieth session (h2).

    /// Lane `i`: nibble `i` of `row`, `(row >> 4 i) & 15` (a broadcast, one variable shift and
    /// an and). Eight small numbers packed into one scalar word spread to the lanes without a
    /// store: the compensated first order's lists of packed pairs (a lane number in the low
    /// three bits, a flag in bit 3) become [`F32x8::permute`] indices
    /// (`bsdf::mnm::compensated::lanes`).
    #[inline(always)]
    pub fn nibbles(self, row: u32) -> I32x8 {
        // SAFETY: the token proves AVX2.
        unsafe {
            let shifts = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
            let v = _mm256_srlv_epi32(_mm256_set1_epi32(row as i32), shifts);
            I32x8(_mm256_and_si256(v, _mm256_set1_epi32(15)))
        }
    }

    // The thirty-first session's h1 block.

    /// The permutation of a compress, and how many lanes it keeps: lane `j` of the index is the
    /// source lane of output `j` (the lanes of `keep`'s low 8 bits in lane order, then the
    /// others in lane order), for [`F32x8::permute`] and [`I32x8::permute`]; the count is the
    /// number of bits set. [`Self::compress_store`]'s table lookup, for compressing several
    /// columns by one mask (the stream kernels' pending light samples: the shadow rays' and
    /// contributions' columns before their transposes). Bits above 7 are ignored.
    ///
    /// The permutation is spread from one packed word of [`COMPRESS`] (a broadcast, a
    /// variable shift and an and), not loaded whole from [`COMPRESS_ROWS`] as in
    /// [`Self::compress_store`]: with the whole-vector load the diffuse kernel's code around
    /// its pending light samples cost 11 instructions more a call (the thirty-seventh
    /// session, h3: cbox-rgb +2 a sample).
    #[inline(always)]
    pub fn compress_index(self, keep: u32) -> (I32x8, usize) {
        let row = COMPRESS[(keep & 0xff) as usize];
        // SAFETY: the token proves AVX2.
        let perm = unsafe {
            // Lane j's source lane is bits 3j..3j + 3 of the row.
            let shifts = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
            I32x8(_mm256_and_si256(
                _mm256_srlv_epi32(_mm256_set1_epi32(row as i32), shifts),
                _mm256_set1_epi32(7),
            ))
        };
        (perm, (row >> 24) as usize)
    }

    // Added in the thirty-fifth session (h1).

    /// Appends the 8 lanes of `v` to `out`, in lane order: one capacity check, two 32-byte
    /// stores into the vector's spare room, its length advanced by 8 (nothing zero-filled, no
    /// copy through the stack). The batch fill's PCG32 columns (`sampler::for_samples_x8`),
    /// which went through an array and `extend_from_slice` (~12 instructions a column of 8).
    #[inline(always)]
    pub fn append_u64(self, out: &mut Vec<u64>, v: U64x8) {
        out.reserve(8);
        let len = out.len();
        // SAFETY: the token proves AVX. `reserve` left room for at least 8 more `u64`s past
        // `len`; the two 32-byte stores write exactly those 8, so the first `len + 8` elements
        // are initialised when the length is set.
        unsafe {
            let p = out.as_mut_ptr().add(len).cast::<__m256i>();
            _mm256_storeu_si256(p, v.0[0]);
            _mm256_storeu_si256(p.add(1), v.0[1]);
            out.set_len(len + 8);
        }
    }

    /// The inverse of [`Self::vec2_columns`], appended to `out`: lane `k` of `x` and of `y` as
    /// point `len + k` (moves only: each point's fields are its lanes' bits), with one
    /// capacity check, two 32-byte stores into the spare room and the length advanced by 8.
    /// The batch fill's film positions, added in lanes (`sampler::for_samples_x8`; the
    /// thirty-second session's form stored them to an array on the stack, which
    /// `extend_from_slice` then copied).
    #[inline(always)]
    pub fn append_vec2_rows(self, out: &mut Vec<glam::Vec2>, x: F32x8, y: F32x8) {
        out.reserve(8);
        let len = out.len();
        // SAFETY: the token proves AVX. A `glam::Vec2` is two f32s, x then y, 8 bytes
        // (asserted below `impl Lane for F32x8`); `reserve` left room for 8 more past `len`,
        // 16 floats, which the two stores of 8 write (every bit pattern is a valid `f32`).
        unsafe {
            // x0 y0 x1 y1 | x4 y4 x5 y5 and x2 y2 x3 y3 | x6 y6 x7 y7.
            let lo = _mm256_unpacklo_ps(x.0, y.0);
            let hi = _mm256_unpackhi_ps(x.0, y.0);
            let p = out.as_mut_ptr().add(len).cast::<f32>();
            _mm256_storeu_ps(p, _mm256_permute2f128_ps::<0x20>(lo, hi));
            _mm256_storeu_ps(p.add(8), _mm256_permute2f128_ps::<0x31>(lo, hi));
            out.set_len(len + 8);
        }
    }

    // Added in the thirty-sixth session (h1).

    /// Whether every id of `ids` is below `len`, as unsigned numbers: one unsigned max of the
    /// ids and the broadcast length, compared with the ids (equal exactly where an id is at
    /// least `len`), and one mask test, instead of a compare and a branch per id (the bounds
    /// checks of eight indexed reads or stores: [`Self::ray_fields`],
    /// [`Self::ray_rows_through`]). A length past `u32::MAX` holds every id.
    #[inline(always)]
    pub fn ids_below(self, ids: &[u32; 8], len: usize) -> bool {
        let Ok(len) = u32::try_from(len) else {
            return true;
        };
        // SAFETY: the token proves AVX2; the load reads the 32 bytes of `ids`.
        unsafe {
            let v = _mm256_loadu_si256(ids.as_ptr().cast());
            let past = _mm256_cmpeq_epi32(_mm256_max_epu32(v, _mm256_set1_epi32(len as i32)), v);
            _mm256_movemask_epi8(past) == 0
        }
    }

    /// The 8 entries `items[ids[k]]`, with the 8 ids' bounds checked at once
    /// ([`Self::ids_below`]) instead of a compare and a branch each: `None` when an id is not
    /// below `items.len()` (the caller's indexing then panics as it would have). The emission
    /// stage's 8 path states of a full chunk (`stream::emission`; thirty-seventh session, h2).
    #[inline(always)]
    pub fn entries_at<'a, T>(self, items: &'a [T], ids: &[u32; 8]) -> Option<[&'a T; 8]> {
        if !self.ids_below(ids, items.len()) {
            return None;
        }
        // SAFETY: every id is below `items.len()` (checked just above).
        Some(unsafe {
            [
                items.get_unchecked(ids[0] as usize),
                items.get_unchecked(ids[1] as usize),
                items.get_unchecked(ids[2] as usize),
                items.get_unchecked(ids[3] as usize),
                items.get_unchecked(ids[4] as usize),
                items.get_unchecked(ids[5] as usize),
                items.get_unchecked(ids[6] as usize),
                items.get_unchecked(ids[7] as usize),
            ]
        })
    }

    /// `f(k, &mut items[ids[k]])` for k = 0 to 7 in turn (a repeated id's entry is handed on
    /// again, after the earlier call has returned), with the 8 ids' bounds checked at once
    /// ([`Self::ids_below`]). Pass `f` with `#[inline(always)]`: out of line it would lose the
    /// lanes' target features.
    ///
    /// # Panics
    /// If an id is not below `items.len()`, before `f` is called.
    #[inline(always)]
    pub fn for_each_at_mut<T>(
        self,
        items: &mut [T],
        ids: &[u32; 8],
        mut f: impl FnMut(usize, &mut T),
    ) {
        assert!(
            self.ids_below(ids, items.len()),
            "an id past the {} entries",
            items.len()
        );
        for (k, &i) in ids.iter().enumerate() {
            // SAFETY: every id is below `items.len()` (asserted above); one entry is borrowed
            // at a time.
            f(k, unsafe { items.get_unchecked_mut(i as usize) });
        }
    }

    /// Tier A's packet of the 8 rays `rays[ids[k]]` from and to the path columns: the rays'
    /// rows loaded where they lie and turned into lanes ([`Self::ray_fields`]: o.x, o.y, o.z,
    /// d.x, d.y, d.z, tmin, tmax), traced by `trace` into the 8 fields of their hits' rows,
    /// and each row stored from the lanes with one 32-byte store at `hit[ids[k]]`, in lane
    /// order (`accel::brute`'s packets of active paths). Both columns' bounds are checked once
    /// for all 8 ids ([`Self::ids_below`]): indexed one by one, the reads and stores cost a
    /// compare and a branch each, beside the caller's test of the ids' own length for each
    /// of the 8 (metal_plastic's bounce packets: ~60 instructions a packet).
    ///
    /// # Panics
    /// If an id is not below both columns' lengths (before anything is read or stored).
    #[inline(always)]
    pub fn ray_rows_through(
        self,
        rays: &[crate::geometry::Ray],
        ids: &[u32; 8],
        hit: &mut [crate::accel::HitRow],
        trace: impl FnOnce([F32x8; 8]) -> [F32x8; 8],
    ) {
        assert!(
            self.ids_below(ids, rays.len().min(hit.len())),
            "a packet's id past its columns"
        );
        // SAFETY: every id is below `rays.len()` (the assertion).
        let rows = ids.map(|i| self.ray_row(unsafe { rays.get_unchecked(i as usize) }));
        let out = F32x8::transpose8(trace(F32x8::transpose8(rows)));
        for (row, &i) in out.iter().zip(ids) {
            // SAFETY: every id is below `hit.len()` (the assertion).
            row.store_bits(&mut unsafe { hit.get_unchecked_mut(i as usize) }.0);
        }
    }
}

/// A table of 256 rows of 8 byte lanes, each row at an 8-byte boundary (so that no row
/// straddles a cache line): a row is one `vpmovzxbd` from memory, widened to 8 `u32` lanes.
#[repr(C, align(8))]
struct Rows256([[u8; 8]; 256]);

/// [`Avx2::compress_index`]'s table, per mask (bit k for lane k): the source lane of each of
/// the 8 outputs in bits 3j..3j + 3 (the kept lanes in order, then the others in order) and
/// the number kept in bits 24..28.
const COMPRESS: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let mut row = 0;
        let mut j = 0;
        while j < 8 {
            row |= (COMPRESS_ROWS.0[m][j] as u32) << (3 * j);
            j += 1;
        }
        t[m] = row | (m as u32).count_ones() << 24;
        m += 1;
    }
    t
};

/// [`Avx2::compress_store`]'s table, per mask (bit k for lane k): lane j of the row is the
/// source lane of output j, the kept lanes in lane order, then the others in lane order. Bytes
/// (2 KB, 8 rows a cache line), not `u32`s (8 KB): the same one load a mask, widened by the
/// load itself, with a quarter of the cache footprint. A `static`, so the binary holds one copy.
static COMPRESS_ROWS: Rows256 = {
    let mut t = [[0u8; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut n = 0;
        let mut pass = 0;
        while pass < 2 {
            let mut k = 0;
            while k < 8 {
                // Pass 0 takes the kept lanes, pass 1 the others.
                if (m >> k & 1) as u32 == 1 - pass {
                    t[m][n] = k as u8;
                    n += 1;
                }
                k += 1;
            }
            pass += 1;
        }
        m += 1;
    }
    Rows256(t)
};
