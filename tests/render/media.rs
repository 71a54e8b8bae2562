//! Participating media under `volpath` against Mitsuba 3.9.1 references (tests/refs/media_*.exr,
//! made by tests/refs/make_refs.py): a homogeneous hg sphere behind a null boundary, the sensor
//! and an emitter inside a fog, a dielectric with an absorbing interior; and a white furnace
//! (albedo 1, no reference: every pixel is 1); heterogeneous media (`gridvolume`, delta and ratio
//! tracking) against `tests/refs/media_hetero.exr`, and a chromatic heterogeneous white furnace.
//! Each has a sensitivity check that the comparison sees the feature. Run in release mode: `cargo test --release --test render media`.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene, Rendered};

fn comparison(r: &Rendered, reference: &str) -> common::imgcmp::Comparison {
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("{reference}: {}", c.report());
    c
}

#[test]
fn homogeneous_sphere_behind_a_null_boundary_matches_mitsuba() {
    let r = render_scene(&test_scene("media_sphere.xml"), &[], 512, 61, 0, |_| {});
    comparison(&r, "media_sphere").assert_consistent("media_sphere.xml, 512 spp");
}

#[test]
fn sensor_and_emitter_inside_a_fog_match_mitsuba() {
    let r = render_scene(&test_scene("media_fog.xml"), &[], 512, 62, 0, |_| {});
    comparison(&r, "media_fog").assert_consistent("media_fog.xml, 512 spp");
}

#[test]
fn dielectric_with_an_absorbing_interior_matches_mitsuba() {
    let r = render_scene(&test_scene("media_glass.xml"), &[], 512, 63, 0, |_| {});
    comparison(&r, "media_glass").assert_consistent("media_glass.xml, 512 spp");
}

