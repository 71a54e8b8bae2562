//! Bidirectional scattering distribution functions.
//!
//! # Conventions (tested in `tests/bsdf_*.rs`)
//! - A BSDF works in its **local frame**: `z` is the shading normal, `wi` and `wo` are unit vectors
//!   pointing away from the surface. `wi` points toward the previous path vertex (the camera side
//!   when tracing radiance), `wo` toward the next one (the light side) — Mitsuba's naming.
//! - `eval(wi, wo)` returns `f(wi, wo) · |cos θo|` (cosine against local `z`).
//! - `pdf(wi, wo)` is the solid-angle density with which `sample` produces `wo`.
//! - `sample(wi)` returns `BsdfSample { wo, pdf, weight = f·|cos θo| / pdf, eta, lobe }`. For
//!   deterministic BSDFs `weight == eval / pdf` pointwise; stochastic BSDFs (random walks) only
//!   in expectation, which is why the integrator always uses a sample's own weight and never
//!   re-evaluates `eval / pdf` for a sampled direction.
//! - Delta lobes: `eval = pdf = 0` for any given pair; `sample` returns the weight without the
//!   cosine (`pdf` of a delta sample is reported as 0 and flagged by its lobe).
//!
//! # Models (one file each; plain constructors with Mitsuba 3's parameter names, `Default` = Mitsuba's defaults)
//! - [`Diffuse`] `{ reflectance }`.
//! - [`Conductor`] `{ eta, k, specular_reflectance }`; (η, k) from [`named_conductor`] (`material`).
//! - [`RoughConductor`] `{ distribution, eta, k, specular_reflectance }` with a
//!   [`MicrofacetDistribution`] `::anisotropic(kind, alpha_u, alpha_v, sample_visible)`.
//! - [`Dielectric::new`], [`ThinDielectric::new`] `(int_ior, ext_ior, specular_reflectance,
//!   specular_transmittance)`; [`RoughDielectric::new`] `(distribution, int_ior, ext_ior, ...)`;
//!   named indices from [`named_ior`].
//! - [`Plastic::new`] `(diffuse_reflectance, specular_reflectance, int_ior, ext_ior, nonlinear)`.
//! - [`RoughPlastic::new`] `(distribution, alpha, sample_visible, diffuse_reflectance,
//!   specular_reflectance, int_ior, ext_ior, nonlinear)` — isotropic only, like Mitsuba; it
//!   precomputes (and caches process-wide) its coating table, so build it at load time.
//! - [`Principled`] (`principled`) and [`PrincipledThin`] (`principledthin`): Burley's Disney
//!   BSDF as Mitsuba 3.9.1 has it; parameters stored beside the nodes (`BsdfArena::principled`),
//!   built by [`BsdfArena::push_principled`] / [`BsdfArena::push_principled_thin`].
//! - `Null` (`null`: straight pass-through, a delta lobe flagged [`Lobes::NULL`]).
//! - Wrappers (children by arena index): `TwoSided { front, back }`, [`NormalMap`] (classic
//!   normal mapping, Mitsuba 3.9.1 semantics; also the node of `bumpmap`, whose perturbed normal
//!   [`bumpmap`] derives from a height texture), [`Blend`] (`blendbsdf`), [`Mask`] (`mask`),
//!   [`mnm::MicrofacetNormalMap`].
//!
//! Each model's file also holds, apart from the evaluation code and below its table of XML
//! parameters, its XML constructor (`mod load`, called by [`crate::load`]'s `bsdfs`).
//!
//! Verified pointwise against Mitsuba 3.9.1 (`tests/bsdf_mitsuba/models.rs`, data in
//! `tests/data/mitsuba_bsdf_points.json`) and statistically (`tests/bsdf/harness.rs`).
//!
//! # Storage without allocation per hit
//! A material evaluates its textures at a hit and writes plain-valued [`BsdfNode`]s into a
//! per-thread [`BsdfArena`] that is cleared (not freed) at every hit; nested BSDFs (twosided,
//! normal maps, blends) refer to their children by index. [`Bsdf`] is a borrowed view of one
//! node of the arena.

