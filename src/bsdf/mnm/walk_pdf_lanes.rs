//! The random walk's light-sample evaluation at the shading points of a stream chunk (issue 18,
//! fortieth session): `mnm::eval_pdf` of the walk (reflection, no table: `walk_eval_pdf`) for
//! up to 8 points over one shared nested leaf with a lane form (`roughconductor`,
//! `roughplastic`), with the nested pairs of its MIS density in 8-wide calls.
//!
//! The walk's MIS density (decision 3 of `docs/spec/mnm.md`) is (1 − c)·p1 + c·cos θo/π, p1 a
//! short sum Σ_j w_j P_{k_j}(a_j, b_j) of nested densities ([`PdfTerms`]: Variant M's three
//! paths over the mirror sawtooth, single scattering's one term per facet otherwise), and the
//! walk's next-event estimate evaluates the nested BSDF at some of the same pairs at its first
//! vertex. Per point the scalar code evaluates each term once: fused with the walk's eval where
//! the walk asks for the pair (`PdfTerms::f`), else its density alone (`PdfTerms::total`).
//! Here every term of every point goes into one batch of pairs ([`Pairs`], at most 3 a point)
//! evaluated in full 8-wide calls of the leaf's lane form (`nested_batch::eval_pdf_lanes`);
//! then each point's walk runs as before, lane by lane on its own stream, taking a term's value
//! from the batch where the scalar walk would have evaluated it ([`Known`]), and p1 is the
//! terms' sum over the batch's densities.
//!
//! **The same bits.** A term's value is a pure function of its pair: the lane form equals the
//! scalar `eval_pdf` bit for bit at any width (`nested_batch`'s tests), and the walk looks a
//! pair up by the same exact comparison of (k, a, b) as `PdfTerms::f`, so wherever the scalar
//! walk took a term's value from a fused call (or, for a pair met again, from `eval`, which is
//! `eval_pdf`'s value for both leaves) it gets the same value here. The densities that the
//! scalar code takes from `pdf` (the terms the walk did not meet) are `eval_pdf`'s density
//! here: `roughplastic`'s `pdf` is that density; `roughconductor`'s differs only where D(h) = 0
//! (`eval_pdf` gives +0, `pdf` 0·x, a zero of either sign, or 0 for NaN), and a zero's sign
//! cannot change p1 = 0 + Σ w_j P_j (a sum that starts at +0 never becomes −0, and adding a
//! zero of either sign to it changes nothing), so p1 and the density are the scalar ones
//! (`tests`). The nested evaluations draw no random number (the leaves' `eval_pdf` and `pdf`
//! take no sampler), so evaluating them before the walks leaves every stream's order as it was.

