//! `evaluation = compensated` (issue 17 item 4; design `shared/spec/mnm_fast.md` §4.3, re-derived
//! here): the walk's exact first order plus a reciprocal rank-1 remainder,
//!
//!   f·z(ωo) = f1·z(ωo) + E_ms(ωi) E_ms(ωo) z(ωo) / (π Ē_ms)        (per colour channel),
//!
//! - f1: every path with exactly one non-delta vertex, in closed form — the four paths of
//!   `explicit4` over the mirror sawtooth, single scattering on every other microsurface (there
//!   every vertex is non-delta);
//! - E_ms(ω): the energy of the walk's paths with ≥ 2 non-delta vertices, from the per-order
//!   tables of [`super::ms_table`] with the colour applied per order at the hit;
//! - Ē_ms = (1/π) ∫ E_ms z dω, the exact mean of the same interpolant.
//!
//! Properties: reciprocal (f1 is, and the product term is symmetric); ∫ f_ms z dωo = E_ms(ωi)
//! exactly (the Kelemen / Kulla–Conty construction with a direction-dependent remainder), so the
//! albedo is E1(ωi) + E_ms(ωi), which equals the walk's at the table nodes up to table noise;
//! deterministic (eval consumes no random numbers). Sampling: with probability
//! s(ωi) = Y(E_ms(ωi)) / (Y(c·W1(ωi)) + Y(E_ms(ωi))) a cosine lobe about ωg, else the first
//! order's own sampler; pdf = (1 − s) p1 + s z/π exactly, weight = eval / pdf.
//!
//! Cost (issue 17 item 1): everything that depends on ωi alone — the first order's entries
//! (λ(ωi), R(ωi), both in the facet frames) and, for tables with the colour baked in, E_ms(ωi)
//! and s(ωi) — is computed once per shading point ([`AtIncident`], built with the BSDF at the
//! hit) and shared by next-event estimation and sampling. A sample takes the term of the path it
//! drew from the nested sample record (F = weight · pdf, P = pdf) instead of evaluating the
//! nested BSDF again; eval and pdf come from one pass ([`eval_pdf`]).

pub(crate) mod lanes;

use super::facets::MAX_FACETS;
use super::ms_table::{Colour, MsTable, ThetaCell};
use super::nested_batch::{self, Evaluated, Pairs};
use super::MicrofacetNormalMap;
use crate::bsdf::diffuse::Diffuse;
use crate::bsdf::roughconductor::RoughConductor;
use crate::bsdf::roughplastic::RoughPlastic;
use crate::bsdf::{Bsdf, BsdfContext, BsdfNode, BsdfSample};
use crate::math::{warp, INV_PI};
use crate::sampler::{Draw, Sampler};
use crate::spectrum::{luminance, Spectrum};
use glam::Vec3;

/// A shading point's table and its place in it (built per hit), with the ωi cache
/// ([`MsPlace`], which it dereferences to, and [`AtIncident`]).
#[derive(Clone, Copy, Debug)]
pub struct MsRef {
    place: MsPlace,
    /// The incident direction's share, when the hit's ωi is known at build time
    /// ([`MicrofacetNormalMap::with_incident`]); used for queries with that exact ωi.
    at: Option<AtIncident>,
}

/// A shading point's table and its place in it: what every query reads ([`MsRef`] without
/// its ωi cache; the stream kernel's points keep this alone, `lanes::Point`).
#[derive(Clone, Copy, Debug)]
pub struct MsPlace {
    pub table: &'static MsTable,
    pub cell: ThetaCell,
    /// With the colour baked in ([`Colour::Baked`]): 1 / (π Ē_ms) of this point, per channel.
    baked_norm: Option<Spectrum>,
}

impl std::ops::Deref for MsRef {
    type Target = MsPlace;
    #[inline(always)]
    fn deref(&self) -> &MsPlace {
        &self.place
    }
}

impl MsPlace {
    /// [`MsRef::in_cell`] without the cache.
    #[inline(always)]
    pub fn in_cell(table: &'static MsTable, cell: ThetaCell) -> MsPlace {
        let baked_norm = (table.spec.colour == Colour::Baked).then(|| {
            let m = table.mean_baked(&cell);
            Vec3::new(inv(m.x), inv(m.y), inv(m.z)) * INV_PI
        });
        MsPlace {
            table,
            cell,
            baked_norm,
        }
    }
}

impl MsRef {
    /// `wp`: the (clamped, not flat) perturbed normal.
    #[inline(always)]
    pub fn new(table: &'static MsTable, wp: Vec3) -> MsRef {
        Self::in_cell(table, table.cell(wp))
    }

    /// [`Self::new`] with ωp's cell already found ([`MsTable::cells`], several points at once).
    #[inline(always)]
    pub fn in_cell(table: &'static MsTable, cell: ThetaCell) -> MsRef {
        MsRef {
            place: MsPlace::in_cell(table, cell),
            at: None,
        }
    }

    /// The cached incident share for the query direction `wi`, if it was built for exactly it
    /// (bit for bit: a query from another ωi, e.g. a light path's, computes its own).
    #[inline]
    fn at(&self, wi: Vec3) -> Option<&AtIncident> {
        self.at
            .as_ref()
            .filter(|a| a.wi.to_array().map(f32::to_bits) == wi.to_array().map(f32::to_bits))
    }
}

/// The first order's entries at ωi (module doc of `explicit.rs`): over the mirror sawtooth
/// (direct: facet 0 from ωi with weight λp(ωi); via the wall: facet 0 from R(ωi) with λt(ωi),
/// where ωi·ωt > 0), else one per facet seen from ωi (single scattering, weight λ_k(ωi)); each
/// with its incident direction already in the facet's frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Entries {
    k: [u8; MAX_FACETS],
    n: u8,
    /// Bit j: entry j reaches facet 0 through the mirror wall (R(ωi), weight λt(ωi)).
    via_wall: u8,
    w: [f32; MAX_FACETS],
    a: [Vec3; MAX_FACETS],
}

impl Entries {
    /// No entries (also [`lanes`]' placeholder for a lane without a point).
    const EMPTY: Entries = Entries {
        k: [0; MAX_FACETS],
        n: 0,
        via_wall: 0,
        w: [0.0; MAX_FACETS],
        a: [Vec3::ZERO; MAX_FACETS],
    };

