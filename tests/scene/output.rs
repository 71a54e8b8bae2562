//! Output: EXR round trips and Mitsuba's EXRs, PNG sRGB encoding, atomic writes.

use std::fs;
use std::path::{Path, PathBuf};

use groove::error::Error;
use groove::film::Image;
use groove::output::{read_exr, write_image, Metadata};

/// A fresh empty directory under the target dir for one test.
fn scratch(name: &str) -> PathBuf {
    let base = option_env!("CARGO_TARGET_TMPDIR")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    let dir = base.join(format!("groove-output-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// Names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn test_image() -> Image {
    let (w, h) = (5u32, 3u32);
    let mut img = Image::new(w, h);
    for (i, p) in img.data.iter_mut().enumerate() {
        let i = i as f32;
        *p = [i * 0.1, -i * 1.7e-3, 1.0 / (i + 3.0)];
    }
    img.data[1] = [f32::MIN_POSITIVE / 8.0, 65504.0 * 3.0, 1e-30];
    img.data[2] = [f32::INFINITY, 0.0, -0.0];
    img
}

fn meta() -> Metadata {
    Metadata(vec![
        ("groove.spp".into(), "64".into()),
        ("groove.seed".into(), "7".into()),
        ("groove.render_time_s".into(), "1.25".into()),
        ("groove.scene".into(), "/scenes/ü/日本.xml".into()),
        ("groove.version".into(), "0.1.0".into()),
    ])
}

#[test]
fn exr_round_trip_is_bit_exact_with_metadata() {
    let dir = scratch("exr-rt");
    let path = dir.join("out.exr");
    let img = test_image();
    write_image(&path, &img, &meta()).unwrap();
    let (back, m) = read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (img.width, img.height));
    for (a, b) in img.data.iter().zip(&back.data) {
        for c in 0..3 {
            assert_eq!(a[c].to_bits(), b[c].to_bits());
        }
    }
    for (k, v) in &meta().0 {
        assert_eq!(m.get(k), Some(v.as_str()), "{k}");
    }
    assert_eq!(listing(&dir), vec!["out.exr".to_string()]);
    // Upper-case extension works too, and overwriting replaces the file.
    let upper = dir.join("OUT2.EXR");
    write_image(&upper, &img, &Metadata::default()).unwrap();
    write_image(&upper, &Image::new(2, 2), &Metadata::default()).unwrap();
    assert_eq!(read_exr(&upper).unwrap().0, Image::new(2, 2));
}

/// Written by Mitsuba 3.9.1 (`mi.Bitmap(array).write(...)`, float32 and float16 RGB).
fn mitsuba_expected(x: u32, y: u32) -> [f32; 3] {
    if (x, y) == (0, 0) {
        return [0.1, 3.5, 1000.0];
    }
    let (xf, yf) = (x as f32, y as f32);
    [xf * 0.25, yf * 0.5, 1.0 + 0.125 * (xf + 4.0 * yf)]
}

#[test]
fn reads_mitsuba_exr() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/output");
    for (file, first_r) in [
        ("mitsuba_4x4.exr", 0.1f32),
        ("mitsuba_4x4_f16.exr", 1638.0 / 16384.0), // 0.1 in f16
    ] {
        let (img, m) = read_exr(&data.join(file)).unwrap();
        assert_eq!((img.width, img.height), (4, 4));
        for y in 0..4 {
            for x in 0..4 {
                let mut e = mitsuba_expected(x, y);
                if (x, y) == (0, 0) {
                    e[0] = first_r;
                }
                assert_eq!(img.get(x, y), e, "{file} ({x},{y})");
            }
        }
        assert_eq!(m.get("generatedBy"), Some("Mitsuba version 3.9.1"));
    }
}

#[test]
fn read_exr_errors_name_the_file() {
    let dir = scratch("exr-bad");
    let missing = dir.join("missing.exr");
    let e = read_exr(&missing).unwrap_err().to_string();
    assert!(e.contains("missing.exr"), "{e}");
    let junk = dir.join("junk.exr");
    fs::write(&junk, b"not an exr at all").unwrap();
    let e = read_exr(&junk).unwrap_err().to_string();
    assert!(e.contains("junk.exr"), "{e}");
}

#[test]
fn png_is_srgb_8bit() {
    let dir = scratch("png");
    let path = dir.join("out.png");
    let mut img = Image::new(4, 2);
    img.data[0] = [0.0, 1.0, 0.5];
    img.data[1] = [0.0031308, -1.0, 42.0];
    img.data[2] = [f32::NAN, 0.18, 0.002];
    img.data[7] = [1.0, 1.0, 1.0];
    write_image(&path, &img, &meta()).unwrap();
    let back = image::open(&path).unwrap().into_rgb8();
    assert_eq!(back.dimensions(), (4, 2));
    assert_eq!(back.get_pixel(0, 0).0, [0, 255, 188]);
    assert_eq!(back.get_pixel(1, 0).0, [10, 0, 255]);
    assert_eq!(back.get_pixel(2, 0).0, [0, 118, 7]);
    assert_eq!(back.get_pixel(3, 1).0, [255, 255, 255]);
    assert_eq!(back.get_pixel(0, 1).0, [0, 0, 0]);
}

#[test]
fn unsupported_extension_is_a_usage_error() {
    let dir = scratch("ext");
    for name in ["out.tif", "out"] {
        let e = write_image(&dir.join(name), &Image::new(1, 1), &Metadata::default()).unwrap_err();
        assert!(matches!(e, Error::Usage(_)), "{e:?}");
        if name == "out.tif" {
            assert!(e.to_string().contains(".tif"), "{e}");
        }
    }
    assert!(listing(&dir).is_empty());
}

#[test]
fn failed_writes_leave_no_temp_file_and_keep_the_old_target() {
    let dir = scratch("fail");
    // Missing output directory: the error names it.
    let nodir = dir.join("no/such/dir");
    let e = write_image(
        &nodir.join("x.exr"),
        &Image::new(1, 1),
        &Metadata::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no/such/dir"), "{e}");
    assert!(listing(&dir).is_empty());

    // The target is a directory.
    fs::create_dir(dir.join("taken.exr")).unwrap();
    let e = write_image(
        &dir.join("taken.exr"),
        &Image::new(1, 1),
        &Metadata::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("taken.exr"), "{e}");
    assert_eq!(listing(&dir), vec!["taken.exr".to_string()]);

    // An existing good file survives encoding failures that happen after the temp file exists.
    let good = dir.join("good.exr");
    write_image(&good, &test_image(), &meta()).unwrap();
    let before = fs::read(&good).unwrap();
    let bad_meta = Metadata(vec![("bad\0key".into(), "v".into())]);
    assert!(write_image(&good, &test_image(), &bad_meta).is_err());
    assert!(write_image(&good, &Image::new(0, 0), &Metadata::default()).is_err());
    let inconsistent = Image {
        width: 3,
        height: 3,
        data: vec![[0.0; 3]; 2],
    };
    assert!(write_image(&good, &inconsistent, &Metadata::default()).is_err());
    assert!(write_image(&dir.join("good.png"), &inconsistent, &Metadata::default()).is_err());
    assert_eq!(fs::read(&good).unwrap(), before);
    assert_eq!(
        listing(&dir),
        vec!["good.exr".to_string(), "taken.exr".to_string()]
    );
}
