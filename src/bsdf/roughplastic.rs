//! `roughplastic`: a diffuse base under a rough dielectric coating (Mitsuba 3's rough plastic,
//! after Weidlich & Wilkie 2007). Two lobes:
//! - the coating's microfacet reflection F D G / (4 cos θi) · `specular_reflectance` (isotropic
//!   Beckmann or GGX);
//! - the base seen through the coating: ρ / (π η² (1 − R_int)) · T(θi) T(θo) cos θo, where
//!   T(θ) is the rough coating's directional transmittance from outside (refracted energy that
//!   is not masked, ∫ (1 − F) G1) and R_int the cosine-weighted albedo of the coating from inside
//!   (`nonlinear`: 1 − ρ R_int in the denominator).
//!
//! Mitsuba precomputes these once per material and so do we, by the same method: the specular
//! albedo R(μ) = ∫ F(wi·m) G1(wo, m) dP_vis(m) is integrated with a 2-D Gauss–Legendre rule over
//! the visible-normal sample space (32² nodes for η > 1, 128² otherwise), likewise the
//! transmittance T(μ) = ∫ (1 − F(wi·m)) G1(wt, m) dP_vis(m), for μ = cos θ on a 64-entry
//! uniform grid (μ₀ clamped to 1e-6) read back with linear interpolation; R_int = 2 · mean(R(μ; 1/η) μ)
//! over the same grid. The lobe choice uses 1 − T(θi) and T(θi) with the specular sampling weight
//! as in `plastic`. The quadrature's integrand is a lane kernel, run 8 nodes wide under AVX2 with
//! the bits of width 1.
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
//! | `distribution` | string | `beckmann` | `beckmann` or `ggx` |
//! | `alpha` | float | 0.1 | roughness (isotropic; no texture, as in Mitsuba 3) |
//! | `sample_visible` | boolean | true | sample the visible normals |

use super::lanes::LaneBsdfSample;
use super::microfacet::{gauss_legendre, MicrofacetDistribution, MicrofacetType};
use super::plastic::{base_albedo, specular_sampling_weight, splat3};
use super::{BsdfSample, Lobes};
use crate::lane::fresnel as lane_fresnel;
use crate::lane::microfacet::Microfacet;
use crate::lane::vec::{V2, V3};
use crate::lane::warp;
#[cfg(target_arch = "x86_64")]
use crate::lane::Avx2;
use crate::lane::{Lane, LaneI32, LaneMask};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use std::sync::{Mutex, OnceLock};

/// Entries of the transmittance table (Mitsuba's resolution).
pub const TRANSMITTANCE_RES: usize = 64;

/// The precomputed coating terms of one (distribution, α, η).
#[derive(Debug, PartialEq)]
pub struct RoughPlasticTable {
    pub external_transmittance: [f32; TRANSMITTANCE_RES],
    pub internal_reflectance: f32,
}

/// Reflected (`transmit = false`) or transmitted energy of a rough dielectric interface lit from
/// `wi` (upper side, relative index `eta`): ∫ F G1(wo, m) resp. ∫ (1 − F) G1(wo, m) over the
/// normals visible from `wi`, by Gauss–Legendre quadrature of the visible-normal warp (as Mitsuba 3).
/// The integrand runs 8 nodes at a time where the CPU has AVX2 (the lane kernels: the same bits
/// as at width 1, so the tables do not depend on the CPU), summed in f64 in node order.
pub fn rough_interface_albedo(
    distr: &MicrofacetDistribution,
    wi: Vec3,
    eta: f32,
    transmit: bool,
) -> f32 {
    albedo(distr, wi, eta, transmit, true)
}

