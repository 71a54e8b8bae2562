//! Textured rendering against Mitsuba 3.9.1: bitmap reflectances (bilinear on a rectangle;
//! nearest + mirror + `to_uv` on a sphere) under a constant environment. Statistical comparison
//! with `common::imgcmp` (see tests/refs/README.md). Run in release mode.

use crate::common;

use common::{compare, load_reference, render_scene, test_scene};

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
    let r = render_scene(&test_scene("textured_quad.xml"), &[], 64, 22, 0, |loaded| {
        let t = &mut loaded.scene.materials.textures;
        let i = t
            .iter()
            .position(|t| {
                t.as_bitmap()
                    .is_some_and(|b| b.source().ends_with("render8x6.png"))
            })
            .expect("the picture texture");
        let b = t[i].as_bitmap().unwrap();
        let (w, h) = b.resolution();
        let flipped: Vec<_> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, h - 1 - y)))
            .map(|(x, y)| b.texel(x, y))
            .collect();
        let opts = groove::texture::BitmapOptions::default();
        t[i] = groove::texture::BitmapTexture::from_texels(w, h, flipped, false, &opts).into();
    });
    let (m, v) = load_reference("textured_quad");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("flipped: {}", c.report());
    assert!(!c.is_consistent(), "a flipped texture was accepted");
}
