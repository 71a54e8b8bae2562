//! `shapegroup` + `instance`: a surface seen through an instance equals the same shape transformed
//! and loaded directly (t, point, normals, uv, tangent), shadow rays agree, the geometry of a
//! group is stored once, and what Mitsuba 3.9.1 refuses is refused at its element.

use glam::Vec3;
use groove::geometry::{Ray, SurfaceInteraction};
use groove::load::Loaded;
use groove::math::Pcg32;
use std::path::Path;

const GEOMETRY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/geometry");

fn text(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n")
}

fn load(body: &str) -> Result<Loaded, String> {
    let doc = groove::scene::xml::parse::load_str(&text(body), Path::new("mem.xml"), &[])
        .map_err(|e| e.to_string())?;
    groove::load::instantiate(&doc, Path::new("mem.xml")).map_err(|e| e.to_string())
}

fn loads(body: &str) -> Loaded {
    load(body).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(body: &str) -> String {
    match load(body) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e,
    }
}

fn assert_err(err: &str, loc: &str, msg: &str) {
    assert!(
        err.starts_with(&format!("{loc}: ")),
        "expected location {loc}, got: {err}"
    );
    assert!(err.contains(msg), "expected '{msg}' in: {err}");
}

/// The members of the comparison: each shape element with a `{T}` where its own transform ops go.
fn members(similarity: bool) -> Vec<String> {
    let mut m = vec![
        format!(
            "<shape type=\"obj\"><string name=\"filename\" value=\"{GEOMETRY}/octahedron.obj\"/>\
             <transform name=\"to_world\"><scale value=\"0.7\"/><rotate y=\"1\" angle=\"20\"/>{{T}}</transform></shape>"
        ),
        format!(
            "<shape type=\"obj\"><string name=\"filename\" value=\"{GEOMETRY}/quad.obj\"/>\
             <transform name=\"to_world\"><scale value=\"0.4\"/><translate x=\"1.2\" z=\"0.2\"/>{{T}}</transform></shape>"
        ),
        "<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"0.3\"/>\
         <rotate x=\"1\" angle=\"30\"/><translate x=\"-1.1\" y=\"0.4\"/>{T}</transform></shape>"
            .into(),
        "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"0.5\" y=\"0.3\"/>\
         <translate y=\"-1.2\"/>{T}</transform></shape>"
            .into(),
        "<shape type=\"disk\"><transform name=\"to_world\"><scale value=\"0.4\"/>\
         <rotate x=\"1\" angle=\"-60\"/><translate y=\"1.3\" z=\"0.4\"/>{T}</transform></shape>"
            .into(),
    ];
    if similarity {
        // Mitsuba's sphere and cylinder take only similarity transforms when loaded directly.
        m.push(
            "<shape type=\"sphere\"><point name=\"center\" x=\"0.2\" y=\"0.1\" z=\"1.1\"/>\
             <float name=\"radius\" value=\"0.35\"/><transform name=\"to_world\">\
             <rotate z=\"1\" angle=\"40\"/>{T}</transform></shape>"
                .into(),
        );
        m.push(
            "<shape type=\"cylinder\"><float name=\"radius\" value=\"0.2\"/>\
             <transform name=\"to_world\"><rotate x=\"1\" angle=\"70\"/>\
             <translate x=\"1.0\" y=\"1.0\" z=\"-0.8\"/>{T}</transform></shape>"
                .into(),
        );
    }
    m
}

/// The same shapes as a group placed by the transform ops `ops`, and loaded directly with `ops`
/// appended to their own.
fn twin_scenes(ops: &str, similarity: bool) -> (Loaded, Loaded) {
    let ms = members(similarity);
    let group: String = ms.iter().map(|m| m.replace("{T}", "")).collect();
    let instanced = loads(&format!(
        "<shape type=\"shapegroup\" id=\"g\">{group}</shape>\
         <shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\">{ops}</transform></shape>"
    ));
    let direct: String = ms.iter().map(|m| m.replace("{T}", ops)).collect();
    (instanced, loads(&direct))
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).length() <= tol * a.length().max(1.0)
}

