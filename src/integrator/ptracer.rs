//! `ptracer`: light tracing (Mitsuba 3's particle tracer, `src/integrators/ptracer.cpp`). Paths
//! start on the emitters and every vertex connects to the sensor; the contributions are splatted
//! at the film positions they reach (Veach 1997, §10.2; the adjoint BSDF with shading normals,
//! §5.3, p. 155).
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `max_depth` | integer | −1 | longest path in vertices counting the sensor's (−1: unlimited); 1 = only emitters seen directly, 2 = direct illumination |
//! | `rr_depth` | integer | 5 | Russian roulette once a light path has more than this many vertices; ≥ 1 |
//! | `hide_emitters` | boolean | false | skip the direct connection of emitters to the sensor |
//! | `samples_per_pass` | integer | all | Mitsuba's work split into passes of this many samples per pixel; the sample count must be a multiple of it. In Mitsuba 3.9.1's scalar variants it only sets the grain of the parallel loop over all samples (and so its samplers' seeds: the noise, not the expectation); groove's samples have their own streams whatever the split, so it is checked and changes nothing |
//!
//! One sample, as Mitsuba 3.9.1's `ParticleTracerIntegrator::sample`:
//! 1. Emitters seen directly (unless `hide_emitters` or `max_depth` 0): an emitter picked by the
//!    light sampler, a point on it (area lights, by area) or a direction toward it
//!    (environments, from the sensor), connected to the sensor; delta lights are never seen.
//! 2. A light path: an emitter picked by the light sampler, a ray leaving it
//!    ([`crate::emitter::emission`]), then at every surface vertex (while the path has fewer
//!    than `max_depth` vertices with the sensor's) a connection to the sensor through the BSDF
//!    in importance mode, and a BSDF sample in importance mode to continue. Both carry the
//!    shading-normal correction |cos_s(wi)·cos_g(wo)| / |cos_s(wo)·cos_g(wi)| and the side
//!    tests of [`crate::bsdf::SurfaceBsdf`] (a direction whose shading and geometric sides
//!    disagree carries nothing). Russian roulette after `rr_depth` vertices with survival
//!    min(max(throughput)·η², 0.95).
//!
//! The render draws spp × (film width × height) samples (Mitsuba's count: the full film, not the
//! crop) and scales each splat by (crop pixels) / (that count).
//!
//! Determinism: sample i draws from its own stream (`Sampler::for_sample` keyed by i / spp and
//! i mod spp). The samples are cut into [`CHUNKS`] fixed, contiguous chunks, grouped in order
//! into [`SLICES`] slices. Each chunk is traced by one task, in order, into its own
//! [`SplatImage`]; waves of as many chunks as there are threads run in parallel, and after each
//! wave the chunk images are added, in chunk order, into their slice's image, and a finished
//! slice into the film. Which thread traces a chunk changes nothing, so the same seed gives a
//! bit-identical image at any thread count, and up to [`CHUNKS`] threads have work. The slices
//! are independent estimates of the image: the film receives each slice's image, scaled to a
//! whole estimate, as one sample per pixel, so its variance is the variance between slices
//! (light paths splat into many pixels, so per-splat statistics would not be a pixel's
//! variance; pixels of one slice stay correlated, see tests/render/ptracer_agree.rs).

use super::splat::{crop_of, SplatImage, MAX_TAPS};
use super::{RayCounters, RayKind, Scratch};
use crate::bsdf::{is_positive, BsdfContext, SurfaceBsdf, TransportMode};
use crate::emitter::emission::VisiblePoint;
use crate::error::{Error, Result, SourceLoc};
use crate::film::{Block, Film, FilmDesc, Filter};
use crate::geometry::ray::offset_origin;
use crate::geometry::{Ray, SurfaceInteraction};
use crate::render::{thread_pool, RenderOptions, RenderOutput, RenderSettings, RenderStats};
use crate::sampler::{Sampler, SamplerDesc};
use crate::scene::Scene;
use crate::spectrum::{is_finite, max_component, Spectrum};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// Number of independent slices a render is cut into (fixed, so that the image does not depend
/// on the thread count; also the sample count of the variance estimate).
pub const SLICES: u64 = 32;

/// Number of chunks, the units of parallel work (fixed for the same reason); a multiple of
/// [`SLICES`], so that every slice is [`CHUNKS`] / [`SLICES`] whole chunks.
pub const CHUNKS: u64 = SLICES * 8;

/// Mitsuba's `ptracer` settings.
#[derive(Clone, Debug)]
pub struct PtracerSettings {
    /// Longest path in vertices counting the sensor's (−1: unlimited).
    pub max_depth: i32,
    /// Russian roulette once a light path has more than this many vertices.
    pub rr_depth: i32,
    pub hide_emitters: bool,
    /// Samples per pixel of one pass (`None`: all in one pass).
    pub samples_per_pass: Option<u32>,
    /// The `<integrator>` element (for errors found when the sensor is known).
    pub loc: SourceLoc,
}

