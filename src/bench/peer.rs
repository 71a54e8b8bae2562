//! The Mitsuba 3 peer column: when `mitsuba` is importable by the given Python, the scene is
//! rendered as written (Mitsuba knows `normalmap`, not `microfacet_normalmap`, so only a scene
//! written with plain normal maps is comparable: the classic mode) with `scalar_rgb`, and with
//! `llvm_ad_rgb` when Debian's LLVM 19 is present, at the same spp and thread count. Each variant
//! renders once untimed (LLVM compiles its kernels then), then `repeat` timed renders; only
//! `mi.render` is timed, as for groove.

use serde::Serialize;
use std::path::Path;
use std::process::Command;

/// Where Debian 12's `libllvm19` puts the library Dr.Jit needs.
const DEBIAN_LLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1";

/// The driver run by Python (groove's own, a few lines of Mitsuba's public API).
const SCRIPT: &str = r#"
import json, sys, time
import drjit as dr
import mitsuba as mi
variant, path, spp, threads, repeat = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
defines = dict(a.split("=", 1) for a in sys.argv[6:])
mi.set_variant(variant)
mi.set_log_level(mi.LogLevel.Warn)
if threads > 0:
    dr.set_thread_count(threads)
scene = mi.load_file(path, **defines)
def once(seed):
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t
warm = once(1000)
times = [once(i) for i in range(repeat)]
print("GROOVE_PEER " + json.dumps({"warmup": warm, "times": times}))
"#;

#[derive(Clone, Debug, Serialize)]
pub struct PeerResult {
    pub scene: String,
    /// The groove mode this corresponds to.
    pub mode: String,
    pub variant: String,
    pub spp: u32,
    pub threads: usize,
    pub min_seconds: Option<f64>,
    pub median_seconds: Option<f64>,
    /// First (untimed) render: includes LLVM kernel compilation.
    pub warmup_seconds: Option<f64>,
    pub times: Vec<f64>,
    /// Why there is no time.
    pub reason: Option<String>,
}

/// Whether `python` can import mitsuba 3.
pub fn available(python: &str) -> Result<(), String> {
    match Command::new(python)
        .args(["-c", "import mitsuba, drjit; print(mitsuba.__version__)"])
        .output()
    {
        Err(e) => Err(format!("cannot run '{python}': {e}")),
        Ok(o) if !o.status.success() => Err(format!(
            "'{python} -c \"import mitsuba\"' failed ({})",
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .last()
                .unwrap_or("")
                .trim()
        )),
        Ok(_) => Ok(()),
    }
}

/// The variants to run here: scalar_rgb, and llvm_ad_rgb when its LLVM is found.
fn variants() -> Vec<(&'static str, Option<String>)> {
    let mut v = vec![("scalar_rgb", None)];
    let llvm = std::env::var("DRJIT_LIBLLVM_PATH")
        .ok()
        .filter(|p| Path::new(p).exists())
        .or_else(|| {
            Path::new(DEBIAN_LLVM)
                .exists()
                .then(|| DEBIAN_LLVM.to_string())
        });
    v.push(("llvm_ad_rgb", llvm));
    v
}

/// Render `path` with every variant; a failure becomes a result with a reason.
pub fn run_all(
    python: &str,
    path: &Path,
    spp: u32,
    threads: usize,
    repeat: u32,
    defines: &[(String, String)],
) -> Vec<PeerResult> {
    variants()
        .into_iter()
        .map(|(variant, llvm)| {
            let mut r = PeerResult {
                scene: super::scene_name(path),
                mode: "classic".into(),
                variant: variant.into(),
                spp,
                threads,
                min_seconds: None,
                median_seconds: None,
                warmup_seconds: None,
                times: Vec::new(),
                reason: None,
            };
            if variant.starts_with("llvm") && llvm.is_none() {
                r.reason = Some(format!(
                    "no LLVM for Dr.Jit (install libllvm19 or set DRJIT_LIBLLVM_PATH; looked for {DEBIAN_LLVM})"
                ));
                return r;
            }
            match run_one(python, variant, llvm.as_deref(), path, spp, threads, repeat, defines) {
                Ok((warm, mut times)) => {
                    r.warmup_seconds = Some(warm);
                    r.times = times.clone();
                    r.min_seconds = times.iter().copied().reduce(f64::min);
                    r.median_seconds = Some(super::median(&mut times));
                }
                Err(e) => r.reason = Some(e),
            }
            r
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn run_one(
    python: &str,
    variant: &str,
    llvm: Option<&str>,
    path: &Path,
    spp: u32,
    threads: usize,
    repeat: u32,
    defines: &[(String, String)],
) -> Result<(f64, Vec<f64>), String> {
    let mut cmd = Command::new(python);
    cmd.arg("-c")
        .arg(SCRIPT)
        .arg(variant)
        .arg(path)
        .arg(spp.to_string())
        .arg(threads.to_string())
        .arg(repeat.max(1).to_string());
    for (k, v) in defines {
        cmd.arg(format!("{k}={v}"));
    }
    if let Some(l) = llvm {
        cmd.env("DRJIT_LIBLLVM_PATH", l);
    }
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run '{python}': {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("GROOVE_PEER "))
        .ok_or_else(|| {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("no output");
            format!("Mitsuba failed: {}", last.trim())
        })?;
    #[derive(serde::Deserialize)]
    struct Out {
        warmup: f64,
        times: Vec<f64>,
    }
    let o: Out = serde_json::from_str(line).map_err(|e| format!("bad peer output: {e}"))?;
    Ok((o.warmup, o.times))
}
