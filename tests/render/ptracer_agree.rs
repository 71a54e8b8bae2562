//! Does groove's `ptracer` estimate the same image as its `path` on one scene? Both are rendered
//! from the same loaded scene (the `path` integrator swapped for a `ptracer` of the same
//! `max_depth`, `rr_depth` and `hide_emitters`) and compared by per-tile z-tests.
//!
//! Light tracing's pixels are not independent estimates: one light path splats into as many
//! pixels as it has vertices, so the sum of per-pixel variances misses the covariance between
//! pixels of a tile (the "slightly optimistic" per-tile variance of the first sweep). Here the
//! `ptracer` side is instead rendered as `K` independent renders (seeds), and the variance of a
//! tile's mean is the sample variance of the K tile means / K, covariances included. With that
//! variance estimated from K − 1 degrees of freedom, the statistic is Student-t (Welch–
//! Satterthwaite degrees of freedom with the `path` side's own, Welch 1947); each tile×channel
//! t is turned into the normal z of the same two-sided tail probability, so one threshold
//! applies to all tiles:
//! - max |z| against the Bonferroni threshold Φ⁻¹(1 − α / 2m) over the m tile×channel tests
//!   at family rate α = [`ALPHA`];
//! - Σ z² per channel against χ²(tiles), the three channels combined by Bonferroni
//!   (p = 3·min p_c ≥ [`P_CHI2_MIN`]);
//! - the whole-image mean ratio per channel within [`RATIO_SIGMAS`] (as a z of the same kind).
//!
//! The `path` side's pixels are independent (every test scene uses the box filter, which the
//! comparison asserts), so its tile variance is the sum of its pixel variances.

use crate::common::{self, RgbImage};
use groove::film::Filter;
use groove::integrator::IntegratorDesc;
use groove::load::options::{LoadOptions, NormalMapping};
use groove::load::Loaded;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};
use std::path::Path;

/// Family-wise false-alarm rate of the max-|z| test of one scene.
pub const ALPHA: f64 = 1e-4;
/// Smallest accepted (Bonferroni-combined) χ² p-value of one scene.
pub const P_CHI2_MIN: f64 = 1e-3;
/// Largest accepted |z| of the whole-image mean ratio.
pub const RATIO_SIGMAS: f64 = 4.0;
/// Tile variances below (this × the tile mean)² are float rounding, not noise.
const ROUNDING_REL: f64 = 1e-5;
/// Relative tolerance of tiles without variance on either side.
const EXACT_REL_TOL: f64 = 1e-4;

/// How to render one scene for the comparison.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// `path` samples per pixel.
    pub spp_path: u32,
    /// `ptracer` samples per pixel of each of the `k` renders.
    pub spp_pt: u32,
    /// Independent `ptracer` renders (≥ 8).
    pub k: usize,
    /// Tile size of the z-tests.
    pub block: usize,
    pub seed: u64,
}

/// The outcome of one comparison.
#[derive(Clone, Debug)]
pub struct Agreement {
    pub z_max: f64,
    pub z_threshold: f64,
    /// Tile x, y and channel of `z_max`, and the ptracer and path tile means there.
    pub worst: (usize, usize, usize, f64, f64),
    pub tests: usize,
    pub p_chi2: f64,
    /// Whole-image mean ratio ptracer / path per channel, its σ and its z.
    pub ratio: [f64; 3],
    pub ratio_sigma: [f64; 3],
    pub ratio_z: [f64; 3],
    /// Tile×channel pairs without variance on either side, and how many of those differ.
    pub exact: usize,
    pub exact_mismatches: usize,
    /// Non-finite pixels in either image.
    pub bad_pixels: usize,
    pub seconds_path: f64,
    pub seconds_pt: f64,
}

