//! Spot, directional and environment-map lighting rendered by groove against Mitsuba 3.9.1
//! references (tests/refs/light_*.exr, made by tests/refs/make_refs.py), and the envmap's
//! densities checked inside the integrator: light sampling only, BSDF sampling only and MIS must
//! agree. Run in release mode: `cargo test --release --test render lights`.

use crate::common;

use common::{compare, load_reference, render_scene, test_scene};
use groove::integrator::{IntegratorDesc, Strategy};

fn matches_reference(r: &common::Rendered, reference: &str, block: usize, what: &str) {
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, block);
    println!("{what}:\n{}", c.report());
    c.assert_consistent(what);
}

fn set_strategy(s: Strategy) -> impl FnOnce(&mut groove::load::Loaded) {
    move |loaded| match &mut loaded.settings.integrator {
        IntegratorDesc::Path(p) => p.strategy = s,
        other => panic!("expected a path integrator, got {other:?}"),
    }
}

#[test]
fn spot_and_directional_lights_match_mitsuba() {
    let r = render_scene(&test_scene("light_spot_dir.xml"), &[], 512, 21, 0, |_| {});
    matches_reference(&r, "light_spot_dir", 8, "light_spot_dir.xml");
}

#[test]
fn envmap_lighting_matches_mitsuba() {
    let r = render_scene(&test_scene("light_envmap.xml"), &[], 512, 22, 0, |_| {});
    matches_reference(&r, "light_envmap", 8, "light_envmap.xml");
}

#[test]
fn dim_envmap_beside_a_bright_area_light_matches_mitsuba() {
    let r = render_scene(
        &test_scene("light_envmap_area.xml"),
        &[],
        512,
        23,
        0,
        |_| {},
    );
    matches_reference(&r, "light_envmap_area", 8, "light_envmap_area.xml");
}

#[test]
fn envmap_light_only_and_bsdf_only_agree_with_mitsuba() {
    // Light sampling alone relies on sample_direct's pdf, BSDF sampling alone on eval_env; MIS
    // (tested above) also on pdf_direct_env. All three must give the same image.
    let scene = test_scene("light_envmap.xml");
    let light = render_scene(&scene, &[], 512, 24, 0, set_strategy(Strategy::LightOnly));
    let bsdf = render_scene(&scene, &[], 512, 25, 0, set_strategy(Strategy::BsdfOnly));
    matches_reference(&light, "light_envmap", 8, "envmap, light sampling only");
    matches_reference(&bsdf, "light_envmap", 8, "envmap, BSDF sampling only");
}

#[test]
fn envmap_from_an_rgbe_file_matches_mitsuba() {
    let r = render_scene(&test_scene("light_envmap_hdr.xml"), &[], 256, 34, 0, |_| {});
    matches_reference(&r, "light_envmap_hdr", 4, "light_envmap_hdr.xml");
}

#[test]
fn projector_matches_mitsuba() {
    // A non-square bitmap projected obliquely (uv convention, aspect, 1/(z² cos θ), scale).
    let r = render_scene(&test_scene("light_projector.xml"), &[], 512, 141, 0, |_| {});
    matches_reference(&r, "light_projector", 8, "light_projector.xml");
}

#[test]
fn textured_spot_matches_mitsuba() {
    let r = render_scene(&test_scene("light_spot_tex.xml"), &[], 512, 142, 0, |_| {});
    matches_reference(&r, "light_spot_tex", 8, "light_spot_tex.xml");
}

#[test]
fn area_light_with_zero_area_triangles_matches_mitsuba() {
    // The reference is Mitsuba's render of the mesh with five zero-area triangles; groove must
    // match it with and without them.
    let scene = test_scene("degenerate_mesh.xml");
    let with = render_scene(&scene, &[], 512, 143, 0, |_| {});
    matches_reference(&with, "degenerate_mesh", 4, "degenerate_mesh.xml");
    let without = render_scene(&scene, &[("mesh", "quad_emit.obj")], 512, 143, 0, |_| {});
    matches_reference(
        &without,
        "degenerate_mesh",
        4,
        "degenerate_mesh.xml, clean quad",
    );
}
