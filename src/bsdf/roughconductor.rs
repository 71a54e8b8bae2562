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

use super::lanes::LaneBsdfSample;
use super::microfacet::MicrofacetDistribution;
use super::{BsdfSample, Lobes};
use crate::lane::fresnel::{conductor as lane_conductor, ConductorIndex};
use crate::lane::microfacet::Microfacet;
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneMask};
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

/// `v` in every lane, with the width of `like`.
#[inline(always)]
fn splat3<L: Lane>(like: L, v: Vec3) -> V3<L> {
    V3::splat(like, v.x, v.y, v.z)
}

impl RoughConductor {
    /// The distribution with its parameters in every lane (the width of `like`).
    #[inline(always)]
    fn microfacet<L: Lane>(&self, like: L) -> Microfacet<L> {
        let d = &self.distribution;
        Microfacet {
            kind: d.kind,
            alpha_u: like.splat(d.alpha_u),
            alpha_v: like.splat(d.alpha_v),
            sample_visible: d.sample_visible,
        }
    }

    /// `specular_reflectance · F(cos θ)` per lane (`spec`: the reflectance per lane).
    /// `ix`: this material's [`Self::index`] where the caller computed it once (the stream's
    /// wrapper-chain driver, once per run of the material); else the index's terms are
    /// computed here, in lanes (the same values).
    #[inline(always)]
    fn fresnel_lanes<L: Lane>(
        &self,
        spec: V3<L>,
        cos_theta: L,
        ix: Option<&ConductorIndex>,
    ) -> V3<L> {
        match ix {
            Some(ix) => spec * ix.reflectance(cos_theta),
            None => {
                let eta = splat3(cos_theta, self.eta);
                let k = splat3(cos_theta, self.k);
                spec * lane_conductor(cos_theta, eta, k)
            }
        }
    }

    /// The complex index's angle-free Fresnel terms (η² − k², 4η²k² per channel), for a
    /// caller that evaluates this material many times to compute once
    /// ([`Self::eval_pdf_with`], [`Self::sample_with`]).
    #[inline(always)]
    pub(crate) fn index(&self) -> ConductorIndex {
        ConductorIndex::new(self.eta.to_array(), self.k.to_array())
    }

    /// The textured parameters in every lane (width of `like`): `specular_reflectance` and the
    /// distribution, what [`Self::eval_pdf_with`] and [`Self::sample_with`] take per lane.
    #[inline(always)]
    pub(crate) fn params_lanes<L: Lane>(&self, like: L) -> (V3<L>, Microfacet<L>) {
        (
            splat3(like, self.specular_reflectance),
            self.microfacet(like),
        )
    }

