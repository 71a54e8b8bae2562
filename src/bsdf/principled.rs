//! `principled`: the Disney principled BSDF (Burley 2012, "Physically Based Shading at Disney";
//! Burley 2015, "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering") as
//! Mitsuba 3.9.1 implements it, without subsurface scattering. Lobes:
//! - diffuse with retro-reflection and fake subsurface (`flatness`), weight (1 − metallic)(1 − spec_trans);
//! - sheen, weight `sheen`·(1 − metallic), tinted by `sheen_tint`;
//! - the main GGX specular reflection (anisotropic), with Disney's Fresnel: the dielectric Fresnel
//!   blended with Schlick terms for `metallic` (tinted by `base_color`) and `spec_tint`;
//! - GGX transmission (Walter et al. 2007) tinted by √base_color, weight (1 − metallic)·spec_trans;
//! - clearcoat: GTR1 with Schlick Fresnel (R0 = 0.04), separable GGX masking of α 0.25.
//!
//! From the back side (`wi.z < 0`) only the dielectric reflection and transmission remain.
//! Sampling picks diffuse, clearcoat, transmission or reflection by the sampling rates
//! (`*_sampling_rate`) and the Fresnel term at the sampled facet, as Mitsuba does.
//!
//! | parameter | type (Mitsuba 3) | default |
//! | --- | --- | --- |
//! | `base_color` | colour or texture | 0.5 |
//! | `roughness` | float or texture | 0.5 |
//! | `anisotropic` | float or texture | 0 |
//! | `metallic` | float or texture | 0 |
//! | `spec_trans` | float or texture | 0 |
//! | `eta` or `specular` (not both) | float | specular 0.5 (η = 2/(1 − √(0.08·specular)) − 1 = 1.5) |
//! | `spec_tint` | float or texture | 0 |
//! | `sheen` | float or texture | 0 |
//! | `sheen_tint` | float or texture | 0 |
//! | `flatness` | float or texture | 0 |
//! | `clearcoat` | float or texture | 0 |
//! | `clearcoat_gloss` | float or texture | 0 |
//! | `main_specular_sampling_rate` | float | 1 |
//! | `clearcoat_sampling_rate` | float | 1 |
//! | `diffuse_reflectance_sampling_rate` | float | 1 |
//!
//! As in Mitsuba, a `spec_trans` given (and not the constant 0) enables the transmission lobe and
//! then moves η = 1 to 1.001 (specular 0 to 0.001), which is not a plausible interface.

use super::disney::{
    alphas, clearcoat_g, diffuse_base, facet_compatible, schlick, schlick_r0, schlick_rgb,
    sheen as sheen_lobe, tint_color, Gtr1,
};
use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::{MicrofacetDistribution, MicrofacetType};
use super::{BsdfSample, Lobes, TransportMode};
use crate::error::{Error, Result};
use crate::material::{MaterialNode, PrincipledMaterial, Slot, TexId};
use crate::math::{reflect, warp};
use crate::scene::xml::props::Props;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// The parameters of one `principled` BSDF at a hit (textures already evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    pub base_color: Spectrum,
    pub roughness: f32,
    pub anisotropic: f32,
    pub metallic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    /// Relative index of refraction (inside / outside).
    pub eta: f32,
    pub main_specular_sampling_rate: f32,
    pub clearcoat_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
    /// The transmission lobe exists (Mitsuba's `m_has_spec_trans`): it changes the back side's
    /// sampling probabilities and the lobes, even where `spec_trans` evaluates to 0.
    pub has_spec_trans: bool,
}

impl Default for Principled {
    /// Mitsuba's defaults: grey, roughness 0.5, specular 0.5 (η 1.5), every other weight 0.
    fn default() -> Self {
        Principled {
            base_color: Spectrum::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            metallic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            eta: eta_from_specular(0.5),
            main_specular_sampling_rate: 1.0,
            clearcoat_sampling_rate: 1.0,
            diffuse_reflectance_sampling_rate: 1.0,
            has_spec_trans: false,
        }
    }
}

