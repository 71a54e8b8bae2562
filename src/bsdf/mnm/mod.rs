//! Microfacet-based normal mapping (Schüssler, Heitz, Hanika, Dachsbacher 2017, "Microfacet-based
//! Normal Mapping for Robust Monte Carlo Path Tracing") and its extensions. The spec with every
//! formula and decision is `docs/spec/mnm.md`; section numbers below refer to it.
//!
//! At each shading point the normal map's perturbed normal ωp defines a microsurface of a few
//! facets whose mean normal is the macro normal ωg (closure, [`facets`]). Light scatters on that
//! microsurface: every facet carries the nested BSDF, except the sawtooth's vertical wall when
//! `tangent = mirror` (the paper's model), which is a perfect mirror.
//!
//! - `evaluation = explicit`: paths of at most two vertices in closed form ([`explicit`]):
//!   Variant M (mirror wall: p→o, p→t→o, t→p→o; exact pdf) or single scattering (same).
//! - `evaluation = explicit4`: the complete first order, all four paths with one non-delta
//!   vertex (the paper's three plus t→p→t→o; exact pdf; issue 17 item 3).
//! - `evaluation = random_walk`: the Smith random walk on the microsurface ([`walk`]); sampling
//!   follows the walk, eval is its next-event estimate (stochastic, unbiased), the pdf for MIS is
//!   the approximate mixture of decision 3. Over a Lambertian nested BSDF the walk has exact
//!   closed forms, used instead of it ([`lambert`]: same BSDF, deterministic eval, exact pdf).
//! - `evaluation = compensated`: the complete first order plus a reciprocal rank-1 remainder
//!   whose per-order energies are tabulated from the walk ([`compensated`], [`ms_table`],
//!   [`ms_cache`]); deterministic, exact pdf. Over a Lambertian nested BSDF the walk's closed
//!   forms are used, as for the walk.
//! - `evaluation = auto`: per shading point, from the misplaced-energy table M(θp) of the
//!   compensated model against the walk ([`misplaced`]): compensated where M ≤ 2 %, the walk
//!   where M ≥ 4 %, the mixture β f_comp + (1 − β) f_walk in between (issue 17 item 5).
//!
//! Directions are in the macro shading frame (z = ωg). Over a transmitting nested BSDF (e.g.
//! `roughdielectric`) only the random walk exists: by default the reciprocal two-sided walk of
//! spec §9.3, or, for comparison, the student project's walk that ends at the first refraction
//! (§9.4, [`TransmissionWalk::ExitOnRefraction`]). Both report the walk's net η and leave the
//! 1/η² radiance scaling to the nested BSDF.
//!
//! The XML parameters and their defaults: `load.rs`.

pub mod compensated;
pub mod explicit;
pub mod facet_bsdf;
pub mod facets;
pub mod lambert;
pub(crate) mod lane_cols;
pub(crate) mod load;
pub(crate) mod map_view;
pub mod misplaced;
pub mod ms_cache;
pub mod ms_nested;
pub mod ms_table;
mod nested_batch;
pub mod walk;
mod walk_density_lanes;
pub(crate) mod walk_pdf_lanes;

use super::{Bsdf, BsdfContext, BsdfSample};
use crate::math::{Frame, INV_PI};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use facets::{Microgeometry, Microsurface, MAX_FACETS};
use glam::Vec3;

/// A perturbed normal whose x and y are both below this in magnitude counts as unperturbed
/// ([`MicrofacetNormalMap::is_flat`]; the stream kernel tests 8 lanes at once against it).
pub(crate) const FLAT: f32 = 1e-6;

/// Closed form or random walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluation {
    /// The paper's explicit model (Variant M over a mirror wall: three paths; single scattering
    /// otherwise).
    Explicit,
    /// The complete first order over a mirror wall: the paper's three paths plus t→p→t→o
    /// (`explicit4`; single scattering otherwise, which is already complete).
    ExplicitComplete,
    RandomWalk,
    /// The complete first order plus a reciprocal rank-1 remainder from per-order energy
    /// tables of the walk (issue 17 item 4, [`compensated`]); needs a table
    /// ([`MicrofacetNormalMap::with_ms_table`]), without one it is the random walk.
    Compensated,
    /// Per shading point the compensated model where its misplaced energy against the walk is
    /// small, the walk where it is large, a mixture across the band between ([`misplaced`];
    /// issue 17 item 5); needs a table with its M(θp) ([`MicrofacetNormalMap::with_ms_table`]),
    /// without one it is the random walk.
    Auto,
}

