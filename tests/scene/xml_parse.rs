//! The XML front end through its public API: every error class with its message and exact
//! `file:line:col`, parameters, includes, the 0.6 upgrade, transforms, spectra and the real
//! Cornell box scenes.

use std::f32::consts::FRAC_1_SQRT_2;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use groove::scene::xml::ir::{Document, Node};
use groove::scene::xml::parse::{load_file, load_str};
use groove::scene::xml::props::Props;
use groove::spectrum::SpectrumUse;
use groove::Spectrum;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/xml")
        .join(name)
}

fn opts(defines: &[(&str, &str)]) -> Vec<(String, String)> {
    defines
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn load(text: &str) -> groove::Result<Document> {
    load_str(text, Path::new("mem.xml"), &[])
}

fn load_err(text: &str) -> String {
    load(text).expect_err("expected an error").to_string()
}

/// Asserts that `err` starts with `loc` and contains `msg`.
fn assert_err(err: &str, loc: &str, msg: &str) {
    assert!(
        err.starts_with(&format!("{loc}: ")),
        "expected location {loc}, got: {err}"
    );
    assert!(err.contains(msg), "expected '{msg}' in: {err}");
}

fn child<'a>(n: &'a Node, tag: &str, id: &str) -> &'a Node {
    n.children
        .iter()
        .find(|c| c.tag == tag && c.attr("id") == Some(id))
        .unwrap_or_else(|| panic!("no <{tag} id={id}>"))
}

fn mat_close(a: Mat4, b: Mat4) {
    assert!(a.abs_diff_eq(b, 1e-5), "{a:?}\n!=\n{b:?}");
}

// ----------------------------------------------------------------------------------------------
// Error classes

#[test]
fn malformed_xml() {
    let e = load_err("<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\">\n</scene>\n");
    assert_err(&e, "mem.xml:3:1", "malformed XML");
}

#[test]
fn malformed_attribute_quotes() {
    let e = load_err("<scene version=\"3.0.0\">\n  <bsdf type=diffuse/>\n</scene>");
    assert_err(&e, "mem.xml:2:14", "must be quoted");
}

#[test]
fn unknown_tag() {
    let e = load_err("<scene version=\"3.0.0\">\n    <bdsf type=\"diffuse\"/>\n</scene>");
    assert_err(&e, "mem.xml:2:5", "unknown tag <bdsf>");
}

#[test]
fn lookat_camel_case_in_v3_file_is_unknown() {
    let e = load_err(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">\n<lookAt origin=\"0,0,1\" target=\"0,0,0\"/></transform></sensor></scene>",
    );
    assert_err(&e, "mem.xml:2:1", "unknown tag <lookAt>");
}

#[test]
fn unknown_attribute() {
    let e = load_err(
        "<scene version=\"3.0.0\">\n  <float name=\"x\" value=\"1\" unit=\"m\"/>\n</scene>",
    );
    assert_err(&e, "mem.xml:2:29", "unknown attribute 'unit' on <float>");
}

#[test]
fn missing_version() {
    let e = load_err("<!-- hi -->\n<scene>\n</scene>");
    assert_err(&e, "mem.xml:2:1", "missing version attribute");
}

#[test]
fn undefined_parameter() {
    let e = load_err(
        "<scene version=\"3.0.0\">\n <integrator type=\"path\">\n  <integer name=\"max_depth\" value=\"$depth\"/>\n </integrator>\n</scene>",
    );
    assert_err(&e, "mem.xml:3:29", "undefined parameter '$depth'");
}

#[test]
fn unused_define() {
    let e = load_str(
        "<scene version=\"3.0.0\">\n</scene>",
        Path::new("mem.xml"),
        &opts(&[("spp", "4")]),
    )
    .unwrap_err()
    .to_string();
    assert_err(&e, "mem.xml:1:1", "unused -D value 'spp'");
}

#[test]
fn duplicate_id() {
    let e = load_err(
        "<scene version=\"3.0.0\">\n <bsdf type=\"diffuse\" id=\"a\"/>\n <shape type=\"sphere\">\n  <bsdf type=\"diffuse\" id=\"a\"/>\n </shape>\n</scene>",
    );
    assert_err(
        &e,
        "mem.xml:4:24",
        "duplicate id 'a' (first defined at mem.xml:2:23)",
    );
}

#[test]
fn refs_do_not_count_as_duplicate_ids() {
    let doc = load(
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"a\"/><shape type=\"sphere\"><ref id=\"a\"/></shape><shape type=\"sphere\"><ref id=\"a\"/></shape></scene>",
    )
    .unwrap();
    assert_eq!(doc.root.children.len(), 3);
}

