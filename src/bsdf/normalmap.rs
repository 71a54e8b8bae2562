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

/// The lane forms of this file's frame and shadowing term (the stream renderer's conductor
/// kernels, `stream::kernels::conductor`): the operations of [`perturbed_frame`],
/// [`NormalMap::frame`] and [`shadow_terminator`] in the same order, with selects for branches,
/// so every lane equals the scalar function bit for bit (tested below).
pub(crate) mod lanes {
    use crate::lane::frame::Frame;
    use crate::lane::vec::V3;
    use crate::lane::{Lane, LaneMask};

    /// `max(1 − cos², 0) / cos²` of `w`.
    #[inline(always)]
    fn tan2<L: Lane>(w: V3<L>) -> L {
        let c2 = w.z * w.z;
        (c2.splat(1.0) - c2).max(c2.splat(0.0)) / c2
    }

    /// [`super::shadow_terminator`].
    #[inline(always)]
    pub(crate) fn shadow_terminator<L: Lane>(n: V3<L>, wo: V3<L>) -> L {
        let k = |c: f32| n.z.splat(c);
        let alpha2 = (k(0.125) * tan2(n)).min(k(1.0));
        let g = k(2.0) / (k(1.0) + (k(1.0) + alpha2 * tan2(wo)).sqrt());
        let g = L::select(g.is_finite(), g, k(0.0));
        L::select(alpha2.le(k(0.0)) | alpha2.is_nan(), k(1.0), g)
    }

    /// [`super::perturbed_frame`].
    #[inline(always)]
    pub(crate) fn perturbed_frame<L: Lane>(n: V3<L>) -> Frame<L> {
        let k = |c: f32| n.z.splat(c);
        let len2 = n.length_squared();
        let good = len2.gt(k(0.0)) & len2.is_finite();
        let n = V3::select(
            good,
            n.div_by(len2.sqrt()),
            V3::splat(k(0.0), 0.0, 0.0, 1.0),
        );
        // Vec3::X − n · n.x.
        let s = V3::new(k(1.0) - n.x * n.x, k(0.0) - n.y * n.x, k(0.0) - n.z * n.x);
        let ls2 = s.length_squared();
        let good = ls2.gt(k(0.0)) & ls2.is_finite();
        let s = V3::select(good, s.div_by(ls2.sqrt()), V3::splat(k(0.0), 0.0, 1.0, 0.0));
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// [`super::NormalMap::frame`] for the decoded normal `n` (not normalised) and the
    /// incident direction `wi`.
    #[inline(always)]
    pub(crate) fn frame<L: Lane>(n: V3<L>, flip_invalid_normals: bool, wi: V3<L>) -> Frame<L> {
        let f = perturbed_frame(n);
        if !flip_invalid_normals {
            return f;
        }
        let flip = (wi.z * wi.dot(n)).le(wi.z.splat(0.0));
        if !flip.any() {
            // Fast path (same bits as the selects below): no lane flips.
            return f;
        }
        let g = perturbed_frame(V3::new(-n.x, -n.y, n.z));
        Frame {
            s: V3::select(flip, g.s, f.s),
            t: V3::select(flip, g.t, f.t),
            n: V3::select(flip, g.n, f.n),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::*;
    use crate::lane::vec::V3;
    #[cfg(target_arch = "x86_64")]
    use crate::lane::Lane;
    use crate::math::Pcg32;

    /// Decoded normals as a normal map gives them (2·rgb − 1, rgb in [0, 1], so neither unit
    /// nor always above the surface), the exact ±z and the degenerate zero vector.
    fn normals(r: &mut Pcg32, n: usize) -> Vec<Vec3> {
        let mut v: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 2.0 - Vec3::ONE)
            .collect();
        v.extend([
            Vec3::ZERO,
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.5, 0.5, 1.0),
        ]);
        v
    }

    /// The lane frame and shadowing term at width 1 equal the scalar ones, and at width 8
    /// width 1, lane by lane.
    #[test]
    fn lane_frame_and_shadowing_equal_the_scalar_ones() {
        let mut r = Pcg32::new(9, 4);
        let ns = normals(&mut r, 3000);
        let cases: Vec<(Vec3, Vec3, Vec3)> = ns
            .iter()
            .map(|&n| (n, direction(&mut r), direction(&mut r)))
            .collect();
        for flip in [false, true] {
            for &(n, wi, wo) in &cases {
                let f = NormalMap::new(0, n, flip, true).frame(wi);
                let g = lanes::frame(V3::from(n), flip, V3::from(wi));
                assert!(
                    same3(f.s, g.s.into()) && same3(f.t, g.t.into()) && same3(f.n, g.n.into()),
                    "{n} {wi}"
                );
                let t = lanes::shadow_terminator(V3::from(f.n), V3::from(wo));
                assert!(same(t, shadow_terminator(f.n, wo)), "{n} {wo}");
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                for c in cases.chunks_exact(8) {
                    let n: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                    let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].1);
                    let wo: [Vec3; 8] = std::array::from_fn(|k| c[k].2);
                    let (f, t) = avx.run(|| {
                        let f = lanes::frame(load3(avx, &n), flip, load3(avx, &wi));
                        (f, lanes::shadow_terminator(f.n, load3(avx, &wo)))
                    });
                    for k in 0..8 {
                        let g = lanes::frame(V3::from(n[k]), flip, V3::from(wi[k]));
                        assert!(
                            same3(lane3(f.s, k), g.s.into()) && same3(lane3(f.n, k), g.n.into())
                        );
                        assert!(same3(lane3(f.t, k), g.t.into()));
                        let t1 = lanes::shadow_terminator(g.n, V3::from(wo[k]));
                        assert!(same(t.lane(k), t1));
                    }
                }
            }
        }
    }
}