/// [`rough_interface_albedo`], 8 wide when `wide` and the CPU allows (`false`: width 1 only).
fn albedo(distr: &MicrofacetDistribution, wi: Vec3, eta: f32, transmit: bool, wide: bool) -> f32 {
    let d = MicrofacetDistribution {
        sample_visible: true,
        ..*distr
    };
    // Gauss–Legendre rules of both resolutions, computed once per process.
    static RULES: [OnceLock<(Vec<f64>, Vec<f64>)>; 2] = [OnceLock::new(), OnceLock::new()];
    let (slot, res) = if eta > 1.0 { (0, 32) } else { (1, 128) };
    let (nodes, weights) = RULES[slot].get_or_init(|| gauss_legendre(res));
    // The nodes as sample coordinates in [0, 1] (load time: one allocation per call is fine).
    let us: Vec<f32> = nodes.iter().map(|x| (0.5 * x + 0.5) as f32).collect();
    let mut row = vec![0.0f32; us.len()];
    let mut sum = 0.0f64;
    for (&ux, wx) in us.iter().zip(weights) {
        integrand_row(&d, wi, eta, transmit, ux, &us, &mut row, wide);
        for (&v, wy) in row.iter().zip(weights) {
            sum += v as f64 * wx * wy * 0.25;
        }
    }
    sum as f32
}

/// `out[j]` = the integrand at (ux, `uys[j]`): 8 nodes per step inside [`crate::lane::Avx2::run`] when `wide`
/// and the CPU has AVX2, else (and for a tail) at width 1.
#[allow(clippy::too_many_arguments)]
fn integrand_row(
    d: &MicrofacetDistribution,
    wi: Vec3,
    eta: f32,
    transmit: bool,
    ux: f32,
    uys: &[f32],
    out: &mut [f32],
    wide: bool,
) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect().filter(|_| wide) {
        done = integrand_row8(avx, d, wi, eta, transmit, ux, uys, out);
    }
    let l = Microfacet::new(d.kind, d.alpha_u, d.alpha_v, true);
    for (o, &uy) in out[done..].iter_mut().zip(&uys[done..]) {
        *o = integrand(&l, wi.into(), V2::new(ux, uy), eta, transmit);
    }
}

/// The whole chunks of 8 of [`integrand_row`]; returns how many nodes it filled.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn integrand_row8(
    avx: Avx2,
    d: &MicrofacetDistribution,
    wi: Vec3,
    eta: f32,
    transmit: bool,
    ux: f32,
    uys: &[f32],
    out: &mut [f32],
) -> usize {
    avx.run(
        #[inline(always)]
        || {
            let l = Microfacet::new(d.kind, avx.splat(d.alpha_u), avx.splat(d.alpha_v), true);
            let wi8 = V3::new(avx.splat(wi.x), avx.splat(wi.y), avx.splat(wi.z));
            let (eta8, ux8) = (avx.splat(eta), avx.splat(ux));
            let mut n = 0;
            for (u, o) in uys.chunks_exact(8).zip(out.chunks_exact_mut(8)) {
                let uy = avx.load(u.try_into().expect("chunk of 8"));
                let v = integrand(&l, wi8, V2::new(ux8, uy), eta8, transmit);
                v.store(o.try_into().expect("chunk of 8"));
                n += 8;
            }
            n
        },
    )
}

/// One quadrature node's integrand per lane: F G1(wo, m) for the reflection, (1 − F) G1(wt, m)
/// for the refraction through the normal sampled at `u` by Mitsuba's map; 0 where the scattered
/// direction leaves on the wrong side (the nodes the sum skips: adding an exact zero to its
/// non-negative partial sums changes no bit).
#[inline(always)]
fn integrand<L: Lane>(d: &Microfacet<L>, wi: V3<L>, u: V2<L>, eta: L, transmit: bool) -> L {
    let k = |c: f32| eta.splat(c);
    let m = d.sample_normal_mitsuba_map(wi, u);
    let c = wi.dot(m);
    let fr = lane_fresnel::dielectric(c, eta);
    if transmit {
        // bsdf::fresnel::refract.
        let wo = m.scale(c * fr.eta_ti + fr.cos_theta_t) - wi.scale(fr.eta_ti);
        let v = (k(1.0) - fr.r) * d.smith_g1(wo, m);
        L::select((wo.z * wi.z).ge(k(0.0)), k(0.0), v)
    } else {
        // math::reflect.
        let wo = m.scale(k(2.0) * c) - wi;
        let v = fr.r * d.smith_g1(wo, m);
        L::select(wo.z.le(k(0.0)) | wi.z.le(k(0.0)), k(0.0), v)
    }
}