use super::explicit::PdfTerms;
use super::facets::MAX_FACETS;
use super::map_view::{ColMap, MapRef, MapView};
use super::nested_batch::{self, Evaluated, Pairs, CHUNK};
use super::walk::{self, Terms};
use super::{Evaluation, MicrofacetNormalMap};
use crate::bsdf::{Bsdf, BsdfContext, BsdfNode};
use crate::math::INV_PI;
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// The walk's light-sample queries of a chunk's points (lane k: bit k of `on`), their terms
/// and the terms' nested values ([`Self::push`], [`Self::evaluate`], then [`Self::eval_pdf`]
/// per lane). The chunk's own part (its leaf, lanes and maps) is here; the arrays of
/// numbers are a [`WalkEvalsBuf`] that the caller keeps across chunks (fields reached through
/// `Deref`, as if they were this struct's).
pub(crate) struct WalkEvals<'a, 'b> {
    /// The chunk's shared nested leaf, and its node.
    nested: Bsdf<'a>,
    child: u32,
    /// Bit k: lane k's query is here.
    on: u8,
    /// Bit k: lane k's walk ran in [`Self::walk_x8`], its f·cos θo in `f` (`[component][lane]`).
    walked: u8,
    /// Each lane's map, or its view of the build's columns ([`Self::push_view`]).
    maps: [Option<MapRef<'a>>; 8],
    buf: &'b mut WalkEvalsBuf,
}

/// [`WalkEvals`]' arrays (~3.4 KB: the lanes' directions and terms, the batch of pairs and
/// its values, the walks' results), kept by the stream kernel across the chunks of a run
/// instead of built (and moved) per chunk. What a chunk reads before it writes is reset:
/// the pairs' count ([`WalkEvals::new`]), the first connections' indices and `f` where no
/// lane walks ([`WalkEvals::walk_x8`]); every other entry is read only for a lane this chunk
/// wrote it for, and a pair left past the count by an earlier chunk is a valid pair whose
/// values nobody reads.
pub(crate) struct WalkEvalsBuf {
    wi: [Vec3; 8],
    wo: [Vec3; 8],
    terms: [PdfTerms; 8],
    /// Lane k's first pair in `pairs` (its term j is pair `first[k] + j`).
    first: [u8; 8],
    pairs: Pairs<CHUNK>,
    ev: Evaluated<CHUNK>,
    f: [[f32; 8]; 3],
    /// Where `ev` holds the walks' first connections ([`WalkEvals::walk_x8`]).
    #[cfg(target_arch = "x86_64")]
    known: super::compensated::lanes::FirstConnections,
}

impl WalkEvalsBuf {
    pub(crate) fn new() -> Self {
        WalkEvalsBuf {
            wi: [Vec3::Z; 8],
            wo: [Vec3::Z; 8],
            terms: [PdfTerms::empty(); 8],
            first: [0; 8],
            pairs: Pairs::new(),
            ev: Evaluated::zero(),
            f: [[0.0; 8]; 3],
            #[cfg(target_arch = "x86_64")]
            known: super::compensated::lanes::FirstConnections::new(),
        }
    }

    /// The buffer's batch of pairs (emptied) and their values, lent to the chunk's sample
    /// densities after its light queries (`walk_density_lanes::reflection_pdfs`): no batch
    /// built per chunk (its ~1 KB of pairs and values were set from constants per call).
    /// A pair left past the count by an earlier use is a valid pair whose values nobody reads.
    #[inline(always)]
    pub(super) fn batch(&mut self) -> (&mut Pairs<CHUNK>, &mut Evaluated<CHUNK>) {
        self.pairs.clear();
        (&mut self.pairs, &mut self.ev)
    }
}

impl Default for WalkEvalsBuf {
    fn default() -> Self {
        Self::new()
    }
}

impl std::ops::Deref for WalkEvals<'_, '_> {
    type Target = WalkEvalsBuf;
    #[inline(always)]
    fn deref(&self) -> &WalkEvalsBuf {
        self.buf
    }
}

impl std::ops::DerefMut for WalkEvals<'_, '_> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut WalkEvalsBuf {
        self.buf
    }
}

impl<'a, 'b> WalkEvals<'a, 'b> {
    /// No query yet, over the chunk's shared nested leaf `nested` (node `child` of the arena:
    /// the maps' `nested`), its arrays in `buf` (reset here); `None` unless it is a leaf with
    /// a lane form that does not transmit (the walk over a transmitting leaf is the two-sided
    /// one, not this).
    #[inline(always)]
    pub(crate) fn new(nested: Bsdf<'a>, child: u32, buf: &'b mut WalkEvalsBuf) -> Option<Self> {
        let lane_form = matches!(
            nested.node(),
            BsdfNode::RoughConductor(_) | BsdfNode::RoughPlastic(_)
        );
        if !lane_form || nested.lobes().has_transmission() {
            return None;
        }
        buf.pairs.clear();
        Some(WalkEvals {
            nested,
            child,
            on: 0,
            walked: 0,
            maps: [None; 8],
            buf,
        })
    }