impl Evaluation {
    /// A deterministic closed form (`explicit`, `explicit4`).
    pub fn is_explicit(self) -> bool {
        matches!(self, Evaluation::Explicit | Evaluation::ExplicitComplete)
    }
}

/// What the sawtooth's vertical wall carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tangent {
    /// A perfect mirror (the paper's model).
    Mirror,
    /// The nested BSDF, like the perturbed facet.
    Same,
}

/// How the walk treats a refraction by the nested BSDF (spec §9.3, §9.4; decisions page
/// `transmission_walk`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransmissionWalk {
    /// The walker continues on the material side (masked by G1(−d), hitting facet undersides):
    /// reciprocal (§9.3).
    TwoSided,
    /// The student project's simplification (§9.4): the walk ends at the first refraction and
    /// returns the refracted direction without exit masking. Not reciprocal. A refraction that
    /// points back to the walk's starting side of the macro surface (failure mode (a), possible
    /// once the facet is tilted enough) is absorbed, identically in sample and eval: it is
    /// neither a transmission nor a masked reflection, and groove's strict side test compares
    /// geometric and shading normals only, so it would not catch it (on flat or analytic
    /// geometry the two agree) and the light would leak.
    ExitOnRefraction,
}

/// A microfacet normal-mapped BSDF at one shading point (plain values, built per hit).
#[derive(Clone, Copy, Debug)]
pub struct MicrofacetNormalMap {
    /// Arena index of the nested BSDF.
    pub nested: u32,
    /// Perturbed normal in the shading frame (already clamped to `max_theta`).
    pub wp: Vec3,
    surface: Microsurface,
    frames: [Frame; MAX_FACETS],
    /// Facet 1 is the sawtooth's mirror wall.
    mirror_wall: bool,
    pub evaluation: Evaluation,
    pub max_order: u32,
    /// ωp = ωg: the model reduces to the nested BSDF (delegated exactly, §2.5).
    degenerate: bool,
    /// Weight of the cosine lobe in the walk's MIS pdf (decision 3); computed in [`Self::new`]
    /// only for the random walk (the explicit closed forms need it only over transmitting
    /// nested BSDFs, where [`Self::mis_c`] computes it on demand).
    mis_c: Option<f32>,
    /// Only used over transmitting nested BSDFs.
    pub transmission_walk: TransmissionWalk,
    /// The microgeometry `surface` was built from (`None` for [`Self::with_surface`]).
    geometry: Option<Microgeometry>,
    /// Use the Lambert closed forms when the nested BSDF is diffuse (default true).
    lambert_closed_form: bool,
    /// The walk's closed form over the nested Lambertian ([`lambert`]), as an index into the
    /// arena's side table, set by [`crate::bsdf::BsdfArena::push_microfacet_normal_map`]. (An
    /// index, not the form itself: the form is ~140 bytes that every hit would copy twice.)
    lambert: Option<u32>,
    /// `evaluation = compensated`: the remainder table and this point's place in it
    /// ([`Self::with_ms_table`]).
    ms: Option<compensated::MsRef>,
    /// `evaluation = auto`: the compensated model's share β of the mixture (1 otherwise; with
    /// `ms` = None the walk evaluates).
    blend: f32,
}

impl MicrofacetNormalMap {
    /// `wp` must be unit with `wp.z > 0` (see [`facets::clamp_perturbed_normal`]).
    ///
    /// This and the `with_*` steps after it are built once per hit as one chain of moves of a
    /// ~400-byte value: always inlined, so that the chain is built in place (out of line, each
    /// step was a call and a copy of the whole model).
    #[inline(always)]
    pub fn new(
        nested: u32,
        wp: Vec3,
        geometry: Microgeometry,
        tangent: Tangent,
        evaluation: Evaluation,
        max_order: u32,
    ) -> Self {
        // Reference guard (§2.5): no perturbation → the nested BSDF in the macro frame.
        let degenerate = Self::is_flat(wp);
        let surface = Microsurface::new(geometry, if degenerate { Vec3::Z } else { wp });
        Self::assemble(
            nested,
            wp,
            degenerate,
            surface,
            geometry,
            tangent,
            evaluation,
            max_order,
            // Tangent along the shading frame's s (= dp/du), as Mitsuba's normalmap does.
            |surface, k| Frame::from_normal_tangent(surface.normal(k), Vec3::X),
        )
    }