/// How the direct scene may differ from the instanced one.
#[derive(Clone, Copy, PartialEq)]
enum Twin {
    /// Only by float rounding.
    Same,
    /// By the octahedron's (member 0) computed vertex normals: the direct scene computes them
    /// from the transformed mesh, where a non-uniform scale changes the angles that weight them;
    /// the instance maps the normals computed in group space.
    Stretched,
    /// Mirrored: a mirroring `to_world` turns a directly loaded mesh's winding, so its geometric
    /// normal (members 0–2, the meshes) and the vertex normals computed from the winding (member
    /// 0) point the other way, while an instance maps outward normals to outward normals, as
    /// Mitsuba's instance does.
    Mirrored,
}

/// Compares the two scenes along `n` random rays aimed at the group's region; returns the number
/// of hits.
fn compare_hits(a: &Loaded, b: &Loaded, n: usize, twin: Twin) -> usize {
    let mut rng = Pcg32::new(7, 3);
    let mut unit = || 2.0 * rng.next_f32() - 1.0;
    let mut hits = 0;
    for k in 0..n {
        let o = Vec3::new(unit(), unit(), unit()).normalize_or_zero() * 9.0;
        let target = Vec3::new(unit(), unit(), unit()) * 2.5;
        let ray = Ray::new(o, (target - o).normalize());
        let (ha, hb) = (a.scene.intersect(&ray), b.scene.intersect(&ray));
        assert_eq!(a.scene.occluded(&ray), ha.is_some(), "ray {k}: occluded");
        assert_eq!(b.scene.occluded(&ray), hb.is_some(), "ray {k}: occluded");
        let (ha, hb): (SurfaceInteraction, SurfaceInteraction) = match (ha, hb) {
            (None, None) => continue,
            (Some(x), Some(y)) => (x, y),
            // A ray grazing an edge may slip past one of the two.
            (x, y) => {
                let si = x.or(y).unwrap();
                let graze = si.ng.dot(ray.d).abs() < 0.02;
                let other = if x.is_some() { b } else { a };
                let near = Ray {
                    tmin: si.t * 0.999,
                    tmax: si.t * 1.001,
                    ..ray
                };
                let moved = |dx: Vec3| {
                    let r = Ray {
                        o: ray.o + dx,
                        ..near
                    };
                    other.scene.occluded(&r)
                };
                let e = 2e-4 * si.t;
                let edge = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
                    .iter()
                    .any(|d| moved(*d * e));
                assert!(graze || edge, "ray {k}: one hit only, at {}", si.p);
                continue;
            }
        };
        hits += 1;
        assert_eq!(ha.shape, hb.shape, "ray {k}: another shape");
        // Rounding moves a hit along the ray by more the more grazing the ray is.
        let graze = 1.0 / ha.ng.dot(ray.d).abs().max(1e-2);
        assert!(
            (ha.t - hb.t).abs() <= 2e-5 * graze * ha.t,
            "ray {k}: t {} vs {}",
            ha.t,
            hb.t
        );
        assert!(
            close(ha.p, hb.p, 2e-5 * graze),
            "ray {k} (shape {}, cos {}): p {} vs {}",
            ha.shape,
            ha.ng.dot(ray.d),
            ha.p,
            hb.p
        );
        let mirrored = twin == Twin::Mirrored;
        let ng_sign = if mirrored && ha.shape <= 2 { -1.0 } else { 1.0 };
        let ns_sign = if mirrored && ha.shape == 0 { -1.0 } else { 1.0 };
        assert!(
            close(ha.ng, hb.ng * ng_sign, 1e-4),
            "ray {k} (shape {}): ng {} vs {}",
            ha.shape,
            ha.ng,
            hb.ng
        );
        assert!(
            (twin == Twin::Stretched && ha.shape == 0) || close(ha.sh.n, hb.sh.n * ns_sign, 1e-4),
            "ray {k} (shape {}): ns {} vs {}",
            ha.shape,
            ha.sh.n,
            hb.sh.n
        );
        assert!(
            (ha.uv - hb.uv).abs().max_element() <= 1e-4,
            "ray {k} (shape {}): uv {} vs {}",
            ha.shape,
            ha.uv,
            hb.uv
        );
        assert_eq!(ha.prim, hb.prim, "ray {k}: another triangle");
        assert!(close(ha.wi, hb.wi, 1e-6));
        // A mesh without uvs has an arbitrary tangent frame around its normal; every other
        // shape's dp/du and dp/dv, and so the shading tangent, are the same.
        if ha.shape != 0 {
            let rel = |x: Vec3, y: Vec3| (x - y).length() <= 1e-4 * x.length().max(y.length());
            assert!(
                rel(ha.dpdu, hb.dpdu),
                "ray {k}: dpdu {} vs {}",
                ha.dpdu,
                hb.dpdu
            );
            assert!(
                rel(ha.dpdv, hb.dpdv),
                "ray {k}: dpdv {} vs {}",
                ha.dpdv,
                hb.dpdv
            );
            assert!(
                close(ha.sh.s, hb.sh.s, 2e-4),
                "ray {k} (shape {}): s {} vs {}",
                ha.shape,
                ha.sh.s,
                hb.sh.s
            );
        }
    }
    hits
}

