//! The `projector` light and the textured `spot` against numbers read off Mitsuba 3.9.1
//! (`scalar_rgb`, `Emitter::sample_direction` from the listed points; bitmap
//! tests/data/textures/render8x6.png, 8 × 6, nearest filter), and their errors. Run with
//! `cargo test --release --test scene projector`.

use std::path::PathBuf;

use glam::{Vec2, Vec3};
use groove::load::options::LoadOptions;
use groove::load::{load_scene, Loaded};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A scene with `body` (on line 3 on) and a camera, written to a scratch folder and loaded.
fn load_body(name: &str, body: &str) -> groove::Result<Loaded> {
    let dir =
        crate::common::Scratch::new(&format!("groove_projector_{}_{name}", std::process::id()));
    let text = format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n{body}\n<sensor type=\"perspective\"/>\n</scene>\n"
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, text).unwrap();
    load_scene(&path, &LoadOptions::default())
}

fn bitmap(name: &str) -> String {
    let f = repo().join("tests/data/textures/render8x6.png");
    format!(
        r#"<texture type="bitmap" name="{name}"><string name="filename" value="{}"/><string name="filter_type" value="nearest"/></texture>"#,
        f.display()
    )
}

/// Expects a scene error on `line` whose message contains `msg`.
fn expect_err(name: &str, body: &str, line: u32, msg: &str) {
    match load_body(name, body) {
        Ok(_) => panic!("{name}: expected an error"),
        Err(groove::Error::Scene { loc, msg: m }) => {
            assert_eq!(loc.line, line, "{name}: {m}");
            assert!(m.contains(msg), "{name}: expected '{msg}' in '{m}'");
        }
        Err(e) => panic!("{name}: expected a scene error, got {e}"),
    }
}

/// (reference point, Mitsuba's direction to the light, Mitsuba's weight; zero = not lit).
type Case = ([f32; 3], [f32; 3], [f32; 3]);

fn check_cases(loaded: &Loaded, emitter: usize, cases: &[Case]) {
    let scene = &loaded.scene;
    let em = &scene.emitters()[emitter];
    for (p, d, w) in cases {
        let p = Vec3::from(*p);
        let got = em.sample_direct(scene.shapes(), p, Vec2::new(0.5, 0.5));
        if w.iter().all(|&c| c == 0.0) {
            assert!(
                got.is_none(),
                "emitter {emitter} at {p}: expected no light, got {got:?}"
            );
            continue;
        }
        let s = got.unwrap_or_else(|| panic!("emitter {emitter} at {p}: no sample"));
        assert!(s.delta && s.pdf == 1.0);
        assert!(
            (s.d - Vec3::from(*d)).length() < 1e-5,
            "{p}: d {} vs {d:?}",
            s.d
        );
        for k in 0..3 {
            let rel = (s.value[k] - w[k]).abs() / w[k].abs().max(1e-3);
            assert!(rel < 2e-4, "emitter {emitter} at {p}: {} vs {w:?}", s.value);
        }
    }
}

#[test]
fn projector_matches_mitsuba() {
    let body = format!(
        r#"<emitter type="projector">{}
  <float name="scale" value="2"/><float name="fov" value="30"/><string name="fov_axis" value="y"/>
  <transform name="to_world"><scale value="1.5"/><lookat origin="0,2,0" target="0.2,0,0.1" up="0,0,1"/></transform>
</emitter>
<emitter type="projector">
  <transform name="to_world"><lookat origin="0,2,0" target="0,0,0" up="0,0,1"/></transform>
</emitter>"#,
        bitmap("irradiance")
    );
    let loaded = load_body("proj", &body).unwrap_or_else(|e| panic!("{e}"));
    // A bitmap, fov 30° on y of an 8 × 6 image (x fov 39.3201°), scale 2, and a to_world with a
    // uniform scale 1.5 (Mitsuba's unnormalised n and local z).
    check_cases(
        &loaded,
        0,
        &[
            (
                [0.3, 0.0, 0.2],
                [-0.14762, 0.984136, -0.0984136],
                [0.235005, 1.37268, 1.21158],
            ),
            (
                [-0.2, 0.0, 0.4],
                [0.09759, 0.9759, -0.19518],
                [0.340513, 0.504451, 0.761229],
            ),
            (
                [0.5, 0.5, -0.3],
                [-0.310685, 0.932055, 0.186411],
                [3.41422, 1.80844, 0.0129684],
            ),
            (
                [0.0, -1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.00598034, 0.0530316, 0.0170664],
            ),
            (
                [0.9, 0.0, 0.1],
                [-0.409939, 0.910975, -0.0455488],
                [0.828345, 0.909615, 0.0444367],
            ),
            ([0.0, 3.0, 0.0], [0.0; 3], [0.0; 3]),
        ],
    );
    // The defaults: irradiance 1 (a 1 × 1 image), focal_length 50mm (x fov 34.0221°).
    check_cases(
        &loaded,
        1,
        &[
            (
                [0.3, 0.0, 0.2],
                [-0.14762, 0.984136, -0.0984136],
                [0.798059; 3],
            ),
            ([-0.2, 0.0, 0.4], [0.09759, 0.9759, -0.19518], [0.804794; 3]),
            ([0.5, 0.5, -0.3], [0.0; 3], [0.0; 3]),
            ([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.349066; 3]),
            ([0.9, 0.0, 0.1], [0.0; 3], [0.0; 3]),
        ],
    );
    assert!(loaded.scene.emitters().iter().all(|e| e.is_delta()));
}

