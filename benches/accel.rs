//! Per-packet cost of tier A (`groove::accel`, brute-force analytic intersection): the nearest
//! hit and occlusion queries of 4096 random rays against the shapes of
//! `scenes/bench/metal_plastic.xml` (two spheres, two rectangles), one ray at a time and in
//! packets of 8. Rays start at random points of the scene's box (y in [0, 3], x and z in ±3)
//! with random unit directions, tmin 0, tmax ∞ (shadow rays: tmax 4). Criterion's throughput is
//! rays per second.
//! Run: `cargo bench --bench accel` (a filter such as `-- occluded` picks queries).

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use groove::accel::{Accel, Tier};
use groove::geometry::Ray;
use groove::math::Pcg32;
use std::path::Path;
use std::time::Duration;

const N: usize = 4096;

fn rays(tmax: f32) -> Vec<Ray> {
    let mut r = Pcg32::new(7, 3);
    let mut u = move || 2.0 * r.next_f32() - 1.0;
    (0..N)
        .map(|_| {
            let o = Vec3::new(3.0 * u(), 1.5 + 1.5 * u(), 3.0 * u());
            let d = loop {
                let d = Vec3::new(u(), u(), u());
                if (0.01..=1.0).contains(&d.length_squared()) {
                    break d.normalize();
                }
            };
            Ray::segment(o, d, tmax)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bench/metal_plastic.xml");
    let loaded = groove::load::load_scene(&path, &Default::default()).unwrap();
    let accel = Accel::build_tiered(loaded.scene.shapes(), &[], &[], Tier::Brute).unwrap();
    let (bounce, shadow) = (rays(f32::INFINITY), rays(4.0));
    let mut g = c.benchmark_group("tier_a");
    g.throughput(Throughput::Elements(N as u64))
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("intersect", |b| {
        b.iter(|| {
            bounce
                .iter()
                .filter(|r| accel.intersect(black_box(r)).is_some())
                .count()
        })
    });
    g.bench_function("intersect8", |b| {
        b.iter(|| {
            let mut out = [None; 8];
            let mut n = 0;
            for p in bounce.chunks(8) {
                accel.intersect8(black_box(p), false, &mut out);
                n += out.iter().filter(|h| h.is_some()).count();
            }
            n
        })
    });
    g.bench_function("occluded", |b| {
        b.iter(|| {
            shadow
                .iter()
                .filter(|r| accel.occluded(black_box(r)))
                .count()
        })
    });
    g.bench_function("occluded8", |b| {
        b.iter(|| {
            shadow
                .chunks(8)
                .map(|p| accel.occluded8(black_box(p)).count_ones())
                .sum::<u32>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
