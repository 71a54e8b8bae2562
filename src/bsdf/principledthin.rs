//! `principledthin`: the thin-surface variant of the Disney BSDF (Burley 2015, "Extending the
//! Disney BRDF to a BSDF with Integrated Subsurface Scattering", §5.3 and fig. 15) as Mitsuba
//! 3.9.1 implements it. A two-sided sheet with no interior: both sides see the same lobes
//! (directions are mirrored to the front), nothing bends on crossing.
//! - diffuse with retro-reflection and fake subsurface (`flatness`) and sheen, weight
//!   (1 − spec_trans)(1 − diff_trans/2);
//! - Lambertian transmission, weight (1 − spec_trans)·diff_trans/2 (`diff_trans` ranges over [0, 2]);
//! - GGX reflection with the dielectric Fresnel blended toward a tinted Schlick term by
//!   `spec_tint`, weight `spec_trans`;
//! - GGX transmission straight through (the reflection mirrored to the other side) with
//!   roughness scaled by (0.65 η − 0.35) (Burley 2015, fig. 15), tinted by `base_color`,
//!   weight `spec_trans`·(1 − F).
//!
//! | parameter | type (Mitsuba 3) | default |
//! | --- | --- | --- |
//! | `base_color` | colour or texture | 0.5 |
//! | `roughness` | float or texture | 0.5 |
//! | `anisotropic` | float or texture | 0 |
//! | `spec_trans` | float or texture | 0 |
//! | `eta` | float or texture | 1.5 |
//! | `spec_tint` | float or texture | 0 |
//! | `sheen` | float or texture | 0 |
//! | `sheen_tint` | float or texture | 0 |
//! | `flatness` | float or texture | 0 |
//! | `diff_trans` | float or texture | 0 |
//! | `specular_reflectance_sampling_rate` | float | 1 |
//! | `specular_transmittance_sampling_rate` | float | 1 |
//! | `diffuse_reflectance_sampling_rate` | float | 1 |
//! | `diffuse_transmittance_sampling_rate` | float | 1 |

use super::disney::{
    alphas, diffuse_base, facet_compatible, schlick_r0, schlick_rgb, sheen as sheen_lobe,
    tint_color,
};
use super::fresnel::fresnel_dielectric;
use super::microfacet::{MicrofacetDistribution, MicrofacetType};
use super::principled::{base_color_param, check_objects, rate_param, scalar_param};
use super::{BsdfSample, Lobes};
use crate::error::Result;
use crate::material::{MaterialNode, PrincipledMaterial, Slot, TexId};
use crate::math::{reflect, warp};
use crate::scene::xml::props::Props;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// The parameters of one `principledthin` BSDF at a hit (textures already evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledThin {
    pub base_color: Spectrum,
    pub roughness: f32,
    pub anisotropic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    /// As given, in [0, 2] (the lobes use half of it).
    pub diff_trans: f32,
    /// Relative index of the sheet.
    pub eta: f32,
    pub specular_reflectance_sampling_rate: f32,
    pub specular_transmittance_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
    pub diffuse_transmittance_sampling_rate: f32,
}

impl Default for PrincipledThin {
    /// Mitsuba's defaults: grey, roughness 0.5, η 1.5, every other weight 0.
    fn default() -> Self {
        PrincipledThin {
            base_color: Spectrum::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
            diff_trans: 0.0,
            eta: 1.5,
            specular_reflectance_sampling_rate: 1.0,
            specular_transmittance_sampling_rate: 1.0,
            diffuse_reflectance_sampling_rate: 1.0,
            diffuse_transmittance_sampling_rate: 1.0,
        }
    }
}

/// The front-side view of a pair shared by `eval` and `pdf`.
struct Geometry {
    /// `wi` and `wo` mirrored so that `wi` is on the front.
    wi: Vec3,
    wo: Vec3,
    reflect: bool,
    refract: bool,
    /// Half vector of `wi` and `wo` mirrored to the front (also for transmission).
    wh: Vec3,
    reflect_ok: bool,
    refract_ok: bool,
}

impl PrincipledThin {
    /// The lobes (Mitsuba's components): diffuse and glossy reflection, diffuse transmission,
    /// glossy transmission when `transmits`.
    pub fn lobes(transmits: bool) -> Lobes {
        let l = Lobes::DIFFUSE_REFLECTION | Lobes::GLOSSY_REFLECTION | Lobes::DIFFUSE_TRANSMISSION;
        if transmits {
            l | Lobes::GLOSSY_TRANSMISSION
        } else {
            l
        }
    }

    fn reflection_distribution(&self) -> MicrofacetDistribution {
        let (ax, ay) = alphas(self.anisotropic, self.roughness);
        MicrofacetDistribution::anisotropic(MicrofacetType::Ggx, ax, ay, true)
    }

    /// Transmission roughness scaled by (0.65 η − 0.35) (Burley 2015, fig. 15).
    fn transmission_distribution(&self) -> MicrofacetDistribution {
        let r = (0.65 * self.eta - 0.35) * self.roughness;
        let (ax, ay) = alphas(self.anisotropic, r);
        MicrofacetDistribution::anisotropic(MicrofacetType::Ggx, ax, ay, true)
    }