    /// The map of [`Self::new`] and [`Self::of_lane`] from its microsurface; `frame(surface,
    /// k)`: facet `k`'s frame.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn assemble(
        nested: u32,
        wp: Vec3,
        degenerate: bool,
        surface: Microsurface,
        geometry: Microgeometry,
        tangent: Tangent,
        evaluation: Evaluation,
        max_order: u32,
        mut frame: impl FnMut(&Microsurface, usize) -> Frame,
    ) -> Self {
        let mirror_wall =
            geometry == Microgeometry::Sawtooth && tangent == Tangent::Mirror && surface.len() == 2;
        let mut frames = [Frame::from_normal(Vec3::Z); MAX_FACETS];
        // Only facets that carry the nested BSDF get a frame: the mirror wall is never queried
        // in one (every nested query goes through `facet_bsdf.rs`, which never sees it), and
        // its frame was a normalisation and a Gram–Schmidt step per hit for nothing.
        let carrying = if mirror_wall { 1 } else { surface.len() };
        for (k, f) in frames.iter_mut().enumerate().take(carrying) {
            *f = frame(&surface, k);
        }
        let mis_c =
            matches!(evaluation, Evaluation::RandomWalk | Evaluation::Auto).then(|| mis_weight(wp));
        MicrofacetNormalMap {
            nested,
            wp,
            surface,
            frames,
            mirror_wall,
            evaluation,
            max_order: max_order.max(1),
            degenerate,
            mis_c,
            transmission_walk: TransmissionWalk::TwoSided,
            geometry: Some(geometry),
            lambert_closed_form: true,
            lambert: None,
            ms: None,
            blend: 1.0,
        }
    }

    /// Whether the perturbed normal `wp` counts as unperturbed (the reference guard, §2.5).
    #[inline(always)]
    pub(crate) fn is_flat(wp: Vec3) -> bool {
        wp.x.abs() < FLAT && wp.y.abs() < FLAT
    }

    /// How many of a microgeometry's candidate facets may carry the nested BSDF and so get a
    /// frame ([`facets::Candidates::new`]'s `framed`): the sawtooth's first facet only under
    /// the mirror wall, else all.
    #[inline(always)]
    pub(crate) fn framed(geometry: Microgeometry, tangent: Tangent) -> usize {
        if geometry == Microgeometry::Sawtooth && tangent == Tangent::Mirror {
            1
        } else {
            MAX_FACETS
        }
    }

    /// [`Self::new`] for lane `i` of `facets`, the candidates built for the perturbed normals
    /// (per lane: +z where [`Self::is_flat`]) with [`Self::framed`] frames, stored
    /// ([`facets::Candidates::cols`]); `wp`: lane `i`'s
    /// perturbed normal. Several points' candidates are built at once by the stream
    /// renderer's compensated kernel (the same map as [`Self::new`] bit for bit: `tests` of
    /// `facets.rs`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn of_lane<const W: usize>(
        nested: u32,
        wp: Vec3,
        facets: &facets::FacetCols<W>,
        i: usize,
        geometry: Microgeometry,
        tangent: Tangent,
        evaluation: Evaluation,
        max_order: u32,
    ) -> Self {
        let degenerate = Self::is_flat(wp);
        let (surface, from) = Microsurface::of_lane(facets, i);
        Self::assemble(
            nested,
            wp,
            degenerate,
            surface,
            geometry,
            tangent,
            evaluation,
            max_order,
            |surface, k| surface.frame_of_lane(facets, &from, i, k),
        )
    }

    /// Attach the remainder table of `evaluation = compensated` ([`ms_table`]; built for this
    /// nested BSDF, microgeometry, wall and `max_order`). Without a table (or for another
    /// evaluation) nothing changes: a compensated BSDF without one is the random walk.
    ///
    /// Under `evaluation = auto` the table's misplaced energy at this θp sets the blend β
    /// ([`misplaced::blend`]); β = 0, or a table without M, leaves the walk.
    #[inline(always)]
    pub fn with_ms_table(mut self, table: Option<&'static ms_table::MsTable>) -> Self {
        self.set_ms_table(table);
        self
    }

    /// [`Self::with_ms_table`] in place (the arena's in-place build,
    /// [`crate::bsdf::BsdfArena::push_microfacet_normal_map_with`]).
    #[inline(always)]
    pub fn set_ms_table(&mut self, table: Option<&'static ms_table::MsTable>) {
        if self.degenerate {
            return;
        }
        match self.evaluation {
            Evaluation::Compensated => {
                self.ms = table.map(|t| compensated::MsRef::new(t, self.wp));
            }
            Evaluation::Auto => {
                let Some(t) = table else { return };
                let beta = t
                    .misplaced
                    .get()
                    .map_or(0.0, |mm| misplaced::blend(mm.at(self.wp.z)));
                self.set_blend(t, beta);
            }
            _ => {}
        }
    }

    /// [`Self::set_ms_table`] with ωp's θp cell `cell` (the table's
    /// [`ms_table::MsTable::cell`] of ωp, found for several points at once): under
    /// `evaluation = compensated` the table's reference in that cell, else `set_ms_table`.
    #[inline(always)]
    pub(crate) fn set_ms_table_in(
        &mut self,
        table: Option<&'static ms_table::MsTable>,
        cell: ms_table::ThetaCell,
    ) {
        match (self.degenerate, self.evaluation) {
            (true, _) => {}
            (false, Evaluation::Compensated) => {
                self.ms = table.map(|t| compensated::MsRef::in_cell(t, cell));
            }
            _ => self.set_ms_table(table),
        }
    }

    /// A map for an arena slot that is about to be overwritten (the flat microsurface).
    #[inline(never)]
    pub(crate) fn placeholder() -> Self {
        Self::new(
            0,
            Vec3::Z,
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Explicit,
            1,
        )
    }

    /// `evaluation = auto` with the blend β forced (tests of the mixture; β ∈ [0, 1]).
    pub fn with_blend(mut self, table: &'static ms_table::MsTable, beta: f32) -> Self {
        if self.evaluation == Evaluation::Auto && !self.degenerate {
            self.set_blend(table, beta.clamp(0.0, 1.0));
        }
        self
    }

    #[inline(always)]
    fn set_blend(&mut self, t: &'static ms_table::MsTable, beta: f32) {
        self.blend = beta;
        self.ms = (beta > 0.0).then(|| compensated::MsRef::new(t, self.wp));
    }

    /// True when the compensated model (with its table) evaluates this BSDF, alone or (under
    /// `auto`) in a mixture with the walk.
    pub fn uses_ms_table(&self) -> bool {
        self.ms.is_some()
    }

    /// The compensated model's share of the BSDF: 1 for `compensated` with a table, β under
    /// `auto`, 0 when the walk (or a closed form) evaluates alone.
    pub fn compensated_share(&self) -> f32 {
        if self.ms.is_some() {
            self.blend
        } else {
            0.0
        }
    }

    /// The same BSDF with the Lambert closed forms on (default) or off: off, a diffuse nested
    /// BSDF runs the random walk (tests that compare the two).
    #[inline]
    pub fn with_lambert_closed_form(mut self, on: bool) -> Self {
        self.set_lambert_closed_form(on);
        self
    }

    /// [`Self::with_lambert_closed_form`] in place.
    #[inline(always)]
    pub fn set_lambert_closed_form(&mut self, on: bool) {
        self.lambert_closed_form = on;
    }

    /// Point at the closed form over the nested Lambertian, entry `i` of the arena's table
    /// ([`lambert::LambertForm::new`] decides whether one applies). Called by the arena when it
    /// stores this BSDF over a `diffuse` (or a `twosided` whose front is one: the walk queries
    /// facets from their front only).
    pub(crate) fn set_lambert(&mut self, i: u32) {
        self.lambert = Some(i);
    }

    /// True when a closed form over a Lambertian stands in for the random walk.
    pub fn uses_lambert_closed_form(&self) -> bool {
        self.lambert.is_some()
    }

    /// True when the nested BSDF transmits (the two-sided walk applies).
    #[inline]
    fn transmits(&self, nested: &Bsdf) -> bool {
        nested.lobes().has_transmission()
    }

    /// Weight c of the cosine lobe in the MIS pdf (decision 3).
    #[inline]
    fn mis_c(&self) -> f32 {
        match self.mis_c {
            Some(c) => c,
            None => mis_weight(self.wp),
        }
    }

    /// The same BSDF with another transmission walk (default: two-sided).
    #[inline]
    pub fn with_transmission_walk(mut self, walk: TransmissionWalk) -> Self {
        self.transmission_walk = walk;
        self
    }

    /// A random-walk BSDF on an explicit microsurface whose facets all carry the nested BSDF
    /// (experiments: other facet sets, broken closures). `wp` only sets the MIS lobe weight.
    pub fn with_surface(nested: u32, wp: Vec3, surface: Microsurface, max_order: u32) -> Self {
        let mut m = Self::new(
            nested,
            wp,
            Microgeometry::VGroove,
            Tangent::Same,
            Evaluation::RandomWalk,
            max_order,
        );
        m.surface = surface;
        m.degenerate = false;
        m.geometry = None;
        for k in 0..surface.len() {
            m.frames[k] = Frame::from_normal_tangent(surface.normal(k), Vec3::X);
        }
        m
    }
}

