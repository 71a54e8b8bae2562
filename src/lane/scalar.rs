//! Width 1: [`Lane`] for `f32` (masks `bool`, integers `i32`/`u64`). Each operation is the
//! scalar twin of the AVX2 one in `avx2.rs`, with the same x86 semantics for min/max and
//! float→integer conversion, so generic code gives the same bits at both widths.

use super::{Lane, LaneI32, LaneMask, LaneU64};

impl LaneMask for bool {
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
}

impl Lane for f32 {
    type Mask = bool;
    type I32 = i32;
    type U64 = u64;
    const WIDTH: usize = 1;

    /// Inlined as written: the scalar code has no piece large enough to need it.
    #[inline(always)]
    fn outlined<R>(self, f: impl FnOnce() -> R) -> R {
        f()
    }

    #[inline(always)]
    fn splat(self, c: f32) -> f32 {
        c
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn mul_add(self, a: f32, b: f32) -> f32 {
        f32::mul_add(self, a, b)
    }
    #[inline(always)]
    fn min(self, o: f32) -> f32 {
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn to_bits(self) -> i32 {
        f32::to_bits(self) as i32
    }
    #[inline(always)]
    fn from_bits(b: i32) -> f32 {
        f32::from_bits(b as u32)
    }
    #[inline(always)]
    fn round_i32(self) -> i32 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE is part of the x86-64 baseline.
            unsafe { core::arch::x86_64::_mm_cvtss_si32(core::arch::x86_64::_mm_set_ss(self)) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            if self.abs() < 2_147_483_648.0 {
                self.round_ties_even() as i32
            } else {
                i32::MIN
            }
        }
    }
    #[inline(always)]
    fn trunc_i32(self) -> i32 {
        if f32::abs(self) < 2_147_483_648.0 {
            self as i32
        } else {
            i32::MIN
        }
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn gather<const N: usize>(table: &[f32; N], idx: i32) -> f32 {
        const { assert!(N >= 1 && N <= i32::MAX as usize) };
        table[(idx as u32).min(N as u32 - 1) as usize]
    }
    #[inline(always)]
    fn gather3(table: &[glam::Vec3], idx: i32) -> [f32; 3] {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize / 3);
        table[(idx as u32).min(table.len() as u32 - 1) as usize].to_array()
    }
    #[inline(always)]
    fn gather_slice(table: &[f32], idx: i32) -> f32 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        table[(idx as u32).min(table.len() as u32 - 1) as usize]
    }
}

impl LaneI32 for i32 {
    type F = f32;
    type Mask = bool;
    #[inline(always)]
    fn gather_bytes4(table: &[[u8; 4]], idx: i32) -> i32 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        i32::from_le_bytes(table[(idx as u32).min(table.len() as u32 - 1) as usize])
    }
    #[inline(always)]
    fn gather_u32(table: &[u32], idx: i32) -> i32 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize);
        table[(idx as u32).min(table.len() as u32 - 1) as usize] as i32
    }
    #[inline(always)]
    fn splat(self, c: i32) -> i32 {
        c
    }
    #[inline(always)]
    fn add(self, o: i32) -> i32 {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn sub(self, o: i32) -> i32 {
        self.wrapping_sub(o)
    }
    #[inline(always)]
    fn and(self, o: i32) -> i32 {
        self & o
    }
    #[inline(always)]
    fn andnot(self, o: i32) -> i32 {
        self & !o
    }
    #[inline(always)]
    fn or(self, o: i32) -> i32 {
        self | o
    }
    #[inline(always)]
    fn xor(self, o: i32) -> i32 {
        self ^ o
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> i32 {
        ((self as u32) << N) as i32
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> i32 {
        ((self as u32) >> N) as i32
    }
    #[inline(always)]
    fn sar<const N: i32>(self) -> i32 {
        self >> N
    }
    #[inline(always)]
    fn rotate_right(self, r: i32) -> i32 {
        (self as u32).rotate_right(r as u32 & 31) as i32
    }
    #[inline(always)]
    fn eq(self, o: i32) -> bool {
        self == o
    }
    #[inline(always)]
    fn gt(self, o: i32) -> bool {
        self > o
    }
    #[inline(always)]
    fn select(m: bool, a: i32, b: i32) -> i32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> i32 {
        self
    }
}

impl LaneU64 for u64 {
    type I32 = i32;
    #[inline(always)]
    fn splat(self, c: u64) -> u64 {
        c
    }
    #[inline(always)]
    fn add(self, o: u64) -> u64 {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn mul(self, o: u64) -> u64 {
        self.wrapping_mul(o)
    }
    #[inline(always)]
    fn xor(self, o: u64) -> u64 {
        self ^ o
    }
    #[inline(always)]
    fn or(self, o: u64) -> u64 {
        self | o
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> u64 {
        self << N
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> u64 {
        self >> N
    }
    #[inline(always)]
    fn low_u32(self) -> i32 {
        self as u32 as i32
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> u64 {
        self
    }
}

impl super::pcg::PcgOps<i32> for u64 {
    #[inline(always)]
    fn gather_u64(table: &[u64], idx: i32) -> u64 {
        table[(idx as u32 as usize).min(table.len() - 1)]
    }
    #[inline(always)]
    fn xsh_rr(self) -> i32 {
        let xorshifted = (((self >> 18) ^ self) >> 27) as u32;
        xorshifted.rotate_right((self >> 59) as u32) as i32
    }
}

impl super::LaneLookup<f32> for i32 {
    #[inline(always)]
    fn lookup8(table: &[f32; 8], idx: i32) -> f32 {
        table[(idx as u32).min(7) as usize]
    }
}
