//! The render loop: image blocks rendered in parallel by rayon, each pixel sample drawing from its
//! own deterministic stream, blocks merged into the film in a fixed order so the image is
//! bit-identical for a given seed whatever the thread count. Counts rays and times the render.

use crate::budget::Budget;
use crate::cancel::Cancel;
use crate::error::{Error, Result};
use crate::film::{Block, Film, FilmDesc};
use crate::integrator::{IntegratorDesc, LoggedRay, RayCounters, Scratch};
use crate::sampler::{Sampler, SamplerDesc};
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use glam::Vec2;
use rayon::prelude::*;
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;
use std::time::Instant;

/// How the scene file asks for it to be rendered: the integrator, the film (size, crop window,
/// reconstruction filter) and the sampler. Kept apart from the [`Scene`] it renders, which
/// knows nothing of integrators.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub integrator: IntegratorDesc,
    pub film: FilmDesc,
    pub sampler: SamplerDesc,
}

/// How to render (command-line overrides of the scene's own settings).
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Samples per pixel; `None` = the scene sampler's `sample_count`.
    pub spp: Option<u32>,
    /// Seed; `None` = the scene sampler's `seed`.
    pub seed: Option<u64>,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Block edge in pixels.
    pub block_size: u32,
    /// Record up to this many of the traced rays into [`RenderOutput::ray_log`] (0: none);
    /// `groove bench` traces them again for its Embree ceiling.
    pub record_rays: usize,
    /// Stop early when this is raised: the render checks it every 4096 samples and returns
    /// [`Error::Cancelled`] (no image).
    pub cancel: Option<Cancel>,
    /// The memory budget the film and its blocks must fit in (with what the scene's load
    /// reserved, when it is the load's budget), checked before anything is allocated.
    pub budget: Budget,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            threads: 0,
            spp: None,
            seed: None,
            progress: false,
            block_size: DEFAULT_BLOCK,
            record_rays: 0,
            cancel: None,
            budget: Budget::default(),
        }
    }
}

/// What a render measured.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub seconds: f64,
    pub spp: u32,
    pub seed: u64,
    pub threads: usize,
    pub samples: u64,
    pub rays: RayCounters,
    /// Samples whose radiance was NaN or infinite (dropped, as Mitsuba does).
    pub invalid_samples: u64,
}

impl RenderStats {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }
    pub fn rays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(1e-9)
    }
}

pub struct RenderOutput {
    pub film: Film,
    pub stats: RenderStats,
    /// The recorded rays ([`RenderOptions::record_rays`]), block by block in image order.
    pub ray_log: Vec<LoggedRay>,
}

/// Block edge in pixels of [`RenderOptions::default`].
pub const DEFAULT_BLOCK: u32 = 32;

/// Bytes a render of `desc` in blocks of `block` pixels allocates: the film's accumulators
/// (32 bytes a pixel), every block until it is merged (the same, with the filter's border
/// around each block), the developed image (12 bytes a pixel) and the encoder's copy (12).
pub fn film_bytes(desc: &FilmDesc, block: u32) -> u64 {
    let (w, h) = desc.crop_size;
    let px = w.min(desc.width) as u64 * h.min(desc.height) as u64;
    let r = desc.filter.radius();
    let border = if r.is_finite() && r > 0.0 {
        r.ceil().min(64.0) as u64
    } else {
        0
    };
    let b = block.max(1) as u64;
    let blocks = (w as u64).div_ceil(b) * (h as u64).div_ceil(b);
    let block_px = blocks.saturating_mul((b + 2 * border).pow(2));
    px.saturating_mul(32 + 12 + 12)
        .saturating_add(block_px.saturating_mul(32))
}

/// Bytes one worker thread takes beside the film: its stack (rayon's default, 2 MiB of address
/// space, reserved here in full) and its scratch (the BSDF arena, ray counters, sampler state).
pub const THREAD_BYTES: u64 = 4 << 20;

/// Most worker threads per core `-t` may ask for: more cannot render faster, and thousands
/// of threads only cost memory and start-up time.
pub const MAX_THREADS_PER_CORE: usize = 8;

/// The largest thread count accepted: [`MAX_THREADS_PER_CORE`] per core, at least 64.
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (cores * MAX_THREADS_PER_CORE).max(64)
}

/// Build the worker pool: `threads` workers (0 = all cores), each with flush-to-zero set.
/// More than [`max_threads`] is an error, not a pool of thousands of threads.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    let max = max_threads();
    if threads > max {
        return Err(Error::Usage(format!(
            "{threads} worker threads asked for; at most {max} are accepted ({MAX_THREADS_PER_CORE} per core of this machine, at least 64)"
        )));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| crate::accel::set_flush_denormals())
        .build()
        .map_err(|e| Error::Native(format!("cannot start worker threads: {e}")))
}

