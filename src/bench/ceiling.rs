//! The Embree ceiling: how fast this machine intersects the rays a render traces.
//!
//! One classic render (untimed) records every ray it traces ([`RenderOptions::record_rays`]): camera and
//! bounce rays ask for the nearest hit, shadow rays for occlusion. The recorded rays are then
//! traced again through the same acceleration structure, in parallel on the same number of
//! threads, with no shading, surface reconstruction or sampling: the render's own ray
//! distribution at the intersection limit. Rays beyond the recording cap are made up by tracing
//! the recorded ones again, so the count equals the render's.

use crate::error::Result;
use crate::integrator::LoggedRay;
use crate::load::Loaded;
use crate::render::{render, thread_pool, RenderOptions};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// At most this many rays are kept (32 bytes each: 512 MiB).
pub const RECORD_CAP: usize = 16 << 20;

#[derive(Clone, Debug, Serialize)]
pub struct Ceiling {
    pub scene: String,
    /// Rays traced (= the recorded render's ray count).
    pub rays: u64,
    /// Distinct rays recorded (fewer than `rays` when the cap was reached).
    pub recorded: u64,
    pub shadow_fraction: f64,
    /// Best of the repeats.
    pub seconds: f64,
    pub rays_per_second: f64,
}

/// Record a classic render of the loaded scene at `spp` and trace its rays again `repeat` times.
pub fn measure(
    loaded: &Loaded,
    name: &str,
    spp: u32,
    threads: usize,
    repeat: u32,
) -> Result<Ceiling> {
    let out = render(
        &loaded.scene,
        &loaded.settings,
        &RenderOptions {
            threads,
            spp: Some(spp),
            seed: Some(0),
            record_rays: RECORD_CAP,
            ..Default::default()
        },
    )?;
    let total = out.stats.rays.total() as usize;
    let rays = out.ray_log;
    debug_assert_eq!(rays.len(), total.min(RECORD_CAP));
    let recorded = rays.len();
    let shadow = rays.iter().filter(|r| r.shadow).count();
    let pool = thread_pool(threads)?;
    let mut best = f64::INFINITY;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        let hits: usize = pool.install(|| trace(&loaded.scene, &rays, total));
        best = best.min(t0.elapsed().as_secs_f64());
        std::hint::black_box(hits);
    }
    Ok(Ceiling {
        scene: name.into(),
        rays: total as u64,
        recorded: recorded as u64,
        shadow_fraction: shadow as f64 / recorded.max(1) as f64,
        seconds: best,
        rays_per_second: total as f64 / best,
    })
}

/// Trace `total` rays cycling through `rays`; returns the number of hits (kept so the work is
/// not optimised away).
fn trace(scene: &Scene, rays: &[LoggedRay], total: usize) -> usize {
    if rays.is_empty() {
        return 0;
    }
    const CHUNK: usize = 4096;
    let chunks = total.div_ceil(CHUNK);
    (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut hits = 0;
            for i in c * CHUNK..((c + 1) * CHUNK).min(total) {
                let r = &rays[i % rays.len()];
                let hit = if r.shadow {
                    scene.accel.occluded(&r.ray)
                } else {
                    scene.accel.intersect(&r.ray).is_some()
                };
                hits += hit as usize;
            }
            hits
        })
        .sum()
}