/// Decision 3's cosine-lobe weight c = 0.2 · min(1, θp / 15°). At θp ≥ 15° (cos θp ≤ cos 15°)
/// it is 0.2 without the `acos`.
fn mis_weight(wp: Vec3) -> f32 {
    const COS_15: f32 = 0.965_925_8;
    if wp.z <= COS_15 {
        return 0.2;
    }
    let theta_p = wp.z.clamp(-1.0, 1.0).acos();
    0.2 * (theta_p / 15f32.to_radians()).min(1.0)
}

pub(super) fn eval(
    b: Bsdf,
    m: &MicrofacetNormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    let nested = b.child(m.nested);
    if m.degenerate {
        return nested.eval(ctx, wi, wo, s);
    }
    if m.transmits(&nested) {
        if wi.z == 0.0 || wo.z == 0.0 {
            return Spectrum::ZERO;
        }
        return walk::eval_t(m, &nested, ctx, wi, wo, s);
    }
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Spectrum::ZERO;
    }
    if let Some(l) = m.lambert.map(|i| &b.arena.lambert[i as usize]) {
        return l.eval(m, wi, wo);
    }
    if let Some(r) = &m.ms {
        // `auto` in its blend band: one model by its share β, so that E[eval] = β f_comp +
        // (1 − β) f_walk at the cost of one model (the walk's eval is stochastic anyway).
        if m.blend >= 1.0 || s.next_1d() < m.blend {
            return compensated::eval_pdf(m, r, &nested, ctx, wi, wo, s).0;
        }
        return walk::eval(m, &nested, ctx, wi, wo, s, &mut explicit::PdfTerms::empty());
    }
    match (m.evaluation, m.mirror_wall) {
        (Evaluation::Explicit, true) => explicit::eval_pdf_mirror(m, &nested, ctx, wi, wo, s).0,
        (Evaluation::ExplicitComplete, true) => {
            explicit::eval_pdf_complete(m, &nested, ctx, wi, wo, s).0
        }
        (Evaluation::Explicit | Evaluation::ExplicitComplete, false) => {
            explicit::eval_pdf_single(m, &nested, ctx, wi, wo, s).0
        }
        (Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto, _) => {
            walk::eval(m, &nested, ctx, wi, wo, s, &mut explicit::PdfTerms::empty())
        }
    }
}

