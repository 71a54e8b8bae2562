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
#[allow(dead_code)] // until the first lane form lands (remove then)
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
