//! Polynomial `sin cos acos atan2 exp log pow`, generic over [`Lane`], so that width 1 and
//! width 8 give the same bits. Each is a range reduction plus a short polynomial with the
//! coefficients of Moshier's Cephes single-precision library (S. L. Moshier, "Methods and
//! Programs for Mathematical Functions", 1989: `sinf`/`cosf`, `expf`, `logf`, `asinf`, `atanf`),
//! evaluated by Horner's rule with separate multiplies and adds (no FMA), constants split
//! Cody–Waite style (Cody & Waite, "Software Manual for the Elementary Functions", 1980).
//!
//! Accuracy against f64 `std` (max error in ulps of the f32 result, tested in `tests/lane/`;
//! see `docs/design/lanes.md` for the measured table):
//! - `sin`, `cos`: |x| ≤ 6434 (exact reduction: the quotient fits 12 bits); beyond, the error
//!   grows with |x|. ±inf and NaN give NaN.
//! - `exp`: everywhere (overflow to +inf above 88.72, gradual underflow to 0 below −103.97).
//! - `log`: every positive float including subnormals; log(0) = −inf, log(x < 0) = NaN.
//! - `acos`: [−1, 1]; NaN outside.
//! - `atan2`: everywhere, with C99 Annex F signed zeros and infinities.
//! - `pow` = exp(y·log|x|) with C99's special cases: the error grows with |y·ln x| (an ulp of
//!   log becomes |y·ln x| ulps of the result).

// The coefficients are written as published (and the split constants to full f64 digits):
// each literal rounds to the f32 the tests measured.
#![allow(clippy::excessive_precision)]

use super::{Lane, LaneI32, LaneMask};

/// π/2 in four parts of 12, 12, 12 and 24 bits: j·part is exact for j < 2¹².
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_512_969_970_703e-4;
const PIO2_3: f32 = 7.549_533_620_476_723e-8;
const PIO2_4: f32 = 2.563_344_151_594_519e-12;
/// The f32 nearest π, π/2, π/4 and the remainders.
const PI_HI: f32 = 3.141_592_741_012_573_2;
const PI_LO: f32 = -8.742_277_657_347_586e-8;
const PIO2_HI: f32 = 1.570_796_370_506_286_6;
const PIO2_LO: f32 = -4.371_138_828_673_793e-8;
const PIO4_HI: f32 = 0.785_398_185_253_143_3;
const PIO4_LO: f32 = -2.185_569_414_336_896_4e-8;
const FRAC_2_PI: f32 = 0.636_619_746_685_028_1;
/// Arguments of sin/cos are clamped here so the quadrant fits an i32 (results beyond are not
/// accurate; they stay finite).
const SINCOS_MAX: f32 = 16_777_216.0;

/// `sin(x)` and `cos(x)` together (one range reduction).
#[inline(always)]
pub fn sincos<L: Lane>(x: L) -> (L, L) {
    let k = |c: f32| x.splat(c);
    let ax = x.abs().min(k(SINCOS_MAX));
    // Quadrant j = round(|x|·2/π); r = |x| − j·π/2 ∈ [−π/4, π/4].
    let j = (ax * k(FRAC_2_PI)).round_i32();
    let jf = j.to_f32();
    let r = (((ax - jf * k(PIO2_1)) - jf * k(PIO2_2)) - jf * k(PIO2_3)) - jf * k(PIO2_4);
    let z = r * r;
    let ps = (k(-1.951_529_589_1e-4) * z + k(8.332_160_873_6e-3)) * z + k(-1.666_665_461_1e-1);
    let s = r + r * z * ps;
    let pc = (k(2.443_315_711_809_948e-5) * z + k(-1.388_731_625_493_765e-3)) * z
        + k(4.166_664_568_298_827e-2);
    let c = ((pc * z * z) - k(0.5) * z) + k(1.0);
    let zero = j.splat(0);
    let swap = j.and(j.splat(1)).eq(zero).not_();
    let (sr, cr) = (L::select(swap, c, s), L::select(swap, s, c));
    // sin is negative in quadrants 2, 3 and for negative x; cos in quadrants 1, 2.
    let sneg = j.and(j.splat(2)).shl::<30>();
    let cneg = j.add(j.splat(1)).and(j.splat(2)).shl::<30>();
    let sin = L::from_bits(sr.to_bits().xor(sneg)).mulsign(x);
    let cos = L::from_bits(cr.to_bits().xor(cneg));
    let bad = x.is_finite().not_();
    let nan = k(f32::NAN);
    (L::select(bad, nan, sin), L::select(bad, nan, cos))
}

/// `sin(x)`.
#[inline(always)]
pub fn sin<L: Lane>(x: L) -> L {
    sincos(x).0
}

/// `cos(x)`.
#[inline(always)]
pub fn cos<L: Lane>(x: L) -> L {
    sincos(x).1
}