    /// Lane `k`'s query `Bsdf::eval_pdf` of root `root` from `wi` toward `wo` (shading frame)
    /// is here when it reaches the walk's `walk_eval_pdf` (as `mnm::eval_pdf` routes it: a
    /// map that is not flat, over the shared leaf, both directions above the surface, no
    /// Lambert form, no table, the walk's evaluation); then its terms and their pairs (in
    /// facet k's frame, `MicrofacetNormalMap::fp`'s arguments) are pushed, and `true`
    /// returned. Else nothing changes (the caller evaluates the lane by the scalar code).
    #[inline(always)]
    pub(crate) fn push(&mut self, k: usize, root: Bsdf<'a>, wi: Vec3, wo: Vec3) -> bool {
        let BsdfNode::MicrofacetNormalMap { map, .. } = root.node() else {
            return false;
        };
        let m = &root.arena.mnm[*map as usize];
        let walk = matches!(
            m.evaluation,
            Evaluation::RandomWalk | Evaluation::Compensated | Evaluation::Auto
        );
        if !walk
            || m.degenerate
            || m.nested != self.child
            || m.lambert.is_some()
            || m.ms.is_some()
            || wi.z <= 0.0
            || wo.z <= 0.0
        {
            return false;
        }
        self.push_terms(k, MapRef::Map(m), wi, wo);
        true
    }

