//! Materials at Mitsuba 3 parity: the BSDF families (rough and smooth conductors, rough and smooth
//! dielectrics, thin dielectric, plastic and rough plastic) and the real shared Cornell boxes
//! rendered by groove against Mitsuba 3.9.1 `scalar_rgb` references (tests/refs/mat_*.exr and
//! cbox_values / cbox_spectral, made by tests/refs/make_refs.py; numbers in tests/refs/README.md).
//! Every material scene is lit by an area light and a dim constant environment.
//! Run in release mode: `cargo test --release --test render materials -- --nocapture`.

use crate::common;

use common::{compare, load_reference, mean_and_var_of_mean, read_exr_rgb, render_scene, RgbImage};
use std::path::PathBuf;

/// Samples per pixel of every groove render here (64×64: about a second on 2 cores).
const SPP: u32 = 512;

fn matches_reference(r: &common::Rendered, reference: &str, block: usize, what: &str) {
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, block);
    println!("{what} vs {reference}:\n{}", c.report());
    c.assert_consistent(what);
}

fn scene_matches(scene: &str, defines: &[(&str, &str)], seed: u64, reference: &str) {
    let r = render_scene(&common::test_scene(scene), defines, SPP, seed, 0, |_| {});
    let what = format!("{scene} {defines:?}");
    matches_reference(&r, reference, 8, &what);
}

fn shared_cbox_file(name: &str) -> PathBuf {
    common::repo_root()
        .join("..")
        .join("shared")
        .join("scenes")
        .join("mitsuba_cbox")
        .join(name)
}

#[test]
fn rough_gold_ggx_alphas_match_mitsuba() {
    scene_matches(
        "mat_roughconductor.xml",
        &[("distribution", "ggx")],
        301,
        "mat_roughconductor_ggx",
    );
}

#[test]
fn rough_gold_beckmann_alphas_match_mitsuba() {
    scene_matches(
        "mat_roughconductor.xml",
        &[("distribution", "beckmann")],
        302,
        "mat_roughconductor_beckmann",
    );
}

#[test]
fn explicit_eta_k_anisotropic_and_smooth_conductors_match_mitsuba() {
    scene_matches("mat_metals.xml", &[], 303, "mat_metals");
}

#[test]
fn rough_glass_over_checkerboard_matches_mitsuba() {
    scene_matches("mat_roughglass.xml", &[], 304, "mat_roughglass");
}

#[test]
fn smooth_glass_sphere_and_thin_pane_match_mitsuba() {
    scene_matches("mat_glass.xml", &[], 305, "mat_glass");
}

#[test]
fn plastic_and_roughplastic_match_mitsuba() {
    scene_matches("mat_plastic.xml", &[], 306, "mat_plastic");
}

#[test]
fn plastic_and_roughplastic_nonlinear_match_mitsuba() {
    scene_matches(
        "mat_plastic.xml",
        &[("nonlinear", "true")],
        307,
        "mat_plastic_nl",
    );
}

/// `cbox-spectral.xml` (includes; wavelength:value spectra; box filter), loaded unchanged.
#[test]
fn shared_cbox_spectral_matches_mitsuba() {
    let r = render_scene(
        &shared_cbox_file("cbox-spectral.xml"),
        &[("res", "64")],
        SPP,
        308,
        0,
        |_| {},
    );
    matches_reference(&r, "cbox_spectral", 8, "cbox-spectral.xml at 64x64");
}

/// Averages of `t`×`t` pixel tiles.
fn tile_means(img: &RgbImage, t: usize) -> RgbImage {
    let (w, h) = (img.width / t, img.height / t);
    let mut out = RgbImage::new(w, h);
    for y in 0..h * t {
        for x in 0..w * t {
            let p = img.get(x, y);
            let o = &mut out.data[(y / t) * w + x / t];
            for c in 0..3 {
                o[c] += p[c] / (t * t) as f64;
            }
        }
    }
    out
}

/// `cbox.xml` (wavelength:value spectra, converted to RGB) loaded unchanged. It uses the gaussian
/// reconstruction filter, so neighbouring pixels are correlated and per-pixel variances summed
/// over a tile would underestimate the tile's variance. Both sides are therefore compared as
/// 8×8-tile averages whose variance comes from the scatter over independent renders: Mitsuba 16
/// seeds (tests/refs/cbox_values.t8*.exr), groove 32 seeds × 16 spp here.
#[test]
fn shared_cbox_wavelength_values_matches_mitsuba() {
    const T: usize = 8;
    // Loaded once, rendered 32 times (16 spp each, seeds 400..431).
    let opts = groove::load::options::LoadOptions {
        defines: [("res".to_string(), "64".to_string())]
            .into_iter()
            .collect(),
        ..Default::default()
    };
    let loaded =
        groove::load::load_scene(&shared_cbox_file("cbox.xml"), &opts).expect("loading cbox.xml");
    let renders: Vec<RgbImage> = (0..32u64)
        .map(|s| {
            let ro = groove::render::RenderOptions {
                threads: 0,
                spp: Some(16),
                seed: Some(400 + s),
                renderer: crate::common::renderer(),
                ..Default::default()
            };
            let out = groove::render::render(&loaded.scene, &loaded.settings, &ro).expect("render");
            let img = out.film.develop();
            let mut rgb = RgbImage::new(img.width as usize, img.height as usize);
            for (o, p) in rgb.data.iter_mut().zip(&img.data) {
                *o = [p[0] as f64, p[1] as f64, p[2] as f64];
            }
            tile_means(&rgb, T)
        })
        .collect();
    let (m, v) = mean_and_var_of_mean(&renders);
    let dir = common::repo_root().join("tests").join("refs");
    let rm = read_exr_rgb(&dir.join(format!("cbox_values.t{T}.exr")));
    let rv = read_exr_rgb(&dir.join(format!("cbox_values.t{T}.var.exr")));
    let c = compare(&m, &v, &rm, &rv, 1);
    println!("cbox.xml at 64x64, 8x8 tiles:\n{}", c.report());
    c.assert_consistent("cbox.xml (wavelength:value spectra) at 64x64, 8x8 tile averages");
}

/// `principled` (anisotropic metal with a checkerboard roughness, rough glass via `spec_trans`,
/// clearcoat, sheen, the documented all-parameter mix) and a `principledthin` sheet.
#[test]
fn principled_and_principledthin_match_mitsuba() {
    scene_matches("mat_principled.xml", &[], 309, "mat_principled");
}

/// Sensitivity check: the thin sheet with `diff_trans` 0.7 instead of 1 (a little less light
/// through it, a little more reflected) must be rejected.
#[test]
fn the_principled_comparison_sees_the_thin_sheets_diffuse_transmission() {
    let r = render_scene(
        &common::test_scene("mat_principled.xml"),
        &[("diff_trans", "0.7")],
        SPP,
        310,
        0,
        |_| {},
    );
    let (m, v) = load_reference("mat_principled");
    let c = compare(&r.mean, &r.var, &m, &v, 8);
    println!("mat_principled.xml with diff_trans 0.7:\n{}", c.report());
    assert!(!c.is_consistent(), "diff_trans 0.7 was accepted");
}
