//! The `direct` integrator on the stream renderer: Mitsuba's direct illumination
//! ([`crate::integrator::direct`]) over a batch of camera paths, stage by stage, with the scalar
//! renderer's image bit for bit (`tests/render/stream.rs`).
//!
//! Per batch (the batch of [`super::Batch`], filled by [`super::render_block`]):
//! 1. **trace** the camera rays ([`super::trace`], coherent 8-wide packets);
//! 2. **camera emission** (`direct::add_camera_emission`) into each path's `result`;
//! 3. **sample**, path after path in the batch order: the BSDF at the hit, then its
//!    `emitter_samples` light samples (`nee::prepare_light`, up to the shadow ray) and its
//!    `bsdf_samples` BSDF samples, each path drawing from its own stream in the scalar order;
//!    every sample becomes an item of [`Items`] with its ray, in the path's order;
//! 4. **trace** the items' shadow and bounce rays (as one Embree stream each, or 8-wide
//!    packets, where the scene's [`Packets`] say so, as for the path integrator's rays);
//! 5. **add** the items in order: an unblocked light sample's term (`direct::light_term`), what a
//!    BSDF sample found (`direct::add_bsdf_hit`).
//!
//! Tracing draws no random number and each path's terms are added in the scalar order, so
//! drawing every sample before tracing gives the same sums. The BSDFs are shaded lane by lane
//! (the scalar functions): the 8-wide kernels of [`super::kernels`] end a BSDF sample in
//! `PathState::advance`, whose throughput test drops a zero-weight sample that `direct` still
//! traces, so they are not used here yet.

use super::batch::Batch;
use super::{slots, trace, Packets};
use crate::bsdf::{BsdfContext, Lobes};
use crate::geometry::{Hit, Ray};
use crate::integrator::direct::{
    add_bsdf_hit, add_camera_emission, light_term, takes_light_samples,
};
use crate::integrator::nee::prepare_light;
use crate::integrator::{DirectSettings, RayKind, Scratch};
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// One sample of a path whose ray is still to be traced.
#[derive(Clone, Copy, Debug)]
enum Item {
    /// A light sample: its term joins the path's radiance when nothing blocks `shadow`.
    Light {
        path: u32,
        shadow: Ray,
        term: Spectrum,
    },
    /// A BSDF sample leaving `p` along `ray` (weight, density, through a delta lobe).
    Bsdf {
        path: u32,
        p: Vec3,
        ray: Ray,
        weight: Spectrum,
        pdf: f32,
        delta: bool,
    },
}

/// The samples of one batch in order (per path, its light samples then its BSDF samples), and
/// what tracing found for each: allocated once per worker, reused for every batch.
#[derive(Default)]
pub(crate) struct Items {
    items: Vec<Item>,
    /// Per item: a light sample's shadow ray is blocked.
    blocked: Vec<bool>,
    /// Per item: what a BSDF sample's ray hit.
    hit: Vec<Option<Hit>>,
    /// Indices of the light items, then of the BSDF items (the rays traced together).
    shadow_ids: Vec<u32>,
    bounce_ids: Vec<u32>,
}

/// Runs the `direct` integrator `cfg` on every path of `batch` (camera rays set).
pub(crate) fn run_batch(
    scene: &Scene,
    cfg: &DirectSettings,
    batch: &mut Batch,
    scratch: &mut Scratch,
    packets: Packets,
    items: &mut Items,
) {
    scratch.rays.counters.lanes.batches += 1;
    batch.active.clear();
    batch.active.extend(0..batch.len() as u32);
    trace(
        scene,
        batch,
        RayKind::Camera,
        packets.camera.then_some(packets.stream),
        &mut scratch.rays,
    );

    // Camera emission; the paths that hit a surface go on to the sampling stage.
    batch.scatter.clear();
    for i in 0..batch.len() {
        let ray = &batch.ray[i];
        let si = batch.hit[i].map(|h| scene.interaction(ray, &h));
        add_camera_emission(cfg, scene, &mut batch.state[i].result, ray, si.as_ref());
        if let Some(si) = si {
            batch.surf.set(i, &si);
            batch.scatter.push(i as u32);
        }
    }
    let lanes = &mut scratch.rays.counters.lanes;
    lanes.shade_used += batch.scatter.len() as u64;
    lanes.shade_slots += slots(batch.scatter.len());

    // Every sample of every path, in path order.
    let ctx = BsdfContext::default();
    items.items.clear();
    for &i in &batch.scatter {
        let si = &batch.surf.get(i as usize);
        let sampler = &mut batch.sampler[i as usize];
        let Some(bsdf) = scene.bsdf_at(si, &mut scratch.arena) else {
            continue;
        };
        if takes_light_samples(scene, &bsdf) {
            for _ in 0..cfg.emitter_samples {
                if let Some((ls, shadow)) = prepare_light(scene, si, &bsdf, &ctx, sampler) {
                    items.items.push(Item::Light {
                        path: i,
                        shadow,
                        term: light_term(cfg, &ls),
                    });
                }
            }
        }
        for _ in 0..cfg.bsdf_samples {
            if let Some(bs) = bsdf.sample(&ctx, sampler) {
                items.items.push(Item::Bsdf {
                    path: i,
                    p: si.p,
                    ray: si.spawn_ray(bs.wo),
                    weight: bs.weight,
                    pdf: bs.pdf,
                    delta: bs.lobe.intersects(Lobes::DELTA),
                });
            }
        }
    }

    items.trace(scene, packets, scratch);

    // The terms, in each path's order.
    for (k, item) in items.items.iter().enumerate() {
        match *item {
            Item::Light { path, term, .. } => {
                if !items.blocked[k] {
                    batch.state[path as usize].result += term;
                }
            }
            Item::Bsdf {
                path,
                p,
                ray,
                weight,
                pdf,
                delta,
            } => {
                let hit = items.hit[k].map(|h| scene.interaction(&ray, &h));
                let result = &mut batch.state[path as usize].result;
                add_bsdf_hit(
                    cfg,
                    scene,
                    result,
                    p,
                    ray.d,
                    weight,
                    pdf,
                    delta,
                    hit.as_ref(),
                );
            }
        }
    }
}

