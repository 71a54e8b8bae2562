//! Statistical image comparison for the acceptance tests: "does this render match that Mitsuba 3
//! reference within noise?".
//!
//! Both images come with a per-pixel variance *of the mean* (for a reference made of K independent
//! renders: sample variance across the K renders / K; for a single render of N samples per pixel:
//! per-pixel sample variance of the N samples / N). Pixels must be independent estimates, which holds
//! for the box reconstruction filter that every test scene uses.
//!
//! The comparison groups pixels into `block`×`block` tiles (edge tiles may be smaller). Per tile and
//! channel
//!
//! ```text
//!     z = (mean_t − mean_r) / sqrt(var_t + var_r),   var_x = Σ pixel variances / n²
//! ```
//!
//! and three checks are made (see [`Comparison::assert_consistent`]):
//! * χ² = Σ z² per channel against χ²(tiles); channels of one pixel are strongly correlated (one path
//!   carries all three), so the three per-channel p-values are combined by Bonferroni
//!   (`p = min(1, 3·min p_c)`), which is valid whatever that correlation is;
//! * max |z| against a Šidák-corrected normal threshold for the number of tile×channel tests at a
//!   family-wise false-alarm rate of 1e-4 (≈ 4.5–5σ for typical tile counts);
//! * the whole-image mean ratio test/reference per channel, |ratio − 1| ≤ 4σ.
//!
//! Tiles where both variances are 0 (constant background, directly seen emitters with a black BSDF,
//! pure black) are compared exactly: |diff| ≤ 1e-4·max(|mean_t|, |mean_r|). The tolerance is
//! the reference's own rounding: Mitsuba sums a pixel's samples in float32, which drifts by up to
//! about N·2⁻²⁴ relative over N samples (2e-5 measured at 512 spp: 0.050001 for a constant 0.05),
//! while groove's film sums exactly (`src/film_sum.rs`).
#![allow(dead_code)]

use std::path::Path;

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

/// Family-wise p-value threshold of the χ² test (per comparison).
pub const P_VALUE_MIN: f64 = 1e-3;
/// Family-wise false-alarm rate used to set the max-|z| threshold (Šidák).
pub const Z_MAX_FAMILY_ALPHA: f64 = 1e-4;
/// Number of standard deviations allowed for the whole-image mean ratio.
pub const MEAN_RATIO_SIGMAS: f64 = 4.0;
/// Relative tolerance for tiles without variance on either side (see the module's comment).
pub const EXACT_REL_TOL: f64 = 1e-4;
/// Tile variances below (this × the tile mean)² are float32 rounding, not sampling noise.
pub const ROUNDING_REL: f64 = 1e-5;

/// A linear RGB image, row-major, `data[y * width + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<[f64; 3]>,
}

impl RgbImage {
    pub fn new(width: usize, height: usize) -> Self {
        RgbImage {
            width,
            height,
            data: vec![[0.0; 3]; width * height],
        }
    }

    pub fn get(&self, x: usize, y: usize) -> [f64; 3] {
        self.data[y * self.width + x]
    }

    /// Every value multiplied by `s` (a variance image of a scaled image needs `s²`).
    pub fn scaled(&self, s: f64) -> RgbImage {
        RgbImage {
            width: self.width,
            height: self.height,
            data: self
                .data
                .iter()
                .map(|p| [p[0] * s, p[1] * s, p[2] * s])
                .collect(),
        }
    }

    /// Per-channel mean over all pixels.
    pub fn channel_means(&self) -> [f64; 3] {
        let mut m = [0.0; 3];
        for p in &self.data {
            for c in 0..3 {
                m[c] += p[c];
            }
        }
        let n = self.data.len().max(1) as f64;
        [m[0] / n, m[1] / n, m[2] / n]
    }
}

/// Reads the R, G, B channels of the first valid layer of an OpenEXR file (any sample type).
/// Panics with the path and the reason if the file cannot be read.
pub fn read_exr_rgb(path: &Path) -> RgbImage {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _channels: &RgbaChannels| {
            RgbImage::new(resolution.width(), resolution.height())
        },
        |img: &mut RgbImage, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = img.width;
            img.data[pos.y() * w + pos.x()] = [r as f64, g as f64, b as f64];
        },
    )
    .unwrap_or_else(|e| panic!("cannot read RGB EXR {}: {e}", path.display()));
    image.layer_data.channel_data.pixels
}

