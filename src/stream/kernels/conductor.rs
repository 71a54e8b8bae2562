//! The 8-wide `roughconductor` and `conductor` kernels, bare or under `twosided` (one nested
//! BSDF for both sides), classic `normalmap` and `bumpmap` wrappers, and the same wrappers
//! around a `plastic` or `roughplastic` leaf (a bare plastic leaf goes to [`super::plastic`]),
//! around a `diffuse` leaf (constant or textured reflectance, gathered per lane by the driver; a
//! bare `diffuse` goes to [`super::diffuse`]) and around the dielectric leaves: what
//! [`PathState::scatter`](crate::integrator::path::PathState::scatter) does at such a vertex, for
//! 8 paths at a time.
//!
//! A material qualifies when its tree is at most [`MAX_WRAPS`] wrappers (`twosided` with
//! `front == back`, `normalmap`, `bumpmap`) around a `diffuse` leaf, or a `roughconductor`,
//! `conductor`, `plastic`, `roughplastic`, `dielectric`, `roughdielectric` or `thindielectric`
//! leaf. A leaf's parameters may be textured (`Leaf::takes`: colours, and the rough
//! conductor's and rough dielectric's roughness; at most [`MAX_SLOTS`]): the driver patches the
//! leaf's template per lane as `Materials::build_at` does and hands the values to the lane forms
//! as [`Params`] (`RoughDielectric::*_with` take them as `roughdielectric::Params`). A constant
//! leaf's [`Params`] are built once per run of the material, from the template; a chain without
//! textured leaf parameters, `mask` or `bumpmap` runs the driver's lighter instance
//! (`Material::full`). A `blendbsdf` of two such chains (their wrappers `twosided` only)
//! goes to [`super::blend`], which runs both children's lane forms here and mixes them.
//! The wrappers' texture lookups (a normal map's colour, a bump map's height gradient and
//! `bsdf::bumpmap::perturbed_normal`) are done lane by lane; their perturbed frames (`normalmap`
//! and `bumpmap` are both Mitsuba's `PerturbedBSDF`), the side tests and the BSDF in lanes
//! (`bsdf::normalmap::lanes`, `RoughConductor::*_with`, `Conductor::*_with`, …).
//!
//! The per-vertex sequence (gather, random numbers, light points, scatter back) is
//! [`super::vertex`]'s, shared with nothing else yet; the light-sample part mirrors the `diffuse`
//! kernel's (BSDF value and density toward the light point, power heuristic, shadow ray), then
//! the BSDF sample gives the next ray. A `conductor` (a delta lobe) takes no light sample,
//! exactly as `PathState::scatter` asks `Lobes::is_smooth`. The plastic leaves draw `u1` (the
//! lobe) before `u2`, as `Bsdf::sample` does; `plastic`'s specular lobe is a delta lobe per lane
//! (the mask [`sample`] returns, passed to `PathState::advance`).
//!
//! Dielectric leaves (radiance transport, the path integrator's): `dielectric` and
//! `thindielectric` draw `u1` only and are delta lobes (no light sample); `roughdielectric`
//! draws `u1` then `u2` and takes light samples. A refracted direction leaves on the other side;
//! the side tests (`SurfaceBsdf`), the wrappers and the ray origin
//! (`SurfaceInteraction::spawn_ray`) are the same operations for either side, and [`sample`]
//! returns each lane's η for `PathState::advance` (Russian roulette uses the product of the
//! crossings' η²).

use crate::bsdf::lanes::LaneBsdfSample;
use crate::bsdf::microfacet::MicrofacetDistribution;
use crate::bsdf::normalmap::lanes as nmap;
use crate::bsdf::plastic::splat3;
use crate::bsdf::roughdielectric;
use crate::bsdf::{
    BsdfNode, Conductor, Dielectric, Diffuse, Plastic, RoughConductor, RoughDielectric,
    RoughPlastic, ThinDielectric, TransportMode,
};
use crate::lane::frame::Frame;
use crate::lane::fresnel::ConductorIndex;
use crate::lane::microfacet::Microfacet;
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::material::{MatId, MaterialNode, Materials, Slot, TexId};
use glam::Vec3;

/// Most wrappers a kernel material may have around its leaf (e.g. `twosided` over `normalmap`).
pub(crate) const MAX_WRAPS: usize = 2;

/// Most textured parameters a kernel leaf may have (`MaterialNode::Leaf`'s slots: a rough
/// conductor's `specular_reflectance`, `alpha_u` and `alpha_v`).
pub(crate) const MAX_SLOTS: usize = 3;

/// The leaf's parameters that textures may set, per lane: gathered by the driver where the
/// leaf is textured (or a `diffuse`), else [`Material::params`]'s constants in every lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Params<L: Lane> {
    /// `diffuse`: `reflectance`; plastics: `diffuse_reflectance`; conductors and dielectrics:
    /// `specular_reflectance`.
    pub c0: V3<L>,
    /// Plastics: `specular_reflectance`; dielectrics: `specular_transmittance`.
    pub c1: V3<L>,
    /// The rough conductor's roughness, as its distribution holds it (clamped by
    /// `MicrofacetDistribution::anisotropic`).
    pub alpha_u: L,
    pub alpha_v: L,
    /// The `mask` wrapper's opacity (clamped to [0, 1], NaN read as 0; 1 without a mask).
    pub opacity: L,
    /// The lanes whose `mask` chose the pass-through (`bsdf::null::pass_through`; none
    /// without a mask).
    pub through: L::Mask,
    /// The rough conductor's Fresnel terms of its (constant) index, computed once per run of
    /// the material ([`Leaf::fresnel`]); `None`: computed at each evaluation.
    pub fresnel: Option<ConductorIndex>,
}

