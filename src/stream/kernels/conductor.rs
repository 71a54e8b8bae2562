//! The 8-wide `roughconductor` and `conductor` kernels, bare or under `twosided` (one nested
//! BSDF for both sides) and classic `normalmap` wrappers: what
//! [`PathState::scatter`](crate::integrator::path::PathState::scatter) does at such a vertex, for
//! 8 paths at a time.
//!
//! A material qualifies when its tree is at most [`MAX_WRAPS`] wrappers (`twosided` with
//! `front == back`, `normalmap`) around a `roughconductor` or `conductor` leaf whose parameters
//! are all constant (a textured `specular_reflectance` or roughness has no kernel: such a
//! material is shaded lane by lane, as every material without a kernel, and its paths show in
//! `LaneCounters::shade_used − kernel_lanes`). The normal maps' texture lookups are done lane
//! by lane; their perturbed frames, the side tests and the BSDF in lanes
//! (`bsdf::normalmap::lanes`, `RoughConductor::*_lanes`, `Conductor::*_lanes`).
//!
//! The per-vertex sequence (gather, random numbers, light points, scatter back) is
//! [`super::vertex`]'s, shared with nothing else yet; the light-sample part mirrors the `diffuse`
//! kernel's (BSDF value and density toward the light point, power heuristic, shadow ray), then
//! the BSDF sample gives the next ray. A `conductor` (a delta lobe) takes no light sample,
//! exactly as `PathState::scatter` asks `Lobes::is_smooth`.

use crate::bsdf::lanes::LaneBsdfSample;
use crate::bsdf::normalmap::lanes as nmap;
use crate::bsdf::{BsdfNode, Conductor, RoughConductor};
use crate::lane::frame::Frame;
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::material::{MatId, MaterialNode, Materials, TexId};

/// Most wrappers a kernel material may have around its leaf (e.g. `twosided` over `normalmap`).
pub(crate) const MAX_WRAPS: usize = 2;

/// The leaf BSDF, with its (constant) parameters.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Leaf {
    Rough(RoughConductor),
    Smooth(Conductor),
}

/// A wrapper around the leaf (outermost first in [`Material::wraps`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Wrap {
    /// `twosided` with one BSDF for both sides.
    TwoSided,
    /// Classic `normalmap`, its texture and flags.
    NormalMap {
        texture: TexId,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    },
}

/// A material the conductor kernel shades: its wrappers, outermost first, and its leaf.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Material {
    pub wraps: [Wrap; MAX_WRAPS],
    pub n_wraps: usize,
    pub leaf: Leaf,
    /// It takes light samples (`Lobes::is_smooth`: the rough leaf).
    pub smooth: bool,
}

impl Material {
    /// The kernel material of material `m`, if its tree qualifies (see the module doc).
    pub(crate) fn of(materials: &Materials, m: MatId) -> Option<Material> {
        let mut wraps = [Wrap::TwoSided; MAX_WRAPS];
        let mut n_wraps = 0;
        let mut id = m;
        let leaf = loop {
            let wrap = match &materials.nodes()[id as usize] {
                MaterialNode::Leaf { template, slots } if slots.is_empty() => {
                    break match **template {
                        BsdfNode::RoughConductor(b) => Leaf::Rough(b),
                        BsdfNode::Conductor(b) => Leaf::Smooth(b),
                        _ => return None,
                    };
                }
                MaterialNode::TwoSided { front, back } if front == back => {
                    id = *front;
                    Wrap::TwoSided
                }
                MaterialNode::NormalMap {
                    nested,
                    normalmap,
                    flip_invalid_normals,
                    use_shadowing_function,
                } => {
                    id = *nested;
                    Wrap::NormalMap {
                        texture: *normalmap,
                        flip_invalid_normals: *flip_invalid_normals,
                        use_shadowing_function: *use_shadowing_function,
                    }
                }
                _ => return None,
            };
            if n_wraps == MAX_WRAPS {
                return None;
            }
            wraps[n_wraps] = wrap;
            n_wraps += 1;
        };
        Some(Material {
            wraps,
            n_wraps,
            leaf,
            smooth: materials.lobes(m).is_smooth(),
        })
    }

    /// The wrappers, outermost first.
    #[inline(always)]
    pub(crate) fn wraps(&self) -> &[Wrap] {
        &self.wraps[..self.n_wraps]
    }

    /// The sample is through a delta lobe (the smooth `conductor`).
    #[inline(always)]
    pub(crate) fn delta(&self) -> bool {
        matches!(self.leaf, Leaf::Smooth(_))
    }
}

/// `twosided`'s mirror through the surface.
#[inline(always)]
fn flip<L: Lane>(w: V3<L>) -> V3<L> {
    V3::new(w.x, w.y, -w.z)
}

