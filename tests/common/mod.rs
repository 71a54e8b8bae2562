//! Shared helpers for groove's integration tests (each test file does `mod common;`).
#![allow(dead_code, unused_imports)]

pub mod chi2;
pub mod imgcmp;
pub mod scratch;

pub use scratch::{Scratch, ScratchFile};

pub use imgcmp::{
    compare, mean_and_var_of_mean, read_exr_rgb, write_exr_rgb, Comparison, RgbImage,
};

use std::path::{Path, PathBuf};

/// The repository root (where Cargo.toml is).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `tests/refs/NAME.exr` and `tests/refs/NAME.var.exr`, read as (mean, variance of the mean).
pub fn load_reference(name: &str) -> (RgbImage, RgbImage) {
    let dir = repo_root().join("tests").join("refs");
    (
        read_exr_rgb(&dir.join(format!("{name}.exr"))),
        read_exr_rgb(&dir.join(format!("{name}.var.exr"))),
    )
}

/// `tests/data/scenes/NAME`.
pub fn test_scene(name: &str) -> PathBuf {
    repo_root()
        .join("tests")
        .join("data")
        .join("scenes")
        .join(name)
}

/// The shared Cornell box scene (`../shared/scenes/mitsuba_cbox/cbox-rgb.xml` from the repo root).
pub fn shared_cbox() -> PathBuf {
    repo_root()
        .join("..")
        .join("shared")
        .join("scenes")
        .join("mitsuba_cbox")
        .join("cbox-rgb.xml")
}

/// Mitsuba's regression scenes with media (`mitsuba-data/tests/scenes/participating_media`):
/// under `$MITSUBA_DATA` when set, else `../survey/mitsuba-data` beside the repository; `None`
/// (the tests that use them skip) when absent.
pub fn mitsuba_media_scenes() -> Option<PathBuf> {
    let root = std::env::var_os("MITSUBA_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo_root().join("..").join("survey/mitsuba-data"));
    let dir = root.join("tests/scenes/participating_media");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipped: {} is not here (set MITSUBA_DATA)", dir.display());
        None
    }
}

pub fn exists(p: &Path) -> bool {
    p.is_file()
}

/// A rendered image with its per-pixel variance of the mean, as test images.
pub struct Rendered {
    pub mean: RgbImage,
    pub var: RgbImage,
    pub stats: groove::render::RenderStats,
}

fn to_rgb(img: &groove::film::Image) -> RgbImage {
    let mut out = RgbImage::new(img.width as usize, img.height as usize);
    for (o, p) in out.data.iter_mut().zip(&img.data) {
        *o = [p[0] as f64, p[1] as f64, p[2] as f64];
    }
    out
}

/// Load `scene` with `-D` values and render it in-process.
pub fn render_scene(
    scene: &Path,
    defines: &[(&str, &str)],
    spp: u32,
    seed: u64,
    threads: usize,
    tweak: impl FnOnce(&mut groove::load::Loaded),
) -> Rendered {
    let opts = groove::load::options::LoadOptions {
        defines: defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..Default::default()
    };
    let mut loaded = groove::load::load_scene(scene, &opts)
        .unwrap_or_else(|e| panic!("loading {}: {e}", scene.display()));
    tweak(&mut loaded);
    render_loaded(&loaded, spp, seed, threads)
}

/// The render loop of the render tests: `$GROOVE_TEST_RENDERER` (`auto`, `scalar` or `stream`),
/// default `auto` (the stream renderer where it runs the scene's integrator, as `groove render`
/// does). `stream` makes the tests of other integrators fail with the stream renderer's refusal;
/// `scalar` runs every test on the scalar renderer.
pub fn renderer() -> groove::render::Renderer {
    match std::env::var("GROOVE_TEST_RENDERER") {
        Err(_) => groove::render::Renderer::Auto,
        Ok(s) => groove::render::Renderer::parse(&s).unwrap_or_else(|| {
            panic!(
                "GROOVE_TEST_RENDERER={s}: expected one of {}",
                groove::render::Renderer::NAMES.join(", ")
            )
        }),
    }
}

/// Render a loaded scene at `spp` with `seed` on `threads` workers (0: all cores), on the render
/// loop [`renderer`] says.
pub fn render_loaded(
    loaded: &groove::load::Loaded,
    spp: u32,
    seed: u64,
    threads: usize,
) -> Rendered {
    let ro = groove::render::RenderOptions {
        threads,
        spp: Some(spp),
        seed: Some(seed),
        renderer: renderer(),
        ..Default::default()
    };
    let out = groove::render::render(&loaded.scene, &loaded.settings, &ro).expect("render");
    Rendered {
        mean: to_rgb(&out.film.develop()),
        var: to_rgb(&out.film.develop_variance().expect("second moments")),
        stats: out.stats,
    }
}

