//! `path`: unidirectional path tracing with next-event estimation and BSDF sampling combined by
//! the power heuristic (Veach 1997, ch. 9), Russian roulette, and Mitsuba 3's depth semantics.
//! The side tests that keep shading normals honest live in [`crate::bsdf::SurfaceBsdf`].

use super::nee::sample_light;
use super::{PathSettings, RayKind, Scratch, Strategy};
use crate::bsdf::{BsdfContext, Lobes};
use crate::geometry::Ray;
use crate::math::mis::power_heuristic;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{max_component, Spectrum};
use glam::Vec3;

/// What the previous vertex knew about the direction it sampled (for MIS on emitter hits).
#[derive(Clone, Copy)]
struct PrevVertex {
    p: Vec3,
    bsdf_pdf: f32,
    delta: bool,
}

/// Radiance along `ray`.
pub fn li(
    cfg: &PathSettings,
    scene: &Scene,
    mut ray: Ray,
    sampler: &mut Sampler,
    scratch: &mut Scratch,
) -> Spectrum {
    let ctx = BsdfContext::default();
    let max_depth = super::depth_limit(cfg.max_depth);
    let mut result = Spectrum::ZERO;
    let mut throughput = Spectrum::ONE;
    let mut eta = 1.0f32;
    let mut depth: u32 = 0;
    let mut prev: Option<PrevVertex> = None;
    if max_depth == 0 {
        return result;
    }

    loop {
        let kind = if depth == 0 {
            RayKind::Camera
        } else {
            RayKind::Bounce
        };
        let hit = scratch.rays.intersect(scene, &ray, kind);

        // ---- Emission seen by this ray (from an escaped ray or an area light hit) ----
        let show = depth > 0 || !cfg.hide_emitters;
        let si = match hit {
            None => {
                if show {
                    for &e in &scene.env_emitters {
                        let em = &scene.emitters[e as usize];
                        let le = em.eval_env(ray.d);
                        if le == Spectrum::ZERO {
                            continue;
                        }
                        let w = emission_weight(cfg, prev, || {
                            em.pdf_direct_env(ray.d) * scene.light_sampler.pmf(e as usize)
                        });
                        result += throughput * le * w;
                    }
                }
                break;
            }
            Some(si) => si,
        };
        if show {
            if let Some(e) = scene.shape_emitter[si.shape as usize] {
                let em = &scene.emitters[e as usize];
                let le = em.eval_surface(&si);
                if le != Spectrum::ZERO {
                    let w = emission_weight(cfg, prev, || {
                        let p = prev.map_or(si.p, |v| v.p);
                        em.pdf_direct_surface(&scene.shapes, p, &si)
                            * scene.light_sampler.pmf(e as usize)
                    });
                    result += throughput * le * w;
                }
            }
        }

        // Mitsuba: continue only while depth + 1 < max_depth.
        if depth.saturating_add(1) >= max_depth {
            break;
        }

        // ---- Scattering ----
        let Some(bsdf) = scene.bsdf_at(&si, &mut scratch.arena) else {
            break;
        };

        // Next-event estimation.
        if cfg.strategy != Strategy::BsdfOnly && bsdf.lobes().is_smooth() {
            if let Some(ls) = sample_light(scene, &si, &bsdf, &ctx, sampler, &mut scratch.rays) {
                let w = if ls.delta || cfg.strategy == Strategy::LightOnly {
                    1.0
                } else {
                    power_heuristic(ls.light_pdf, ls.bsdf_pdf)
                };
                result += throughput * (ls.f_value * (w / ls.light_pdf));
            }
        }

        // BSDF sampling.
        let Some(bs) = bsdf.sample(&ctx, sampler) else {
            break;
        };
        throughput *= bs.weight;
        eta *= bs.eta;
        prev = Some(PrevVertex {
            p: si.p,
            bsdf_pdf: bs.pdf,
            delta: bs.lobe.intersects(Lobes::DELTA),
        });
        ray = si.spawn_ray(bs.wo);
        depth += 1;

        // Russian roulette (Mitsuba 3: survival min(max(throughput)·η², 0.95) from rr_depth on).
        let tmax = max_component(throughput);
        if !(tmax.is_finite() && tmax > 0.0) {
            break;
        }
        if depth as i64 >= cfg.rr_depth as i64 {
            let q = (tmax * eta * eta).min(0.95);
            if sampler.next_1d() >= q {
                break;
            }
            throughput /= q;
        }
    }
    result
}

/// MIS weight of emission found by a BSDF-sampled ray (1 for camera rays and delta bounces).
#[inline]
fn emission_weight(
    cfg: &PathSettings,
    prev: Option<PrevVertex>,
    light_pdf: impl FnOnce() -> f32,
) -> f32 {
    match prev {
        None => 1.0,
        Some(v) if v.delta => 1.0,
        Some(v) => match cfg.strategy {
            Strategy::Mis => power_heuristic(v.bsdf_pdf, light_pdf()),
            Strategy::BsdfOnly => 1.0,
            Strategy::LightOnly => 0.0,
        },
    }
}
