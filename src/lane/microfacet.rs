//! The microfacet distributions of `bsdf::microfacet` (Beckmann and GGX, anisotropic, Smith
//! masking) per lane, with the roughness per lane (textured roughness) and the model and
//! sampling strategy shared by the lanes (one material per batch). `bsdf::microfacet` is this
//! kernel at width 1, so the scalar renderer and an 8-wide one share every bit.
//!
//! - D(m): Walter et al. 2007; Beckmann's G1 by its rational approximation (eq. 27);
//! - visible GGX normals: Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical Caps"
//!   (rendering), and Heitz 2018, "Sampling the GGX Distribution of Visible Normals", over the
//!   concentric disk (`roughplastic`'s tables, whose quadrature over the sample square must
//!   reproduce Mitsuba 3's numbers);
//! - visible Beckmann normals: the visible slopes of the stretched α = 1 surface (Heitz & d'Eon
//!   2014, §4), inverted in f32 by safeguarded Newton steps from an erf-domain starting guess;
//!   each lane stops on its own convergence test (a per-lane mask), so both widths agree;
//! - all normals (D(m) cos θm): slope-space inversion (Walter et al. 2007, eqs. 28–29).

use super::math::{erfc, erfinv, exp, log, sincos};
use super::vec::{V2, V3};
use super::warp::{safe_sqrt, square_to_disk_concentric};
use super::{Lane, LaneMask};
use crate::bsdf::microfacet::{MicrofacetType, MIN_ALPHA};
use crate::math::PI;

/// A microfacet distribution whose roughness varies per lane.
#[derive(Clone, Copy, Debug)]
pub struct Microfacet<L> {
    pub kind: MicrofacetType,
    pub alpha_u: L,
    pub alpha_v: L,
    pub sample_visible: bool,
}

impl<L: Lane> Microfacet<L> {
    /// Roughnesses clamped to [`MIN_ALPHA`] as `MicrofacetDistribution::anisotropic` does.
    #[inline(always)]
    pub fn new(kind: MicrofacetType, alpha_u: L, alpha_v: L, sample_visible: bool) -> Self {
        let m = alpha_u.splat(MIN_ALPHA);
        Microfacet {
            kind,
            alpha_u: rust_max(alpha_u, m),
            alpha_v: rust_max(alpha_v, m),
            sample_visible,
        }
    }

    /// D(m), per solid angle, projected-area normalised; 0 where D·cos θm ≤ 1e-20 or D is not
    /// finite, and below the horizon.
    #[inline(always)]
    pub fn eval(&self, m: V3<L>) -> L {
        let k = |c: f32| m.z.splat(c);
        let ct = m.z;
        let up = ct.gt(k(0.0));
        if !up.any() {
            // Fast path (same bits as the select below): every lane is below the horizon.
            return k(0.0);
        }
        let ct2 = ct * ct;
        let ax = m.x / self.alpha_u;
        let ay = m.y / self.alpha_v;
        let auv = self.alpha_u * self.alpha_v;
        let d = match self.kind {
            MicrofacetType::Beckmann => exp(-(ax * ax + ay * ay) / ct2) / (k(PI) * auv * ct2 * ct2),
            MicrofacetType::Ggx => {
                let t = ax * ax + ay * ay + ct2;
                k(1.0) / (k(PI) * auv * t * t)
            }
        };
        let ok = up & (d * ct).gt(k(1e-20)) & d.is_finite();
        L::select(ok, d, k(0.0))
    }

    /// α² tan²θ of `v` in the direction of `v`, and whether `v` is exactly normal.
    #[inline(always)]
    fn alpha_tan2(&self, v: V3<L>) -> (L, L::Mask) {
        let a = self.alpha_u * v.x;
        let b = self.alpha_v * v.y;
        let xy = a * a + b * b;
        (xy / (v.z * v.z), xy.eq(xy.splat(0.0)))
    }

    /// Walter et al.'s rational approximation of Beckmann's G1 at a = 1/(α tan θ), below 1.6.
    #[inline(always)]
    fn beckmann_rational(a: L) -> L {
        let k = |c: f32| a.splat(c);
        (k(3.535) * a + k(2.181) * a * a) / (k(1.0) + k(2.276) * a + k(2.577) * a * a)
    }

