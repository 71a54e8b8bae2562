//! Self-check of the reference images and of the statistical comparison harness
//! (tests/common/imgcmp.rs), without running groove:
//!
//! * (a) the cbox reference (Mitsuba 3.9.1, 4 seeds × 4096 spp) is ACCEPTED against an independent
//!   Mitsuba render of the same scene (`cbox.check`, other seeds, 4 × 256 spp);
//! * (b) the same independent render scaled by 0.98 (a 2% brightness bias) is REJECTED — the
//!   acceptance criterion "would catch a 2% bias in mean brightness";
//! * the harness's false-alarm rate and power on synthetic Gaussian images;
//! * sanity of every committed reference and a few analytic facts they must show.
//!
//! Run with `cargo test --test render refs_selfcheck -- --nocapture` to see the numbers.

use crate::common;

use common::imgcmp::*;
use common::load_reference;

const BLOCK: usize = 8;

const REFS: &[(&str, usize, usize)] = &[
    ("furnace_sphere", 32, 32),
    ("depth_sphere_d1", 32, 32),
    ("depth_sphere_d2", 32, 32),
    ("depth_sphere_d3", 32, 32),
    ("mis_quad", 64, 64),
    ("mis_quad_nopoint", 64, 64),
    ("cbox_v3", 64, 64),
    ("area_point", 48, 32),
    ("cbox", 64, 64),
    ("cbox.check", 64, 64),
];

#[test]
fn references_are_sane() {
    for &(name, w, h) in REFS {
        let (m, v) = load_reference(name);
        assert_eq!((m.width, m.height), (w, h), "{name}: size");
        assert_eq!((v.width, v.height), (w, h), "{name}: variance size");
        for (i, (p, q)) in m.data.iter().zip(&v.data).enumerate() {
            for c in 0..3 {
                assert!(
                    p[c].is_finite() && p[c] >= 0.0,
                    "{name}: pixel {i} channel {c} = {}",
                    p[c]
                );
                assert!(
                    q[c].is_finite() && q[c] >= 0.0,
                    "{name}: variance {i} channel {c} = {}",
                    q[c]
                );
            }
        }
        let means = m.channel_means();
        assert!(
            means.iter().all(|&x| x > 0.0),
            "{name}: black image? means {means:?}"
        );
    }
}

#[test]
fn cbox_independent_render_is_accepted() {
    let (r, rv) = load_reference("cbox");
    let (t, tv) = load_reference("cbox.check");
    for block in [BLOCK, 4, 16] {
        let cmp = compare(&t, &tv, &r, &rv, block);
        println!(
            "[accept, block {block}] cbox.check vs cbox:\n{}",
            cmp.report()
        );
        cmp.assert_consistent(&format!("cbox.check vs cbox reference (block {block})"));
    }
}

#[test]
fn cbox_two_percent_bias_is_rejected() {
    let (r, rv) = load_reference("cbox");
    let (t, tv) = load_reference("cbox.check");
    let s = 0.98;
    let (tb, tbv) = (t.scaled(s), tv.scaled(s * s));
    for block in [BLOCK, 4, 16] {
        let cmp = compare(&tb, &tbv, &r, &rv, block);
        println!(
            "[2% bias, block {block}] 0.98 * cbox.check vs cbox:\n{}",
            cmp.report()
        );
        assert!(
            !cmp.is_consistent(),
            "a 2% brightness bias was NOT detected:\n{}",
            cmp.report()
        );
        // Both the tile χ² test and the whole-image mean-ratio test must catch it on their own.
        assert!(
            cmp.p_value < P_VALUE_MIN,
            "chi2 test alone misses the 2% bias:\n{}",
            cmp.report()
        );
        for c in 0..3 {
            let sig = (cmp.mean_ratio[c] - 1.0).abs() / cmp.mean_ratio_sigma[c];
            assert!(
                sig > MEAN_RATIO_SIGMAS,
                "mean ratio of channel {c} misses the bias ({sig:.1} sigma)"
            );
        }
    }
    // The reference's own whole-image noise is far below 2%.
    let cmp = compare(&t, &tv, &r, &rv, BLOCK);
    for c in 0..3 {
        assert!(
            cmp.mean_ratio_sigma[c] < 0.02 / 8.0,
            "mean-ratio sigma too large: {:?}",
            cmp.mean_ratio_sigma
        );
    }
}

#[test]
fn a_reference_is_consistent_with_itself_and_exact_tiles_work() {
    // Identical images: every z is 0.
    let (r, rv) = load_reference("furnace_sphere");
    let cmp = compare(&r, &rv, &r, &rv, BLOCK);
    assert_eq!(cmp.z_max, 0.0);
    cmp.assert_consistent("furnace_sphere vs itself");
    // A noise-free tile that differs must fail: one pixel 1 % off moves its 8×8 tile's mean by
    // 1.6e-4, above the exact-tile tolerance of 1e-4 (tests/common/imgcmp.rs: Mitsuba's float32
    // pixel sums drift by ~2e-5 on constant tiles).
    let mut bad = r.clone();
    let zero = RgbImage::new(r.width, r.height);
    let mut rz = r.clone();
    for p in rz.data.iter_mut() {
        *p = [1.0; 3];
    }
    bad.data.iter_mut().for_each(|p| *p = [1.0; 3]);
    bad.data[0] = [1.01, 1.0, 1.0];
    let cmp = compare(&bad, &zero, &rz, &zero, BLOCK);
    assert_eq!(cmp.exact_mismatches, 1, "{}", cmp.report());
    assert!(!cmp.is_consistent());
    let cmp = compare(&rz, &zero, &rz, &zero, BLOCK);
    assert!(cmp.is_consistent(), "{}", cmp.report());
}

