//! `mesh_attribute`, `rawconstant` and the PLY loader's mesh attributes: the attributes equal what
//! Mitsuba 3.9.1 makes of the same files (tests/data/textures/float_images.json, written by
//! tests/data/textures/mitsuba_float_images.py), the textures evaluate them at hits, and the uses
//! Mitsuba only fails on while rendering are errors at the `<texture>` when the scene loads.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use groove::geometry::attributes::Per;
use groove::geometry::ply::parse_ply_attributed;
use groove::geometry::{Hit, Ray};
use groove::load::instantiate;
use groove::scene::xml::parse::load_str;
use groove::texture::{TexPoint, Texture};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

#[test]
fn ply_attributes_equal_mitsubas() {
    let text = std::fs::read_to_string(data().join("textures/float_images.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["mitsuba"], "3.9.1");
    for (rel, attrs) in json["ply"].as_object().unwrap() {
        let bytes = std::fs::read(data().join(rel)).unwrap();
        let ply = parse_ply_attributed(&bytes).unwrap();
        let mut names: Vec<&str> = ply.attributes.iter().map(|a| a.name.as_str()).collect();
        let mut want: Vec<&str> = attrs
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        names.sort();
        want.sort();
        assert_eq!(names, want, "{rel}");
        for a in &ply.attributes {
            let m: Vec<f32> = attrs[&a.name]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap() as f32)
                .collect();
            assert_eq!(a.data.len(), m.len(), "{rel} {}", a.name);
            // Within f32 rounding (groove decodes the sRGB curve in f64, Mitsuba in f32).
            for (k, (g, w)) in a.data.iter().zip(&m).enumerate() {
                assert!(
                    (g - w).abs() <= 1e-6 * w.abs().max(1e-3),
                    "{rel} {}[{k}]: {g} vs Mitsuba {w}",
                    a.name
                );
            }
            assert_eq!(a.per == Per::Vertex, a.name.starts_with("vertex_"));
        }
        // Mitsuba's warnings: integer colours.
        if rel.ends_with("attr_types.ply") {
            assert!(ply
                .warnings
                .iter()
                .any(|w| w.contains("\"vertex_color\" has integer fields")));
        }
    }
}

/// A scene with a camera, and `body` from line 3 on, in the data folder's `scenes` (so the PLY is
/// `../geometry/...`).
fn scene_text(body: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n\
         <sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor>\n\
         {body}\n\
         </scene>\n"
    )
}

fn load(body: &str) -> groove::Result<groove::load::Loaded> {
    let path = data().join("scenes/attr_test.xml");
    let doc = load_str(&scene_text(body), &path, &[])?;
    instantiate(&doc, &path)
}

/// A grid shape with BSDF `bsdf`; its `<texture>`s start on line 4.
fn grid(bsdf: &str) -> String {
    format!(
        "<shape type=\"ply\"><string name=\"filename\" value=\"../geometry/attr_grid.ply\"/>\n{bsdf}</shape>"
    )
}

fn mesh_attribute(slot: &str, name: &str) -> String {
    format!(
        "<texture type=\"mesh_attribute\" name=\"{slot}\"><string name=\"name\" value=\"{name}\"/></texture>\n"
    )
}