#[test]
fn missing_include_file() {
    let path = data("missing_include.xml");
    let e = load_file(&path, &[]).unwrap_err().to_string();
    assert_err(
        &e,
        &format!("{}:2:16", path.display()),
        "included file 'nope/absent.xml' not found",
    );
}

#[test]
fn include_cycle() {
    let path = data("cycle_a.xml");
    let e = load_file(&path, &[]).unwrap_err().to_string();
    assert_err(
        &e,
        &format!("{}:2:14", data("cycle_b.xml").display()),
        "include cycle",
    );
}

#[test]
fn bad_number() {
    let doc = load(
        "<scene version=\"3.0.0\">\n <bsdf type=\"roughconductor\">\n  <float name=\"alpha\" value=\"0.1x\"/>\n </bsdf>\n</scene>",
    )
    .unwrap();
    let props = Props::new(&doc.root.children[0]).unwrap();
    let e = props.float("alpha", 0.1).unwrap_err().to_string();
    assert_err(
        &e,
        "mem.xml:3:23",
        "could not parse floating point value '0.1x'",
    );
}

#[test]
fn integer_rejects_fraction_and_nan_is_rejected() {
    let doc = load(
        "<scene version=\"3.0.0\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"1.5\"/><float name=\"f\" value=\"nan\"/><boolean name=\"b\" value=\"1\"/></integrator></scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert!(p
        .int("max_depth", 1)
        .unwrap_err()
        .to_string()
        .contains("could not parse integer value '1.5'"));
    assert!(p
        .float("f", 0.0)
        .unwrap_err()
        .to_string()
        .contains("not finite"));
    assert!(p.bool("b", false).unwrap_err().to_string().contains("'1'"));
}

