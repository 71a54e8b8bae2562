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
use crate::stream::StreamScratch;
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

/// Values kept per rayon worker (indexed by `rayon::current_thread_index`) across the jobs of
/// one render, so that per-worker buffers are built once per worker rather than once per job
/// split. A slot is locked only to take or return its value (with `try_lock`: a slot that is
/// busy, empty or out of range just means a fresh value), never while the value is in use, so a
/// nested job on the same worker cannot deadlock: it finds the slot empty and builds its own.
struct WorkerPool<T> {
    slots: Vec<std::sync::Mutex<Option<T>>>,
}

/// A value taken from a [`WorkerPool`] (or freshly built), returned to the current worker's
/// slot when dropped.
struct Held<'a, T> {
    value: Option<T>,
    pool: &'a WorkerPool<T>,
}

impl<T> WorkerPool<T> {
    fn new(workers: usize) -> WorkerPool<T> {
        WorkerPool {
            slots: (0..workers).map(|_| std::sync::Mutex::new(None)).collect(),
        }
    }

    /// The current worker's slot.
    fn slot(&self) -> Option<&std::sync::Mutex<Option<T>>> {
        self.slots.get(rayon::current_thread_index()?)
    }

    /// The current worker's value, or `make()` when it has none (or its slot is busy).
    fn take_or(&self, make: impl FnOnce() -> T) -> Held<'_, T> {
        let kept = self
            .slot()
            .and_then(|s| s.try_lock().ok().and_then(|mut v| v.take()));
        Held {
            value: Some(kept.unwrap_or_else(make)),
            pool: self,
        }
    }
}

impl<T> Held<'_, T> {
    fn get(&mut self) -> &mut T {
        self.value.as_mut().expect("held until dropped")
    }
}

impl<T> Drop for Held<'_, T> {
    fn drop(&mut self) {
        if let Some(slot) = self.pool.slot() {
            if let Ok(mut v) = slot.try_lock() {
                if v.is_none() {
                    *v = self.value.take();
                }
            }
        }
    }
}

/// Which render loop runs the integrator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Renderer {
    /// The stream renderer where it runs the scene's integrator, the scalar renderer otherwise,
    /// decided per render ([`RenderStats::renderer`] says which ran). The default: the stream
    /// renderer took fewer instructions per sample than the scalar one on every scene measured
    /// (`docs/bench/README.md`, "Issue 18: the default renderer").
    #[default]
    Auto,
    /// One path at a time, depth first (every integrator).
    Scalar,
    /// Batches of paths, stage by stage ([`crate::stream`]); the `path` integrator only, with
    /// an image equal to the scalar renderer's bit for bit.
    Stream,
}

impl Renderer {
    /// The `--renderer` values.
    pub const NAMES: &'static [&'static str] = &["auto", "scalar", "stream"];

    pub fn parse(s: &str) -> Option<Renderer> {
        match s {
            "auto" => Some(Renderer::Auto),
            "scalar" => Some(Renderer::Scalar),
            "stream" => Some(Renderer::Stream),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Renderer::Auto => "auto",
            Renderer::Scalar => "scalar",
            Renderer::Stream => "stream",
        }
    }
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
    /// Render this window (x, y, width, height, in full-film pixels) instead of the scene's
    /// crop window. Either way the pixels of a border as wide as the filter radius around the
    /// window are sampled too, so that the window's pixels equal the full render's bit for bit.
    pub crop: Option<(u32, u32, u32, u32)>,
    /// Render only the sample indices [a, b) of each pixel's streams of `spp` samples (the
    /// streams stay those of the full render); `None`: all of them.
    pub samples: Option<(u32, u32)>,
    /// Stop at the first pass boundary after this many seconds and return what was rendered
    /// ([`RenderStats::sample_range`] says how many samples).
    pub time_limit: Option<f64>,
    /// Called after every pass with the film so far and the sample range it holds (e.g. to
    /// write the current image on SIGUSR1). With a time limit the samples are rendered in passes
    /// of 1, 1, 2, 4, … (at most 64) samples per pixel; with only a hook, 8 samples and then
    /// passes of about a second each, multiples of 8 (`Passes`); the image is the same.
    pub on_pass: Option<PassHook>,
    /// The render loop (`--renderer`).
    pub renderer: Renderer,
    /// Which rays the stream renderer traces as packets; `None`: as
    /// [`crate::stream::Packets::from_env`] says.
    pub packets: Option<crate::stream::Packets>,
    /// The widest lanes the stream renderer may use (1, 8 or 16; it uses the widest the CPU
    /// has up to this); `None`: as the `GROOVE_LANES` environment variable says (default 16).
    /// The image is the same at every width.
    pub lanes: Option<usize>,
    /// Keep each pixel's second moments (Σw·v², Σw²), which [`Film::develop_variance`] and a
    /// part file need (default). Without them the splats convert and add half the sums; the
    /// image is the same bit for bit ([`crate::film::FilmDesc::second_moments`]).
    pub second_moments: bool,
}

