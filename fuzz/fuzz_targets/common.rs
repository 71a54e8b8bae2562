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