/// The leaf BSDF, with its constant parameters (the template that a textured leaf's slots
/// patch per lane).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Leaf {
    Rough(RoughConductor),
    Smooth(Conductor),
    /// `plastic`: a diffuse lobe and a delta (specular) lobe, chosen per lane by `u1`.
    Plastic(Plastic),
    /// `roughplastic`: a diffuse and a glossy lobe, chosen per lane by `u1`.
    RoughPlastic(RoughPlastic),
    /// `diffuse` with its reflectance texture (constant or not: the driver evaluates it per
    /// lane, as `Materials::build_at` does, and passes it as `rho`).
    Diffuse(TexId),
    /// `dielectric`: delta reflection and refraction, chosen per lane by `u1`.
    Dielectric(Dielectric),
    /// `roughdielectric`: glossy reflection and refraction (the lobe chosen per lane by `u1`).
    RoughDielectric(RoughDielectric),
    /// `thindielectric`: delta reflection and straight transmission, chosen per lane by `u1`.
    ThinDielectric(ThinDielectric),
}

impl Leaf {
    /// The kernel leaf of a leaf BSDF node (`None`: no lane form in the driver).
    pub(crate) fn of(node: &BsdfNode) -> Option<Leaf> {
        Some(match *node {
            BsdfNode::RoughConductor(b) => Leaf::Rough(b),
            BsdfNode::Conductor(b) => Leaf::Smooth(b),
            BsdfNode::Plastic(b) => Leaf::Plastic(b),
            BsdfNode::RoughPlastic(b) => Leaf::RoughPlastic(b),
            BsdfNode::Dielectric(b) => Leaf::Dielectric(b),
            BsdfNode::RoughDielectric(b) => Leaf::RoughDielectric(b),
            BsdfNode::ThinDielectric(b) => Leaf::ThinDielectric(b),
            _ => return None,
        })
    }

    /// The BSDF node of the leaf (a `diffuse` leaf's with reflectance `rho`).
    pub(crate) fn node(&self, rho: Vec3) -> BsdfNode {
        match *self {
            Leaf::Diffuse(_) => BsdfNode::Diffuse(Diffuse { reflectance: rho }),
            Leaf::Dielectric(b) => BsdfNode::Dielectric(b),
            Leaf::RoughDielectric(b) => BsdfNode::RoughDielectric(b),
            Leaf::ThinDielectric(b) => BsdfNode::ThinDielectric(b),
            Leaf::Rough(b) => BsdfNode::RoughConductor(b),
            Leaf::Smooth(b) => BsdfNode::Conductor(b),
            Leaf::Plastic(b) => BsdfNode::Plastic(b),
            Leaf::RoughPlastic(b) => BsdfNode::RoughPlastic(b),
        }
    }

    /// The values of [`Params`] (`c0`, `c1`, `alpha_u`, `alpha_v`) this leaf holds (0 where
    /// unused; a `diffuse` leaf's reflectance is its texture's, gathered apart).
    pub(crate) fn values(&self) -> (Vec3, Vec3, f32, f32) {
        let z = Vec3::ZERO;
        match self {
            Leaf::Rough(b) => {
                let d = &b.distribution;
                (b.specular_reflectance, z, d.alpha_u, d.alpha_v)
            }
            Leaf::Smooth(b) => (b.specular_reflectance, z, 0.0, 0.0),
            Leaf::Plastic(b) => (b.diffuse_reflectance, b.specular_reflectance, 0.0, 0.0),
            Leaf::RoughPlastic(b) => (b.diffuse_reflectance, b.specular_reflectance, 0.0, 0.0),
            Leaf::Dielectric(b) => (b.specular_reflectance, b.specular_transmittance, 0.0, 0.0),
            Leaf::ThinDielectric(b) => (b.specular_reflectance, b.specular_transmittance, 0.0, 0.0),
            Leaf::RoughDielectric(b) => {
                let d = &b.distribution;
                let (r, t) = (b.specular_reflectance, b.specular_transmittance);
                (r, t, d.alpha_u, d.alpha_v)
            }
            Leaf::Diffuse(_) => (z, z, 0.0, 0.0),
        }
    }

    /// The rough conductor's angle-free Fresnel terms ([`RoughConductor::index`]; its index
    /// is the template's in every lane: the lane form takes no textured η or k).
    pub(crate) fn fresnel(&self) -> Option<ConductorIndex> {
        match self {
            Leaf::Rough(b) => Some(b.index()),
            _ => None,
        }
    }

    /// The lane form takes these textured slots per lane ([`Params`]).
    fn takes(&self, slot: Slot) -> bool {
        match self {
            Leaf::Rough(_) => matches!(
                slot,
                Slot::SpecularReflectance | Slot::Alpha | Slot::AlphaU | Slot::AlphaV
            ),
            Leaf::RoughDielectric(_) => matches!(
                slot,
                Slot::SpecularReflectance
                    | Slot::SpecularTransmittance
                    | Slot::Alpha
                    | Slot::AlphaU
                    | Slot::AlphaV
            ),
            Leaf::Smooth(_) => slot == Slot::SpecularReflectance,
            Leaf::Plastic(_) | Leaf::RoughPlastic(_) => {
                matches!(slot, Slot::SpecularReflectance | Slot::DiffuseReflectance)
            }
            Leaf::Dielectric(_) | Leaf::ThinDielectric(_) => {
                matches!(
                    slot,
                    Slot::SpecularReflectance | Slot::SpecularTransmittance
                )
            }
            Leaf::Diffuse(_) => false,
        }
    }
}

/// A wrapper around the leaf (outermost first in [`Material::wraps`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Wrap {
    /// `twosided` with one BSDF for both sides.
    TwoSided,
    /// Classic `normalmap` or `bumpmap` (both Mitsuba's `PerturbedBSDF`: `bsdf::bumpmap`), where
    /// its normal comes from and its flags.
    NormalMap {
        normal: Normal,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    },
    /// `mask` with its opacity texture (at most one per material: it draws the choice).
    Mask { opacity: TexId },
}

/// Where a perturbed-frame wrapper's normal comes from (looked up per lane by the driver, as
/// `Materials::build_at` does).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Normal {
    /// `normalmap`: n = 2·rgb − 1 of this texture.
    Map(TexId),
    /// `bumpmap`: `bumpmap::perturbed_normal` of `scale` times this height texture's gradient.
    Bump { height: TexId, scale: f32 },
}

