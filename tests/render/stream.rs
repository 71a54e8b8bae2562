//! The stream renderer (`--renderer stream`) gives the scalar renderer's image bit for bit: the
//! film's exact sums of every pixel, the ray counts and the dropped samples, at 1, 2, 3 and 7
//! threads, on a representative subset of scenes at low spp (bench scenes, a Cornell box,
//! textures, classic and microfacet normal maps, glass, an environment map, instances, hair on
//! curves). 3 spp
//! so that batches of 1024 paths end inside a pixel. The slow tier sweeps every scene in
//! `scenes/` and `tests/data/scenes/` that the path integrator renders:
//! `cargo test --release --test render stream -- --ignored`.
//!
//! Its helpers are `pub(super)` so that the newer `stream_*` test files share them.

use crate::common::{repo_root, test_scene};
use groove::integrator::{IntegratorDesc, PathSettings};
use groove::load::options::{LoadOptions, NormalMapping};
use groove::load::Loaded;
use groove::render::{RenderOptions, Renderer};
use groove::stream::Packets;
use std::path::{Path, PathBuf};

/// What a render produced, exactly (and, not compared, the lane counters).
#[derive(Debug)]
pub(super) struct Exact {
    pub(super) pixels: Vec<groove::film::RawPixel>,
    pub(super) rays: (u64, u64, u64),
    pub(super) invalid: u64,
    pub(super) lanes: groove::stream::LaneCounters,
}

impl PartialEq for Exact {
    fn eq(&self, o: &Exact) -> bool {
        (&self.pixels, self.rays, self.invalid) == (&o.pixels, o.rays, o.invalid)
    }
}

