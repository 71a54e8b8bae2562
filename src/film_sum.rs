//! Exact, order-independent sums of f32 film contributions: fixed-point integers.
//!
//! Why: a pixel's sums (Σw·v, Σw, …) receive contributions from samples of several pixels, and a
//! split render (blocks, threads, crops of a farm, sample ranges `[0, a) + [a, n)`) adds them in
//! different groupings. Floating-point addition is not associative, so the groupings differ in
//! their last bits (~6e-7 on 16-pixel block borders). Every contribution is therefore rounded
//! once, on its own, to an integer multiple of 2⁻⁶⁴ held in an `i128`; integer addition is
//! associative and commutative, so any grouping of the same contributions gives the same bits.
//!
//! Range and precision: an addend is exact when its magnitude is at least 2⁻⁴¹ (an f32 has 24
//! significant bits, and the grid is 2⁻⁶⁴); smaller addends are rounded to the grid (half away
//! from zero), an absolute error below 2.8e-20. An addend is clamped to ±2⁶² (4.6e18). First
//! moments (Σw·v) are added with wrapping arithmetic, which is associative in all cases and exact
//! while the true total stays within ±2⁶³ (9.2e18). Second moments and weights (Σw·v², Σw, Σw²)
//! have non-negative addends and saturate, which is associative for non-negative addends.

/// Fraction bits of the fixed-point grid: values are integers times 2⁻⁶⁴.
pub(crate) const FRAC_BITS: i32 = 64;

/// Largest addend magnitude, 2⁶² in fixed-point units.
const MAX_ADDEND: i128 = 1 << (62 + FRAC_BITS);

/// The fixed-point value of `x`: clamped to ±2⁶² (so ±∞ give the clamp), 0 for NaN. The film
/// records non-finite colour values apart (as flags).
///
/// The common case, 2⁻⁴¹ ≤ |x| < 2⁶² (biased exponent 86..=188), is the 24-bit significand
/// with its sign, shifted; zero is one test more; everything else (tiny and subnormal values
/// that need rounding, the clamp, NaN) is out of line.
#[inline(always)]
pub(crate) fn fixed(x: f32) -> i128 {
    let bits = x.to_bits();
    let e = (bits >> 23) & 0xff;
    // x = ±m · 2^(e − 150), so x · 2⁶⁴ = ±m · 2^(e − 86), with 0 ≤ e − 86 ≤ 102 and m < 2²⁴:
    // below 2¹²⁶ in magnitude, exact. The sign is applied to the 64-bit significand before the
    // shift (a left shift of a two's-complement integer multiplies it by the power of two), so
    // the 128-bit value needs no negation.
    if e.wrapping_sub(86) <= 188 - 86 {
        let m = ((bits & 0x7f_ffff) | 0x80_0000) as i64;
        // 0 for +, −1 for −: (m ^ s) − s is m or −m.
        let s = ((bits as i32) >> 31) as i64;
        (((m ^ s) - s) as i128) << (e - 86)
    } else if bits << 1 == 0 {
        0
    } else {
        fixed_rare(x)
    }
}

/// [`fixed`] outside its common range and not zero: magnitudes below 2⁻⁴¹ (rounded to the
/// grid, half away from zero), the clamp at ±2⁶² and NaN.
#[cold]
#[inline(never)]
fn fixed_rare(x: f32) -> i128 {
    let bits = x.to_bits();
    if bits << 1 == 0 || x.is_nan() {
        return 0;
    }
    let e = ((bits >> 23) & 0xff) as i32;
    let frac = (bits & 0x7f_ffff) as i128;
    // x = m · 2^lsb with m < 2²⁴.
    let (m, lsb) = if e == 0 {
        (frac, -149)
    } else {
        (frac | 0x80_0000, e - 150)
    };
    let shift = lsb + FRAC_BITS;
    let mag = if shift >= 0 {
        if lsb + 24 > 62 {
            MAX_ADDEND
        } else {
            m << shift
        }
    } else {
        let s = -shift; // at most 149 − 64 = 85
        (m + (1i128 << (s - 1))) >> s
    };
    if bits >> 31 != 0 {
        -mag
    } else {
        mag
    }
}

