//! Shared by the targets: the memory budget every load runs under (far below libFuzzer's
//! `-rss_limit_mb`, so an input that gets past a budget check shows up as an OOM finding) and
//! a per-process scratch folder for inputs that must be files.

use groove::budget::Budget;
use std::path::PathBuf;

/// 256 MB: the loaders must refuse anything larger before allocating it.
pub fn budget() -> Budget {
    Budget::new(256 << 20)
}

/// A scratch folder of this process (created once).
#[allow(dead_code)]
pub fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("groove-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch folder");
    d
}

/// Lets groove's own guards see panics: libFuzzer's hook aborts at every panic, even one that
/// groove catches at a decoder boundary (`output::exr_guarded`: the `exr` crate's overflow bugs
/// on corrupt blocks become an error). A panic that escapes groove still ends the fuzz target
/// (it cannot unwind out of libFuzzer's `extern "C"` entry point: the process aborts), so it is
/// still a finding.
#[allow(dead_code)]
pub fn let_groove_catch_decoder_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| std::panic::set_hook(Box::new(|_| {})));
}
