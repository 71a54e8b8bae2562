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

use super::explicit;
use super::ms_table::{Colour, MsTable, ThetaCell};
use super::MicrofacetNormalMap;
use crate::bsdf::{Bsdf, BsdfContext, BsdfNode, BsdfSample};
use crate::math::{warp, INV_PI};
use crate::sampler::Sampler;
use crate::spectrum::{luminance, Spectrum};
use glam::Vec3;

/// A shading point's table and its place in it (built per hit).
#[derive(Clone, Copy, Debug)]
pub struct MsRef {
    pub table: &'static MsTable,
    pub cell: ThetaCell,
    /// With the colour baked in ([`Colour::Baked`]): 1 / (π Ē_ms) of this point, per channel.
    baked_norm: Option<Spectrum>,
}

impl MsRef {
    /// `wp`: the (clamped, not flat) perturbed normal.
    pub fn new(table: &'static MsTable, wp: Vec3) -> MsRef {
        let cell = table.cell(wp);
        let baked_norm = (table.spec.colour == Colour::Baked).then(|| {
            let m = table.mean_baked(&cell);
            Vec3::new(inv(m.x), inv(m.y), inv(m.z)) * INV_PI
        });
        MsRef {
            table,
            cell,
            baked_norm,
        }
    }
}

/// What depends on ωi only: the colour coefficients, Ē_ms, E_ms(ωi) and the lobe choice s(ωi).
struct AtWi {
    k: [[Spectrum; 3]; 2],
    /// 1 / (π Ē_ms) per channel (0 where Ē_ms = 0).
    norm: Spectrum,
    ei: Spectrum,
    select: f32,
}

/// The per-bounce colour c at this hit (1 when the table has the colours baked in).
#[inline]
fn colour(r: &MsRef, nested: &Bsdf) -> Spectrum {
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
    #[inline]
    fn new(r: &MsRef, nested: &Bsdf, wi: Vec3) -> AtWi {
        let t = r.table;
        if let Some(norm) = r.baked_norm {
            let [w1, ei] = t.lookup_baked(&r.cell, wi, true);
            return AtWi {
                k: [[Spectrum::ONE; 3]; 2],
                norm,
                ei,
                select: selection(ei, w1),
            };
        }
        let c = colour(r, nested);
        let k = t.coefficients(&r.cell, c);
        let ebar = t.mean_remainder(&r.cell, &k);
        let norm = Vec3::new(inv(ebar.x), inv(ebar.y), inv(ebar.z)) * INV_PI;
        let l = t.lookup(&r.cell, wi);
        let ei = MsTable::remainder(&l, &k);
        AtWi {
            k,
            norm,
            ei,
            select: selection(ei, c * MsTable::first(&l, &r.cell)),
        }
    }

    /// The rank-1 remainder's f·z(ωo).
    #[inline]
    fn remainder(&self, r: &MsRef, wo: Vec3) -> Spectrum {
        if self.ei == Spectrum::ZERO {
            return Spectrum::ZERO;
        }
        let eo = if r.baked_norm.is_some() {
            r.table.lookup_baked(&r.cell, wo, false)[1]
        } else {
            MsTable::remainder(&r.table.lookup(&r.cell, wo), &self.k)
        };
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

/// The first order's eval and pdf (fused nested calls).
#[inline]
fn first_order(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    if m.mirror_wall {
        explicit::eval_pdf_complete(m, nested, ctx, wi, wo, s)
    } else {
        explicit::eval_pdf_single(m, nested, ctx, wi, wo, s)
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
    let a = AtWi::new(r, nested, wi);
    let (f1, p1) = first_order(m, nested, ctx, wi, wo, s);
    (
        f1 + a.remainder(r, wo),
        (1.0 - a.select) * p1 + a.select * wo.z * INV_PI,
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
    let a = AtWi::new(r, nested, wi);
    let p1 = if m.mirror_wall {
        explicit::pdf_complete(m, nested, ctx, wi, wo)
    } else {
        explicit::pdf_single(m, nested, ctx, wi, wo)
    };
    (1.0 - a.select) * p1 + a.select * wo.z * INV_PI
}

/// The mixture of the first order's sampler and a cosine lobe (module doc); weight = eval/pdf.
pub(super) fn sample(
    m: &MicrofacetNormalMap,
    r: &MsRef,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let a = AtWi::new(r, nested, wi);
    let wo = if s.next_1d() < a.select {
        warp::square_to_cosine_hemisphere(s.next_2d())
    } else if m.mirror_wall {
        explicit::draw_complete(m, nested, ctx, wi, s)?
    } else {
        explicit::draw_single(m, nested, ctx, wi, s)?
    };
    if wo.z <= 0.0 {
        return None;
    }
    let (f1, p1) = first_order(m, nested, ctx, wi, wo, s);
    let pdf = (1.0 - a.select) * p1 + a.select * wo.z * INV_PI;
    if !(pdf.is_finite() && pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wo,
        pdf,
        weight: (f1 + a.remainder(r, wo)) / pdf,
        eta: 1.0,
        lobe: explicit::lobe_of(nested.lobes()),
    })
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
