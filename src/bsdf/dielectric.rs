//! `dielectric`: a smooth interface between two dielectrics (glass, water): delta reflection and
//! delta refraction, chosen in proportion to the Fresnel reflectance, so the sample weight is 1
//! (times `specular_reflectance` / `specular_transmittance`). Works from both sides; a ray from
//! inside sees the inverted relative index and can be totally internally reflected.
//!
//! Radiance crossing into a denser medium is compressed into a smaller solid angle: in
//! [`TransportMode::Radiance`] the refracted weight is scaled by (η_i/η_t)² (Veach 1997, §5.2);
//! importance is not scaled.
//!
//! Lane form (`src/bsdf/lanes.rs`): [`Dielectric::eval_pdf_lanes`], [`Dielectric::sample_lanes`]
//! (with the transport mode, and the crossing's η per lane); [`Dielectric::sample`] is its width
//! 1, checked bit for bit against the code it replaced (the tests below).
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
use super::{BsdfSample, Lobes, TransportMode};
use crate::lane::fresnel::dielectric as lane_dielectric;
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Relative index `int_ior / ext_ior` (default bk7 / air = 1.5046 / 1.000277).
    pub eta: f32,
    /// Multiplier of the reflected part (default 1; not physical, for artistic control).
    pub specular_reflectance: Spectrum,
    /// Multiplier of the transmitted part (default 1).
    pub specular_transmittance: Spectrum,
}

/// Mitsuba's default interior (bk7) and exterior (air) indices.
pub const DEFAULT_INT_IOR: f32 = 1.5046;
pub const DEFAULT_EXT_IOR: f32 = 1.000277;

impl Dielectric {
    /// From Mitsuba's parameters `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`.
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Spectrum,
        specular_transmittance: Spectrum,
    ) -> Self {
        Dielectric {
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
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
        delta_eval_pdf(wi)
    }

    /// Reflection where `u1 ≤ F`, refraction elsewhere (`u2` unused): the lane form of
    /// [`Self::sample`], which is its width 1. Every lane samples (`ok` all set); also returns
    /// the relative index η of each lane's crossing (1 where reflected) and the reflected lanes.
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(
        &self,
        mode: TransportMode,
        wi: V3<L>,
        u1: L,
        _u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L, L::Mask) {
        let (r, t) = (self.specular_reflectance, self.specular_transmittance);
        let s = |c: Spectrum| V3::splat(wi.z, c.x, c.y, c.z);
        self.sample_with(mode, s(r), s(t), wi, u1)
    }

    /// [`Self::sample_lanes`] with `specular_reflectance` (`r`) and `specular_transmittance`
    /// (`tr`) per lane (the stream kernel's textured parameters).
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(
        &self,
        mode: TransportMode,
        r: V3<L>,
        tr: V3<L>,
        wi: V3<L>,
        u1: L,
    ) -> (LaneBsdfSample<L>, L, L::Mask) {
        let k = |c: f32| wi.z.splat(c);
        let f = lane_dielectric(wi.z, k(self.eta));
        let reflect = u1.le(f.r);
        // Refraction about the normal: the tangential part scales by η_i/η_t.
        let t = V3::new(-f.eta_ti * wi.x, -f.eta_ti * wi.y, f.cos_theta_t);
        let scale = match mode {
            TransportMode::Radiance => f.eta_ti * f.eta_ti,
            TransportMode::Importance => k(1.0),
        };
        let weight_t = V3::new(tr.x * scale, tr.y * scale, tr.z * scale);
        let sample = LaneBsdfSample {
            ok: reflect | !reflect,
            wo: V3::select(reflect, V3::new(-wi.x, -wi.y, wi.z), t),
            pdf: k(0.0),
            weight: V3::select(reflect, r, weight_t),
        };
        (sample, L::select(reflect, k(1.0), f.eta_it), reflect)
    }

    /// [`Self::sample_lanes`] at width 1.
    pub fn sample(&self, mode: TransportMode, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let (s, eta, reflect) = self.sample_lanes(mode, V3::from(wi), u, V2::new(0.0, 0.0));
        let lobes = (Lobes::DELTA_REFLECTION, Lobes::DELTA_TRANSMISSION);
        width_1_sample(s, eta, reflect, lobes)
    }
}

/// `(eval, pdf)` of delta lobes only, per lane: 0 and 0 (`dielectric`, `thindielectric`).
#[inline(always)]
pub(super) fn delta_eval_pdf<L: Lane>(wi: V3<L>) -> (V3<L>, L) {
    let zero = wi.z.splat(0.0);
    (V3::new(zero, zero, zero), zero)
}

/// A dielectric's lane-form sample at width 1 as a [`BsdfSample`]: `None` where not `ok`, the
/// lobe `lobes.0` where reflected, else `lobes.1` (the three dielectrics' scalar `sample`).
#[inline]
pub(super) fn width_1_sample(
    s: LaneBsdfSample<f32>,
    eta: f32,
    reflect: bool,
    lobes: (Lobes, Lobes),
) -> Option<BsdfSample> {
    s.ok.then(|| BsdfSample {
        wo: s.wo.into(),
        pdf: s.pdf,
        weight: s.weight.into(),
        eta,
        lobe: if reflect { lobes.0 } else { lobes.1 },
    })
}

