//! The microfacet distributions of `bsdf::microfacet` (Beckmann and GGX, anisotropic, Smith
//! masking) per lane, with the roughness per lane (textured roughness) and the model and
//! sampling strategy shared by the lanes (one material per batch).
//!
//! Same formulas, order and guards as `bsdf::microfacet::MicrofacetDistribution`, so width 1
//! equals it bit for bit where no transcendental function is taken (GGX `eval`, `lambda`,
//! `smith_g1`, `pdf`, Beckmann `lambda`, `smith_g1`); Beckmann's `eval` (exp) and the samplers
//! (sincos, log) use the polynomials of [`super::math`] instead of libm.
//! - D(m): Walter et al. 2007; Beckmann's G1 by its rational approximation (eq. 27);
//! - visible GGX normals: Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical Caps";
//! - all normals (D(m) cos θm): slope-space inversion (Walter et al. 2007, eqs. 28–29).
//!
//! Not here yet: Beckmann visible-normal sampling (groove's scalar one inverts a CDF by Newton
//! iterations in f64) and the Heitz 2018 concentric-disk map used for `roughplastic`'s tables.

use super::math::{exp, log, sincos};
use super::vec::{V2, V3};
use super::warp::safe_sqrt;
use super::Lane;
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
        let ok = ct.gt(k(0.0)) & (d * ct).gt(k(1e-20)) & d.is_finite();
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
        let g = L::select(normal, k(1.0), g);
        L::select((v.dot(m) * v.z).le(k(0.0)), k(0.0), g)
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

    /// A sampled microfacet normal. Visible normals: GGX only (Beckmann's visible sampler is
    /// not ported yet: it returns `None` so the caller cannot mistake it).
    #[inline(always)]
    pub fn sample_normal(&self, wi: V3<L>, u: V2<L>) -> Option<V3<L>> {
        if !self.sample_visible {
            return Some(self.sample_all_normals(u));
        }
        match self.kind {
            MicrofacetType::Ggx => Some(self.sample_visible_ggx(wi, u)),
            MicrofacetType::Beckmann => None,
        }
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
        let wi_s = V3::new(
            self.alpha_u * wi.x,
            self.alpha_v * wi.y,
            rust_max(wi.z, k(0.0)),
        );
        let len = wi_s.length();
        let v = wi_s.div_by(len);
        let z = (k(1.0) - u.y) * (k(1.0) + v.z) - v.z;
        let sin_t = safe_sqrt(k(1.0) - z * z);
        let (s, c) = sincos(k(2.0 * PI) * u.x);
        let m = self.unstretch(V3::new(sin_t * c + v.x, sin_t * s + v.y, z + v.z));
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