/// What a [`PassHook`] runs: the film so far and the sample range [a, b) it holds.
pub type PassFn = dyn Fn(&Film, (u32, u32)) + Send + Sync;

/// A callback run between passes of a render with the film so far and its sample range.
#[derive(Clone)]
pub struct PassHook(pub Arc<PassFn>);

impl std::fmt::Debug for PassHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PassHook")
    }
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
            crop: None,
            samples: None,
            time_limit: None,
            on_pass: None,
            renderer: Renderer::Auto,
            packets: None,
            lanes: None,
            second_moments: true,
        }
    }
}

/// What a render measured.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub seconds: f64,
    /// Samples rendered per pixel (the length of [`RenderStats::sample_range`]).
    pub spp: u32,
    /// Samples per pixel of the full render whose streams were drawn from.
    pub sample_count: u32,
    /// The sample indices [a, b) rendered (shorter than asked when the time limit stopped it).
    pub sample_range: (u32, u32),
    /// The window rendered (full-film pixels: x, y, width, height).
    pub crop: (u32, u32, u32, u32),
    /// Pixels sampled: the window and its filter border.
    pub sampled_pixels: u64,
    /// True when the time limit stopped the render before the end of its sample range.
    pub stopped_early: bool,
    pub seed: u64,
    pub threads: usize,
    /// The render loop that ran: [`Renderer::Scalar`] or [`Renderer::Stream`] (what
    /// [`Renderer::Auto`] chose).
    pub renderer: Renderer,
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

/// Bytes a render of `desc` in blocks of `block` pixels allocates: the film's exact
/// accumulators ([`crate::film::PIXEL_BYTES`] a pixel), every block until it is merged (the
/// same, with the filter's border around each block), the developed image (12 bytes a pixel)
/// and the encoder's copy (12).
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
    let acc = crate::film::PIXEL_BYTES;
    px.saturating_mul(acc + 12 + 12)
        .saturating_add(block_px.saturating_mul(acc))
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

/// Pixels around a window whose samples reach it through the filter: none for the box filter
/// (a sample counts for its own pixel), else ceil(radius).
pub fn sample_border(desc: &FilmDesc) -> u32 {
    let r = desc.filter.radius();
    if desc.filter == crate::film::Filter::Box || !(r.is_finite() && r > 0.5) {
        0
    } else {
        r.ceil().min(1024.0) as u32
    }
}

/// The film description with `opts.crop` applied (checked to lie inside the film).
pub fn film_for(settings: &RenderSettings, opts: &RenderOptions) -> Result<FilmDesc> {
    let mut desc = settings.film.clone();
    if let Some((x, y, w, h)) = opts.crop {
        let fits = w > 0
            && h > 0
            && x.checked_add(w).is_some_and(|e| e <= desc.width)
            && y.checked_add(h).is_some_and(|e| e <= desc.height);
        if !fits {
            return Err(Error::Usage(format!(
                "crop {x},{y},{w},{h} does not lie inside the {}×{} film",
                desc.width, desc.height
            )));
        }
        desc.crop_offset = (x, y);
        desc.crop_size = (w, h);
    }
    desc.second_moments = opts.second_moments;
    Ok(desc)
}