/// Writes a float32 RGB OpenEXR (handy to keep a failing render for inspection).
pub fn write_exr_rgb(path: &Path, img: &RgbImage) {
    exr::prelude::write_rgb_file(path, img.width, img.height, |x, y| {
        let p = img.data[y * img.width + x];
        (p[0] as f32, p[1] as f32, p[2] as f32)
    })
    .unwrap_or_else(|e| panic!("cannot write EXR {}: {e}", path.display()));
}

/// Per-pixel mean and variance of the mean of K ≥ 2 independent renders of one scene
/// (unbiased sample variance across the renders / K) — the same estimate the references use.
pub fn mean_and_var_of_mean(renders: &[RgbImage]) -> (RgbImage, RgbImage) {
    let k = renders.len();
    assert!(
        k >= 2,
        "need at least 2 independent renders to estimate a variance, got {k}"
    );
    let (w, h) = (renders[0].width, renders[0].height);
    for r in renders {
        assert!(r.width == w && r.height == h, "renders differ in size");
    }
    let mut mean = RgbImage::new(w, h);
    let mut var = RgbImage::new(w, h);
    for i in 0..w * h {
        for c in 0..3 {
            let m = renders.iter().map(|r| r.data[i][c]).sum::<f64>() / k as f64;
            let ss = renders
                .iter()
                .map(|r| (r.data[i][c] - m).powi(2))
                .sum::<f64>();
            mean.data[i][c] = m;
            var.data[i][c] = ss / (k as f64 - 1.0) / k as f64;
        }
    }
    (mean, var)
}

/// Result of [`compare`]. `chi2`/`dof` are totals over tiles×channels (for information); the
/// p-value is the Bonferroni combination of the per-channel χ² tests (`chi2_rgb`, `p_rgb`).
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Largest |z| over all statistically compared tile×channel pairs (∞ if an exact tile differs).
    pub z_max: f64,
    /// Σ z² over all statistically compared tile×channel pairs.
    pub chi2: f64,
    /// Number of statistically compared tile×channel pairs.
    pub dof: usize,
    /// min(1, 3·min over channels of the χ² survival probability).
    pub p_value: f64,
    /// Whole-image mean of test / mean of reference, per channel.
    pub mean_ratio: [f64; 3],
    /// Standard deviation of `mean_ratio` (from both variance images), per channel.
    pub mean_ratio_sigma: [f64; 3],
    /// Number of tiles (per channel).
    pub blocks: usize,
    /// Tile size used.
    pub block: usize,
    /// Per-channel Σ z², number of statistical tiles and χ² survival probability.
    pub chi2_rgb: [f64; 3],
    pub dof_rgb: [usize; 3],
    pub p_rgb: [f64; 3],
    /// The max-|z| threshold (Šidák over `dof` tests at family rate [`Z_MAX_FAMILY_ALPHA`]).
    pub z_threshold: f64,
    /// Tile x, tile y, channel of the largest |z|.
    pub worst_tile: (usize, usize, usize),
    /// Test and reference tile means at the worst tile.
    pub worst_values: (f64, f64),
    /// Tile×channel pairs without variance on either side, and how many of those differ.
    pub exact_tiles: usize,
    pub exact_mismatches: usize,
    /// Pixels of the test image (or its variance) that are NaN/∞ or have a negative variance.
    pub bad_pixels: usize,
    /// Whole-image channel means of test and reference.
    pub mean_test: [f64; 3],
    pub mean_ref: [f64; 3],
}