pub mod blend;
pub mod bumpmap;
pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod disney;
pub mod fresnel;
pub mod hair;
pub mod ior;
pub(crate) mod lanes;
pub mod lobes;
pub mod mask;
pub mod microfacet;
pub mod mnm;
pub mod normalmap;
pub mod null;
pub mod plastic;
pub mod principled;
pub mod principledthin;
pub mod roughconductor;
pub mod roughdielectric;
pub mod roughplastic;
pub mod surface;
pub mod thindielectric;
pub mod twosided;

pub use blend::Blend;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use hair::Hair;
pub use ior::{named_conductor, named_ior};
pub use lobes::Lobes;
pub use mask::Mask;
pub use microfacet::{MicrofacetDistribution, MicrofacetType};
pub use normalmap::NormalMap;
pub use plastic::Plastic;
pub use principled::Principled;
pub use principledthin::PrincipledThin;
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use roughplastic::RoughPlastic;
pub use surface::{SurfaceBsdf, SurfaceSample};
pub use thindielectric::ThinDielectric;

use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;
use std::sync::atomic::{AtomicU64, Ordering};

/// Radiance: tracing from the camera (the integrator's case); importance: tracing from lights.
/// Refraction scales radiance by 1/η² but not importance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Per-query context.
#[derive(Clone, Copy, Debug)]
pub struct BsdfContext {
    pub mode: TransportMode,
}

impl Default for BsdfContext {
    fn default() -> Self {
        BsdfContext {
            mode: TransportMode::Radiance,
        }
    }
}

/// A sampled direction with its weight.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wo: Vec3,
    /// Solid-angle density of `wo` (0 for delta lobes).
    pub pdf: f32,
    /// `f · |cos θo| / pdf` (delta lobes: the lobe's value without cosine).
    pub weight: Spectrum,
    /// Relative index of refraction of the crossing (1 for reflection).
    pub eta: f32,
    /// The lobe that produced the sample (one of the single-lobe [`Lobes`] constants).
    pub lobe: Lobes,
}

/// One BSDF node with plain (already texture-evaluated) parameters.
// Nodes live in a reused per-thread arena; the large microfacet normal map lives beside them
// (`BsdfArena::mnm`) so that a node stays small (64 bytes) without allocating per hit.
#[derive(Clone, Copy, Debug)]
pub enum BsdfNode {
    Diffuse(Diffuse),
    /// Smooth metal (delta reflection).
    Conductor(Conductor),
    /// Microfacet metal.
    RoughConductor(RoughConductor),
    /// Smooth glass (delta reflection and refraction).
    Dielectric(Dielectric),
    /// Thin glass pane (delta reflection and straight transmission).
    ThinDielectric(ThinDielectric),
    /// Microfacet glass (Walter et al. 2007).
    RoughDielectric(RoughDielectric),
    /// Diffuse base under a smooth coating.
    Plastic(Plastic),
    /// Diffuse base under a rough coating.
    RoughPlastic(RoughPlastic),
    /// Front side uses `front`, back side (`wi.z < 0`) uses `back` mirrored to the front.
    TwoSided {
        front: u32,
        back: u32,
    },
    /// Microfacet-based normal mapping around a nested BSDF: an index into the arena's
    /// microfacet normal maps (the model is 232 bytes; stored inline it would make every node,
    /// and every copy of one, that large). Built by [`BsdfArena::push_microfacet_normal_map`].
    MicrofacetNormalMap {
        /// Index into the arena's microfacet normal maps.
        map: u32,
        /// Arena index of the nested BSDF (also in the map; here for [`BsdfNode::lobes`]).
        nested: u32,
    },
    /// Classic normal mapping (Mitsuba 3's `normalmap`) around a nested BSDF.
    NormalMap(NormalMap),
    /// `blendbsdf`: `(1 − w)·f₀ + w·f₁`.
    Blend(Blend),
    /// `null`: the ray passes straight through (delta lobe [`Lobes::NULL`]).
    Null,
    /// `mask`: `opacity · f_nested` plus a pass-through lobe of weight `1 − opacity`.
    Mask(Mask),
    /// `principled`: an index into the arena's principled parameters (72 bytes, stored beside
    /// the nodes like the microfacet normal maps). Built by [`BsdfArena::push_principled`].
    Principled {
        index: u32,
        /// Its lobes ([`Principled::lobes`]).
        lobes: Lobes,
    },
    /// `hair`: Chiang et al.'s fiber model (glossy reflection and transmission).
    Hair(Hair),
    /// `principledthin`: an index into the arena's thin principled parameters. Built by
    /// [`BsdfArena::push_principled_thin`].
    PrincipledThin {
        index: u32,
        /// Its lobes ([`PrincipledThin::lobes`]).
        lobes: Lobes,
    },
}

