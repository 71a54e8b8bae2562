//! Foundation acceptance: groove's renders against Mitsuba 3.9.1 references and analytic answers,
//! MIS unbiasedness, depth semantics and determinism. Statistical comparisons use
//! `common::imgcmp` (per-tile z-tests with both images' own noise; see tests/refs/README.md).
//! Run in release mode (`cargo test --release`); sample counts are chosen so each render takes
//! about a second on 2 cores while a 2% brightness bias stays detectable (tests/render/refs_selfcheck.rs).

use crate::common;

use common::{compare, load_reference, render_scene, shared_cbox, test_scene, RgbImage};
use groove::integrator::{IntegratorDesc, Strategy};

fn matches_reference(r: &common::Rendered, reference: &str, block: usize, what: &str) {
    let (m, v) = load_reference(reference);
    let c = compare(&r.mean, &r.var, &m, &v, block);
    c.assert_consistent(what);
}

#[test]
fn cbox_rgb_from_mitsuba_data_matches_mitsuba() {
    let r = render_scene(&shared_cbox(), &[("res", "64")], 512, 1, 0, |_| {});
    matches_reference(&r, "cbox", 8, "cbox-rgb.xml at 64x64, 512 spp");
}

#[test]
fn point_light_sphere_light_twosided_room_matches_mitsuba() {
    let r = render_scene(&test_scene("area_point.xml"), &[], 512, 2, 0, |_| {});
    matches_reference(&r, "area_point", 4, "area_point.xml");
}

#[test]
fn mis_quad_with_point_light_matches_mitsuba() {
    let r = render_scene(&test_scene("mis_quad.xml"), &[], 256, 3, 0, |_| {});
    matches_reference(&r, "mis_quad", 8, "mis_quad.xml");
}

fn set_strategy(s: Strategy) -> impl FnOnce(&mut groove::load::Loaded) {
    move |loaded| match &mut loaded.settings.integrator {
        IntegratorDesc::Path(p) => p.strategy = s,
        other => panic!("expected a path integrator, got {other:?}"),
    }
}

#[test]
fn light_only_bsdf_only_and_mis_agree() {
    let scene = test_scene("mis_quad.xml");
    let d = [("point", "0")];
    let mis = render_scene(&scene, &d, 256, 4, 0, set_strategy(Strategy::Mis));
    let light = render_scene(&scene, &d, 256, 5, 0, set_strategy(Strategy::LightOnly));
    let bsdf = render_scene(&scene, &d, 1024, 6, 0, set_strategy(Strategy::BsdfOnly));
    for (r, what) in [
        (&mis, "MIS"),
        (&light, "light sampling only"),
        (&bsdf, "BSDF sampling only"),
    ] {
        matches_reference(r, "mis_quad_nopoint", 8, what);
    }
    // And against each other, with both noise estimates.
    compare(&light.mean, &light.var, &bsdf.mean, &bsdf.var, 8).assert_consistent("light vs BSDF");
    compare(&mis.mean, &mis.var, &light.mean, &light.var, 8).assert_consistent("MIS vs light");
}

#[test]
fn two_strategy_scene_of_our_own_agrees_under_all_strategies() {
    let scene = test_scene("mis_area.xml");
    let mis = render_scene(&scene, &[], 128, 7, 0, set_strategy(Strategy::Mis));
    let light = render_scene(&scene, &[], 256, 8, 0, set_strategy(Strategy::LightOnly));
    let bsdf = render_scene(&scene, &[], 512, 9, 0, set_strategy(Strategy::BsdfOnly));
    compare(&light.mean, &light.var, &mis.mean, &mis.var, 4).assert_consistent("light vs MIS");
    compare(&bsdf.mean, &bsdf.var, &mis.mean, &mis.var, 4).assert_consistent("BSDF vs MIS");
    // MIS must not be noisier than the worse single strategy at equal spp: compare total variance
    // at 128 spp (light and BSDF renders scaled to 128 spp).
    let total = |img: &RgbImage, scale: f64| -> f64 {
        img.data.iter().map(|p| (p[0] + p[1] + p[2]) * scale).sum()
    };
    let v_mis = total(&mis.var, 1.0);
    let v_light = total(&light.var, 2.0);
    let v_bsdf = total(&bsdf.var, 4.0);
    assert!(
        v_mis < v_light.max(v_bsdf),
        "MIS variance {v_mis} vs light {v_light}, BSDF {v_bsdf}"
    );
}