impl RoughPlasticTable {
    /// Compute the table (≈10⁶ microfacet samples: do it once per material, see [`Self::cached`]).
    pub fn compute(kind: MicrofacetType, alpha: f32, eta: f32) -> Self {
        let d = MicrofacetDistribution::new(kind, alpha, true);
        let mut ext = [0.0; TRANSMITTANCE_RES];
        let mut internal = 0.0f64;
        for (i, t) in ext.iter_mut().enumerate() {
            let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            *t = rough_interface_albedo(&d, wi, eta, true);
            internal += (rough_interface_albedo(&d, wi, 1.0 / eta, false) * mu) as f64;
        }
        RoughPlasticTable {
            external_transmittance: ext,
            internal_reflectance: (2.0 * internal / TRANSMITTANCE_RES as f64) as f32,
        }
    }

    /// A shared table for (kind, α, η), computed on first use and kept for the life of the
    /// process (one per distinct coating of the scene).
    pub fn cached(kind: MicrofacetType, alpha: f32, eta: f32) -> &'static RoughPlasticTable {
        type Key = (MicrofacetType, u32, u32);
        static CACHE: Mutex<Vec<(Key, &'static RoughPlasticTable)>> = Mutex::new(Vec::new());
        let key = (kind, alpha.to_bits(), eta.to_bits());
        let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, t)) = cache.iter().find(|(k, _)| *k == key) {
            return t;
        }
        let t: &'static RoughPlasticTable = Box::leak(Box::new(Self::compute(kind, alpha, eta)));
        cache.push((key, t));
        t
    }

    /// T(θ) by linear interpolation in cos θ (the `f32` instantiation of [`Self::transmittance_lanes`]).
    #[inline]
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        self.transmittance_lanes(cos_theta)
    }

    /// T(θ) per lane: cos θ clamped to [0, 1] (NaN stays NaN, as `f32::clamp`), the grid cell
    /// i = min(⌊63 cos θ⌋, 62) (0 for NaN) read by a table gather, linear interpolation.
    #[inline(always)]
    pub fn transmittance_lanes<L: Lane>(&self, cos_theta: L) -> L {
        let k = |c: f32| cos_theta.splat(c);
        let c = L::select(cos_theta.lt(k(0.0)), k(0.0), cos_theta);
        let c = L::select(c.gt(k(1.0)), k(1.0), c);
        let x = c * k((TRANSMITTANCE_RES - 1) as f32);
        // `x as usize` saturates NaN to 0; trunc_i32 gives i32::MIN there: clamp to [0, 62].
        let i = x.trunc_i32();
        let last = i.splat(TRANSMITTANCE_RES as i32 - 2);
        let i = LaneI32::select(i.gt(last), last, i);
        let i = LaneI32::select(i.lt(i.splat(0)), i.splat(0), i);
        let w = x - i.to_f32();
        let t = &self.external_transmittance;
        (k(1.0) - w) * L::gather(t, i) + w * L::gather(t, i.add(i.splat(1)))
    }
}

#[derive(Clone, Copy, Debug)]
pub struct RoughPlastic {
    /// Isotropic distribution (defaults: Beckmann, α 0.1, `sample_visible` true).
    pub distribution: MicrofacetDistribution,
    /// Albedo of the base (default 0.5).
    pub diffuse_reflectance: Spectrum,
    /// Multiplier of the coating's reflection (default 1).
    pub specular_reflectance: Spectrum,
    /// Relative index `int_ior / ext_ior` (default polypropylene / air).
    pub eta: f32,
    pub nonlinear: bool,
    /// See [`super::plastic::Plastic::specular_sampling_weight`].
    pub specular_sampling_weight: f32,
    pub table: &'static RoughPlasticTable,
}

