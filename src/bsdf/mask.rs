//! `mask`: an opacity mask over a nested BSDF (Mitsuba 3's `mask`):
//! `f = opacity · f_nested`, plus a pass-through delta lobe of weight `1 − opacity`
//! (see [`super::null`]). `opacity` is the scalar texture value at the hit, clamped to [0, 1].
//!
//! Sampling follows Mitsuba 3.9.1 (`src/bsdfs/mask.cpp`): the nested BSDF is chosen with
//! probability `opacity` and keeps its own sample weight (the choice probability cancels the
//! opacity factor); otherwise the path passes straight through with weight 1. `pdf(wi, wo)` is
//! `opacity · pdf_nested`, and a smooth nested sample reports that pdf too (as Mitsuba 3.9.1
//! does, checked with `bsdf.sample` / `bsdf.pdf`), the density of the whole mixture used by MIS.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `opacity` | float, spectrum or texture | 0.5 | probability of the nested BSDF (read as a scalar, in [0, 1]) |
//! | (nested) | one `<bsdf>` | required | the masked BSDF |

use super::{null, Bsdf, BsdfContext, BsdfSample};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// A mask at one shading point (plain values, built per hit).
#[derive(Clone, Copy, Debug)]
pub struct Mask {
    /// Arena index of the nested (opaque part's) BSDF.
    pub nested: u32,
    /// Opacity in [0, 1] (1 = only the nested BSDF, 0 = fully transparent).
    pub opacity: f32,
}

pub(super) fn eval(
    b: Bsdf,
    m: &Mask,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    if m.opacity <= 0.0 {
        return Spectrum::ZERO;
    }
    m.opacity * b.child(m.nested).eval(ctx, wi, wo, s)
}

pub(super) fn pdf(b: Bsdf, m: &Mask, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    if m.opacity <= 0.0 {
        return 0.0;
    }
    m.opacity * b.child(m.nested).pdf(ctx, wi, wo)
}

/// Eval and pdf of one query from the nested BSDF's own `eval_pdf`, so that next-event
/// estimation sees the density that the nested `sample` reports (a nested BSDF with a
/// stochastic branch choice, `auto`'s blend band, reports the picked branch's density from both:
/// `bsdf::mnm`'s `mixture_pdf`).
pub(super) fn eval_pdf(
    b: Bsdf,
    m: &Mask,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    if m.opacity <= 0.0 {
        return (Spectrum::ZERO, 0.0);
    }
    let (f, p) = b.child(m.nested).eval_pdf(ctx, wi, wo, s);
    (m.opacity * f, m.opacity * p)
}

pub(super) fn sample(
    b: Bsdf,
    m: &Mask,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let o = m.opacity;
    let nested = if o <= 0.0 {
        false
    } else if o >= 1.0 {
        true
    } else {
        s.next_1d() < o
    };
    if !nested {
        return Some(null::pass_through(wi));
    }
    let mut bs = b.child(m.nested).sample(ctx, wi, s)?;
    // Delta samples report pdf 0; a smooth one the mixture's density (weight unchanged).
    bs.pdf *= o;
    Some(bs)
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::load::check;
    use crate::material::MaterialNode;
    use crate::spectrum::{luminance, Spectrum};
    use crate::texture::Texture;

    /// `mask`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        for c in cx.props().objects() {
            match cx.props().kind(c) {
                "bsdf" => {}
                "texture" if c.attr("name") == Some("opacity") => {}
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a mask (a nested <bsdf> and a float or <texture name=\"opacity\">)"))),
            }
        }
        let nested = match cx.props().one_child("bsdf")? {
            Some(c) => cx.bsdf(c)?,
            None => return Err(Error::scene(cx.props().loc(), "mask needs a nested <bsdf>")),
        };
        let opacity = cx.color("opacity", Spectrum::splat(0.5))?;
        if let Texture::Constant(c) = cx.texture_at(opacity) {
            check(
                cx.props().loc(),
                (0.0..=1.0).contains(&luminance(*c)),
                "mask opacity must be in [0, 1]",
            )?;
        }
        Ok(MaterialNode::Mask { opacity, nested })
    }
}
