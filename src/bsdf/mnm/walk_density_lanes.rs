//! The MIS densities of the random walks' BSDF samples at the shading points of a stream chunk
//! (issue 18, forty-first session): the density that `mnm::sample` reports for a walk that
//! escaped, for the lanes that the masked 8-lane walks (`compensated::lanes::walk`) walked,
//! with the nested densities in 8-wide calls instead of one scalar call per term and lane.
//!
//! Both are decision 3 of `docs/spec/mnm.md`: (1 − c)·p1 + c·(cosine lobe), p1 the density
//! of the walks that escape after one vertex, a short sum of nested densities over the facets.
//!
//! - **The two-sided walk** (a transmitting leaf, `roughdielectric`; `mnm::pdf` →
//!   `walk::single_scatter_pdf_t`): p1 = Σ_k λ_k(w)·P_k(ωi, ωo)·g_k over the facets that carry
//!   the leaf, w = ωi seen from its side, g_k the connection factor toward ωo (G1 on the side ωo
//!   leaves facet k on; for the early-exit walk a refraction counts 1 on the far macro side and
//!   0 on the near one), and the cosine lobe split over both hemispheres, c·½·|cos θo|/π
//!   ([`two_sided_p1`], [`two_sided_pdf`]). Every step is 8-wide here: λ from each lane's area
//!   vectors, G1(±ωo) by [`SurfaceLanes::g1`], the pairs' frames, one
//!   `RoughDielectric::pdf_lanes` call per facet slot that a lane counts, the sum.
//! - **The reflection walk** (`roughconductor`, `roughplastic`; `mnm::walk_sample_of`): p1 =
//!   Σ_j w_j·P_j over `PdfTerms` (Variant M's three paths over the mirror sawtooth, one term per
//!   facet otherwise), the first vertex's term known from the nested sample's own density when
//!   the walk escaped right after it (`PdfTerms::know`, as the scalar code). What the terms
//!   are built from is computed 8-wide (λ(ωi), G1(ωo), R(ωo), G1(R(ωo)), R(ωi): [`LaneTerms`])
//!   and each lane's terms from those values by the scalar terms' code (`PdfTerms::mirror_of`,
//!   `single_of`); the unknown terms' pairs of every lane go into one batch of density-only
//!   pairs (`nested_batch::Pairs`, lent by the kernel's `WalkEvalsBuf`) evaluated in 8-wide calls of the leaf's lane form
//!   (`nested_batch::eval_pdf_lanes`) ([`reflection_pdfs`]).
//!
//! **The same bits.** The leaves' scalar `pdf` is their lane form's density at width 1
//! (`RoughDielectric::pdf` is `pdf_lanes` at width 1; the batch's density-only pairs are
//! `pdf` bit for bit, `nested_batch`'s tests), and the lane form gives every lane the width-1
//! result (the lane module's rule); the frames' `to_local` is the lane form at width 1 too.
//! λ: the scalar λ_k(w) = a_k/Σ with a_k = max(⟨w, v_k⟩, 0) and Σ the sum of the facets'
//! a_k; a lane's padded slots (zero area vectors) add ±0 to Σ, which leaves a positive Σ as it
//! is, and a Σ that is not positive gives λ = 0 either way. The sums are added in the scalar
//! order from the scalar start (`Iterator::sum`'s neutral element, taken from the standard
//! library itself, for the two-sided p1; 0 for `PdfTerms::total`'s), skipping the slots the
//! scalar loop skips (past the facets, the mirror wall), and the final mixtures are the
//! scalar expressions. `tests` checks it against `mnm::pdf` and `Bsdf::sample`'s density.
//! The densities draw no random number, so computing them after the walks changes no stream.
//!
//! Here, beside `walk.rs` and `walk_pdf_lanes.rs`, rather than in the masked walks' file:
//! it reads the maps' private facets, frames and MIS weight as those do, and uses
//! `nested_batch`'s batch of pairs.

use super::explicit::PdfTerms;
use super::facets::{store3, SurfaceLanes, MAX_FACETS};
use super::map_view::{MapRef, MapView};
use super::nested_batch;
use super::walk::FirstVertex;
use super::walk_pdf_lanes::WalkEvalsBuf;
use super::MicrofacetNormalMap;
use crate::bsdf::roughdielectric::RoughDielectric;
use crate::bsdf::{Bsdf, BsdfContext, BsdfNode};
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::vec::V3;
use crate::lane::{Avx2, F32x8, Lane};
use crate::math::INV_PI;
use glam::Vec3;

