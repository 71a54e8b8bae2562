//! The MIS density of the two-sided random walk's BSDF samples at the shading points of a
//! stream chunk (issue 18, forty-first session): the density that `mnm::sample` reports for a
//! walk that escaped, for the lanes that the masked 8-lane walk (`compensated::lanes::walk`)
//! walked, 8-wide instead of one scalar `mnm::pdf` per lane.
//!
//! It is decision 3 of `docs/spec/mnm.md` for a transmitting leaf (`roughdielectric`;
//! `mnm::pdf` → `walk::single_scatter_pdf_t`): (1 − c)·p1 + c·½·|cos θo|/π (the cosine lobe
//! split over both hemispheres), p1 = Σ_k λ_k(w)·P_k(ωi, ωo)·g_k over the facets that carry
//! the leaf, w = ωi seen from its side, g_k the connection factor toward ωo (G1 on the side ωo
//! leaves facet k on; for the early-exit walk a refraction counts 1 on the far macro side and 0
//! on the near one) ([`two_sided_p1`], [`two_sided_pdf`]). Every step is 8-wide here: λ from
//! each lane's area vectors, G1(±ωo) by [`SurfaceLanes::g1`], the pairs' frames, one
//! `RoughDielectric::pdf_lanes` call per facet slot that a lane counts, the sum.
//!
//! **The same bits.** The leaf's scalar `pdf` is `pdf_lanes` at width 1, and the lane form
//! gives every lane the width-1 result (the lane module's rule); the frames' `to_local` is the
//! lane form at width 1 too. λ: the scalar λ_k(w) = a_k/Σ with a_k = max(⟨w, v_k⟩, 0) and Σ
//! the sum of the facets' a_k; a lane's padded slots (zero area vectors) add ±0 to Σ, which
//! leaves a positive Σ as it is, and a Σ that is not positive gives λ = 0 either way. The sum
//! is added in the scalar order from the scalar start (`Iterator::sum`'s neutral element,
//! taken from the standard library itself), skipping the slots the scalar loop skips (past the
//! facets, the mirror wall), and the final mixture is the scalar expression. `tests` checks it
//! against `mnm::pdf`. The density draws no random number, so computing it after the walks
//! changes no stream.
//!
//! Here, beside `walk.rs` and `walk_pdf_lanes.rs`, rather than in the masked walks' file: it
//! reads the maps' private facets, frames and MIS weight as those do.

use super::facets::{SurfaceLanes, MAX_FACETS};
use super::MicrofacetNormalMap;
use crate::bsdf::roughdielectric::RoughDielectric;
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
#[inline(always)]
#[allow(clippy::needless_range_loop)] // slot j indexes five column sets and `a` alike
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same};
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::bsdf::mnm::facets::Microgeometry;
    use crate::bsdf::mnm::{pdf as mnm_pdf, walk, Evaluation, Tangent};
    use crate::bsdf::mnm::{TransmissionWalk, FLAT};
    use crate::bsdf::{BsdfArena, BsdfContext, BsdfNode, TransportMode};
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
    #[test]
    #[allow(clippy::needless_range_loop)] // lane k indexes the columns, `roots` and `p1` alike
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
}
