//! `path`: unidirectional path tracing with next-event estimation and BSDF sampling combined by
//! the power heuristic (Veach 1997, ch. 9), Russian roulette, and Mitsuba 3's depth semantics.
//!
//! Two side tests keep shading normals honest: a direction whose side with respect to the true
//! geometric normal disagrees with its side in the shading frame carries no light (Veach's
//! "strict normals"); this prevents light leaking through smooth-shaded meshes.

use super::{PathSettings, RayCounters, Scratch, Strategy};
use crate::bsdf::{lobe, BsdfContext};
use crate::emitter::Emitter;
use crate::geometry::{Ray, SurfaceInteraction};
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
    let max_depth: u32 = if cfg.max_depth < 0 {
        u32::MAX
    } else {
        cfg.max_depth as u32
    };
    let mut result = Spectrum::ZERO;
    let mut throughput = Spectrum::ONE;
    let mut eta = 1.0f32;
    let mut depth: u32 = 0;
    let mut prev: Option<PrevVertex> = None;
    if max_depth == 0 {
        return result;
    }

    loop {
        // Count rays where they are traced (a path ended by Russian roulette traces no more).
        if depth == 0 {
            scratch.counters.camera += 1;
        } else {
            scratch.counters.bounce += 1;
        }
        let hit = scene.intersect(&ray);

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
        let Some((bsdf, wi, flags)) = scene.bsdf_at(&si, &mut scratch.arena) else {
            break;
        };

        // Next-event estimation.
        if cfg.strategy != Strategy::BsdfOnly && flags & lobe::SMOOTH != 0 {
            result += throughput
                * sample_light(
                    cfg,
                    scene,
                    &si,
                    wi,
                    &bsdf,
                    &ctx,
                    sampler,
                    &mut scratch.counters,
                );
        }

        // BSDF sampling.
        let Some(bs) = bsdf.sample(&ctx, wi, sampler) else {
            break;
        };
        let wo_world = si.sh.to_world(bs.wo);
        if !consistent_side(&si, wo_world, bs.wo) {
            break;
        }
        throughput *= bs.weight;
        eta *= bs.eta;
        prev = Some(PrevVertex {
            p: si.p,
            bsdf_pdf: bs.pdf,
            delta: bs.lobe & lobe::DELTA != 0,
        });
        ray = si.spawn_ray(wo_world);
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

/// A direction agrees in its side of the surface in world (true normal) and shading frames.
#[inline]
pub(crate) fn consistent_side(si: &SurfaceInteraction, w_world: Vec3, w_local: Vec3) -> bool {
    w_world.dot(si.ng) * w_local.z > 0.0
}

/// One light sample at `si`, MIS-weighted against BSDF sampling (unweighted for delta lights).
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_light(
    cfg: &PathSettings,
    scene: &Scene,
    si: &SurfaceInteraction,
    wi: Vec3,
    bsdf: &crate::bsdf::Bsdf,
    ctx: &BsdfContext,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Spectrum {
    let u_sel = sampler.next_1d();
    let u = sampler.next_2d();
    let Some((e, sel_pdf, _)) = scene.light_sampler.sample(u_sel) else {
        return Spectrum::ZERO;
    };
    let em: &Emitter = &scene.emitters[e];
    let Some(ds) = em.sample_direct(&scene.shapes, si.p, u) else {
        return Spectrum::ZERO;
    };
    if ds.value == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    let wo = si.sh.to_local(ds.d);
    if !consistent_side(si, ds.d, wo) {
        return Spectrum::ZERO;
    }
    let (f, bsdf_pdf) = bsdf.eval_pdf(ctx, wi, wo, sampler);
    if f == Spectrum::ZERO {
        return Spectrum::ZERO;
    }
    let shadow = if ds.dist.is_finite() {
        si.spawn_ray_to(ds.p, ds.n)
    } else {
        si.spawn_ray(ds.d)
    };
    counters.shadow += 1;
    if scene.occluded(&shadow) {
        return Spectrum::ZERO;
    }
    let light_pdf = ds.pdf * sel_pdf;
    let w = if ds.delta || cfg.strategy == Strategy::LightOnly {
        1.0
    } else {
        power_heuristic(light_pdf, bsdf_pdf)
    };
    f * ds.value * (w / light_pdf)
}
