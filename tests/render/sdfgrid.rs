//! Mitsuba 3.9.1's `sdfgrid` (`tests/data/scenes/sdfgrid.xml`, reference `tests/refs/sdfgrid.exr`
//! by tests/refs/make_refs.py, grids by tests/refs/make_sdfgrids.py): an instanced torus with
//! `smooth` normals and an ellipsoid with `analytic` ones under a non-uniform scale. The smooth
//! normals are shown to be seen: the torus with `analytic` normals is rejected. Run with
//! `cargo test --release --test render sdfgrid`.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};

#[test]
fn sdfgrid_matches_mitsuba() {
    let scene = test_scene("sdfgrid.xml");
    let (m, v) = load_reference("sdfgrid");
    let r = render_scene(&scene, &[], 1024, 181, 0, |l| {
        assert!(
            l.warnings.iter().all(|w| !w.contains("sdfgrid")),
            "{:?}",
            l.warnings
        );
    });
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("sdfgrid: {}", c.report());
    c.assert_consistent("sdfgrid.xml");

    let faceted = render_scene_edited(
        &scene,
        |t| {
            t.replacen(
                r#"<string name="normals" value="smooth"/>"#,
                r#"<string name="normals" value="analytic"/>"#,
                1,
            )
        },
        1024,
        182,
    );
    let c = compare(&faceted.mean, &faceted.var, &m, &v, 4);
    eprintln!("sdfgrid, torus with analytic normals: {}", c.report());
    assert!(
        !c.is_consistent(),
        "the torus with analytic normals was accepted"
    );
}