pub(super) fn pdf(b: Bsdf, m: &MicrofacetNormalMap, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let nested = b.child(m.nested);
    if m.degenerate {
        return nested.pdf(ctx, wi, wo);
    }
    if m.transmits(&nested) {
        if wi.z == 0.0 || wo.z == 0.0 {
            return 0.0;
        }
        // Decision 3 with the cosine lobe split over both hemispheres.
        let p1 = walk::single_scatter_pdf_t(m, &nested, ctx, wi, wo);
        return (1.0 - m.mis_c()) * p1 + m.mis_c() * 0.5 * wo.z.abs() * INV_PI;
    }
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    if let Some(l) = m.lambert.map(|i| &b.arena.lambert[i as usize]) {
        return l.pdf(m, wi, wo);
    }
    if let Some(r) = &m.ms {
        let pc = compensated::pdf(m, r, &nested, ctx, wi, wo);
        if m.blend >= 1.0 {
            return pc;
        }
        return mixture_pdf(m.blend, pc, walk_pdf(m, &nested, ctx, wi, wo));
    }
    walk_or_explicit_pdf(m, &nested, ctx, wi, wo)
}

/// The mixture's density β p_comp + (1 − β) p_walk of `auto`'s blend band (0 < β < 1): what
/// [`pdf`] returns, and the MIS density that [`sample`] and [`eval_pdf`] report when they pick
/// the compensated model (probability β; the walk's p_walk then comes from the compensated
/// pass's own nested densities, almost free). When they pick the walk they report the walk's
/// own MIS density p_walk (decision 3): the compensated model's would cost a second model's
/// pass per query (≈ 600–700 instructions, `docs/mnm.md`).
///
/// Why MIS stays unbiased: let q_b(ωo) be branch b's reported density (a fixed function of ωo
/// per branch) and p_L the light's. BSDF sampling contributes, per ωo, Σ_b β_b f_b q_b / (q_b +
/// p_L) (branch b's sample has E[weight · 1_A] = ∫_A f_b z, and its MIS weight depends on ωo
/// only), next-event estimation Σ_b β_b f_b p_L / (p_L + q_b) (its eval picks b with the same
/// probabilities); the sum is Σ_b β_b f_b = f for any q_b, because both strategies use the same
/// q_b within a branch (the weights of a direction sum to 1 per branch; Veach 1997 §9.2 with the
/// branch as part of the sample). [`pdf`] (no random number, so no branch) is the mixture's true
/// density; a composite must pair a child's `sample` with its `eval_pdf` (as `mask`, `twosided`
/// and `normalmap` do) or override the sample's density with the child's `pdf` (`blendbsdf`).
/// Tested: `tests/bsdf/mnm_auto.rs`, `blend_band_mis_is_unbiased`.
#[inline]
fn mixture_pdf(beta: f32, p_comp: f32, p_walk: f32) -> f32 {
    beta * p_comp + (1.0 - beta) * p_walk
}

