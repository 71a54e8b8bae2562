//! Mitsuba 3.9.1 quirks that change the image, matched by groove for parity (and warned about
//! when a scene is loaded): `direct` weighting delta-light emitter samples by 1 whatever
//! `emitter_samples` is, and `<rotate>` with a non-unit axis used unnormalised. Each reference
//! was made by tests/refs/make_refs.py; each test also shows that the quirk-free image is
//! rejected. Run with `cargo test --release --test render parity`.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};

#[test]
fn direct_with_four_emitter_samples_and_a_point_light_matches_mitsuba() {
    let scene = test_scene("direct_delta.xml");
    let (m, v) = load_reference("direct_delta");
    let r = render_scene(&scene, &[], 256, 151, 0, |l| {
        assert!(
            l.warnings.iter().any(|w| w.contains("emitter_samples = 4")),
            "{:?}",
            l.warnings
        );
    });
    compare(&r.mean, &r.var, &m, &v, 4).assert_consistent("direct_delta.xml");
    // One emitter sample: the point light counts once, which is not Mitsuba's image at 4.
    let one = render_scene(&scene, &[("es", "1")], 256, 152, 0, |l| {
        assert!(!l.warnings.iter().any(|w| w.contains("emitter_samples")));
    });
    let c = compare(&one.mean, &one.var, &m, &v, 4);
    assert!(!c.is_consistent(), "emitter_samples = 1 was accepted");
}

#[test]
fn non_unit_rotation_axes_match_mitsuba() {
    let scene = test_scene("rotate_axis.xml");
    let (m, v) = load_reference("rotate_axis");
    let r = render_scene(&scene, &[], 512, 153, 0, |l| {
        let n = l
            .warnings
            .iter()
            .filter(|w| w.contains("<rotate> axis"))
            .count();
        assert_eq!(n, 2, "{:?}", l.warnings);
    });
    compare(&r.mean, &r.var, &m, &v, 4).assert_consistent("rotate_axis.xml");
    // The same axes normalised (a pure rotation) give another image.
    let s = std::f32::consts::FRAC_1_SQRT_2.to_string();
    let unit = render_scene_edited(
        &scene,
        |t| {
            t.replace(
                r#"<rotate x="1" y="1" angle="50"/>"#,
                &format!(r#"<rotate x="{s}" y="{s}" angle="50"/>"#),
            )
            .replace(
                r#"<rotate y="0.5" z="0.5" angle="70"/>"#,
                &format!(r#"<rotate y="{s}" z="{s}" angle="70"/>"#),
            )
        },
        512,
        154,
    );
    let c = compare(&unit.mean, &unit.var, &m, &v, 4);
    assert!(!c.is_consistent(), "normalised rotation axes were accepted");
}
