//! `principled` and `principledthin` against Mitsuba 3.9.1 point evaluations
//! (tests/data/principled_points.json, written by tests/refs/principled_points.py from Mitsuba's
//! own `eval` and `pdf` in `scalar_rgb`, both transport modes). Each parameter set is loaded from
//! its XML through groove's loader, so the parameter names, defaults, Mitsuba's η/specular rules
//! and the texture slots are checked along with the model.

use std::path::Path;

use glam::{Vec2, Vec3};
use groove::bsdf::{BsdfArena, BsdfContext, TransportMode};
use groove::geometry::SurfaceInteraction;
use groove::load::instantiate;
use groove::math::Frame;
use groove::sampler::Sampler;
use groove::scene::xml::parse::load_str;
use serde_json::Value;

fn data() -> Value {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/principled_points.json");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    assert_eq!(v["mitsuba"], "3.9.1");
    v
}

fn v3(v: &Value) -> Vec3 {
    let a: Vec<f32> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect();
    Vec3::new(a[0], a[1], a[2])
}

/// The material of a one-sphere scene whose BSDF is `bsdf_xml`.
fn load(bsdf_xml: &str) -> (groove::material::Materials, u32) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scene.xml");
    let scene = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor><shape type=\"sphere\">{bsdf_xml}</shape></scene>"
    );
    let doc = load_str(&scene, &path, &[]).unwrap();
    let s = instantiate(&doc, &path).unwrap().scene;
    let m = s.shape_materials()[0];
    (s.materials().clone(), m)
}

fn si_at(uv: Vec2) -> SurfaceInteraction {
    let sh = Frame {
        s: Vec3::X,
        t: Vec3::Y,
        n: Vec3::Z,
    };
    SurfaceInteraction {
        p: Vec3::ZERO,
        t: 1.0,
        ng: Vec3::Z,
        sh,
        uv,
        dpdu: Vec3::X,
        dpdv: Vec3::Y,
        shape: 0,
        prim: 0,
        wi: Vec3::Z,
    }
}

fn check_model(model: &str, min_points: usize) {
    let d = data();
    let mut s = Sampler::from_seed(5, 0);
    let (mut n, mut nonzero, mut worst) = (0, 0, 0.0f32);
    let mut fails = Vec::new();
    for case in d[model].as_array().unwrap() {
        let xml = case["xml"].as_str().unwrap();
        let (materials, mat) = load(xml);
        for p in case["points"].as_array().unwrap() {
            let uv = p["uv"].as_array().unwrap();
            let uv = Vec2::new(
                uv[0].as_f64().unwrap() as f32,
                uv[1].as_f64().unwrap() as f32,
            );
            let mode = if p["mode"].as_u64().unwrap() == 0 {
                TransportMode::Radiance
            } else {
                TransportMode::Importance
            };
            let ctx = BsdfContext { mode };
            let mut arena = BsdfArena::new();
            let root = materials.build(mat, &si_at(uv), &mut arena);
            let b = arena.bsdf(root);
            let (wi, wo) = (v3(&p["wi"]), v3(&p["wo"]));
            let (e, pdf) = (b.eval(&ctx, wi, wo, &mut s), b.pdf(&ctx, wi, wo));
            let (ep, pp) = b.eval_pdf(&ctx, wi, wo, &mut s);
            assert_eq!((e, pdf), (ep, pp), "eval_pdf differs from eval and pdf");
            let (re, rp) = (v3(&p["eval"]), p["pdf"].as_f64().unwrap() as f32);
            // Relative error with a floor (absolute near 0): f32 rounding of the large GGX
            // peaks and of the 1/(4 cos) Jacobians dominates.
            let err_e = ((e - re).abs() / re.abs().max(Vec3::splat(1e-2))).max_element();
            let err_p = (pdf - rp).abs() / rp.abs().max(1e-2);
            let err = err_e.max(err_p);
            worst = worst.max(err);
            n += 1;
            nonzero += usize::from(re.max_element() > 0.0);
            if err.is_nan() || err >= 2e-4 {
                fails.push(format!(
                    "{xml}\n  uv {uv} mode {mode:?} wi {wi} wo {wo}: eval {e} vs {re}, pdf {pdf} vs {rp}"
                ));
            }
        }
    }
    assert!(
        fails.is_empty(),
        "{} of {n} points differ:\n{}",
        fails.len(),
        fails[..fails.len().min(20)].join("\n")
    );
    assert!(
        n >= min_points && nonzero * 4 >= n,
        "{n} points, {nonzero} non-zero"
    );
    eprintln!("{model}: {n} points ({nonzero} non-zero), worst relative difference {worst:.2e}");
}

#[test]
fn principled_matches_mitsuba_pointwise() {
    check_model("principled", 1500);
}

#[test]
fn principledthin_matches_mitsuba_pointwise() {
    check_model("principledthin", 1000);
}

/// The loader's error for a one-sphere scene with BSDF `bsdf_xml` (None if it loads).
fn load_error(bsdf_xml: &str) -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scene.xml");
    let scene = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor><shape type=\"sphere\">{bsdf_xml}</shape></scene>"
    );
    let doc = load_str(&scene, &path, &[]).ok()?;
    instantiate(&doc, &path).err().map(|e| e.to_string())
}

#[test]
fn bad_parameters_are_errors_with_their_location() {
    let cases = [
        (
            r#"<bsdf type="principled"><float name="metalic" value="1"/></bsdf>"#,
            "unreferenced property 'metalic'",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="1.5"/><float name="specular" value="0.5"/></bsdf>"#,
            "either 'eta' or 'specular'",
        ),
        (
            r#"<bsdf type="principled"><texture type="checkerboard" name="eta"/></bsdf>"#,
            "is not expected inside bsdf 'principled'",
        ),
        (
            r#"<bsdf type="principled"><rgb name="base_color" value="1.5, 0.2, 0.2"/></bsdf>"#,
            "must be in the range [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><rgb name="roughness" value="0.5"/></bsdf>"#,
            "expected <float>",
        ),
        (
            r#"<bsdf type="principled"><float name="clearcoat_sampling_rate" value="-1"/></bsdf>"#,
            "must be a number >= 0",
        ),
        (
            r#"<bsdf type="principledthin"><float name="metallic" value="0.5"/></bsdf>"#,
            "unreferenced property 'metallic'",
        ),
        (
            r#"<bsdf type="principledthin"><bsdf type="diffuse" name="base_color"/></bsdf>"#,
            "expects a value or a <texture>",
        ),
    ];
    for (xml, want) in cases {
        let e = load_error(xml).unwrap_or_else(|| panic!("{xml} loaded"));
        assert!(e.contains(want), "{xml}: {e}");
        // FILE:LINE:COL
        assert!(e.contains("scene.xml:1:"), "{xml}: {e}");
    }
    assert_eq!(
        load_error(
            r#"<bsdf type="principledthin"><texture type="checkerboard" name="eta"><float name="color0" value="1.3"/><float name="color1" value="1.6"/></texture></bsdf>"#
        ),
        None
    );
}
