//! The random walk's next-event estimate ([`crate::bsdf::mnm::walk::eval`]) of up to 8 shading
//! points at once, one lane per point (issue 18, the light-sample side of the stream kernel's
//! walk modes): the points whose light-sample query reaches `walk_eval_pdf` over a shared
//! `roughconductor` or `roughplastic` leaf (`walk_pdf_lanes::WalkEvals`) walk together, each
//! lane active until its own walk ends, the chunk looping until no lane is.
//!
//! Per iteration, as the scalar loop (Heitz et al. 2016's walk with next-event estimation on our
//! facet set, spec §3, §5): over the mirror wall the reflection; else the connections toward ωo
//! (F_k(−d, ωo)·G1(ωo) where ωo·n_k > 0) and through the wall (F_k(−d, R(ωo))·(1 − G1(R(ωo)))·
//! G1(ωo) where the wall faces ωo, below `max_order` and R(ωo)·n_k > 0), each one 8-wide
//! evaluation of the leaf's lane form in facet k's frame (the map's stored frames, the same
//! bits as [`crate::bsdf::mnm::MicrofacetNormalMap::f`]) for the lanes that connect, added to
//! each lane's sum as the scalar `sum += thr·F·g`; at `max_order` the nested lanes stop; then
//! the nested sample (one 8-wide call, [`super::sample::Asks`], as the sample walk's `walk8`),
//! the exit test against G1(d) and the next facet ∝ a_j(−d). Each lane draws from its own
//! stream only while active, in the scalar order (entry pick; the nested sample's numbers;
//! exit; pick): the evaluations draw nothing (the leaves' `eval` takes no sampler's number),
//! so the masked draws are the scalar walk's, stratified streams handled as the sample walk
//! handles them ([`super::walk::draw_2d`]).
//!
//! **The same bits.** The scalar walk takes its first vertex's connections from the MIS
//! density's terms (the fused nested `eval_pdf`, or `WalkEvals`' batch of it) and the others
//! from the nested `eval`; both leaves' `eval` is `eval_pdf`'s value bit for bit, and the lane
//! form is the scalar `eval_pdf` at any width (`nested_batch`'s tests). So the first vertex's
//! connections are read from `WalkEvals`' batch (the pairs pushed there from the same ωi, ωo,
//! R(ωo) and facet frames: [`FirstConnections`]) and every other connection is evaluated here
//! by the lane form (`tests`: each lane's value, density and stream against the scalar
//! `Bsdf::eval_pdf` of its map).

use super::super::Nested;
use super::draws::step;
use super::sample::{draws_u1, Asks};
use super::walk::{
    cols_of, draw_2d, frame_of, l3, map_is_cols, next_facet, pick3, set3, store_cols, BuiltFacets,
    Col3, MapCols,
};
use super::Cols;
use crate::bsdf::mnm::facets::{SurfaceLanes, MAX_FACETS};
use crate::bsdf::mnm::map_view::{MapRef, MapView};
use crate::bsdf::mnm::nested_batch::{LaneNested, CHUNK};
use crate::bsdf::{Bsdf, BsdfNode};
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::pcg::Pcg;
use crate::lane::vec::V3;
use crate::lane::{Avx2, F32x8, I32x8, Lane, LaneI32};
use crate::sampler::Samplers;
use glam::Vec3;

/// One lane's query of [`eval_walks_x8`]: its map, ωi and ωo (shading frame, both above), and
/// the walk's two connection factors as `walk::eval` takes them from its terms: G1(ωo) (> 0)
/// and the mirror-wall weight (1 − G1(R(ωo)))·G1(ωo) where the wall faces ωo, else 0 (the
/// scalar walk's `w > 0` test then fails as its `None` does).
#[derive(Clone, Copy)]
pub(crate) struct EvalQuery<'m> {
    /// The lane's map, or its view of the build's columns (`map_view`).
    pub m: MapRef<'m>,
    pub wi: Vec3,
    pub wo: Vec3,
    pub g1o: f32,
    pub wall_w: f32,
}

