//! Emitters `spot`, `directional` and `envmap`: Mitsuba 3 conventions (numbers read off Mitsuba
//! 3.9.1 `scalar_rgb`), the 2-D importance sampling distribution, the envmap estimator's
//! unbiasedness and the consistency of its densities, power estimates for light selection, and
//! errors for bad input. Run with `cargo test --release --test scene emitters`.

use std::path::{Path, PathBuf};

use glam::{Mat3, Vec2, Vec3};
use groove::emitter::envmap::EnvMapLight;
use groove::emitter::spot::SpotLight;
use groove::emitter::Emitter;
use groove::load::load_scene;
use groove::load::options::LoadOptions;
use groove::math::{Distribution2D, Pcg32};
use groove::scene::Scene;
use groove::Spectrum;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn fixture() -> PathBuf {
    repo().join("tests/data/envmaps/sky_sun.exr")
}

/// A scratch folder of its own for each test.
fn scratch(name: &str) -> crate::common::Scratch {
    crate::common::Scratch::new(&format!("groove_emitters_{}_{name}", std::process::id()))
}

/// A minimal scene (a sphere, a camera) with `emitters` (XML) at the top level, written to
/// `dir/scene.xml`; the emitter XML starts on line 4.
fn scene_text(emitters: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<scene version="3.0.0">
    <shape type="sphere"/>
{emitters}
    <sensor type="perspective">
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
</scene>
"#
    )
}

fn load_in(dir: &Path, emitters: &str) -> groove::Result<Scene> {
    let path = dir.join("scene.xml");
    std::fs::write(&path, scene_text(emitters)).unwrap();
    load_scene(&path, &LoadOptions::default()).map(|l| l.scene)
}

fn load(name: &str, emitters: &str) -> Scene {
    let dir = scratch(name);
    load_in(&dir, emitters).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads and expects a scene error on line `line` mentioning `msg`.
fn load_err(name: &str, emitters: &str, line: u32, msg: &str) {
    let dir = scratch(name);
    let err = match load_in(&dir, emitters) {
        Ok(_) => panic!("{name}: expected an error"),
        Err(e) => e,
    };
    match &err {
        groove::Error::Scene { loc, msg: m } => {
            assert_eq!(loc.line, line, "{name}: {err}");
            assert!(m.contains(msg), "{name}: expected '{msg}' in: {err}");
        }
        other => panic!("{name}: expected a scene error, got {other}"),
    }
}

fn close(a: Spectrum, b: [f32; 3], rel: f32) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= rel * b[i].abs().max(1e-3))
}

/// Mitsuba's lat-long direction of (u, v): u = atan2(x, −z)/2π, v = acos(y)/π.
fn dir_of(u: f32, v: f32) -> Vec3 {
    EnvMapLight::local_of_uv(Vec2::new(u, v))
}

// ------------------------------------------------------------------------------ Distribution2D