    /// The entries at `wi` (z > 0), with the same conditions and values as
    /// `explicit::eval_pdf_complete` / `eval_pdf_single` use.
    fn new(m: &MicrofacetNormalMap, wi: Vec3) -> Entries {
        let surf = &m.surface;
        let mut e = Entries::EMPTY;
        let l = surf.lambdas(wi);
        if m.mirror_wall {
            let fr = &m.frames[0];
            if l[0] > 0.0 {
                e.push(0, l[0], fr.to_local(wi));
            }
            if l[1] > 0.0 && wi.dot(surf.normal(1)) > 0.0 {
                e.via_wall |= 1 << e.n;
                e.push(0, l[1], fr.to_local(m.reflect_wall(wi)));
            }
        } else {
            for (k, &lk) in l.iter().enumerate().take(surf.len()) {
                if lk > 0.0 {
                    e.push(k, lk, m.frames[k].to_local(wi));
                }
            }
        }
        e
    }

    fn push(&mut self, k: usize, w: f32, a: Vec3) {
        let n = self.n as usize;
        self.k[n] = k as u8;
        self.w[n] = w;
        self.a[n] = a;
        self.n += 1;
    }

    #[inline]
    fn len(&self) -> usize {
        self.n as usize
    }

    #[inline]
    fn via_wall(&self, j: usize) -> bool {
        self.via_wall & (1 << j) != 0
    }
}

/// What a shading point computes once for its incident direction (module doc).
#[derive(Clone, Copy, Debug)]
pub(super) struct AtIncident {
    wi: Vec3,
    entries: Entries,
    /// Baked tables: E_ms(ωi) and the lobe choice s(ωi).
    baked: Option<(Spectrum, f32)>,
}

impl AtIncident {
    fn new(m: &MicrofacetNormalMap, r: &MsRef, wi: Vec3) -> AtIncident {
        let baked = r.baked_norm.map(|_| {
            let [w1, ei] = r.table.lookup_baked(&r.cell, wi, true);
            (ei, selection(ei, w1))
        });
        AtIncident {
            wi,
            entries: Entries::new(m, wi),
            baked,
        }
    }

    /// [`Self::new`] from the baked table's [W1, E_ms] at ωi, looked up by the caller (8 points
    /// at once: [`lanes::with_incident_x8`]).
    #[inline(always)]
    fn from_lookup(m: &MicrofacetNormalMap, wi: Vec3, [w1, ei]: [Spectrum; 2]) -> Self {
        AtIncident {
            wi,
            entries: Entries::new(m, wi),
            baked: Some((ei, selection(ei, w1))),
        }
    }

    /// Whether [`MicrofacetNormalMap::with_incident`] builds a cache for `m` at `wi` (its
    /// conditions).
    #[inline(always)]
    fn wanted(m: &MicrofacetNormalMap, wi: Vec3) -> bool {
        m.ms.is_some() && wi.z > 0.0 && !m.degenerate
    }
}

impl MicrofacetNormalMap {
    /// The compensated model's per-point cache for the hit's incident direction `wi` (shading
    /// frame): computed here once, used by every query with exactly this ωi. Without a table,
    /// or with ωi below the surface, nothing changes. Results are the same with or without it.
    #[inline(always)]
    pub fn with_incident(mut self, wi: Vec3) -> Self {
        self.set_incident(wi);
        self
    }

    /// [`Self::with_incident`] in place (the arena's in-place build,
    /// [`crate::bsdf::BsdfArena::push_microfacet_normal_map_with`]).
    #[inline(always)]
    pub fn set_incident(&mut self, wi: Vec3) {
        if let Some(r) = &self.ms {
            if wi.z > 0.0 && !self.degenerate {
                let at = AtIncident::new(self, r, wi);
                if let Some(r) = &mut self.ms {
                    r.at = Some(at);
                }
            }
        }
    }
}

/// What depends on ωi only: the colour coefficients, Ē_ms, E_ms(ωi) and the lobe choice s(ωi).
#[derive(Clone, Copy, Debug)]
struct AtWi {
    /// Per-bounce colours: the per-order coefficients ([`MsTable::coefficients`]); `None` for a
    /// table with the colours baked in (the remainder is then the baked lookup, and a baked
    /// point's state is not burdened with 72 bytes of ones).
    k: Option<[[Spectrum; 3]; 2]>,
    /// 1 / (π Ē_ms) per channel (0 where Ē_ms = 0).
    norm: Spectrum,
    ei: Spectrum,
    select: f32,
}

/// The per-bounce colour c at this hit (1 when the table has the colours baked in).
#[inline]
fn colour(r: &MsPlace, nested: &Bsdf) -> Spectrum {
    if r.table.spec.colour == Colour::Baked {
        return Spectrum::ONE;
    }
    match nested.node() {
        BsdfNode::Diffuse(d) => d.reflectance,
        BsdfNode::RoughConductor(b) => b.specular_reflectance,
        BsdfNode::TwoSided { front, .. } => match nested.child(*front).node() {
            BsdfNode::Diffuse(d) => d.reflectance,
            _ => Spectrum::ONE,
        },
        _ => Spectrum::ONE,
    }
}

impl AtWi {
    /// A placeholder (all zero) for a lane without a point ([`lanes`]' per-lane state).
    const UNUSED: AtWi = AtWi {
        k: None,
        norm: Spectrum::ZERO,
        ei: Spectrum::ZERO,
        select: 0.0,
    };

    #[inline]
    fn new(r: &MsPlace, nested: &Bsdf, wi: Vec3, at: Option<&AtIncident>) -> AtWi {
        let t = r.table;
        if let Some(norm) = r.baked_norm {
            let (ei, select) = match at.and_then(|a| a.baked) {
                Some(b) => b,
                None => {
                    let [w1, ei] = t.lookup_baked(&r.cell, wi, true);
                    (ei, selection(ei, w1))
                }
            };
            return AtWi {
                k: None,
                norm,
                ei,
                select,
            };
        }
        let c = colour(r, nested);
        let k = t.coefficients(&r.cell, c);
        let ebar = t.mean_remainder(&r.cell, &k);
        let norm = Vec3::new(inv(ebar.x), inv(ebar.y), inv(ebar.z)) * INV_PI;
        let l = t.lookup(&r.cell, wi);
        let ei = MsTable::remainder(&l, &k);
        AtWi {
            k: Some(k),
            norm,
            ei,
            select: selection(ei, c * MsTable::first(&l, &r.cell)),
        }
    }

