//! The stream renderer (`--renderer stream`) gives the scalar renderer's image bit for bit: the
//! film's exact sums of every pixel, the ray counts and the dropped samples, at 1, 2, 3 and 7
//! threads, on a representative subset of scenes at low spp (bench scenes, a Cornell box,
//! textures, classic and microfacet normal maps, glass, an environment map, instances, hair on
//! curves). 3 spp
//! so that batches of 1024 paths end inside a pixel. The slow tier sweeps every scene in
//! `scenes/` and `tests/data/scenes/` that the path integrator renders:
//! `cargo test --release --test render stream -- --ignored`.

use crate::common::{repo_root, test_scene};
use groove::integrator::IntegratorDesc;
use groove::load::options::{LoadOptions, NormalMapping};
use groove::load::Loaded;
use groove::render::{RenderOptions, Renderer};
use groove::stream::Packets;
use std::path::{Path, PathBuf};

/// What a render produced, exactly.
#[derive(Debug, PartialEq)]
struct Exact {
    pixels: Vec<groove::film::RawPixel>,
    rays: (u64, u64, u64),
    invalid: u64,
}

fn load(path: &Path, mode: &str) -> Loaded {
    let opts = LoadOptions {
        normal_mapping: NormalMapping::parse(mode).unwrap(),
        ..Default::default()
    };
    groove::load::load_scene(path, &opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A window of at most 40×36 pixels around the film's centre: two by two blocks of 32.
fn window(l: &Loaded) -> (u32, u32, u32, u32) {
    let (w, h) = (l.settings.film.width, l.settings.film.height);
    let (cw, ch) = (w.min(40), h.min(36));
    ((w - cw) / 2, (h - ch) / 2, cw, ch)
}

/// With the scene's default packets.
fn render(l: &Loaded, renderer: Renderer, threads: usize, spp: u32) -> Exact {
    render_seeded(l, renderer, threads, spp, 7, Packets::default_for(&l.scene))
}

fn render_seeded(
    l: &Loaded,
    renderer: Renderer,
    threads: usize,
    spp: u32,
    seed: u64,
    packets: Packets,
) -> Exact {
    let out = groove::render::render(
        &l.scene,
        &l.settings,
        &RenderOptions {
            threads,
            spp: Some(spp),
            seed: Some(seed),
            crop: Some(window(l)),
            renderer,
            packets: Some(packets),
            ..Default::default()
        },
    )
    .expect("render");
    let n = out.film.develop().data.len();
    Exact {
        pixels: (0..n).map(|i| out.film.raw_pixel(i)).collect(),
        rays: (
            out.stats.rays.camera,
            out.stats.rays.bounce,
            out.stats.rays.shadow,
        ),
        invalid: out.stats.invalid_samples,
    }
}

/// Stream images at 1, 2, 3 and 7 threads against the scalar image (1 thread).
fn assert_identical(l: &Loaded, label: &str, spp: u32) {
    let scalar = render(l, Renderer::Scalar, 1, spp);
    assert!(scalar.rays.0 > 0, "{label}: nothing rendered");
    for t in [1, 2, 3, 7] {
        let stream = render(l, Renderer::Stream, t, spp);
        assert_eq!(
            stream.rays, scalar.rays,
            "{label}: ray counts at {t} threads"
        );
        assert_eq!(stream.invalid, scalar.invalid, "{label}: invalid samples");
        if let Some(i) = (0..scalar.pixels.len()).find(|&i| stream.pixels[i] != scalar.pixels[i]) {
            panic!(
                "{label}: pixel {i} differs at {t} threads: {:?} vs {:?}",
                stream.pixels[i], scalar.pixels[i]
            );
        }
    }
}

fn scene(rel: &str) -> PathBuf {
    repo_root().join(rel)
}

#[test]
fn stream_equals_scalar_on_the_bench_scenes() {
    for (name, mode) in [
        ("metal_plastic", "classic"),
        ("metal_plastic", "walk-same"),
        ("glass", "classic"),
        ("strong", "explicit"),
    ] {
        let l = load(&scene(&format!("scenes/bench/{name}.xml")), mode);
        assert_identical(&l, &format!("{name} ({mode})"), 3);
    }
}

#[test]
fn stream_equals_scalar_on_a_representative_subset() {
    for (path, mode) in [
        (scene("scenes/cornell/cbox-rgb.xml"), "as_written"),
        (test_scene("textured_quad.xml"), "as_written"),
        (test_scene("nmap_plane.xml"), "classic"),
        (test_scene("nmap_plane.xml"), "walk-mirror"),
        (test_scene("mat_glass.xml"), "as_written"),
        (test_scene("light_envmap.xml"), "as_written"),
        (test_scene("shape_instance.xml"), "as_written"),
        // Curves: traced without packets (their packet hits differ in the last bits).
        (test_scene("mat_hair.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        assert_identical(&l, &format!("{name} ({mode})"), 3);
    }
}

/// Every ray kind traced as 8-wide packets (the default under tier A only) and camera packets
/// alone (the default under Embree) still give the scalar image.
#[test]
fn stream_with_every_packet_equals_scalar() {
    let all = Packets {
        camera: true,
        bounce: true,
        shadow: true,
    };
    for (path, mode) in [
        (scene("scenes/bench/metal_plastic.xml"), "classic"),
        (scene("scenes/cornell/cbox-rgb.xml"), "as_written"),
        (test_scene("shape_instance.xml"), "as_written"),
        (test_scene("light_envmap.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let scalar = render(&l, Renderer::Scalar, 1, 3);
        for (t, p) in [(1, all), (3, all), (2, Packets::DEFAULT)] {
            let stream = render_seeded(&l, Renderer::Stream, t, 3, 7, p);
            assert!(
                stream == scalar,
                "{name} ({mode}): differs at {t} threads, {p:?}"
            );
        }
    }
}

/// The comparison sees a change of one path's stream: another seed is another image.
#[test]
fn the_comparison_rejects_another_seed() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    let a = render_seeded(&l, Renderer::Scalar, 1, 1, 7, Packets::ALL);
    let b = render_seeded(&l, Renderer::Stream, 1, 1, 8, Packets::ALL);
    assert_ne!(a.pixels, b.pixels);
}

#[test]
fn the_stream_renderer_refuses_other_integrators() {
    let l = load(&test_scene("direct_delta.xml"), "as_written");
    let err = groove::render::render(
        &l.scene,
        &l.settings,
        &RenderOptions {
            spp: Some(1),
            renderer: Renderer::Stream,
            ..Default::default()
        },
    )
    .err()
    .expect("the stream renderer rendered a direct integrator");
    let msg = err.to_string();
    assert!(
        msg.contains("path integrator only") && msg.contains("direct"),
        "{msg}"
    );
}

/// Slow tier: every scene of the repository that the path integrator renders, as written and
/// (when it has normal maps) in classic and walk modes.
#[test]
#[ignore]
fn stream_equals_scalar_on_every_path_scene() {
    let mut scenes = Vec::new();
    for dir in [
        "scenes/bench",
        "scenes/cornell",
        "scenes/diffuse_normalmap",
        "scenes/showcase",
    ]
    .map(scene)
    .into_iter()
    .chain([repo_root().join("tests/data/scenes")])
    {
        let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "xml"))
            .collect();
        v.sort();
        scenes.extend(v);
    }
    let mut rendered = 0;
    for path in &scenes {
        let text = std::fs::read_to_string(path).unwrap();
        let modes: &[&str] = if text.contains("normalmap") {
            &["as_written", "classic", "walk-same"]
        } else {
            &["as_written"]
        };
        for &mode in modes {
            let opts = LoadOptions {
                normal_mapping: NormalMapping::parse(mode).unwrap(),
                ..Default::default()
            };
            let Ok(l) = groove::load::load_scene(path, &opts) else {
                continue; // a mode that cannot apply, or a scene that needs -D values
            };
            if !matches!(l.settings.integrator, IntegratorDesc::Path(_)) {
                break;
            }
            let name = path.file_name().unwrap().to_string_lossy();
            assert_identical(&l, &format!("{name} ({mode})"), 5);
            rendered += 1;
        }
    }
    eprintln!("{rendered} scene/mode pairs identical");
    assert!(rendered >= 40, "only {rendered} scene/mode pairs rendered");
}
