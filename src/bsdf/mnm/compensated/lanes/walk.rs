//! The random walk's sample ([`crate::bsdf::mnm::walk::sample_counted`]) of up to 8 shading
//! points at once, one lane per point (issue 18: "the random walks may run as masked loops or
//! fall back to the 1-lane kernel lane by lane"): the stream kernel's points whose BSDF is a
//! microfacet normal map that samples by the reflection walk ([`crate::bsdf::mnm::walk_alone`])
//! over a shared `roughconductor` or `roughplastic` leaf walk together, each lane active until
//! its own walk ends (escaped, absorbed, or `max_order` vertices), the chunk looping until no
//! lane is.
//!
//! Per iteration, as the scalar loop: over the mirror wall the reflection; else the nested
//! sample in the facet's frame (the map's stored frames, the same bits), asked of all the
//! lanes at a nested vertex in one 8-wide call of the leaf's lane form ([`super::sample`]:
//! bit for bit `Bsdf::sample` with its rejection of degenerate samples); the exit test
//! against G1(d); the next facet picked ∝ a_j(−d) (the lane forms of
//! [`crate::bsdf::mnm::facets::SurfaceLanes`]). Each lane draws from its own stream only while
//! active, in the scalar order (entry pick; the nested sample's numbers; exit; pick), as
//! masked 8-wide PCG32 steps on the batch's columns ([`super::draws`]); a stream whose 2-D
//! draw is still stratified draws it alone (`Samplers::next_2d`). The walks' ends are counted
//! as the scalar walk counts them (`Bsdf::record_walk`, the bench's mean walk length), and
//! each escaped walk's MIS density is the scalar one's (`mnm::walk_sample_of`'s) from the
//! walk's results, its nested densities in 8-wide calls (`mnm::walk_density_lanes`). So every
//! lane's sample and stream end where the scalar `Bsdf::sample` leaves them (`tests`).
//!
//! The two-sided walk over a transmitting leaf ([`crate::bsdf::mnm::walk::sample_t`], spec
//! §9.2–9.4; [`crate::bsdf::mnm::walk_two_sided`]) runs the same way for the lanes over a
//! shared `roughdielectric` leaf ([`walk8_t`]): the entry from ωi's side, the side-dependent
//! exit test and pick, η multiplied in, the early-exit walk's end at a refraction; its
//! density is the scalar `pdf` of each lane's map as `mnm::sample` computes it, 8-wide after
//! the walk (`mnm::walk_density_lanes`).
//!
//! Here rather than beside `walk.rs`: it reuses this module's private pieces (the nested
//! lane samples [`super::sample::Asks`], the masked draws [`super::draws`]).

use super::super::Nested;
use super::draws::{step, stratified};
use super::sample::{accepted, draws_u1, Asks};
use super::Cols;
use crate::bsdf::mnm::facets::{FacetCols, SurfaceLanes, MAX_FACETS};
use crate::bsdf::mnm::map_view::{ColMap, MapRef, MapView};
use crate::bsdf::mnm::walk::FirstVertex;
use crate::bsdf::mnm::walk_density_lanes::{
    reflection_pdfs, two_sided_p1, two_sided_pdf, Escaped, ReflectionCols, TwoSidedCols,
};
use crate::bsdf::mnm::walk_pdf_lanes::WalkEvalsBuf;
use crate::bsdf::mnm::{explicit::lobe_of, walk_alone, MicrofacetNormalMap};
use crate::bsdf::mnm::{walk_two_sided, TransmissionWalk};
use crate::bsdf::roughdielectric::RoughDielectric;
use crate::bsdf::{accept_sample, Bsdf, BsdfContext, BsdfNode, BsdfSample, Lobes, TransportMode};
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::pcg::Pcg;
use crate::lane::vec::{V2, V3};
use crate::lane::{Avx2, F32x8, I32x8, Lane, U64x8, M8};
use crate::sampler::Samplers;
use glam::Vec3;

/// The samples of [`sample_walks_x8`]: bit k of `lanes`, lane k walked here (its sample, or
/// `None`, in `out[k]`: what `Bsdf::sample` of its root returns); the other lanes are left to
/// the caller.
pub(crate) struct WalkSamples {
    pub lanes: u8,
    pub out: [Option<BsdfSample>; 8],
}

impl WalkSamples {
    /// No lane walked.
    #[inline(always)]
    pub(crate) fn none() -> Self {
        WalkSamples {
            lanes: 0,
            out: [None; 8],
        }
    }
}

/// Which of [`sample_walks_x8`]'s two walk groups a call looks for. A lane walks by
/// reflection only over a reflecting nested BSDF ([`walk_alone`]) and two-sided only over a
/// transmitting one ([`walk_two_sided`]); the stream kernel's chunk is one material, whose
/// nested node's lobes (`Materials::lobes`, the arena node's too) say which, so it asks for
/// that group alone ([`Self::of_lobes`]) and skips the other's scan of the lanes (~40
/// instructions a sample on the reflection scenes, the fortieth session's h3). Both groups:
/// chunks of maps over different nested BSDFs, as the tests mix them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct WalkGroups {
    /// The reflection walks ([`reflection_walks`]).
    pub reflection: bool,
    /// The two-sided walks ([`two_sided_walks`]).
    pub two_sided: bool,
}

impl WalkGroups {
    /// The group of the maps over a nested BSDF with `lobes`: the two-sided walk where it
    /// transmits (as `MicrofacetNormalMap::transmits` tests it), else the reflection walk.
    #[inline(always)]
    pub(crate) fn of_lobes(lobes: Lobes) -> Self {
        let two_sided = lobes.has_transmission();
        WalkGroups {
            reflection: !two_sided,
            two_sided,
        }
    }
}

/// The chunk's facet columns from the build (the stream kernel's `MnmCols`: the candidates'
/// area vectors, normals and frames of 8 hits, `MnmSettings::lanes_at`) and the lanes whose
/// maps were written from them (bit k: lane k's map is `MnmSettings::map_lane_into` of lane
/// k). The walks read a walking lane's facets and frames from these columns, 8-wide as they
/// are, instead of from its map, where every walking lane's map was written from them and
/// keeps every candidate ([`cols_of`]).
#[derive(Clone, Copy)]
pub(crate) struct BuiltFacets<'c> {
    pub facets: &'c FacetCols<8>,
    pub lanes: u8,
    /// The lanes built without a map (the stream kernel's walking lanes over a shared
    /// reflecting leaf, not flat, ωi above the surface): their views of these columns
    /// (`map_view::ColMap`), which stand for their maps; such a lane's point (`pts`) is the
    /// nested leaf itself, and it walks by reflection here.
    pub views: Option<&'c [Option<ColMap<'c>>; 8]>,
}

/// The build's columns for the walking lanes `walking`, where they hold those lanes' maps'
/// numbers bit for bit: every walking lane's map written from them (`built.lanes`) and
/// keeping all the microgeometry's candidates (`FacetCols::keeps`, 8-wide): then the map's
/// facets are the candidates in order (`Microsurface::of_lane` drops none: the same area
/// vectors and normals) and its carrying facets' frames are the columns' (the carrying
/// facets are the framed candidates, `MicrofacetNormalMap::framed`; `frame_of_lane` copies
/// them). A lane that drops a candidate (a U-groove of fill 1, a flat point) or whose map
/// was built otherwise (`Scene::bsdf_root`) sends the chunk to the maps (`None`). The other
/// lanes' columns hold numbers the walk computes with but never keeps (it masks them off), as
/// do the candidates past a lane's facets (zero area vectors: never picked) and the frames
/// past the carrying ones (placeholders: never asked).
#[inline(always)]
pub(super) fn cols_of<'c>(
    avx: Avx2,
    built: Option<BuiltFacets<'c>>,
    walking: u8,
) -> Option<&'c FacetCols<8>> {
    let b = built?;
    if walking & !b.lanes != 0 {
        return None;
    }
    let f = b.facets;
    let kept = Cols::of(avx).run(
        #[inline(always)]
        |c| f.keeps_bits8(c, f.candidates()),
    );
    (walking & !kept == 0).then_some(f)
}

