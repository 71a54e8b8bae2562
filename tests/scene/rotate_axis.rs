//! `<rotate>` with a non-unit axis, as Mitsuba 3.9.1 does it (see src/scene/xml/transform.rs):
//! the unnormalised Rodrigues matrix, mesh normals transformed by the matrix itself (Mitsuba's
//! stored inverse transpose) and the spot light's `to_world.inverse()` built from it; numbers
//! read off Mitsuba 3.9.1 `scalar_rgb`. Run with `cargo test --release --test scene rotate_axis`.

use std::path::PathBuf;

use glam::{Vec2, Vec3};
use groove::geometry::ShapeKind;
use groove::load::options::LoadOptions;
use groove::load::{load_scene, Loaded};
use groove::scene::xml::transform::rotate_raw;

fn load_body(name: &str, body: &str) -> Loaded {
    let dir = crate::common::Scratch::new(&format!("groove_rotate_{}_{name}", std::process::id()));
    let text = format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n{body}\n<sensor type=\"perspective\"/>\n</scene>\n"
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, text).unwrap();
    load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn quad() -> String {
    let f = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/geometry/quad.obj");
    f.display().to_string()
}

#[test]
fn mesh_positions_and_normals_follow_mitsubas_matrices() {
    let loaded = load_body(
        "mesh",
        &format!(
            r#"<shape type="obj"><string name="filename" value="{}"/>
<transform name="to_world"><scale x="2" y="1" z="0.5"/>
<rotate x="1" y="0.5" z="1" angle="50"/><translate x="0.5"/></transform></shape>"#,
            quad()
        ),
    );
    let ShapeKind::Mesh(m) = &loaded.scene.shapes()[0].kind else {
        panic!("expected a mesh");
    };
    // Mitsuba 3.9.1: vertex_positions_buffer() and vertex_normals_buffer().
    let want_p = [
        [-0.9125618, -2.621392, -0.893031],
        [3.087438, 1.1572106, -0.9962703],
        [1.9125618, 2.621392, 0.893031],
        [-2.087438, -1.1572106, 0.9962703],
    ];
    let want_n = Vec3::new(0.5380102, -0.4269562, 0.7268104);
    for (p, w) in m.positions.iter().zip(want_p) {
        assert!((*p - Vec3::from(w)).length() < 1e-5, "{p} vs {w:?}");
    }
    for n in m.normals.as_ref().expect("the quad has normals") {
        assert!((*n - want_n).length() < 1e-5, "{n} vs {want_n}");
    }
    // The true inverse transpose would tilt the normal elsewhere: the quirk is what is tested.
    let r = rotate_raw(Vec3::new(1.0, 0.5, 1.0), 50.0);
    let true_n = (r.inverse().transpose() * Vec3::new(0.0, 0.0, 2.0)).normalize();
    assert!((true_n - want_n).length() > 0.05);
    // One located warning, at the <rotate> (line 5 of the scene file).
    let w: Vec<_> = loaded
        .warnings
        .iter()
        .filter(|w| w.contains("<rotate> axis"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", loaded.warnings);
    assert!(w[0].contains(":5:"), "{}", w[0]);
}

#[test]
fn spot_light_frames_follow_mitsubas_inverse() {
    let loaded = load_body(
        "spot",
        r#"<emitter type="spot"><transform name="to_world"><rotate x="0" y="2" z="0" angle="30"/>
<rotate x="1" angle="90"/><translate y="1"/></transform>
<float name="cutoff_angle" value="60"/><float name="beam_width" value="10"/></emitter>
<emitter type="spot"><transform name="to_world"><rotate x="1" angle="90"/>
<rotate x="1" y="1" angle="30"/><translate y="1"/></transform>
<float name="cutoff_angle" value="60"/><float name="beam_width" value="10"/></emitter>"#,
    );
    // Mitsuba 3.9.1 `sample_direction` weights (intensity 1) from three points.
    let points = [[0.3, -0.5, 0.2], [-0.2, 0.0, 0.4], [0.5, 0.2, -0.3]];
    let want = [[0.180753, 0.0, 0.71271], [0.182507, 0.20026, 0.466765]];
    let scene = &loaded.scene;
    for (e, w) in want.iter().enumerate() {
        for (p, w) in points.iter().zip(w) {
            let v = scene.emitters()[e]
                .sample_direct(scene.shapes(), Vec3::from(*p), Vec2::ZERO)
                .map_or(0.0, |s| s.value.x);
            assert!(
                (v - w).abs() < 2e-5 * w.max(1.0),
                "spot {e} at {p:?}: {v} vs {w}"
            );
        }
    }
    assert_eq!(
        loaded
            .warnings
            .iter()
            .filter(|w| w.contains("<rotate> axis"))
            .count(),
        2
    );
}

#[test]
fn raw_rotation_is_rodrigues_with_the_axis_as_given() {
    // cos·I + sin·[a]× + (1 − cos)·a·aᵀ: along the axis a scale of cos + (1 − cos)|a|².
    let a = Vec3::new(0.0, 0.5, 0.5);
    let r = rotate_raw(a, 70.0);
    let c = 70f32.to_radians().cos();
    let along = r * a.normalize();
    assert!((along - a.normalize() * (c + (1.0 - c) * 0.5)).length() < 1e-6);
    // A unit axis gives the rotation.
    let u = rotate_raw(Vec3::Y, 30.0);
    assert!(u.abs_diff_eq(glam::Mat3::from_rotation_y(30f32.to_radians()), 1e-6));
}

#[test]
fn cube_shading_normals_follow_mitsubas_matrix() {
    // Mitsuba 3.9.1 `ray_intersect` of a `cube` under <rotate x="1" y="0.5" z="1" angle="50"/>
    // from (0.05, 0.1, 5) along −z: t 3.0942419, n = the face's true normal, sh_frame.n the
    // quirky one.
    let loaded = load_body(
        "cube",
        r#"<shape type="cube"><transform name="to_world">
<rotate x="1" y="0.5" z="1" angle="50"/></transform></shape>"#,
    );
    let ray = groove::geometry::Ray::new(Vec3::new(0.05, 0.1, 5.0), Vec3::NEG_Z);
    let si = loaded.scene.intersect(&ray).expect("cube hit");
    assert!((si.t - 3.0942419).abs() < 1e-5, "t {}", si.t);
    let n = Vec3::new(-0.492758, 0.540267, 0.68213);
    let sh = Vec3::new(-0.441122, 0.549745, 0.709361);
    assert!((si.ng - n).length() < 1e-5, "ng {}", si.ng);
    assert!((si.sh.n - sh).length() < 1e-5, "sh {}", si.sh.n);
}