/// Sensitivity: an isotropic phase function instead of hg, the sensor outside the fog, and clear
/// glass (no interior medium) each differ from their reference by more than the noise.
#[test]
fn the_comparisons_see_the_phase_function_the_sensor_medium_and_the_interior() {
    let r = render_scene(
        &test_scene("media_sphere.xml"),
        &[("g", "0")],
        256,
        64,
        0,
        |_| {},
    );
    assert!(
        !comparison(&r, "media_sphere").is_consistent(),
        "g = 0 was accepted"
    );
    let r = render_scene_edited(
        &test_scene("media_fog.xml"),
        |t| t.replacen(r#"<ref id="fog"/>"#, "", 1),
        256,
        65,
    );
    assert!(
        !comparison(&r, "media_fog").is_consistent(),
        "a sensor outside the fog was accepted"
    );
    let r = render_scene_edited(
        &test_scene("media_glass.xml"),
        |t| t.replace(r#"<ref name="interior" id="tint"/>"#, ""),
        256,
        66,
    );
    assert!(
        !comparison(&r, "media_glass").is_consistent(),
        "clear glass was accepted"
    );
}

/// Per channel: the largest |pixel − 1| in standard errors, and the image mean's deviation.
pub(crate) fn furnace_deviation(r: &Rendered) -> (f64, [f64; 3]) {
    let mut worst: f64 = 0.0;
    let mut mean_z = [0.0; 3];
    let n = r.mean.data.len() as f64;
    for c in 0..3 {
        let (mut s, mut v) = (0.0, 0.0);
        for (m, var) in r.mean.data.iter().zip(&r.var.data) {
            s += m[c];
            v += var[c];
            if var[c] > 0.0 {
                worst = worst.max((m[c] - 1.0).abs() / var[c].sqrt());
            } else {
                assert_eq!(m[c], 1.0, "a noise-free pixel must be exactly 1");
            }
        }
        mean_z[c] = (s / n - 1.0) / (v / (n * n)).sqrt();
    }
    (worst, mean_z)
}

/// White furnace: an albedo-1 medium (grey extinction, so that every path's weight is its
/// Russian-roulette factor alone; hg) inside a constant environment
/// of radiance 1 renders 1: the image mean within 3σ per channel, and no pixel beyond 4.5σ
/// (256 pixels × 3 channels). With albedo 0.95 the mean falls detectably below 1.
#[test]
fn albedo_one_medium_in_a_white_furnace_renders_one() {
    let scene = test_scene("media_furnace.xml");
    let r = render_scene(&scene, &[], 1024, 67, 0, |_| {});
    let (worst, z) = furnace_deviation(&r);
    eprintln!("furnace: worst pixel {worst:.2} σ, image mean {z:?} σ");
    assert!(z.iter().all(|z| z.abs() < 3.0), "image mean off 1: {z:?} σ");
    assert!(worst < 4.5, "a pixel is {worst:.2} σ off 1");

    let r = render_scene(&scene, &[("albedo", "0.95")], 1024, 68, 0, |_| {});
    let (_, z) = furnace_deviation(&r);
    eprintln!("furnace, albedo 0.95: image mean {z:?} σ");
    assert!(
        z.iter().all(|z| *z < -3.0),
        "albedo 0.95 was not seen: {z:?} σ"
    );
}

/// Two heterogeneous media (a smooth 1-channel trilinear grid, a 3-channel nearest checkerboard)
/// under an area light: delta tracking on camera and bounce rays, ratio tracking on shadow rays.
#[test]
fn heterogeneous_grids_match_mitsuba() {
    let r = render_scene(&test_scene("media_hetero.xml"), &[], 512, 69, 0, |_| {});
    comparison(&r, "media_hetero").assert_consistent("media_hetero.xml, 512 spp");
}

/// Sensitivity: the smooth grid with x and y exchanged (`blob_transposed.vol`: also what a wrong
/// index order would render), and a density scale of 4.5 instead of 6, each differ from the
/// reference by more than the noise.
#[test]
fn the_heterogeneous_comparison_sees_the_grid_order_and_the_density() {
    let variants: [(&[(&str, &str)], &str); 2] = [
        (&[("grid", "blob_transposed")], "the transposed grid"),
        (&[("scale", "4.5")], "scale 4.5"),
    ];
    for (i, (defines, what)) in variants.into_iter().enumerate() {
        let r = render_scene(
            &test_scene("media_hetero.xml"),
            defines,
            256,
            70 + i as u64,
            0,
            |_| {},
        );
        assert!(
            !comparison(&r, "media_hetero").is_consistent(),
            "{what} was accepted"
        );
    }
}

/// White furnace in a chromatic heterogeneous medium (see `media_furnace_hetero.xml`): the image
/// mean is 1 within 3σ per channel; albedo 0.95 is detected.
#[test]
fn albedo_one_heterogeneous_medium_in_a_white_furnace_renders_one() {
    let scene = test_scene("media_furnace_hetero.xml");
    let r = render_scene(&scene, &[], 1024, 72, 0, |_| {});
    let (worst, z) = furnace_deviation(&r);
    eprintln!("heterogeneous furnace: worst pixel {worst:.2} σ, image mean {z:?} σ");
    assert!(z.iter().all(|z| z.abs() < 3.0), "image mean off 1: {z:?} σ");
    // No per-pixel 4.5σ bound here: a path's weight is a product of per-collision ratios up to
    // 20 apart, so a pixel's z-score, from its own sample variance, is far from Gaussian in the
    // tail; the image mean (256 pixels) is. Only a gross outlier fails.
    assert!(worst < 8.0, "a pixel is {worst:.2} σ off 1");

    let r = render_scene(&scene, &[("albedo", "0.95")], 1024, 73, 0, |_| {});
    let (_, z) = furnace_deviation(&r);
    eprintln!("heterogeneous furnace, albedo 0.95: image mean {z:?} σ");
    assert!(
        z.iter().all(|z| *z < -3.0),
        "albedo 0.95 was not seen: {z:?} σ"
    );
}
