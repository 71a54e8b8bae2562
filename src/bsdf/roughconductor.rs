//! `roughconductor`: a rough metal, the Cook–Torrance microfacet BRDF
//! f = F(wi·h) D(h) G(wi, wo, h) / (4 cos θi cos θo) (Walter et al. 2007, eq. 20) with the conductor
//! Fresnel term per RGB channel, Beckmann or GGX, isotropic or anisotropic. One-sided.
//!
//! Sampling picks a microfacet normal (visible normals by default) and reflects `wi` about it;
//! with visible-normal sampling the weight is simply F · G1(wo, h).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `material` | string | `none` | a named conductor's (η, k) ([`super::named_conductor`]) |
//! | `eta`, `k` | spectrum | 0, 1 | the complex index η + ik, instead of `material` |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflectance |
//! | `distribution` | string | `beckmann` | `beckmann` or `ggx` |
//! | `alpha` | float or texture | 0.1 | roughness (isotropic) |
//! | `alpha_u`, `alpha_v` | float or texture | 0.1 | roughness along the tangent and bitangent, instead of `alpha` |
//! | `sample_visible` | boolean | true | sample the visible normals |

use super::fresnel::fresnel_conductor;
use super::microfacet::MicrofacetDistribution;
use super::{is_positive, BsdfSample, Lobes};
use crate::math::reflect;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    /// Distribution, `alpha_u`/`alpha_v` and `sample_visible` (defaults: Beckmann, 0.1, true).
    pub distribution: MicrofacetDistribution,
    /// Real part of the relative index (default: material "none", η = 0).
    pub eta: Spectrum,
    /// Imaginary part (default: material "none", k = 1).
    pub k: Spectrum,
    /// Multiplier of the reflectance (default 1).
    pub specular_reflectance: Spectrum,
}

impl RoughConductor {
    #[inline]
    fn fresnel(&self, cos_theta: f32) -> Spectrum {
        self.specular_reflectance * fresnel_conductor(cos_theta, self.eta, self.k)
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(wi, wo).0
    }

    /// `(eval, pdf)` sharing the half vector, D(h) and G1(wi, h).
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let h = (wi + wo).normalize();
        let d = self.distribution.eval(h);
        if d == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let g1i = self.distribution.smith_g1(wi, h);
        // f cos θo = F D G / (4 cos θi).
        let f =
            self.fresnel(wi.dot(h)) * (d * g1i * self.distribution.smith_g1(wo, h) / (4.0 * wi.z));
        (f, self.distribution.reflection_pdf(wi, wo, h, d, g1i))
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let d = self.distribution.eval(h);
        let g1i = if self.distribution.sample_visible {
            self.distribution.smith_g1(wi, h)
        } else {
            1.0
        };
        self.distribution.reflection_pdf(wi, wo, h, d, g1i)
    }

    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let (m, pm) = self.distribution.sample(wi, u);
        if !is_positive(pm) {
            return None;
        }
        let wo = reflect(wi, m);
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = pm / (4.0 * wo.dot(m));
        let w = if self.distribution.sample_visible {
            self.distribution.smith_g1(wo, m)
        } else {
            self.distribution.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        if !is_positive(pdf) || !is_positive(w) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.fresnel(wi.dot(m)) * w,
            eta: 1.0,
            lobe: Lobes::GLOSSY_REFLECTION,
        })
    }
}

impl Default for RoughConductor {
    /// Mitsuba's defaults: Beckmann, α = 0.1, visible sampling, material "none" (η 0, k 1).
    fn default() -> Self {
        RoughConductor {
            distribution: MicrofacetDistribution::default(),
            eta: Spectrum::ZERO,
            k: Spectrum::ONE,
            specular_reflectance: Spectrum::ONE,
        }
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::RoughConductor;
    use crate::bsdf::ior::load::conductor_ior;
    use crate::bsdf::microfacet::load::distribution;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot};

    /// `roughconductor`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let (eta, k) = conductor_ior(cx.props())?;
        let (spec, mut slots) =
            cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        let (distribution, alpha_slots) = distribution(cx, true, true)?;
        slots.extend(alpha_slots);
        let template = BsdfNode::RoughConductor(RoughConductor {
            distribution,
            eta,
            k,
            specular_reflectance: spec,
        });
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
