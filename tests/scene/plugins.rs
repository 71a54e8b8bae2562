//! Plugins groove does not build: polarisation plugins name the variant they need, other
//! Mitsuba 3.9.1 plugins say that groove lacks them, unknown names stay unknown (with the list of
//! supported ones); and the loader's checks of the `moment` and `aov` integrators. Every message
//! carries the element's file:line:col.

use std::path::Path;

/// Loads `body` inside a scene with a sensor; returns the error text.
fn load_err(body: &str) -> String {
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[])
        .expect("the XML parses");
    match groove::load::instantiate(&doc, Path::new("mem.xml")) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    }
}

fn loads(body: &str) -> groove::load::Loaded {
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[]).unwrap();
    groove::load::instantiate(&doc, Path::new("mem.xml")).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_err(err: &str, loc: &str, msg: &str) {
    assert!(
        err.starts_with(&format!("{loc}: ")),
        "expected location {loc}, got: {err}"
    );
    assert!(err.contains(msg), "expected '{msg}' in: {err}");
}

#[test]
fn polarisation_plugins_name_the_variant_they_need() {
    for (body, col) in [
        (
            "<shape type=\"sphere\"><bsdf type=\"polarizer\"/></shape>",
            22,
        ),
        (
            "<shape type=\"sphere\"><bsdf type=\"pplastic\"/></shape>",
            22,
        ),
        (
            "<shape type=\"sphere\"><bsdf type=\"retarder\"/></shape>",
            22,
        ),
        (
            "<shape type=\"sphere\"><bsdf type=\"measured_polarized\"/></shape>",
            22,
        ),
        ("<bsdf type=\"circular\"/>", 1),
        (
            "<integrator type=\"stokes\"><integrator type=\"path\"/></integrator>",
            1,
        ),
    ] {
        let e = load_err(body);
        assert_err(
            &e,
            &format!("mem.xml:3:{col}"),
            "needs a polarised variant (Mitsuba's *_polarized); groove renders RGB",
        );
    }
}

#[test]
fn other_mitsuba_plugins_are_named_as_unsupported() {
    for (body, name, kind) in [
        ("<shape type=\"sphere\"><bsdf type=\"measured\"/></shape>", "measured", "bsdf"),
        ("<shape type=\"ellipsoids\"/>", "ellipsoids", "shape"),
        ("<emitter type=\"sunsky\"/>", "sunsky", "emitter"),
        ("<integrator type=\"depth\"/>", "depth", "integrator"),
        ("<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"volume\" name=\"reflectance\"/></bsdf></shape>", "volume", "texture"),
    ] {
        let e = load_err(body);
        assert!(e.starts_with("mem.xml:3:"), "{e}");
        assert!(
            e.contains(&format!("Mitsuba plugin '{name}' ({kind}) is not supported by groove")),
            "{e}"
        );
    }
}

#[test]
fn unknown_plugins_stay_unknown_with_the_supported_list() {
    let e = load_err("<shape type=\"sphere\"><bsdf type=\"difuse\"/></shape>");
    assert_err(
        &e,
        "mem.xml:3:22",
        "unknown bsdf plugin 'difuse' (groove supports: diffuse",
    );
    let e = load_err("<integrator type=\"pathh\"/>");
    assert_err(&e, "mem.xml:3:1", "unknown integrator plugin 'pathh'");
    assert!(e.contains("moment, aov"), "{e}");
}

#[test]
fn moment_and_aov_channel_names_follow_mitsuba() {
    let l = loads(
        "<integrator type=\"moment\"><integrator type=\"path\"/><integrator type=\"direct\" name=\"d\"/><integrator type=\"path\"/></integrator>",
    );
    assert_eq!(
        l.settings.integrator.aov_names(),
        [
            "_arg_0.X",
            "_arg_0.Y",
            "_arg_0.Z",
            "d.X",
            "d.Y",
            "d.Z",
            "_arg_1.X",
            "_arg_1.Y",
            "_arg_1.Z",
            "m2__arg_0.X",
            "m2__arg_0.Y",
            "m2__arg_0.Z",
            "m2_d.X",
            "m2_d.Y",
            "m2_d.Z",
            "m2__arg_1.X",
            "m2__arg_1.Y",
            "m2__arg_1.Z"
        ]
    );
    // moment of aov: the inner channels come first, prefixed by the inner integrator's name.
    let l = loads(
        "<integrator type=\"moment\"><integrator type=\"aov\" name=\"a\"><string name=\"aovs\" value=\"z:depth\"/><integrator type=\"path\" name=\"p\"/></integrator></integrator>",
    );
    assert_eq!(
        l.settings.integrator.aov_names(),
        [
            "a.p.R", "a.p.G", "a.p.B", "a.p.A", "a.z.T", "a.X", "a.Y", "a.Z", "m2_a.p.R",
            "m2_a.p.G", "m2_a.p.B", "m2_a.p.A", "m2_a.z.T", "m2_a.X", "m2_a.Y", "m2_a.Z"
        ]
    );
    let l = loads("<integrator type=\"aov\"><string name=\"aovs\" value=\"dd.y:depth, n:sh_normal,i:shape_index\"/></integrator>");
    assert_eq!(
        l.settings.integrator.aov_names(),
        ["dd.y.T", "n.X", "n.Y", "n.Z", "i.I"]
    );
}