/// Where the MIS density's batch already holds the first vertex's connections of
/// [`eval_walks_x8`]'s lanes (`WalkEvals`: the terms' nested `eval_pdf` in 8-wide calls, their
/// values `[component][pair]`). At its first vertex a walk is on its entry facet k with
/// a = −d = ωi, so its two connections are the pairs (k, ωi, ωo) and, over the mirror
/// sawtooth (k = 0), (0, ωi, R(ωo)): terms of single scattering (one a facet seen from ωi)
/// and of Variant M (i→p→o, i→p→t→o), the same pairs in the same frames, whose values the
/// scalar walk takes from the terms (`Terms::f`). The walk reads them from the batch by
/// these indices (8-wide gathers) instead of evaluating the leaf again; a lane whose facet
/// has no such term (λ_k(ωi) rounded to 0) evaluates the connection itself, as before.
#[derive(Clone, Copy)]
pub(crate) struct FirstConnections {
    /// Lane l's pair index of (k, ωi, ωo) in the batch, by facet k; −1: none.
    pub wo: [[i32; 8]; MAX_FACETS],
    /// Lane l's pair index of (0, ωi, R(ωo)); −1: none.
    pub rwo: [i32; 8],
}

impl FirstConnections {
    /// None known.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        FirstConnections {
            wo: [[-1; 8]; MAX_FACETS],
            rwo: [-1; 8],
        }
    }
}

/// `walk::eval` of each lane of `q` (`None`: no walk here) over the shared leaf `nested`
/// (a `roughconductor` or `roughplastic`) with every lane's `max_order` equal to `max_order`,
/// each from stream `ids[k]` of `samplers`: f·cos θo by lane (`[component][lane]`), every
/// walking stream left where the scalar walk leaves it. `built`: the build's facet columns
/// where the chunk's maps were written from them: the walk reads them as they are where they
/// hold every walking lane's map bit for bit (`walk::cols_of`, as the sample walks), else
/// each lane's map (`MapCols::set_lane`). `first`: where the density's batch holds the first
/// vertex's connections, and the batch's values `[component][pair]` (the others are
/// evaluated here).
#[inline(never)]
#[allow(clippy::too_many_arguments)] // (the merge of h1 and h3 gave it its eighth)
pub(crate) fn eval_walks_x8(
    avx: Avx2,
    nested: &Bsdf<'_>,
    q: &[Option<EvalQuery<'_>>; 8],
    max_order: u32,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    built: Option<BuiltFacets<'_>>,
    first: (&FirstConnections, &[[f32; CHUNK]; 3]),
) -> Col3 {
    let mut wi = [[0.0; 8]; 3];
    let mut wo = [[0.0; 8]; 3];
    let mut rwo = [[0.0; 8]; 3];
    let (mut g1o, mut wall_w) = ([0.0; 8], [0.0; 8]);
    let (mut lanes, mut mirror) = (0u8, 0u8);
    for (k, e) in q.iter().enumerate() {
        let Some(e) = e else { continue };
        let m = e.m;
        set3(&mut wi, k, e.wi);
        set3(&mut wo, k, e.wo);
        if e.wall_w != 0.0 {
            set3(&mut rwo, k, m.reflect_wall(e.wo));
        }
        g1o[k] = e.g1o;
        wall_w[k] = e.wall_w;
        mirror |= u8::from(m.mirror_wall()) << k;
        lanes |= 1 << k;
    }
    // The points' facets (area vectors, normals), the carrying facets' frames, by lane: the
    // build's columns as they are where they hold the walking lanes' maps, else each map's.
    let own;
    let (v, nrm, fr) = match cols_of(avx, built, lanes) {
        Some(f) => {
            debug_assert!(q
                .iter()
                .enumerate()
                .all(|(k, e)| e.is_none_or(|e| map_is_cols(&e.m, f, k))));
            (f.area_vector_cols(), f.normal_cols(), f.frame_cols())
        }
        None => {
            let mut c = MapCols::new();
            for (k, e) in q.iter().enumerate() {
                if let Some(e) = e {
                    c.set_lane(k, &e.m, true);
                }
            }
            own = c;
            (&own.v, &own.nrm, &own.fr)
        }
    };
    let c = EvalCols {
        v,
        nrm,
        fr,
        wi,
        wo,
        rwo,
        g1o,
        wall_w,
        lanes,
        mirror,
    };
    let kind = Nested::of(nested);
    match nested.node() {
        BsdfNode::RoughConductor(b) => {
            walk8_eval(avx, b, kind, &c, max_order, samplers, ids, first)
        }
        BsdfNode::RoughPlastic(b) => walk8_eval(avx, b, kind, &c, max_order, samplers, ids, first),
        _ => unreachable!("the eval walk's leaf has a lane form"),
    }
}

/// [`eval_walks_x8`]'s inputs by lane.
struct EvalCols<'c> {
    /// The points' facets (area vectors, normals) and carrying facets' frames.
    v: &'c [Col3; MAX_FACETS],
    nrm: &'c [Col3; MAX_FACETS],
    fr: &'c [[Col3; 3]; MAX_FACETS],
    wi: Col3,
    wo: Col3,
    /// R(ωo) where the lane's wall weight is not 0.
    rwo: Col3,
    g1o: [f32; 8],
    wall_w: [f32; 8],
    /// Bit k: lane k walks; lane k's map has the mirror wall.
    lanes: u8,
    mirror: u8,
}

