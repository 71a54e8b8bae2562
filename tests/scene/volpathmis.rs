//! Loading `<integrator type="volpathmis">`: Mitsuba 3.9.1's parameters and defaults
//! (`max_depth`, `rr_depth`, `hide_emitters`, `use_spectral_mis`), nested in `moment`, and its
//! errors at the element's file:line:col.

use super::media::{assert_err, load, load_err};
use groove::integrator::IntegratorDesc;

fn settings(body: &str) -> groove::integrator::volpathmis::VolpathMisSettings {
    let l = load(body).unwrap_or_else(|e| panic!("{e}"));
    match l.settings.integrator {
        IntegratorDesc::VolpathMis(s) => (*s).clone(),
        other => panic!("not volpathmis: {other:?}"),
    }
}

#[test]
fn volpathmis_parameters_and_mitsuba_defaults() {
    // Mitsuba 3.9.1: max_depth -1, rr_depth 5, hide_emitters false, use_spectral_mis true.
    let s = settings("<integrator type=\"volpathmis\"/>");
    assert_eq!(
        (s.max_depth, s.rr_depth, s.hide_emitters, s.spectral_mis),
        (-1, 5, false, true)
    );
    assert_eq!(s.loc.to_string(), "mem.xml:3:1");
    let s = settings(
        "<integrator type=\"volpathmis\"><integer name=\"max_depth\" value=\"7\"/>\
         <integer name=\"rr_depth\" value=\"3\"/><boolean name=\"hide_emitters\" value=\"true\"/>\
         <boolean name=\"use_spectral_mis\" value=\"false\"/></integrator>",
    );
    assert_eq!(
        (s.max_depth, s.rr_depth, s.hide_emitters, s.spectral_mis),
        (7, 3, true, false)
    );
    // Inside a wrapper, with a medium on the sensor.
    let l = load(
        "<medium type=\"homogeneous\" id=\"m\"/>\n<integrator type=\"moment\">\
         <integrator type=\"volpathmis\" name=\"v\"/></integrator>",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let IntegratorDesc::Moment(m) = &l.settings.integrator else {
        panic!("not moment")
    };
    assert!(matches!(m.inner[0].1, IntegratorDesc::VolpathMis(_)));
}

#[test]
fn volpathmis_errors_name_the_element() {
    let e = load_err(
        "<integrator type=\"volpathmis\"><integer name=\"max_depth\" value=\"-2\"/></integrator>",
    );
    assert_err(
        &e,
        "mem.xml:3:1",
        "max_depth must be -1 (unlimited) or >= 0",
    );
    let e = load_err(
        "<integrator type=\"volpathmis\"><integer name=\"rr_depth\" value=\"0\"/></integrator>",
    );
    assert_err(&e, "mem.xml:3:1", "rr_depth must be >= 1");
    let e = load_err(
        "<integrator type=\"volpathmis\"><boolean name=\"use_spectral_mi\" value=\"false\"/></integrator>",
    );
    assert_err(
        &e,
        "mem.xml:3:40",
        "unreferenced property 'use_spectral_mi'",
    );
    let e = load_err(
        "<integrator type=\"volpathmis\"><integer name=\"use_spectral_mis\" value=\"1\"/></integrator>",
    );
    assert_err(
        &e,
        "mem.xml:3:31",
        "'use_spectral_mis' of <integrator type=\"volpathmis\"> is a <integer>, expected <boolean>",
    );
    // A misspelt type lists volpathmis among the supported integrators.
    let e = load_err("<integrator type=\"volpathmiss\"/>");
    assert!(e.starts_with("mem.xml:3:1: "), "{e}");
    assert!(e.contains("volpathmis"), "{e}");
}
