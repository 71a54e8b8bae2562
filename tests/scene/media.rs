//! Loading participating media: `<medium>` (`homogeneous`), `<phase>`, the media of shapes and of
//! the sensor, `volpath`; errors at the element's file:line:col; and Mitsuba 3's own regression
//! scenes with media (`../survey/mitsuba-data/tests/scenes/participating_media`, when present).
//! Heterogeneous media: `media_hetero.rs`.

use groove::medium::{Medium, Phase};
use std::path::Path;

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n")
}

/// Shared with the other media loader tests.
pub(crate) fn load(body: &str) -> groove::error::Result<groove::load::Loaded> {
    let doc = groove::scene::xml::parse::load_str(&scene(body), Path::new("mem.xml"), &[])
        .expect("the XML parses");
    groove::load::instantiate(&doc, Path::new("mem.xml"))
}

/// Shared with the other media loader tests.
pub(crate) fn load_err(body: &str) -> String {
    match load(body) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    }
}

/// Shared with the other media loader tests.
pub(crate) fn assert_err(err: &str, loc: &str, msg: &str) {
    assert!(
        err.starts_with(&format!("{loc}: ")),
        "expected location {loc}, got: {err}"
    );
    assert!(err.contains(msg), "expected '{msg}' in: {err}");
}

#[test]
fn shape_media_by_reference_and_nested_and_the_sensor_medium() {
    let text = "<scene version=\"3.0.0\">\n\
        <medium type=\"homogeneous\" id=\"m\"><float name=\"sigma_t\" value=\"2\"/><float name=\"scale\" value=\"3\"/><rgb name=\"albedo\" value=\"0.5, 0.6, 0.7\"/><phase type=\"hg\"><float name=\"g\" value=\"0.3\"/></phase></medium>\n\
        <integrator type=\"volpath\"><integer name=\"max_depth\" value=\"7\"/></integrator>\n\
        <sensor type=\"perspective\"><ref id=\"m\"/></sensor>\n\
        <shape type=\"sphere\"><bsdf type=\"null\"/><ref name=\"interior\" id=\"m\"/>\
        <medium type=\"homogeneous\" name=\"exterior\"/></shape>\n\
        </scene>\n";
    let doc = groove::scene::xml::parse::load_str(text, Path::new("mem.xml"), &[]).unwrap();
    let l = groove::load::instantiate(&doc, Path::new("mem.xml")).unwrap_or_else(|e| panic!("{e}"));
    let s = &l.scene;
    assert_eq!(
        s.media().len(),
        2,
        "one medium per element, however often referenced"
    );
    assert_eq!(s.camera_medium(), Some(0));
    assert_eq!(s.shape_media()[0].interior, Some(0));
    assert_eq!(s.shape_media()[0].exterior, Some(1));
    let Medium::Homogeneous(m) = &s.media()[0] else {
        panic!("not homogeneous")
    };
    assert_eq!(m.sigma_t, glam::Vec3::splat(6.0));
    assert!(
        (m.sigma_s - glam::Vec3::new(3.0, 3.6, 4.2))
            .abs()
            .max_element()
            < 1e-5
    );
    assert!(matches!(m.phase, Phase::Hg(h) if h.g == 0.3));
    // Mitsuba's defaults: sigma_t 1, albedo 0.75, isotropic, sample_emitters.
    let Medium::Homogeneous(d) = &s.media()[1] else {
        panic!("not homogeneous")
    };
    assert_eq!(d.sigma_t, glam::Vec3::ONE);
    assert_eq!(d.sigma_s, glam::Vec3::splat(0.75));
    assert!(matches!(d.phase, Phase::Isotropic) && d.sample_emitters);
    assert!(matches!(
        l.settings.integrator,
        groove::integrator::IntegratorDesc::Volpath(v) if v.max_depth == 7 && v.rr_depth == 5
    ));
}