/// The real value of a fixed-point sum, rounded to f64.
#[inline]
pub(crate) fn to_f64(s: i128) -> f64 {
    // i128 → f64 rounds to nearest; the power of two is exact.
    s as f64 * (-FRAC_BITS as f64).exp2()
}

/// Adds a first-moment addend (any sign): wrapping, so associative whatever the values.
#[inline]
pub(crate) fn add_signed(acc: &mut i128, x: i128) {
    *acc = acc.wrapping_add(x);
}

/// Adds a non-negative addend to a non-negative sum (weights, second moments): saturating at
/// `i128::MAX`, which is associative for non-negative addends. Both being non-negative, the
/// wrapped sum is negative exactly when the true sum exceeds `i128::MAX`: one sign test
/// instead of a two-sided saturation. (Part files are checked for negative such sums when
/// read, so the premise holds for every sum.)
#[inline(always)]
pub(crate) fn add_unsigned(acc: &mut i128, x: i128) {
    let s = acc.wrapping_add(x);
    *acc = if s < 0 { i128::MAX } else { s };
}

/// [`add_signed`] on a sum stored biased (s ^ [`LOW_BIAS`], as a film keeps it): unbiased,
/// added and biased again in place, two `xor`s of its low word.
#[inline(always)]
pub(crate) fn add_signed_biased(acc: &mut i128, x: i128) {
    *acc = (*acc ^ LOW_BIAS).wrapping_add(x) ^ LOW_BIAS;
}

/// Adds non-negative addends to non-negative sums stored biased (s ^ [`LOW_BIAS`]), like
/// [`add_unsigned`] on each unbiased pair, with one test for all: only when some wrapped sum is
/// negative are they saturated one by one. The bias leaves bit 127 alone, so a biased sum has
/// the sign of the sum and the test reads the biased values; a saturated sum is stored as
/// `i128::MAX ^ LOW_BIAS`. (In place: unbiasing a pixel's eight sums into a copy and biasing
/// them back cost the scalar box splat 73 instructions a sample, session 19.)
#[inline(always)]
pub(crate) fn add_unsigned_all_biased<const N: usize>(acc: [&mut i128; N], x: [i128; N]) {
    let mut any = 0i128;
    for (a, &v) in acc.iter().zip(&x) {
        any |= (**a ^ LOW_BIAS).wrapping_add(v);
    }
    if any < 0 {
        for (a, v) in acc.into_iter().zip(x) {
            let s = (*a ^ LOW_BIAS).wrapping_add(v);
            *a = if s < 0 { i128::MAX } else { s } ^ LOW_BIAS;
        }
    } else {
        for (a, v) in acc.into_iter().zip(x) {
            *a = (*a ^ LOW_BIAS).wrapping_add(v) ^ LOW_BIAS;
        }
    }
}

/// [`fixed`] of eight values at once (AVX2; call its methods inside
/// [`crate::lane::Avx2::run`]), equal to it bit for bit in every lane: into two columns of a
/// per-lane table ([`Fixed8::into_columns`]) or into registers ([`Fixed8::row`]), as separate
/// low and high 64-bit words ([`crate::lane::Words8`]).
///
/// In the common range the value is the signed significand `sm` (|sm| < 2²⁴) times 2^sh,
/// sh = e − 86 ∈ [0, 102]; its 32-bit word i (bits 32i to 32i + 31) is ⌊sm·2^(sh − 32i)⌋
/// mod 2³²: with d = sh − 32i, `sm << d` for d ≥ 0 (0 from d = 32 on, as the multiple of 2³²
/// it is) and the arithmetic `sm >> −d` for d < 0 (the sign from −d = 32 on). AVX2 has these
/// variable 32-bit shifts (`vpsllvd`, `vpsravd`), so the four words of eight lanes take ~16
/// instructions and a 4×4 transpose joins them; word 0 has d = sh ≥ 0. ±0 and the lanes
/// outside the common range get sm = 0; those outside it and not zero then take [`fixed`]
/// itself, one by one.
///
/// The struct holds the count step 32 in every lane, hidden from the optimiser
/// ([`core::hint::black_box`]: one store and load per [`Fixed8::new`]): words 1 to 3 step
/// their counts d and −d by it. Seeing constants, LLVM folds the steps into six distinct
/// ones (sh − 32i and 32i − sh, i = 1, 2, 3) plus a compare per word, more than the 16
/// registers hold next to a splat's values, and re-broadcast or spilled them in every
/// conversion (session 18's "what is left"); so a splat makes one [`Fixed8`] and converts
/// with it in a loop.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Fixed8 {
    step: crate::lane::I32x8,
}