/// Analytic facts the Mitsuba references show (documented in tests/refs/README.md).
#[test]
fn references_show_the_analytic_values() {
    // Furnace: background exactly 1 (constant emitter seen directly), sphere centre = albedo 0.8.
    let (f, fv) = load_reference("furnace_sphere");
    for &(x, y) in &[(0, 0), (31, 0), (0, 31), (31, 31)] {
        assert_eq!(f.get(x, y), [1.0; 3], "furnace background pixel ({x},{y})");
    }
    // Sphere interior (projected radius ≈ 11.4 px; take pixel centres within 9 px of the centre).
    let (mut sum, mut var, mut n) = (0.0, 0.0, 0.0);
    for y in 0..32 {
        for x in 0..32 {
            let (dx, dy) = (x as f64 + 0.5 - 16.0, y as f64 + 0.5 - 16.0);
            if dx.hypot(dy) < 9.0 {
                sum += f.get(x, y)[0];
                var += fv.get(x, y)[0];
                n += 1.0;
            }
        }
    }
    let (mean, sigma) = (sum / n, var.sqrt() / n);
    println!("furnace sphere interior: {mean:.6} ± {sigma:.6} over {n} pixels (analytic 0.8)");
    assert!(
        (mean - 0.8).abs() <= 4.0 * sigma,
        "furnace sphere interior {mean} ± {sigma}, analytic 0.8"
    );
    // Depth 1: only directly seen emitters: the sphere centre is black, the sky is 1.
    let (d1, _) = load_reference("depth_sphere_d1");
    assert_eq!(d1.get(16, 12), [0.0; 3], "depth 1 sphere");
    assert_eq!(d1.get(16, 0), [1.0; 3], "depth 1 sky");
    // Depth 2 < depth 3 on the floor near the sphere (interreflection), and the sky stays 1.
    let (d2, d2v) = load_reference("depth_sphere_d2");
    let (d3, d3v) = load_reference("depth_sphere_d3");
    let cmp = compare(&d2, &d2v, &d3, &d3v, BLOCK);
    assert!(
        cmp.mean_ratio[0] < 1.0 && !cmp.is_consistent(),
        "depth 2 should be darker than depth 3: {}",
        cmp.report()
    );
}

// ---------------------------------------------------------------------------------------------
// Synthetic check of the statistics: Gaussian pixel noise, variances estimated from K = 4 "seeds"
// on both sides, as for the real references.

struct Rng(u64);
impl Rng {
    fn next_f64(&mut self) -> f64 {
        // splitmix64
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.next_f64(), self.next_f64());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// K renders of a 64×64 image whose pixel (x, y) has expectation `truth * scale` and per-render
/// relative standard deviation `rel_sd`; the three channels share most of their noise (like one path
/// carrying RGB).
fn synthetic(
    rng: &mut Rng,
    truth: &RgbImage,
    scale: f64,
    rel_sd: f64,
    k: usize,
) -> (RgbImage, RgbImage) {
    let renders: Vec<RgbImage> = (0..k)
        .map(|_| {
            let mut img = truth.clone();
            for p in img.data.iter_mut() {
                let common = rng.normal();
                for v in p.iter_mut() {
                    let e = 0.9 * common + (1.0f64 - 0.81).sqrt() * rng.normal();
                    *v = scale * *v * (1.0 + rel_sd * e);
                }
            }
            img
        })
        .collect();
    mean_and_var_of_mean(&renders)
}

#[test]
fn synthetic_false_alarm_rate_and_power() {
    let mut rng = Rng(12345);
    let mut truth = RgbImage::new(64, 64);
    for y in 0..64 {
        for x in 0..64 {
            let v = 0.2 + 0.8 * ((x as f64 / 9.0).sin() * (y as f64 / 7.0).cos()).abs();
            truth.data[y * 64 + x] = [v, 0.6 * v, 0.3 * v];
        }
    }
    let trials = 200;
    let mut false_alarms = 0;
    let mut detected = 0;
    for _ in 0..trials {
        // Reference: low noise; test: 4x the reference's standard deviation (fewer spp).
        let (r, rv) = synthetic(&mut rng, &truth, 1.0, 0.03, 4);
        let (t, tv) = synthetic(&mut rng, &truth, 1.0, 0.12, 4);
        if !compare(&t, &tv, &r, &rv, BLOCK).is_consistent() {
            false_alarms += 1;
        }
        let (tb, tbv) = synthetic(&mut rng, &truth, 0.98, 0.12, 4);
        if !compare(&tb, &tbv, &r, &rv, BLOCK).is_consistent() {
            detected += 1;
        }
    }
    println!(
        "synthetic: {false_alarms}/{trials} false alarms, {detected}/{trials} 2% biases detected"
    );
    assert!(
        false_alarms <= 3,
        "too many false alarms: {false_alarms}/{trials}"
    );
    assert!(
        detected >= trials - 2,
        "2% bias missed too often: detected {detected}/{trials}"
    );
}
