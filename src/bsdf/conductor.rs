//! `conductor`: a smooth metal, i.e. a perfect mirror weighted by the conductor Fresnel reflectance
//! of the complex index η + ik (per RGB channel) and by `specular_reflectance`. One-sided like
//! Mitsuba 3: light arriving from below the shading frame is not reflected.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `material` | string | `none` | a named conductor's (η, k) ([`super::named_conductor`]: none, Au, Ag, Cu, Al, Cr, ...) |
//! | `eta`, `k` | spectrum | 0, 1 | the complex index η + ik, instead of `material` |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflectance |

use super::lanes::LaneBsdfSample;
use super::{BsdfSample, Lobes};
use crate::lane::fresnel::conductor as lane_conductor;
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneMask};
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Real part of the relative index (default: material "none", η = 0).
    pub eta: Spectrum,
    /// Imaginary part (default: material "none", k = 1).
    pub k: Spectrum,
    /// Multiplier of the reflectance (default 1).
    pub specular_reflectance: Spectrum,
}

impl Default for Conductor {
    /// Mitsuba's default: material "none", a perfect mirror.
    fn default() -> Self {
        Conductor {
            eta: Spectrum::ZERO,
            k: Spectrum::ONE,
            specular_reflectance: Spectrum::ONE,
        }
    }
}

impl Conductor {
    /// A delta lobe: `f · cos θo` and the density are 0 for any given pair of directions. The
    /// lane form (`bsdf::lanes`).
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, _wo: V3<L>) -> (V3<L>, L) {
        let zero = wi.z.splat(0.0);
        (V3::new(zero, zero, zero), zero)
    }

    /// The mirror direction about the shading normal, weighted by `specular_reflectance` times
    /// the conductor Fresnel reflectance; `ok` where `wi` is above the surface (zeros in the
    /// other lanes). Density 0 (a delta lobe). `u1`, `u2` unused. The lane form;
    /// [`Self::sample`] is its width 1.
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(&self, wi: V3<L>, _u1: L, _u2: V2<L>) -> LaneBsdfSample<L> {
        let r = self.specular_reflectance;
        self.sample_with(V3::splat(wi.z, r.x, r.y, r.z), wi)
    }

    /// [`Self::sample_lanes`] with `specular_reflectance` per lane (`spec`: the stream kernel's
    /// textured parameter).
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(&self, spec: V3<L>, wi: V3<L>) -> LaneBsdfSample<L> {
        let zero = wi.z.splat(0.0);
        let zero3 = V3::new(zero, zero, zero);
        let ok = !wi.z.le(zero);
        if !ok.any() {
            // Fast path (the bits of the selects below).
            return LaneBsdfSample {
                ok,
                wo: zero3,
                pdf: zero,
                weight: zero3,
            };
        }
        // The splats written out, not through a closure (which may be left out of line,
        // outside the SIMD target features: `tests/cli/simd_calls.rs`).
        let (eta, k) = (self.eta, self.k);
        let eta = V3::splat(wi.z, eta.x, eta.y, eta.z);
        let k = V3::splat(wi.z, k.x, k.y, k.z);
        let weight = spec * lane_conductor(wi.z, eta, k);
        LaneBsdfSample {
            ok,
            // fresnel::reflect_z.
            wo: V3::select(ok, V3::new(-wi.x, -wi.y, wi.z), zero3),
            pdf: zero,
            weight: V3::select(ok, weight, zero3),
        }
    }

    /// A delta lobe: `eval` is 0 for any given pair of directions ([`Self::eval_pdf_lanes`]
    /// at width 1).
    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf_lanes(V3::from(wi), V3::from(wo)).0.into()
    }

    /// 0: [`Self::eval_pdf_lanes`] at width 1.
    #[inline]
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf_lanes(V3::from(wi), V3::from(wo)).1
    }

    /// [`Self::sample_lanes`] at width 1.
    #[inline]
    pub fn sample(&self, wi: Vec3) -> Option<BsdfSample> {
        let s = self.sample_lanes(V3::from(wi), 0.0, V2::new(0.0, 0.0));
        s.ok.then(|| BsdfSample {
            wo: s.wo.into(),
            pdf: 0.0,
            weight: s.weight.into(),
            eta: 1.0,
            lobe: Lobes::DELTA_REFLECTION,
        })
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Conductor;
    use crate::bsdf::ior::load::conductor_ior;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot};

    /// `conductor`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let (eta, k) = conductor_ior(cx.props())?;
        let (spec, slots) =
            cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        let template = BsdfNode::Conductor(Conductor {
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
    use crate::math::Pcg32;

    /// `Conductor::sample` as it was before the lane form (frozen here, commit 6b74181).
    fn before(b: &Conductor, wi: Vec3) -> Option<BsdfSample> {
        use crate::bsdf::fresnel::{fresnel_conductor, reflect_z};
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: reflect_z(wi),
            pdf: 0.0,
            weight: b.specular_reflectance * fresnel_conductor(wi.z, b.eta, b.k),
            eta: 1.0,
            lobe: Lobes::DELTA_REFLECTION,
        })
    }

    fn bsdfs() -> [Conductor; 2] {
        [
            Conductor::default(),
            Conductor {
                eta: Spectrum::new(0.2, 0.92, 1.1),
                k: Spectrum::new(3.9, 2.45, 2.14),
                specular_reflectance: Spectrum::new(0.9, 0.7, 1.0),
            },
        ]
    }

    /// Width 1 gives the bits of the code it replaced; width 8 those of width 1, lane by lane.
    #[test]
    fn lane_form_equals_the_scalar_code() {
        let mut r = Pcg32::new(5, 1);
        let wis: Vec<Vec3> = (0..8000).map(|_| direction(&mut r)).collect();
        for b in bsdfs() {
            for &wi in &wis {
                let (s, s0) = (b.sample(wi), before(&b, wi));
                assert_eq!(s.is_some(), s0.is_some(), "{wi}");
                if let (Some(s), Some(s0)) = (s, s0) {
                    assert!(same3(s.wo, s0.wo) && same3(s.weight, s0.weight), "{wi}");
                    assert!(same(s.pdf, s0.pdf) && s.lobe == s0.lobe && s.eta == s0.eta);
                }
                let (f, p) = b.eval_pdf_lanes(V3::from(wi), V3::from(-wi));
                assert!(same3(f.into(), Vec3::ZERO) && same(p, 0.0));
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                for c in wis.chunks_exact(8) {
                    let wi: [Vec3; 8] = c.try_into().expect("8");
                    let u = avx.splat(0.3);
                    let s = avx.run(|| b.sample_lanes(load3(avx, &wi), u, V2::new(u, u)));
                    let ok = s.ok.to_array();
                    for k in 0..8 {
                        let s1 = b.sample_lanes(V3::from(wi[k]), 0.3, V2::new(0.3, 0.3));
                        assert_eq!(ok[k], s1.ok);
                        assert!(same3(lane3(s.wo, k), s1.wo.into()) && same(s.pdf.lane(k), 0.0));
                        assert!(same3(lane3(s.weight, k), s1.weight.into()));
                    }
                }
            }
        }
    }
}
