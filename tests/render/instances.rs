//! `shapegroup` + `instance` rendered by groove against a Mitsuba 3.9.1 reference
//! (tests/refs/shape_instance.exr, made by tests/refs/make_refs.py): a mesh, a sphere and a cube
//! placed four times (translated; rotated and scaled; non-uniformly scaled, which makes the
//! sphere an ellipsoid; mirrored), casting shadows under an area light. Run in release mode:
//! `cargo test --release --test render instance`.

use crate::common;

use common::{compare, load_reference, render_scene, test_scene};

#[test]
fn instances_of_a_shape_group_match_mitsuba() {
    let r = render_scene(&test_scene("shape_instance.xml"), &[], 1024, 47, 0, |_| {});
    let (m, v) = load_reference("shape_instance");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("shape_instance: {}", c.report());
    c.assert_consistent("shape_instance.xml, 1024 spp");
}

#[test]
fn the_instance_comparison_sees_a_wrong_scale() {
    // Sensitivity: the third instance 7% wider along x (1.6 instead of 1.5) is rejected.
    let r = render_scene(
        &test_scene("shape_instance.xml"),
        &[("sx", "1.6")],
        1024,
        48,
        0,
        |_| {},
    );
    let (m, v) = load_reference("shape_instance");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("shape_instance, sx 1.6: {}", c.report());
    assert!(!c.is_consistent(), "a 7% wider instance was accepted");
}
