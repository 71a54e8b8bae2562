//! Loading heterogeneous media: `<medium type="heterogeneous">` with `gridvolume` and
//! `constvolume` (`tests/data/volumes`, written by `tests/refs/make_volumes.py`): the grid's index
//! order, `use_grid_bbox`, `to_world`, `scale`, the majorant, Mitsuba's unit-cube extent of a
//! constant; and clear errors at file:line:col for what is not supported or not valid.

use super::media::{assert_err, load, load_err};
use glam::Vec3;
use groove::medium::Medium;
use std::path::{Path, PathBuf};

fn volumes() -> PathBuf {
    crate::common::repo_root().join("tests/data/volumes")
}

fn grid_medium(file: &Path, extra: &str) -> String {
    format!(
        "<medium type=\"heterogeneous\"><volume type=\"gridvolume\" name=\"sigma_t\">\
         <string name=\"filename\" value=\"{}\"/>{extra}</volume></medium>",
        file.display()
    )
}

/// `ramp_box.vol` (6×4×2, value x + 10y + 100z at voxel (x, y, z), box (−1, 0, 2)..(2, 1, 3)) with
/// `use_grid_bbox` and a translation: voxel centres land where Mitsuba puts them and read their
/// value (x fastest in the file), the majorant is scale × the grid's maximum, the medium's extent
/// is the placed box.
#[test]
fn grid_index_order_bbox_scale_and_majorant() {
    let body = format!(
        "<medium type=\"heterogeneous\"><float name=\"scale\" value=\"0.5\"/>\
         <volume type=\"gridvolume\" name=\"sigma_t\">\
         <string name=\"filename\" value=\"{}\"/><boolean name=\"use_grid_bbox\" value=\"true\"/>\
         <transform name=\"to_world\"><translate x=\"10\"/></transform></volume>\
         <rgb name=\"albedo\" value=\"0.5, 0.25, 1\"/></medium>",
        volumes().join("ramp_box.vol").display()
    );
    let l = load(&body).unwrap_or_else(|e| panic!("{e}"));
    let m = &l.scene.media()[0];
    assert!(!m.is_homogeneous());
    assert_eq!(m.majorant(), Vec3::splat(0.5 * 135.0));
    for (x, y, z) in [(0, 0, 0), (5, 0, 0), (2, 3, 0), (4, 1, 1), (5, 3, 1)] {
        let p = Vec3::new(
            9.0 + (x as f32 + 0.5) / 2.0,
            (y as f32 + 0.5) / 4.0,
            2.0 + (z as f32 + 0.5) / 2.0,
        );
        let c = m.coefficients(p);
        let want = 0.5 * (x + 10 * y + 100 * z) as f32;
        assert!(
            (c.sigma_t - Vec3::splat(want)).abs().max_element() < 1e-3,
            "voxel ({x}, {y}, {z}): {} vs {want}",
            c.sigma_t
        );
        assert!(
            (c.sigma_s - Vec3::new(0.5, 0.25, 1.0) * want)
                .abs()
                .max_element()
                < 1e-3
        );
        assert!((c.sigma_n - Vec3::splat(67.5 - want)).abs().max_element() < 1e-3);
    }
    let (t0, t1) = m.clip(Vec3::new(0.0, 0.5, 2.5), Vec3::X, 100.0).unwrap();
    assert!(
        (t0 - 9.0).abs() < 1e-4 && (t1 - 12.0).abs() < 1e-4,
        "{t0} {t1}"
    );
    assert!(m.clip(Vec3::new(0.0, 1.5, 2.5), Vec3::X, 100.0).is_none());
}