    /// [`Self::push`] for a lane built without its map (the stream kernel's walking lanes
    /// over the shared leaf, not flat, ωi above the surface): its view `v` of the build's
    /// columns stands for the map (the same numbers, `map_view`); the query is here when ωo
    /// is above the surface too (`wo.z <= 0` is the scalar query's (0, 0), no draw: `false`
    /// is returned and the caller answers it so).
    #[inline(always)]
    pub(crate) fn push_view(&mut self, k: usize, v: &'a ColMap<'a>, wi: Vec3, wo: Vec3) -> bool {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return false;
        }
        self.push_terms(k, MapRef::Cols(v), wi, wo);
        true
    }

    /// `walk_eval_pdf`'s terms of lane `k` over map (or view) `m`, and their pairs.
    /// (The terms built in place in the buffer: `PdfTerms::single` returned by value was
    /// copied, ~160 bytes a lane.)
    #[inline(always)]
    fn push_terms(&mut self, k: usize, m: MapRef<'a>, wi: Vec3, wo: Vec3) {
        let b = &mut *self.buf;
        let t = &mut b.terms[k];
        if m.mirror_wall() {
            t.mirror_into(&m, wi, wo);
        } else {
            t.single_into(&m, wi, wo);
        }
        b.first[k] = b.pairs.len() as u8;
        for j in 0..t.len() {
            let (f, x, y) = t.pair(j);
            let fr = m.frame(f);
            b.pairs.push(fr.to_local(x), fr.to_local(y), false);
        }
        (b.wi[k], b.wo[k]) = (wi, wo);
        self.maps[k] = Some(m);
        self.on |= 1 << k;
    }

    /// Every pushed term's nested value and density: the batch in 8-wide calls of the leaf's
    /// lane form (pair by pair at width 1 on a CPU without AVX2: the same numbers).
    #[inline(always)]
    pub(crate) fn evaluate(&mut self) {
        if self.on == 0 {
            return;
        }
        let b = &mut *self.buf;
        match self.nested.node() {
            BsdfNode::RoughConductor(c) => {
                nested_batch::eval_pdf_lanes_into(c, &b.pairs, &mut b.ev)
            }
            BsdfNode::RoughPlastic(p) => nested_batch::eval_pdf_lanes_into(p, &b.pairs, &mut b.ev),
            _ => unreachable!("`new` takes the leaves with a lane form"),
        }
    }

    /// The walks of the lanes here that share the first such lane's `max_order`, as one
    /// masked 8-lane walk (`compensated::lanes::eval_walks_x8`), each lane from stream
    /// `ids[k]` of `samplers`: its value `walk::eval`'s bit for bit, its stream left where
    /// that walk leaves it; then [`Self::walked`] and [`Self::value`]. A lane with G1(ωo) ≤ 0
    /// is zero and draws nothing (the scalar walk's first test). The other lanes here keep
    /// [`Self::eval_pdf`] (the scalar walk). `built`: the build's facet columns where the
    /// chunk's maps were written from them (the walk's set-up reads them instead of the maps
    /// where they hold the walking lanes' maps bit for bit).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn walk_x8(
        &mut self,
        avx: crate::lane::Avx2,
        samplers: &mut crate::sampler::Samplers,
        ids: &[u32; 8],
        built: Option<super::compensated::lanes::BuiltFacets<'_>>,
    ) {
        use super::compensated::lanes::{eval_walks_x8, EvalQuery, FirstConnections};
        let mut q: [Option<EvalQuery<'a>>; 8] = [None; 8];
        let mut max_order = None;
        let mut walking = 0u8;
        let mut rest = self.on;
        let b = &mut *self.buf;
        b.known = FirstConnections::new();
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let m = self.maps[k].expect("a lane with a query");
            if *max_order.get_or_insert(m.max_order()) != m.max_order() {
                continue;
            }
            self.walked |= 1 << k;
            // `walk::eval`'s factors, from the terms as it takes them.
            let (wi, wo) = (b.wi[k], b.wo[k]);
            let t = &mut b.terms[k];
            let g1o = t.g1_wo_of(&m, wo);
            if g1o <= 0.0 {
                continue; // zero, no draw
            }
            let wall_w = if m.mirror_wall() && wo.dot(m.surface().normal(1)) > 0.0 {
                (1.0 - t.g1_rwo_of(&m, m.reflect_wall(wo))) * g1o
            } else {
                0.0
            };
            q[k] = Some(EvalQuery {
                m,
                wi,
                wo,
                g1o,
                wall_w,
            });
            walking |= 1 << k;
            // Where the batch holds the first vertex's connections: single scattering's
            // terms are (k, ωi, ωo), one a facet; Variant M's with a = ωi are (0, ωi, ωo)
            // and (0, ωi, R(ωo)) (its third term starts from R(ωi) ≠ ωi).
            let first = b.first[k] as i32;
            if !m.mirror_wall() {
                for j in 0..t.len() {
                    b.known.wo[t.pair(j).0][k] = first + j as i32;
                }
            } else {
                for j in 0..t.len() {
                    let (_, a, bj) = t.pair(j);
                    if a == wi && bj == wo {
                        b.known.wo[0][k] = first + j as i32;
                    } else if a == wi {
                        debug_assert!(bj == m.reflect_wall(wo));
                        b.known.rwo[k] = first + j as i32;
                    }
                }
            }
        }
        b.f = match (max_order, walking != 0) {
            (Some(order), true) => {
                let first = (&b.known, b.ev.f_cols());
                eval_walks_x8(avx, &self.nested, &q, order, samplers, ids, built, first)
            }
            // (No lane walks: every walked lane's value is zero.)
            _ => [[0.0; 8]; 3],
        };
    }

    /// The lanes whose walks ran in [`Self::walk_x8`], as bits (tests).
    #[cfg(test)]
    pub(crate) fn walked_bits(&self) -> u8 {
        self.walked
    }

    /// Whether lane `k`'s walk ran in [`Self::walk_x8`].
    #[inline(always)]
    pub(crate) fn walked(&self, k: usize) -> bool {
        self.walked & (1 << k) != 0
    }

    /// Lane `k`'s `(f·cos θo, MIS density)` after [`Self::walk_x8`] walked it:
    /// `walk_eval_pdf`'s bit for bit.
    #[inline(always)]
    pub(crate) fn value(&self, k: usize) -> (Spectrum, f32) {
        let m = self.maps[k].expect("a lane with a query");
        let f = Vec3::new(self.f[0][k], self.f[1][k], self.f[2][k]);
        (f, self.density(&m, k))
    }

    /// Lane `k`'s MIS density (1 − c)·p1 + c·cos θo/π, p1 over the batch's densities.
    #[inline(always)]
    fn density(&self, m: &impl MapView, k: usize) -> f32 {
        let first = self.first[k] as usize;
        let p1 = self.terms[k].total_of(|j| self.ev.p(first + j));
        let c = m.mis_c();
        (1.0 - c) * p1 + c * self.wo[k].z * INV_PI
    }

    /// Whether lane `k`'s query is here.
    #[inline(always)]
    pub(crate) fn has(&self, k: usize) -> bool {
        self.on & (1 << k) != 0
    }

    /// Lane `k`'s `(f·cos θo, MIS density)`, `walk_eval_pdf`'s bit for bit: the walk on the
    /// lane's stream `s` (its draws as the scalar walk's), the terms' values from the batch
    /// ([`Self::evaluate`] first).
    #[inline(always)]
    pub(crate) fn eval_pdf(
        &mut self,
        k: usize,
        ctx: &BsdfContext,
        s: &mut Sampler,
    ) -> (Spectrum, f32) {
        // (A lane of a view shares the chunk's `max_order`: it walked in `walk_x8`.)
        let m = self.maps[k]
            .and_then(|m| m.map())
            .expect("a lane with its map");
        let b = &mut *self.buf;
        let (wi, wo, first) = (b.wi[k], b.wo[k], b.first[k] as usize);
        let mut known = Known {
            terms: &mut b.terms[k],
            ev: &b.ev,
            first,
        };
        let f = walk::eval(m, &self.nested, ctx, wi, wo, s, &mut known);
        (f, self.density(m, k))
    }
}