/// A material the conductor kernel shades: its wrappers, outermost first, and its leaf.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Material {
    pub wraps: [Wrap; MAX_WRAPS],
    pub n_wraps: usize,
    pub leaf: Leaf,
    /// The leaf's textured parameters (`MaterialNode::Leaf`'s slots), looked up per lane.
    pub slots: [(Slot, TexId); MAX_SLOTS],
    pub n_slots: usize,
    /// It takes light samples (`Lobes::is_smooth`: the rough leaf).
    pub smooth: bool,
}

impl Material {
    /// The kernel material of material `m`, if its tree qualifies (see the module doc).
    pub(crate) fn of(materials: &Materials, m: MatId) -> Option<Material> {
        let mut wraps = [Wrap::TwoSided; MAX_WRAPS];
        let mut n_wraps = 0;
        let mut id = m;
        let mut slots = [(Slot::Reflectance, 0); MAX_SLOTS];
        let mut n_slots = 0;
        let leaf = loop {
            let wrap = match &materials.nodes()[id as usize] {
                MaterialNode::Leaf { template, slots: s } => {
                    let leaf = Leaf::of(template)?;
                    if s.len() > MAX_SLOTS || !s.iter().all(|&(slot, _)| leaf.takes(slot)) {
                        return None;
                    }
                    slots[..s.len()].copy_from_slice(s);
                    n_slots = s.len();
                    break leaf;
                }
                MaterialNode::Diffuse { reflectance } => break Leaf::Diffuse(*reflectance),
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
                        normal: Normal::Map(*normalmap),
                        flip_invalid_normals: *flip_invalid_normals,
                        use_shadowing_function: *use_shadowing_function,
                    }
                }
                MaterialNode::Mask { opacity, nested }
                    if !wraps[..n_wraps]
                        .iter()
                        .any(|w| matches!(w, Wrap::Mask { .. })) =>
                {
                    id = *nested;
                    Wrap::Mask { opacity: *opacity }
                }
                MaterialNode::BumpMap {
                    nested,
                    height,
                    scale,
                    flip_invalid_normals,
                    use_shadowing_function,
                } => {
                    id = *nested;
                    Wrap::NormalMap {
                        normal: Normal::Bump {
                            height: *height,
                            scale: *scale,
                        },
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
            slots,
            n_slots,
            smooth: materials.lobes(m).is_smooth(),
        })
    }

    /// The wrappers, outermost first.
    #[inline(always)]
    pub(crate) fn wraps(&self) -> &[Wrap] {
        &self.wraps[..self.n_wraps]
    }

    /// The leaf's textured parameters.
    #[inline(always)]
    pub(crate) fn slots(&self) -> &[(Slot, TexId)] {
        &self.slots[..self.n_slots]
    }

    /// The chain needs the driver's full instance (`vertex::x8::shade`'s `FULL`): textured leaf
    /// parameters, a `mask` or a `bumpmap`, whose lookups take the whole interaction.
    #[inline(always)]
    pub(crate) fn full(&self) -> bool {
        self.n_slots > 0
            || self.wraps().iter().any(|w| {
                matches!(
                    w,
                    Wrap::Mask { .. }
                        | Wrap::NormalMap {
                            normal: Normal::Bump { .. },
                            ..
                        }
                )
            })
    }

    /// The `mask` wrapper's opacity texture, if it has one.
    #[inline(always)]
    pub(crate) fn mask(&self) -> Option<TexId> {
        self.wraps().iter().find_map(|w| match *w {
            Wrap::Mask { opacity } => Some(opacity),
            _ => None,
        })
    }

    /// The leaf's [`Params`] differ per lane: the driver gathers them (a `diffuse` leaf, or
    /// textured parameters).
    #[inline(always)]
    pub(crate) fn per_lane(&self) -> bool {
        self.n_slots > 0 || matches!(self.leaf, Leaf::Diffuse(_))
    }

    /// The leaf's constant [`Params`] in every lane (width of `like`).
    #[inline(always)]
    pub(crate) fn params<L: Lane>(&self, like: L) -> Params<L> {
        let (c0, c1, au, av) = self.leaf.values();
        Params {
            c0: splat3(like, c0),
            c1: splat3(like, c1),
            alpha_u: like.splat(au),
            alpha_v: like.splat(av),
            opacity: like.splat(1.0),
            through: like.splat(0.0).ne(like.splat(0.0)),
            fresnel: self.leaf.fresnel(),
        }
    }

    /// The leaf's `sample` draws the lobe choice `u1` (`Bsdf::sample`: the coated models and
    /// the dielectrics).
    #[inline(always)]
    pub(crate) fn draws_u1(&self) -> bool {
        matches!(
            self.leaf,
            Leaf::Plastic(_)
                | Leaf::RoughPlastic(_)
                | Leaf::Dielectric(_)
                | Leaf::RoughDielectric(_)
                | Leaf::ThinDielectric(_)
        )
    }

    /// The `diffuse` leaf's reflectance texture, evaluated per lane by the driver.
    #[inline(always)]
    pub(crate) fn reflectance(&self) -> Option<TexId> {
        match self.leaf {
            Leaf::Diffuse(t) => Some(t),
            _ => None,
        }
    }

    /// The leaf's `sample` draws `u2` (all but the smooth `conductor`, `dielectric` and
    /// `thindielectric`, which draw `u1` only).
    #[inline(always)]
    pub(crate) fn draws_u2(&self) -> bool {
        !matches!(
            self.leaf,
            Leaf::Smooth(_) | Leaf::Dielectric(_) | Leaf::ThinDielectric(_)
        )
    }
}

/// A rough leaf's distribution `d` with the roughness of `p` per lane.
#[inline(always)]
fn microfacet<L: Lane>(d: &MicrofacetDistribution, p: &Params<L>) -> Microfacet<L> {
    Microfacet {
        kind: d.kind,
        alpha_u: p.alpha_u,
        alpha_v: p.alpha_v,
        sample_visible: d.sample_visible,
    }
}