impl RoughPlastic {
    /// From Mitsuba's parameters (`distribution`, `alpha`, `sample_visible`, `diffuse_reflectance`,
    /// `specular_reflectance`, `int_ior`, `ext_ior`, `nonlinear`). Looks the coating table up in a
    /// process-wide cache (a lock): build one per material at load time and copy it per hit,
    /// changing only the reflectances.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        distribution: MicrofacetType,
        alpha: f32,
        sample_visible: bool,
        diffuse_reflectance: Spectrum,
        specular_reflectance: Spectrum,
        int_ior: f32,
        ext_ior: f32,
        nonlinear: bool,
    ) -> Self {
        let eta = int_ior / ext_ior;
        let distribution = MicrofacetDistribution::new(distribution, alpha, sample_visible);
        RoughPlastic {
            distribution,
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
            specular_sampling_weight: specular_sampling_weight(
                diffuse_reflectance,
                specular_reflectance,
            ),
            table: RoughPlasticTable::cached(distribution.kind, distribution.alpha_u, eta),
        }
    }

    /// The lane form's distribution (the parameters splatted; already clamped by `new`).
    #[inline(always)]
    pub(crate) fn distribution_lanes<L: Lane>(&self, like: L) -> Microfacet<L> {
        let d = &self.distribution;
        Microfacet {
            kind: d.kind,
            alpha_u: like.splat(d.alpha_u),
            alpha_v: like.splat(d.alpha_v),
            sample_visible: d.sample_visible,
        }
    }

    /// Probability of the specular lobe given T(θi): ps / (ps + pd) with ps = (1 − T) w_s and
    /// pd = T (1 − w_s).
    #[inline(always)]
    pub(crate) fn prob_specular<L: Lane>(&self, t_i: L) -> L {
        let k = |c: f32| t_i.splat(c);
        let ps = (k(1.0) - t_i) * k(self.specular_sampling_weight);
        let pd = t_i * k(1.0 - self.specular_sampling_weight);
        ps / (ps + pd)
    }

    /// `f · cos θo` (RGB) and the sampling density (`bsdf::lanes` convention).
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        let rho = splat3(wi.z, self.diffuse_reflectance);
        let spec = splat3(wi.z, self.specular_reflectance);
        self.eval_pdf_with(rho, spec, wi, wo)
    }

    /// `sample_lanes` of the convention (`u1` picks the lobe). The stream kernel calls
    /// [`Self::sample_with`] (per-lane reflectances, and the lobe); the compensated normal map
    /// (issue 17) calls this.
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        let rho = splat3(wi.z, self.diffuse_reflectance);
        let spec = splat3(wi.z, self.specular_reflectance);
        self.sample_with(rho, spec, wi, u1, u2).0
    }

    /// [`Self::eval_pdf_lanes`] with the reflectances per lane (`rho` = `diffuse_reflectance`,
    /// `spec` = `specular_reflectance`: textured materials gathered by the stream kernel); the
    /// sampling weight stays the material's (from the textures' means, as in Mitsuba). 0 in
    /// lanes where wi or wo is below the surface.
    #[inline(always)]
    pub(crate) fn eval_pdf_with<L: Lane>(
        &self,
        rho: V3<L>,
        spec: V3<L>,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let below = wi.z.le(k(0.0)) | wo.z.le(k(0.0));
        if below.all() {
            // Fast path (the bits of the selects below): no lane has a pair above the surface.
            let zero = k(0.0);
            return (V3::new(zero, zero, zero), zero);
        }
        let dist = self.distribution_lanes(wi.z);
        // The coating: F D G / (4 cos θi) · specular_reflectance.
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let g1i = dist.smith_g1(wi, h);
        let f = lane_fresnel::dielectric(wi.dot(h), k(self.eta)).r;
        let g = g1i * dist.smith_g1(wo, h);
        let specular = spec.scale(f * d * g / (k(4.0) * wi.z));
        // The base: ρ / (π η² (1 − R_int)) T(θi) T(θo) cos θo (or 1 − ρ R_int).
        let albedo = base_albedo(rho, k(self.table.internal_reflectance), self.nonlinear);
        let t_i = self.table.transmittance_lanes(wi.z);
        let t = t_i * self.table.transmittance_lanes(wo.z);
        let value = specular
            + albedo.scale(k(crate::math::INV_PI) * wo.z * t / (k(self.eta) * k(self.eta)));
        // The sampling mixture: specular lobe with probability ps(T(θi)), else cosine.
        let ps = self.prob_specular(t_i);
        let p_spec = dist.reflection_pdf(wi, wo, h, d, g1i);
        let p = ps * p_spec + (k(1.0) - ps) * warp::cosine_hemisphere_pdf(wo);
        let p = L::select(p.is_finite(), p, k(0.0));
        let zero = k(0.0);
        (
            V3::select(below, V3::new(zero, zero, zero), value),
            L::select(below, zero, p),
        )
    }

    /// [`Self::sample_lanes`] with the reflectances per lane (see [`Self::eval_pdf_with`]);
    /// also returns the lanes that chose the glossy lobe (the others chose the diffuse one).
    /// Each lobe's sampling is skipped when no lane chose it (the select would drop it anyway).
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(
        &self,
        rho: V3<L>,
        spec: V3<L>,
        wi: V3<L>,
        u1: L,
        u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L::Mask) {
        let k = |c: f32| wi.z.splat(c);
        let up = !wi.z.le(k(0.0));
        let ps = self.prob_specular(self.table.transmittance_lanes(wi.z));
        let glossy = u1.lt(ps);
        let mut wo = V3::new(k(0.0), k(0.0), k(1.0));
        if glossy.any() {
            // math::reflect about a sampled microfacet normal.
            let m = self.distribution_lanes(wi.z).sample_normal(wi, u2);
            wo = m.scale(k(2.0) * wi.dot(m)) - wi;
        }
        if (!glossy).any() {
            wo = V3::select(glossy, wo, warp::square_to_cosine_hemisphere(u2));
        }
        let (value, pdf) = self.eval_pdf_with(rho, spec, wi, wo);
        let ok = up & pdf.gt(k(0.0));
        let s = LaneBsdfSample {
            ok,
            wo,
            pdf,
            weight: value.div_by(pdf),
        };
        (s, glossy)
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(wi, wo).0
    }

    /// `(eval, pdf)`: the `f32` instantiation of [`Self::eval_pdf_lanes`].
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (v, p) = self.eval_pdf_lanes::<f32>(wi.into(), wo.into());
        (v.into(), p)
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// The `f32` instantiation of [`Self::sample_lanes`], with the chosen lobe.
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let rho = self.diffuse_reflectance.into();
        let spec = self.specular_reflectance.into();
        let (s, glossy) = self.sample_with::<f32>(rho, spec, wi.into(), u1, u2.into());
        s.ok.then(|| BsdfSample {
            wo: s.wo.into(),
            pdf: s.pdf,
            weight: s.weight.into(),
            eta: 1.0,
            lobe: if glossy {
                Lobes::GLOSSY_REFLECTION
            } else {
                Lobes::DIFFUSE_REFLECTION
            },
        })
    }
}