/// `e^x`.
#[inline(always)]
pub fn exp<L: Lane>(x: L) -> L {
    let k = |c: f32| x.splat(c);
    // Beyond these the result is 0 or +inf anyway; the clamp keeps 2ⁿ representable.
    let xc = x.max(k(-104.0)).min(k(89.0));
    let n = (xc * k(std::f32::consts::LOG2_E)).round_i32();
    let nf = n.to_f32();
    // ln 2 = 0.693359375 − 2.12194440e-4 (+ 4e-12): n·hi is exact for |n| < 2¹⁵.
    let r = (xc - nf * k(0.693_359_375)) - nf * k(-2.121_944_4e-4);
    let z = r * r;
    let p = ((((k(1.987_569_15e-4) * r + k(1.398_199_950_7e-3)) * r + k(8.333_451_907_3e-3)) * r
        + k(4.166_579_589_4e-2))
        * r
        + k(1.666_666_545_9e-1))
        * r
        + k(5.000_000_120_1e-1);
    let y = (p * z + r) + k(1.0);
    // Scale by 2ⁿ as 2^(n/2)·2^(n − n/2): both factors are normal for n ∈ [−150, 128], and
    // the second product rounds a subnormal result once.
    let n1 = n.sar::<1>();
    let n2 = n.sub(n1);
    let bias = n.splat(127);
    let s1 = L::from_bits(n1.add(bias).shl::<23>());
    let s2 = L::from_bits(n2.add(bias).shl::<23>());
    L::select(x.is_nan(), x, (y * s1) * s2)
}

/// Natural logarithm.
#[inline(always)]
pub fn log<L: Lane>(x: L) -> L {
    let k = |c: f32| x.splat(c);
    // Subnormals: scale by 2²³ first.
    let tiny = x.lt(k(f32::MIN_POSITIVE));
    let xs = L::select(tiny, x * k(8_388_608.0), x);
    let bits = xs.to_bits();
    let i = |c: i32| bits.splat(c);
    let e = bits
        .shr::<23>()
        .and(i(0xff))
        .sub(i(127))
        .sub(LaneI32::select(tiny, i(23), i(0)));
    // Mantissa m ∈ [1, 2); above √2 use m/2 and e + 1, so t = m − 1 ∈ [−0.29, 0.41] (exact).
    let m = L::from_bits(bits.and(i(0x007f_ffff)).or(i(0x3f80_0000)));
    let big = m.gt(k(std::f32::consts::SQRT_2));
    let t = L::select(big, m * k(0.5), m) - k(1.0);
    let fe = e.add(LaneI32::select(big, i(1), i(0))).to_f32();
    let z = t * t;
    let mut p = k(7.037_683_629_2e-2);
    for c in [
        -1.151_461_031_0e-1,
        1.167_699_874_0e-1,
        -1.242_014_084_6e-1,
        1.424_932_278_7e-1,
        -1.666_805_766_5e-1,
        2.000_071_476_5e-1,
        -2.499_999_399_3e-1,
        3.333_333_117_4e-1,
    ] {
        p = p * t + k(c);
    }
    let y = t * z * p + fe * k(-2.121_944_4e-4) - k(0.5) * z;
    let r = (t + y) + fe * k(0.693_359_375);
    let r = L::select(x.eq(k(0.0)), k(f32::NEG_INFINITY), r);
    let r = L::select(x.lt(k(0.0)), k(f32::NAN), r);
    let r = L::select(x.eq(k(f32::INFINITY)), x, r);
    L::select(x.is_nan(), x, r)
}

/// `x^y` = exp(y·log|x|), with C99 Annex F's special cases (pow(x, ±0) = pow(1, y) = 1, signs
/// for negative bases and odd integer exponents, NaN for a negative finite base with a
/// non-integer finite exponent, pow(−1, ±inf) = 1).
#[inline(always)]
pub fn pow<L: Lane>(x: L, y: L) -> L {
    let k = |c: f32| x.splat(c);
    let ax = x.abs();
    let r = exp(y * log(ax));
    let ay = y.abs();
    // Every float of magnitude ≥ 2²⁴ is an even integer.
    let big = ay.ge(k(16_777_216.0));
    let yi = y.trunc_i32();
    let is_int = big | yi.to_f32().eq(y);
    let odd = big.not_() & yi.and(yi.splat(1)).eq(yi.splat(1));
    let neg = x.sign_bit() & x.is_nan().not_();
    let r = L::select(neg & odd, -r, r);
    let inf = k(f32::INFINITY);
    let undefined = x.lt(k(0.0)) & ax.lt(inf) & is_int.not_() & ay.lt(inf);
    let r = L::select(undefined, k(f32::NAN), r);
    let r = L::select(x.eq(k(-1.0)) & ay.eq(inf), k(1.0), r);
    L::select(x.eq(k(1.0)) | y.eq(k(0.0)), k(1.0), r)
}

