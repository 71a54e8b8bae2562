//! Classic `normalmap` with Mitsuba 3.9.1 semantics (Mitsuba's `PerturbedBSDF` base of
//! `normalmap`/`bumpmap`, `src/bsdfs/perturbed_bsdf.h`): the nested BSDF is evaluated in the
//! frame of the perturbed normal n = 2·rgb − 1 (shading-frame coordinates), with
//! - `flip_invalid_normals` (default true): when `cos θi · (wi · n) <= 0` the normal is mirrored to
//!   `(−n.x, −n.y, n.z)`, keeping it on the side of the incident direction;
//! - `use_shadowing_function` (default true): eval and sample weights are multiplied by the
//!   Estevez et al. 2019 terminator term `2 / (1 + sqrt(1 + α²·tan²θo))`,
//!   `α² = min(tan²θn / 8, 1)`, θo measured in the unperturbed shading frame;
//! - directions whose side differs between the perturbed and the unperturbed frame are rejected
//!   (eval and pdf 0, sample none).
//!
//! The perturbed frame's tangent is the shading frame's `s` (= dp/du) made orthogonal to n by
//! Gram–Schmidt (falling back to `t` when degenerate), as Mitsuba builds it.
//! Both flags false is the plain model of Mitsuba 0.6 and of the benchmarks' classic baseline.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `normalmap` | texture | required | the normal map, n = 2·rgb − 1 in the shading frame |
//! | (nested) | one `<bsdf>` | required | the normal-mapped BSDF |
//! | `flip_invalid_normals` | boolean | true (false in files upgraded from 0.6) | mirror a normal that faces away from the incident direction |
//! | `use_shadowing_function` | boolean | true (false in files upgraded from 0.6) | the Estevez et al. 2019 shadowing term |

use super::{Bsdf, BsdfContext, BsdfSample};
use crate::math::Frame;
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// A classic normal-mapped BSDF at one shading point (plain values, built per hit with
/// [`NormalMap::new`]).
#[derive(Clone, Copy, Debug)]
pub struct NormalMap {
    /// Arena index of the nested BSDF.
    pub nested: u32,
    /// The decoded (not normalized) perturbed normal 2·rgb − 1 in the shading frame.
    normal: Vec3,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
    /// The perturbed frame of `normal` as given, built once per hit: eval, pdf and sample all
    /// need it (only a flipped normal builds another).
    frame: Frame,
}

#[inline]
fn tan2(w: Vec3) -> f32 {
    let c2 = w.z * w.z;
    (1.0 - c2).max(0.0) / c2
}

/// Estevez et al. 2019, "A Microfacet-Based Shadowing Function to Solve the Bump Terminator
/// Problem" (Ray Tracing Gems, ch. 12): `n` the perturbed normal and `wo` in the shading frame.
pub fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan2(n)).min(1.0);
    if alpha2 <= 0.0 || alpha2.is_nan() {
        return 1.0;
    }
    let g = 2.0 / (1.0 + (1.0 + alpha2 * tan2(wo)).sqrt());
    if g.is_finite() {
        g
    } else {
        0.0
    }
}

/// The frame of the perturbed normal `n` (shading-frame coordinates): n normalised (+z when
/// degenerate), tangent = the shading frame's s made orthogonal to n (t when degenerate).
fn perturbed_frame(n: Vec3) -> Frame {
    let len2 = n.length_squared();
    let n = if len2 > 0.0 && len2.is_finite() {
        n / len2.sqrt()
    } else {
        Vec3::Z
    };
    let s = Vec3::X - n * n.x;
    let ls2 = s.length_squared();
    let s = if ls2 > 0.0 && ls2.is_finite() {
        s / ls2.sqrt()
    } else {
        Vec3::Y
    };
    Frame {
        s,
        t: n.cross(s),
        n,
    }
}

impl NormalMap {
    /// `normal`: the decoded perturbed normal 2·rgb − 1 (not normalised) in the shading frame.
    pub fn new(
        nested: u32,
        normal: Vec3,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    ) -> Self {
        NormalMap {
            nested,
            normal,
            flip_invalid_normals,
            use_shadowing_function,
            frame: perturbed_frame(normal),
        }
    }

    /// The decoded perturbed normal as given.
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The perturbed frame in shading-frame coordinates for the incident direction `wi`.
    #[inline]
    pub fn frame(&self, wi: Vec3) -> Frame {
        let n = self.normal;
        if self.flip_invalid_normals && wi.z * wi.dot(n) <= 0.0 {
            perturbed_frame(Vec3::new(-n.x, -n.y, n.z))
        } else {
            self.frame
        }
    }

