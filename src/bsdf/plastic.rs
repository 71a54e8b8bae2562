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

use super::fresnel::fresnel_diffuse_reflectance;
use super::lanes::LaneBsdfSample;
use super::{BsdfSample, Lobes};
use crate::lane::fresnel as lane_fresnel;
use crate::lane::vec::{V2, V3};
use crate::lane::{warp, Lane, LaneMask};
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
    #[inline(always)]
    fn prob_specular<L: Lane>(&self, cos_theta_i: L) -> (L, L) {
        let k = |c: f32| cos_theta_i.splat(c);
        let f_i = lane_fresnel::dielectric(cos_theta_i, k(self.eta)).r;
        let ps = f_i * k(self.specular_sampling_weight);
        let pd = (k(1.0) - f_i) * k(1.0 - self.specular_sampling_weight);
        (ps / (ps + pd), f_i)
    }

    /// `f · cos θo` of the diffuse lobe (RGB; the delta lobe evaluates to 0) and the sampling
    /// density (`bsdf::lanes` convention).
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        self.eval_pdf_with(splat3(wi.z, self.diffuse_reflectance), wi, wo)
    }

    /// `sample_lanes` of the convention (`u1` picks the lobe). The stream kernel calls
    /// [`Self::sample_with`] (per-lane reflectances, and the lobe).
    #[allow(dead_code)] // the convention's entry point; no caller outside the tests yet
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        let rho = splat3(wi.z, self.diffuse_reflectance);
        let spec = splat3(wi.z, self.specular_reflectance);
        self.sample_with(rho, spec, wi, u1, u2).0
    }

    /// [`Self::eval_pdf_lanes`] with `diffuse_reflectance` per lane (`rho`: a texture gathered
    /// by the stream kernel); 0 in lanes where wi or wo is below the surface.
    #[inline(always)]
    pub(crate) fn eval_pdf_with<L: Lane>(&self, rho: V3<L>, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let below = wi.z.le(k(0.0)) | wo.z.le(k(0.0));
        if below.all() {
            // Fast path (the bits of the selects below): no lane has a pair above the surface.
            let zero = k(0.0);
            return (V3::new(zero, zero, zero), zero);
        }
        let (ps, f_i) = self.prob_specular(wi.z);
        let f_o = lane_fresnel::dielectric(wo.z, k(self.eta)).r;
        let cos_pdf = warp::cosine_hemisphere_pdf(wo);
        let s = cos_pdf * (k(1.0) - f_i) * (k(1.0) - f_o) / (k(self.eta) * k(self.eta));
        let value = base_albedo(rho, k(self.fdr_int), self.nonlinear).scale(s);
        let pdf = cos_pdf * (k(1.0) - ps);
        let zero = k(0.0);
        (
            V3::select(below, V3::new(zero, zero, zero), value),
            L::select(below, zero, pdf),
        )
    }

    /// [`Self::sample_lanes`] with the reflectances per lane (see [`Self::eval_pdf_with`]);
    /// also returns the lanes that chose the delta (specular) lobe, whose density is 0 by
    /// convention. The diffuse lobe's sampling is skipped when no lane chose it.
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
        let (ps, f_i) = self.prob_specular(wi.z);
        let delta = u1.lt(ps);
        // The delta lobe: the mirror direction, weight F / P(specular).
        let mut wo = V3::new(-wi.x, -wi.y, wi.z);
        let mut pdf = k(0.0);
        let mut weight = spec.scale(f_i / ps);
        let mut ok = up & delta;
        if (!delta).any() {
            let pd = k(1.0) - ps;
            let wd = warp::square_to_cosine_hemisphere(u2);
            let f_o = lane_fresnel::dielectric(wd.z, k(self.eta)).r;
            let pdf_d = pd * warp::cosine_hemisphere_pdf(wd);
            let s = (k(1.0) - f_i) * (k(1.0) - f_o) / (k(self.eta) * k(self.eta) * pd);
            let weight_d = base_albedo(rho, k(self.fdr_int), self.nonlinear).scale(s);
            wo = V3::select(delta, wo, wd);
            pdf = L::select(delta, pdf, pdf_d);
            weight = V3::select(delta, weight, weight_d);
            ok = ok | (up & !delta & !wd.z.le(k(0.0)));
        }
        let s = LaneBsdfSample {
            ok,
            wo,
            pdf,
            weight,
        };
        (s, delta)
    }

    /// The `f32` instantiation of [`Self::eval_pdf_lanes`]'s value.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf_lanes::<f32>(wi.into(), wo.into()).0.into()
    }

    /// The `f32` instantiation of [`Self::eval_pdf_lanes`]'s density.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf_lanes::<f32>(wi.into(), wo.into()).1
    }

    /// `(eval, pdf)` in one pass.
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (v, p) = self.eval_pdf_lanes::<f32>(wi.into(), wo.into());
        (v.into(), p)
    }

    /// The `f32` instantiation of [`Self::sample_lanes`], with the chosen lobe.
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let rho = self.diffuse_reflectance.into();
        let spec = self.specular_reflectance.into();
        let (s, delta) = self.sample_with::<f32>(rho, spec, wi.into(), u1, u2.into());
        s.ok.then(|| BsdfSample {
            wo: s.wo.into(),
            pdf: s.pdf,
            weight: s.weight.into(),
            eta: 1.0,
            lobe: if delta {
                Lobes::DELTA_REFLECTION
            } else {
                Lobes::DIFFUSE_REFLECTION
            },
        })
    }
}