#[test]
fn mesh_attribute_evaluates_the_hit_meshs_values() {
    let loaded = load(&grid(&format!(
        "<bsdf type=\"diffuse\">{}</bsdf>\n",
        mesh_attribute("reflectance", "vertex_color")
    )))
    .unwrap();
    let scene = &loaded.scene;
    let shape = &scene.shapes()[0];
    // A ray down the z axis onto the grid at (x, y): triangle 0 is (0, 1, 4) of the 3x3 grid
    // (vertex i + 3j at (i − 1, j − 1)); colours r = 0.2 + 0.4 i, g = 0.9 − 0.35 j,
    // b = 0.15 + 0.3 ((i + j) mod 2), interpolated linearly over each triangle.
    let colour =
        |i: f32, j: f32, odd: f32| Vec3::new(0.2 + 0.4 * i, 0.9 - 0.35 * j, 0.15 + 0.3 * odd);
    let tex = scene
        .materials()
        .textures
        .iter()
        .find(|t| matches!(t, Texture::MeshAttribute(_)))
        .unwrap();
    let (x, y) = (-0.75f32, -0.9f32); // inside triangle (0, 1, 4)
    let ray = Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z);
    // Barycentrics of (x, y) in (p0, p1, p4) = ((−1, −1), (0, −1), (0, 0)): Embree's
    // p = (1 − u − v)·p0 + u·p1 + v·p4 gives v = y + 1, u = x + 1 − v.
    let v = y + 1.0;
    let u = x + 1.0 - v;
    let hit = Hit {
        geom: 0,
        prim: 0,
        t: 1.0,
        u,
        v,
        inst: groove::geometry::hit::NO_INSTANCE,
    };
    let si = shape.interaction(0, &ray, &hit);
    let got = tex.eval(TexPoint::on_shape(&si, shape));
    let want = colour(0.0, 0.0, 0.0) * (1.0 - u - v)
        + colour(1.0, 0.0, 1.0) * u
        + colour(1.0, 1.0, 0.0) * v;
    assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
    // Looked up by uv alone (no mesh), the attribute is 0, as in Mitsuba's vectorised variants.
    assert_eq!(tex.eval(Vec2::new(0.5, 0.5)), Vec3::ZERO);
}

fn assert_error(body: &str, line: u32, needles: &[&str]) {
    let e = match load(body) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    };
    let loc = format!("{}:{line}:", data().join("scenes/attr_test.xml").display());
    assert!(e.starts_with(&loc), "expected location {loc}, got: {e}");
    for n in needles {
        assert!(e.contains(n), "expected '{n}' in: {e}");
    }
}

#[test]
fn misused_attributes_are_errors_at_the_texture() {
    // An attribute the mesh lacks: Mitsuba's message (it fails at render time), located.
    assert_error(
        &grid(&format!(
            "<bsdf type=\"diffuse\">{}</bsdf>",
            mesh_attribute("reflectance", "vertex_uv")
        )),
        4,
        &[
            "Invalid attribute requested vertex_uv.",
            "face_shade",
            "vertex_color",
        ],
    );
    // On a sphere, which has no attributes.
    assert_error(
        &format!(
            "<shape type=\"sphere\">\n<bsdf type=\"diffuse\">{}</bsdf></shape>",
            mesh_attribute("reflectance", "vertex_color")
        ),
        4,
        &["Invalid attribute requested vertex_color.", "no attributes"],
    );
    // A three-value attribute read as a scalar (a blend weight).
    assert_error(
        &grid(&format!(
            "<bsdf type=\"blendbsdf\">{}<bsdf type=\"diffuse\"/><bsdf type=\"conductor\"/></bsdf>",
            mesh_attribute("weight", "vertex_color")
        )),
        4,
        &["eval_attribute_1(): Attribute \"vertex_color\" requested but had size 3."],
    );
    // A name without vertex_ / face_ (Mitsuba's constructor error), a missing name.
    assert_error(
        &grid(&format!(
            "<bsdf type=\"diffuse\">{}</bsdf>",
            mesh_attribute("reflectance", "color")
        )),
        4,
        &["Invalid mesh attribute name"],
    );
    assert_error(
        &grid("<bsdf type=\"diffuse\">\n<texture type=\"mesh_attribute\" name=\"reflectance\"/></bsdf>"),
        5,
        &["needs a 'name'"],
    );
    // Unknown parameters are errors, as for every plugin.
    assert_error(
        &grid("<bsdf type=\"diffuse\">\n<texture type=\"mesh_attribute\" name=\"reflectance\"><string name=\"name\" value=\"vertex_color\"/><float name=\"gain\" value=\"2\"/></texture></bsdf>"),
        5,
        &["gain"],
    );
    // Plastics need the texture's mean (Mitsuba's mean() is not implemented for it).
    assert_error(
        &grid(&format!(
            "<bsdf type=\"plastic\">\n{}</bsdf>",
            mesh_attribute("diffuse_reflectance", "vertex_color")
        )),
        4,
        &["mean"],
    );
    // An area light's radiance.
    assert_error(
        &grid(&format!(
            "<emitter type=\"area\">\n{}</emitter>",
            mesh_attribute("radiance", "vertex_color")
        )),
        5,
        &["not supported by groove"],
    );
}

