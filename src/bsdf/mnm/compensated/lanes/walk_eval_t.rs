//! The two-sided walk's light-sample query ([`crate::bsdf::mnm::eval_pdf`]'s transmitting
//! branch: the next-event estimate [`crate::bsdf::mnm::walk::eval_t`] with the MIS density
//! `mnm::pdf`) of up to 8 shading points at once, one lane per point (issue 18, the glass
//! lanes' step 3 of the stream kernel's walk modes): the points whose query reaches that
//! branch over a `roughdielectric` leaf shared with the first such lane (same node, `max_order`
//! and `TransmissionWalk`) walk together, each lane active until its own walk ends.
//!
//! Per iteration, as the scalar loop (spec §9.2–9.4, the reciprocal two-sided walk with
//! next-event estimation): over the mirror wall the reflection; else the connection toward ωo
//! with `walk::connection_factor` (G1 on the side ωo leaves facet k on; for the early-exit walk
//! a refraction counts 1 on the far macro side and 0 on the near one), and, over the mirror
//! sawtooth below `max_order` (and for the early-exit walk not across the facet), the path
//! through the two-sided wall toward R(ωo) with its blocked·escape factor ((1 − G1(±R(ωo)))·
//! G1(±ωo), the side R(ωo) leaves facet k on); each connection one 8-wide
//! `RoughDielectric::eval_lanes` in facet k's frame (the maps' stored frames; the scalar
//! `MicrofacetNormalMap::f` reaches `RoughDielectric::eval`, its width 1, with the ctx's
//! transport mode), added to each lane's sum as the scalar `sum += thr·F·g`; at `max_order`
//! the nested lanes stop (a mirror lane still exits or picks); then the nested sample (one
//! 8-wide `RoughDielectric::sample_lanes`, as the sample walk's `walk8_t`), the early-exit
//! walk's end at a refraction, the exit test against G1 on the side d leaves the facet on and
//! the next facet ∝ a_j(∓d). Each lane draws from its own stream only while active, in the
//! scalar order (entry; `u1`, `u2`; exit; pick): the evaluations draw nothing.
//!
//! The density is `mnm::pdf`'s transmitting branch, 8-wide: `walk_density_lanes::two_sided_p1`
//! over the same columns, then the scalar mixture (`two_sided_pdf`). The lanes of a chunk are
//! one per stream, so walking them before the kernel's lane-by-lane loop keeps each stream's
//! order (`tests`: each lane against the scalar `Bsdf::eval_pdf` of its map).

use super::draws::step;
use super::sample::accepted;
use super::walk::{draw_2d, frame_of, l3, next_facet, pick3, set3, store_cols, Col3, MapCols};
use crate::bsdf::mnm::facets::{SurfaceLanes, MAX_FACETS};
use crate::bsdf::mnm::walk_density_lanes::{two_sided_p1, two_sided_pdf, TwoSidedCols};
use crate::bsdf::mnm::{walk_two_sided, MicrofacetNormalMap, TransmissionWalk};
use crate::bsdf::roughdielectric::RoughDielectric;
use crate::bsdf::{Bsdf, BsdfContext, BsdfNode, TransportMode};
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::pcg::Pcg;
use crate::lane::vec::V3;
use crate::lane::{Avx2, F32x8, Lane};
use crate::sampler::Samplers;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// The queries of [`two_sided_evals_x8`]: bit k of `lanes`, lane k was answered here (its
/// value and density by [`Self::value`]); the other lanes are left to the caller.
pub(crate) struct TwoSidedEvals {
    pub lanes: u8,
    f: Col3,
    pdf: [f32; 8],
}

impl TwoSidedEvals {
    /// No lane answered.
    #[inline(always)]
    pub(crate) fn none() -> Self {
        TwoSidedEvals {
            lanes: 0,
            f: [[0.0; 8]; 3],
            pdf: [0.0; 8],
        }
    }

    /// Whether lane `k` was answered here.
    #[inline(always)]
    pub(crate) fn has(&self, k: usize) -> bool {
        self.lanes & (1 << k) != 0
    }