/// Eight lanes of a vector: `[component][lane]`.
pub(super) type Col3 = [[f32; 8]; 3];

/// The two-sided walks' lanes as [`two_sided_p1`] reads them (the masked walk's columns):
/// each lane's area vectors (slots past its facets zero), unit normals and the carrying
/// facets' frames (s, t, n), ωi and the escaped walks' ωo.
pub(super) struct TwoSidedCols<'c> {
    pub v: &'c [Col3; MAX_FACETS],
    pub nrm: &'c [Col3; MAX_FACETS],
    pub fr: &'c [[Col3; 3]; MAX_FACETS],
    pub wi: &'c Col3,
    pub wo: &'c Col3,
}

#[inline(always)]
fn l3(avx: Avx2, c: &Col3) -> V3<F32x8> {
    V3::new(avx.load(&c[0]), avx.load(&c[1]), avx.load(&c[2]))
}

/// `walk::single_scatter_pdf_t` (the p1 of the two-sided walk's MIS density) of the lanes
/// `lanes` (bit k: lane k), bit for bit, 8-wide: `leaf` the lanes' shared nested
/// `roughdielectric`, `exits` their walk (`TransmissionWalk::ExitOnRefraction`), `mirror`
/// the lanes whose facet 1 is the sawtooth's mirror wall. Lanes outside `lanes` hold 0.
#[allow(clippy::needless_range_loop)] // facet slots and lanes index several arrays
#[inline(always)]
pub(super) fn two_sided_p1(
    avx: Avx2,
    leaf: &RoughDielectric,
    exits: bool,
    c: TwoSidedCols<'_>,
    lanes: u8,
    mirror: u8,
) -> [f32; 8] {
    let mut out = [0.0f32; 8];
    if lanes == 0 {
        return out;
    }
    // The scalar sum's start (`Iterator::sum` of f32 folds from its neutral element).
    let start: f32 = core::iter::empty::<f32>().sum();
    avx.run(
        #[inline(always)]
        || {
            let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
            let on = avx.mask_bits(u32::from(lanes));
            let wall = avx.mask_bits(u32::from(mirror));
            let (wi, wo) = (l3(avx, c.wi), l3(avx, c.wo));
            let surf = SurfaceLanes {
                v: [l3(avx, &c.v[0]), l3(avx, &c.v[1]), l3(avx, &c.v[2])],
            };
            // λ_k(w), w = ωi seen from its side (`walk::entry`): a_k / Σ, Σ over the facets.
            let w = V3::select(wi.z.ge(zero), wi, -wi);
            let mut a = [zero; MAX_FACETS];
            let mut s = zero;
            for (ak, vk) in a.iter_mut().zip(&surf.v) {
                *ak = w.dot(*vk).max(zero);
                s = s + *ak;
            }
            let faces = s.gt(zero);
            // G1 of ωo on either side (`walk::exit_factor`), and the early exit's test of a
            // refraction's macro side.
            let (g1_up, g1_down) = (surf.g1(wo), surf.g1(-wo));
            let far = (wo.z * wi.z).lt(zero);
            let d = -wi;
            let mut p1 = avx.splat(start);
            for j in 0..MAX_FACETS {
                let vj = surf.v[j];
                // The lanes whose facet j exists and carries the leaf.
                let real = vj.x.ne(zero) | vj.y.ne(zero) | vj.z.ne(zero);
                let mut counted = on & real;
                if j == 1 {
                    counted = counted & !wall;
                }
                if counted.bits() == 0 {
                    continue;
                }
                let n = l3(avx, &c.nrm[j]);
                let won = wo.dot(n);
                let mut g = F32x8::select(won.gt(zero), g1_up, g1_down);
                if exits {
                    let refracted = (d.dot(n) * won).gt(zero);
                    g = F32x8::select(refracted, F32x8::select(far, one, zero), g);
                }
                let f = LaneFrame {
                    s: l3(avx, &c.fr[j][0]),
                    t: l3(avx, &c.fr[j][1]),
                    n: l3(avx, &c.fr[j][2]),
                };
                let p = leaf.pdf_lanes(f.to_local(wi), f.to_local(wo));
                let l = F32x8::select(faces, a[j] / s, zero);
                let term = F32x8::select(l.gt(zero), l * p * g, zero);
                p1 = F32x8::select(counted, p1 + term, p1);
            }
            F32x8::select(on, p1, zero).store(&mut out);
        },
    );
    out
}