/// Upper critical value of χ² with `k` degrees of freedom at normal quantile `z`
/// (Wilson–Hilferty).
fn chi2_critical(k: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

#[test]
fn distribution2d_samples_follow_its_pdf_chi_square() {
    let (nx, ny) = (12usize, 7usize);
    let mut rng = Pcg32::new(7, 1);
    let mut w: Vec<f32> = (0..nx * ny)
        .map(|_| {
            let x = rng.next_f32();
            x * x * 5.0
        })
        .collect();
    // Zero cells and a whole zero row must never be sampled.
    w[3] = 0.0;
    w[20] = 0.0;
    for x in 0..nx {
        w[4 * nx + x] = 0.0;
    }
    let d = Distribution2D::new(&w, nx, ny).unwrap();
    // Bins: each cell split 2×2 (the density is uniform within a cell).
    let (bx, by) = (2 * nx, 2 * ny);
    let mut counts = vec![0f64; bx * by];
    let n = 400_000;
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let (p, pdf) = d.sample(u);
        assert!(
            (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y),
            "{p}"
        );
        let pdf2 = d.pdf(p);
        assert!(
            (pdf - pdf2).abs() <= 1e-4 * pdf.max(1.0),
            "sample pdf {pdf} vs pdf() {pdf2} at {p}"
        );
        let i = ((p.x * bx as f32) as usize).min(bx - 1);
        let j = ((p.y * by as f32) as usize).min(by - 1);
        counts[j * bx + i] += 1.0;
    }
    // Expected counts from the pdf (integrated over each bin by its centre value: exact here).
    let mut chi2 = 0.0;
    let mut dof = 0usize;
    let mut pooled = (0.0f64, 0.0f64);
    for j in 0..by {
        for i in 0..bx {
            let c = Vec2::new((i as f32 + 0.5) / bx as f32, (j as f32 + 0.5) / by as f32);
            let e = d.pdf(c) as f64 / (bx * by) as f64 * n as f64;
            let o = counts[j * bx + i];
            if e == 0.0 {
                assert_eq!(o, 0.0, "zero-density bin ({i}, {j}) was sampled");
                continue;
            }
            if e < 5.0 {
                // Pooled into one bin (the χ² approximation needs expected counts ≥ 5).
                pooled.0 += o;
                pooled.1 += e;
                continue;
            }
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled.1 > 0.0 {
        assert!(pooled.1 >= 5.0, "pooled bin too small: {}", pooled.1);
        chi2 += (pooled.0 - pooled.1).powi(2) / pooled.1;
        dof += 1;
    }
    let k = (dof - 1) as f64;
    let crit = chi2_critical(k, 4.75); // p ≈ 1e-6
    assert!(chi2 < crit, "chi2 {chi2:.1} with {k} dof exceeds {crit:.1}");
    // And the pdf integrates to one.
    let total: f64 = (0..by * bx)
        .map(|b| {
            let c = Vec2::new(
                ((b % bx) as f32 + 0.5) / bx as f32,
                ((b / bx) as f32 + 0.5) / by as f32,
            );
            d.pdf(c) as f64 / (bx * by) as f64
        })
        .sum();
    assert!((total - 1.0).abs() < 1e-5, "pdf integrates to {total}");
}

// ------------------------------------------------------------------------------ envmap

fn fixture_light(scale: f32, to_world: Mat3) -> EnvMapLight {
    let (img, _) = groove::output::read_exr(&fixture()).unwrap();
    EnvMapLight::new(
        img.width as usize,
        img.height as usize,
        &img.data,
        scale,
        to_world,
    )
    .unwrap()
}

#[test]
fn envmap_eval_matches_mitsuba_orientation_and_bilinear_lookup() {
    // `emitter.eval(si)` of Mitsuba 3.9.1 (scalar_rgb) on the fixture, si.wi = −dir_of(u, v).
    let scene = load(
        "orient",
        &format!(
            r#"<emitter type="envmap"><string name="filename" value="{}"/></emitter>"#,
            fixture().display()
        ),
    );
    assert_eq!(scene.env_emitters(), vec![0]);
    let em = &scene.emitters()[0];
    assert!(em.is_environment());
    let cases: [((f32, f32), [f32; 3]); 5] = [
        ((40.5 / 64.0, 9.5 / 32.0), [57.895084, 49.292084, 35.008656]),
        ((0.5 / 64.0, 0.5 / 32.0), [0.2577693, 0.3262203, 0.47155446]),
        (
            (10.5 / 64.0, 20.5 / 32.0),
            [0.16767004, 0.24065022, 0.28103825],
        ),
        (
            (11.0 / 64.0, 20.5 / 32.0),
            [0.17648788, 0.25442678, 0.29426336],
        ),
        // u = 0 lies between the last and the first column (wrap-around).
        ((0.0, 20.5 / 32.0), [0.18276237, 0.18342577, 0.25558743]),
    ];
    for ((u, v), want) in cases {
        let got = em.eval_env(dir_of(u, v));
        assert!(
            close(got, want, 1e-4),
            "({u}, {v}): {got} vs Mitsuba {want:?}"
        );
    }
    // With `scale` 2 and `to_world` = rotate(y, 90°): Mitsuba gives this at dir_of(0.3, 0.4).
    let scene = load(
        "orient_rot",
        &format!(
            r#"<emitter type="envmap"><string name="filename" value="{}"/>
        <float name="scale" value="2"/>
        <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#,
            fixture().display()
        ),
    );
    let got = scene.emitters()[0].eval_env(dir_of(0.3, 0.4));
    let want = [0.5346105, 0.54904735, 0.7485445];
    assert!(close(got, want, 1e-4), "{got} vs Mitsuba {want:?}");
}

fn rot_y(deg: f32) -> Mat3 {
    Mat3::from_rotation_y(deg.to_radians())
}

#[test]
fn envmap_sample_pdf_equals_pdf_direct_and_value_equals_eval() {
    let light = fixture_light(1.0, rot_y(60.0) * Mat3::from_rotation_x(0.3));
    let em = Emitter::EnvMap(light);
    let mut rng = Pcg32::new(3, 5);
    let mut n_ok = 0;
    for _ in 0..20_000 {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let Some(ds) = em.sample_direct(&[], Vec3::new(0.3, -0.2, 1.0), u) else {
            continue;
        };
        n_ok += 1;
        assert!(!ds.delta && ds.dist.is_infinite());
        assert!((ds.d.length() - 1.0).abs() < 1e-4);
        let pdf = em.pdf_direct_env(ds.d);
        assert!(
            (pdf - ds.pdf).abs() <= 2e-3 * ds.pdf,
            "sampled pdf {} vs pdf_direct_env {pdf} at {}",
            ds.pdf,
            ds.d
        );
        let e = em.eval_env(ds.d);
        assert!(
            (e - ds.value).abs().max_element() <= 2e-3 * e.max_element().max(1e-2),
            "value {} vs eval {e}",
            ds.value
        );
    }
    assert!(n_ok > 19_900, "only {n_ok} valid samples");
}

#[test]
fn envmap_sampled_directions_follow_pdf_direct_env_chi_square() {
    // The reported density must be the density the sampler really draws from. The density is
    // constant in (u, v) on the fixture's 64 × 31 patches between texel centres (u from
    // (i + ½)/64, v from j/31), so bins made of whole patches get exact expected counts:
    // p(u, v) = pdf_ω · 2π² sin θ, evaluated at patch centres.
    let rot = rot_y(25.0);
    let em = Emitter::EnvMap(fixture_light(1.0, rot));
    let (w, bands) = (64usize, 31usize);
    let pi = std::f64::consts::PI;
    let patch_p = |i: usize, j: usize| -> f64 {
        let u = ((i as f64 + 1.0) / w as f64) % 1.0;
        let v = (j as f64 + 0.5) / bands as f64;
        let pdf = em.pdf_direct_env(rot * dir_of(u as f32, v as f32)) as f64;
        pdf * 2.0 * pi * pi * (pi * v).sin() / (w * bands) as f64
    };
    // Bins: 2 patches in u × 1 band in v.
    let (bu, bv) = (w / 2, bands);
    let mut expect = vec![0f64; bu * bv];
    let mut total = 0.0;
    for j in 0..bands {
        for i in 0..w {
            let p = patch_p(i, j);
            expect[j * bu + i / 2] += p;
            total += p;
        }
    }
    assert!(
        (total - 1.0).abs() < 1e-4,
        "pdf_direct_env integrates to {total}"
    );
    let n = 300_000;
    let mut counts = vec![0f64; bu * bv];
    let mut rng = Pcg32::new(17, 3);
    let mut failed = 0;
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let Some(ds) = em.sample_direct(&[], Vec3::ZERO, u) else {
            // Only at a pole (sin θ = 0 in f32): must be very rare.
            failed += 1;
            continue;
        };
        let uv = EnvMapLight::uv_of_local(rot.transpose() * ds.d);
        // Patch column: u measured from the first texel centre.
        let x = (uv.x as f64 * w as f64 - 0.5).rem_euclid(w as f64);
        let i = (x as usize).min(w - 1);
        let j = ((uv.y as f64 * bands as f64) as usize).min(bands - 1);
        counts[j * bu + i / 2] += 1.0;
    }
    assert!(failed <= n / 10_000, "{failed} failed samples");
    let n = (n - failed) as f64;
    let (mut chi2, mut dof, mut pooled) = (0.0, 0usize, (0.0f64, 0.0f64));
    for (e, o) in expect.iter().zip(&counts) {
        let e = e * n;
        if e < 5.0 {
            pooled.0 += o;
            pooled.1 += e;
            continue;
        }
        chi2 += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pooled.1 >= 5.0 {
        chi2 += (pooled.0 - pooled.1).powi(2) / pooled.1;
        dof += 1;
    }
    let k = (dof - 1) as f64;
    let crit = chi2_critical(k, 4.75);
    assert!(chi2 < crit, "chi2 {chi2:.1} with {k} dof exceeds {crit:.1}");
}

/// ∫ L dω over the sphere by the midpoint rule in (u, v) (nu × nv points), through `eval_env`.
fn sphere_integral(em: &Emitter, to_world: Mat3, nu: usize, nv: usize) -> [f64; 3] {
    let mut acc = [0f64; 3];
    let pi = std::f64::consts::PI;
    for j in 0..nv {
        let v = (j as f64 + 0.5) / nv as f64;
        let jac = 2.0 * pi * pi * (pi * v).sin() / (nu * nv) as f64;
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let l = em.eval_env(to_world * dir_of(u as f32, v as f32));
            for c in 0..3 {
                acc[c] += l[c] as f64 * jac;
            }
        }
    }
    acc
}

/// E[L / pdf] over `n` light samples, with its standard error.
fn mc_integral(em: &Emitter, n: usize, seed: u64) -> ([f64; 3], [f64; 3]) {
    let mut rng = Pcg32::new(seed, 11);
    let (mut s, mut s2) = ([0f64; 3], [0f64; 3]);
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if let Some(ds) = em.sample_direct(&[], Vec3::ZERO, u) {
            for c in 0..3 {
                let x = ds.value[c] as f64 / ds.pdf as f64;
                s[c] += x;
                s2[c] += x * x;
            }
        }
    }
    let nf = n as f64;
    let mean = s.map(|x| x / nf);
    let se = [0, 1, 2].map(|c| ((s2[c] / nf - mean[c] * mean[c]).max(0.0) / nf).sqrt());
    (mean, se)
}

