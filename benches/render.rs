//! Throughput of the whole renderer on the Cornell box: samples per second (criterion reports the
//! time per render of a 64×64 image at 16 spp = 65,536 samples; divide to get samples/s).
//! `groove render` prints samples/s and rays/s for any scene as well.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use groove::load::load_scene;
use groove::load::options::LoadOptions;
use groove::render::{render, RenderOptions};
use std::path::PathBuf;

fn cbox(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/cbox-rgb.xml");
    let opts = LoadOptions {
        defines: vec![("res".into(), "64".into())],
        ..Default::default()
    };
    let loaded = load_scene(&path, &opts).expect("scene");
    let ro = RenderOptions {
        spp: Some(16),
        seed: Some(0),
        threads: 0,
        ..Default::default()
    };
    let mut g = c.benchmark_group("cbox");
    g.throughput(Throughput::Elements(64 * 64 * 16));
    g.sample_size(10);
    g.bench_function("render_64x64_16spp", |b| {
        b.iter(|| render(&loaded.scene, &loaded.settings, &ro).expect("render"))
    });
    g.finish();
}

criterion_group!(benches, cbox);
criterion_main!(benches);