    /// [`Self::new`] of a point with a baked table (`r.baked_norm` set) from its [W1, E_ms] at
    /// ωi, looked up by the caller (8 points at once: `lanes::Chunk::new`).
    #[inline(always)]
    fn baked(r: &MsPlace, [w1, ei]: [Spectrum; 2]) -> AtWi {
        AtWi {
            k: None,
            norm: r.baked_norm.expect("a baked table"),
            ei,
            select: selection(ei, w1),
        }
    }

    /// The rank-1 remainder's f·z(ωo).
    #[inline]
    fn remainder(&self, r: &MsPlace, wo: Vec3) -> Spectrum {
        if self.ei == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let eo = match &self.k {
            None => r.table.lookup_baked(&r.cell, wo, false)[1],
            Some(k) => MsTable::remainder(&r.table.lookup(&r.cell, wo), k),
        };
        self.remainder_from(eo, wo)
    }

    /// [`Self::remainder`] from E_ms(ωo) `eo` (looked up elsewhere; `ei` ≠ 0).
    #[inline(always)]
    fn remainder_from(&self, eo: Spectrum, wo: Vec3) -> Spectrum {
        self.ei * eo * self.norm * wo.z
    }
}

/// s(ωi) = Y(E_ms) / (Y(c·W1) + Y(E_ms)), 0 without a remainder.
#[inline]
fn selection(ei: Spectrum, first: Spectrum) -> f32 {
    let a = luminance(ei).max(0.0);
    let b = luminance(first).max(0.0);
    if a > 0.0 {
        a / (a + b)
    } else {
        0.0
    }
}

#[inline]
fn inv(x: f32) -> f32 {
    if x > 0.0 {
        1.0 / x
    } else {
        0.0
    }
}

/// One term of the first order already known from the nested sample that drew ωo: entry `j`,
/// exit through the wall or not, and the nested F and P of that pair.
#[derive(Clone, Copy, Debug)]
struct Known {
    j: usize,
    wall: bool,
    f: Spectrum,
    p: f32,
}

/// The first order at ωo: f1·z(ωo), its density p1, and the random walk's first-order density
/// (decision 3's p1: `explicit::PdfTerms::mirror` / `single`) from the same nested densities.
#[derive(Clone, Copy)]
pub(super) struct FirstOrder {
    pub f: Spectrum,
    pub p: f32,
    /// The walk's p1 (`auto`'s blend band reports the mixture's density, which needs it):
    /// over the mirror sawtooth the same nested densities with the wall entry [t, p] unmasked
    /// and no [t, p, t] path (Variant M's sampler), otherwise equal to `p`. Summed in
    /// `PdfTerms`' order with its weights, so equal to `explicit::pdf_mirror` / `pdf_single`
    /// bit for bit where the nested densities are (the nested `eval_pdf`'s density is its
    /// `pdf` for `roughconductor` and `roughplastic` with visible-normal sampling); a drawn
    /// path's density from the sample record differs from `pdf` in the last bits.
    pub p_walk: f32,
}

/// The first order's eval and pdf at ωo (z > 0) from the entries at ωi: the sum of
/// `explicit::eval_pdf_complete` (mirror sawtooth) or `explicit::eval_pdf_single`, in the same
/// order and with the same operations (so bit for bit equal to them), with ωo (and R(ωo)) put
/// into the facet frame once for all entries, and the `known` term not evaluated again. The
/// nested evaluations of all terms are made in one batch ([`super::nested_batch`]: one 8-wide
/// call for nested BSDFs with a lane form, a scalar call for a single pair:
/// [`Nested::eval_pairs`]). The walk's density comes along when `WALK`
/// ([`FirstOrder::p_walk`], else 0).
#[inline]
fn first_order<const WALK: bool>(
    m: &MicrofacetNormalMap,
    e: &Entries,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wo: Vec3,
    s: &mut Sampler,
    known: Option<Known>,
) -> FirstOrder {
    let mut pairs = Pairs::new();
    let c = Collected::new(m, e, wo, known, &mut pairs);
    let ev = Nested::of(nested).eval_pairs(ctx, &pairs, s);
    c.sum::<WALK, { nested_batch::WIDTH }>(e, known, &ev)
}

/// Pass 1 of the first order at ωo: its nested pairs pushed into a batch (slot `NONE`: the
/// known term, or no such path), and what pass 2 ([`Collected::sum`]) needs besides their
/// values. Split so that the stream renderer's kernel can evaluate the pairs of 8 shading
/// points in full 8-wide calls ([`crate::bsdf::mnm::compensated::lanes`]).
#[derive(Clone, Copy)]
struct Collected {
    mirror_wall: bool,
    g1o: f32,
    pdf_only: bool,
    /// Over the mirror sawtooth: the wall exit's (R(ωo) in the facet frame, 1 − G1).
    exit_t: Option<(Vec3, f32)>,
    slot: [[u8; 2]; MAX_FACETS],
    /// Elsewhere: ωo faces entry j's facet (and G1(ωo) > 0).
    facing: [bool; MAX_FACETS],
}

impl Collected {
    /// A placeholder for a lane without a point ([`lanes`]' per-lane state; never summed).
    const UNUSED: Collected = Collected {
        mirror_wall: false,
        g1o: 0.0,
        pdf_only: true,
        exit_t: None,
        slot: [[NONE; 2]; MAX_FACETS],
        facing: [false; MAX_FACETS],
    };

    #[inline(always)]
    fn new<const W: usize>(
        m: &MicrofacetNormalMap,
        e: &Entries,
        wo: Vec3,
        known: Option<Known>,
        pairs: &mut Pairs<W>,
    ) -> Collected {
        let surf = &m.surface;
        let g1o = surf.g1(wo);
        let pdf_only = g1o <= 0.0;
        let is_known =
            |j: usize, wall: bool| matches!(known, Some(kn) if kn.j == j && kn.wall == wall);
        let mut c = Collected {
            mirror_wall: m.mirror_wall,
            g1o,
            pdf_only,
            exit_t: None,
            slot: [[NONE; 2]; MAX_FACETS],
            facing: [false; MAX_FACETS],
        };
        if m.mirror_wall {
            let fr = &m.frames[0];
            let bo = fr.to_local(wo);
            c.exit_t = wall_exit(m, wo);
            for (j, (sl, &a)) in c.slot.iter_mut().zip(&e.a).enumerate().take(e.len()) {
                if !is_known(j, false) {
                    sl[0] = pairs.push(a, bo, pdf_only) as u8;
                }
                if let Some((rb, _)) = c.exit_t {
                    if !is_known(j, true) {
                        sl[1] = pairs.push(a, rb, pdf_only) as u8;
                    }
                }
            }
        } else {
            for j in 0..e.len() {
                let k = e.k[j] as usize;
                let b = m.frames[k].to_local(wo);
                c.facing[j] = !pdf_only && wo.dot(surf.normal(k)) > 0.0;
                let kn = match known {
                    Some(kn) if c.facing[j] => kn.j == j && !kn.wall,
                    Some(kn) => kn.j == j,
                    None => false,
                };
                if !kn {
                    c.slot[j][0] = pairs.push(e.a[j], b, !c.facing[j]) as u8;
                }
            }
        }
        c
    }

