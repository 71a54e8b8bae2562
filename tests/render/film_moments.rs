//! A render without second moments (`RenderOptions::second_moments` false, what `groove render`
//! without a part and `groove bench` ask for) gives the same image bit for bit as one with
//! them, on both renderers and under the box (metal_plastic) and the Gaussian (cbox-rgb)
//! filter; its film refuses a variance and a part file.

use super::stream::{load, scene, window};
use groove::render::{RenderOptions, Renderer};

/// The developed image's bits, whether the film kept its second moments, and whether a variance
/// was refused.
fn image(
    l: &groove::load::Loaded,
    renderer: Renderer,
    threads: usize,
    second: bool,
) -> (Vec<[u32; 3]>, bool, bool) {
    let opts = RenderOptions {
        threads,
        spp: Some(3),
        seed: Some(5),
        renderer,
        crop: Some(window(l)),
        second_moments: second,
        ..Default::default()
    };
    let out = groove::render::render(&l.scene, &l.settings, &opts).expect("render");
    let bits = out
        .film
        .develop()
        .data
        .iter()
        .map(|p| p.map(f32::to_bits))
        .collect();
    (
        bits,
        out.film.has_second_moments(),
        out.film.develop_variance().is_err(),
    )
}

#[test]
fn stream_and_scalar_images_without_second_moments_are_the_same() {
    for rel in [
        "scenes/bench/metal_plastic.xml",
        "scenes/cornell/cbox-rgb.xml",
    ] {
        let l = load(&scene(rel), "as_written");
        let (want, kept, refused) = image(&l, Renderer::Scalar, 1, true);
        assert!(kept && !refused, "{rel}");
        assert!(want.iter().any(|p| p[0] != 0), "{rel}: nothing rendered");
        for (renderer, threads) in [
            (Renderer::Scalar, 2),
            (Renderer::Stream, 1),
            (Renderer::Stream, 3),
        ] {
            let (got, kept, refused) = image(&l, renderer, threads, false);
            assert!(!kept && refused, "{rel}: {renderer:?}");
            assert!(
                got == want,
                "{rel}: {renderer:?} at {threads} threads without second moments"
            );
        }
    }
}

#[test]
fn a_film_without_second_moments_refuses_a_part() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "as_written");
    let opts = RenderOptions {
        threads: 1,
        spp: Some(1),
        crop: Some((0, 0, 4, 4)),
        second_moments: false,
        ..Default::default()
    };
    let out = groove::render::render(&l.scene, &l.settings, &opts).expect("render");
    let dir = tempfile_dir();
    let path = dir.join("part.exr");
    let meta = groove::output::Metadata(Vec::new());
    let e = groove::output::part::write_part(&path, &out.film, &[], &meta).unwrap_err();
    assert!(e.to_string().contains("second moments"), "{e}");
    assert!(!path.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A fresh directory under the system's temporary directory.
fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("groove-moments-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
