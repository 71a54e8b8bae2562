//! `direct`: Mitsuba's direct-illumination integrator. `emitter_samples` light samples and
//! `bsdf_samples` BSDF samples per hit, combined with the power heuristic (Veach 1997, §9.2.2:
//! the multi-sample model with sample counts in the weights).
//!
//! Mitsuba 3.9.1 quirk, matched for parity: an emitter sample that lands on a delta light
//! (point, spot, projector, directional) gets the weight 1 instead of 1/`emitter_samples`
//! (`direct.cpp`: `select(ds.delta, 1, mis_weight(..) * m_weight_lum)`), so with N emitter
//! samples a delta light counts N times. The loader warns when a scene meets this case.

use super::nee::sample_light;
use super::{DirectSettings, RayKind, Scratch};
use crate::bsdf::{BsdfContext, Lobes};
use crate::geometry::Ray;
use crate::math::mis::power_heuristic;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;

pub fn li(
    cfg: &DirectSettings,
    scene: &Scene,
    ray: Ray,
    sampler: &mut Sampler,
    scratch: &mut Scratch,
) -> Spectrum {
    let ctx = BsdfContext::default();
    let mut result = Spectrum::ZERO;
    let Some(si) = scratch.rays.intersect(scene, &ray, RayKind::Camera) else {
        if !cfg.hide_emitters {
            for &e in &scene.env_emitters {
                result += scene.emitters[e as usize].eval_env(ray.d);
            }
        }
        return result;
    };
    if !cfg.hide_emitters {
        if let Some(e) = scene.shape_emitter[si.shape as usize] {
            result += scene.emitters[e as usize].eval_surface(&si);
        }
    }
    let Some(bsdf) = scene.bsdf_at(&si, &mut scratch.arena) else {
        return result;
    };
    let ne = cfg.emitter_samples as f32;
    let nb = cfg.bsdf_samples as f32;

    if bsdf.lobes().is_smooth() && !scene.light_sampler.is_empty() {
        for _ in 0..cfg.emitter_samples {
            let Some(ls) = sample_light(scene, &si, &bsdf, &ctx, sampler, &mut scratch.rays) else {
                continue;
            };
            // Delta lights: weight 1, not 1/ne (Mitsuba's quirk, see the module comment).
            let (w, n) = if ls.delta {
                (1.0, 1.0)
            } else {
                (power_heuristic(ne * ls.light_pdf, nb * ls.bsdf_pdf), ne)
            };
            result += ls.f_value * (w / (ls.light_pdf * n));
        }
    }

    for _ in 0..cfg.bsdf_samples {
        let Some(bs) = bsdf.sample(&ctx, sampler) else {
            continue;
        };
        let d = bs.wo;
        let r = si.spawn_ray(d);
        let delta = bs.lobe.intersects(Lobes::DELTA);
        match scratch.rays.intersect(scene, &r, RayKind::Bounce) {
            Some(hit) => {
                if let Some(e) = scene.shape_emitter[hit.shape as usize] {
                    let em = &scene.emitters[e as usize];
                    let le = em.eval_surface(&hit);
                    if le == Spectrum::ZERO {
                        continue;
                    }
                    let w = if delta {
                        1.0
                    } else {
                        let lpdf = em.pdf_direct_surface(&scene.shapes, si.p, &hit)
                            * scene.light_sampler.pmf(e as usize);
                        power_heuristic(nb * bs.pdf, ne * lpdf)
                    };
                    result += bs.weight * le * (w / nb);
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
                        power_heuristic(nb * bs.pdf, ne * lpdf)
                    };
                    result += bs.weight * le * (w / nb);
                }
            }
        }
    }
    result
}
