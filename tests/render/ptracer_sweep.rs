//! Issue 19's acceptance: `path` and `ptracer` agree in groove on every test scene they can
//! agree on, and the others are listed with the reason, which is checked. Every scene of
//! `tests/data/scenes/` is in [`SCENES`] (a test fails when a new scene is not).
//!
//! - Default tier (`cargo test --release --test render ptracer_sweep`): the table is complete,
//!   every exclusion's reason holds, and a representative subset agrees.
//! - Full sweep (`cargo test --release --test render -- --ignored --nocapture
//!   path_and_ptracer_agree_on_every_test_scene`): every compared scene agrees, every excluded
//!   scene whose reason is a difference of estimators disagrees; the table it prints is in
//!   `docs/consistency.md`.
//!
//! The comparison is [`super::ptracer_agree`]'s (K independent ptracer renders for the variance
//! of a tile, t-tests, Bonferroni over tiles × channels).

use super::ptracer_agree::{load, path_vs_ptracer, Agreement, Plan};
use crate::common::test_scene;
use groove::integrator::IntegratorDesc;
use groove::load::options::NormalMapping;

/// Why a scene cannot be compared.
#[derive(Clone, Copy, Debug)]
enum Why {
    /// An orthographic sensor: Mitsuba 3.9.1's has no `sample_direction`, so `ptracer` refuses
    /// it (checked: the error).
    Orthographic,
    /// The integrator adds output channels (`aov`, `moment`) that light tracing cannot produce;
    /// the loader refuses a `ptracer` inside them, as Mitsuba does (checked: the integrator).
    Wrapper(&'static str),
    /// Classic `normalmap`/`bumpmap`, which is not its own adjoint (tests/bsdf/adjoint.rs):
    /// both directions converge to different images (checked: the plugin is in the scene, and
    /// the full sweep finds the disagreement).
    Classic(&'static str),
    /// The camera sees light through a delta BSDF — the named plugin: smooth reflection or
    /// refraction, or `null`'s pass-through (whose surface blocks shadow rays) — that a light
    /// path can never connect to a pinhole (and, from a point light, a caustic a path tracer
    /// never finds); Mitsuba's `ptracer` shares this (checked: the plugin is in the scene, and
    /// the full sweep finds the disagreement).
    Specular(&'static str),
    /// Participating media (`volpath`, `volpathmis`): groove's `ptracer` traces surfaces only
    /// (checked: the scene's integrator is one of those).
    Media,
    /// A BSDF that is not its own adjoint and, as in Mitsuba 3.9.1, is evaluated the same in
    /// both transport modes — the named plugin (`hair`: its fiber offset h and scale tilts come
    /// from the incident direction only; tests/bsdf/adjoint.rs) — so both directions converge
    /// to different images (checked: the plugin is in the scene, and the full sweep finds the
    /// disagreement with the scene's curves closed, [`CLOSED_HAIR`], so that their open ends,
    /// the other cause, are not what it finds).
    NotAdjoint(&'static str),
}

/// What the sweep does with a scene.
#[derive(Clone, Copy, Debug)]
enum Entry {
    /// Compared under the given `-D` values and normal mapping, at `scale` × the default work.
    Compare(&'static [(&'static str, &'static str)], Nm, u32),
    Exclude(Why),
}

/// The normal mapping a compared scene is loaded with.
#[derive(Clone, Copy, Debug)]
enum Nm {
    AsWritten,
    /// Every classic `normalmap` made a `microfacet_normalmap` (the decisions page's defaults).
    Microfacet,
}

use Entry::{Compare, Exclude};
use Why::*;

const NONE: &[(&str, &str)] = &[];

/// The scenes with curves, with every B-spline curve continued to radius 0 at both ends
/// (`tests/data/geometry/*_closed.txt`). An open end of a round curve (Embree's B-spline tubes
/// have no caps) makes visibility one-way under Mitsuba's backface culling of curves: a ray
/// that enters the tube through the opening leaves through the wall unseen (a hit from
/// inside), the reverse ray stops at the same wall seen from outside. Camera rays and sensor
/// connections then see different things, in groove as in Mitsuba 3.9.1 (docs/consistency.md,
/// "Open curve ends"; [`open_curve_ends_make_path_and_ptracer_disagree`]).
const CLOSED_CURVES: &[(&str, &str)] = &[("bspline", "curves_bspline_closed.txt")];
const CLOSED_HAIR: &[(&str, &str)] = &[
    ("bspline", "curves_bspline_closed.txt"),
    ("fibers", "curves_hair_closed.txt"),
];

/// Every scene of tests/data/scenes/, in file order. Glossy scenes get 4× the work: with
/// less, rare bright connections through a glossy lobe make the K-render variance unreliable
/// (measured: false alarms at 1×, agreement at 4×).
const SCENES: &[(&str, Entry)] = &[
    ("aov.xml", Exclude(Wrapper("aov"))),
    ("aov_instance.xml", Exclude(Wrapper("aov"))),
    ("area_point.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("cam_ortho.xml", Exclude(Orthographic)),
    ("cam_thinlens.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("cbox_v06.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("cbox_v3.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("cylinder_quirks.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("degenerate_mesh.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("depth_sphere.xml", Compare(NONE, Nm::AsWritten, 1)),
    // emitter_samples 1: with more, Mitsuba's `direct` counts a delta light once per emitter
    // sample (weight 1, not 1/emitter_samples; src/integrator/direct.rs), so the scene's es = 4
    // is not an estimate of the image light tracing converges to.
    (
        "direct_delta.xml",
        Compare(&[("es", "1")], Nm::AsWritten, 1),
    ),
    ("furnace_inside.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("furnace_sphere.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_area_tex.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_envmap.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_envmap_area.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_envmap_hdr.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_projector.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_spot_dir.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("light_spot_tex.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("mat_bumpmap.xml", Exclude(Classic("bumpmap"))),
    ("mat_glass.xml", Exclude(Specular("dielectric"))),
    ("mat_hair.xml", Exclude(NotAdjoint("hair"))),
    ("mat_mask.xml", Exclude(Specular("null"))),
    ("mat_metals.xml", Exclude(Specular("conductor"))),
    ("mat_plastic.xml", Exclude(Specular("plastic"))),
    ("mat_principled.xml", Compare(NONE, Nm::AsWritten, 4)),
    ("mat_rough_tex.xml", Compare(NONE, Nm::AsWritten, 4)),
    ("mat_roughconductor.xml", Compare(NONE, Nm::AsWritten, 4)),
    ("mat_roughglass.xml", Compare(NONE, Nm::AsWritten, 4)),
    ("media_albedo_grid.xml", Exclude(Media)),
    ("media_chroma.xml", Exclude(Media)),
    ("media_fog.xml", Exclude(Media)),
    ("media_furnace.xml", Exclude(Media)),
    ("media_furnace_hetero.xml", Exclude(Media)),
    ("media_glass.xml", Exclude(Media)),
    ("media_hetero.xml", Exclude(Media)),
    ("media_sphere.xml", Exclude(Media)),
    ("mis_area.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("mis_quad.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("mnm_furnace.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("mnm_glass_furnace.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("moment.xml", Exclude(Wrapper("moment"))),
    ("nmap_plane.xml", Compare(NONE, Nm::Microfacet, 1)),
    ("ptracer_cbox.xml", Compare(PATH, Nm::AsWritten, 1)),
    ("ptracer_glass.xml", Exclude(Specular("dielectric"))),
    ("ptracer_nmap.xml", Compare(PATH, Nm::Microfacet, 1)),
    ("ptracer_point_spot.xml", Compare(PATH, Nm::AsWritten, 1)),
    ("rotate_axis.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("rotate_shapes.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("sdfgrid.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("serialized.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("shape_curves.xml", Compare(CLOSED_CURVES, Nm::AsWritten, 1)),
    ("shape_cylinder.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("shape_instance.xml", Compare(NONE, Nm::AsWritten, 1)),
    // The stream renderer's `blendbsdf` kernel (tests/render/stream_blend.rs): a smooth
    // `conductor` and `dielectric` child in view.
    ("stream_blend.xml", Exclude(Specular("conductor"))),
    // The stream renderer's wrapper-chain driver with `bumpmap` (tests/render/stream.rs).
    ("stream_bumpmap.xml", Exclude(Classic("bumpmap"))),
    // The stream renderer's conductor kernels (tests/render/stream.rs): a smooth `conductor`
    // sphere in view (and classic normal maps).
    ("stream_conductors.xml", Exclude(Specular("conductor"))),
    // The stream renderer's cylinders in lanes (tests/render/stream_emission_shapes.rs).
    ("stream_cylinders.xml", Compare(NONE, Nm::AsWritten, 1)),
    // Its wrapper-chain driver around dielectric leaves: smooth `dielectric` in view.
    ("stream_dielectrics.xml", Exclude(Specular("dielectric"))),
    // Its wrapper-chain driver around diffuse leaves: classic normal maps, compared converted
    // (as nmap_plane.xml).
    (
        "stream_diffuse_wrapped.xml",
        Compare(NONE, Nm::Microfacet, 1),
    ),
    // The stream renderer's disks in lanes (tests/render/stream.rs).
    ("stream_disks.xml", Compare(NONE, Nm::AsWritten, 1)),
    // The stream renderer's emitters in lanes (tests/render/stream.rs).
    ("stream_emitters.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("stream_emitters_env.xml", Compare(NONE, Nm::AsWritten, 1)),
    // Envmap and sphere-light emission in lanes (tests/render/stream_emission_shapes.rs).
    ("stream_envmap_spheres.xml", Compare(NONE, Nm::AsWritten, 1)),
    // The stream renderer's instanced meshes in lanes (tests/render/stream.rs).
    ("stream_instances.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("stream_lights.xml", Compare(NONE, Nm::AsWritten, 1)),
    // Its wrapper-chain driver with `mask`: a smooth `dielectric` sphere behind a mask.
    ("stream_mask.xml", Exclude(Specular("dielectric"))),
    // The gather stage's one-mesh and mixed chunks of triangle hits
    // (tests/render/stream_mesh_chunks.rs).
    ("stream_mesh_chunks.xml", Compare(NONE, Nm::AsWritten, 1)),
    // Triangle-mesh lights sampled in lanes (tests/render/stream_light.rs); glossy.
    ("stream_mesh_lights.xml", Compare(NONE, Nm::AsWritten, 4)),
    (
        "stream_mesh_lights_many.xml",
        Compare(NONE, Nm::AsWritten, 4),
    ),
    // The stream renderer's plastic kernel (tests/render/stream.rs): smooth `plastic` in view.
    ("stream_plastic.xml", Exclude(Specular("plastic"))),
    // Its wrapper-chain driver around plastic leaves: smooth `plastic` under normal maps.
    ("stream_plastics_wrapped.xml", Exclude(Specular("plastic"))),
    // Its wrapper-chain driver around textured rough dielectrics: classic normal map.
    (
        "stream_rough_glass_textured.xml",
        Exclude(Classic("normalmap")),
    ),
    // The stream renderer's surface interactions in lanes (tests/render/stream.rs).
    ("stream_surfaces.xml", Compare(NONE, Nm::AsWritten, 1)),
    // Its driver around textured leaves: a smooth `conductor` sphere in view.
    ("stream_textured_leaves.xml", Exclude(Specular("conductor"))),
    // The stream renderer's textured area and spot lights in lanes (tests/render/stream.rs).
    (
        "stream_textured_lights.xml",
        Compare(NONE, Nm::AsWritten, 1),
    ),
    ("tex_hdr_pfm.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("tex_mesh_attr.xml", Compare(NONE, Nm::AsWritten, 1)),
    ("textured_quad.xml", Compare(NONE, Nm::AsWritten, 1)),
];

/// The `ptracer_*` scenes choose their integrator by `-D integrator`.
const PATH: &[(&str, &str)] = &[("integrator", "path")];

/// The `-D` values that make `scene` a `path` scene (for the excluded ones), with its curves
/// closed (`mat_hair.xml`).
fn defines_of(scene: &str) -> &'static [(&'static str, &'static str)] {
    if scene.starts_with("ptracer_") {
        PATH
    } else if scene == "mat_hair.xml" {
        CLOSED_HAIR
    } else {
        NONE
    }
}

/// The work of one comparison at `scale` 1.
fn plan(scale: u32, seed: u64) -> Plan {
    Plan {
        spp_path: 256 * scale,
        spp_pt: 32 * scale,
        k: 16,
        block: 8,
        seed,
    }
}

fn normal_mapping(nm: Nm) -> NormalMapping {
    match nm {
        Nm::AsWritten => NormalMapping::AsWritten,
        Nm::Microfacet => NormalMapping::Microfacet,
    }
}

/// Compares `scene` by its entry (panics for an excluded one).
fn compare_scene(scene: &str, seed: u64, scale_work: u32) -> Agreement {
    let (defines, nm, scale) = match SCENES.iter().find(|(s, _)| *s == scene) {
        Some((_, Compare(defines, nm, scale))) => (*defines, *nm, *scale),
        _ => panic!("{scene} is not a compared scene"),
    };
    let loaded = load(&test_scene(scene), defines, normal_mapping(nm));
    path_vs_ptracer(loaded, &plan(scale * scale_work, seed))
}

/// Checks the reason `why` on `scene` without rendering.
fn check_reason(scene: &str, why: Why) {
    let path = test_scene(scene);
    let text = std::fs::read_to_string(&path).expect("scene text");
    match why {
        Orthographic => {
            let mut loaded = load(&path, defines_of(scene), NormalMapping::AsWritten);
            super::ptracer_agree::swapped_to_ptracer(&mut loaded);
            let ro = groove::render::RenderOptions {
                spp: Some(1),
                ..Default::default()
            };
            let e = groove::render::render(&loaded.scene, &loaded.settings, &ro)
                .err()
                .unwrap_or_else(|| panic!("{scene}: ptracer rendered an orthographic sensor"));
            assert!(
                e.to_string()
                    .contains("ptracer needs a perspective or thinlens sensor"),
                "{scene}: {e}"
            );
        }
        Wrapper(kind) => {
            let loaded = load(&path, NONE, NormalMapping::AsWritten);
            let ok = matches!(
                (&loaded.settings.integrator, kind),
                (IntegratorDesc::Aov(_), "aov") | (IntegratorDesc::Moment(_), "moment")
            );
            assert!(ok, "{scene}: the integrator is not {kind}");
            // The loader refuses light tracing inside the wrapper.
            let nested = text.replacen(
                "<integrator type=\"path\"",
                "<integrator type=\"ptracer\"",
                1,
            );
            assert_ne!(nested, text, "{scene}: no nested path integrator");
            let doc = groove::scene::xml::parse::load_str(&nested, &path, &[]).expect("parse");
            let e = groove::load::instantiate(&doc, &path)
                .err()
                .unwrap_or_else(|| panic!("{scene}: ptracer accepted inside {kind}"));
            assert!(e.to_string().contains("ptracer"), "{scene}: {e}");
        }
        Media => {
            let loaded = load(&path, NONE, NormalMapping::AsWritten);
            assert!(
                matches!(
                    loaded.settings.integrator,
                    IntegratorDesc::Volpath(_) | IntegratorDesc::VolpathMis(_)
                ),
                "{scene}: the integrator is not volpath or volpathmis"
            );
        }
        Classic(plugin) | Specular(plugin) | NotAdjoint(plugin) => {
            let tag = format!("<bsdf type=\"{plugin}\"");
            assert!(text.contains(&tag), "{scene} has no {plugin} BSDF");
        }
    }
}

/// Every scene file is in the table once, in file order, and every exclusion's reason holds.
#[test]
fn every_test_scene_is_compared_or_excluded_for_a_checked_reason() {
    let dir = crate::common::repo_root().join("tests/data/scenes");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .expect("scenes dir")
        .filter_map(|e| {
            let n = e.ok()?.file_name().into_string().ok()?;
            n.ends_with(".xml").then_some(n)
        })
        .collect();
    files.sort();
    let listed: Vec<String> = SCENES.iter().map(|(s, _)| s.to_string()).collect();
    assert_eq!(
        listed, files,
        "SCENES must list tests/data/scenes/*.xml in order"
    );
    for (scene, entry) in SCENES {
        if let Exclude(why) = entry {
            check_reason(scene, *why);
        }
    }
}

/// The default tier: cheap scenes covering every emitter kind groove has (area, point, spot,
/// directional, projector, constant, envmap), the thin lens, `direct` against a ptracer of
/// depth 2, rough plastic and conductor, and the microfacet normal map (a converted classic
/// one and a written one).
#[test]
fn path_and_ptracer_agree_on_a_representative_subset() {
    let mut failed = Vec::new();
    for (i, scene) in [
        "mis_quad.xml",
        "light_spot_dir.xml",
        "light_envmap_hdr.xml",
        "light_projector.xml",
        "cam_thinlens.xml",
        "direct_delta.xml",
        "nmap_plane.xml",
        "mnm_furnace.xml",
    ]
    .into_iter()
    .enumerate()
    {
        let a = compare_scene(scene, 4000 + 100 * i as u64, 1);
        println!("{scene}: {}", a.summary());
        if !a.agrees() {
            failed.push(format!("{scene}: {:?}", a.failures()));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// The full sweep (see the module comment for the command). Prints the table of
/// docs/consistency.md.
#[test]
#[ignore = "full path vs ptracer sweep, minutes: run with --ignored"]
fn path_and_ptracer_agree_on_every_test_scene() {
    let start = std::time::Instant::now();
    let mut failed = Vec::new();
    println!("| scene | max \\|z\\| | threshold | ratio ptracer/path (R, G, B) | verdict |");
    println!("|---|---|---|---|---|");
    // GROOVE_SWEEP=a.xml,b.xml restricts the sweep to those scenes (for investigating one).
    let only = std::env::var("GROOVE_SWEEP").ok();
    // GROOVE_SWEEP_WORK=n multiplies every scene's samples by n.
    let work: u32 = std::env::var("GROOVE_SWEEP_WORK")
        .ok()
        .map(|w| w.parse().expect("GROOVE_SWEEP_WORK: a count"))
        .unwrap_or(1);
    for (i, (scene, entry)) in SCENES.iter().enumerate() {
        if only
            .as_ref()
            .is_some_and(|o| !o.split(',').any(|s| s == *scene))
        {
            continue;
        }
        let seed = 5000 + 100 * i as u64;
        let (a, expect_agree) = match entry {
            Compare(..) => (compare_scene(scene, seed, work), true),
            Exclude(why @ (Classic(_) | Specular(_) | NotAdjoint(_))) => {
                check_reason(scene, *why);
                let loaded = load(
                    &test_scene(scene),
                    defines_of(scene),
                    NormalMapping::AsWritten,
                );
                (path_vs_ptracer(loaded, &plan(work, seed)), false)
            }
            Exclude(why) => {
                check_reason(scene, *why);
                println!("| {scene} | — | — | — | excluded: {why:?} |");
                continue;
            }
        };
        let verdict = match (a.agrees(), expect_agree) {
            (true, true) => "agree".to_string(),
            (false, false) => format!("disagree, as expected ({entry:?})"),
            (true, false) => format!("**agrees although excluded** ({entry:?})"),
            (false, true) => format!("**DISAGREE**: {:?}", a.failures()),
        };
        println!(
            "| {scene} | {:.2} | {:.2} | {:.4} ± {:.4}, {:.4} ± {:.4}, {:.4} ± {:.4} | {verdict} |",
            a.z_max,
            a.z_threshold,
            a.ratio[0],
            a.ratio_sigma[0],
            a.ratio[1],
            a.ratio_sigma[1],
            a.ratio[2],
            a.ratio_sigma[2]
        );
        eprintln!("{scene}: {}", a.summary());
        if a.agrees() != expect_agree {
            failed.push(format!("{scene}: {}", a.summary()));
        }
    }
    println!("sweep: {:.0} s", start.elapsed().as_secs_f64());
    assert!(failed.is_empty(), "{failed:#?}");
}

/// Open curve ends, not the curves' normals, are why `path` and `ptracer` disagree on
/// `shape_curves.xml` (docs/consistency.md, "Open curve ends"). As written, the helix's lower
/// end is open and faces away from the camera: camera rays there stop at the tube's wall, while
/// a sensor connection from the floor behind enters through the opening and leaves through that
/// wall from inside, where Mitsuba's backface culling of curves lets it pass. So light tracing
/// is brighter at the helix's end (tile (6, 4)), by the floor seen through the tube; Mitsuba
/// 3.9.1's own `ptracer` and `path` differ there the same way. With every B-spline curve closed
/// (continued to radius 0, the sweep's entry for the scene) the two agree at the same work.
/// Slow tier (4× the sweep's work, both sides).
#[test]
#[ignore = "slow (about a minute): run with --ignored"]
fn open_curve_ends_make_path_and_ptracer_disagree() {
    let open = path_vs_ptracer(
        load(
            &test_scene("shape_curves.xml"),
            NONE,
            NormalMapping::AsWritten,
        ),
        &plan(4, 7100),
    );
    println!("shape_curves.xml as written: {}", open.summary());
    let (bx, by, _, pt, path) = open.worst;
    assert!(!open.agrees(), "as written: {}", open.summary());
    assert_eq!((bx, by), (6, 4), "the worst tile: {:?}", open.worst);
    assert!(
        pt > path,
        "light tracing is not the brighter: {:?}",
        open.worst
    );
    let closed = compare_scene("shape_curves.xml", 7200, 4);
    println!("shape_curves.xml closed: {}", closed.summary());
    assert!(closed.agrees(), "closed: {:?}", closed.failures());
}

/// A smooth-normal mesh light seen directly: the octahedron without normals gets Mitsuba's
/// smooth vertex normals, which differ from its faces' normals everywhere. A camera ray that
/// hits it sees its radiance; the light tracer's connection of a sampled light point to the
/// camera must convert area to solid angle with the face's own cosine, not the shading
/// normal's (which made the octahedron of `stream_textured_lights.xml` 25% too dark in
/// `ptracer`). Nothing else is in the scene: what such a light illuminates is a different
/// question (docs/consistency.md, "smooth-normal mesh lights"). The scene is written to a
/// temporary file (its mesh by absolute path).
#[test]
fn path_and_ptracer_agree_on_a_smooth_normal_mesh_light_seen_directly() {
    let obj = crate::common::repo_root().join("tests/data/geometry/octahedron.obj");
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0.7, 0.9, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/><rfilter type="box"/></film>
    </sensor>
    <shape type="obj">
        <string name="filename" value="{}"/>
        <transform name="to_world"><scale value="0.8"/><rotate y="1" angle="20"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 0.8, 0.6"/></emitter>
    </shape>
</scene>
"#,
        obj.display()
    );
    let dir = crate::common::Scratch::new(&format!("groove_smooth_light_{}", std::process::id()));
    let scene = dir.join("smooth_light.xml");
    std::fs::write(&scene, xml).expect("write scene");
    let loaded = load(&scene, NONE, NormalMapping::AsWritten);
    let a = path_vs_ptracer(loaded, &plan(1, 7100));
    println!("smooth-normal light: {}", a.summary());
    assert!(a.agrees(), "{:?}", a.failures());
}