#[test]
fn an_instance_under_a_non_uniform_scale_and_shear_equals_the_transformed_shapes() {
    // Unit rotation axes: a non-unit one is Mitsuba's non-rigid quirk (`scene::xml::transform`).
    let ops = "<scale x=\"1.6\" y=\"0.6\" z=\"1.1\"/><rotate x=\"0.70710678\" y=\"0.70710678\" angle=\"35\"/>\
               <scale x=\"1\" y=\"1.4\" z=\"1\"/><translate x=\"0.3\" y=\"-0.2\" z=\"0.5\"/>";
    let (a, b) = twin_scenes(ops, false);
    let hits = compare_hits(&a, &b, 20_000, Twin::Stretched);
    assert!(hits > 1_500, "{hits} hits");
}

#[test]
fn an_instance_under_a_similarity_equals_the_transformed_shapes_spheres_and_cylinders_too() {
    let ops = "<rotate x=\"0.25916053\" y=\"0.86386843\" z=\"-0.43193421\" angle=\"110\"/><scale value=\"1.3\"/>\
               <translate x=\"-0.4\" z=\"0.2\"/>";
    let (a, b) = twin_scenes(ops, true);
    let hits = compare_hits(&a, &b, 20_000, Twin::Same);
    assert!(hits > 1_500, "{hits} hits");
}

#[test]
fn a_mirroring_instance_keeps_the_groups_normals_outward() {
    let ops = "<scale x=\"-1.3\" y=\"1.3\" z=\"1.3\"/><rotate y=\"1\" angle=\"25\"/>";
    let (a, b) = twin_scenes(ops, false);
    let hits = compare_hits(&a, &b, 20_000, Twin::Mirrored);
    assert!(hits > 1_500, "{hits} hits");
    // The octahedron's normal through the mirroring instance points away from its centre.
    let ray = Ray::new(Vec3::new(0.0, 0.0, 9.0), -Vec3::Z);
    let si = a.scene.intersect(&ray).unwrap();
    assert_eq!(si.shape, 0);
    assert!(si.ng.z > 0.5 && si.sh.n.z > 0.5, "{} {}", si.ng, si.sh.n);
}

#[test]
fn a_group_is_stored_once_and_not_traced_by_itself() {
    let group = format!(
        "<shape type=\"shapegroup\" id=\"g\"><shape type=\"obj\">\
         <string name=\"filename\" value=\"{GEOMETRY}/octahedron.obj\"/></shape>\
         <shape type=\"sphere\"><float name=\"radius\" value=\"0.2\"/></shape></shape>"
    );
    // Forward reference: the instances come before the group in the file, and one holds its
    // group nested.
    let inst = |x: i32| {
        format!("<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate x=\"{x}\"/></transform></shape>")
    };
    let l = loads(&format!("{}{}{group}{}", inst(-3), inst(3), inst(6)));
    assert_eq!(l.scene.shapes().len(), 2, "the members, once");
    assert_eq!(l.scene.instances().len(), 3);
    let down = |x: f32| Ray::new(Vec3::new(x, 5.0, 0.0), -Vec3::Y);
    assert!(
        l.scene.intersect(&down(0.0)).is_none(),
        "the group itself is not traced"
    );
    for x in [-3.0, 3.0, 6.0] {
        let si = l.scene.intersect(&down(x)).unwrap();
        assert_eq!(si.shape, 0);
        assert!((si.p - Vec3::new(x, 1.0, 0.0)).length() < 1e-5, "{}", si.p);
        assert!(l.scene.occluded(&down(x)));
    }
    assert!(!l.scene.occluded(&down(0.0)));
    // The bounding sphere holds the instances, not the group at the origin alone.
    let (c, r) = l.scene.bsphere();
    assert!(c.x > 1.0 && r > 4.5, "{c} {r}");

    // A group nested in its instance, and an empty group.
    let l = loads(
        "<shape type=\"instance\"><shape type=\"shapegroup\"><shape type=\"sphere\"/></shape>\
         <transform name=\"to_world\"><translate y=\"-3\"/></transform></shape>\
         <shape type=\"shapegroup\" id=\"e\"/><shape type=\"instance\"><ref id=\"e\"/></shape>",
    );
    let si = l.scene.intersect(&down(0.0)).unwrap();
    assert!((si.p.y + 2.0).abs() < 1e-5, "{}", si.p);
}