/// One lane's terms with their values known ([`WalkEvals::evaluate`]): the walk's nested
/// evals at a term's pair take the term's value, the others call the nested BSDF
/// ([`MicrofacetNormalMap::f`], as `PdfTerms::f` does for a pair that is no term).
struct Known<'t> {
    terms: &'t mut PdfTerms,
    ev: &'t Evaluated<CHUNK>,
    first: usize,
}

impl Terms for Known<'_> {
    #[inline(always)]
    fn g1_wo(&mut self, m: &MicrofacetNormalMap, wo: Vec3) -> f32 {
        self.terms.g1_wo(m, wo)
    }
    #[inline(always)]
    fn g1_rwo(&mut self, m: &MicrofacetNormalMap, rwo: Vec3) -> f32 {
        self.terms.g1_rwo(m, rwo)
    }
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn f(
        &mut self,
        m: &MicrofacetNormalMap,
        nested: &Bsdf,
        k: usize,
        ctx: &BsdfContext,
        a: Vec3,
        b: Vec3,
        s: &mut Sampler,
    ) -> Spectrum {
        for j in 0..self.terms.len() {
            if self.terms.pair(j) == (k, a, b) {
                return self.ev.f(self.first + j);
            }
        }
        m.f(nested, k, ctx, a, b, s)
    }
}