    /// Smith's Λ(v) (G1 = 1 / (1 + Λ)).
    #[inline(always)]
    pub fn lambda(&self, v: V3<L>) -> L {
        let k = |c: f32| v.z.splat(c);
        let (t2, normal) = self.alpha_tan2(v);
        let l = match self.kind {
            MicrofacetType::Ggx => k(0.5) * (k(-1.0) + (k(1.0) + t2).sqrt()),
            MicrofacetType::Beckmann => {
                let a = k(1.0) / t2.sqrt();
                let g = Self::beckmann_rational(a);
                L::select(a.ge(k(1.6)), k(0.0), k(1.0) / g - k(1.0))
            }
        };
        L::select(normal, k(0.0), l)
    }

    /// Smith's G1(v, m); 0 when `m` is back-facing as seen from `v`'s side.
    #[inline(always)]
    pub fn smith_g1(&self, v: V3<L>, m: V3<L>) -> L {
        Self::smith_g1_from(self.smith_g1_of(v), v, m)
    }

    /// G(wi, wo, m) = G1(wi, m) G1(wo, m).
    #[inline(always)]
    pub fn g(&self, wi: V3<L>, wo: V3<L>, m: V3<L>) -> L {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density (per solid angle of `m`) of [`Self::sample_normal`] from `wi` (`wi.z > 0`).
    #[inline(always)]
    pub fn pdf(&self, wi: V3<L>, m: V3<L>) -> L {
        let d = self.eval(m);
        if self.sample_visible {
            let k = |c: f32| wi.z.splat(c);
            let p = d * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z;
            L::select(wi.z.le(k(0.0)), k(0.0), p)
        } else {
            d * m.z
        }
    }

    /// Density of a reflection sampled through the microfacet normal `h = normalize(wi + wo)`,
    /// given `d = D(h)` and `g1i = G1(wi, h)` (unused without visible sampling): the normal's
    /// density times the reflection map's Jacobian dωh/dωo = 1/(4 wo·h) (Walter et al. 2007,
    /// eq. 14); visible normals have D_wi(h) = G1(wi, h) |wi·h| D(h) / cos θi and wi·h = wo·h.
    /// 0 where it is not finite, never negative.
    #[inline(always)]
    pub fn reflection_pdf(&self, wi: V3<L>, wo: V3<L>, h: V3<L>, d: L, g1i: L) -> L {
        let k = |c: f32| d.splat(c);
        let p = if self.sample_visible {
            d * g1i / (k(4.0) * wi.z)
        } else {
            d * h.z / (k(4.0) * wo.dot(h))
        };
        L::select(p.is_finite(), rust_max(p, k(0.0)), k(0.0))
    }

    /// A sampled microfacet normal: visible normals from `wi` or all normals, as configured.
    #[inline(always)]
    pub fn sample_normal(&self, wi: V3<L>, u: V2<L>) -> V3<L> {
        if !self.sample_visible {
            return self.sample_all_normals(u);
        }
        match self.kind {
            MicrofacetType::Ggx => self.sample_visible_ggx(wi, u),
            MicrofacetType::Beckmann => self.sample_visible_beckmann(wi, u),
        }
    }

    /// [`Self::sample_normal`]'s distribution with the sample square mapped as Mitsuba 3 maps it
    /// (GGX: [`Self::sample_visible_ggx_concentric`]; Beckmann and all normals: the same map).
    #[inline(always)]
    pub fn sample_normal_mitsuba_map(&self, wi: V3<L>, u: V2<L>) -> V3<L> {
        if self.sample_visible && self.kind == MicrofacetType::Ggx {
            return self.sample_visible_ggx_concentric(wi, u);
        }
        self.sample_normal(wi, u)
    }

    /// `wi` in the α = 1 configuration (stretched by (α_u, α_v), lower hemisphere clamped to the
    /// horizon), normalised, and its length before normalising (0 where `wi` degenerates): the
    /// common first step of the visible-normal samplers.
    #[inline(always)]
    fn stretched_view(&self, wi: V3<L>) -> (V3<L>, L) {
        let wi_s = V3::new(
            self.alpha_u * wi.x,
            self.alpha_v * wi.y,
            rust_max(wi.z, wi.z.splat(0.0)),
        );
        let len = wi_s.length();
        (wi_s.div_by(len), len)
    }

    /// Visible Beckmann normals (Heitz & d'Eon 2014): in the α = 1 configuration seen from θ,
    /// the slope along the view azimuth has density ∝ max(0, cos θ − x sin θ) e^{−x²} and the
    /// slope across it is an independent Gaussian ∝ e^{−y²}; rotate to the azimuth of `wi`,
    /// stretch by (α_u, α_v). +Z where `wi` degenerates.
    #[inline(always)]
    pub fn sample_visible_beckmann(&self, wi: V3<L>, u: V2<L>) -> V3<L> {
        let k = |c: f32| u.x.splat(c);
        let (v, len) = self.stretched_view(wi);
        let cos_t = v.z;
        let sin_t = safe_sqrt(k(1.0) - cos_t * cos_t);
        // Keep the inverse CDFs off ±1 (their infinite ends).
        let lo_u = k(1.0 / 16_777_216.0);
        let hi_u = k(1.0 - 1.0 / 16_777_216.0);
        let (ux, uy) = (u.x.max(lo_u).min(hi_u), u.y.max(lo_u).min(hi_u));
        let y = erfinv(k(2.0) * uy - k(1.0));
        let x = sample_visible_slope_x(cos_t, sin_t, ux);
        let rs = (v.x * v.x + v.y * v.y).sqrt();
        let az = sin_t.gt(k(0.0));
        let cp = L::select(az, v.x / rs, k(1.0));
        let sp = L::select(az, v.y / rs, k(0.0));
        let sx = cp * x - sp * y;
        let sy = sp * x + cp * y;
        let m = slope_to_normal(sx * self.alpha_u, sy * self.alpha_v);
        V3::select(len.gt(k(0.0)), m, V3::splat(k(0.0), 0.0, 0.0, 1.0))
    }

    /// D(m) cos θm by slope-space inversion of the α = 1 configuration, stretched by (α_u, α_v).
    #[inline(always)]
    pub fn sample_all_normals(&self, u: V2<L>) -> V3<L> {
        let k = |c: f32| u.x.splat(c);
        let one_minus = rust_max(k(1.0) - u.x, k(f32::MIN_POSITIVE));
        let r2 = match self.kind {
            MicrofacetType::Beckmann => -log(one_minus),
            MicrofacetType::Ggx => u.x / one_minus,
        };
        let r = rust_max(r2, k(0.0)).sqrt();
        let (s, c) = sincos(k(2.0 * PI) * u.y);
        slope_to_normal(r * c * self.alpha_u, r * s * self.alpha_v)
    }

    /// Visible GGX normals (Dupuy & Benyoub 2023): in the α = 1 configuration, v + c with c
    /// uniform on the spherical cap z ≥ −v.z, then unstretched; +Z where `wi` degenerates.
    #[inline(always)]
    pub fn sample_visible_ggx(&self, wi: V3<L>, u: V2<L>) -> V3<L> {
        let k = |c: f32| u.x.splat(c);
        let (v, len) = self.stretched_view(wi);
        let z = (k(1.0) - u.y) * (k(1.0) + v.z) - v.z;
        let sin_t = safe_sqrt(k(1.0) - z * z);
        let (s, c) = sincos(k(2.0 * PI) * u.x);
        let m = self.unstretch(V3::new(sin_t * c + v.x, sin_t * s + v.y, z + v.z));
        V3::select(len.gt(k(0.0)), m, V3::splat(k(0.0), 0.0, 0.0, 1.0))
    }

    /// Visible GGX normals by Heitz 2018 ("Sampling the GGX Distribution of Visible Normals"):
    /// an orthonormal basis around the stretched view v, a point of the concentric disk
    /// (Shirley & Chiu 1997) whose lower half is squashed by (1 + v.z)/2, lifted onto the
    /// hemisphere and unstretched. Same density as [`Self::sample_visible_ggx`], another map of
    /// the sample square: Mitsuba 3's, which `roughplastic`'s quadrature tables need. +Z where
    /// `wi` degenerates.
    #[inline(always)]
    pub fn sample_visible_ggx_concentric(&self, wi: V3<L>, u: V2<L>) -> V3<L> {
        let k = |c: f32| u.x.splat(c);
        let (v, len) = self.stretched_view(wi);
        let lensq = v.x * v.x + v.y * v.y;
        let t1 = V3::select(
            lensq.gt(k(0.0)),
            V3::new(-v.y, v.x, k(0.0)).div_by(lensq.sqrt()),
            V3::splat(k(0.0), 1.0, 0.0, 0.0),
        );
        let t2 = v.cross(t1);
        let d = square_to_disk_concentric(u);
        let p1 = d.x;
        let s = k(0.5) * (k(1.0) + v.z);
        let p2 = (k(1.0) - s) * safe_sqrt(k(1.0) - p1 * p1) + s * d.y;
        let n = safe_sqrt(k(1.0) - p1 * p1 - p2 * p2);
        let h = t1.scale(p1) + t2.scale(p2) + v.scale(n);
        let m = self.unstretch(h);
        V3::select(len.gt(k(0.0)), m, V3::splat(k(0.0), 0.0, 0.0, 1.0))
    }

    /// A normal of the α = 1 configuration mapped back to this roughness, normalised; +Z if it
    /// degenerates.
    #[inline(always)]
    fn unstretch(&self, h: V3<L>) -> V3<L> {
        let k = |c: f32| h.z.splat(c);
        let m = V3::new(
            self.alpha_u * h.x,
            self.alpha_v * h.y,
            rust_max(h.z, k(0.0)),
        );
        let l = m.length();
        V3::select(l.gt(k(0.0)), m.div_by(l), V3::splat(k(0.0), 0.0, 0.0, 1.0))
    }
}

/// At most this many Newton steps in [`sample_visible_slope_x`] (a lane that has not met
/// [`SLOPE_TOL`] by then, e.g. a NaN input, keeps its last iterate). Over a 201 × 2000 grid of
/// (cos θ, u) every lane converged within 8 (mean 2.9).
const SLOPE_STEPS: usize = 12;

/// A lane stops after a Newton step (not a bisection) of at most `SLOPE_TOL · (1 + |x|)`:
/// Newton converges quadratically, so the step taken is then accurate to ~1e-8, below what f32
/// resolves of the CDF (on the grid above the mean |x − x_f64| is 8e-8 with it, as with 16 fixed
/// steps; 1e-3 gives 3e-7).
const SLOPE_TOL: f32 = 1e-4;

/// x with P(X ≤ x) = u for the density ∝ max(0, c − x s) e^{−x²} on [−7, min(c/s, 7)] (the
/// slope along the view azimuth of a facet of the α = 1 Beckmann surface visible from θ;
/// c = cos θ, s = sin θ), whose unnormalised CDF is C(x) = (c √π erfc(−x) + s e^{−x²}) / 2 at
/// every θ. Newton's method safeguarded by bisection (Press et al., "Numerical Recipes",
/// `rtsafe`), each lane frozen once its step is below [`SLOPE_TOL`] (a mask, so a lane's result
/// depends on its inputs only; the loop ends when every lane is frozen, a fast path with the
/// same bits as running all [`SLOPE_STEPS`]).
///
/// The start is a guess in the erf domain, t = erf(x): t₀ = m − (m + 1) erf(√(−ln u)) with
/// m = erf(c/s), exact at grazing incidence (where x = −√(−ln u)) and monotone in u; Mitsuba 3
/// starts from the same guess (and then takes three unguarded Newton steps in t). Against the
/// normal-incidence Gaussian guess it saves 1.7 steps on average.
#[inline(always)]
fn sample_visible_slope_x<L: Lane>(c: L, s: L, u: L) -> L {
    let k = |v: f32| u.splat(v);
    let sqrt_pi = k(1.772_453_9);
    let mut hi = L::select(s.gt(k(0.0)), (c / s).min(k(7.0)), k(7.0));
    let mut lo = k(-7.0);
    // erfc(−hi) = 1 + erf(hi): the CDF's total and the guess's upper end.
    let e_hi = erfc(-hi);
    let target = u * (k(0.5) * (c * sqrt_pi * e_hi + s * exp(-hi * hi)));
    let m = e_hi - k(1.0);
    let t0 = m - (m + k(1.0)) * (k(1.0) - erfc(safe_sqrt(-log(u))));
    let mut x = erfinv(t0).max(lo).min(hi);
    let mut done = u.ne(u) & u.eq(u);
    for _ in 0..SLOPE_STEPS {
        let e = exp(-x * x);
        let f = k(0.5) * (c * sqrt_pi * erfc(-x) + s * e) - target;
        let above = f.gt(k(0.0));
        hi = L::select(above, x, hi);
        lo = L::select(above, lo, x);
        let dens = (c - x * s).max(k(0.0)) * e;
        let nx = x - f / dens;
        // Inclusive: a converged step (nx == x on the bracket's end) must stay, not bisect.
        let inside = nx.ge(lo) & nx.le(hi);
        let small = (nx - x).abs().le(k(SLOPE_TOL) * (k(1.0) + x.abs()));
        x = L::select(done, x, L::select(inside, nx, k(0.5) * (lo + hi)));
        done = done | (inside & small);
        if done.all() {
            break;
        }
    }
    x
}

/// The normal of the facet with slopes (sx, sy), m ∝ (−sx, −sy, 1); a grazing normal in the
/// sampled azimuth when the slope is infinite.
#[inline(always)]
fn slope_to_normal<L: Lane>(sx: L, sy: L) -> V3<L> {
    let k = |c: f32| sx.splat(c);
    let m = V3::new(-sx, -sy, k(1.0));
    let l = m.length();
    // glam's normalize_or_zero of (−sx, −sy): v · (1/|v|) when that factor is finite and > 0.
    let l2 = (sx * sx + sy * sy).sqrt();
    let rcp = k(1.0) / l2;
    let ok2 = rcp.is_finite() & rcp.gt(k(0.0));
    let g = V3::new(
        L::select(ok2, -sx * rcp, k(0.0)),
        L::select(ok2, -sy * rcp, k(0.0)),
        k(0.0),
    );
    V3::select(l.is_finite() & l.gt(k(0.0)), m.div_by(l), g)
}

/// `a.max(b)` with Rust's `f32::max` semantics for a NaN `a` (gives `b`), which the x86 max
/// shares when `b` is not NaN: the groove code this mirrors calls `f32::max` with a constant `b`.
#[inline(always)]
fn rust_max<L: Lane>(a: L, b: L) -> L {
    a.max(b)
}

/// Smith's G1(v, m) in two steps, for many microfacet normals `m` seen from one direction `v`
/// (the compensated first order evaluates its nested BSDF from each entry and toward each exit
/// more than once per query, issue 18): [`Microfacet::smith_g1_of`] the part that depends on
/// `v` alone, [`Microfacet::smith_g1_from`] the back-facing test against `m`. Together they are
/// [`Microfacet::smith_g1`] bit for bit: its operations in its order, split after the last one
/// that does not read `m`.
impl<L: Lane> Microfacet<L> {
    /// [`Microfacet::smith_g1`] before its test against `m`: G1 toward the normal itself (1
    /// where `v` is exactly normal, 0 where not finite).
    #[inline(always)]
    pub fn smith_g1_of(&self, v: V3<L>) -> L {
        let k = |c: f32| v.z.splat(c);
        let (t2, normal) = self.alpha_tan2(v);
        let g = match self.kind {
            MicrofacetType::Ggx => k(2.0) / (k(1.0) + (k(1.0) + t2).sqrt()),
            MicrofacetType::Beckmann => {
                let a = k(1.0) / t2.sqrt();
                L::select(a.ge(k(1.6)), k(1.0), Self::beckmann_rational(a))
            }
        };
        let g = L::select(g.is_finite(), g, k(0.0));
        L::select(normal, k(1.0), g)
    }

    /// G1(v, m) from `g` = [`Microfacet::smith_g1_of`]`(v)`: 0 where `m` is back-facing as
    /// seen from `v`'s side.
    #[inline(always)]
    pub fn smith_g1_from(g: L, v: V3<L>, m: V3<L>) -> L {
        let zero = g.splat(0.0);
        L::select((v.dot(m) * v.z).le(zero), zero, g)
    }
}