/// Render `scene` as `settings` say, with the overrides of `opts`; returns the film with its
/// statistics.
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    opts: &RenderOptions,
) -> Result<RenderOutput> {
    let stream_cfg = match (opts.renderer, &settings.integrator) {
        (Renderer::Scalar, _) => None,
        (Renderer::Stream | Renderer::Auto, IntegratorDesc::Path(cfg)) => {
            Some(crate::stream::StreamIntegrator::Path(*cfg))
        }
        (Renderer::Stream | Renderer::Auto, IntegratorDesc::Direct(cfg)) => {
            Some(crate::stream::StreamIntegrator::Direct(*cfg))
        }
        (Renderer::Auto, _) => None,
        (Renderer::Stream, other) => {
            return Err(Error::Usage(format!(
                "the stream renderer (--renderer stream) runs the path and direct integrators only, not {}; use --renderer scalar",
                integrator_name(other)
            )))
        }
    };
    if let IntegratorDesc::Ptracer(cfg) = &settings.integrator {
        // The light tracer splats anywhere on the film: it renders whole images only.
        if opts.crop.is_some() || opts.samples.is_some() || opts.time_limit.is_some() {
            return Err(Error::Usage(
                "the ptracer integrator renders whole images only: --crop, --tile, --samples and --time-limit are not supported with it".into(),
            ));
        }
        return crate::integrator::ptracer::render(scene, settings, cfg, opts);
    }
    let packets = match (opts.packets, stream_cfg) {
        (Some(p), _) => p,
        (None, Some(_)) => crate::stream::Packets::from_env(scene)?,
        (None, None) => crate::stream::Packets::DEFAULT,
    };
    let desc = film_for(settings, opts)?;
    let desc = &desc;
    let bs = opts.block_size.max(1);
    let crop = desc.crop_rect();
    let (cw, ch) = (crop.2, crop.3);
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
    let spp = sampler_desc.sample_count;
    let (s_lo, s_hi) = opts.samples.unwrap_or((0, spp));
    if s_lo >= s_hi || s_hi > spp {
        return Err(Error::Usage(format!(
            "sample range {s_lo}..{s_hi} is empty or beyond the {spp} samples per pixel"
        )));
    }
    // The window plus the filter's border, cut to the film: the pixels whose samples reach it.
    let b = sample_border(desc);
    let x0 = crop.0.saturating_sub(b);
    let y0 = crop.1.saturating_sub(b);
    let x1 = (crop.0 + cw).saturating_add(b).min(desc.width);
    let y1 = (crop.1 + ch).saturating_add(b).min(desc.height);
    let mut rects = Vec::new();
    if cw > 0 && ch > 0 {
        let mut y = y0;
        while y < y1 {
            let mut x = x0;
            while x < x1 {
                rects.push((x, y, bs.min(x1 - x), bs.min(y1 - y)));
                x = x.saturating_add(bs);
            }
            y = y.saturating_add(bs);
        }
    }
    let sampled_pixels = if rects.is_empty() {
        0
    } else {
        (x1 - x0) as u64 * (y1 - y0) as u64
    };
    // Passes: one, unless something must happen between passes (`Passes`).
    let mut passes = Passes::new(
        (s_lo, s_hi),
        opts.time_limit.is_some(),
        opts.on_pass.is_some(),
    );

    let bar = if opts.progress {
        let b = indicatif::ProgressBar::new(rects.len() as u64 * (s_hi - s_lo) as u64);
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
    let mut film = Film::with_channels(desc.clone(), nch);
    let mut rays = RayCounters::default();
    let mut invalid = 0;
    let mut ray_log = Vec::new();
    let mut done = s_lo;
    // One scratch per worker for the whole render: rayon calls `map_init`'s init about once
    // per job split (≈ once per block), and a stream scratch is ~300 KB of buffers and the
    // scene's kernel tables.
    let workers = WorkerPool::new(pool.current_num_threads());
    // The blocks of the pass before, merged and kept for the next pass's jobs to clear and
    // reuse: a pass then allocates no block memory afresh (its page faults cost ~1 ms a pass
    // at 240×160; `docs/bench/README.md`, the thirtieth session's cold render).
    let spare = std::sync::Mutex::new(Vec::<Block>::new());
    while let Some((p_lo, p_hi)) = passes.next(start.elapsed().as_secs_f64()) {
        let results: Vec<(Block, RayCounters, u64, Vec<LoggedRay>)> = pool.install(|| {
            rects
                .par_iter()
                .map_init(
                    || {
                        workers.take_or(|| {
                            let mut s = Scratch::default();
                            if opts.record_rays > 0 {
                                s.rays.record(log_budget.clone());
                            }
                            let stream =
                                stream_cfg.map(|_| StreamScratch::new(scene, packets, opts.lanes));
                            (s, stream)
                        })
                    },
                    |held, &(x0, y0, w, h)| {
                        let (scratch, stream) = held.get();
                        scratch.rays.counters = RayCounters::default();
                        let _ = scratch.arena.take_walk_counts();
                        let mut block = spare_block(&spare, desc, (x0, y0, w, h), nch);
                        let job = BlockJob {
                            rect: (x0, y0, w, h),
                            samples: (p_lo, p_hi),
                        };
                        let invalid = match (&stream_cfg, stream) {
                            (Some(cfg), Some(stream)) => crate::stream::render_block(
                                scene,
                                cfg,
                                &sampler_desc,
                                settings.film.width,
                                &mut block,
                                job.rect,
                                job.samples,
                                scratch,
                                stream,
                                cancel,
                            ),
                            _ => render_block(
                                scene,
                                settings,
                                &sampler_desc,
                                &mut block,
                                job,
                                scratch,
                                cancel,
                            ),
                        };
                        let walks = scratch.arena.take_walk_counts();
                        let mut counters = scratch.rays.counters;
                        counters.walks = walks.walks;
                        counters.walk_vertices = walks.vertices;
                        if let Some(b) = &bar {
                            b.inc((p_hi - p_lo) as u64);
                        }
                        (block, counters, invalid, scratch.rays.take_log())
                    },
                )
                .collect()
        });
        if cancel.is_some_and(|c| c.requested().is_some()) {
            if let Some(b) = &bar {
                b.finish_and_clear();
            }
            return Err(Error::Cancelled);
        }
        let mut merged = Vec::with_capacity(results.len());
        for (block, c, inv, log) in results {
            film.merge(&block);
            rays.add(&c);
            invalid += inv;
            ray_log.extend(log);
            merged.push(block);
        }
        if let Ok(mut s) = spare.lock() {
            *s = merged;
        }
        done = p_hi;
        if let Some(h) = &opts.on_pass {
            (h.0)(&film, (s_lo, done));
        }
        if opts
            .time_limit
            .is_some_and(|t| start.elapsed().as_secs_f64() >= t)
        {
            break;
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let stats = RenderStats {
        seconds,
        spp: done - s_lo,
        sample_count: spp,
        sample_range: (s_lo, done),
        crop,
        sampled_pixels,
        stopped_early: done < s_hi,
        seed: sampler_desc.seed,
        threads: pool.current_num_threads(),
        renderer: if stream_cfg.is_some() {
            Renderer::Stream
        } else {
            Renderer::Scalar
        },
        samples: sampled_pixels * (done - s_lo) as u64,
        rays,
        invalid_samples: invalid,
    };
    Ok(RenderOutput {
        film,
        stats,
        ray_log,
    })
}

/// A block for the rectangle `(x0, y0, w, h)`: one of `spare` (an earlier pass's, of the same
/// film description) cleared and moved there, its allocations reused, or a new one. A cleared
/// block is a new block's equal ([`Block::clear`]), so the image does not depend on which.
fn spare_block(
    spare: &std::sync::Mutex<Vec<Block>>,
    desc: &FilmDesc,
    (x0, y0, w, h): (u32, u32, u32, u32),
    nch: usize,
) -> Block {
    match spare.lock().ok().and_then(|mut s| s.pop()) {
        Some(mut b) => {
            b.clear(x0, y0, w, h);
            b
        }
        None => Block::with_channels(desc, x0, y0, w, h, nch),
    }
}

/// The sample ranges [a, b) a render runs in turn, each over every block (a pass ends with all
/// blocks done, so the film then holds the same samples everywhere). One pass, unless something
/// must happen between passes; the image is the same for any schedule (the film's sums are exact).
/// - With a time limit: passes of 1, 1, 2, 4, … (at most 64) samples, so the render stops soon
///   after the limit.
/// - With only a pass hook (the CLI's SIGUSR1 snapshot): [`Passes::ALIGN`] samples, then passes
///   sized from the time per sample so far to take about [`Passes::HOOK_SECONDS`] each, so a
///   snapshot comes within about that long while a short render runs in one or two passes.
///   (Each pass costs a barrier: at 240×160 and 16 spp the fixed 1, 1, 2, 4, 8 schedule made
///   the CLI's render ~25 % slower than one pass.) Every pass but the last is a multiple of
///   [`Passes::ALIGN`] samples long.
struct Passes {
    next: u32,
    end: u32,
    start: u32,
    count: u32,
    len: u32,
    kind: Schedule,
}

#[derive(Clone, Copy, PartialEq)]
enum Schedule {
    One,
    Doubling,
    Timed,
}

impl Passes {
    /// The time a pass of a hook-only render aims at.
    const HOOK_SECONDS: f64 = 1.0;

    /// The length, in samples per pixel, a hook-only render's passes are a multiple of (all but
    /// the last): the stream renderer fills its 8-lane chunks with consecutive samples of a
    /// pass, so in a pass of 8k samples every chunk holds 8 samples of one pixel (coherent
    /// camera packets, one film add per chunk). A first pass of 1 sample, as before, left the
    /// rest of a 16-spp render at 15 a pixel, and about half its chunks straddling two pixels:
    /// metal_plastic's CLI render counted ~1,023 instructions a sample against ~970 in one
    /// aligned pass (callgrind, stream, 8 lanes).
    const ALIGN: u32 = 8;

    fn new((lo, hi): (u32, u32), time_limit: bool, hook: bool) -> Passes {
        let kind = match (time_limit, hook) {
            (true, _) => Schedule::Doubling,
            (false, true) => Schedule::Timed,
            (false, false) => Schedule::One,
        };
        Passes {
            next: lo,
            end: hi,
            start: lo,
            count: 0,
            len: 1,
            kind,
        }
    }

    /// The next pass's sample range, given the seconds the render has taken so far.
    fn next(&mut self, elapsed: f64) -> Option<(u32, u32)> {
        if self.next >= self.end {
            return None;
        }
        let len = match self.kind {
            Schedule::One => self.end - self.next,
            Schedule::Doubling => {
                let l = self.len;
                if self.count >= 1 {
                    self.len = (self.len * 2).min(64);
                }
                l
            }
            Schedule::Timed if self.count == 0 => Self::ALIGN,
            Schedule::Timed => {
                let per_sample = elapsed / (self.next - self.start) as f64;
                let l = Self::HOOK_SECONDS / per_sample.max(1e-9);
                let l = l.clamp(1.0, u32::MAX as f64) as u32;
                (l / Self::ALIGN * Self::ALIGN).max(Self::ALIGN)
            }
        };
        let a = self.next;
        self.next = a.saturating_add(len).min(self.end);
        self.count += 1;
        Some((a, self.next))
    }
}

/// The scene-file name of an integrator (for messages).
fn integrator_name(i: &IntegratorDesc) -> &'static str {
    match i {
        IntegratorDesc::Path(_) => "path",
        IntegratorDesc::Direct(_) => "direct",
        IntegratorDesc::Volpath(_) => "volpath",
        IntegratorDesc::VolpathMis(_) => "volpathmis",
        IntegratorDesc::Moment(_) => "moment",
        IntegratorDesc::Aov(_) => "aov",
        IntegratorDesc::Ptracer(_) => "ptracer",
    }
}

/// The pixels and sample indices one block renders.
#[derive(Clone, Copy, Debug)]
struct BlockJob {
    /// Full-film pixels: x0, y0, width, height.
    rect: (u32, u32, u32, u32),
    /// Sample indices [a, b) of every pixel.
    samples: (u32, u32),
}

/// Render the samples of `job` of the pixels of one block; returns the number of invalid
/// samples. Stops within 4096 samples once `cancel` is raised (the render is then discarded).
fn render_block(
    scene: &Scene,
    settings: &RenderSettings,
    sampler_desc: &SamplerDesc,
    block: &mut Block,
    job: BlockJob,
    scratch: &mut Scratch,
    cancel: Option<&Cancel>,
) -> u64 {
    let (x0, y0, w, h) = job.rect;
    let (s_lo, s_hi) = job.samples;
    let width = settings.film.width as u64;
    let mut invalid = 0;
    // The integrator's extra channels (AOVs) of one sample: allocated per block, not per ray.
    let mut aovs = vec![0.0f32; settings.integrator.aov_count()];
    let stop = || cancel.is_some_and(|c| c.requested().is_some());
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel_index = y as u64 * width + x as u64;
            for s in s_lo..s_hi {
                // Every 4096 samples (at least once per pixel): an uncontended load.
                if (s - s_lo) % 4096 == 0 && stop() {
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

#[cfg(test)]
mod tests {
    use super::Passes;

    fn all(mut p: Passes, elapsed: impl Fn(u32) -> f64) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        let mut done = 0;
        while let Some(r) = p.next(elapsed(done)) {
            done = r.1;
            v.push(r);
        }
        v
    }

    #[test]
    fn one_pass_without_a_hook_or_a_limit() {
        assert_eq!(all(Passes::new((3, 40), false, false), |_| 0.0), [(3, 40)]);
    }

    #[test]
    fn a_time_limit_doubles_up_to_64() {
        let v = all(Passes::new((0, 300), true, true), |_| 0.0);
        let lens: Vec<u32> = v.iter().map(|r| r.1 - r.0).collect();
        assert_eq!(lens[..9], [1, 1, 2, 4, 8, 16, 32, 64, 64]);
        assert_eq!((v[0].0, v.last().unwrap().1), (0, 300));
        assert!(v.windows(2).all(|w| w[0].1 == w[1].0));
    }

    #[test]
    fn a_hook_alone_sizes_passes_to_about_a_second() {
        // 10 ms per sample: 8 samples, then passes of 100 samples rounded down to a multiple
        // of 8, the last one cut.
        let v = all(Passes::new((0, 250), false, true), |done| {
            done as f64 * 0.01
        });
        assert_eq!(v, [(0, 8), (8, 104), (104, 200), (200, 250)]);
        // A fast render: 8 samples, then the rest at once.
        let v = all(Passes::new((5, 21), false, true), |done| {
            (done - 5) as f64 * 1e-3
        });
        assert_eq!(v, [(5, 13), (13, 21)]);
        // A slow one: passes of 8 however long a sample takes.
        let v = all(Passes::new((0, 20), false, true), |done| done as f64 * 5.0);
        assert_eq!(v, [(0, 8), (8, 16), (16, 20)]);
        // Fewer samples than a pass: one pass.
        let v = all(Passes::new((0, 3), false, true), |_| 0.0);
        assert_eq!(v, [(0, 3)]);
        // A render with no measurable time so far still advances.
        let v = all(Passes::new((0, 30), false, true), |_| 0.0);
        assert_eq!(v, [(0, 8), (8, 30)]);
    }
}
