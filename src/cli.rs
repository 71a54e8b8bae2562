//! Command-line interface (clap derive): `groove render ...`.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "groove",
    version,
    about = "Physically based renderer for Mitsuba XML scenes"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render one or more scenes to EXR or PNG.
    Render(RenderArgs),
    /// Add the parts of a split render (`render --crop/--tile/--samples`) into one image.
    Merge(MergeArgs),
    /// Time classic against microfacet normal mapping (every mode, equal spp and equal time),
    /// against Embree's intersection ceiling and, when importable, Mitsuba 3.
    Bench(BenchArgs),
}

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Scene files (default: the benchmark set, scenes/bench/*.xml).
    pub scenes: Vec<PathBuf>,
    /// Samples per pixel of the timed renders.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: u32,
    /// Worker threads (0 = all cores).
    #[arg(short = 't', long = "threads", default_value_t = 0)]
    pub threads: usize,
    /// Timed renders per scene and mode (min and median are reported).
    #[arg(long, default_value_t = 3)]
    pub repeat: u32,
    /// Modes to compare, comma-separated (default: all; `classic` is the ratios' reference).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "classic,explicit,walk-mirror,walk-same,vgroove,ugroove"
    )]
    pub modes: Vec<String>,
    /// Only the Embree ceiling: trace a classic render's rays again without shading.
    #[arg(long)]
    pub rays: bool,
    /// Skip the Embree ceiling.
    #[arg(long)]
    pub no_ceiling: bool,
    /// Reference spp of the equal-time comparison (default 8 × --spp; 0 = no comparison).
    #[arg(long)]
    pub ref_spp: Option<u32>,
    /// Cache for the references (default: the system temp directory's groove-bench-refs).
    #[arg(long)]
    pub ref_dir: Option<PathBuf>,
    /// Also write each mode's reference as PNG and an image grid with differences from classic.
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
    /// JSON output (one record per scene × mode × repeat, plus summaries).
    #[arg(long, value_name = "FILE", default_value = "groove-bench.json")]
    pub json: PathBuf,
    /// Markdown table (also printed on stdout).
    #[arg(long, value_name = "FILE", default_value = "groove-bench.md")]
    pub md: PathBuf,
    /// PNG bar chart of the render times.
    #[arg(long, value_name = "FILE", default_value = "groove-bench.png")]
    pub plot: PathBuf,
    /// Mitsuba 3 peer column: `auto` (when `import mitsuba` works) or `off`.
    #[arg(long, default_value = "auto", value_parser = ["auto", "off"])]
    pub peer: String,
    /// Python interpreter for the peer (default: $GROOVE_MITSUBA_PYTHON, else python3).
    #[arg(long, value_name = "PYTHON")]
    pub mitsuba_python: Option<String>,
    /// Scene parameter: sets `$key`, repeatable.
    #[arg(short = 'D', value_name = "KEY=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
    /// Render loops of the timed renders, comma-separated: `auto`, `scalar`, `stream` (see
    /// `groove render --renderer`); with several, each mode is timed under each, interleaved,
    /// one record per renderer.
    #[arg(
        long,
        value_name = "KIND[,KIND]",
        value_delimiter = ',',
        default_value = "auto",
        value_parser = parse_renderer
    )]
    pub renderer: Vec<crate::render::Renderer>,
    /// No progress lines.
    #[arg(short = 'q', long = "quiet")]
    pub quiet: bool,
}

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene files (Mitsuba XML).
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// Output image (.exr or .png). With several scenes: a directory, created if missing.
    /// Default: the scene's file stem + .exr in the working directory.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Scene parameter: sets `$key` (overrides the scene's `<default>`), repeatable.
    #[arg(short = 'D', value_name = "KEY=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
    /// Samples per pixel (overrides the sampler's `sample_count`; at least 1).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Worker threads (0 = all cores).
    #[arg(short = 't', long = "threads", default_value_t = 0)]
    pub threads: usize,
    /// Memory limit in GB (2^30 bytes) for what the scene and its render allocate (images,
    /// meshes, the expanded XML, the film), checked before allocating. Default: half of the
    /// machine's physical memory.
    #[arg(long = "max-memory", value_name = "GB", value_parser = parse_gb)]
    pub max_memory: Option<f64>,
    /// Random seed (overrides the sampler's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Normal-mapping model for every normal map of the scene: `classic` (plain `normalmap`, no
    /// flip, no shadowing term), `microfacet` (`microfacet_normalmap`, its parameters as written
    /// or defaults), or one microfacet model forced everywhere: `explicit` (sawtooth, mirror
    /// wall, closed form), `explicit4` (its complete first order), `compensated` (the complete
    /// first order plus the walk's tabulated remainder), `auto` (per shading point `compensated`
    /// where its misplaced energy against the walk is small, else `walk-mirror`, blended
    /// between), `walk-mirror`, `walk-same` (the default model), `vgroove`, `ugroove`.
    /// Default: as the scene is written.
    #[arg(long = "normal-mapping", value_name = "MODE", value_parser = parse_normal_mapping)]
    pub normal_mapping: Option<crate::load::options::NormalMapping>,
    /// No progress bar and no warnings (errors and the summary still print).
    #[arg(short = 'q', long = "quiet")]
    pub quiet: bool,
    /// Render only the pixels X..X+W, Y..Y+H of the film (a filter-radius border around them is
    /// sampled too); writes a part (see --part).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    pub crop: Option<(u32, u32, u32, u32)>,
    /// Render tile I of N (0 ≤ I < N): the rows of the crop window (the scene's, or --crop) cut
    /// into N strips of nearly equal height; writes a part.
    #[arg(long, value_name = "I/N", value_parser = parse_tile)]
    pub tile: Option<(u32, u32)>,
    /// Render the sample indices A..B (A included, B not) of each pixel's streams of --spp (or
    /// the scene's) samples; writes a part.
    #[arg(long, value_name = "A..B", value_parser = parse_samples)]
    pub samples: Option<(u32, u32)>,
    /// Write a part (an EXR with the exact sums, for `groove merge`) even without --crop,
    /// --tile or --samples.
    #[arg(long)]
    pub part: bool,
    /// Stop at the first pass boundary after this many seconds and write what was rendered
    /// (the metadata `groove.samples` says how many samples).
    #[arg(long = "time-limit", value_name = "SECONDS", value_parser = parse_seconds)]
    pub time_limit: Option<f64>,
    /// Render loop: `auto` (the stream renderer where it runs the scene's integrator, else the
    /// scalar one), `scalar` (one path at a time; every integrator) or `stream` (batches of
    /// paths stage by stage; the `path` integrator only, same image bit for bit; an error for
    /// other integrators).
    #[arg(long, value_name = "KIND", default_value = "auto", value_parser = parse_renderer)]
    pub renderer: crate::render::Renderer,
    /// Write a JSON record of every render of the batch (timings, rays, samples, warnings,
    /// outputs) and a summary to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Output image (.exr or .png).
    pub output: PathBuf,
    /// The parts (EXR files written by `groove render --crop/--tile/--samples/--part`).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Merge even when samples or pixels are missing (each gap is reported; nothing is filled).
    #[arg(long = "allow-missing")]
    pub allow_missing: bool,
    /// Memory limit in GB (default: half of the physical memory).
    #[arg(long = "max-memory", value_name = "GB", value_parser = parse_gb)]
    pub max_memory: Option<f64>,
    /// No summary line.
    #[arg(short = 'q', long = "quiet")]
    pub quiet: bool,
}

fn parse_crop(s: &str) -> Result<(u32, u32, u32, u32), String> {
    match crate::output::part::parse_rect(s) {
        Some(r) if r.2 > 0 && r.3 > 0 => Ok(r),
        _ => Err(format!(
            "expected X,Y,W,H (pixels, W and H at least 1), got '{s}'"
        )),
    }
}

fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let t = s
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    match t {
        Some((i, n)) if i < n => Ok((i, n)),
        _ => Err(format!("expected I/N with 0 <= I < N, got '{s}'")),
    }
}

fn parse_samples(s: &str) -> Result<(u32, u32), String> {
    match crate::output::part::parse_range(s) {
        Some((a, b)) if a < b => Ok((a, b)),
        _ => Err(format!("expected A..B with A < B, got '{s}'")),
    }
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a number of seconds, got '{s}'")),
    }
}

pub(crate) fn parse_normal_mapping(s: &str) -> Result<crate::load::options::NormalMapping, String> {
    use crate::load::options::NormalMapping;
    match NormalMapping::parse(s) {
        Some(m) if s != "as_written" && s != "as-written" => Ok(m),
        _ => Err(format!(
            "expected one of {}, got '{s}'",
            NormalMapping::NAMES.join(", ")
        )),
    }
}

fn parse_renderer(s: &str) -> Result<crate::render::Renderer, String> {
    crate::render::Renderer::parse(s).ok_or_else(|| {
        format!(
            "expected one of {}, got '{s}'",
            crate::render::Renderer::NAMES.join(", ")
        )
    })
}

fn parse_gb(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a positive number of GB, got '{s}'")),
    }
}

/// Parses one `-D KEY=VALUE` (public for the fuzz target).
pub fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
        _ => Err(format!("expected KEY=VALUE, got '{s}'")),
    }
}
