//! `volpathmis`: volumetric path tracing with spectral MIS, Mitsuba 3.9.1's
//! `VolumetricMisPathIntegrator` (Miller, Georgiev, Jarosz, "A null-scattering path integral
//! formulation of light transport", SIGGRAPH 2019: a path's contribution divided by the sum of
//! the densities of every technique that could have sampled it, including the other colour
//! channels' distance sampling).
//!
//! - One colour channel per path (the hero, drawn first, uniformly) samples free-flight
//!   distances, as in `volpath`; but each channel's estimate is divided by the *mean* of the
//!   three channels' path densities (one-sample MIS over the hero choice with the balance
//!   heuristic, as Miller et al. do over wavelengths). In a chromatic medium a path sampled
//!   with one channel's extinction then carries no large Tr/pdf ratio in the others: less
//!   colour noise, same mean.
//! - Emitters found by BSDF / phase sampling and by next-event estimation are combined with
//!   the balance heuristic over both techniques and the three hero channels (Mitsuba uses the
//!   balance heuristic here, not the power heuristic of `path` and `volpath`).
//! - Depth, Russian roulette (on the MIS throughput; its survival probability stays out of the
//!   MIS densities, unlike Mitsuba's, which is biased there: `Weights::roulette`), `null`
//!   boundaries, medium changes, the `sample_emitters` switch of a medium and `hide_emitters`
//!   follow `volpath` ([`super::volpath`]); `hide_emitters` skips area emitters only along a camera ray that
//!   starts outside media, as Mitsuba 3.9.1 does.
//! - `use_spectral_mis` = false: each channel is divided by the hero channel's density alone
//!   (Mitsuba's `Volpath_no_spectral_mis`), which is `volpath`'s estimator with the balance
//!   heuristic. Where one channel's throughput is zero, Mitsuba 3.9.1 zeroes all three channels
//!   of that path in this mode; groove zeroes that channel only (Mitsuba's result is biased there).
//!
//! # Bookkeeping
//!
//! Mitsuba keeps a 3×3 matrix `p_over_f[i][j]` = P_j / F_i (P_j: the path's density had channel
//! j been the hero, F_i: its throughput in channel i). Every update multiplies it by an outer
//! ratio p_j / f_i, so it is always rank one; groove keeps the two vectors instead, divided by
//! the hero's density P_c so that they stay near 1: `beta` = F / P_c (the throughput `volpath`
//! carries) and `r` = P / P_c (r_c = 1). Channel i's MIS throughput is beta_i / mean(r).
//! `r_nee` is the density of the same path had its last segment been found by next-event
//! estimation, without the emitter's own density (Mitsuba's `p_over_f_nee`).
//!
//! Shadow rays use the closed-form transmittance of `volpath` ([`super::media_nee`]): both
//! techniques' densities then omit the shadow segment's free-flight density. This is Mitsuba's
//! estimator with its track-length shadow-ray estimate averaged out: the weights of the two
//! techniques for a direction are p_e / (p_e + p_d) and p_d / (p_e + p_d) of their directional
//! densities, a partition of one, so the mean is unchanged (derivation in `docs/media.md`).
//!
//! Heterogeneous media (Mitsuba's null-collision form of the same weights): delta tracking
//! against the medium's grey majorant ([`crate::medium::Heterogeneous::delta_track`]); each
//! step's density and each null/real choice's probability are the same for every hero channel,
//! so only the throughput ratios σn/mean(σn) and σs/mean(σt) enter, as in `volpath`. What differs
//! from `volpath` is the weighing of path tracing against next-event estimation: a shadow ray
//! ratio-tracks, i.e. passes every tentative collision as null with probability 1, where path
//! tracing chose null with probability P_n = mean(σn)/σ̄ at each. So a path that reaches an
//! emitter through null collisions has next-event density (relative to its own) times
//! Π 1/P_n (`Weights::null_collisions`), and a shadow ray's path has path-tracing density times
//! Π P_n over its ratio-tracking steps ([`super::media_nee::EmitterSample::null_ratio`]): the
//! balance heuristic over the null-scattering path space of Miller et al., as Mitsuba's
//! `p_over_f` / `p_over_f_nee` / `p_over_f_uni` updates compute it. Mitsuba rolls no Russian
//! roulette right after a null collision; groove tracks to the next real collision in one call
//! and rolls it only there, the same.
//!
//! # XML parameters (Mitsuba 3.9.1 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `max_depth` | integer | −1 | longest path in scattering events (−1: unlimited) |
//! | `rr_depth` | integer | 5 | Russian roulette after this many events (>= 1) |
//! | `hide_emitters` | boolean | false | directly visible emitters render black |
//! | `use_spectral_mis` | boolean | true | divide by the mean of the channels' densities (false: the hero's alone) |