impl BsdfNode {
    /// The lobes this node can produce, given its children's (`child(arena index)`): the one
    /// rule for both the per-hit arena and the material table (`Materials`, at load time).
    pub fn lobes(&self, child: impl Fn(u32) -> Lobes) -> Lobes {
        match self {
            BsdfNode::Diffuse(_) => Lobes::DIFFUSE_REFLECTION,
            BsdfNode::Conductor(_) => Lobes::DELTA_REFLECTION,
            BsdfNode::RoughConductor(_) => Lobes::GLOSSY_REFLECTION,
            BsdfNode::Dielectric(_) | BsdfNode::ThinDielectric(_) => {
                Lobes::DELTA_REFLECTION | Lobes::DELTA_TRANSMISSION
            }
            BsdfNode::RoughDielectric(_) => Lobes::GLOSSY_REFLECTION | Lobes::GLOSSY_TRANSMISSION,
            BsdfNode::Plastic(_) => Lobes::DELTA_REFLECTION | Lobes::DIFFUSE_REFLECTION,
            BsdfNode::RoughPlastic(_) => Lobes::GLOSSY_REFLECTION | Lobes::DIFFUSE_REFLECTION,
            BsdfNode::Hair(_) => Lobes::GLOSSY_REFLECTION | Lobes::GLOSSY_TRANSMISSION,
            BsdfNode::TwoSided { front, back } => child(*front) | child(*back),
            BsdfNode::MicrofacetNormalMap { nested, .. } => child(*nested),
            BsdfNode::NormalMap(m) => child(m.nested),
            BsdfNode::Blend(m) => child(m.bsdf0) | child(m.bsdf1),
            BsdfNode::Null => Lobes::NULL,
            BsdfNode::Mask(m) => child(m.nested) | Lobes::NULL,
            BsdfNode::Principled { lobes, .. } | BsdfNode::PrincipledThin { lobes, .. } => *lobes,
        }
    }
}

/// Per-thread storage of the BSDF nodes built at one hit.
#[derive(Default, Debug)]
pub struct BsdfArena {
    nodes: Vec<BsdfNode>,
    /// The lobes of each node ([`BsdfNode::lobes`]), computed when it is pushed (its children
    /// come before it), so that [`Bsdf::lobes`] is a load, not a walk of the tree.
    lobes: Vec<Lobes>,
    /// Payloads of the `BsdfNode::MicrofacetNormalMap` nodes: the first `mnm_len` are this
    /// hit's; the slots after them are kept across [`BsdfArena::clear`] (plain `Copy` values)
    /// so that the next hits build their maps in place
    /// ([`BsdfArena::push_microfacet_normal_map_with`]) instead of copying a ~400-byte value in.
    mnm: Vec<mnm::MicrofacetNormalMap>,
    mnm_len: usize,
    /// Closed forms of the microfacet normal maps over Lambertian nested BSDFs.
    lambert: Vec<mnm::lambert::LambertForm>,
    /// Payloads of the `BsdfNode::Principled` and `BsdfNode::PrincipledThin` nodes.
    principled: Vec<Principled>,
    principled_thin: Vec<PrincipledThin>,
    /// Random walks sampled since the last [`BsdfArena::take_walk_counts`], and their
    /// vertices. The arena is per-thread scratch: relaxed loads and stores (plain moves, no
    /// locked read-modify-write) keep it `Sync` for tests that share one read-only arena
    /// across threads, where the counts may then miss increments.
    walks: [AtomicU64; 2],
}

