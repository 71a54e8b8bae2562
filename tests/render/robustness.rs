//! Geometric robustness that fuzzing the parsers cannot see (issue 15), as property tests:
//! ray origins offset to the right side by a bounded amount, degenerate triangles that never
//! give non-finite samples, non-finite transforms refused by the loader, and renders of
//! extreme but valid scenes whose film never holds a NaN or an infinity (invalid samples are
//! dropped and counted instead).

use glam::{Vec2, Vec3};
use groove::geometry::mesh::TriMesh;
use groove::geometry::ray::offset_origin;
use groove::geometry::Shape;
use proptest::prelude::*;
use std::path::Path;

/// A unit vector from two uniform numbers.
fn unit(a: f32, b: f32) -> Vec3 {
    let z = 2.0 * a - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * b;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Coordinates from tiny to large, both signs, and exact zeros.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), -1e-3f32..1e-3, -10.0f32..10.0, -1e6f32..1e6,]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The offset origin is finite, on the side `dir` points to (never behind the surface)
    /// and within a few ulps of the hit point (no light leak through thin geometry).
    #[test]
    fn offset_origin_moves_a_little_to_the_right_side(
        x in coord(), y in coord(), z in coord(),
        a in 0f32..1.0, b in 0f32..1.0, c in 0f32..1.0, d in 0f32..1.0,
    ) {
        let p = Vec3::new(x, y, z);
        let n = unit(a, b);
        let dir = unit(c, d);
        prop_assume!(n.dot(dir).abs() > 1e-3);
        let o = offset_origin(p, n, dir);
        prop_assert!(o.is_finite(), "{o}");
        let side = if n.dot(dir) < 0.0 { -n } else { n };
        prop_assert!((o - p).dot(side) >= 0.0, "p {p} n {n} dir {dir} -> {o}");
        let bound = 1e-4 * p.abs().max_element().max(1.0);
        prop_assert!((o - p).abs().max_element() <= bound, "moved {} from {p}", (o - p).length());
    }

    /// Meshes with zero-area triangles (repeated or collinear corners) beside a proper one:
    /// the shape builds, its area is finite, and every position sample is finite with a
    /// finite positive density (degenerate triangles are never picked).
    #[test]
    fn degenerate_triangles_never_give_non_finite_samples(
        s in 1e-3f32..1e3,
        dup in 0usize..4,
        col in 0usize..4,
        t in 0f32..1.0,
        us in prop::collection::vec((0f32..1.0, 0f32..1.0), 16),
    ) {
        let mut positions = vec![Vec3::ZERO, Vec3::X * s, Vec3::Y * s];
        let mut indices = vec![[0u32, 1, 2]];
        for k in 0..dup {
            indices.push([k as u32 % 3, k as u32 % 3, (k as u32 + 1) % 3]);
        }
        for _ in 0..col {
            let i = positions.len() as u32;
            positions.push(Vec3::X * s * t);
            indices.push([0, 1, i]);
        }
        let mesh = TriMesh { positions, normals: None, uvs: None, indices };
        let shape = Shape::from_mesh(mesh, false, false).expect("one proper triangle");
        let area = shape.area();
        prop_assert!(area.is_finite() && area > 0.0, "area {area}");
        for (u, v) in us {
            let ps = shape.sample_position(Vec2::new(u, v));
            prop_assert!(ps.p.is_finite() && ps.n.is_finite() && ps.uv.is_finite(), "{ps:?}");
            prop_assert!(ps.pdf.is_finite() && ps.pdf > 0.0, "pdf {}", ps.pdf);
            prop_assert!((ps.n.length() - 1.0).abs() < 1e-3, "n {}", ps.n);
        }
    }

    /// A mesh whose every triangle is degenerate is refused or has zero area: no panic.
    #[test]
    fn all_degenerate_meshes_do_not_panic(s in -1e3f32..1e3, t in 0f32..1.0) {
        let positions = vec![Vec3::ZERO, Vec3::X * s, Vec3::X * s * t];
        let mesh = TriMesh { positions, normals: None, uvs: None, indices: vec![[0, 1, 2], [0, 0, 1]] };
        if let Ok(shape) = Shape::from_mesh(mesh, false, false) {
            prop_assert!(shape.area().is_finite());
        }
    }
}