use super::media_nee::{sample_emitter, skip_area_emitters, EmitterSample, Origin};
use super::{RayKind, Scratch};
use crate::bsdf::{BsdfContext, Lobes};
use crate::error::SourceLoc;
use crate::geometry::Ray;
use crate::medium::{FreeFlight, Medium};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{max_component, Spectrum};
use glam::Vec3;

/// Mitsuba's `volpathmis` settings.
#[derive(Clone, Debug)]
pub struct VolpathMisSettings {
    /// Longest path in scattering events (−1: unlimited).
    pub max_depth: i32,
    /// Russian roulette once the depth exceeds this.
    pub rr_depth: i32,
    pub hide_emitters: bool,
    /// Spectral MIS (Mitsuba's `use_spectral_mis`).
    pub spectral_mis: bool,
    /// The `<integrator>` element, for errors found once the scene is built.
    pub loc: SourceLoc,
}

/// The path's throughput and densities (see the module's "Bookkeeping").
struct Weights {
    /// F / P_c per channel.
    beta: Spectrum,
    /// P / P_c per channel (the hero's entry is 1).
    r: Spectrum,
    /// The next-event density of the path to the next emitter hit, without the emitter's
    /// density, over P_c.
    r_nee: Spectrum,
    channel: usize,
    spectral: bool,
}

impl Weights {
    fn new(channel: usize, spectral: bool) -> Self {
        Weights {
            beta: Spectrum::ONE,
            r: Spectrum::ONE,
            r_nee: Spectrum::ONE,
            channel,
            spectral,
        }
    }

    /// The density a channel's estimate is divided by: the mean over the hero choices, or the
    /// hero's alone without spectral MIS.
    #[inline]
    fn density(&self, r: Spectrum) -> f32 {
        if self.spectral {
            (r.x + r.y + r.z) * (1.0 / 3.0)
        } else {
            r[self.channel]
        }
    }

    /// F_i divided by the combined density of the path (Mitsuba's `mis_weight(p_over_f)`).
    #[inline]
    fn throughput(&self) -> Spectrum {
        self.beta / self.density(self.r)
    }

    /// Survived Russian roulette with probability `q`. The survival probability stays out of
    /// the densities the techniques are weighted by (as `path` leaves it out of its MIS): the
    /// next-event estimate made before the roulette cannot include it, so the two weights are
    /// p_d / (p_d + p_e) and p_e / (p_d + p_e), a partition of one. Mitsuba 3.9.1 multiplies
    /// its unidirectional density by q (`update_weights(p_over_f, q, 1)`) but not the next-event
    /// one, so its weights sum to less than one once roulette starts: its albedo-1 furnace
    /// renders 0.99706 ± 0.00024 (see `docs/media.md`).
    #[inline]
    fn roulette(&mut self, q: f32) {
        self.beta /= q;
    }

    /// A factor common to f and p in every channel, relative to the hero's (`k` = ratio / ratio_c).
    #[inline]
    fn scale_all(&mut self, k: Spectrum) {
        self.beta *= k;
        self.r = nan_to_zero(self.r * k);
        self.r_nee = nan_to_zero(self.r_nee * k);
    }

    /// A real scattering event whose direction was sampled with density `pdf` (0: a delta
    /// lobe) and weight f/pdf: the next-event density restarts here.
    #[inline]
    fn scatter(&mut self, weight: Spectrum, pdf: f32) {
        self.beta *= weight;
        self.r_nee = if pdf > 0.0 { self.r / pdf } else { self.r };
    }

    /// Null collisions chosen by delta tracking in a heterogeneous medium, `p_nulls` the product
    /// of their probabilities (Mitsuba's `update_weights(p_over_f_nee, 1, σn)` against
    /// `update_weights(p_over_f, P_null, σn)`). Their throughput ratios σn / mean(σn) and the
    /// majorant's free-flight densities are grey, common to every hero channel and to both
    /// techniques, so `beta` takes the first (in the free-flight weight) and `r` nothing; but
    /// next-event estimation (ratio tracking) passes these collisions with probability 1, so
    /// its density relative to path tracing's grows by 1 / `p_nulls`.
    #[inline]
    fn null_collisions(&mut self, p_nulls: f32) {
        if p_nulls != 1.0 {
            self.r_nee /= p_nulls;
        }
    }