/// Random walks sampled by microfacet normal maps and their vertices (facet scatterings and
/// mirror-wall reflections), for the mean walk length `groove bench` reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    pub walks: u64,
    pub vertices: u64,
}

impl BsdfArena {
    pub fn new() -> Self {
        BsdfArena {
            nodes: Vec::with_capacity(16),
            lobes: Vec::with_capacity(16),
            mnm: Vec::with_capacity(4),
            mnm_len: 0,
            lambert: Vec::with_capacity(4),
            principled: Vec::new(),
            principled_thin: Vec::new(),
            walks: [AtomicU64::new(0), AtomicU64::new(0)],
        }
    }
    /// Forget the nodes of the previous hit (keeps the allocation).
    #[inline]
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.lobes.clear();
        self.mnm_len = 0; // the slots stay, to be overwritten in place
        self.lambert.clear();
        self.principled.clear();
        self.principled_thin.clear();
    }
    /// Store a node and return its index.
    #[inline]
    pub fn push(&mut self, node: BsdfNode) -> u32 {
        let lobes = node.lobes(|c| self.lobes[c as usize]);
        self.push_with_lobes(lobes, node)
    }

    /// Store a node whose lobes the caller knows already (the material table has them, by the
    /// same rule [`BsdfNode::lobes`]).
    #[inline(always)]
    pub fn push_with_lobes(&mut self, lobes: Lobes, node: BsdfNode) -> u32 {
        self.lobes.push(lobes);
        self.nodes.push(node);
        (self.nodes.len() - 1) as u32
    }
    /// Store a microfacet normal map and return its node's index.
    /// Over a `diffuse` nested BSDF (or a `twosided` whose front is one) the walk's closed
    /// form is prepared here ([`mnm::lambert`]).
    #[inline]
    pub fn push_microfacet_normal_map(&mut self, m: mnm::MicrofacetNormalMap) -> u32 {
        self.push_microfacet_normal_map_with(m.nested, |slot| *slot = m)
    }

    /// [`Self::push_microfacet_normal_map`] built in place: `build` writes the whole map over
    /// node `nested` into the arena's slot (a slot of an earlier hit, or a placeholder when
    /// the arena grows; `build` must overwrite every field, e.g. `*slot =
    /// MicrofacetNormalMap::new(..)` and then its `set_*` steps), so that the per-hit build
    /// does not copy the ~400-byte model from the stack into the arena. Same node, same
    /// values as pushing the built map.
    #[inline(always)]
    pub fn push_microfacet_normal_map_with(
        &mut self,
        nested: u32,
        build: impl FnOnce(&mut mnm::MicrofacetNormalMap),
    ) -> u32 {
        let rho = self.lambertian_reflectance(nested);
        let i = self.mnm_len;
        if i == self.mnm.len() {
            self.mnm.push(mnm::MicrofacetNormalMap::placeholder());
        }
        self.mnm_len += 1;
        let m = &mut self.mnm[i];
        build(m);
        debug_assert_eq!(m.nested, nested, "the map is built over `nested`");
        if let Some(form) = rho.and_then(|rho| mnm::lambert::LambertForm::new(m, rho)) {
            self.lambert.push(form);
            m.set_lambert((self.lambert.len() - 1) as u32);
        }
        let lobes = self.lobes[nested as usize];
        self.push_with_lobes(
            lobes,
            BsdfNode::MicrofacetNormalMap {
                map: i as u32,
                nested,
            },
        )
    }
    /// The microfacet normal map of node `i` (`None` for another kind), to finish its per-hit
    /// build in place: the stream kernel's ωi caches, 8 points at once
    /// (`mnm::compensated::lanes::with_incident_x8`).
    #[inline]
    pub(crate) fn mnm_mut(&mut self, i: u32) -> Option<&mut mnm::MicrofacetNormalMap> {
        match self.nodes.get(i as usize)? {
            BsdfNode::MicrofacetNormalMap { map, .. } => {
                self.mnm[..self.mnm_len].get_mut(*map as usize)
            }
            _ => None,
        }
    }
    /// The albedo of node `i` when it is Lambertian as the microfacet normal map's facets see it
    /// (queried from the front only): `diffuse`, or `twosided` with a `diffuse` front.
    fn lambertian_reflectance(&self, i: u32) -> Option<Spectrum> {
        match self.nodes.get(i as usize)? {
            BsdfNode::Diffuse(d) => Some(d.reflectance),
            BsdfNode::TwoSided { front, .. } => match self.nodes.get(*front as usize)? {
                BsdfNode::Diffuse(d) => Some(d.reflectance),
                _ => None,
            },
            _ => None,
        }
    }
    /// Store a `principled` BSDF (`transmits`: it has the transmission lobe, Mitsuba's
    /// `m_has_spec_trans`, which the parameters carry) and return its node's index.
    #[inline]
    pub fn push_principled(&mut self, p: Principled) -> u32 {
        let lobes = Principled::lobes(p.has_spec_trans);
        self.principled.push(p);
        let index = (self.principled.len() - 1) as u32;
        self.push_with_lobes(lobes, BsdfNode::Principled { index, lobes })
    }
    /// Store a `principledthin` BSDF (`transmits`: it has the glossy transmission lobe, i.e.
    /// `spec_trans` was given and is not the constant 0) and return its node's index.
    #[inline]
    pub fn push_principled_thin(&mut self, p: PrincipledThin, transmits: bool) -> u32 {
        let lobes = PrincipledThin::lobes(transmits);
        self.principled_thin.push(p);
        let index = (self.principled_thin.len() - 1) as u32;
        self.push_with_lobes(lobes, BsdfNode::PrincipledThin { index, lobes })
    }
    /// Node `index`, for patching texture values in place (a patch must keep the node's kind:
    /// its lobes were computed when it was pushed).
    #[inline]
    pub fn node_mut(&mut self, index: u32) -> &mut BsdfNode {
        &mut self.nodes[index as usize]
    }
    /// A view of node `root`.
    #[inline]
    pub fn bsdf(&self, root: u32) -> Bsdf<'_> {
        Bsdf { arena: self, root }
    }

    /// The walks sampled since the last call, and reset them.
    pub fn take_walk_counts(&self) -> WalkCounts {
        WalkCounts {
            walks: self.walks[0].swap(0, Ordering::Relaxed),
            vertices: self.walks[1].swap(0, Ordering::Relaxed),
        }
    }
}