    /// Pass 2: the sums, term by term in the order of the explicit closed forms, from the
    /// pairs' values `ev` (indexed by the slots of pass 1).
    #[inline(always)]
    fn sum<const WALK: bool, const W: usize>(
        &self,
        e: &Entries,
        known: Option<Known>,
        ev: &Evaluated<W>,
    ) -> FirstOrder {
        let (g1o, pdf_only, slot) = (self.g1o, self.pdf_only, &self.slot);
        let mut v = Spectrum::ZERO;
        let mut p = 0.0;
        let mut pw = 0.0;
        if self.mirror_wall {
            let exit_t = self.exit_t;
            let term = |j: usize, wall: bool| -> (Spectrum, f32) {
                match known {
                    Some(kn) if kn.j == j && kn.wall == wall => (kn.f, kn.p),
                    _ => {
                        let i = slot[j][usize::from(wall)] as usize;
                        (if pdf_only { Spectrum::ZERO } else { ev.f(i) }, ev.p(i))
                    }
                }
            };
            for j in 0..e.len() {
                let w = e.w[j];
                let via_wall = e.via_wall(j);
                let (f, pd) = term(j, false);
                v += w * f;
                p += w * g1o * pd;
                if WALK {
                    pw += if via_wall { w * pd } else { w * g1o * pd };
                }
                if let Some((_, bt)) = exit_t {
                    let (f, pd) = term(j, true);
                    v += (w * bt) * f;
                    p += w * bt * pd;
                    if WALK && !via_wall {
                        pw += w * bt * pd;
                    }
                }
            }
        } else {
            for (j, sl) in slot.iter().enumerate().take(e.len()) {
                let lk = e.w[j];
                let i = sl[0];
                let known_p = known.map_or(0.0, |kn| kn.p);
                if self.facing[j] {
                    let (f, pd) = if i == NONE {
                        (known.map_or(Spectrum::ZERO, |kn| kn.f), known_p)
                    } else {
                        (ev.f(i as usize), ev.p(i as usize))
                    };
                    v += lk * f;
                    p += lk * pd;
                } else {
                    let pd = if i == NONE { known_p } else { ev.p(i as usize) };
                    p += lk * pd;
                }
            }
            if WALK {
                pw = p;
            }
        }
        FirstOrder {
            f: v * g1o,
            p,
            p_walk: pw,
        }
    }
}

/// No pair (the known term, or a path that does not exist).
const NONE: u8 = u8::MAX;