/// The walk's MIS density of decision 3 (the random walk, and `auto`'s walk share).
fn walk_pdf(m: &MicrofacetNormalMap, nested: &Bsdf, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let p1 = if m.mirror_wall {
        explicit::pdf_mirror(m, nested, ctx, wi, wo)
    } else {
        explicit::pdf_single(m, nested, ctx, wi, wo)
    };
    walk_mis_pdf(m, p1, wo)
}

/// Decision 3's mixture from the walk's first-order density `p1` at ωo.
#[inline]
fn walk_mis_pdf(m: &MicrofacetNormalMap, p1: f32, wo: Vec3) -> f32 {
    (1.0 - m.mis_c()) * p1 + m.mis_c() * wo.z * INV_PI
}

/// [`pdf`] of the explicit forms and the walk (reflection, no table).
fn walk_or_explicit_pdf(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    let p1 = match (m.mirror_wall, m.evaluation) {
        (true, Evaluation::ExplicitComplete) => explicit::pdf_complete(m, nested, ctx, wi, wo),
        (true, _) => explicit::pdf_mirror(m, nested, ctx, wi, wo),
        (false, _) => explicit::pdf_single(m, nested, ctx, wi, wo),
    };
    match m.evaluation {
        Evaluation::Explicit | Evaluation::ExplicitComplete => p1,
        // Decision 3: (1 − c)·p1 + c·cosine lobe; MIS stays unbiased with any such pdf
        // because the integrator uses the walk's own sample weight.
        Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto => {
            (1.0 - m.mis_c()) * p1 + m.mis_c() * wo.z * INV_PI
        }
    }
}

/// The compensated model alone at root `b` (a microfacet normal map): `Some` exactly when
/// [`eval_pdf`] (at ωi, ωo both above the surface) and [`sample`] (at ωi above it) reach
/// `compensated::eval_pdf` / `compensated::sample` — not degenerate, a reflecting nested BSDF,
/// no Lambert closed form, a table and β = 1. The stream kernel's 8-wide form
/// ([`compensated::lanes`]) starts from it.
#[inline]
pub(crate) fn compensated_alone<'a>(
    b: Bsdf<'a>,
) -> Option<(&'a MicrofacetNormalMap, &'a compensated::MsRef, Bsdf<'a>)> {
    let super::BsdfNode::MicrofacetNormalMap { map, .. } = b.node() else {
        return None;
    };
    let m = &b.arena.mnm[*map as usize];
    let nested = b.child(m.nested);
    if m.degenerate || m.transmits(&nested) || m.lambert.is_some() || m.blend < 1.0 {
        return None;
    }
    Some((m, m.ms.as_ref()?, nested))
}

