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
//! Lane form (`src/bsdf/lanes.rs`, with the transport mode as an argument):
//! [`RoughDielectric::eval_pdf_lanes`], [`RoughDielectric::sample_lanes`] (with the crossing's η
//! per lane), and `eval_lanes` / `pdf_lanes`; the scalar `eval`, `pdf`, `eval_pdf` and `sample`
//! are their width 1, checked bit for bit against the code they replaced (the tests below).
//! At width 1 only the branch the lane takes (reflection or refraction) is computed.
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

use super::lanes::LaneBsdfSample;
use super::microfacet::MicrofacetDistribution;
use super::{BsdfSample, Lobes, TransportMode};
use crate::lane::fresnel::{dielectric as lane_dielectric, Dielectric};
use crate::lane::microfacet::Microfacet;
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneMask};
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

/// `-v` where `v.z < 0`, else `v`.
#[inline(always)]
fn flip_to_upper<L: Lane>(v: V3<L>) -> V3<L> {
    V3::select(v.z.lt(v.z.splat(0.0)), -v, v)
}

/// glam's `normalize_or_zero`: `v · (1/|v|)` where that reciprocal is finite and positive, else 0.
#[inline(always)]
fn normalize_or_zero<L: Lane>(v: V3<L>) -> V3<L> {
    let k = |c: f32| v.x.splat(c);
    let rcp = k(1.0) / v.length();
    let zero = V3::new(k(0.0), k(0.0), k(0.0));
    V3::select(rcp.is_finite() & rcp.gt(k(0.0)), v.scale(rcp), zero)
}

/// `v` in every lane, with the width of `like`.
#[inline(always)]
fn splat3<L: Lane>(like: L, v: Vec3) -> V3<L> {
    V3::splat(like, v.x, v.y, v.z)
}

/// The parameters a texture may set, per lane: the stream kernel's textured leaf gathers them
/// (`Materials::patch_leaf`'s values: the roughness clamped by
/// `MicrofacetDistribution::anisotropic`); the other forms splat the constants
/// ([`RoughDielectric::params_lanes`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Params<L: Lane> {
    pub specular_reflectance: V3<L>,
    pub specular_transmittance: V3<L>,
    /// The distribution (its kind and `sample_visible` are the material's).
    pub distribution: Microfacet<L>,
}

/// The generalised half vector of a pair (Walter et al. 2007, eq. 16), per lane.
#[derive(Clone, Copy, Debug)]
struct Half<L: Lane> {
    /// Oriented to the upper side.
    h: V3<L>,
    /// The pair is a reflection (both directions on one side).
    reflect: L::Mask,
    /// η_t/η_i of the crossing.
    eta: L,
    /// Usable: neither direction in the plane, both see the facet from its front.
    ok: L::Mask,
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

    /// The constant parameters in every lane (the width of `like`).
    #[inline(always)]
    pub(crate) fn params_lanes<L: Lane>(&self, like: L) -> Params<L> {
        Params {
            specular_reflectance: splat3(like, self.specular_reflectance),
            specular_transmittance: splat3(like, self.specular_transmittance),
            distribution: self.distribution.splat_lanes(like),
        }
    }

    /// The distribution `sample` draws from for this `wi` (per lane: without visible-normal
    /// sampling the roughness is widened by 1.2 − 0.2 √|cos θi|, Walter et al. 2007, §5.3).
    #[inline(always)]
    fn sampling_distribution<L: Lane>(&self, p: &Params<L>, cos_theta_i: L) -> Microfacet<L> {
        let d = p.distribution;
        if d.sample_visible {
            return d;
        }
        let k = |c: f32| cos_theta_i.splat(c);
        let s = k(1.2) - k(0.2) * cos_theta_i.abs().sqrt();
        Microfacet {
            alpha_u: d.alpha_u * s,
            alpha_v: d.alpha_v * s,
            ..d
        }
    }

    /// The half vector of (wi, wo), where the pair is usable.
    #[inline(always)]
    fn half_vector<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> Half<L> {
        let k = |c: f32| wi.z.splat(c);
        let (ci, co) = (wi.z, wo.z);
        let planar = ci.eq(k(0.0)) | co.eq(k(0.0));
        let reflect = (ci * co).gt(k(0.0));
        let eta = L::select(ci.gt(k(0.0)), k(self.eta), k(1.0 / self.eta));
        let h = wi + wo.scale(L::select(reflect, k(1.0), eta));
        let h = flip_to_upper(normalize_or_zero(h));
        // Only facets seen from the front by both directions contribute.
        let front = (wi.dot(h) * ci).gt(k(0.0)) & (wo.dot(h) * co).gt(k(0.0));
        Half {
            h,
            reflect,
            eta,
            ok: !planar & front,
        }
    }