    /// A `null` pass (`null`, `mask`, `thindielectric`'s transmission): its throughput only.
    /// Both techniques leave the pass's selection probability out of the densities they are
    /// weighted by (a shadow ray passes deterministically, attenuated), as Mitsuba does, so
    /// that their weights stay p_d / (p_d + p_e) and p_e / (p_d + p_e) of the directional
    /// densities (Mitsuba also leaves the pass's throughput out of the next-event density,
    /// which is biased when that throughput is not 1, e.g. a tinted `thindielectric`).
    #[inline]
    fn null_pass(&mut self, weight: Spectrum) {
        self.beta *= weight;
    }

    /// An emitter of radiance `le` hit by the path; `pdf_e` the density with which next-event
    /// estimation picks it from the last scattering vertex (Mitsuba's `mis_weight(p_over_f,
    /// p_over_f_nee)`).
    #[inline]
    fn hit(&self, le: Spectrum, pdf_e: f32) -> Spectrum {
        // (`r_nee` is infinite only after null probabilities that underflowed: weight 0.)
        let nee = if pdf_e > 0.0 {
            pdf_e * self.density(self.r_nee)
        } else {
            0.0
        };
        self.beta * le / (self.density(self.r) + nee)
    }

    /// Next-event estimation from the current vertex: `f` the BSDF (with cosine) or phase
    /// value toward the emitter, `pdf_dir` the density with which the vertex samples that
    /// direction (0 for a delta emitter). Path tracing would also have had to choose the shadow
    /// ray's null collisions as null, with probability `ls.null_ratio` (Mitsuba's
    /// `p_over_f_uni` in its shadow-ray loop).
    #[inline]
    fn nee(&self, ls: &EmitterSample, f: Spectrum, pdf_dir: f32) -> Spectrum {
        let d = self.density(self.r) * (ls.pdf + pdf_dir * ls.null_ratio);
        self.beta * f * ls.radiance / d
    }
}

#[inline]
fn nan_to_zero(v: Spectrum) -> Spectrum {
    Vec3::select(v.is_nan_mask(), Vec3::ZERO, v)
}

