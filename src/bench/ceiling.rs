//! The Embree ceiling: how fast this machine intersects the rays a render traces.
//!
//! One classic render (untimed) records every ray it traces ([`RenderOptions::record_rays`]): camera and
//! bounce rays ask for the nearest hit, shadow rays for occlusion. The recorded rays are then
//! traced again through the same acceleration structure, in parallel on the same number of
//! threads, with no shading, surface reconstruction or sampling: the render's own ray
//! distribution at the intersection limit. Rays beyond the recording cap are made up by tracing
//! the recorded ones again, so the count equals the render's.
//!
//! Three replays of the same rays (issue 16's measurements for the stream renderer):
//! - **single**: one `rtcIntersect1`/`rtcOccluded1` per ray, as the renderer traces today;
//! - **packets**: every ray in 8-wide packets (`rtcIntersect8`/`rtcOccluded8`), consecutive
//!   rays of one kind together, in log order: incoherent packets, what a stream renderer that
//!   does not sort its rays would trace;
//! - **camera packets**: the camera rays alone, 8 consecutive ones per coherent packet (the log
//!   keeps a pixel's samples together, so a packet is 8 samples of one pixel, as Dr.Jit's
//!   `llvm_ad_rgb` traces them), against the same camera rays traced one by one.
//!
//! These three go through the Embree tier, whatever tier the scene would take. When the scene
//! qualifies for tier A (only spheres, disks, rectangles and boxes, no instances; issue 16
//! item 3), the same rays are replayed through tier A too: single rays (one ray × 8
//! primitives), all rays as packets and camera packets (8 rays × every primitive).

use crate::accel::{Accel, Tier};
use crate::error::Result;
use crate::geometry::Ray;
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
    /// The replay loop without intersections ([`trace_floor`]): best time. The single-ray
    /// replays below include it.
    pub floor_seconds: f64,
    /// Best of the repeats.
    pub seconds: f64,
    pub rays_per_second: f64,
    /// All rays in 8-wide packets: best time and rays/s.
    pub packet_seconds: f64,
    pub packet_rays_per_second: f64,
    /// Camera rays among the recorded ones, traced one by one and as coherent 8-wide packets.
    pub camera_rays: u64,
    pub camera_single_rays_per_second: f64,
    pub camera_packet_rays_per_second: f64,
    /// Lane occupancy of 8-sample packets, per path depth ([`lanes`]).
    pub lanes: Vec<LaneStats>,
    /// The same replays through tier A, when the scene qualifies.
    pub tier_a: Option<TierA>,
}

/// Replay throughputs of tier A (rays/s): the analytic primitives by brute force.
#[derive(Clone, Debug, Serialize)]
pub struct TierA {
    /// Analytic primitives in the scene.
    pub primitives: usize,
    /// Every ray one by one (one ray × 8 primitives per test): best time and rays/s.
    pub single_seconds: f64,
    pub single_rays_per_second: f64,
    /// Every ray in 8-wide packets (8 rays × each primitive).
    pub packet_rays_per_second: f64,
    /// Camera rays in packets of 8 samples of a pixel.
    pub camera_packet_rays_per_second: f64,
}

