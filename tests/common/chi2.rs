//! Statistical test harness for BSDFs (deterministic and stochastic).
//!
//! - [`chi2_sample_vs_pdf`]: chi-square goodness of fit of `sample` against `pdf` over the whole
//!   sphere. Cells are a (cos θ, φ) grid (equal solid angle); the expected count of a cell is
//!   N ∫_cell pdf dω by adaptive Gauss–Legendre quadrature (refined until the quadrature error
//!   is < 2% of the cell's Poisson noise). Samples that fail (`None`) or come from delta lobes fall
//!   in one extra "rest" outcome whose expected count is N (1 − ∫ pdf). Cells with expected count
//!   < 5 are pooled. A sample landing in a cell whose integrated pdf is 0 fails outright.
//! - [`weight_matches_eval_over_pdf`]: deterministic BSDFs, `weight == eval / pdf` pointwise.
//! - [`cell_consistency`]: for every cell, mean(weight · 1{wo ∈ cell}) against ∫_cell eval dω
//!   with a z-test using the samples' own variance (the test stochastic BSDFs must pass: their
//!   weights are only correct in expectation). For a stochastic `eval` ([`TestBsdf::deterministic`]
//!   false) each quadrature node is evaluated twice and the estimated noise of ∫_cell eval is
//!   added to the variance. Besides the worst cell, Σz² over the cells (χ²) and the whole sphere
//!   are tested, which catch small biases spread over many cells.
//! - [`furnace`]: E[weight] with its standard error (white-furnace albedo).
//! - [`reciprocity`]: f(wi, wo)/|cos θo| against f(wo, wi)/|cos θi| with a caller-given factor.
//!
//! Significance: every p-value is compared with a Šidák-corrected level ([`Sidak`]) so that the
//! whole suite has overall false-alarm probability α = 0.01.

#![allow(dead_code)]

use glam::Vec3;
use groove::bsdf::{BsdfArena, BsdfContext, BsdfNode, BsdfSample, Lobes, TransportMode};
use groove::sampler::Sampler;
use statrs::distribution::{ChiSquared, ContinuousCDF, DiscreteCDF, Normal, Poisson};
use std::f64::consts::PI;

/// What the harness needs from a BSDF (local frame, `eval` = f·|cos θo|).
pub trait TestBsdf {
    /// `f(wi, wo) |cos θo|`; stochastic BSDFs may use `sampler` (an unbiased estimate).
    fn eval(&self, wi: Vec3, wo: Vec3, sampler: &mut Sampler) -> Vec3;
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32;
    fn sample(&self, wi: Vec3, sampler: &mut Sampler) -> Option<BsdfSample>;
    /// True when `weight == eval / pdf` must hold pointwise.
    fn deterministic(&self) -> bool {
        true
    }
}

/// A BSDF tree in an arena (root node last), queried through groove's dispatch.
pub struct ArenaBsdf {
    pub arena: BsdfArena,
    pub root: u32,
    pub ctx: BsdfContext,
    pub deterministic: bool,
}

impl ArenaBsdf {
    /// A single node.
    pub fn new(node: BsdfNode, mode: TransportMode) -> Self {
        let mut arena = BsdfArena::new();
        let root = arena.push(node);
        ArenaBsdf {
            arena,
            root,
            ctx: BsdfContext { mode },
            deterministic: true,
        }
    }
}

impl TestBsdf for ArenaBsdf {
    fn eval(&self, wi: Vec3, wo: Vec3, sampler: &mut Sampler) -> Vec3 {
        self.arena.bsdf(self.root).eval(&self.ctx, wi, wo, sampler)
    }
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.arena.bsdf(self.root).pdf(&self.ctx, wi, wo)
    }
    fn sample(&self, wi: Vec3, sampler: &mut Sampler) -> Option<BsdfSample> {
        self.arena.bsdf(self.root).sample(&self.ctx, wi, sampler)
    }
    fn deterministic(&self) -> bool {
        self.deterministic
    }
}

/// Šidák correction: the per-test level for `n` independent tests at overall level `alpha`.
#[derive(Clone, Copy, Debug)]
pub struct Sidak {
    pub alpha: f64,
    pub tests: usize,
}

