//! Width 16: thin wrappers over `core::arch::x86_64` AVX-512 (`__m512`, `__m512i`, `__mmask16`),
//! an experiment (issue 18, twelfth session): does doubling the lane width pay on a CPU with
//! AVX-512 (Zen 4)? See `docs/design/lanes.md` for the measurements and the verdict.
//!
//! Soundness as in `avx2.rs`: a value of these types can only be built from an [`Avx512`] token
//! (which [`Avx512::detect`] returns only when the CPU has AVX-512 F, DQ, BW and VL, and FMA) or
//! computed from another such value; their fields are private (the mask [`M16`] holds a plain
//! `u16` and needs no feature). Every operation is `#[inline(always)]`; put loops inside
//! [`Avx512::run`].
//!
//! The semantics match `scalar.rs` and `avx2.rs` lane by lane: the same correctly rounded
//! operations (`vaddps vsubps vmulps vdivps vsqrtps`, FMA only in `mul_add`), ordered
//! comparisons (`!=` unordered) into mask registers, `vminps`/`vmaxps` (second operand on NaN or
//! equal), `vcvtps2dq`/`vcvttps2dq` (`i32::MIN` when out of range), selects as mask blends.
//! Shifts by a constant go through the count-register form (`vpslld zmm, xmm`), whose
//! semantics for counts ≥ 32 (zero, or sign fill) are those of the immediate form; the
//! intrinsics' immediate form wants a `u32` constant, which a generic `i32` one cannot become
//! on stable Rust. LLVM folds the constant count back into an immediate.

// The AVX-512 intrinsics are stable since Rust 1.89, the crate's `rust-version`.

use super::{Lane, LaneI32, LaneMask, LaneU64};
use core::arch::x86_64::*;
use core::fmt;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

/// Proof that the CPU has AVX-512 F/DQ/BW/VL and FMA: the only way to make 16-wide values.
#[derive(Clone, Copy, Debug)]
pub struct Avx512(());

/// Sixteen `f32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x16(__m512);

/// Sixteen lane masks: bit `i` is lane `i` (an AVX-512 mask register).
#[derive(Clone, Copy, PartialEq, Eq)]
#[repr(transparent)]
pub struct M16(u16);

/// Sixteen `i32` lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x16(__m512i);

/// Sixteen `u64` lanes: lanes 0–7 in the first register, 8–15 in the second.
#[derive(Clone, Copy)]
pub struct U64x16([__m512i; 2]);

impl Avx512 {
    /// The token, when this CPU has AVX-512 F, DQ, BW, VL and FMA.
    pub fn detect() -> Option<Avx512> {
        if is_x86_feature_detected!("avx512f")
            && is_x86_feature_detected!("avx512dq")
            && is_x86_feature_detected!("avx512bw")
            && is_x86_feature_detected!("avx512vl")
            && is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
        {
            Some(Avx512(()))
        } else {
            None
        }
    }

