//! Next-event estimation: one light sample at a surface point, shared by `path` and `direct`.
//! The estimators differ only in how they weight it (their MIS sample counts and strategies), so
//! this routine returns the unweighted contribution and both densities.

use super::Rays;
use crate::bsdf::{BsdfContext, SurfaceBsdf};
use crate::emitter::DirectSample;
use crate::geometry::{Ray, SurfaceInteraction};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;

/// An unoccluded light sample that the BSDF scatters toward the viewer.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// `f · |cos θo| · Le / (emitter pdf)` as the emitter reports it: the BSDF value times the
    /// emitter sample's value (not yet divided by the selection pmf nor MIS-weighted).
    pub f_value: Spectrum,
    /// Solid-angle density of the light sample, selection pmf included (delta lights: the
    /// emitter's discrete pmf).
    pub light_pdf: f32,
    /// The BSDF's sampling density of the same direction.
    pub bsdf_pdf: f32,
    /// A delta light (point, spot, directional): no MIS.
    pub delta: bool,
}

/// Pick an emitter, sample a point on it, evaluate the BSDF toward it and trace the shadow ray.
/// Draws three numbers from `sampler` first (then any the BSDF's evaluation needs).
#[inline(always)]
pub fn sample_light(
    scene: &Scene,
    si: &SurfaceInteraction,
    bsdf: &SurfaceBsdf,
    ctx: &BsdfContext,
    sampler: &mut Sampler,
    rays: &mut Rays,
) -> Option<LightSample> {
    let (ls, shadow) = prepare_light(scene, si, bsdf, ctx, sampler)?;
    if rays.occluded(scene, &shadow) {
        return None;
    }
    Some(ls)
}

/// [`sample_light`] up to its shadow ray, which is returned untraced (the stream renderer traces
/// the shadow rays of a whole batch together). Draws the same numbers as [`sample_light`].
#[inline(always)]
pub fn prepare_light(
    scene: &Scene,
    si: &SurfaceInteraction,
    bsdf: &SurfaceBsdf,
    ctx: &BsdfContext,
    sampler: &mut Sampler,
) -> Option<(LightSample, Ray)> {
    let u_sel = sampler.next_1d();
    let u = sampler.next_2d();
    let (ds, sel_pdf) = sample_emitter(scene, si.p, u_sel, u)?;
    let (f, bsdf_pdf) = bsdf.eval_pdf(ctx, ds.d, sampler)?;
    if f == Spectrum::ZERO {
        return None;
    }
    let shadow = if ds.dist.is_finite() {
        si.spawn_ray_to(ds.p, ds.n)
    } else {
        si.spawn_ray(ds.d)
    };
    Some((
        LightSample {
            f_value: f * ds.value,
            light_pdf: ds.pdf * sel_pdf,
            bsdf_pdf,
            delta: ds.delta,
        },
        shadow,
    ))
}

/// The light point of [`prepare_light`] from its three random numbers: the emitter chosen by
/// `u_sel`, a point on it sampled from `p` with `u`, and the selection probability; `None` when
/// the scene has no light or the sample carries nothing. The stream renderer's kernels do the
/// same with the same bits in `stream::kernels::light` (the selection 8-wide for up to 8
/// emitters, area lights on meshes, rectangles and spheres 8-wide, other emitters lane by lane).
#[inline(always)]
pub(crate) fn sample_emitter(
    scene: &Scene,
    p: glam::Vec3,
    u_sel: f32,
    u: glam::Vec2,
) -> Option<(DirectSample, f32)> {
    let (e, sel_pdf, _) = scene.light_sampler.sample(u_sel)?;
    let ds = scene.emitters[e].sample_direct(&scene.shapes, p, u)?;
    if ds.value == Spectrum::ZERO {
        return None;
    }
    Some((ds, sel_pdf))
}