/// Like [`render_scene`], for a variant of the scene file `scene`: its text passed through `edit`
/// and loaded as if it were that file (relative asset paths resolve as for the original). The
/// sensitivity tests make their variants this way, through the loader, not by editing a loaded
/// scene.
pub fn render_scene_edited(
    scene: &Path,
    edit: impl FnOnce(String) -> String,
    spp: u32,
    seed: u64,
) -> Rendered {
    let text = std::fs::read_to_string(scene).expect("scene text");
    let edited = edit(text.clone());
    assert_ne!(edited, text, "the edit changed nothing");
    let doc = groove::scene::xml::parse::load_str(&edited, scene, &[])
        .unwrap_or_else(|e| panic!("parsing the edited {}: {e}", scene.display()));
    let loaded = groove::load::instantiate(&doc, scene)
        .unwrap_or_else(|e| panic!("loading the edited {}: {e}", scene.display()));
    render_loaded(&loaded, spp, seed, 0)
}

/// Mean over the whole image with its standard error (grey images: channel 0).
pub fn image_mean(r: &Rendered) -> (f64, f64) {
    let n = r.mean.data.len() as f64;
    let m = r.mean.data.iter().map(|p| p[0]).sum::<f64>() / n;
    let v = r.var.data.iter().map(|p| p[0]).sum::<f64>() / (n * n);
    (m, v.sqrt())
}

/// A unit direction from polar angle θ and azimuth φ in degrees (z up).
pub fn dir(theta_deg: f32, phi_deg: f32) -> glam::Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    glam::Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Mean of `n` draws of `f` and its standard error.
pub fn mean_se(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
    let (mut a, mut a2) = (0.0, 0.0);
    for _ in 0..n {
        let x = f();
        a += x;
        a2 += x * x;
    }
    let m = a / n as f64;
    (m, ((a2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

/// Rough glass for transmission tests: GGX α, η = 1.5 against 1, white.
pub fn rough_glass(alpha: f32) -> groove::bsdf::BsdfNode {
    use groove::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    groove::bsdf::BsdfNode::RoughDielectric(groove::bsdf::roughdielectric::RoughDielectric::new(
        MicrofacetDistribution::new(MicrofacetType::Ggx, alpha, true),
        1.5,
        1.0,
        glam::Vec3::ONE,
        glam::Vec3::ONE,
    ))
}

/// Rough gold (Mitsuba's "Au"): GGX α with visible-normal sampling, white specular reflectance.
pub fn rough_gold(alpha: f32) -> groove::bsdf::BsdfNode {
    use groove::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    let (eta, k) = groove::bsdf::named_conductor("Au").unwrap();
    groove::bsdf::BsdfNode::RoughConductor(groove::bsdf::RoughConductor {
        distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, alpha, true),
        eta,
        k,
        specular_reflectance: glam::Vec3::ONE,
    })
}

/// Rough plastic: blue diffuse base (0.2, 0.5, 0.8) under a coating of η = 1.49 in air,
/// nonlinear, with the given distribution, α and sampling strategy.
pub fn rough_plastic(
    kind: groove::bsdf::MicrofacetType,
    alpha: f32,
    sample_visible: bool,
) -> groove::bsdf::BsdfNode {
    groove::bsdf::BsdfNode::RoughPlastic(groove::bsdf::RoughPlastic::new(
        kind,
        alpha,
        sample_visible,
        glam::Vec3::new(0.2, 0.5, 0.8),
        glam::Vec3::ONE,
        1.49,
        1.000277,
        true,
    ))
}

/// A one-sphere scene (8×8 perspective film) whose BSDF is the XML `bsdf`, written to a fresh
/// temporary folder named by `tag` and `name`.
pub fn one_sphere_scene(tag: &str, name: &str, bsdf: &str) -> ScratchFile {
    let dir = Scratch::new(&format!("groove-{tag}-{}-{name}", std::process::id()));
    let path = ScratchFile::new(dir, "scene.xml");
    let xml = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="sphere">
{bsdf}
    </shape>
</scene>"#
    );
    std::fs::write(&path, xml).unwrap();
    path
}