#[cfg(target_arch = "x86_64")]
impl Fixed8 {
    /// The conversions of one splat (the step hidden from the optimiser).
    #[inline(always)]
    pub(crate) fn new(avx: crate::lane::Avx2) -> Fixed8 {
        Fixed8 {
            step: core::hint::black_box(avx.load_i32(&[32; 8])),
        }
    }

    /// The conversion of a single value vector (the step a plain constant).
    #[inline(always)]
    pub(crate) fn single(avx: crate::lane::Avx2) -> Fixed8 {
        Fixed8 {
            step: avx.load_i32(&[32; 8]),
        }
    }

    /// The four 32-bit words of `fixed(x)` per lane where x is in the common range or ±0, and
    /// the mask of those lanes (where the words are `fixed`'s).
    #[inline(always)]
    fn words(self, x: crate::lane::F32x8) -> ([crate::lane::I32x8; 4], crate::lane::M8) {
        use crate::lane::{I32x8, Lane, LaneI32};
        /// Word i ≥ 1 from its counts d = sh − 32i and n = −d (a function, not a closure: a
        /// closure may be compiled out of line, without AVX2).
        #[inline(always)]
        fn word(sm: I32x8, d: I32x8, n: I32x8) -> I32x8 {
            d.select_neg(sm.sar_var(n), sm.shl_var(d))
        }
        let bits = x.to_bits();
        let sh = bits.shr::<23>().and(bits.splat(0xff)).sub(bits.splat(86));
        // 0 ≤ sh ≤ 102 as an unsigned comparison.
        let common = sh.min_u32(bits.splat(102)).eq(sh);
        let m = bits.and(bits.splat(0x7f_ffff)).or(bits.splat(0x80_0000));
        let s = bits.sar::<31>();
        let sm = I32x8::select(common, m.xor(s).sub(s), bits.splat(0));
        let k = self.step;
        let (d1, n1) = (sh.sub(k), k.sub(sh));
        let (d2, n2) = (d1.sub(k), n1.add(k));
        let (d3, n3) = (d2.sub(k), n2.add(k));
        let words = [
            sm.shl_var(sh),
            word(sm, d1, n1),
            word(sm, d2, n2),
            word(sm, d3, n3),
        ];
        (words, common | x.eq(x.splat(0.0)))
    }

    /// Lane k's `fixed(x[0])` and `fixed(x[1])` to slots `s` and `s + 1` of `out[k]` (two
    /// columns of a per-lane table whose rows are the addends of one pixel as words,
    /// [`crate::lane::Avx2::add_i128x8_biased`]): two conversions, joined by
    /// [`crate::lane::I32x8::join_pair_into`].
    ///
    /// # Panics
    /// If `s` ≥ 7.
    #[inline(always)]
    pub(crate) fn into_columns(
        self,
        x: [crate::lane::F32x8; 2],
        out: &mut [crate::lane::Words8; 8],
        s: usize,
    ) {
        use crate::lane::{I32x8, Lane, LaneMask};
        let (wa, pa) = self.words(x[0]);
        let (wb, pb) = self.words(x[1]);
        I32x8::join_pair_into(wa, wb, out, s);
        if !(pa & pb).all() {
            for (c, (x, p)) in [(x[0], pa), (x[1], pb)].into_iter().enumerate() {
                for (l, p) in p.to_array().into_iter().enumerate() {
                    if !p {
                        let v = fixed(x.lane(l));
                        (out[l][0][s + c], out[l][1][s + c]) = (v as u64, (v >> 64) as u64);
                    }
                }
            }
        }
    }