#[test]
fn textured_spot_matches_mitsuba() {
    let body = format!(
        r#"<emitter type="spot">
  <rgb name="intensity" value="2, 3, 4"/>{}
  <float name="cutoff_angle" value="40"/>
  <transform name="to_world"><lookat origin="0,2,0" target="0.2,0,0.1" up="0,0,1"/></transform>
</emitter>"#,
        bitmap("texture")
    );
    let loaded = load_body("spot", &body).unwrap_or_else(|e| panic!("{e}"));
    check_cases(
        &loaded,
        0,
        &[
            (
                [0.3, 0.0, 0.2],
                [-0.14762, 0.984136, -0.0984136],
                [0.417994, 0.0849667, 0.0776948],
            ),
            (
                [-0.2, 0.0, 0.4],
                [0.09759, 0.9759, -0.19518],
                [0.0401792, 0.334131, 0.372926],
            ),
            (
                [0.5, 0.5, -0.3],
                [-0.310685, 0.932055, 0.186411],
                [0.267725, 0.907573, 0.051127],
            ),
            (
                [0.0, -1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0227204, 0.199067, 0.234274],
            ),
            (
                [0.9, 0.0, 0.1],
                [-0.409939, 0.910975, -0.0455488],
                [0.143861, 0.487679, 0.0274728],
            ),
            ([0.0, 3.0, 0.0], [0.0; 3], [0.0; 3]),
        ],
    );
}

#[test]
fn projector_and_spot_errors_are_located() {
    expect_err(
        "proj_fov",
        r#"<emitter type="projector"><float name="fov" value="180"/></emitter>"#,
        3,
        "fov",
    );
    expect_err(
        "proj_both",
        r#"<emitter type="projector"><float name="fov" value="30"/><string name="focal_length" value="35mm"/></emitter>"#,
        3,
        "not both",
    );
    expect_err(
        "proj_axis",
        r#"<emitter type="projector"><float name="fov" value="30"/><string name="fov_axis" value="z"/></emitter>"#,
        3,
        "fov_axis",
    );
    expect_err(
        "proj_scale",
        r#"<emitter type="projector"><float name="scale" value="-1"/></emitter>"#,
        3,
        "scale",
    );
    expect_err(
        "proj_unknown",
        r#"<emitter type="projector"><float name="near_clip" value="1"/></emitter>"#,
        3,
        "near_clip",
    );
    expect_err(
        "proj_singular",
        r#"<emitter type="projector"><transform name="to_world"><scale z="0"/></transform></emitter>"#,
        3,
        "not invertible",
    );
    expect_err(
        "proj_nested",
        &format!(
            r#"<emitter type="projector">{}</emitter>"#,
            bitmap("texture")
        ),
        3,
        "named 'texture'",
    );
    // Mitsuba: "The parameter 'texture' must be spatially varying" and "'intensity' cannot be
    // spatially varying".
    expect_err(
        "spot_const_tex",
        r#"<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>"#,
        3,
        "spatially varying",
    );
    expect_err(
        "spot_tex_intensity",
        &format!(r#"<emitter type="spot">{}</emitter>"#, bitmap("intensity")),
        3,
        "'intensity' cannot be spatially varying",
    );
}