/// A BSDF: a node of an arena, with its children.
#[derive(Clone, Copy)]
pub struct Bsdf<'a> {
    arena: &'a BsdfArena,
    root: u32,
}

impl<'a> Bsdf<'a> {
    /// Mitsuba 3's `eval_null_transmission` at local incident direction `wi`: the fraction of
    /// light that crosses the surface unscattered, along a straight line (1 for `null`, 1 −
    /// opacity·(1 − nested) for `mask`, the slab's (1 − R)·transmittance for `thindielectric`,
    /// 0 for every BSDF without such a component). Volumetric shadow rays pass surfaces by it.
    pub fn null_transmission(&self, wi: Vec3) -> Spectrum {
        match self.node() {
            BsdfNode::Null => Spectrum::ONE,
            BsdfNode::Mask(m) => {
                Spectrum::ONE
                    - m.opacity * (Spectrum::ONE - self.child(m.nested).null_transmission(wi))
            }
            BsdfNode::ThinDielectric(t) => (1.0 - t.reflectance(wi.z)) * t.specular_transmittance,
            BsdfNode::TwoSided { front, back } => {
                if wi.z >= 0.0 {
                    self.child(*front).null_transmission(wi)
                } else {
                    self.child(*back)
                        .null_transmission(Vec3::new(wi.x, wi.y, -wi.z))
                }
            }
            _ => Spectrum::ZERO,
        }
    }