    /// `fixed` of four columns of eight lanes each as the lanes' rows in registers (value c of
    /// row k is `fixed(x[c])` of lane k: a splat's w·v and w per pixel, what a pixel's first
    /// four sums take; [`crate::lane::I32x8::rows4`]), when every lane of every column is in
    /// the common range or ±0; `None` otherwise (then [`Fixed8::into_columns`], which converts
    /// the other lanes one by one).
    #[inline(always)]
    pub(crate) fn rows4(self, x: [crate::lane::F32x8; 4]) -> Option<[crate::lane::I128x4; 8]> {
        use crate::lane::{I32x8, LaneMask};
        let (w0, p0) = self.words(x[0]);
        let (w1, p1) = self.words(x[1]);
        let (w2, p2) = self.words(x[2]);
        let (w3, p3) = self.words(x[3]);
        (p0 & p1 & p2 & p3)
            .all()
            .then(|| I32x8::rows4([w0, w1, w2, w3]))
    }

    /// [`Fixed8::rows4`] with each column converted by [`Fixed8::words_small`] where it
    /// can be: the grouped Gaussian splat's addends, weights below 1 and most w·v too.
    #[inline(always)]
    pub(crate) fn rows4_small(
        self,
        x: [crate::lane::F32x8; 4],
    ) -> Option<[crate::lane::I128x4; 8]> {
        use crate::lane::{I32x8, LaneMask};
        let (w0, p0) = self.words_small(x[0]);
        let (w1, p1) = self.words_small(x[1]);
        let (w2, p2) = self.words_small(x[2]);
        let (w3, p3) = self.words_small(x[3]);
        (p0 & p1 & p2 & p3)
            .all()
            .then(|| I32x8::rows4([w0, w1, w2, w3]))
    }

    /// [`Fixed8::words`], shorter where every lane is ±0 or in the common range with a shift
    /// sh ≤ 39 (|x| < 2⁻¹): then |fixed(x)| = |m|·2^sh < 2⁶³, so words 2 and 3 are the sign
    /// of the signed significand and only words 0 and 1 take shifts (the same words as
    /// `words` gives: the value's two's complement). Otherwise `words` itself.
    #[inline(always)]
    fn words_small(self, x: crate::lane::F32x8) -> ([crate::lane::I32x8; 4], crate::lane::M8) {
        use crate::lane::{I32x8, Lane, LaneI32, LaneMask};
        let bits = x.to_bits();
        let sh = bits.shr::<23>().and(bits.splat(0xff)).sub(bits.splat(86));
        // 0 ≤ sh ≤ 39 as an unsigned comparison.
        let small = sh.min_u32(bits.splat(39)).eq(sh);
        let zero = x.eq(x.splat(0.0));
        if !(small | zero).all() {
            return self.words(x);
        }
        let m = bits.and(bits.splat(0x7f_ffff)).or(bits.splat(0x80_0000));
        let s = bits.sar::<31>();
        let sm = I32x8::select(small, m.xor(s).sub(s), bits.splat(0));
        let k = self.step;
        let (d1, n1) = (sh.sub(k), k.sub(sh));
        let sign = sm.sar::<31>();
        let words = [
            sm.shl_var(sh),
            d1.select_neg(sm.sar_var(n1), sm.shl_var(d1)),
            sign,
            sign,
        ];
        (words, small | zero)
    }

    /// `fixed` of the eight lanes of `x` in registers as words (value i from lane
    /// [`crate::lane::ROW_LANES`]`[i]`: one pixel's addends, given in that order,
    /// [`crate::lane::Avx2::add_i128x8_biased_regs`]), when every lane is in the common range
    /// or ±0; `None` otherwise.
    #[inline(always)]
    pub(crate) fn row(self, x: crate::lane::F32x8) -> Option<crate::lane::I128x8> {
        use crate::lane::{I32x8, LaneMask};
        let (words, plain) = self.words(x);
        plain.all().then(|| I32x8::join_words(words))
    }
}