/// `mnm::pdf` of a map over a transmitting leaf (not degenerate) from its two-sided walk's p1
/// ([`two_sided_p1`]): decision 3 with the cosine lobe split over both hemispheres, 0 where ωi
/// or ωo lies in the surface's plane; the scalar expression.
#[inline(always)]
pub(super) fn two_sided_pdf(m: &MicrofacetNormalMap, p1: f32, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z == 0.0 || wo.z == 0.0 {
        return 0.0;
    }
    (1.0 - m.mis_c()) * p1 + m.mis_c() * 0.5 * wo.z.abs() * INV_PI
}

/// One escaped reflection walk for [`reflection_pdfs`]: its map, ωi, ωo and the first vertex
/// when it escaped right after it (`walk::FirstVertex`).
#[derive(Clone, Copy)]
pub(super) struct Escaped<'a> {
    /// The lane's map, or its view of the build's columns (`map_view`).
    pub m: MapRef<'a>,
    pub wi: Vec3,
    pub wo: Vec3,
    pub first: Option<FirstVertex>,
}

/// The reflection walks' lanes as [`reflection_pdfs`] reads them (the masked walk's
/// columns): each lane's area vectors (slots past its facets zero), the mirror wall's normal
/// (lanes with the wall; else anything), its carrying facets' frames (s, t, n; other slots
/// anything), ωi and the escaped walks' ωo.
pub(super) struct ReflectionCols<'c> {
    pub v: &'c [Col3; MAX_FACETS],
    pub n1: &'c Col3,
    pub fr: &'c [[Col3; 3]; MAX_FACETS],
    pub wi: &'c Col3,
    pub wo: &'c Col3,
}

/// What the terms of [`reflection_pdfs`]' lanes are built from, 8-wide: λ(ωi) per facet slot,
/// G1(ωo), and for the mirror sawtooth R(ωo), G1(R(ωo)), R(ωi) and whether ωo and ωi face the
/// wall (bit k: lane k).
struct LaneTerms {
    l: [[f32; 8]; MAX_FACETS],
    g1o: [f32; 8],
    rwo: Col3,
    g1r: [f32; 8],
    rwi: Col3,
    wo_t: u8,
    wi_t: u8,
}

/// [`LaneTerms`] of the lanes of `c`: `Microsurface::lambdas` (a_k = max(⟨ωi, v_k⟩, 0), Σ
/// their sum, a_k / Σ where Σ > 0; a padded slot adds ±0 to Σ and is never read),
/// `Microsurface::g1` by [`SurfaceLanes::g1`], and the wall's reflection ω − (2⟨ω, ωt⟩) ωt
/// (`facet_bsdf::reflect_across`'s operations), bit for bit the scalar values.
#[inline(always)]
fn lane_terms(avx: Avx2, c: &ReflectionCols<'_>, mirror: u8) -> LaneTerms {
    avx.run(
        #[inline(always)]
        || {
            let zero = avx.splat(0.0);
            let (wi, wo, n1) = (l3(avx, c.wi), l3(avx, c.wo), l3(avx, c.n1));
            let surf = SurfaceLanes {
                v: [l3(avx, &c.v[0]), l3(avx, &c.v[1]), l3(avx, &c.v[2])],
            };
            let mut a = [zero; MAX_FACETS];
            let mut s = zero;
            for (ak, vk) in a.iter_mut().zip(&surf.v) {
                *ak = wi.dot(*vk).max(zero);
                s = s + *ak;
            }
            let faces = s.gt(zero);
            let mut t = LaneTerms {
                l: [[0.0; 8]; MAX_FACETS],
                g1o: [0.0; 8],
                rwo: [[0.0; 8]; 3],
                g1r: [0.0; 8],
                rwi: [[0.0; 8]; 3],
                wo_t: 0,
                wi_t: 0,
            };
            for (lk, ak) in t.l.iter_mut().zip(a) {
                F32x8::select(faces, ak / s, zero).store(lk);
            }
            surf.g1(wo).store(&mut t.g1o);
            if mirror != 0 {
                let two = avx.splat(2.0);
                let (don, din) = (wo.dot(n1), wi.dot(n1));
                let rwo = wo - n1.scale(two * don);
                let rwi = wi - n1.scale(two * din);
                surf.g1(rwo).store(&mut t.g1r);
                for (col, x) in t.rwo.iter_mut().zip([rwo.x, rwo.y, rwo.z]) {
                    x.store(col);
                }
                for (col, x) in t.rwi.iter_mut().zip([rwi.x, rwi.y, rwi.z]) {
                    x.store(col);
                }
                t.wo_t = don.gt(zero).bits() as u8 & mirror;
                t.wi_t = din.gt(zero).bits() as u8 & mirror;
            }
            t
        },
    )
}