    /// [`Self::eval_pdf_lanes`]' value alone: the width-8 form of [`Self::eval`].
    #[inline(always)]
    pub(crate) fn eval_lanes<L: Lane>(&self, mode: TransportMode, wi: V3<L>, wo: V3<L>) -> V3<L> {
        self.valued(&self.params_lanes(wi.z), mode, wi, wo).1
    }

    /// The half vector, f · |cos θo| (0 where the pair is unusable or D(h) = 0), and the
    /// Fresnel reflectance, D(h) and G1(wi, h) it used.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn valued<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (Half<L>, V3<L>, L, L, L) {
        let k = |c: f32| wi.z.splat(c);
        let hv = self.half_vector(wi, wo);
        let dist = p.distribution;
        let d = dist.eval(hv.h);
        let f = lane_dielectric(wi.dot(hv.h), k(self.eta)).r;
        // G1 is even in its direction argument, so G1(wi, h) also serves the flipped wi of the pdf.
        let g1i = dist.smith_g1(wi, hv.h);
        let v = self.value(p, mode, wi, wo, &hv, f, d, g1i);
        let zero = V3::new(k(0.0), k(0.0), k(0.0));
        (hv, V3::select(hv.ok & !d.eq(k(0.0)), v, zero), f, d, g1i)
    }

    /// The density of [`Self::sample_lanes`] alone: the lane form of [`Self::pdf`].
    #[inline(always)]
    pub(crate) fn pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> L {
        let k = |c: f32| wi.z.splat(c);
        let hv = self.half_vector(wi, wo);
        let f = lane_dielectric(wi.dot(hv.h), k(self.eta)).r;
        let p = self.density(&self.params_lanes(wi.z), wi, wo, &hv, f, None);
        L::select(hv.ok, p, k(0.0))
    }

    /// `(f · |cos θo|, pdf)` sharing the half vector, the Fresnel term, D(h) and G1(wi, h), in
    /// transport mode `mode` (uniform over the lanes): the lane form (`bsdf::lanes`, with the
    /// mode); [`Self::eval_pdf`] is its width 1.
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(
        &self,
        mode: TransportMode,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        self.eval_pdf_with(&self.params_lanes(wi.z), mode, wi, wo)
    }

    /// [`Self::eval_pdf_lanes`] with the textured parameters `p` per lane.
    #[inline(always)]
    pub(crate) fn eval_pdf_with<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let (hv, value, f, d, g1i) = self.valued(p, mode, wi, wo);
        let pdf = self.density(p, wi, wo, &hv, f, Some((d, g1i)));
        (value, L::select(hv.ok, pdf, k(0.0)))
    }

    /// f·|cos θo| for the half vector `hv`, Fresnel reflectance `f`, D(h) = `d` and
    /// G1(wi, h) = `g1i` (Walter et al. 2007, eqs. 20–21).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn value<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        wo: V3<L>,
        hv: &Half<L>,
        f: L,
        d: L,
        g1i: L,
    ) -> V3<L> {
        let g = g1i * p.distribution.smith_g1(wo, hv.h);
        // Fast path at width 1: the lane's branch alone (the select would keep it alone; −7 %
        // of the scalar `eval_pdf` instructions on glass). Width 8 computes both and selects:
        // branching on chunks whose lanes all take one branch cost more than it saved there
        // (`docs/bench/README.md`, "Issue 18: direct, textured lights, mixed kinds").
        if L::WIDTH == 1 && hv.reflect.all() {
            self.reflection_value(p, wi, f, d, g)
        } else if L::WIDTH == 1 && !hv.reflect.any() {
            self.refraction_value(p, mode, wi, wo, hv, f, d, g)
        } else {
            let r = self.reflection_value(p, wi, f, d, g);
            V3::select(
                hv.reflect,
                r,
                self.refraction_value(p, mode, wi, wo, hv, f, d, g),
            )
        }
    }

    /// f·|cos θo| of a reflection pair (Walter et al. 2007, eq. 20; `g` = G(wi, wo, h)).
    #[inline(always)]
    fn reflection_value<L: Lane>(&self, p: &Params<L>, wi: V3<L>, f: L, d: L, g: L) -> V3<L> {
        let k = |c: f32| wi.z.splat(c);
        p.specular_reflectance
            .scale(f * d * g / (k(4.0) * wi.z.abs()))
    }

    /// f·|cos θo| of a refraction pair (Walter et al. 2007, eq. 21; 0 where not finite).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn refraction_value<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        wo: V3<L>,
        hv: &Half<L>,
        f: L,
        d: L,
        g: L,
    ) -> V3<L> {
        let k = |c: f32| wi.z.splat(c);
        let (h, eta) = (hv.h, hv.eta);
        let (dih, doh) = (wi.dot(h), wo.dot(h));
        let denom = dih + eta * doh;
        let scale = match mode {
            TransportMode::Radiance => k(1.0) / (eta * eta),
            TransportMode::Importance => k(1.0),
        };
        let v =
            ((k(1.0) - f) * d * g * eta * eta * dih * doh * scale / (wi.z * denom * denom)).abs();
        V3::select(
            v.is_finite(),
            p.specular_transmittance.scale(v),
            V3::new(k(0.0), k(0.0), k(0.0)),
        )
    }

    /// The density of `sample` producing `wo`, for the half vector `hv` and Fresnel
    /// reflectance `f`; `shared` = (D(h), G1(wi, h)) of the unscaled distribution when the
    /// caller has them (used when that distribution is the sampling one).
    #[inline(always)]
    fn density<L: Lane>(
        &self,
        p: &Params<L>,
        wi: V3<L>,
        wo: V3<L>,
        hv: &Half<L>,
        f: L,
        shared: Option<(L, L)>,
    ) -> L {
        let k = |c: f32| wi.z.splat(c);
        let (h, eta) = (hv.h, hv.eta);
        let doh = wo.dot(h);
        // Jacobians dωh/dωo of reflection (1/(4 wo·h)) and refraction (η² wo·h / (wi·h + η wo·h)²).
        let denom = wi.dot(h) + eta * doh;
        let dh_dwo = L::select(
            hv.reflect,
            k(1.0) / (k(4.0) * doh),
            eta * eta * doh / (denom * denom),
        );
        let wi_up = flip_to_upper(wi);
        let pm = match shared {
            // Visible normals: D_wi(h) = D(h) G1(wi, h) |wi·h| / cos θi (the form of `pdf`).
            Some((d, g1i)) if self.distribution.sample_visible => L::select(
                wi_up.z.le(k(0.0)),
                k(0.0),
                d * g1i * wi_up.dot(h).abs() / wi_up.z,
            ),
            _ => self.sampling_distribution(p, wi.z).pdf(wi_up, h),
        };
        let p = pm * L::select(hv.reflect, f, k(1.0) - f) * dh_dwo.abs();
        L::select(p.is_finite(), p, k(0.0))
    }

    /// A microfacet normal from `u2` (seen from `wi` flipped to the upper side), then
    /// reflection where `u1 ≤ F` and refraction elsewhere, in transport mode `mode`: the lane
    /// form (`bsdf::lanes`, with the mode); [`Self::sample`] is its width 1. Also returns the
    /// relative index η of each lane's crossing (1 where reflected) and the reflected lanes.
    /// Lanes outside `ok` hold unspecified values.
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(
        &self,
        mode: TransportMode,
        wi: V3<L>,
        u1: L,
        u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L, L::Mask) {
        self.sample_with(&self.params_lanes(wi.z), mode, wi, u1, u2)
    }

    /// [`Self::sample_lanes`] with the textured parameters `p` per lane.
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        u1: L,
        u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L, L::Mask) {
        let k = |c: f32| wi.z.splat(c);
        let ci = wi.z;
        let sd = self.sampling_distribution(p, ci);
        let wi_up = flip_to_upper(wi);
        let m = sd.sample_normal(wi_up, u2);
        let pm = sd.pdf(wi_up, m);
        let fr = lane_dielectric(wi.dot(m), k(self.eta));
        let reflect = u1.le(fr.r);
        // Fast path at width 1: the lane's branch alone (the selects would keep it alone; −4 %
        // of the scalar `sample` instructions on glass); width 8 computes both (see `value`).
        let (wo, pdf, mut weight) = if L::WIDTH == 1 && reflect.all() {
            self.reflected(p, wi, m, pm, &fr)
        } else if L::WIDTH == 1 && !reflect.any() {
            self.refracted(p, mode, wi, m, pm, &fr)
        } else {
            let (wo_r, pdf_r, w_r) = self.reflected(p, wi, m, pm, &fr);
            let (wo_t, pdf_t, w_t) = self.refracted(p, mode, wi, m, pm, &fr);
            (
                V3::select(reflect, wo_r, wo_t),
                L::select(reflect, pdf_r, pdf_t),
                V3::select(reflect, w_r, w_t),
            )
        };
        let side = L::select(reflect, ci * wo.z, -ci * wo.z).gt(k(0.0));
        // With F / (1 − F) as the lobe choice the Fresnel factor cancels.
        let dist = p.distribution;
        let w = if dist.sample_visible {
            dist.smith_g1(wo, m)
        } else {
            (dist.eval(m) * dist.g(wi, wo, m) * wi.dot(m) / (pm * ci)).abs()
        };
        weight = weight.scale(w);
        let ok =
            !ci.eq(k(0.0)) & pm.gt(k(0.0)) & side & pdf.gt(k(0.0)) & pdf.is_finite() & w.gt(k(0.0));
        let sample = LaneBsdfSample {
            ok,
            wo,
            pdf,
            weight,
        };
        (sample, L::select(reflect, k(1.0), fr.eta_it), reflect)
    }

    /// The reflection of `wi` about the facet normal `m` (math::reflect: 2 (wi·m) m − wi), its
    /// density (facet density `pm`) and weight before the shadowing term.
    #[inline(always)]
    fn reflected<L: Lane>(
        &self,
        p: &Params<L>,
        wi: V3<L>,
        m: V3<L>,
        pm: L,
        fr: &Dielectric<L>,
    ) -> (V3<L>, L, V3<L>) {
        let k = |c: f32| wi.z.splat(c);
        let wo = m.scale(k(2.0) * wi.dot(m)) - wi;
        let pdf = pm * fr.r / (k(4.0) * wo.dot(m)).abs();
        (wo, pdf, p.specular_reflectance)
    }

    /// The refraction of `wi` through the facet normal `m` (fresnel::refract:
    /// m (wi·m η_ti + cos θt) − wi η_ti), its density and weight before the shadowing term.
    #[inline(always)]
    fn refracted<L: Lane>(
        &self,
        p: &Params<L>,
        mode: TransportMode,
        wi: V3<L>,
        m: V3<L>,
        pm: L,
        fr: &Dielectric<L>,
    ) -> (V3<L>, L, V3<L>) {
        let k = |c: f32| wi.z.splat(c);
        let wo = m.scale(wi.dot(m) * fr.eta_ti + fr.cos_theta_t) - wi.scale(fr.eta_ti);
        let (dih, doh) = (wi.dot(m), wo.dot(m));
        let denom = dih + fr.eta_it * doh;
        let pdf = pm * (k(1.0) - fr.r) * (fr.eta_it * fr.eta_it * doh / (denom * denom)).abs();
        let scale = match mode {
            TransportMode::Radiance => fr.eta_ti * fr.eta_ti,
            TransportMode::Importance => k(1.0),
        };
        (wo, pdf, p.specular_transmittance.scale(scale))
    }

    /// [`Self::eval_lanes`] at width 1.
    pub fn eval(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_lanes(mode, V3::from(wi), V3::from(wo)).into()
    }

    /// [`Self::pdf_lanes`] at width 1.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.pdf_lanes(V3::from(wi), V3::from(wo))
    }

    /// `(eval, pdf)`: [`Self::eval_pdf_lanes`] at width 1.
    pub fn eval_pdf(&self, mode: TransportMode, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (f, p) = self.eval_pdf_lanes(mode, V3::from(wi), V3::from(wo));
        (f.into(), p)
    }

    /// [`Self::sample_lanes`] at width 1.
    pub fn sample(&self, mode: TransportMode, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let (s, eta, reflect) = self.sample_lanes(mode, V3::from(wi), u1, V2::from(u2));
        let lobes = (Lobes::GLOSSY_REFLECTION, Lobes::GLOSSY_TRANSMISSION);
        super::dielectric::width_1_sample(s, eta, reflect, lobes)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::*;
    use crate::bsdf::microfacet::MicrofacetType;
    use crate::math::Pcg32;

    /// The scalar code this file had before its lane form, frozen as the reference.
    mod frozen {
        use crate::bsdf::fresnel::{fresnel_dielectric, refract};
        use crate::bsdf::microfacet::MicrofacetDistribution;
        use crate::bsdf::{is_positive, BsdfSample, Lobes, TransportMode};
        use crate::math::reflect;
        use crate::spectrum::Spectrum;
        use glam::{Vec2, Vec3};

        pub(super) struct Frozen {
            pub distribution: MicrofacetDistribution,
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

        impl Frozen {
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
                    let v = ((1.0 - f) * d * g * eta * eta * dih * doh * scale
                        / (wi.z * denom * denom))
                        .abs();
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

            pub fn sample(
                &self,
                mode: TransportMode,
                wi: Vec3,
                u1: f32,
                u2: Vec2,
            ) -> Option<BsdfSample> {
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
                    let pdf =
                        pm * (1.0 - fr.r) * (fr.eta_it * fr.eta_it * doh / (denom * denom)).abs();
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
                    (self.distribution.eval(m) * self.distribution.g(wi, wo, m) * wi.dot(m)
                        / (pm * ci))
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
    }

    fn models() -> Vec<RoughDielectric> {
        use MicrofacetType::{Beckmann, Ggx};
        let tint = (Spectrum::new(0.9, 0.8, 0.7), Spectrum::new(0.6, 0.7, 0.8));
        vec![
            RoughDielectric::default(),
            RoughDielectric::new(
                MicrofacetDistribution::new(Ggx, 0.3, true),
                1.5,
                1.0,
                tint.0,
                tint.1,
            ),
            RoughDielectric::new(
                MicrofacetDistribution::new(Beckmann, 0.2, false),
                1.33,
                1.000277,
                Spectrum::ONE,
                Spectrum::ONE,
            ),
            RoughDielectric::new(
                MicrofacetDistribution::anisotropic(Ggx, 0.05, 0.4, false),
                1.0,
                1.7,
                tint.0,
                tint.1,
            ),
            RoughDielectric::new(
                MicrofacetDistribution::anisotropic(Beckmann, 0.6, 0.15, true),
                2.4,
                1.0,
                Spectrum::ONE,
                tint.1,
            ),
        ]
    }

    fn frozen(b: &RoughDielectric) -> frozen::Frozen {
        frozen::Frozen {
            distribution: b.distribution,
            eta: b.eta,
            specular_reflectance: b.specular_reflectance,
            specular_transmittance: b.specular_transmittance,
        }
    }

    /// Width 1 (`eval`, `pdf`, `eval_pdf`, `sample`) is the frozen scalar code bit for bit on
    /// random pairs from both sides (reflection and refraction pairs, near-horizon and exact
    /// normal directions mixed in), in both transport modes; width 8 is width 1 lane by lane.
    #[test]
    fn lane_form_is_the_replaced_scalar_code_bit_for_bit() {
        let mut r = Pcg32::new(18, 13);
        let (mut nonzero, mut refracted, mut reflected) = (0, 0, 0);
        // Width-8 chunks that sampled reflection in every lane, refraction in every lane.
        let mut uniform = (0u32, 0u32);
        for b in models() {
            let old = frozen(&b);
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                // 4,000 random cases, then 800 whose pairs are all reflections with u1 = 0
                // (every lane samples reflection) and 800 all refractions with u1 = 1 and wi
                // on the side without total internal reflection (every lane refracts but where
                // F = 1): whole chunks of 8 whose lanes take one branch.
                let cases: Vec<(Vec3, Vec3, f32, Vec2)> = (0..5600)
                    .map(|j| {
                        let (mut wi, mut wo) = (direction(&mut r), direction(&mut r));
                        let mut u1 = r.next_f32();
                        if j >= 4000 {
                            let same_side = j < 4800;
                            if !same_side && (wi.z > 0.0) != (b.eta > 1.0) {
                                wi.z = -wi.z;
                            }
                            if (wi.z * wo.z > 0.0) != same_side {
                                wo.z = -wo.z;
                            }
                            u1 = if same_side { 0.0 } else { 1.0 };
                        }
                        (wi, wo, u1, Vec2::new(r.next_f32(), r.next_f32()))
                    })
                    .collect();
                for &(wi, wo, u1, u2) in &cases {
                    let label = format!("{b:?} {mode:?} {wi} {wo} {u1} {u2}");
                    assert!(
                        same3(b.eval(mode, wi, wo), old.eval(mode, wi, wo)),
                        "{label}"
                    );
                    assert!(same(b.pdf(wi, wo), old.pdf(wi, wo)), "{label}");
                    let (f, p) = b.eval_pdf(mode, wi, wo);
                    let (f0, p0) = old.eval_pdf(mode, wi, wo);
                    assert!(same3(f, f0) && same(p, p0), "{label}");
                    nonzero += (f0 != Vec3::ZERO) as u32;
                    let (a, n) = (b.sample(mode, wi, u1, u2), old.sample(mode, wi, u1, u2));
                    assert_eq!(a.is_some(), n.is_some(), "{label}");
                    if let (Some(a), Some(n)) = (a, n) {
                        assert!(same3(a.wo, n.wo) && same3(a.weight, n.weight), "{label}");
                        assert!(same(a.pdf, n.pdf) && same(a.eta, n.eta), "{label}");
                        assert_eq!(a.lobe, n.lobe, "{label}");
                        if a.lobe == Lobes::GLOSSY_TRANSMISSION {
                            refracted += 1;
                        } else {
                            reflected += 1;
                        }
                    }
                }
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = crate::lane::Avx2::detect() {
                    for c in cases.chunks_exact(8) {
                        let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                        let wo: [Vec3; 8] = std::array::from_fn(|k| c[k].1);
                        let u1: [f32; 8] = std::array::from_fn(|k| c[k].2);
                        let u2: [Vec2; 8] = std::array::from_fn(|k| c[k].3);
                        let (f, p, e, q, (s, eta, refl)) = avx.run(|| {
                            let (wi8, wo8) = (load3(avx, &wi), load3(avx, &wo));
                            let (f, p) = b.eval_pdf_lanes(mode, wi8, wo8);
                            let e = b.eval_lanes(mode, wi8, wo8);
                            let q = b.pdf_lanes(wi8, wo8);
                            let s = b.sample_lanes(mode, wi8, avx.load(&u1), load2(avx, &u2));
                            (f, p, e, q, s)
                        });
                        let (ok, refl) = (s.ok.to_array(), refl.to_array());
                        uniform.0 += refl.iter().all(|&x| x) as u32;
                        uniform.1 += refl.iter().all(|&x| !x) as u32;
                        for k in 0..8 {
                            let (wi1, wo1) = (V3::from(wi[k]), V3::from(wo[k]));
                            let (f1, p1) = b.eval_pdf_lanes(mode, wi1, wo1);
                            assert!(same3(lane3(f, k), f1.into()) && same(p.lane(k), p1));
                            let e1 = b.eval_lanes(mode, wi1, wo1);
                            assert!(same3(lane3(e, k), e1.into()));
                            assert!(same(q.lane(k), b.pdf_lanes(wi1, wo1)));
                            let one = b.sample_lanes(mode, wi1, u1[k], V2::from(u2[k]));
                            assert_eq!((ok[k], refl[k]), (one.0.ok, one.2));
                            if ok[k] {
                                assert!(same3(lane3(s.wo, k), one.0.wo.into()));
                                assert!(same3(lane3(s.weight, k), one.0.weight.into()));
                                assert!(same(s.pdf.lane(k), one.0.pdf));
                                assert!(same(eta.lane(k), one.1));
                            }
                        }
                    }
                }
            }
        }
        // Not vacuous: many pairs carry light, both lobes are sampled often.
        assert!(nonzero > 10_000, "{nonzero}");
        assert!(
            refracted > 5_000 && reflected > 1_000,
            "{refracted} {reflected}"
        );
        // Whole chunks took one branch (width 1's fast path against width 8's selects on
        // them): of the 1,000 chunks drawn for each, at least half (a lane with a NaN Fresnel
        // term, or a facet sampled so that it reflects totally, spoils a chunk).
        #[cfg(target_arch = "x86_64")]
        if crate::lane::Avx2::detect().is_some() {
            assert!(uniform.0 >= 500 && uniform.1 >= 500, "{uniform:?}");
        }
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