#[test]
fn envmap_estimator_is_unbiased_for_the_sphere_integral() {
    let rot = rot_y(-35.0);
    let em = Emitter::EnvMap(fixture_light(1.5, rot));
    let exact = sphere_integral(&em, rot, 1024, 512);
    let (mean, se) = mc_integral(&em, 400_000, 1);
    for c in 0..3 {
        let z = (mean[c] - exact[c]) / se[c];
        assert!(
            z.abs() < 4.0,
            "channel {c}: MC {} ± {} vs quadrature {} (z = {z:.2})",
            mean[c],
            se[c],
            exact[c]
        );
        // Importance sampling by luminance × sin θ: the estimator is not noisy.
        assert!(se[c] / mean[c] < 2e-3, "relative error {}", se[c] / mean[c]);
    }
    // The power estimate uses the same integral: mean luminance = ∫ Y dω / 4π.
    let Emitter::EnvMap(m) = &em else {
        unreachable!()
    };
    let y = 0.212671 * exact[0] + 0.715160 * exact[1] + 0.072169 * exact[2];
    let mean_y = y / (4.0 * std::f64::consts::PI);
    assert!(
        (m.mean_luminance() as f64 - mean_y).abs() < 0.02 * mean_y,
        "mean luminance {} vs {mean_y}",
        m.mean_luminance()
    );
}

