//! The `groove` binary: parse the command line, load each scene, render it, write the image.
//! A failing scene is reported (`error: FILE:LINE:COL: message`) and skipped; the exit status is
//! non-zero if any scene failed. SIGINT / SIGTERM stop the render within a few thousand samples,
//! write nothing for the interrupted scene, skip the rest of the batch and exit with 130 / 143.

use anyhow::{Context, Result};
use clap::Parser;
use groove::budget::Budget;
use groove::cancel::Cancel;
use groove::cli::{BenchArgs, Cli, Command, RenderArgs};
use groove::output::{write_image_channels, Metadata};
use groove::render::{render, RenderOptions};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Compensated normal mapping's remainder tables persist between runs (memory only if
    // neither $XDG_CACHE_HOME nor $HOME is set; a folder that cannot be written is a warning).
    groove::bsdf::mnm::ms_cache::enable_disk_cache(groove::bsdf::mnm::ms_cache::default_dir());
    match cli.command {
        Command::Render(args) => run_render(&args),
        Command::Bench(args) => match run_bench(&args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}

fn run_bench(args: &BenchArgs) -> Result<()> {
    use groove::bench;
    for m in &args.modes {
        if !bench::MODES.contains(&m.as_str()) {
            anyhow::bail!(
                "unknown mode '{m}' in --modes (expected {})",
                bench::MODES.join(", ")
            );
        }
    }
    // Check every output before spending minutes on renders.
    for (p, ext) in [(&args.json, "json"), (&args.md, "md"), (&args.plot, "png")] {
        if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
            anyhow::bail!("{}: expected a .{ext} file", p.display());
        }
        if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
            if !d.is_dir() {
                anyhow::bail!("{}: output directory does not exist", d.display());
            }
        }
    }
    let scenes = if args.scenes.is_empty() {
        bench::default_scenes()?
    } else {
        args.scenes.clone()
    };
    let peer_python = (args.peer == "auto").then(|| {
        args.mitsuba_python
            .clone()
            .or_else(|| std::env::var("GROOVE_MITSUBA_PYTHON").ok())
            .unwrap_or_else(|| "python3".into())
    });
    let opts = bench::BenchOptions {
        scenes,
        spp: args.spp.max(1),
        threads: args.threads,
        repeat: args.repeat.max(1),
        modes: args.modes.clone(),
        defines: args.defines.clone(),
        ref_spp: args.ref_spp.unwrap_or(8 * args.spp.max(1)),
        ref_dir: Some(
            args.ref_dir
                .clone()
                .unwrap_or_else(|| std::env::temp_dir().join("groove-bench-refs")),
        ),
        images: args.images.clone(),
        ceiling: !args.no_ceiling,
        rays_only: args.rays,
        peer_python,
        verbose: !args.quiet,
    };
    let t0 = std::time::Instant::now();
    let report = bench::run(&opts)?;
    let command: Vec<String> = std::env::args()
        .enumerate()
        .map(|(i, a)| if i == 0 { "groove".into() } else { a })
        .collect();
    let md = bench::report::markdown(&report, &command.join(" "));
    bench::report::write_json(&args.json, &report)?;
    bench::report::write_text(&args.md, &md)?;
    if !args.rays {
        bench::chart::write_bar_chart(&args.plot, &report)?;
    }
    print!("{md}");
    if !args.quiet {
        eprintln!(
            "bench: {:.1} s in all -> {}, {}{}",
            t0.elapsed().as_secs_f64(),
            args.json.display(),
            args.md.display(),
            if args.rays {
                String::new()
            } else {
                format!(", {}", args.plot.display())
            }
        );
    }
    Ok(())
}