/// The masked eval walk of the lanes of `c` (see the module's doc), in 8-wide code: `leaf`
/// evaluates the connections (but the first vertex's that `first` holds), `kind` (the same
/// leaf) answers the nested samples.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn walk8_eval<B: LaneNested>(
    avx: Avx2,
    leaf: &B,
    kind: Nested,
    c: &EvalCols<'_>,
    max_order: u32,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    first: (&FirstConnections, &[[f32; CHUNK]; 3]),
) -> Col3 {
    let (at, ev) = first;
    let u1_drawn = draws_u1(kind);
    let all_plain = samplers.all_plain();
    let cols = Cols::of(avx);
    avx.run(
        #[inline(always)]
        || {
            let zero = avx.splat(0.0);
            let one = avx.splat(1.0);
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
            let wall = avx.mask_bits(u32::from(c.mirror));
            let (wi, wo, rwo) = (l3(avx, &c.wi), l3(avx, &c.wo), l3(avx, &c.rwo));
            let (g1o, wall_w) = (avx.load(&c.g1o), avx.load(&c.wall_w));
            let through = wall_w.gt(zero);
            let idx = avx.load_u32(ids);
            let on = avx.mask_bits(u32::from(c.lanes));
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            // The entry: the facet hit from ωi.
            let u = step(avx, &mut rng, on);
            let (some, mut k) = surf.pick(wi, u);
            let mut act = on & some;
            let mut d = -wi;
            let mut thr = V3::new(one, one, one);
            let mut sum = V3::new(zero, zero, zero);
            let mut asks = Asks::new();
            // `next_facet` notes where walks end (the sample walk's counts): not used here.
            let mut ends = [0u32; 8];
            for order in 1..=max_order {
                if act.bits() == 0 {
                    break;
                }
                let mir = act & wall & k[1];
                let nest = act & !mir;
                // The mirror wall: d − (2 ⟨d, n⟩) n (a delta vertex: no next-event estimate).
                let n1 = nrm[1];
                let r = d - n1.scale(avx.splat(2.0) * d.dot(n1));
                d = V3::select(mir, r, d);
                if nest.bits() != 0 {
                    let n = pick3(&k, &nrm);
                    let f = frame_of(&k, &fr);
                    let a = f.to_local(-d);
                    let none = V3::new(zero, zero, zero);
                    // Toward ωo: F_k(−d, ωo)·G1(ωo); at the first vertex (entry facet k,
                    // a = ωi) from the density's batch where it holds (k, ωi, ωo).
                    let to_wo = nest & wo.dot(n).gt(zero);
                    if to_wo.bits() != 0 {
                        let (mut fv, mut need) = (none, to_wo);
                        if order == 1 {
                            let col = |j: usize| avx.load_i32(&at.wo[j]);
                            let mut i = col(0);
                            for (j, kj) in k.iter().enumerate().skip(1) {
                                i = I32x8::select(*kj, col(j), i);
                            }
                            fv = V3::new(
                                F32x8::gather(&ev[0], i),
                                F32x8::gather(&ev[1], i),
                                F32x8::gather(&ev[2], i),
                            );
                            need = to_wo & !i.gt(i.splat(-1));
                        }
                        if need.bits() != 0 {
                            let (fe, _) = leaf.eval_pdf_lanes(a, f.to_local(wo));
                            fv = V3::select(need, fe, fv);
                        }
                        sum = V3::select(to_wo, sum + (thr * fv).scale(g1o), sum);
                    }
                    // Through the mirror wall: p → t → ωo needs one more vertex; at the first
                    // vertex (facet 0) from the batch where it holds (0, ωi, R(ωo)).
                    if order < max_order {
                        let to_rwo = nest & through & rwo.dot(n).gt(zero);
                        if to_rwo.bits() != 0 {
                            let (mut fv, mut need) = (none, to_rwo);
                            if order == 1 {
                                let i = avx.load_i32(&at.rwo);
                                fv = V3::new(
                                    F32x8::gather(&ev[0], i),
                                    F32x8::gather(&ev[1], i),
                                    F32x8::gather(&ev[2], i),
                                );
                                need = to_rwo & !(k[0] & i.gt(i.splat(-1)));
                            }
                            if need.bits() != 0 {
                                let (fe, _) = leaf.eval_pdf_lanes(a, f.to_local(rwo));
                                fv = V3::select(need, fe, fv);
                            }
                            sum = V3::select(to_rwo, sum + (thr * fv).scale(wall_w), sum);
                        }
                    }
                    if order == max_order {
                        // The nested lanes end here; a mirror lane still exits or picks.
                        act = act & !nest;
                    } else {
                        let nb = nest.bits() as u8;
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
                        let ok = avx.mask_bits(u32::from(ans.ok() & nb));
                        // A nested sample that is none: the walk ends.
                        act = act & !(nest & !ok);
                        thr = V3::select(ok, thr * l3(avx, ans.weight()), thr);
                        d = V3::select(ok, f.to_world(l3(avx, ans.wo())), d);
                    }
                }
                // The exit test against G1(d).
                let u = step(avx, &mut rng, act);
                act = act & !u.lt(surf.g1(d));
                // The next facet, hit ∝ a_j(−d).
                act = next_facet(avx, &mut rng, &surf, -d, act, &mut k, &mut ends, order);
            }
            let (states, _) = samplers.pcg_mut();
            avx.store_u64_at(states, idx, on, rng.parts().0, old);
            let mut out = [[0.0f32; 8]; 3];
            store_cols(&mut out, sum);
            out
        },
    )
}

