//! The `groove` binary: parse the command line, load each scene, render it, write the image.
//! A failing scene is reported (`error: FILE:LINE:COL: message`) and skipped; the exit status is
//! non-zero if any scene failed. SIGINT / SIGTERM stop the render within a few thousand samples,
//! write nothing for the interrupted scene, skip the rest of the batch and exit with 130 / 143;
//! SIGUSR1 writes the current image at the next pass boundary and goes on. `groove merge` adds
//! the parts of a split render.

use anyhow::{Context, Result};
use clap::Parser;
use groove::budget::Budget;
use groove::cancel::Cancel;
use groove::cli::{BenchArgs, Cli, Command, MergeArgs, RenderArgs};
use groove::output::{part, write_image_window, Format, Metadata, Window};
use groove::render::{render, PassHook, RenderOptions};
use serde_json::json;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Compensated normal mapping's remainder tables persist between runs (memory only if
    // neither $XDG_CACHE_HOME nor $HOME is set; a folder that cannot be written is a warning).
    groove::bsdf::mnm::ms_cache::enable_disk_cache(groove::bsdf::mnm::ms_cache::default_dir());
    match cli.command {
        Command::Render(args) => run_render(&args),
        Command::Merge(args) => match run_merge(&args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
        Command::Bench(args) => match run_bench(&args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}

/// `--renderer` of `groove bench`: each loop once, in the order first given.
fn dedup_renderers(v: &[groove::render::Renderer]) -> Vec<groove::render::Renderer> {
    let mut out = Vec::new();
    for r in v {
        if !out.contains(r) {
            out.push(*r);
        }
    }
    out
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
        renderers: dedup_renderers(&args.renderer),
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

fn run_merge(args: &MergeArgs) -> Result<()> {
    let budget = match args.max_memory {
        Some(gb) => Budget::from_gb(gb).context("--max-memory must be a positive number of GB")?,
        None => Budget::default(),
    };
    groove::output::check_extension(&args.output)?;
    groove::merge::check_output(&args.output, &args.parts)?;
    let t0 = std::time::Instant::now();
    let m = groove::merge::merge(&args.parts, args.allow_missing, &budget)?;
    for line in &m.missing {
        eprintln!("warning: missing: {line}");
    }
    let (img, extra) = m.develop();
    let all = write_image_window(
        &args.output,
        &img,
        &extra,
        &m.meta,
        groove::merge::window(&m),
    )
    .with_context(|| format!("writing {}", args.output.display()))?;
    if !all {
        eprintln!(
            "warning: {}: a PNG holds the RGB image only; the {} extra channels are not written",
            args.output.display(),
            extra.len()
        );
    }
    if !args.quiet {
        println!(
            "merged {} parts: {}x{}{} in {:.2} s -> {}",
            args.parts.len(),
            img.width,
            img.height,
            if m.missing.is_empty() {
                String::new()
            } else {
                format!(", {} gaps", m.missing.len())
            },
            t0.elapsed().as_secs_f64(),
            args.output.display()
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
    // SIGUSR1: write the current image at the next pass boundary (the handler only sets a flag).
    let usr1 = Arc::new(AtomicBool::new(false));
    let usr1 = signal_hook::flag::register(signal_hook::consts::SIGUSR1, usr1.clone())
        .map(|_| usr1)
        .map_err(|e| eprintln!("warning: cannot catch SIGUSR1 ({e})"))
        .ok();
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
    if let Some(j) = &args.json {
        if jobs.iter().any(|(s, o)| {
            groove::output::clash::output_key(o) == groove::output::clash::output_key(j)
                || groove::output::clash::same_file(s, j)
        }) {
            eprintln!(
                "error: --json {} is a scene or an image output of the batch",
                j.display()
            );
            return ExitCode::FAILURE;
        }
    }
    let t_batch = std::time::Instant::now();
    let mut records = Vec::new();
    // Every file read by the scenes rendered so far: a later output must not replace one.
    let mut inputs: Vec<PathBuf> = args.scenes.clone();
    let mut status = None;
    for (i, scene_path) in args.scenes.iter().enumerate() {
        let result = render_one(args, scene_path, multi, &cancel, usr1.as_ref(), &mut inputs);
        let record = match &result {
            Ok(r) => r.clone(),
            Err(e) => json!({ "scene": scene_path, "error": format!("{e:#}") }),
        };
        records.push(record);
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
            status = Some(ExitCode::from((128 + sig.min(127)) as u8));
            break;
        }
        if let Err(e) = result {
            failed += 1;
            eprintln!("error: {e:#}");
        }
    }
    if let Some(j) = &args.json {
        let doc = json!({
            "groove_version": groove::VERSION,
            "renders": records,
            "summary": {
                "scenes": args.scenes.len(),
                "rendered": records.iter().filter(|r| r.get("error").is_none()).count(),
                "failed": failed,
                "interrupted": status.is_some(),
                "seconds": t_batch.elapsed().as_secs_f64(),
            }
        });
        let text = serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n";
        if let Err(e) = groove::output::write_atomic(j, |w| {
            std::io::Write::write_all(w, text.as_bytes()).map_err(|e| e.to_string())
        }) {
            eprintln!("error: --json: {e}");
            failed += 1;
        }
    }
    if let Some(s) = status {
        return s;
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

/// What to write of a film: a part, or the developed image (placed in its frame when it is a
/// crop), with the attributes of the render.
#[derive(Clone)]
struct Writer {
    out: PathBuf,
    part: bool,
    window: Option<Window>,
    aovs: Vec<String>,
    meta: Metadata,
}

impl Writer {
    /// Writes `film` holding the samples `range`; `Ok(false)` when a PNG dropped the AOVs.
    fn write(
        &self,
        film: &groove::film::Film,
        range: (u32, u32),
        extra_meta: &[(&str, String)],
    ) -> Result<bool> {
        let mut meta = self.meta.clone();
        meta.0
            .push(("groove.samples".into(), format!("{}..{}", range.0, range.1)));
        meta.0
            .push(("groove.spp".into(), (range.1 - range.0).to_string()));
        for (k, v) in extra_meta {
            meta.0.push((k.to_string(), v.clone()));
        }
        if self.part {
            part::write_part(&self.out, film, &self.aovs, &meta)
                .with_context(|| format!("writing {}", self.out.display()))?;
            return Ok(true);
        }
        let extra: Vec<(String, Vec<f32>)> = self
            .aovs
            .iter()
            .enumerate()
            .map(|(c, name)| (name.clone(), film.develop_channel(c)))
            .collect();
        write_image_window(&self.out, &film.develop(), &extra, &meta, self.window)
            .with_context(|| format!("writing {}", self.out.display()))
    }
}

/// Loads, renders and writes one scene; `inputs` collects the files the batch has read.
/// Returns the scene's JSON record.
fn render_one(
    args: &RenderArgs,
    scene_path: &Path,
    multi: bool,
    cancel: &Cancel,
    usr1: Option<&Arc<AtomicBool>>,
    inputs: &mut Vec<PathBuf>,
) -> Result<serde_json::Value> {
    let out = output_path(args, scene_path, multi);
    let format = groove::output::check_extension(&out)?;
    let is_part = args.part || args.crop.is_some() || args.tile.is_some() || args.samples.is_some();
    if is_part && format != Format::Exr {
        anyhow::bail!(
            "{}: a part (--crop, --tile, --samples, --part) is an EXR file; merge parts into a PNG with groove merge",
            out.display()
        );
    }
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
    let mut warnings: Vec<String> = loaded.warnings.clone();
    if !args.quiet {
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
    }
    let load_s = t0.elapsed().as_secs_f64();
    let mut opts = RenderOptions {
        threads: args.threads,
        spp: args.spp,
        seed: args.seed,
        progress: !args.quiet && std::io::stderr().is_terminal(),
        cancel: Some(cancel.clone()),
        budget,
        crop: args.crop,
        samples: args.samples,
        time_limit: args.time_limit,
        renderer: args.renderer,
        // Only a part carries the second moments (Σw·v², Σw²); an image needs the first ones.
        second_moments: is_part,
        ..Default::default()
    };
    let desc = groove::render::film_for(&loaded.settings, &opts)?;
    if let Some((i, n)) = args.tile {
        let (x, y, w, h) = desc.crop_rect();
        if n > h {
            anyhow::bail!(
                "--tile {i}/{n}: the window to tile has only {h} rows (at most {h} tiles)"
            );
        }
        let r0 = (h as u64 * i as u64 / n as u64) as u32;
        let r1 = (h as u64 * (i as u64 + 1) / n as u64) as u32;
        opts.crop = Some((x, y + r0, w, r1 - r0));
    }
    let desc = groove::render::film_for(&loaded.settings, &opts)?;
    let crop = desc.crop_rect();
    let full = (desc.width, desc.height);
    let aovs = loaded.settings.integrator.aov_names();
    // Defines sorted by key, the order of one key's values kept (whichever wins, it is the same).
    let mut defines = args.defines.clone();
    defines.sort_by(|a, b| a.0.cmp(&b.0));
    let mut hashed = vec![scene_path.to_path_buf()];
    hashed.extend(loaded.inputs.iter().cloned());
    let spp_total = args
        .spp
        .unwrap_or(loaded.settings.sampler.sample_count)
        .max(1);
    let seed = args.seed.unwrap_or(loaded.settings.sampler.seed);
    let meta = Metadata(vec![
        ("groove.version".into(), groove::VERSION.into()),
        ("groove.scene".into(), scene_path.display().to_string()),
        ("groove.scene_hash".into(), part::scene_hash(&hashed)?),
        ("groove.defines".into(), serde_json::to_string(&defines)?),
        (
            "groove.normal_mapping".into(),
            format!("{:?}", args.normal_mapping.unwrap_or_default()),
        ),
        ("groove.seed".into(), seed.to_string()),
        ("groove.sample_count".into(), spp_total.to_string()),
        ("groove.aovs".into(), serde_json::to_string(&aovs)?),
        (
            "groove.crop".into(),
            format!("{},{},{},{}", crop.0, crop.1, crop.2, crop.3),
        ),
        ("groove.film".into(), format!("{}x{}", full.0, full.1)),
        ("groove.filter".into(), format!("{:?}", desc.filter)),
    ]);
    let window = ((crop.0, crop.1, crop.2, crop.3) != (0, 0, full.0, full.1)).then_some(Window {
        full,
        offset: (crop.0, crop.1),
    });
    let writer = Writer {
        out: out.clone(),
        part: is_part,
        window,
        aovs: aovs.clone(),
        meta,
    };
    if let Some(flag) = usr1 {
        let w = writer.clone();
        let flag = flag.clone();
        opts.on_pass = Some(PassHook(Arc::new(move |film, range| {
            if flag.swap(false, Ordering::SeqCst) {
                match w.write(film, range, &[("groove.snapshot", "1".into())]) {
                    Ok(_) => eprintln!(
                        "SIGUSR1: wrote {} (samples {}..{})",
                        w.out.display(),
                        range.0,
                        range.1
                    ),
                    Err(e) => eprintln!("warning: SIGUSR1: {e:#}"),
                }
            }
        })));
    }
    let result = render(&loaded.scene, &loaded.settings, &opts)?;
    let st = &result.stats;
    let all = writer.write(
        &result.film,
        st.sample_range,
        &[
            ("groove.threads", st.threads.to_string()),
            ("groove.render_time_s", format!("{:.6}", st.seconds)),
        ],
    )?;
    if !all {
        let w = format!(
            "{}: a PNG holds the RGB image only; the integrator's {} extra channels \
             (AOVs) are not written (use .exr)",
            out.display(),
            aovs.len()
        );
        if !args.quiet {
            eprintln!("warning: {w}");
        }
        warnings.push(w);
    }
    if st.invalid_samples > 0 {
        let w = format!(
            "{}: {} samples were NaN or infinite and were dropped",
            scene_path.display(),
            st.invalid_samples
        );
        if !args.quiet {
            eprintln!("warning: {w}");
        }
        warnings.push(w);
    }
    if st.stopped_early {
        let w = format!(
            "{}: the time limit stopped the render after samples {}..{} of {}..{}",
            scene_path.display(),
            st.sample_range.0,
            st.sample_range.1,
            st.sample_range.0,
            args.samples.map_or(st.sample_count, |s| s.1)
        );
        if !args.quiet {
            eprintln!("warning: {w}");
        }
        warnings.push(w);
    }
    let dropped = if st.invalid_samples > 0 {
        format!(", {} NaN/inf samples dropped", st.invalid_samples)
    } else {
        String::new()
    };
    println!(
        "{}: {}x{} {} spp, load {:.2} s, render {:.3} s, {:.3} Msamples/s, {:.3} Mrays/s ({} threads, {} renderer){dropped} -> {}",
        scene_path.display(),
        crop.2,
        crop.3,
        st.spp,
        load_s,
        st.seconds,
        st.samples_per_second() * 1e-6,
        st.rays_per_second() * 1e-6,
        st.threads,
        st.renderer.name(),
        out.display()
    );
    Ok(json!({
        "scene": scene_path,
        "output": out,
        "part": is_part,
        "film": [full.0, full.1],
        "crop": [crop.0, crop.1, crop.2, crop.3],
        "sample_count": st.sample_count,
        "samples": [st.sample_range.0, st.sample_range.1],
        "spp": st.spp,
        "stopped_early": st.stopped_early,
        "seed": st.seed,
        "threads": st.threads,
        "renderer": st.renderer.name(),
        "load_seconds": load_s,
        "render_seconds": st.seconds,
        "pixel_samples": st.samples,
        "rays": st.rays.total(),
        "rays_per_second": st.rays_per_second(),
        "invalid_samples": st.invalid_samples,
        "warnings": warnings,
    }))
}