impl Agreement {
    /// Why the two images disagree (empty when they agree).
    pub fn failures(&self) -> Vec<String> {
        let mut f = Vec::new();
        if self.bad_pixels > 0 {
            f.push(format!("{} non-finite pixels", self.bad_pixels));
        }
        if self.exact_mismatches > 0 {
            f.push(format!(
                "{} of {} noise-free tile×channels differ",
                self.exact_mismatches, self.exact
            ));
        }
        if self.z_max > self.z_threshold {
            f.push(format!(
                "max |z| {:.2} > {:.2} at tile {:?}",
                self.z_max, self.z_threshold, self.worst
            ));
        }
        if self.p_chi2 < P_CHI2_MIN {
            f.push(format!("χ² p-value {:.2e} < {P_CHI2_MIN:e}", self.p_chi2));
        }
        for c in 0..3 {
            if self.ratio_z[c].is_nan() || self.ratio_z[c].abs() > RATIO_SIGMAS {
                f.push(format!(
                    "mean ratio {} = {:.4} ± {:.4} (z {:.1})",
                    ["R", "G", "B"][c],
                    self.ratio[c],
                    self.ratio_sigma[c],
                    self.ratio_z[c]
                ));
            }
        }
        f
    }

    pub fn agrees(&self) -> bool {
        self.failures().is_empty()
    }

    /// One line: max |z| (threshold), χ² p, mean ratio (G channel) ± σ, times.
    pub fn summary(&self) -> String {
        format!(
            "max |z| {:.2} (threshold {:.2}, {} tests), χ² p {:.3}, ratio {:.4} ± {:.4}, {:.4} ± {:.4}, {:.4} ± {:.4}; {} exact tiles; {:.1} s + {:.1} s",
            self.z_max,
            self.z_threshold,
            self.tests,
            self.p_chi2,
            self.ratio[0],
            self.ratio_sigma[0],
            self.ratio[1],
            self.ratio_sigma[1],
            self.ratio[2],
            self.ratio_sigma[2],
            self.exact,
            self.seconds_path,
            self.seconds_pt
        )
    }
}

/// Loads `scene` with `defines` and `normal_mapping`.
pub fn load(scene: &Path, defines: &[(&str, &str)], normal_mapping: NormalMapping) -> Loaded {
    let opts = LoadOptions {
        defines: defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        normal_mapping,
        ..Default::default()
    };
    groove::load::load_scene(scene, &opts)
        .unwrap_or_else(|e| panic!("loading {}: {e}", scene.display()))
}

/// `loaded` with its `path` integrator replaced by a `ptracer` of the same depth, roulette and
/// `hide_emitters`; a `direct` one by a `ptracer` of `max_depth` 2 (direct illumination and the
/// emitters seen directly, which is what `direct` estimates). Panics for other integrators.
pub fn swapped_to_ptracer(loaded: &mut Loaded) {
    let (max_depth, rr_depth, hide_emitters) = match &loaded.settings.integrator {
        IntegratorDesc::Path(p) => (p.max_depth, p.rr_depth, p.hide_emitters),
        IntegratorDesc::Direct(d) => (2, 5, d.hide_emitters),
        _ => panic!("the scene's integrator is neither path nor direct"),
    };
    let s = groove::integrator::ptracer::PtracerSettings {
        max_depth,
        rr_depth,
        hide_emitters,
        samples_per_pass: None,
        loc: groove::error::SourceLoc::new("swapped_to_ptracer", 0, 0),
    };
    loaded.settings.integrator = IntegratorDesc::Ptracer(std::sync::Arc::new(s));
}

/// Renders `loaded` (integrator `path` or `direct`) both ways by `plan` and compares.
pub fn path_vs_ptracer(mut loaded: Loaded, plan: &Plan) -> Agreement {
    assert!(plan.k >= 8, "too few ptracer renders for a variance");
    assert!(
        matches!(loaded.settings.film.filter, Filter::Box),
        "pixels are independent only under the box filter"
    );
    let t0 = std::time::Instant::now();
    let path = common::render_loaded(&loaded, plan.spp_path, plan.seed, 0);
    let seconds_path = t0.elapsed().as_secs_f64();
    swapped_to_ptracer(&mut loaded);
    let t0 = std::time::Instant::now();
    let pts: Vec<RgbImage> = (0..plan.k)
        .map(|i| common::render_loaded(&loaded, plan.spp_pt, plan.seed + 1 + i as u64, 0).mean)
        .collect();
    let seconds_pt = t0.elapsed().as_secs_f64();
    let mut a = compare_k(&pts, &path.mean, &path.var, plan.spp_path, plan.block);
    a.seconds_path = seconds_path;
    a.seconds_pt = seconds_pt;
    a
}