#[cfg(test)]
mod tests {
    use super::super::walk::cols_of;
    use super::super::walk::tests::{
        assert_same_streams, random_wp, same, same3, streams, walk_of, ColBuild, GEOMETRIES,
    };
    use super::super::BuiltFacets;
    use crate::bsdf::mnm::compensated::tests::push_reflectors;
    use crate::bsdf::mnm::map_view::{view_is_map, ColMap, MapRef};
    use crate::bsdf::mnm::walk_pdf_lanes::{WalkEvals, WalkEvalsBuf};
    use crate::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
    use crate::bsdf::BsdfNode;
    use crate::bsdf::{BsdfArena, BsdfContext};
    use crate::lane::Avx2;
    use crate::math::Pcg32;
    use glam::Vec3;

    /// A direction over the upper hemisphere (some grazing, some +z), or now and then below
    /// (a query that is not the walk's).
    fn random_dir(r: &mut Pcg32) -> Vec3 {
        let z = match r.next_u32() % 16 {
            0 => r.next_f32() * 0.02,
            1 => 1.0,
            2 => -r.next_f32(),
            _ => r.next_f32(),
        };
        let phi = r.next_f32() * std::f32::consts::TAU;
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// The masked eval walk (`WalkEvals::walk_x8`) equals the scalar `walk::eval` of each
    /// lane's map bit for bit: every walked lane's value and MIS density against the scalar
    /// `Bsdf::eval_pdf` of its map (which reaches `walk_eval_pdf`, the walk with the terms of
    /// `PdfTerms`), every stream left where the scalar query leaves it (the streams of the
    /// lanes without a query untouched): the sawtooth with and without the mirror wall, the
    /// V-groove and two U-grooves, both rough conductors and the rough plastic, independent
    /// and stratified streams (some still in their strata), random ωi and ωo (grazing, +z,
    /// some below: not walked), lanes without a light sample, flat maps (not walked), walks
    /// of at most 1, 3 and 8 vertices, and lanes whose `max_order` is not the first walking
    /// lane's (left to the scalar walk, `WalkEvals::eval_pdf`). Two rounds in three build the
    /// maps from a chunk's build columns as the stream kernel does (the walk's set-up then
    /// reads the columns, `BuiltFacets`), and half their lanes that are not flat and seen from
    /// above are queried through their views of the columns (`WalkEvals::push_view`, each
    /// view checked against its map, `view_is_map`), the ones with ωo below answered (0, 0)
    /// as the kernel answers them.
    #[test]
    fn masked_eval_walks_equal_the_scalar_walks() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(41, 1);
        let geometries = GEOMETRIES;
        let (mut walked, mut nonzero, mut scalar, mut unlit, mut stratified_draws) =
            (0, 0, 0, 0, 0);
        let mut mirror_nonzero = 0;
        // One buffer for every chunk, as the stream kernel keeps it.
        let mut buf = WalkEvalsBuf::new();
        let (mut col_rounds, mut view_walks, mut view_below) = (0, 0, 0);
        for round in 0..3000 {
            let mut arena = BsdfArena::new();
            let leaves = push_reflectors(&mut arena);
            let child = leaves[round % leaves.len()];
            let (geo, tangent) = geometries[(round / 3) % geometries.len()];
            let max_order = [1, 3, 8][(round / 15) % 3];
            let stratified = round % 2 == 1;
            let mut roots = [u32::MAX; 8];
            let (mut wi, mut wo) = ([Vec3::Z; 8], [Vec3::Z; 8]);
            // Two rounds in three build their maps as the stream kernel does, from the build's
            // columns (`ColBuild`, one walk length): the eval walk then reads the columns
            // (`BuiltFacets`), and half the lanes that are not flat and seen from above are
            // queried through their views of the columns instead of their maps
            // (`WalkEvals::push_view`; the maps kept for the scalar queries compared with).
            let by_cols = round % 3 != 0;
            let build = ColBuild::new(avx, &mut rng, (geo, tangent), max_order, walk_of(0));
            for k in 0..8 {
                // Now and then a lane with another walk length.
                let order = if !by_cols && rng.next_u32().is_multiple_of(13) {
                    max_order + 1
                } else {
                    max_order
                };
                roots[k] = if by_cols {
                    build.push(&mut arena, child, k, true)
                } else {
                    let m = MicrofacetNormalMap::new(
                        child,
                        random_wp(&mut rng),
                        geo,
                        tangent,
                        Evaluation::RandomWalk,
                        order,
                    );
                    arena.push_microfacet_normal_map(m)
                };
                (wi[k], wo[k]) = (random_dir(&mut rng), random_dir(&mut rng));
            }
            let mut views: [Option<ColMap<'_>>; 8] = [None; 8];
            if by_cols {
                for k in 0..8 {
                    if wi[k].z > 0.0 && rng.next_u32().is_multiple_of(2) {
                        views[k] = build.view(k);
                    }
                    let BsdfNode::MicrofacetNormalMap { map, .. } = arena.bsdf(roots[k]).node()
                    else {
                        unreachable!("a map");
                    };
                    if let Some(v) = &views[k] {
                        assert!(
                            view_is_map(&MapRef::Cols(v), &arena.mnm[*map as usize]),
                            "lane {k}"
                        );
                    }
                }
            }
            let built = by_cols.then_some(BuiltFacets {
                facets: build.cols.facets(),
                lanes: u8::MAX,
                views: None,
            });
            let (mut all, ids, mut cols) = streams(&mut rng, stratified, &mut stratified_draws);
            let nested = arena.bsdf(child);
            let mut lanes =
                WalkEvals::new(nested, child, &mut buf).expect("a leaf with a lane form");
            // The lanes with a light sample (the others are not pushed).
            let lit = (rng.next_u32() & 0xff) as u8;
            for k in 0..8 {
                if lit & (1 << k) != 0 {
                    match &views[k] {
                        Some(v) => lanes.push_view(k, v, wi[k], wo[k]),
                        None => lanes.push(k, arena.bsdf(roots[k]), wi[k], wo[k]),
                    };
                }
            }
            lanes.evaluate();
            lanes.walk_x8(avx, &mut cols, &ids, built);
            col_rounds +=
                usize::from(by_cols && cols_of(avx, built, lanes.walked_bits()).is_some());
            if by_cols {
                build.check(avx, &arena, &roots.map(|r| Some((r, Vec3::Z))), built, 0);
            }
            for k in 0..8 {
                if lit & (1 << k) == 0 {
                    unlit += 1;
                    continue;
                }
                if !lanes.has(k) {
                    if views[k].is_some() {
                        // A view's lane not pushed: ωo below, the caller answers (0, 0) with no
                        // draw, as the scalar query does.
                        let s = ids[k] as usize;
                        let (f, p) = arena
                            .bsdf(roots[k])
                            .eval_pdf(&ctx, wi[k], wo[k], &mut all[s]);
                        assert!(
                            same3(f, Vec3::ZERO) && same(p, 0.0),
                            "round {round} lane {k}"
                        );
                        view_below += 1;
                    }
                    // Not the walk's query: the caller's scalar path (its stream must not
                    // have moved).
                    continue;
                }
                view_walks += usize::from(views[k].is_some());
                let s = ids[k] as usize;
                let (f, p) = arena
                    .bsdf(roots[k])
                    .eval_pdf(&ctx, wi[k], wo[k], &mut all[s]);
                let (fl, pl) = if lanes.walked(k) {
                    walked += 1;
                    lanes.value(k)
                } else {
                    scalar += 1;
                    lanes.eval_pdf(k, &ctx, &mut cols.at(s))
                };
                assert!(same3(f, fl), "round {round} lane {k}: {f} {fl}");
                assert!(same(p, pl), "round {round} lane {k}: {p} {pl}");
                nonzero += usize::from(f != Vec3::ZERO);
                mirror_nonzero += usize::from(f != Vec3::ZERO && tangent == Tangent::Mirror);
            }
            assert_same_streams(&mut all, &cols, round);
        }
        // Most queries walk masked, with values (over the mirror sawtooth too); some lanes
        // are left to the scalar walk; lanes without a light sample; streams in their strata.
        assert!(walked > 8000 && nonzero > 6000, "{walked} {nonzero}");
        assert!(mirror_nonzero > 2000, "{mirror_nonzero}");
        assert!(scalar > 150 && unlit > 5000, "{scalar} {unlit}");
        assert!(stratified_draws > 3000, "{stratified_draws}");
        // Walks from the build's columns, lanes through their views (some with ωo below).
        assert!(col_rounds > 1000, "{col_rounds}");
        assert!(
            view_walks > 1500 && view_below > 50,
            "{view_walks} {view_below}"
        );
    }
}
