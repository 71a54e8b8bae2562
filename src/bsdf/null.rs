//! `null`: an index-matched pass-through surface (Mitsuba 3's `null` BSDF). It never scatters
//! light off the straight line: `eval = pdf = 0`, and `sample` continues the path straight
//! through (`wo = −wi`) with weight 1 as a delta lobe flagged [`Lobes::NULL`].
//!
//! Mitsuba 3's `path` integrator treats this as an ordinary delta bounce (the depth increments and
//! shadow rays are blocked by the surface), and so does groove's.

use super::{BsdfSample, Lobes};
use crate::spectrum::Spectrum;
use glam::Vec3;

/// The pass-through sample shared by `null` and `mask`.
#[inline]
pub fn pass_through(wi: Vec3) -> BsdfSample {
    BsdfSample {
        wo: -wi,
        pdf: 0.0,
        weight: Spectrum::ONE,
        eta: 1.0,
        lobe: Lobes::NULL,
    }
}
