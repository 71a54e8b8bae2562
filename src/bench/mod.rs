//! `groove bench`: classic against microfacet normal mapping, timed honestly.
//!
//! For every scene the benchmark renders each normal-mapping mode (`classic`, `explicit`,
//! `walk-mirror`, `walk-same`, `vgroove`, `ugroove`; see [`NormalMapping::parse`]) at equal spp,
//! `repeat` times, interleaving modes so slow drifts of a shared machine hit all of them alike;
//! with several render loops (`--renderer scalar,stream`) each mode is timed under each, also
//! interleaved, and every record and summary names the loop that ran.
//! It records time, samples/s, rays/s and mean walk length, then:
//! - the Embree ceiling ([`ceiling`]): the rays of a classic render, recorded and traced again
//!   with no shading, so each mode's rays/s reads as a fraction of the intersection limit;
//! - an equal-time comparison ([`equal_time`]): each mode renders with the spp that fits the
//!   classic render's time, and its RMSE against a high-spp reference of the same mode is
//!   reported (references are cached on disk);
//! - optionally Mitsuba 3's time for the modes it can render ([`peer`]).
//!
//! Results go to JSON (one record per scene × mode × repeat), Markdown and a PNG chart
//! ([`report`], [`chart`]).

pub mod ceiling;
pub mod chart;
pub mod equal_time;
pub mod peer;
pub mod report;

use crate::error::Result;
use crate::film::Image;
use crate::load::options::{LoadOptions, NormalMapping};
use crate::load::{load_scene, Loaded};
use crate::render::{render, RenderOptions, RenderStats, Renderer};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The modes a benchmark compares, in report order (`classic` first: ratios refer to it): every
/// `--normal-mapping` value but `microfacet` (which is "as written").
pub const MODES: &[&str] = NormalMapping::NAMES
    .split_at(NormalMapping::NAMES.len() - 1)
    .0;

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub scenes: Vec<PathBuf>,
    pub spp: u32,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    pub repeat: u32,
    pub modes: Vec<String>,
    pub defines: Vec<(String, String)>,
    /// Reference spp for the equal-time comparison (0 = no comparison).
    pub ref_spp: u32,
    /// Where references are cached (`None` = not cached).
    pub ref_dir: Option<PathBuf>,
    /// Write per-mode reference PNGs, difference images and a grid here.
    pub images: Option<PathBuf>,
    /// Measure the Embree ceiling.
    pub ceiling: bool,
    /// Only the ceiling, no mode renders (`--rays`).
    pub rays_only: bool,
    /// Python interpreter for the Mitsuba 3 peer column (`None` = skip it).
    pub peer_python: Option<String>,
    /// Progress lines on stderr.
    pub verbose: bool,
    /// The render loops of the timed renders, each timed on every mode (the images are the
    /// same bit for bit: the equal-time comparison renders under `auto`, the ceiling records
    /// the scalar loop's rays; the equal-time spp come from the first loop's times).
    pub renderers: Vec<Renderer>,
}

/// One timed render.
#[derive(Clone, Debug, Serialize)]
pub struct RunRecord {
    pub scene: String,
    pub mode: String,
    /// The render loop that ran (`scalar` or `stream`: what `auto` chose).
    pub renderer: String,
    pub repeat: u32,
    pub spp: u32,
    pub threads: usize,
    pub width: u32,
    pub height: u32,
    pub seconds: f64,
    pub samples: u64,
    pub samples_per_second: f64,
    pub rays: u64,
    pub camera_rays: u64,
    pub bounce_rays: u64,
    pub shadow_rays: u64,
    pub rays_per_second: f64,
    /// Vertices per sampled microfacet walk (`null` when the mode samples no walk).
    pub mean_walk_length: Option<f64>,
    pub invalid_samples: u64,
    /// The stream renderer's active-lane fractions of its 8-wide stages (trace, shade per
    /// material run, shadow rays); `null` under the scalar renderer.
    pub active_lanes: Option<[f64; 3]>,
}