/// The random walk alone at root `b` (a microfacet normal map) seen from `wi`: `Some` (the
/// map and its nested BSDF) exactly where [`sample`] reaches [`walk_sample`] — not
/// degenerate, a reflecting nested BSDF, ωi above the surface (a NaN ωi.z too is left out:
/// the caller's scalar path answers it), no Lambert closed form, no table, an evaluation
/// that walks. The stream kernel's walks 8 at a time (`compensated::lanes::walk`) start
/// from it.
#[inline]
pub(crate) fn walk_alone<'a>(b: Bsdf<'a>, wi: Vec3) -> Option<(&'a MicrofacetNormalMap, Bsdf<'a>)> {
    let super::BsdfNode::MicrofacetNormalMap { map, .. } = b.node() else {
        return None;
    };
    let m = &b.arena.mnm[*map as usize];
    let nested = b.child(m.nested);
    if m.degenerate
        || m.transmits(&nested)
        || wi.z.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        || m.lambert.is_some()
        || m.ms.is_some()
    {
        return None;
    }
    matches!(
        m.evaluation,
        Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto
    )
    .then_some((m, nested))
}

/// The two-sided (or early-exit) walk at root `b` (a microfacet normal map) seen from `wi`:
/// `Some` (the map and its nested BSDF) exactly where [`sample`] reaches [`walk::sample_t`] —
/// not degenerate, a transmitting nested BSDF, ωi not in the surface's plane (a NaN ωi.z is
/// left out too: the caller's scalar path answers it). The stream kernel's two-sided walks 8
/// at a time (`compensated::lanes::walk`) start from it.
#[inline]
pub(crate) fn walk_two_sided<'a>(
    b: Bsdf<'a>,
    wi: Vec3,
) -> Option<(&'a MicrofacetNormalMap, Bsdf<'a>)> {
    let super::BsdfNode::MicrofacetNormalMap { map, .. } = b.node() else {
        return None;
    };
    let m = &b.arena.mnm[*map as usize];
    let nested = b.child(m.nested);
    (!m.degenerate && m.transmits(&nested) && wi.z != 0.0 && !wi.z.is_nan()).then_some((m, nested))
}

/// Eval and pdf of one query (next-event estimation); equal to [`eval`] and [`pdf`] called
/// separately up to rounding. The closed forms evaluate each path's nested BSDF once for both
/// ([`explicit::eval_pdf_mirror`], [`explicit::eval_pdf_single`]); the random walk shares the
/// nested evaluations of its first vertices with the MIS density ([`explicit::PdfTerms`]).
pub(super) fn eval_pdf(
    b: Bsdf,
    m: &MicrofacetNormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let nested = b.child(m.nested);
    if m.degenerate {
        return nested.eval_pdf(ctx, wi, wo, s);
    }
    if m.transmits(&nested) {
        return (eval(b, m, ctx, wi, wo, s), pdf(b, m, ctx, wi, wo));
    }
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return (Spectrum::ZERO, 0.0);
    }
    if let Some(l) = m.lambert.map(|i| &b.arena.lambert[i as usize]) {
        return l.eval_pdf(m, wi, wo);
    }
    if let Some(r) = &m.ms {
        if m.blend >= 1.0 {
            return compensated::eval_pdf(m, r, &nested, ctx, wi, wo, s);
        }
        // The blend band: the eval of one model picked by β (as [`eval`]) with that branch's
        // MIS density ([`mixture_pdf`]), the same function of ωo that [`sample`]'s branch
        // reports.
        let b = m.blend;
        return if s.next_1d() < b {
            // The walk's density from the same nested densities as the compensated one.
            let (fc, pc, p1) = compensated::eval_pdf_walk(m, r, &nested, ctx, wi, wo, s);
            (fc, mixture_pdf(b, pc, walk_mis_pdf(m, p1, wo)))
        } else {
            walk_eval_pdf(m, &nested, ctx, wi, wo, s)
        };
    }
    if matches!(
        m.evaluation,
        Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto
    ) {
        return walk_eval_pdf(m, &nested, ctx, wi, wo, s);
    }
    match (m.mirror_wall, m.evaluation) {
        (true, Evaluation::ExplicitComplete) => {
            explicit::eval_pdf_complete(m, &nested, ctx, wi, wo, s)
        }
        (true, _) => explicit::eval_pdf_mirror(m, &nested, ctx, wi, wo, s),
        (false, _) => explicit::eval_pdf_single(m, &nested, ctx, wi, wo, s),
    }
}

/// The walk's eval and MIS density of one query (reflection).
fn walk_eval_pdf(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    // The walk's first vertices evaluate the nested BSDF at pairs that are terms of p1:
    // those terms take their pdf from the same fused call.
    let mut terms = if m.mirror_wall {
        explicit::PdfTerms::mirror(m, wi, wo)
    } else {
        explicit::PdfTerms::single(m, wi, wo)
    };
    let f = walk::eval(m, nested, ctx, wi, wo, s, &mut terms);
    let p1 = terms.total(m, nested, ctx);
    let c = m.mis_c();
    (f, (1.0 - c) * p1 + c * wo.z * INV_PI)
}