    fn geometry(&self, wi: Vec3, wo: Vec3) -> Geometry {
        let (wi, wo) = if wi.z.is_sign_negative() {
            (-wi, -wo)
        } else {
            (wi, wo)
        };
        let wo_r = Vec3::new(wo.x, wo.y, wo.z.abs());
        let wh = (wi + wo_r).normalize();
        Geometry {
            wi,
            wo,
            reflect: wo.z > 0.0,
            refract: wo.z < 0.0,
            wh,
            reflect_ok: facet_compatible(wh, wi, wo, wi.z, true),
            refract_ok: facet_compatible(wh, wi, wo, wi.z, false),
        }
    }

    /// (spec reflection, spec transmission, diffuse reflection, diffuse transmission)
    /// probabilities, normalised.
    fn probabilities(&self) -> (f32, f32, f32, f32) {
        let dt = 0.5 * self.diff_trans;
        let sr = 0.5 * self.spec_trans * self.specular_reflectance_sampling_rate;
        let st = 0.5 * self.spec_trans * self.specular_transmittance_sampling_rate;
        let dr = self.diffuse_reflectance_sampling_rate * (1.0 - self.spec_trans) * (1.0 - dt);
        let dtr = self.diffuse_transmittance_sampling_rate * (1.0 - self.spec_trans) * dt;
        let inv = 1.0 / (sr + st + dr + dtr);
        (sr * inv, st * inv, dr * inv, dtr * inv)
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z == 0.0 {
            return Spectrum::ZERO;
        }
        self.eval_with(&self.geometry(wi, wo))
    }

    fn eval_with(&self, g: &Geometry) -> Spectrum {
        let (wi, wo, wh) = (g.wi, g.wo, g.wh);
        let cos_i = wi.z;
        let cos_o = wo.z;
        let dt = 0.5 * self.diff_trans;
        let st = self.spec_trans;
        let mut value = Spectrum::ZERO;
        let spec_reflect = st > 0.0 && g.reflect && g.reflect_ok;
        let spec_trans = st > 0.0 && g.refract && g.refract_ok;
        if spec_reflect || spec_trans {
            let f = fresnel_dielectric(wi.dot(wh), self.eta).r;
            if spec_reflect {
                let d = self.reflection_distribution();
                // The dielectric Fresnel blended toward a tinted Schlick term.
                let r0 = tint_color(self.base_color) * schlick_r0(self.eta);
                let schlick = schlick_rgb(r0, wi.dot(wh), self.eta);
                let fr = Spectrum::splat(f) + (schlick - Spectrum::splat(f)) * self.spec_tint;
                value += fr * (st * d.eval(wh) * d.g(wi, wo, wh) / (4.0 * cos_i));
            } else {
                let d = self.transmission_distribution();
                value += self.base_color
                    * (st * (1.0 - f) * d.eval(wh) * d.g(wi, wo, wh) / (4.0 * cos_i));
            }
        }
        if g.reflect && st < 1.0 && dt < 1.0 {
            let cos_d = wh.dot(wo);
            let base = diffuse_base(cos_i, cos_o.abs(), cos_d, self.roughness, self.flatness);
            let w = (1.0 - st) * (1.0 - dt);
            value += self.base_color * (w * cos_o * crate::math::INV_PI * base);
            if self.sheen > 0.0 {
                value += sheen_lobe(self.base_color, self.sheen_tint, cos_d)
                    * (self.sheen * w * cos_o.abs());
            }
        }
        if g.refract && st < 1.0 && dt > 0.0 {
            value += self.base_color * ((1.0 - st) * dt * crate::math::INV_PI * cos_o.abs());
        }
        value
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z == 0.0 {
            return 0.0;
        }
        self.pdf_with(&self.geometry(wi, wo))
    }