impl Sidak {
    pub fn new(alpha: f64, tests: usize) -> Self {
        Sidak { alpha, tests }
    }
    /// Per-test significance level 1 − (1 − α)^(1/n).
    pub fn level(&self) -> f64 {
        1.0 - (1.0 - self.alpha).powf(1.0 / self.tests.max(1) as f64)
    }
    /// The level for one of `k` sub-tests of one of the `n` tests.
    pub fn split(&self, k: usize) -> f64 {
        1.0 - (1.0 - self.level()).powf(1.0 / k.max(1) as f64)
    }
}

/// The (cos θ, φ) grid over the sphere; every cell has solid angle 4π / (n_cos n_phi).
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub n_cos: usize,
    pub n_phi: usize,
}

impl Default for Grid {
    fn default() -> Self {
        Grid {
            n_cos: 40,
            n_phi: 80,
        }
    }
}

impl Grid {
    pub fn cells(&self) -> usize {
        self.n_cos * self.n_phi
    }
    pub fn cell_of(&self, w: Vec3) -> usize {
        let z = w.z.clamp(-1.0, 1.0) as f64;
        let i = (((z + 1.0) * 0.5 * self.n_cos as f64) as usize).min(self.n_cos - 1);
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let j = ((phi / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }
    /// (z0, z1, φ0, φ1) of a cell.
    pub fn bounds(&self, c: usize) -> (f64, f64, f64, f64) {
        let (i, j) = (c / self.n_phi, c % self.n_phi);
        let dz = 2.0 / self.n_cos as f64;
        let dp = 2.0 * PI / self.n_phi as f64;
        (
            -1.0 + i as f64 * dz,
            -1.0 + (i + 1) as f64 * dz,
            j as f64 * dp,
            (j + 1) as f64 * dp,
        )
    }
}

/// 4-point Gauss–Legendre rule on [−1, 1].
const GL4_X: [f64; 4] = [
    -0.861_136_311_594_053,
    -0.339_981_043_584_856,
    0.339_981_043_584_856,
    0.861_136_311_594_053,
];
const GL4_W: [f64; 4] = [
    0.347_854_845_137_454,
    0.652_145_154_862_546,
    0.652_145_154_862_546,
    0.347_854_845_137_454,
];

fn dir(z: f64, phi: f64) -> Vec3 {
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32)
}

/// Integrals over one region: pdf, eval (channels summed), and the variance of the eval
/// integral caused by a stochastic `eval` (0 for deterministic BSDFs).
#[derive(Clone, Copy, Debug, Default)]
struct Quad {
    pdf: f64,
    eval: f64,
    eval_var: f64,
}

impl std::ops::Add for Quad {
    type Output = Quad;
    fn add(self, o: Quad) -> Quad {
        Quad {
            pdf: self.pdf + o.pdf,
            eval: self.eval + o.eval,
            eval_var: self.eval_var + o.eval_var,
        }
    }
}

/// One integrand value: (pdf, eval, variance of that eval value).
type Integrand<'a> = dyn FnMut(Vec3) -> (f64, f64, f64) + 'a;

/// ∫ over a rectangle of (z, φ) with a 4×4 Gauss rule.
fn gl_rect(f: &mut Integrand, z0: f64, z1: f64, p0: f64, p1: f64) -> Quad {
    let (hz, hp) = (0.5 * (z1 - z0), 0.5 * (p1 - p0));
    let (cz, cp) = (0.5 * (z1 + z0), 0.5 * (p1 + p0));
    let mut q = Quad::default();
    for (xi, wi) in GL4_X.iter().zip(GL4_W) {
        for (xj, wj) in GL4_X.iter().zip(GL4_W) {
            let (p, e, v) = f(dir(cz + hz * xi, cp + hp * xj));
            let w = wi * wj * hz * hp;
            q.pdf += w * p;
            q.eval += w * e;
            q.eval_var += w * w * v;
        }
    }
    q
}

/// Adaptive integration: split into quadrants while the 4×4 estimate and the sum over the
/// quadrants disagree by more than 2% of the Poisson noise of N samples (pdf; and eval when it
/// is deterministic — a noisy eval would refine forever).
#[allow(clippy::too_many_arguments)]
fn integrate(
    f: &mut Integrand,
    z0: f64,
    z1: f64,
    p0: f64,
    p1: f64,
    whole: Quad,
    n: f64,
    depth: u32,
    refine_eval: bool,
) -> Quad {
    let (zm, pm) = (0.5 * (z0 + z1), 0.5 * (p0 + p1));
    let r = [
        (z0, zm, p0, pm),
        (zm, z1, p0, pm),
        (z0, zm, pm, p1),
        (zm, z1, pm, p1),
    ];
    let q = r.map(|(a, b, c, d)| gl_rect(f, a, b, c, d));
    let sum = q.iter().fold(Quad::default(), |s, v| s + *v);
    let ok = |a: f64, b: f64| (a - b).abs() * n <= 0.02 * (n * b.abs() + 1.0).sqrt();
    if depth == 0 || (ok(whole.pdf, sum.pdf) && (!refine_eval || ok(whole.eval, sum.eval))) {
        return sum;
    }
    let mut total = Quad::default();
    for (k, (a, b, c, d)) in r.into_iter().enumerate() {
        total = total + integrate(f, a, b, c, d, q[k], n, depth - 1, refine_eval);
    }
    total
}

/// Per-cell integrals for one incident direction.
pub struct CellIntegrals {
    /// ∫_cell pdf dω.
    pub pdf: Vec<f64>,
    /// ∫_cell eval dω, RGB channels summed.
    pub eval: Vec<f64>,
    /// Variance of `eval` due to a stochastic `eval` (each node is evaluated twice; the squared
    /// difference estimates the noise). All 0 for deterministic BSDFs.
    pub eval_var: Vec<f64>,
}

/// Per-cell integrals of pdf and eval for `wi`, accurate enough for `n` samples.
pub fn cell_integrals(
    bsdf: &dyn TestBsdf,
    wi: Vec3,
    grid: &Grid,
    n: usize,
    seed: u64,
) -> CellIntegrals {
    let mut sampler = Sampler::from_seed(seed ^ 0x5eed, 7);
    let stochastic = !bsdf.deterministic();
    let mut f = |wo: Vec3| {
        let p = bsdf.pdf(wi, wo) as f64;
        let e = bsdf.eval(wi, wo, &mut sampler);
        let a = (e.x + e.y + e.z) as f64;
        if stochastic {
            let e2 = bsdf.eval(wi, wo, &mut sampler);
            let b = (e2.x + e2.y + e2.z) as f64;
            // Mean of two evaluations and the unbiased variance of that mean.
            (p, 0.5 * (a + b), 0.25 * (a - b) * (a - b))
        } else {
            (p, a, 0.0)
        }
    };
    let cells = grid.cells();
    let mut out = CellIntegrals {
        pdf: vec![0.0; cells],
        eval: vec![0.0; cells],
        eval_var: vec![0.0; cells],
    };
    for c in 0..cells {
        let (z0, z1, p0, p1) = grid.bounds(c);
        let whole = gl_rect(&mut f, z0, z1, p0, p1);
        let q = integrate(&mut f, z0, z1, p0, p1, whole, n as f64, 7, !stochastic);
        out.pdf[c] = q.pdf;
        out.eval[c] = q.eval;
        out.eval_var[c] = q.eval_var;
    }
    out
}

/// Everything the tests need from one batch of samples.
pub struct Samples {
    pub n: usize,
    /// Smooth (non-delta) samples per cell.
    pub counts: Vec<u64>,
    /// Σ weight (channels summed) and Σ weight² per cell, smooth samples.
    pub wsum: Vec<f64>,
    pub w2sum: Vec<f64>,
    /// Delta-lobe samples and failed samples.
    pub delta: u64,
    pub failed: u64,
    /// Σ weight over all samples (failed count as 0), per channel, and Σ weight².
    pub albedo_sum: [f64; 3],
    pub albedo_sq: [f64; 3],
    /// Non-finite or negative weights / pdfs seen.
    pub invalid: u64,
    /// First few samples whose `weight != eval / pdf` (deterministic BSDFs only).
    pub weight_mismatch: Vec<String>,
}

/// Draw `n` samples from `wi`.
pub fn draw(
    bsdf: &dyn TestBsdf,
    wi: Vec3,
    grid: &Grid,
    n: usize,
    seed: u64,
    check_weights: bool,
) -> Samples {
    let mut sampler = Sampler::from_seed(seed, 1);
    let mut eval_sampler = Sampler::from_seed(seed, 3);
    let mut s = Samples {
        n,
        counts: vec![0; grid.cells()],
        wsum: vec![0.0; grid.cells()],
        w2sum: vec![0.0; grid.cells()],
        delta: 0,
        failed: 0,
        albedo_sum: [0.0; 3],
        albedo_sq: [0.0; 3],
        invalid: 0,
        weight_mismatch: Vec::new(),
    };
    for _ in 0..n {
        let Some(bs) = bsdf.sample(wi, &mut sampler) else {
            s.failed += 1;
            continue;
        };
        let w = bs.weight;
        if !(w.is_finite()
            && w.min_element() >= 0.0
            && bs.pdf.is_finite()
            && bs.pdf >= 0.0
            && bs.wo.is_finite())
        {
            s.invalid += 1;
            continue;
        }
        for k in 0..3 {
            s.albedo_sum[k] += w[k] as f64;
            s.albedo_sq[k] += (w[k] as f64).powi(2);
        }
        if bs.lobe.intersects(Lobes::DELTA) {
            s.delta += 1;
            continue;
        }
        let c = grid.cell_of(bs.wo);
        s.counts[c] += 1;
        let ws = (w.x + w.y + w.z) as f64;
        s.wsum[c] += ws;
        s.w2sum[c] += ws * ws;
        if check_weights && s.weight_mismatch.len() < 5 {
            let e = bsdf.eval(wi, bs.wo, &mut eval_sampler);
            let p = bsdf.pdf(wi, bs.wo);
            let expect = e / p;
            let rel = ((w - expect).abs()
                / expect
                    .abs()
                    .max(Vec3::splat(1e-4 * expect.max_element().max(1e-6))))
            .max_element();
            // The sample's own pdf is compared loosely: it is computed from the sampled normal
            // while `pdf` rebuilds the half vector from (wi, wo), and the dielectric Fresnel term
            // has an infinite slope at the critical angle, which amplifies f32 rounding (the
            // weight itself does not contain F and must match tightly).
            let prel = ((bs.pdf - p) / p).abs();
            if !(rel <= 1e-3 && prel <= 1e-2) {
                s.weight_mismatch.push(format!(
                    "wo {:?}: weight {:?} vs eval/pdf {:?}; sample pdf {} vs pdf {}",
                    bs.wo, w, expect, bs.pdf, p
                ));
            }
        }
    }
    s
}

/// Outcome of a test: `Err` carries a human-readable reason.
pub type Outcome = Result<(), String>;

/// Chi-square test of the sample histogram against the integrated pdf (see module docs).
pub fn chi2_sample_vs_pdf(s: &Samples, pdf_cells: &[f64], level: f64) -> Outcome {
    chi2_sample_vs_pdf_opts(s, pdf_cells, level, 0.0)
}

/// [`chi2_sample_vs_pdf`] for models whose `pdf` is known to be the sampled density times a
/// constant (per `wi`) within `renormalize` (relative): the constant is fitted (and must lie within
/// the tolerance), the expected counts rescaled, and the "rest" outcome dropped. Used for
/// Beckmann visible-normal sampling, where Mitsuba's pdf uses Walter's rational approximation of
/// G1(wi) (≤ 0.4% off) while the sampled density is exact.
pub fn chi2_sample_vs_pdf_opts(
    s: &Samples,
    pdf_cells: &[f64],
    level: f64,
    renormalize: f64,
) -> Outcome {
    let n = s.n as f64;
    let rest_obs = (s.delta + s.failed + s.invalid) as f64;
    let total: f64 = pdf_cells.iter().sum();
    let scale = if renormalize > 0.0 && total > 0.0 {
        let r = (n - rest_obs) / (n * total);
        if (r - 1.0).abs() > renormalize + 4.0 / (n * total).sqrt() {
            return Err(format!(
                "pdf normalisation off by {:.4}, more than {renormalize}",
                r - 1.0
            ));
        }
        r
    } else {
        1.0
    };
    let mut pooled_obs = 0.0;
    let mut pooled_exp = 0.0;
    let mut chi2 = 0.0;
    let mut dof = 0usize;
    let mut total_p = 0.0;
    for (c, &p) in pdf_cells.iter().enumerate() {
        total_p += p;
        let obs = s.counts[c] as f64;
        // A sample where the cell's quadrature found no pdf: either the sampler is wrong, or
        // the pdf lives on a sliver thinner than the quadrature resolves (e.g. a glossy lobe
        // at a facet's horizon under microfacet normal mapping, measured: pdf 0.046 on a band
        // 7e-4 wide). One such sample is what a sliver gives; a wrong sampler gives many.
        if p <= 0.0 && obs > 1.0 {
            return Err(format!(
                "{obs} samples in cell {c} where the integrated pdf is 0"
            ));
        }
        let e = n * p * scale;
        if e < 5.0 {
            pooled_obs += obs;
            pooled_exp += e;
        } else {
            chi2 += (obs - e).powi(2) / e;
            dof += 1;
        }
    }
    // Delta-lobe and failed samples: the mass the pdf does not cover.
    let rest_exp = n * (1.0 - total_p).max(0.0);
    if scale != 1.0 || renormalize > 0.0 {
        // The rest outcome carries the normalisation, fitted above.
    } else if rest_exp >= 5.0 {
        chi2 += (rest_obs - rest_exp).powi(2) / rest_exp;
        dof += 1;
    } else {
        pooled_obs += rest_obs;
        pooled_exp += rest_exp;
    }
    if pooled_exp >= 5.0 {
        chi2 += (pooled_obs - pooled_exp).powi(2) / pooled_exp;
        dof += 1;
    } else if pooled_obs > 0.0 {
        // Too few expected for the chi-square approximation: a Poisson tail test instead.
        let tail = Poisson::new(pooled_exp.max(1e-12))
            .unwrap()
            .sf(pooled_obs as u64 - 1);
        if tail < level {
            return Err(format!(
                "{pooled_obs} samples where only {pooled_exp:.3} are expected (sparse cells, delta, failed)"
            ));
        }
    }
    if total_p > 1.0 + 1e-3 + 5.0 / n.sqrt() {
        return Err(format!("pdf integrates to {total_p} > 1"));
    }
    if dof < 2 {
        return Ok(());
    }
    let dist = ChiSquared::new((dof - 1) as f64).unwrap();
    let p_value = 1.0 - dist.cdf(chi2);
    if p_value < level {
        Err(format!(
            "chi2 = {chi2:.1}, dof = {}, p = {p_value:.3e} < {level:.1e} (∫pdf = {total_p:.5})",
            dof - 1
        ))
    } else {
        Ok(())
    }
}

/// Deterministic BSDFs: weight == eval / pdf for every sampled direction.
pub fn weight_matches_eval_over_pdf(s: &Samples) -> Outcome {
    if s.invalid > 0 {
        return Err(format!("{} samples with invalid weight/pdf", s.invalid));
    }
    if s.weight_mismatch.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "weight != eval/pdf: {}",
            s.weight_mismatch.join("; ")
        ))
    }
}

