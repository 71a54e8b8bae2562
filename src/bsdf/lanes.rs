//! The lane form of a BSDF (issues 17 and 18): one BSDF model's `eval_pdf` and `sample` written
//! once over [`Lane`], so that the scalar BSDF is the `f32` instantiation and an 8-wide material
//! kernel (the stream renderer) or a batch of nested evaluations (the compensated microfacet
//! normal map) is the [`crate::lane::F32x8`] one, bit for bit (the rule in [`crate::lane`]).
//!
//! Convention for a BSDF file that has a lane form (parameters uniform across the lanes, already
//! texture-evaluated, i.e. `&self` of the plain BSDF struct):
//! - `fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L)`: `f · |cos θo|`
//!   (RGB) and the solid-angle density of `sample`, both 0 in lanes where the pair is invalid;
//! - `fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L>`
//!   (`u1` is the lobe-selection number for BSDFs that have one; others ignore it).

use crate::lane::vec::V3;
use crate::lane::Lane;

/// A sampled direction per lane, with its weight: [`super::BsdfSample`] in lanes. The lobe and
/// the relative index are the BSDF's own (one value for all lanes) and are not repeated here.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneBsdfSample<L: Lane> {
    /// Lanes where a direction was sampled (the scalar `sample` returned `Some`).
    pub ok: L::Mask,
    pub wo: V3<L>,
    /// Solid-angle density of `wo`.
    pub pdf: L,
    /// `f · |cos θo| / pdf`.
    pub weight: V3<L>,
}

/// Helpers for the lane-form tests: random inputs, 8 scalar vectors as one vector of 8 lanes,
/// bit comparisons (NaN equal to NaN, as the rule in [`crate::lane`] says).
#[cfg(test)]
pub(crate) mod testing {
    use crate::lane::vec::{V2, V3};
    use crate::math::Pcg32;
    use glam::{Vec2, Vec3};

    /// Directions for a BSDF test: uniform on the sphere (both hemispheres), with exact and
    /// near-horizon, normal and slightly non-unit ones mixed in.
    pub(crate) fn direction(r: &mut Pcg32) -> Vec3 {
        let z = 2.0 * r.next_f32() - 1.0;
        let phi = 2.0 * core::f32::consts::PI * r.next_f32();
        let s = (1.0 - z * z).max(0.0).sqrt();
        let v = Vec3::new(s * phi.cos(), s * phi.sin(), z);
        match r.next_f32() {
            x if x < 0.03 => Vec3::new(v.x, v.y, 0.0).normalize(),
            x if x < 0.06 => Vec3::new(v.x, v.y, 1e-4 * v.z.signum()).normalize(),
            x if x < 0.08 => Vec3::Z,
            x if x < 0.12 => v * (1.0 + 1e-3 * (r.next_f32() - 0.5)),
            _ => v,
        }
    }

    /// Equal bits, or both NaN.
    pub(crate) fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    pub(crate) fn same3(a: Vec3, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    #[cfg(target_arch = "x86_64")]
    pub(crate) use x8::*;

    #[cfg(target_arch = "x86_64")]
    mod x8 {
        use super::*;
        use crate::lane::{Avx2, F32x8, Lane};

        /// Lane k = `v[k]`.
        pub(crate) fn load3(avx: Avx2, v: &[Vec3; 8]) -> V3<F32x8> {
            V3::new(
                avx.load(&v.map(|a| a.x)),
                avx.load(&v.map(|a| a.y)),
                avx.load(&v.map(|a| a.z)),
            )
        }

        pub(crate) fn load2(avx: Avx2, v: &[Vec2; 8]) -> V2<F32x8> {
            V2::new(avx.load(&v.map(|a| a.x)), avx.load(&v.map(|a| a.y)))
        }

        /// Lane `k` of a vector of lanes.
        pub(crate) fn lane3(v: V3<F32x8>, k: usize) -> Vec3 {
            Vec3::new(v.x.lane(k), v.y.lane(k), v.z.lane(k))
        }
    }
}