/// `Bsdf::sample`'s guard, applied at every node: a finite direction and weight, a density ≥ 0.
#[inline(always)]
fn valid<L: Lane>(s: &LaneBsdfSample<L>) -> L::Mask {
    let zero = s.pdf.splat(0.0);
    s.wo.x.is_finite()
        & s.wo.y.is_finite()
        & s.wo.z.is_finite()
        & s.pdf.ge(zero)
        & s.weight.x.is_finite()
        & s.weight.y.is_finite()
        & s.weight.z.is_finite()
}

/// `f · |cos θo|` and the density of the material's BSDF for local `wi`, `wo` (the shading
/// frame's), `normals[j]` the decoded normal of wrapper `j` where it is a normal map: the
/// wrappers' `eval_pdf` (`bsdf::twosided`, `bsdf::normalmap`) down to the leaf's lane form and
/// the shadowing terms back up, innermost first. 0 where a normal map rejects `wo`.
#[inline(always)]
pub(crate) fn eval_pdf<L: Lane>(
    mat: &Material,
    normals: &[V3<L>; MAX_WRAPS],
    wi: V3<L>,
    wo: V3<L>,
) -> (V3<L>, L) {
    let k = |c: f32| wi.z.splat(c);
    let (mut wi, mut wo) = (wi, wo);
    let mut reject = k(0.0).ne(k(0.0));
    let mut shadow = [None; MAX_WRAPS];
    for (j, w) in mat.wraps().iter().enumerate() {
        match *w {
            Wrap::TwoSided => {
                let back = !wi.z.ge(k(0.0));
                wi = V3::select(back, flip(wi), wi);
                wo = V3::select(back, flip(wo), wo);
            }
            Wrap::NormalMap {
                flip_invalid_normals,
                use_shadowing_function,
                ..
            } => {
                let f = nmap::frame(normals[j], flip_invalid_normals, wi);
                let pwo = f.to_local(wo);
                reject = reject | (wo.z * pwo.z).le(k(0.0));
                if use_shadowing_function {
                    shadow[j] = Some(nmap::shadow_terminator(f.n, wo));
                }
                wi = f.to_local(wi);
                wo = pwo;
            }
        }
    }
    let (mut f, mut pdf) = match &mat.leaf {
        Leaf::Rough(b) => b.eval_pdf_lanes(wi, wo),
        Leaf::Smooth(b) => b.eval_pdf_lanes(wi, wo),
    };
    for s in shadow[..mat.n_wraps].iter().rev().flatten() {
        f = f.scale(*s);
    }
    let zero = V3::splat(k(0.0), 0.0, 0.0, 0.0);
    f = V3::select(reject, zero, f);
    pdf = L::select(reject, k(0.0), pdf);
    (f, pdf)
}

/// The material's BSDF sample from local `wi` (see [`eval_pdf`] for `normals`): the wrappers'
/// `sample` down to the leaf's lane form and back up, with `Bsdf::sample`'s guard at every
/// node. `u2` is drawn by the rough leaf only.
#[inline(always)]
pub(crate) fn sample<L: Lane>(
    mat: &Material,
    normals: &[V3<L>; MAX_WRAPS],
    wi: V3<L>,
    u2: V2<L>,
) -> LaneBsdfSample<L> {
    let k = |c: f32| wi.z.splat(c);
    let mut wi = wi;
    let none = k(0.0).ne(k(0.0));
    let mut back = [none; MAX_WRAPS];
    let mut frames = [Frame {
        s: wi,
        t: wi,
        n: wi,
    }; MAX_WRAPS];
    for (j, w) in mat.wraps().iter().enumerate() {
        match *w {
            Wrap::TwoSided => {
                back[j] = !wi.z.ge(k(0.0));
                wi = V3::select(back[j], flip(wi), wi);
            }
            Wrap::NormalMap {
                flip_invalid_normals,
                ..
            } => {
                frames[j] = nmap::frame(normals[j], flip_invalid_normals, wi);
                wi = frames[j].to_local(wi);
            }
        }
    }
    let mut s = match &mat.leaf {
        Leaf::Rough(b) => b.sample_lanes(wi, k(0.0), u2),
        Leaf::Smooth(b) => b.sample_lanes(wi, k(0.0), u2),
    };
    s.ok = s.ok & valid(&s);
    for (j, w) in mat.wraps().iter().enumerate().rev() {
        match *w {
            Wrap::TwoSided => s.wo = V3::select(back[j], flip(s.wo), s.wo),
            Wrap::NormalMap {
                use_shadowing_function,
                ..
            } => {
                let wo = frames[j].to_world(s.wo);
                s.ok = s.ok & !(s.wo.z * wo.z).le(k(0.0));
                s.wo = wo;
                if use_shadowing_function {
                    s.weight = s.weight.scale(nmap::shadow_terminator(frames[j].n, wo));
                }
            }
        }
        s.ok = s.ok & valid(&s);
    }
    s
}