/// Radiance along the camera ray `ray`.
pub fn li(
    cfg: &VolpathMisSettings,
    scene: &Scene,
    mut ray: Ray,
    sampler: &mut Sampler,
    scratch: &mut Scratch,
) -> Spectrum {
    let ctx = BsdfContext::default();
    let max_depth = super::depth_limit(cfg.max_depth);
    let mut result = Spectrum::ZERO;
    let mut eta = 1.0f32;
    let mut depth: u32 = 0;
    let mut medium = scene.camera_medium;
    // The hero channel (Mitsuba: drawn first, uniformly).
    let channel = ((sampler.next_1d() * 3.0) as usize).min(2);
    let mut w = Weights::new(channel, cfg.spectral_mis);
    let mut specular_chain = !cfg.hide_emitters;
    // The last real scattering vertex (for the emitter density of a hit).
    let mut last_p = ray.o;
    // Camera rays, and rays continuing one through `null` surfaces, are "depth 0".
    let mut from_camera = true;

    loop {
        // ---- Termination (Russian roulette on the MIS throughput) ----
        let tmax = max_component(w.throughput());
        if !(tmax.is_finite() && tmax > 0.0) {
            break;
        }
        let u_rr = sampler.next_1d();
        if depth > cfg.rr_depth.max(0) as u32 {
            let q = (tmax * eta * eta).min(0.95);
            if u_rr >= q {
                break;
            }
            w.roulette(q);
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

        // ---- Free flight through the current medium (hero channel) ----
        if let Some(m) = medium {
            let med = &scene.media[m as usize];
            let t_max = hit.as_ref().map_or(f32::INFINITY, |si| si.t);
            let scattered = match med {
                Medium::Homogeneous(h) => {
                    let s_c = h.sigma_t[channel];
                    let u = sampler.next_1d();
                    let t = if s_c > 0.0 {
                        -(1.0 - u).ln() / s_c
                    } else {
                        f32::INFINITY
                    };
                    if t >= t_max {
                        // Passed to the surface: p = f = Tr in every channel.
                        if h.spectral_extinction {
                            w.scale_all(crate::medium::homogeneous::tr_ratio(
                                t_max, h.sigma_t, s_c,
                            ));
                        }
                        None
                    } else {
                        // Scattered: p_j = Tr_j·σt_j, f_i = Tr_i·σs_i (grey-extinction
                        // shortcut: p_j = σt_j, f_i = σs_i, as Mitsuba 3.9.1).
                        let k = if h.spectral_extinction {
                            crate::medium::homogeneous::tr_ratio(t, h.sigma_t, s_c)
                        } else {
                            Spectrum::ONE
                        };
                        // σs at the scattering point (a grid albedo varies; σt does not).
                        w.beta *= k * h.sigma_s_at(ray.o + ray.d * t) / s_c;
                        w.r = nan_to_zero(w.r * k * h.sigma_t / s_c);
                        Some(t)
                    }
                }
                // Delta tracking against the grey majorant: every density of a step is the same
                // for all hero channels, so `r` stays; the weights σn/mean(σn) and
                // σs/mean(σt) are Mitsuba's F/P ratios (1 and σs/σt without spectral
                // extinction, Mitsuba's shortcut for a grey σt).
                Medium::Heterogeneous(h) => match h.delta_track(ray.o, ray.d, t_max, sampler) {
                    (FreeFlight::Pass { weight }, p_nulls) => {
                        w.beta *= weight;
                        w.null_collisions(p_nulls);
                        None
                    }
                    // (The next-event density restarts at the scattering vertex: its null
                    // collisions on the way do not matter.)
                    (FreeFlight::Scatter { t, weight }, _) => {
                        w.beta *= weight;
                        Some(t)
                    }
                },
            };
            if let Some(t) = scattered {
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
                        let pdf_dir = if ls.delta { 0.0 } else { pdf };
                        result += w.nee(&ls, Spectrum::splat(val), pdf_dir);
                    }
                }
                let Some(ps) = phase.sample(wi, sampler.next_1d(), sampler.next_2d()) else {
                    break;
                };
                if ps.pdf.is_nan() || ps.pdf <= 0.0 {
                    break;
                }
                w.scatter(Spectrum::splat(ps.weight), ps.pdf);
                last_p = p;
                ray = Ray::new(p, ps.wo);
                continue;
            }
        }

        // ---- A surface, or the environment ----
        // Mitsuba 3.9.1 skips area emitters where the surface step traces the ray itself,
        // i.e. not along a segment that crossed a medium.
        if cfg.hide_emitters && from_camera && medium.is_none() {
            hit = skip_area_emitters(scene, hit, &ray, scratch);
        }
        let count_direct = from_camera || specular_chain;
        let show = !(from_camera && cfg.hide_emitters);
        let Some(si) = hit else {
            if show {
                for (e, em, le) in scene.env_emission(ray.d) {
                    result += if count_direct {
                        w.throughput() * le
                    } else {
                        let pdf = em.pdf_direct_env(ray.d) * scene.light_sampler.pmf(e);
                        w.hit(le, pdf)
                    };
                }
            }
            break;
        };
        if show {
            if let Some(e) = scene.shape_emitter[si.shape as usize] {
                let em = &scene.emitters[e as usize];
                let le = em.eval_surface(&si);
                if le != Spectrum::ZERO {
                    result += if count_direct {
                        w.throughput() * le
                    } else {
                        let pdf = em.pdf_direct_surface(&scene.shapes, last_p, &si)
                            * scene.light_sampler.pmf(e as usize);
                        w.hit(le, pdf)
                    };
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
                    let pdf_dir = if ls.delta { 0.0 } else { bsdf_pdf };
                    result += w.nee(&ls, f, pdf_dir);
                }
            }
        }
        let Some(bs) = bsdf.sample(&ctx, sampler) else {
            break;
        };
        eta *= bs.eta;
        let null = {
            let (b, wi) = bsdf.local();
            b.is_null_sample(wi, bs.lobe)
        };
        if null {
            w.null_pass(bs.weight);
        } else {
            depth += 1;
            last_p = si.p;
            from_camera = false;
            if bs.lobe.intersects(Lobes::DELTA) {
                specular_chain = true;
            }
            if bs.lobe.is_smooth() {
                specular_chain = false;
            }
            w.scatter(bs.weight, bs.pdf);
        }
        let mi = &scene.shape_media[si.shape as usize];
        if mi.is_transition() {
            medium = mi.target(si.ng, bs.wo);
        }
        ray = si.spawn_ray(bs.wo);
    }
    result
}