#[test]
fn a_groups_to_world_is_ignored_with_a_warning() {
    let l = loads(
        "<shape type=\"shapegroup\" id=\"g\"><transform name=\"to_world\"><translate x=\"5\"/></transform>\
         <shape type=\"sphere\"/></shape><shape type=\"instance\"><ref id=\"g\"/></shape>",
    );
    assert!(
        l.warnings
            .iter()
            .any(|w| w.starts_with("mem.xml:3:1: ") && w.contains("to_world is ignored")),
        "{:?}",
        l.warnings
    );
    let si = l
        .scene
        .intersect(&Ray::new(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y));
    assert!(si.is_some_and(|si| (si.p.y - 1.0).abs() < 1e-5));
}

#[test]
fn what_mitsuba_refuses_in_groups_and_instances_is_refused_at_its_element() {
    const G: &str = "<shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\"/></shape>\n";
    let cases: &[(&str, &str, &str)] = &[
        (
            "<shape type=\"shapegroup\">\n<shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape></shape>",
            "mem.xml:4:22",
            "cannot carry an emitter",
        ),
        (
            "<shape type=\"shapegroup\">\n<shape type=\"shapegroup\"/></shape>",
            "mem.xml:4:1",
            "nested shape groups are not permitted",
        ),
        (
            "<shape type=\"shapegroup\" id=\"g\">\n<ref id=\"g\"/></shape>",
            "mem.xml:4:1",
            "nested shape groups are not permitted",
        ),
        (
            "<shape type=\"shapegroup\">\n<shape type=\"instance\"/></shape>",
            "mem.xml:4:1",
            "nested instancing is not permitted",
        ),
        (
            "<shape type=\"shapegroup\">\n<bsdf type=\"diffuse\"/></shape>",
            "mem.xml:4:1",
            "a shapegroup holds only shapes, not <bsdf>",
        ),
        (
            "<shape type=\"instance\"/>",
            "mem.xml:3:1",
            "an instance needs a shapegroup",
        ),
        (
            "<shape type=\"sphere\" id=\"s\"/>\n<shape type=\"instance\"><ref id=\"s\"/></shape>",
            "mem.xml:4:24",
            "an instance takes only a shapegroup, not a 'sphere' shape",
        ),
        (
            "<shape type=\"instance\"><ref id=\"nope\"/></shape>",
            "mem.xml:3:29",
            "reference to unknown id 'nope'",
        ),
        (
            &format!("{G}<shape type=\"instance\"><ref id=\"g\"/><ref id=\"g\"/></shape>"),
            "mem.xml:4:37",
            "an instance takes only one shapegroup",
        ),
        (
            &format!("{G}<shape type=\"instance\"><ref id=\"g\"/><bsdf type=\"diffuse\"/></shape>"),
            "mem.xml:4:37",
            "an instance takes only a shapegroup, not <bsdf>",
        ),
        (
            &format!("{G}<shape type=\"instance\"><ref id=\"g\"/><boolean name=\"flip_normals\" value=\"true\"/></shape>"),
            "mem.xml:4:46",
            "unreferenced property 'flip_normals'",
        ),
        (
            &format!("{G}<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><scale y=\"0\"/></transform></shape>"),
            "mem.xml:4:1",
            "not an invertible affine map",
        ),
        (
            "<shape type=\"shapegroup\" id=\"g\">\n<shape type=\"sphere\"><float name=\"radius\" value=\"-1\"/></shape></shape>\n<shape type=\"instance\"><ref id=\"g\"/></shape>",
            "mem.xml:4:1",
            "sphere radius must be positive",
        ),
    ];
    for (body, loc, msg) in cases {
        let e = load_err(body);
        eprintln!("{e}");
        assert_err(&e, loc, msg);
    }
}