/// A 4×3 scene with `shape_xform` inside the sphere's `to_world` and `radiance` on its area
/// light, lit by a constant environment.
fn scene(shape_xform: &str, radiance: &str, env: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="3"/></film>
    </sensor>
    <shape type="sphere">
        <transform name="to_world">{shape_xform}</transform>
        <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
    </shape>
    <shape type="rectangle"><bsdf type="roughconductor"/></shape>
    <emitter type="constant"><rgb name="radiance" value="{env}"/></emitter>
</scene>"#
    )
}

/// Numbers a careless or hostile file may hold.
fn wild() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e39".to_string()),
        Just("1e30".to_string()),
        Just("-1e30".to_string()),
        Just("1e-30".to_string()),
        Just("0".to_string()),
        (-5.0f64..5.0).prop_map(|v| format!("{v}")),
    ]
}

/// Loads `text` as a virtual file: the scene, or the error message.
fn load(text: &str) -> Result<groove::load::Loaded, String> {
    let path = Path::new("/virtual/robust.xml");
    groove::scene::xml::parse::load_str(text, path, &[])
        .and_then(|doc| groove::load::instantiate(&doc, path))
        .map_err(|e| e.to_string())
}

/// Renders `loaded` on one thread; checks every pixel is finite; returns the dropped samples.
fn render_finite(loaded: &groove::load::Loaded) -> Result<u64, String> {
    let opts = groove::render::RenderOptions {
        threads: 1,
        renderer: crate::common::renderer(),
        ..Default::default()
    };
    let out = groove::render::render(&loaded.scene, &loaded.settings, &opts)
        .map_err(|e| e.to_string())?;
    let img = out.film.develop();
    if let Some(p) = img.data.iter().find(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("pixel {p:?} reached the film"));
    }
    Ok(out.stats.invalid_samples)
}

/// The extreme but valid end of the range renders to a finite film.
#[test]
fn extreme_valid_values_render_to_a_finite_film() {
    for (xform, rad, env) in [
        (r#"<scale value="1e-6"/>"#, "1e30, 1e30, 1e30", "1e30"),
        (
            r#"<scale value="1e6"/><translate x="1e6" y="0" z="0"/>"#,
            "1e30, 0, 0",
            "0",
        ),
        (
            r#"<matrix value="1 0 0 0 0 1 0 0 0 0 1 -3.9 0 0 0 1"/>"#,
            "1, 1, 1",
            "1e-30",
        ),
    ] {
        let l = load(&scene(xform, rad, env)).unwrap_or_else(|e| panic!("{xform}: {e}"));
        render_finite(&l).unwrap_or_else(|e| panic!("{xform} {rad} {env}: {e}"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// One wild number in a transform or a radiance (the rest sane): non-finite or
    /// overflowing values are refused by the loader with a located message; whatever loads
    /// renders to a film with only finite pixels, the NaN and infinite samples dropped and
    /// counted instead.
    #[test]
    fn nan_and_inf_never_reach_the_film(which in 0usize..5, v in wild()) {
        let mut vals = ["0.5", "1", "0", "1", "0.2"].map(String::from);
        vals[which] = v;
        let [tx, sc, m, rad, env] = vals;
        let xform = format!(
            r#"<scale value="{sc}"/><translate x="{tx}" y="0" z="0"/><matrix value="1 0 0 0 0 1 0 0 0 0 1 {m} 0 0 0 1"/>"#
        );
        let text = scene(&xform, &format!("{rad}, 1, 1"), &env);
        let non_finite = |s: &str| !s.parse::<f32>().is_ok_and(f32::is_finite);
        match load(&text) {
            Err(e) => {
                // Refused: with a clear, located message.
                prop_assert!(e.starts_with("/virtual/robust.xml:"), "{e}");
            }
            Ok(loaded) => {
                for v in [&tx, &sc, &m, &rad, &env] {
                    prop_assert!(!non_finite(v), "{v} was accepted");
                }
                let dropped = render_finite(&loaded);
                prop_assert!(dropped.is_ok(), "{:?}; scene: {text}", dropped);
                prop_assert!(dropped.unwrap() <= 48, "more dropped samples than samples");
            }
        }
    }
}