/// Pixels of `img` whose centre lies within `r` pixels of (cx, cy).
fn disk_pixels(img: &RgbImage, cx: f64, cy: f64, r: f64) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    for y in 0..img.height {
        for x in 0..img.width {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
            if dx * dx + dy * dy <= r * r {
                v.push((x, y));
            }
        }
    }
    v
}

/// Mean over `px` of channel-averaged values with its standard error.
fn region_mean(r: &common::Rendered, px: &[(usize, usize)]) -> (f64, f64) {
    let n = px.len() as f64;
    let mut m = 0.0;
    let mut v = 0.0;
    for &(x, y) in px {
        let a = r.mean.get(x, y);
        let b = r.var.get(x, y);
        m += (a[0] + a[1] + a[2]) / 3.0;
        v += (b[0] + b[1] + b[2]) / 3.0; // channels are grey and fully correlated
    }
    (m / n, v.sqrt() / n)
}

#[test]
fn white_furnace_sphere_reflects_its_albedo() {
    // The issue asks for 1.0 with albedo 0.8; for a convex object in a uniform environment the
    // exact answer is albedo × radiance (nothing is reflected twice). Mitsuba 3 agrees (0.80004).
    // With albedo 1 the image is 1 everywhere; the multi-bounce furnace is the next test.
    let scene = test_scene("furnace_sphere.xml");
    let r = render_scene(&scene, &[], 1024, 10, 0, |_| {});
    matches_reference(&r, "furnace_sphere", 8, "furnace sphere");
    let px = disk_pixels(&r.mean, 16.0, 16.0, 9.0);
    let (m, se) = region_mean(&r, &px);
    assert!(
        (m - 0.8).abs() < 4.0 * se + 1e-6,
        "sphere {m} ± {se}, expected 0.8"
    );

    let r1 = render_scene(&scene, &[("albedo", "1")], 256, 11, 0, |_| {});
    let (m1, se1) = region_mean(&r1, &px);
    assert!(
        (m1 - 1.0).abs() < 4.0 * se1 + 1e-6,
        "albedo 1: {m1} ± {se1}"
    );
    let all: Vec<(usize, usize)> = (0..32).flat_map(|y| (0..32).map(move |x| (x, y))).collect();
    let (ma, sea) = region_mean(&r1, &all);
    assert!(
        (ma - 1.0).abs() < 4.0 * sea + 1e-6,
        "whole image {ma} ± {sea}"
    );
}

#[test]
fn furnace_inside_an_emitting_sphere_converges_to_le_over_one_minus_albedo() {
    // L = le · Σ_{k<max_depth} ρ^k: unlimited depth → 0.2 / (1 − 0.8) = 1.
    let scene = test_scene("furnace_inside.xml");
    let all: Vec<(usize, usize)> = (0..16).flat_map(|y| (0..16).map(move |x| (x, y))).collect();
    for (depth, expected) in [("-1", 1.0), ("1", 0.2), ("2", 0.36), ("3", 0.488)] {
        let r = render_scene(&scene, &[("max_depth", depth)], 256, 12, 0, |_| {});
        let (m, se) = region_mean(&r, &all);
        assert!(
            (m - expected).abs() < 4.0 * se + 1e-5,
            "max_depth {depth}: {m} ± {se}, expected {expected}"
        );
        if depth == "1" {
            // Only the directly visible emitter: exact, no noise.
            assert!(r.mean.data.iter().all(|p| (p[0] - 0.2).abs() < 1e-6));
        }
    }
}

#[test]
fn max_depth_one_two_three_match_mitsuba() {
    let scene = test_scene("depth_sphere.xml");
    for (d, name, spp) in [
        ("1", "depth_sphere_d1", 16),
        ("2", "depth_sphere_d2", 256),
        ("3", "depth_sphere_d3", 256),
    ] {
        let r = render_scene(&scene, &[("max_depth", d)], spp, 13, 0, |_| {});
        matches_reference(&r, name, 4, &format!("depth_sphere max_depth={d}"));
        if d == "1" {
            // Only emitters seen directly: the sky is 1 and objects 0; pixels on a silhouette
            // average the two.
            assert!(r
                .mean
                .data
                .iter()
                .all(|p| (0.0..=1.0 + 1e-6).contains(&p[0])));
            assert_eq!(r.mean.get(16, 16)[0], 0.0, "the sphere's centre is black");
            assert_eq!(r.mean.get(1, 1)[0], 1.0, "the sky is exactly 1");
        }
    }
}