/// The ray an item traces: a light sample's shadow ray, a BSDF sample's bounce ray.
#[inline]
fn ray_ref(item: &Item) -> &Ray {
    match item {
        Item::Light { shadow, .. } => shadow,
        Item::Bsdf { ray, .. } => ray,
    }
}

impl Items {
    /// Traces the items' rays: the shadow rays (`occluded`), then the bounce rays, each as
    /// one Embree stream (`packets.stream`, the default under Embree, as the path stream's
    /// bounce and shadow rays) or 8-wide packets of consecutive items where `packets` says so,
    /// else one by one.
    fn trace(&mut self, scene: &Scene, packets: Packets, scratch: &mut Scratch) {
        let n = self.items.len();
        self.blocked.clear();
        self.blocked.resize(n, false);
        self.hit.clear();
        self.hit.resize(n, None);
        self.shadow_ids.clear();
        self.bounce_ids.clear();
        for (k, item) in self.items.iter().enumerate() {
            match item {
                Item::Light { .. } => self.shadow_ids.push(k as u32),
                Item::Bsdf { .. } => self.bounce_ids.push(k as u32),
            }
        }
        let rays = &mut scratch.rays;
        let lanes = &mut rays.counters.lanes;
        lanes.shadow_used += self.shadow_ids.len() as u64;
        lanes.shadow_slots += slots(self.shadow_ids.len());
        lanes.trace_used += self.bounce_ids.len() as u64;
        lanes.trace_slots += slots(self.bounce_ids.len());
        let items = &self.items;
        let mut packet = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
        if packets.shadow && packets.stream {
            let (ids, blocked) = (&self.shadow_ids, &mut self.blocked);
            let traced = ids.iter().map(|&k| ray_ref(&items[k as usize]));
            rays.occluded_stream(scene, traced, false, |j, b| {
                blocked[ids[j] as usize] = b;
            });
        } else if packets.shadow {
            for chunk in self.shadow_ids.chunks(8) {
                for (p, &k) in packet.iter_mut().zip(chunk) {
                    *p = *ray_ref(&items[k as usize]);
                }
                let blocked = rays.occluded8(scene, &packet[..chunk.len()]);
                for (j, &k) in chunk.iter().enumerate() {
                    self.blocked[k as usize] = blocked >> j & 1 == 1;
                }
            }
        } else {
            for &k in &self.shadow_ids {
                self.blocked[k as usize] = rays.occluded(scene, ray_ref(&items[k as usize]));
            }
        }
        if packets.bounce && packets.stream {
            let (ids, hit) = (&self.bounce_ids, &mut self.hit);
            let traced = ids.iter().map(|&k| ray_ref(&items[k as usize]));
            rays.intersect_stream(scene, traced, RayKind::Bounce, false, |j, h| {
                hit[ids[j] as usize] = h;
            });
        } else if packets.bounce {
            let mut out: [Option<Hit>; 8] = [None; 8];
            for chunk in self.bounce_ids.chunks(8) {
                for (p, &k) in packet.iter_mut().zip(chunk) {
                    *p = *ray_ref(&items[k as usize]);
                }
                rays.intersect8(scene, &packet[..chunk.len()], RayKind::Bounce, &mut out);
                for (h, &k) in out.iter().zip(chunk) {
                    self.hit[k as usize] = *h;
                }
            }
        } else {
            for &k in &self.bounce_ids {
                let ray = ray_ref(&items[k as usize]);
                self.hit[k as usize] = rays.intersect_hit(scene, ray, RayKind::Bounce);
            }
        }
    }
}