/// Mean of `xs` and the variance of that mean (sample variance / n).
fn mean_var(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let ss = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>();
    (m, ss / (n - 1.0) / n)
}

/// The normal z with the two-sided tail probability of `t` under Student-t with `dof` degrees
/// of freedom.
fn z_of_t(t: f64, dof: f64) -> f64 {
    if !t.is_finite() {
        return f64::INFINITY;
    }
    let p = 2.0 * StudentsT::new(0.0, 1.0, dof).expect("dof").sf(t.abs());
    if p <= 1e-300 {
        return t.abs(); // beyond any threshold; |t| bounds the z from above
    }
    let z = -Normal::new(0.0, 1.0).unwrap().inverse_cdf(p / 2.0);
    z.min(t.abs()).max(0.0) * t.signum()
}

/// Welch–Satterthwaite degrees of freedom of v1 + v2 (variances with dof d1, d2).
fn welch_dof(v1: f64, d1: f64, v2: f64, d2: f64) -> f64 {
    let den = v1 * v1 / d1 + v2 * v2 / d2;
    if den > 0.0 {
        ((v1 + v2).powi(2) / den).max(1.0)
    } else {
        d1.min(d2)
    }
}

/// The statistics of the module comment: `pts` are the K ptracer renders, `path`/`path_var`
/// the path render's mean and variance of the mean at `spp_path`.
pub fn compare_k(
    pts: &[RgbImage],
    path: &RgbImage,
    path_var: &RgbImage,
    spp_path: u32,
    block: usize,
) -> Agreement {
    let (w, h) = (path.width, path.height);
    for p in pts {
        assert!(p.width == w && p.height == h, "image sizes differ");
    }
    let k = pts.len() as f64;
    let d_path = (spp_path.max(2) - 1) as f64;
    let bad_pixels = (0..w * h)
        .filter(|&i| {
            (0..3).any(|c| {
                !path.data[i][c].is_finite()
                    || !path_var.data[i][c].is_finite()
                    || pts.iter().any(|p| !p.data[i][c].is_finite())
            })
        })
        .count();
    let (tx, ty) = (w.div_ceil(block), h.div_ceil(block));
    let mut zs: Vec<(usize, usize, usize, f64, f64, f64)> = Vec::new();
    let (mut exact, mut exact_mismatches) = (0, 0);
    let mut tile_means = vec![0.0; pts.len()];
    for by in 0..ty {
        for bx in 0..tx {
            let (x0, y0) = (bx * block, by * block);
            let (x1, y1) = ((x0 + block).min(w), (y0 + block).min(h));
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            for c in 0..3 {
                let (mut sp, mut vp) = (0.0, 0.0);
                for (j, m) in tile_means.iter_mut().enumerate() {
                    *m = 0.0;
                    for y in y0..y1 {
                        for x in x0..x1 {
                            *m += finite(pts[j].data[y * w + x][c]);
                        }
                    }
                    *m /= n;
                }
                for y in y0..y1 {
                    for x in x0..x1 {
                        sp += finite(path.data[y * w + x][c]);
                        vp += finite(path_var.data[y * w + x][c]).max(0.0);
                    }
                }
                let (mp, vp) = (sp / n, vp / (n * n));
                let (mt, vt) = mean_var(&tile_means);
                let rounding = (ROUNDING_REL * mt.abs().max(mp.abs())).powi(2);
                let (vt, vp) = (
                    if vt > rounding { vt } else { 0.0 },
                    if vp > rounding { vp } else { 0.0 },
                );
                if vt + vp == 0.0 {
                    exact += 1;
                    if (mt - mp).abs() > EXACT_REL_TOL * mt.abs().max(mp.abs()) {
                        exact_mismatches += 1;
                    }
                    continue;
                }
                let t = (mt - mp) / (vt + vp).sqrt();
                let z = z_of_t(t, welch_dof(vt, k - 1.0, vp, d_path));
                zs.push((bx, by, c, z, mt, mp));
            }
        }
    }
    let tests = zs.len();
    let z_threshold = -Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(ALPHA / (2.0 * tests.max(1) as f64));
    let mut worst = (0, 0, 0, 0.0, 0.0);
    let mut z_max = 0.0f64;
    let mut chi2 = [0.0; 3];
    let mut dof = [0usize; 3];
    for &(bx, by, c, z, mt, mp) in &zs {
        chi2[c] += z * z;
        dof[c] += 1;
        if z.abs() > z_max {
            z_max = z.abs();
            worst = (bx, by, c, mt, mp);
        }
    }
    let mut p_chi2 = 1.0f64;
    for c in 0..3 {
        if dof[c] > 0 {
            let p = ChiSquared::new(dof[c] as f64).unwrap().sf(chi2[c]);
            p_chi2 = p_chi2.min(3.0 * p);
        }
    }
    let (mut ratio, mut ratio_sigma, mut ratio_z) = ([1.0; 3], [0.0; 3], [0.0; 3]);
    for c in 0..3 {
        let npx = (w * h) as f64;
        let means: Vec<f64> = pts
            .iter()
            .map(|p| p.data.iter().map(|q| finite(q[c])).sum::<f64>() / npx)
            .collect();
        let (mt, vt) = mean_var(&means);
        let mp = path.data.iter().map(|q| finite(q[c])).sum::<f64>() / npx;
        let vp = path_var
            .data
            .iter()
            .map(|q| finite(q[c]).max(0.0))
            .sum::<f64>()
            / (npx * npx);
        if mp == 0.0 && mt == 0.0 {
            continue;
        }
        let sd = (vt + vp).sqrt();
        ratio_z[c] = if sd > 0.0 {
            z_of_t((mt - mp) / sd, welch_dof(vt, k - 1.0, vp, d_path))
        } else if (mt - mp).abs() <= EXACT_REL_TOL * mt.abs().max(mp.abs()) {
            0.0
        } else {
            f64::INFINITY
        };
        ratio[c] = mt / mp;
        ratio_sigma[c] = sd / mp.abs();
    }
    Agreement {
        z_max,
        z_threshold,
        worst,
        tests,
        p_chi2,
        ratio,
        ratio_sigma,
        ratio_z,
        exact,
        exact_mismatches,
        bad_pixels,
        seconds_path: 0.0,
        seconds_pt: 0.0,
    }
}