/// A float `sigma_t` is a `constvolume` on the unit cube, as in Mitsuba: the medium exists there
/// only. Defaults: albedo 0.75, isotropic, sample_emitters.
#[test]
fn a_constant_heterogeneous_medium_lives_in_the_unit_cube() {
    let l = load("<medium type=\"heterogeneous\"><float name=\"sigma_t\" value=\"2\"/></medium>")
        .unwrap_or_else(|e| panic!("{e}"));
    let m = &l.scene.media()[0];
    let Medium::Heterogeneous(h) = m else {
        panic!("not heterogeneous")
    };
    assert_eq!(h.majorant, 2.0);
    assert!(h.sample_emitters && h.spectral_extinction);
    let c = m.coefficients(Vec3::splat(0.5));
    assert_eq!(c.sigma_s, Vec3::splat(1.5));
    let (t0, t1) = m.clip(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 10.0).unwrap();
    assert_eq!((t0, t1), (1.0, 2.0));
    // A constvolume's to_world moves the cube.
    let l = load(
        "<medium type=\"heterogeneous\"><volume type=\"constvolume\" name=\"sigma_t\">\
         <float name=\"value\" value=\"3\"/><transform name=\"to_world\"><scale value=\"4\"/>\
         </transform></volume></medium>",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let m = &l.scene.media()[0];
    let (t0, t1) = m.clip(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 10.0).unwrap();
    assert_eq!((t0, t1), (1.0, 5.0));
}

/// Writes a `.vol` file into a scratch folder of its own (removed with the returned file).
fn temp_vol(
    name: &str,
    n: [i32; 3],
    channels: i32,
    values: &[f32],
    real_len: Option<usize>,
) -> crate::common::ScratchFile {
    let dir = crate::common::Scratch::new(&format!("groove_h21_{}_{name}", std::process::id()));
    let path = crate::common::ScratchFile::new(dir, "grid.vol");
    let mut b = b"VOL\x03".to_vec();
    for v in [1, n[0], n[1], n[2], channels] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in [0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in values {
        b.extend_from_slice(&v.to_le_bytes());
    }
    if let Some(len) = real_len {
        b.truncate(len);
    }
    std::fs::write(&path, b).unwrap();
    path
}

#[test]
fn heterogeneous_errors_name_the_element() {
    let e = load_err(
        "<medium type=\"heterogeneous\"><volume type=\"gridvolume\" name=\"sigma_t\"/></medium>",
    );
    assert_err(&e, "mem.xml:3:30", "gridvolume needs a 'filename'");
    let e = load_err(&grid_medium(
        &volumes().join("blob.vol"),
        "<string name=\"filter_type\" value=\"cubic\"/>",
    ));
    assert_err(&e, "mem.xml:3:30", "invalid filter type \"cubic\"");
    let e = load_err(&grid_medium(
        &volumes().join("blob.vol"),
        "<string name=\"wrap_mode\" value=\"border\"/>",
    ));
    assert_err(&e, "mem.xml:3:30", "invalid wrap mode \"border\"");
    let e = load_err(&grid_medium(
        &volumes().join("blob.vol"),
        "<float name=\"max_value\" value=\"0.5\"/>",
    ));
    assert_err(
        &e,
        "mem.xml:3:30",
        "'max_value' 0.5 is below the grid's largest value",
    );
    let e = load_err(&grid_medium(&volumes().join("no_such.vol"), ""));
    assert!(e.contains("no_such.vol"), "{e}");
    // A NaN, a 6-channel grid, a header promising more voxels than the file holds, absurd sizes.
    let nan = temp_vol("nan", [2, 2, 1], 1, &[0.0, 1.0, f32::NAN, 0.0], None);
    let e = load_err(&grid_medium(&nan, ""));
    assert_err(&e, "mem.xml:3:30", "value NaN at voxel (x 0, y 1, z 0)");
    let six = temp_vol("six", [1, 1, 1], 6, &[0.0; 6], None);
    let e = load_err(&grid_medium(&six, ""));
    assert_err(&e, "mem.xml:3:30", "needs 1 or 3 channels, this grid has 6");
    let short = temp_vol("short", [4, 4, 4], 1, &[0.0; 64], Some(48 + 100));
    let e = load_err(&grid_medium(&short, ""));
    assert_err(
        &e,
        "mem.xml:3:30",
        "4x4x4 voxels of 1 channel(s) need 256 bytes",
    );
    let huge = temp_vol("huge", [100_000, 100_000, 100_000], 1, &[0.0; 4], None);
    let e = load_err(&grid_medium(&huge, ""));
    assert_err(&e, "mem.xml:3:30", "100000x100000x100000 voxels");
    let bad = temp_vol("magic", [1, 1, 1], 1, &[0.0], None);
    let mut bytes = std::fs::read(&bad).unwrap();
    bytes[0] = b'X';
    std::fs::write(&bad, bytes).unwrap();
    let e = load_err(&grid_medium(&bad, ""));
    assert_err(&e, "mem.xml:3:30", "no 'VOL' magic");
    // Other volume plugins, names, and grids where groove needs a constant.
    let e = load_err(
        "<medium type=\"heterogeneous\"><volume type=\"sphere\" name=\"sigma_t\"/></medium>",
    );
    assert_err(&e, "mem.xml:3:30", "volume");
    let e = load_err(
        "<medium type=\"heterogeneous\"><volume type=\"constvolume\" name=\"density\"/></medium>",
    );
    assert_err(
        &e,
        "mem.xml:3:30",
        "takes volumes named 'sigma_t' or 'albedo', not 'density'",
    );
    let e = load_err(&format!(
        "<medium type=\"homogeneous\"><volume type=\"gridvolume\" name=\"sigma_t\">\
         <string name=\"filename\" value=\"{}\"/></volume></medium>",
        volumes().join("blob.vol").display()
    ));
    assert_err(&e, "mem.xml:3:28", "must be a constant");
    let e =
        load_err("<medium type=\"heterogeneous\"><rgb name=\"radiance\" value=\"1\"/></medium>");
    assert_err(&e, "mem.xml:3:1", "emissive media are not supported");
    let e = load_err(&grid_medium(
        &volumes().join("blob.vol"),
        "<float name=\"density\" value=\"1\"/>",
    ));
    assert!(e.contains("unreferenced property 'density'"), "{e}");
}