    #[inline]
    fn shadow(&self, f: &Frame, wo: Vec3) -> f32 {
        if self.use_shadowing_function {
            shadow_terminator(f.n, wo)
        } else {
            1.0
        }
    }
}

/// The perturbed frame for `wi` with `wi` and `wo` in it, or `None` when `wo` changes sides
/// between the perturbed and the unperturbed frame (no light, as in Mitsuba).
#[inline]
fn perturbed_query(m: &NormalMap, wi: Vec3, wo: Vec3) -> Option<(Frame, Vec3, Vec3)> {
    let f = m.frame(wi);
    let pwo = f.to_local(wo);
    if wo.z * pwo.z <= 0.0 {
        return None;
    }
    Some((f, f.to_local(wi), pwo))
}

pub(super) fn eval(
    b: Bsdf,
    m: &NormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    let Some((f, pwi, pwo)) = perturbed_query(m, wi, wo) else {
        return Spectrum::ZERO;
    };
    b.child(m.nested).eval(ctx, pwi, pwo, s) * m.shadow(&f, wo)
}

pub(super) fn pdf(b: Bsdf, m: &NormalMap, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let Some((_, pwi, pwo)) = perturbed_query(m, wi, wo) else {
        return 0.0;
    };
    b.child(m.nested).pdf(ctx, pwi, pwo)
}

pub(super) fn eval_pdf(
    b: Bsdf,
    m: &NormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let Some((f, pwi, pwo)) = perturbed_query(m, wi, wo) else {
        return (Spectrum::ZERO, 0.0);
    };
    let (v, p) = b.child(m.nested).eval_pdf(ctx, pwi, pwo, s);
    (v * m.shadow(&f, wo), p)
}

pub(super) fn sample(
    b: Bsdf,
    m: &NormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let f = m.frame(wi);
    let mut bs = b.child(m.nested).sample(ctx, f.to_local(wi), s)?;
    let wo = f.to_world(bs.wo);
    if bs.wo.z * wo.z <= 0.0 {
        return None;
    }
    bs.wo = wo;
    bs.weight *= m.shadow(&f, wo);
    Some(bs)
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result, SourceLoc};
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MatId, MaterialNode, TexId};
    use crate::spectrum::Spectrum;

    /// `normalmap`; `plain` (the classic side of `--normal-mapping`) forces both flags false.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>, plain: bool) -> Result<MaterialNode> {
        let (nested, _, normalmap) = parts(cx, "normalmap")?;
        let default = !cx.upgraded_from_v0();
        let flip = cx.props().bool("flip_invalid_normals", default)?;
        let shadow = cx.props().bool("use_shadowing_function", default)?;
        Ok(MaterialNode::NormalMap {
            nested,
            normalmap,
            flip_invalid_normals: flip && !plain,
            use_shadowing_function: shadow && !plain,
        })
    }

    /// The nested BSDF (with where it is written, for errors about it) and the `normalmap`
    /// texture of a `normalmap` or a `microfacet_normalmap` (`kind`).
    pub(crate) fn parts<'d>(
        cx: &mut BsdfCtx<'_, 'd>,
        kind: &str,
    ) -> Result<(MatId, &'d SourceLoc, TexId)> {
        for c in cx.props().objects() {
            match cx.props().kind(c) {
                "bsdf" => {}
                "texture" if c.attr("name") == Some("normalmap") => {}
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a {kind} (a nested <bsdf> and a <texture name=\"normalmap\">)"))),
            }
        }
        let Some(nested_node) = cx.props().one_child("bsdf")? else {
            return Err(Error::scene(
                cx.props().loc(),
                format!("{kind} needs a nested <bsdf>"),
            ));
        };
        let nested = cx.bsdf(nested_node)?;
        let texture = cx
            .props()
            .objects()
            .find(|c| cx.props().kind(c) == "texture" && c.attr("name") == Some("normalmap"));
        let normalmap = match texture {
            Some(t) => cx.texture(t)?,
            None if cx.props().has("normalmap") => {
                cx.color("normalmap", Spectrum::new(0.5, 0.5, 1.0))?
            }
            None => {
                return Err(Error::scene(
                    cx.props().loc(),
                    format!("{kind} needs a <texture name=\"normalmap\">"),
                ))
            }
        };
        Ok((nested, &nested_node.loc, normalmap))
    }
}