/// What one chunk of the render produced.
struct ChunkStats {
    rays: RayCounters,
    invalid: u64,
}

/// Render `scene` by light tracing (called by [`crate::render::render`] for a `ptracer`).
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    cfg: &PtracerSettings,
    opts: &RenderOptions,
) -> Result<RenderOutput> {
    // The film keeps its second moments as asked (`groove render` without a part does not).
    let film_desc = FilmDesc {
        second_moments: opts.second_moments,
        ..settings.film.clone()
    };
    let desc = &film_desc;
    if !scene.camera.supports_light_tracing() {
        return Err(Error::scene(
            &cfg.loc,
            "ptracer needs a perspective or thinlens sensor (Mitsuba 3.9.1's orthographic \
             sensor cannot be connected to: it has no sample_direction)",
        ));
    }
    let r = desc.filter.radius();
    if !(r.is_finite() && 2.0 * r < MAX_TAPS as f32) {
        return Err(Error::Usage(format!(
            "ptracer: the reconstruction filter's radius {r} is too large to splat with"
        )));
    }
    let spp = opts.spp.unwrap_or(settings.sampler.sample_count).max(1);
    if let Some(per_pass) = cfg.samples_per_pass {
        let per_pass = per_pass.min(spp);
        if !spp.is_multiple_of(per_pass) {
            return Err(Error::scene(
                &cfg.loc,
                format!("sample_count ({spp}) must be a multiple of samples_per_pass ({per_pass})"),
            ));
        }
    }
    let sampler_desc = SamplerDesc {
        kind: settings.sampler.kind,
        sample_count: spp,
        seed: opts.seed.unwrap_or(settings.sampler.seed),
    };
    let pool = thread_pool(opts.threads)?;
    let threads = pool.current_num_threads();
    let crop = crop_of(desc);
    let total = spp as u64 * desc.width as u64 * desc.height as u64;
    let slices = SLICES.min(total.max(1));
    let chunks = CHUNKS.min(total.max(1));
    let wave = (threads as u64).clamp(1, chunks) as usize;
    // The chunk images of one wave and the open slice's, the film and its block (32 bytes a
    // pixel each), the developed image and the encoder's copy (12 each).
    let px = crop.2 as u64 * crop.3 as u64;
    opts.budget
        .check(
            (wave as u64 + 1)
                .saturating_mul(SplatImage::bytes(desc))
                .saturating_add(px.saturating_mul(32 + 32 + 24))
                .saturating_add(threads as u64 * crate::render::THREAD_BYTES),
            &format!(
                "light tracing film {}×{} with {threads} worker threads",
                crop.2, crop.3
            ),
        )
        .map_err(Error::Usage)?;

    let start = Instant::now();
    let box_desc = FilmDesc {
        filter: Filter::Box,
        ..desc.clone()
    };
    let mut film = Film::new(desc.clone());
    let mut rays = RayCounters::default();
    let mut invalid = 0;
    if !scene.light_sampler.is_empty() && crop.2 > 0 && crop.3 > 0 {
        let ctx = Context {
            scene,
            cfg,
            sampler: &sampler_desc,
            crop,
            scale: (px as f64 / total as f64) as f32,
            cancel: opts.cancel.as_ref(),
        };
        let mut images: Vec<SplatImage> = (0..wave).map(|_| SplatImage::new(desc)).collect();
        // The slice being summed (chunks are merged in order, so one is open at a time).
        let mut open = SplatImage::new(desc);
        let mut open_slice = 0u64;
        let mut block = Block::new(&box_desc, crop.0, crop.1, crop.2, crop.3);
        // A finished slice's image, scaled to a whole estimate, is one film sample per pixel.
        let put_slice = |img: &SplatImage, block: &mut Block| {
            let whole = slices as f32;
            for (j, p) in img.pixels().iter().enumerate() {
                let x = crop.0 + (j as u32 % crop.2);
                let y = crop.1 + (j as u32 / crop.2);
                let v = Spectrum::from_array(*p) * whole;
                block.put(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), v);
            }
        };
        let mut first = 0u64;
        while first < chunks {
            let n = (chunks - first).min(wave as u64) as usize;
            let stats: Vec<ChunkStats> = pool.install(|| {
                images[..n]
                    .par_iter_mut()
                    .enumerate()
                    .map(|(i, img)| {
                        let k = first + i as u64;
                        img.clear();
                        ctx.trace_chunk(img, total * k / chunks, total * (k + 1) / chunks)
                    })
                    .collect()
            });
            // Chunk order: the sums do not depend on which thread traced what.
            for (i, (img, s)) in images[..n].iter().zip(stats).enumerate() {
                rays.add(&s.rays);
                invalid += s.invalid;
                let slice = (first + i as u64) * slices / chunks;
                if slice != open_slice {
                    put_slice(&open, &mut block);
                    open.clear();
                    open_slice = slice;
                }
                open.add(img);
            }
            first += n as u64;
            if ctx.cancelled() {
                return Err(Error::Cancelled);
            }
        }
        put_slice(&open, &mut block);
        film.merge(&block);
    }
    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        spp,
        sample_count: spp,
        sample_range: (0, spp),
        crop,
        sampled_pixels: crop.2 as u64 * crop.3 as u64,
        stopped_early: false,
        seed: sampler_desc.seed,
        threads,
        renderer: crate::render::Renderer::Scalar,
        samples: total,
        rays,
        invalid_samples: invalid,
    };
    Ok(RenderOutput {
        film,
        stats,
        ray_log: Vec::new(),
    })
}

