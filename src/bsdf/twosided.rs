//! `twosided`: makes a one-sided BSDF reflect on both sides (Mitsuba's `twosided`). When the query
//! comes from the back (`wi.z < 0`) both directions are mirrored through the surface, handed to the
//! back BSDF (the front one if only one is given), and the result mirrored back.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | (nested) | one or two `<bsdf>` | | the front BSDF, and the back one (the front one again when only one is given) |

use super::{Bsdf, BsdfContext, BsdfSample};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[inline]
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// The BSDF that answers a query from `wi`'s side, with the directions it sees: the front one as
/// given, or the back one with both directions mirrored through the surface.
#[inline]
fn side<'a>(b: Bsdf<'a>, front: u32, back: u32, wi: Vec3, wo: Vec3) -> (Bsdf<'a>, Vec3, Vec3) {
    if wi.z >= 0.0 {
        (b.child(front), wi, wo)
    } else {
        (b.child(back), flip(wi), flip(wo))
    }
}

pub(super) fn eval(
    b: Bsdf,
    front: u32,
    back: u32,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    sampler: &mut Sampler,
) -> Spectrum {
    let (bsdf, wi, wo) = side(b, front, back, wi, wo);
    bsdf.eval(ctx, wi, wo, sampler)
}

pub(super) fn pdf(b: Bsdf, front: u32, back: u32, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let (bsdf, wi, wo) = side(b, front, back, wi, wo);
    bsdf.pdf(ctx, wi, wo)
}

pub(super) fn eval_pdf(
    b: Bsdf,
    front: u32,
    back: u32,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    sampler: &mut Sampler,
) -> (Spectrum, f32) {
    let (bsdf, wi, wo) = side(b, front, back, wi, wo);
    bsdf.eval_pdf(ctx, wi, wo, sampler)
}

pub(super) fn sample(
    b: Bsdf,
    front: u32,
    back: u32,
    ctx: &BsdfContext,
    wi: Vec3,
    sampler: &mut Sampler,
) -> Option<BsdfSample> {
    if wi.z >= 0.0 {
        b.child(front).sample(ctx, wi, sampler)
    } else {
        let mut s = b.child(back).sample(ctx, flip(wi), sampler)?;
        s.wo = flip(s.wo);
        Some(s)
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;

    /// `twosided`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let mut bsdfs = Vec::new();
        for c in cx.props().objects() {
            if cx.props().kind(c) != "bsdf" {
                return Err(Error::scene(
                    &c.loc,
                    format!("twosided expects nested <bsdf>s, not <{}>", c.tag),
                ));
            }
            bsdfs.push(cx.bsdf(c)?);
        }
        match bsdfs[..] {
            [f] => Ok(MaterialNode::TwoSided { front: f, back: f }),
            [f, b] => Ok(MaterialNode::TwoSided { front: f, back: b }),
            _ => Err(Error::scene(
                cx.props().loc(),
                format!(
                    "twosided takes one or two nested BSDFs, found {}",
                    bsdfs.len()
                ),
            )),
        }
    }
}
