//! The curve shapes `linearcurve` and `bsplinecurve` (`tests/data/scenes/shape_curves.xml`,
//! reference `tests/refs/shape_curves.exr`) and the `hair` BSDF on B-spline fibers
//! (`mat_hair.xml`, `mat_hair.exr`) against Mitsuba 3.9.1.

use crate::common;
use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};

#[test]
fn curves_match_mitsuba() {
    // Linear curves (zigzag, taper, loop; to_world scales positions, not radii) with a uv
    // checkerboard; B-spline curves (helix, wave with zero-radius ends) in rough gold and
    // again with a uv checkerboard.
    let r = render_scene(&test_scene("shape_curves.xml"), &[], 1024, 47, 0, |_| {});
    let (m, v) = load_reference("shape_curves");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("shape_curves: {}", c.report());
    c.assert_consistent("shape_curves.xml, 1024 spp");
}

#[test]
fn the_curve_comparison_sees_the_uv_phase() {
    // Sensitivity: each checkerboard shifted by half a checker (u on the linear curves, v on
    // the diffuse B-spline curves) is rejected, so the comparison pins down where u = 0 lies
    // around a curve and how v runs along its segments.
    let (m, v) = load_reference("shape_curves");
    for (from, to, what) in [
        (
            r#"<scale x="4" y="9"/>"#,
            r#"<translate x="0.125"/><scale x="4" y="9"/>"#,
            "linear u + 1/8",
        ),
        (
            r#"<scale x="4" y="12"/>"#,
            r#"<translate y="0.0417"/><scale x="4" y="12"/>"#,
            "B-spline v + 1/24",
        ),
    ] {
        let r = render_scene_edited(
            &test_scene("shape_curves.xml"),
            |s| s.replace(from, to),
            1024,
            48,
        );
        let c = compare(&r.mean, &r.var, &m, &v, 4);
        eprintln!("shape_curves, {what}: {}", c.report());
        assert!(!c.is_consistent(), "{what} was accepted");
    }
}

#[test]
fn hair_on_curves_matches_mitsuba() {
    // Default brown and blonde fibers, and a thick helix with sigma_a (R, TT, TRT resolved).
    let r = render_scene(&test_scene("mat_hair.xml"), &[], 1024, 49, 0, |_| {});
    let (m, v) = load_reference("mat_hair");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("mat_hair: {}", c.report());
    c.assert_consistent("mat_hair.xml, 1024 spp");
}

#[test]
fn the_hair_comparison_sees_the_cuticle_tilt() {
    // Sensitivity: the blonde fibers' scales untilted (scale_tilt 0 instead of 4 degrees, which
    // moves the R and TRT highlights along the fiber) are rejected.
    let r = render_scene(
        &test_scene("mat_hair.xml"),
        &[("tilt", "0")],
        1024,
        50,
        0,
        |_| {},
    );
    let (m, v) = load_reference("mat_hair");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("mat_hair, scale_tilt 0: {}", c.report());
    assert!(!c.is_consistent(), "scale_tilt 0 was accepted");
}
