//! `null`: an index-matched pass-through surface (Mitsuba 3's `null` BSDF). It never scatters
//! light off the straight line: `eval = pdf = 0`, and `sample` continues the path straight
//! through (`wo = −wi`) with weight 1 as a delta lobe flagged [`Lobes::NULL`].
//!
//! Mitsuba 3's `path` integrator treats this as an ordinary delta bounce (the depth increments and
//! shadow rays are blocked by the surface), and so does groove's.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | (none) | | | `null` takes no parameters and no nested objects |

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

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;

    /// `null`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        if let Some(c) = cx.props().objects().next() {
            return Err(Error::scene(
                &c.loc,
                format!(
                    "<{}> is not expected inside a null BSDF (it takes no parameters)",
                    c.tag
                ),
            ));
        }
        Ok(MaterialNode::Null)
    }
}