#[test]
fn envmap_with_one_bright_texel_at_a_pole_and_zero_rows_is_unbiased() {
    // 8×4 map: black except one texel in the first row (the +y pole) and one in the third.
    let (w, h) = (8, 4);
    let mut px = vec![[0.0f32; 3]; w * h];
    px[3] = [10.0, 5.0, 1.0];
    px[2 * w + 6] = [0.0, 0.0, 4.0];
    let light = EnvMapLight::new(w, h, &px, 1.0, Mat3::IDENTITY).unwrap();
    let em = Emitter::EnvMap(light);
    let exact = sphere_integral(&em, Mat3::IDENTITY, 2048, 1024);
    let (mean, se) = mc_integral(&em, 400_000, 2);
    for c in 0..3 {
        let z = (mean[c] - exact[c]) / se[c].max(1e-12);
        assert!(
            z.abs() < 4.0 || (mean[c] - exact[c]).abs() < 1e-4 * exact[c],
            "channel {c}: MC {} ± {} vs quadrature {} (z = {z:.2})",
            mean[c],
            se[c],
            exact[c]
        );
    }
    // Directions where the map is black have zero density only if L is zero there too.
    let mut rng = Pcg32::new(9, 9);
    for _ in 0..10_000 {
        let d = dir_of(rng.next_f32(), rng.next_f32());
        // (Exactly at a pole, where f32 rounding gives sin θ = 0, the density is 0: a set of
        // measure zero that BSDF sampling covers alone.)
        if d.y.abs() < 0.99999 && em.eval_env(d).max_element() > 0.0 {
            assert!(em.pdf_direct_env(d) > 0.0, "L > 0 but pdf 0 at {d}");
        }
    }
}

