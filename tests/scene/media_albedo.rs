//! Loading a `homogeneous` medium whose `albedo` is a `gridvolume` (Mitsuba 3.9.1 evaluates it at
//! each interaction point; σt stays constant): the lookup through the volume's `to_world` and wrap
//! mode, what stays as it was for constant albedos, the errors; and Mitsuba's documentation scene
//! that needs it (`medium_homogeneous_sss_textured.xml`, when a `mitsuba-data` checkout is beside
//! the repository).

use super::media::{assert_err, load, load_err};
use glam::Vec3;
use groove::medium::Medium;
use std::path::PathBuf;

fn volumes() -> PathBuf {
    crate::common::repo_root().join("tests/data/volumes")
}

/// The albedo of `albedo_grid.vol` (as `tests/refs/make_volumes.py` writes it) at voxel (x, y, z).
fn albedo_voxel(x: usize, y: usize, z: usize) -> Vec3 {
    let (u, v, w) = (
        (x as f32 + 0.5) / 16.0,
        (y as f32 + 0.5) / 12.0,
        (z as f32 + 0.5) / 8.0,
    );
    Vec3::new(
        0.1 + 0.85 * u * u,
        0.2 + 0.35 * (1.0 + (2.0 * std::f32::consts::PI * v).cos()),
        0.9 - 0.7 * u * w,
    )
}

fn medium(extra_volume: &str, extra_medium: &str) -> String {
    format!(
        "<medium type=\"homogeneous\"><rgb name=\"sigma_t\" value=\"0.5, 0.25, 1\"/>\
         <float name=\"scale\" value=\"4\"/>{extra_medium}\
         <volume type=\"gridvolume\" name=\"albedo\">\
         <string name=\"filename\" value=\"{}\"/>{extra_volume}</volume></medium>",
        volumes().join("albedo_grid.vol").display()
    )
}