    /// Run `f` inside a function compiled for AVX-512, so that the 16-wide operations inlined
    /// into it become single instructions. Put whole loops inside.
    #[inline(always)]
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        // SAFETY: the token exists only when the CPU has these features.
        unsafe { run_avx512(f) }
    }

    #[inline(always)]
    pub fn splat(self, c: f32) -> F32x16 {
        // SAFETY: the token proves AVX-512F (here and below).
        F32x16(unsafe { _mm512_set1_ps(c) })
    }
    #[inline(always)]
    pub fn load(self, a: &[f32; 16]) -> F32x16 {
        F32x16(unsafe { _mm512_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    pub fn load_i32(self, a: &[i32; 16]) -> I32x16 {
        I32x16(unsafe { _mm512_loadu_epi32(a.as_ptr()) })
    }
    #[inline(always)]
    pub fn load_u64(self, a: &[u64; 16]) -> U64x16 {
        let p = a.as_ptr().cast::<i64>();
        // SAFETY: `a` holds 16 u64, two registers of 8.
        unsafe { U64x16([_mm512_loadu_epi64(p), _mm512_loadu_epi64(p.add(8))]) }
    }
    /// Sixteen consecutive rays in lanes, field by field: o.x, o.y, o.z, d.x, d.y, d.z, tmin,
    /// tmax (tier A's 16-ray packets). Moves only: eight 64-byte loads (rays 2k and 2k + 1 each,
    /// a `Ray` being eight f32s, asserted in `avx2.rs`), the 4×4 transposes of
    /// [`super::F32x8::transpose8`] within each 128-bit lane, then one two-source permute per
    /// field that puts the rays back in order.
    #[inline(always)]
    pub fn ray_fields16(self, rays: &[crate::geometry::Ray; 16]) -> [F32x16; 8] {
        let p = rays.as_ptr().cast::<f32>();
        // SAFETY: the token proves AVX-512F; `rays` is 16 × 8 initialised f32s without padding,
        // so load k reads floats 16k .. 16k + 16, inside it.
        unsafe {
            let v: [__m512; 8] = core::array::from_fn(|k| _mm512_loadu_ps(p.add(16 * k)));
            fields_of_pairs16(v)
        }
    }
    /// A mask from sixteen booleans: one 16-byte load and a byte test (`vptestmb`), not 16
    /// booleans widened to `i32` lanes.
    #[inline(always)]
    pub fn mask(self, a: &[bool; 16]) -> M16 {
        // SAFETY: the token proves AVX-512BW and VL (`Avx512::detect`); the load reads the 16
        // bytes of `a`, each 0 or 1 (a `bool`), so the test sets bit k exactly where `a[k]`.
        M16(unsafe {
            let b = _mm_loadu_si128(a.as_ptr().cast());
            _mm_test_epi8_mask(b, b)
        })
    }
}

#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx2,fma")]
fn run_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`Lane::outlined`] at width 16: as [`run_avx512`], never inlined.
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx2,fma")]
#[inline(never)]
fn outlined_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

impl F32x16 {
    #[inline(always)]
    pub fn to_array(self) -> [f32; 16] {
        let mut a = [0.0f32; 16];
        // SAFETY: an F32x16 exists only with AVX-512F (module doc); `a` holds 16 floats.
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    pub fn store(self, out: &mut [f32; 16]) {
        unsafe { _mm512_storeu_ps(out.as_mut_ptr(), self.0) };
    }
}

impl I32x16 {
    #[inline(always)]
    pub fn to_array(self) -> [i32; 16] {
        let mut a = [0i32; 16];
        unsafe { _mm512_storeu_epi32(a.as_mut_ptr(), self.0) };
        a
    }
}

impl U64x16 {
    #[inline(always)]
    pub fn to_array(self) -> [u64; 16] {
        let mut a = [0u64; 16];
        let p = a.as_mut_ptr().cast::<i64>();
        unsafe {
            _mm512_storeu_epi64(p, self.0[0]);
            _mm512_storeu_epi64(p.add(8), self.0[1]);
        }
        a
    }
}

impl M16 {
    #[inline(always)]
    pub fn to_array(self) -> [bool; 16] {
        super::bits::bools16(self.0 as u32)
    }
    /// The lanes as the low 16 bits of a number (bit `i` for lane `i`), as [`super::M8::bits`].
    #[inline(always)]
    pub fn bits(self) -> u32 {
        self.0 as u32
    }
}

impl fmt::Debug for F32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x16{:?}", self.to_array())
    }
}
impl fmt::Debug for I32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x16{:?}", self.to_array())
    }
}
impl fmt::Debug for U64x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "U64x16{:?}", self.to_array())
    }
}
impl fmt::Debug for M16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M16{:?}", self.to_array())
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $intr:ident) => {
        impl $tr for F32x16 {
            type Output = F32x16;
            #[inline(always)]
            fn $f(self, o: F32x16) -> F32x16 {
                // SAFETY: an F32x16 exists only with AVX-512F (module doc).
                F32x16(unsafe { $intr(self.0, o.0) })
            }
        }
    };
}
binop!(Add, add, _mm512_add_ps);
binop!(Sub, sub, _mm512_sub_ps);
binop!(Mul, mul, _mm512_mul_ps);
binop!(Div, div, _mm512_div_ps);

impl Neg for F32x16 {
    type Output = F32x16;
    #[inline(always)]
    fn neg(self) -> F32x16 {
        // Flips the sign bit only (NaN stays NaN), as `-x` at width 1.
        F32x16(unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(self.0),
                _mm512_set1_epi32(i32::MIN),
            ))
        })
    }
}

impl BitAnd for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitand(self, o: M16) -> M16 {
        M16(self.0 & o.0)
    }
}
impl BitOr for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitor(self, o: M16) -> M16 {
        M16(self.0 | o.0)
    }
}
impl BitXor for M16 {
    type Output = M16;
    #[inline(always)]
    fn bitxor(self, o: M16) -> M16 {
        M16(self.0 ^ o.0)
    }
}
impl Not for M16 {
    type Output = M16;
    #[inline(always)]
    fn not(self) -> M16 {
        M16(!self.0)
    }
}