fn finite(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// The statistic's own check: two sets of renders of one image agree, and a 3 % brighter
/// copy of the path image is found.
#[test]
fn the_k_render_comparison_accepts_noise_and_finds_a_three_percent_bias() {
    // Synthetic images: a smooth 32×32 image, ptracer-like renders with correlated noise
    // (each "light path" adds the same error to a 2×2 block), path-like independent noise.
    let (w, h, k) = (32usize, 32usize, 16usize);
    let truth = |x: usize, y: usize| 0.2 + 0.3 * ((x + 2 * y) as f64 / 96.0);
    let mut rng = 0x2545f4914f6cdd1du64;
    let mut gauss = move || {
        // Box–Muller from a xorshift.
        let mut u = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            ((rng >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    };
    let sd_pt = 0.02;
    let pts: Vec<RgbImage> = (0..k)
        .map(|_| {
            let mut img = RgbImage::new(w, h);
            for by in (0..h).step_by(2) {
                for bx in (0..w).step_by(2) {
                    let e = sd_pt * gauss();
                    for (x, y) in [(bx, by), (bx + 1, by), (bx, by + 1), (bx + 1, by + 1)] {
                        let v = truth(x, y) + e;
                        img.data[y * w + x] = [v; 3];
                    }
                }
            }
            img
        })
        .collect();
    let sd_path = 0.01;
    let mut path = RgbImage::new(w, h);
    let mut var = RgbImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = truth(x, y) + sd_path * gauss();
            path.data[y * w + x] = [v; 3];
            var.data[y * w + x] = [sd_path * sd_path; 3];
        }
    }
    let a = compare_k(&pts, &path, &var, 256, 8);
    assert!(a.agrees(), "{:?}", a.failures());
    let brighter = path.scaled(1.03);
    let b = compare_k(&pts, &brighter, &var.scaled(1.03 * 1.03), 256, 8);
    assert!(!b.agrees(), "a 3 % bias went unnoticed: {}", b.summary());
}
