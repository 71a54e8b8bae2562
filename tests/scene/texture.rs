//! Textures through the public API: the `bitmap` texture against Mitsuba 3.9.1 point evaluations
//! (tests/data/textures/points.json, written by tests/refs/texture_points.py), sRGB decoding,
//! filtering, wrapping, `to_uv`, 16-bit / grey / EXR data, and bad input reported at the
//! `<texture>` with the file's name.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use groove::load::instantiate;
use groove::scene::xml::parse::load_str;
use groove::spectrum::luminance;
use groove::texture::bitmap::{round_to_f16, srgb_to_linear};
use groove::texture::{BitmapOptions, BitmapTexture, FilterType, Texture, WrapMode};

fn textures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/textures")
}

/// A scene with one top-level `<texture>` on line 3 (so errors point at `FILE:3:1`).
fn scene_with(texture_xml: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n\
         <sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor>\n\
         {texture_xml}\n\
         </scene>\n"
    )
}

/// Loads `texture_xml` as if it were in `dir/scene.xml`; returns the texture and the warnings.
fn load_texture_in(dir: &Path, texture_xml: &str) -> groove::Result<(Texture, Vec<String>)> {
    let path = dir.join("scene.xml");
    let doc = load_str(&scene_with(texture_xml), &path, &[])?;
    let loaded = instantiate(&doc, &path)?;
    Ok((
        loaded.scene.materials().textures[0].clone(),
        loaded.warnings,
    ))
}

fn load_texture(texture_xml: &str) -> Texture {
    load_texture_in(&textures_dir(), texture_xml)
        .unwrap_or_else(|e| panic!("{texture_xml}: {e}"))
        .0
}

fn bitmap_xml(file: &str, extra: &str) -> String {
    format!(
        "<texture type=\"bitmap\"><string name=\"filename\" value=\"{file}\"/>{extra}</texture>"
    )
}

/// A fresh temporary folder for files written by a test.
fn temp_dir(name: &str) -> crate::common::Scratch {
    crate::common::Scratch::new(&format!("groove-texture-{}-{name}", std::process::id()))
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol * b.abs().max_element().max(1.0)
}

// ----------------------------------------------------------------------------------------------
// Against Mitsuba 3.9.1