#[test]
fn envmap_bad_input_is_a_scene_error_at_the_emitter() {
    let dir = scratch("envbad");
    // Missing file.
    load_err(
        "env_missing",
        r#"    <emitter type="envmap"><string name="filename" value="nope.exr"/></emitter>"#,
        4,
        "nope.exr",
    );
    // Corrupt file.
    let corrupt = dir.join("corrupt.exr");
    std::fs::write(&corrupt, b"this is not an EXR file").unwrap();
    load_err(
        "env_corrupt",
        &format!(
            r#"    <emitter type="envmap"><string name="filename" value="{}"/></emitter>"#,
            corrupt.display()
        ),
        4,
        "cannot read envmap",
    );
    // Not an EXR.
    let png = dir.join("sky.png");
    std::fs::write(&png, b"x").unwrap();
    load_err(
        "env_png",
        &format!(
            r#"    <emitter type="envmap"><string name="filename" value="{}"/></emitter>"#,
            png.display()
        ),
        4,
        "unsupported image format",
    );
    // NaN texel, zero power, negative texel.
    let write = |name: &str, px: Vec<[f32; 3]>| -> PathBuf {
        let p = dir.join(name);
        let img = groove::film::Image {
            width: 4,
            height: 2,
            data: px,
        };
        groove::output::write_image(&p, &img, &Default::default()).unwrap();
        p
    };
    let mut px = vec![[1.0f32; 3]; 8];
    px[5] = [f32::NAN, 0.0, 0.0];
    let nan = write("nan.exr", px);
    let zero = write("zero.exr", vec![[0.0f32; 3]; 8]);
    let mut px = vec![[1.0f32; 3]; 8];
    px[2] = [-1.0, 0.0, 0.0];
    let neg = write("neg.exr", px);
    for (name, file, msg) in [
        ("env_nan", &nan, "not finite"),
        ("env_zero", &zero, "emits no light"),
        ("env_neg", &neg, "negative"),
    ] {
        load_err(
            name,
            &format!(
                r#"    <emitter type="envmap"><string name="filename" value="{}"/></emitter>"#,
                file.display()
            ),
            4,
            msg,
        );
    }
    let fx = fixture();
    load_err(
        "env_scale",
        &format!(
            r#"    <emitter type="envmap"><string name="filename" value="{}"/><float name="scale" value="-1"/></emitter>"#,
            fx.display()
        ),
        4,
        "scale",
    );
    load_err(
        "env_shear",
        &format!(
            r#"    <emitter type="envmap"><string name="filename" value="{}"/><transform name="to_world"><scale x="2"/></transform></emitter>"#,
            fx.display()
        ),
        4,
        "rotation",
    );
    load_err(
        "env_nofile",
        r#"    <emitter type="envmap"/>"#,
        4,
        "filename",
    );
}

// ------------------------------------------------------------------------------ spot