/// The rough dielectric's parameters per lane (`p`: reflectance, transmittance, roughness).
#[inline(always)]
fn rough_dielectric<L: Lane>(b: &RoughDielectric, p: &Params<L>) -> roughdielectric::Params<L> {
    roughdielectric::Params {
        specular_reflectance: p.c0,
        specular_transmittance: p.c1,
        distribution: microfacet(&b.distribution, p),
    }
}

/// `twosided`'s mirror through the surface.
#[inline(always)]
fn flip<L: Lane>(w: V3<L>) -> V3<L> {
    V3::new(w.x, w.y, -w.z)
}

/// `Bsdf::sample`'s guard, applied at every node: a finite direction and weight, a density ≥ 0.
#[inline(always)]
pub(crate) fn valid<L: Lane>(s: &LaneBsdfSample<L>) -> L::Mask {
    let zero = s.pdf.splat(0.0);
    s.wo.x.is_finite()
        & s.wo.y.is_finite()
        & s.wo.z.is_finite()
        & s.pdf.ge(zero)
        & s.weight.x.is_finite()
        & s.weight.y.is_finite()
        & s.weight.z.is_finite()
}

/// The incident direction's way down the wrappers, outermost first: where `twosided`
/// mirrored it, each normal map's perturbed frame (`bsdf::normalmap::lanes::frame` of its
/// normal and the incident direction it sees), the incident direction each `mask` sees, and
/// the leaf's local `wi`. It depends on `wi` alone, so [`eval_pdf_from`] (toward the light) and
/// [`sample_from`] share it: the same operations as each did on its own, done once.
///
/// Each wrapper's entry is an `Option`, set only at the wrappers of its kind: a `None` is one
/// byte to write, where a placeholder frame was nine vectors stored per chunk (and the masks'
/// and `mask`s' entries three more), for slots that no wrapper reads.
#[derive(Clone, Copy)]
pub(crate) struct Down<L: Lane> {
    back: [Option<L::Mask>; MAX_WRAPS],
    frames: [Option<Frame<L>>; MAX_WRAPS],
    at: [Option<V3<L>>; MAX_WRAPS],
    wi: V3<L>,
}

impl<L: Lane> Down<L> {
    /// Where `twosided` wrapper `j` mirrored the incident direction.
    #[inline(always)]
    fn back(&self, j: usize) -> L::Mask {
        self.back[j].expect("set by `down` at a twosided wrapper")
    }

    /// The perturbed frame of normal-map wrapper `j`.
    #[inline(always)]
    fn frame(&self, j: usize) -> &Frame<L> {
        self.frames[j]
            .as_ref()
            .expect("set by `down` at a normal-map wrapper")
    }

    /// The incident direction `mask` wrapper `j` sees.
    #[inline(always)]
    fn at(&self, j: usize) -> V3<L> {
        self.at[j].expect("set by `down` at a mask wrapper")
    }
}

/// [`Down`] of local `wi` (the shading frame's) through `mat`'s wrappers (`normals[j]` the
/// decoded normal of wrapper `j` where it is a normal map). `MASK` as in [`eval_pdf`].
#[inline(always)]
pub(crate) fn down<L: Lane, const MASK: bool>(
    mat: &Material,
    normals: &[V3<L>; MAX_WRAPS],
    wi: V3<L>,
) -> Down<L> {
    let k = |c: f32| wi.z.splat(c);
    let mut d = Down {
        back: [None; MAX_WRAPS],
        frames: [None; MAX_WRAPS],
        at: [None; MAX_WRAPS],
        wi,
    };
    for (j, w) in mat.wraps().iter().enumerate() {
        match *w {
            Wrap::TwoSided => {
                let back = !d.wi.z.ge(k(0.0));
                d.back[j] = Some(back);
                d.wi = V3::select(back, flip(d.wi), d.wi);
            }
            Wrap::NormalMap {
                flip_invalid_normals,
                ..
            } => {
                let f = nmap::frame(normals[j], flip_invalid_normals, d.wi);
                d.wi = f.to_local(d.wi);
                d.frames[j] = Some(f);
            }
            Wrap::Mask { .. } if MASK => d.at[j] = Some(d.wi),
            Wrap::Mask { .. } => {}
        }
    }
    d
}

/// `f · |cos θo|` and the density of the material's BSDF for local `wi`, `wo` (the shading
/// frame's), `normals[j]` the decoded normal of wrapper `j` where it is a normal map, `p` the
/// leaf's parameters per lane: the
/// wrappers' `eval_pdf` (`bsdf::twosided`, `bsdf::normalmap`) down to the leaf's lane form and
/// the shadowing terms back up, innermost first. 0 where a normal map rejects `wo`.
///
/// `MASK` false says that `mat` has no `mask` wrapper (`Material::mask`): the driver picks the
/// instance once per run of a material, so that a chain without a mask carries no opacity.
#[inline(always)]
pub(crate) fn eval_pdf<L: Lane, const MASK: bool>(
    mat: &Material,
    normals: &[V3<L>; MAX_WRAPS],
    p: &Params<L>,
    wi: V3<L>,
    wo: V3<L>,
) -> (V3<L>, L) {
    eval_pdf_from::<L, MASK>(mat, p, &down::<L, MASK>(mat, normals, wi), wo)
}