impl LaneMask for M16 {
    #[inline(always)]
    fn any(self) -> bool {
        self.0 != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.0 == u16::MAX
    }
}

macro_rules! cmp {
    ($f:ident, $imm:ident) => {
        #[inline(always)]
        fn $f(self, o: F32x16) -> M16 {
            M16(unsafe { _mm512_cmp_ps_mask::<$imm>(self.0, o.0) })
        }
    };
}

/// A shift count as the low quadword of an `xmm` register (`vpsllX zmm, zmm, xmm`).
#[inline(always)]
fn count(n: i32) -> __m128i {
    // SAFETY: SSE2 is part of x86-64.
    unsafe { _mm_cvtsi32_si128(n) }
}

impl Lane for F32x16 {
    type Mask = M16;
    type I32 = I32x16;
    type U64 = U64x16;
    const WIDTH: usize = 16;

    #[inline(always)]
    fn outlined<R>(self, f: impl FnOnce() -> R) -> R {
        // SAFETY: an F32x16 exists only where the AVX-512 features are on (module doc).
        unsafe { outlined_avx512(f) }
    }

    #[inline(always)]
    fn splat(self, c: f32) -> F32x16 {
        F32x16(unsafe { _mm512_set1_ps(c) })
    }
    #[inline(always)]
    fn sqrt(self) -> F32x16 {
        F32x16(unsafe { _mm512_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn mul_add(self, a: F32x16, b: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_fmadd_ps(self.0, a.0, b.0) })
    }
    #[inline(always)]
    fn min(self, o: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: F32x16) -> F32x16 {
        F32x16(unsafe { _mm512_max_ps(self.0, o.0) })
    }
    cmp!(eq, _CMP_EQ_OQ);
    cmp!(ne, _CMP_NEQ_UQ);
    cmp!(lt, _CMP_LT_OQ);
    cmp!(le, _CMP_LE_OQ);
    cmp!(gt, _CMP_GT_OQ);
    cmp!(ge, _CMP_GE_OQ);
    #[inline(always)]
    fn select(m: M16, a: F32x16, b: F32x16) -> F32x16 {
        // vblendmps takes the second operand where the mask is set.
        F32x16(unsafe { _mm512_mask_blend_ps(m.0, b.0, a.0) })
    }
    #[inline(always)]
    fn to_bits(self) -> I32x16 {
        I32x16(unsafe { _mm512_castps_si512(self.0) })
    }
    #[inline(always)]
    fn from_bits(b: I32x16) -> F32x16 {
        F32x16(unsafe { _mm512_castsi512_ps(b.0) })
    }
    #[inline(always)]
    fn round_i32(self) -> I32x16 {
        I32x16(unsafe { _mm512_cvtps_epi32(self.0) })
    }
    #[inline(always)]
    fn trunc_i32(self) -> I32x16 {
        I32x16(unsafe { _mm512_cvttps_epi32(self.0) })
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[f32; N], idx: I32x16) -> F32x16 {
        const { assert!(N >= 1 && N <= i32::MAX as usize) };
        // SAFETY: an I32x16 exists only with AVX-512F; after the unsigned clamp every index is
        // below N, so each of the 16 loads reads inside `table`.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(N as i32 - 1));
            F32x16(_mm512_i32gather_ps::<4>(i, table.as_ptr()))
        }
    }
    #[inline(always)]
    fn gather_slice(table: &[f32], idx: I32x16) -> F32x16 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x16 exists only with AVX-512F; after the unsigned clamp every index is
        // below len, so each of the 16 loads reads inside `table`.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(table.len() as i32 - 1));
            F32x16(_mm512_i32gather_ps::<4>(i, table.as_ptr()))
        }
    }
    #[inline(always)]
    fn gather3(table: &[glam::Vec3], idx: I32x16) -> [F32x16; 3] {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize / 3);
        // SAFETY: as `avx2.rs` (`glam::Vec3` is three consecutive f32, asserted there); after
        // the unsigned clamp r < len and 3r + 2 < 3·len ≤ i32::MAX, so each load reads inside
        // `table`.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(table.len() as i32 - 1));
            let i3 = _mm512_add_epi32(_mm512_add_epi32(i, i), i);
            let base = table.as_ptr().cast::<f32>();
            [
                F32x16(_mm512_i32gather_ps::<4>(i3, base)),
                F32x16(_mm512_i32gather_ps::<4>(i3, base.add(1))),
                F32x16(_mm512_i32gather_ps::<4>(i3, base.add(2))),
            ]
        }
    }
}