    /// Whether a sample of `lobe` drawn at local `wi` is Mitsuba's `Null` component (the ray
    /// continues unbent): the pass-through of `null` and `mask`, and `thindielectric`'s
    /// transmission, which Mitsuba 3 flags `Null` (volumetric path tracing counts no bounce
    /// there).
    pub fn is_null_sample(&self, wi: Vec3, lobe: Lobes) -> bool {
        if lobe.intersects(Lobes::NULL) {
            return true;
        }
        if lobe != Lobes::DELTA_TRANSMISSION {
            return false;
        }
        match self.node() {
            BsdfNode::ThinDielectric(_) => true,
            BsdfNode::Mask(m) => self.child(m.nested).is_null_sample(wi, lobe),
            BsdfNode::TwoSided { front, back } => {
                if wi.z >= 0.0 {
                    self.child(*front).is_null_sample(wi, lobe)
                } else {
                    self.child(*back)
                        .is_null_sample(Vec3::new(wi.x, wi.y, -wi.z), lobe)
                }
            }
            _ => false,
        }
    }

    #[inline]
    fn node(&self) -> &'a BsdfNode {
        &self.arena.nodes[self.root as usize]
    }

    #[inline]
    fn child(&self, index: u32) -> Bsdf<'a> {
        Bsdf {
            arena: self.arena,
            root: index,
        }
    }

    /// The lobes this BSDF can produce (a union over both sides).
    #[inline]
    pub fn lobes(&self) -> Lobes {
        self.arena.lobes[self.root as usize]
    }

    /// Count one sampled random walk of `vertices` vertices (microfacet normal maps).
    #[inline]
    pub(crate) fn record_walk(&self, vertices: u32) {
        let [w, v] = &self.arena.walks;
        w.store(w.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
        v.store(
            v.load(Ordering::Relaxed) + vertices as u64,
            Ordering::Relaxed,
        );
    }

    /// `f(wi, wo) · |cos θo|` in the local frame. `sampler` feeds stochastic BSDFs only.
    pub fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3, sampler: &mut Sampler) -> Spectrum {
        match self.node() {
            BsdfNode::Diffuse(d) => d.eval(wi, wo),
            BsdfNode::Conductor(b) => b.eval(wi, wo),
            BsdfNode::RoughConductor(b) => b.eval(wi, wo),
            BsdfNode::Dielectric(b) => b.eval(wi, wo),
            BsdfNode::ThinDielectric(b) => b.eval(wi, wo),
            BsdfNode::RoughDielectric(b) => b.eval(ctx.mode, wi, wo),
            BsdfNode::Plastic(b) => b.eval(wi, wo),
            BsdfNode::RoughPlastic(b) => b.eval(wi, wo),
            BsdfNode::Hair(b) => b.eval(wi, wo),
            BsdfNode::TwoSided { front, back } => {
                twosided::eval(*self, *front, *back, ctx, wi, wo, sampler)
            }
            BsdfNode::MicrofacetNormalMap { map: i, .. } => {
                mnm::eval(*self, &self.arena.mnm[*i as usize], ctx, wi, wo, sampler)
            }
            BsdfNode::NormalMap(m) => normalmap::eval(*self, m, ctx, wi, wo, sampler),
            BsdfNode::Blend(m) => blend::eval(*self, m, ctx, wi, wo, sampler),
            BsdfNode::Null => Spectrum::ZERO,
            BsdfNode::Mask(m) => mask::eval(*self, m, ctx, wi, wo, sampler),
            BsdfNode::Principled { .. } | BsdfNode::PrincipledThin { .. } => {
                self.principled_eval_pdf(ctx, wi, wo).0
            }
        }
    }

    /// Solid-angle density of sampling `wo` from `wi`.
    pub fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        match self.node() {
            BsdfNode::Diffuse(d) => d.pdf(wi, wo),
            BsdfNode::Conductor(b) => b.pdf(wi, wo),
            BsdfNode::RoughConductor(b) => b.pdf(wi, wo),
            BsdfNode::Dielectric(b) => b.pdf(wi, wo),
            BsdfNode::ThinDielectric(b) => b.pdf(wi, wo),
            BsdfNode::RoughDielectric(b) => b.pdf(wi, wo),
            BsdfNode::Plastic(b) => b.pdf(wi, wo),
            BsdfNode::RoughPlastic(b) => b.pdf(wi, wo),
            BsdfNode::Hair(b) => b.pdf(wi, wo),
            BsdfNode::TwoSided { front, back } => twosided::pdf(*self, *front, *back, ctx, wi, wo),
            BsdfNode::MicrofacetNormalMap { map: i, .. } => {
                mnm::pdf(*self, &self.arena.mnm[*i as usize], ctx, wi, wo)
            }
            BsdfNode::NormalMap(m) => normalmap::pdf(*self, m, ctx, wi, wo),
            BsdfNode::Blend(m) => blend::pdf(*self, m, ctx, wi, wo),
            BsdfNode::Null => 0.0,
            BsdfNode::Mask(m) => mask::pdf(*self, m, ctx, wi, wo),
            BsdfNode::Principled { .. } | BsdfNode::PrincipledThin { .. } => {
                self.principled_eval_pdf(ctx, wi, wo).1
            }
        }
    }

    /// Importance-sample an outgoing direction.
    pub fn sample(&self, ctx: &BsdfContext, wi: Vec3, sampler: &mut Sampler) -> Option<BsdfSample> {
        let s = match self.node() {
            BsdfNode::Diffuse(d) => d.sample(wi, sampler.next_2d()),
            BsdfNode::Conductor(b) => b.sample(wi),
            BsdfNode::RoughConductor(b) => b.sample(wi, sampler.next_2d()),
            BsdfNode::Dielectric(b) => b.sample(ctx.mode, wi, sampler.next_1d()),
            BsdfNode::ThinDielectric(b) => b.sample(wi, sampler.next_1d()),
            BsdfNode::RoughDielectric(b) => {
                let u1 = sampler.next_1d();
                b.sample(ctx.mode, wi, u1, sampler.next_2d())
            }
            BsdfNode::Plastic(b) => {
                let u1 = sampler.next_1d();
                b.sample(wi, u1, sampler.next_2d())
            }
            BsdfNode::RoughPlastic(b) => {
                let u1 = sampler.next_1d();
                b.sample(wi, u1, sampler.next_2d())
            }
            BsdfNode::Hair(b) => {
                let u1 = sampler.next_1d();
                b.sample(wi, u1, sampler.next_2d())
            }
            BsdfNode::TwoSided { front, back } => {
                twosided::sample(*self, *front, *back, ctx, wi, sampler)
            }
            BsdfNode::MicrofacetNormalMap { map: i, .. } => {
                mnm::sample(*self, &self.arena.mnm[*i as usize], ctx, wi, sampler)
            }
            BsdfNode::NormalMap(m) => normalmap::sample(*self, m, ctx, wi, sampler),
            BsdfNode::Blend(m) => blend::sample(*self, m, ctx, wi, sampler),
            BsdfNode::Null => Some(null::pass_through(wi)),
            BsdfNode::Mask(m) => mask::sample(*self, m, ctx, wi, sampler),
            BsdfNode::Principled { .. } | BsdfNode::PrincipledThin { .. } => {
                self.principled_sample(ctx, wi, sampler)
            }
        }?;
        // One place rejects degenerate samples for every model (`accept_sample`'s test, written
        // out: through the call the scalar renderer's `sample` cost ~25 instructions per sample
        // more on metal_plastic).
        if !(s.wo.is_finite() && s.pdf >= 0.0 && crate::spectrum::is_finite(s.weight)) {
            return None;
        }
        Some(s)
    }

    /// Eval and pdf together (next-event estimation needs both). Models whose two queries share
    /// work (the half vector, D and G1, a perturbed frame) compute it once; the result equals
    /// `(eval, pdf)` called separately.
    pub fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        wo: Vec3,
        sampler: &mut Sampler,
    ) -> (Spectrum, f32) {
        match self.node() {
            BsdfNode::Diffuse(d) => (d.eval(wi, wo), d.pdf(wi, wo)),
            BsdfNode::RoughConductor(b) => b.eval_pdf(wi, wo),
            BsdfNode::RoughPlastic(b) => b.eval_pdf(wi, wo),
            BsdfNode::Hair(b) => b.eval_pdf(wi, wo),
            BsdfNode::RoughDielectric(b) => b.eval_pdf(ctx.mode, wi, wo),
            BsdfNode::TwoSided { front, back } => {
                twosided::eval_pdf(*self, *front, *back, ctx, wi, wo, sampler)
            }
            BsdfNode::MicrofacetNormalMap { map: i, .. } => {
                mnm::eval_pdf(*self, &self.arena.mnm[*i as usize], ctx, wi, wo, sampler)
            }
            BsdfNode::NormalMap(m) => normalmap::eval_pdf(*self, m, ctx, wi, wo, sampler),
            BsdfNode::Mask(m) => mask::eval_pdf(*self, m, ctx, wi, wo, sampler),
            BsdfNode::Principled { .. } | BsdfNode::PrincipledThin { .. } => {
                self.principled_eval_pdf(ctx, wi, wo)
            }
            _ => (self.eval(ctx, wi, wo, sampler), self.pdf(ctx, wi, wo)),
        }
    }
}

