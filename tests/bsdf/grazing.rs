//! `roughconductor` with visible-normal sampling at grazing incidence (issue 14's rim doubt:
//! groove renders the rims of rough gold spheres 1.5–2.6 % brighter than Mitsuba 3.9.1 with
//! `sample_visible`, and agrees without it). The chi-square harness stops at θi = 85°; here,
//! from 88° to 89.95°, the mean sample weight (= ∫ eval dωo when `sample` draws from its pdf)
//! must equal a quadrature of `eval` over the hemisphere. Mitsuba 3.9.1's own numbers for the
//! same BSDF and angles are in `tests/refs/roughconductor_grazing.py` (its visible sampling is
//! not lossy there either).

use glam::Vec3;
use groove::bsdf::*;
use groove::sampler::Sampler;

/// ∫ eval(wi, wo) dωo by the midpoint rule in (cos θo, φo): `n` × 2`n` cells.
fn integral_of_eval(b: &RoughConductor, wi: Vec3, n: usize) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..n {
        let c = (i as f64 + 0.5) / n as f64;
        let s = (1.0 - c * c).sqrt();
        for j in 0..2 * n {
            let phi = (j as f64 + 0.5) / (2 * n) as f64 * std::f64::consts::TAU;
            let wo = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
            sum += b.eval(wi, wo).x as f64;
        }
    }
    sum * (1.0 / n as f64) * (std::f64::consts::TAU / (2 * n) as f64)
}

/// Mean and standard error of the sample weight over `n` samples.
fn mean_weight(b: &RoughConductor, wi: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut s = Sampler::from_seed(seed, 1);
    let (mut m, mut m2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let w = b
            .sample(wi, s.next_2d())
            .map_or(0.0, |bs| bs.weight.x as f64);
        m += w;
        m2 += w * w;
    }
    let mean = m / n as f64;
    (mean, ((m2 / n as f64 - mean * mean) / n as f64).sqrt())
}

#[test]
fn visible_sampling_keeps_the_energy_of_eval_up_to_grazing() {
    let mut fails = Vec::new();
    for (kind, name, tol) in [
        // GGX: exact G1, so the weights' mean is ∫ eval (quadrature error ~1e-4).
        (MicrofacetType::Ggx, "ggx", 5e-4),
        // Beckmann: Walter's rational G1 (as Mitsuba) is ~0.35 % from the exact masking that
        // the visible-slope sampler follows, so the two differ by up to that much.
        (MicrofacetType::Beckmann, "beckmann", 5e-3),
    ] {
        let b = RoughConductor {
            distribution: MicrofacetDistribution::new(kind, 0.25, true),
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
            specular_reflectance: Vec3::ONE,
        };
        for (i, theta) in [88.0f64, 89.0, 89.5, 89.8, 89.95].into_iter().enumerate() {
            let t = theta.to_radians();
            let wi = Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
            let integral = integral_of_eval(&b, wi, 1200);
            let (mean, se) = mean_weight(&b, wi, 500_000, 700 + i as u64);
            println!(
                "{name} α 0.25 θi {theta}: E[weight] {mean:.5} ± {se:.5}, ∫ eval {integral:.5}"
            );
            if (mean - integral).abs() > 5.0 * se + tol * integral {
                fails.push(format!("{name} θi {theta}: {mean} ± {se} vs {integral}"));
            }
        }
    }
    assert!(fails.is_empty(), "{fails:#?}");
}