/// The nested BSDF with its kind matched once per query instead of once per nested call (the
/// first order makes about two): the functions [`Bsdf::eval_pdf`] and [`Bsdf::pdf`] reach for
/// these kinds, called directly, so the values are the same bit for bit.
#[derive(Clone, Copy)]
enum Nested<'a, 'b> {
    Diffuse(&'a Diffuse),
    Conductor(&'a RoughConductor),
    Plastic(&'a RoughPlastic),
    Other(&'b Bsdf<'a>),
}

impl<'a, 'b> Nested<'a, 'b> {
    #[inline(always)]
    fn of(b: &'b Bsdf<'a>) -> Self {
        match b.node() {
            BsdfNode::Diffuse(d) => Nested::Diffuse(d),
            BsdfNode::RoughConductor(c) => Nested::Conductor(c),
            BsdfNode::RoughPlastic(p) => Nested::Plastic(p),
            _ => Nested::Other(b),
        }
    }

    /// Every pair of `pairs` in one call of the nested BSDF's lane form, for the kinds that
    /// have one (`None` for the others).
    #[inline(always)]
    fn lanes<const W: usize>(self, pairs: &Pairs<W>) -> Option<Evaluated<W>> {
        match self {
            Nested::Diffuse(d) => Some(nested_batch::eval_pdf_lanes(d, pairs)),
            Nested::Conductor(c) => Some(nested_batch::eval_pdf_lanes(c, pairs)),
            Nested::Plastic(p) => Some(nested_batch::eval_pdf_lanes(p, pairs)),
            Nested::Other(_) => None,
        }
    }

    /// Every pair of `pairs`: in one lane call for kinds with a lane form, else pair by pair
    /// (`pdf` for a pair that needs only the density, `eval_pdf` otherwise, in order: a nested
    /// BSDF that draws random numbers draws them as before). A single pair (44 % of the
    /// queries on `scenes/bench/metal_plastic.xml`, e.g. a sample with one term besides the
    /// drawn one) goes to the scalar BSDF directly: the same numbers (the lane forms equal
    /// `eval_pdf` and `pdf` bit for bit, `nested_batch`'s tests), and an 8-wide call with one
    /// lane used costs about the scalar call's arithmetic plus its staging.
    #[inline(always)]
    fn eval_pairs(self, ctx: &BsdfContext, pairs: &Pairs, s: &mut Sampler) -> Evaluated {
        if pairs.len() > 1 {
            if let Some(ev) = self.lanes(pairs) {
                return ev;
            }
        }
        let mut out = Evaluated::zero();
        for i in 0..pairs.len() {
            let (a, b) = (pairs.a(i), pairs.b(i));
            if pairs.pdf_only(i) {
                out.set(i, Spectrum::ZERO, self.pdf(ctx, a, b));
            } else {
                let (f, p) = self.eval_pdf(ctx, a, b, s);
                out.set(i, f, p);
            }
        }
        out
    }

    /// The densities of every pair of `pairs` (`f` left 0 except in a lane call, where it is
    /// not read): in one lane call for kinds with a lane form, else (or for a single pair,
    /// as [`Self::eval_pairs`]) pair by pair.
    #[inline(always)]
    fn pdf_pairs(self, ctx: &BsdfContext, pairs: &Pairs) -> Evaluated {
        if pairs.len() > 1 {
            if let Some(ev) = self.lanes(pairs) {
                return ev;
            }
        }
        let mut out = Evaluated::zero();
        for i in 0..pairs.len() {
            out.set(i, Spectrum::ZERO, self.pdf(ctx, pairs.a(i), pairs.b(i)));
        }
        out
    }

    #[inline(always)]
    fn eval_pdf(self, ctx: &BsdfContext, a: Vec3, b: Vec3, s: &mut Sampler) -> (Spectrum, f32) {
        match self {
            Nested::Diffuse(d) => (d.eval(a, b), d.pdf(a, b)),
            Nested::Conductor(c) => c.eval_pdf(a, b),
            Nested::Plastic(p) => p.eval_pdf(a, b),
            Nested::Other(n) => n.eval_pdf(ctx, a, b, s),
        }
    }

    #[inline(always)]
    fn pdf(self, ctx: &BsdfContext, a: Vec3, b: Vec3) -> f32 {
        match self {
            Nested::Diffuse(d) => d.pdf(a, b),
            Nested::Conductor(c) => c.pdf(a, b),
            Nested::Plastic(p) => p.pdf(a, b),
            Nested::Other(n) => n.pdf(ctx, a, b),
        }
    }
}

/// The mirror wall's exit of ωo (path [·, t]): ωo mirrored across the wall, in the first facet's
/// frame, with the wall's 1 − G1 of that mirror image; `None` when ωo does not face the wall or
/// nothing leaves that way.
#[inline]
fn wall_exit(m: &MicrofacetNormalMap, wo: Vec3) -> Option<(Vec3, f32)> {
    let surf = &m.surface;
    (wo.dot(surf.normal(1)) > 0.0)
        .then(|| {
            let rwo = m.reflect_wall(wo);
            (rwo, 1.0 - surf.g1(rwo))
        })
        .filter(|&(_, bt)| bt > 0.0)
        .map(|(rwo, bt)| (m.frames[0].to_local(rwo), bt))
}

/// The entries at `wi`: the point's cache, else computed.
#[inline]
fn entries(m: &MicrofacetNormalMap, at: Option<&AtIncident>, wi: Vec3) -> Entries {
    match at {
        Some(a) => a.entries,
        None => Entries::new(m, wi),
    }
}

/// Eval and pdf (both z(ωi), z(ωo) > 0; the caller checks).
pub(super) fn eval_pdf(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let (f, p, _) = eval_pdf_with::<false>(m, r, nested, ctx, wi, wo, s);
    (f, p)
}

/// [`eval_pdf`] and the walk's first-order density p1 at the same ωo ([`FirstOrder::p_walk`]).
pub(super) fn eval_pdf_walk(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32, f32) {
    eval_pdf_with::<true>(m, r, nested, ctx, wi, wo, s)
}

#[inline(always)]
fn eval_pdf_with<const WALK: bool>(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32, f32) {
    let at = r.at(wi);
    let a = AtWi::new(r, nested, wi, at);
    let e = entries(m, at, wi);
    let fo = first_order::<WALK>(m, &e, nested, ctx, wo, s, None);
    (
        fo.f + a.remainder(r, wo),
        (1.0 - a.select) * fo.p + a.select * wo.z * INV_PI,
        fo.p_walk,
    )
}

/// The exact density of [`sample`].
pub(super) fn pdf(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    let at = r.at(wi);
    let select = match (r.baked_norm, at.and_then(|a| a.baked)) {
        (Some(_), Some((_, sel))) => sel,
        _ => AtWi::new(r, nested, wi, at).select,
    };
    let e = entries(m, at, wi);
    let p1 = first_pdf(m, &e, nested, ctx, wo);
    (1.0 - select) * p1 + select * wo.z * INV_PI
}

/// The first order's density alone (`explicit::pdf_complete` / `pdf_single` from the entries),
/// its nested densities in one batch as in [`first_order`].
fn first_pdf(
    m: &MicrofacetNormalMap,
    e: &Entries,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wo: Vec3,
) -> f32 {
    let nested = Nested::of(nested);
    let surf = &m.surface;
    let mut pairs = Pairs::new();
    let mut p = 0.0;
    if m.mirror_wall {
        let fr = &m.frames[0];
        let g1o = surf.g1(wo);
        let bo = fr.to_local(wo);
        let exit_t = wall_exit(m, wo);
        for j in 0..e.len() {
            pairs.push(e.a[j], bo, true);
            if let Some((rb, _)) = exit_t {
                pairs.push(e.a[j], rb, true);
            }
        }
        let ev = nested.pdf_pairs(ctx, &pairs);
        let mut i = 0;
        for j in 0..e.len() {
            let w = e.w[j];
            p += w * g1o * ev.p(i);
            i += 1;
            if let Some((_, bt)) = exit_t {
                p += w * bt * ev.p(i);
                i += 1;
            }
        }
    } else {
        for j in 0..e.len() {
            let k = e.k[j] as usize;
            pairs.push(e.a[j], m.frames[k].to_local(wo), true);
        }
        let ev = nested.pdf_pairs(ctx, &pairs);
        for j in 0..e.len() {
            p += e.w[j] * ev.p(j);
        }
    }
    p
}

/// True when the nested BSDF's samples carry weight = eval / pdf, so that a drawn path's term
/// can be taken from its sample record (F = weight · pdf): the microfacet reflectors whose
/// `sample` computes its weight from the same f and pdf as `eval_pdf` (a `blendbsdf`, for one,
/// reports the chosen component's weight against the mixture's pdf, so it is not listed).
#[inline]
fn sample_record_is_exact(nested: &Bsdf) -> bool {
    matches!(
        nested.node(),
        BsdfNode::RoughConductor(_) | BsdfNode::RoughPlastic(_) | BsdfNode::Diffuse(_)
    )
}

/// The mixture of the first order's sampler and a cosine lobe (module doc); weight = eval/pdf.
/// The first order's sampler draws with independent random numbers per decision, as
/// `explicit::draw_complete` / `draw_single` do; the drawn path's nested F and P come from the
/// nested sample record (when [`sample_record_is_exact`]), the other terms are evaluated.
pub(super) fn sample(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    sample_with::<false>(m, r, nested, ctx, wi, s).map(|(bs, _)| bs)
}

/// [`sample`] and the walk's first-order density p1 at the sampled ωo
/// ([`FirstOrder::p_walk`]; the drawn path's nested density is the sample record's).
pub(super) fn sample_walk(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<(BsdfSample, f32)> {
    sample_with::<true>(m, r, nested, ctx, wi, s)
}

#[inline(always)]
fn sample_with<const WALK: bool>(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<(BsdfSample, f32)> {
    let at = r.at(wi);
    let a = AtWi::new(r, nested, wi, at);
    let e = entries(m, at, wi);
    let (wo, known) = if s.next_1d() < a.select {
        (warp::square_to_cosine_hemisphere(s.next_2d()), None)
    } else {
        draw(m, &e, nested, ctx, s)?
    };
    if wo.z <= 0.0 {
        return None;
    }
    let known = known.filter(|_| sample_record_is_exact(nested));
    let fo = first_order::<WALK>(m, &e, nested, ctx, wo, s, known);
    let pdf = (1.0 - a.select) * fo.p + a.select * wo.z * INV_PI;
    if !(pdf.is_finite() && pdf > 0.0) {
        return None;
    }
    let bs = BsdfSample {
        wo,
        pdf,
        weight: (fo.f + a.remainder(r, wo)) / pdf,
        eta: 1.0,
        lobe: super::explicit::lobe_of(nested.lobes()),
    };
    Some((bs, fo.p_walk))
}

/// The first order's sampler from the entries: pick an entry by its weight ([`pick_entry`]),
/// sample the nested BSDF in its facet's frame, then leave the microsurface ([`leave`]).
/// Returns ωo and the drawn term.
fn draw(
    m: &MicrofacetNormalMap,
    e: &Entries,
    nested: &Bsdf,
    ctx: &BsdfContext,
    s: &mut Sampler,
) -> Option<(Vec3, Option<Known>)> {
    let j = pick_entry(e, s.next_1d())?;
    let bs = nested.sample(ctx, e.a[j], s)?;
    Some(leave(m, e.k[j] as usize, j, (bs.wo, bs.pdf, bs.weight), s))
}

/// The entry that `x` (a uniform number) picks by the entries' weights (they sum to 1 up to
/// rounding; the last entry takes the rest); `None` without entries. [`draw`]'s first step,
/// shared with the stream kernel's sampler (`lanes::sample_x8`).
#[inline(always)]
fn pick_entry(e: &Entries, x: f32) -> Option<usize> {
    let n = e.len();
    let mut j = 0;
    let mut acc = 0.0;
    while j + 1 < n {
        acc += e.w[j];
        if x < acc {
            break;
        }
        j += 1;
    }
    (n != 0).then_some(j)
}

/// [`draw`]'s last step, once entry `j`'s nested sample `(ωo, pdf, weight)` (ωo in the
/// frame of the entry's facet `facet`) is known: u = ωo in the shading frame; over the mirror sawtooth u
/// leaves directly with probability G1(u) (one more number drawn from `s`), else it is
/// blocked and leaves through the wall (R(u)). Returns ωo and the drawn term. Shared with the
/// stream kernel's sampler (`lanes::sample_x8`), which samples the nested BSDF of 8 points at
/// once in between.
#[inline(always)]
fn leave<M: Leaves>(
    m: &M,
    facet: usize,
    j: usize,
    (bwo, bpdf, bweight): (Vec3, f32, Spectrum),
    s: &mut impl Draw,
) -> (Vec3, Option<Known>) {
    let u = m.facet_to_world(facet, bwo);
    if !m.mirror_wall() {
        return (u, known_term(j, false, bpdf, bweight));
    }
    leave_mirror(u, m.g1(u), || m.reflect_wall(u), j, (bpdf, bweight), s)
}

/// [`leave`]'s last step over the mirror sawtooth from u (the nested sample's ωo in the
/// shading frame), G1(u) and R(u) (`reflect`, called only where the ray is blocked): one number
/// drawn from `s`, u where it is below G1(u), else R(u). The stream kernel's chunk
/// (`lanes::sample_x8_cols`) computes u, G1(u) and R(u) of 8 points in lanes, makes this draw
/// and comparison per lane from the batch's columns (`Samplers::stream`, the same number as the
/// path's `Sampler`) and keeps the known terms in columns (`lanes::first::Mirror8::sampled`:
/// [`known_term`]'s test and products).
#[inline(always)]
fn leave_mirror(
    u: Vec3,
    g1u: f32,
    reflect: impl FnOnce() -> Vec3,
    j: usize,
    (bpdf, bweight): (f32, Spectrum),
    s: &mut impl Draw,
) -> (Vec3, Option<Known>) {
    if s.next_1d() < g1u {
        (u, known_term(j, false, bpdf, bweight))
    } else {
        (reflect(), known_term(j, true, bpdf, bweight)) // blocked: the ray hits the mirror wall
    }
}

/// The term of entry `j` (through the wall or not) that the nested sample (density `bpdf`,
/// weight `bweight`) makes known: `None` unless its density is finite and positive.
#[inline(always)]
fn known_term(j: usize, wall: bool, bpdf: f32, bweight: Spectrum) -> Option<Known> {
    (bpdf.is_finite() && bpdf > 0.0).then_some(Known {
        j,
        wall,
        f: bweight * bpdf,
        p: bpdf,
    })
}

/// What [`leave`] reads of a point's microsurface: the map itself, or over the mirror
/// sawtooth one lane of the stream chunk's columns (`lanes`, points built without their map;
/// the same numbers, so the same operations on them).
trait Leaves {
    /// `w` (in facet `k`'s frame) in the shading frame.
    fn facet_to_world(&self, k: usize, w: Vec3) -> Vec3;
    /// Facet 1 is the sawtooth's mirror wall.
    fn mirror_wall(&self) -> bool;
    /// G1 of the microsurface ([`super::facets::Microsurface::g1`]).
    fn g1(&self, w: Vec3) -> f32;
    /// The mirror wall's reflection ([`MicrofacetNormalMap::reflect_wall`]).
    fn reflect_wall(&self, w: Vec3) -> Vec3;
}

impl Leaves for MicrofacetNormalMap {
    #[inline(always)]
    fn facet_to_world(&self, k: usize, w: Vec3) -> Vec3 {
        self.frames[k].to_world(w)
    }
    #[inline(always)]
    fn mirror_wall(&self) -> bool {
        self.mirror_wall
    }
    #[inline(always)]
    fn g1(&self, w: Vec3) -> f32 {
        self.surface.g1(w)
    }
    #[inline(always)]
    fn reflect_wall(&self, w: Vec3) -> Vec3 {
        MicrofacetNormalMap::reflect_wall(self, w)
    }
}

impl MicrofacetNormalMap {
    /// E_ms(ωi) of the compensated model at this shading point for the per-bounce colour
    /// `colour` (1 when the table has the colours baked in), and Ē_ms; `None` without a table
    /// (tests and measurements: the albedo identity ∫ f_ms z dωo = E_ms(ωi)).
    pub fn remainder_energy(&self, colour: Spectrum, wi: Vec3) -> Option<(Spectrum, Spectrum)> {
        let r = self.ms.as_ref()?;
        let k = r.table.coefficients(&r.cell, colour);
        let e = MsTable::remainder(&r.table.lookup(&r.cell, wi), &k);
        Some((e, r.table.mean_remainder(&r.cell, &k)))
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::explicit;
    use super::super::facets::Microgeometry;
    use super::super::{Evaluation, Tangent};
    use super::*;
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::bsdf::BsdfArena;

    /// `auto`'s blend band reports the walk's first-order density from the compensated first
    /// order's nested densities ([`FirstOrder::p_walk`]): bit for bit `explicit::pdf_mirror`
    /// (mirror sawtooth) and `pdf_single` (V-groove), which the band evaluated before, over a
    /// rough conductor (whose `eval_pdf` density is its `pdf`). The table's values do not enter
    /// (an exact Lambert table: instant).
    #[test]
    fn first_order_reports_the_walks_density_bit_for_bit() {
        let mut arena = BsdfArena::new();
        let n = arena.push(BsdfNode::RoughConductor(RoughConductor {
            distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
            eta: Vec3::new(0.2, 0.4, 1.4),
            k: Vec3::new(3.6, 2.4, 1.8),
            specular_reflectance: Vec3::ONE,
        }));
        let ctx = BsdfContext::default();
        let mut s = Sampler::from_seed(5, 1);
        for (geometry, tangent) in [
            (Microgeometry::Sawtooth, Tangent::Mirror),
            (Microgeometry::VGroove, Tangent::Same),
        ] {
            let table =
                MsTable::unit_lambert(geometry, tangent, super::super::ms_table::Colour::PerBounce);
            let (mut walls, mut checked) = (0, 0);
            for _ in 0..2000 {
                let wp = warp::square_to_uniform_cone(s.next_2d(), 70f32.to_radians().cos());
                let m = MicrofacetNormalMap::new(
                    n,
                    wp,
                    geometry,
                    tangent,
                    Evaluation::Compensated,
                    256,
                )
                .with_ms_table(Some(table));
                let Some(r) = m.ms.as_ref() else { continue };
                let nested = arena.bsdf(n);
                let wi = warp::square_to_cosine_hemisphere(s.next_2d());
                let wo = warp::square_to_cosine_hemisphere(s.next_2d());
                if wi.z <= 0.0 || wo.z <= 0.0 {
                    continue;
                }
                let (_, _, p_walk) = eval_pdf_walk(&m, r, &nested, &ctx, wi, wo, &mut s);
                let expected = if m.mirror_wall {
                    explicit::pdf_mirror(&m, &nested, &ctx, wi, wo)
                } else {
                    explicit::pdf_single(&m, &nested, &ctx, wi, wo)
                };
                assert_eq!(
                    p_walk.to_bits(),
                    expected.to_bits(),
                    "{geometry:?} {wp} {wi} {wo}"
                );
                checked += 1;
                walls += usize::from(m.mirror_wall && wo.dot(m.surface.normal(1)) > 0.0);
            }
            assert!(checked > 1900, "{checked}");
            assert!(
                geometry != Microgeometry::Sawtooth || walls > 300,
                "{walls} wall exits"
            );
        }
    }

    /// Nested BSDFs with a lane form for the first-order tests: a GGX rough conductor with
    /// visible-normal sampling, a Beckmann one without, a rough plastic (`compensated::lanes`'
    /// test and `walk_pdf_lanes`' use them too).
    pub(in crate::bsdf::mnm) fn push_reflectors(arena: &mut BsdfArena) -> [u32; 3] {
        [
            arena.push(BsdfNode::RoughConductor(RoughConductor {
                distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
                eta: Vec3::new(0.2, 0.4, 1.4),
                k: Vec3::new(3.6, 2.4, 1.8),
                specular_reflectance: Vec3::ONE,
            })),
            arena.push(BsdfNode::RoughConductor(RoughConductor {
                distribution: MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.3, false),
                eta: Vec3::new(0.2, 0.4, 1.4),
                k: Vec3::new(3.6, 2.4, 1.8),
                specular_reflectance: Vec3::new(1.0, 0.8, 0.6),
            })),
            arena.push(BsdfNode::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Ggx,
                0.3,
                true,
                Vec3::new(0.5, 0.2, 0.1),
                Vec3::ONE,
                1.5,
                1.0,
                false,
            ))),
        ]
    }

    // The first order as it was before the batch (commit 6b74181), the reference of
    // `batched_first_order_is_bit_for_bit_the_pair_by_pair_one`.
    fn old_first_order<const WALK: bool>(
        m: &MicrofacetNormalMap,
        e: &Entries,
        nested: &Bsdf,
        ctx: &BsdfContext,
        wo: Vec3,
        s: &mut Sampler,
        known: Option<Known>,
    ) -> FirstOrder {
        let nested = Nested::of(nested);
        let surf = &m.surface;
        let g1o = surf.g1(wo);
        let pdf_only = g1o <= 0.0;
        let mut v = Spectrum::ZERO;
        let mut p = 0.0;
        let mut pw = 0.0;
        let fp = |j: usize, wall: bool, b: Vec3, s: &mut Sampler| -> (Spectrum, f32) {
            match known {
                Some(kn) if kn.j == j && kn.wall == wall => (kn.f, kn.p),
                _ if pdf_only => (Spectrum::ZERO, nested.pdf(ctx, e.a[j], b)),
                _ => nested.eval_pdf(ctx, e.a[j], b, s),
            }
        };
        if m.mirror_wall {
            let fr = &m.frames[0];
            let bo = fr.to_local(wo);
            let exit_t = wall_exit(m, wo);
            for j in 0..e.len() {
                let w = e.w[j];
                let via_wall = e.via_wall(j);
                let (f, pd) = fp(j, false, bo, s);
                v += w * f;
                p += w * g1o * pd;
                if WALK {
                    pw += if via_wall { w * pd } else { w * g1o * pd };
                }
                if let Some((rb, bt)) = exit_t {
                    let (f, pd) = fp(j, true, rb, s);
                    v += (w * bt) * f;
                    p += w * bt * pd;
                    if WALK && !via_wall {
                        pw += w * bt * pd;
                    }
                }
            }
        } else {
            for j in 0..e.len() {
                let (k, lk) = (e.k[j] as usize, e.w[j]);
                let b = m.frames[k].to_local(wo);
                if !pdf_only && wo.dot(surf.normal(k)) > 0.0 {
                    let (f, pd) = fp(j, false, b, s);
                    v += lk * f;
                    p += lk * pd;
                } else {
                    let pd = match known {
                        Some(kn) if kn.j == j => kn.p,
                        _ => nested.pdf(ctx, e.a[j], b),
                    };
                    p += lk * pd;
                }
            }
            if WALK {
                pw = p;
            }
        }
        FirstOrder {
            f: v * g1o,
            p,
            p_walk: pw,
        }
    }

    /// The first order's density alone (`explicit::pdf_complete` / `pdf_single` from the entries).
    fn old_first_pdf(
        m: &MicrofacetNormalMap,
        e: &Entries,
        nested: &Bsdf,
        ctx: &BsdfContext,
        wo: Vec3,
    ) -> f32 {
        let nested = Nested::of(nested);
        let surf = &m.surface;
        let mut p = 0.0;
        if m.mirror_wall {
            let fr = &m.frames[0];
            let g1o = surf.g1(wo);
            let bo = fr.to_local(wo);
            let exit_t = wall_exit(m, wo);
            for j in 0..e.len() {
                let w = e.w[j];
                p += w * g1o * nested.pdf(ctx, e.a[j], bo);
                if let Some((rb, bt)) = exit_t {
                    p += w * bt * nested.pdf(ctx, e.a[j], rb);
                }
            }
        } else {
            for j in 0..e.len() {
                let k = e.k[j] as usize;
                p += e.w[j] * nested.pdf(ctx, e.a[j], m.frames[k].to_local(wo));
            }
        }
        p
    }

    /// The batched first order ([`super::nested_batch`]) equals the pair-by-pair one it
    /// replaced (kept above as `old_first_order` / `old_first_pdf`) bit for bit: eval, pdf and
    /// the walk's density, with and without a known (drawn) term, over diffuse, rough conductors
    /// (visible-normal sampling or not) and a rough plastic (lane forms), and a `twosided`
    /// (pair by pair), for the mirror sawtooth and the V-groove; random
    /// ωp, ωi, ωo. The table's values do not enter (an exact Lambert table: instant).
    #[test]
    fn batched_first_order_is_bit_for_bit_the_pair_by_pair_one() {
        fn bits(v: Vec3) -> [u32; 3] {
            v.to_array().map(f32::to_bits)
        }
        let mut arena = BsdfArena::new();
        let mut nodes = vec![arena.push(BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::new(0.7, 0.4, 0.2),
        }))];
        nodes.extend(push_reflectors(&mut arena));
        let c = nodes[1];
        nodes.push(arena.push(BsdfNode::TwoSided { front: c, back: c }));
        let ctx = BsdfContext::default();
        let mut s = Sampler::from_seed(9, 2);
        for n in nodes {
            for (geometry, tangent) in [
                (Microgeometry::Sawtooth, Tangent::Mirror),
                (Microgeometry::VGroove, Tangent::Same),
            ] {
                let (mut checked, mut four, mut with_known) = (0, 0, 0);
                for _ in 0..1500 {
                    let wp = warp::square_to_uniform_cone(s.next_2d(), 70f32.to_radians().cos());
                    let m = MicrofacetNormalMap::new(
                        n,
                        wp,
                        geometry,
                        tangent,
                        Evaluation::Compensated,
                        256,
                    );
                    let nested = arena.bsdf(n);
                    let wi = warp::square_to_cosine_hemisphere(s.next_2d());
                    let wo = warp::square_to_cosine_hemisphere(s.next_2d());
                    if m.degenerate || wi.z <= 0.0 || wo.z <= 0.0 {
                        continue;
                    }
                    let e = Entries::new(&m, wi);
                    let known = (e.len() > 0 && s.next_1d() < 0.5).then(|| Known {
                        j: ((s.next_1d() * e.len() as f32) as usize).min(e.len() - 1),
                        wall: m.mirror_wall && s.next_1d() < 0.5,
                        f: Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()),
                        p: s.next_1d(),
                    });
                    for kn in [None, known] {
                        let mut s1 = Sampler::from_seed(1, 1);
                        let mut s2 = Sampler::from_seed(1, 1);
                        let a = first_order::<true>(&m, &e, &nested, &ctx, wo, &mut s1, kn);
                        let b = old_first_order::<true>(&m, &e, &nested, &ctx, wo, &mut s2, kn);
                        let at = format!("{n:?} {geometry:?} {wp} {wi} {wo} {kn:?}");
                        assert_eq!(bits(a.f), bits(b.f), "{at}");
                        assert_eq!(a.p.to_bits(), b.p.to_bits(), "{at}");
                        assert_eq!(a.p_walk.to_bits(), b.p_walk.to_bits(), "{at}");
                        with_known += usize::from(kn.is_some());
                    }
                    let a = first_pdf(&m, &e, &nested, &ctx, wo);
                    let b = old_first_pdf(&m, &e, &nested, &ctx, wo);
                    assert_eq!(a.to_bits(), b.to_bits(), "{geometry:?} {wp} {wi} {wo}");
                    checked += 1;
                    four += usize::from(
                        m.mirror_wall && e.len() == 2 && wo.dot(m.surface.normal(1)) > 0.0,
                    );
                }
                assert!(checked > 1400, "{checked}");
                assert!(with_known > 600, "{with_known}");
                assert!(
                    geometry != Microgeometry::Sawtooth || four > 50,
                    "{four} four-path"
                );
            }
        }
    }
}