fn run_render(args: &RenderArgs) -> ExitCode {
    let cancel = match Cancel::on_signals() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("warning: cannot catch SIGINT/SIGTERM ({e}); Ctrl-C will kill the render");
            Cancel::new()
        }
    };
    let mut failed = 0usize;
    let multi = args.scenes.len() > 1;
    if multi {
        if let Some(dir) = &args.output {
            if let Err(e) = std::fs::create_dir_all(dir) {
                eprintln!(
                    "error: {}: cannot create output directory: {e}",
                    dir.display()
                );
                return ExitCode::FAILURE;
            }
        }
    }
    // Outputs that would overwrite a scene file or each other: refused before any render.
    let jobs: Vec<(PathBuf, PathBuf)> = args
        .scenes
        .iter()
        .map(|s| (s.clone(), output_path(args, s, multi)))
        .collect();
    if let Err(e) = groove::output::clash::check_batch(&jobs) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    // Every file read by the scenes rendered so far: a later output must not replace one.
    let mut inputs: Vec<PathBuf> = args.scenes.clone();
    for (i, scene_path) in args.scenes.iter().enumerate() {
        let result = render_one(args, scene_path, multi, &cancel, &mut inputs);
        if let Some(sig) = cancel.requested() {
            let skipped = args.scenes.len() - i - 1;
            eprintln!(
                "interrupted ({}): {} {}{}",
                signal_name(sig),
                scene_path.display(),
                if result.is_ok() {
                    "was written"
                } else {
                    "not written"
                },
                if skipped > 0 {
                    format!(", {skipped} more scenes skipped")
                } else {
                    String::new()
                }
            );
            return ExitCode::from((128 + sig.min(127)) as u8);
        }
        if let Err(e) = result {
            failed += 1;
            eprintln!("error: {e:#}");
        }
    }
    if failed > 0 {
        if multi {
            eprintln!("{failed} of {} scenes failed", args.scenes.len());
        }
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn signal_name(sig: usize) -> String {
    match sig as i32 {
        signal_hook::consts::SIGINT => "SIGINT".into(),
        signal_hook::consts::SIGTERM => "SIGTERM".into(),
        s => format!("signal {s}"),
    }
}

fn output_path(args: &RenderArgs, scene: &Path, multi: bool) -> PathBuf {
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    match (&args.output, multi) {
        (Some(dir), true) => dir.join(format!("{stem}.exr")),
        (Some(file), false) => file.clone(),
        (None, _) => PathBuf::from(format!("{stem}.exr")),
    }
}

/// Loads, renders and writes one scene; `inputs` collects the files the batch has read.
fn render_one(
    args: &RenderArgs,
    scene_path: &Path,
    multi: bool,
    cancel: &Cancel,
    inputs: &mut Vec<PathBuf>,
) -> Result<()> {
    let out = output_path(args, scene_path, multi);
    groove::output::check_extension(&out)?;
    let budget = match args.max_memory {
        Some(gb) => Budget::from_gb(gb).context("--max-memory must be a positive number of GB")?,
        None => Budget::default(),
    };
    let load = groove::load::options::LoadOptions {
        defines: args.defines.clone(),
        normal_mapping: args.normal_mapping.unwrap_or_default(),
        budget: budget.clone(),
    };
    let t0 = std::time::Instant::now();
    let loaded = groove::load::load_scene(scene_path, &load)?;
    inputs.extend(loaded.inputs.iter().cloned());
    groove::output::clash::check_not_input(&out, inputs).map_err(anyhow::Error::msg)?;
    if !args.quiet {
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
    }
    let load_s = t0.elapsed().as_secs_f64();
    let opts = RenderOptions {
        threads: args.threads,
        spp: args.spp,
        seed: args.seed,
        progress: !args.quiet && std::io::stderr().is_terminal(),
        cancel: Some(cancel.clone()),
        budget,
        ..Default::default()
    };
    let result = render(&loaded.scene, &loaded.settings, &opts)?;
    let st = &result.stats;
    let img = result.film.develop();
    let meta = Metadata(vec![
        ("groove.version".into(), groove::VERSION.into()),
        ("groove.scene".into(), scene_path.display().to_string()),
        ("groove.spp".into(), st.spp.to_string()),
        ("groove.seed".into(), st.seed.to_string()),
        ("groove.threads".into(), st.threads.to_string()),
        ("groove.render_time_s".into(), format!("{:.6}", st.seconds)),
    ]);
    let extra: Vec<(String, Vec<f32>)> = loaded
        .settings
        .integrator
        .aov_names()
        .into_iter()
        .enumerate()
        .map(|(c, name)| (name, result.film.develop_channel(c)))
        .collect();
    let all = write_image_channels(&out, &img, &extra, &meta)
        .with_context(|| format!("writing {}", out.display()))?;
    if !all && !args.quiet {
        eprintln!(
            "warning: {}: a PNG holds the RGB image only; the integrator's {} extra channels \
             (AOVs) are not written (use .exr)",
            out.display(),
            extra.len()
        );
    }
    if st.invalid_samples > 0 && !args.quiet {
        eprintln!(
            "warning: {}: {} samples were NaN or infinite and were dropped",
            scene_path.display(),
            st.invalid_samples
        );
    }
    let dropped = if st.invalid_samples > 0 {
        format!(", {} NaN/inf samples dropped", st.invalid_samples)
    } else {
        String::new()
    };
    println!(
        "{}: {}x{} {} spp, load {:.2} s, render {:.3} s, {:.3} Msamples/s, {:.3} Mrays/s ({} threads){dropped} -> {}",
        scene_path.display(),
        img.width,
        img.height,
        st.spp,
        load_s,
        st.seconds,
        st.samples_per_second() * 1e-6,
        st.rays_per_second() * 1e-6,
        st.threads,
        out.display()
    );
    Ok(())
}