#[test]
fn media_errors_name_the_element() {
    // Mitsuba 3.9.1 reads an rgb sigma_t as a reflectance.
    let e =
        load_err("<medium type=\"homogeneous\"><rgb name=\"sigma_t\" value=\"2, 1, 1\"/></medium>");
    assert_err(&e, "mem.xml:3:48", "must be in the range [0, 1]");
    let e = load_err("<medium type=\"inhomogeneous\"/>");
    assert_err(&e, "mem.xml:3:1", "inhomogeneous");
    let e = load_err("<medium type=\"homogeneous\"><rgb name=\"radiance\" value=\"1\"/></medium>");
    assert_err(&e, "mem.xml:3:1", "emissive media are not supported");
    let e = load_err("<medium type=\"homogeneous\"><phase type=\"hg\"><float name=\"g\" value=\"1\"/></phase></medium>");
    assert_err(&e, "mem.xml:3:28", "'g' must lie in the interval (-1, 1)");
    let e = load_err("<medium type=\"homogeneous\"><phase type=\"blendphase\"><float name=\"weight\" value=\"0.5\"/><phase type=\"isotropic\"/></phase></medium>");
    assert_err(
        &e,
        "mem.xml:3:28",
        "two child phase functions must be specified",
    );
    let e = load_err("<medium type=\"homogeneous\"><phase type=\"rayleigh\"/></medium>");
    assert_err(
        &e,
        "mem.xml:3:28",
        "Mitsuba plugin 'rayleigh' (phase) is not supported by groove",
    );
    let e = load_err("<medium type=\"homogeneous\"><float name=\"sigmat\" value=\"1\"/></medium>");
    assert_err(&e, "mem.xml:3:35", "unreferenced property 'sigmat'");
    let e = load_err(
        "<medium type=\"homogeneous\"><volume type=\"gridvolume\" name=\"sigma_t\"/></medium>",
    );
    assert_err(&e, "mem.xml:3:28", "not a 'gridvolume' volume");
    let e =
        load_err("<shape type=\"sphere\"><medium type=\"homogeneous\" name=\"inside\"/></shape>");
    assert_err(&e, "mem.xml:3:22", "must be named 'interior' or 'exterior'");
    let e =
        load_err("<medium type=\"homogeneous\"><float name=\"albedo\" value=\"1.5\"/></medium>");
    assert_err(&e, "mem.xml:3:1", "'albedo' must lie in [0, 1]");
}

/// Mitsuba 3's regression scenes with homogeneous and heterogeneous media load (their integrators
/// wrapped in `moment`), the two `volpathmis` ones included.
#[test]
fn mitsuba_regression_media_scenes_load() {
    // Beside the repository, as the shared Cornell box is (`../survey/mitsuba-data`), or under
    // `$MITSUBA_DATA`.
    let Some(dir) = crate::common::mitsuba_media_scenes() else {
        return;
    };
    let opts = groove::load::options::LoadOptions {
        defines: vec![("spp".into(), "4".into()), ("res".into(), "8".into())],
        ..Default::default()
    };
    let mut loaded = 0;
    for name in [
        "test_homo_area_light_volpath",
        "test_homo_dielectric_envmap_volpath",
        "test_homo_emitter_inside_medium_volpath",
        "test_homo_null_envmap_volpath",
        "test_homo_obj_inside_medium_volpath",
        "test_homo_roughdielectric_spot_volpath",
        "test_surf_area_light_volpath",
        "test_hetero_sigmat_albedo_volpath",
        "test_hetero_sigmat_volpath",
        "test_hetero_spectral_sigmat_no_scattering_volpath",
    ] {
        let l = groove::load::load_scene(&dir.join(format!("{name}.xml")), &opts)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            name.starts_with("test_surf") || !l.scene.media().is_empty(),
            "{name}"
        );
        loaded += 1;
    }
    assert_eq!(loaded, 10);
    for name in [
        "test_homo_spectral_sigmat_volpathmis",
        "test_hetero_spectral_sigmat_volpathmis",
    ] {
        let l = groove::load::load_scene(&dir.join(format!("{name}.xml")), &opts)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!l.scene.media().is_empty(), "{name}");
    }
}