/// [`eval_pdf`] from the incident direction's [`Down`] (`wo`: local, the shading frame's).
#[inline(always)]
pub(crate) fn eval_pdf_from<L: Lane, const MASK: bool>(
    mat: &Material,
    p: &Params<L>,
    dn: &Down<L>,
    wo: V3<L>,
) -> (V3<L>, L) {
    debug_assert!(MASK || mat.mask().is_none());
    let k = |c: f32| wo.z.splat(c);
    let mut wo = wo;
    let mut reject = k(0.0).ne(k(0.0));
    let mut shadow = [None; MAX_WRAPS];
    for (j, w) in mat.wraps().iter().enumerate() {
        match *w {
            Wrap::TwoSided => wo = V3::select(dn.back(j), flip(wo), wo),
            Wrap::NormalMap {
                use_shadowing_function,
                ..
            } => {
                let f = dn.frame(j);
                let pwo = f.to_local(wo);
                reject = reject | (wo.z * pwo.z).le(k(0.0));
                if use_shadowing_function {
                    shadow[j] = Some(nmap::shadow_terminator(f.n, wo));
                }
                wo = pwo;
            }
            Wrap::Mask { .. } => {}
        }
    }
    let wi = dn.wi;
    let (mut f, mut pdf) = match &mat.leaf {
        Leaf::Rough(b) => b.eval_pdf_with(
            p.c0,
            &microfacet(&b.distribution, p),
            p.fresnel.as_ref(),
            wi,
            wo,
        ),
        Leaf::Smooth(b) => b.eval_pdf_lanes(wi, wo),
        Leaf::Plastic(b) => b.eval_pdf_with(p.c0, wi, wo),
        Leaf::RoughPlastic(b) => b.eval_pdf_with(p.c0, p.c1, wi, wo),
        Leaf::Diffuse(_) => Diffuse::eval_pdf_with(p.c0, wi, wo),
        // The path integrator's context: radiance transport.
        Leaf::RoughDielectric(b) => {
            b.eval_pdf_with(&rough_dielectric(b, p), TransportMode::Radiance, wi, wo)
        }
        Leaf::Dielectric(b) => b.eval_pdf_lanes(wi, wo),
        Leaf::ThinDielectric(b) => b.eval_pdf_lanes(wi, wo),
    };
    let zero = V3::splat(k(0.0), 0.0, 0.0, 0.0);
    // Back up, innermost first: the shadowing terms, the mask's opacity (`bsdf::mask`: 0 and 0
    // where the opacity is ≤ 0, else both scaled by it).
    for (j, w) in mat.wraps().iter().enumerate().rev() {
        match *w {
            Wrap::NormalMap { .. } => {
                if let Some(s) = shadow[j] {
                    f = f.scale(s);
                }
            }
            Wrap::Mask { .. } if MASK => {
                let gone = p.opacity.le(k(0.0));
                f = V3::select(gone, zero, f.scale(p.opacity));
                pdf = L::select(gone, k(0.0), p.opacity * pdf);
            }
            Wrap::TwoSided | Wrap::Mask { .. } => {}
        }
    }
    f = V3::select(reject, zero, f);
    pdf = L::select(reject, k(0.0), pdf);
    (f, pdf)
}

/// The material's BSDF sample from local `wi` (see [`eval_pdf`] for `normals` and `p`): the wrappers'
/// `sample` down to the leaf's lane form and back up, with `Bsdf::sample`'s guard at every
/// node. `u1` is drawn by the plastic and dielectric leaves, `u2` by all but the smooth
/// conductor and the smooth and thin dielectrics. Also returns the lanes whose sample went
/// through a delta lobe (all for `conductor`, `dielectric` and `thindielectric`, those that
/// chose the specular lobe for `plastic`, none otherwise) and the relative index η of each
/// lane's crossing (`BsdfSample::eta`: 1 but where a dielectric refracted).
/// `MASK` as in [`eval_pdf`].
#[inline(always)]
pub(crate) fn sample<L: Lane, const MASK: bool>(
    mat: &Material,
    normals: &[V3<L>; MAX_WRAPS],
    p: &Params<L>,
    wi: V3<L>,
    u1: L,
    u2: V2<L>,
) -> (LaneBsdfSample<L>, L::Mask, L) {
    sample_from::<L, MASK>(mat, p, &down::<L, MASK>(mat, normals, wi), u1, u2)
}

