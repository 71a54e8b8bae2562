//! The `ptracer` integrator's parameters as Mitsuba 3.9.1's `AdjointIntegrator` reads them, its
//! checks (with the element's file:line:col), and its refusal to be nested.

use std::path::Path;

fn load(body: &str) -> groove::error::Result<groove::load::Loaded> {
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[])
        .expect("the XML parses");
    groove::load::instantiate(&doc, Path::new("mem.xml"))
}

fn err(body: &str) -> String {
    match load(body) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn parameters_and_defaults() {
    use groove::integrator::IntegratorDesc;
    let l = load("<integrator type=\"ptracer\"/>").unwrap();
    let IntegratorDesc::Ptracer(p) = &l.settings.integrator else {
        panic!("{:?}", l.settings.integrator)
    };
    assert_eq!((p.max_depth, p.rr_depth, p.hide_emitters), (-1, 5, false));
    assert_eq!(p.samples_per_pass, None);
    let l = load(
        "<integrator type=\"ptracer\"><integer name=\"max_depth\" value=\"3\"/>\
         <integer name=\"rr_depth\" value=\"2\"/><boolean name=\"hide_emitters\" value=\"true\"/>\
         <integer name=\"samples_per_pass\" value=\"4\"/></integrator>",
    )
    .unwrap();
    let IntegratorDesc::Ptracer(p) = &l.settings.integrator else {
        panic!()
    };
    assert_eq!((p.max_depth, p.rr_depth, p.hide_emitters), (3, 2, true));
    assert_eq!(p.samples_per_pass, Some(4));
}

#[test]
fn bad_values_are_errors_at_the_element() {
    for (body, msg) in [
        (
            "<integrator type=\"ptracer\"><integer name=\"rr_depth\" value=\"0\"/></integrator>",
            "rr_depth must be set to a value greater than zero",
        ),
        (
            "<integrator type=\"ptracer\"><integer name=\"max_depth\" value=\"-2\"/></integrator>",
            "max_depth must be set to -1 (infinite) or a value >= 0",
        ),
        (
            "<integrator type=\"ptracer\"><integer name=\"samples_per_pass\" value=\"0\"/></integrator>",
            "samples_per_pass must be a positive sample count",
        ),
        (
            "<integrator type=\"ptracer\"><float name=\"max_dept\" value=\"3\"/></integrator>",
            "max_dept",
        ),
    ] {
        let e = err(body);
        assert!(e.starts_with("mem.xml:3:"), "{e}");
        assert!(e.contains(msg), "{e}");
    }
}

#[test]
fn ptracer_cannot_be_nested() {
    let e = err("<integrator type=\"moment\"><integrator type=\"ptracer\"/></integrator>");
    assert!(e.starts_with("mem.xml:3:27: "), "{e}");
    assert!(e.contains("a ptracer cannot be nested"), "{e}");
}

#[test]
fn sample_count_must_be_a_multiple_of_samples_per_pass() {
    let l = load(
        "<integrator type=\"ptracer\"><integer name=\"samples_per_pass\" value=\"3\"/></integrator>\
         <emitter type=\"constant\"/>",
    )
    .unwrap();
    let opts = |spp| groove::render::RenderOptions {
        spp: Some(spp),
        ..Default::default()
    };
    let e = groove::render::render(&l.scene, &l.settings, &opts(4))
        .err()
        .expect("4 is not a multiple of 3")
        .to_string();
    assert!(e.starts_with("mem.xml:3:1: "), "{e}");
    assert!(
        e.contains("sample_count (4) must be a multiple of samples_per_pass (3)"),
        "{e}"
    );
    assert!(groove::render::render(&l.scene, &l.settings, &opts(3)).is_ok());
}