impl LaneI32 for I32x16 {
    type F = F32x16;
    type Mask = M16;
    #[inline(always)]
    fn gather_u32(table: &[u32], idx: I32x16) -> I32x16 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x16 exists only with AVX-512F; after the unsigned clamp every index is
        // below len, so each 4-byte load reads one entry of `table`.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(table.len() as i32 - 1));
            I32x16(_mm512_i32gather_epi32::<4>(i, table.as_ptr().cast::<i32>()))
        }
    }
    #[inline(always)]
    fn gather_bytes4(table: &[[u8; 4]], idx: I32x16) -> I32x16 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x16 exists only with AVX-512F; after the unsigned clamp every index is
        // below len, so each 4-byte load reads one entry of `table` (little-endian, as width 1).
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(table.len() as i32 - 1));
            I32x16(_mm512_i32gather_epi32::<4>(i, table.as_ptr().cast::<i32>()))
        }
    }
    #[inline(always)]
    fn splat(self, c: i32) -> I32x16 {
        I32x16(unsafe { _mm512_set1_epi32(c) })
    }
    #[inline(always)]
    fn add(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_add_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn sub(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_sub_epi32(self.0, o.0) })
    }
    #[inline(always)]
    fn and(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_and_si512(self.0, o.0) })
    }
    #[inline(always)]
    fn andnot(self, o: I32x16) -> I32x16 {
        // vpandnd computes !first & second.
        I32x16(unsafe { _mm512_andnot_si512(o.0, self.0) })
    }
    #[inline(always)]
    fn or(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_or_si512(self.0, o.0) })
    }
    #[inline(always)]
    fn xor(self, o: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_xor_si512(self.0, o.0) })
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> I32x16 {
        I32x16(unsafe { _mm512_sll_epi32(self.0, count(N)) })
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> I32x16 {
        I32x16(unsafe { _mm512_srl_epi32(self.0, count(N)) })
    }
    #[inline(always)]
    fn sar<const N: i32>(self) -> I32x16 {
        I32x16(unsafe { _mm512_sra_epi32(self.0, count(N)) })
    }
    #[inline(always)]
    fn rotate_right(self, r: I32x16) -> I32x16 {
        // vprorvd rotates by the count modulo 32, as `u32::rotate_right(r & 31)`.
        I32x16(unsafe { _mm512_rorv_epi32(self.0, r.0) })
    }
    #[inline(always)]
    fn eq(self, o: I32x16) -> M16 {
        M16(unsafe { _mm512_cmpeq_epi32_mask(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: I32x16) -> M16 {
        M16(unsafe { _mm512_cmpgt_epi32_mask(self.0, o.0) })
    }
    #[inline(always)]
    fn select(m: M16, a: I32x16, b: I32x16) -> I32x16 {
        I32x16(unsafe { _mm512_mask_blend_epi32(m.0, b.0, a.0) })
    }
    #[inline(always)]
    fn to_f32(self) -> F32x16 {
        F32x16(unsafe { _mm512_cvtepi32_ps(self.0) })
    }
    #[inline(always)]
    fn lane(self, i: usize) -> i32 {
        self.to_array()[i]
    }
}

impl LaneU64 for U64x16 {
    type I32 = I32x16;
    #[inline(always)]
    fn splat(self, c: u64) -> U64x16 {
        let v = unsafe { _mm512_set1_epi64(c as i64) };
        U64x16([v, v])
    }
    #[inline(always)]
    fn add(self, o: U64x16) -> U64x16 {
        unsafe {
            U64x16([
                _mm512_add_epi64(self.0[0], o.0[0]),
                _mm512_add_epi64(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn mul(self, o: U64x16) -> U64x16 {
        // SAFETY: the token proves AVX-512DQ (vpmullq: the low 64 bits of the product).
        unsafe {
            U64x16([
                _mm512_mullo_epi64(self.0[0], o.0[0]),
                _mm512_mullo_epi64(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn xor(self, o: U64x16) -> U64x16 {
        unsafe {
            U64x16([
                _mm512_xor_si512(self.0[0], o.0[0]),
                _mm512_xor_si512(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn or(self, o: U64x16) -> U64x16 {
        unsafe {
            U64x16([
                _mm512_or_si512(self.0[0], o.0[0]),
                _mm512_or_si512(self.0[1], o.0[1]),
            ])
        }
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> U64x16 {
        unsafe {
            U64x16([
                _mm512_sll_epi64(self.0[0], count(N)),
                _mm512_sll_epi64(self.0[1], count(N)),
            ])
        }
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> U64x16 {
        unsafe {
            U64x16([
                _mm512_srl_epi64(self.0[0], count(N)),
                _mm512_srl_epi64(self.0[1], count(N)),
            ])
        }
    }
    #[inline(always)]
    fn low_u32(self) -> I32x16 {
        // vpmovqd truncates each quadword to its low doubleword.
        unsafe {
            let a = _mm512_cvtepi64_epi32(self.0[0]);
            let b = _mm512_cvtepi64_epi32(self.0[1]);
            I32x16(_mm512_inserti64x4::<1>(_mm512_castsi256_si512(a), b))
        }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> u64 {
        self.to_array()[i]
    }
}

impl Avx512 {
    /// Sixteen rays from their fields in lanes (o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax): the
    /// inverse of [`Avx512::ray_fields16`] (moves only: each ray's fields are its lane's bits).
    #[inline(always)]
    pub fn ray_rows16(self, f: [F32x16; 8]) -> [crate::geometry::Ray; 16] {
        let mut out = core::mem::MaybeUninit::<[crate::geometry::Ray; 16]>::uninit();
        // SAFETY: the token proves AVX-512F and DQ (`Avx512::run`'s features); a `Ray` is
        // eight f32s without padding (asserted in `avx2.rs`), so `rows16`'s 16 runs of 8
        // floats initialise every ray of `out`, all of whose bit patterns are valid `f32`s.
        unsafe {
            rows16(f, out.as_mut_ptr().cast::<f32>());
            out.assume_init()
        }
    }

    /// Sixteen lanes' rows of 8 floats from 8 fields in lanes: row `k` is lane `k` of each
    /// field, in order (moves only; [`Avx512::ray_rows16`]'s transpose, for rows of other
    /// structures: the stream kernels' path states).
    #[inline(always)]
    pub fn rows8_16(self, f: [F32x16; 8]) -> [[f32; 8]; 16] {
        let mut out = [[0.0f32; 8]; 16];
        // SAFETY: the token proves AVX-512F and DQ; `out` is 16 × 8 floats.
        unsafe { rows16(f, out.as_mut_ptr().cast::<f32>()) };
        out
    }
}

/// The 4×4 transposes of [`super::F32x8::transpose8`] within each 128-bit lane of 8 rows
/// (unpacks, then shuffles): element j of each 128-bit lane of rows 0–3 in `u[j]`, of rows
/// 4–7 in `u[4 + j]`. Moves only. Shared by [`Avx512::ray_fields16`] and `rows16`.
///
/// # Safety
/// AVX-512F must be available.
#[inline(always)]
unsafe fn quads16(v: [__m512; 8]) -> [__m512; 8] {
    let t0 = _mm512_unpacklo_ps(v[0], v[1]);
    let t1 = _mm512_unpackhi_ps(v[0], v[1]);
    let t2 = _mm512_unpacklo_ps(v[2], v[3]);
    let t3 = _mm512_unpackhi_ps(v[2], v[3]);
    let t4 = _mm512_unpacklo_ps(v[4], v[5]);
    let t5 = _mm512_unpackhi_ps(v[4], v[5]);
    let t6 = _mm512_unpacklo_ps(v[6], v[7]);
    let t7 = _mm512_unpackhi_ps(v[6], v[7]);
    [
        _mm512_shuffle_ps::<0x44>(t0, t2),
        _mm512_shuffle_ps::<0xee>(t0, t2),
        _mm512_shuffle_ps::<0x44>(t1, t3),
        _mm512_shuffle_ps::<0xee>(t1, t3),
        _mm512_shuffle_ps::<0x44>(t4, t6),
        _mm512_shuffle_ps::<0xee>(t4, t6),
        _mm512_shuffle_ps::<0x44>(t5, t7),
        _mm512_shuffle_ps::<0xee>(t5, t7),
    ]
}

/// The 8 fields in lanes of 16 rays held two per register (`v[k]`: ray 2k's 8 floats, then
/// ray 2k + 1's): [`Avx512::ray_fields16`]'s transpose.
///
/// # Safety
/// AVX-512F must be available.
#[inline(always)]
unsafe fn fields_of_pairs16(v: [__m512; 8]) -> [F32x16; 8] {
    // Per 128-bit lane L of row k (L0: ray 2k fields 0–3, L1: its fields 4–7, L2 and
    // L3: ray 2k + 1's), as in `transpose8`: u[j] holds element j of each lane of rows
    // 0–3, u[4 + j] of rows 4–7.
    let u = quads16(v);
    // Field j of ray 2i is u[j]'s element i (lane L0), of ray 2i + 1 its element 8 + i
    // (lane L2); rays 8–15 likewise in u[4 + j] (indices 16 up); fields 4–7 are 4
    // elements further (lanes L1 and L3).
    let lo = _mm512_setr_epi32(0, 8, 1, 9, 2, 10, 3, 11, 16, 24, 17, 25, 18, 26, 19, 27);
    let hi = _mm512_add_epi32(lo, _mm512_set1_epi32(4));
    [
        F32x16(_mm512_permutex2var_ps(u[0], lo, u[4])),
        F32x16(_mm512_permutex2var_ps(u[1], lo, u[5])),
        F32x16(_mm512_permutex2var_ps(u[2], lo, u[6])),
        F32x16(_mm512_permutex2var_ps(u[3], lo, u[7])),
        F32x16(_mm512_permutex2var_ps(u[0], hi, u[4])),
        F32x16(_mm512_permutex2var_ps(u[1], hi, u[5])),
        F32x16(_mm512_permutex2var_ps(u[2], hi, u[6])),
        F32x16(_mm512_permutex2var_ps(u[3], hi, u[7])),
    ]
}

/// Writes lane `r` of the 8 fields `f` as floats `8r .. 8r + 8` from `p`, for r in 0..16. The
/// 4×4 transposes of [`super::F32x8::transpose8`] within each 128-bit lane give, in 128-bit
/// lane L of `u[m]`, fields 0–3 of row 4L + m (`u[4 + m]`: its fields 4–7); one two-source
/// permute per pair of rows joins the halves, and each 256-bit half is one row.
///
/// # Safety
/// AVX-512F and DQ must be available, and `p` valid for writes of 128 floats.
#[inline(always)]
unsafe fn rows16(f: [F32x16; 8], p: *mut f32) {
    let v = [
        f[0].0, f[1].0, f[2].0, f[3].0, f[4].0, f[5].0, f[6].0, f[7].0,
    ];
    let u = quads16(v);
    // Rows m and 4 + m (128-bit lanes 0 and 1), then 8 + m and 12 + m (lanes 2, 3).
    let lo = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 4, 5, 6, 7, 20, 21, 22, 23);
    let hi = _mm512_add_epi32(lo, _mm512_set1_epi32(8));
    for m in 0..4 {
        let a = _mm512_permutex2var_ps(u[m], lo, u[4 + m]);
        let b = _mm512_permutex2var_ps(u[m], hi, u[4 + m]);
        _mm256_storeu_ps(p.add(8 * m), _mm512_castps512_ps256(a));
        _mm256_storeu_ps(p.add(8 * (4 + m)), _mm512_extractf32x8_ps::<1>(a));
        _mm256_storeu_ps(p.add(8 * (8 + m)), _mm512_castps512_ps256(b));
        _mm256_storeu_ps(p.add(8 * (12 + m)), _mm512_extractf32x8_ps::<1>(b));
    }
}

impl super::pcg::PcgOps<I32x16> for U64x16 {
    #[inline(always)]
    fn gather_u64(table: &[u64], idx: I32x16) -> U64x16 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        // SAFETY: an I32x16 exists only with AVX-512; after the unsigned clamp every index is
        // below len, so each of the 16 loads (`vpgatherdq`, eight per half) reads inside `table`.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(table.len() as i32 - 1));
            let p = table.as_ptr().cast::<i64>();
            U64x16([
                _mm512_i32gather_epi64::<8>(_mm512_castsi512_si256(i), p),
                _mm512_i32gather_epi64::<8>(_mm512_extracti64x4_epi64::<1>(i), p),
            ])
        }
    }
    #[inline(always)]
    fn xsh_rr(self) -> I32x16 {
        // SAFETY: a U64x16 exists only with AVX-512.
        unsafe {
            // x = ((s >> 18) ^ s) >> 27 per 64-bit lane: its low word is the xorshifted
            // output, its high word s >> 59, the rotation (as in `avx2.rs`).
            let a = self.0[0];
            let a = _mm512_srl_epi64(
                _mm512_xor_si512(_mm512_srl_epi64(a, count(18)), a),
                count(27),
            );
            let b = self.0[1];
            let b = _mm512_srl_epi64(
                _mm512_xor_si512(_mm512_srl_epi64(b, count(18)), b),
                count(27),
            );
            // vpermt2d: the low (even) or the high (odd) words of both registers, in lane order.
            let even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
            let odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
            let lo = _mm512_permutex2var_epi32(a, even, b);
            let rot = _mm512_permutex2var_epi32(a, odd, b);
            // vprorvd rotates by the count modulo 32 (rot < 32).
            I32x16(_mm512_rorv_epi32(lo, rot))
        }
    }
}

impl super::LaneLookup<F32x16> for I32x16 {
    #[inline(always)]
    fn lookup8(table: &[f32; 8], idx: I32x16) -> F32x16 {
        // SAFETY: an I32x16 exists only with AVX-512; the load reads the 8 floats of `table`,
        // and after the clamp vpermps reads only those (the upper half of the register is never
        // selected).
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(7));
            let t = _mm512_castps256_ps512(_mm256_loadu_ps(table.as_ptr()));
            F32x16(_mm512_permutexvar_ps(i, t))
        }
    }
}

impl Avx512 {
    /// A mask from the low sixteen bits of `bits` (lane `k` set when bit `k` is; the inverse
    /// of [`M16::bits`]): a move to a mask register, no per-lane work.
    #[inline(always)]
    pub fn mask_bits(self, bits: u32) -> M16 {
        M16(bits as u16)
    }

    // Added in the twenty-sixth session (h2).

    /// Per lane `k`, from the last lane to the first, `table[idx[k]] = new[k]` where `on`,
    /// else `old[k]` (where an index repeats, the lowest lane's value is left), as
    /// [`super::Avx2::store_u64_at`]: one range test in lanes, two blends, then a store per
    /// lane.
    ///
    /// # Panics
    /// If an index (as `u32`) is not below `table.len()`, before any store.
    #[inline(always)]
    pub fn store_u64_at(self, table: &mut [u64], idx: I32x16, on: M16, new: U64x16, old: U64x16) {
        assert!(!table.is_empty(), "store_u64_at: an empty table");
        let last = table.len().min(u32::MAX as usize) as u32 - 1;
        let mut ix = [0u32; 16];
        let mut v = [0u64; 16];
        // SAFETY: the token proves AVX-512 F. The stores write the locals `ix` and `v`.
        let fits = unsafe {
            let fits = _mm512_cmple_epu32_mask(idx.0, _mm512_set1_epi32(last as i32));
            let v0 = _mm512_mask_blend_epi64(on.0 as u8, old.0[0], new.0[0]);
            let v1 = _mm512_mask_blend_epi64((on.0 >> 8) as u8, old.0[1], new.0[1]);
            _mm512_storeu_si512(ix.as_mut_ptr().cast(), idx.0);
            _mm512_storeu_si512(v.as_mut_ptr().cast(), v0);
            _mm512_storeu_si512(v.as_mut_ptr().add(8).cast(), v1);
            fits
        };
        assert!(fits == 0xffff, "store_u64_at: an index out of range");
        let p = table.as_mut_ptr();
        // SAFETY: every index is at most `last` < `table.len()` (tested above).
        unsafe {
            for k in (0..16).rev() {
                *p.add(ix[k] as usize) = v[k];
            }
        }
    }

    // The thirty-first session's h1 block.

    /// [`Self::ray_fields16`] of the 16 rays `ray(0)`, … `ray(15)`, each read where it lies
    /// (one 32-byte load per ray, two joined per register): tier A's 16-ray packets read the
    /// stream renderer's rays in place, through its ids, instead of copying them into a
    /// packet first. The same lanes as `ray_fields16` of the rays copied.
    #[inline(always)]
    pub fn ray_fields16_at<'r>(
        self,
        ray: impl Fn(usize) -> &'r crate::geometry::Ray,
    ) -> [F32x16; 8] {
        let row = |k: usize| {
            let r: *const crate::geometry::Ray = ray(k);
            r.cast::<f32>()
        };
        // SAFETY: the token proves AVX-512F and DQ. A `Ray` is eight f32s, o.x … tmax, without
        // padding (asserted in `avx2.rs`), all initialised, so each 32-byte load reads exactly
        // one ray.
        unsafe {
            let v: [__m512; 8] = core::array::from_fn(|k| {
                let a = _mm512_castps256_ps512(_mm256_loadu_ps(row(2 * k)));
                _mm512_insertf32x8::<1>(a, _mm256_loadu_ps(row(2 * k + 1)))
            });
            fields_of_pairs16(v)
        }
    }
}

// The forty-third session's h1 block: the gather stage's one-mesh chunks 16 wide
// (`stream::kernels::surface`).

impl Avx512 {
    /// `b` in every lane of a mask (a chunk-wide flag), as [`super::Avx2::mask_splat`].
    #[inline(always)]
    pub fn mask_splat(self, b: bool) -> M16 {
        M16(if b { u16::MAX } else { 0 })
    }

    /// `table[min(idx as u32, 15)]` per lane: one `vpermps` over the 16 floats (the 16-wide
    /// form of [`super::Avx2::lookup16`], which needs two and a blend; the same entries).
    #[inline(always)]
    pub fn lookup16(self, table: &[f32; 16], idx: I32x16) -> F32x16 {
        // SAFETY: the token proves AVX-512F; the load reads the 16 floats of `table`, and
        // after the clamp every index selects one of them.
        unsafe {
            let i = _mm512_min_epu32(idx.0, _mm512_set1_epi32(15));
            F32x16(_mm512_permutexvar_ps(i, _mm512_loadu_ps(table.as_ptr())))
        }
    }

    /// Sixteen rows of 8 words in lanes: lane `k` of field `j` is word `j` of `row(k)`, its
    /// bits as a float (the gather stage's hit rows, `accel::HitRow`). Moves only: one 32-byte
    /// load per row, two joined per register, then [`Self::ray_fields16`]'s transposes.
    #[inline(always)]
    pub fn words16_at<'r>(self, row: impl Fn(usize) -> &'r [u32; 8]) -> [F32x16; 8] {
        // SAFETY: the token proves AVX-512F and DQ; each 32-byte load reads the 8 words of
        // one row.
        unsafe {
            let mut v = [_mm512_setzero_ps(); 8];
            for (k, x) in v.iter_mut().enumerate() {
                let a = _mm512_castps256_ps512(_mm256_loadu_ps(row(2 * k).as_ptr().cast()));
                *x = _mm512_insertf32x8::<1>(a, _mm256_loadu_ps(row(2 * k + 1).as_ptr().cast()));
            }
            fields_of_pairs16(v)
        }
    }

    /// The rows of 8 fields `f` of 16 lanes, two to a register: `out[k]` holds lane `k`'s row
    /// (field 0 first) in its low 256 bits and lane `k + 8`'s in its high 256 bits, for rows
    /// that lie apart ([`F32x16::store_low8`], [`F32x16::store_high8`]; the gather stage's
    /// surface rows). Moves only: `rows16`'s transposes, its permutes pairing other rows.
    #[inline(always)]
    pub fn row_pairs16(self, f: [F32x16; 8]) -> [F32x16; 8] {
        let v = [
            f[0].0, f[1].0, f[2].0, f[3].0, f[4].0, f[5].0, f[6].0, f[7].0,
        ];
        // SAFETY: the token proves AVX-512F.
        unsafe {
            // Row 4L + m: fields 0–3 in 128-bit lane L of u[m], fields 4–7 in that of u[4 + m]
            // (`rows16`). Rows m and 8 + m are lanes 0 and 2, rows 4 + m and 12 + m lanes 1, 3.
            let u = quads16(v);
            let lo = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
            let hi = _mm512_add_epi32(lo, _mm512_set1_epi32(4));
            [
                F32x16(_mm512_permutex2var_ps(u[0], lo, u[4])),
                F32x16(_mm512_permutex2var_ps(u[1], lo, u[5])),
                F32x16(_mm512_permutex2var_ps(u[2], lo, u[6])),
                F32x16(_mm512_permutex2var_ps(u[3], lo, u[7])),
                F32x16(_mm512_permutex2var_ps(u[0], hi, u[4])),
                F32x16(_mm512_permutex2var_ps(u[1], hi, u[5])),
                F32x16(_mm512_permutex2var_ps(u[2], hi, u[6])),
                F32x16(_mm512_permutex2var_ps(u[3], hi, u[7])),
            ]
        }
    }
}

impl F32x16 {
    /// Lanes 0–7 into `out` (one 32-byte store).
    #[inline(always)]
    pub fn store_low8(self, out: &mut [f32; 8]) {
        // SAFETY: an F32x16 exists only with AVX-512F (module doc); `out` holds 8 floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), _mm512_castps512_ps256(self.0)) };
    }
    /// Lanes 8–15 into `out` (an extract and one 32-byte store).
    #[inline(always)]
    pub fn store_high8(self, out: &mut [f32; 8]) {
        // SAFETY: an F32x16 exists only with the token's features, AVX-512DQ among them;
        // `out` holds 8 floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), _mm512_extractf32x8_ps::<1>(self.0)) };
    }
}