/// A mode on a scene, summarised over its repeats.
#[derive(Clone, Debug, Serialize)]
pub struct ModeSummary {
    pub scene: String,
    pub mode: String,
    /// The render loop that ran (`scalar` or `stream`; for a skipped mode, the one asked for).
    pub renderer: String,
    /// `ok`, or `skipped` with `reason`.
    pub status: String,
    pub reason: Option<String>,
    pub min_seconds: f64,
    pub median_seconds: f64,
    pub samples_per_second: f64,
    pub rays_per_second: f64,
    pub mean_walk_length: Option<f64>,
    /// Median time over the classic mode's median time under the same render loop.
    pub ratio_to_classic: Option<f64>,
    /// Rays traced per camera sample (paths that survive longer trace more).
    pub rays_per_sample: f64,
    /// Time per traced ray over classic's: the cost of shading a vertex, whatever the path
    /// lengths.
    pub ray_cost_to_classic: Option<f64>,
    /// Rays/s over the scene's Embree ceiling.
    pub fraction_of_ceiling: Option<f64>,
    pub equal_time: Option<equal_time::EqualTime>,
}

/// Everything a benchmark measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub groove_version: String,
    pub spp: u32,
    pub repeat: u32,
    pub threads: usize,
    /// The render loops asked for (`--renderer`), in order: `auto`, `scalar`, `stream`.
    pub renderers: Vec<String>,
    pub cpu: String,
    pub records: Vec<RunRecord>,
    pub summaries: Vec<ModeSummary>,
    pub ceilings: Vec<ceiling::Ceiling>,
    pub peers: Vec<peer::PeerResult>,
    /// Why the peer column is missing, when it is.
    pub peer_note: Option<String>,
}

/// The default benchmark set: `scenes/bench/*.xml` under the working directory, else under the
/// source tree groove was built from.
pub fn default_scenes() -> Result<Vec<PathBuf>> {
    let local = PathBuf::from("scenes/bench");
    let dir = if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bench")
    };
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| crate::error::Error::io(&dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "xml"))
        .collect();
    v.sort();
    if v.is_empty() {
        return Err(crate::error::Error::file(
            &dir,
            "no benchmark scenes (*.xml) here",
        ));
    }
    Ok(v)
}