/// Per-cell z-test of mean(weight · 1{cell}) against ∫_cell eval dω (channels summed). Cells
/// expecting fewer than 50 samples (N ∫_cell pdf, not the observed count, which would bias the
/// selection) are pooled into one group so the normal approximation holds; the minimum p-value
/// is compared with the level split over the groups (Šidák).
pub fn cell_consistency(s: &Samples, cells: &CellIntegrals, level: f64) -> Outcome {
    cell_consistency_opts(s, cells, level, 0.0)
}

/// Relative accuracy assumed for the quadrature of ∫_cell eval (added to the sample variance, so
/// that nearly constant weights do not turn quadrature rounding into "significant" differences).
const QUADRATURE_REL: f64 = 2e-4;

/// [`cell_consistency`] with the same pdf renormalisation as [`chi2_sample_vs_pdf_opts`]: when
/// the sampled density is r · pdf, E[weight · 1{cell}] = r ∫_cell eval.
pub fn cell_consistency_opts(
    s: &Samples,
    cells: &CellIntegrals,
    level: f64,
    renormalize: f64,
) -> Outcome {
    let pdf_cells = &cells.pdf[..];
    let n = s.n as f64;
    let total_pdf: f64 = pdf_cells.iter().sum();
    let rest_obs = (s.delta + s.failed + s.invalid) as f64;
    let r = if renormalize > 0.0 && total_pdf > 0.0 {
        (n - rest_obs) / (n * total_pdf)
    } else {
        1.0
    };
    let scaled: Vec<f64> = cells.eval.iter().map(|e| e * r).collect();
    let eval_cells = &scaled[..];
    let normal = Normal::new(0.0, 1.0).unwrap();
    // (Σw, Σw², ∫eval, ∫pdf, variance of ∫eval, name)
    let mut groups: Vec<(f64, f64, f64, f64, f64, String)> = Vec::new();
    let (mut ps, mut ps2, mut pe, mut pp, mut pv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for c in 0..eval_cells.len() {
        let ev = cells.eval_var[c] * r * r;
        if n * pdf_cells[c] >= 50.0 {
            groups.push((
                s.wsum[c],
                s.w2sum[c],
                eval_cells[c],
                pdf_cells[c],
                ev,
                format!("cell {c}"),
            ));
        } else {
            ps += s.wsum[c];
            ps2 += s.w2sum[c];
            pe += eval_cells[c];
            pp += pdf_cells[c];
            pv += ev;
        }
    }
    groups.push((ps, ps2, pe, pp, pv, "pooled sparse cells".into()));
    // Σ z² over the disjoint groups is χ²(k) distributed: catches a bias spread thinly over
    // many cells; the whole sphere as one more group catches a global scale error.
    let mut z2 = 0.0;
    let mut k_z2 = 0usize;
    for (sw, sw2, integral, _, evar, _) in &groups {
        let mean = sw / n;
        let var = (sw2 / n - mean * mean).max(0.0) / n + (QUADRATURE_REL * integral).powi(2) + evar;
        // Groups without samples are judged by the no-sample rule below.
        if *sw2 > 0.0 && var > 0.0 {
            z2 += (mean - integral).powi(2) / var;
            k_z2 += 1;
        }
    }
    let total = groups.iter().fold((0.0, 0.0, 0.0, 0.0, 0.0), |t, g| {
        (t.0 + g.0, t.1 + g.1, t.2 + g.2, t.3 + g.3, t.4 + g.4)
    });
    groups.push((
        total.0,
        total.1,
        total.2,
        total.3,
        total.4,
        "whole sphere".into(),
    ));
    let k = groups.len() + 1;
    let cell_level = 1.0 - (1.0 - level).powf(1.0 / k as f64);
    let mut worst = (1.0f64, String::new());
    for (sw, sw2, integral, prob, evar, name) in groups {
        let mean = sw / n;
        let mut var =
            (sw2 / n - mean * mean).max(0.0) / n + (QUADRATURE_REL * integral).powi(2) + evar;
        if evar == 0.0 && prob > 0.0 && integral > 0.0 {
            // Deterministic BSDF with an exact pdf: the count in a cell is binomial with the
            // *expected* probability ∫pdf, and each weight is ≈ ∫eval/∫pdf there, so
            // Var(Σw·1{cell}/n) ≥ (∫eval)²·(1 − ∫pdf)/(n·∫pdf). The sample variance alone comes
            // from the count that happened to land, and is too small when it is low (a cell
            // with half its expected samples would look too certain).
            var = var.max(integral * integral * (1.0 - prob).max(0.0) / (n * prob));
        }
        let diff = mean - integral;
        if sw2 == 0.0 {
            // No samples: only suspicious if the pdf made samples likely, or eval has mass the
            // sampler can never reach.
            if integral > 1e-9 && (prob == 0.0 || (-n * prob).exp() < cell_level) {
                return Err(format!(
                    "{name}: no samples but ∫eval = {integral:.3e}, ∫pdf = {prob:.3e}"
                ));
            }
            continue;
        }
        let z = diff / var.sqrt();
        let p = 2.0 * (1.0 - normal.cdf(z.abs()));
        if p < worst.0 {
            worst = (
                p,
                format!("{name}: mean weight {mean:.5e} vs ∫eval {integral:.5e} (z = {z:.2})"),
            );
        }
    }
    if k_z2 > 0 {
        let p = 1.0 - ChiSquared::new(k_z2 as f64).unwrap().cdf(z2);
        if p < worst.0 {
            worst = (p, format!("Σz² = {z2:.1} over {k_z2} groups"));
        }
    }
    if worst.0 < cell_level {
        Err(format!(
            "{} p = {:.2e} < {cell_level:.1e}",
            worst.1, worst.0
        ))
    } else {
        Ok(())
    }
}

/// White furnace: (mean weight, standard error) per channel.
pub fn furnace(s: &Samples) -> ([f64; 3], [f64; 3]) {
    let n = s.n as f64;
    let mut m = [0.0; 3];
    let mut se = [0.0; 3];
    for k in 0..3 {
        m[k] = s.albedo_sum[k] / n;
        se[k] = ((s.albedo_sq[k] / n - m[k] * m[k]).max(0.0) / n).sqrt();
    }
    (m, se)
}

/// Albedo ≤ 1 + 4σ per channel, and = 1 within 4σ (plus 1e-4 for f32 sums) when `lossless`.
pub fn furnace_test(s: &Samples, lossless: bool) -> Outcome {
    let (m, se) = furnace(s);
    for k in 0..3 {
        let tol = 4.0 * se[k] + 1e-4;
        if m[k] > 1.0 + tol {
            return Err(format!("albedo {m:?} > 1 (σ {se:?})"));
        }
        if lossless && (m[k] - 1.0).abs() > tol {
            return Err(format!("albedo {m:?} != 1 for a lossless model (σ {se:?})"));
        }
    }
    Ok(())
}

/// Reciprocity on random direction pairs: f(wi, wo) · factor(wi, wo) == f(wo, wi), with
/// f = eval / |cos θo|. `factor` is 1 for reflection, (η_o/η_i)² for refraction in radiance mode.
pub fn reciprocity(
    bsdf: &dyn TestBsdf,
    pairs: usize,
    seed: u64,
    factor: &dyn Fn(Vec3, Vec3) -> f32,
) -> Outcome {
    let mut rng = Sampler::from_seed(seed, 11);
    let mut es = Sampler::from_seed(seed, 12);
    for _ in 0..pairs {
        let a = groove::math::warp::square_to_uniform_sphere(rng.next_2d());
        let b = groove::math::warp::square_to_uniform_sphere(rng.next_2d());
        if a.z.abs() < 0.05 || b.z.abs() < 0.05 {
            continue;
        }
        let fab = bsdf.eval(a, b, &mut es) / b.z.abs();
        let fba = bsdf.eval(b, a, &mut es) / a.z.abs();
        let lhs = fab * factor(a, b);
        let tol = 2e-3 * lhs.max_element().max(fba.max_element()) + 1e-6;
        if (lhs - fba).abs().max_element() > tol {
            return Err(format!(
                "f({a:?}, {b:?}) · factor = {lhs:?} but f(wo, wi) = {fba:?}"
            ));
        }
    }
    Ok(())
}

/// A unit direction at polar angle `theta_deg` (measured from +z; > 90° is below), azimuth `phi_deg`.
pub fn direction(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Per-cell sums of an eval estimate: Σ eval/p, Σ (eval/p)² and the count of non-zero terms per
/// cell, over `m` directions drawn from a density p (for stochastic BSDFs, whose eval cannot be
/// integrated by quadrature without bias; see `tests/bsdf/mnm_harness.rs`).
pub struct EvalCells {
    pub m: usize,
    pub sum: Vec<f64>,
    pub sum2: Vec<f64>,
    pub nonzero: Vec<usize>,
}

impl EvalCells {
    pub fn new(cells: usize, m: usize) -> Self {
        EvalCells {
            m,
            sum: vec![0.0; cells],
            sum2: vec![0.0; cells],
            nonzero: vec![0; cells],
        }
    }

    /// Add one term `v` = eval/p of a direction in `cell`.
    pub fn add(&mut self, cell: usize, v: f64) {
        self.sum[cell] += v;
        self.sum2[cell] += v * v;
        if v > 0.0 {
            self.nonzero[cell] += 1;
        }
    }
}

/// Sample weights against an eval estimate, cell by cell and in total.
pub struct CellComparison {
    /// Σ z² over the cells with ≥ 30 terms on both sides, its degrees of freedom and p-value.
    pub z2: f64,
    pub dof: usize,
    pub p: f64,
    /// Whole-sphere mean weight and ∫eval, their z-score and two-sided p-value.
    pub weight: f64,
    pub eval: f64,
    pub z_total: f64,
    pub p_total: f64,
}

impl CellComparison {
    pub fn describe(&self) -> String {
        format!(
            "Σz² = {:.1} over {} cells (p = {:.2e}); total weight {:.5} vs ∫eval {:.5} (z = {:.2}, p = {:.2e})",
            self.z2, self.dof, self.p, self.weight, self.eval, self.z_total, self.p_total
        )
    }
}

/// Compare two independent Monte Carlo estimates of the same per-cell integral: the sample
/// weights `s` (N samples) and the eval terms `e` (M directions), each with its own variance.
pub fn compare_cells(s: &Samples, e: &EvalCells) -> CellComparison {
    let (n, mf) = (s.n as f64, e.m as f64);
    let (mut z2, mut dof) = (0.0, 0usize);
    let (mut tw, mut tw2, mut te, mut te2) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..e.sum.len() {
        tw += s.wsum[k];
        tw2 += s.w2sum[k];
        te += e.sum[k];
        te2 += e.sum2[k];
        if s.counts[k] < 30 || e.nonzero[k] < 30 {
            continue;
        }
        let mw = s.wsum[k] / n;
        let vw = (s.w2sum[k] / n - mw * mw).max(0.0) / n;
        let me = e.sum[k] / mf;
        let ve = (e.sum2[k] / mf - me * me).max(0.0) / mf;
        if vw + ve > 0.0 {
            z2 += (mw - me).powi(2) / (vw + ve);
            dof += 1;
        }
    }
    let p = if dof > 0 {
        statrs::distribution::ContinuousCDF::sf(
            &statrs::distribution::ChiSquared::new(dof as f64).unwrap(),
            z2,
        )
    } else {
        1.0
    };
    let (mw, me) = (tw / n, te / mf);
    let z_total = (mw - me) / ((tw2 / n - mw * mw) / n + (te2 / mf - me * me) / mf).sqrt();
    let normal = statrs::distribution::Normal::new(0.0, 1.0).unwrap();
    let p_total = 2.0 * (1.0 - statrs::distribution::ContinuousCDF::cdf(&normal, z_total.abs()));
    CellComparison {
        z2,
        dof,
        p,
        weight: mw,
        eval: me,
        z_total,
        p_total,
    }
}

impl ArenaBsdf {
    /// `Bsdf::eval_pdf` (the fused query of next-event estimation) equals separate `eval` and
    /// `pdf` calls to float rounding (relative 1e-5) for `n` random direction pairs over the whole
    /// sphere. Deterministic BSDFs only (a random walk's eval differs from call to call).
    pub fn check_eval_pdf(&self, n: usize, seed: u64) -> Result<(), String> {
        assert!(
            self.deterministic,
            "eval_pdf check needs a deterministic BSDF"
        );
        let mut s = Sampler::from_seed(seed, 11);
        let b = self.arena.bsdf(self.root);
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()) + 1e-30;
        for _ in 0..n {
            let wi = groove::math::warp::square_to_uniform_sphere(s.next_2d());
            let wo = groove::math::warp::square_to_uniform_sphere(s.next_2d());
            let (f, p) = b.eval_pdf(&self.ctx, wi, wo, &mut s);
            let f2 = b.eval(&self.ctx, wi, wo, &mut s);
            let p2 = b.pdf(&self.ctx, wi, wo);
            let ok = close(p, p2) && (0..3).all(|c| close(f[c], f2[c]));
            if !ok {
                return Err(format!(
                    "wi {wi} wo {wo}: eval_pdf ({f}, {p}) vs eval {f2}, pdf {p2}"
                ));
            }
        }
        Ok(())
    }
}