#[test]
fn four_value_colours_cannot_be_evaluated() {
    // red green blue alpha → a 4-value vertex_color, which Mitsuba's eval refuses.
    let dir = crate::common::Scratch::new(&format!("groove-attr-{}", std::process::id()));
    let ply = dir.join("rgba.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property float red\nproperty float green\nproperty float blue\nproperty float alpha\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n0 1 0 0 0 1 1\n3 0 1 2\n",
    )
    .unwrap();
    let body = format!(
        "<shape type=\"ply\"><string name=\"filename\" value=\"{}\"/>\n<bsdf type=\"diffuse\">{}</bsdf></shape>",
        ply.display(),
        mesh_attribute("reflectance", "vertex_color")
    );
    assert_error(
        &body,
        4,
        &["eval_attribute(): Attribute \"vertex_color\" requested but had size 4."],
    );
}

#[test]
fn rawconstant_values_and_errors() {
    let raw = |value: &str| {
        format!("<shape type=\"sphere\"><bsdf type=\"diffuse\">\n<texture type=\"rawconstant\" name=\"reflectance\">{value}</texture></bsdf></shape>")
    };
    // A vector is used as is (no range check: 1.5 stays 1.5), a float in every channel.
    for (v, want) in [
        (
            "<vector name=\"value\" x=\"1.5\" y=\"-0.25\" z=\"0.5\"/>",
            Vec3::new(1.5, -0.25, 0.5),
        ),
        (
            "<point name=\"value\" x=\"0.1\" y=\"0.2\" z=\"0.3\"/>",
            Vec3::new(0.1, 0.2, 0.3),
        ),
        ("<float name=\"value\" value=\"0.7\"/>", Vec3::splat(0.7)),
    ] {
        let loaded = load(&raw(v)).unwrap();
        let t = &loaded.scene.materials().textures;
        assert!(
            t.iter()
                .any(|t| matches!(t, Texture::Constant(c) if *c == want)),
            "{v}: {t:?}"
        );
    }
    assert_error(&raw(""), 4, &["missing required parameter \"value\""]);
    assert_error(
        &raw("<integer name=\"value\" value=\"2\"/>"),
        4,
        &["incorrect type"],
    );
    assert_error(
        &raw("<rgb name=\"value\" value=\"0.1, 0.2, 0.3\"/>"),
        4,
        &["incorrect type"],
    );
    assert_error(
        &raw("<float name=\"value\" value=\"0.7\"/><float name=\"scale\" value=\"2\"/>"),
        4,
        &["scale"],
    );
    // A 3-D value read as a scalar: Mitsuba's eval_1 error, at the texture.
    assert_error(
        "<shape type=\"sphere\"><bsdf type=\"roughconductor\">\n<texture type=\"rawconstant\" name=\"alpha\"><vector name=\"value\" x=\"0.1\" y=\"0.2\" z=\"0.3\"/></texture></bsdf></shape>",
        4,
        &["eval_1() is not defined for 3D-valued textures"],
    );
    // A 1-D value as a roughness is fine.
    assert!(load("<shape type=\"sphere\"><bsdf type=\"roughconductor\">\n<texture type=\"rawconstant\" name=\"alpha\"><float name=\"value\" value=\"0.2\"/></texture></bsdf></shape>").is_ok());
}

#[test]
fn the_attribute_check_visits_shared_bsdfs_once() {
    // 40 levels of blendbsdf, each blending two references to the level below: 2^40 paths to the
    // innermost diffuse, whose mesh_attribute is checked once (the load would not end otherwise).
    let mut xml = String::from("<bsdf type=\"diffuse\" id=\"b0\">\n");
    xml += &mesh_attribute("reflectance", "vertex_color");
    xml += "</bsdf>\n";
    for k in 1..=40 {
        xml += &format!(
            "<bsdf type=\"blendbsdf\" id=\"b{k}\"><float name=\"weight\" value=\"0.5\"/><ref id=\"b{}\"/><ref id=\"b{}\"/></bsdf>\n",
            k - 1,
            k - 1
        );
    }
    xml += &grid("<ref id=\"b40\"/>");
    let t = std::time::Instant::now();
    load(&xml).unwrap();
    assert!(t.elapsed().as_secs() < 10);
    // The same with a missing attribute fails at the innermost texture.
    let bad = xml.replace("value=\"vertex_color\"", "value=\"vertex_nope\"");
    assert_error(&bad, 4, &["Invalid attribute requested vertex_nope."]);
}