/// What every sample of one render shares.
struct Context<'a> {
    scene: &'a Scene,
    cfg: &'a PtracerSettings,
    sampler: &'a SamplerDesc,
    crop: (u32, u32, u32, u32),
    /// Crop pixels / samples: each splat's factor.
    scale: f32,
    cancel: Option<&'a crate::cancel::Cancel>,
}

/// The BSDF queries of light tracing.
const IMPORTANCE: BsdfContext = BsdfContext {
    mode: TransportMode::Importance,
};

impl Context<'_> {
    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.requested().is_some())
    }

    /// Trace samples `begin..end` (one chunk) in order into `img`.
    fn trace_chunk(&self, img: &mut SplatImage, begin: u64, end: u64) -> ChunkStats {
        let mut scratch = Scratch::default();
        let mut invalid = 0;
        let spp = self.sampler.sample_count as u64;
        for i in begin..end {
            if (i - begin).is_multiple_of(4096) && self.cancelled() {
                break;
            }
            let mut sampler = Sampler::for_sample(self.sampler, i / spp, (i % spp) as u32);
            invalid += self.sample(img, &mut sampler, &mut scratch);
        }
        ChunkStats {
            rays: scratch.rays.counters,
            invalid,
        }
    }

    /// One sample: the emitters seen directly, then one light path. Returns the number of
    /// non-finite contributions dropped.
    fn sample(&self, img: &mut SplatImage, sampler: &mut Sampler, scratch: &mut Scratch) -> u64 {
        let mut invalid = 0;
        if self.cfg.max_depth != 0 && !self.cfg.hide_emitters {
            invalid += self.visible_emitters(img, sampler, scratch);
        }
        invalid + self.light_path(img, sampler, scratch)
    }

    /// Adds `value` at `pos` unless it is not finite (then counts it).
    #[inline]
    fn splat(&self, img: &mut SplatImage, pos: Vec2, value: Spectrum) -> u64 {
        if !is_finite(value) {
            return 1;
        }
        if value != Spectrum::ZERO {
            img.put(pos, value * self.scale);
        }
        0
    }

    /// Mitsuba's `sample_visible_emitters`: a point or direction of one emitter connected to
    /// the sensor.
    fn visible_emitters(
        &self,
        img: &mut SplatImage,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
    ) -> u64 {
        let scene = self.scene;
        let u_sel = sampler.next_1d();
        let u = sampler.next_2d();
        let aperture = sampler.next_2d();
        let Some((e, pmf)) = pick_emitter(scene, u_sel) else {
            return 0;
        };
        let Some(cam_p) = scene.camera.light_tracing_origin() else {
            return 0;
        };
        let Some(vp) = scene.emitters[e].sample_visible(&scene.shapes, cam_p, u) else {
            return 0;
        };
        match vp {
            VisiblePoint::Surface { p, n, ng, weight } => {
                let Some(ss) = scene.camera.sample_direction(p, aperture, self.crop) else {
                    return 0;
                };
                // One-sided emission: no light leaves the back of the shading normal (the side
                // `AreaLight::eval` tests, so the camera sees what a path hitting `p` sees).
                if !is_positive(n.dot(ss.d)) {
                    return 0;
                }
                // The area-to-solid-angle cosine is the area element's own, the geometric
                // normal's (the shading normal's would scale a smooth-normal mesh light).
                let cos = ng.dot(ss.d).abs();
                let o = offset_origin(p, ng, ss.d);
                let v = ss.p - o;
                let dist = v.length();
                let mut shadow = Ray::new(o, v / dist);
                shadow.tmax = dist * (1.0 - 1e-4);
                if scratch.rays.occluded(scene, &shadow) {
                    return 0;
                }
                self.splat(img, ss.film_pos, weight * (cos * ss.weight / pmf))
            }
            VisiblePoint::Environment { d, weight } => {
                // As Mitsuba: the environment's point at twice the radius of the bounding
                // sphere grown to hold the sensor, in area measure (× dist²).
                let (c, r) = scene.bsphere;
                let t = 2.0 * r.max((cam_p - c).length());
                if !(t.is_finite() && t > 0.0) {
                    return 0;
                }
                let far = cam_p + d * t;
                let Some(ss) = scene.camera.sample_direction(far, aperture, self.crop) else {
                    return 0;
                };
                let mut shadow = Ray::new(ss.p, -ss.d);
                shadow.tmax = ss.dist;
                if scratch.rays.occluded(scene, &shadow) {
                    return 0;
                }
                self.splat(img, ss.film_pos, weight * (ss.weight * t * t / pmf))
            }
        }
    }

    /// Mitsuba's `prepare_ray` and `trace_light_ray`: a path from an emitter, connected to the
    /// sensor at every surface vertex.
    fn light_path(
        &self,
        img: &mut SplatImage,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
    ) -> u64 {
        let scene = self.scene;
        let cfg = self.cfg;
        let u_sel = sampler.next_1d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let Some((e, pmf)) = pick_emitter(scene, u_sel) else {
            return 0;
        };
        let Some(er) = scene.emitters[e].sample_ray(&scene.shapes, scene.bsphere, u_pos, u_dir)
        else {
            return 0;
        };
        let mut throughput = er.weight / pmf;
        let mut ray = er.ray;
        let mut eta = 1.0f32;
        // Vertices of the path so far, counting the sensor's (Mitsuba's `depth` starts at 1).
        let mut depth: i64 = 1;
        let max_depth = cfg.max_depth as i64;
        if max_depth >= 0 && depth >= max_depth {
            return 0;
        }
        let mut invalid = 0;
        while let Some(si) = scratch.rays.intersect(scene, &ray, RayKind::Bounce) {
            let aperture = sampler.next_2d();
            let Some(bsdf) = scene.bsdf_at(&si, &mut scratch.arena) else {
                // The arriving direction's shading and geometric sides disagree: no light
                // scatters from here (Mitsuba's leak test kills the path too).
                break;
            };
            // ---- Connection to the sensor ----
            if let Some(ss) = scene.camera.sample_direction(si.p, aperture, self.crop) {
                if let Some(value) = connect(&si, &bsdf, ss.d, sampler) {
                    let value = throughput * value * ss.weight;
                    if value != Spectrum::ZERO {
                        let shadow = si.spawn_ray_to(ss.p, None);
                        if !scratch.rays.occluded(scene, &shadow) {
                            invalid += self.splat(img, ss.film_pos, value);
                        }
                    }
                }
            }
            // ---- BSDF sampling (importance transport) ----
            let Some(bs) = bsdf.sample(&IMPORTANCE, sampler) else {
                break;
            };
            let corr = shading_correction(&si, bs.wo);
            if !(corr.is_finite() && corr > 0.0) {
                break;
            }
            throughput *= bs.weight * corr;
            eta *= bs.eta;
            let tmax = max_component(throughput);
            if !(tmax.is_finite() && tmax > 0.0) {
                break;
            }
            depth += 1;
            if max_depth >= 0 && depth >= max_depth {
                break;
            }
            if depth > cfg.rr_depth as i64 {
                let q = (tmax * eta * eta).min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                throughput /= q;
            }
            ray = si.spawn_ray(bs.wo);
        }
        invalid
    }
}

