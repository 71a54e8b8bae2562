//! `thindielectric`: a thin slab of dielectric (a window pane) seen as a single surface. Light is
//! either reflected or passes straight through (no offset, no bending); the interreflections
//! inside the slab are summed in closed form: with R the single-interface Fresnel reflectance,
//! R_total = R + T²R/(1 − R²) = 2R/(1 + R) and T_total = 1 − R_total. Both sides behave the same.
//!
//! Lane form (`src/bsdf/lanes.rs`): [`ThinDielectric::eval_pdf_lanes`],
//! [`ThinDielectric::sample_lanes`] (with the reflected lanes); [`ThinDielectric::sample`] is
//! its width 1, checked bit for bit against the code it replaced (the tests below).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `int_ior` | float or string | 1.5046 (`bk7`) | interior index of refraction, a number or a name ([`super::named_ior`]) |
//! | `ext_ior` | float or string | 1.000277 (`air`) | exterior index of refraction |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflection |
//! | `specular_transmittance` | spectrum or texture | 1 | multiplier of the transmission |

use super::lanes::LaneBsdfSample;
use super::{BsdfSample, Lobes};
use crate::lane::fresnel::dielectric as lane_dielectric;
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Relative index `int_ior / ext_ior` (default bk7 / air).
    pub eta: f32,
    pub specular_reflectance: Spectrum,
    pub specular_transmittance: Spectrum,
}