/// [`sample`] from the incident direction's [`Down`].
#[inline(always)]
pub(crate) fn sample_from<L: Lane, const MASK: bool>(
    mat: &Material,
    p: &Params<L>,
    dn: &Down<L>,
    u1: L,
    u2: V2<L>,
) -> (LaneBsdfSample<L>, L::Mask, L) {
    debug_assert!(MASK || mat.mask().is_none());
    let wi = dn.wi;
    let k = |c: f32| wi.z.splat(c);
    let none = k(0.0).ne(k(0.0));
    let all = k(0.0).eq(k(0.0));
    let one = k(1.0);
    let (mut s, mut delta, mut eta) = match &mat.leaf {
        Leaf::Rough(b) => (
            b.sample_with(
                p.c0,
                &microfacet(&b.distribution, p),
                p.fresnel.as_ref(),
                wi,
                u2,
            ),
            none,
            one,
        ),
        Leaf::Smooth(b) => (b.sample_with(p.c0, wi), all, one),
        Leaf::Plastic(b) => {
            let (s, delta) = b.sample_with(p.c0, p.c1, wi, u1, u2);
            (s, delta, one)
        }
        Leaf::RoughPlastic(b) => (b.sample_with(p.c0, p.c1, wi, u1, u2).0, none, one),
        Leaf::Diffuse(_) => (Diffuse::sample_with(p.c0, wi, u2), none, one),
        Leaf::Dielectric(b) => {
            let (s, eta, _) = b.sample_with(TransportMode::Radiance, p.c0, p.c1, wi, u1);
            (s, all, eta)
        }
        Leaf::RoughDielectric(b) => {
            let q = rough_dielectric(b, p);
            let (s, eta, _) = b.sample_with(&q, TransportMode::Radiance, wi, u1, u2);
            (s, none, eta)
        }
        Leaf::ThinDielectric(b) => (b.sample_with(p.c0, p.c1, wi, u1).0, all, one),
    };
    s.ok = s.ok & valid(&s);
    for (j, w) in mat.wraps().iter().enumerate().rev() {
        match *w {
            Wrap::TwoSided => s.wo = V3::select(dn.back(j), flip(s.wo), s.wo),
            Wrap::NormalMap {
                use_shadowing_function,
                ..
            } => {
                let f = dn.frame(j);
                let wo = f.to_world(s.wo);
                s.ok = s.ok & !(s.wo.z * wo.z).le(k(0.0));
                s.wo = wo;
                if use_shadowing_function {
                    s.weight = s.weight.scale(nmap::shadow_terminator(f.n, wo));
                }
            }
            Wrap::Mask { .. } if MASK => {
                // bsdf::mask::sample: the nested sample with its density times the opacity, or
                // the pass-through (`null::pass_through`: −wi, weight 1, a delta lobe, η 1).
                let t = p.through;
                s.ok = s.ok | t;
                s.wo = V3::select(t, -dn.at(j), s.wo);
                s.pdf = L::select(t, k(0.0), s.pdf * p.opacity);
                s.weight = V3::select(t, V3::splat(k(0.0), 1.0, 1.0, 1.0), s.weight);
                delta = delta | t;
                eta = L::select(t, one, eta);
            }
            Wrap::Mask { .. } => {}
        }
        s.ok = s.ok & valid(&s);
    }
    (s, delta, eta)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::*;
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::bsdf::{BsdfArena, BsdfContext, Lobes, Mask, NormalMap};
    use crate::math::Pcg32;
    use crate::sampler::Sampler;
    use crate::spectrum::Spectrum;
    use glam::{Vec2, Vec3};

    /// [`eval_pdf`] in the instance the driver picks for `mat`.
    #[inline(always)]
    fn eval_pdf_of<L: Lane>(
        mat: &Material,
        n: &[V3<L>; MAX_WRAPS],
        p: &Params<L>,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        if mat.mask().is_some() {
            eval_pdf::<L, true>(mat, n, p, wi, wo)
        } else {
            eval_pdf::<L, false>(mat, n, p, wi, wo)
        }
    }

    /// [`sample`] in the instance the driver picks for `mat`.
    #[inline(always)]
    fn sample_of<L: Lane>(
        mat: &Material,
        n: &[V3<L>; MAX_WRAPS],
        p: &Params<L>,
        wi: V3<L>,
        u1: L,
        u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L::Mask, L) {
        if mat.mask().is_some() {
            sample::<L, true>(mat, n, p, wi, u1, u2)
        } else {
            sample::<L, false>(mat, n, p, wi, u1, u2)
        }
    }

    /// The wrapper lists tested (outermost first): none, each alone (every flag combination of
    /// the normal map), and both orders of the two.
    fn wrapper_lists() -> Vec<Vec<Wrap>> {
        let nm = |f, s| Wrap::NormalMap {
            normal: Normal::Map(0),
            flip_invalid_normals: f,
            use_shadowing_function: s,
        };
        vec![
            vec![],
            vec![Wrap::TwoSided],
            vec![nm(false, false)],
            vec![nm(true, false)],
            vec![nm(false, true)],
            vec![nm(true, true)],
            vec![Wrap::TwoSided, nm(true, true)],
            vec![nm(true, true), Wrap::TwoSided],
            vec![nm(false, false), Wrap::TwoSided],
            vec![Wrap::Mask { opacity: 0 }],
            vec![Wrap::Mask { opacity: 0 }, Wrap::TwoSided],
            vec![nm(true, true), Wrap::Mask { opacity: 0 }],
        ]
    }

    pub(in crate::stream::kernels) fn leaves() -> [Leaf; 12] {
        let metal = |d| RoughConductor {
            distribution: d,
            eta: Spectrum::new(0.2, 0.92, 1.1),
            k: Spectrum::new(3.9, 2.45, 2.14),
            specular_reflectance: Spectrum::new(0.9, 0.8, 1.0),
        };
        [
            Leaf::Rough(metal(MicrofacetDistribution::new(
                MicrofacetType::Ggx,
                0.2,
                true,
            ))),
            Leaf::Rough(metal(MicrofacetDistribution::anisotropic(
                MicrofacetType::Beckmann,
                0.1,
                0.35,
                false,
            ))),
            Leaf::Smooth(Conductor::default()),
            Leaf::Plastic(Plastic::new(
                Spectrum::new(0.2, 0.5, 0.7),
                Spectrum::new(0.9, 1.0, 0.8),
                1.49,
                1.000277,
                false,
            )),
            Leaf::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Ggx,
                0.15,
                true,
                Spectrum::new(0.6, 0.3, 0.1),
                Spectrum::ONE,
                1.5,
                1.0,
                true,
            )),
            Leaf::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Beckmann,
                0.3,
                false,
                Spectrum::new(0.1, 0.4, 0.8),
                Spectrum::new(0.7, 0.7, 0.9),
                1.49,
                1.000277,
                false,
            )),
            Leaf::Diffuse(0),
            Leaf::Dielectric(Dielectric::default()),
            Leaf::Dielectric(Dielectric::new(
                1.0,
                1.33,
                Spectrum::ONE,
                Spectrum::splat(0.9),
            )),
            Leaf::RoughDielectric(RoughDielectric::new(
                MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
                1.5,
                1.0,
                Spectrum::new(0.9, 0.8, 1.0),
                Spectrum::ONE,
            )),
            Leaf::RoughDielectric(RoughDielectric::new(
                MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.3, false),
                1.0,
                1.33,
                Spectrum::ONE,
                Spectrum::new(0.7, 0.9, 0.8),
            )),
            Leaf::ThinDielectric(ThinDielectric::default()),
        ]
    }

    /// A `diffuse` leaf's reflectance for a test case: varies with the case (per lane at width
    /// 8), as a texture's would.
    pub(in crate::stream::kernels) fn rho_of(wi: Vec3, wo: Vec3) -> Vec3 {
        Vec3::new(0.9 * wi.x.abs(), 0.5, 0.25 + 0.5 * wo.y.abs())
    }

    /// `leaf` with the parameters a texture may set (`Leaf::takes`) varying with the case, as
    /// textured ones do per lane (roughness through `MicrofacetDistribution::anisotropic`, as
    /// `material::patch_scalar` sets it).
    fn textured(leaf: Leaf, wi: Vec3, wo: Vec3) -> Leaf {
        let (c0, c1) = (rho_of(wi, wo), Vec3::new(0.3 + 0.6 * wo.x.abs(), 0.8, 0.5));
        let (a, a2) = (
            0.02 + 0.6 * wi.y.abs(),
            0.02 + 0.3 * wi.y.abs() + 0.1 * wo.z.abs(),
        );
        // The roughness (au, av) as a texture sets it.
        let rough = |d: MicrofacetDistribution, au, av| {
            MicrofacetDistribution::anisotropic(d.kind, au, av, d.sample_visible)
        };
        match leaf {
            Leaf::Rough(mut b) => {
                b.specular_reflectance = c0;
                b.distribution = rough(b.distribution, a, a2);
                Leaf::Rough(b)
            }
            Leaf::Smooth(mut b) => {
                b.specular_reflectance = c0;
                Leaf::Smooth(b)
            }
            Leaf::Plastic(mut b) => {
                (b.diffuse_reflectance, b.specular_reflectance) = (c0, c1);
                Leaf::Plastic(b)
            }
            Leaf::RoughPlastic(mut b) => {
                (b.diffuse_reflectance, b.specular_reflectance) = (c0, c1);
                Leaf::RoughPlastic(b)
            }
            Leaf::Dielectric(mut b) => {
                (b.specular_reflectance, b.specular_transmittance) = (c0, c1);
                Leaf::Dielectric(b)
            }
            Leaf::ThinDielectric(mut b) => {
                (b.specular_reflectance, b.specular_transmittance) = (c0, c1);
                Leaf::ThinDielectric(b)
            }
            Leaf::RoughDielectric(mut b) => {
                (b.specular_reflectance, b.specular_transmittance) = (c0, c1);
                b.distribution = rough(b.distribution, a2, a);
                Leaf::RoughDielectric(b)
            }
            Leaf::Diffuse(_) => leaf,
        }
    }

    /// The kernel's per-lane parameters of a case's (textured) leaf, as the driver gathers them
    /// (a `diffuse` leaf's reflectance `rho`).
    pub(in crate::stream::kernels) fn case_values(
        leaf: &Leaf,
        rho: Vec3,
    ) -> (Vec3, Vec3, f32, f32) {
        match leaf {
            Leaf::Diffuse(_) => (rho, Vec3::ZERO, 0.0, 0.0),
            _ => leaf.values(),
        }
    }

    /// A mask's opacity for a test case: 0, 1 or between, as `Materials::build_at` clamps it.
    fn opacity_of(wi: Vec3, wo: Vec3) -> f32 {
        let q = (wo.x + wi.y).abs();
        if q < 0.15 {
            0.0
        } else if q > 0.85 {
            1.0
        } else {
            q
        }
    }

    pub(in crate::stream::kernels) fn params1(
        v: (Vec3, Vec3, f32, f32),
        opacity: f32,
        through: bool,
    ) -> Params<f32> {
        Params {
            c0: v.0.into(),
            c1: v.1.into(),
            alpha_u: v.2,
            alpha_v: v.3,
            opacity,
            through,
            fresnel: None,
        }
    }

    pub(in crate::stream::kernels) fn material(wraps: &[Wrap], leaf: Leaf) -> Material {
        let mut w = [Wrap::TwoSided; MAX_WRAPS];
        w[..wraps.len()].copy_from_slice(wraps);
        Material {
            wraps: w,
            n_wraps: wraps.len(),
            leaf,
            slots: [(Slot::Reflectance, 0); MAX_SLOTS],
            n_slots: 0,
            smooth: !matches!(
                leaf,
                Leaf::Smooth(_) | Leaf::Dielectric(_) | Leaf::ThinDielectric(_)
            ),
        }
    }

    /// The scalar BSDF tree of `mat` with the leaf `leaf`, the decoded normals `normals` (and a
    /// `diffuse` leaf's reflectance `rho`); returns its root.
    fn tree(
        arena: &mut BsdfArena,
        mat: &Material,
        leaf: &Leaf,
        normals: &[Vec3; MAX_WRAPS],
        rho: Vec3,
        opacity: f32,
    ) -> u32 {
        arena.clear();
        let mut id = arena.push(leaf.node(rho));
        for (j, w) in mat.wraps().iter().enumerate().rev() {
            id = arena.push(match *w {
                Wrap::TwoSided => BsdfNode::TwoSided {
                    front: id,
                    back: id,
                },
                Wrap::NormalMap {
                    flip_invalid_normals,
                    use_shadowing_function,
                    ..
                } => BsdfNode::NormalMap(NormalMap::new(
                    id,
                    normals[j],
                    flip_invalid_normals,
                    use_shadowing_function,
                )),
                Wrap::Mask { .. } => BsdfNode::Mask(Mask {
                    nested: id,
                    opacity,
                }),
            });
        }
        id
    }

    /// Random (wi, wo, normals): normal-map normals 2·rgb − 1 with rgb in [0, 1] (blue ≥ 0.5,
    /// as normal maps store them, so that most are above the surface).
    fn inputs(r: &mut Pcg32, n: usize) -> Vec<(Vec3, Vec3, [Vec3; MAX_WRAPS])> {
        let normal = |r: &mut Pcg32| {
            Vec3::new(r.next_f32(), r.next_f32(), 0.5 + 0.5 * r.next_f32()) * 2.0 - Vec3::ONE
        };
        (0..n)
            .map(|_| {
                let wi = direction(r);
                let wo = direction(r);
                (wi, wo, [normal(r), normal(r)])
            })
            .collect()
    }

    /// At width 1 the kernel's BSDF gives the scalar tree's `eval_pdf` and `sample` bit for bit
    /// (the sample from the number the rough leaf draws), at width 8 width 1's, lane by lane.
    #[test]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // the mask's choice as `bsdf::mask` writes it
    fn kernel_bsdf_equals_the_scalar_tree() {
        let mut r = Pcg32::new(21, 2);
        let cases = inputs(&mut r, 1600);
        let mut arena = BsdfArena::new();
        let ctx = BsdfContext::default();
        let (mut nonzero, mut sampled) = (0, 0);
        for wraps in wrapper_lists() {
            for leaf in leaves() {
                let mat = material(&wraps, leaf);
                for (c, &(wi, wo, ns)) in cases.iter().enumerate() {
                    let rho = rho_of(wi, wo);
                    let lc = textured(leaf, wi, wo);
                    let masked = mat.mask().is_some();
                    let o = if masked { opacity_of(wi, wo) } else { 1.0 };
                    let root = tree(&mut arena, &mat, &lc, &ns, rho, o);
                    let bsdf = arena.bsdf(root);
                    let mut sampler = Sampler::from_seed(c as u64, 5);
                    let (f0, p0) = bsdf.eval_pdf(&ctx, wi, wo, &mut sampler);
                    // The numbers in `Bsdf::sample`'s order: a mask's choice (where 0 < o < 1),
                    // then the leaf's `u1` (plastics, dielectrics) and `u2`, as the driver draws.
                    let mut draws = sampler.clone();
                    let through = masked
                        && if o <= 0.0 {
                            true
                        } else if o >= 1.0 {
                            false
                        } else {
                            !(draws.next_1d() < o)
                        };
                    let p1 = params1(case_values(&lc, rho), o, through);
                    let n1 = ns.map(V3::from);
                    let (f1, q1) = eval_pdf_of(&mat, &n1, &p1, V3::from(wi), V3::from(wo));
                    assert!(
                        same3(f0, f1.into()) && same(p0, q1),
                        "{mat:?} {wi} {wo} {ns:?}"
                    );
                    nonzero += (f0 != Vec3::ZERO) as u32;
                    let u1 = if mat.draws_u1() { draws.next_1d() } else { 0.0 };
                    let u2 = draws.next_2d();
                    let s0 = bsdf.sample(&ctx, wi, &mut sampler);
                    let (s1, d1, e1) = sample_of(&mat, &n1, &p1, V3::from(wi), u1, V2::from(u2));
                    assert_eq!(s0.is_some(), s1.ok, "{mat:?} {wi} {ns:?}");
                    if let Some(s0) = s0 {
                        sampled += 1;
                        assert_eq!(s0.lobe.intersects(Lobes::DELTA), d1, "{mat:?} {wi}");
                        assert!(same(s0.eta, e1), "{mat:?} {wi}");
                        assert!(same3(s0.wo, s1.wo.into()) && same(s0.pdf, s1.pdf));
                        assert!(same3(s0.weight, s1.weight.into()), "{mat:?} {wi}");
                    }
                }
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = crate::lane::Avx2::detect() {
                    for c in cases.chunks_exact(8) {
                        let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
                        let wo: [Vec3; 8] = std::array::from_fn(|k| c[k].1);
                        let n: [[Vec3; 8]; MAX_WRAPS] =
                            std::array::from_fn(|j| std::array::from_fn(|k| c[k].2[j]));
                        let u: [Vec2; 8] =
                            std::array::from_fn(|k| Vec2::new(wo[k].x.abs(), wi[k].y.abs()));
                        let u1: [f32; 8] = std::array::from_fn(|k| wo[k].y.abs());
                        let v: [_; 8] = std::array::from_fn(|k| {
                            let lc = textured(leaf, wi[k], wo[k]);
                            case_values(&lc, rho_of(wi[k], wo[k]))
                        });
                        let (c0, c1) = (v.map(|v| v.0), v.map(|v| v.1));
                        let (au, av) = (v.map(|v| v.2), v.map(|v| v.3));
                        let op: [f32; 8] = std::array::from_fn(|k| opacity_of(wi[k], wo[k]));
                        let th: [bool; 8] =
                            std::array::from_fn(|k| op[k] <= 0.0 || wi[k].x > 0.3 && op[k] < 1.0);
                        let (f, p, (s, d, e)) = avx.run(|| {
                            let n8 = n.map(|v| load3(avx, &v));
                            let (wi8, wo8) = (load3(avx, &wi), load3(avx, &wo));
                            let p8 = Params {
                                c0: load3(avx, &c0),
                                c1: load3(avx, &c1),
                                alpha_u: avx.load(&au),
                                alpha_v: avx.load(&av),
                                opacity: avx.load(&op),
                                through: avx.mask(&th),
                                fresnel: mat.leaf.fresnel(),
                            };
                            let (f, p) = eval_pdf_of(&mat, &n8, &p8, wi8, wo8);
                            let u1 = avx.load(&u1);
                            (f, p, sample_of(&mat, &n8, &p8, wi8, u1, load2(avx, &u)))
                        });
                        let (ok, d) = (s.ok.to_array(), d.to_array());
                        for k in 0..8 {
                            let n1 = std::array::from_fn(|j| V3::from(n[j][k]));
                            let (wi1, wo1) = (V3::from(wi[k]), V3::from(wo[k]));
                            let r1 = params1(v[k], op[k], th[k]);
                            let (f1, p1) = eval_pdf_of(&mat, &n1, &r1, wi1, wo1);
                            assert!(same3(lane3(f, k), f1.into()) && same(p.lane(k), p1));
                            let (s1, d1, e1) =
                                sample_of(&mat, &n1, &r1, wi1, u1[k], V2::from(u[k]));
                            assert!(same(e.lane(k), e1));
                            assert_eq!((ok[k], d[k]), (s1.ok, d1));
                            assert!(same3(lane3(s.wo, k), s1.wo.into()));
                            assert!(same(s.pdf.lane(k), s1.pdf));
                            assert!(same3(lane3(s.weight, k), s1.weight.into()));
                        }
                    }
                }
            }
        }
        // Not vacuous: many pairs carry light and many samples succeed.
        assert!(nonzero > 5_000 && sampled > 20_000, "{nonzero} {sampled}");
    }
}