pub(super) fn load(path: &Path, mode: &str) -> Loaded {
    let opts = LoadOptions {
        normal_mapping: NormalMapping::parse(mode).unwrap(),
        ..Default::default()
    };
    groove::load::load_scene(path, &opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A window of at most 40×36 pixels around the film's centre: two by two blocks of 32.
pub(super) fn window(l: &Loaded) -> (u32, u32, u32, u32) {
    let (w, h) = (l.settings.film.width, l.settings.film.height);
    let (cw, ch) = (w.min(40), h.min(36));
    ((w - cw) / 2, (h - ch) / 2, cw, ch)
}

/// With the scene's default packets.
pub(super) fn render(l: &Loaded, renderer: Renderer, threads: usize, spp: u32) -> Exact {
    render_seeded(l, renderer, threads, spp, 7, Packets::default_for(&l.scene))
}

pub(super) fn render_seeded(
    l: &Loaded,
    renderer: Renderer,
    threads: usize,
    spp: u32,
    seed: u64,
    packets: Packets,
) -> Exact {
    render_with(
        l,
        RenderOptions {
            threads,
            spp: Some(spp),
            seed: Some(seed),
            renderer,
            packets: Some(packets),
            ..Default::default()
        },
    )
}

/// `l` rendered with `opts` over its centre window ([`window`]): the film's exact sums, the ray
/// counts, the dropped samples and the lane counters.
pub(super) fn render_with(l: &Loaded, opts: RenderOptions) -> Exact {
    let opts = RenderOptions {
        crop: Some(window(l)),
        ..opts
    };
    let out = groove::render::render(&l.scene, &l.settings, &opts).expect("render");
    let n = out.film.develop().data.len();
    Exact {
        pixels: (0..n).map(|i| out.film.raw_pixel(i)).collect(),
        rays: (
            out.stats.rays.camera,
            out.stats.rays.bounce,
            out.stats.rays.shadow,
        ),
        invalid: out.stats.invalid_samples,
        lanes: out.stats.rays.lanes,
    }
}

/// Stream images at 1, 2, 3 and 7 threads against the scalar image (1 thread); returns the
/// stream renderer's lane counters at 1 thread.
pub(super) fn assert_identical(l: &Loaded, label: &str, spp: u32) -> groove::stream::LaneCounters {
    let scalar = render(l, Renderer::Scalar, 1, spp);
    let mut lanes = None;
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
        lanes.get_or_insert(stream.lanes);
    }
    lanes.expect("rendered at 1 thread")
}

pub(super) fn scene(rel: &str) -> PathBuf {
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

/// The scenes where the 8-wide `diffuse` kernel runs (its Cornell boxes, the bench scenes'
/// diffuse floor and sphere, bitmap and mesh-attribute reflectance textures, every emitter kind
/// its light samples meet: mesh, rectangle, sphere and textured area lights, environment maps,
/// point, spot, directional and projector lights; a thin-lens camera) give the scalar image at
/// 1, 2, 3 and 7 threads, and the kernel shaded paths in each (so a silent fallback to the
/// 1-lane code cannot pass).
#[test]
fn stream_equals_scalar_where_the_diffuse_kernel_runs() {
    for (path, mode) in [
        (scene("scenes/bench/strong.xml"), "explicit"),
        (scene("scenes/bench/glass.xml"), "classic"),
        (test_scene("cbox_v3.xml"), "as_written"),
        (test_scene("tex_mesh_attr.xml"), "as_written"),
        (test_scene("light_area_tex.xml"), "as_written"),
        (test_scene("light_envmap_area.xml"), "as_written"),
        (test_scene("light_spot_dir.xml"), "as_written"),
        (test_scene("light_projector.xml"), "as_written"),
        (test_scene("area_point.xml"), "as_written"),
        (test_scene("mis_area.xml"), "as_written"),
        (test_scene("cam_thinlens.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let lanes = assert_identical(&l, &format!("{name} ({mode})"), 3);
        assert!(
            lanes.kernel_lanes > 0,
            "{name}: no path went through the 8-wide diffuse kernel"
        );
    }
}

/// The diffuse kernel under every setting that changes what a vertex does: the stratified
/// sampler (whose first 2-D draws of a path are stratified: the kernel's light sample at the
/// first bounce is one), the light-only and BSDF-only strategies, Russian roulette from the
/// first bounce, hidden emitters and a depth limit of 2.
#[test]
fn stream_equals_scalar_in_the_diffuse_kernel_under_every_setting() {
    use groove::integrator::Strategy;
    use groove::sampler::SamplerKind;
    let base = || load(&scene("scenes/cornell/cbox-rgb.xml"), "as_written");
    let path = |l: &mut Loaded| match &mut l.settings.integrator {
        IntegratorDesc::Path(p) => *p,
        _ => unreachable!("a path scene"),
    };
    let mut variants: Vec<(&str, Loaded)> = Vec::new();
    for (label, jitter) in [("stratified", true), ("stratified, no jitter", false)] {
        let mut l = base();
        l.settings.sampler.kind = SamplerKind::Stratified { jitter };
        l.settings.sampler.sample_count = 4;
        variants.push((label, l));
    }
    for (label, edit) in [
        (
            "light only",
            (|p| p.strategy = Strategy::LightOnly) as fn(&mut PathSettings),
        ),
        ("bsdf only", |p| p.strategy = Strategy::BsdfOnly),
        ("rr_depth 1", |p| p.rr_depth = 1),
        ("hide_emitters", |p| p.hide_emitters = true),
        ("max_depth 2", |p| p.max_depth = 2),
    ] {
        let mut l = base();
        let mut p = path(&mut l);
        edit(&mut p);
        l.settings.integrator = IntegratorDesc::Path(p);
        variants.push((label, l));
    }
    for (label, l) in &variants {
        let spp = l.settings.sampler.sample_count.min(4);
        let lanes = assert_identical(l, &format!("cbox-rgb ({label})"), spp);
        assert!(lanes.kernel_lanes > 0, "{label}: the kernel never ran");
    }
}

/// The lane counters see the kernel: on the Cornell box (every material `diffuse`) at least
/// 98 % of the shaded paths go through it, on metal_plastic (no `diffuse` but its area
/// light's own) as many, nearly all of them the conductor kernels'. A run of one material at
/// one bounce leaves to the 1-lane code
/// only a last path alone: its last 2–7 paths are one padded chunk
/// (`kernels::vertex::x8::PAD_MIN`); without that, metal_plastic's share was ~0.97.
#[test]
fn the_lane_counters_count_the_diffuse_kernel() {
    let l = load(&scene("scenes/cornell/cbox-rgb.xml"), "as_written");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.kernel_lanes as f64 / c.shade_used as f64;
    assert!((0.98..=1.0).contains(&share), "{c:?}: {share}");
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.kernel_lanes as f64 / c.shade_used as f64;
    assert!(
        c.shade_used > 0 && driver_all_but_emitters(&c) && share >= 0.98,
        "{c:?}: {share}"
    );
}

/// On a scene whose every material is a wrapper chain, the kernel paths are the driver's but
/// those that scatter off an area light's own default `diffuse` BSDF: runs of a few paths, which
/// the `diffuse` kernel takes as padded chunks (under 1 % of the shaded paths).
pub(super) fn driver_all_but_emitters(c: &groove::stream::LaneCounters) -> bool {
    c.kernel_lanes >= c.conductor_lanes && c.kernel_lanes - c.conductor_lanes <= c.shade_used / 100
}

// ---------------------------------------------------------------------------------------------
// The `plastic` / `roughplastic` kernel (issue 18, `stream::kernels::plastic`).
// ---------------------------------------------------------------------------------------------

/// `tests/data/scenes/stream_plastic.xml` with `-D` values.
pub(super) fn plastic_scene(defines: &[(&str, &str)]) -> Loaded {
    load_defined("stream_plastic.xml", defines)
}

/// The scenes where the 8-wide plastic kernel runs give the scalar image at 1, 2, 3 and 7
/// threads: `stream_plastic.xml` (smooth and rough coatings, Beckmann sampling all normals and
/// GGX visible normals, linear and nonlinear, textured diffuse and specular reflectances, which
/// the kernel gathers per lane; mesh, rectangle and sphere area lights, point, spot and
/// environment lights) and `mat_plastic.xml` (both `nonlinear` values). `stream_plastic.xml`
/// has no `diffuse` material, so its kernel lanes are the plastic kernel's: a silent fallback
/// to the 1-lane code cannot pass.
#[test]
fn stream_equals_scalar_where_the_plastic_kernel_runs() {
    let lanes = assert_identical(&plastic_scene(&[]), "stream_plastic.xml", 3);
    assert!(
        lanes.kernel_lanes > 0,
        "stream_plastic.xml: no path went through the 8-wide plastic kernel"
    );
    for nonlinear in ["false", "true"] {
        let opts = LoadOptions {
            defines: vec![("nonlinear".into(), nonlinear.into())],
            ..Default::default()
        };
        let l = groove::load::load_scene(&test_scene("mat_plastic.xml"), &opts).unwrap();
        assert_identical(&l, &format!("mat_plastic.xml (nonlinear {nonlinear})"), 3);
    }
}

/// The plastic kernel under every setting that changes what a vertex does: the stratified
/// sampler, the light-only and BSDF-only strategies, Russian roulette from the first bounce,
/// hidden emitters and a depth limit of 2.
#[test]
fn stream_equals_scalar_in_the_plastic_kernel_under_every_setting() {
    use groove::integrator::Strategy;
    use groove::sampler::SamplerKind;
    let path = |l: &Loaded| match &l.settings.integrator {
        IntegratorDesc::Path(p) => *p,
        _ => unreachable!("a path scene"),
    };
    let mut variants: Vec<(&str, Loaded)> = Vec::new();
    let mut l = plastic_scene(&[]);
    l.settings.sampler.kind = SamplerKind::Stratified { jitter: true };
    l.settings.sampler.sample_count = 4;
    variants.push(("stratified", l));
    for (label, edit) in [
        (
            "light only",
            (|p| p.strategy = Strategy::LightOnly) as fn(&mut PathSettings),
        ),
        ("bsdf only", |p| p.strategy = Strategy::BsdfOnly),
        ("rr_depth 1", |p| p.rr_depth = 1),
        ("hide_emitters", |p| p.hide_emitters = true),
        ("max_depth 2", |p| p.max_depth = 2),
    ] {
        let mut l = plastic_scene(&[]);
        let mut p = path(&l);
        edit(&mut p);
        l.settings.integrator = IntegratorDesc::Path(p);
        variants.push((label, l));
    }
    for (label, l) in &variants {
        let spp = l.settings.sampler.sample_count.min(4);
        let lanes = assert_identical(l, &format!("stream_plastic ({label})"), spp);
        assert!(lanes.kernel_lanes > 0, "{label}: the kernel never ran");
    }
}

/// Every ray kind traced as 8-wide packets (the default under tier A only) and camera packets
/// alone (the default under Embree) still give the scalar image.
#[test]
fn stream_with_every_packet_equals_scalar() {
    let all = Packets::ALL;
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
    let l = load(&test_scene("moment.xml"), "as_written");
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
    .expect("the stream renderer rendered a moment integrator");
    let msg = err.to_string();
    assert!(
        msg.contains("path and direct integrators only") && msg.contains("moment"),
        "{msg}"
    );
}

// ---- The conductor kernels (issue 18, step 2: `stream::kernels::conductor`) ----

/// The scenes where the 8-wide `roughconductor`/`conductor` kernels run give the scalar image at
/// 1, 2, 3 and 7 threads, and the kernels shaded paths in each (a silent fallback to the 1-lane
/// code cannot pass): the bench scenes' normal-mapped rough metals (classic), bare rough
/// (isotropic and anisotropic GGX) and smooth metals, normal maps with Mitsuba's default flags
/// (flipped normals, shadowing term), and `twosided` over and under `normalmap`, seen from the
/// back, with anisotropic Beckmann sampled without visible normals
/// (`tests/data/scenes/stream_conductors.xml`).
#[test]
fn stream_equals_scalar_where_the_conductor_kernels_run() {
    for (path, mode) in [
        (scene("scenes/bench/metal_plastic.xml"), "classic"),
        (scene("scenes/bench/strong.xml"), "classic"),
        (test_scene("mat_metals.xml"), "as_written"),
        (test_scene("nmap_plane.xml"), "as_written"),
        (test_scene("stream_conductors.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let lanes = assert_identical(&l, &format!("{name} ({mode})"), 3);
        assert!(
            lanes.conductor_lanes > 0,
            "{name}: no path went through the 8-wide conductor kernels"
        );
    }
}

/// `tests/data/scenes/NAME` under the settings that change what a vertex does: the stratified
/// sampler (4 spp), the light-only and BSDF-only strategies, Russian roulette from the first
/// bounce.
pub(super) fn settings_variants(name: &str) -> Vec<(&'static str, Loaded)> {
    variants_of(|| load(&test_scene(name), "as_written"))
}

/// The scene `base` makes under the settings of [`settings_variants`].
pub(super) fn variants_of(base: impl Fn() -> Loaded) -> Vec<(&'static str, Loaded)> {
    use groove::integrator::Strategy;
    use groove::sampler::SamplerKind;
    let mut variants: Vec<(&str, Loaded)> = Vec::new();
    let mut l = base();
    l.settings.sampler.kind = SamplerKind::Stratified { jitter: true };
    l.settings.sampler.sample_count = 4;
    variants.push(("stratified", l));
    for (label, edit) in [
        (
            "light only",
            (|p| p.strategy = Strategy::LightOnly) as fn(&mut PathSettings),
        ),
        ("bsdf only", |p| p.strategy = Strategy::BsdfOnly),
        ("rr_depth 1", |p| p.rr_depth = 1),
    ] {
        let mut l = base();
        let IntegratorDesc::Path(mut p) = l.settings.integrator else {
            unreachable!("a path scene")
        };
        edit(&mut p);
        l.settings.integrator = IntegratorDesc::Path(p);
        variants.push((label, l));
    }
    variants
}

/// The conductor kernels under the settings that change what a vertex does: the light-only and
/// BSDF-only strategies, Russian roulette from the first bounce, the stratified sampler.
#[test]
fn stream_equals_scalar_in_the_conductor_kernels_under_every_setting() {
    for (label, l) in &settings_variants("stream_conductors.xml") {
        let lanes = assert_identical(l, &format!("stream_conductors ({label})"), 4);
        assert!(lanes.conductor_lanes > 0, "{label}: the kernels never ran");
    }
}

/// On metal_plastic (classic) the two normal-mapped rough metals (floor and gold sphere) go
/// through the conductor kernels: most of the shaded paths, all but the plastic sphere's and the
/// runs' tails. Every kernel path there is the wrapper-chain driver's but the few that scatter
/// off the area light's own default `diffuse` (runs of 2–7 paths, which the `diffuse` kernel
/// takes as padded chunks: under 1 % of the shaded paths), and the scene's one area light is a
/// rectangle: the driver samples it in lanes (the shared gather of `kernels::light`), and
/// nothing else in lanes.
#[test]
fn the_lane_counters_count_the_conductor_kernels() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.conductor_lanes as f64 / c.shade_used as f64;
    eprintln!("metal_plastic (classic), 40×36 window, 3 spp: {c:?}, conductor share {share:.4}");
    assert!((0.5..=1.0).contains(&share), "{c:?}: {share}");
    assert!(driver_all_but_emitters(&c), "{c:?}");
    let [t, r, s, ..] = c.kernel_lights;
    assert!(r > 0 && t == 0 && s == 0, "{c:?}");
}

// ---- Plastic leaves under the wrapper chain (issue 18, render core step 2: `kernels::vertex`) ----

/// The scenes where the wrapper-chain driver shades a `plastic`/`roughplastic` leaf give the
/// scalar image at 1, 2, 3 and 7 threads: metal_plastic (classic: its sphere is `normalmap`
/// over `roughplastic`) and `tests/data/scenes/stream_plastics_wrapped.xml` (`normalmap` over
/// `roughplastic` and over `plastic`, `twosided` over `roughplastic`, `twosided` over and under
/// `normalmap`, seen from the back, Mitsuba's default normal-map flags). That scene has no
/// conductor, so its driver paths (`conductor_lanes`) are all wrapped plastics: a silent
/// fallback to the 1-lane code cannot pass (metal_plastic's share is checked in
/// `the_lane_counters_count_the_wrapped_plastic`).
#[test]
fn stream_equals_scalar_where_wrapped_plastics_run_in_lanes() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    assert_identical(&l, "metal_plastic (classic)", 3);
    let l = load(&test_scene("stream_plastics_wrapped.xml"), "as_written");
    let lanes = assert_identical(&l, "stream_plastics_wrapped", 3);
    assert!(lanes.conductor_lanes > 0, "never in lanes: {lanes:?}");
}

/// The wrapped plastics under the settings that change what a vertex does: the light-only and
/// BSDF-only strategies, Russian roulette from the first bounce, the stratified sampler.
#[test]
fn stream_equals_scalar_for_wrapped_plastics_under_every_setting() {
    assert_driver_under_every_setting("stream_plastics_wrapped");
}

/// On metal_plastic (classic) every material has a kernel now: the normal-mapped plastic sphere
/// goes through the wrapper-chain driver, and only the runs' tails (< 8 paths of each run) are
/// shaded lane by lane. Without the plastic sphere in lanes the share was 70.9 % (3,672 of
/// 5,182 shaded paths, `docs/bench/README.md`); with it, the tails alone (3 materials × ≤ 7
/// paths per run and bounce) leave it above 85 %.
#[test]
fn the_lane_counters_count_the_wrapped_plastic() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.kernel_lanes as f64 / c.shade_used as f64;
    eprintln!("metal_plastic (classic), 40×36 window, 3 spp: {c:?}, kernel share {share:.4}");
    assert!(driver_all_but_emitters(&c), "{c:?}");
    assert!((0.85..=1.0).contains(&share), "{c:?}: {share}");
}

/// Every scene of the repository that the path integrator renders, as written and (when it has
/// normal maps) in classic and walk modes; also the million-triangle scene when
/// `scenes/bench/make_million.py` has written its meshes, and the shared Cornell boxes
/// (`../shared/scenes/mitsuba_cbox/`) when they are beside the repository. Once a slow tier; it
/// takes about 4 s (96 pairs at small size), so it runs by default.
#[test]
fn stream_equals_scalar_on_every_path_scene() {
    let mut scenes = Vec::new();
    let million = scene("scenes/bench/million");
    let optional = [
        million.clone(),
        repo_root().join("../shared/scenes/mitsuba_cbox"),
    ];
    for dir in [
        "scenes/bench",
        "scenes/cornell",
        "scenes/diffuse_normalmap",
        "scenes/showcase",
    ]
    .map(scene)
    .into_iter()
    .chain([repo_root().join("tests/data/scenes")])
    .chain(optional.into_iter().filter(|d| {
        let here = d.is_dir() && (d != &million || d.join("million_terrain.ply").is_file());
        if !here {
            eprintln!("skipped: {} (not here)", d.display());
        }
        here
    })) {
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

// ---------------------------------------------------------------------------------------------
// Issue 18, step 2 (session 8, h1): the 8-wide PCG32 draws and the rectangle and sphere lights
// of the diffuse kernel.
// ---------------------------------------------------------------------------------------------

/// The diffuse kernel with rectangle and sphere area lights sampled in lanes (plain and flipped
/// rectangles, one with Mitsuba's non-unit-rotation shading normal, plain and flipped spheres;
/// `tests/data/scenes/stream_lights.xml`, and the older rectangle and sphere light scenes) and
/// its numbers drawn 8-wide: the scalar image at 1, 2, 3 and 7 threads, also under the
/// stratified sampler (whose first light sample is drawn lane by lane, the rest 8-wide), the
/// light-only and BSDF-only strategies and Russian roulette from the first bounce (its draw lane
/// by lane after the 8-wide ones).
#[test]
fn stream_equals_scalar_with_rectangle_and_sphere_lights_in_lanes() {
    use groove::integrator::Strategy;
    use groove::sampler::SamplerKind;
    let lights = || load(&test_scene("stream_lights.xml"), "as_written");
    let edit = |f: fn(&mut PathSettings)| {
        let mut l = lights();
        let IntegratorDesc::Path(mut p) = l.settings.integrator else {
            unreachable!("a path scene")
        };
        f(&mut p);
        l.settings.integrator = IntegratorDesc::Path(p);
        l
    };
    let mut stratified = lights();
    stratified.settings.sampler.kind = SamplerKind::Stratified { jitter: true };
    stratified.settings.sampler.sample_count = 4;
    let cases: Vec<(&str, Loaded, [bool; 2])> = vec![
        ("stream_lights", lights(), [true, true]),
        ("stream_lights (stratified)", stratified, [true, true]),
        (
            "stream_lights (light only)",
            edit(|p| p.strategy = Strategy::LightOnly),
            [true, true],
        ),
        (
            "stream_lights (bsdf only)",
            edit(|p| p.strategy = Strategy::BsdfOnly),
            [false, false],
        ),
        (
            "stream_lights (rr_depth 1)",
            edit(|p| p.rr_depth = 1),
            [true, true],
        ),
        (
            "mis_area",
            load(&test_scene("mis_area.xml"), "as_written"),
            [true, false],
        ),
        (
            "area_point",
            load(&test_scene("area_point.xml"), "as_written"),
            [false, true],
        ),
    ];
    for (label, l, [rect, sphere]) in &cases {
        let spp = l.settings.sampler.sample_count.min(3);
        let lanes = assert_identical(l, label, spp);
        assert!(lanes.kernel_lanes > 0, "{label}: the kernel never ran");
        let [_, r, s, ..] = lanes.kernel_lights;
        assert_eq!((r > 0, s > 0), (*rect, *sphere), "{label}: {lanes:?}");
    }
}

/// The lane counters see which lights the kernel sampled in lanes, so a silent fallback to the
/// scalar emitter code fails: the Cornell box's light is a mesh (triangles only). In
/// `stream_lights.xml` every emitter is a rectangle or a sphere of constant radiance, so every
/// kernel path that takes a light sample takes it in lanes, except where it stands on a sphere
/// light itself (the emitters' default diffuse BSDF) and picks that sphere (area sampling, lane
/// by lane): the two spheres cover a few per cent of the view, so at least 80 % of the kernel's
/// paths sample in lanes (none of them under the BSDF-only strategy, which takes no light
/// samples: `stream_equals_scalar_with_rectangle_and_sphere_lights_in_lanes`).
#[test]
fn the_lane_counters_count_the_lights_sampled_in_lanes() {
    let l = load(&scene("scenes/cornell/cbox-rgb.xml"), "as_written");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let [t, r, s, ..] = c.kernel_lights;
    assert!(t > 0 && r == 0 && s == 0, "{c:?}");
    assert!(t as f64 >= 0.8 * c.kernel_lanes as f64, "{c:?}");
    let l = load(&test_scene("stream_lights.xml"), "as_written");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let [t, r, s, ..] = c.kernel_lights;
    assert!(t == 0 && r > 0 && s > 0, "{c:?}");
    assert!((r + s) as f64 >= 0.8 * c.kernel_lanes as f64, "{c:?}");
}

// ---------------------------------------------------------------------------------------------
// Issues 17/18 (session 9, h4): the compensated microfacet normal map on the stream renderer
// (`stream::kernels::mnm`).
// ---------------------------------------------------------------------------------------------

/// metal_plastic and strong with `--normal-mapping compensated` (every normal map a
/// compensated microfacet normal map: over rough conductors, a rough plastic and, in strong,
/// a diffuse leaf) give the scalar image at 1, 2, 3 and 7 threads, and the compensated kernel
/// shaded paths in each (a silent fallback to the 1-lane code cannot pass).
#[test]
fn stream_equals_scalar_where_the_compensated_kernel_runs() {
    for name in ["metal_plastic", "strong"] {
        let l = load(&scene(&format!("scenes/bench/{name}.xml")), "compensated");
        let lanes = assert_identical(&l, &format!("{name} (compensated)"), 3);
        assert!(
            lanes.mnm_lanes > 0,
            "{name}: never in the kernel: {lanes:?}"
        );
    }
}

/// The compensated kernel under the settings that change what a vertex does: the light-only
/// and BSDF-only strategies (no light sample: the kernel's step 3 skipped), Russian roulette
/// from the first bounce, the stratified sampler; on metal_plastic, whose three materials are
/// all compensated normal maps in this mode.
#[test]
fn stream_equals_scalar_in_the_compensated_kernel_under_every_setting() {
    let variants = variants_of(|| load(&scene("scenes/bench/metal_plastic.xml"), "compensated"));
    for (label, l) in &variants {
        let spp = l.settings.sampler.sample_count.min(4);
        let lanes = assert_identical(l, &format!("metal_plastic compensated ({label})"), spp);
        assert!(lanes.mnm_lanes > 0, "{label}: the kernel never ran");
    }
}

/// The microfacet normal map kernel over the other models without a table (issue 18,
/// thirty-ninth session): the random walk (`walk-same`, `walk-mirror`) and the closed form
/// (`explicit`) on metal_plastic and strong, and the two-sided walk over glass's rough
/// dielectric (`walk-same`), give the scalar image at 1, 2, 3 and 7 threads,
/// with the kernel's build, light and ray steps in lanes and the BSDF's eval and sample lane by
/// lane (the walks draw from each path's stream between the light's numbers and the sample's,
/// as in `PathState::scatter`); the kernel shaded paths in each (a silent fallback to the
/// 1-lane code cannot pass).
#[test]
fn stream_equals_scalar_where_the_mnm_kernel_runs_the_walks_and_closed_forms() {
    for name in ["metal_plastic", "strong"] {
        for mode in ["walk-same", "walk-mirror", "explicit"] {
            let l = load(&scene(&format!("scenes/bench/{name}.xml")), mode);
            let lanes = assert_identical(&l, &format!("{name} ({mode})"), 3);
            assert!(
                lanes.mnm_lanes > 0,
                "{name} ({mode}): never in the kernel: {lanes:?}"
            );
        }
    }
    let l = load(&scene("scenes/bench/glass.xml"), "walk-same");
    let lanes = assert_identical(&l, "glass (walk-same)", 3);
    assert!(lanes.mnm_lanes > 0, "glass: never in the kernel: {lanes:?}");
}

/// The kernel's random walks under the settings that change what a vertex does (the
/// light-only and BSDF-only strategies, Russian roulette from the first bounce, the
/// stratified sampler), on metal_plastic with `walk-same`.
#[test]
fn stream_equals_scalar_in_the_mnm_kernel_walks_under_every_setting() {
    let variants = variants_of(|| load(&scene("scenes/bench/metal_plastic.xml"), "walk-same"));
    for (label, l) in &variants {
        let spp = l.settings.sampler.sample_count.min(4);
        let lanes = assert_identical(l, &format!("metal_plastic walk-same ({label})"), spp);
        assert!(lanes.mnm_lanes > 0, "{label}: the kernel never ran");
    }
}

/// On metal_plastic (compensated) the three normal-mapped materials are compensated normal
/// maps (the light's own diffuse BSDF, a few paths, goes to the diffuse kernel), so no path
/// goes to the wrapper-chain driver, and a run of one material at one bounce leaves to the
/// 1-lane code only a last path alone (its last 2–7 paths are one padded chunk,
/// `kernels::vertex::x8::PAD_MIN`, since the thirty-first session): at least 98 % of the
/// shaded paths in the compensated kernel; its one area light is a rectangle, sampled in
/// lanes.
#[test]
fn the_lane_counters_count_the_compensated_kernel() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "compensated");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.mnm_lanes as f64 / c.shade_used as f64;
    eprintln!("metal_plastic (compensated), 40×36 window, 3 spp: {c:?}, share {share:.4}");
    assert_eq!(c.conductor_lanes, 0, "{c:?}");
    assert!((0.98..=1.0).contains(&share), "{c:?}: {share}");
    let [t, r, s, ..] = c.kernel_lights;
    assert!(r > 0 && t == 0 && s == 0, "{c:?}");
}

// ---------------------------------------------------------------------------------------------
// Issue 18 (session 9, h3): every emitter kind in lanes (`stream::kernels::emitters`) and the
// `direct` integrator on the stream.
// ---------------------------------------------------------------------------------------------

/// `LaneCounters::kernel_lights` by name: triangle meshes, rectangles, spheres, point, spot,
/// directional, constant, envmap.
const LIGHT_KINDS: [&str; 8] = [
    "triangles",
    "rectangle",
    "sphere",
    "point",
    "spot",
    "directional",
    "constant",
    "envmap",
];

/// The kinds a render sampled in lanes.
pub(super) fn kinds_in_lanes(lanes: &groove::stream::LaneCounters) -> Vec<&'static str> {
    LIGHT_KINDS
        .iter()
        .zip(lanes.kernel_lights)
        .filter(|(_, n)| *n > 0)
        .map(|(k, _)| *k)
        .collect()
}

/// Point, spot (scaled frame; a textured spot beside it, lane by lane), directional, constant
/// and rectangle lights (`stream_emitters.xml`), and an environment map with a point light
/// (`stream_emitters_env.xml`), over `diffuse`, a rough conductor and a twosided rough plastic
/// (the wrapper-chain driver) and a bare rough plastic (the plastic kernel): the scalar image
/// at 1, 2, 3 and 7 threads, as written and under the stratified sampler, the light-only and
/// BSDF-only strategies and Russian roulette from the first bounce; the three kernels ran, and
/// the counters saw each kind sampled in lanes (none under BSDF-only, which takes no light
/// samples), so a silent fallback to the scalar emitters fails.
#[test]
fn stream_equals_scalar_with_every_emitter_kind_in_lanes() {
    for (name, kinds) in [
        (
            "stream_emitters.xml",
            &["rectangle", "point", "spot", "directional", "constant"][..],
        ),
        ("stream_emitters_env.xml", &["point", "envmap"][..]),
    ] {
        let mut cases = vec![("as written", load(&test_scene(name), "as_written"))];
        cases.extend(settings_variants(name));
        for (label, l) in &cases {
            let spp = l.settings.sampler.sample_count.min(3);
            let lanes = assert_identical(l, &format!("{name} ({label})"), spp);
            assert!(
                lanes.conductor_lanes > 0 && lanes.kernel_lanes > lanes.conductor_lanes,
                "{name} ({label}): {lanes:?}"
            );
            let want: &[&str] = if *label == "bsdf only" { &[] } else { kinds };
            assert_eq!(kinds_in_lanes(&lanes), want, "{name} ({label}): {lanes:?}");
        }
    }
}

/// `scene` with its integrator replaced by `direct` (`emitter_samples`, `bsdf_samples`,
/// `hide_emitters`).
pub(super) fn as_direct(mut l: Loaded, es: u32, bs: u32, hide: bool) -> Loaded {
    l.settings.integrator = IntegratorDesc::Direct(groove::integrator::DirectSettings {
        emitter_samples: es,
        bsdf_samples: bs,
        hide_emitters: hide,
    });
    l
}

/// The `direct` integrator on the stream renderer (`stream::direct`) gives the scalar image,
/// ray counts and dropped samples at 1, 2, 3 and 7 threads: `direct_delta.xml` as written (4
/// emitter samples, delta lights: Mitsuba's weighting), and with the integrator swapped to
/// `direct` the emitter scenes (every emitter kind, the three kernels' materials), the Cornell
/// box, glass (delta lobes: no MIS), an environment map, under several sample counts (none of
/// one kind included) and `hide_emitters`.
#[test]
fn stream_equals_scalar_with_the_direct_integrator() {
    let l = load(&test_scene("direct_delta.xml"), "as_written");
    assert!(matches!(l.settings.integrator, IntegratorDesc::Direct(_)));
    assert_identical(&l, "direct_delta.xml", 3);
    let emitters = || load(&test_scene("stream_emitters.xml"), "as_written");
    let cases = [
        ("stream_emitters (1, 1)", as_direct(emitters(), 1, 1, false)),
        ("stream_emitters (3, 2)", as_direct(emitters(), 3, 2, false)),
        ("stream_emitters (0, 2)", as_direct(emitters(), 0, 2, false)),
        (
            "stream_emitters (2, 0, hidden)",
            as_direct(emitters(), 2, 0, true),
        ),
        (
            "stream_emitters_env (1, 1)",
            as_direct(
                load(&test_scene("stream_emitters_env.xml"), "as_written"),
                1,
                1,
                false,
            ),
        ),
        (
            "cbox-rgb (1, 1)",
            as_direct(
                load(&scene("scenes/cornell/cbox-rgb.xml"), "as_written"),
                1,
                1,
                false,
            ),
        ),
        (
            "mat_glass (2, 1)",
            as_direct(
                load(&test_scene("mat_glass.xml"), "as_written"),
                2,
                1,
                false,
            ),
        ),
        (
            "light_envmap (1, 3)",
            as_direct(
                load(&test_scene("light_envmap.xml"), "as_written"),
                1,
                3,
                false,
            ),
        ),
    ];
    for (label, l) in &cases {
        let lanes = assert_identical(l, label, 3);
        assert!(lanes.shade_used > 0, "{label}: nothing shaded");
    }
}

// ---------------------------------------------------------------------------------------------
// Rays as Embree streams (issue 18, rays, camera, sampler and film; ninth session)

/// Bounce and shadow rays handed to Embree as one stream per stage (`rtcIntersect1M` /
/// `rtcOccluded1M`, `Packets::stream`) give the scalar image: the Cornell box and the other
/// mesh scenes (an instanced group, a textured mesh), an envmap scene with analytic shapes
/// under Embree, and metal_plastic (tier A, which traces the streams as its own 8-wide
/// packets), at 1, 2 and 7 threads.
#[test]
fn stream_with_embree_ray_streams_equals_scalar() {
    let streams = Packets {
        stream: true,
        ..Packets::ALL
    };
    for (path, mode) in [
        (scene("scenes/cornell/cbox-rgb.xml"), "as_written"),
        (test_scene("shape_instance.xml"), "as_written"),
        (test_scene("light_envmap.xml"), "as_written"),
        (scene("scenes/bench/metal_plastic.xml"), "classic"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let scalar = render(&l, Renderer::Scalar, 1, 3);
        for t in [1, 2, 7] {
            let stream = render_seeded(&l, Renderer::Stream, t, 3, 7, streams);
            assert!(
                stream == scalar,
                "{name} ({mode}): differs at {t} threads with Embree streams"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// ---- Diffuse leaves under the wrapper chain (issue 18, ninth session: `kernels::vertex`) ----

/// The scenes where the wrapper-chain driver shades a `diffuse` leaf give the scalar image at
/// 1, 2, 3 and 7 threads: strong (classic: its sphere is `normalmap` over `diffuse`) and
/// `tests/data/scenes/stream_diffuse_wrapped.xml` (`normalmap` over a bitmap, a checkerboard and
/// a constant reflectance, `twosided` over and under `normalmap`, seen from the back, a
/// `twosided` card seen from both sides). That scene has no conductor and no plastic, so its
/// driver paths (`conductor_lanes`) are all wrapped diffuse leaves: a silent fallback to the
/// 1-lane code cannot pass.
#[test]
fn stream_equals_scalar_where_wrapped_diffuse_runs_in_lanes() {
    let l = load(&scene("scenes/bench/strong.xml"), "classic");
    assert_identical(&l, "strong (classic)", 3);
    let l = load(&test_scene("stream_diffuse_wrapped.xml"), "as_written");
    let lanes = assert_identical(&l, "stream_diffuse_wrapped", 3);
    let share = lanes.conductor_lanes as f64 / lanes.shade_used as f64;
    eprintln!("stream_diffuse_wrapped, 3 spp: {lanes:?}, driver share {share:.4}");
    assert!(share > 0.5, "too little in lanes: {lanes:?}");
}

/// The wrapped diffuse leaves under the settings that change what a vertex does: the light-only
/// and BSDF-only strategies, Russian roulette from the first bounce, the stratified sampler.
#[test]
fn stream_equals_scalar_for_wrapped_diffuse_under_every_setting() {
    assert_driver_under_every_setting("stream_diffuse_wrapped");
}

/// On strong (classic) the diffuse sphere, `normalmap` over `diffuse`, now goes through the
/// driver, as its floor (`normalmap` over `roughplastic`) and metal sphere already did
/// (measured: 5,064 of 5,390 shaded paths, 94.0 %).
#[test]
fn the_lane_counters_count_the_wrapped_diffuse() {
    let l = load(&scene("scenes/bench/strong.xml"), "classic");
    let c = render(&l, Renderer::Stream, 1, 3).lanes;
    let share = c.conductor_lanes as f64 / c.shade_used as f64;
    eprintln!("strong (classic), 40×36 window, 3 spp: {c:?}, driver share {share:.4}");
    // Every material is wrapped now: all kernel paths are the driver's (but the area light's
    // own `diffuse`), and only a run's last path alone is shaded lane by lane.
    assert!(driver_all_but_emitters(&c), "{c:?}");
    assert!((0.85..=1.0).contains(&share), "{c:?}: {share}");
}

// ---- Dielectric leaves in the wrapper chain (issue 18, ninth session: `kernels::vertex`) ----

/// The scenes where the wrapper-chain driver shades a `dielectric`, `roughdielectric` or
/// `thindielectric` leaf give the scalar image at 1, 2, 3 and 7 threads: glass (classic: its
/// sphere and cube are `normalmap` over `roughdielectric`), `mat_glass.xml` and
/// `tests/data/scenes/stream_dielectrics.xml` (the three kinds bare, `normalmap` over
/// `roughdielectric`, `twosided` over that, an index below the outside's, crossed from outside
/// and inside). That scene's only other material is its bare diffuse floor (the diffuse
/// kernel's), so its driver paths (`conductor_lanes`) are all dielectrics: a silent fallback to
/// the 1-lane code cannot pass.
#[test]
fn stream_equals_scalar_where_dielectrics_run_in_lanes() {
    for (path, mode) in [
        (scene("scenes/bench/glass.xml"), "classic"),
        (test_scene("mat_glass.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let lanes = assert_identical(&l, &format!("{name} ({mode})"), 3);
        assert!(
            lanes.conductor_lanes > 0,
            "{name}: never in lanes: {lanes:?}"
        );
    }
    let l = load(&test_scene("stream_dielectrics.xml"), "as_written");
    let lanes = assert_identical(&l, "stream_dielectrics", 3);
    let share = lanes.conductor_lanes as f64 / lanes.shade_used as f64;
    eprintln!("stream_dielectrics, 3 spp: {lanes:?}, driver share {share:.4}");
    assert!(share > 0.3, "too little in lanes: {lanes:?}");
}

/// `name` (a scene in `tests/data/scenes`, without `.xml`) under the settings that change what a
/// vertex does ([`settings_variants`]): the scalar image at 1, 2, 3 and 7 threads in each, with
/// the wrapper-chain driver running.
fn assert_driver_under_every_setting(name: &str) {
    for (label, l) in &settings_variants(&format!("{name}.xml")) {
        let lanes = assert_identical(l, &format!("{name} ({label})"), 4);
        assert!(lanes.conductor_lanes > 0, "{label}: never in lanes");
    }
}

/// The dielectric leaves under the settings that change what a vertex does: the light-only and
/// BSDF-only strategies, Russian roulette from the first bounce (where η² enters the survival
/// probability), the stratified sampler.
#[test]
fn stream_equals_scalar_for_dielectrics_under_every_setting() {
    assert_driver_under_every_setting("stream_dielectrics");
}

// ---------------------------------------------------------------------------------------------
// Issue 18, surface interaction in lanes (session 10, h1): the gather stage reconstructs hits on
// triangle meshes, similarity spheres and rectangles 8 at a time
// (`src/geometry/surface_lanes.rs`, `src/stream/kernels/surface.rs`); the lane forms equal
// `Shape::interaction` bit for bit in the unit tests `geometry::surface_lanes::tests`.
// ---------------------------------------------------------------------------------------------

/// Every shape kind the gather stage meets (`tests/data/scenes/stream_surfaces.xml`: meshes with
/// and without normals and uvs, flipped, face-normal and cube meshes; plain, flipped, mirrored
/// and non-uniformly scaled spheres; plain, flipped and non-unit-rotated rectangles; a disk and a
/// cylinder), instances (`shape_instance.xml`) and the Cornell box's meshes give the scalar image
/// at 1, 2, 3 and 7 threads, with hits reconstructed in lanes in each (so a silent fallback to
/// `Scene::interaction` cannot pass).
#[test]
fn stream_equals_scalar_with_surfaces_in_lanes() {
    for (path, mode) in [
        (test_scene("stream_surfaces.xml"), "as_written"),
        (test_scene("shape_instance.xml"), "as_written"),
        (test_scene("cbox_v3.xml"), "as_written"),
    ] {
        let l = load(&path, mode);
        let name = path.file_name().unwrap().to_string_lossy();
        let lanes = assert_identical(&l, &format!("{name} ({mode})"), 3);
        assert!(
            lanes.surface_lanes > 0,
            "{name}: no surface reconstructed in lanes: {lanes:?}"
        );
    }
}

// ---- Textured leaves and bumpmap in the wrapper chain (issue 18, tenth session, h5) ----

/// Renders `name` at 3 spp through [`assert_identical`] (1, 2, 3 and 7 threads) and checks that
/// the wrapper-chain driver shaded at least 85 % of its shaded paths (every material of the
/// scene but the emitters' default `diffuse` is the driver's: only the runs' tails, ≤ 7 paths
/// per material, run and bounce, are shaded lane by lane), so a silent fallback to the 1-lane
/// code fails.
fn assert_in_the_driver(name: &str) {
    let l = load(&test_scene(name), "as_written");
    let lanes = assert_identical(&l, name, 3);
    let share = lanes.conductor_lanes as f64 / lanes.shade_used as f64;
    eprintln!("{name}, 3 spp: {lanes:?}, driver share {share:.4}");
    assert!(share >= 0.85, "too little in lanes: {lanes:?}");
}

/// Textured leaf parameters (`tests/data/scenes/stream_textured_leaves.xml`): a bitmap `alpha`
/// and `specular_reflectance` on a rough conductor, a textured `alpha_u` (anisotropic), a
/// textured smooth conductor, dielectric and thin dielectric, a twosided rough plastic and a
/// normal-mapped plastic with textured reflectances: the scalar image at 1, 2, 3 and 7 threads,
/// with ≥ 85 % of the shaded paths in the driver.
#[test]
fn stream_equals_scalar_where_textured_leaves_run_in_lanes() {
    assert_in_the_driver("stream_textured_leaves.xml");
}

/// The textured leaves under the settings that change what a vertex does: the light-only and
/// BSDF-only strategies, Russian roulette from the first bounce, the stratified sampler.
#[test]
fn stream_equals_scalar_for_textured_leaves_under_every_setting() {
    assert_driver_under_every_setting("stream_textured_leaves");
}

/// `bumpmap` as a wrapper (`tests/data/scenes/stream_bumpmap.xml`: over diffuse, a rough
/// conductor, a rough dielectric, under and over `twosided`, both flags off on the floor): the
/// scalar image at 1, 2, 3 and 7 threads, with ≥ 85 % of the shaded paths in the driver; and
/// `mat_bumpmap.xml` (a Mitsuba-reference scene).
#[test]
fn stream_equals_scalar_where_bumpmaps_run_in_lanes() {
    assert_in_the_driver("stream_bumpmap.xml");
    let l = load(&test_scene("mat_bumpmap.xml"), "as_written");
    let lanes = assert_identical(&l, "mat_bumpmap", 2);
    assert!(lanes.conductor_lanes > 0, "mat_bumpmap: never in lanes");
}

/// The bump maps under the settings that change what a vertex does.
#[test]
fn stream_equals_scalar_for_bumpmaps_under_every_setting() {
    assert_driver_under_every_setting("stream_bumpmap");
}

/// `mask` as a wrapper (`tests/data/scenes/stream_mask.xml`: bitmap, checkerboard and constant
/// opacities of 0, 1 and between, over `twosided`, a normal map, a rough conductor with a
/// textured roughness and a dielectric, and under `twosided`): its choice and the nested BSDF's
/// numbers drawn lane by lane in the scalar order, the pass-through continuing the path; the
/// scalar image at 1, 2, 3 and 7 threads with ≥ 85 % of the shaded paths in the driver; and
/// `mat_mask.xml` (a Mitsuba-reference scene with a `null` sphere, shaded lane by lane).
#[test]
fn stream_equals_scalar_where_masks_run_in_lanes() {
    assert_in_the_driver("stream_mask.xml");
    let l = load(&test_scene("mat_mask.xml"), "as_written");
    let lanes = assert_identical(&l, "mat_mask", 2);
    assert!(lanes.conductor_lanes > 0, "mat_mask: never in lanes");
}

/// The masks under the settings that change what a vertex does.
#[test]
fn stream_equals_scalar_for_masks_under_every_setting() {
    assert_driver_under_every_setting("stream_mask");
}

// ---- Disks and instanced meshes in lanes (issue 18, eleventh session, h2) ----

/// Scenes whose every surface hit is a disk (`tests/data/scenes/stream_disks.xml`) or a mesh
/// seen through an instance (`stream_instances.xml`): the scalar image at 1, 2, 3 and 7 threads,
/// with hits reconstructed in lanes in each (nothing else in them has a lane form, so a silent
/// fallback of either kind to `Scene::interaction` fails).
#[test]
fn stream_equals_scalar_with_disks_and_instances_in_lanes() {
    for name in ["stream_disks.xml", "stream_instances.xml"] {
        let l = load(&test_scene(name), "as_written");
        let lanes = assert_identical(&l, name, 2);
        assert!(
            lanes.surface_lanes > 0,
            "{name}: no surface reconstructed in lanes: {lanes:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Issue 18 (session 11, h3): the render loop around the kernels in lanes: the emission stage
// (`stream::emission`).
// ---------------------------------------------------------------------------------------------

/// The emission stage in lanes (constant environment lights for escaped rays, area lights of
/// constant radiance on meshes and rectangles; spheres and textured lights lane by lane): the
/// scalar image at 1, 2, 3 and 7 threads on the Cornell box (a mesh light seen directly and by
/// BSDF samples), `stream_lights.xml` (rectangle lights, a flipped one, sphere lights),
/// `stream_emitters.xml` (a constant environment, a rectangle light, delta lights) and metal_plastic (a constant environment and a
/// rectangle light), each under the settings that change the weight (light-only and BSDF-only
/// strategies, hidden emitters, max_depth 1 and 2); and the stage computed paths in lanes in
/// each but max_depth 1 (a silent fallback to `add_emission` cannot pass).
#[test]
fn stream_equals_scalar_where_emission_runs_in_lanes() {
    use groove::integrator::Strategy;
    for name in [
        scene("scenes/cornell/cbox-rgb.xml"),
        test_scene("stream_lights.xml"),
        test_scene("stream_emitters.xml"),
        scene("scenes/bench/metal_plastic.xml"),
    ] {
        let label = name.display().to_string();
        type Edit = (&'static str, fn(&mut PathSettings));
        let edits: [Edit; 6] = [
            ("as written", |_| {}),
            ("light only", |p| p.strategy = Strategy::LightOnly),
            ("bsdf only", |p| p.strategy = Strategy::BsdfOnly),
            ("hidden emitters", |p| p.hide_emitters = true),
            ("max_depth 1", |p| p.max_depth = 1),
            ("max_depth 2", |p| p.max_depth = 2),
        ];
        for (what, edit) in edits {
            let mut l = load(&name, "as_written");
            let IntegratorDesc::Path(mut p) = l.settings.integrator else {
                unreachable!("a path scene")
            };
            edit(&mut p);
            l.settings.integrator = IntegratorDesc::Path(p);
            let lanes = assert_identical(&l, &format!("{label}, {what}"), 2);
            // At max_depth 1 only camera rays see emitters, and the Cornell box's centre
            // window sees none.
            assert!(
                lanes.emission_lanes > 0 || what == "max_depth 1",
                "{label}, {what}: no emission in lanes: {lanes:?}"
            );
        }
    }
}

// ---- The driver's materials (issue 18, eleventh session, h4) ----

/// A `roughdielectric` with textured parameters (`tests/data/scenes/stream_rough_glass_textured.xml`:
/// bitmap `alpha`, `alpha_u` and `alpha_v`, a checkerboard `alpha`, textured reflectance and
/// transmittance; GGX and Beckmann, visible-normal sampling on and off; bare, under `twosided`
/// with an index below the outside's, under a normal map) runs in the driver: the scalar image
/// at 1, 2, 3 and 7 threads, with ≥ 85 % of the shaded paths in the driver.
#[test]
fn stream_equals_scalar_where_textured_rough_glass_runs_in_lanes() {
    assert_in_the_driver("stream_rough_glass_textured.xml");
}

/// The textured rough dielectrics under the settings that change what a vertex does: the
/// light-only and BSDF-only strategies, Russian roulette from the first bounce, the stratified
/// sampler.
#[test]
fn stream_equals_scalar_for_textured_rough_glass_under_every_setting() {
    assert_driver_under_every_setting("stream_rough_glass_textured");
}

// ---------------------------------------------------------------------------------------------
// `direct` through the kernels (issue 18, eleventh session)
// ---------------------------------------------------------------------------------------------

/// `tests/data/scenes/NAME` with `-D` values.
fn load_defined(name: &str, defines: &[(&str, &str)]) -> Loaded {
    let opts = LoadOptions {
        defines: defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..Default::default()
    };
    let path = test_scene(name);
    groove::load::load_scene(&path, &opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The `direct` integrator with one light and one BSDF sample per hit takes its samples in the
/// 8-wide kernels (`stream::direct`'s tail) and gives the scalar image at 1, 2, 3 and 7 threads:
/// `direct_delta.xml` with `es = 1` (a point and a rectangle light over `diffuse` and a bare
/// rough plastic), `stream_emitters.xml` as `direct` (every kernel family, every emitter kind
/// the kernels sample in lanes) and the Cornell box as `direct` (mesh lights). The counters show
/// the kernels shaded (the wrapper-chain driver and another kernel on the emitter scene; most
/// of the Cornell box's hits) and the lights went through the lane forms, so a silent fallback
/// to the 1-lane code fails; with 3 emitter samples the kernels stand aside (lane by lane).
#[test]
fn the_direct_integrator_runs_in_the_kernels() {
    let l = load_defined("direct_delta.xml", &[("es", "1")]);
    let lanes = assert_identical(&l, "direct_delta.xml (es = 1)", 3);
    assert!(lanes.kernel_lanes > 0, "direct_delta: {lanes:?}");
    assert_eq!(kinds_in_lanes(&lanes), ["rectangle", "point"], "{lanes:?}");

    let emitters = || load(&test_scene("stream_emitters.xml"), "as_written");
    let lanes = assert_identical(&as_direct(emitters(), 1, 1, false), "emitters (1, 1)", 3);
    assert!(
        lanes.conductor_lanes > 0 && lanes.kernel_lanes > lanes.conductor_lanes,
        "emitters (1, 1): {lanes:?}"
    );
    let kinds = ["rectangle", "point", "spot", "directional", "constant"];
    assert_eq!(kinds_in_lanes(&lanes), kinds, "{lanes:?}");
    let lanes = assert_identical(&as_direct(emitters(), 3, 1, false), "emitters (3, 1)", 3);
    assert_eq!(lanes.kernel_lanes, 0, "emitters (3, 1): {lanes:?}");

    let cbox = load(&scene("scenes/cornell/cbox-rgb.xml"), "as_written");
    let lanes = assert_identical(&as_direct(cbox, 1, 1, false), "cbox-rgb (1, 1)", 3);
    assert!(
        lanes.kernel_lanes * 10 >= lanes.shade_used * 8,
        "cbox-rgb (1, 1): {lanes:?}"
    );
    assert_eq!(kinds_in_lanes(&lanes), ["triangles"], "{lanes:?}");
}

// ---------------------------------------------------------------------------------------------
// Textured area and spot lights in lanes (issue 18, eleventh session)
// ---------------------------------------------------------------------------------------------

/// Textured lights sampled in lanes (`stream_textured_lights.xml`: bitmap radiances on a
/// rectangle, a cube mesh, a panel with irregular uvs and an octahedron without uvs, a
/// checkerboard radiance, two spot lights projecting different
/// bitmaps, a textured sphere light lane by lane) give the scalar image at 1, 2, 3 and 7
/// threads, under `path` as written and under the settings that change a vertex, and under
/// `direct` (one sample of each kind: the kernels); the counters show triangles, rectangles
/// and spots sampled in lanes (the scene has no untextured light of those kinds, so a silent
/// fallback to the scalar emitters fails) and no sphere (its textured light stays lane by lane).
#[test]
fn stream_equals_scalar_with_textured_lights_in_lanes() {
    let name = "stream_textured_lights.xml";
    let base = || load(&test_scene(name), "as_written");
    let mut cases = vec![("as written", base())];
    cases.extend(settings_variants(name));
    cases.push(("direct (1, 1)", as_direct(base(), 1, 1, false)));
    for (label, l) in &cases {
        let lanes = assert_identical(l, &format!("{name} ({label})"), 3);
        assert!(
            lanes.conductor_lanes > 0 && lanes.kernel_lanes > lanes.conductor_lanes,
            "{name} ({label}): {lanes:?}"
        );
        let want: &[&str] = if *label == "bsdf only" {
            &[]
        } else {
            &["triangles", "rectangle", "spot"]
        };
        assert_eq!(kinds_in_lanes(&lanes), want, "{name} ({label}): {lanes:?}");
    }
}