    /// Lane `k`'s `(f·|cos θo|, MIS density)`: `Bsdf::eval_pdf` of its map bit for bit.
    #[inline(always)]
    pub(crate) fn value(&self, k: usize) -> (Spectrum, f32) {
        let f = Vec3::new(self.f[0][k], self.f[1][k], self.f[2][k]);
        (f, self.pdf[k])
    }
}

/// The light-sample queries of `q` (each lane's root BSDF, ωi and ωo in the shading frame;
/// `None`: no query) that reach `mnm::eval_pdf`'s transmitting branch (`walk_two_sided`: not
/// degenerate, a transmitting leaf, ωi.z ≠ 0; and ωo.z ≠ 0; a NaN ωi.z or ωo.z is left to the
/// scalar path) over a `roughdielectric` leaf shared with the first such lane (same node,
/// `max_order`, transmission walk), answered together, each lane from stream `ids[k]` of
/// `samplers`, its stream left where the scalar query leaves it.
#[inline(never)]
pub(crate) fn two_sided_evals_x8(
    avx: Avx2,
    ctx: &BsdfContext,
    q: &[Option<(Bsdf<'_>, Vec3, Vec3)>; 8],
    samplers: &mut Samplers,
    ids: &[u32; 8],
) -> TwoSidedEvals {
    let mut out = TwoSidedEvals::none();
    let mut maps: [Option<&MicrofacetNormalMap>; 8] = [None; 8];
    let mut shared: Option<(Bsdf<'_>, u32, bool)> = None;
    let mut c = ColsE {
        f: MapCols::new(),
        wi: [[0.0; 8]; 3],
        wo: [[0.0; 8]; 3],
        rwo: [[0.0; 8]; 3],
        lanes: 0,
        mirror: 0,
    };
    for (k, e) in q.iter().enumerate() {
        let Some((b, wi, wo)) = e else { continue };
        let Some((m, nested)) = walk_two_sided(*b, *wi) else {
            continue;
        };
        if wo.z == 0.0 || wo.z.is_nan() || !matches!(nested.node(), BsdfNode::RoughDielectric(_)) {
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
        // The point's facets (area vectors, normals), the carrying facets' frames.
        c.f.set_lane(k, m, true);
        set3(&mut c.wi, k, *wi);
        set3(&mut c.wo, k, *wo);
        if m.mirror_wall {
            set3(&mut c.rwo, k, m.reflect_wall(*wo));
            c.mirror |= 1 << k;
        }
        c.lanes |= 1 << k;
        maps[k] = Some(m);
    }
    let Some((nested, max_order, exits)) = shared else {
        return out;
    };
    let BsdfNode::RoughDielectric(leaf) = nested.node() else {
        unreachable!("the walking lanes' leaf is a rough dielectric");
    };
    let shape = (max_order, exits);
    out.f = walk8_eval_t(avx, leaf, ctx.mode, &c, shape, samplers, ids);
    // `mnm::pdf`: p1 8-wide, then the scalar mixture.
    let p1 = two_sided_p1(
        avx,
        leaf,
        exits,
        TwoSidedCols {
            v: &c.f.v,
            nrm: &c.f.nrm,
            fr: &c.f.fr,
            wi: &c.wi,
            wo: &c.wo,
        },
        c.lanes,
        c.mirror,
    );
    let mut rest = c.lanes;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let m = maps[k].expect("a walked lane has its map");
        let at = |col: &Col3| Vec3::new(col[0][k], col[1][k], col[2][k]);
        out.pdf[k] = two_sided_pdf(m, p1[k], at(&c.wi), at(&c.wo));
    }
    out.lanes = c.lanes;
    out
}

/// [`two_sided_evals_x8`]'s inputs by lane.
struct ColsE {
    /// The points' facets (area vectors, normals) and carrying facets' frames.
    f: MapCols,
    wi: Col3,
    wo: Col3,
    /// R(ωo) for the lanes whose map has the mirror wall.
    rwo: Col3,
    /// Bit k: lane k walks; lane k's map has the mirror wall.
    lanes: u8,
    mirror: u8,
}

/// The masked `walk::eval_t` of the lanes of `c` (see the module's doc), in 8-wide code:
/// `shape` is `max_order` and whether the walk ends at refractions. Returns each lane's sum.
#[inline(always)]
fn walk8_eval_t(
    avx: Avx2,
    leaf: &RoughDielectric,
    mode: TransportMode,
    c: &ColsE,
    shape: (u32, bool),
    samplers: &mut Samplers,
    ids: &[u32; 8],
) -> Col3 {
    let (max_order, exits) = shape;
    let all_plain = samplers.all_plain();
    avx.run(
        #[inline(always)]
        || {
            let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
            let surf = SurfaceLanes {
                v: [l3(avx, &c.f.v[0]), l3(avx, &c.f.v[1]), l3(avx, &c.f.v[2])],
            };
            let nrm = [
                l3(avx, &c.f.nrm[0]),
                l3(avx, &c.f.nrm[1]),
                l3(avx, &c.f.nrm[2]),
            ];
            let mut fr = [LaneFrame {
                s: V3::new(zero, zero, zero),
                t: V3::new(zero, zero, zero),
                n: V3::new(zero, zero, zero),
            }; MAX_FACETS];
            for (f, col) in fr.iter_mut().zip(c.f.fr.iter()) {
                *f = LaneFrame {
                    s: l3(avx, &col[0]),
                    t: l3(avx, &col[1]),
                    n: l3(avx, &col[2]),
                };
            }
            let wall = avx.mask_bits(u32::from(c.mirror));
            let (wi, wo, rwo) = (l3(avx, &c.wi), l3(avx, &c.wo), l3(avx, &c.rwo));
            // G1 of ωo and R(ωo) on either side (`walk::exit_factor`, the wall's term), and
            // the early exit's test of a refraction's macro side.
            let (g1_up, g1_down) = (surf.g1(wo), surf.g1(-wo));
            let (rg1_up, rg1_down) = (surf.g1(rwo), surf.g1(-rwo));
            let far = (wo.z * wi.z).lt(zero);
            let idx = avx.load_u32(ids);
            let on = avx.mask_bits(u32::from(c.lanes));
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            // The entry: the facet hit from ωi, seen from its side (`walk::entry`).
            let u = step(avx, &mut rng, on);
            let (some, mut k) = surf.pick(V3::select(wi.z.ge(zero), wi, -wi), u);
            let mut act = on & some;
            let mut d = -wi;
            let mut thr = V3::new(one, one, one);
            let mut sum = V3::new(zero, zero, zero);
            // `next_facet` notes where walks end (the sample walk's counts): not used here.
            let mut ends = [0u32; 8];
            for order in 1..=max_order {
                if act.bits() == 0 {
                    break;
                }
                let n = pick3(&k, &nrm);
                let mir = act & wall & k[1];
                let nest = act & !mir;
                // The mirror wall: d − (2 ⟨d, n⟩) n (a delta vertex: no next-event estimate).
                let r = d - n.scale(avx.splat(2.0) * d.dot(n));
                d = V3::select(mir, r, d);
                if nest.bits() != 0 {
                    let f = frame_of(&k, &fr);
                    let a = f.to_local(-d);
                    let dn = d.dot(n);
                    // Toward ωo: `walk::connection_factor`.
                    let won = wo.dot(n);
                    let mut g = F32x8::select(won.gt(zero), g1_up, g1_down);
                    if exits {
                        let refracts = (dn * won).gt(zero);
                        g = F32x8::select(refracts, F32x8::select(far, one, zero), g);
                    }
                    let to_wo = nest & g.gt(zero);
                    if to_wo.bits() != 0 {
                        let fv = leaf.eval_lanes(mode, a, f.to_local(wo));
                        sum = V3::select(to_wo, sum + (thr * fv).scale(g), sum);
                    }
                    // Through the two-sided mirror wall: p → t → ωo needs one more vertex.
                    if order < max_order {
                        let rwon = rwo.dot(n);
                        let mut through = nest & wall;
                        if exits {
                            through = through & !(dn * rwon).gt(zero);
                        }
                        let up = rwon.gt(zero);
                        let blocked = F32x8::select(up, one - rg1_up, one - rg1_down);
                        let escape = F32x8::select(up, g1_up, g1_down);
                        let through = through & blocked.gt(zero) & escape.gt(zero);
                        if through.bits() != 0 {
                            let fv = leaf.eval_lanes(mode, a, f.to_local(rwo));
                            let w = blocked * escape;
                            sum = V3::select(through, sum + (thr * fv).scale(w), sum);
                        }
                    }
                    if order == max_order {
                        // The nested lanes end here; a mirror lane still exits or picks.
                        act = act & !nest;
                    } else {
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
                        let (s, _, _) = leaf.sample_lanes(mode, a, u1, u2);
                        let ok = nest & accepted(&s);
                        // A nested sample that is none: the walk ends.
                        act = act & !(nest & !ok);
                        thr = V3::select(ok, thr * s.weight, thr);
                        let out = f.to_world(s.wo);
                        if exits {
                            // §9.4: the sampled walk ends at a refraction.
                            act = act & !(ok & (dn * out.dot(n)).gt(zero));
                        }
                        d = V3::select(ok, out, d);
                    }
                }
                // The exit test against G1 on the side d leaves the facet on (`walk::step`).
                let upper = d.dot(n).gt(zero);
                let g1 = surf.g1(V3::select(upper, d, -d));
                let towards = V3::select(upper, -d, d);
                let u = step(avx, &mut rng, act);
                act = act & !u.lt(g1);
                // The next facet, hit ∝ a_j(towards).
                act = next_facet(avx, &mut rng, &surf, towards, act, &mut k, &mut ends, order);
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
    use super::super::walk::tests::{
        assert_same_streams, random_wp, same, same3, streams, GEOMETRIES,
    };
    use super::*;
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::bsdf::mnm::{Evaluation, Tangent};
    use crate::bsdf::BsdfArena;
    use crate::math::Pcg32;

    /// A direction over the whole sphere (the two-sided walk takes either side), grazing
    /// ones and +z mixed in, now and then one exactly in the plane (not walked).
    fn random_dir(r: &mut Pcg32) -> Vec3 {
        let z = match r.next_u32() % 20 {
            0 => (r.next_f32() - 0.5) * 0.04,
            1 => 0.0,
            2 => 1.0,
            _ => 2.0 * r.next_f32() - 1.0,
        };
        let phi = r.next_f32() * std::f32::consts::TAU;
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// The masked two-sided eval (`two_sided_evals_x8`) equals the scalar `Bsdf::eval_pdf` of
    /// each lane's map (`mnm::eval_pdf`'s transmitting branch: `walk::eval_t` and `mnm::pdf`)
    /// bit for bit in value and MIS density, and leaves every stream where the scalar query
    /// leaves it (the streams of the lanes not answered here untouched until the scalar query
    /// runs on them): both `TransmissionWalk` variants, both transport modes, two rough
    /// dielectrics (GGX with visible sampling and η 1.5; Beckmann without, η 1/1.33, coloured
    /// reflectance and transmittance), the sawtooth with and without the mirror wall, the
    /// V-groove, U-grooves with fill 0.5 and 1, random ωi and ωo on both sides (grazing, +z,
    /// in the plane: not walked), independent and stratified streams (some still in their
    /// strata), lanes without a light sample, flat maps and reflecting maps (not walked),
    /// `max_order` 1, 3 and 10, and lanes with another `max_order` (left to the scalar walk).
    #[test]
    fn masked_two_sided_evals_equal_the_scalar_queries() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut rng = Pcg32::new(41, 4);
        let geometries = GEOMETRIES;
        let (mut walked, mut nonzero, mut scalar, mut unlit, mut stratified_draws) =
            (0, 0, 0, 0, 0);
        let (mut mirror_nonzero, mut far_nonzero, mut from_below, mut exit_nonzero) = (0, 0, 0, 0);
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
            let walk = if (round / 30) % 2 == 0 {
                TransmissionWalk::TwoSided
            } else {
                TransmissionWalk::ExitOnRefraction
            };
            let ctx = BsdfContext {
                mode: if (round / 60) % 2 == 0 {
                    TransportMode::Radiance
                } else {
                    TransportMode::Importance
                },
            };
            let stratified = round % 3 == 1;
            let mut pts: [Option<(u32, Vec3, Vec3)>; 8] = [None; 8];
            for p in pts.iter_mut() {
                if rng.next_u32().is_multiple_of(7) {
                    unlit += 1;
                    continue; // a lane without a light sample
                }
                let reflecting = rng.next_u32().is_multiple_of(11);
                // Now and then a lane with another walk length.
                let order = if rng.next_u32().is_multiple_of(13) {
                    max_order + 1
                } else {
                    max_order
                };
                let m = MicrofacetNormalMap::new(
                    if reflecting { conductor } else { n },
                    random_wp(&mut rng),
                    geo,
                    tangent,
                    Evaluation::RandomWalk,
                    order,
                )
                .with_transmission_walk(walk);
                let (wi, wo) = (random_dir(&mut rng), random_dir(&mut rng));
                *p = Some((arena.push_microfacet_normal_map(m), wi, wo));
            }
            let (mut all, ids, mut cols) = streams(&mut rng, stratified, &mut stratified_draws);
            let arena = &arena;
            let q: [Option<(Bsdf<'_>, Vec3, Vec3)>; 8] =
                std::array::from_fn(|k| pts[k].map(|(r, wi, wo)| (arena.bsdf(r), wi, wo)));
            let got = two_sided_evals_x8(avx, &ctx, &q, &mut cols, &ids);
            // The lanes that must be here: the transmitting branch over the first such
            // lane's leaf with its `max_order`.
            let mut want = 0u8;
            let mut first_order = None;
            for (k, e) in q.iter().enumerate() {
                let Some((b, wi, wo)) = e else { continue };
                let Some((m, _)) = walk_two_sided(*b, *wi) else {
                    continue;
                };
                if wo.z == 0.0 || *first_order.get_or_insert(m.max_order) != m.max_order {
                    continue;
                }
                want |= 1 << k;
            }
            assert_eq!(got.lanes, want, "round {round}");
            for k in 0..8 {
                let Some((r, wi, wo)) = pts[k] else { continue };
                let s = ids[k] as usize;
                let (f, p) = arena.bsdf(r).eval_pdf(&ctx, wi, wo, &mut all[s]);
                let (fl, pl) = if got.has(k) {
                    walked += 1;
                    got.value(k)
                } else {
                    scalar += 1;
                    arena.bsdf(r).eval_pdf(&ctx, wi, wo, &mut cols.at(s))
                };
                assert!(same3(f, fl), "round {round} lane {k}: {f} {fl}");
                assert!(same(p, pl), "round {round} lane {k}: {p} {pl}");
                if got.has(k) && f != Vec3::ZERO {
                    nonzero += 1;
                    mirror_nonzero += usize::from(tangent == Tangent::Mirror);
                    far_nonzero += usize::from(wi.z * wo.z < 0.0);
                    from_below += usize::from(wi.z < 0.0);
                    exit_nonzero += usize::from(walk == TransmissionWalk::ExitOnRefraction);
                }
            }
            assert_same_streams(&mut all, &cols, round);
        }
        // Most queries are answered here with values: over the mirror sawtooth, across the
        // surface, from below, by the early-exit walk; some lanes are left to the scalar
        // query; lanes without a light sample; streams in their strata.
        let seen = format!(
            "walked {walked} nonzero {nonzero} mirror {mirror_nonzero} far {far_nonzero} \
             below {from_below} exit {exit_nonzero} scalar {scalar} unlit {unlit} \
             stratified {stratified_draws}"
        );
        eprintln!("{seen}");
        assert!(walked > 12000 && nonzero > 6000, "{seen}");
        assert!(
            mirror_nonzero > 1500 && far_nonzero > 1000 && from_below > 2000,
            "{seen}"
        );
        assert!(exit_nonzero > 2000, "{seen}");
        assert!(scalar > 1500 && unlit > 2000, "{seen}");
        assert!(stratified_draws > 2000, "{seen}");
    }
}