/// The relative index whose normal-incidence reflectance is 0.08·`specular` (Burley 2015, §5.2:
/// `specular` 0.5 is η 1.5).
pub fn eta_from_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

/// What one (wi, wo) pair shares between `eval` and `pdf`.
struct Geometry {
    cos_i: f32,
    cos_o: f32,
    front: bool,
    reflect: bool,
    refract: bool,
    /// η seen along the path (η from the front, 1/η from the back).
    eta_path: f32,
    wh: Vec3,
    /// Dielectric Fresnel at wi·wh.
    f: f32,
    reflect_ok: bool,
    refract_ok: bool,
}

impl Principled {
    /// The lobes (Mitsuba's components): diffuse and glossy reflection, glossy transmission when
    /// `transmits`.
    pub fn lobes(transmits: bool) -> Lobes {
        let l = Lobes::DIFFUSE_REFLECTION | Lobes::GLOSSY_REFLECTION;
        if transmits {
            l | Lobes::GLOSSY_TRANSMISSION
        } else {
            l
        }
    }

    /// The main specular distribution (GGX, visible normals).
    #[inline]
    fn distribution(&self) -> MicrofacetDistribution {
        let (ax, ay) = alphas(self.anisotropic, self.roughness);
        MicrofacetDistribution::anisotropic(MicrofacetType::Ggx, ax, ay, true)
    }