/// Voxel centres of the placed grid read their voxel (nearest and trilinear), points outside
/// its box read it through the wrap mode (the medium itself is unbounded: `clip` is the whole
/// ray), σt is the constant times `scale`, and the majorant is σt.
#[test]
fn a_grid_albedo_is_read_at_the_point_through_to_world() {
    // The unit cube scaled by 2 and moved by (1, 0, −1): voxel (x, y, z)'s centre is at
    // ((x + ½)/16, (y + ½)/12, (z + ½)/8)·2 + (1, 0, −1).
    let placed = "<transform name=\"to_world\"><scale value=\"2\"/>\
                  <translate value=\"1, 0, -1\"/></transform>";
    let centre = |x: usize, y: usize, z: usize| {
        Vec3::new(
            (x as f32 + 0.5) / 16.0 * 2.0 + 1.0,
            (y as f32 + 0.5) / 12.0 * 2.0,
            (z as f32 + 0.5) / 8.0 * 2.0 - 1.0,
        )
    };
    let sigma_t = Vec3::new(2.0, 1.0, 4.0);
    for filter in ["nearest", "trilinear"] {
        let l = load(&medium(
            &format!("<string name=\"filter_type\" value=\"{filter}\"/>{placed}"),
            "",
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        let m = &l.scene.media()[0];
        assert!(m.is_homogeneous());
        assert_eq!(m.majorant(), sigma_t);
        assert_eq!(m.clip(Vec3::splat(-50.0), Vec3::X, 1e3), Some((0.0, 1e3)));
        for (x, y, z) in [(0, 0, 0), (15, 11, 7), (3, 7, 2), (12, 1, 6)] {
            let c = m.coefficients(centre(x, y, z));
            assert_eq!(c.sigma_t, sigma_t);
            let want = sigma_t * albedo_voxel(x, y, z);
            assert!(
                (c.sigma_s - want).abs().max_element() < 1e-5,
                "{filter} ({x}, {y}, {z}): {} vs {want}",
                c.sigma_s
            );
        }
        // Clamp (the default): beyond the box in −x, +y, +z, voxel (0, 11, 7) is read.
        let c = m.coefficients(Vec3::new(-5.0, 9.0, 9.0));
        assert!(
            (c.sigma_s - sigma_t * albedo_voxel(0, 11, 7))
                .abs()
                .max_element()
                < 1e-5
        );
    }
    // Repeat: one box further along x reads the same voxel as inside.
    let l = load(&medium(
        &format!(
            "<string name=\"filter_type\" value=\"nearest\"/>\
                  <string name=\"wrap_mode\" value=\"repeat\"/>{placed}"
        ),
        "",
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let m = &l.scene.media()[0];
    let p = centre(5, 4, 3) + Vec3::new(2.0, 0.0, 0.0);
    assert!(
        (m.coefficients(p).sigma_s - sigma_t * albedo_voxel(5, 4, 3))
            .abs()
            .max_element()
            < 1e-5
    );
}

/// A constant albedo, given as a property or as a `constvolume`, loads as before: one σs, no
/// volume; grid values above 1 are accepted (as for `heterogeneous`, as in Mitsuba), a constant
/// above 1 is not.
#[test]
fn constant_albedos_are_unchanged_and_only_grids_may_exceed_one() {
    for body in [
        "<medium type=\"homogeneous\"><rgb name=\"albedo\" value=\"0.2, 0.4, 0.6\"/></medium>",
        "<medium type=\"homogeneous\"><volume type=\"constvolume\" name=\"albedo\">\
         <rgb name=\"value\" value=\"0.2, 0.4, 0.6\"/></volume></medium>",
    ] {
        let l = load(body).unwrap_or_else(|e| panic!("{e}"));
        let Medium::Homogeneous(h) = &l.scene.media()[0] else {
            panic!("not homogeneous")
        };
        assert!(h.albedo_volume.is_none());
        assert_eq!(h.sigma_s, Vec3::new(0.2, 0.4, 0.6));
        assert_eq!(h.sigma_s_at(Vec3::new(3.0, -7.0, 1.0)), h.sigma_s);
    }
    // ramp_box.vol holds values up to 135: accepted as an albedo grid.
    let body = format!(
        "<medium type=\"homogeneous\"><volume type=\"gridvolume\" name=\"albedo\">\
         <string name=\"filename\" value=\"{}\"/></volume></medium>",
        volumes().join("ramp_box.vol").display()
    );
    load(&body).unwrap_or_else(|e| panic!("{e}"));
    let e = load_err(
        "<medium type=\"homogeneous\"><volume type=\"constvolume\" name=\"albedo\">\
         <float name=\"value\" value=\"1.5\"/></volume></medium>",
    );
    assert_err(&e, "mem.xml:3:1", "'albedo' must lie in [0, 1]");
}

/// What stays refused, at the element: a grid `sigma_t` in a homogeneous medium (its free
/// flights need a constant), an `albedo` property beside an albedo volume (the parser's duplicate), the grid's own errors.
#[test]
fn grid_albedo_errors_name_the_element() {
    let e = load_err(&format!(
        "<medium type=\"homogeneous\"><volume type=\"gridvolume\" name=\"sigma_t\">\
         <string name=\"filename\" value=\"{}\"/></volume></medium>",
        volumes().join("blob.vol").display()
    ));
    assert_err(&e, "mem.xml:3:28", "'sigma_t' must be a constant");
    assert!(e.contains("heterogeneous"), "{e}");
    let e = load_err(&medium("", "<float name=\"albedo\" value=\"0.5\"/>"));
    assert!(e.contains("duplicate property 'albedo'"), "{e}");
    let e = load_err(&medium("<string name=\"wrap_mode\" value=\"border\"/>", ""));
    assert_err(&e, "mem.xml:3:101", "invalid wrap mode \"border\"");
    let e = load_err(&format!(
        "<medium type=\"homogeneous\"><volume type=\"gridvolume\" name=\"albedo\">\
         <string name=\"filename\" value=\"{}\"/></volume></medium>",
        volumes().join("no_such.vol").display()
    ));
    assert_err(&e, "mem.xml:3:28", "no_such.vol");
}

/// Mitsuba's documentation scene with a grid albedo (`docs/scenes/medium_homogeneous_sss_textured.xml`
/// of `mitsuba-data`) loads with its albedo as a volume, when a checkout with `docs/scenes` is
/// beside the repository (`../survey/mitsuba-data`); its render against Mitsuba is in
/// `docs/media.md`.
#[test]
fn mitsubas_textured_sss_scene_loads_when_present() {
    let file = crate::common::repo_root()
        .join("..")
        .join("survey/mitsuba-data/docs/scenes/medium_homogeneous_sss_textured.xml");
    if !file.is_file() {
        eprintln!("skipped: {} is not here", file.display());
        return;
    }
    let opts = groove::load::options::LoadOptions {
        defines: vec![("spp".into(), "1".into())],
        ..Default::default()
    };
    let l = groove::load::load_scene(&file, &opts).unwrap_or_else(|e| panic!("{e}"));
    let Medium::Homogeneous(h) = &l.scene.media()[0] else {
        panic!("not homogeneous")
    };
    assert!(h.albedo_volume.is_some());
    assert!(!h.spectral_extinction && !h.sample_emitters);
}
