//! Mitsuba 3.9.1's transform quirks on the analytic shapes and on instances, point by point: a
//! `<rotate>` with a non-unit axis on a `rectangle` (shading normal by the raw matrix), a `disk`
//! (intersected in the quirky object space) and an `instance` (normals by the raw matrix, the
//! member evaluated for the quirkily mapped ray), and `sphere`s whose `to_world` is not a
//! similarity (kept a sphere, uv through the transform) or mirrors (normals flipped). Every
//! number was read off Mitsuba 3.9.1 `scalar_rgb` `scene.ray_intersect` for the same ray (from
//! `o` along −z). Run with `cargo test --release --test scene transform_quirks`.

// The numbers are Mitsuba's printed output (six digits), some of which happen to be 1/√2.
#![allow(clippy::approx_constant)]

use glam::{Vec2, Vec3};
use groove::geometry::{Ray, SurfaceInteraction};
use groove::load::options::LoadOptions;
use groove::load::{load_scene, Loaded};

fn load_body(name: &str, body: &str) -> Loaded {
    let dir = crate::common::Scratch::new(&format!("groove_quirks_{}_{name}", std::process::id()));
    let text = format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n{body}\n<sensor type=\"perspective\"/>\n</scene>\n"
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, text).unwrap();
    load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Mitsuba's interaction for one ray: t, p, n, sh_frame.n, uv, dp_du.
struct Want {
    t: f32,
    p: [f32; 3],
    n: [f32; 3],
    sh: [f32; 3],
    uv: [f32; 2],
    dpdu: [f32; 3],
}

fn check(what: &str, si: &SurfaceInteraction, w: &Want) {
    let close = |a: Vec3, b: [f32; 3], tol: f32| (a - Vec3::from(b)).length() <= tol;
    assert!(
        (si.t - w.t).abs() < 1e-5,
        "{what}: t {} (Mitsuba {})",
        si.t,
        w.t
    );
    assert!(close(si.p, w.p, 1e-5), "{what}: p {}", si.p);
    assert!(close(si.ng, w.n, 1e-5), "{what}: n {}", si.ng);
    assert!(close(si.sh.n, w.sh, 1e-5), "{what}: sh {}", si.sh.n);
    assert!(
        (si.uv - Vec2::from(w.uv)).length() < 1e-5,
        "{what}: uv {}",
        si.uv
    );
    let scale = Vec3::from(w.dpdu).length();
    // Mitsuba printed six significant digits.
    assert!(
        close(si.dpdu, w.dpdu, 1e-5 * scale),
        "{what}: dpdu {}",
        si.dpdu
    );
}

fn hit(loaded: &Loaded, o: [f32; 3]) -> SurfaceInteraction {
    let ray = Ray::new(Vec3::from(o), Vec3::NEG_Z);
    loaded.scene.intersect(&ray).expect("a hit")
}

#[test]
fn rectangle_shading_normal_follows_mitsubas_matrix() {
    let l = load_body(
        "rect",
        r#"<shape type="rectangle"><transform name="to_world">
<rotate x="1" z="1" angle="60"/></transform></shape>"#,
    );
    let want = Want {
        t: 4.832154,
        p: [0.1, 0.2, 0.167846],
        n: [0.267261, -0.694365, 0.668153],
        sh: [0.353553, -0.612372, 0.707107],
        uv: [0.589282, 0.545359],
        dpdu: [2.0, 1.73205, 1.0],
    };
    check("rectangle", &hit(&l, [0.1, 0.2, 5.0]), &want);
}

#[test]
fn disk_is_intersected_in_mitsubas_quirky_object_space() {
    let body = r#"<shape type="disk"><transform name="to_world">
<rotate y="1" z="1" angle="-60"/></transform></shape>"#;
    let l = load_body("disk", body);
    let want = Want {
        t: 5.013398,
        p: [0.1, 0.2, -0.0133976],
        n: [-0.612372, 0.353553, 0.707107],
        sh: [-0.612372, 0.353553, 0.707107],
        uv: [0.310675, 0.321435],
        dpdu: [0.563289, 1.27674, 0.0746921],
    };
    check("disk", &hit(&l, [0.1, 0.2, 5.0]), &want);
    // The same matrix written as a <matrix> (true inverse) is another disk: the ray meets it
    // elsewhere.
    let m = groove::scene::xml::transform::rotate_raw(Vec3::new(0.0, 1.0, 1.0), -60.0);
    let rows: Vec<String> = (0..3)
        .flat_map(|r| (0..3).map(move |c| (r, c)))
        .map(|(r, c)| m.col(c)[r].to_string())
        .collect();
    let matrix = format!(
        r#"<shape type="disk"><transform name="to_world"><matrix value="{} {} {} 0 {} {} {} 0 {} {} {} 0 0 0 0 1"/></transform></shape>"#,
        rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], rows[6], rows[7], rows[8]
    );
    let plain = load_body("disk_matrix", &matrix);
    let t = plain
        .scene
        .intersect(&Ray::new(Vec3::new(0.1, 0.2, 5.0), Vec3::NEG_Z))
        .map(|si| si.t);
    assert!(t.is_none_or(|t| (t - want.t).abs() > 1e-3), "{t:?}");
}