    /// Weights of the reflective base and of the transmission: (1 − m)(1 − t), (1 − m) t.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let brdf = (1.0 - self.metallic) * (1.0 - self.spec_trans);
        let bsdf = if self.has_spec_trans {
            (1.0 - self.metallic) * self.spec_trans
        } else {
            0.0
        };
        (brdf, bsdf)
    }

    fn geometry(&self, wi: Vec3, wo: Vec3) -> Geometry {
        let cos_i = wi.z;
        let cos_o = wo.z;
        let front = cos_i > 0.0;
        let reflect = cos_i * cos_o > 0.0;
        let refract = cos_i * cos_o < 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        // The (generalised) half vector, turned outward.
        let wh = (wi + wo * if reflect { 1.0 } else { eta_path }).normalize();
        let wh = if wh.z.is_sign_negative() { -wh } else { wh };
        let f = fresnel_dielectric(wi.dot(wh), self.eta).r;
        Geometry {
            cos_i,
            cos_o,
            front,
            reflect,
            refract,
            eta_path,
            wh,
            f,
            reflect_ok: facet_compatible(wh, wi, wo, cos_i, true),
            refract_ok: facet_compatible(wh, wi, wo, cos_i, false),
        }
    }

    /// Disney's specular Fresnel: from the front, the dielectric term for the (1 − metallic)
    /// (1 − spec_tint) share plus Schlick terms for metallic (R0 = base colour) and the tinted
    /// dielectric (R0 = tint · R0(η)); from the back the plain dielectric term times the
    /// transmission weight.
    fn fresnel(&self, f_dielectric: f32, cos_theta_i: f32, front: bool, bsdf: f32) -> Spectrum {
        if !front {
            return Spectrum::splat(bsdf * f_dielectric);
        }
        let eta_it = if cos_theta_i >= 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let m = self.metallic;
        let metal = m * schlick_rgb(self.base_color, cos_theta_i, self.eta);
        let r0_tint = tint_color(self.base_color) * schlick_r0(eta_it);
        let tinted = (1.0 - m) * self.spec_tint * schlick_rgb(r0_tint, cos_theta_i, self.eta);
        Spectrum::splat((1.0 - m) * (1.0 - self.spec_tint) * f_dielectric) + metal + tinted
    }

    pub fn eval(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z == 0.0 {
            return Spectrum::ZERO;
        }
        let g = self.geometry(wi, wo);
        self.eval_with(mode, wi, wo, &g, &self.distribution())
    }

    fn eval_with(
        &self,
        mode: TransportMode,
        wi: Vec3,
        wo: Vec3,
        g: &Geometry,
        distr: &MicrofacetDistribution,
    ) -> Spectrum {
        let (brdf, bsdf) = self.weights();
        let mut value = Spectrum::ZERO;
        let spec_reflect = g.reflect && g.reflect_ok && g.f > 0.0;
        let spec_trans =
            self.has_spec_trans && bsdf > 0.0 && g.refract && g.refract_ok && g.f < 1.0;
        if spec_reflect || spec_trans {
            let d = distr.eval(g.wh);
            let gg = distr.g(wi, wo, g.wh);
            if spec_reflect {
                let f = self.fresnel(g.f, wi.dot(g.wh), g.front, bsdf);
                value += f * (d * gg / (4.0 * g.cos_i.abs()));
            }
            if spec_trans {
                // Radiance is compressed by 1/η² on crossing (Veach 1997, §5.2).
                let scale = match mode {
                    TransportMode::Radiance => 1.0 / (g.eta_path * g.eta_path),
                    TransportMode::Importance => 1.0,
                };
                let dih = wi.dot(g.wh);
                let doh = wo.dot(g.wh);
                let denom = dih + g.eta_path * doh;
                let t = (scale * (1.0 - g.f) * d * gg * g.eta_path * g.eta_path * dih * doh
                    / (g.cos_i * denom * denom))
                    .abs();
                value += self.base_color.map(f32::sqrt) * (bsdf * t);
            }
        }
        if !g.front || !g.reflect {
            return value;
        }
        if self.clearcoat > 0.0 && g.reflect_ok {
            let fcc = schlick(0.04, wi.dot(g.wh), self.eta);
            let dcc = Gtr1::clearcoat(self.clearcoat_gloss).eval(g.wh);
            let gcc = clearcoat_g(wi, wo, g.wh);
            value += Spectrum::splat(0.25 * self.clearcoat * fcc * dcc * gcc * g.cos_o.abs());
        }
        // Mitsuba 3.9.1 (scalar) evaluates sheen inside the diffuse branch: no sheen where the
        // diffuse weight is 0.
        if brdf > 0.0 {
            let cos_d = g.wh.dot(wo);
            let base = diffuse_base(
                g.cos_i.abs(),
                g.cos_o.abs(),
                cos_d,
                self.roughness,
                self.flatness,
            );
            value += self.base_color * (brdf * g.cos_o.abs() * crate::math::INV_PI * base);
            if self.sheen > 0.0 && 1.0 - self.metallic > 0.0 {
                value += sheen_lobe(self.base_color, self.sheen_tint, cos_d)
                    * (self.sheen * (1.0 - self.metallic) * g.cos_o.abs());
            }
        }
        value
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z == 0.0 {
            return 0.0;
        }
        let g = self.geometry(wi, wo);
        self.pdf_with(wi, wo, &g, &self.distribution())
    }

    fn pdf_with(&self, wi: Vec3, wo: Vec3, g: &Geometry, distr: &MicrofacetDistribution) -> f32 {
        let (brdf, bsdf) = self.weights();
        let (p_diffuse, p_clearcoat, p_reflect, p_trans) =
            self.probabilities(g.front, brdf, bsdf, g.f);
        let doh = wo.dot(g.wh);
        let dwh_dwo = if g.refract && self.has_spec_trans {
            let denom = wi.dot(g.wh) + g.eta_path * doh;
            (g.eta_path * g.eta_path * doh / (denom * denom)).abs()
        } else {
            (1.0 / (4.0 * doh)).abs()
        };
        let wi_up = if g.cos_i.is_sign_negative() { -wi } else { wi };
        let mut pdf = 0.0;
        if g.reflect {
            if g.reflect_ok {
                pdf += p_reflect * distr.pdf(wi_up, g.wh) * dwh_dwo;
                if p_clearcoat > 0.0 {
                    pdf += p_clearcoat * Gtr1::clearcoat(self.clearcoat_gloss).pdf(g.wh) * dwh_dwo;
                }
            }
            pdf += p_diffuse * warp::cosine_hemisphere_pdf(wo);
        }
        if g.refract && self.has_spec_trans && g.refract_ok {
            pdf += p_trans * distr.pdf(wi_up, g.wh) * dwh_dwo;
        }
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// Normalised probabilities of (diffuse, clearcoat, specular reflection, transmission) given
    /// the dielectric Fresnel term `f` at the facet. From the front the two specular lobes
    /// share the main specular rate in proportion F : (1 − F) of the transmitted part.
    fn probabilities(&self, front: bool, brdf: f32, bsdf: f32, f: f32) -> (f32, f32, f32, f32) {
        let srate = self.main_specular_sampling_rate;
        let (pd, pc, pr, pt) = if front {
            (
                brdf * self.diffuse_reflectance_sampling_rate,
                0.25 * self.clearcoat * self.clearcoat_sampling_rate,
                srate * (1.0 - bsdf * (1.0 - f)),
                if self.has_spec_trans {
                    srate * bsdf * (1.0 - f)
                } else {
                    0.0
                },
            )
        } else {
            (0.0, 0.0, f, if self.has_spec_trans { 1.0 - f } else { 0.0 })
        };
        let inv = 1.0 / (pd + pc + pr + pt);
        (pd * inv, pc * inv, pr * inv, pt * inv)
    }

    /// `(eval, pdf)` sharing the half vector, Fresnel term and distribution.
    pub fn eval_pdf(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let g = self.geometry(wi, wo);
        let distr = self.distribution();
        (
            self.eval_with(mode, wi, wo, &g, &distr),
            self.pdf_with(wi, wo, &g, &distr),
        )
    }

    pub fn sample(&self, mode: TransportMode, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let front = cos_i > 0.0;
        let (brdf, bsdf) = self.weights();
        // Inside, only the transmission lobe's material scatters.
        if !front && bsdf <= 0.0 {
            return None;
        }
        // The diffuse and clearcoat shares do not depend on the facet (the specular lobes'
        // sum is the main rate from the front, 1 from the back): pick them first.
        let (p_diffuse, p_clearcoat, _, _) = self.probabilities(front, brdf, bsdf, 0.5);
        let (wo, lobe, eta) = if u1 < p_diffuse {
            (
                warp::square_to_cosine_hemisphere(u2),
                Lobes::DIFFUSE_REFLECTION,
                1.0,
            )
        } else if u1 < p_diffuse + p_clearcoat {
            let m = Gtr1::clearcoat(self.clearcoat_gloss).sample(u2);
            let wo = reflect(wi, m);
            if !(facet_compatible(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0) {
                return None;
            }
            (wo, Lobes::GLOSSY_REFLECTION, 1.0)
        } else {
            let wi_up = if front { wi } else { -wi };
            let m = self.distribution().sample_normal(wi_up, u2);
            let fr = fresnel_dielectric(wi.dot(m), self.eta);
            let (_, _, _, p_trans) = self.probabilities(front, brdf, bsdf, fr.r);
            if self.has_spec_trans && u1 < p_diffuse + p_clearcoat + p_trans {
                let wo = refract(wi, m, fr.cos_theta_t, fr.eta_ti);
                if !(facet_compatible(m, wi, wo, cos_i, false) && cos_i * wo.z < 0.0) {
                    return None;
                }
                (wo, Lobes::GLOSSY_TRANSMISSION, fr.eta_it)
            } else {
                let wo = reflect(wi, m);
                if !(facet_compatible(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0) {
                    return None;
                }
                (wo, Lobes::GLOSSY_REFLECTION, 1.0)
            }
        };
        let (value, pdf) = self.eval_pdf(mode, wi, wo);
        if !super::is_positive(pdf) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: value / pdf,
            eta,
            lobe,
        })
    }

    /// Write a texture value into the parameter `slot` (colour slots use `v`, scalar slots `s`).
    pub fn patch(&mut self, slot: Slot, v: Vec3, s: f32) {
        match slot {
            Slot::BaseColor => self.base_color = v,
            Slot::Roughness => self.roughness = s,
            Slot::Anisotropic => self.anisotropic = s,
            Slot::Metallic => self.metallic = s,
            Slot::SpecTrans => self.spec_trans = s,
            Slot::SpecTint => self.spec_tint = s,
            Slot::Sheen => self.sheen = s,
            Slot::SheenTint => self.sheen_tint = s,
            Slot::Flatness => self.flatness = s,
            Slot::Clearcoat => self.clearcoat = s,
            Slot::ClearcoatGloss => self.clearcoat_gloss = s,
            // The loader only creates the slots above for this model.
            _ => {}
        }
    }
}