    fn pdf_with(&self, g: &Geometry) -> f32 {
        let (p_sr, p_st, p_dr, p_dt) = self.probabilities();
        let mut pdf = 0.0;
        if self.spec_trans > 0.0 {
            let wo_r = Vec3::new(g.wo.x, g.wo.y, g.wo.z.abs());
            let dwh_dwo = (1.0 / (4.0 * wo_r.dot(g.wh))).abs();
            if g.reflect && g.reflect_ok {
                pdf += p_sr * self.reflection_distribution().pdf(g.wi, g.wh) * dwh_dwo;
            }
            if g.refract && g.refract_ok {
                pdf += p_st * self.transmission_distribution().pdf(g.wi, g.wh) * dwh_dwo;
            }
        }
        if g.reflect {
            pdf += p_dr * warp::cosine_hemisphere_pdf(g.wo);
        }
        if g.refract {
            pdf += p_dt * warp::cosine_hemisphere_pdf(-g.wo);
        }
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// `(eval, pdf)` sharing the mirrored directions and half vector.
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let g = self.geometry(wi, wo);
        (self.eval_with(&g), self.pdf_with(&g))
    }

    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let flip = wi.z.is_sign_negative();
        let wi_f = if flip { -wi } else { wi };
        let (p_sr, p_st, p_dr, _) = self.probabilities();
        let (wo_f, lobe) = if u1 < p_sr {
            let m = self.reflection_distribution().sample_normal(wi_f, u2);
            let wo = reflect(wi_f, m);
            if !(facet_compatible(m, wi_f, wo, wi_f.z, true) && wo.z > 0.0) {
                return None;
            }
            (wo, Lobes::GLOSSY_REFLECTION)
        } else if u1 < p_sr + p_st {
            let m = self.transmission_distribution().sample_normal(wi_f, u2);
            // Straight through: the reflection mirrored to the other side.
            let r = reflect(wi_f, m);
            let wo = Vec3::new(r.x, r.y, -r.z);
            if !(facet_compatible(m, wi_f, wo, wi_f.z, false) && wo.z < 0.0) {
                return None;
            }
            (wo, Lobes::GLOSSY_TRANSMISSION)
        } else if u1 < p_sr + p_st + p_dr || self.diff_trans <= 0.0 {
            (
                warp::square_to_cosine_hemisphere(u2),
                Lobes::DIFFUSE_REFLECTION,
            )
        } else {
            (
                -warp::square_to_cosine_hemisphere(u2),
                Lobes::DIFFUSE_TRANSMISSION,
            )
        };
        let wo = if flip { -wo_f } else { wo_f };
        let (value, pdf) = self.eval_pdf(wi, wo);
        if !super::is_positive(pdf) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: value / pdf,
            eta: 1.0,
            lobe,
        })
    }

    /// Write a texture value into the parameter `slot` (colour slots use `v`, scalar slots `s`).
    pub fn patch(&mut self, slot: Slot, v: Vec3, s: f32) {
        match slot {
            Slot::BaseColor => self.base_color = v,
            Slot::Roughness => self.roughness = s,
            Slot::Anisotropic => self.anisotropic = s,
            Slot::SpecTrans => self.spec_trans = s,
            Slot::SpecTint => self.spec_tint = s,
            Slot::Sheen => self.sheen = s,
            Slot::SheenTint => self.sheen_tint = s,
            Slot::Flatness => self.flatness = s,
            Slot::DiffTrans => self.diff_trans = s,
            Slot::Eta => self.eta = s,
            // The loader only creates the slots above for this model.
            _ => {}
        }
    }
}

/// Build a `principledthin` material from its XML properties (see
/// [`super::principled::material`] for `texture`). The caller checks for unreferenced properties.
pub fn material(
    p: &Props<'_>,
    texture: &mut dyn FnMut(&str) -> Result<Option<TexId>>,
) -> Result<MaterialNode> {
    const TEXTURED: &[&str] = &[
        "base_color",
        "roughness",
        "anisotropic",
        "spec_trans",
        "eta",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "flatness",
        "diff_trans",
    ];
    check_objects(p, TEXTURED)?;
    let mut slots = Vec::new();
    let mut b = PrincipledThin {
        base_color: base_color_param(p, texture, &mut slots)?,
        ..PrincipledThin::default()
    };
    let mut scalar = |name: &str, slot: Slot, default: f32| {
        scalar_param(p, name, slot, default, texture, &mut slots)
    };
    b.roughness = scalar("roughness", Slot::Roughness, 0.5)?.0;
    b.anisotropic = scalar("anisotropic", Slot::Anisotropic, 0.0)?.0;
    let (spec_trans, transmits) = scalar("spec_trans", Slot::SpecTrans, 0.0)?;
    b.spec_trans = spec_trans;
    b.eta = scalar("eta", Slot::Eta, 1.5)?.0;
    b.spec_tint = scalar("spec_tint", Slot::SpecTint, 0.0)?.0;
    b.sheen = scalar("sheen", Slot::Sheen, 0.0)?.0;
    b.sheen_tint = scalar("sheen_tint", Slot::SheenTint, 0.0)?.0;
    b.flatness = scalar("flatness", Slot::Flatness, 0.0)?.0;
    b.diff_trans = scalar("diff_trans", Slot::DiffTrans, 0.0)?.0;
    b.specular_reflectance_sampling_rate = rate_param(p, "specular_reflectance_sampling_rate")?;
    b.specular_transmittance_sampling_rate = rate_param(p, "specular_transmittance_sampling_rate")?;
    b.diffuse_reflectance_sampling_rate = rate_param(p, "diffuse_reflectance_sampling_rate")?;
    b.diffuse_transmittance_sampling_rate = rate_param(p, "diffuse_transmittance_sampling_rate")?;
    if b.specular_reflectance_sampling_rate
        + b.specular_transmittance_sampling_rate
        + b.diffuse_reflectance_sampling_rate
        + b.diffuse_transmittance_sampling_rate
        <= 0.0
    {
        return Err(crate::error::Error::scene(
            p.loc(),
            "bsdf 'principledthin' needs a sampling rate > 0",
        ));
    }
    Ok(MaterialNode::Principled(Box::new(
        PrincipledMaterial::Thin {
            template: b,
            transmits,
            slots,
        },
    )))
}