/// Compares a test image (with its per-pixel variance of the mean) against a reference (mean and
/// variance of the mean). See the module documentation for the statistics.
pub fn compare(
    test: &RgbImage,
    test_var: &RgbImage,
    reference: &RgbImage,
    reference_var: &RgbImage,
    block: usize,
) -> Comparison {
    let (w, h) = (reference.width, reference.height);
    for (img, what) in [
        (test, "test"),
        (test_var, "test variance"),
        (reference_var, "reference variance"),
    ] {
        assert!(
            img.width == w && img.height == h,
            "image size mismatch: {what} is {}x{}, reference is {w}x{h}",
            img.width,
            img.height
        );
    }
    assert!(block >= 1, "block size must be >= 1");

    let mut bad_pixels = 0;
    for i in 0..w * h {
        let ok = (0..3).all(|c| {
            test.data[i][c].is_finite()
                && test_var.data[i][c].is_finite()
                && test_var.data[i][c] >= 0.0
        });
        if !ok {
            bad_pixels += 1;
        }
    }

    let tiles_x = w.div_ceil(block);
    let tiles_y = h.div_ceil(block);
    let mut chi2_rgb = [0.0; 3];
    let mut dof_rgb = [0usize; 3];
    let mut z_max = 0.0f64;
    let mut worst_tile = (0, 0, 0);
    let mut worst_values = (0.0, 0.0);
    let mut exact_tiles = 0;
    let mut exact_mismatches = 0;

    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            let (x0, y0) = (tx * block, ty * block);
            let (x1, y1) = ((x0 + block).min(w), (y0 + block).min(h));
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            for c in 0..3 {
                let (mut st, mut sr, mut vt, mut vr) = (0.0, 0.0, 0.0, 0.0);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let i = y * w + x;
                        let t = test.data[i][c];
                        let tv = test_var.data[i][c];
                        // Non-finite pixels are counted in bad_pixels; keep the tile sums finite.
                        st += if t.is_finite() { t } else { 0.0 };
                        vt += if tv.is_finite() { tv.max(0.0) } else { 0.0 };
                        sr += reference.data[i][c];
                        vr += reference_var.data[i][c].max(0.0);
                    }
                }
                let (mt, mr) = (st / n, sr / n);
                let v = (vt + vr) / (n * n);
                // Variances below float32 rounding of the tile mean are rounding noise of the
                // accumulation (e.g. a sky pixel of 1 stored as 0.99999994), not sampling noise:
                // such tiles are compared exactly, within EXACT_REL_TOL.
                let rounding = (ROUNDING_REL * mt.abs().max(mr.abs())).powi(2);
                let v = if v > rounding { v } else { 0.0 };
                let z = if v > 0.0 {
                    chi2_rgb[c] += (mt - mr).powi(2) / v;
                    dof_rgb[c] += 1;
                    (mt - mr) / v.sqrt()
                } else {
                    exact_tiles += 1;
                    if (mt - mr).abs() <= EXACT_REL_TOL * mt.abs().max(mr.abs()) {
                        0.0
                    } else {
                        exact_mismatches += 1;
                        f64::INFINITY
                    }
                };
                if z.abs() > z_max {
                    z_max = z.abs();
                    worst_tile = (tx, ty, c);
                    worst_values = (mt, mr);
                }
            }
        }
    }

    let mut p_rgb = [1.0; 3];
    for c in 0..3 {
        if dof_rgb[c] > 0 {
            p_rgb[c] = ChiSquared::new(dof_rgb[c] as f64)
                .expect("chi2 dof")
                .sf(chi2_rgb[c]);
        }
    }
    let p_value = (3.0 * p_rgb.iter().cloned().fold(1.0, f64::min)).min(1.0);
    let dof: usize = dof_rgb.iter().sum();
    let chi2: f64 = chi2_rgb.iter().sum();

    // Šidák: per-test two-sided alpha so that P(any of m |z| exceeds) = family alpha.
    let m = dof.max(1) as f64;
    let alpha1 = -(-Z_MAX_FAMILY_ALPHA).ln_1p() / m; // ≈ 1 − (1−α)^(1/m), accurate for tiny α
    let alpha1 = -(-alpha1).exp_m1();
    let z_threshold = -Normal::new(0.0, 1.0).unwrap().inverse_cdf(alpha1 / 2.0);

    // Whole-image means and their ratio.
    let npix = (w * h) as f64;
    let mut mean_test = [0.0; 3];
    let mut mean_ref = [0.0; 3];
    let mut mean_ratio = [1.0; 3];
    let mut mean_ratio_sigma = [0.0; 3];
    for c in 0..3 {
        let (mut st, mut sr, mut vt, mut vr) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..w * h {
            let t = test.data[i][c];
            let tv = test_var.data[i][c];
            st += if t.is_finite() { t } else { 0.0 };
            vt += if tv.is_finite() { tv.max(0.0) } else { 0.0 };
            sr += reference.data[i][c];
            vr += reference_var.data[i][c].max(0.0);
        }
        let (mt, mr) = (st / npix, sr / npix);
        let (vmt, vmr) = (vt / (npix * npix), vr / (npix * npix));
        mean_test[c] = mt;
        mean_ref[c] = mr;
        if mr != 0.0 {
            let r = mt / mr;
            mean_ratio[c] = r;
            mean_ratio_sigma[c] = if mt != 0.0 {
                r.abs() * (vmt / (mt * mt) + vmr / (mr * mr)).sqrt()
            } else {
                (vmr / (mr * mr)).sqrt() // ratio 0: sigma from the reference side
            };
        } else if mt == 0.0 {
            mean_ratio[c] = 1.0; // both black
        } else {
            mean_ratio[c] = f64::INFINITY;
        }
    }

    Comparison {
        z_max,
        chi2,
        dof,
        p_value,
        mean_ratio,
        mean_ratio_sigma,
        blocks: tiles_x * tiles_y,
        block,
        chi2_rgb,
        dof_rgb,
        p_rgb,
        z_threshold,
        worst_tile,
        worst_values,
        exact_tiles,
        exact_mismatches,
        bad_pixels,
        mean_test,
        mean_ref,
    }
}

