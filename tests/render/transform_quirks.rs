//! Mitsuba 3.9.1's transform quirks on the analytic shapes and on instances
//! (`tests/data/scenes/rotate_shapes.xml`, reference `tests/refs/rotate_shapes.exr` by
//! tests/refs/make_refs.py): a rectangle, a disk and an instance under `<rotate>`s with non-unit
//! axes, and spheres under a non-uniform scale and a shear. Each quirk is also shown to be seen:
//! the scene with that one `<rotate>` replaced by a `<matrix>` of the same values (which groove
//! treats with the true inverse transpose, as it treated these shapes before matching Mitsuba) is
//! rejected, and so is the scaled sphere replaced by the similar one of the same radius. Run with
//! `cargo test --release --test render transform_quirks`.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};
use glam::Vec3;
use groove::scene::xml::transform::rotate_raw;

/// `<matrix>` of Mitsuba's `<rotate>` matrix for `axis` and `angle` (degrees), row-major.
pub(crate) fn rotate_as_matrix(axis: Vec3, angle: f32) -> String {
    let m = rotate_raw(axis, angle);
    let mut v = Vec::new();
    for row in 0..3 {
        for col in 0..3 {
            v.push(m.col(col)[row].to_string());
        }
        v.push("0".into());
    }
    v.extend(["0", "0", "0", "1"].map(String::from));
    format!(r#"<matrix value="{}"/>"#, v.join(" "))
}

#[test]
fn analytic_shapes_and_instances_under_mitsubas_transform_quirks_match_mitsuba() {
    let scene = test_scene("rotate_shapes.xml");
    let (m, v) = load_reference("rotate_shapes");
    let r = render_scene(&scene, &[], 1024, 161, 0, |l| {
        let count = |s: &str| l.warnings.iter().filter(|w| w.contains(s)).count();
        assert_eq!(count("<rotate> axis"), 3, "{:?}", l.warnings);
        assert_eq!(count("shouldn't contain non-uniform scaling"), 2);
        assert_eq!(count("shouldn't contain any shearing"), 1);
    });
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("rotate_shapes: {}", c.report());
    c.assert_consistent("rotate_shapes.xml");

    // Each quirk changes the image: the same matrix with the true inverse transpose is rejected.
    let quirks = [
        (
            "rectangle",
            r#"<rotate x="0.7" z="1" angle="90"/>"#,
            Vec3::new(0.7, 0.0, 1.0),
            90.0,
        ),
        (
            "disk",
            r#"<rotate y="1" z="1" angle="-60"/>"#,
            Vec3::new(0.0, 1.0, 1.0),
            -60.0,
        ),
        (
            "instance",
            r#"<rotate x="1" y="1" z="1" angle="40"/>"#,
            Vec3::ONE,
            40.0,
        ),
    ];
    for (k, (what, rotate, axis, angle)) in quirks.into_iter().enumerate() {
        let plain = render_scene_edited(
            &scene,
            |t| t.replace(rotate, &rotate_as_matrix(axis, angle)),
            1024,
            162 + k as u64,
        );
        let c = compare(&plain.mean, &plain.var, &m, &v, 4);
        assert!(
            !c.is_consistent(),
            "the {what} with the true inverse transpose was accepted"
        );
    }

    // The scaled sphere's uv map goes through the transform: the similar sphere of the same
    // centre and radius (0.35), whose checkerboard follows the unit direction, is rejected.
    let similar = render_scene_edited(
        &scene,
        |t| {
            t.replace(
                r#"<scale x="0.35" y="0.5" z="0.6"/>"#,
                r#"<scale value="0.35"/>"#,
            )
        },
        1024,
        166,
    );
    let c = compare(&similar.mean, &similar.var, &m, &v, 4);
    assert!(!c.is_consistent(), "the similar sphere was accepted");
}