/// ωi and ωo in each facet slot's frame (`Frame::to_local`'s lane form, the scalar one's bits),
/// by lane: the single-scattering lanes' pairs of [`reflection_pdfs`], 8-wide from the
/// columns' frames instead of each lane's frames read and applied one by one (forty-third
/// session).
struct LocalPairs {
    wi: [Col3; MAX_FACETS],
    wo: [Col3; MAX_FACETS],
}

/// [`LocalPairs`] of the lanes of `c`.
#[inline(always)]
fn local_pairs(avx: Avx2, c: &ReflectionCols<'_>) -> LocalPairs {
    avx.run(
        #[inline(always)]
        || {
            let (wi, wo) = (l3(avx, c.wi), l3(avx, c.wo));
            let mut p = LocalPairs {
                wi: [[[0.0; 8]; 3]; MAX_FACETS],
                wo: [[[0.0; 8]; 3]; MAX_FACETS],
            };
            for (f, fr) in c.fr.iter().enumerate() {
                let fr = LaneFrame {
                    s: l3(avx, &fr[0]),
                    t: l3(avx, &fr[1]),
                    n: l3(avx, &fr[2]),
                };
                p.wi[f] = store3(fr.to_local(wi));
                p.wo[f] = store3(fr.to_local(wo));
            }
            p
        },
    )
}