impl Default for Dielectric {
    fn default() -> Self {
        Dielectric::new(
            DEFAULT_INT_IOR,
            DEFAULT_EXT_IOR,
            Spectrum::ONE,
            Spectrum::ONE,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel::{fresnel_dielectric, reflect_z};
    use crate::bsdf::lanes::testing::*;
    use crate::math::Pcg32;
    use glam::Vec2;

    /// The scalar `sample` this file had before its lane form, frozen as the reference.
    fn reference(b: &Dielectric, mode: TransportMode, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let f = fresnel_dielectric(wi.z, b.eta);
        if u <= f.r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                pdf: 0.0,
                weight: b.specular_reflectance,
                eta: 1.0,
                lobe: Lobes::DELTA_REFLECTION,
            })
        } else {
            let wo = Vec3::new(-f.eta_ti * wi.x, -f.eta_ti * wi.y, f.cos_theta_t);
            let scale = match mode {
                TransportMode::Radiance => f.eta_ti * f.eta_ti,
                TransportMode::Importance => 1.0,
            };
            Some(BsdfSample {
                wo,
                pdf: 0.0,
                weight: b.specular_transmittance * scale,
                eta: f.eta_it,
                lobe: Lobes::DELTA_TRANSMISSION,
            })
        }
    }

    fn models() -> [Dielectric; 3] {
        [
            Dielectric::default(),
            Dielectric::new(1.33, 1.0, Spectrum::new(0.9, 0.8, 0.7), Spectrum::ONE),
            Dielectric::new(1.0, 1.7, Spectrum::ONE, Spectrum::new(0.5, 0.6, 0.7)),
        ]
    }

    /// Width 1 is the frozen scalar code bit for bit, both sides (total internal reflection
    /// included) and both transport modes; width 8 is width 1 lane by lane.
    #[test]
    fn lane_form_is_the_replaced_scalar_code_bit_for_bit() {
        let mut r = Pcg32::new(18, 9);
        let mut refracted = 0;
        for b in models() {
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let cases: Vec<(Vec3, f32)> = (0..4000)
                    .map(|_| (direction(&mut r), r.next_f32()))
                    .collect();
                for &(wi, u) in &cases {
                    let (a, n) = (b.sample(mode, wi, u), reference(&b, mode, wi, u));
                    let (a, n) = (a.expect("always samples"), n.expect("always"));
                    assert!(same3(a.wo, n.wo) && same3(a.weight, n.weight), "{wi} {u}");
                    assert!(same(a.pdf, n.pdf) && same(a.eta, n.eta) && a.lobe == n.lobe);
                    refracted += (a.lobe == Lobes::DELTA_TRANSMISSION) as u32;
                    let (f, p) = b.eval_pdf_lanes(V3::from(wi), V3::from(-wi));
                    assert!(Vec3::from(f) == Vec3::ZERO && p == 0.0);
                }
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = crate::lane::Avx2::detect() {
                    for c in cases.chunks_exact(8) {
                        let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                        let u: [f32; 8] = std::array::from_fn(|k| c[k].1);
                        let (s, eta, refl) = avx.run(|| {
                            let u2 = load2(avx, &[Vec2::ZERO; 8]);
                            b.sample_lanes(mode, load3(avx, &wi), avx.load(&u), u2)
                        });
                        let refl = refl.to_array();
                        for k in 0..8 {
                            let one =
                                b.sample_lanes(mode, V3::from(wi[k]), u[k], V2::new(0.0, 0.0));
                            assert_eq!((one.0.ok, one.2), (s.ok.to_array()[k], refl[k]));
                            assert!(same3(lane3(s.wo, k), one.0.wo.into()));
                            assert!(same3(lane3(s.weight, k), one.0.weight.into()));
                            assert!(same(s.pdf.lane(k), one.0.pdf) && same(eta.lane(k), one.1));
                        }
                    }
                }
            }
        }
        // Not vacuous: both lobes are taken.
        assert!((5_000..20_000).contains(&refracted), "{refracted}");
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Dielectric;
    use crate::bsdf::dielectric::{DEFAULT_EXT_IOR, DEFAULT_INT_IOR};
    use crate::bsdf::ior::load::ior_param;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot, TexId};
    use crate::spectrum::Spectrum;

    /// What every dielectric interface (`dielectric`, `thindielectric`, `roughdielectric`) reads:
    /// the two indices and the two (possibly textured) colours with their texture slots.
    pub(crate) struct Interface {
        pub int_ior: f32,
        pub ext_ior: f32,
        pub r: Spectrum,
        pub tr: Spectrum,
        pub slots: Vec<(Slot, TexId)>,
    }

    pub(crate) fn interface(cx: &mut BsdfCtx<'_, '_>) -> Result<Interface> {
        let int_ior = ior_param(cx.props(), "int_ior", DEFAULT_INT_IOR)?;
        let ext_ior = ior_param(cx.props(), "ext_ior", DEFAULT_EXT_IOR)?;
        let (r, mut slots) =
            cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        let (tr, s2) = cx.leaf_color("specular_transmittance", Slot::SpecularTransmittance, 1.0)?;
        slots.extend(s2);
        Ok(Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        })
    }

    /// `dielectric`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        } = interface(cx)?;
        let template = BsdfNode::Dielectric(Dielectric::new(int_ior, ext_ior, r, tr));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