/// A scene's display name: its file stem.
pub fn scene_name(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

fn load_mode(path: &Path, mode: &str, defines: &[(String, String)]) -> Result<Loaded> {
    let normal_mapping = NormalMapping::parse(mode).ok_or_else(|| {
        crate::error::Error::Usage(format!(
            "unknown normal-mapping mode '{mode}' (expected one of {})",
            MODES.join(", ")
        ))
    })?;
    let opts = LoadOptions {
        defines: defines.to_vec(),
        normal_mapping,
        ..Default::default()
    };
    load_scene(path, &opts)
}

/// A render under the default loop ([`Renderer::Auto`]: the same image whichever runs).
fn render_at(loaded: &Loaded, spp: u32, seed: u64, threads: usize) -> Result<(Image, RenderStats)> {
    render_with(loaded, spp, seed, threads, Renderer::Auto)
}

/// [`render_at`] with the render loop `renderer`.
fn render_with(
    loaded: &Loaded,
    spp: u32,
    seed: u64,
    threads: usize,
    renderer: Renderer,
) -> Result<(Image, RenderStats)> {
    let out = render(
        &loaded.scene,
        &loaded.settings,
        &RenderOptions {
            threads,
            spp: Some(spp),
            seed: Some(seed),
            progress: false,
            renderer,
            // The developed image only, as `groove render` without a part.
            second_moments: false,
            ..Default::default()
        },
    )?;
    Ok((out.film.develop(), out.stats))
}

fn record(scene: &str, mode: &str, repeat: u32, st: &RenderStats, w: u32, h: u32) -> RunRecord {
    RunRecord {
        scene: scene.into(),
        mode: mode.into(),
        renderer: st.renderer.name().into(),
        repeat,
        spp: st.spp,
        threads: st.threads,
        width: w,
        height: h,
        seconds: st.seconds,
        samples: st.samples,
        samples_per_second: st.samples_per_second(),
        rays: st.rays.total(),
        camera_rays: st.rays.camera,
        bounce_rays: st.rays.bounce,
        shadow_rays: st.rays.shadow,
        rays_per_second: st.rays_per_second(),
        mean_walk_length: (st.rays.walks > 0).then(|| st.rays.mean_walk_length()),
        invalid_samples: st.invalid_samples,
        active_lanes: (st.rays.lanes.batches > 0).then(|| {
            let (a, b, c) = st.rays.lanes.fractions();
            [a, b, c]
        }),
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Run the benchmark: per scene the Embree ceiling, the timed modes, the equal-time comparison
/// and the summaries; then the Mitsuba 3 peer column.
pub fn run(opts: &BenchOptions) -> Result<BenchReport> {
    let threads = crate::render::thread_pool(opts.threads)?.current_num_threads();
    let mut report = BenchReport {
        groove_version: env!("CARGO_PKG_VERSION").into(),
        spp: opts.spp,
        repeat: opts.repeat,
        threads,
        renderers: opts
            .renderers
            .iter()
            .map(|r| r.name().to_string())
            .collect(),
        cpu: cpu_model(),
        records: Vec::new(),
        summaries: Vec::new(),
        ceilings: Vec::new(),
        peers: Vec::new(),
        peer_note: None,
    };
    for path in &opts.scenes {
        bench_scene(opts, path, threads, &mut report)?;
    }
    run_peers(opts, threads, &mut report);
    Ok(report)
}

/// A progress line on stderr when `--verbose`.
fn say(opts: &BenchOptions, m: String) {
    if opts.verbose {
        eprintln!("bench: {m}");
    }
}

/// Every mode of one scene, loaded: a mode that cannot apply (e.g. explicit over glass) holds
/// the reason it was skipped.
type ModeScenes = Vec<(String, std::result::Result<Loaded, String>)>;

/// The median render times of one scene's modes, and the classic mode's reference values.
struct Timing {
    /// Median seconds per mode (`None` for a skipped mode).
    medians: Vec<Option<f64>>,
    /// Classic's median seconds.
    classic: Option<f64>,
    /// Classic's (median seconds, mean rays per render).
    classic_rays: Option<(f64, f64)>,
}

/// One scene: ceiling, modes, equal-time comparison, images and summaries, into `report`.
fn bench_scene(
    opts: &BenchOptions,
    path: &Path,
    threads: usize,
    report: &mut BenchReport,
) -> Result<()> {
    let name = scene_name(path);
    // Ceiling first: it also proves the scene loads.
    let ceil = if opts.ceiling || opts.rays_only {
        say(opts, format!("{name}: Embree ceiling"));
        let scene = load_mode(path, "classic", &opts.defines)?;
        let c = ceiling::measure(&scene, &name, opts.spp, threads, opts.repeat.max(1))?;
        say(
            opts,
            format!(
                "{name}: {} rays traced again at {:.2} Mrays/s",
                c.rays,
                c.rays_per_second / 1e6
            ),
        );
        if let Some(a) = &c.tier_a {
            say(
                opts,
                format!(
                    "{name}: tier A ({} primitives): {:.2} Mrays/s single, {:.2} Mrays/s packets \
                     (Embree {:.2} single, {:.2} packets)",
                    a.primitives,
                    a.single_rays_per_second / 1e6,
                    a.packet_rays_per_second / 1e6,
                    c.rays_per_second / 1e6,
                    c.packet_rays_per_second / 1e6
                ),
            );
        }
        report.ceilings.push(c.clone());
        Some(c)
    } else {
        None
    };
    if opts.rays_only {
        return Ok(());
    }
    let scenes = load_modes(opts, path, &name);
    // runs[k][i]: renderer k, mode i.
    let runs = time_modes(opts, &name, &scenes, threads, report)?;
    let timings: Vec<Timing> = runs.iter().map(|r| timing(&scenes, r)).collect();
    let eq = equal_time_modes(opts, path, &name, &scenes, &timings[0], threads)?;
    if let Some(dir) = &opts.images {
        let refs: Vec<(String, &Image)> = scenes
            .iter()
            .zip(&eq)
            .filter_map(|((m, _), e)| e.as_ref().map(|e| (m.clone(), &e.1)))
            .collect();
        if !refs.is_empty() {
            chart::write_image_grid(dir, &name, &refs)?;
        }
    }
    let none = None;
    for (i, (mode, s)) in scenes.iter().enumerate() {
        for (k, renderer) in opts.renderers.iter().enumerate() {
            let summary = match s {
                Err(e) => skipped_summary(&name, mode, renderer.name(), e),
                Ok(_) => mode_summary(
                    &name,
                    mode,
                    &runs[k][i],
                    &timings[k],
                    i,
                    ceil.as_ref(),
                    if k == 0 { &eq[i] } else { &none },
                ),
            };
            report.summaries.push(summary);
        }
    }
    Ok(())
}

/// Loads the scene once per requested mode.
fn load_modes(opts: &BenchOptions, path: &Path, name: &str) -> ModeScenes {
    let mut scenes: ModeScenes = Vec::new();
    for mode in &opts.modes {
        let s = load_mode(path, mode, &opts.defines).map_err(|e| e.to_string());
        if let Err(e) = &s {
            say(opts, format!("{name}: {mode} skipped: {e}"));
        }
        scenes.push((mode.clone(), s));
    }
    scenes
}

/// Warm-up (untimed, 1 spp), then `repeat` rounds over the modes and, within a mode, the render
/// loops; each timed render is recorded in `report` and returned per render loop and mode.
fn time_modes(
    opts: &BenchOptions,
    name: &str,
    scenes: &ModeScenes,
    threads: usize,
    report: &mut BenchReport,
) -> Result<Vec<Vec<Vec<RenderStats>>>> {
    for (_, s) in scenes {
        if let Ok(s) = s {
            for &renderer in &opts.renderers {
                render_with(s, 1, 0, threads, renderer)?;
            }
        }
    }
    let mut runs = vec![vec![Vec::new(); scenes.len()]; opts.renderers.len()];
    for r in 0..opts.repeat.max(1) {
        for (i, (mode, s)) in scenes.iter().enumerate() {
            let Ok(s) = s else { continue };
            for (k, &renderer) in opts.renderers.iter().enumerate() {
                let (_, st) = render_with(s, opts.spp, r as u64, threads, renderer)?;
                say(
                    opts,
                    format!(
                        "{name}: {mode} {} #{r}: {:.3} s",
                        st.renderer.name(),
                        st.seconds
                    ),
                );
                report.records.push(record(
                    name,
                    mode,
                    r,
                    &st,
                    s.settings.film.crop_size.0,
                    s.settings.film.crop_size.1,
                ));
                runs[k][i].push(st);
            }
        }
    }
    Ok(runs)
}

/// Median times per mode and classic's reference values.
fn timing(scenes: &ModeScenes, runs: &[Vec<RenderStats>]) -> Timing {
    let medians: Vec<Option<f64>> = runs
        .iter()
        .map(|v| {
            (!v.is_empty()).then(|| median(&mut v.iter().map(|s| s.seconds).collect::<Vec<_>>()))
        })
        .collect();
    let classic = scenes
        .iter()
        .position(|(m, _)| m == "classic")
        .and_then(|i| medians[i]);
    let classic_rays = scenes
        .iter()
        .position(|(m, _)| m == "classic")
        .filter(|&i| !runs[i].is_empty())
        .and_then(|i| {
            let r = &runs[i];
            let rays = r.iter().map(|s| s.rays.total() as f64).sum::<f64>() / r.len() as f64;
            medians[i].map(|m| (m, rays))
        });
    Timing {
        medians,
        classic,
        classic_rays,
    }
}

/// The equal-time comparison (when `--ref-spp` > 0): each mode at the spp that fits classic's
/// median time (or the first timed mode's), against a high-spp reference.
fn equal_time_modes(
    opts: &BenchOptions,
    path: &Path,
    name: &str,
    scenes: &ModeScenes,
    timing: &Timing,
    threads: usize,
) -> Result<Vec<Option<(equal_time::EqualTime, Image)>>> {
    if opts.ref_spp == 0 {
        return Ok(vec![None; scenes.len()]);
    }
    let medians = &timing.medians;
    let budget = timing
        .classic
        .or_else(|| medians.iter().flatten().next().copied());
    let mut v = Vec::new();
    for (i, (mode, s)) in scenes.iter().enumerate() {
        let (Ok(s), Some(budget), Some(t)) = (s, budget, medians[i]) else {
            v.push(None);
            continue;
        };
        let spp = ((opts.spp as f64 * budget / t).round() as u32).max(1);
        say(
            opts,
            format!(
                "{name}: {mode} equal time: {spp} spp vs {} spp reference",
                opts.ref_spp
            ),
        );
        v.push(Some(equal_time::measure(
            s,
            path,
            name,
            mode,
            spp,
            opts.ref_spp,
            threads,
            opts.ref_dir.as_deref(),
            &opts.defines,
        )?));
    }
    Ok(v)
}

/// The summary of a mode that could not be loaded.
fn skipped_summary(name: &str, mode: &str, renderer: &str, reason: &str) -> ModeSummary {
    ModeSummary {
        scene: name.to_string(),
        mode: mode.to_string(),
        renderer: renderer.to_string(),
        status: "skipped".into(),
        reason: Some(reason.to_string()),
        min_seconds: f64::NAN,
        median_seconds: f64::NAN,
        samples_per_second: f64::NAN,
        rays_per_second: f64::NAN,
        mean_walk_length: None,
        ratio_to_classic: None,
        rays_per_sample: f64::NAN,
        ray_cost_to_classic: None,
        fraction_of_ceiling: None,
        equal_time: None,
    }
}

/// The summary of mode `i` over its timed renders `v`.
fn mode_summary(
    name: &str,
    mode: &str,
    v: &[RenderStats],
    timing: &Timing,
    i: usize,
    ceil: Option<&ceiling::Ceiling>,
    eq: &Option<(equal_time::EqualTime, Image)>,
) -> ModeSummary {
    let med = timing.medians[i].unwrap_or(f64::NAN);
    let min = v.iter().map(|s| s.seconds).fold(f64::INFINITY, f64::min);
    let samples = v[0].samples as f64;
    let rays = v.iter().map(|s| s.rays.total() as f64).sum::<f64>() / v.len() as f64;
    let mut walks = crate::integrator::RayCounters::default();
    for s in v {
        walks.add(&s.rays);
    }
    let rps = rays / med;
    ModeSummary {
        scene: name.to_string(),
        mode: mode.to_string(),
        renderer: v[0].renderer.name().to_string(),
        status: "ok".into(),
        reason: None,
        min_seconds: min,
        median_seconds: med,
        samples_per_second: samples / med,
        rays_per_second: rps,
        mean_walk_length: (walks.walks > 0).then(|| walks.mean_walk_length()),
        ratio_to_classic: timing.classic.map(|c| med / c),
        rays_per_sample: rays / samples,
        ray_cost_to_classic: timing.classic_rays.map(|(c, cr)| (med / rays) / (c / cr)),
        fraction_of_ceiling: ceil.map(|c| rps / c.rays_per_second),
        equal_time: eq.as_ref().map(|e| e.0.clone()),
    }
}

/// The Mitsuba 3 peer column (`--peer`), or the note saying why it is missing.
fn run_peers(opts: &BenchOptions, threads: usize, report: &mut BenchReport) {
    match &opts.peer_python {
        None => report.peer_note = Some("peer column not requested (--peer off)".into()),
        Some(py) => match peer::available(py) {
            Err(why) => {
                say(opts, format!("Mitsuba peer skipped: {why}"));
                report.peer_note = Some(format!("Mitsuba 3 peer skipped: {why}"));
            }
            Ok(()) if opts.rays_only => {}
            Ok(()) => {
                for path in &opts.scenes {
                    for r in peer::run_all(py, path, opts.spp, threads, opts.repeat, &opts.defines)
                    {
                        say(
                            opts,
                            format!(
                                "{}: Mitsuba {} {}",
                                r.scene,
                                r.variant,
                                match (&r.median_seconds, &r.reason) {
                                    (Some(t), _) => format!("{t:.3} s"),
                                    (None, Some(e)) => format!("skipped: {e}"),
                                    _ => "skipped".into(),
                                }
                            ),
                        );
                        report.peers.push(r);
                    }
                }
            }
        },
    }
}

/// The CPU model from /proc/cpuinfo (empty when unknown).
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_default()
}
