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
#[inline(always)]
pub(crate) fn fixed(x: f32) -> i128 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32;
    if x.is_nan() {
        return 0;
    }
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

/// Adds a non-negative addend (weights, second moments): saturating.
#[inline]
pub(crate) fn add_unsigned(acc: &mut i128, x: i128) {
    *acc = acc.saturating_add(x);
}

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
