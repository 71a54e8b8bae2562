//! Loading `linearcurve` / `bsplinecurve` shapes: the file through the loader, and the errors
//! Mitsuba 3.9.1 also stops at (located at the element, with the curve file's own line).

use groove::geometry::ShapeKind;
use groove::load::load_scene;
use groove::load::options::LoadOptions;

/// A scratch folder with `curves.txt` holding `curves`, and `scene.xml` with `shape` (XML, on
/// line 3) beside it.
fn load(tag: &str, curves: &str, shape: &str) -> groove::Result<groove::load::Loaded> {
    let d = crate::common::Scratch::new(&format!("groove_curves_{}_{tag}", std::process::id()));
    std::fs::write(d.join("curves.txt"), curves).unwrap();
    let scene = format!(
        "<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n{shape}\n<sensor type=\"perspective\"/>\n</scene>\n"
    );
    std::fs::write(d.join("scene.xml"), scene).unwrap();
    load_scene(&d.join("scene.xml"), &LoadOptions::default())
}

fn err(tag: &str, curves: &str, shape: &str) -> String {
    match load(tag, curves, shape) {
        Ok(_) => panic!("{tag}: expected an error"),
        Err(e) => e.to_string(),
    }
}

const TWO: &str = "0 0 0 0.1\n1 0 0 0.1\n\n0 1 0 0.2\n1 1 0 0.2\n2 1 0 0.2\n";

#[test]
fn curve_files_load_through_the_scene_with_to_world_on_positions_only() {
    let l = load(
        "ok",
        TWO,
        r#"<shape type="linearcurve"><string name="filename" value="curves.txt"/>
           <transform name="to_world"><scale value="2"/><translate z="1"/></transform></shape>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ShapeKind::Curves(c) = &l.scene.shapes()[0].kind else {
        panic!("not curves")
    };
    assert_eq!(c.segments, vec![0, 2, 3]);
    assert_eq!(c.points[4], [4.0, 2.0, 1.0, 0.2]);
    // The scene traces it: the first curve runs from (0,0,1) to (2,0,1) with radius 0.1.
    let ray = groove::geometry::Ray::new(glam::Vec3::new(1.0, 0.05, 5.0), -glam::Vec3::Z);
    let si = l.scene.intersect(&ray).expect("a hit");
    let t = 4.0 - (0.1f32 * 0.1 - 0.05 * 0.05).sqrt();
    assert!((si.t - t).abs() < 1e-4, "t {} vs {t}", si.t);
    let b = load(
        "bspline",
        "0 0 0 1\n1 0 0 1\n2 0 0 1\n3 0 0 1\n4 0 0 1\n",
        r#"<shape type="bsplinecurve"><string name="filename" value="curves.txt"/>
           <float name="silhouette_sampling_weight" value="0.5"/></shape>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ShapeKind::Curves(c) = &b.scene.shapes()[0].kind else {
        panic!("not curves")
    };
    assert_eq!(c.segments, vec![0, 1]);
}

#[test]
fn curve_errors_are_located_at_the_element_and_in_the_file() {
    // A bad line: the element's place, then the file's own line and column.
    let e = err(
        "badline",
        "0 0 0 0.1\n1 0 zero 0.1\n",
        r#"<shape type="linearcurve"><string name="filename" value="curves.txt"/></shape>"#,
    );
    assert!(
        e.contains("scene.xml:3:1: cannot load curves 'curves.txt'"),
        "{e}"
    );
    assert!(
        e.contains("curves.txt:2:5: `zero` is not a finite number"),
        "{e}"
    );
    // Too few control points for a B-spline.
    let e = err(
        "short",
        TWO,
        r#"<shape type="bsplinecurve"><string name="filename" value="curves.txt"/></shape>"#,
    );
    assert!(
        e.contains("curves.txt:1:1:") && e.contains("at least 4"),
        "{e}"
    );
    // No file, a missing file.
    let e = err("nofile", TWO, r#"<shape type="linearcurve"/>"#);
    assert!(
        e.contains("scene.xml:3:1:") && e.contains("needs a 'filename'"),
        "{e}"
    );
    let e = err(
        "missing",
        TWO,
        r#"<shape type="linearcurve"><string name="filename" value="nope.txt"/></shape>"#,
    );
    assert!(e.contains("scene.xml:3:") && e.contains("nope.txt"), "{e}");
    // Not parameters of Mitsuba's curves: flip_normals, and an area emitter.
    let e = err(
        "flip",
        TWO,
        r#"<shape type="linearcurve"><string name="filename" value="curves.txt"/>
           <boolean name="flip_normals" value="true"/></shape>"#,
    );
    assert!(
        e.contains("scene.xml:4:") && e.contains("flip_normals"),
        "{e}"
    );
    let e = err(
        "emitter",
        TWO,
        r#"<shape type="linearcurve"><string name="filename" value="curves.txt"/>
           <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
    );
    assert!(
        e.contains("scene.xml:4:12:") && e.contains("cannot carry an area emitter"),
        "{e}"
    );
}