#[test]
fn old_dialect_scene_renders_like_its_version3_twin() {
    let v06 = render_scene(&test_scene("cbox_v06.xml"), &[], 64, 14, 0, |_| {});
    let v3 = render_scene(&test_scene("cbox_v3.xml"), &[], 64, 14, 0, |_| {});
    assert_eq!(
        v06.mean.data, v3.mean.data,
        "same scene after upgrade: identical pixels"
    );
    matches_reference(&v3, "cbox_v3", 8, "cbox_v3.xml");
}

#[test]
fn same_seed_gives_identical_pixels_with_one_or_two_threads() {
    let scene = shared_cbox();
    let d = [("res", "40")];
    let a = render_scene(&scene, &d, 8, 99, 1, |_| {});
    let b = render_scene(&scene, &d, 8, 99, 2, |_| {});
    assert_eq!(a.stats.threads, 1);
    assert_eq!(b.stats.threads, 2);
    let bits = |img: &RgbImage| -> Vec<u64> {
        img.data
            .iter()
            .flat_map(|p| p.iter().map(|c| c.to_bits()))
            .collect()
    };
    assert_eq!(bits(&a.mean), bits(&b.mean));
    // And the written EXRs carry identical pixel data.
    let dir = crate::common::Scratch::new(&format!("groove-det-{}", std::process::id()));
    let mut pixels = Vec::new();
    for (r, name) in [(&a, "t1.exr"), (&b, "t2.exr")] {
        let img = groove::film::Image {
            width: r.mean.width as u32,
            height: r.mean.height as u32,
            data: r
                .mean
                .data
                .iter()
                .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
                .collect(),
        };
        let path = dir.join(name);
        groove::output::write_image(&path, &img, &groove::output::Metadata::default()).unwrap();
        let (back, _) = groove::output::read_exr(&path).unwrap();
        pixels.push(
            back.data
                .iter()
                .flat_map(|p| p.map(f32::to_bits))
                .collect::<Vec<u32>>(),
        );
    }
    assert_eq!(pixels[0], pixels[1]);
    let c = render_scene(&scene, &d, 8, 100, 2, |_| {});
    assert_ne!(
        bits(&a.mean),
        bits(&c.mean),
        "another seed gives another image"
    );
}

#[test]
fn direct_integrator_matches_path_tracing_at_depth_two() {
    // mis_quad.xml uses path with max_depth 2 (direct light only): the `direct` integrator must
    // give the same image (reference: Mitsuba's path render). With its point light, one emitter
    // sample: Mitsuba 3.9.1's `direct` counts a delta light once per emitter sample (see
    // src/integrator/direct.rs and tests/render/parity.rs), so more samples are tested on the
    // variant without the point light.
    let direct = |emitter_samples| {
        move |loaded: &mut groove::load::Loaded| {
            loaded.settings.integrator =
                IntegratorDesc::Direct(groove::integrator::DirectSettings {
                    emitter_samples,
                    bsdf_samples: 1,
                    hide_emitters: false,
                })
        }
    };
    let scene = test_scene("mis_quad.xml");
    let r = render_scene(&scene, &[], 128, 15, 0, direct(1));
    matches_reference(&r, "mis_quad", 8, "direct integrator on mis_quad.xml");
    let r = render_scene(&scene, &[("point", "0")], 128, 17, 0, direct(2));
    matches_reference(
        &r,
        "mis_quad_nopoint",
        8,
        "direct integrator, 2 emitter samples, on mis_quad.xml -D point=0",
    );
}

#[test]
fn hide_emitters_hides_only_directly_visible_emitters() {
    let scene = test_scene("furnace_sphere.xml");
    let hide = |l: &mut groove::load::Loaded| match &mut l.settings.integrator {
        IntegratorDesc::Path(p) => p.hide_emitters = true,
        other => panic!("{other:?}"),
    };
    let r = render_scene(&scene, &[], 64, 16, 0, hide);
    // Background (the environment seen directly) is black; the sphere still reflects it.
    assert_eq!(r.mean.get(0, 0), [0.0; 3]);
    let px = disk_pixels(&r.mean, 16.0, 16.0, 9.0);
    let (m, se) = region_mean(&r, &px);
    assert!((m - 0.8).abs() < 4.0 * se + 1e-6, "{m} ± {se}");
}

