//! Zero-area triangles and zero-area meshes: warnings (once per mesh, located, with the count),
//! never sampled; a zero-area area light is an error, as Mitsuba 3.9.1 `scalar_rgb` makes it
//! ("DiscreteDistribution: no probability mass found!"). The render side is
//! tests/render/lights.rs (`degenerate_mesh`). Run with `cargo test --release --test scene
//! degenerate`.

use std::path::PathBuf;

use glam::Vec2;
use groove::load::load_scene;
use groove::load::options::LoadOptions;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scene_with(mesh: &str) -> groove::load::Loaded {
    let opts = LoadOptions {
        defines: vec![("mesh".into(), mesh.into())],
        ..LoadOptions::default()
    };
    load_scene(&repo().join("tests/data/scenes/degenerate_mesh.xml"), &opts)
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn zero_area_triangles_and_meshes_are_warnings() {
    let l = scene_with("quad_emit_degenerate.obj");
    let flat: Vec<_> = l
        .warnings
        .iter()
        .filter(|w| w.contains("zero surface area"))
        .collect();
    assert_eq!(flat.len(), 1, "{:?}", l.warnings);
    // The <shape> of flat_line.obj is on line 43 of the scene file.
    assert!(flat[0].contains("degenerate_mesh.xml:43:"), "{}", flat[0]);
    assert!(flat[0].contains("all 3 triangles"), "{}", flat[0]);
    let tris: Vec<_> = l
        .warnings
        .iter()
        .filter(|w| w.contains("zero-area triangle"))
        .collect();
    assert_eq!(tris.len(), 1, "{:?}", l.warnings);
    assert!(tris[0].contains("degenerate_mesh.xml:48:"), "{}", tris[0]);
    assert!(
        tris[0].contains("5 zero-area triangle(s) of 7"),
        "{}",
        tris[0]
    );
    // Without the degenerate triangles: only the flat mesh is warned about.
    let clean = scene_with("quad_emit.obj");
    assert!(!clean
        .warnings
        .iter()
        .any(|w| w.contains("zero-area triangle")));
}

#[test]
fn zero_area_triangles_are_never_sampled() {
    // The light's sampling picks the same points with or without the degenerate triangles:
    // they get no probability, and the others keep theirs.
    let a = scene_with("quad_emit_degenerate.obj");
    let b = scene_with("quad_emit.obj");
    let (sa, sb) = (&a.scene.shapes()[2], &b.scene.shapes()[2]);
    assert_eq!(sa.zero_area_triangles(), 5);
    assert!((sa.area() - sb.area()).abs() < 1e-6);
    let n = 64;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let (pa, pb) = (sa.sample_position(u), sb.sample_position(u));
            assert!((pa.p - pb.p).length() < 1e-6, "{u}: {} vs {}", pa.p, pb.p);
            assert_eq!(pa.n, pb.n);
            assert_eq!(pa.pdf, pb.pdf);
        }
    }
    // The last sample before 1 stays on a triangle with area.
    let last = sa.sample_position(Vec2::new(0.5, 1.0 - f32::EPSILON));
    assert!(last.n.is_finite() && last.pdf > 0.0);
}

#[test]
fn a_zero_area_area_light_is_an_error() {
    let dir = crate::common::Scratch::new(&format!("groove_degenerate_{}", std::process::id()));
    let mesh = repo().join("tests/data/geometry/flat_line.obj");
    let text = format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"obj\">\n<string name=\"filename\" value=\"{}\"/>\n<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n</shape>\n</scene>\n",
        mesh.display()
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, text).unwrap();
    match load_scene(&path, &LoadOptions::default()) {
        Err(groove::Error::Scene { loc, msg }) => {
            assert_eq!(loc.line, 3, "{msg}");
            assert!(msg.contains("zero surface area"), "{msg}");
        }
        Err(e) => panic!("expected a scene error, got {e}"),
        Ok(_) => panic!("expected an error"),
    }
}