pub(super) fn sample(
    b: Bsdf,
    m: &MicrofacetNormalMap,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let nested = b.child(m.nested);
    if m.degenerate {
        return nested.sample(ctx, wi, s);
    }
    if m.transmits(&nested) {
        if wi.z == 0.0 {
            return None;
        }
        let (wo, weight, eta, lobe) = walk::sample_t(m, &nested, ctx, wi, s)?;
        return Some(BsdfSample {
            wo,
            pdf: pdf(b, m, ctx, wi, wo),
            weight,
            eta,
            lobe,
        });
    }
    if wi.z <= 0.0 {
        return None;
    }
    if let Some(l) = m.lambert.map(|i| &b.arena.lambert[i as usize]) {
        let (wo, weight, pdf) = l.sample(m, wi, s)?;
        return Some(BsdfSample {
            wo,
            pdf,
            weight,
            eta: 1.0,
            lobe: explicit::lobe_of(nested.lobes()),
        });
    }
    if let Some(r) = &m.ms {
        if m.blend >= 1.0 {
            return compensated::sample(m, r, &nested, ctx, wi, s);
        }
        // `auto` in its blend band: one model by its share, each with its own weight (the
        // compensated model's eval/pdf, the walk's throughput), so E[weight · 1{ωo ∈ A}] =
        // β ∫_A f_comp z + (1 − β) ∫_A f_walk z; the reported density is the branch's MIS
        // density ([`mixture_pdf`]), as [`eval_pdf`]'s branch reports it.
        let beta = m.blend;
        return if s.next_1d() < beta {
            let (mut bs, p1) = compensated::sample_walk(m, r, &nested, ctx, wi, s)?;
            bs.pdf = mixture_pdf(beta, bs.pdf, walk_mis_pdf(m, p1, bs.wo));
            Some(bs)
        } else {
            walk_sample(m, &nested, ctx, wi, s)
        };
    }
    match (m.evaluation, m.mirror_wall) {
        (Evaluation::Explicit, true) => explicit::sample_mirror(m, &nested, ctx, wi, s),
        (Evaluation::ExplicitComplete, true) => explicit::sample_complete(m, &nested, ctx, wi, s),
        (Evaluation::Explicit | Evaluation::ExplicitComplete, false) => {
            explicit::sample_single(m, &nested, ctx, wi, s)
        }
        (Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto, _) => {
            walk_sample(m, &nested, ctx, wi, s)
        }
    }
}

/// A sample of the random walk (reflection), with the MIS density of decision 3.
fn walk_sample(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let (wo, weight, lobe, first) = walk::sample(m, nested, ctx, wi, s)?;
    Some(walk_sample_of(m, nested, ctx, wi, wo, weight, lobe, first))
}

/// [`walk_sample`]'s sample from its walk's results (ωo, throughput, lobe, first vertex):
/// the MIS density of decision 3 with the first vertex's term known. The walks run 8 at a
/// time (`compensated::lanes::walk`) report the same density with their nested densities in
/// 8-wide calls (`walk_density_lanes::reflection_pdfs`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn walk_sample_of(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    weight: Spectrum,
    lobe: super::Lobes,
    first: Option<walk::FirstVertex>,
) -> BsdfSample {
    // The walk escapes upward only (G1 = 0 below), so `pdf`'s wo.z ≤ 0 case is moot.
    let mut terms = if m.mirror_wall {
        explicit::PdfTerms::mirror(m, wi, wo)
    } else {
        explicit::PdfTerms::single(m, wi, wo)
    };
    // A walk that escaped from its first vertex sampled ωo with the nested BSDF from ωi:
    // its sample density is the term P_k(ωi, ωo) (not for delta lobes, whose sample
    // density is no pdf value).
    if let Some(v) = first {
        if !nested.lobes().has_delta() {
            terms.know(v.k, wi, wo, v.pdf);
        }
    }
    let p1 = terms.total(m, nested, ctx);
    let c = m.mis_c();
    BsdfSample {
        wo,
        pdf: (1.0 - c) * p1 + c * wo.z * INV_PI,
        weight,
        eta: 1.0,
        lobe,
    }
}
