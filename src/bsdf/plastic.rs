//! `plastic`: a diffuse base under a smooth dielectric coating (Mitsuba's smooth plastic, after
//! Weidlich & Wilkie 2007, "Arbitrarily Layered Micro-Facet Surfaces", restricted to a smooth
//! interface). Two lobes:
//! - delta specular reflection off the coating, weight F(θi) · `specular_reflectance`;
//! - the diffuse base seen through the coating: light refracts in (1 − F(θi)), bounces inside
//!   between the base (albedo ρ) and the coating (which reflects a fraction F_dr of diffuse light
//!   back), and refracts out (1 − F(θo)), with the radiance compression 1/η²:
//!   f_d = (1 − F(θi)) (1 − F(θo)) ρ / (π η² (1 − F_dr))   (`nonlinear = false`), or with
//!   1 − ρ F_dr in the denominator (`nonlinear = true`, the geometric series of the bounces,
//!   which also shifts the colour).
//!
//! The lobe is chosen with probabilities ∝ F(θi) w_s and (1 − F(θi)) (1 − w_s), where the
//! `specular_sampling_weight` w_s = mean(specular) / (mean(diffuse) + mean(specular)) as in Mitsuba.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `int_ior` | float or string | 1.49 (`polypropylene`) | index of refraction of the coating, a number or a name ([`super::named_ior`]) |
//! | `ext_ior` | float or string | 1.000277 (`air`) | exterior index of refraction |
//! | `diffuse_reflectance` | spectrum or texture | 0.5 | albedo of the base |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the coating's reflection |
//! | `nonlinear` | boolean | false | account for the colour shift of the internal bounces |

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance, reflect_z};
use super::{BsdfSample, Lobes};
use crate::math::warp;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// Mitsuba's default interior index of `plastic`/`roughplastic` (polypropylene).
pub const DEFAULT_PLASTIC_INT_IOR: f32 = 1.49;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// Albedo of the base (default 0.5).
    pub diffuse_reflectance: Spectrum,
    /// Multiplier of the coating's specular reflection (default 1).
    pub specular_reflectance: Spectrum,
    /// Relative index `int_ior / ext_ior` (default polypropylene 1.49 / air 1.000277).
    pub eta: f32,
    /// Model the colour shift of repeated internal bounces (default false).
    pub nonlinear: bool,
    /// Probability weight of the specular lobe before Fresnel; Mitsuba derives it from the means
    /// of the (possibly textured) reflectances over the whole texture — a textured material should
    /// set it from the texture means once, not per hit.
    pub specular_sampling_weight: f32,
    /// Diffuse Fresnel reflectance of the coating seen from inside, F_dr(1/η).
    pub fdr_int: f32,
}

/// Mean of the RGB channels (Mitsuba's `mean()` of an RGB texture value).
#[inline]
pub(super) fn mean(c: Spectrum) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// w_s = mean(specular) / (mean(diffuse) + mean(specular)).
pub fn specular_sampling_weight(
    diffuse_reflectance: Spectrum,
    specular_reflectance: Spectrum,
) -> f32 {
    let (d, s) = (mean(diffuse_reflectance), mean(specular_reflectance));
    s / (d + s)
}

impl Plastic {
    /// From Mitsuba's parameters `diffuse_reflectance`, `specular_reflectance`, `int_ior`,
    /// `ext_ior`, `nonlinear`.
    pub fn new(
        diffuse_reflectance: Spectrum,
        specular_reflectance: Spectrum,
        int_ior: f32,
        ext_ior: f32,
        nonlinear: bool,
    ) -> Self {
        let eta = int_ior / ext_ior;
        Plastic {
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
            specular_sampling_weight: specular_sampling_weight(
                diffuse_reflectance,
                specular_reflectance,
            ),
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
        }
    }

    /// Probability of choosing the specular lobe at incidence cosine `cos_theta_i`, and F(θi).
    #[inline]
    fn prob_specular(&self, cos_theta_i: f32) -> (f32, f32) {
        let f_i = fresnel_dielectric(cos_theta_i, self.eta).r;
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        (ps / (ps + pd), f_i)
    }

    /// ρ / (1 − F_dr) or ρ / (1 − ρ F_dr).
    #[inline]
    fn diffuse_albedo(&self) -> Spectrum {
        let d = self.diffuse_reflectance;
        if self.nonlinear {
            d / (Spectrum::ONE - d * self.fdr_int)
        } else {
            d / (1.0 - self.fdr_int)
        }
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f_i = fresnel_dielectric(wi.z, self.eta).r;
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        self.diffuse_albedo()
            * (warp::cosine_hemisphere_pdf(wo) * (1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta))
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let (ps, _) = self.prob_specular(wi.z);
        warp::cosine_hemisphere_pdf(wo) * (1.0 - ps)
    }

    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let (ps, f_i) = self.prob_specular(wi.z);
        if u1 < ps {
            // Delta lobe: pdf reported as 0 by convention, weight = F / P(specular).
            return Some(BsdfSample {
                wo: reflect_z(wi),
                pdf: 0.0,
                weight: self.specular_reflectance * (f_i / ps),
                eta: 1.0,
                lobe: Lobes::DELTA_REFLECTION,
            });
        }
        let pd = 1.0 - ps;
        let wo = warp::square_to_cosine_hemisphere(u2);
        if wo.z <= 0.0 {
            return None;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        Some(BsdfSample {
            wo,
            pdf: pd * warp::cosine_hemisphere_pdf(wo),
            weight: self.diffuse_albedo()
                * ((1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta * pd)),
            eta: 1.0,
            lobe: Lobes::DIFFUSE_REFLECTION,
        })
    }
}

impl Default for Plastic {
    fn default() -> Self {
        Plastic::new(
            Spectrum::splat(0.5),
            Spectrum::ONE,
            DEFAULT_PLASTIC_INT_IOR,
            super::dielectric::DEFAULT_EXT_IOR,
            false,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Plastic;
    use crate::bsdf::dielectric::DEFAULT_EXT_IOR;
    use crate::bsdf::ior::load::ior_param;
    use crate::bsdf::plastic::DEFAULT_PLASTIC_INT_IOR;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot};

    /// `plastic`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let int_ior = ior_param(cx.props(), "int_ior", DEFAULT_PLASTIC_INT_IOR)?;
        let ext_ior = ior_param(cx.props(), "ext_ior", DEFAULT_EXT_IOR)?;
        // Sampling weights come from the textures' means, as Mitsuba does.
        let (d, mut slots) = cx.leaf_color("diffuse_reflectance", Slot::DiffuseReflectance, 0.5)?;
        let (sr, s2) = cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        slots.extend(s2);
        let nonlinear = cx.props().bool("nonlinear", false)?;
        let template = BsdfNode::Plastic(Plastic::new(d, sr, int_ior, ext_ior, nonlinear));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
