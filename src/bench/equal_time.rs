//! Equal-time error: a mode renders with the spp that fits the classic render's time budget, and
//! its RMSE is measured against a high-spp reference of the same mode (each model converges to
//! its own image; comparing across models would measure their difference, not their noise).
//!
//! The reference's own noise adds to the measured MSE: with `ref_spp` = 8 × the budget spp
//! (the default) it inflates the RMSE by about 6 %, alike for every mode. References are cached as EXR files keyed by the scene
//! directory's contents, the defines, the mode, `ref_spp` and groove's version.

use super::render_at;
use crate::error::Result;
use crate::film::Image;
use crate::load::Loaded;
use crate::output::{read_exr, write_image, Metadata};
use serde::Serialize;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

/// Seeds distinct from the timing renders' (0..repeat).
const REF_SEED: u64 = 0x5eed_0001;
const TEST_SEED: u64 = 0x5eed_0002;

#[derive(Clone, Debug, Serialize)]
pub struct EqualTime {
    /// Samples per pixel that fit the budget.
    pub spp: u32,
    pub seconds: f64,
    pub ref_spp: u32,
    pub rmse: f64,
    /// RMSE over the reference's mean pixel value.
    pub rel_rmse: f64,
    /// 1 / (MSE · seconds): higher is better, independent of the spp chosen.
    pub efficiency: f64,
}

/// Render `scene` at `spp` and compare with its reference; returns the comparison and the
/// reference image.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    scene: &Loaded,
    path: &Path,
    name: &str,
    mode: &str,
    spp: u32,
    ref_spp: u32,
    threads: usize,
    ref_dir: Option<&Path>,
    defines: &[(String, String)],
) -> Result<(EqualTime, Image)> {
    let reference = reference(scene, path, name, mode, ref_spp, threads, ref_dir, defines)?;
    let (img, st) = render_at(scene, spp, TEST_SEED, threads)?;
    let (mse, mean) = mse(&img, &reference);
    Ok((
        EqualTime {
            spp,
            seconds: st.seconds,
            ref_spp,
            rmse: mse.sqrt(),
            rel_rmse: mse.sqrt() / mean.max(1e-12),
            efficiency: 1.0 / (mse * st.seconds).max(1e-300),
        },
        reference,
    ))
}

/// Mean squared difference over pixels and channels, and the mean of `reference`.
pub fn mse(img: &Image, reference: &Image) -> (f64, f64) {
    let mut se = 0.0f64;
    let mut sum = 0.0f64;
    for (a, b) in img.data.iter().zip(&reference.data) {
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            se += d * d;
            sum += b[c] as f64;
        }
    }
    let n = (3 * reference.data.len()).max(1) as f64;
    (se / n, sum / n)
}

#[allow(clippy::too_many_arguments)]
fn reference(
    scene: &Loaded,
    path: &Path,
    name: &str,
    mode: &str,
    ref_spp: u32,
    threads: usize,
    ref_dir: Option<&Path>,
    defines: &[(String, String)],
) -> Result<Image> {
    let cached: Option<PathBuf> = ref_dir.map(|d| {
        d.join(format!(
            "{name}.{mode}.{ref_spp}spp.{:016x}.exr",
            cache_key(path, defines)
        ))
    });
    if let Some(p) = &cached {
        if let Ok((img, _)) = read_exr(p) {
            if (img.width, img.height) == scene.settings.film.crop_size {
                return Ok(img);
            }
        }
    }
    let (img, _) = render_at(scene, ref_spp, REF_SEED, threads)?;
    if let (Some(p), Some(d)) = (&cached, ref_dir) {
        std::fs::create_dir_all(d).map_err(|e| crate::error::Error::io(d, e))?;
        write_image(p, &img, &Metadata::default())?;
    }
    Ok(img)
}

/// Hash of what a reference depends on: the scene directory's files (names, sizes, modification
/// times), the scene file's bytes, the defines and groove's version.
fn cache_key(path: &Path, defines: &[(String, String)]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    env!("CARGO_PKG_VERSION").hash(&mut h);
    std::fs::read(path).unwrap_or_default().hash(&mut h);
    defines.hash(&mut h);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(rd) = std::fs::read_dir(dir) {
            let mut files: Vec<(String, u64, u128)> = rd
                .filter_map(|e| e.ok())
                .filter_map(|e| {
                    let m = e.metadata().ok()?;
                    let t = m
                        .modified()
                        .ok()?
                        .duration_since(std::time::UNIX_EPOCH)
                        .ok()?;
                    Some((
                        e.file_name().to_string_lossy().into_owned(),
                        m.len(),
                        t.as_nanos(),
                    ))
                })
                .collect();
            files.sort();
            files.hash(&mut h);
        }
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mse_of_a_constant_offset() {
        let mut a = Image::new(2, 2);
        let mut b = Image::new(2, 2);
        for p in &mut a.data {
            *p = [1.5; 3];
        }
        for p in &mut b.data {
            *p = [1.0; 3];
        }
        let (m, mean) = mse(&a, &b);
        assert!((m - 0.25).abs() < 1e-12 && (mean - 1.0).abs() < 1e-12);
    }
}