/// How 8 samples of one pixel, run as one 8-lane packet that lives until its longest path ends
/// (Dr.Jit's `llvm_ad_rgb` without compaction), would fill the lanes at one path depth: the
/// stream renderer's two counters, measured on the scalar renderer's recorded paths (so they
/// cost nothing when not benchmarking).
#[derive(Clone, Debug, Serialize)]
pub struct LaneStats {
    /// Path depth: 0 = the camera ray, k = the k-th bounce ray.
    pub depth: u32,
    /// Packets with at least one path still alive at this depth.
    pub packets: u64,
    /// Mean fraction of the 8 lanes alive in those packets.
    pub active_fraction: f64,
    /// Mean number of distinct materials the alive lanes hit (a miss counts as one more kind):
    /// how many material kernels the packet runs at this depth.
    pub distinct_materials: f64,
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
            // The scalar renderer: the log in its path-by-path order is what the packet
            // statistics below assume (the stream renderer's image is the same).
            renderer: crate::render::Renderer::Scalar,
            ..Default::default()
        },
    )?;
    let total = out.stats.rays.total() as usize;
    let rays = out.ray_log;
    debug_assert_eq!(rays.len(), total.min(RECORD_CAP));
    let recorded = rays.len();
    let shadow = rays.iter().filter(|r| r.shadow).count();
    let pool = thread_pool(threads)?;
    let best_of = |f: &(dyn Fn() -> usize + Sync)| {
        let mut best = f64::INFINITY;
        for _ in 0..repeat.max(1) {
            let t0 = Instant::now();
            std::hint::black_box(pool.install(f));
            best = best.min(t0.elapsed().as_secs_f64());
        }
        best
    };
    let scene = &loaded.scene;
    let shapes = scene.shapes();
    let rebuilt;
    let embree = if scene.accel().tier() == Tier::Embree {
        scene.accel()
    } else {
        // Tier A scenes are flat: no groups, no instances.
        rebuilt = Accel::build_tiered(shapes, &[], &[], Tier::Embree)?;
        &rebuilt
    };
    let floor = best_of(&|| trace_floor(&rays, total));
    let single = best_of(&|| trace(embree, &rays, total));
    let packets = best_of(&|| trace8(embree, &rays, total));
    let camera: Vec<LoggedRay> = rays.iter().filter(|r| r.camera).copied().collect();
    let camera_single = best_of(&|| trace(embree, &camera, camera.len()));
    let camera_packets = best_of(&|| trace_camera8(embree, &camera));
    let lanes = lanes(scene, &rays);
    let per_s = |n: usize, t: f64| n as f64 / t;
    let brute = match scene.accel().tier() {
        Tier::Brute => None,
        _ if !scene.instances().is_empty() => None,
        _ => Accel::build_tiered(shapes, &[], &[], Tier::Brute).ok(),
    };
    let brute = brute
        .as_ref()
        .or((scene.accel().tier() == Tier::Brute).then(|| scene.accel()));
    let tier_a = brute.map(|b| {
        let single_seconds = best_of(&|| trace(b, &rays, total));
        TierA {
            primitives: crate::accel::analytic_primitives(shapes).unwrap_or(0),
            single_seconds,
            single_rays_per_second: per_s(total, single_seconds),
            packet_rays_per_second: per_s(total, best_of(&|| trace8(b, &rays, total))),
            camera_packet_rays_per_second: per_s(
                camera.len(),
                best_of(&|| trace_camera8(b, &camera)),
            ),
        }
    });
    let per_s = |n: usize, t: f64| n as f64 / t;
    Ok(Ceiling {
        scene: name.into(),
        rays: total as u64,
        recorded: recorded as u64,
        shadow_fraction: shadow as f64 / recorded.max(1) as f64,
        floor_seconds: floor,
        seconds: single,
        rays_per_second: per_s(total, single),
        packet_seconds: packets,
        packet_rays_per_second: per_s(total, packets),
        camera_rays: camera.len() as u64,
        camera_single_rays_per_second: per_s(camera.len(), camera_single),
        camera_packet_rays_per_second: per_s(camera.len(), camera_packets),
        lanes,
        tier_a,
    })
}

/// Trace `total` rays cycling through `rays`; returns the number of hits (kept so the work is
/// not optimised away).
fn trace(accel: &Accel, rays: &[LoggedRay], total: usize) -> usize {
    replay(rays, total, |r| {
        if r.shadow {
            accel.occluded(&r.ray)
        } else {
            accel.intersect(&r.ray).is_some()
        }
    })
}

/// The replay loop alone: every ray read and a trivial test of it instead of an intersection.
/// Its time is the floor under every single-ray replay (loads, loop, parallel split), so the
/// tiers can be compared net of it.
fn trace_floor(rays: &[LoggedRay], total: usize) -> usize {
    replay(rays, total, |r| {
        std::hint::black_box(r.ray.d.x + r.ray.tmax) > 0.0
    })
}

/// `total` calls of `test` cycling through `rays` (a wrapping index, no division per ray), the
/// chunks in parallel; returns how many returned true.
fn replay(rays: &[LoggedRay], total: usize, test: impl Fn(&LoggedRay) -> bool + Sync) -> usize {
    if rays.is_empty() {
        return 0;
    }
    sum_over_chunks(total, |range| {
        let mut hits = 0;
        let mut i = range.start % rays.len();
        for _ in range {
            hits += test(&rays[i]) as usize;
            i += 1;
            if i == rays.len() {
                i = 0;
            }
        }
        hits
    })
}

