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

/// Adds non-negative addends to non-negative sums, like [`add_unsigned`] on each pair, with one
/// test for all: only when some wrapped sum is negative are they saturated one by one.
#[inline(always)]
pub(crate) fn add_unsigned_all<const N: usize>(acc: [&mut i128; N], x: [i128; N]) {
    let mut any = 0i128;
    let mut s = [0i128; N];
    for ((d, a), &v) in s.iter_mut().zip(&acc).zip(&x) {
        *d = a.wrapping_add(v);
        any |= *d;
    }
    if any < 0 {
        s = s.map(|v| if v < 0 { i128::MAX } else { v });
    }
    for (a, v) in acc.into_iter().zip(s) {
        *a = v;
    }
}

/// [`fixed`] of eight values at once (AVX2; call it inside [`crate::lane::Avx2::run`]), equal
/// to it bit for bit in every lane: lane k's value goes to `out[k][j]` (a column of a per-lane
/// table whose rows are the addends of one pixel, [`crate::lane::Avx2::add_i128x8_biased`]).
///
/// In the common range the value is the signed significand `sm` (|sm| < 2²⁴) times 2^sh,
/// sh = e − 86 ∈ [0, 102]; its 32-bit word i (bits 32i to 32i + 31) is ⌊sm·2^(sh − 32i)⌋
/// mod 2³²: with d = sh − 32i, `sm << d` for d ≥ 0 (0 from d = 32 on, as the multiple of 2³²
/// it is) and the arithmetic `sm >> −d` for d < 0 (the sign from −d = 32 on). AVX2 has these
/// variable 32-bit shifts (`vpsllvd`, `vpsravd`), so the four words of eight lanes take ~16
/// instructions and a 4×4 transpose joins them ([`crate::lane::I32x8::join_words_into`]);
/// word 0 has d = sh ≥ 0. ±0 and the lanes outside the common range get sm = 0; those outside
/// it and not zero then take [`fixed`] itself, one by one.
///
/// # Panics
/// If `j` ≥ 8.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn fixed8_into(x: crate::lane::F32x8, out: &mut [[i128; 8]; 8], j: usize) {
    use crate::lane::{I32x8, Lane, LaneI32, LaneMask};
    /// Word `i` ≥ 1 of sm·2^sh (a function, not a closure: a closure may be compiled out of
    /// line, without AVX2).
    #[inline(always)]
    fn word(sm: I32x8, sh: I32x8, i: i32) -> I32x8 {
        let d = sh.sub(sh.splat(32 * i));
        d.select_neg(sm.sar_var(sh.splat(32 * i).sub(sh)), sm.shl_var(d))
    }
    let bits = x.to_bits();
    let sh = bits.shr::<23>().and(bits.splat(0xff)).sub(bits.splat(86));
    // 0 ≤ sh ≤ 102 as an unsigned comparison.
    let common = sh.min_u32(bits.splat(102)).eq(sh);
    let m = bits.and(bits.splat(0x7f_ffff)).or(bits.splat(0x80_0000));
    let s = bits.sar::<31>();
    let sm = I32x8::select(common, m.xor(s).sub(s), bits.splat(0));
    let words = [
        sm.shl_var(sh),
        word(sm, sh, 1),
        word(sm, sh, 2),
        word(sm, sh, 3),
    ];
    I32x8::join_words_into(words, out, j);
    let plain = common | bits.shl::<1>().eq(bits.splat(0));
    if !plain.all() {
        for (l, p) in plain.to_array().into_iter().enumerate() {
            if !p {
                out[l][j] = fixed(x.lane(l));
            }
        }
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

    /// [`fixed8_into`] equals [`fixed`] in every lane (and writes only its column) on every exponent and sign with boundary
    /// significands (each value in every lane position) and on 2²⁰ random bit patterns.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn fixed8_into_equals_fixed() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2: fixed8_into not tested");
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
        for shift in 0..8 {
            for c in xs[shift..].chunks_exact(8) {
                let c: [f32; 8] = c.try_into().unwrap();
                let col = shift;
                let mut t = [[-5i128; 8]; 8];
                avx.run(|| fixed8_into(avx.load(&c), &mut t, col));
                for (row, &x) in t.iter().zip(&c) {
                    for (j, &v) in row.iter().enumerate() {
                        if j == col {
                            assert_eq!(v, fixed(x), "{x:e} ({:#x})", x.to_bits());
                        } else {
                            assert_eq!(v, -5);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn grouped_saturation_equals_pairwise() {
        let near = i128::MAX - 3;
        for (acc, x) in [
            ([1i128, 2, 3], [4i128, 5, 6]),
            ([near, 0, 7], [10, 0, 1]),
            ([near, near, 0], [3, 4, 0]),
            ([i128::MAX, 1, 2], [i128::MAX, 0, 0]),
        ] {
            let mut a = acc;
            let mut b = acc;
            let [a0, a1, a2] = &mut a;
            add_unsigned_all([a0, a1, a2], x);
            for (s, v) in b.iter_mut().zip(x) {
                *s = s.saturating_add(v);
            }
            assert_eq!(a, b);
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