impl Comparison {
    /// Why the comparison fails (empty if the images are consistent within noise).
    pub fn failures(&self) -> Vec<String> {
        let mut f = Vec::new();
        if self.bad_pixels > 0 {
            f.push(format!(
                "{} pixels of the test image or its variance are NaN/inf/negative",
                self.bad_pixels
            ));
        }
        if self.exact_mismatches > 0 {
            f.push(format!(
                "{} of {} noise-free tile×channels differ (rel. tol {EXACT_REL_TOL:e})",
                self.exact_mismatches, self.exact_tiles
            ));
        }
        if self.p_value < P_VALUE_MIN {
            f.push(format!(
                "chi2 p-value {:.3e} < {P_VALUE_MIN:e}",
                self.p_value
            ));
        }
        if self.z_max > self.z_threshold {
            f.push(format!(
                "max |z| {:.2} > threshold {:.2}",
                self.z_max, self.z_threshold
            ));
        }
        for c in 0..3 {
            let dev = (self.mean_ratio[c] - 1.0).abs();
            let tol = if self.mean_ratio_sigma[c] > 0.0 {
                MEAN_RATIO_SIGMAS * self.mean_ratio_sigma[c]
            } else {
                EXACT_REL_TOL
            };
            if dev.is_nan() || dev > tol {
                f.push(format!(
                    "mean ratio {} = {:.5} ± {:.5} is {:.1}σ from 1",
                    ["R", "G", "B"][c],
                    self.mean_ratio[c],
                    self.mean_ratio_sigma[c],
                    dev / self.mean_ratio_sigma[c]
                ));
            }
        }
        f
    }

    pub fn is_consistent(&self) -> bool {
        self.failures().is_empty()
    }

    /// Everything, on a few lines.
    pub fn report(&self) -> String {
        let (tx, ty, c) = self.worst_tile;
        format!(
            "chi2 {:.1} / dof {} (per channel R,G,B: {:.1}/{}, {:.1}/{}, {:.1}/{}; p {:.3e}, {:.3e}, {:.3e}) \
             -> p {:.3e} (min {P_VALUE_MIN:e})\n\
             max |z| {:.2} (threshold {:.2}) at tile ({tx},{ty}) of {}x{} px, channel {}: test {:.6} ref {:.6}\n\
             mean test {:.6?} ref {:.6?} ratio [{:.5} ± {:.5}, {:.5} ± {:.5}, {:.5} ± {:.5}]\n\
             {} tiles, {} exact tile×channels ({} differ), {} bad test pixels",
            self.chi2,
            self.dof,
            self.chi2_rgb[0],
            self.dof_rgb[0],
            self.chi2_rgb[1],
            self.dof_rgb[1],
            self.chi2_rgb[2],
            self.dof_rgb[2],
            self.p_rgb[0],
            self.p_rgb[1],
            self.p_rgb[2],
            self.p_value,
            self.z_max,
            self.z_threshold,
            self.block,
            self.block,
            ["R", "G", "B"][c],
            self.worst_values.0,
            self.worst_values.1,
            self.mean_test,
            self.mean_ref,
            self.mean_ratio[0],
            self.mean_ratio_sigma[0],
            self.mean_ratio[1],
            self.mean_ratio_sigma[1],
            self.mean_ratio[2],
            self.mean_ratio_sigma[2],
            self.blocks,
            self.exact_tiles,
            self.exact_mismatches,
            self.bad_pixels,
        )
    }

    /// Panics (with the full report) unless the test image is consistent with the reference:
    /// no bad pixels, exact tiles equal, χ² p-value ≥ 1e-3, max |z| ≤ Šidák threshold, and every
    /// channel's whole-image mean ratio within 4σ of 1.
    pub fn assert_consistent(&self, what: &str) {
        let f = self.failures();
        if !f.is_empty() {
            panic!(
                "{what}: image does not match the reference:\n  - {}\n{}",
                f.join("\n  - "),
                self.report()
            );
        }
    }
}