#[test]
fn aov_specifications_are_checked() {
    let e = load_err(
        "<integrator type=\"aov\">\n<string name=\"aovs\" value=\"dd:depthh\"/></integrator>",
    );
    assert_err(&e, "mem.xml:4:1", "invalid AOV type 'depthh'");
    let e =
        load_err("<integrator type=\"aov\">\n<string name=\"aovs\" value=\"dd\"/></integrator>");
    assert_err(&e, "mem.xml:4:1", "invalid AOV specification 'dd'");
    let e = load_err(
        "<integrator type=\"aov\">\n<string name=\"aovs\" value=\"a:albedo\"/></integrator>",
    );
    assert_err(
        &e,
        "mem.xml:4:1",
        "Mitsuba's AOV type 'albedo' is not supported by groove",
    );
    let e = load_err("<integrator type=\"aov\"/>");
    assert_err(&e, "mem.xml:3:1", "aov needs a string 'aovs'");
    let e = load_err("<integrator type=\"moment\">\n<bsdf type=\"diffuse\"/></integrator>");
    assert_err(&e, "mem.xml:4:1", "child objects must be integrators");
}

// ----------------------------------------------------------------------------------------------
// Parser parity with Mitsuba 3.9.1

fn load_text(text: &str) -> groove::Result<groove::load::Loaded> {
    let doc = groove::scene::xml::parse::load_str(text, Path::new("mem.xml"), &[])?;
    groove::load::instantiate(&doc, Path::new("mem.xml"))
}

#[test]
fn a_top_level_sampler_with_an_id_is_used_by_reference() {
    let l = load_text(
        "<scene version=\"3.0.0\">\n<sampler type=\"independent\" id=\"s\"><integer name=\"sample_count\" value=\"37\"/></sampler>\n<sensor type=\"perspective\"><ref id=\"s\"/></sensor>\n</scene>",
    )
    .unwrap();
    assert_eq!(l.settings.sampler.sample_count, 37);
    // Without an id it cannot be used: still an error at it.
    let e = load_text(
        "<scene version=\"3.0.0\">\n<sampler type=\"independent\"/>\n<sensor type=\"perspective\"/>\n</scene>",
    )
    .err()
    .unwrap()
    .to_string();
    assert_err(&e, "mem.xml:2:1", "belongs inside <sensor>");
}

#[test]
fn a_utf8_byte_order_mark_is_skipped() {
    let l = load_text(
        "\u{feff}<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\"><sensor type=\"perspective\"/></scene>",
    );
    assert!(l.is_ok(), "{:?}", l.err());
    // Positions on later lines are unchanged.
    let e = load_text("\u{feff}<scene version=\"3.0.0\">\n<sensor type=\"perspektive\"/></scene>")
        .err()
        .unwrap()
        .to_string();
    assert!(e.starts_with("mem.xml:2:1: "), "{e}");
}

#[test]
fn high_quality_edges_is_accepted_with_a_warning_only_in_upgraded_scenes() {
    let film =
        "<film type=\"hdrfilm\"><boolean name=\"high_quality_edges\" value=\"false\"/></film>";
    let e = load_text(&format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">{film}</sensor></scene>"
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("unreferenced property 'high_quality_edges'"),
        "{e}"
    );
    let l = load_text(&format!(
        "<scene version=\"0.6.0\">\n<sensor type=\"perspective\">{}</sensor></scene>",
        film.replace("high_quality_edges", "highQualityEdges")
    ))
    .unwrap();
    assert!(
        l.warnings.iter().any(|w| w.contains("high_quality_edges")),
        "{:?}",
        l.warnings
    );
}

#[test]
fn a_path_inside_an_included_file_is_relative_to_that_file() {
    let dir = crate::common::Scratch::new(&format!("groove-incpath-{}", std::process::id()));
    let sub = dir.join("sub");
    std::fs::create_dir_all(sub.join("assets")).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/geometry/quad.obj"),
        sub.join("assets/quad.obj"),
    )
    .unwrap();
    std::fs::write(
        sub.join("part.xml"),
        "<scene version=\"3.0.0\"><path value=\"assets\"/></scene>",
    )
    .unwrap();
    let main = dir.join("main.xml");
    std::fs::write(
        &main,
        "<scene version=\"3.0.0\"><include filename=\"sub/part.xml\"/><sensor type=\"perspective\"/><shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/></shape></scene>",
    )
    .unwrap();
    let l = groove::load::load_scene(&main, &Default::default());
    assert_eq!(l.unwrap_or_else(|e| panic!("{e}")).scene.shapes().len(), 1);
}

/// A `<path>` in an included file that does not exist from that file's folder is looked up from
/// the main scene's folder (and earlier `<path>`s), as Mitsuba 3.9.1's file resolver does:
/// mitsuba-data's `docs/scenes/include/emitter_scene.xml` says `<path value="../../common"/>`,
/// meant from `docs/scenes/`.
#[test]
fn a_path_inside_an_included_file_falls_back_to_the_search_folders() {
    let dir = crate::common::Scratch::new(&format!("groove-incpath2-{}", std::process::id()));
    let scenes = dir.join("docs/scenes");
    std::fs::create_dir_all(scenes.join("include")).unwrap();
    std::fs::create_dir_all(dir.join("common/meshes")).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/geometry/quad.obj"),
        dir.join("common/meshes/quad.obj"),
    )
    .unwrap();
    std::fs::write(
        scenes.join("include/part.xml"),
        "<scene version=\"3.0.0\"><path value=\"../../common\"/></scene>",
    )
    .unwrap();
    let main = scenes.join("main.xml");
    std::fs::write(
        &main,
        "<scene version=\"3.0.0\"><include filename=\"include/part.xml\"/><sensor type=\"perspective\"/><shape type=\"obj\"><string name=\"filename\" value=\"meshes/quad.obj\"/></shape></scene>",
    )
    .unwrap();
    let l = groove::load::load_scene(&main, &Default::default());
    assert_eq!(l.unwrap_or_else(|e| panic!("{e}")).scene.shapes().len(), 1);
}
