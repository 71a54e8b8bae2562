//! `roughdielectric`: a rough interface between two dielectrics, the microfacet BSDF of
//! Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces":
//! - reflection  f_r = F D G / (4 |cos θi| |cos θo|)                                    (eq. 20)
//! - refraction  f_t = |wi·h| |wo·h| η² (1 − F) D G / (|cos θi| |cos θo| (wi·h + η wo·h)²) (eq. 21)
//!   with the generalised half vector h ∝ −(wi + η wo) (eq. 16) and η = η_t/η_i of the crossing.
//!
//! Both sides work (a query from inside uses the inverted index). As in Mitsuba 3, `f_t` above is
//! the importance-transport form; in [`TransportMode::Radiance`] it is divided by η² (radiance is
//! compressed into the smaller solid angle of the denser side). The radiance BSDF then satisfies
//! f(wo, wi) = (η_o/η_i)² f(wi, wo), η_i and η_o being the indices on the sides of wi and wo
//! (Veach 1997, §5.2); reflection is plainly reciprocal.
//!
//! Sampling: a microfacet normal from the distribution as seen from `wi` (flipped to the upper
//! side), then reflection or refraction chosen with probability F / 1 − F. Without visible-normal
//! sampling the roughness of the sampling distribution is widened by 1.2 − 0.2 √|cos θi|
//! (Walter et al. 2007, §5.3), as Mitsuba does.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `int_ior` | float or string | 1.5046 (`bk7`) | interior index of refraction, a number or a name ([`super::named_ior`]) |
//! | `ext_ior` | float or string | 1.000277 (`air`) | exterior index of refraction |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflection |
//! | `specular_transmittance` | spectrum or texture | 1 | multiplier of the transmission |
//! | `distribution` | string | `beckmann` | `beckmann` or `ggx` |
//! | `alpha` | float or texture | 0.1 | roughness (isotropic) |
//! | `alpha_u`, `alpha_v` | float or texture | 0.1 | roughness along the tangent and bitangent, instead of `alpha` |
//! | `sample_visible` | boolean | true | sample the visible normals |

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::MicrofacetDistribution;
use super::{is_positive, BsdfSample, Lobes, TransportMode};
use crate::math::reflect;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Distribution, roughness and sampling strategy (defaults: Beckmann, 0.1, true).
    pub distribution: MicrofacetDistribution,
    /// Relative index `int_ior / ext_ior` (default bk7 / air).
    pub eta: f32,
    pub specular_reflectance: Spectrum,
    pub specular_transmittance: Spectrum,
}

#[inline]
fn flip_to_upper(v: Vec3) -> Vec3 {
    if v.z < 0.0 {
        -v
    } else {
        v
    }
}

