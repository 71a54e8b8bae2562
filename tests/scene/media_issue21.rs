//! Issue 21's audit of what a medium refuses or converts (see `docs/media.md`, "Issue 21
//! checklist"): emission (Mitsuba 3.9.1's media have none: a `radiance` and a nested `<emitter>`
//! are errors at the element, as Mitsuba refuses the unreferenced object), spectra in an RGB
//! render (wavelength:value lists are converted and clamped as Mitsuba's `scalar_rgb` does; a
//! spectrum plugin or `.spd` file is an error at the attribute).

use super::media::{assert_err, load, load_err};
use glam::Vec3;
use groove::medium::Medium;
use std::path::Path;

fn homogeneous(l: &groove::load::Loaded) -> &groove::medium::Homogeneous {
    match &l.scene.media()[0] {
        Medium::Homogeneous(h) => h,
        _ => panic!("not homogeneous"),
    }
}

#[test]
fn emissive_media_and_emitters_inside_a_medium_are_errors_at_the_element() {
    for kind in ["homogeneous", "heterogeneous"] {
        let e = load_err(&format!(
            "<medium type=\"{kind}\"><rgb name=\"radiance\" value=\"1\"/></medium>"
        ));
        assert_err(&e, "mem.xml:3:1", "emissive media are not supported");
        for emitter in [
            "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>",
            "<emitter type=\"point\"/>",
        ] {
            let e = load_err(&format!("<medium type=\"{kind}\">{emitter}</medium>"));
            let col = 16 + kind.len() + 1;
            assert_err(
                &e,
                &format!("mem.xml:3:{col}"),
                &format!("<emitter> is not expected inside a {kind} <medium>"),
            );
        }
    }
}

#[test]
fn spectra_in_media_convert_as_mitsubas_rgb_variants_or_fail_at_the_attribute() {
    // A wavelength:value list above 1 is an out-of-gamut reflectance: Mitsuba 3.9.1 `scalar_rgb`
    // clamps it (its traversed sigma_t is [1, 1, 1]); a single value is a constant.
    let l = load(
        "<medium type=\"homogeneous\"><spectrum name=\"sigma_t\" value=\"400:2, 700:3\"/>\
         <spectrum name=\"albedo\" value=\"0.5\"/></medium>",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let h = homogeneous(&l);
    assert_eq!(h.sigma_t, Vec3::ONE);
    assert_eq!(h.sigma_s, Vec3::splat(0.5));
    for (attr, col) in [("type=\"blackbody\"", 53), ("filename=\"sigma.spd\"", 53)] {
        // Refused by the parser (before the loader sees the medium).
        let text = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n\
             <medium type=\"homogeneous\"><spectrum name=\"sigma_t\" {attr}/></medium>\n</scene>\n"
        );
        let e = match groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[]) {
            Ok(_) => panic!("{attr} was accepted"),
            Err(e) => e.to_string(),
        };
        assert_err(
            &e,
            &format!("mem.xml:3:{col}"),
            "spectrum plugins and spectrum files are not supported",
        );
    }
}
