//! `direct`: Mitsuba's direct-illumination integrator. `emitter_samples` light samples and
//! `bsdf_samples` BSDF samples per hit, combined with the power heuristic (Veach 1997, §9.2.2:
//! the multi-sample model with sample counts in the weights).
//!
//! Mitsuba 3.9.1 quirk, matched for parity: an emitter sample that lands on a delta light
//! (point, spot, projector, directional) gets the weight 1 instead of 1/`emitter_samples`
//! (`direct.cpp`: `select(ds.delta, 1, mis_weight(..) * m_weight_lum)`), so with N emitter
//! samples a delta light counts N times. The loader warns when a scene meets this case.
//!
//! The estimator is split into steps that both renderers call, so its arithmetic is one source:
//! [`li`] (the scalar renderer) runs them for one camera ray, tracing each ray as it is drawn; the
//! stream renderer (`crate::stream::direct`) draws every sample of a batch's paths first, traces
//! the rays together, then adds the terms in the same order. The steps are
//! [`add_camera_emission`] (what the camera ray sees), [`light_term`] (a light sample, added when
//! its shadow ray is unblocked) and [`add_bsdf_hit`] (what a BSDF-sampled ray finds). No step
//! draws a random number after a ray is traced, so drawing first changes nothing.

use super::nee::{sample_light, LightSample};
use super::{DirectSettings, RayKind, Scratch};
use crate::bsdf::{BsdfContext, Lobes, SurfaceBsdf};
use crate::geometry::{Ray, SurfaceInteraction};
use crate::math::mis::power_heuristic;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// What the camera ray sees (`hit`: its surface, or `None` when it escapes), added to
/// `result` unless `hide_emitters`.
#[inline(always)]
pub fn add_camera_emission(
    cfg: &DirectSettings,
    scene: &Scene,
    result: &mut Spectrum,
    ray: &Ray,
    hit: Option<&SurfaceInteraction>,
) {
    if cfg.hide_emitters {
        return;
    }
    match hit {
        None => {
            for &e in &scene.env_emitters {
                *result += scene.emitters[e as usize].eval_env(ray.d);
            }
        }
        Some(si) => {
            if let Some(e) = scene.shape_emitter[si.shape as usize] {
                *result += scene.emitters[e as usize].eval_surface(si);
            }
        }
    }
}

/// Whether the BSDF at a hit takes light samples: a smooth lobe and a light to sample.
#[inline(always)]
pub fn takes_light_samples(scene: &Scene, bsdf: &SurfaceBsdf) -> bool {
    bsdf.lobes().is_smooth() && !scene.light_sampler.is_empty()
}

/// The MIS-weighted term of one light sample (added when its shadow ray is unblocked).
#[inline(always)]
pub fn light_term(cfg: &DirectSettings, ls: &LightSample) -> Spectrum {
    let ne = cfg.emitter_samples as f32;
    let nb = cfg.bsdf_samples as f32;
    // Delta lights: weight 1, not 1/ne (Mitsuba's quirk, see the module comment).
    let (w, n) = if ls.delta {
        (1.0, 1.0)
    } else {
        (power_heuristic(ne * ls.light_pdf, nb * ls.bsdf_pdf), ne)
    };
    ls.f_value * (w / (ls.light_pdf * n))
}

/// A BSDF sample leaving the point `p` toward `d` (sample weight `weight`, density `pdf`, through
/// a delta lobe when `delta`) found `hit` (`None`: it escaped): adds the emission it sees,
/// MIS-weighted, to `result`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn add_bsdf_hit(
    cfg: &DirectSettings,
    scene: &Scene,
    result: &mut Spectrum,
    p: Vec3,
    d: Vec3,
    weight: Spectrum,
    pdf: f32,
    delta: bool,
    hit: Option<&SurfaceInteraction>,
) {
    let ne = cfg.emitter_samples as f32;
    let nb = cfg.bsdf_samples as f32;
    match hit {
        Some(hit) => {
            if let Some(e) = scene.shape_emitter[hit.shape as usize] {
                let em = &scene.emitters[e as usize];
                let le = em.eval_surface(hit);
                if le == Spectrum::ZERO {
                    return;
                }
                let w = if delta {
                    1.0
                } else {
                    let lpdf = em.pdf_direct_surface(&scene.shapes, p, hit)
                        * scene.light_sampler.pmf(e as usize);
                    power_heuristic(nb * pdf, ne * lpdf)
                };
                *result += weight * le * (w / nb);
            }
        }
        None => {
            for &e in &scene.env_emitters {
                let em = &scene.emitters[e as usize];
                let le = em.eval_env(d);
                let w = if delta {
                    1.0
                } else {
                    let lpdf = em.pdf_direct_env(d) * scene.light_sampler.pmf(e as usize);
                    power_heuristic(nb * pdf, ne * lpdf)
                };
                *result += weight * le * (w / nb);
            }
        }
    }
}

/// Radiance along the camera ray `ray` (the scalar renderer).
pub fn li(
    cfg: &DirectSettings,
    scene: &Scene,
    ray: Ray,
    sampler: &mut Sampler,
    scratch: &mut Scratch,
) -> Spectrum {
    let ctx = BsdfContext::default();
    let mut result = Spectrum::ZERO;
    let hit = scratch.rays.intersect(scene, &ray, RayKind::Camera);
    add_camera_emission(cfg, scene, &mut result, &ray, hit.as_ref());
    let Some(si) = hit else {
        return result;
    };
    let Some(bsdf) = scene.bsdf_at(&si, &mut scratch.arena) else {
        return result;
    };

    if takes_light_samples(scene, &bsdf) {
        for _ in 0..cfg.emitter_samples {
            let Some(ls) = sample_light(scene, &si, &bsdf, &ctx, sampler, &mut scratch.rays) else {
                continue;
            };
            result += light_term(cfg, &ls);
        }
    }

    for _ in 0..cfg.bsdf_samples {
        let Some(bs) = bsdf.sample(&ctx, sampler) else {
            continue;
        };
        let r = si.spawn_ray(bs.wo);
        let hit = scratch.rays.intersect(scene, &r, RayKind::Bounce);
        add_bsdf_hit(
            cfg,
            scene,
            &mut result,
            si.p,
            bs.wo,
            bs.weight,
            bs.pdf,
            bs.lobe.intersects(Lobes::DELTA),
            hit.as_ref(),
        );
    }
    result
}
