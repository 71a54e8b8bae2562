//! The stream renderer's `blendbsdf` kernel (issue 18, thirteenth session, h4):
//! `tests/data/scenes/stream_blend.xml` (blends of diffuse + roughconductor, plastic +
//! dielectric, roughplastic + twosided(conductor) under a bitmap weight of 0, 1 and values
//! between, twosided(blend) with textured children, roughdielectric + thindielectric under a
//! checkerboard weight of 0 and 1) gives the scalar image bit for bit at 1, 2, 3 and 7 threads,
//! under `path` (every setting that changes a vertex) and `direct`, and the kernel shaded (its
//! counter counts only the paths it shaded, so a fallback to the 1-lane code fails).

use super::stream::{as_direct, assert_identical, load, variants_of};
use crate::common::test_scene;

fn blends() -> groove::load::Loaded {
    load(&test_scene("stream_blend.xml"), "as_written")
}

#[test]
fn stream_equals_scalar_where_blends_run_in_lanes() {
    let lanes = assert_identical(&blends(), "stream_blend", 8);
    assert!(
        lanes.blend_lanes > 0 && lanes.blend_lanes <= lanes.kernel_lanes,
        "{lanes:?}"
    );
}

/// Under the light-only and BSDF-only strategies, Russian roulette from the first bounce and
/// the stratified sampler (whose first vertex draws lane by lane).
#[test]
fn stream_equals_scalar_for_blends_under_every_setting() {
    for (label, l) in &variants_of(blends) {
        let lanes = assert_identical(l, &format!("stream_blend ({label})"), 4);
        assert!(lanes.blend_lanes > 0, "{label}: the kernel never ran");
    }
}

/// The `direct` integrator's tail: one light and one BSDF sample per hit, with and without
/// `hide_emitters`.
#[test]
fn stream_equals_scalar_for_blends_under_direct() {
    for (label, hide) in [("1, 1", false), ("1, 1, hidden", true)] {
        let l = as_direct(blends(), 1, 1, hide);
        let lanes = assert_identical(&l, &format!("stream_blend direct ({label})"), 4);
        assert!(lanes.blend_lanes > 0, "{label}: the kernel never ran");
    }
}
