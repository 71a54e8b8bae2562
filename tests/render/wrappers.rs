//! `mask`/`null`, `bumpmap`, textured roughness and a textured area light at render level against
//! Mitsuba 3.9.1 references (tests/refs/{mat_mask,mat_bumpmap,mat_rough_tex,light_area_tex}.exr,
//! see tests/refs/README.md), with sensitivity checks that the comparison sees the feature.

use crate::common;

use common::{compare, load_reference, render_scene, render_scene_edited, test_scene};

fn check(scene: &str, reference: &str, spp: u32, seed: u64) {
    let r = render_scene(&test_scene(scene), &[], spp, seed, 0, |_| {});
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("{reference}: {}", c.report());
    c.assert_consistent(&format!("{scene}, {spp} spp"));
}

#[test]
fn mask_and_null_match_mitsuba() {
    check("mat_mask.xml", "mat_mask", 1024, 41);
}

#[test]
fn bumpmap_matches_mitsuba() {
    check("mat_bumpmap.xml", "mat_bumpmap", 512, 42);
}

#[test]
fn textured_roughness_matches_mitsuba() {
    check("mat_rough_tex.xml", "mat_rough_tex", 512, 43);
}

#[test]
fn textured_area_light_matches_mitsuba() {
    check("light_area_tex.xml", "light_area_tex", 512, 44);
}

/// Sensitivity: without the bumps (scale 0), or with the roughness texture replaced by its
/// mean, the images differ from the references by more than the tests' noise.
#[test]
fn the_comparisons_see_bumps_and_roughness_textures() {
    let r = render_scene_edited(
        &test_scene("mat_bumpmap.xml"),
        |t| {
            t.replace(r#"name="scale" value="0.08""#, r#"name="scale" value="0""#)
                .replace(r#"name="scale" value="0.3""#, r#"name="scale" value="0""#)
        },
        256,
        45,
    );
    let (m, v) = load_reference("mat_bumpmap");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("mat_bumpmap without bumps: {}", c.report());
    assert!(!c.is_consistent(), "flat shading was accepted");

    // The roughness texture's mean, as the loader takes it for a textured alpha's template.
    let scene = test_scene("mat_rough_tex.xml");
    let loaded = groove::load::load_scene(&scene, &Default::default()).unwrap();
    let mean = loaded
        .scene
        .materials()
        .textures
        .iter()
        .find(|t| {
            t.as_bitmap()
                .is_some_and(|b| b.source().ends_with("alpha_stripes.png"))
        })
        .map(|t| groove::spectrum::luminance(t.mean()))
        .expect("the roughness texture");
    let r = render_scene_edited(
        &scene,
        |t| {
            t.replace(
                r#"<ref name="alpha" id="alpha"/>"#,
                &format!(r#"<float name="alpha" value="{mean}"/>"#),
            )
            .replace(
                r#"<ref name="alpha_u" id="alpha"/>"#,
                &format!(r#"<float name="alpha_u" value="{mean}"/>"#),
            )
        },
        256,
        46,
    );
    let (m, v) = load_reference("mat_rough_tex");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("mat_rough_tex with mean roughness: {}", c.report());
    assert!(!c.is_consistent(), "a constant roughness was accepted");
}

/// A `null` surface is an ordinary delta bounce for `path`, as in Mitsuba 3.9.1: behind a null
/// panel, a diffuse floor under a constant environment is black at `max_depth` 2 (camera → null →
/// floor leaves no bounce for the environment) and lit at 3. Mitsuba 3.9.1 renders the centre
/// pixel of this scene as 0 at depth 2 and 0.39 at depth 3 (0.50 without the panel).
#[test]
fn null_counts_as_a_bounce() {
    let dir = crate::common::Scratch::new(&format!("groove-null-{}", std::process::id()));
    let path = dir.join("null_panel.xml");
    std::fs::write(
        &path,
        r#"<scene version="3.0.0">
    <default name="depth" value="2"/>
    <integrator type="path"><integer name="max_depth" value="$depth"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0,0,6" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.5"/><translate z="1"/></transform>
        <bsdf type="null"/>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#,
    )
    .unwrap();
    let centre = |depth: &str| {
        let r = render_scene(&path, &[("depth", depth)], 4096, 47, 0, |_| {});
        r.mean.get(4, 4)[0]
    };
    assert_eq!(centre("2"), 0.0);
    let d3 = centre("3");
    assert!((d3 - 0.39).abs() < 0.02, "depth 3: {d3}");
}