/// [`Bsdf::sample`]'s rejection of degenerate samples, for the stream kernels that sample a
/// model without it (the same test; `Bsdf::sample` writes it out).
#[inline(always)]
pub(crate) fn accept_sample(s: BsdfSample) -> Option<BsdfSample> {
    if !(s.wo.is_finite() && s.pdf >= 0.0 && crate::spectrum::is_finite(s.weight)) {
        return None;
    }
    Some(s)
}

impl Bsdf<'_> {
    /// `(eval, pdf)` of a principled node. The principled models are reached through these two
    /// out-of-line functions so that the dispatch above stays as small as it was for the other
    /// models (the bench scenes' instruction counts; `eval` and `pdf` alone share the work).
    #[inline(never)]
    fn principled_eval_pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        match self.node() {
            BsdfNode::Principled { index, .. } => {
                self.arena.principled[*index as usize].eval_pdf(ctx.mode, wi, wo)
            }
            BsdfNode::PrincipledThin { index, .. } => {
                self.arena.principled_thin[*index as usize].eval_pdf(wi, wo)
            }
            _ => (Spectrum::ZERO, 0.0),
        }
    }

    #[inline(never)]
    fn principled_sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        sampler: &mut Sampler,
    ) -> Option<BsdfSample> {
        let u1 = sampler.next_1d();
        let u2 = sampler.next_2d();
        match self.node() {
            BsdfNode::Principled { index, .. } => {
                self.arena.principled[*index as usize].sample(ctx.mode, wi, u1, u2)
            }
            BsdfNode::PrincipledThin { index, .. } => {
                self.arena.principled_thin[*index as usize].sample(wi, u1, u2)
            }
            _ => None,
        }
    }
}

/// `x > 0`, false for NaN: the guard every sampling routine applies to pdfs and weights.
#[inline]
pub fn is_positive(x: f32) -> bool {
    x > 0.0
}

/// Cosine of a local direction.
#[inline]
pub fn cos_theta(w: Vec3) -> f32 {
    w.z
}

/// True when `a` and `b` lie on the same side of the local surface.
#[inline]
pub fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

#[cfg(test)]
mod size_tests {
    /// Nodes are copied per hit: the large models live beside them (`BsdfArena::mnm`,
    /// `BsdfArena::principled`), keeping a node at 64 bytes (its size before `principled`).
    #[test]
    fn node_stays_small() {
        assert_eq!(std::mem::size_of::<super::BsdfNode>(), 64);
    }
}