#[test]
fn non_similar_spheres_stay_spheres_with_mitsubas_uv_map() {
    let l = load_body(
        "sphere_scaled",
        r#"<shape type="sphere"><transform name="to_world"><scale x="0.35" y="0.5" z="0.6"/>
<rotate y="1" angle="30"/><translate x="0.35" y="-0.5"/></transform></shape>"#,
    );
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("shouldn't contain non-uniform scaling")),
        "{:?}",
        l.warnings
    );
    let want = Want {
        t: 4.679844,
        p: [0.45, -0.4, 0.320156],
        n: [0.285714, 0.285714, 0.914732],
        sh: [0.285714, 0.285714, 0.914732],
        uv: [0.378855, 0.173771],
        dpdu: [-0.380898, -0.659515, 0.219912],
    };
    check("scaled sphere", &hit(&l, [0.45, -0.4, 5.0]), &want);

    let l = load_body(
        "sphere_quirk",
        r#"<shape type="sphere"><transform name="to_world">
<rotate x="1" y="1" angle="50"/></transform></shape>"#,
    );
    let want = Want {
        t: 3.741261,
        p: [0.2, 0.3, 1.25874],
        n: [0.152746, 0.22912, 0.961339],
        sh: [0.152746, 0.22912, 0.961339],
        uv: [0.322763, 0.545899],
        dpdu: [-9.86719, -7.12647, 3.26627],
    };
    check(
        "sphere under a non-unit axis",
        &hit(&l, [0.2, 0.3, 5.0]),
        &want,
    );
}

#[test]
fn mirrored_spheres_flip_their_normals_as_mitsuba() {
    let l = load_body(
        "sphere_mirror",
        r#"<shape type="sphere"><transform name="to_world"><scale x="-1"/></transform></shape>"#,
    );
    assert!(
        l.warnings.iter().all(|w| !w.contains("sphere")),
        "{:?}",
        l.warnings
    );
    let want = Want {
        t: 4.067262,
        p: [0.2, 0.3, 0.932738],
        n: [-0.2, -0.3, -0.932738],
        sh: [-0.2, -0.3, -0.932738],
        uv: [0.343584, 0.117413],
        dpdu: [1.88496, -1.25664, 0.0],
    };
    check("mirrored sphere", &hit(&l, [0.2, 0.3, 5.0]), &want);
}

#[test]
fn instances_use_mitsubas_quirky_inverse() {
    let group = r#"<shape type="shapegroup" id="g">
<shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/></shape>
<shape type="cube"><transform name="to_world"><scale value="0.5"/></transform></shape></shape>
<shape type="instance"><ref id="g"/><transform name="to_world">
<rotate x="1" y="1" z="1" angle="40"/></transform></shape>"#;
    let l = load_body("instance", group);
    // The sphere member is evaluated for the ray taken to group space by Mitsuba's quirky
    // inverse: its point is not on the world ray.
    let sphere = Want {
        t: 3.465348,
        p: [-0.321874, 1.26805, 1.53172],
        n: [0.121955, 0.375927, 0.918589],
        sh: [0.121955, 0.375927, 0.918589],
        uv: [0.254597, 0.29586],
        dpdu: [-2.4866, -2.27887, 0.965013],
    };
    check("instanced sphere", &hit(&l, [-0.2, 0.9, 5.0]), &sphere);
    // The cube member (a mesh): its point from the barycentrics, its normals by the raw matrix.
    let cube = Want {
        t: 4.152153,
        p: [0.1, -0.1, 0.847847],
        n: [0.630144, -0.293841, 0.718732],
        sh: [0.630144, -0.293841, 0.718732],
        uv: [0.795251, 0.282336],
        dpdu: [-0.408832, 1.0, 0.876743],
    };
    check("instanced cube", &hit(&l, [0.1, -0.1, 5.0]), &cube);
}
