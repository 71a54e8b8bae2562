//! The Smith random walk on the microsurface (spec §3, §5; Heitz et al. 2016's walk on our facet
//! set): the ray enters on facet k with probability λ_k(ωi), scatters by the facet's BSDF (or is
//! mirrored by the sawtooth's wall), escapes with probability G1(d), otherwise hits the next facet
//! chosen ∝ a_j(−d). `max_order` vertices at most: a longer walk is absorbed, identically in
//! `sample` and `eval`.
//!
//! `eval` is the walk's next-event estimate (unbiased): at every facet vertex it adds the
//! throughput times F_k(−d, ωo)·G1(ωo), and, for the mirror wall, the path that reaches ωo
//! through the mirror (correction 1 of the decisions page; without it a furnace reads 0.76 at
//! θp = 60°).

use super::explicit::lobe_of;
use super::MicrofacetNormalMap;
use crate::bsdf::{Bsdf, BsdfContext, Lobes};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[inline]
fn mirror(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// A walk that escaped right after its first vertex, on facet `k` (not the mirror): ωo was
/// sampled by the nested BSDF from ωi in facet k's frame with density `pdf`, which is the term
/// P_k(ωi, ωo) of the MIS density (`PdfTerms::know`).
#[derive(Clone, Copy, Debug)]
pub(super) struct FirstVertex {
    pub k: usize,
    pub pdf: f32,
}

/// Sample an outgoing direction by walking; returns (ωo, throughput, lobe, the first vertex when
/// the walk escaped from it).
pub(super) fn sample(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<(Vec3, Spectrum, Lobes, Option<FirstVertex>)> {
    let w = sample_counted(m, nested, ctx, wi, s)?;
    Some((w.wo, w.weight, lobe_of(nested.lobes()), w.first))
}

/// One escaped walk of [`sample_counted`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Walked {
    pub wo: Vec3,
    pub weight: Spectrum,
    /// The first vertex when the walk escaped from it.
    pub first: Option<FirstVertex>,
    /// Scattering events on facets that carry the nested BSDF (the mirror wall's reflections
    /// are not counted): the walk's order in the sense of the per-order energy tables
    /// ([`super::ms_table`]).
    pub nested_vertices: u32,
}

/// [`sample`] that also counts the nested BSDF's vertices (the same walk, the same random
/// numbers).
pub(super) fn sample_counted(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<Walked> {
    let surf = &m.surface;
    let (mut k, _) = surf.pick(wi, s.next_1d())?;
    let mut d = -wi;
    let mut thr = Spectrum::ONE;
    let mut first = None;
    let mut nested_vertices = 0;
    for order in 1..=m.max_order {
        if m.is_mirror(k) {
            d = mirror(d, surf.normal(k));
        } else {
            let Some(bs) = m.sample_facet(nested, k, ctx, -d, s) else {
                nested.record_walk(order);
                return None;
            };
            thr *= bs.weight;
            d = bs.wo;
            nested_vertices += 1;
            if order == 1 {
                first = Some(FirstVertex { k, pdf: bs.pdf });
            }
        }
        if s.next_1d() < surf.g1(d) {
            nested.record_walk(order);
            let first = if order == 1 { first } else { None };
            return Some(Walked {
                wo: d,
                weight: thr,
                first,
                nested_vertices,
            });
        }
        let Some((j, _)) = surf.pick(-d, s.next_1d()) else {
            nested.record_walk(order);
            return None;
        };
        k = j;
    }
    nested.record_walk(m.max_order);
    None
}

/// What [`eval`] asks of the MIS density's terms: G1(ωo) and G1(R(ωo)), each computed once,
/// and the nested eval F_k(a, b) of each connection, which the terms may already know (the
/// walk's first vertex evaluates pairs that are terms). `PdfTerms` computes a term's value
/// when the walk first asks for it (its density from the same fused call); the stream kernel's
/// lanes (`walk_pdf_lanes`) hand in the values their 8-wide calls computed before the walk.
pub(super) trait Terms {
    /// G1(ωo) (the `wo` these terms were built for), computed once.
    fn g1_wo(&mut self, m: &MicrofacetNormalMap, wo: Vec3) -> f32;
    /// G1(R(ωo)) (`rwo` = R(ωo) of that `wo`), computed once.
    fn g1_rwo(&mut self, m: &MicrofacetNormalMap, rwo: Vec3) -> f32;
    /// F_k(a, b), the nested eval in facet k's frame ([`MicrofacetNormalMap::f`]'s value).
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
    ) -> Spectrum;
}

/// Next-event estimate of f·cos along one walk (stochastic, unbiased). Nested evals go through
/// `terms` (`PdfTerms`' [`Terms::f`]): where the walk evaluates a pair that is also a term of
/// the MIS density (its first vertex: (ωi, ωo), (ωi, R(ωo)), after the mirror (R(ωi), ωo)),
/// the term's pdf comes from the same fused call, and G1(ωo), G1(R(ωo)) are shared with the
/// terms. Pass
/// `PdfTerms::empty` when no pdf is wanted. (Generic over [`Terms`]: the stream kernel's
/// lanes pass terms whose values are known before the walk. Out of line, as it was before it
/// was generic: its callers in the stream kernel's AVX2 region would otherwise take in the
/// whole walk.)
#[inline(never)]
pub(super) fn eval<T: Terms>(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
    terms: &mut T,
) -> Spectrum {
    let surf = &m.surface;
    let g1o = terms.g1_wo(m, wo);
    if g1o <= 0.0 {
        return Spectrum::ZERO;
    }
    // Connection through the mirror wall toward ωo (only when ωo faces the wall).
    let through_mirror = if m.mirror_wall && wo.dot(surf.normal(1)) > 0.0 {
        let rwo = m.reflect_wall(wo);
        Some((rwo, (1.0 - terms.g1_rwo(m, rwo)) * g1o))
    } else {
        None
    };
    let Some((mut k, _)) = surf.pick(wi, s.next_1d()) else {
        return Spectrum::ZERO;
    };
    let mut d = -wi;
    let mut thr = Spectrum::ONE;
    let mut sum = Spectrum::ZERO;
    for order in 1..=m.max_order {
        if m.is_mirror(k) {
            d = mirror(d, surf.normal(k)); // delta vertex: no next-event estimate
        } else {
            let n = surf.normal(k);
            if wo.dot(n) > 0.0 {
                sum += thr * terms.f(m, nested, k, ctx, -d, wo, s) * g1o;
            }
            if let Some((rwo, w)) = through_mirror {
                // p → t → ωo needs one more vertex: keep truncation identical to sampling.
                if order < m.max_order && w > 0.0 && rwo.dot(n) > 0.0 {
                    sum += thr * terms.f(m, nested, k, ctx, -d, rwo, s) * w;
                }
            }
            if order == m.max_order {
                break;
            }
            let Some(bs) = m.sample_facet(nested, k, ctx, -d, s) else {
                break;
            };
            thr *= bs.weight;
            d = bs.wo;
        }
        if s.next_1d() < surf.g1(d) {
            break;
        }
        match surf.pick(-d, s.next_1d()) {
            Some((j, _)) => k = j,
            None => break,
        }
    }
    sum
}

// ---------------------------------------------------------------------------------------------
// Transmission (spec §9.2–9.3): the reciprocal two-sided walk. The walker is on the air side of
// the microsurface or inside the material; seen from inside, the microsurface is the same facet
// set with normals −m_k and "up" −ωg, so λ and G1 of a direction ω below are those of −ω. After
// scattering at facet m into d: d·m > 0 means the air side (escape upward with G1(d), else hit
// the facet ∝ a_j(−d)), d·m < 0 the material side (escape downward with G1(−d), else hit a
// facet's underside ∝ a_j(d)). The sawtooth's mirror wall reflects on both sides.
//
// With `TransmissionWalk::ExitOnRefraction` (§9.4) the same functions end the walk at the first
// refraction (the nested sample leaves facet m on the other side than it arrived): the refracted
// direction is returned with no exit masking if it lies on the far side of the macro surface,
// and the walk is absorbed otherwise (failure mode (a), see `TransmissionWalk`). The walker thus
// never changes sides; eval's next-event estimate gives a refracting connection the factor 1 (or
// 0 on the wrong macro side) instead of G1, and the mirror-wall connection only on the arrival
// side, so that eval stays the density of what sample produces.

/// Exit factor toward ωo from a vertex on facet normal `n`: G1 on the side ωo leaves on.
#[inline]
fn exit_factor(m: &MicrofacetNormalMap, n: Vec3, wo: Vec3) -> f32 {
    if wo.dot(n) > 0.0 {
        m.surface.g1(wo)
    } else {
        m.surface.g1(-wo)
    }
}

/// True when the walk ends at refractions (§9.4).
#[inline]
fn exits_on_refraction(m: &MicrofacetNormalMap) -> bool {
    m.transmission_walk == super::TransmissionWalk::ExitOnRefraction
}

/// Factor of a connection from a vertex on facet normal `n`, reached by a ray arriving along
/// `d` (from the walk that started at `wi`), toward `wo`: G1 on the side `wo` leaves on; for the
/// early-exit walk a refraction is not masked (1) and counts only on the far macro side.
#[inline]
fn connection_factor(m: &MicrofacetNormalMap, n: Vec3, d: Vec3, wi: Vec3, wo: Vec3) -> f32 {
    if exits_on_refraction(m) && d.dot(n) * wo.dot(n) > 0.0 {
        // −d and wo on opposite sides of the facet: a refraction.
        if wo.z * wi.z < 0.0 {
            1.0
        } else {
            0.0
        }
    } else {
        exit_factor(m, n, wo)
    }
}

/// The facet first hit by a ray arriving from `wi` (which may lie below the macro surface).
#[inline]
fn entry(m: &MicrofacetNormalMap, wi: Vec3, u: f32) -> Option<usize> {
    let w = if wi.z >= 0.0 { wi } else { -wi };
    m.surface.pick(w, u).map(|(k, _)| k)
}

/// After leaving a facet of normal `n` in direction `d`: escaped (Some(true)), or the next facet.
#[inline]
fn step(m: &MicrofacetNormalMap, n: Vec3, d: Vec3, s: &mut Sampler) -> Result<usize, bool> {
    let (g1, towards) = if d.dot(n) > 0.0 {
        (m.surface.g1(d), -d)
    } else {
        (m.surface.g1(-d), d)
    };
    if s.next_1d() < g1 {
        return Err(true);
    }
    m.surface
        .pick(towards, s.next_1d())
        .map(|(k, _)| k)
        .ok_or(false)
}

/// Sample by the two-sided (or early-exit) walk; returns (ωo, throughput, net η, lobe).
pub(super) fn sample_t(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<(Vec3, Spectrum, f32, Lobes)> {
    let surf = &m.surface;
    let mut k = entry(m, wi, s.next_1d())?;
    let mut d = -wi;
    let mut thr = Spectrum::ONE;
    let mut eta = 1.0f32;
    for order in 1..=m.max_order {
        let n = surf.normal(k);
        if m.is_mirror(k) {
            d = mirror(d, n);
        } else {
            let Some(bs) = m.sample_facet(nested, k, ctx, -d, s) else {
                nested.record_walk(order);
                return None;
            };
            thr *= bs.weight;
            eta *= bs.eta;
            let out = bs.wo;
            // Arrived along d (from the side of −d), left along `out`: other side = refraction.
            let refracted = d.dot(n) * out.dot(n) > 0.0;
            d = out;
            if exits_on_refraction(m) && refracted {
                // §9.4: returned at once, unmasked; on the wrong macro side: absorbed.
                nested.record_walk(order);
                return (d.z * wi.z < 0.0).then_some((d, thr, eta, Lobes::GLOSSY_TRANSMISSION));
            }
        }
        let next = step(m, n, d, s);
        if next.is_err() {
            nested.record_walk(order);
        }
        match next {
            Err(true) => {
                let lobe = if d.z * wi.z < 0.0 {
                    Lobes::GLOSSY_TRANSMISSION
                } else {
                    crate::bsdf::Lobes::GLOSSY_REFLECTION
                };
                return Some((d, thr, eta, lobe));
            }
            Err(false) => return None,
            Ok(j) => k = j,
        }
    }
    nested.record_walk(m.max_order);
    None
}

/// Next-event estimate along one two-sided (or early-exit) walk (stochastic, unbiased).
pub(super) fn eval_t(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    let surf = &m.surface;
    let Some(mut k) = entry(m, wi, s.next_1d()) else {
        return Spectrum::ZERO;
    };
    let mut d = -wi;
    let mut thr = Spectrum::ONE;
    let mut sum = Spectrum::ZERO;
    for order in 1..=m.max_order {
        let n = surf.normal(k);
        if m.is_mirror(k) {
            d = mirror(d, n);
        } else {
            let g = connection_factor(m, n, d, wi, wo);
            if g > 0.0 {
                sum += thr * m.f(nested, k, ctx, -d, wo, s) * g;
            }
            let rwo_refracts = d.dot(n) * m.reflect_wall(wo).dot(n) > 0.0;
            if m.mirror_wall && order < m.max_order && !(exits_on_refraction(m) && rwo_refracts) {
                // Through the (two-sided) mirror wall: leave facet k toward R(ωo) on one side
                // (air if R(ωo)·n > 0), be blocked there, reflect to ωo — the mirror keeps the
                // side — and escape on that side.
                let rwo = m.reflect_wall(wo);
                let (blocked, escape) = if rwo.dot(n) > 0.0 {
                    (1.0 - surf.g1(rwo), surf.g1(wo))
                } else {
                    (1.0 - surf.g1(-rwo), surf.g1(-wo))
                };
                if blocked > 0.0 && escape > 0.0 {
                    sum += thr * m.f(nested, k, ctx, -d, rwo, s) * (blocked * escape);
                }
            }
            if order == m.max_order {
                break;
            }
            let Some(bs) = m.sample_facet(nested, k, ctx, -d, s) else {
                break;
            };
            thr *= bs.weight;
            let out = bs.wo;
            if exits_on_refraction(m) && d.dot(n) * out.dot(n) > 0.0 {
                break; // the sampled walk ends at this refraction
            }
            d = out;
        }
        match step(m, n, d, s) {
            Err(_) => break,
            Ok(j) => k = j,
        }
    }
    sum
}

/// Single-scattering density of successful one-vertex walks, the p1 of the MIS pdf (decision 3)
/// for transmitting nested BSDFs (for the early-exit walk, refractions unmasked).
pub(super) fn single_scatter_pdf_t(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    let surf = &m.surface;
    let w = if wi.z >= 0.0 { wi } else { -wi };
    (0..surf.len())
        .filter(|&k| !m.is_mirror(k))
        .map(|k| {
            let l = surf.lambda(k, w);
            if l > 0.0 {
                l * m.p(nested, k, ctx, wi, wo) * connection_factor(m, surf.normal(k), -wi, wi, wo)
            } else {
                0.0
            }
        })
        .sum()
}
