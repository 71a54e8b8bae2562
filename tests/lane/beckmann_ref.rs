//! The f64 reference for visible Beckmann slopes: the sampler the scalar renderer used before it
//! moved onto the f32 lane kernel (safeguarded Newton on the exact marginal CDF, iterated to a
//! 1e-9 step). Kept here only to measure the kernel's error (`beckmann.rs`).

const SQRT_PI: f64 = 1.772_453_850_905_516;

/// erfc with fractional error < 1.2e-7 everywhere (Chebyshev fit, Press et al., "Numerical
/// Recipes", §6.2, `erfcc`).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let p = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * p.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Solve F(x) = target for an increasing F with derivative `dens` on [lo, hi], from `x0`: Newton
/// steps safeguarded by bisection, until a 1e-9 step.
fn invert_monotone(
    f: impl Fn(f64) -> f64,
    dens: impl Fn(f64) -> f64,
    target: f64,
    mut lo: f64,
    mut hi: f64,
    x0: f64,
) -> f64 {
    let mut x = x0.clamp(lo, hi);
    for _ in 0..200 {
        let fx = f(x) - target;
        if fx > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let mut nx = x - fx / dens(x);
        if !(nx > lo && nx < hi) {
            nx = 0.5 * (lo + hi);
        }
        if (nx - x).abs() < 1e-9 * (1.0 + x.abs()) || hi - lo < 1e-10 {
            return nx;
        }
        x = nx;
    }
    x
}

/// erf⁻¹(x) to ~1e-12: a bisection start refined on [`erfc`]'s exact inverse.
pub fn erfinv(x: f64) -> f64 {
    let u = 0.5 * (x + 1.0);
    invert_monotone(
        |y| 0.5 * erfc(-y),
        |y| (-y * y).exp() / SQRT_PI,
        u,
        -9.0,
        9.0,
        0.0,
    )
}

/// x with P(X ≤ x) = u for the density ∝ max(0, c − x s) e^{−x²} (c = cos θ, s = sin θ).
pub fn slope_x(c: f64, s: f64, u: f64) -> f64 {
    let cdf = |x: f64| 0.5 * (c * SQRT_PI * erfc(-x) + s * (-x * x).exp());
    let hi = if s > 0.0 { (c / s).min(7.0) } else { 7.0 };
    let dens = |x: f64| ((c - x * s).max(0.0)) * (-x * x).exp();
    invert_monotone(cdf, dens, u * cdf(hi), -7.0, hi, 0.0f64.min(hi))
}

/// The visible Beckmann normal for (α_u, α_v), `wi` and `u`, all in f64 (the kernel's steps: stretch,
/// slopes of the α = 1 configuration in the azimuth of `wi`, unstretch).
pub fn visible_normal(au: f64, av: f64, wi: [f64; 3], u: [f64; 2]) -> [f64; 3] {
    let ws = [au * wi[0], av * wi[1], wi[2].max(0.0)];
    let len = (ws[0] * ws[0] + ws[1] * ws[1] + ws[2] * ws[2]).sqrt();
    if len <= 0.0 {
        return [0.0, 0.0, 1.0];
    }
    let v = [ws[0] / len, ws[1] / len, ws[2] / len];
    let (c, s) = (v[2], (1.0 - v[2] * v[2]).max(0.0).sqrt());
    let x = slope_x(c, s, u[0]);
    let y = erfinv(2.0 * u[1] - 1.0);
    let rs = (v[0] * v[0] + v[1] * v[1]).sqrt();
    let (cp, sp) = if s > 0.0 && rs > 0.0 {
        (v[0] / rs, v[1] / rs)
    } else {
        (1.0, 0.0)
    };
    let (sx, sy) = ((cp * x - sp * y) * au, (sp * x + cp * y) * av);
    let l = (sx * sx + sy * sy + 1.0).sqrt();
    [-sx / l, -sy / l, 1.0 / l]
}
