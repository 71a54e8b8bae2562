//! Textured rendering against Mitsuba 3.9.1: bitmap reflectances (bilinear on a rectangle;
//! nearest + mirror + `to_uv` on a sphere) under a constant environment. Statistical comparison
//! with `common::imgcmp` (see tests/refs/README.md). Run in release mode.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};

#[test]
fn textured_quad_and_sphere_match_mitsuba() {
    let r = render_scene(&test_scene("textured_quad.xml"), &[], 256, 21, 0, |_| {});
    let (m, v) = load_reference("textured_quad");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("textured_quad: {}", c.report());
    c.assert_consistent("textured_quad.xml, 256 spp");
}

#[test]
fn the_comparison_sees_a_vertically_flipped_texture() {
    // Sensitivity check: the same scene with the picture's v flipped must be rejected, so the
    // test above really pins the texture's orientation (uv (0, 0) = first stored row).
    // uv -> (u, 1 - v) through the bitmap's `to_uv`: the picture's rows flipped.
    let r = render_scene_edited(
        &test_scene("textured_quad.xml"),
        |t| {
            t.replace(
                r#"<string name="filename" value="../textures/render8x6.png"/>"#,
                r#"<string name="filename" value="../textures/render8x6.png"/>
        <transform name="to_uv"><scale y="-1"/><translate y="1"/></transform>"#,
            )
        },
        64,
        22,
    );
    let (m, v) = load_reference("textured_quad");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("flipped: {}", c.report());
    assert!(!c.is_consistent(), "a flipped texture was accepted");
}

#[test]
fn hdr_and_pfm_bitmaps_match_mitsuba() {
    // RGBE (run-length), colour PFM (big-endian, nearest), grey PFM (little-endian, scale −0.5).
    let r = render_scene(&test_scene("tex_hdr_pfm.xml"), &[], 256, 31, 0, |_| {});
    let (m, v) = load_reference("tex_hdr_pfm");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("tex_hdr_pfm: {}", c.report());
    c.assert_consistent("tex_hdr_pfm.xml, 256 spp");
}

#[test]
fn mesh_attribute_and_rawconstant_match_mitsuba() {
    let r = render_scene(&test_scene("tex_mesh_attr.xml"), &[], 256, 32, 0, |_| {});
    let (m, v) = load_reference("tex_mesh_attr");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("tex_mesh_attr: {}", c.report());
    c.assert_consistent("tex_mesh_attr.xml, 256 spp");
}

#[test]
fn the_comparison_sees_a_wrong_face_attribute_scale() {
    // Sensitivity check: the blend weight read from the face attribute at a third of its scale
    // must be rejected, so the test above pins the per-face values.
    let r = render_scene_edited(
        &test_scene("tex_mesh_attr.xml"),
        |t| {
            t.replace(
                r#"<float name="scale" value="0.9"/>"#,
                r#"<float name="scale" value="0.3"/>"#,
            )
        },
        64,
        33,
    );
    let (m, v) = load_reference("tex_mesh_attr");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("wrong scale: {}", c.report());
    assert!(!c.is_consistent(), "a wrong attribute scale was accepted");
}