impl RoughDielectric {
    /// From Mitsuba's parameters.
    pub fn new(
        distribution: MicrofacetDistribution,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Spectrum,
        specular_transmittance: Spectrum,
    ) -> Self {
        RoughDielectric {
            distribution,
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
    }

    /// The distribution `sample` draws from for this `wi`.
    #[inline]
    fn sampling_distribution(&self, cos_theta_i: f32) -> MicrofacetDistribution {
        if self.distribution.sample_visible {
            self.distribution
        } else {
            self.distribution
                .scaled(1.2 - 0.2 * cos_theta_i.abs().sqrt())
        }
    }

    /// The half vector of (wi, wo) oriented to the upper side, whether the pair is a reflection,
    /// and the relative index η_t/η_i of the crossing; `None` for unusable configurations.
    #[inline]
    fn half_vector(&self, wi: Vec3, wo: Vec3) -> Option<(Vec3, bool, f32)> {
        let (ci, co) = (wi.z, wo.z);
        if ci == 0.0 || co == 0.0 {
            return None;
        }
        let is_reflect = ci * co > 0.0;
        let eta = if ci > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = wi + wo * if is_reflect { 1.0 } else { eta };
        let h = flip_to_upper(h.normalize_or_zero());
        // Only facets seen from the front by both directions contribute.
        if !(wi.dot(h) * ci > 0.0 && wo.dot(h) * co > 0.0) {
            return None;
        }
        Some((h, is_reflect, eta))
    }

    pub fn eval(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> Spectrum {
        let Some((h, is_reflect, eta)) = self.half_vector(wi, wo) else {
            return Spectrum::ZERO;
        };
        let d = self.distribution.eval(h);
        if d == 0.0 {
            return Spectrum::ZERO;
        }
        let f = fresnel_dielectric(wi.dot(h), self.eta).r;
        let g1i = self.distribution.smith_g1(wi, h);
        self.value(mode, wi, wo, (h, is_reflect, eta), f, d, g1i)
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let Some(hv) = self.half_vector(wi, wo) else {
            return 0.0;
        };
        let f = fresnel_dielectric(wi.dot(hv.0), self.eta).r;
        self.density(wi, wo, hv, f, None)
    }

    /// `(eval, pdf)` sharing the half vector, the Fresnel term, D(h) and G1(wi, h).
    pub fn eval_pdf(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let Some(hv) = self.half_vector(wi, wo) else {
            return (Spectrum::ZERO, 0.0);
        };
        let h = hv.0;
        let d = self.distribution.eval(h);
        let f = fresnel_dielectric(wi.dot(h), self.eta).r;
        // G1 is even in its direction argument, so G1(wi, h) also serves the flipped wi of the pdf.
        let g1i = self.distribution.smith_g1(wi, h);
        let value = if d == 0.0 {
            Spectrum::ZERO
        } else {
            self.value(mode, wi, wo, hv, f, d, g1i)
        };
        (value, self.density(wi, wo, hv, f, Some((d, g1i))))
    }

    /// f·|cos θo| for the half vector `(h, is_reflect, eta)`, Fresnel reflectance `f`, D(h) = `d`
    /// and G1(wi, h) = `g1i` (Walter et al. 2007, eqs. 20–21).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn value(
        &self,
        mode: TransportMode,
        wi: Vec3,
        wo: Vec3,
        (h, is_reflect, eta): (Vec3, bool, f32),
        f: f32,
        d: f32,
        g1i: f32,
    ) -> Spectrum {
        let g = g1i * self.distribution.smith_g1(wo, h);
        if is_reflect {
            self.specular_reflectance * (f * d * g / (4.0 * wi.z.abs()))
        } else {
            let (dih, doh) = (wi.dot(h), wo.dot(h));
            let denom = dih + eta * doh;
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta * eta),
                TransportMode::Importance => 1.0,
            };
            let v =
                ((1.0 - f) * d * g * eta * eta * dih * doh * scale / (wi.z * denom * denom)).abs();
            if v.is_finite() {
                self.specular_transmittance * v
            } else {
                Spectrum::ZERO
            }
        }
    }

    /// The density of `sample` producing `wo`, for the half vector `(h, is_reflect, eta)` and
    /// Fresnel reflectance `f`; `shared` = (D(h), G1(wi, h)) of the unscaled distribution when the
    /// caller has them (used when that distribution is the sampling one).
    #[inline]
    fn density(
        &self,
        wi: Vec3,
        wo: Vec3,
        (h, is_reflect, eta): (Vec3, bool, f32),
        f: f32,
        shared: Option<(f32, f32)>,
    ) -> f32 {
        let doh = wo.dot(h);
        // Jacobians dωh/dωo of reflection (1/(4 wo·h)) and refraction (η² wo·h / (wi·h + η wo·h)²).
        let dh_dwo = if is_reflect {
            1.0 / (4.0 * doh)
        } else {
            let denom = wi.dot(h) + eta * doh;
            eta * eta * doh / (denom * denom)
        };
        let wi_up = flip_to_upper(wi);
        let pm = match shared {
            // Visible normals: D_wi(h) = D(h) G1(wi, h) |wi·h| / cos θi (the form of `pdf`).
            Some((d, g1i)) if self.distribution.sample_visible => {
                if wi_up.z <= 0.0 {
                    0.0
                } else {
                    d * g1i * wi_up.dot(h).abs() / wi_up.z
                }
            }
            _ => self.sampling_distribution(wi.z).pdf(wi_up, h),
        };
        let p = pm * if is_reflect { f } else { 1.0 - f } * dh_dwo.abs();
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    pub fn sample(&self, mode: TransportMode, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let ci = wi.z;
        if ci == 0.0 {
            return None;
        }
        let sd = self.sampling_distribution(ci);
        let (m, pm) = sd.sample(flip_to_upper(wi), u2);
        if !is_positive(pm) {
            return None;
        }
        let fr = fresnel_dielectric(wi.dot(m), self.eta);
        let is_reflect = u1 <= fr.r;
        let (wo, eta, pdf, mut weight, lobe_kind) = if is_reflect {
            let wo = reflect(wi, m);
            if !is_positive(ci * wo.z) {
                return None;
            }
            let pdf = pm * fr.r / (4.0 * wo.dot(m)).abs();
            (
                wo,
                1.0,
                pdf,
                self.specular_reflectance,
                Lobes::GLOSSY_REFLECTION,
            )
        } else {
            let wo = refract(wi, m, fr.cos_theta_t, fr.eta_ti);
            if !is_positive(-ci * wo.z) {
                return None;
            }
            let (dih, doh) = (wi.dot(m), wo.dot(m));
            let denom = dih + fr.eta_it * doh;
            let pdf = pm * (1.0 - fr.r) * (fr.eta_it * fr.eta_it * doh / (denom * denom)).abs();
            let scale = match mode {
                TransportMode::Radiance => fr.eta_ti * fr.eta_ti,
                TransportMode::Importance => 1.0,
            };
            (
                wo,
                fr.eta_it,
                pdf,
                self.specular_transmittance * scale,
                Lobes::GLOSSY_TRANSMISSION,
            )
        };
        // With F / (1 − F) as the lobe choice the Fresnel factor cancels.
        let w = if self.distribution.sample_visible {
            self.distribution.smith_g1(wo, m)
        } else {
            (self.distribution.eval(m) * self.distribution.g(wi, wo, m) * wi.dot(m) / (pm * ci))
                .abs()
        };
        weight *= w;
        if !(is_positive(pdf) && pdf.is_finite() && is_positive(w)) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight,
            eta,
            lobe: lobe_kind,
        })
    }
}

impl Default for RoughDielectric {
    /// Mitsuba's defaults: Beckmann, α = 0.1, visible sampling, bk7 inside air.
    fn default() -> Self {
        RoughDielectric::new(
            MicrofacetDistribution::default(),
            super::dielectric::DEFAULT_INT_IOR,
            super::dielectric::DEFAULT_EXT_IOR,
            Spectrum::ONE,
            Spectrum::ONE,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::RoughDielectric;
    use crate::bsdf::dielectric::load::{interface, Interface};
    use crate::bsdf::microfacet::load::distribution;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;

    /// `roughdielectric`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            mut slots,
        } = interface(cx)?;
        let (distribution, alpha_slots) = distribution(cx, true, true)?;
        slots.extend(alpha_slots);
        let template =
            BsdfNode::RoughDielectric(RoughDielectric::new(distribution, int_ior, ext_ior, r, tr));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