/// A float parameter that Mitsuba reads with `get_texture`: a texture (returned as a slot, and
/// counted as "given") or a `<float>` (Mitsuba's `get_flag`: given unless it is the constant 0).
/// Returns (value, given, slot).
pub(crate) fn scalar_param(
    p: &Props<'_>,
    name: &str,
    slot: Slot,
    default: f32,
    texture: &mut dyn FnMut(&str) -> Result<Option<TexId>>,
    slots: &mut Vec<(Slot, TexId)>,
) -> Result<(f32, bool)> {
    if let Some(t) = texture(name)? {
        slots.push((slot, t));
        return Ok((default, true));
    }
    match p.float_opt(name)? {
        Some(v) if !v.is_finite() => Err(Error::scene(
            p.loc(),
            format!("'{name}' of bsdf '{}' must be finite", p.plugin_type()),
        )),
        Some(v) => Ok((v, v != 0.0)),
        None => Ok((default, false)),
    }
}

/// `base_color`: a colour in [0, 1] or a texture.
pub(crate) fn base_color_param(
    p: &Props<'_>,
    texture: &mut dyn FnMut(&str) -> Result<Option<TexId>>,
    slots: &mut Vec<(Slot, TexId)>,
) -> Result<Spectrum> {
    if let Some(t) = texture("base_color")? {
        slots.push((Slot::BaseColor, t));
        return Ok(Spectrum::splat(0.5));
    }
    p.color("base_color", Spectrum::splat(0.5))
}