impl Default for RoughPlastic {
    /// Mitsuba's defaults: Beckmann, α = 0.1, visible sampling, ρ = 0.5, polypropylene in air.
    fn default() -> Self {
        RoughPlastic::new(
            MicrofacetType::Beckmann,
            0.1,
            true,
            Spectrum::splat(0.5),
            Spectrum::ONE,
            super::plastic::DEFAULT_PLASTIC_INT_IOR,
            super::dielectric::DEFAULT_EXT_IOR,
            false,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::RoughPlastic;
    use crate::bsdf::dielectric::DEFAULT_EXT_IOR;
    use crate::bsdf::ior::load::ior_param;
    use crate::bsdf::microfacet::load::distribution;
    use crate::bsdf::plastic::DEFAULT_PLASTIC_INT_IOR;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot};

    /// `roughplastic`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let int_ior = ior_param(cx.props(), "int_ior", DEFAULT_PLASTIC_INT_IOR)?;
        let ext_ior = ior_param(cx.props(), "ext_ior", DEFAULT_EXT_IOR)?;
        // Sampling weights come from the textures' means, as Mitsuba does.
        let (d, mut slots) = cx.leaf_color("diffuse_reflectance", Slot::DiffuseReflectance, 0.5)?;
        let (sr, s2) = cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        slots.extend(s2);
        let nonlinear = cx.props().bool("nonlinear", false)?;
        // Mitsuba 3's roughplastic takes a plain float `alpha` (no texture).
        let (dist, _) = distribution(cx, false, false)?;
        let template = BsdfNode::RoughPlastic(RoughPlastic::new(
            dist.kind,
            dist.alpha_u,
            dist.sample_visible,
            d,
            sr,
            int_ior,
            ext_ior,
            nonlinear,
        ));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scalar code before the lane form (commit 6b74181), kept as the reference of
    /// [`lane_form_f32_equals_the_former_scalar_code`].
    mod former {
        use super::super::RoughPlastic;
        use crate::bsdf::fresnel::fresnel_dielectric;
        use crate::bsdf::{is_positive, BsdfSample, Lobes};
        use crate::math::{reflect, warp};
        use crate::spectrum::Spectrum;
        use glam::{Vec2, Vec3};

        fn transmittance(b: &RoughPlastic, cos_theta: f32) -> f32 {
            let x = cos_theta.clamp(0.0, 1.0) * (super::TRANSMITTANCE_RES - 1) as f32;
            let i = (x as usize).min(super::TRANSMITTANCE_RES - 2);
            let w = x - i as f32;
            let t = &b.table.external_transmittance;
            (1.0 - w) * t[i] + w * t[i + 1]
        }
        fn prob_specular(b: &RoughPlastic, t_i: f32) -> f32 {
            let ps = (1.0 - t_i) * b.specular_sampling_weight;
            let pd = t_i * (1.0 - b.specular_sampling_weight);
            ps / (ps + pd)
        }
        pub fn eval_pdf(b: &RoughPlastic, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return (Spectrum::ZERO, 0.0);
            }
            let h = (wi + wo).normalize();
            let d = b.distribution.eval(h);
            let g1i = b.distribution.smith_g1(wi, h);
            let f = fresnel_dielectric(wi.dot(h), b.eta).r;
            let g = g1i * b.distribution.smith_g1(wo, h);
            let spec = b.specular_reflectance * (f * d * g / (4.0 * wi.z));
            let rho = b.diffuse_reflectance;
            let r_int = b.table.internal_reflectance;
            let albedo = if b.nonlinear {
                rho / (Spectrum::ONE - rho * r_int)
            } else {
                rho / (1.0 - r_int)
            };
            let t_i = transmittance(b, wi.z);
            let t = t_i * transmittance(b, wo.z);
            let value = spec + albedo * (crate::math::INV_PI * wo.z * t / (b.eta * b.eta));
            (value, mixture_pdf(b, t_i, wi, wo, h, d, g1i))
        }
        pub fn pdf(b: &RoughPlastic, wi: Vec3, wo: Vec3) -> f32 {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return 0.0;
            }
            let h = (wi + wo).normalize();
            let d = b.distribution.eval(h);
            let g1i = if b.distribution.sample_visible {
                b.distribution.smith_g1(wi, h)
            } else {
                1.0
            };
            mixture_pdf(b, transmittance(b, wi.z), wi, wo, h, d, g1i)
        }
        fn mixture_pdf(
            b: &RoughPlastic,
            t_i: f32,
            wi: Vec3,
            wo: Vec3,
            h: Vec3,
            d: f32,
            g1i: f32,
        ) -> f32 {
            let ps = prob_specular(b, t_i);
            let p_spec = b.distribution.reflection_pdf(wi, wo, h, d, g1i);
            let p = ps * p_spec + (1.0 - ps) * warp::cosine_hemisphere_pdf(wo);
            if p.is_finite() {
                p
            } else {
                0.0
            }
        }
        pub fn sample(b: &RoughPlastic, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
            if wi.z <= 0.0 {
                return None;
            }
            let ps = prob_specular(b, transmittance(b, wi.z));
            let (wo, kind) = if u1 < ps {
                let m = b.distribution.sample_normal(wi, u2);
                (reflect(wi, m), Lobes::GLOSSY_REFLECTION)
            } else {
                (
                    warp::square_to_cosine_hemisphere(u2),
                    Lobes::DIFFUSE_REFLECTION,
                )
            };
            let (value, pdf) = eval_pdf(b, wi, wo);
            if !is_positive(pdf) {
                return None;
            }
            Some(BsdfSample {
                wo,
                pdf,
                weight: value / pdf,
                eta: 1.0,
                lobe: kind,
            })
        }
    }

    /// Materials covering both distributions, visible and all-normal sampling, linear and
    /// non-linear, η above and below 1, coloured reflectances.
    fn materials() -> Vec<RoughPlastic> {
        let mut v = Vec::new();
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for (alpha, sv, nl, int_ior) in [
                (0.1, true, false, 1.49),
                (0.35, false, true, 1.5),
                (0.8, true, true, 1.33),
                (0.02, true, false, 0.8),
            ] {
                v.push(RoughPlastic::new(
                    kind,
                    alpha,
                    sv,
                    Spectrum::new(0.7, 0.3, 0.05),
                    Spectrum::new(1.0, 0.8, 0.6),
                    int_ior,
                    1.000277,
                    nl,
                ));
            }
        }
        v
    }

    /// Random directions over the whole sphere (both sides), a few special ones, and u's.
    fn inputs(n: usize) -> Vec<(Vec3, Vec3, f32, Vec2)> {
        let mut r = crate::math::rng::Pcg32::new(18, 7);
        let dir = |r: &mut crate::math::rng::Pcg32| {
            crate::math::warp::square_to_uniform_sphere(Vec2::new(r.next_f32(), r.next_f32()))
        };
        let mut v: Vec<_> = (0..n)
            .map(|_| {
                let wi = dir(&mut r);
                let wo = dir(&mut r);
                (wi, wo, r.next_f32(), Vec2::new(r.next_f32(), r.next_f32()))
            })
            .collect();
        let special = [
            Vec3::Z,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.6, 0.0, 0.8),
            -Vec3::Z,
        ];
        for a in special {
            for b in special {
                v.push((a, b, 0.5, Vec2::new(0.5, 0.5)));
                v.push((a, -a, 0.0, Vec2::new(0.0, 0.999_999_94)));
            }
        }
        v
    }

    /// Equal bits, NaN as NaN.
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }
    fn same3(a: Vec3, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// The lane form at width 1 gives the former scalar code's bits: eval, pdf, eval_pdf and
    /// sample (direction, density, weight, lobe, and where it fails) on 200 000 random pairs
    /// per material.
    #[test]
    fn lane_form_f32_equals_the_former_scalar_code() {
        let inp = inputs(25_000);
        for b in materials() {
            for &(wi, wo, u1, u2) in &inp {
                let (v, p) = b.eval_pdf(wi, wo);
                let (v0, p0) = former::eval_pdf(&b, wi, wo);
                assert!(
                    same3(v, v0) && same(p, p0),
                    "{b:?} {wi} {wo}: {v} {p} vs {v0} {p0}"
                );
                assert!(same3(b.eval(wi, wo), v0));
                let pf = former::pdf(&b, wi, wo);
                assert!(
                    same(b.pdf(wi, wo), pf),
                    "{wi} {wo}: {} vs {pf}",
                    b.pdf(wi, wo)
                );
                let s = b.sample(wi, u1, u2);
                let s0 = former::sample(&b, wi, u1, u2);
                match (s, s0) {
                    (None, None) => {}
                    (Some(s), Some(s0)) => assert!(
                        same3(s.wo, s0.wo)
                            && same(s.pdf, s0.pdf)
                            && same3(s.weight, s0.weight)
                            && s.lobe == s0.lobe,
                        "{wi} {u1} {u2}: {s:?} vs {s0:?}"
                    ),
                    _ => panic!("{b:?} {wi} {u1} {u2}: {s:?} vs {s0:?}"),
                }
            }
        }
    }

    /// 8 lanes give each lane the bits of width 1 (eval_pdf and sample, NaN as NaN).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_lanes_equal_width_1() {
        let Some(avx) = Avx2::detect() else { return };
        let inp = inputs(8_000);
        let col = |f: &dyn Fn(usize) -> f32| -> [f32; 8] { core::array::from_fn(f) };
        for b in materials() {
            for c in inp.chunks_exact(8) {
                let wi = [0, 1, 2].map(|j| col(&|k| c[k].0[j]));
                let wo = [0, 1, 2].map(|j| col(&|k| c[k].1[j]));
                let u1 = col(&|k| c[k].2);
                let u2 = [0, 1].map(|j| col(&|k| c[k].3[j]));
                let (e, s) = avx.run(|| {
                    let v3 = |a: &[[f32; 8]; 3]| {
                        V3::new(avx.load(&a[0]), avx.load(&a[1]), avx.load(&a[2]))
                    };
                    let (wi8, wo8) = (v3(&wi), v3(&wo));
                    let u2 = V2::new(avx.load(&u2[0]), avx.load(&u2[1]));
                    (
                        b.eval_pdf_lanes(wi8, wo8),
                        b.sample_lanes(wi8, avx.load(&u1), u2),
                    )
                });
                for (k, &(wi, wo, u1, u2)) in c.iter().enumerate() {
                    let (v1, p1) = b.eval_pdf_lanes::<f32>(wi.into(), wo.into());
                    let v8 = Vec3::new(e.0.x.lane(k), e.0.y.lane(k), e.0.z.lane(k));
                    assert!(same3(v8, v1.into()) && same(e.1.lane(k), p1), "{wi} {wo}");
                    let s1 = b.sample_lanes::<f32>(wi.into(), u1, u2.into());
                    let ok8 = s.ok.to_array()[k];
                    assert_eq!(ok8, s1.ok, "{wi} {u1} {u2}");
                    let wo8 = Vec3::new(s.wo.x.lane(k), s.wo.y.lane(k), s.wo.z.lane(k));
                    let w8 = Vec3::new(s.weight.x.lane(k), s.weight.y.lane(k), s.weight.z.lane(k));
                    assert!(
                        same3(wo8, s1.wo.into())
                            && same(s.pdf.lane(k), s1.pdf)
                            && same3(w8, s1.weight.into()),
                        "{wi} {u1} {u2}"
                    );
                }
            }
        }
    }

    /// The table lookup at 8 lanes equals width 1, at the grid nodes, between them, outside
    /// [0, 1] and at NaN.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn transmittance_8_wide_equals_width_1() {
        let Some(avx) = Avx2::detect() else { return };
        let t = RoughPlasticTable::cached(MicrofacetType::Ggx, 0.3, 1.5);
        let mut xs: Vec<f32> = (0..=640).map(|i| i as f32 / 640.0).collect();
        xs.extend([
            -1.0,
            -0.0,
            1.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            62.5 / 63.0,
            1e-30,
        ]);
        while !xs.len().is_multiple_of(8) {
            xs.push(0.25);
        }
        for c in xs.chunks_exact(8) {
            let a: [f32; 8] = c.try_into().expect("8");
            let r = avx.run(|| t.transmittance_lanes(avx.load(&a))).to_array();
            for k in 0..8 {
                assert!(same(r[k], t.transmittance(a[k])), "{}", a[k]);
            }
        }
        assert!(t.transmittance(f32::NAN).is_nan());
        assert_eq!(
            t.transmittance(2.0),
            t.external_transmittance[TRANSMITTANCE_RES - 1]
        );
    }

    /// The 8-wide quadrature gives the width-1 one's bits (so a table does not depend on the
    /// CPU), for both distributions, both resolutions (η > 1 and < 1), reflection and
    /// transmission, from normal to grazing incidence.
    #[test]
    fn albedo_8_wide_equals_width_1() {
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for alpha in [0.05, 0.3, 0.9] {
                let d = MicrofacetDistribution::new(kind, alpha, true);
                for mu in [1e-6f32, 0.1, 0.5, 0.97, 1.0] {
                    let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                    for eta in [1.5f32, 1.0 / 1.5] {
                        for transmit in [false, true] {
                            let a = albedo(&d, wi, eta, transmit, true);
                            let b = albedo(&d, wi, eta, transmit, false);
                            assert_eq!(
                                a.to_bits(),
                                b.to_bits(),
                                "{kind:?} {alpha} {mu} {eta} {transmit}: {a} {b}"
                            );
                        }
                    }
                }
            }
        }
    }
}