#[test]
fn instances_are_counted_against_the_memory_budget() {
    let group = "<shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\"/></shape>\n";
    let body =
        group.to_string() + &"<shape type=\"instance\"><ref id=\"g\"/></shape>\n".repeat(300);
    let doc = groove::scene::xml::parse::load_str(&text(&body), Path::new("mem.xml"), &[]).unwrap();
    let within = |limit: u64| {
        groove::load::instantiate_within(
            &doc,
            Path::new("mem.xml"),
            groove::load::options::NormalMapping::AsWritten,
            &groove::budget::Budget::new(limit),
        )
    };
    assert!(within(8 << 20).is_ok());
    let e = within(1 << 20).err().expect("over the budget").to_string();
    assert!(e.starts_with("mem.xml:"), "{e}");
    assert!(e.contains("an instance needs"), "{e}");
}

#[test]
fn rays_leaving_an_instanced_surface_do_not_hit_it_again() {
    // Convex members (a sphere that the instance stretches into an ellipsoid, and a cube) far
    // from the origin: a ray spawned outward from a hit point must escape; one spawned inward
    // must reach the far side (checked on the ellipsoid only: far from the origin the offset
    // origin, 125 ulps ≈ 0.015 here, can cross a nearby edge of the box).
    for (smooth, member) in [true, false].into_iter().zip([
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/></shape>",
        "<shape type=\"cube\"><transform name=\"to_world\"><rotate x=\"1\" y=\"2\" angle=\"33\"/></transform></shape>",
    ]) {
        let l = loads(&format!(
            "<shape type=\"shapegroup\" id=\"g\">{member}</shape><shape type=\"instance\"><ref id=\"g\"/>\
             <transform name=\"to_world\"><scale x=\"3\" y=\"0.4\" z=\"1.5\"/><rotate z=\"1\" angle=\"30\"/>\
             <translate x=\"2000\" y=\"-700\" z=\"350\"/></transform></shape>"
        ));
        let centre = Vec3::new(2000.0, -700.0, 350.0);
        let mut rng = Pcg32::new(5, 9);
        let mut unit = || 2.0 * rng.next_f32() - 1.0;
        let (mut hits, mut escaped, mut crossed) = (0, 0, 0);
        for _ in 0..4000 {
            let o = centre + Vec3::new(unit(), unit(), unit()).normalize_or_zero() * 20.0;
            let target = centre + Vec3::new(unit(), unit(), unit()) * 0.3;
            let Some(si) = l.scene.intersect(&Ray::new(o, (target - o).normalize())) else {
                continue;
            };
            hits += 1;
            let d = Vec3::new(unit(), unit(), unit()).normalize_or_zero();
            if d.dot(si.ng).abs() < 1e-2 {
                continue;
            }
            let out = if d.dot(si.ng) > 0.0 { d } else { -d };
            assert!(
                l.scene.intersect(&si.spawn_ray(out)).is_none(),
                "{member}: an outward ray from {} hit the surface again",
                si.p
            );
            escaped += 1;
            if !smooth {
                continue;
            }
            let back = l.scene.intersect(&si.spawn_ray(-out));
            let Some(far) = back else {
                let r = si.spawn_ray(-out);
                panic!(
                    "{member}: an inward ray from {} (ng {}, ns {}) along {} (origin {}) missed; cos {}",
                    si.p, si.ng, si.sh.n, -out, r.o, out.dot(si.ng)
                );
            };
            assert!(far.t > 1e-3, "{member}: inward ray stopped at t {}", far.t);
            crossed += 1;
        }
        assert!(hits > 3000 && escaped > 2900, "{hits} {escaped}");
        assert!(!smooth || crossed == escaped, "{crossed} of {escaped}");
    }
}
