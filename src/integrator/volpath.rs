//! `volpath`: volumetric path tracing with Mitsuba 3.9.1's semantics (`VolumetricPathIntegrator`).
//!
//! - One colour channel per path samples free-flight distances (Mitsuba's RGB mode: the
//!   channel is drawn first, and the throughput carries Tr/pdf of that channel; no spectral MIS).
//!   Heterogeneous media are delta-tracked against their majorant (null collisions count no
//!   depth and meet no Russian roulette; Mitsuba rolls its roulette at each one, which changes
//!   the noise, not the expectation); see [`crate::medium::heterogeneous`].
//! - Depth counts real scattering events, at surfaces and in media; `null` surfaces are passed
//!   without a bounce. Russian roulette from depth > `rr_depth`, survival min(max(β)·η², 0.95).
//! - Next-event estimation at smooth surfaces and at medium scattering events (unless the
//!   medium's `sample_emitters` is off), with the power heuristic against BSDF / phase sampling;
//!   shadow rays pass `null` surfaces, change medium there and are attenuated by the media they
//!   cross ([`super::media_nee::transmittance`]). Emitters hit after a delta chain (or a medium without emitter
//!   sampling) count fully. Shadow-ray transmittance is closed-form in homogeneous media and a
//!   ratio-tracking estimate in heterogeneous ones (as Mitsuba's).
//! - The current medium changes at every surface that has a medium interface, to the side
//!   dot(ray direction, geometric normal) points to ([`crate::medium::MediumInterface::target`]).
//! - `hide_emitters`: a camera ray passes area emitters (Mitsuba's `skip_area_emitters`) and does
//!   not see the environment.
//!
//! # XML parameters (Mitsuba 3 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `max_depth` | integer | −1 | longest path in scattering events (−1: unlimited) |
//! | `rr_depth` | integer | 5 | Russian roulette after this many events (>= 1) |
//! | `hide_emitters` | boolean | false | directly visible emitters render black |

use super::media_nee::{sample_emitter, skip_area_emitters, Origin};
use super::{RayKind, Scratch};
use crate::bsdf::{BsdfContext, Lobes};
use crate::geometry::Ray;
use crate::math::mis::power_heuristic;
use crate::medium::FreeFlight;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{max_component, Spectrum};

/// Mitsuba's `volpath` settings.
#[derive(Clone, Copy, Debug)]
pub struct VolpathSettings {
    /// Longest path in scattering events (−1: unlimited).
    pub max_depth: i32,
    /// Russian roulette once the depth exceeds this.
    pub rr_depth: i32,
    pub hide_emitters: bool,
}

