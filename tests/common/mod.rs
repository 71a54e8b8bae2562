//! Shared helpers for groove's integration tests (each test file does `mod common;`).
#![allow(dead_code, unused_imports)]

pub mod imgcmp;

pub use imgcmp::{
    compare, mean_and_var_of_mean, read_exr_rgb, write_exr_rgb, Comparison, RgbImage,
};

use std::path::{Path, PathBuf};

/// The repository root (where Cargo.toml is).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `tests/refs/NAME.exr` and `tests/refs/NAME.var.exr`, read as (mean, variance of the mean).
pub fn load_reference(name: &str) -> (RgbImage, RgbImage) {
    let dir = repo_root().join("tests").join("refs");
    (
        read_exr_rgb(&dir.join(format!("{name}.exr"))),
        read_exr_rgb(&dir.join(format!("{name}.var.exr"))),
    )
}

/// `tests/data/scenes/NAME`.
pub fn test_scene(name: &str) -> PathBuf {
    repo_root()
        .join("tests")
        .join("data")
        .join("scenes")
        .join(name)
}

/// The shared Cornell box scene (`../shared/scenes/mitsuba_cbox/cbox-rgb.xml` from the repo root).
pub fn shared_cbox() -> PathBuf {
    repo_root()
        .join("..")
        .join("shared")
        .join("scenes")
        .join("mitsuba_cbox")
        .join("cbox-rgb.xml")
}

pub fn exists(p: &Path) -> bool {
    p.is_file()
}