/// `c` in every lane, with the width of `like`.
#[inline(always)]
pub(crate) fn splat3<L: Lane>(like: L, c: Spectrum) -> V3<L> {
    V3::splat(like, c.x, c.y, c.z)
}

/// The base's albedo seen through the coating: ρ / (1 − R) (`nonlinear` false) or ρ / (1 − ρ R)
/// per channel, R the coating's internal diffuse reflectance (`plastic`'s F_dr,
/// `roughplastic`'s R_int).
#[inline(always)]
pub(crate) fn base_albedo<L: Lane>(rho: V3<L>, r: L, nonlinear: bool) -> V3<L> {
    let one = r.splat(1.0);
    if nonlinear {
        V3::new(
            rho.x / (one - rho.x * r),
            rho.y / (one - rho.y * r),
            rho.z / (one - rho.z * r),
        )
    } else {
        rho.div_by(one - r)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel::{fresnel_dielectric, reflect_z};
    #[cfg(target_arch = "x86_64")]
    use crate::lane::Avx2;

    /// The scalar code before the lane form (commit 2d43d9e), kept as the reference of
    /// [`lane_form_f32_equals_the_former_scalar_code`].
    mod former {
        use super::*;
        use crate::math::warp;

        fn prob_specular(b: &Plastic, cos_theta_i: f32) -> (f32, f32) {
            let f_i = fresnel_dielectric(cos_theta_i, b.eta).r;
            let ps = f_i * b.specular_sampling_weight;
            let pd = (1.0 - f_i) * (1.0 - b.specular_sampling_weight);
            (ps / (ps + pd), f_i)
        }
        fn diffuse_albedo(b: &Plastic) -> Spectrum {
            let d = b.diffuse_reflectance;
            if b.nonlinear {
                d / (Spectrum::ONE - d * b.fdr_int)
            } else {
                d / (1.0 - b.fdr_int)
            }
        }
        pub fn eval(b: &Plastic, wi: Vec3, wo: Vec3) -> Spectrum {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return Spectrum::ZERO;
            }
            let f_i = fresnel_dielectric(wi.z, b.eta).r;
            let f_o = fresnel_dielectric(wo.z, b.eta).r;
            diffuse_albedo(b)
                * (warp::cosine_hemisphere_pdf(wo) * (1.0 - f_i) * (1.0 - f_o) / (b.eta * b.eta))
        }
        pub fn pdf(b: &Plastic, wi: Vec3, wo: Vec3) -> f32 {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return 0.0;
            }
            let (ps, _) = prob_specular(b, wi.z);
            warp::cosine_hemisphere_pdf(wo) * (1.0 - ps)
        }
        pub fn sample(b: &Plastic, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
            if wi.z <= 0.0 {
                return None;
            }
            let (ps, f_i) = prob_specular(b, wi.z);
            if u1 < ps {
                return Some(BsdfSample {
                    wo: reflect_z(wi),
                    pdf: 0.0,
                    weight: b.specular_reflectance * (f_i / ps),
                    eta: 1.0,
                    lobe: Lobes::DELTA_REFLECTION,
                });
            }
            let pd = 1.0 - ps;
            let wo = warp::square_to_cosine_hemisphere(u2);
            if wo.z <= 0.0 {
                return None;
            }
            let f_o = fresnel_dielectric(wo.z, b.eta).r;
            Some(BsdfSample {
                wo,
                pdf: pd * warp::cosine_hemisphere_pdf(wo),
                weight: diffuse_albedo(b) * ((1.0 - f_i) * (1.0 - f_o) / (b.eta * b.eta * pd)),
                eta: 1.0,
                lobe: Lobes::DIFFUSE_REFLECTION,
            })
        }
    }

    /// Linear and non-linear, η above and below 1, coloured reflectances, a black base.
    fn materials() -> Vec<Plastic> {
        let (d, s) = (Spectrum::new(0.7, 0.3, 0.05), Spectrum::new(1.0, 0.8, 0.6));
        vec![
            Plastic::new(d, s, 1.49, 1.000277, false),
            Plastic::new(d, s, 1.5, 1.0, true),
            Plastic::new(d, s, 0.8, 1.0, false),
            Plastic::new(Spectrum::ZERO, s, 1.33, 1.0, true),
            Plastic::default(),
        ]
    }

    /// Random directions over the whole sphere (both sides), a few special ones, and u's.
    fn inputs(n: usize) -> Vec<(Vec3, Vec3, f32, Vec2)> {
        let mut r = crate::math::rng::Pcg32::new(18, 9);
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
                v.push((a, b, 0.999_999_94, Vec2::new(1.0, 0.0)));
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
    /// sample (direction, density, weight, lobe, and where it fails) on random pairs.
    #[test]
    fn lane_form_f32_equals_the_former_scalar_code() {
        let inp = inputs(40_000);
        for b in materials() {
            for &(wi, wo, u1, u2) in &inp {
                let v0 = former::eval(&b, wi, wo);
                let p0 = former::pdf(&b, wi, wo);
                assert!(same3(b.eval(wi, wo), v0), "{b:?} {wi} {wo}");
                assert!(same(b.pdf(wi, wo), p0), "{b:?} {wi} {wo}");
                let (v, p) = b.eval_pdf(wi, wo);
                assert!(same3(v, v0) && same(p, p0));
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
        let get =
            |v: V3<crate::lane::F32x8>, k: usize| Vec3::new(v.x.lane(k), v.y.lane(k), v.z.lane(k));
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
                    assert!(same3(get(e.0, k), v1.into()) && same(e.1.lane(k), p1));
                    let s1 = b.sample_lanes::<f32>(wi.into(), u1, u2.into());
                    assert_eq!(s.ok.to_array()[k], s1.ok, "{wi} {u1} {u2}");
                    assert!(
                        same3(get(s.wo, k), s1.wo.into())
                            && same(s.pdf.lane(k), s1.pdf)
                            && same3(get(s.weight, k), s1.weight.into()),
                        "{wi} {u1} {u2}"
                    );
                }
            }
        }
    }
}
