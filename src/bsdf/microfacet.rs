//! Microfacet normal distributions: Beckmann and GGX (Trowbridge–Reitz), isotropic or anisotropic
//! (`alpha_u` along the local x axis, `alpha_v` along y), with Smith's separable masking-shadowing
//! G(wi, wo, m) = G1(wi, m) G1(wo, m) and two sampling strategies:
//! - `sample_visible = true`: the distribution of normals visible from `wi`,
//!   D_wi(m) = G1(wi, m) max(0, wi·m) D(m) / cos θi (Heitz & d'Eon 2014, "Importance Sampling
//!   Microfacet-Based BSDFs using the Distribution of Visible Normals"); GGX uses Heitz 2018,
//!   "Sampling the GGX Distribution of Visible Normals" (hemisphere of the stretched configuration)
//!   for `roughplastic`'s tables and Dupuy & Benyoub 2023's spherical caps for rendering,
//!   Beckmann samples the visible slope distribution of the stretched (α = 1) configuration by
//!   inverting its marginal CDF (Heitz & d'Eon 2014, §4);
//! - `sample_visible = false`: D(m) cos θm (Walter et al. 2007, eqs. 28–29, written in slope space).
//!
//! Semantics and numerical guards follow Mitsuba 3 so renders match it: D is cut to 0 where
//! D·cos θm < 1e-20, Beckmann's G1 uses Walter et al.'s rational approximation (2007, eq. 27).

use crate::lane::microfacet::Microfacet;
use glam::{Vec2, Vec3};

/// Which normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    Beckmann,
    Ggx,
}

impl MicrofacetType {
    /// Mitsuba's XML names: "beckmann", "ggx".
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "beckmann" => Some(MicrofacetType::Beckmann),
            "ggx" => Some(MicrofacetType::Ggx),
            _ => None,
        }
    }
}

/// A microfacet distribution with its roughness and sampling strategy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetDistribution {
    pub kind: MicrofacetType,
    pub alpha_u: f32,
    pub alpha_v: f32,
    pub sample_visible: bool,
}

/// Smallest roughness accepted: below it the peak of D overflows f32 (Mitsuba clamps to 1e-4 too).
pub const MIN_ALPHA: f32 = 1e-4;

impl Default for MicrofacetDistribution {
    /// Mitsuba's defaults for the rough BSDFs: Beckmann, α = 0.1, visible-normal sampling.
    fn default() -> Self {
        MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.1, true)
    }
}

impl MicrofacetDistribution {
    /// An isotropic distribution (`alpha` as given in the XML, clamped to [`MIN_ALPHA`]).
    pub fn new(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Self {
        Self::anisotropic(kind, alpha, alpha, sample_visible)
    }

    /// An anisotropic distribution.
    pub fn anisotropic(
        kind: MicrofacetType,
        alpha_u: f32,
        alpha_v: f32,
        sample_visible: bool,
    ) -> Self {
        MicrofacetDistribution {
            kind,
            alpha_u: alpha_u.max(MIN_ALPHA),
            alpha_v: alpha_v.max(MIN_ALPHA),
            sample_visible,
        }
    }

    /// The same distribution with both roughnesses multiplied by `s`.
    pub fn scaled(&self, s: f32) -> Self {
        MicrofacetDistribution {
            alpha_u: self.alpha_u * s,
            alpha_v: self.alpha_v * s,
            ..*self
        }
    }

    /// D(m): microfacet normal density per solid angle (projected-area normalised:
    /// ∫ D(m) cos θm dm = 1).
    pub fn eval(&self, m: Vec3) -> f32 {
        self.lanes().eval(m.into())
    }

    /// This distribution as the width-1 lane kernel (`lane::microfacet`): the scalar renderer
    /// evaluates D, Λ, G1 and the densities there, so both widths share one source.
    /// The distribution with its parameters in every lane (the width of `like`).
    #[inline(always)]
    pub(crate) fn splat_lanes<L: crate::lane::Lane>(&self, like: L) -> Microfacet<L> {
        Microfacet {
            kind: self.kind,
            alpha_u: like.splat(self.alpha_u),
            alpha_v: like.splat(self.alpha_v),
            sample_visible: self.sample_visible,
        }
    }

    #[inline(always)]
    fn lanes(&self) -> Microfacet<f32> {
        Microfacet {
            kind: self.kind,
            alpha_u: self.alpha_u,
            alpha_v: self.alpha_v,
            sample_visible: self.sample_visible,
        }
    }

    /// Smith's Λ(v) (so that G1 = 1 / (1 + Λ) for the facets visible from `v`). Beckmann uses the
    /// inverse of Walter et al.'s rational approximation of G1 to stay consistent with [`Self::smith_g1`].
    pub fn lambda(&self, v: Vec3) -> f32 {
        self.lanes().lambda(v.into())
    }

    /// Smith's monodirectional masking G1(v, m); 0 when `m` is back-facing as seen from `v`'s
    /// side. GGX: Walter et al. 2007, eq. 34; Beckmann: their rational approximation (eq. 27,
    /// exact to ~0.35%).
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        self.lanes().smith_g1(v.into(), m.into())
    }

