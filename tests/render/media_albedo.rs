//! A `homogeneous` medium with a `gridvolume` albedo (looked up at each scattering point, σt
//! constant) against Mitsuba 3.9.1 `scalar_rgb` references (`tests/refs/media_albedo_grid.exr`
//! under `volpath`, `media_albedo_grid_mis.exr` under `volpathmis`, `media_albedo_grid_nonee.exr`
//! with `sample_emitters` off, `media_albedo_grid_grey*.exr` with `has_spectral_extinction` off),
//! with sensitivity
//! variants that must be rejected: the grid mirrored in x, and a constant albedo at the grid's
//! mean; and the same bits at one and two threads for media scenes. Run in release mode:
//! `cargo test --release --test render media_albedo`.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene, Rendered};

fn comparison(r: &Rendered, reference: &str) -> common::imgcmp::Comparison {
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("{reference}: {}", c.report());
    c
}

/// The scene with its albedo grid replaced by the constant at the grid's mean (per channel, as
/// `tests/refs/make_volumes.py` prints it): same mean albedo, no spatial variation.
fn constant_albedo(text: String) -> String {
    let start = text
        .find("<volume type=\"gridvolume\"")
        .expect("the albedo grid");
    let end = start + text[start..].find("</volume>").expect("its end") + "</volume>".len();
    format!(
        "{}<rgb name=\"albedo\" value=\"0.383057, 0.55, 0.725\"/>{}",
        &text[..start],
        &text[end..]
    )
}

#[test]
fn homogeneous_medium_with_a_grid_albedo_matches_mitsuba() {
    let scene = test_scene("media_albedo_grid.xml");
    let r = render_scene(&scene, &[], 512, 81, 0, |_| {});
    comparison(&r, "media_albedo_grid").assert_consistent("media_albedo_grid.xml, 512 spp");
    let r = render_scene(&scene, &[("integrator", "volpathmis")], 512, 82, 0, |_| {});
    comparison(&r, "media_albedo_grid_mis")
        .assert_consistent("media_albedo_grid.xml, volpathmis, 512 spp");
}

/// Without next-event estimation in the medium (`sample_emitters` off, as in Mitsuba's
/// `medium_homogeneous_sss_textured.xml`): light reaches scattering points only by phase sampling.
#[test]
fn grid_albedo_without_emitter_sampling_matches_mitsuba() {
    let r = render_scene(
        &test_scene("media_albedo_grid.xml"),
        &[("sample_emitters", "false")],
        512,
        86,
        0,
        |_| {},
    );
    comparison(&r, "media_albedo_grid_nonee")
        .assert_consistent("media_albedo_grid.xml, no emitter sampling, 512 spp");
}

/// `has_spectral_extinction` off with a chromatic σt (Mitsuba's grey shortcut): shadow rays see
/// exp(−σt_c·d) in every channel for the path's channel c, under `volpath` and `volpathmis`
/// (`media_albedo_grid_grey*.exr`). The spectral render must not pass as the grey one.
#[test]
fn grey_extinction_shortcut_matches_mitsuba() {
    let scene = test_scene("media_albedo_grid.xml");
    let grey = [("sample_emitters", "false"), ("spectral", "false")];
    let r = render_scene(&scene, &grey, 512, 87, 0, |_| {});
    comparison(&r, "media_albedo_grid_grey")
        .assert_consistent("media_albedo_grid.xml, grey extinction, 512 spp");
    let mis = [grey[0], grey[1], ("integrator", "volpathmis")];
    let r = render_scene(&scene, &mis, 512, 88, 0, |_| {});
    comparison(&r, "media_albedo_grid_grey_mis")
        .assert_consistent("media_albedo_grid.xml, grey extinction, volpathmis, 512 spp");
    let spectral = render_scene(&scene, &grey[..1], 512, 89, 0, |_| {});
    assert!(
        !comparison(&spectral, "media_albedo_grid_grey").is_consistent(),
        "the spectral render passed as the grey-extinction reference"
    );
}

/// Sensitivity: the grid mirrored in x, and a constant albedo at the grid's mean, each differ
/// from the `volpath` reference by more than the noise.
#[test]
fn the_grid_albedo_comparison_sees_the_grid_and_its_variation() {
    let scene = test_scene("media_albedo_grid.xml");
    let r = render_scene(
        &scene,
        &[("grid", "albedo_grid_flipped")],
        256,
        83,
        0,
        |_| {},
    );
    assert!(
        !comparison(&r, "media_albedo_grid").is_consistent(),
        "the mirrored grid was accepted"
    );
    let r = render_scene_edited(&scene, constant_albedo, 256, 84);
    assert!(
        !comparison(&r, "media_albedo_grid").is_consistent(),
        "a constant albedo at the grid's mean was accepted"
    );
}

/// Deterministic streams through media: one seed gives the same bits at one and two threads,
/// under `volpath` (the grid albedo; the heterogeneous grids' delta and ratio tracking) and
/// `volpathmis`.
#[test]
fn media_renders_are_identical_at_one_and_two_threads() {
    let bits = |r: &Rendered| -> Vec<u64> {
        r.mean
            .data
            .iter()
            .flat_map(|p| p.iter().map(|c| c.to_bits()))
            .collect()
    };
    for (scene, defines) in [
        ("media_albedo_grid.xml", &[][..]),
        ("media_albedo_grid.xml", &[("integrator", "volpathmis")][..]),
        ("media_hetero.xml", &[][..]),
    ] {
        let a = render_scene(&test_scene(scene), defines, 8, 85, 1, |_| {});
        let b = render_scene(&test_scene(scene), defines, 8, 85, 2, |_| {});
        assert_eq!(b.stats.threads, 2);
        assert!(
            bits(&a) == bits(&b),
            "{scene} {defines:?}: 1 and 2 threads differ"
        );
    }
}