/// `acos(x)`, in [0, π].
#[inline(always)]
pub fn acos<L: Lane>(x: L) -> L {
    let k = |c: f32| x.splat(c);
    let ax = x.abs();
    // asin on [0, 0.5] directly; above, asin(√((1 − |x|)/2)) (acos(|x|) = 2·asin(√((1 − |x|)/2))).
    let big = ax.gt(k(0.5));
    let z = L::select(big, k(0.5) * (k(1.0) - ax), ax * ax);
    let s = L::select(big, z.sqrt(), ax);
    let p = (((k(4.216_319_904_8e-2) * z + k(2.418_131_104_9e-2)) * z + k(4.547_002_599_8e-2)) * z
        + k(7.495_300_268_6e-2))
        * z
        + k(1.666_675_242_2e-1);
    let asn = s + s * z * p;
    let small_r = (k(PIO2_HI) - asn.mulsign(x)) + k(PIO2_LO);
    let two = asn + asn;
    let big_r = L::select(x.lt(k(0.0)), (k(PI_HI) - two) + k(PI_LO), two);
    L::select(big, big_r, small_r)
}

/// `atan2(y, x)`, in [−π, π], with C99 Annex F signed zeros and infinities.
#[inline(always)]
pub fn atan2<L: Lane>(y: L, x: L) -> L {
    let k = |c: f32| x.splat(c);
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = (ax.min(ay), ax.max(ay));
    // a = min/max ∈ [0, 1]; 0/0 → 0 and inf/inf → 1 (the limits C99 asks for).
    let a = num / den;
    let a = L::select(den.eq(k(0.0)), k(0.0), a);
    let a = L::select(num.eq(k(f32::INFINITY)), k(1.0), a);
    // atan(a) = π/4 + atan((a − 1)/(a + 1)) above tan(π/8).
    let red = a.gt(k(0.414_213_562_373_095));
    let t = L::select(red, (a - k(1.0)) / (a + k(1.0)), a);
    let z = t * t;
    let p = ((k(8.053_744_495_38e-2) * z + k(-1.387_768_560_32e-1)) * z + k(1.997_771_064_78e-1))
        * z
        + k(-3.333_294_915_39e-1);
    let p = p * z * t + t;
    let r = L::select(red, (k(PIO4_HI) + p) + k(PIO4_LO), p);
    let r = L::select(ay.gt(ax), (k(PIO2_HI) - r) + k(PIO2_LO), r);
    let r = L::select(x.sign_bit(), (k(PI_HI) - r) + k(PI_LO), r);
    let r = r.copysign(y);
    L::select(x.is_nan() | y.is_nan(), x + y, r)
}

/// `!m` spelled as a method, so generic code reads left to right.
trait NotExt {
    fn not_(self) -> Self;
}
impl<M: LaneMask> NotExt for M {
    #[inline(always)]
    fn not_(self) -> M {
        !self
    }
}

/// `erfc(x)` with fractional error < 1.2e-7 in exact arithmetic (Chebyshev fit, Press et al.,
/// "Numerical Recipes", §6.2, `erfcc`; `tests/lane/beckmann_ref.rs` has it in f64); in
/// f32 the exp and the rounding add a few ulps.
#[inline(always)]
pub fn erfc<L: Lane>(x: L) -> L {
    let k = |c: f32| x.splat(c);
    let z = x.abs();
    let t = k(1.0) / (k(1.0) + k(0.5) * z);
    let mut p = k(0.170_872_77);
    for c in [
        -0.822_152_23,
        1.488_515_87,
        -1.135_203_98,
        0.278_868_07,
        -0.186_288_06,
        0.096_784_18,
        0.374_091_96,
        1.000_023_68,
    ] {
        p = p * t + k(c);
    }
    let r = t * exp((-z * z - k(1.265_512_23)) + t * p);
    L::select(x.ge(k(0.0)), r, k(2.0) - r)
}

/// `erf⁻¹(x)` on (−1, 1) by Giles' single-precision polynomials (M. Giles 2010, "Approximating
/// the erfinv function"; relative error ≈ 1e-7 before f32 rounding); ±inf at ±1, NaN outside.
#[inline(always)]
pub fn erfinv<L: Lane>(x: L) -> L {
    let k = |c: f32| x.splat(c);
    let w = -log((k(1.0) - x) * (k(1.0) + x));
    let central = w.lt(k(5.0));
    let wc = w - k(2.5);
    let mut p = k(2.810_226_36e-8);
    for c in [
        3.432_739_39e-7,
        -3.523_387_7e-6,
        -4.391_506_54e-6,
        2.185_808_7e-4,
        -1.253_725_03e-3,
        -4.177_681_64e-3,
        2.466_407_27e-1,
        1.501_409_41,
    ] {
        p = p * wc + k(c);
    }
    let wt = w.sqrt() - k(3.0);
    let mut q = k(-2.002_142_57e-4);
    for c in [
        1.009_505_58e-4,
        1.349_343_22e-3,
        -3.673_428_44e-3,
        5.739_507_73e-3,
        -7.622_461_3e-3,
        9.438_870_47e-3,
        1.001_674_06,
        2.832_976_82,
    ] {
        q = q * wt + k(c);
    }
    L::select(central, p, q) * x
}