/// The MIS density of each escaped reflection walk of `walks` (lane k: `walks[k]`, its
/// columns in `c`, bit k of `mirror` where its facet 1 is the mirror wall), as
/// `mnm::walk_sample_of` reports it, bit for bit: each lane's terms (`PdfTerms::mirror_of` /
/// `single_of` from [`LaneTerms`]: `PdfTerms::mirror` / `single`'s), with the first vertex's
/// density known where the scalar code knows it; every unknown term's pair in one batch of
/// density-only pairs evaluated in 8-wide calls of the leaf's lane form (`roughconductor`,
/// `roughplastic`; another leaf evaluates its terms by the scalar `PdfTerms::total`); p1 = Σ_j
/// w_j P_j in `PdfTerms::total`'s order, (1 − c)·p1 + c·cos θo/π. Lanes without a walk hold 0.
#[allow(clippy::needless_range_loop)] // facet slots and lanes index several arrays
#[inline(always)]
pub(super) fn reflection_pdfs(
    avx: Avx2,
    nested: &Bsdf,
    ctx: &BsdfContext,
    c: ReflectionCols<'_>,
    mirror: u8,
    walks: &[Option<Escaped<'_>>; 8],
    buf: &mut WalkEvalsBuf,
) -> [f32; 8] {
    let mut out = [0.0f32; 8];
    if walks.iter().all(Option::is_none) {
        return out;
    }
    let lt = lane_terms(avx, &c, mirror);
    let delta = nested.lobes().has_delta();
    if !matches!(
        nested.node(),
        BsdfNode::RoughConductor(_) | BsdfNode::RoughPlastic(_)
    ) {
        // No lane form: the scalar densities.
        for (k, e) in walks.iter().enumerate() {
            let Some(e) = e else { continue };
            // (A view's lane walks over a leaf with a lane form only: not here.)
            let m = e.m.map().expect("a lane with its map");
            let mut t = PdfTerms::empty();
            terms_into(&mut t, &lt, k, e, delta);
            out[k] = walk_mis(&e.m, t.total(m, nested, ctx), e.wo);
        }
        return out;
    }
    // Variant M's lanes keep their `PdfTerms` (term j's pair at `at[k][j]` where unknown).
    // Single scattering's lanes (the walk-same microsurfaces) need no `PdfTerms` (~160 bytes
    // built and copied a lane): their terms are λ_f(ωi)·P_f(ωi, ωo) for each facet f with
    // λ_f > 0, in facet order (`PdfTerms::single_of`), the first vertex's facet's P known
    // (bit f of `known[k]`, the value `kp[k]`) exactly where `PdfTerms::know` finds its term
    // (the same facet, and ωi, ωo equal to themselves: no NaN), the others' pairs at
    // `at[k][f]`.
    let mut terms: [Option<PdfTerms>; 8] = [None; 8];
    let mut at = [[0u8; MAX_FACETS]; 8];
    // The single-scattering lanes' pairs in their facets' frames, 8-wide (where there is one).
    let mut single = 0u8;
    for (k, e) in walks.iter().enumerate() {
        single |= u8::from(e.is_some()) << k;
    }
    let lp = (single & !mirror != 0).then(|| local_pairs(avx, &c));
    let (mut known, mut kp) = ([0u8; 8], [0.0f32; 8]);
    // The batch lent by the kernel's per-render buffer (emptied; no batch set up per call).
    let (pairs, ev) = buf.batch();
    for (k, e) in walks.iter().enumerate() {
        let Some(e) = e else { continue };
        if e.m.mirror_wall() {
            let t = terms[k].insert(PdfTerms::empty());
            terms_into(t, &lt, k, e, delta);
            for j in 0..t.len() {
                if t.known(j).is_none() {
                    let (f, a, b) = t.pair(j);
                    let fr = e.m.frame(f);
                    at[k][j] = pairs.push(fr.to_local(a), fr.to_local(b), true) as u8;
                }
            }
            continue;
        }
        let kf = match e.first {
            Some(v) if !delta && !e.wi.is_nan() && !e.wo.is_nan() => {
                kp[k] = v.pdf;
                v.k
            }
            _ => MAX_FACETS,
        };
        for f in 0..e.m.surface().len() {
            if lt.l[f][k] > 0.0 {
                if f == kf {
                    known[k] = 1 << f;
                } else {
                    let lp = lp.as_ref().expect("a single-scattering lane's pairs");
                    let at3 = |c: &Col3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                    at[k][f] = pairs.push(at3(&lp.wi[f]), at3(&lp.wo[f]), true) as u8;
                }
            }
        }
    }
    // (Into the buffer: `eval_pdf_lanes`' 512-byte result was copied out, then a zeroed
    // local was set per call.)
    match nested.node() {
        BsdfNode::RoughConductor(c) => nested_batch::eval_pdf_lanes_into(c, pairs, ev),
        BsdfNode::RoughPlastic(p) => nested_batch::eval_pdf_lanes_into(p, pairs, ev),
        _ => unreachable!("the leaves with a lane form, tested above"),
    }
    for (k, e) in walks.iter().enumerate() {
        let Some(e) = e else { continue };
        let p1 = match &terms[k] {
            Some(t) => t.total_of(|j| match t.known(j) {
                Some(p) => p,
                None => ev.p(at[k][j] as usize),
            }),
            None => {
                // `PdfTerms::total_of`'s sum over the same terms in the same order.
                let mut p = 0.0;
                for f in 0..e.m.surface().len() {
                    let l = lt.l[f][k];
                    if l > 0.0 {
                        let pf = match known[k] & (1 << f) != 0 {
                            true => kp[k],
                            false => ev.p(at[k][f] as usize),
                        };
                        p += l * pf;
                    }
                }
                p
            }
        };
        out[k] = walk_mis(&e.m, p1, e.wo);
    }
    out
}

/// Lane `k`'s terms into `t` as `walk_sample_of` builds them (`PdfTerms::mirror` /
/// `single`, from the lanes' values `lt`), the first vertex's density known where it knows
/// it (not for a leaf with delta lobes, `delta`).
#[inline(always)]
fn terms_into(t: &mut PdfTerms, lt: &LaneTerms, k: usize, e: &Escaped<'_>, delta: bool) {
    let l = [lt.l[0][k], lt.l[1][k], lt.l[2][k]];
    let col = |c: &Col3| Vec3::new(c[0][k], c[1][k], c[2][k]);
    *t = if e.m.mirror_wall() {
        let wall_o = (lt.wo_t & (1 << k) != 0).then(|| (col(&lt.rwo), lt.g1r[k]));
        let rwi = (lt.wi_t & (1 << k) != 0).then(|| col(&lt.rwi));
        PdfTerms::mirror_of(e.wi, e.wo, l, lt.g1o[k], wall_o, rwi)
    } else {
        PdfTerms::single_of(e.wi, e.wo, l, e.m.surface().len())
    };
    if let Some(v) = e.first {
        if !delta {
            t.know(v.k, e.wi, e.wo, v.pdf);
        }
    }
}

/// Decision 3's mixture of the reflection walk (`mnm::walk_sample_of`'s expression).
#[inline(always)]
fn walk_mis(m: &impl MapView, p1: f32, wo: Vec3) -> f32 {
    let c = m.mis_c();
    (1.0 - c) * p1 + c * wo.z * INV_PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same};
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::bsdf::mnm::compensated::tests::push_reflectors;
    use crate::bsdf::mnm::facets::Microgeometry;
    use crate::bsdf::mnm::{pdf as mnm_pdf, walk, walk_sample_of, Evaluation, Tangent};
    use crate::bsdf::mnm::{TransmissionWalk, FLAT};
    use crate::bsdf::{BsdfArena, Lobes, TransportMode};
    use crate::math::Pcg32;

    const GEOMETRIES: [(Microgeometry, Tangent); 5] = [
        (Microgeometry::Sawtooth, Tangent::Mirror),
        (Microgeometry::Sawtooth, Tangent::Same),
        (Microgeometry::VGroove, Tangent::Same),
        (Microgeometry::UGroove { fill: 0.5 }, Tangent::Same),
        (Microgeometry::UGroove { fill: 1.0 }, Tangent::Mirror),
    ];

    /// A perturbed normal tilted up to ~70°, some nearly flat (never flat: a flat map is not
    /// walked).
    fn perturbed(r: &mut Pcg32) -> Vec3 {
        let t = if r.next_f32() < 0.1 {
            1e-3 * r.next_f32() + 2.0 * FLAT
        } else {
            1.2 * r.next_f32()
        };
        let phi = 2.0 * core::f32::consts::PI * r.next_f32();
        Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
    }

    fn set3(c: &mut Col3, k: usize, v: Vec3) {
        (c[0][k], c[1][k], c[2][k]) = (v.x, v.y, v.z);
    }

    /// The 8-wide p1 of the two-sided walk and its density equal the scalar
    /// `walk::single_scatter_pdf_t` and `mnm::pdf` of each lane's map bit for bit: ωi and ωo
    /// on both sides (some grazing, in the plane or +z), both transmission walks, two rough
    /// dielectrics (GGX with visible sampling and η 1.5; Beckmann without, η 1/1.33), the
    /// sawtooth with and without its mirror wall, the V-groove and U-grooves with fill 0.5 and
    /// 1; lanes outside the mask (dead lanes, their columns left as they were) hold 0.
    #[allow(clippy::needless_range_loop)] // facet slots and lanes index several arrays
    #[test]
    fn two_sided_densities_equal_the_scalar_ones() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut rng = Pcg32::new(41, 2);
        let ctx = BsdfContext {
            mode: TransportMode::Radiance,
        };
        let (mut compared, mut positive, mut far_side, mut dead) = (0, 0, 0, 0);
        for round in 0..3000 {
            let mut arena = BsdfArena::new();
            let leaves = [
                RoughDielectric::new(
                    MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
                    1.5,
                    1.0,
                    Vec3::ONE,
                    Vec3::ONE,
                ),
                RoughDielectric::new(
                    MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.4, false),
                    1.0,
                    1.33,
                    Vec3::new(1.0, 0.9, 0.8),
                    Vec3::new(0.7, 0.8, 0.9),
                ),
            ];
            let leaf = leaves[round % 2];
            let n = arena.push(BsdfNode::RoughDielectric(leaf));
            let (geo, tangent) = GEOMETRIES[(round / 2) % GEOMETRIES.len()];
            let walk = if (round / 10) % 2 == 0 {
                TransmissionWalk::TwoSided
            } else {
                TransmissionWalk::ExitOnRefraction
            };
            let (mut v, mut nrm) = (
                [[[0.0f32; 8]; 3]; MAX_FACETS],
                [[[0.0f32; 8]; 3]; MAX_FACETS],
            );
            let mut fr = [[[[0.0f32; 8]; 3]; 3]; MAX_FACETS];
            let (mut wi, mut wo) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3]);
            let (mut lanes, mut mirror) = (0u8, 0u8);
            let mut roots = [None; 8];
            for k in 0..8 {
                let m = MicrofacetNormalMap::new(
                    n,
                    perturbed(&mut rng),
                    geo,
                    tangent,
                    Evaluation::RandomWalk,
                    4,
                )
                .with_transmission_walk(walk);
                let (i, o) = (direction(&mut rng), direction(&mut rng));
                if rng.next_u32().is_multiple_of(7) || i.z == 0.0 {
                    // A dead lane: something in its columns, not in the mask.
                    set3(&mut wi, k, Vec3::new(f32::NAN, 1.0, -2.0));
                    dead += 1;
                    continue;
                }
                let surf = &m.surface;
                for j in 0..surf.len() {
                    set3(&mut v[j], k, surf.area_vector(j));
                    set3(&mut nrm[j], k, surf.normal(j));
                }
                let carrying = if m.mirror_wall { 1 } else { surf.len() };
                for (j, f) in fr.iter_mut().enumerate().take(carrying) {
                    let g = &m.frames[j];
                    set3(&mut f[0], k, g.s);
                    set3(&mut f[1], k, g.t);
                    set3(&mut f[2], k, g.n);
                }
                mirror |= u8::from(m.mirror_wall) << k;
                set3(&mut wi, k, i);
                set3(&mut wo, k, o);
                lanes |= 1 << k;
                roots[k] = Some((arena.push_microfacet_normal_map(m), i, o));
            }
            let exits = walk == TransmissionWalk::ExitOnRefraction;
            let cols = TwoSidedCols {
                v: &v,
                nrm: &nrm,
                fr: &fr,
                wi: &wi,
                wo: &wo,
            };
            let p1 = two_sided_p1(avx, &leaf, exits, cols, lanes, mirror);
            for k in 0..8 {
                let Some((r, i, o)) = roots[k] else {
                    assert!(same(p1[k], 0.0), "round {round} dead lane {k}");
                    continue;
                };
                let b = arena.bsdf(r);
                let BsdfNode::MicrofacetNormalMap { map, .. } = b.node() else {
                    unreachable!()
                };
                let m = &arena.mnm[*map as usize];
                let nested = b.child(m.nested);
                assert!(nested.lobes().has_transmission());
                let want = walk::single_scatter_pdf_t(m, &nested, &ctx, i, o);
                assert!(
                    same(p1[k], want),
                    "round {round} lane {k}: {} {want}",
                    p1[k]
                );
                let (got, want) = (two_sided_pdf(m, p1[k], i, o), mnm_pdf(b, m, &ctx, i, o));
                assert!(same(got, want), "round {round} lane {k}: {got} {want}");
                compared += 1;
                positive += usize::from(want > 0.0 && p1[k] > 0.0);
                far_side += usize::from(i.z * o.z < 0.0 && p1[k] > 0.0);
            }
        }
        assert!(compared > 15000 && positive > 8000, "{compared} {positive}");
        assert!(far_side > 1000 && dead > 2000, "{far_side} {dead}");
    }

    /// The reflection walk's densities from the batch equal `mnm::walk_sample_of`'s bit for
    /// bit: Variant M's terms over the mirror sawtooth and single scattering's on the other
    /// microsurfaces, both rough conductors and the rough plastic (the compensated tests'
    /// leaves), ωi and ωo above the surface (some grazing or +z), with and without a known
    /// first vertex (its density the nested one's, or any number: the scalar code takes the
    /// walk's value as it is), a first vertex whose pair is no term (nothing known), lanes
    /// without a walk.
    #[allow(clippy::needless_range_loop)] // facet slots and lanes index several arrays
    #[test]
    fn reflection_densities_equal_the_scalar_ones() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut rng = Pcg32::new(41, 3);
        let ctx = BsdfContext::default();
        let (mut compared, mut known, mut positive) = (0, 0, 0);
        // One buffer for every round, as the stream kernel lends it per render: each round's
        // batch over the pairs an earlier round left.
        let mut buf = WalkEvalsBuf::new();
        for round in 0..3000 {
            let mut arena = BsdfArena::new();
            let n = push_reflectors(&mut arena)[round % 3];
            let (geo, tangent) = GEOMETRIES[(round / 3) % GEOMETRIES.len()];
            let mut walks: [Option<Escaped<'_>>; 8] = [None; 8];
            let mut roots = [u32::MAX; 8];
            for root in roots.iter_mut() {
                let m = MicrofacetNormalMap::new(
                    n,
                    perturbed(&mut rng),
                    geo,
                    tangent,
                    Evaluation::RandomWalk,
                    4,
                );
                *root = arena.push_microfacet_normal_map(m);
            }
            let arena = &arena;
            let nested = arena.bsdf(n);
            let (mut v, mut n1) = ([[[0.0f32; 8]; 3]; MAX_FACETS], [[0.0f32; 8]; 3]);
            let mut fr = [[[[0.0f32; 8]; 3]; 3]; MAX_FACETS];
            let (mut wi, mut wo, mut mirror) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3], 0u8);
            for (k, w) in walks.iter_mut().enumerate() {
                if rng.next_u32().is_multiple_of(6) {
                    continue; // no walk
                }
                let BsdfNode::MicrofacetNormalMap { map, .. } = arena.bsdf(roots[k]).node() else {
                    unreachable!()
                };
                let m = &arena.mnm[*map as usize];
                let (mut i, mut o) = (direction(&mut rng), direction(&mut rng));
                (i.z, o.z) = (i.z.abs().max(1e-6), o.z.abs().max(1e-6));
                let first = match rng.next_u32() % 4 {
                    0 => None,
                    c => {
                        let carrying = if m.mirror_wall { 1 } else { m.surface.len() };
                        let k = rng.next_u32() as usize % carrying;
                        let pdf = if c == 1 {
                            100.0 * rng.next_f32()
                        } else {
                            m.p(&nested, k, &ctx, i, o)
                        };
                        Some(FirstVertex { k, pdf })
                    }
                };
                // The walk's columns, as `reflection_walks` fills them.
                let surf = &m.surface;
                for j in 0..surf.len() {
                    set3(&mut v[j], k, surf.area_vector(j));
                }
                if m.mirror_wall {
                    set3(&mut n1, k, surf.normal(1));
                    mirror |= 1 << k;
                }
                let carrying = if m.mirror_wall { 1 } else { surf.len() };
                for (j, f) in fr.iter_mut().enumerate().take(carrying) {
                    let g = m.frames[j];
                    set3(&mut f[0], k, g.s);
                    set3(&mut f[1], k, g.t);
                    set3(&mut f[2], k, g.n);
                }
                set3(&mut wi, k, i);
                set3(&mut wo, k, o);
                *w = Some(Escaped {
                    m: MapRef::Map(m),
                    wi: i,
                    wo: o,
                    first,
                });
            }
            let cols = ReflectionCols {
                v: &v,
                n1: &n1,
                fr: &fr,
                wi: &wi,
                wo: &wo,
            };
            let got = reflection_pdfs(avx, &nested, &ctx, cols, mirror, &walks, &mut buf);
            for (k, w) in walks.iter().enumerate() {
                let Some(e) = w else {
                    assert!(same(got[k], 0.0), "round {round} lane {k}");
                    continue;
                };
                let lobe = Lobes::GLOSSY_REFLECTION;
                let m = e.m.map().unwrap();
                let want = walk_sample_of(m, &nested, &ctx, e.wi, e.wo, Vec3::ONE, lobe, e.first);
                assert!(
                    same(got[k], want.pdf),
                    "round {round} lane {k}: {} {}",
                    got[k],
                    want.pdf
                );
                compared += 1;
                known += usize::from(e.first.is_some());
                positive += usize::from(want.pdf > 0.0);
            }
        }
        assert!(compared > 15000 && known > 10000, "{compared} {known}");
        assert!(positive > 15000, "{positive}");
    }
}