    /// `(f · cos θo, pdf)` sharing the half vector, D(h) and G1(wi, h); both 0 where `wi` or
    /// `wo` is not above the surface or D(h) = 0. The lane form (`bsdf::lanes`); [`Self::eval_pdf`]
    /// is its width 1.
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        let (spec, dist) = self.params_lanes(wi.z);
        self.eval_pdf_with(spec, &dist, None, wi, wo)
    }

    /// [`Self::eval_pdf_lanes`] with `specular_reflectance` and the distribution per lane (the
    /// stream kernel's textured parameters; [`Self::params_lanes`] gives the constant ones), and
    /// the Fresnel terms `ix` when the caller computed them ([`Self::index`]; `None`: here).
    #[inline(always)]
    pub(crate) fn eval_pdf_with<L: Lane>(
        &self,
        spec: V3<L>,
        dist: &Microfacet<L>,
        ix: Option<&ConductorIndex>,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let zero = V3::splat(k(0.0), 0.0, 0.0, 0.0);
        let below = wi.z.le(k(0.0)) | wo.z.le(k(0.0));
        if below.all() {
            // Fast path (the bits of the selects below): no lane has a pair above the surface.
            return (zero, k(0.0));
        }
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let bad = below | d.eq(k(0.0));
        if bad.all() {
            return (zero, k(0.0));
        }
        let g1i = dist.smith_g1(wi, h);
        // f cos θo = F D G / (4 cos θi).
        let f = self
            .fresnel_lanes(spec, wi.dot(h), ix)
            .scale(d * g1i * dist.smith_g1(wo, h) / (k(4.0) * wi.z));
        let pdf = dist.reflection_pdf(wi, wo, h, d, g1i);
        (V3::select(bad, zero, f), L::select(bad, k(0.0), pdf))
    }

    /// The density of [`Self::sample_lanes`] alone (no Fresnel term); 0 where `wi` or `wo` is
    /// not above the surface.
    #[inline(always)]
    pub(crate) fn pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> L {
        let k = |c: f32| wi.z.splat(c);
        let below = wi.z.le(k(0.0)) | wo.z.le(k(0.0));
        if below.all() {
            // Fast path (the bits of the select below).
            return k(0.0);
        }
        let dist = self.microfacet(wi.z);
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let g1i = if dist.sample_visible {
            dist.smith_g1(wi, h)
        } else {
            k(1.0)
        };
        let pdf = dist.reflection_pdf(wi, wo, h, d, g1i);
        L::select(below, k(0.0), pdf)
    }

    /// A microfacet normal from `u2` (`u1` unused: one lobe), `wi` reflected about it. Lanes
    /// outside `ok` hold zeros. The lane form; [`Self::sample`] is its width 1.
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(&self, wi: V3<L>, _u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        let (spec, dist) = self.params_lanes(wi.z);
        self.sample_with(spec, &dist, None, wi, u2)
    }

    /// [`Self::sample_lanes`] with `specular_reflectance`, the distribution and the Fresnel
    /// terms as [`Self::eval_pdf_with`] takes them.
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(
        &self,
        spec: V3<L>,
        dist: &Microfacet<L>,
        ix: Option<&ConductorIndex>,
        wi: V3<L>,
        u2: V2<L>,
    ) -> LaneBsdfSample<L> {
        let k = |c: f32| wi.z.splat(c);
        let zero = V3::splat(k(0.0), 0.0, 0.0, 0.0);
        let none = LaneBsdfSample {
            ok: k(0.0).ne(k(0.0)),
            wo: zero,
            pdf: k(0.0),
            weight: zero,
        };
        // Fast paths (the bits of the final selects) where no lane is left.
        let ok = !wi.z.le(k(0.0));
        if !ok.any() {
            return none;
        }
        let m = dist.sample_normal(wi, u2);
        let pm = dist.pdf(wi, m);
        let ok = ok & pm.gt(k(0.0));
        if !ok.any() {
            return none;
        }
        // math::reflect: 2 (wi·m) m − wi.
        let wo = m.scale(k(2.0) * wi.dot(m)) - wi;
        let ok = ok & !wo.z.le(k(0.0));
        if !ok.any() {
            return none;
        }
        let pdf = pm / (k(4.0) * wo.dot(m));
        let w = if dist.sample_visible {
            dist.smith_g1(wo, m)
        } else {
            dist.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        let ok = ok & pdf.gt(k(0.0)) & w.gt(k(0.0));
        LaneBsdfSample {
            ok,
            wo: V3::select(ok, wo, zero),
            pdf: L::select(ok, pdf, k(0.0)),
            weight: V3::select(ok, self.fresnel_lanes(spec, wi.dot(m), ix).scale(w), zero),
        }
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(wi, wo).0
    }

    /// `(eval, pdf)`: [`Self::eval_pdf_lanes`] at width 1.
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (f, pdf) = self.eval_pdf_lanes(V3::from(wi), V3::from(wo));
        (f.into(), pdf)
    }

    /// [`Self::pdf_lanes`] at width 1.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.pdf_lanes(V3::from(wi), V3::from(wo))
    }

    /// [`Self::sample_lanes`] at width 1.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        let s = self.sample_lanes(V3::from(wi), 0.0, V2::from(u));
        s.ok.then(|| BsdfSample {
            wo: s.wo.into(),
            pdf: s.pdf,
            weight: s.weight.into(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::*;
    use crate::bsdf::microfacet::MicrofacetType;
    use crate::math::Pcg32;

    /// The scalar code as it was before the lane form (frozen here, commit 6b74181): the lane
    /// form at width 1 must give its bits.
    mod before {
        use super::super::RoughConductor;
        use crate::bsdf::fresnel::fresnel_conductor;
        use crate::bsdf::{is_positive, BsdfSample, Lobes};
        use crate::math::reflect;
        use crate::spectrum::Spectrum;
        use glam::{Vec2, Vec3};

        fn fresnel(b: &RoughConductor, cos_theta: f32) -> Spectrum {
            b.specular_reflectance * fresnel_conductor(cos_theta, b.eta, b.k)
        }

        pub fn eval_pdf(b: &RoughConductor, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return (Spectrum::ZERO, 0.0);
            }
            let h = (wi + wo).normalize();
            let d = b.distribution.eval(h);
            if d == 0.0 {
                return (Spectrum::ZERO, 0.0);
            }
            let g1i = b.distribution.smith_g1(wi, h);
            let f =
                fresnel(b, wi.dot(h)) * (d * g1i * b.distribution.smith_g1(wo, h) / (4.0 * wi.z));
            (f, b.distribution.reflection_pdf(wi, wo, h, d, g1i))
        }

        pub fn pdf(b: &RoughConductor, wi: Vec3, wo: Vec3) -> f32 {
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
            b.distribution.reflection_pdf(wi, wo, h, d, g1i)
        }

        pub fn sample(b: &RoughConductor, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
            if wi.z <= 0.0 {
                return None;
            }
            let (m, pm) = b.distribution.sample(wi, u);
            if !is_positive(pm) {
                return None;
            }
            let wo = reflect(wi, m);
            if wo.z <= 0.0 {
                return None;
            }
            let pdf = pm / (4.0 * wo.dot(m));
            let w = if b.distribution.sample_visible {
                b.distribution.smith_g1(wo, m)
            } else {
                b.distribution.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
            };
            if !is_positive(pdf) || !is_positive(w) {
                return None;
            }
            Some(BsdfSample {
                wo,
                pdf,
                weight: fresnel(b, wi.dot(m)) * w,
                eta: 1.0,
                lobe: Lobes::GLOSSY_REFLECTION,
            })
        }
    }

    /// Both models, isotropic and anisotropic, both sampling strategies, rough and nearly
    /// smooth, a named metal and the default.
    fn bsdfs() -> Vec<RoughConductor> {
        let mut v = Vec::new();
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for (au, av) in [(0.1, 0.1), (0.45, 0.12), (1e-3, 1e-3), (1.2, 0.7)] {
                for visible in [true, false] {
                    v.push(RoughConductor {
                        distribution: MicrofacetDistribution::anisotropic(kind, au, av, visible),
                        eta: Spectrum::new(0.2, 0.92, 1.1),
                        k: Spectrum::new(3.9, 2.45, 2.14),
                        specular_reflectance: Spectrum::new(0.9, 0.7, 1.0),
                    });
                }
            }
        }
        v.push(RoughConductor::default());
        v
    }

    /// Random (wi, wo, u) per BSDF: `n` of them.
    fn inputs(seed: u64, n: usize) -> Vec<(Vec3, Vec3, Vec2)> {
        let mut r = Pcg32::new(seed, 3);
        (0..n)
            .map(|_| {
                let wi = direction(&mut r);
                // Half the pairs near the specular direction, where the lobe is.
                let wo = if r.next_f32() < 0.5 {
                    (Vec3::new(-wi.x, -wi.y, wi.z) + 0.3 * direction(&mut r)).normalize()
                } else {
                    direction(&mut r)
                };
                (wi, wo, Vec2::new(r.next_f32(), r.next_f32()))
            })
            .collect()
    }

    /// The lane form at width 1 gives the bits of the code it replaced.
    #[test]
    fn width_1_equals_the_code_before_the_lane_form() {
        let mut sampled = 0;
        for b in bsdfs() {
            for (wi, wo, u) in inputs(7, 4000) {
                let (f, p) = b.eval_pdf(wi, wo);
                let (f0, p0) = before::eval_pdf(&b, wi, wo);
                assert!(same3(f, f0) && same(p, p0), "{b:?} {wi} {wo}");
                assert!(
                    same(b.pdf(wi, wo), before::pdf(&b, wi, wo)),
                    "{b:?} {wi} {wo}"
                );
                let (s, s0) = (b.sample(wi, u), before::sample(&b, wi, u));
                assert_eq!(s.is_some(), s0.is_some(), "{b:?} {wi} {u}");
                if let (Some(s), Some(s0)) = (s, s0) {
                    sampled += 1;
                    assert!(same3(s.wo, s0.wo) && same(s.pdf, s0.pdf), "{b:?} {wi} {u}");
                    assert!(same3(s.weight, s0.weight) && s.lobe == s0.lobe && s.eta == s0.eta);
                }
            }
        }
        // About half the wi are above the surface, and most of their samples succeed.
        assert!(sampled > 20_000, "{sampled}");
    }

    /// Width 8 equals width 1 lane by lane.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn width_8_equals_width_1() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        for b in bsdfs() {
            for c in inputs(11, 2000).chunks_exact(8) {
                let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                let wo: [Vec3; 8] = std::array::from_fn(|k| c[k].1);
                let u: [Vec2; 8] = std::array::from_fn(|k| c[k].2);
                let (f, p, q, s) = avx.run(|| {
                    let (wi8, wo8) = (load3(avx, &wi), load3(avx, &wo));
                    let (f, p) = b.eval_pdf_lanes(wi8, wo8);
                    let q = b.pdf_lanes(wi8, wo8);
                    (f, p, q, b.sample_lanes(wi8, avx.splat(0.5), load2(avx, &u)))
                });
                let ok = s.ok.to_array();
                for k in 0..8 {
                    let (f1, p1) = b.eval_pdf_lanes(V3::from(wi[k]), V3::from(wo[k]));
                    assert!(same3(lane3(f, k), f1.into()) && same(p.lane(k), p1));
                    assert!(same(
                        q.lane(k),
                        b.pdf_lanes(V3::from(wi[k]), V3::from(wo[k]))
                    ));
                    let s1 = b.sample_lanes(V3::from(wi[k]), 0.5, V2::from(u[k]));
                    assert_eq!(ok[k], s1.ok, "{b:?} {} {}", wi[k], u[k]);
                    assert!(same3(lane3(s.wo, k), s1.wo.into()) && same(s.pdf.lane(k), s1.pdf));
                    assert!(same3(lane3(s.weight, k), s1.weight.into()));
                }
            }
        }
    }
}