/// Whether map `m` (lane `k` of a chunk whose columns [`cols_of`] took) holds the columns'
/// numbers bit for bit: the same facets (area vectors, normals) and carrying facets' frames.
pub(super) fn map_is_cols(m: &impl MapView, f: &FacetCols<8>, k: usize) -> bool {
    let at = |c: &Col3| Vec3::new(c[0][k], c[1][k], c[2][k]);
    let same = |a: Vec3, b: Vec3| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits);
    let surf = m.surface();
    let mut ok = surf.len() == f.candidates();
    for j in 0..surf.len().min(MAX_FACETS) {
        ok &= same(surf.area_vector(j), at(&f.area_vector_cols()[j]));
        ok &= same(surf.normal(j), at(&f.normal_cols()[j]));
    }
    let carrying = if m.mirror_wall() { 1 } else { surf.len() };
    for j in 0..carrying.min(MAX_FACETS) {
        let (g, c) = (&m.frame(j), &f.frame_cols()[j]);
        ok &= same(g.s, at(&c[0])) && same(g.t, at(&c[1])) && same(g.n, at(&c[2]));
    }
    ok
}

/// A lane's columns: `[component][lane]`.
pub(super) type Col3 = [[f32; 8]; 3];

#[inline(always)]
pub(super) fn l3(avx: Avx2, c: &Col3) -> V3<F32x8> {
    V3::new(avx.load(&c[0]), avx.load(&c[1]), avx.load(&c[2]))
}

#[inline(always)]
pub(super) fn set3(c: &mut Col3, k: usize, v: Vec3) {
    c[0][k] = v.x;
    c[1][k] = v.y;
    c[2][k] = v.z;
}

/// `a` where `m`, else `b`, for one-hot facet masks.
#[inline(always)]
pub(super) fn frame_of(
    k: &[M8; MAX_FACETS],
    fr: &[LaneFrame<F32x8>; MAX_FACETS],
) -> LaneFrame<F32x8> {
    let mut f = fr[0];
    for j in 1..MAX_FACETS {
        f = LaneFrame {
            s: V3::select(k[j], fr[j].s, f.s),
            t: V3::select(k[j], fr[j].t, f.t),
            n: V3::select(k[j], fr[j].n, f.n),
        };
    }
    f
}

