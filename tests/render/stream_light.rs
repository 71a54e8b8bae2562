//! Light sampling in lanes (issue 18, "emitters and the light sampler in lanes"): the light
//! selection 8-wide (counted over few emitters, searched lane by lane over many, none needed
//! for one) and the triangles of a mesh light picked, gathered and sampled 8-wide give the
//! scalar renderer's image bit for bit. `stream_mesh_lights.xml` (five emitters: a ball of 288
//! triangles with vertex normals, an octahedron without, a flipped cube, a rectangle, a sphere)
//! and `stream_mesh_lights_many.xml` (eleven), over the diffuse, conductor, plastic and blend
//! kernels, as written and under the settings variants, at both lane widths; the Cornell box
//! (one mesh light) is in `tests/render/stream.rs`.

use super::stream::{
    assert_identical, kinds_in_lanes, load, render, render_with, settings_variants,
};
use crate::common::test_scene;
use groove::render::{RenderOptions, Renderer};
use groove::stream::Packets;

const SCENES: [&str; 2] = ["stream_mesh_lights.xml", "stream_mesh_lights_many.xml"];

/// The stream image equals the scalar one at 1, 2, 3 and 7 threads, as written and under the
/// stratified sampler, the light-only and BSDF-only strategies and early Russian roulette; the
/// counters saw triangles, rectangles and spheres sampled in lanes (none under BSDF-only), so
/// a silent fallback to the scalar emitters fails.
#[test]
fn stream_equals_scalar_with_mesh_lights_in_lanes() {
    for name in SCENES {
        let mut cases = vec![("as written", load(&test_scene(name), "as_written"))];
        cases.extend(settings_variants(name));
        for (label, l) in &cases {
            let spp = l.settings.sampler.sample_count.min(3);
            let lanes = assert_identical(l, &format!("{name} ({label})"), spp);
            let want: &[&str] = if *label == "bsdf only" {
                &[]
            } else {
                &["triangles", "rectangle", "sphere"]
            };
            assert_eq!(kinds_in_lanes(&lanes), want, "{name} ({label}): {lanes:?}");
        }
    }
}

/// At lane width 8 too (the default is 16 on a CPU with AVX-512): the 8-wide gathers of the
/// triangle pick give the scalar image.
#[test]
fn stream_mesh_lights_at_width_8_equal_scalar() {
    for name in SCENES {
        let l = load(&test_scene(name), "as_written");
        let scalar = render(&l, Renderer::Scalar, 1, 3);
        for threads in [1, 3] {
            let s8 = render_with(
                &l,
                RenderOptions {
                    threads,
                    spp: Some(3),
                    seed: Some(7),
                    renderer: Renderer::Stream,
                    packets: Some(Packets::default_for(&l.scene)),
                    lanes: Some(8),
                    ..Default::default()
                },
            );
            assert_eq!(s8, scalar, "{name}: width 8 at {threads} threads");
            assert!(s8.lanes.kernel_lights[0] > 0, "{name}: {:?}", s8.lanes);
        }
    }
}