/// Render `scene` as `settings` say, with the overrides of `opts`; returns the film with its
/// statistics.
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    opts: &RenderOptions,
) -> Result<RenderOutput> {
    if let IntegratorDesc::Ptracer(cfg) = &settings.integrator {
        return crate::integrator::ptracer::render(scene, settings, cfg, opts);
    }
    let desc = &settings.film;
    let bs = opts.block_size.max(1);
    let (cw, ch) = desc.crop_size;
    let pool = thread_pool(opts.threads)?;
    let n = pool.current_num_threads() as u64;
    opts.budget
        .check(
            film_bytes(desc, bs).saturating_add(n * THREAD_BYTES),
            &format!("film {cw}×{ch} with {n} worker threads"),
        )
        .map_err(Error::Usage)?;
    let sampler_desc = SamplerDesc {
        kind: settings.sampler.kind,
        sample_count: opts.spp.unwrap_or(settings.sampler.sample_count).max(1),
        seed: opts.seed.unwrap_or(settings.sampler.seed),
    };
    let (cx, cy) = desc.crop_offset;
    let mut rects = Vec::new();
    let mut y = 0;
    while y < ch {
        let mut x = 0;
        while x < cw {
            rects.push((cx + x, cy + y, bs.min(cw - x), bs.min(ch - y)));
            x += bs;
        }
        y += bs;
    }

    let bar = if opts.progress {
        let b = indicatif::ProgressBar::new(rects.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(b)
    } else {
        None
    };

    let start = Instant::now();
    let log_budget = Arc::new(AtomicUsize::new(opts.record_rays));
    let cancel = opts.cancel.as_ref();
    let nch = settings.integrator.aov_count();
    let results: Vec<(Block, RayCounters, u64, Vec<LoggedRay>)> = pool.install(|| {
        rects
            .par_iter()
            .map_init(
                || {
                    let mut s = Scratch::default();
                    if opts.record_rays > 0 {
                        s.rays.record(log_budget.clone());
                    }
                    s
                },
                |scratch, &(x0, y0, w, h)| {
                    scratch.rays.counters = RayCounters::default();
                    let _ = scratch.arena.take_walk_counts();
                    let mut block = Block::with_channels(desc, x0, y0, w, h, nch);
                    let rect = (x0, y0, w, h);
                    let invalid = render_block(
                        scene,
                        settings,
                        &sampler_desc,
                        &mut block,
                        rect,
                        scratch,
                        cancel,
                    );
                    let walks = scratch.arena.take_walk_counts();
                    let mut counters = scratch.rays.counters;
                    counters.walks = walks.walks;
                    counters.walk_vertices = walks.vertices;
                    if let Some(b) = &bar {
                        b.inc(1);
                    }
                    (block, counters, invalid, scratch.rays.take_log())
                },
            )
            .collect()
    });
    let seconds = start.elapsed().as_secs_f64();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if cancel.is_some_and(|c| c.requested().is_some()) {
        return Err(Error::Cancelled);
    }

    let mut film = Film::with_channels(desc.clone(), nch);
    let mut rays = RayCounters::default();
    let mut invalid = 0;
    let mut ray_log = Vec::new();
    for (block, c, inv, log) in results {
        film.merge(&block);
        rays.add(&c);
        invalid += inv;
        ray_log.extend(log);
    }
    let stats = RenderStats {
        seconds,
        spp: sampler_desc.sample_count,
        seed: sampler_desc.seed,
        threads: pool.current_num_threads(),
        samples: cw as u64 * ch as u64 * sampler_desc.sample_count as u64,
        rays,
        invalid_samples: invalid,
    };
    Ok(RenderOutput {
        film,
        stats,
        ray_log,
    })
}

/// Render every sample of the pixels of one block; returns the number of invalid samples.
/// Stops within 4096 samples once `cancel` is raised (the render is then discarded).
fn render_block(
    scene: &Scene,
    settings: &RenderSettings,
    sampler_desc: &SamplerDesc,
    block: &mut Block,
    (x0, y0, w, h): (u32, u32, u32, u32),
    scratch: &mut Scratch,
    cancel: Option<&Cancel>,
) -> u64 {
    let width = settings.film.width as u64;
    let mut invalid = 0;
    // The integrator's extra channels (AOVs) of one sample: allocated per block, not per ray.
    let mut aovs = vec![0.0f32; settings.integrator.aov_count()];
    let stop = || cancel.is_some_and(|c| c.requested().is_some());
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel_index = y as u64 * width + x as u64;
            for s in 0..sampler_desc.sample_count {
                // Every 4096 samples (at least once per pixel): an uncontended load.
                if s % 4096 == 0 && stop() {
                    return invalid;
                }
                let mut sampler = Sampler::for_sample(sampler_desc, pixel_index, s);
                let pos = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let ray = scene.camera.sample_ray(pos, &mut sampler);
                let mut l =
                    settings
                        .integrator
                        .sample(scene, ray, &mut sampler, scratch, &mut aovs);
                if !crate::spectrum::is_finite(l) {
                    invalid += 1;
                    l = Spectrum::ZERO;
                }
                if aovs.is_empty() {
                    block.put(pos, l);
                } else {
                    block.put_channels(pos, l, &aovs);
                }
            }
        }
    }
    invalid
}