/// Radiance along the camera ray `ray`.
pub fn li(
    cfg: &VolpathSettings,
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
    let mut medium = scene.camera_medium;
    // The channel that samples distances (Mitsuba: drawn first, uniformly).
    let channel = ((sampler.next_1d() * 3.0) as usize).min(2);
    let mut specular_chain = !cfg.hide_emitters;
    // The last real scattering vertex and the density of the direction it sampled (for MIS).
    let mut last_p = ray.o;
    let mut last_pdf = 1.0f32;
    // Camera rays, and rays continuing one through `null` surfaces, are "depth 0".
    let mut from_camera = true;

    loop {
        // ---- Termination ----
        let tmax = max_component(throughput);
        if !(tmax.is_finite() && tmax > 0.0) {
            break;
        }
        let u_rr = sampler.next_1d();
        if depth > cfg.rr_depth.max(0) as u32 {
            let q = (tmax * eta * eta).min(0.95);
            if u_rr >= q {
                break;
            }
            throughput /= q;
        }
        if depth >= max_depth {
            break;
        }

        let kind = if from_camera {
            RayKind::Camera
        } else {
            RayKind::Bounce
        };
        let mut hit = scratch.rays.intersect(scene, &ray, kind);

        // ---- Free flight through the current medium ----
        if let Some(m) = medium {
            let med = &scene.media[m as usize];
            let t_max = hit.as_ref().map_or(f32::INFINITY, |si| si.t);
            match med.sample_free_flight(ray.o, ray.d, t_max, channel, sampler) {
                FreeFlight::Pass { weight } => throughput *= weight,
                FreeFlight::Scatter { t, weight } => {
                    throughput *= weight;
                    depth += 1;
                    if depth >= max_depth {
                        break;
                    }
                    let p = ray.o + ray.d * t;
                    let wi = -ray.d;
                    let phase = med.phase();
                    let sample_emitters = med.sample_emitters();
                    specular_chain = !sample_emitters;
                    from_camera = false;
                    if sample_emitters {
                        if let Some(ls) = sample_emitter(
                            scene,
                            Origin::Medium(p),
                            medium,
                            channel,
                            sampler,
                            &mut scratch.rays,
                            &mut scratch.shadow_arena,
                        ) {
                            let (val, pdf) = phase.eval_pdf(wi, ls.d);
                            let w = power_heuristic(ls.pdf, if ls.delta { 0.0 } else { pdf });
                            result += throughput * val * ls.value * w;
                        }
                    }
                    let Some(ps) = phase.sample(wi, sampler.next_1d(), sampler.next_2d()) else {
                        break;
                    };
                    if ps.pdf.is_nan() || ps.pdf <= 0.0 {
                        break;
                    }
                    throughput *= ps.weight;
                    last_p = p;
                    last_pdf = ps.pdf;
                    ray = Ray::new(p, ps.wo);
                    continue;
                }
            }
        }

        // ---- A surface, or the environment ----
        if cfg.hide_emitters && from_camera {
            hit = skip_area_emitters(scene, hit, &ray, scratch);
        }
        let count_direct = from_camera || specular_chain;
        let show = !(from_camera && cfg.hide_emitters);
        let Some(si) = hit else {
            if show {
                for (e, em, le) in scene.env_emission(ray.d) {
                    let w = if count_direct {
                        1.0
                    } else {
                        let pdf = em.pdf_direct_env(ray.d) * scene.light_sampler.pmf(e);
                        power_heuristic(last_pdf, pdf)
                    };
                    result += throughput * le * w;
                }
            }
            break;
        };
        if show {
            if let Some(e) = scene.shape_emitter[si.shape as usize] {
                let em = &scene.emitters[e as usize];
                let le = em.eval_surface(&si);
                if le != Spectrum::ZERO {
                    let w = if count_direct {
                        1.0
                    } else {
                        let pdf = em.pdf_direct_surface(&scene.shapes, last_p, &si)
                            * scene.light_sampler.pmf(e as usize);
                        power_heuristic(last_pdf, pdf)
                    };
                    result += throughput * le * w;
                }
            }
        }

        let Some(bsdf) = scene.bsdf_at(&si, &mut scratch.arena) else {
            break;
        };
        // Next-event estimation (the shadow ray starts in the medium on the light's side).
        if bsdf.lobes().is_smooth() && depth.saturating_add(1) < max_depth {
            if let Some(ls) = sample_emitter(
                scene,
                Origin::Surface(&si),
                medium,
                channel,
                sampler,
                &mut scratch.rays,
                &mut scratch.shadow_arena,
            ) {
                if let Some((f, bsdf_pdf)) = bsdf.eval_pdf(&ctx, ls.d, sampler) {
                    let w = power_heuristic(ls.pdf, if ls.delta { 0.0 } else { bsdf_pdf });
                    result += throughput * f * ls.value * w;
                }
            }
        }
        let Some(bs) = bsdf.sample(&ctx, sampler) else {
            break;
        };
        throughput *= bs.weight;
        eta *= bs.eta;
        let null = {
            let (b, wi) = bsdf.local();
            b.is_null_sample(wi, bs.lobe)
        };
        if !null {
            depth += 1;
            last_p = si.p;
            last_pdf = bs.pdf;
            from_camera = false;
            if bs.lobe.intersects(Lobes::DELTA) {
                specular_chain = true;
            }
            if bs.lobe.is_smooth() {
                specular_chain = false;
            }
        }
        let mi = &scene.shape_media[si.shape as usize];
        if mi.is_transition() {
            medium = mi.target(si.ng, bs.wo);
        }
        ray = si.spawn_ray(bs.wo);
    }
    result
}