#[test]
fn wrong_property_type() {
    let doc = load(
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\">\n<string name=\"reflectance\" value=\"red\"/></bsdf></scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    let e = p
        .color("reflectance", Spectrum::ONE)
        .unwrap_err()
        .to_string();
    assert_err(
        &e,
        "mem.xml:2:1",
        "is a <string>, expected <rgb> or <spectrum>",
    );
}

#[test]
fn duplicate_property() {
    let doc = load(
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1\"/>\n<rgb name=\"reflectance\" value=\"0\"/></bsdf></scene>",
    )
    .unwrap();
    let e = Props::new(&doc.root.children[0]).err().unwrap().to_string();
    assert_err(&e, "mem.xml:3:6", "duplicate property 'reflectance'");
}

#[test]
fn unreferenced_property() {
    let doc = load(
        "<scene version=\"3.0.0\">\n <bsdf type=\"dielectric\">\n  <float name=\"int_ior\" value=\"1.5\"/>\n  <float name=\"ext_eta\" value=\"1\"/>\n </bsdf>\n</scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert_eq!(p.float("int_ior", 1.5046).unwrap(), 1.5);
    let e = p.finish().unwrap_err().to_string();
    assert_err(
        &e,
        "mem.xml:4:10",
        "unreferenced property 'ext_eta' in <bsdf type=\"dielectric\">",
    );
    assert!(!e.contains("Mitsuba 0.6"), "{e}");
}

#[test]
fn camel_case_name_in_v3_file_gets_version_hint() {
    let doc = load(
        "<scene version=\"3.0.0\">\n <bsdf type=\"dielectric\">\n  <float name=\"extEta\" value=\"1\"/>\n </bsdf>\n</scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    let _ = p.float("ext_eta", 1.0).unwrap();
    let e = p.finish().unwrap_err().to_string();
    assert_err(
        &e,
        "mem.xml:3:10",
        "unreferenced property 'extEta' in <bsdf type=\"dielectric\"> (a Mitsuba 0.6 name? set <scene version=\"0.6.0\"> or use 'ext_eta')",
    );
}

#[test]
fn all_properties_used_finishes() {
    let doc = load(
        "<scene version=\"3.0.0\"><shape type=\"sphere\"><point name=\"center\" x=\"1\" z=\"3\"/><float name=\"radius\" value=\"2\"/><bsdf type=\"diffuse\"/></shape></scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert_eq!(p.plugin_type(), "sphere");
    assert_eq!(
        p.point("center", Vec3::ZERO).unwrap(),
        Vec3::new(1.0, 0.0, 3.0)
    );
    assert_eq!(p.float("radius", 1.0).unwrap(), 2.0);
    assert_eq!(p.objects().count(), 1);
    assert!(p.has("radius"));
    p.finish().unwrap();
}

// ----------------------------------------------------------------------------------------------
// Parameters

const PARAM_SCENE: &str = r#"<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="spp_max" value="1024"/>
    <default name="integrator" value="path"/>
    <integrator type="$integrator">
        <integer name="a" value="$spp"/>
        <integer name="b" value="$spp_max"/>
        <string name="c" value="$spp-$spp_max"/>
    </integrator>
</scene>"#;

fn param_values(doc: &Document) -> (String, i64, i64, String) {
    let n = &doc.root.children[0];
    let p = Props::new(n).unwrap();
    (
        p.plugin_type().to_string(),
        p.int("a", 0).unwrap(),
        p.int("b", 0).unwrap(),
        p.string("c", "").unwrap(),
    )
}

#[test]
fn defaults_and_longest_name_first() {
    let doc = load(PARAM_SCENE).unwrap();
    assert_eq!(
        param_values(&doc),
        ("path".into(), 64, 1024, "64-1024".into())
    );
}

#[test]
fn define_overrides_default() {
    let doc = load_str(
        PARAM_SCENE,
        Path::new("mem.xml"),
        &opts(&[("spp", "8"), ("integrator", "direct"), ("spp", "4")]),
    )
    .unwrap();
    assert_eq!(
        param_values(&doc),
        ("direct".into(), 4, 1024, "4-1024".into())
    );
}

#[test]
fn define_without_default_is_used_by_dollar() {
    let doc = load_str(
        "<scene version=\"3.0.0\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"$d\"/></integrator></scene>",
        Path::new("mem.xml"),
        &opts(&[("d", "3")]),
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert_eq!(p.int("max_depth", -1).unwrap(), 3);
}

// ----------------------------------------------------------------------------------------------
// Includes

#[test]
fn include_splices_with_file_locations() {
    let path = data("main_include.xml");
    let doc = load_file(&path, &[]).unwrap();
    let tags: Vec<(&str, Option<&str>)> = doc
        .root
        .children
        .iter()
        .map(|c| (c.tag.as_str(), c.attr("id")))
        .collect();
    assert_eq!(
        tags,
        vec![
            ("bsdf", Some("mat")),
            ("bsdf", Some("glass")),
            ("shape", Some("s"))
        ]
    );
    let mat = child(&doc.root, "bsdf", "mat");
    assert_eq!(mat.loc.file, data("inc/part.xml"));
    assert_eq!((mat.loc.line, mat.loc.col), (3, 5));
    // `$refl` from the including file's <default> reaches the included file.
    let p = Props::new(mat).unwrap();
    assert_eq!(
        p.color("reflectance", Spectrum::ONE).unwrap(),
        Spectrum::splat(0.25)
    );
    p.finish().unwrap();
    // The included 0.6 file is upgraded by its own version; the main file is not "upgraded".
    let glass = child(&doc.root, "bsdf", "glass");
    assert_eq!(glass.children[0].attr("name"), Some("int_ior"));
    assert_eq!(glass.loc.file, data("old_part.xml"));
    assert!(!doc.upgraded_from_v0);
    let s = child(&doc.root, "shape", "s");
    assert_eq!(s.loc.file, path);
    assert_eq!(doc.search_paths[0], data(""));
}

// ----------------------------------------------------------------------------------------------
// 0.6 upgrade

#[test]
fn old_scene_is_upgraded() {
    let doc = load_file(&data("old_scene.xml"), &[]).unwrap();
    assert!(doc.upgraded_from_v0);
    assert_eq!(doc.version, (0, 5, 0));
    assert!(
        doc.warnings
            .iter()
            .any(|w| w.contains("old_scene.xml:9:13") && w.contains("<lookAt>")),
        "{:?}",
        doc.warnings
    );

    let integ = &doc.root.children[0];
    let p = Props::new(integ).unwrap();
    assert_eq!(p.int("max_depth", -1).unwrap(), 8);
    p.finish().unwrap();

    let sensor = &doc.root.children[1];
    let p = Props::new(sensor).unwrap();
    assert_eq!(p.string("fov_axis", "x").unwrap(), "smaller");
    let m = p.transform("to_world").unwrap();
    // Looking from +5z towards the origin: forward (column 2) is -z.
    assert!(m
        .z_axis
        .truncate()
        .abs_diff_eq(Vec3::new(0.0, 0.0, -1.0), 1e-6));
    p.finish().unwrap();
    let sampler = &sensor.children[2];
    assert_eq!(sampler.children[0].attr("name"), Some("sample_count"));

    // diffuseReflectance → reflectance (a named texture); a lone uoffset → to_uv translate.
    let d = child(&doc.root, "bsdf", "d");
    let tex = &d.children[0];
    assert_eq!(tex.attr("name"), Some("reflectance"));
    let tp = Props::new(tex).unwrap();
    mat_close(
        tp.transform("to_uv").unwrap(),
        Mat4::from_translation(Vec3::new(0.5, 0.0, 0.0)),
    );
    assert_eq!(tp.string("filename", "").unwrap(), "tex.png");
    tp.finish().unwrap();

    // All four: translate then scale, as Mitsuba 3's upgrade composes them.
    let c = child(&doc.root, "texture", "c");
    let cp = Props::new(c).unwrap();
    mat_close(
        cp.transform("to_uv").unwrap(),
        Mat4::from_scale(Vec3::new(4.0, 2.0, 1.0))
            * Mat4::from_translation(Vec3::new(0.25, 0.5, 0.0)),
    );
    cp.finish().unwrap();

    let g = child(&doc.root, "bsdf", "g");
    let names: Vec<_> = g.children.iter().filter_map(|c| c.attr("name")).collect();
    assert_eq!(names, vec!["int_ior", "alpha_u"]);
}

// ----------------------------------------------------------------------------------------------
// Transforms

fn transform_of(body: &str) -> Mat4 {
    let doc = load(&format!(
        "<scene version=\"3.0.0\"><shape type=\"sphere\"><transform name=\"to_world\">{body}</transform></shape></scene>"
    ))
    .unwrap();
    Props::new(&doc.root.children[0])
        .unwrap()
        .transform("to_world")
        .unwrap()
}

#[test]
fn transform_composition_order() {
    let m = transform_of(
        "<scale value=\"2\"/><rotate z=\"1\" angle=\"90\"/><translate x=\"1\" y=\"2\" z=\"3\"/>",
    );
    let want = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_z(90f32.to_radians())
        * Mat4::from_scale(Vec3::splat(2.0));
    mat_close(m, want);
    // (1,0,0) → scaled (2,0,0) → rotated (0,2,0) → translated (1,4,3).
    assert!(m
        .transform_point3(Vec3::X)
        .abs_diff_eq(Vec3::new(1.0, 4.0, 3.0), 1e-5));
}

#[test]
fn scale_xyz_defaults_to_one_and_translate_value() {
    mat_close(
        transform_of("<scale y=\"3\"/><translate value=\"1, 2, 3\"/>"),
        Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0)),
    );
}

#[test]
fn matrix_is_row_major() {
    let m = transform_of("<matrix value=\"1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1\"/>");
    mat_close(m, Mat4::from_translation(Vec3::new(5.0, 6.0, 7.0)));
    let m3 = transform_of("<matrix value=\"0 -1 0  1 0 0  0 0 1\"/>");
    mat_close(m3, Mat4::from_rotation_z(90f32.to_radians()));
}

/// Row-major 3x4 (the layout Mitsuba prints) to a glam matrix.
fn rows(r: [[f32; 4]; 3]) -> Mat4 {
    Mat4::from_cols_array_2d(&[r[0], r[1], r[2], [0.0, 0.0, 0.0, 1.0]]).transpose()
}

#[test]
fn lookat_matches_mitsuba_convention() {
    // Expected matrices printed by Mitsuba 3.9.1 (0.707107 there) (`ScalarTransform4f().look_at(...)`, and the
    // world transform of a sensor loaded from XML for the case without `up`).
    mat_close(
        transform_of(
            "<lookat origin=\"278, 273, -800\" target=\"278, 273, -799\" up=\"0, 1, 0\"/>",
        ),
        Mat4::from_translation(Vec3::new(278.0, 273.0, -800.0)),
    );
    mat_close(
        transform_of("<lookat origin=\"1,2,3\" target=\"4,-1,0\" up=\"0,0,1\"/>"),
        rows([
            [FRAC_1_SQRT_2, 0.408248, 0.57735, 1.0],
            [FRAC_1_SQRT_2, -0.408248, -0.57735, 2.0],
            [0.0, 0.816497, -0.57735, 3.0],
        ]),
    );
    mat_close(
        transform_of("<lookat origin=\"1,2,3\" target=\"1,2,4\"/>"),
        rows([
            [0.0, 1.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0, 2.0],
            [0.0, 0.0, 1.0, 3.0],
        ]),
    );
}

#[test]
fn lookat_with_parallel_up_is_an_error() {
    let doc = load(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">\n  <lookat origin=\"0,0,0\" target=\"0,1,0\" up=\"0,1,0\"/></transform></sensor></scene>",
    )
    .unwrap();
    let e = Props::new(&doc.root.children[0])
        .unwrap()
        .transform("to_world")
        .unwrap_err()
        .to_string();
    assert_err(&e, "mem.xml:2:3", "invalid lookat transformation");
}

// ----------------------------------------------------------------------------------------------
// Colours and spectra

#[test]
fn colours_and_spectra() {
    let doc = load(
        r#"<scene version="3.0.0"><bsdf type="x">
        <rgb name="a" value="0.1, 0.2 0.3"/>
        <rgb name="b" value="0.5"/>
        <spectrum name="c" value="0.25"/>
        <float name="d" value="0.75"/>
        <spectrum name="e" value="400:0, 500:8, 600:15.6, 700:18.4"/>
        <spectrum name="f" value="400:0, 500:8, 600:15.6, 700:18.4"/>
        </bsdf></scene>"#,
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert_eq!(
        p.color("a", Spectrum::ZERO).unwrap(),
        Spectrum::new(0.1, 0.2, 0.3)
    );
    assert_eq!(p.color("b", Spectrum::ZERO).unwrap(), Spectrum::splat(0.5));
    assert_eq!(p.color("c", Spectrum::ZERO).unwrap(), Spectrum::splat(0.25));
    assert_eq!(p.color("d", Spectrum::ZERO).unwrap(), Spectrum::splat(0.75));
    assert_eq!(p.color("missing", Spectrum::ONE).unwrap(), Spectrum::ONE);
    // Mitsuba 3.9.1 (scalar_rgb) gives [20.7108, 10.8546, 2.77115] inside an emitter.
    let e = p
        .color_with("e", Spectrum::ZERO, SpectrumUse::Emission)
        .unwrap();
    assert!(
        e.abs_diff_eq(Spectrum::new(20.7108, 10.8546, 2.77115), 2e-3),
        "{e}"
    );
    // As a reflectance it is clamped to [0, 1], as Mitsuba does, with a warning.
    assert!(p.take_warnings().is_empty());
    assert_eq!(p.color("f", Spectrum::ZERO).unwrap(), Spectrum::ONE);
    let w = p.take_warnings();
    assert!(
        w.len() == 1 && w[0].starts_with("mem.xml:7:") && w[0].contains("clamped"),
        "{w:?}"
    );
    p.finish().unwrap();
}

#[test]
fn rgb_reflectance_out_of_range_is_an_error() {
    // Mitsuba 3.9.1: "Invalid RGB reflectance value [1.5, 1.5, 1.5], must be in the range [0, 1]!"
    let doc = load(
        "<scene version=\"3.0.0\"><bsdf type=\"x\">\n<rgb name=\"r\" value=\"1.5\"/><rgb name=\"eta\" value=\"2\"/></bsdf></scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    let e = p.color("r", Spectrum::ZERO).unwrap_err().to_string();
    assert_err(&e, "mem.xml:2:15", "must be in the range [0, 1]");
    let eta = p
        .color_with("eta", Spectrum::ZERO, SpectrumUse::Unbounded)
        .unwrap();
    assert_eq!(eta, Spectrum::splat(2.0));
}

#[test]
fn bad_spectrum_is_an_error() {
    let doc = load(
        "<scene version=\"3.0.0\"><bsdf type=\"x\">\n<spectrum name=\"c\" value=\"500:1, 400:2\"/></bsdf></scene>",
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    let e = p.color("c", Spectrum::ZERO).unwrap_err().to_string();
    assert_err(&e, "mem.xml:2:20", "strictly increasing");
}

// ----------------------------------------------------------------------------------------------
// The real Cornell box scenes

/// The shared Cornell boxes, beside the checkout (like `tests/common`'s `shared_cbox`).
const CBOX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/scenes/mitsuba_cbox");

fn cbox(name: &str) -> Option<PathBuf> {
    let p = Path::new(CBOX).join(name);
    p.exists().then_some(p)
}

fn sampler_count(doc: &Document) -> i64 {
    let sensor = doc
        .root
        .children
        .iter()
        .find(|c| c.tag == "sensor")
        .unwrap();
    let sampler = sensor.children.iter().find(|c| c.tag == "sampler").unwrap();
    Props::new(sampler).unwrap().int("sample_count", 0).unwrap()
}

#[test]
fn cbox_rgb_loads_with_includes_and_define() {
    let Some(path) = cbox("cbox-rgb.xml") else {
        return;
    };
    let doc = load_file(&path, &[]).unwrap();
    assert_eq!(sampler_count(&doc), 256);
    let doc = load_file(&path, &opts(&[("spp", "4")])).unwrap();
    assert_eq!(sampler_count(&doc), 4);
    // The emitter declared at top level after the includes; shapes reference it by id.
    let em = child(&doc.root, "emitter", "area-emitter");
    let p = Props::new(em).unwrap();
    let r = p
        .color_with("radiance", Spectrum::ZERO, SpectrumUse::Emission)
        .unwrap();
    assert_eq!(r, Spectrum::new(18.387, 10.9873, 2.75357));
    p.finish().unwrap();
    let shapes = doc
        .root
        .children
        .iter()
        .filter(|c| c.tag == "shape")
        .count();
    assert_eq!(shapes, 8);
    let s = doc.root.children.iter().find(|c| c.tag == "shape").unwrap();
    let sp = Props::new(s).unwrap();
    let mesh = sp.string("filename", "").unwrap();
    let resolved = doc.resolve_file(&mesh, s.attr_loc("type")).unwrap();
    assert!(resolved.ends_with("meshes/cbox_luminaire.obj"));
    let missing = doc
        .resolve_file("meshes/nope.obj", &s.loc)
        .unwrap_err()
        .to_string();
    assert!(missing.contains("'meshes/nope.obj' not found"), "{missing}");
}

#[test]
fn cbox_spectral_loads_and_converts() {
    let Some(path) = cbox("cbox.xml") else {
        return;
    };
    let doc = load_file(&path, &opts(&[("spp", "4")])).unwrap();
    assert_eq!(sampler_count(&doc), 4);
    // Mitsuba 3.9.1 (scalar_rgb) values of the cbox reflectances.
    for (id, want) in [
        ("white", [0.735013, 0.735625, 0.736264]),
        ("red", [0.49132, 0.0492281, 0.0509219]),
        ("green", [0.0682825, 0.39776, 0.0862909]),
    ] {
        let p = Props::new(child(&doc.root, "bsdf", id)).unwrap();
        let c = p.color("reflectance", Spectrum::ZERO).unwrap();
        let want = Spectrum::from(want);
        assert!(
            ((c - want).abs() / want).max_element() < 1e-3,
            "{id}: {c} vs {want}"
        );
        p.finish().unwrap();
    }
    let light = doc
        .root
        .children
        .iter()
        .find(|c| c.tag == "shape" && c.children.iter().any(|e| e.tag == "emitter"))
        .unwrap();
    let em = light.children.iter().find(|e| e.tag == "emitter").unwrap();
    let r = Props::new(em)
        .unwrap()
        .color_with("radiance", Spectrum::ZERO, SpectrumUse::Emission)
        .unwrap();
    let want = Spectrum::new(20.7108, 10.8546, 2.77115);
    assert!(((r - want).abs() / want).max_element() < 1e-3, "{r}");
}

#[test]
fn raw_access_named_objects_and_mark_used() {
    let doc = load(
        r#"<scene version="3.0.0"><bsdf type="diffuse">
        <texture type="bitmap" name="reflectance"><string name="filename" value="a.png"/></texture>
        <string name="note" value="x"/>
        </bsdf></scene>"#,
    )
    .unwrap();
    let p = Props::new(&doc.root.children[0]).unwrap();
    assert!(p.has("reflectance") && p.has("note") && !p.has("other"));
    // A colour query does not see a texture given by name; raw access does.
    assert_eq!(p.color_opt("reflectance").unwrap(), None);
    assert_eq!(p.property_node("reflectance").unwrap().tag, "texture");
    assert_eq!(p.objects().count(), 1);
    assert!(Props::new(&doc.root.children[0]).unwrap().finish().is_err());
    p.mark_used("note");
    p.finish().unwrap();
}

#[test]
fn load_str_resolves_includes_and_paths_next_to_virtual_path() {
    let doc = load_str(
        "<scene version=\"3.0.0\"><default name=\"refl\" value=\"0.5\"/><path value=\"inc\"/><include filename=\"inc/part.xml\"/></scene>",
        &data("virtual.xml"),
        &[],
    )
    .unwrap();
    assert_eq!(doc.root.children.len(), 1);
    assert_eq!(doc.search_paths, vec![data(""), data("inc")]);
    let found = doc.resolve_file("part.xml", &doc.root.loc).unwrap();
    assert_eq!(found, data("inc/part.xml"));
}

// ----------------------------------------------------------------------------------------------
// mask, null, bumpmap and textured roughness: bad parameters are errors at the element

/// Instantiates a scene whose only shape (line 3) holds `bsdf` (starting on line 4).
fn bsdf_err(bsdf: &str) -> String {
    let text = format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor>\n<shape type=\"sphere\">\n{bsdf}\n</shape>\n</scene>\n"
    );
    let doc = load(&text).expect("parses");
    groove::load::instantiate(&doc, Path::new("mem.xml"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
}

#[test]
fn mask_null_bumpmap_and_textured_alpha_load() {
    for ok in [
        r#"<bsdf type="null"/>"#,
        r#"<bsdf type="mask"><bsdf type="diffuse"/></bsdf>"#,
        r#"<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>"#,
        r#"<bsdf type="mask"><texture type="checkerboard" name="opacity"/><bsdf type="diffuse"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><texture type="checkerboard" name="alpha"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><texture type="checkerboard" name="alpha_u"/><float name="alpha_v" value="0.2"/></bsdf>"#,
    ] {
        assert_eq!(bsdf_err(ok), "", "{ok}");
    }
}

#[test]
fn mask_bad_parameters() {
    assert_err(
        &bsdf_err(r#"<bsdf type="mask"><float name="opacity" value="0.3"/></bsdf>"#),
        "mem.xml:4:1",
        "mask needs a nested <bsdf>",
    );
    assert_err(
        &bsdf_err(r#"<bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#),
        "mem.xml:4:41",
        "mask takes exactly one nested BSDF",
    );
    assert_err(
        &bsdf_err(
            r#"<bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf>"#,
        ),
        "mem.xml:4:1",
        "mask opacity must be in [0, 1]",
    );
    assert_err(
        &bsdf_err(r#"<bsdf type="null"><float name="opacity" value="0.5"/></bsdf>"#),
        "mem.xml:4:26",
        "unreferenced property 'opacity' in <bsdf type=\"null\">",
    );
}

#[test]
fn bumpmap_bad_parameters() {
    let tex = r#"<texture type="bitmap"><string name="filename" value="missing-on-purpose.png"/></texture>"#;
    assert_err(
        &bsdf_err(r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#),
        "mem.xml:4:1",
        "bumpmap needs a nested height <texture>",
    );
    assert_err(
        &bsdf_err(r#"<bsdf type="bumpmap"><texture type="checkerboard"/></bsdf>"#),
        "mem.xml:4:22",
        "height texture must be a 'bitmap'",
    );
    // The texture is checked first (a missing file is its own error at the <texture>).
    assert_err(
        &bsdf_err(&format!(r#"<bsdf type="bumpmap">{tex}</bsdf>"#)),
        "mem.xml:4:22",
        "missing-on-purpose.png",
    );
    assert_err(
        &bsdf_err(r#"<bsdf type="bumpmap"><bsdf type="diffuse"/><emitter type="area"/></bsdf>"#),
        "mem.xml:4:44",
        "not expected inside a bumpmap",
    );
}

#[test]
fn textured_alpha_follows_mitsuba_rules() {
    // roughplastic's alpha is a plain float in Mitsuba 3.
    assert_err(
        &bsdf_err(
            r#"<bsdf type="roughplastic"><texture type="checkerboard" name="alpha"/></bsdf>"#,
        ),
        "mem.xml:4:27",
        "'alpha' of bsdf 'roughplastic' must be a number",
    );
    assert_err(
        &bsdf_err(
            r#"<bsdf type="roughconductor"><texture type="checkerboard" name="alpha"/><float name="alpha_u" value="0.1"/></bsdf>"#,
        ),
        "mem.xml:4:1",
        "give either 'alpha' or 'alpha_u'/'alpha_v', not both",
    );
}

// ----------------------------------------------------------------------------------------------
// orthographic and thinlens sensors, cylinder shape: loading and errors at the element

/// Instantiates `sensor` (line 2) with one `shape` (line 3).
fn sensor_shape_err(sensor: &str, shape: &str) -> String {
    let text = format!("<scene version=\"3.0.0\">\n{sensor}\n{shape}\n</scene>\n");
    let doc = load(&text).expect("parses");
    groove::load::instantiate(&doc, Path::new("mem.xml"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
}

const FILM: &str = r#"<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="2"/></film>"#;

#[test]
fn orthographic_thinlens_and_cylinder_load() {
    let sphere = r#"<shape type="sphere"/>"#;
    for sensor in [
        format!(
            r#"<sensor type="orthographic"><float name="near_clip" value="0.5"/><float name="focus_distance" value="3"/>{FILM}</sensor>"#
        ),
        format!(
            r#"<sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/><float name="fov" value="30"/><string name="fov_axis" value="y"/>{FILM}</sensor>"#
        ),
        format!(
            r#"<sensor type="thinlens"><float name="aperture_radius" value="0"/><string name="focal_length" value="35mm"/>{FILM}</sensor>"#
        ),
    ] {
        assert_eq!(sensor_shape_err(&sensor, sphere), "", "{sensor}");
    }
    let sensor = format!(r#"<sensor type="perspective">{FILM}</sensor>"#);
    for shape in [
        r#"<shape type="cylinder"/>"#,
        r#"<shape type="cylinder"><point name="p0" x="1" y="0" z="0"/><point name="p1" x="1" y="2" z="0"/><float name="radius" value="0.3"/><boolean name="flip_normals" value="true"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
        r#"<shape type="cylinder"><transform name="to_world"><scale value="2"/><rotate x="1" angle="30"/></transform></shape>"#,
    ] {
        assert_eq!(sensor_shape_err(&sensor, shape), "", "{shape}");
    }
}

#[test]
fn orthographic_thinlens_and_cylinder_bad_parameters() {
    let sphere = r#"<shape type="sphere"/>"#;
    let s = |body: &str, ty: &str| format!(r#"<sensor type="{ty}">{body}{FILM}</sensor>"#);
    for (sensor, msg) in [
        (s(r#"<float name="fov" value="40"/>"#, "orthographic"), "unreferenced property 'fov'"),
        (s(r#"<float name="near_clip" value="2"/><float name="far_clip" value="1"/>"#, "orthographic"), "far_clip (1) must be finite and greater than near_clip (2)"),
        (s(r#"<transform name="to_world"><scale z="0"/></transform>"#, "orthographic"), "maps the viewing direction (+z) to zero"),
        (s("", "thinlens"), "thinlens needs an 'aperture_radius'"),
        (s(r#"<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="-1"/>"#, "thinlens"), "focus_distance must be positive"),
        (s(r#"<float name="aperture_radius" value="0.1"/><float name="fov" value="30"/><string name="focal_length" value="50mm"/>"#, "thinlens"), "either fov or focal_length"),
        (s(r#"<float name="aperture_radius" value="0.1"/><transform name="to_world"><scale value="2"/></transform>"#, "thinlens"), "thinlens: scale factors"),
        (s(r#"<float name="aperture_radius" value="0.1"/><float name="principal_point_offset_x" value="0.1"/>"#, "thinlens"), "unreferenced property 'principal_point_offset_x'"),
        (s(r#"<float name="shutter_open" value="1"/><float name="shutter_close" value="0.5"/>"#, "orthographic"), "shutter_close (0.5) must not be less than shutter_open (1)"),
        (s("", "fisheye"), "unknown sensor plugin 'fisheye' (groove supports: perspective, orthographic, thinlens)"),
    ] {
        // At the element, or at the unused property inside it.
        let err = sensor_shape_err(&sensor, sphere);
        assert!(err.starts_with("mem.xml:2:"), "{sensor}: {err}");
        assert!(err.contains(msg), "expected '{msg}' in: {err}");
    }
    let sensor = format!(r#"<sensor type="perspective">{FILM}</sensor>"#);
    for (shape, msg) in [
        (r#"<shape type="cylinder"><float name="height" value="2"/></shape>"#, "unreferenced property 'height'"),
        (r#"<shape type="cylinder"><float name="radius" value="0"/></shape>"#, "radius must be finite and non-zero"),
        (r#"<shape type="cylinder"><point name="p0" x="0" y="0" z="1"/></shape>"#, "must be finite and distinct"),
        (r#"<shape type="cylinder"><transform name="to_world"><scale x="0"/></transform></shape>"#, "to_world is degenerate"),
        (r#"<shape type="capsule"/>"#, "unknown shape plugin 'capsule' (groove supports: obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, shapegroup, instance, linearcurve, bsplinecurve, sdfgrid)"),
    ] {
        let err = sensor_shape_err(&sensor, shape);
        assert!(err.starts_with("mem.xml:3:"), "{shape}: {err}");
        assert!(err.contains(msg), "expected '{msg}' in: {err}");
    }
}
