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
use crate::bsdf::{Bsdf, BsdfContext};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[inline]
fn mirror(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Sample an outgoing direction by walking; returns (ωo, throughput, lobe).
pub(super) fn sample(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<(Vec3, Spectrum, u32)> {
    let surf = &m.surface;
    let (mut k, _) = surf.pick(wi, s.next_1d())?;
    let mut d = -wi;
    let mut thr = Spectrum::ONE;
    for _ in 0..m.max_order {
        if m.is_mirror(k) {
            d = mirror(d, surf.normal(k));
        } else {
            let (w, weight) = m.sample_facet(nested, k, ctx, -d, s)?;
            thr *= weight;
            d = w;
        }
        if s.next_1d() < surf.g1(d) {
            return Some((d, thr, lobe_of(nested)));
        }
        k = surf.pick(-d, s.next_1d())?.0;
    }
    None
}

/// Next-event estimate of f·cos along one walk (stochastic, unbiased).
pub(super) fn eval(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> Spectrum {
    let surf = &m.surface;
    let g1o = surf.g1(wo);
    if g1o <= 0.0 {
        return Spectrum::ZERO;
    }
    // Connection through the mirror wall toward ωo (only when ωo faces the wall).
    let through_mirror = if m.mirror_wall && wo.dot(surf.normal(1)) > 0.0 {
        let rwo = m.reflect_wall(wo);
        Some((rwo, (1.0 - surf.g1(rwo)) * g1o))
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
                sum += thr * m.f(nested, k, ctx, -d, wo, s) * g1o;
            }
            if let Some((rwo, w)) = through_mirror {
                // p → t → ωo needs one more vertex: keep truncation identical to sampling.
                if order < m.max_order && w > 0.0 && rwo.dot(n) > 0.0 {
                    sum += thr * m.f(nested, k, ctx, -d, rwo, s) * w;
                }
            }
            if order == m.max_order {
                break;
            }
            let Some((w, weight)) = m.sample_facet(nested, k, ctx, -d, s) else {
                break;
            };
            thr *= weight;
            d = w;
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
