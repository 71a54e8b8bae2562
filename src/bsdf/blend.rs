//! `blendbsdf`: a linear blend `(1 − w)·f₀ + w·f₁` of two nested BSDFs (Mitsuba 3's
//! `blendbsdf`; `w` = `weight` at the hit, clamped to [0, 1]). `sample` picks BSDF 1 with
//! probability w and BSDF 0 otherwise. A delta sample keeps the nested weight (the choice
//! probability cancels the blend factor, as in Mitsuba); a smooth sample reports the blend's full
//! pdf `(1 − w)·p₀ + w·p₁` and weight `eval / pdf`, so that `weight == eval / pdf` and the pdf the
//! integrator uses for MIS are those of the sampled mixture (Mitsuba returns the chosen
//! component's pdf; both are unbiased).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `weight` | float or texture | required | w, the weight of the second BSDF (read as a scalar, in [0, 1]) |
//! | (nested) | two `<bsdf>` | required | the first is weighted 1 − w, the second w |

use super::{Bsdf, BsdfContext, BsdfSample, Lobes};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// A blend at one shading point (plain values, built per hit).
#[derive(Clone, Copy, Debug)]
pub struct Blend {
    /// Arena indices of the nested BSDFs (weight 1 − w and w).
    pub bsdf0: u32,
    pub bsdf1: u32,
    /// Blend weight in [0, 1].
    pub weight: f32,
}

pub(super) fn eval(
    b: Bsdf,
    m: &Blend,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    let w = m.weight;
    let mut v = Spectrum::ZERO;
    if w < 1.0 {
        v += (1.0 - w) * b.child(m.bsdf0).eval(ctx, wi, wo, s);
    }
    if w > 0.0 {
        v += w * b.child(m.bsdf1).eval(ctx, wi, wo, s);
    }
    v
}

pub(super) fn pdf(b: Bsdf, m: &Blend, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let w = m.weight;
    let mut p = 0.0;
    if w < 1.0 {
        p += (1.0 - w) * b.child(m.bsdf0).pdf(ctx, wi, wo);
    }
    if w > 0.0 {
        p += w * b.child(m.bsdf1).pdf(ctx, wi, wo);
    }
    p
}

/// Whether `sample` takes the second BSDF at weight `w`: always for w ≥ 1, never for w ≤ 0,
/// else with probability w from one number of `s` (drawn only then; the stream renderer's blend
/// kernel draws its choices through this too).
#[inline(always)]
pub(crate) fn picks_second(w: f32, s: &mut Sampler) -> bool {
    if w <= 0.0 {
        false
    } else if w >= 1.0 {
        true
    } else {
        s.next_1d() < w
    }
}

pub(super) fn sample(
    b: Bsdf,
    m: &Blend,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let w = m.weight;
    let pick1 = picks_second(w, s);
    let chosen = if pick1 { m.bsdf1 } else { m.bsdf0 };
    let mut bs = b.child(chosen).sample(ctx, wi, s)?;
    if bs.lobe.intersects(Lobes::DELTA) || w <= 0.0 || w >= 1.0 {
        return Some(bs);
    }
    let p = pdf(b, m, ctx, wi, bs.wo);
    if !super::is_positive(p) {
        return None;
    }
    bs.weight = eval(b, m, ctx, wi, bs.wo, s) / p;
    bs.pdf = p;
    Some(bs)
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::load::check;
    use crate::material::MaterialNode;
    use crate::spectrum::Spectrum;

    /// `blendbsdf`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let mut bsdfs = Vec::new();
        let mut weight = None;
        for c in cx.props().objects() {
            match cx.props().kind(c) {
                "bsdf" => bsdfs.push(cx.bsdf(c)?),
                "texture" if c.attr("name") == Some("weight") => weight = Some(cx.texture(c)?),
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a blendbsdf (two nested <bsdf>s and a float or <texture name=\"weight\">)"))),
            }
        }
        let p = cx.props();
        let [bsdf0, bsdf1] = bsdfs[..] else {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "blendbsdf takes exactly two nested BSDFs, found {}",
                    bsdfs.len()
                ),
            ));
        };
        let weight = match weight {
            Some(t) => t,
            None if !p.has("weight") => {
                return Err(Error::scene(
                    p.loc(),
                    "blendbsdf needs a 'weight' (a float or a <texture name=\"weight\">)",
                ))
            }
            None => {
                let w = p.float("weight", 0.5)?;
                check(
                    p.loc(),
                    (0.0..=1.0).contains(&w),
                    "blendbsdf weight must be in [0, 1]",
                )?;
                cx.constant(Spectrum::splat(w))
            }
        };
        Ok(MaterialNode::Blend {
            weight,
            bsdf0,
            bsdf1,
        })
    }
}