#[test]
fn spot_falloff_matches_mitsuba() {
    // Mitsuba 3.9.1 spot, cutoff 20° (beam_width default ¾·20 = 15°), intensity 1, light at the
    // origin looking along +z, reference point at distance 1 and angle θ: sample_direction weight.
    let scene = load(
        "spot_default",
        r#"<emitter type="spot"><float name="cutoff_angle" value="20"/></emitter>"#,
    );
    let em = &scene.emitters()[0];
    let mitsuba = [
        (0.0, 1.0),
        (5.0, 1.0),
        (14.0, 1.0),
        (15.0, 1.0),
        (16.0, 0.8000000715255737),
        (17.5, 0.4999993145465851),
        (19.0, 0.1999989002943039),
        (19.9, 0.019999822601675987),
        (20.0, 0.0),
        (21.0, 0.0),
        (90.0, 0.0),
    ];
    for (deg, want) in mitsuba {
        let t = (deg as f32).to_radians();
        let p = Vec3::new(t.sin(), 0.0, t.cos());
        let got = em
            .sample_direct(scene.shapes(), p, Vec2::splat(0.5))
            .map_or(0.0, |ds| {
                assert!(ds.delta && ds.pdf == 1.0);
                assert!((ds.dist - 1.0).abs() < 1e-5);
                assert!((ds.d + p).length() < 1e-5);
                ds.value.x
            });
        assert!(
            (got - want as f32).abs() < 2e-4,
            "θ = {deg}°: {got} vs Mitsuba {want}"
        );
    }
    // The default cutoff is 20°, and the value falls off with 1/d².
    let scene = load(
        "spot_defaults2",
        r#"<emitter type="spot"><rgb name="intensity" value="4, 8, 12"/>
        <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>"#,
    );
    let em = &scene.emitters()[0];
    let ds = em
        .sample_direct(scene.shapes(), Vec3::ZERO, Vec2::ZERO)
        .unwrap();
    assert!(
        (ds.value - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5,
        "{}",
        ds.value
    );
    assert!((ds.d - Vec3::Y).length() < 1e-6);
    let t = 17.5f32.to_radians();
    let p = Vec3::new(2.0 * t.tan(), 0.0, 0.0); // 17.5° off the axis
    let ds = em.sample_direct(scene.shapes(), p, Vec2::ZERO).unwrap();
    let d2 = 4.0 + p.x * p.x;
    assert!((ds.value.x - 4.0 * 0.5 / d2).abs() < 1e-4, "{}", ds.value);
    assert!(!em.is_environment());
    assert_eq!(em.eval_env(Vec3::Y), Spectrum::ZERO);
}

#[test]
fn spot_power_is_intensity_times_cone_solid_angle() {
    let pi = std::f32::consts::PI;
    // beam = cutoff: a hard-edged cone.
    let s = SpotLight::new(Vec3::ZERO, Mat3::IDENTITY, Vec3::ONE, None, 0.5, 0.5);
    assert!((s.solid_angle() - 2.0 * pi * (1.0 - 0.5f32.cos())).abs() < 1e-5);
    // With a ramp: between the two hard cones.
    let s = SpotLight::new(Vec3::ZERO, Mat3::IDENTITY, Vec3::ONE, None, 0.5, 0.2);
    let (lo, hi) = (
        2.0 * pi * (1.0 - 0.2f32.cos()),
        2.0 * pi * (1.0 - 0.5f32.cos()),
    );
    assert!(s.solid_angle() > lo && s.solid_angle() < hi);
    let em = Emitter::Spot(s.clone());
    let lum = 1.0; // luminance of white
    assert!((em.power(&[], 1.0) - lum * s.solid_angle()).abs() < 1e-6);
}

#[test]
fn spot_bad_angles_and_textures_are_scene_errors() {
    load_err(
        "spot_neg",
        r#"    <emitter type="spot"><float name="cutoff_angle" value="-5"/></emitter>"#,
        4,
        "cutoff_angle",
    );
    load_err(
        "spot_big",
        r#"    <emitter type="spot"><float name="cutoff_angle" value="200"/></emitter>"#,
        4,
        "cutoff_angle",
    );
    load_err(
        "spot_beam",
        r#"    <emitter type="spot"><float name="cutoff_angle" value="20"/><float name="beam_width" value="30"/></emitter>"#,
        4,
        "beam_width",
    );
    load_err(
        "spot_nan",
        r#"    <emitter type="spot"><float name="beam_width" value="nan"/></emitter>"#,
        4,
        "",
    );
    load_err(
        "spot_tex",
        r#"    <emitter type="spot">
        <texture type="checkerboard" name="intensity"/></emitter>"#,
        5,
        "'intensity' cannot be spatially varying",
    );
    load_err(
        "spot_unused",
        r#"    <emitter type="spot"><point name="position" value="0, 1, 0"/></emitter>"#,
        4,
        "position",
    );
}

// ------------------------------------------------------------------------------ directional

#[test]
fn directional_is_a_delta_light_at_infinity() {
    let scene = load(
        "dir",
        r#"<emitter type="directional"><vector name="direction" value="1, -1, 0"/>
        <rgb name="irradiance" value="2, 3, 4"/></emitter>"#,
    );
    let em = &scene.emitters()[0];
    // Mitsuba 3.9.1: ds.d = (−0.707107, 0.707107, 0), pdf 1, delta, weight = irradiance.
    for p in [
        Vec3::ZERO,
        Vec3::new(0.3, 0.0, 0.0),
        Vec3::new(-5.0, 2.0, 7.0),
    ] {
        let ds = em
            .sample_direct(scene.shapes(), p, Vec2::new(0.3, 0.9))
            .unwrap();
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert!((ds.d - Vec3::new(-s, s, 0.0)).length() < 1e-6, "{}", ds.d);
        assert!(ds.delta && ds.pdf == 1.0 && ds.dist.is_infinite() && ds.n.is_none());
        assert_eq!(ds.value, Vec3::new(2.0, 3.0, 4.0));
    }
    // Not seen by escaping rays; no density for MIS.
    assert!(!em.is_environment());
    assert!(scene.env_emitters().is_empty());
    assert_eq!(
        em.eval_env(Vec3::new(-1.0, 1.0, 0.0).normalize()),
        Spectrum::ZERO
    );
    assert_eq!(
        em.pdf_direct_env(Vec3::new(-1.0, 1.0, 0.0).normalize()),
        0.0
    );
    // Power: irradiance × π r² of the scene's bounding sphere.
    let r = scene.bsphere().1;
    let y = 0.212671 * 2.0 + 0.715160 * 3.0 + 0.072169 * 4.0;
    let pw = em.power(scene.shapes(), r);
    assert!((pw - std::f32::consts::PI * r * r * y).abs() < 1e-4 * pw);

    // Default (Mitsuba: travels along +z) and `to_world`.
    let scene = load("dir_default", r#"<emitter type="directional"/>"#);
    let ds = scene.emitters()[0]
        .sample_direct(scene.shapes(), Vec3::ZERO, Vec2::ZERO)
        .unwrap();
    assert!((ds.d + Vec3::Z).length() < 1e-6 && ds.value == Vec3::ONE);
    let scene = load(
        "dir_tw",
        r#"<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>"#,
    );
    let ds = scene.emitters()[0]
        .sample_direct(scene.shapes(), Vec3::ZERO, Vec2::ZERO)
        .unwrap();
    // rotate(x, 90°) maps +z to −y: light travels down, the shadow ray goes up.
    assert!((ds.d - Vec3::Y).length() < 1e-6, "{}", ds.d);
}

#[test]
fn directional_bad_input_is_a_scene_error() {
    load_err(
        "dir_zero",
        r#"    <emitter type="directional"><vector name="direction" value="0, 0, 0"/></emitter>"#,
        4,
        "non-zero",
    );
    load_err(
        "dir_both",
        r#"    <emitter type="directional"><vector name="direction" value="0, 0, 1"/>
        <transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>"#,
        4,
        "not both",
    );
    load_err(
        "dir_neg",
        r#"    <emitter type="directional"><rgb name="irradiance" value="1, -1, 1"/></emitter>"#,
        4,
        "irradiance",
    );
}

// ------------------------------------------------------------------------------ light selection

#[test]
fn light_selection_gives_the_dim_envmap_and_the_bright_area_light_fair_shares() {
    let path = repo().join("tests/data/scenes/light_envmap_area.xml");
    let scene = load_scene(&path, &LoadOptions::default()).unwrap().scene;
    assert_eq!(scene.emitters().len(), 2);
    let env = scene.env_emitters()[0] as usize;
    let area = 1 - env;
    let (pe, pa) = (
        scene.light_sampler().pmf(env),
        scene.light_sampler().pmf(area),
    );
    assert!((pe + pa - 1.0).abs() < 1e-6);
    // Both get a real share: half by power, half uniform, so each gets at least 1/(2N).
    assert!(
        pe >= 0.25 - 1e-6 && pa >= 0.25 - 1e-6,
        "env {pe}, area {pa}"
    );
    let r = scene.bsphere().1;
    let p_env = scene.emitters()[env].power(scene.shapes(), r);
    let p_area = scene.emitters()[area].power(scene.shapes(), r);
    let want_env = 0.5 * p_env / (p_env + p_area) + 0.25;
    assert!((pe - want_env).abs() < 1e-5, "env {pe} vs {want_env}");
}

/// An `area` emitter without `radiance` emits 1, as Mitsuba 3.9.1's default
/// (`get_emissive_texture("radiance", 1.f)`); found loading mitsuba-data's scenes.
#[test]
fn area_radiance_defaults_to_one() {
    let d = scratch("area_default");
    let f = d.join("a.xml");
    std::fs::write(
        &f,
        r#"<scene version="3.0.0"><sensor type="perspective"/>
           <shape type="sphere"><emitter type="area"/></shape></scene>"#,
    )
    .unwrap();
    let loaded = load_scene(&f, &LoadOptions::default()).expect("loads");
    let Emitter::Area(a) = &loaded.scene.emitters()[0] else {
        panic!("an area light")
    };
    match &a.radiance {
        groove::texture::Texture::Constant(c) => assert_eq!(*c, Spectrum::ONE),
        t => panic!("constant radiance expected, got {t:?}"),
    }
}