/// Σ `f(range)` over `0..total` cut into chunks of 4096 ray indices, the chunks in parallel.
fn sum_over_chunks(total: usize, f: impl Fn(std::ops::Range<usize>) -> usize + Sync) -> usize {
    const CHUNK: usize = 4096;
    (0..total.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| f(c * CHUNK..((c + 1) * CHUNK).min(total)))
        .sum()
}

/// [`trace`] in 8-wide packets: each chunk's rays in order, cut into runs of one kind (nearest
/// hit or occlusion) of at most 8, each run one packet.
fn trace8(accel: &Accel, rays: &[LoggedRay], total: usize) -> usize {
    if rays.is_empty() {
        return 0;
    }
    sum_over_chunks(total, |range| {
        let mut hits = 0;
        let mut lanes: Vec<Ray> = Vec::with_capacity(8);
        let mut shadow = false;
        let mut out = [None; 8];
        let mut flush = |lanes: &mut Vec<Ray>, shadow: bool| {
            if shadow {
                hits += accel.occluded8(lanes).count_ones() as usize;
            } else {
                accel.intersect8(lanes, false, &mut out);
                hits += out.iter().filter(|h| h.is_some()).count();
            }
            lanes.clear();
        };
        for i in range {
            let r = &rays[i % rays.len()];
            if !lanes.is_empty() && (r.shadow != shadow || lanes.len() == 8) {
                flush(&mut lanes, shadow);
            }
            shadow = r.shadow;
            lanes.push(r.ray);
        }
        if !lanes.is_empty() {
            flush(&mut lanes, shadow);
        }
        hits
    })
}

/// The camera rays as coherent packets of 8 consecutive ones.
fn trace_camera8(accel: &Accel, camera: &[LoggedRay]) -> usize {
    const CHUNK: usize = 4096;
    camera
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut hits = 0;
            let mut lanes = [Ray::new(glam::Vec3::ZERO, glam::Vec3::Z); 8];
            let mut out = [None; 8];
            for packet in chunk.chunks(8) {
                for (l, r) in lanes.iter_mut().zip(packet) {
                    *l = r.ray;
                }
                accel.intersect8(&lanes[..packet.len()], true, &mut out);
                hits += out.iter().filter(|h| h.is_some()).count();
            }
            hits
        })
        .sum()
}

/// [`LaneStats`] of the recorded rays, up to depth 15: the log is cut into paths at camera rays
/// (a path's nearest-hit rays are its camera ray and bounce rays, in order) and into packets of
/// 8 consecutive paths (8 samples of one pixel when the spp is a multiple of 8).
pub fn lanes(scene: &Scene, rays: &[LoggedRay]) -> Vec<LaneStats> {
    const DEPTHS: usize = 16;
    // Per path: the material (or u32::MAX for a miss) hit at each depth.
    let mut paths: Vec<Vec<u32>> = Vec::new();
    for r in rays.iter().filter(|r| !r.shadow) {
        if r.camera || paths.is_empty() {
            paths.push(Vec::new());
        }
        let path = paths.last_mut().expect("a path was pushed");
        if path.len() < DEPTHS {
            let hit = scene.accel.intersect(&r.ray);
            path.push(hit.map_or(u32::MAX, |h| scene.shape_material[h.geom as usize]));
        }
    }
    let mut sums = [(0u64, 0u64, 0u64); DEPTHS];
    for packet in paths.chunks_exact(8) {
        for (d, sum) in sums.iter_mut().enumerate() {
            let mut kinds: Vec<u32> = packet.iter().filter_map(|p| p.get(d).copied()).collect();
            if kinds.is_empty() {
                break;
            }
            let alive = kinds.len() as u64;
            kinds.sort_unstable();
            kinds.dedup();
            *sum = (sum.0 + 1, sum.1 + alive, sum.2 + kinds.len() as u64);
        }
    }
    sums.iter()
        .enumerate()
        .take_while(|(_, s)| s.0 > 0)
        .map(|(d, &(packets, alive, kinds))| LaneStats {
            depth: d as u32,
            packets,
            active_fraction: alive as f64 / (8 * packets) as f64,
            distinct_materials: kinds as f64 / packets as f64,
        })
        .collect()
}
