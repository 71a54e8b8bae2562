//! `direct`: Mitsuba's direct-illumination integrator. `emitter_samples` light samples and
//! `bsdf_samples` BSDF samples per hit, combined with the power heuristic (Veach 1997, §9.2.2:
//! the multi-sample model with sample counts in the weights).

use super::{DirectSettings, Scratch};
use crate::bsdf::{lobe, BsdfContext};
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
    scratch.counters.camera += 1;
    let mut result = Spectrum::ZERO;
    let Some(si) = scene.intersect(&ray) else {
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
    let Some((bsdf, wi, flags)) = scene.bsdf_at(&si, &mut scratch.arena) else {
        return result;
    };
    let ne = cfg.emitter_samples as f32;
    let nb = cfg.bsdf_samples as f32;

    if flags & lobe::SMOOTH != 0 {
        for _ in 0..cfg.emitter_samples {
            let u_sel = sampler.next_1d();
            let u = sampler.next_2d();
            let Some((e, sel, _)) = scene.light_sampler.sample(u_sel) else {
                break;
            };
            let Some(ds) = scene.emitters[e].sample_direct(&scene.shapes, si.p, u) else {
                continue;
            };
            let wo = si.sh.to_local(ds.d);
            if !super::path::consistent_side(&si, ds.d, wo) {
                continue;
            }
            let (f, bpdf) = bsdf.eval_pdf(&ctx, wi, wo, sampler);
            if f == Spectrum::ZERO || ds.value == Spectrum::ZERO {
                continue;
            }
            let shadow = if ds.dist.is_finite() {
                si.spawn_ray_to(ds.p, ds.n)
            } else {
                si.spawn_ray(ds.d)
            };
            scratch.counters.shadow += 1;
            if scene.occluded(&shadow) {
                continue;
            }
            let lpdf = ds.pdf * sel;
            let w = if ds.delta {
                1.0
            } else {
                power_heuristic(ne * lpdf, nb * bpdf)
            };
            result += f * ds.value * (w / (lpdf * ne));
        }
    }

    for _ in 0..cfg.bsdf_samples {
        let Some(bs) = bsdf.sample(&ctx, wi, sampler) else {
            continue;
        };
        let d = si.sh.to_world(bs.wo);
        if !super::path::consistent_side(&si, d, bs.wo) {
            continue;
        }
        let r = si.spawn_ray(d);
        scratch.counters.bounce += 1;
        let delta = bs.lobe & lobe::DELTA != 0;
        match scene.intersect(&r) {
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