impl ThinDielectric {
    /// From Mitsuba's parameters `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`.
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Spectrum,
        specular_transmittance: Spectrum,
    ) -> Self {
        ThinDielectric {
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
    }

    /// Total reflectance of the slab at incidence cosine `cos_theta`: [`Self::reflectance_lanes`]
    /// at width 1.
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> f32 {
        self.reflectance_lanes(cos_theta)
    }

    /// [`Self::reflectance`] per lane.
    #[inline(always)]
    pub(crate) fn reflectance_lanes<L: Lane>(&self, cos_theta: L) -> L {
        let k = |c: f32| cos_theta.splat(c);
        let r = lane_dielectric(cos_theta.abs(), k(self.eta)).r;
        L::select(r.lt(k(1.0)), k(2.0) * r / (k(1.0) + r), r)
    }

    #[inline]
    pub fn eval(&self, _wi: Vec3, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    #[inline]
    pub fn pdf(&self, _wi: Vec3, _wo: Vec3) -> f32 {
        0.0
    }

    /// `(eval, pdf)` per lane: 0 and 0 (two delta lobes). The lane form (`bsdf::lanes`).
    #[inline(always)]
    pub(crate) fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, _wo: V3<L>) -> (V3<L>, L) {
        super::dielectric::delta_eval_pdf(wi)
    }

    /// Reflection where `u1 ≤ R_total`, straight transmission elsewhere (`u2` unused): the lane
    /// form of [`Self::sample`], which is its width 1. Every lane samples; also returns the
    /// reflected lanes (η is 1 everywhere: the slab bends nothing).
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(
        &self,
        wi: V3<L>,
        u1: L,
        _u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L::Mask) {
        let (r, t) = (self.specular_reflectance, self.specular_transmittance);
        let s = |c: Spectrum| V3::splat(wi.z, c.x, c.y, c.z);
        self.sample_with(s(r), s(t), wi, u1)
    }

    /// [`Self::sample_lanes`] with `specular_reflectance` (`r`) and `specular_transmittance`
    /// (`t`) per lane (the stream kernel's textured parameters).
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(
        &self,
        r: V3<L>,
        t: V3<L>,
        wi: V3<L>,
        u1: L,
    ) -> (LaneBsdfSample<L>, L::Mask) {
        let k = |c: f32| wi.z.splat(c);
        let reflect = u1.le(self.reflectance_lanes(wi.z));
        let sample = LaneBsdfSample {
            ok: reflect | !reflect,
            wo: V3::select(reflect, V3::new(-wi.x, -wi.y, wi.z), -wi),
            pdf: k(0.0),
            weight: V3::select(reflect, r, t),
        };
        (sample, reflect)
    }

    /// [`Self::sample_lanes`] at width 1.
    pub fn sample(&self, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let (s, reflect) = self.sample_lanes(V3::from(wi), u, V2::new(0.0, 0.0));
        let lobes = (Lobes::DELTA_REFLECTION, Lobes::DELTA_TRANSMISSION);
        super::dielectric::width_1_sample(s, 1.0, reflect, lobes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel::{fresnel_dielectric, reflect_z};
    use crate::bsdf::lanes::testing::*;
    use crate::math::Pcg32;

    /// The scalar `reflectance` and `sample` this file had before its lane form, frozen as the
    /// reference.
    fn reference_reflectance(b: &ThinDielectric, cos_theta: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta.abs(), b.eta).r;
        if r < 1.0 {
            2.0 * r / (1.0 + r)
        } else {
            r
        }
    }

    fn reference(b: &ThinDielectric, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let r = reference_reflectance(b, wi.z);
        if u <= r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                pdf: 0.0,
                weight: b.specular_reflectance,
                eta: 1.0,
                lobe: Lobes::DELTA_REFLECTION,
            })
        } else {
            Some(BsdfSample {
                wo: -wi,
                pdf: 0.0,
                weight: b.specular_transmittance,
                eta: 1.0,
                lobe: Lobes::DELTA_TRANSMISSION,
            })
        }
    }

    /// Width 1 is the frozen scalar code bit for bit from both sides (grazing and normal
    /// incidence included); width 8 is width 1 lane by lane.
    #[test]
    fn lane_form_is_the_replaced_scalar_code_bit_for_bit() {
        let mut r = Pcg32::new(18, 11);
        let mut transmitted = 0;
        for b in [
            ThinDielectric::default(),
            ThinDielectric::new(1.33, 1.0, Spectrum::new(0.9, 0.8, 0.7), Spectrum::ONE),
            ThinDielectric::new(1.0, 1.7, Spectrum::ONE, Spectrum::new(0.5, 0.6, 0.7)),
        ] {
            let cases: Vec<(Vec3, f32)> = (0..4000)
                .map(|_| (direction(&mut r), r.next_f32()))
                .collect();
            for &(wi, u) in &cases {
                assert!(same(b.reflectance(wi.z), reference_reflectance(&b, wi.z)));
                let (a, n) = (b.sample(wi, u).unwrap(), reference(&b, wi, u).unwrap());
                assert!(same3(a.wo, n.wo) && same3(a.weight, n.weight), "{wi} {u}");
                assert!(same(a.pdf, n.pdf) && same(a.eta, n.eta) && a.lobe == n.lobe);
                transmitted += (a.lobe == Lobes::DELTA_TRANSMISSION) as u32;
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                for c in cases.chunks_exact(8) {
                    let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                    let u: [f32; 8] = std::array::from_fn(|k| c[k].1);
                    let (s, refl) = avx.run(|| {
                        let u2 = load2(avx, &[glam::Vec2::ZERO; 8]);
                        b.sample_lanes(load3(avx, &wi), avx.load(&u), u2)
                    });
                    for k in 0..8 {
                        let one = b.sample_lanes(V3::from(wi[k]), u[k], V2::new(0.0, 0.0));
                        assert_eq!((one.0.ok, one.1), (s.ok.to_array()[k], refl.to_array()[k]));
                        assert!(same3(lane3(s.wo, k), one.0.wo.into()));
                        assert!(same3(lane3(s.weight, k), one.0.weight.into()));
                    }
                }
            }
        }
        // Not vacuous: both lobes are taken.
        assert!((2_000..11_000).contains(&transmitted), "{transmitted}");
    }
}

impl Default for ThinDielectric {
    fn default() -> Self {
        ThinDielectric::new(
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
    use super::ThinDielectric;
    use crate::bsdf::dielectric::load::{interface, Interface};
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;

    /// `thindielectric`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        } = interface(cx)?;
        let template = BsdfNode::ThinDielectric(ThinDielectric::new(int_ior, ext_ior, r, tr));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