/// At most [`MAX_FACETS`] terms a point: a chunk's fit the batch.
const _: () = assert!(8 * MAX_FACETS <= CHUNK);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same, same3};
    use crate::bsdf::mnm::compensated::tests::push_reflectors as leaves;
    use crate::bsdf::mnm::facets::Microgeometry;
    use crate::bsdf::mnm::Tangent;
    use crate::bsdf::BsdfArena;
    use crate::math::Pcg32;

    /// A perturbed normal: mostly tilted up to ~70°, sometimes flat (the scalar path).
    fn perturbed(r: &mut Pcg32) -> Vec3 {
        if r.next_f32() < 0.05 {
            return Vec3::Z;
        }
        let t = 1.2 * r.next_f32();
        let phi = 2.0 * core::f32::consts::PI * r.next_f32();
        Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
    }

    /// The lanes' queries equal the scalar `Bsdf::eval_pdf` of each lane's map bit for bit
    /// (value and MIS density, and the stream's state after the walk), and each lane's terms
    /// equal the scalar `PdfTerms`: every term's batch value and density the fused nested
    /// `eval_pdf` of its pair (`MicrofacetNormalMap::fp`), p1 over the batch's densities
    /// `PdfTerms::total` with no density known (every term through the nested `pdf`). Over
    /// the sawtooth with and without its mirror wall, the V-groove and a U-groove, both nested
    /// leaves (the conductor with and without visible-normal sampling), random ωi and ωo over
    /// both hemispheres (some grazing or +z), walks up to 1 and 8 vertices long; lanes without
    /// a light sample, lanes whose query is not the walk's (flat maps, below the surface), and
    /// queries on the stream of each lane in lane order after the batch.
    #[test]
    fn lane_terms_and_walk_evals_equal_the_scalar_ones() {
        let mut rng = Pcg32::new(40, 2);
        let mut arena = BsdfArena::new();
        let geometries = [
            (Microgeometry::Sawtooth, Tangent::Mirror),
            (Microgeometry::Sawtooth, Tangent::Same),
            (Microgeometry::VGroove, Tangent::Same),
            (Microgeometry::UGroove { fill: 0.6 }, Tangent::Same),
        ];
        let ctx = BsdfContext::default();
        let (mut walked, mut terms_seen, mut scalar_lanes, mut nonzero) = (0, 0, 0, 0);
        // One buffer for every chunk, as the stream kernel keeps it.
        let mut buf = WalkEvalsBuf::new();
        for chunk in 0..2400 {
            let (geometry, tangent) = geometries[chunk % 4];
            arena.clear();
            let child = leaves(&mut arena)[chunk / 4 % 3];
            let order = if chunk % 5 == 0 { 1 } else { 8 };
            let mut roots = [u32::MAX; 8];
            let (mut wi, mut wo) = ([Vec3::Z; 8], [Vec3::Z; 8]);
            for k in 0..8 {
                let wp = perturbed(&mut rng);
                let m = MicrofacetNormalMap::new(
                    child,
                    wp,
                    geometry,
                    tangent,
                    Evaluation::RandomWalk,
                    order,
                );
                roots[k] = arena.push_microfacet_normal_map(m);
                (wi[k], wo[k]) = (direction(&mut rng), direction(&mut rng));
                if rng.next_f32() < 0.5 {
                    // Mostly above: the walk's queries.
                    (wi[k].z, wo[k].z) = (wi[k].z.abs(), wo[k].z.abs());
                }
            }
            let nested = arena.bsdf(child);
            let mut lanes =
                WalkEvals::new(nested, child, &mut buf).expect("a leaf with a lane form");
            // Lanes with a light sample (the others are not pushed).
            let lit: u8 = (rng.next_u32() & 0xff) as u8;
            let mut pushed = 0u8;
            for k in 0..8 {
                if lit & (1 << k) != 0 && lanes.push(k, arena.bsdf(roots[k]), wi[k], wo[k]) {
                    pushed |= 1 << k;
                }
            }
            assert_eq!(pushed, lanes.on);
            lanes.evaluate();
            for k in 0..8 {
                if lit & (1 << k) == 0 {
                    continue;
                }
                let root = arena.bsdf(roots[k]);
                let seed = rng.next_u32() as u64;
                let (mut s1, mut s2) = (Sampler::from_seed(seed, 4), Sampler::from_seed(seed, 4));
                let (f, p) = root.eval_pdf(&ctx, wi[k], wo[k], &mut s1);
                if !lanes.has(k) {
                    scalar_lanes += 1;
                    continue;
                }
                // The terms against the scalar ones.
                let m = lanes.maps[k].unwrap().map().unwrap();
                let t = if m.mirror_wall {
                    PdfTerms::mirror(m, wi[k], wo[k])
                } else {
                    PdfTerms::single(m, wi[k], wo[k])
                };
                assert_eq!(t.len(), lanes.terms[k].len());
                let first = lanes.first[k] as usize;
                for j in 0..t.len() {
                    assert_eq!(t.pair(j), lanes.terms[k].pair(j));
                    let (fk, a, b) = t.pair(j);
                    let (fs, ps) = m.fp(&nested, fk, &ctx, a, b, &mut s2.clone());
                    assert!(same3(lanes.ev.f(first + j), fs), "term {j}: {fs}");
                    assert!(same(lanes.ev.p(first + j), ps), "term {j}: {ps}");
                    terms_seen += 1;
                }
                let p1 = t.total(m, &nested, &ctx);
                let p1_lanes = lanes.terms[k].total_of(|j| lanes.ev.p(first + j));
                assert!(same(p1, p1_lanes), "p1 {p1} {p1_lanes}");
                // The query against the scalar one, and the streams after it.
                let (fl, pl) = lanes.eval_pdf(k, &ctx, &mut s2);
                assert!(same3(f, fl), "{f} {fl}");
                assert!(same(p, pl), "{p} {pl}");
                assert_eq!(s1.next_1d().to_bits(), s2.next_1d().to_bits());
                walked += 1;
                nonzero += usize::from(f != Vec3::ZERO);
            }
        }
        // The test saw every case: walks with values, terms, lanes left to the scalar code.
        assert!(walked > 3000 && terms_seen > 5000, "{walked} {terms_seen}");
        assert!(
            scalar_lanes > 1000 && nonzero > 1000,
            "{scalar_lanes} {nonzero}"
        );
    }
}