/// The adjoint BSDF's shading-normal factor for light arriving along `si.wi` and leaving along
/// `wo` (world): |cos_s(wi)·cos_g(wo)| / |cos_s(wo)·cos_g(wi)| (Veach 1997, eq. 5.19).
#[inline]
fn shading_correction(si: &SurfaceInteraction, wo: Vec3) -> f32 {
    let n = si.sh.n;
    ((n.dot(si.wi) * si.ng.dot(wo)) / (n.dot(wo) * si.ng.dot(si.wi))).abs()
}

/// `f* · |cos_s(wo)|` times the shading-normal factor toward the sensor direction `wo`, in
/// importance mode; `None` when the side tests refuse `wo`.
#[inline]
fn connect(
    si: &SurfaceInteraction,
    bsdf: &SurfaceBsdf,
    wo: Vec3,
    sampler: &mut Sampler,
) -> Option<Spectrum> {
    let (f, _) = bsdf.eval_pdf(&IMPORTANCE, wo, sampler)?;
    let corr = shading_correction(si, wo);
    (corr.is_finite() && f != Spectrum::ZERO).then(|| f * corr)
}

/// The emitter the light sampler picks with `u` and its probability, when that is positive.
fn pick_emitter(scene: &Scene, u: f32) -> Option<(usize, f32)> {
    let (e, pmf, _) = scene.light_sampler.sample(u)?;
    is_positive(pmf).then_some((e, pmf))
}
