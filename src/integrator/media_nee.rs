//! Next-event estimation through participating media and `null` boundaries, shared by the
//! volumetric integrators (`volpath`, `volpathmis`): an emitter sample seen through the scene
//! ([`sample_emitter`], Mitsuba's `VolumetricPathIntegrator::sample_emitter`), the transmittance
//! of a shadow ray ([`transmittance`], with the null-collision probabilities of its ratio tracking
//! that `volpathmis` weighs by: [`EmitterSample::null_ratio`]) and Mitsuba's `skip_area_emitters`
//! for `hide_emitters`.

use super::{RayKind, Rays, Scratch};
use crate::bsdf::{BsdfArena, Lobes};
use crate::geometry::{Ray, SurfaceInteraction};
use crate::medium::{Medium, MediumId};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// Most surfaces a shadow ray passes (null boundaries) before it counts as blocked: a guard
/// against a ray that keeps re-hitting one surface, far above any real scene's layering.
pub(super) const MAX_CROSSINGS: u32 = 256;

/// Where a shadow ray starts.
#[derive(Clone, Copy)]
pub(super) enum Origin<'a> {
    Surface(&'a SurfaceInteraction),
    Medium(Vec3),
}

/// An emitter sample seen through the scene: `radiance` is Le·Tr (Tr: the shadow ray's
/// transmittance), `value` is Le·Tr / pdf, `pdf` the solid-angle density with the selection pmf.
/// `null_ratio` is the product of the null-collision probabilities over the shadow ray's
/// tentative collisions in heterogeneous media (1 without any): the density with which path
/// tracing (delta tracking) would have passed them, relative to ratio tracking's 1. `volpath`
/// ignores it; `volpathmis` weighs its techniques with it.
pub(super) struct EmitterSample {
    pub d: Vec3,
    pub radiance: Spectrum,
    pub value: Spectrum,
    pub pdf: f32,
    pub delta: bool,
    pub null_ratio: f32,
}

/// Picks an emitter, samples it from `origin` and attenuates it by what lies between
/// (Mitsuba's `VolumetricPathIntegrator::sample_emitter`).
#[inline]
pub(super) fn sample_emitter(
    scene: &Scene,
    origin: Origin<'_>,
    mut medium: Option<MediumId>,
    channel: usize,
    sampler: &mut Sampler,
    rays: &mut Rays,
    arena: &mut BsdfArena,
) -> Option<EmitterSample> {
    let u_sel = sampler.next_1d();
    let u = sampler.next_2d();
    let (e, sel_pdf, _) = scene.light_sampler.sample(u_sel)?;
    let p = match origin {
        Origin::Surface(si) => si.p,
        Origin::Medium(p) => p,
    };
    let ds = scene.emitters[e].sample_direct(&scene.shapes, p, u)?;
    if ds.value == Spectrum::ZERO || ds.pdf.is_nan() || ds.pdf <= 0.0 {
        return None;
    }
    let target = ds.dist.is_finite().then_some((ds.p, ds.n));
    let ray = match origin {
        Origin::Surface(si) => {
            let mi = &scene.shape_media[si.shape as usize];
            if mi.is_transition() {
                medium = mi.target(si.ng, ds.d);
            }
            match target {
                Some((q, n)) => si.spawn_ray_to(q, n),
                None => si.spawn_ray(ds.d),
            }
        }
        Origin::Medium(p) => {
            let mut r = Ray::new(p, ds.d);
            if let Some((q, n)) = target {
                let end = match n {
                    Some(n) => crate::geometry::ray::offset_origin(q, n, -ds.d),
                    None => q,
                };
                r.tmax = (end - p).length() * (1.0 - 1e-4);
            }
            r
        }
    };
    let (tr, null_ratio) = transmittance(scene, ray, target, medium, channel, sampler, rays, arena);
    if tr == Spectrum::ZERO {
        return None;
    }
    let radiance = ds.value * tr;
    Some(EmitterSample {
        d: ds.d,
        radiance,
        value: radiance / (ds.pdf * sel_pdf),
        pdf: ds.pdf * sel_pdf,
        delta: ds.delta,
        null_ratio,
    })
}

/// Transmittance along a shadow ray toward `target` (a point and its surface normal; `None`:
/// infinitely far), starting in `medium`: zero at the first surface that is not `null`, else the
/// product of the media's transmittances over the segments between `null` boundaries (closed form
/// in homogeneous media, ratio tracking with `sampler` in heterogeneous ones). Also the product
/// of the null-collision probabilities of the ratio-tracking steps ([`EmitterSample::null_ratio`]).
/// `channel` is the path's distance-sampling (hero) channel, which a homogeneous medium without
/// spectral extinction attenuates every channel by (Mitsuba's grey shortcut).
#[allow(clippy::too_many_arguments)]
pub(super) fn transmittance(
    scene: &Scene,
    mut ray: Ray,
    target: Option<(Vec3, Option<Vec3>)>,
    mut medium: Option<MediumId>,
    channel: usize,
    sampler: &mut Sampler,
    rays: &mut Rays,
    arena: &mut BsdfArena,
) -> (Spectrum, f32) {
    const BLOCKED: (Spectrum, f32) = (Spectrum::ZERO, 0.0);
    let mut tr = Spectrum::ONE;
    let mut null_ratio = 1.0f32;
    for _ in 0..MAX_CROSSINGS {
        let hit = rays.intersect(scene, &ray, RayKind::Bounce);
        let seg = hit.as_ref().map_or(ray.tmax, |si| si.t);
        if let Some(m) = medium {
            match &scene.media[m as usize] {
                Medium::Heterogeneous(h) => {
                    let (t, p) = h.ratio_track(ray.o, ray.d, seg, sampler);
                    tr *= t;
                    null_ratio *= p;
                }
                med => tr *= med.transmittance(ray.o, ray.d, seg, channel, sampler),
            }
            if tr == Spectrum::ZERO {
                return BLOCKED;
            }
        }
        let Some(si) = hit else {
            return (tr, null_ratio);
        };
        // Mitsuba: the surface's null transmission (0 for an opaque one).
        let material = scene.shape_material[si.shape as usize];
        let lobes = scene.materials.lobes(material);
        if !lobes.intersects(Lobes::NULL | Lobes::DELTA_TRANSMISSION) {
            return BLOCKED;
        }
        arena.clear();
        let root = scene.materials.build(material, &si, arena);
        tr *= arena.bsdf(root).null_transmission(si.sh.to_local(si.wi));
        if tr == Spectrum::ZERO {
            return BLOCKED;
        }
        let mi = &scene.shape_media[si.shape as usize];
        if mi.is_transition() {
            medium = mi.target(si.ng, ray.d);
        }
        ray = match target {
            Some((q, n)) => si.spawn_ray_to(q, n),
            None => si.spawn_ray(ray.d),
        };
    }
    BLOCKED
}

/// Mitsuba's `skip_area_emitters` for a camera ray with `hide_emitters`: the first surface along
/// the ray that is not an area emitter.
pub(super) fn skip_area_emitters(
    scene: &Scene,
    mut hit: Option<SurfaceInteraction>,
    ray: &Ray,
    scratch: &mut Scratch,
) -> Option<SurfaceInteraction> {
    for _ in 0..MAX_CROSSINGS {
        let si = hit?;
        if scene.shape_emitter[si.shape as usize].is_none() {
            return Some(si);
        }
        let mut next = si.spawn_ray(ray.d);
        next.tmax = ray.tmax;
        hit = scratch.rays.intersect(scene, &next, RayKind::Camera);
    }
    None
}
