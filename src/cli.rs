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
    /// Samples per pixel (overrides the sampler's `sample_count`).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads (0 = all cores).
    #[arg(short = 't', long = "threads", default_value_t = 0)]
    pub threads: usize,
    /// Random seed (overrides the sampler's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Normal-mapping model for every normal map of the scene: `classic` (plain `normalmap`, no
    /// flip, no shadowing term), `microfacet` (`microfacet_normalmap`, its parameters as written
    /// or defaults), or one microfacet model forced everywhere: `explicit` (sawtooth, mirror
    /// wall, closed form), `walk-mirror` (the default model), `walk-same`, `vgroove`, `ugroove`.
    /// Default: as the scene is written.
    #[arg(long = "normal-mapping", value_name = "MODE", value_parser = parse_normal_mapping)]
    pub normal_mapping: Option<crate::scene::instantiate::NormalMapping>,
    /// No progress bar and no warnings (errors and the summary still print).
    #[arg(short = 'q', long = "quiet")]
    pub quiet: bool,
}

pub(crate) fn parse_normal_mapping(
    s: &str,
) -> Result<crate::scene::instantiate::NormalMapping, String> {
    use crate::scene::instantiate::NormalMapping;
    match NormalMapping::parse(s) {
        Some(m) if s != "as_written" && s != "as-written" => Ok(m),
        _ => Err(format!(
            "expected one of {}, got '{s}'",
            NormalMapping::NAMES.join(", ")
        )),
    }
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
        _ => Err(format!("expected KEY=VALUE, got '{s}'")),
    }
}