/// A plain float that must be finite and ≥ 0 (sampling rates).
pub(crate) fn rate_param(p: &Props<'_>, name: &str) -> Result<f32> {
    let v = p.float(name, 1.0)?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::scene(
            p.loc(),
            format!(
                "'{name}' of bsdf '{}' must be a number >= 0",
                p.plugin_type()
            ),
        ))
    }
}

/// Every nested object must be a texture for one of `names` (which `texture` then consumes).
pub(crate) fn check_objects(p: &Props<'_>, names: &[&str]) -> Result<()> {
    for c in p.objects() {
        let name = c.attr("name").unwrap_or("");
        if !names.contains(&name) {
            return Err(Error::scene(
                &c.loc,
                format!(
                    "<{}{}> is not expected inside bsdf '{}' (textures may drive: {})",
                    c.tag,
                    if name.is_empty() {
                        String::new()
                    } else {
                        format!(" name=\"{name}\"")
                    },
                    p.plugin_type(),
                    names.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// Build a `principled` material from its XML properties. `texture(name)` returns the texture
/// the element nests (or references) under `name`, if any, and errors for a nested object that
/// is not a texture. The caller checks for unreferenced properties.
pub fn material(
    p: &Props<'_>,
    texture: &mut dyn FnMut(&str) -> Result<Option<TexId>>,
) -> Result<MaterialNode> {
    const TEXTURED: &[&str] = &[
        "base_color",
        "roughness",
        "anisotropic",
        "metallic",
        "spec_trans",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "flatness",
        "clearcoat",
        "clearcoat_gloss",
    ];
    check_objects(p, TEXTURED)?;
    let mut slots = Vec::new();
    let mut b = Principled {
        base_color: base_color_param(p, texture, &mut slots)?,
        ..Principled::default()
    };
    let mut scalar = |name: &str, slot: Slot, default: f32| {
        scalar_param(p, name, slot, default, texture, &mut slots)
    };
    b.roughness = scalar("roughness", Slot::Roughness, 0.5)?.0;
    b.anisotropic = scalar("anisotropic", Slot::Anisotropic, 0.0)?.0;
    let (spec_trans, has_spec_trans) = scalar("spec_trans", Slot::SpecTrans, 0.0)?;
    b.spec_trans = spec_trans;
    b.has_spec_trans = has_spec_trans;
    b.metallic = scalar("metallic", Slot::Metallic, 0.0)?.0;
    b.spec_tint = scalar("spec_tint", Slot::SpecTint, 0.0)?.0;
    b.sheen = scalar("sheen", Slot::Sheen, 0.0)?.0;
    b.sheen_tint = scalar("sheen_tint", Slot::SheenTint, 0.0)?.0;
    b.flatness = scalar("flatness", Slot::Flatness, 0.0)?.0;
    b.clearcoat = scalar("clearcoat", Slot::Clearcoat, 0.0)?.0;
    b.clearcoat_gloss = scalar("clearcoat_gloss", Slot::ClearcoatGloss, 0.0)?.0;
    b.main_specular_sampling_rate = rate_param(p, "main_specular_sampling_rate")?;
    b.clearcoat_sampling_rate = rate_param(p, "clearcoat_sampling_rate")?;
    b.diffuse_reflectance_sampling_rate = rate_param(p, "diffuse_reflectance_sampling_rate")?;
    b.eta = match (p.float_opt("eta")?, p.float_opt("specular")?) {
        (Some(_), Some(_)) => {
            return Err(Error::scene(
                p.loc(),
                "bsdf 'principled' takes either 'eta' or 'specular', not both",
            ))
        }
        (Some(eta), None) if has_spec_trans && eta == 1.0 => 1.001,
        (Some(eta), None) => eta,
        (None, s) => {
            let s = s.unwrap_or(0.5);
            eta_from_specular(if has_spec_trans && s == 0.0 { 1e-3 } else { s })
        }
    };
    if !(b.eta.is_finite() && b.eta > 0.0) {
        return Err(Error::scene(
            p.loc(),
            format!(
                "bsdf 'principled' needs eta > 0 (or specular in [0, 12.5)), got eta {}",
                b.eta
            ),
        ));
    }
    if b.main_specular_sampling_rate
        + b.clearcoat_sampling_rate
        + b.diffuse_reflectance_sampling_rate
        <= 0.0
    {
        return Err(Error::scene(
            p.loc(),
            "bsdf 'principled' needs a sampling rate > 0",
        ));
    }
    Ok(MaterialNode::Principled(Box::new(
        PrincipledMaterial::Full { template: b, slots },
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specular_maps_to_eta() {
        assert!((eta_from_specular(0.5) - 1.5).abs() < 1e-6);
        assert!((eta_from_specular(0.0) - 1.0).abs() < 1e-7);
    }

    #[test]
    fn back_side_without_transmission_does_not_scatter() {
        let b = Principled::default();
        let wi = Vec3::new(0.3, 0.0, -0.954).normalize();
        assert!(b
            .sample(TransportMode::Radiance, wi, 0.5, Vec2::new(0.3, 0.7))
            .is_none());
        let wo = Vec3::new(-0.3, 0.1, -0.9).normalize();
        assert_eq!(b.eval(TransportMode::Radiance, wi, wo), Spectrum::ZERO);
    }
}
