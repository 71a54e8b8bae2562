//! Radiance RGBE (`.hdr`) and PFM images through the loader: the `bitmap` texture's texels and the
//! `envmap`'s radiance equal what Mitsuba 3.9.1 reads from the same files
//! (tests/data/textures/float_images.json, written by tests/data/textures/mitsuba_float_images.py),
//! and broken or hostile files are errors at the element naming the file, before any large
//! allocation.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use groove::budget::Budget;
use groove::emitter::envmap::EnvMapLight;
use groove::emitter::Emitter;
use groove::load::{instantiate, instantiate_within};
use groove::scene::xml::parse::load_str;
use groove::texture::Texture;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn mitsuba() -> serde_json::Value {
    let text = std::fs::read_to_string(data().join("textures/float_images.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["mitsuba"], "3.9.1");
    json
}

/// A scene whose element `xml` is on line 3 (errors point at `FILE:3:1`), in `dir`.
fn scene(dir: &Path, xml: &str, budget: &Budget) -> groove::Result<groove::load::Loaded> {
    let text = format!(
        "<scene version=\"3.0.0\">\n\
         <sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor>\n\
         {xml}\n\
         </scene>\n"
    );
    let path = dir.join("scene.xml");
    let doc = load_str(&text, &path, &[])?;
    instantiate_within(&doc, &path, Default::default(), budget)
}

fn bitmap_xml(file: &Path, extra: &str) -> String {
    format!(
        "<texture type=\"bitmap\"><string name=\"filename\" value=\"{}\"/>{extra}</texture>",
        file.display()
    )
}

fn envmap_xml(file: &Path) -> String {
    format!(
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"{}\"/></emitter>",
        file.display()
    )
}

fn temp_dir(name: &str) -> crate::common::Scratch {
    crate::common::Scratch::new(&format!("groove-float-{}-{name}", std::process::id()))
}

#[test]
fn bitmap_texels_equal_mitsubas() {
    let json = mitsuba();
    for rel in [
        "textures/hdr_rle.hdr",
        "textures/pfm_rgb_be.pfm",
        "textures/pfm_grey_le.pfm",
        "envmaps/sky_rle.hdr",
    ] {
        let m = &json["images"][rel];
        let (w, h, ch) = (
            m["width"].as_u64().unwrap() as u32,
            m["height"].as_u64().unwrap() as u32,
            m["channels"].as_u64().unwrap() as usize,
        );
        let want: Vec<f32> = m["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap() as f32)
            .collect();
        // `raw` changes nothing for linear data.
        for raw in ["false", "true"] {
            let extra = format!("<boolean name=\"raw\" value=\"{raw}\"/>");
            let loaded = scene(
                &data(),
                &bitmap_xml(&data().join(rel), &extra),
                &Budget::default(),
            )
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
            let Texture::Bitmap(b) = &loaded.scene.materials().textures[0] else {
                panic!("{rel}: not a bitmap")
            };
            assert_eq!(b.resolution(), (w, h), "{rel}");
            assert_eq!(b.is_grey(), ch == 1, "{rel}");
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize * ch;
                    let t = b.texel(x, y);
                    let expect = if ch == 1 {
                        Vec3::splat(want[i])
                    } else {
                        Vec3::new(want[i], want[i + 1], want[i + 2])
                    };
                    assert_eq!(t, expect, "{rel} texel ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn envmap_radiance_at_texel_centres_equals_mitsubas_pixels() {
    let json = mitsuba();
    let m = &json["images"]["envmaps/sky_rle.hdr"];
    let want: Vec<f32> = m["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    // The same image as a colour PFM (bottom row first, little-endian), written here.
    let dir = temp_dir("env");
    let pfm = dir.join("sky.pfm");
    let mut bytes = b"PF\n32 16\n-1.0\n".to_vec();
    for y in (0..16).rev() {
        for v in &want[y * 96..(y + 1) * 96] {
            bytes.extend(v.to_le_bytes());
        }
    }
    std::fs::write(&pfm, bytes).unwrap();
    for file in [data().join("envmaps/sky_rle.hdr"), pfm] {
        let loaded = scene(&data(), &envmap_xml(&file), &Budget::default()).unwrap();
        let Emitter::EnvMap(env) = &loaded.scene.emitters()[0] else {
            panic!("not an envmap")
        };
        let env: &EnvMapLight = env;
        for j in 0..16usize {
            for i in 0..32usize {
                let uv = Vec2::new((i as f32 + 0.5) / 32.0, j as f32 / 15.0);
                let got = env.lookup(uv);
                let k = 3 * (j * 32 + i);
                let expect = Vec3::new(want[k], want[k + 1], want[k + 2]);
                assert!(
                    (got - expect).abs().max_element() <= 1e-5 * expect.max_element().max(1.0),
                    "{} texel ({i}, {j}): {got} vs {expect}",
                    file.display()
                );
            }
        }
    }
}

fn error(dir: &Path, xml: &str, budget: &Budget) -> String {
    match scene(dir, xml, budget) {
        Ok(_) => panic!("expected an error for {xml}"),
        Err(e) => e.to_string(),
    }
}

fn assert_error(dir: &Path, xml: &str, budget: &Budget, needles: &[&str]) {
    let e = error(dir, xml, budget);
    let loc = format!("{}:3:1: ", dir.join("scene.xml").display());
    assert!(e.starts_with(&loc), "expected location {loc}, got: {e}");
    for n in needles {
        assert!(e.contains(n), "expected '{n}' in: {e}");
    }
}

#[test]
fn broken_and_hostile_files_are_errors_at_the_element() {
    let dir = temp_dir("bad");
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let big = Budget::default();
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        // Truncated RGBE (flat) and PFM data, with the file's name and the offset.
        (
            write("short.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n\x80\x80\x80\x81"),
            vec!["short.hdr", "truncated RGBE data", "offset"],
        ),
        (
            write("short.pfm", b"PF\n2 2\n-1\n\0\0\0\0"),
            vec!["short.pfm", "truncated PFM data", "offset"],
        ),
        // Corrupt run-length data.
        (
            write(
                "rle.hdr",
                b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n\x02\x02\x00\x08\x90\x00\0\0\0\0\0\0",
            ),
            vec!["rle.hdr", "bad RGBE run-length data", "offset"],
        ),
        // No FORMAT line; an unsupported orientation; a bad PFM header.
        (
            write("nofmt.hdr", b"#?RADIANCE\n\n-Y 1 +X 1\n\0\0\0\0"),
            vec!["nofmt.hdr", "FORMAT"],
        ),
        (
            write("flip.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 1\n\0\0\0\0"),
            vec!["flip.hdr", "orientation"],
        ),
        (write("bad.pfm", b"PF\nwide 2\n-1\n"), vec!["bad.pfm", "bad PFM width"]),
    ];
    for (file, needles) in &cases {
        assert_error(&dir, &bitmap_xml(file, ""), &big, needles);
        assert_error(&dir, &envmap_xml(file), &big, needles);
    }
    // Hostile sizes: a few bytes claiming 60000 x 60000 pixels are refused by the memory budget
    // from the header, before anything is allocated (a 1 GB budget; 60000² f32 RGB is 40 GB).
    let small = Budget::new(1 << 30);
    let huge_hdr = write(
        "huge.hdr",
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 60000 +X 60000\n",
    );
    let huge_pfm = write("huge.pfm", b"PF\n60000 60000\n-1\n");
    for f in [&huge_hdr, &huge_pfm] {
        assert_error(
            &dir,
            &bitmap_xml(f, ""),
            &small,
            &["60000×60000", "memory limit"],
        );
        assert_error(
            &dir,
            &envmap_xml(f),
            &small,
            &["60000×60000", "memory limit"],
        );
    }
    // Within the budget, the same files are truncated.
    assert_error(
        &dir,
        &bitmap_xml(&huge_pfm, ""),
        &Budget::new(1 << 46),
        &["truncated PFM data"],
    );
    // A file of neither kind is still refused by the envmap, naming the formats it reads.
    let png = write("sky.png", b"not an image");
    assert_error(
        &dir,
        &envmap_xml(&png),
        &big,
        &["unsupported image format", "PFM"],
    );
    // The loader without a budget argument behaves the same.
    let text = std::fs::read_to_string(data().join("scenes/tex_hdr_pfm.xml")).unwrap();
    let path = data().join("scenes/tex_hdr_pfm.xml");
    let doc = load_str(&text, &path, &[]).unwrap();
    assert!(instantiate(&doc, &path).is_ok());
}