    /// Separable masking-shadowing G(wi, wo, m) = G1(wi, m) G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density (per solid angle of `m`) with which [`Self::sample`] produces `m` from `wi`
    /// (`wi.z > 0` expected; callers flip a back-side `wi`).
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        self.lanes().pdf(wi.into(), m.into())
    }

    /// Density of a reflection sampled through the microfacet normal `h = normalize(wi + wo)`,
    /// given `d = D(h)` and `g1i = G1(wi, h)` (unused without visible sampling). The Jacobian of
    /// the reflection map is dωh / dωo = 1 / (4 wo·h) (Walter et al. 2007, eq. 14).
    #[inline]
    pub fn reflection_pdf(&self, wi: Vec3, wo: Vec3, h: Vec3, d: f32, g1i: f32) -> f32 {
        self.lanes()
            .reflection_pdf(wi.into(), wo.into(), h.into(), d, g1i)
    }

    /// Sample a microfacet normal; returns `(m, pdf(wi, m))`.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        let m = self.sample_normal(wi, u);
        (m, self.pdf(wi, m))
    }

    /// Sample a microfacet normal without its density (for callers that compute their own).
    #[inline]
    pub fn sample_normal(&self, wi: Vec3, u: Vec2) -> Vec3 {
        if self.sample_visible {
            self.sample_visible_normal(wi, u)
        } else {
            self.sample_all_normals(u)
        }
    }

    /// [`Self::sample_normal`]'s distribution with `u` mapped to normals as Mitsuba 3 maps it
    /// (GGX: Heitz 2018 over the concentric disk). Same density, different map: a quadrature
    /// over the sample square (`roughplastic`'s tables) then reproduces Mitsuba's numbers,
    /// while rendering uses the cheaper spherical-cap map.
    pub fn sample_normal_mitsuba_map(&self, wi: Vec3, u: Vec2) -> Vec3 {
        self.lanes()
            .sample_normal_mitsuba_map(wi.into(), u.into())
            .into()
    }

    /// D(m) cos θm: sample the slope distribution of the α = 1 configuration and stretch it by
    /// (α_u, α_v) (slopes transform linearly; Heitz 2014, "Understanding the Masking-Shadowing
    /// Function in Microfacet-Based BRDFs", §5.3).
    fn sample_all_normals(&self, u: Vec2) -> Vec3 {
        self.lanes().sample_all_normals(u.into()).into()
    }

    /// Visible normals: GGX by spherical caps (Dupuy & Benyoub 2023), Beckmann by inverting
    /// the visible slopes' marginal CDF in f32 (Heitz & d'Eon 2014, §4); both the lane kernel
    /// at width 1 (`lane::microfacet`).
    fn sample_visible_normal(&self, wi: Vec3, u: Vec2) -> Vec3 {
        let l = self.lanes();
        match self.kind {
            MicrofacetType::Ggx => l.sample_visible_ggx(wi.into(), u.into()).into(),
            MicrofacetType::Beckmann => l.sample_visible_beckmann(wi.into(), u.into()).into(),
        }
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton iteration on P_n from the Chebyshev
/// guesses; Abramowitz & Stegun 25.4.29).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            let pm1 = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * p - pm1) / (x * x - 1.0);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[n - 1 - i] = x;
        weights[n - 1 - i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// Reading a distribution from the scene file (for `roughconductor`, `roughdielectric`,
/// `roughplastic`; their parameter tables list it).
pub(crate) mod load {
    use super::{MicrofacetDistribution, MicrofacetType};
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::load::check;
    use crate::material::{Slot, TexId};
    use crate::spectrum::luminance;

    /// `distribution`, `alpha` or `alpha_u`/`alpha_v`, `sample_visible` (Mitsuba's defaults:
    /// beckmann, 0.1, true). `anisotropic` = false for models that are isotropic only;
    /// `textured` = the roughness may be a texture (Mitsuba 3: roughconductor and
    /// roughdielectric, not roughplastic), returned as scalar slots to fill per hit (the
    /// distribution then holds the texture's mean, for load-time decisions only).
    pub(crate) fn distribution(
        cx: &mut BsdfCtx<'_, '_>,
        anisotropic: bool,
        textured: bool,
    ) -> Result<(MicrofacetDistribution, Vec<(Slot, TexId)>)> {
        let p = cx.props();
        let name = p.string("distribution", "beckmann")?;
        let kind = MicrofacetType::from_name(&name).ok_or_else(|| {
            Error::scene(
                p.loc(),
                format!("distribution '{name}' must be 'beckmann' or 'ggx'"),
            )
        })?;
        let visible = p.bool("sample_visible", true)?;
        let mut textures = [None; 3];
        for (i, k) in ["alpha", "alpha_u", "alpha_v"].into_iter().enumerate() {
            let found = cx.props().objects().find(|c| c.attr("name") == Some(k));
            if let Some(c) = found {
                let p = cx.props();
                if !textured || p.kind(c) != "texture" {
                    return Err(Error::scene(
                        &c.loc,
                        if textured {
                            format!("'{k}' expects a number or a <texture>, not a <{}>", c.tag)
                        } else {
                            format!("'{k}' of bsdf '{}' must be a number (Mitsuba 3 takes no texture here)", p.plugin_type())
                        },
                    ));
                }
                textures[i] = Some(cx.texture(c)?);
            }
        }
        let p = cx.props();
        let given = |i: usize, k: &str| textures[i].is_some() || p.has(k);
        let mut slots = Vec::new();
        // A scalar parameter: a texture (its mean now, a slot per hit) or a checked number.
        let mut alpha = |i: usize, k: &str, slot: Slot| -> Result<f32> {
            if let Some(t) = textures[i] {
                slots.push((slot, t));
                return Ok(luminance(cx.texture_at(t).mean()));
            }
            let a = p.float(k, 0.1)?;
            check(p.loc(), a.is_finite() && a >= 0.0, "alpha must be >= 0")?;
            Ok(a)
        };
        if anisotropic && (given(1, "alpha_u") || given(2, "alpha_v")) {
            if given(0, "alpha") {
                return Err(Error::scene(
                    p.loc(),
                    "give either 'alpha' or 'alpha_u'/'alpha_v', not both",
                ));
            }
            let au = alpha(1, "alpha_u", Slot::AlphaU)?;
            let av = alpha(2, "alpha_v", Slot::AlphaV)?;
            let d = MicrofacetDistribution::anisotropic(kind, au, av, visible);
            return Ok((d, slots));
        }
        let a = alpha(0, "alpha", Slot::Alpha)?;
        Ok((MicrofacetDistribution::new(kind, a, visible), slots))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::PI;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(5);
        let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(8)).sum();
        assert!((s - 2.0 / 9.0).abs() < 1e-12, "{s}");
        let (x, w) = gauss_legendre(32);
        let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.cos()).sum();
        assert!((s - 2.0 * 1f64.sin()).abs() < 1e-12);
    }

    /// ∫ D(m) cos θm dm = 1 and ∫ D_wi(m) dm = 1 (midpoint rule over the hemisphere).
    #[test]
    fn normalisation() {
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for (au, av) in [(0.3f32, 0.3f32), (0.5, 0.2)] {
                let d = MicrofacetDistribution::anisotropic(kind, au, av, true);
                let wi = Vec3::new(0.6, 0.3, 0.7).normalize();
                let (nt, np) = (600, 600);
                let (mut a, mut b) = (0.0f64, 0.0f64);
                for i in 0..nt {
                    let ct = (i as f32 + 0.5) / nt as f32;
                    let st = (1.0 - ct * ct).sqrt();
                    for j in 0..np {
                        let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                        let m = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                        let dw = (1.0 / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
                        a += (d.eval(m) * ct) as f64 * dw;
                        b += d.pdf(wi, m) as f64 * dw;
                    }
                }
                assert!((a - 1.0).abs() < 5e-3, "{kind:?} {a}");
                // Beckmann's G1 is an approximation: visible normals integrate to 1 ± 0.5%.
                assert!((b - 1.0).abs() < 1e-2, "{kind:?} {b}");
            }
        }
    }
}