#[test]
fn serialized_meshes_match_mitsuba() {
    // Mitsuba `serialized` files: a v4 two-mesh file (mesh 0 with stored normals + uvs under a
    // checkerboard; mesh 1 double precision with face_normals) and a v3 torus (computed normals).
    let r = render_scene(&test_scene("serialized.xml"), &[], 512, 31, 0, |_| {});
    let (m, v) = load_reference("serialized");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("serialized: {}", c.report());
    c.assert_consistent("serialized.xml, 512 spp");
}

#[test]
fn the_serialized_comparison_sees_smooth_shading_of_the_flat_blob() {
    // Sensitivity check: with face_normals off, the blob is shaded by its stored normals; the
    // reference (flat) must reject that, so the test above pins the face_normals semantics.
    let scene = test_scene("serialized.xml");
    let r = render_scene(&scene, &[("blob_flat", "false")], 512, 32, 0, |_| {});
    let (m, v) = load_reference("serialized");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("smooth blob: {}", c.report());
    assert!(!c.is_consistent(), "a smooth-shaded blob was accepted");
}

// ---------------------------------------------------------------- sensors and the cylinder

#[test]
fn orthographic_sensor_matches_mitsuba() {
    // A scaled film under a look-at, near_clip cutting through the cube and the floor.
    let r = render_scene(&test_scene("cam_ortho.xml"), &[], 512, 41, 0, |_| {});
    let (m, v) = load_reference("cam_ortho");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("cam_ortho: {}", c.report());
    c.assert_consistent("cam_ortho.xml, 512 spp");
}

#[test]
fn the_orthographic_comparison_sees_a_wrong_film_size() {
    // Sensitivity: a film 5% wider than the reference's is rejected.
    let r = render_scene(
        &test_scene("cam_ortho.xml"),
        &[("scale", "2.52")],
        512,
        42,
        0,
        |_| {},
    );
    let (m, v) = load_reference("cam_ortho");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("cam_ortho, scale 2.52: {}", c.report());
    assert!(
        !c.is_consistent(),
        "a 5% larger orthographic film was accepted"
    );
}

#[test]
fn thinlens_sensor_matches_mitsuba() {
    // Visible defocus in front of and behind the plane of focus.
    let r = render_scene(&test_scene("cam_thinlens.xml"), &[], 1024, 43, 0, |_| {});
    let (m, v) = load_reference("cam_thinlens");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("cam_thinlens: {}", c.report());
    c.assert_consistent("cam_thinlens.xml, 1024 spp");
}

#[test]
fn the_thinlens_comparison_sees_a_wrong_focus_or_aperture() {
    // Sensitivity: focus at 4.5 instead of 5.5, and a pinhole-like lens, are both rejected.
    let (m, v) = load_reference("cam_thinlens");
    for (defines, what) in [
        ([("focus", "4.5")], "focus_distance 4.5"),
        ([("aperture", "0.05")], "aperture_radius 0.05"),
    ] {
        let r = render_scene(
            &test_scene("cam_thinlens.xml"),
            &defines,
            1024,
            44,
            0,
            |_| {},
        );
        let c = compare(&r.mean, &r.var, &m, &v, 4);
        eprintln!("cam_thinlens, {what}: {}", c.report());
        assert!(!c.is_consistent(), "{what} was accepted");
    }
}

#[test]
fn cylinders_match_mitsuba() {
    // p0/p1/radius, to_world with a uv checkerboard, an emitting and a flipped emitting cylinder.
    let r = render_scene(&test_scene("shape_cylinder.xml"), &[], 1024, 45, 0, |_| {});
    let (m, v) = load_reference("shape_cylinder");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("shape_cylinder: {}", c.report());
    c.assert_consistent("shape_cylinder.xml, 1024 spp");
}

#[test]
fn the_cylinder_comparison_sees_a_wrong_radius() {
    // Sensitivity: the left cylinder 6% thicker (0.37 instead of 0.35) is rejected.
    let r = render_scene(
        &test_scene("shape_cylinder.xml"),
        &[("radius", "0.37")],
        1024,
        46,
        0,
        |_| {},
    );
    let (m, v) = load_reference("shape_cylinder");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("shape_cylinder, radius 0.37: {}", c.report());
    assert!(!c.is_consistent(), "a 6% thicker cylinder was accepted");
}