/// The bias of the sums a film keeps: a sum s is stored as s ^ `LOW_BIAS` (bit 63, the top
/// bit of its low 64-bit word, flipped), so that the 8-wide adds find the carry out of the low
/// word with one signed compare ([`crate::lane::Avx2::add_i128x8_biased`]). The high word is
/// untouched, so a stored sum has the sign of the sum; zero is stored as `LOW_BIAS`.
pub(crate) const LOW_BIAS: i128 = 1 << 63;

/// The fixed-point value of 1, the weight of a box-filter sample: [`fixed`]`(1.0)`.
pub(crate) const ONE: i128 = 1 << FRAC_BITS;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_are_exact_where_promised() {
        for x in [
            1.0f32,
            -1.0,
            0.5,
            3.25,
            1e-12,
            123456.78,
            -7.5e17,
            f32::MIN_POSITIVE,
        ] {
            let f = fixed(x);
            if x.abs() >= 2f32.powi(-41) {
                assert_eq!(to_f64(f), x as f64, "{x}");
            } else {
                assert!((to_f64(f) - x as f64).abs() <= 2f64.powi(-65), "{x}");
            }
        }
        assert_eq!(fixed(0.0), 0);
        assert_eq!(fixed(-0.0), 0);
        assert_eq!(fixed(f32::NAN), 0);
        assert_eq!(fixed(f32::INFINITY), MAX_ADDEND);
        assert_eq!(fixed(f32::NEG_INFINITY), -MAX_ADDEND);
        assert_eq!(fixed(1e30), MAX_ADDEND);
        assert_eq!(fixed(-1e30), -MAX_ADDEND);
        assert_eq!(fixed(f32::from_bits(1)), 0);
        assert_eq!(fixed(1.0), ONE);
    }

    #[test]
    fn fast_path_agrees_with_the_general_rounding() {
        // Every exponent, both signs, several significands: `fixed` (fast path where it
        // applies) against `fixed_rare`'s general algorithm, which handles every input.
        for e in 0u32..=255 {
            for frac in [0u32, 1, 0x40_0000, 0x7f_ffff, 0x12_3457] {
                for sign in [0u32, 1] {
                    let x = f32::from_bits(sign << 31 | e << 23 | frac);
                    let want = if x.to_bits() << 1 == 0 {
                        0
                    } else {
                        fixed_rare(x)
                    };
                    assert_eq!(fixed(x), want, "{x:e} ({:#x})", x.to_bits());
                }
            }
        }
    }

    /// The common-range conversion as it was before the sign moved onto the 64-bit
    /// significand (session 9): the frozen reference of [`fixed`].
    fn fixed_before(x: f32) -> i128 {
        let bits = x.to_bits();
        let e = (bits >> 23) & 0xff;
        if e.wrapping_sub(86) <= 188 - 86 {
            let m = ((bits & 0x7f_ffff) | 0x80_0000) as u64;
            let mag = ((m as u128) << (e - 86)) as i128;
            let s = ((bits as i32) >> 31) as i128;
            (mag ^ s) - s
        } else if bits << 1 == 0 {
            0
        } else {
            fixed_rare(x)
        }
    }

    /// [`fixed`] equals the former conversion on every exponent and sign with boundary
    /// significands, and on 2²⁰ random bit patterns (each lands in the common range with
    /// probability 0.4).
    #[test]
    fn fixed_equals_the_former_conversion() {
        for e in 0u32..=255 {
            for frac in [0u32, 1, 2, 0x40_0000, 0x7f_fffe, 0x7f_ffff, 0x12_3457] {
                for sign in [0u32, 1] {
                    let x = f32::from_bits(sign << 31 | e << 23 | frac);
                    assert_eq!(fixed(x), fixed_before(x), "{x:e} ({:#x})", x.to_bits());
                }
            }
        }
        let mut z = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..1 << 20 {
            z = z
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = f32::from_bits((z >> 32) as u32);
            assert_eq!(fixed(x), fixed_before(x), "{x:e} ({:#x})", x.to_bits());
        }
    }

    /// [`Fixed8::into_columns`] equals [`fixed`] in every lane of both columns (and writes
    /// only its two slots) on every exponent and sign with boundary significands (each value in
    /// every lane position and in both columns) and on 2²⁰ random bit patterns; [`Fixed8::row`]
    /// gives the same values (value i from lane `ROW_LANES[i]`) when every lane is in the
    /// common range or ±0, and `None` exactly otherwise. Both with the step hidden
    /// ([`Fixed8::new`]) and constant ([`Fixed8::single`]).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn fixed8_equals_fixed() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2: Fixed8 not tested");
            return;
        };
        let mut xs = Vec::new();
        for e in 0u32..=255 {
            for frac in [0u32, 1, 2, 0x40_0000, 0x7f_fffe, 0x7f_ffff, 0x12_3457] {
                for sign in [0u32, 1] {
                    xs.push(f32::from_bits(sign << 31 | e << 23 | frac));
                }
            }
        }
        let mut z = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..1 << 20 {
            z = z
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            xs.push(f32::from_bits((z >> 32) as u32));
        }
        // Runs of common-range values (and zeros), so that whole rows convert in registers.
        for k in 0..1 << 16 {
            z = z
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let e = 86 + (z >> 40) as u32 % 103;
            let bits = ((z >> 63) as u32) << 31 | e << 23 | (z as u32 & 0x7f_ffff);
            xs.push(if k % 29 == 0 {
                -0.0
            } else {
                f32::from_bits(bits)
            });
        }
        let plain = |x: f32| x == 0.0 || (86..=188).contains(&((x.to_bits() >> 23) & 0xff));
        let value = |w: &[[u64; 8]; 2], i: usize| ((w[1][i] as i128) << 64) | w[0][i] as i128;
        let (mut rows, mut nones) = (0, 0);
        for shift in 0..8 {
            for (i, c) in xs[shift..].chunks_exact(8).enumerate() {
                let c: [f32; 8] = c.try_into().unwrap();
                // The second column: the same values three lanes on (each value meets other
                // lanes' values in the pair).
                let c2: [f32; 8] = core::array::from_fn(|k| c[(k + 3) % 8]);
                let s = shift % 7;
                let fx = if i % 2 == 0 {
                    Fixed8::new(avx)
                } else {
                    Fixed8::single(avx)
                };
                let mut t = [[[0x5555_5555_5555_5555u64; 8]; 2]; 8];
                // Four columns for `rows4`: c, c2 and two more rotations.
                let cs: [[f32; 8]; 4] = [
                    c,
                    c2,
                    core::array::from_fn(|k| c[(k + 5) % 8]),
                    core::array::from_fn(|k| c[7 - k]),
                ];
                let (row, rows4) = avx.run(|| {
                    fx.into_columns([avx.load(&c), avx.load(&c2)], &mut t, s);
                    let cols = [
                        avx.load(&cs[0]),
                        avx.load(&cs[1]),
                        avx.load(&cs[2]),
                        avx.load(&cs[3]),
                    ];
                    let rows4 = fx.rows4(cols).map(|r| r.map(|x| x.to_words()));
                    // `rows4_small` gives `rows4`'s rows, on these columns and on them scaled
                    // by 2⁻²⁰ (more of them below 2⁻¹, its short form).
                    let scaled = cols.map(|c| c * avx.splat(1.0 / 1_048_576.0));
                    for cols in [cols, scaled] {
                        let want = fx.rows4(cols).map(|r| r.map(|x| x.to_words()));
                        let small = fx.rows4_small(cols).map(|r| r.map(|x| x.to_words()));
                        assert!(small == want, "rows4_small {c:?}");
                    }
                    (fx.row(avx.load(&c)).map(|r| r.to_words()), rows4)
                });
                // `rows4` where every lane is plain (the four columns hold the same values).
                assert_eq!(rows4.is_some(), c.iter().all(|&x| plain(x)), "{c:?}");
                for (k, r) in rows4.iter().flatten().enumerate() {
                    for (j, col) in cs.iter().enumerate() {
                        assert_eq!(value(r, j), fixed(col[k]), "rows4 lane {k} column {j}");
                    }
                }
                for (k, row) in t.iter().enumerate() {
                    for j in 0..8 {
                        let v = value(row, j);
                        let want = match j {
                            _ if j == s => fixed(c[k]),
                            _ if j == s + 1 => fixed(c2[k]),
                            _ => 0x5555_5555_5555_5555_5555_5555_5555_5555,
                        };
                        assert_eq!(v, want, "lane {k} slot {j}: {c:?} {c2:?}");
                    }
                }
                match row {
                    Some(r) => {
                        rows += 1;
                        for (i, &l) in crate::lane::ROW_LANES.iter().enumerate() {
                            assert_eq!(value(&r, i), fixed(c[l]), "{c:?}");
                        }
                    }
                    None => {
                        nones += 1;
                        assert!(!c.iter().all(|&x| plain(x)), "{c:?}");
                    }
                }
            }
        }
        assert!(rows > 10_000 && nones > 10_000, "{rows} {nones}");
    }

    /// The biased scalar adds equal the unbiased ones ([`add_signed`], [`add_unsigned`] pair
    /// by pair, which saturates like `saturating_add` on non-negative values) on sums at and
    /// near the word boundaries and the limits, with addends that carry, wrap and saturate
    /// (alone, several at once, or not at all).
    #[test]
    fn biased_scalar_adds_equal_unbiased() {
        let near = i128::MAX - 3;
        let mut edge = vec![0i128, 1, 2, near, i128::MAX, i128::MAX - (1 << 64)];
        for k in [32, 62, 63, 64, 65, 100, 126] {
            let p = 1i128 << k;
            edge.extend([p - 1, p, p + 1]);
        }
        let mut z = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            z = z
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            z
        };
        for round in 0..40_000 {
            let mut pick = |signed: bool| -> i128 {
                let r = next();
                let v = match r % 3 {
                    0 => edge[(r >> 8) as usize % edge.len()],
                    1 => ((next() as u128) << 64 | next() as u128) as i128 & i128::MAX,
                    _ => (next() >> (r >> 58)) as i128,
                };
                if signed && r & 1 << 20 != 0 {
                    v.wrapping_neg()
                } else {
                    v
                }
            };
            let acc: [i128; 5] = core::array::from_fn(|_| pick(false));
            let x: [i128; 5] = core::array::from_fn(|_| pick(false));
            let (sa, sx) = (pick(true), pick(true));
            let mut want = acc;
            for (a, &v) in want.iter_mut().zip(&x) {
                add_unsigned(a, v);
                assert!(*a >= 0);
            }
            let mut got = acc.map(|a| a ^ LOW_BIAS);
            let [g0, g1, g2, g3, g4] = &mut got;
            add_unsigned_all_biased([g0, g1, g2, g3, g4], x);
            assert_eq!(
                got.map(|a| a ^ LOW_BIAS),
                want,
                "round {round}: {acc:?} + {x:?}"
            );
            let sat: [i128; 5] = core::array::from_fn(|i| acc[i].saturating_add(x[i]));
            assert_eq!(want, sat);
            let mut s = sa ^ LOW_BIAS;
            add_signed_biased(&mut s, sx);
            assert_eq!(s ^ LOW_BIAS, sa.wrapping_add(sx));
        }
    }

    #[test]
    fn any_grouping_gives_the_same_sum() {
        let xs: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919) % 1013) as f32 * 1e-3 - 0.4)
            .collect();
        let seq = xs.iter().fold(0i128, |mut a, &x| {
            add_signed(&mut a, fixed(x));
            a
        });
        let mut halves = [0i128; 2];
        for (i, &x) in xs.iter().rev().enumerate() {
            add_signed(&mut halves[i % 2], fixed(x));
        }
        let mut two = halves[1];
        add_signed(&mut two, halves[0]);
        assert_eq!(seq, two);
        let exact: f64 = xs.iter().map(|&x| x as f64).sum();
        assert!((to_f64(seq) - exact).abs() < 1e-9);
        // Wrapping keeps associativity even through an intermediate overflow.
        let mut a = i128::MAX;
        add_signed(&mut a, 5);
        add_signed(&mut a, -10);
        assert_eq!(a, i128::MAX - 5);
    }
}