#[test]
fn bitmap_and_checkerboard_match_mitsuba_point_evaluations() {
    let text = std::fs::read_to_string(textures_dir().join("points.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["mitsuba"], "3.9.1");
    let cases = json["cases"].as_array().unwrap();
    assert!(cases.len() >= 36);
    let (mut n_points, mut failures) = (0, Vec::new());
    for case in cases {
        let xml = case["xml"].as_str().unwrap();
        let tol = case["tolerance"].as_f64().unwrap() as f32;
        let tex = load_texture(xml);
        for p in case["points"].as_array().unwrap() {
            let v: Vec<f32> = p
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
                .collect();
            let uv = Vec2::new(v[0], v[1]);
            let want = Vec3::new(v[2], v[3], v[4]);
            let got = tex.eval(uv);
            n_points += 1;
            if !close(got, want, tol) {
                failures.push(format!("{xml}\n  uv {uv}: groove {got}, Mitsuba {want}"));
            }
        }
        // Mitsuba's mean(): the mean texel luminance for a bitmap; the average of the colours'
        // channel means for the checkerboard (its constant colours report their channel mean).
        let m = tex.mean();
        let mean = if tex.as_bitmap().is_some() {
            luminance(m)
        } else {
            m.element_sum() / 3.0
        };
        let want_mean = case["mean"].as_f64().unwrap() as f32;
        if (mean - want_mean).abs() > tol.max(1e-5) * want_mean.abs().max(1.0) {
            failures.push(format!("{xml}\n  mean: groove {mean}, Mitsuba {want_mean}"));
        }
    }
    assert!(n_points >= 900, "only {n_points} points");
    assert!(
        failures.is_empty(),
        "{} of {n_points} evaluations differ from Mitsuba:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn checkerboard_quarter_at_origin_is_color0() {
    let t = load_texture(
        "<texture type=\"checkerboard\"><rgb name=\"color0\" value=\"1, 0, 0\"/><rgb name=\"color1\" value=\"0, 0, 1\"/></texture>",
    );
    for (uv, c0) in [
        ((0.25, 0.25), true),
        ((0.75, 0.25), false),
        ((0.25, 0.75), false),
        ((0.75, 0.75), true),
        ((0.5, 0.5), true), // boundaries belong to the lower quarter (f > 0.5 is the upper)
        ((0.5, 0.51), false),
    ] {
        let want = if c0 { Vec3::X } else { Vec3::Z };
        assert_eq!(t.eval(Vec2::new(uv.0, uv.1)), want, "uv {uv:?}");
    }
}

// ----------------------------------------------------------------------------------------------
// Decoding

#[test]
fn srgb_decode_of_all_8bit_codes_matches_the_formula() {
    let dir = temp_dir("codes");
    let img = image::GrayImage::from_fn(256, 2, |x, _| image::Luma([x as u8]));
    img.save(dir.join("codes.png")).unwrap();
    let opts = BitmapOptions {
        filter: FilterType::Nearest,
        ..Default::default()
    };
    let srgb = BitmapTexture::load(&dir.join("codes.png"), &opts).unwrap();
    let raw =
        BitmapTexture::load(&dir.join("codes.png"), &BitmapOptions { raw: true, ..opts }).unwrap();
    assert!(srgb.is_grey());
    for c in 0..256u32 {
        let v = c as f64 / 255.0;
        let lin = if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        };
        assert_eq!(srgb.texel(c, 1), Vec3::splat(lin as f32), "code {c}");
        assert!((raw.texel(c, 0).x as f64 - v).abs() < 1e-7, "raw code {c}");
        // And through eval at the texel's centre.
        let uv = Vec2::new((c as f32 + 0.5) / 256.0, 0.25);
        assert_eq!(srgb.eval(uv), Vec3::splat(lin as f32));
    }
    assert_eq!(srgb_to_linear(0.04045), 0.04045 / 12.92);
    assert!((srgb_to_linear(0.5) - 0.214_041_140_482_232_54).abs() < 1e-15);
}

#[test]
fn sixteen_bit_png_is_srgb_decoded_and_stored_as_float16() {
    let path = textures_dir().join("rgb16.png");
    let t = BitmapTexture::load(&path, &BitmapOptions::default()).unwrap();
    assert_eq!(t.resolution(), (4, 3));
    let f = |c: u16| round_to_f16(srgb_to_linear(c as f64 / 65535.0) as f32);
    // Pixels set by tests/refs/texture_points.py.
    assert_eq!(t.texel(0, 0), Vec3::new(0.0, f(1), 1.0));
    assert_eq!(t.texel(1, 0), Vec3::new(f(1000), f(30000), f(50000)));
    assert_ne!(f(30000), srgb_to_linear(30000.0 / 65535.0) as f32);
    // format=variant keeps f32; raw skips the sRGB curve.
    let v = BitmapTexture::load(
        &path,
        &BitmapOptions {
            format: groove::texture::StorageFormat::Variant,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(v.texel(1, 0).y, srgb_to_linear(30000.0 / 65535.0) as f32);
    let r = BitmapTexture::load(
        &path,
        &BitmapOptions {
            raw: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(r.texel(1, 0).x, round_to_f16(1000.0 / 65535.0));
}

#[test]
fn grey_png_evaluates_to_grey_and_rgba_ignores_alpha() {
    let g = load_texture(&bitmap_xml("grey8.png", ""));
    let b = g.as_bitmap().unwrap();
    assert!(b.is_grey());
    assert_eq!(g.resolution(), Some((3, 4)));
    let c = g.eval(Vec2::new(0.37, 0.61));
    assert!(c.x == c.y && c.y == c.z);
    assert_eq!(g.eval_1(Vec2::new(0.37, 0.61)), c.x);
    // Grey + alpha: the alpha channel is dropped.
    let ga = load_texture(&bitmap_xml("greya8.png", ""));
    assert!(ga.as_bitmap().unwrap().is_grey());
    // RGBA: texel (0, 0) is (200, 100, 50) with alpha 0, its colour is kept as is.
    let rgba = load_texture(&bitmap_xml(
        "rgba8.png",
        "<boolean name=\"raw\" value=\"true\"/>",
    ));
    let t = rgba.as_bitmap().unwrap().texel(0, 0);
    assert!(close(t, Vec3::new(200.0, 100.0, 50.0) / 255.0, 1e-7), "{t}");
}

#[test]
fn exr_textures_are_linear_unclamped_and_raw_has_no_effect() {
    let (t, warnings) = load_texture_in(&textures_dir(), &bitmap_xml("rgb32.exr", "")).unwrap();
    let b = t.as_bitmap().unwrap();
    assert_eq!(b.resolution(), (4, 3));
    assert_eq!(b.texel(0, 0), Vec3::new(2.5, 0.5, -0.25));
    assert_eq!(b.texel(3, 0), Vec3::new(0.0, 4.0, 0.0));
    assert_eq!(b.texel(0, 2), Vec3::new(1.5, 0.0, 0.25));
    assert!(
        warnings.iter().any(|w| w.contains("outside [0, 1]")),
        "{warnings:?}"
    );
    let raw = load_texture(&bitmap_xml(
        "rgb32.exr",
        "<boolean name=\"raw\" value=\"true\"/>",
    ));
    assert_eq!(raw.as_bitmap().unwrap().texels(), b.texels());
    // One-channel (Y) EXR → grey; half-float EXR values are kept exactly.
    let y = load_texture(&bitmap_xml("grey.exr", ""));
    assert!(y.as_bitmap().unwrap().is_grey());
    assert_eq!(y.as_bitmap().unwrap().texel(0, 0), Vec3::splat(0.5));
    let h = load_texture(&bitmap_xml("half.exr", ""));
    assert_eq!(
        h.as_bitmap().unwrap().texel(1, 0),
        Vec3::new(round_to_f16(0.1), round_to_f16(0.2), round_to_f16(0.3))
    );
    // eval_vec3 is the stored value (what a normal map decodes).
    assert_eq!(
        t.eval_vec3(Vec2::new(0.125, 1.0 / 6.0)),
        Vec3::new(2.5, 0.5, -0.25)
    );
}

#[test]
fn jpeg_loads_as_srgb() {
    let t = load_texture(&bitmap_xml("rgb8.jpg", ""));
    assert_eq!(t.resolution(), Some((8, 8)));
    assert!(!t.as_bitmap().unwrap().is_grey());
}

// ----------------------------------------------------------------------------------------------
// Lookup

/// A 4x2 texture with distinct texels: texel (x, y) = (x, y, 10).
fn grid(filter: FilterType, wrap: WrapMode) -> BitmapTexture {
    let texels = (0..2)
        .flat_map(|y| (0..4).map(move |x| Vec3::new(x as f32, y as f32, 10.0)))
        .collect();
    BitmapTexture::from_texels(
        4,
        2,
        texels,
        false,
        &BitmapOptions {
            filter,
            wrap,
            ..Default::default()
        },
    )
}

#[test]
fn bilinear_at_texel_centres_returns_texels_exactly() {
    let t = grid(FilterType::Bilinear, WrapMode::Repeat);
    for y in 0..2 {
        for x in 0..4 {
            let uv = Vec2::new((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 2.0);
            assert_eq!(t.eval(uv), t.texel(x, y), "texel ({x}, {y})");
        }
    }
    // The same through a file with a non-power-of-two size (centres are not exact binary
    // fractions there; Mitsuba shows the same ~1e-8 leakage).
    let f = BitmapTexture::load(&textures_dir().join("rgb8.png"), &Default::default()).unwrap();
    for y in 0..4 {
        for x in 0..5 {
            let uv = Vec2::new((x as f32 + 0.5) / 5.0, (y as f32 + 0.5) / 4.0);
            assert!(close(f.eval(uv), f.texel(x, y), 1e-6));
        }
    }
    // uv (0, 0) lies on the corner shared by the first row/column and (repeat) the last ones.
    let corner = t.eval(Vec2::ZERO);
    assert_eq!(corner, Vec3::new(1.5, 0.5, 10.0));
}

#[test]
fn wrap_modes_outside_the_unit_square() {
    let v = 0.25; // row 0 centre
    let x = |c: f32| Vec3::new(c, 0.0, 10.0);
    // Nearest: u = -0.25 → column -1; u = 1.25 → column 5.
    let cases = [
        (WrapMode::Repeat, x(3.0), x(1.0)),
        (WrapMode::Mirror, x(0.0), x(2.0)),
        (WrapMode::Clamp, x(0.0), x(3.0)),
    ];
    for (wrap, at_minus, at_plus) in cases {
        let t = grid(FilterType::Nearest, wrap);
        assert_eq!(
            t.eval(Vec2::new(-0.25, v)),
            at_minus,
            "{wrap:?} nearest -0.25"
        );
        assert_eq!(t.eval(Vec2::new(1.25, v)), at_plus, "{wrap:?} nearest 1.25");
    }
    // Bilinear: u = -0.25 → halfway between columns -2 and -1; u = 1.25 → between 4 and 5.
    let cases = [
        (WrapMode::Repeat, x(2.5), x(0.5)),
        (WrapMode::Mirror, x(0.5), x(2.5)),
        (WrapMode::Clamp, x(0.0), x(3.0)),
    ];
    for (wrap, at_minus, at_plus) in cases {
        let t = grid(FilterType::Bilinear, wrap);
        assert_eq!(
            t.eval(Vec2::new(-0.25, v)),
            at_minus,
            "{wrap:?} bilinear -0.25"
        );
        assert_eq!(
            t.eval(Vec2::new(1.25, v)),
            at_plus,
            "{wrap:?} bilinear 1.25"
        );
    }
    // Repeat is periodic, mirror has period 2.
    let r = grid(FilterType::Bilinear, WrapMode::Repeat);
    let m = grid(FilterType::Bilinear, WrapMode::Mirror);
    for uv in [Vec2::new(0.3, 0.7), Vec2::new(0.91, 0.05)] {
        // (Equal up to the rounding of the shifted coordinates.)
        assert!(close(r.eval(uv), r.eval(uv + Vec2::new(3.0, -2.0)), 1e-5));
        assert!(close(m.eval(uv), m.eval(uv + Vec2::new(4.0, -2.0)), 1e-5));
        assert!(close(m.eval(uv), m.eval(Vec2::new(-uv.x, uv.y)), 1e-5));
    }
}

#[test]
fn nearest_and_bilinear_differ_between_centres() {
    let n = grid(FilterType::Nearest, WrapMode::Repeat);
    let b = grid(FilterType::Bilinear, WrapMode::Repeat);
    let uv = Vec2::new(0.3, 0.25); // x = 1.2 texels: nearest column 1; bilinear 0.7
    assert_eq!(n.eval(uv), Vec3::new(1.0, 0.0, 10.0));
    assert!(close(b.eval(uv), Vec3::new(0.7, 0.0, 10.0), 1e-6));
    // Rows too: v = 0.6 → nearest row 1; bilinear y = 0.7 between rows 0 and 1.
    let uv = Vec2::new(0.375, 0.6);
    assert_eq!(n.eval(uv), Vec3::new(1.0, 1.0, 10.0));
    assert!(close(b.eval(uv), Vec3::new(1.0, 0.7, 10.0), 1e-6));
}

#[test]
fn to_uv_scales_and_offsets_the_lookup() {
    let plain = load_texture(&bitmap_xml("rgb8.png", ""));
    let scaled = load_texture(&bitmap_xml(
        "rgb8.png",
        "<transform name=\"to_uv\"><scale x=\"2\" y=\"3\"/><translate x=\"0.25\" y=\"-0.1\"/></transform>",
    ));
    for uv in [
        Vec2::new(0.1, 0.2),
        Vec2::new(0.45, 0.9),
        Vec2::new(-0.3, 1.7),
    ] {
        let mapped = Vec2::new(2.0 * uv.x + 0.25, 3.0 * uv.y - 0.1);
        assert!(close(scaled.eval(uv), plain.eval(mapped), 1e-6), "uv {uv}");
    }
}

#[test]
fn one_pixel_wide_images_are_upsampled_to_two() {
    let (t, warnings) = load_texture_in(&textures_dir(), &bitmap_xml("thin.png", "")).unwrap();
    assert_eq!(t.resolution(), Some((2, 3)));
    assert!(
        warnings.iter().any(|w| w.contains("up-sampled")),
        "{warnings:?}"
    );
    let b = t.as_bitmap().unwrap();
    for y in 0..3 {
        assert_eq!(b.texel(0, y), b.texel(1, y));
    }
}

#[test]
fn constant_textures_report_no_resolution() {
    let c = Texture::Constant(Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(c.resolution(), None);
    assert!(!c.is_spatially_varying());
    assert_eq!(c.eval_vec3(Vec2::new(5.0, -3.0)), Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(c.mean(), Vec3::new(0.1, 0.2, 0.3));
    assert!((c.eval_1(Vec2::ZERO) - luminance(c.mean())).abs() < 1e-7);
}

// ----------------------------------------------------------------------------------------------
// Bad input: an error at the <texture> (FILE:3:1) naming the file, never a panic

fn load_err(dir: &Path, texture_xml: &str) -> String {
    match load_texture_in(dir, texture_xml) {
        Ok(_) => panic!("expected an error for {texture_xml}"),
        Err(e) => e.to_string(),
    }
}

fn assert_texture_error(dir: &Path, texture_xml: &str, needles: &[&str]) {
    let e = load_err(dir, texture_xml);
    let loc = format!("{}:3:1: ", dir.join("scene.xml").display());
    assert!(e.starts_with(&loc), "expected location {loc}, got: {e}");
    for n in needles {
        assert!(e.contains(n), "expected '{n}' in: {e}");
    }
}

#[test]
fn bad_bitmap_files_are_errors_at_the_texture() {
    let dir = temp_dir("bad");
    // Missing file.
    assert_texture_error(
        &dir,
        &bitmap_xml("nope.png", ""),
        &["nope.png", "not found"],
    );
    // Corrupt PNG: a truncated copy of a good one.
    let good = std::fs::read(textures_dir().join("rgb8.png")).unwrap();
    std::fs::write(dir.join("truncated.png"), &good[..good.len() / 2]).unwrap();
    assert_texture_error(&dir, &bitmap_xml("truncated.png", ""), &["truncated.png"]);
    // Not an image at all.
    std::fs::write(dir.join("text.png"), "hello, I am not a PNG\n").unwrap();
    assert_texture_error(&dir, &bitmap_xml("text.png", ""), &["text.png"]);
    // Empty file.
    std::fs::write(dir.join("empty.jpg"), "").unwrap();
    assert_texture_error(&dir, &bitmap_xml("empty.jpg", ""), &["empty.jpg"]);
    // Truncated EXR.
    let exr = std::fs::read(textures_dir().join("rgb32.exr")).unwrap();
    std::fs::write(dir.join("truncated.exr"), &exr[..exr.len() - 40]).unwrap();
    assert_texture_error(&dir, &bitmap_xml("truncated.exr", ""), &["truncated.exr"]);
    // EXR with a NaN texel, and one with channels a texture cannot use.
    use exr::prelude::{
        write_rgb_file, AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer,
        LayerAttributes, WritableImage,
    };
    write_rgb_file(dir.join("nan.exr"), 3, 2, |x, y| {
        if (x, y) == (2, 1) {
            (f32::NAN, 0.0, 0.0)
        } else {
            (0.5, 0.5, 0.5)
        }
    })
    .unwrap();
    assert_texture_error(
        &dir,
        &bitmap_xml("nan.exr", ""),
        &["nan.exr", "texel (2, 1)", "NaN"],
    );
    let uv = AnyChannels::sort(smallvec_of([
        AnyChannel::new("U", FlatSamples::F32(vec![0.0; 6])),
        AnyChannel::new("V", FlatSamples::F32(vec![0.0; 6])),
    ]));
    Image::from_layer(Layer::new(
        (3, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        uv,
    ))
    .write()
    .to_file(dir.join("uv.exr"))
    .unwrap();
    assert_texture_error(&dir, &bitmap_xml("uv.exr", ""), &["uv.exr", "U, V"]);
    // Bad options and a missing filename.
    std::fs::copy(textures_dir().join("rgb8.png"), dir.join("ok.png")).unwrap();
    assert_texture_error(
        &dir,
        &bitmap_xml("ok.png", "<string name=\"wrap_mode\" value=\"wrap\"/>"),
        &["wrap_mode 'wrap'", "repeat, mirror, clamp"],
    );
    assert_texture_error(
        &dir,
        &bitmap_xml(
            "ok.png",
            "<string name=\"filter_type\" value=\"trilinear\"/>",
        ),
        &["filter_type 'trilinear'"],
    );
    assert_texture_error(&dir, "<texture type=\"bitmap\"/>", &["needs a 'filename'"]);
    // An unknown property is reported (Mitsuba's unreferenced-property rule).
    let e = load_err(
        &dir,
        &bitmap_xml("ok.png", "<float name=\"gamma\" value=\"2.2\"/>"),
    );
    assert!(e.contains("unreferenced property 'gamma'"), "{e}");
    // And a good file in the same folder loads.
    assert!(load_texture_in(&dir, &bitmap_xml("ok.png", "")).is_ok());
}

fn smallvec_of<T, const N: usize>(items: [T; N]) -> exr::prelude::SmallVec<[T; 4]> {
    items.into_iter().collect()
}

/// BMP and binary PPM images (Mitsuba 3.9.1's `Bitmap` reads both; mitsuba-data's projector
/// scene uses `flower.bmp`) load to the same texels as the PNG of the same 8-bit pixels.
#[test]
fn bmp_and_ppm_load_like_png() {
    let dir = temp_dir("bmp_ppm");
    let img = image::RgbImage::from_fn(5, 3, |x, y| {
        image::Rgb([(x * 50) as u8, (y * 100) as u8, (255 - x * 40) as u8])
    });
    for ext in ["png", "bmp", "ppm"] {
        img.save(dir.join(format!("i.{ext}"))).unwrap();
    }
    let opts = BitmapOptions {
        filter: FilterType::Nearest,
        ..Default::default()
    };
    let png = BitmapTexture::load(&dir.join("i.png"), &opts).unwrap();
    for ext in ["bmp", "ppm"] {
        let t = BitmapTexture::load(&dir.join(format!("i.{ext}")), &opts).unwrap();
        assert_eq!(t.resolution(), (5, 3), "{ext}");
        for y in 0..3 {
            for x in 0..5 {
                assert_eq!(t.texel(x, y), png.texel(x, y), "{ext} texel ({x}, {y})");
            }
        }
    }
}