/// The lanes of `pts` (each lane's local BSDF and ωi, `None`: no point) whose sample is a
/// random walk that runs here, each from stream `ids[k]` of `samplers`: the reflection walk
/// over a `roughconductor` or `roughplastic` leaf shared with the first such lane and with its
/// `max_order` ([`reflection_walks`]), and the two-sided walk over a `roughdielectric` leaf
/// shared likewise (also its transmission walk, [`two_sided_walks`]), each group walked
/// together; only the groups of `groups` are looked for (a lane of the other group is left
/// out of `lanes`, to the caller). A group of fewer than `min` lanes is not walked here (its
/// lanes left out of `lanes`). `built`: the build's facet columns where the chunk's maps were
/// written from them (the walks then read them instead of the maps, [`cols_of`]). The
/// samples go into `out` (empty before); `buf`: the kernel's per-render buffer, whose batch of
/// pairs the reflection walks' densities borrow (`walk_density_lanes::reflection_pdfs`).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_walks_x8(
    avx: Avx2,
    ctx: &BsdfContext,
    pts: &[Option<(Bsdf<'_>, Vec3)>; 8],
    samplers: &mut Samplers,
    ids: &[u32; 8],
    min: u32,
    groups: WalkGroups,
    built: Option<BuiltFacets<'_>>,
    buf: &mut WalkEvalsBuf,
    out: &mut WalkSamples,
) {
    // (Into the caller's `out` (empty, [`WalkSamples::none`]): returned by value, the
    // ~330-byte samples were copied twice, from the walks and out of this call.)
    if groups.reflection {
        reflection_walks(avx, ctx, pts, samplers, ids, (min, built), buf, out);
    }
    if groups.two_sided {
        two_sided_walks(avx, ctx, pts, samplers, ids, (min, built), out);
    }
}

/// [`sample_walks_x8`]'s reflection walks: the lanes whose sample is the reflection walk over
/// a `roughconductor` or `roughplastic` leaf shared with the first such lane and with its
/// `max_order`, walked together, into `out` (empty before). Fewer than `min` such lanes: none
/// is walked (`lanes` 0). `buf`: the batch of the densities' nested pairs, lent.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn reflection_walks(
    avx: Avx2,
    ctx: &BsdfContext,
    pts: &[Option<(Bsdf<'_>, Vec3)>; 8],
    samplers: &mut Samplers,
    ids: &[u32; 8],
    (min, built): (u32, Option<BuiltFacets<'_>>),
    buf: &mut WalkEvalsBuf,
    out: &mut WalkSamples,
) {
    let mut maps: [Option<MapRef<'_>>; 8] = [None; 8];
    let mut shared: Option<(Bsdf<'_>, u32)> = None;
    let mut wi = [[0.0f32; 8]; 3];
    let mut mirror = 0u8;
    let views = built.and_then(|b| b.views);
    for (k, p) in pts.iter().enumerate() {
        let Some((b, w)) = p else { continue };
        // A lane without a map: its point is the leaf, its view stands for the map (the
        // kernel built it so only where `walk_alone` would take the map).
        let (m, nested) = match views.and_then(|v| v[k].as_ref()) {
            Some(v) => {
                debug_assert!(w.z > 0.0);
                (MapRef::Cols(v), *b)
            }
            None => match walk_alone(*b, *w) {
                Some((m, nested)) => (MapRef::Map(m), nested),
                None => continue,
            },
        };
        if let Nested::Diffuse(_) | Nested::Other(_) = Nested::of(&nested) {
            continue;
        }
        let (n0, order0) = *shared.get_or_insert((nested, m.max_order()));
        if !std::ptr::eq(n0.arena, nested.arena)
            || n0.root != nested.root
            || order0 != m.max_order()
        {
            continue;
        }
        maps[k] = Some(m);
        set3(&mut wi, k, *w);
        out.lanes |= 1 << k;
        mirror |= u8::from(m.mirror_wall()) << k;
    }
    let Some((nested, max_order)) = shared else {
        return;
    };
    if out.lanes.count_ones() < min {
        out.lanes = 0;
        return;
    }
    let kind = Nested::of(&nested);
    // The points' facets, wall normal and carrying facets' frames, by lane: the build's
    // columns as they are where they hold the walking lanes' maps, else from each map.
    let own;
    let c = match cols_of(avx, built, out.lanes) {
        Some(f) => {
            debug_assert!(maps
                .iter()
                .enumerate()
                .all(|(k, m)| m.is_none_or(|m| map_is_cols(&m, f, k))));
            Cols8 {
                v: f.area_vector_cols(),
                n1: &f.normal_cols()[1],
                fr: f.frame_cols(),
                wi: &wi,
            }
        }
        None => {
            own = MapCols::of(maps.iter().map(Option::as_ref), false);
            Cols8 {
                v: &own.v,
                n1: &own.n1,
                fr: &own.fr,
                wi: &wi,
            }
        }
    };
    // (The columns' references, kept for the density after the walk.)
    let (cv, cn1, cfr) = (c.v, c.n1, c.fr);
    // (Filled in place by the walk: returned from its `Avx2::run` the ~270 bytes were copied.)
    let mut walked = Walked {
        escaped: 0,
        wo: [[0.0; 8]; 3],
        weight: [[0.0; 8]; 3],
        first: 0,
        first_k: [0; 8],
        first_pdf: [0.0; 8],
        ends: [0; 8],
    };
    walk8(
        avx,
        Cols::of(avx),
        kind,
        c,
        (out.lanes, mirror, max_order),
        samplers,
        ids,
        &mut walked,
    );
    let mut escaped: [Option<Escaped<'_>>; 8] = [None; 8];
    let mut rest = out.lanes;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if walked.ends[k] != 0 {
            nested.record_walk(walked.ends[k]);
        }
        if walked.escaped & (1 << k) == 0 {
            continue;
        }
        let m = maps[k].expect("a walked lane has its map");
        let at = |c: &Col3| Vec3::new(c[0][k], c[1][k], c[2][k]);
        let first = (walked.first & (1 << k) != 0).then(|| FirstVertex {
            k: walked.first_k[k] as usize,
            pdf: walked.first_pdf[k],
        });
        escaped[k] = Some(Escaped {
            m,
            wi: at(&wi),
            wo: at(&walked.wo),
            first,
        });
    }
    // The escaped walks' MIS densities (`mnm::walk_sample_of`'s), their nested densities in
    // 8-wide calls; then `walk_sample_of`'s sample, `Bsdf::sample`'s rejection.
    let cols = ReflectionCols {
        v: cv,
        n1: cn1,
        fr: cfr,
        wi: &wi,
        wo: &walked.wo,
    };
    let pdf = reflection_pdfs(avx, &nested, ctx, cols, mirror, &escaped, buf);
    let lobe = lobe_of(nested.lobes());
    for (k, e) in escaped.iter().enumerate() {
        let Some(e) = e else { continue };
        let w = &walked.weight;
        out.out[k] = accept_sample(BsdfSample {
            wo: e.wo,
            pdf: pdf[k],
            weight: Vec3::new(w[0][k], w[1][k], w[2][k]),
            eta: 1.0,
            lobe,
        });
    }
}

/// The walks' facet columns read from each walking lane's map (where the build's columns
/// cannot stand in, [`cols_of`]): the area vectors (zero past a lane's facets), the carrying
/// facets' frames (zero past them), by lane; for the two-sided walk the facets' unit normals
/// (zero past a lane's facets), for the reflection walk the mirror wall's.
pub(super) struct MapCols {
    pub(super) v: [Col3; MAX_FACETS],
    pub(super) nrm: [Col3; MAX_FACETS],
    /// The wall normal (facet 1's) of the lanes with a mirror wall (the reflection walk).
    pub(super) n1: Col3,
    pub(super) fr: [[Col3; 3]; MAX_FACETS],
}

impl MapCols {
    /// No lane's columns yet (all zero).
    #[inline(always)]
    pub(super) fn new() -> Self {
        MapCols {
            v: [[[0.0f32; 8]; 3]; MAX_FACETS],
            nrm: [[[0.0f32; 8]; 3]; MAX_FACETS],
            n1: [[0.0f32; 8]; 3],
            fr: [[[[0.0f32; 8]; 3]; 3]; MAX_FACETS],
        }
    }

    /// Lane `k`'s columns from its map `m`: the facets' normals only for the two-sided walks
    /// and the eval walks (`all_normals`; the reflection sample walk reads the wall's normal
    /// `n1` alone).
    #[inline(always)]
    pub(super) fn set_lane(&mut self, k: usize, m: &impl MapView, all_normals: bool) {
        let surf = m.surface();
        for (j, (vc, nc)) in self
            .v
            .iter_mut()
            .zip(self.nrm.iter_mut())
            .enumerate()
            .take(surf.len())
        {
            set3(vc, k, surf.area_vector(j));
            if all_normals {
                set3(nc, k, surf.normal(j));
            }
        }
        let carrying = if m.mirror_wall() { 1 } else { surf.len() };
        for (j, f) in self.fr.iter_mut().enumerate().take(carrying) {
            let g = &m.frame(j);
            set3(&mut f[0], k, g.s);
            set3(&mut f[1], k, g.t);
            set3(&mut f[2], k, g.n);
        }
        if m.mirror_wall() && !all_normals {
            set3(&mut self.n1, k, surf.normal(1));
        }
    }

    /// The columns of the maps `maps` (lane by lane; `None`: a lane that does not walk,
    /// zero); the facets' normals only for the two-sided walk (`two_sided`).
    #[inline(always)]
    fn of<'m, M: MapView + 'm>(maps: impl Iterator<Item = Option<&'m M>>, two_sided: bool) -> Self {
        let mut c = MapCols::new();
        for (k, m) in maps.enumerate() {
            if let Some(m) = m {
                c.set_lane(k, m, two_sided);
            }
        }
        c
    }
}

/// The walk's inputs by lane (see [`sample_walks_x8`]).
struct Cols8<'c> {
    v: &'c [Col3; MAX_FACETS],
    n1: &'c Col3,
    fr: &'c [[Col3; 3]; MAX_FACETS],
    wi: &'c Col3,
}

/// What the walks of [`walk8`] did, by lane.
struct Walked {
    /// Bit k: lane k escaped (its ωo and throughput in `wo` and `weight`).
    escaped: u8,
    wo: Col3,
    weight: Col3,
    /// Bit k: lane k escaped right after its first vertex, a nested one (facet `first_k[k]`,
    /// the nested sample's density `first_pdf[k]`).
    first: u8,
    first_k: [u8; 8],
    first_pdf: [f32; 8],
    /// The vertex count `record_walk` takes for lane k's walk (0: it ended at its entry,
    /// which the scalar walk does not count).
    ends: [u32; 8],
}

/// Lane k's end at `order` for the lanes of `bits`.
#[inline(always)]
fn end(ends: &mut [u32; 8], bits: u8, order: u32) {
    let mut rest = bits;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        ends[k] = order;
    }
}

/// The next facet of the walking lanes `act`, hit ∝ a_j(`towards`) (the scalar walks' pick):
/// each walking lane's number from its own stream; a lane whose pick fails ends its walk at
/// `order`. Returns the lanes still walking, whose facets replace theirs in `k`. Shared by
/// both walks.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn next_facet(
    avx: Avx2,
    rng: &mut Pcg<F32x8>,
    surf: &SurfaceLanes<F32x8>,
    towards: V3<F32x8>,
    act: M8,
    k: &mut [M8; MAX_FACETS],
    ends: &mut [u32; 8],
    order: u32,
) -> M8 {
    let u = step(avx, rng, act);
    let (some, kn) = surf.pick(towards, u);
    let on_next = act & some;
    end(ends, act.bits() as u8 & !(on_next.bits() as u8), order);
    for j in 0..MAX_FACETS {
        k[j] = (on_next & kn[j]) | (!on_next & k[j]);
    }
    on_next
}

/// `v`'s lanes into the columns `col` (`[component][lane]`).
#[inline(always)]
pub(super) fn store_cols(col: &mut [[f32; 8]; 3], v: V3<F32x8>) {
    for (c, x) in col.iter_mut().zip([v.x, v.y, v.z]) {
        x.store(c);
    }
}

/// The 2-D numbers of the lanes `nest` (a nested sample's `u2`), each from its own stream:
/// masked PCG32 steps where the stream's 2-D draw is plain (all lanes when `all_plain`), and
/// stream by stream (`Samplers::next_2d`, the stratum) where it is still stratified — those
/// streams' states stored to the columns first (`at`: the lanes' stream indices, the walking
/// lanes and their states at the walk's start), every lane's state gathered again after.
#[inline(always)]
pub(super) fn draw_2d(
    avx: Avx2,
    rng: &mut Pcg<F32x8>,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    at: (I32x8, M8, U64x8),
    nest: M8,
    all_plain: bool,
) -> V2<F32x8> {
    let (idx, on, old) = at;
    let nb = nest.bits() as u8;
    // The lanes whose 2-D draw is plain (all, where no stream has strata).
    let mut plain = u8::MAX;
    if !all_plain {
        plain = 0;
        let mut rest = nb;
        while rest != 0 {
            let j = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            plain |= u8::from(samplers.plain(ids[j] as usize)) << j;
        }
    }
    let flat = nest & avx.mask_bits(u32::from(plain));
    let mut x = step(avx, rng, flat);
    let mut y = step(avx, rng, flat);
    let late = nb & !plain;
    if late != 0 {
        // Those streams' states to the columns, their stratified draws, and every lane's
        // state back (the others' unchanged).
        let (states, _) = samplers.pcg_mut();
        avx.store_u64_at(states, idx, on, rng.parts().0, old);
        let (mut xs, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
        x.store(&mut xs);
        y.store(&mut ys);
        stratified(samplers, ids, late, &mut xs, &mut ys);
        (x, y) = (avx.load(&xs), avx.load(&ys));
        let (states, incs) = samplers.pcg_mut();
        *rng = Pcg::<F32x8>::gather(states, incs, idx);
    }
    V2::new(x, y)
}

/// The masked walk of the lanes `lanes` (see the module's doc), in 8-wide code, into `w`
/// (all zero before).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn walk8(
    avx: Avx2,
    cols: Cols,
    kind: Nested,
    c: Cols8,
    (lanes, mirror, max_order): (u8, u8, u32),
    samplers: &mut Samplers,
    ids: &[u32; 8],
    w: &mut Walked,
) {
    let u1_drawn = draws_u1(kind);
    let all_plain = samplers.all_plain();
    avx.run(
        #[inline(always)]
        || {
            let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
            let surf = SurfaceLanes {
                v: [l3(avx, &c.v[0]), l3(avx, &c.v[1]), l3(avx, &c.v[2])],
            };
            let mut fr = [LaneFrame {
                s: V3::new(zero, zero, zero),
                t: V3::new(zero, zero, zero),
                n: V3::new(zero, zero, zero),
            }; MAX_FACETS];
            for (f, col) in fr.iter_mut().zip(c.fr.iter()) {
                *f = LaneFrame {
                    s: l3(avx, &col[0]),
                    t: l3(avx, &col[1]),
                    n: l3(avx, &col[2]),
                };
            }
            let n1 = l3(avx, c.n1);
            let wall = avx.mask_bits(u32::from(mirror));
            let wi = l3(avx, c.wi);
            let idx = avx.load_u32(ids);
            let on = avx.mask_bits(u32::from(lanes));
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            // The entry: the facet hit from ωi.
            let u = step(avx, &mut rng, on);
            let (some, mut k) = surf.pick(wi, u);
            let mut act = on & some;
            let mut d = -wi;
            let mut thr = V3::new(one, one, one);
            let (mut wo, mut weight) = (V3::new(zero, zero, zero), V3::new(zero, zero, zero));
            let mut first_ok = 0u8;
            let mut asks = Asks::new();
            for order in 1..=max_order {
                let ab = act.bits() as u8;
                if ab == 0 {
                    break;
                }
                let mir = act & wall & k[1];
                let nest = act & !mir;
                // The mirror wall: d − (2 ⟨d, n⟩) n.
                let r = d - n1.scale(avx.splat(2.0) * d.dot(n1));
                d = V3::select(mir, r, d);
                let nb = nest.bits() as u8;
                if nb != 0 {
                    let f = frame_of(&k, &fr);
                    let a = f.to_local(-d);
                    let u1 = if u1_drawn {
                        step(avx, &mut rng, nest)
                    } else {
                        zero
                    };
                    let u2 = draw_2d(
                        avx,
                        &mut rng,
                        samplers,
                        ids,
                        (idx, on, old),
                        nest,
                        all_plain,
                    );
                    asks.set_lanes(avx, nest, a, u1, u2);
                    let ans = asks.answer(cols, kind);
                    let okb = ans.ok() & nb;
                    let ok = avx.mask_bits(u32::from(okb));
                    // A nested sample that is none: absorbed at this vertex.
                    end(&mut w.ends, nb & !okb, order);
                    act = act & !(nest & !ok);
                    thr = V3::select(ok, thr * l3(avx, ans.weight()), thr);
                    d = V3::select(ok, f.to_world(l3(avx, ans.wo())), d);
                    if order == 1 {
                        first_ok = okb;
                        for (j, kj) in k.iter().enumerate() {
                            let kb = kj.bits() as u8 & okb;
                            let mut rest = kb;
                            while rest != 0 {
                                let i = rest.trailing_zeros() as usize;
                                rest &= rest - 1;
                                w.first_k[i] = j as u8;
                            }
                        }
                        w.first_pdf = *ans.pdf();
                    }
                }
                // The exit test against G1(d).
                let u = step(avx, &mut rng, act);
                let esc = act & u.lt(surf.g1(d));
                let eb = esc.bits() as u8;
                if eb != 0 {
                    end(&mut w.ends, eb, order);
                    wo = V3::select(esc, d, wo);
                    weight = V3::select(esc, thr, weight);
                    w.escaped |= eb;
                    if order == 1 {
                        w.first = eb & first_ok;
                    }
                    act = act & !esc;
                }
                // The next facet, hit ∝ a_j(−d).
                act = next_facet(avx, &mut rng, &surf, -d, act, &mut k, &mut w.ends, order);
            }
            // Still walking after `max_order` vertices: absorbed.
            end(&mut w.ends, act.bits() as u8, max_order);
            let (states, _) = samplers.pcg_mut();
            avx.store_u64_at(states, idx, on, rng.parts().0, old);
            store_cols(&mut w.wo, wo);
            store_cols(&mut w.weight, weight);
        },
    )
}

/// [`sample_walks_x8`]'s two-sided walks ([`crate::bsdf::mnm::walk::sample_t`], spec
/// §9.2–9.4): of the lanes not yet in `out` (the reflection walks' lanes: a reflecting leaf,
/// so none of them walks two-sided), those whose sample is the two-sided or early-exit walk
/// ([`walk_two_sided`]) over a `roughdielectric` leaf shared with the first such lane, with
/// its `max_order` and its transmission walk, walked together ([`walk8_t`]) and added to
/// `out`. Each escaped walk's density is the scalar `pdf` of its map (as `mnm::sample`
/// reports it; 8-wide, `walk_density_lanes`), then `Bsdf::sample`'s rejection of degenerate
/// samples. Fewer
/// than `min` such lanes: none is walked.
#[inline(always)]
fn two_sided_walks(
    avx: Avx2,
    ctx: &BsdfContext,
    pts: &[Option<(Bsdf<'_>, Vec3)>; 8],
    samplers: &mut Samplers,
    ids: &[u32; 8],
    (min, built): (u32, Option<BuiltFacets<'_>>),
    out: &mut WalkSamples,
) {
    let mut lanes = 0u8;
    let mut maps: [Option<&MicrofacetNormalMap>; 8] = [None; 8];
    let mut shared: Option<(Bsdf<'_>, u32, bool)> = None;
    let mut wi = [[0.0f32; 8]; 3];
    let mut mirror = 0u8;
    for (k, p) in pts.iter().enumerate() {
        let Some((b, w)) = p else { continue };
        if out.lanes & (1 << k) != 0 {
            continue;
        }
        let Some((m, nested)) = walk_two_sided(*b, *w) else {
            continue;
        };
        if !matches!(nested.node(), BsdfNode::RoughDielectric(_)) {
            continue;
        }
        let exits = m.transmission_walk == TransmissionWalk::ExitOnRefraction;
        let (n0, order0, exits0) = *shared.get_or_insert((nested, m.max_order, exits));
        if !std::ptr::eq(n0.arena, nested.arena)
            || n0.root != nested.root
            || order0 != m.max_order
            || exits0 != exits
        {
            continue;
        }
        maps[k] = Some(m);
        set3(&mut wi, k, *w);
        lanes |= 1 << k;
        mirror |= u8::from(m.mirror_wall) << k;
    }
    let Some((nested, max_order, exits)) = shared else {
        return;
    };
    if lanes.count_ones() < min {
        return;
    }
    let BsdfNode::RoughDielectric(leaf) = nested.node() else {
        unreachable!("the walking lanes' leaf is a rough dielectric");
    };
    // The points' facets (area vectors and normals), the carrying facets' frames, by lane:
    // the build's columns as they are where they hold the walking lanes' maps, else from
    // each map.
    let own;
    let c = match cols_of(avx, built, lanes) {
        Some(f) => {
            debug_assert!(maps
                .iter()
                .enumerate()
                .all(|(k, m)| m.is_none_or(|m| map_is_cols(m, f, k))));
            ColsT {
                v: f.area_vector_cols(),
                nrm: f.normal_cols(),
                fr: f.frame_cols(),
                wi: &wi,
            }
        }
        None => {
            own = MapCols::of(maps.iter().copied(), true);
            ColsT {
                v: &own.v,
                nrm: &own.nrm,
                fr: &own.fr,
                wi: &wi,
            }
        }
    };
    // (The columns' references, kept for the density after the walk.)
    let (cv, cnrm, cfr) = (c.v, c.nrm, c.fr);
    let walked = walk8_t(
        avx,
        leaf,
        ctx.mode,
        c,
        (lanes, mirror, max_order, exits),
        samplers,
        ids,
    );
    out.lanes |= lanes;
    // The escaped walks' p1 (`walk::single_scatter_pdf_t`), 8-wide.
    let p1 = two_sided_p1(
        avx,
        leaf,
        exits,
        TwoSidedCols {
            v: cv,
            nrm: cnrm,
            fr: cfr,
            wi: &wi,
            wo: &walked.wo,
        },
        walked.escaped,
        mirror,
    );
    let mut rest = lanes;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if walked.ends[k] != 0 {
            nested.record_walk(walked.ends[k]);
        }
        if walked.escaped & (1 << k) == 0 {
            continue;
        }
        let m = maps[k].expect("a walked lane has its map");
        let at = |c: &Col3| Vec3::new(c[0][k], c[1][k], c[2][k]);
        let (wi, wo) = (at(&wi), at(&walked.wo));
        let lobe = if walked.transmitted & (1 << k) != 0 {
            Lobes::GLOSSY_TRANSMISSION
        } else {
            Lobes::GLOSSY_REFLECTION
        };
        out.out[k] = accept_sample(BsdfSample {
            wo,
            pdf: two_sided_pdf(m, p1[k], wi, wo),
            weight: at(&walked.weight),
            eta: walked.eta[k],
            lobe,
        });
    }
}

/// The two-sided walk's inputs by lane (see [`two_sided_walks`]).
struct ColsT<'c> {
    v: &'c [Col3; MAX_FACETS],
    nrm: &'c [Col3; MAX_FACETS],
    fr: &'c [[Col3; 3]; MAX_FACETS],
    wi: &'c Col3,
}

/// What the walks of [`walk8_t`] did, by lane.
struct WalkedT {
    /// Bit k: lane k escaped (its ωo, throughput and net η in `wo`, `weight` and `eta`).
    escaped: u8,
    wo: Col3,
    weight: Col3,
    eta: [f32; 8],
    /// Bit k: lane k's ωo lies on the other macro side than ωi (a transmission).
    transmitted: u8,
    /// The vertex count `record_walk` takes for lane k's walk (0: it ended at its entry).
    ends: [u32; 8],
}

/// `v` per lane from the slot of the one-hot facet masks `k` (slot 0 where none is set).
#[inline(always)]
pub(super) fn pick3(k: &[M8; MAX_FACETS], v: &[V3<F32x8>; MAX_FACETS]) -> V3<F32x8> {
    let mut out = v[0];
    for j in 1..MAX_FACETS {
        out = V3::select(k[j], v[j], out);
    }
    out
}

/// The masked two-sided walk of the lanes `lanes` ([`crate::bsdf::mnm::walk::sample_t`] per
/// lane, in 8-wide code): the entry from ωi or −ωi (ωi below: the walker starts inside);
/// per vertex the mirror wall's reflection or the leaf's sample in the facet's frame (one
/// 8-wide `RoughDielectric::sample_lanes` for the lanes at a nested vertex, its `u1` and `u2`
/// drawn as `Bsdf::sample` draws them), η multiplied in; with `exits` (§9.4) a refraction ends
/// the walk (escaped on the far macro side, else absorbed); then the exit test against G1 on
/// the side d leaves the facet on and the next facet ∝ a_j(∓d). `shape`: the walking lanes'
/// bits, the mirror-wall lanes' bits, `max_order`, `exits`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn walk8_t(
    avx: Avx2,
    leaf: &RoughDielectric,
    mode: TransportMode,
    c: ColsT,
    shape: (u8, u8, u32, bool),
    samplers: &mut Samplers,
    ids: &[u32; 8],
) -> WalkedT {
    let (lanes, mirror, max_order, exits) = shape;
    let all_plain = samplers.all_plain();
    avx.run(
        #[inline(always)]
        || {
            let mut w = WalkedT {
                escaped: 0,
                wo: [[0.0; 8]; 3],
                weight: [[0.0; 8]; 3],
                eta: [0.0; 8],
                transmitted: 0,
                ends: [0; 8],
            };
            let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
            let surf = SurfaceLanes {
                v: [l3(avx, &c.v[0]), l3(avx, &c.v[1]), l3(avx, &c.v[2])],
            };
            let nrm = [l3(avx, &c.nrm[0]), l3(avx, &c.nrm[1]), l3(avx, &c.nrm[2])];
            let mut fr = [LaneFrame {
                s: V3::new(zero, zero, zero),
                t: V3::new(zero, zero, zero),
                n: V3::new(zero, zero, zero),
            }; MAX_FACETS];
            for (f, col) in fr.iter_mut().zip(c.fr.iter()) {
                *f = LaneFrame {
                    s: l3(avx, &col[0]),
                    t: l3(avx, &col[1]),
                    n: l3(avx, &col[2]),
                };
            }
            let wall = avx.mask_bits(u32::from(mirror));
            let wi = l3(avx, c.wi);
            let idx = avx.load_u32(ids);
            let on = avx.mask_bits(u32::from(lanes));
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            // The entry: the facet hit from ωi, seen from its side (`walk::entry`).
            let u = step(avx, &mut rng, on);
            let (some, mut k) = surf.pick(V3::select(wi.z.ge(zero), wi, -wi), u);
            let mut act = on & some;
            let mut d = -wi;
            let mut thr = V3::new(one, one, one);
            let mut eta = one;
            let (mut wo, mut weight, mut eta_out) =
                (V3::new(zero, zero, zero), V3::new(zero, zero, zero), zero);
            for order in 1..=max_order {
                if act.bits() == 0 {
                    break;
                }
                let n = pick3(&k, &nrm);
                let mir = act & wall & k[1];
                let nest = act & !mir;
                // The mirror wall: d − (2 ⟨d, n⟩) n.
                let r = d - n.scale(avx.splat(2.0) * d.dot(n));
                d = V3::select(mir, r, d);
                if nest.bits() != 0 {
                    let f = frame_of(&k, &fr);
                    let a = f.to_local(-d);
                    let u1 = step(avx, &mut rng, nest);
                    let u2 = draw_2d(
                        avx,
                        &mut rng,
                        samplers,
                        ids,
                        (idx, on, old),
                        nest,
                        all_plain,
                    );
                    let (s, e, _) = leaf.sample_lanes(mode, a, u1, u2);
                    let ok = nest & accepted(&s);
                    // A nested sample that is none: absorbed at this vertex.
                    end(&mut w.ends, (nest & !ok).bits() as u8, order);
                    act = act & !(nest & !ok);
                    thr = V3::select(ok, thr * s.weight, thr);
                    eta = F32x8::select(ok, eta * e, eta);
                    let out = f.to_world(s.wo);
                    // Arrived along d, left along `out`: the other side is a refraction.
                    let refracted = (d.dot(n) * out.dot(n)).gt(zero);
                    d = V3::select(ok, out, d);
                    if exits {
                        // §9.4: returned at once, unmasked; on the wrong macro side: absorbed.
                        let ex = ok & refracted;
                        end(&mut w.ends, ex.bits() as u8, order);
                        let far = (d.z * wi.z).lt(zero);
                        let esc = ex & far;
                        wo = V3::select(esc, d, wo);
                        weight = V3::select(esc, thr, weight);
                        eta_out = F32x8::select(esc, eta, eta_out);
                        w.escaped |= esc.bits() as u8;
                        w.transmitted |= esc.bits() as u8;
                        act = act & !ex;
                    }
                }
                // The exit test against G1 on the side d leaves the facet on (`walk::step`).
                let upper = d.dot(n).gt(zero);
                let g1 = surf.g1(V3::select(upper, d, -d));
                let towards = V3::select(upper, -d, d);
                let u = step(avx, &mut rng, act);
                let esc = act & u.lt(g1);
                let eb = esc.bits() as u8;
                if eb != 0 {
                    end(&mut w.ends, eb, order);
                    wo = V3::select(esc, d, wo);
                    weight = V3::select(esc, thr, weight);
                    eta_out = F32x8::select(esc, eta, eta_out);
                    w.escaped |= eb;
                    w.transmitted |= (esc & (d.z * wi.z).lt(zero)).bits() as u8;
                    act = act & !esc;
                }
                // The next facet, hit ∝ a_j(towards).
                act = next_facet(
                    avx,
                    &mut rng,
                    &surf,
                    towards,
                    act,
                    &mut k,
                    &mut w.ends,
                    order,
                );
            }
            // Still walking after `max_order` vertices: absorbed.
            end(&mut w.ends, act.bits() as u8, max_order);
            let (states, _) = samplers.pcg_mut();
            avx.store_u64_at(states, idx, on, rng.parts().0, old);
            store_cols(&mut w.wo, wo);
            store_cols(&mut w.weight, weight);
            eta_out.store(&mut w.eta);
            w
        },
    )
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::bsdf::mnm::facets::{MaxTilt, Microgeometry};
    use crate::bsdf::mnm::map_view::view_is_map;
    use crate::bsdf::mnm::{Evaluation, Tangent};
    use crate::bsdf::BsdfArena;
    use crate::material::{MnmCols, MnmSettings};
    use crate::math::Pcg32;
    use crate::sampler::{Sampler, SamplerDesc, SamplerKind};

    /// Bit for bit equal.
    pub(in crate::bsdf::mnm::compensated::lanes) fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits()
    }

    pub(in crate::bsdf::mnm::compensated::lanes) fn same3(a: Vec3, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// The microsurfaces the walk tests run over: the sawtooth with and without the mirror
    /// wall, the V-groove and two U-grooves.
    pub(in crate::bsdf::mnm::compensated::lanes) const GEOMETRIES: [(Microgeometry, Tangent); 5] = [
        (Microgeometry::Sawtooth, Tangent::Mirror),
        (Microgeometry::Sawtooth, Tangent::Same),
        (Microgeometry::VGroove, Tangent::Same),
        (Microgeometry::UGroove { fill: 0.5 }, Tangent::Same),
        (Microgeometry::UGroove { fill: 1.0 }, Tangent::Mirror),
    ];

    /// A perturbed normal up to 80° from +z, some nearly flat, some exactly flat (degenerate:
    /// not walked).
    pub(in crate::bsdf::mnm::compensated::lanes) fn random_wp(r: &mut Pcg32) -> Vec3 {
        let theta = match r.next_u32() % 10 {
            0 => r.next_f32() * 1e-3,
            1 => 0.0,
            _ => r.next_f32() * 80f32.to_radians(),
        };
        let phi = r.next_f32() * std::f32::consts::TAU;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    /// Each lane's view of a build's columns (`ColMap::of_lane`, as the stream kernel's
    /// `views_of` makes it) holds its own map's numbers (`MnmSettings::map_lane_into` of the same lane) bit for bit, `view_is_map`:
    /// facets, carrying frames, λ and G1, the wall's reflection, the wall flag, `max_order` and
    /// c; on every geometry, the U-groove of fill 1 among them (its flat candidate dropped:
    /// facet 1 is candidate 2), and never the next lane's map (another ωp).
    #[test]
    fn views_are_their_lanes_maps() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut rng = Pcg32::new(43, 3);
        let (mut views, mut dropped) = (0, 0);
        for round in 0..600 {
            let mut arena = BsdfArena::new();
            let n = crate::bsdf::mnm::compensated::tests::push_reflectors(&mut arena)[round % 3];
            let geo = GEOMETRIES[round % GEOMETRIES.len()];
            let build = ColBuild::new(avx, &mut rng, geo, [1, 3, 10][round % 3], walk_of(0));
            let roots: [u32; 8] = std::array::from_fn(|k| build.push(&mut arena, n, k, true));
            let map = |r: u32| match arena.bsdf(r).node() {
                BsdfNode::MicrofacetNormalMap { map, .. } => &arena.mnm[*map as usize],
                _ => unreachable!("a map"),
            };
            for (k, &r) in roots.iter().enumerate() {
                let Some(v) = build.view(k) else { continue };
                let v = MapRef::Cols(&v);
                assert!(view_is_map(&v, map(r)), "round {round}, lane {k}");
                let next = (k + 1) % 8;
                if build.wp[next] != build.wp[k] {
                    assert!(
                        !view_is_map(&v, map(roots[next])),
                        "round {round}, lane {k}"
                    );
                }
                views += 1;
                dropped += usize::from(v.surface().len() < build.cols.facets().candidates());
            }
        }
        assert!(
            views > 3000 && dropped > 300,
            "{views} views, {dropped} with a dropped facet"
        );
    }

    /// ωi mostly above the surface, grazing ones mixed in, a few below (not walked).
    fn random_wi(r: &mut Pcg32) -> Vec3 {
        let z = match r.next_u32() % 12 {
            0 => r.next_f32() * 0.02,
            1 => -r.next_f32(),
            _ => r.next_f32(),
        };
        let phi = r.next_f32() * std::f32::consts::TAU;
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// The masked walk of 8 lanes equals `Bsdf::sample` of each lane's map (the scalar
    /// `walk::sample_counted` with `walk_sample`'s density and the rejection of degenerate
    /// samples) lane by lane, bit for bit, leaves every stream where the scalar sample leaves
    /// it and counts the same walks and vertices: the sawtooth with and without the mirror
    /// wall, the V-groove and two U-grooves, both rough conductors and the rough plastic,
    /// independent and stratified streams (some still in their strata), random ωi, lanes
    /// without a point or not walked (flat maps, ωi below), walks of different lengths and
    /// `max_order` 1, 3 and 10; in the rounds built from the columns, half the lanes that are
    /// not flat and seen from above walk without their maps (the leaf for a point, their
    /// views of the columns in `BuiltFacets::views`, each checked against its map).
    #[test]
    fn masked_walks_equal_the_scalar_walks() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(40, 1);
        let geometries = GEOMETRIES;
        let (mut escaped, mut absorbed, mut walks, mut vertices, mut stratified_draws) =
            (0, 0, 0, 0, 0);
        let (mut col_rounds, mut view_lanes) = (0, 0);
        // One batch buffer for every round (as the kernel lends it per render).
        let mut buf = WalkEvalsBuf::new();
        for round in 0..3000 {
            let mut arena = BsdfArena::new();
            let nested = crate::bsdf::mnm::compensated::tests::push_reflectors(&mut arena);
            let n = nested[round % nested.len()];
            let (geo, tangent) = geometries[(round / 3) % geometries.len()];
            let max_order = [1, 3, 10][(round / 15) % 3];
            let stratified = round % 2 == 1;
            // Most rounds build their maps as the stream kernel does, from the build's
            // columns (a few lanes not); the others by `MicrofacetNormalMap::new`.
            let build = ColBuild::new(avx, &mut rng, (geo, tangent), max_order, walk_of(0));
            let by_cols = round % 5 < 3;
            let mut from_cols = 0u8;
            let mut pts: [Option<(u32, Vec3)>; 8] = [None; 8];
            for (k, p) in pts.iter_mut().enumerate() {
                if rng.next_u32().is_multiple_of(6) {
                    continue; // a lane without a point
                }
                let col = by_cols && !rng.next_u32().is_multiple_of(16);
                from_cols |= u8::from(col) << k;
                *p = Some((build.push(&mut arena, n, k, col), random_wi(&mut rng)));
            }
            let (mut all, ids, mut cols) = streams(&mut rng, stratified, &mut stratified_draws);
            // Half the lanes from the columns that are not flat and seen from above walk
            // without their maps, as the stream kernel builds them: the leaf for a point,
            // the lane's view of the columns for its map (the map kept for the scalar walk
            // it is compared with; the view holds its numbers).
            let mut views: [Option<ColMap<'_>>; 8] = [None; 8];
            for (k, p) in pts.iter().enumerate() {
                let Some((r, wi)) = p else { continue };
                if from_cols & (1 << k) != 0 && wi.z > 0.0 && rng.next_u32().is_multiple_of(2) {
                    views[k] = build.view(k);
                }
                if let (Some(v), BsdfNode::MicrofacetNormalMap { map, .. }) =
                    (&views[k], arena.bsdf(*r).node())
                {
                    assert!(
                        view_is_map(&MapRef::Cols(v), &arena.mnm[*map as usize]),
                        "lane {k}"
                    );
                    view_lanes += 1;
                }
            }
            let arena = &arena;
            let lanes: [Option<(Bsdf<'_>, Vec3)>; 8] = std::array::from_fn(|k| {
                pts[k].map(|(r, wi)| match views[k] {
                    Some(_) => (arena.bsdf(n), wi),
                    None => (arena.bsdf(r), wi),
                })
            });
            // The kernel's group for reflecting leaves, and both groups (the same lanes).
            let groups = WalkGroups {
                reflection: true,
                two_sided: round % 4 == 3,
            };
            let built = by_cols.then_some(BuiltFacets {
                facets: build.cols.facets(),
                lanes: from_cols,
                views: Some(&views),
            });
            let mut got = WalkSamples::none();
            let b = &mut buf;
            sample_walks_x8(
                avx, &ctx, &lanes, &mut cols, &ids, 1, groups, built, b, &mut got,
            );
            col_rounds += build.check(avx, arena, &pts, built, got.lanes);
            let counted = arena.take_walk_counts();
            let mut want_lanes = 0u8;
            for (k, p) in pts.iter().enumerate() {
                if let Some((r, wi)) = p {
                    want_lanes |= u8::from(walk_alone(arena.bsdf(*r), *wi).is_some()) << k;
                }
            }
            assert_eq!(got.lanes, want_lanes, "round {round}");
            for k in 0..8 {
                let Some((r, wi)) = pts[k] else { continue };
                if got.lanes & (1 << k) == 0 {
                    continue;
                }
                let want = arena.bsdf(r).sample(&ctx, wi, &mut all[ids[k] as usize]);
                match (got.out[k], want) {
                    (None, None) => absorbed += 1,
                    (Some(a), Some(e)) => {
                        escaped += 1;
                        assert!(same3(a.wo, e.wo), "round {round} lane {k}");
                        assert!(same3(a.weight, e.weight), "round {round} lane {k}");
                        assert!(same(a.pdf, e.pdf), "round {round} lane {k}");
                        assert!(same(a.eta, e.eta) && a.lobe == e.lobe);
                    }
                    (a, e) => panic!("round {round} lane {k}: {a:?} vs {e:?}"),
                }
            }
            let scalar = arena.take_walk_counts();
            assert_eq!(
                (counted.walks, counted.vertices),
                (scalar.walks, scalar.vertices),
                "round {round}"
            );
            walks += scalar.walks;
            vertices += scalar.vertices;
            assert_same_streams(&mut all, &cols, round);
        }
        // Most lanes walk; a fair share of them escape, of the others many are absorbed;
        // walks of several vertices; streams still stratified; walks from the build's
        // columns.
        assert!(escaped > 8000 && absorbed > 1000, "{escaped} {absorbed}");
        assert!(vertices as f64 > 1.3 * walks as f64, "{walks} {vertices}");
        assert!(stratified_draws > 3000, "{stratified_draws}");
        assert!(
            col_rounds > 500 && view_lanes > 2000,
            "{col_rounds} {view_lanes}"
        );
    }

    /// The early-exit walk for `1`, else the two-sided one.
    pub(in crate::bsdf::mnm::compensated::lanes) fn walk_of(i: usize) -> TransmissionWalk {
        if i == 1 {
            TransmissionWalk::ExitOnRefraction
        } else {
            TransmissionWalk::TwoSided
        }
    }

    /// A test chunk's build as the stream kernel's: 8 random perturbed normals (`random_wp`)
    /// through `MnmSettings::lanes_at` (of their normal map values), stored: the facet columns
    /// that the kernel hands the walks ([`BuiltFacets`]).
    pub(in crate::bsdf::mnm::compensated::lanes) struct ColBuild {
        pub(in crate::bsdf::mnm::compensated::lanes) settings: MnmSettings,
        pub(in crate::bsdf::mnm::compensated::lanes) cols: MnmCols<8>,
        pub(in crate::bsdf::mnm::compensated::lanes) wp: [Vec3; 8],
    }

    impl ColBuild {
        pub(in crate::bsdf::mnm::compensated::lanes) fn new(
            avx: Avx2,
            rng: &mut Pcg32,
            (geometry, tangent): (Microgeometry, Tangent),
            max_order: u32,
            transmission_walk: TransmissionWalk,
        ) -> Self {
            let wp: [Vec3; 8] = std::array::from_fn(|_| random_wp(rng));
            let settings = MnmSettings {
                geometry,
                tangent,
                evaluation: Evaluation::RandomWalk,
                max_order,
                max_theta: MaxTilt::new(85f32.to_radians()),
                transmission_walk,
                lambert_closed_form: true,
                ms_table: None,
            };
            // The normal map's values of the normals (2·rgb − 1 gives them back; flat stays
            // flat).
            let rgb: [Vec3; 8] = wp.map(|w| 0.5 * (w + Vec3::ONE));
            let cols = avx.run(|| {
                let col = |c: usize| avx.load(&rgb.map(|v| v[c]));
                settings
                    .lanes_at(V3::new(col(0), col(1), col(2)))
                    .cols::<8>()
            });
            ColBuild { settings, cols, wp }
        }

        /// Lane `k`'s map over `nested`: written from the columns as the kernel's build
        /// writes it (`MnmSettings::map_lane_into`) where `from_cols`, else
        /// `MicrofacetNormalMap::new` of the lane's perturbed normal with the settings'.
        pub(in crate::bsdf::mnm::compensated::lanes) fn push(
            &self,
            arena: &mut BsdfArena,
            nested: u32,
            k: usize,
            from_cols: bool,
        ) -> u32 {
            if from_cols {
                arena.push_microfacet_normal_map_with(nested, |m| {
                    self.settings.map_lane_into(m, nested, &self.cols, k);
                })
            } else {
                let s = &self.settings;
                let m = MicrofacetNormalMap::new(
                    nested,
                    self.wp[k],
                    s.geometry,
                    s.tangent,
                    s.evaluation,
                    s.max_order,
                )
                .with_transmission_walk(s.transmission_walk);
                arena.push_microfacet_normal_map(m)
            }
        }

        /// Lane `k`'s view of the columns where it is not flat (`ColMap::of_lane` with the
        /// settings, as the stream kernel's `views_of` makes it for a lane without a map).
        pub(in crate::bsdf::mnm::compensated::lanes) fn view(
            &self,
            k: usize,
        ) -> Option<ColMap<'_>> {
            let (wp, s) = (self.cols.wp(k), &self.settings);
            (!MicrofacetNormalMap::is_flat(wp)).then(|| {
                ColMap::of_lane(
                    self.cols.facets(),
                    k,
                    wp,
                    s.geometry,
                    s.tangent,
                    s.max_order,
                )
            })
        }

        /// Every map of `pts` written from the columns (`built.lanes`) that keeps all the
        /// candidates holds the columns' numbers bit for bit (the walks' debug assertion,
        /// here in the release build too); returns 1 where the walks read the columns
        /// ([`cols_of`] of the walked lanes `walked`), else 0.
        pub(in crate::bsdf::mnm::compensated::lanes) fn check(
            &self,
            avx: Avx2,
            arena: &BsdfArena,
            pts: &[Option<(u32, Vec3)>; 8],
            built: Option<BuiltFacets<'_>>,
            walked: u8,
        ) -> usize {
            let Some(b) = built else { return 0 };
            let f = b.facets;
            for (k, p) in pts.iter().enumerate() {
                let Some((r, _)) = p else { continue };
                if b.lanes & (1 << k) == 0 || !f.keeps(f.candidates(), k) {
                    continue;
                }
                let BsdfNode::MicrofacetNormalMap { map, .. } = arena.bsdf(*r).node() else {
                    unreachable!("a map");
                };
                assert!(map_is_cols(&arena.mnm[*map as usize], f, k), "lane {k}");
            }
            usize::from(cols_of(avx, built, walked).is_some())
        }
    }

    /// 12 streams for a test chunk (independent, or stratified ones with 0 to 2 of their
    /// stratified 2-D draws spent, counted in `stratified_draws` where one is still pending),
    /// the lanes' ids 8 of them in random order, and the streams as the kernel's columns.
    pub(in crate::bsdf::mnm::compensated::lanes) fn streams(
        rng: &mut Pcg32,
        stratified: bool,
        stratified_draws: &mut usize,
    ) -> (Vec<Sampler>, [u32; 8], Samplers) {
        let mut all = Vec::new();
        for s in 0..12u32 {
            let smp = if stratified {
                let desc = SamplerDesc {
                    kind: SamplerKind::Stratified { jitter: true },
                    sample_count: 16,
                    seed: rng.next_u32() as u64,
                };
                let mut smp = Sampler::for_sample(&desc, s as u64, rng.next_u32() % 16);
                for _ in 0..rng.next_u32() % 3 {
                    smp.next_2d();
                }
                *stratified_draws += usize::from(smp.plain_parts().is_none());
                smp
            } else {
                Sampler::from_seed(rng.next_u32() as u64, s as u64)
            };
            all.push(smp);
        }
        let mut ids = [0u32; 8];
        let mut perm: Vec<u32> = (0..12).collect();
        for (i, id) in ids.iter_mut().enumerate() {
            perm.swap(i, i + (rng.next_u32() as usize) % (12 - i));
            *id = perm[i];
        }
        let mut cols = Samplers::with_capacity(12);
        cols.extend_from(&all);
        (all, ids, cols)
    }

    /// Every stream of the columns is where its scalar twin is: their next three 2-D draws
    /// equal bit for bit.
    pub(in crate::bsdf::mnm::compensated::lanes) fn assert_same_streams(
        all: &mut [Sampler],
        cols: &Samplers,
        round: usize,
    ) {
        for (i, s) in all.iter_mut().enumerate() {
            let mut c = cols.get(i);
            for _ in 0..3 {
                let (a, b) = (c.next_2d(), s.next_2d());
                assert!(same(a.x, b.x) && same(a.y, b.y), "round {round} stream {i}");
            }
        }
    }

    /// ωi over the whole sphere (the two-sided walk enters from either side), grazing ones
    /// mixed in, a few exactly in the plane (not walked).
    fn random_wi_both(r: &mut Pcg32) -> Vec3 {
        let z = match r.next_u32() % 16 {
            0 => (r.next_f32() - 0.5) * 0.04,
            1 => 0.0,
            _ => 2.0 * r.next_f32() - 1.0,
        };
        let phi = r.next_f32() * std::f32::consts::TAU;
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// The masked two-sided walk of 8 lanes equals `Bsdf::sample` of each lane's map (the
    /// scalar `walk::sample_t` with `mnm::sample`'s density and the rejection of degenerate
    /// samples) lane by lane, bit for bit, leaves every stream where the scalar sample leaves
    /// it and counts the same walks and vertices: both transmission walks (two-sided and early
    /// exit), ωi on both sides, both transport modes, rough dielectrics with and without
    /// visible sampling and with η above and below 1, the sawtooth with and without the mirror
    /// wall, the V-groove and two U-grooves, independent and stratified streams, lanes without
    /// a point, flat maps and ωi in the plane (not walked), lanes walked by the reflection walk
    /// beside them (a rough conductor's map), `max_order` 1, 3 and 10.
    #[test]
    fn masked_two_sided_walks_equal_the_scalar_walks() {
        use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut rng = Pcg32::new(40, 3);
        let geometries = GEOMETRIES;
        let (mut transmitted, mut reflected, mut absorbed, mut from_below) = (0, 0, 0, 0);
        let (mut walks, mut vertices, mut stratified_draws, mut reflection_lanes) = (0, 0, 0, 0);
        let mut col_rounds = 0;
        let mut buf = WalkEvalsBuf::new();
        for round in 0..3000 {
            let mut arena = BsdfArena::new();
            let dielectrics = [
                arena.push(BsdfNode::RoughDielectric(RoughDielectric::new(
                    MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
                    1.5,
                    1.0,
                    Vec3::ONE,
                    Vec3::ONE,
                ))),
                arena.push(BsdfNode::RoughDielectric(RoughDielectric::new(
                    MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.4, false),
                    1.0,
                    1.33,
                    Vec3::new(1.0, 0.9, 0.8),
                    Vec3::new(0.7, 0.8, 0.9),
                ))),
            ];
            let conductor = crate::bsdf::mnm::compensated::tests::push_reflectors(&mut arena)[0];
            let n = dielectrics[round % 2];
            let (geo, tangent) = geometries[(round / 2) % geometries.len()];
            let max_order = [1, 3, 10][(round / 10) % 3];
            let walk = walk_of((round / 30) % 2);
            let ctx = BsdfContext {
                mode: if (round / 60) % 2 == 0 {
                    TransportMode::Radiance
                } else {
                    TransportMode::Importance
                },
            };
            let stratified = round % 3 == 1;
            // Most rounds' maps from the build's columns (a few lanes not), as in the kernel.
            let build = ColBuild::new(avx, &mut rng, (geo, tangent), max_order, walk);
            let by_cols = round % 5 < 3;
            let mut from_cols = 0u8;
            let mut pts: [Option<(u32, Vec3)>; 8] = [None; 8];
            let mut any_reflecting = false;
            for (k, p) in pts.iter_mut().enumerate() {
                if rng.next_u32().is_multiple_of(7) {
                    continue; // a lane without a point
                }
                let reflecting = rng.next_u32().is_multiple_of(9);
                any_reflecting |= reflecting;
                let col = by_cols && !rng.next_u32().is_multiple_of(16);
                from_cols |= u8::from(col) << k;
                let r = build.push(&mut arena, if reflecting { conductor } else { n }, k, col);
                let wi = if reflecting {
                    random_wi(&mut rng)
                } else {
                    random_wi_both(&mut rng)
                };
                *p = Some((r, wi));
            }
            let (mut all, ids, mut cols) = streams(&mut rng, stratified, &mut stratified_draws);
            let arena = &arena;
            let lanes: [Option<(Bsdf<'_>, Vec3)>; 8] =
                std::array::from_fn(|k| pts[k].map(|(r, wi)| (arena.bsdf(r), wi)));
            // The kernel's group for a transmitting leaf where no lane reflects; both groups
            // (the same lanes); on mixed chunks also one group alone (the other's lanes left
            // to the caller, their streams untouched).
            let groups = match (any_reflecting, round % 4) {
                (false, 0 | 1) | (true, 1) => WalkGroups::of_lobes(Lobes::GLOSSY_TRANSMISSION),
                (true, 2) => WalkGroups::of_lobes(Lobes::GLOSSY_REFLECTION),
                _ => WalkGroups {
                    reflection: true,
                    two_sided: true,
                },
            };
            let built = by_cols.then_some(BuiltFacets {
                facets: build.cols.facets(),
                lanes: from_cols,
                views: None,
            });
            let mut got = WalkSamples::none();
            let b = &mut buf;
            sample_walks_x8(
                avx, &ctx, &lanes, &mut cols, &ids, 1, groups, built, b, &mut got,
            );
            col_rounds += build.check(avx, arena, &pts, built, got.lanes);
            let counted = arena.take_walk_counts();
            let mut want_lanes = 0u8;
            for (k, p) in pts.iter().enumerate() {
                if let Some((r, wi)) = p {
                    let b = arena.bsdf(*r);
                    let two = walk_two_sided(b, *wi).is_some() && groups.two_sided;
                    let one = walk_alone(b, *wi).is_some() && groups.reflection;
                    want_lanes |= u8::from(two || one) << k;
                    reflection_lanes += usize::from(one);
                }
            }
            assert_eq!(got.lanes, want_lanes, "round {round}");
            for k in 0..8 {
                let Some((r, wi)) = pts[k] else { continue };
                if got.lanes & (1 << k) == 0 {
                    continue;
                }
                let want = arena.bsdf(r).sample(&ctx, wi, &mut all[ids[k] as usize]);
                match (got.out[k], want) {
                    (None, None) => absorbed += 1,
                    (Some(a), Some(e)) => {
                        if a.lobe == Lobes::GLOSSY_TRANSMISSION {
                            transmitted += 1;
                        } else {
                            reflected += 1;
                        }
                        from_below += usize::from(wi.z < 0.0);
                        assert!(same3(a.wo, e.wo), "round {round} lane {k}");
                        assert!(same3(a.weight, e.weight), "round {round} lane {k}");
                        assert!(same(a.pdf, e.pdf), "round {round} lane {k}");
                        assert!(same(a.eta, e.eta) && a.lobe == e.lobe, "round {round}");
                    }
                    (a, e) => panic!("round {round} lane {k}: {a:?} vs {e:?}"),
                }
            }
            let scalar = arena.take_walk_counts();
            assert_eq!(
                (counted.walks, counted.vertices),
                (scalar.walks, scalar.vertices),
                "round {round}"
            );
            walks += scalar.walks;
            vertices += scalar.vertices;
            assert_same_streams(&mut all, &cols, round);
        }
        // Both lobes escape, from both sides; many walks are absorbed; walks of several
        // vertices; streams still stratified; reflection walks beside the two-sided ones.
        assert!(
            transmitted > 3000 && reflected > 3000 && from_below > 3000 && absorbed > 1000,
            "{transmitted} {reflected} {from_below} {absorbed}"
        );
        assert!(vertices as f64 > 1.3 * walks as f64, "{walks} {vertices}");
        assert!(
            stratified_draws > 2000 && reflection_lanes > 1000,
            "{stratified_draws}"
        );
        // Walks from the build's columns.
        assert!(col_rounds > 500, "{col_rounds}");
    }
}
