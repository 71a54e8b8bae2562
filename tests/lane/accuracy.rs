//! Accuracy of the polynomial functions against f64 `std`, in ulps of the f32 result, and
//! their special values. The bounds asserted here are the ones `docs/design/lanes.md` states.

use crate::harness::{log_uniform, uniform};
use groove::lane::math;
use groove::math::Pcg32;

/// The spacing of f32 values at `y` (the subnormal spacing below the normal range).
fn ulp(y: f32) -> f64 {
    let e = ((y.abs().to_bits() >> 23) & 0xff) as i32;
    2f64.powi(e.max(1) - 127 - 23)
}

/// |got − want| in ulps of `want` rounded to f32 (0 when both are the same infinity or NaN).
fn ulps(got: f32, want: f64) -> f64 {
    if got.is_nan() || want.is_nan() {
        return if got.is_nan() && want.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let w = want as f32;
    if w.is_infinite() || got.is_infinite() {
        return if got == w { 0.0 } else { f64::INFINITY };
    }
    (got as f64 - want).abs() / ulp(w)
}

/// The largest error of `f` against `g` over `n` inputs from `gen`, with its input.
fn worst(
    n: usize,
    seed: u64,
    gen: impl Fn(&mut Pcg32) -> (f32, f32),
    f: impl Fn(f32, f32) -> f32,
    g: impl Fn(f64, f64) -> f64,
) -> (f64, f32, f32) {
    let mut r = Pcg32::new(seed, 3);
    let mut w = (0.0, 0.0, 0.0);
    for _ in 0..n {
        let (x, y) = gen(&mut r);
        let e = ulps(f(x, y), g(x as f64, y as f64));
        if e > w.0 {
            w = (e, x, y);
        }
    }
    w
}

fn n() -> usize {
    crate::harness::count_composite().max(10_000)
}

fn assert_within(name: &str, bound: f64, w: (f64, f32, f32)) {
    eprintln!("{name}: max {:.3} ulp at ({:e}, {:e})", w.0, w.1, w.2);
    assert!(
        w.0 <= bound,
        "{name}: {:.3} ulp > {bound} at ({:e}, {:e})",
        w.0,
        w.1,
        w.2
    );
}

#[test]
fn sin_cos_accuracy() {
    let gen = |r: &mut Pcg32| {
        let x = if r.next_u32() & 1 == 0 {
            uniform(r, -7.0, 7.0)
        } else {
            log_uniform(r, -40, 12, true).clamp(-6434.0, 6434.0)
        };
        (x, 0.0)
    };
    assert_within(
        "sin",
        2.0,
        worst(n(), 1, gen, |x, _| math::sin(x), |x, _| x.sin()),
    );
    assert_within(
        "cos",
        2.0,
        worst(n(), 2, gen, |x, _| math::cos(x), |x, _| x.cos()),
    );
}

#[test]
fn exp_accuracy() {
    let gen = |r: &mut Pcg32| (uniform(r, -103.0, 88.7), 0.0);
    assert_within(
        "exp",
        1.0,
        worst(n(), 3, gen, |x, _| math::exp(x), |x, _| x.exp()),
    );
    let small = |r: &mut Pcg32| (log_uniform(r, -40, 0, true), 0.0);
    assert_within(
        "exp small",
        1.0,
        worst(n(), 4, small, |x, _| math::exp(x), |x, _| x.exp()),
    );
}

#[test]
fn log_accuracy() {
    let gen = |r: &mut Pcg32| (log_uniform(r, -149, 128, false), 0.0);
    assert_within(
        "log",
        2.0,
        worst(n(), 5, gen, |x, _| math::log(x), |x, _| x.ln()),
    );
    let near1 = |r: &mut Pcg32| (uniform(r, 0.5, 2.0), 0.0);
    assert_within(
        "log near 1",
        2.0,
        worst(n(), 6, near1, |x, _| math::log(x), |x, _| x.ln()),
    );
}

#[test]
fn acos_accuracy() {
    let gen = |r: &mut Pcg32| (uniform(r, -1.0, 1.0), 0.0);
    assert_within(
        "acos",
        2.0,
        worst(n(), 7, gen, |x, _| math::acos(x), |x, _| x.acos()),
    );
    let edge = |r: &mut Pcg32| (1.0 - log_uniform(r, -24, -1, false), 0.0);
    assert_within(
        "acos near 1",
        2.0,
        worst(n(), 8, edge, |x, _| math::acos(x), |x, _| x.acos()),
    );
}

#[test]
fn atan2_accuracy() {
    let gen = |r: &mut Pcg32| (log_uniform(r, -60, 60, true), log_uniform(r, -60, 60, true));
    let f = |y: f32, x: f32| math::atan2(y, x);
    let g = |y: f64, x: f64| y.atan2(x);
    assert_within("atan2", 3.0, worst(n(), 9, gen, f, g));
    let unit = |r: &mut Pcg32| (uniform(r, -1.0, 1.0), uniform(r, -1.0, 1.0));
    assert_within("atan2 unit", 3.0, worst(n(), 10, unit, f, g));
}

/// pow = exp(y·log x): an error of log's ulp is amplified by |y·ln x|; the bound is stated in
/// two ranges of that product.
#[test]
fn pow_accuracy() {
    let f = |x: f32, y: f32| math::pow(x, y);
    let g = |x: f64, y: f64| x.powf(y);
    let small = |r: &mut Pcg32| loop {
        let (x, y) = (log_uniform(r, -8, 8, false), uniform(r, -4.0, 4.0));
        if (y * x.ln()).abs() <= 2.0 {
            break (x, y);
        }
    };
    assert_within("pow |y ln x| <= 2", 4.0, worst(n(), 11, small, f, g));
    // Beyond: at most 4 + 2·|y ln x| ulps (measured: about 1.6 per unit of |y ln x|).
    let mut r = Pcg32::new(12, 3);
    let mut worst_excess = (f64::NEG_INFINITY, 0.0f32, 0.0f32, 0.0f64);
    for _ in 0..n() {
        let (x, y) = (
            log_uniform(&mut r, -30, 30, false),
            uniform(&mut r, -10.0, 10.0),
        );
        let p = (y as f64 * (x as f64).ln()).abs();
        if p > 80.0 {
            continue;
        }
        let e = ulps(f(x, y), g(x as f64, y as f64));
        let excess = e - (4.0 + 2.0 * p);
        if excess > worst_excess.0 {
            worst_excess = (excess, x, y, e);
        }
    }
    let (ex, x, y, e) = worst_excess;
    eprintln!("pow |y ln x| <= 80: worst {e:.1} ulp - (4 + 2|y ln x|) = {ex:.2} at ({x:e}, {y:e})");
    assert!(ex <= 0.0, "pow({x:e}, {y:e}): {e:.1} ulp > 4 + 2|y ln x|");
}

#[test]
fn special_values() {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (inf, nan) = (f32::INFINITY, f32::NAN);
    let bits = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let cases: &[(&str, f32, f32)] = &[
        ("sin 0", math::sin(0.0), 0.0),
        ("sin -0", math::sin(-0.0), -0.0),
        ("sin denormal", math::sin(1e-40), 1e-40),
        ("sin inf", math::sin(inf), nan),
        ("sin nan", math::sin(nan), nan),
        ("cos 0", math::cos(0.0), 1.0),
        ("cos -inf", math::cos(-inf), nan),
        ("exp 0", math::exp(0.0), 1.0),
        ("exp -0", math::exp(-0.0), 1.0),
        ("exp inf", math::exp(inf), inf),
        ("exp -inf", math::exp(-inf), 0.0),
        ("exp 89", math::exp(89.0), inf),
        ("exp -104", math::exp(-104.0), 0.0),
        ("exp nan", math::exp(nan), nan),
        ("log 1", math::log(1.0), 0.0),
        ("log 0", math::log(0.0), -inf),
        ("log -0", math::log(-0.0), -inf),
        ("log -1", math::log(-1.0), nan),
        ("log inf", math::log(inf), inf),
        ("log nan", math::log(nan), nan),
        ("acos 1", math::acos(1.0), 0.0),
        ("acos -1", math::acos(-1.0), PI),
        ("acos 0", math::acos(0.0), FRAC_PI_2),
        ("acos 1.5", math::acos(1.5), nan),
        ("acos nan", math::acos(nan), nan),
        ("atan2 +0 +0", math::atan2(0.0, 0.0), 0.0),
        ("atan2 -0 +0", math::atan2(-0.0, 0.0), -0.0),
        ("atan2 +0 -0", math::atan2(0.0, -0.0), PI),
        ("atan2 -0 -0", math::atan2(-0.0, -0.0), -PI),
        ("atan2 1 0", math::atan2(1.0, 0.0), FRAC_PI_2),
        ("atan2 -1 -0", math::atan2(-1.0, -0.0), -FRAC_PI_2),
        ("atan2 inf inf", math::atan2(inf, inf), FRAC_PI_4),
        ("atan2 -inf -inf", math::atan2(-inf, -inf), -3.0 * FRAC_PI_4),
        ("atan2 1 inf", math::atan2(1.0, inf), 0.0),
        ("atan2 1 -inf", math::atan2(1.0, -inf), PI),
        ("atan2 -inf 5", math::atan2(-inf, 5.0), -FRAC_PI_2),
        ("atan2 nan 1", math::atan2(nan, 1.0), nan),
        ("atan2 1 nan", math::atan2(1.0, nan), nan),
        ("pow x 0", math::pow(nan, 0.0), 1.0),
        ("pow 1 nan", math::pow(1.0, nan), 1.0),
        ("pow -1 inf", math::pow(-1.0, inf), 1.0),
        ("pow -2 3", math::pow(-2.0, 3.0), -8.0),
        ("pow -2 2", math::pow(-2.0, 2.0), 4.0),
        ("pow -2 0.5", math::pow(-2.0, 0.5), nan),
        ("pow 0 -1", math::pow(0.0, -1.0), inf),
        ("pow -0 -1", math::pow(-0.0, -1.0), -inf),
        ("pow -0 -2", math::pow(-0.0, -2.0), inf),
        ("pow -0 3", math::pow(-0.0, 3.0), -0.0),
        ("pow -0 0.5", math::pow(-0.0, 0.5), 0.0),
        ("pow -inf 3", math::pow(-inf, 3.0), -inf),
        ("pow -inf -3", math::pow(-inf, -3.0), -0.0),
        ("pow -inf 0.5", math::pow(-inf, 0.5), inf),
        ("pow 0.5 inf", math::pow(0.5, inf), 0.0),
        ("pow 0.5 -inf", math::pow(0.5, -inf), inf),
        ("pow 2 inf", math::pow(2.0, inf), inf),
        ("pow -2 1e30", math::pow(-2.0, 1e30), inf),
        ("pow 2 nan", math::pow(2.0, nan), nan),
    ];
    for &(name, got, want) in cases {
        let ok = if want.is_nan() || want.is_infinite() || want == 0.0 {
            bits(got, want)
        } else {
            ulps(got, want as f64) <= 1.0
        };
        assert!(
            ok,
            "{name}: got {got:e} ({:#010x}), want {want:e}",
            got.to_bits()
        );
    }
    // sin and cos stay finite (and bounded) on huge finite arguments.
    for x in [1e10f32, -3e38, f32::MAX, 16_777_216.0, 1e7] {
        let (s, c) = math::sincos(x);
        assert!(
            s.abs() <= 1.5 && c.abs() <= 1.5,
            "sincos({x:e}) = ({s}, {c})"
        );
    }
}
