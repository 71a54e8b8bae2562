//! Loading `evaluation = compensated` (issue 17 items 4 and 6): the table is built at load for a
//! nested BSDF it can describe, a nested BSDF it cannot describe is an error at the element when
//! the file asks for `compensated` and a warning plus the random walk under
//! `--normal-mapping compensated`, and the table is shared between loads (memory cache; these
//! tests do not use the disk cache).

use groove::load::load_scene;
use groove::load::options::{LoadOptions, NormalMapping};

/// A one-sphere scene whose BSDF is `bsdf`, written to a fresh temporary folder.
fn scene(name: &str, bsdf: &str) -> crate::common::ScratchFile {
    crate::common::one_sphere_scene("comp-load", name, bsdf)
}

const GOLD: &str = r#"<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.25"/></bsdf>"#;

#[test]
fn compensated_over_a_rough_conductor_loads() {
    let p = scene(
        "gold",
        &format!(
            r#"<bsdf type="microfacet_normalmap"><string name="evaluation" value="compensated"/>
            <rgb name="normalmap" value="0.7, 0.5, 0.9"/>{GOLD}</bsdf>"#
        ),
    );
    let t0 = std::time::Instant::now();
    let a = load_scene(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let first = t0.elapsed();
    let t1 = std::time::Instant::now();
    let b = load_scene(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let second = t1.elapsed();
    eprintln!("load with a table build {first:?}, again (memory cache) {second:?}");
    assert!(
        a.warnings.is_empty() && b.warnings.is_empty(),
        "{:?}",
        a.warnings
    );
    assert!(second < first, "the second load rebuilt the table");
}

#[test]
fn compensated_over_a_textured_roughness_is_an_error_at_the_element() {
    let p = scene(
        "textured",
        r#"<bsdf type="microfacet_normalmap"><string name="evaluation" value="compensated"/>
            <rgb name="normalmap" value="0.7, 0.5, 0.9"/>
            <bsdf type="roughconductor"><texture name="alpha" type="checkerboard"/></bsdf></bsdf>"#,
    );
    let e = load_scene(&p, &LoadOptions::default())
        .err()
        .expect("a textured roughness has no table")
        .to_string();
    assert!(e.contains("compensated") && e.contains("textured"), "{e}");
    assert!(
        e.contains("scene.xml:7:"),
        "the error names the element: {e}"
    );
}

#[test]
fn forced_compensated_over_glass_warns_and_walks() {
    let p = scene(
        "glass",
        r#"<bsdf type="normalmap"><rgb name="normalmap" value="0.7, 0.5, 0.9"/>
            <bsdf type="roughdielectric"><float name="alpha" value="0.1"/></bsdf></bsdf>"#,
    );
    let opts = LoadOptions {
        normal_mapping: NormalMapping::parse("compensated").unwrap(),
        ..LoadOptions::default()
    };
    let l = load_scene(&p, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("transmits") && w.contains("random walk")),
        "{:?}",
        l.warnings
    );
}

#[test]
fn compensated_is_a_normal_mapping_mode() {
    assert!(NormalMapping::NAMES.contains(&"compensated"));
    assert!(groove::bench::MODES.contains(&"compensated"));
}
