//! The `direct` integrator on the stream renderer: Mitsuba's direct illumination
//! ([`crate::integrator::direct`]) over a batch of camera paths, stage by stage, with the scalar
//! renderer's image bit for bit (`tests/render/stream.rs`).
//!
//! Per batch (the batch of [`super::Batch`], filled by [`super::render_block`]):
//! 1. **trace** the camera rays ([`super::trace`], coherent 8-wide packets) and reconstruct the
//!    hits' surfaces ([`super::kernels::surface::fill`], 8-wide where a shape has a lane form);
//! 2. **camera emission** (`direct::add_camera_emission`) into each path's `result`;
//! 3. **sample**: the paths at a surface, sorted by material (stable), go through the path
//!    integrator's shading stage ([`super::shade`]) with this integrator's tail ([`DirectTail`]):
//!    a run of ≥ 8 paths of a material with an 8-wide kernel takes its light sample and BSDF
//!    sample 8 at a time (light points, BSDF values and densities, power heuristic, BSDF
//!    samples in lanes), the rest lane by lane through the scalar steps (`nee::prepare_light`,
//!    `SurfaceBsdf::sample`); each path draws from its own stream in the scalar order, and
//!    every sample becomes an item of [`Items`] with its ray, in the path's order;
//! 4. **trace** the items' shadow and bounce rays (as one Embree stream each, or 8-wide
//!    packets, where the scene's [`Packets`] say so, as for the path integrator's rays);
//! 5. **add** the items in order: an unblocked light sample's term (`direct::light_term`), what a
//!    BSDF sample found (`direct::add_bsdf_hit`).
//!
//! Tracing draws no random number and each path's terms are added in the scalar order, so
//! drawing every sample before tracing gives the same sums.
//!
//! The kernels serve `direct` when it takes one light sample and one BSDF sample per hit (the
//! default, `emitter_samples = bsdf_samples = 1`): their light-sample contribution is then
//! `light_term`'s value bit for bit (throughput 1 at the camera vertex, sample counts 1 in the
//! power heuristic; `tests/render/stream.rs`), the compensated normal map's kernel included.
//! Other sample counts and every material without a kernel are shaded lane by lane.

use super::batch::Batch;
use super::kernels::tail::{Sampled, Tail};
use super::{slots, trace, Kernels, Packets};
use crate::bsdf::{BsdfArena, BsdfContext, Lobes};
use crate::geometry::{Hit, Ray};
use crate::integrator::direct::{
    add_bsdf_hit, add_camera_emission, light_term, takes_light_samples,
};
use crate::integrator::nee::prepare_light;
use crate::integrator::{DirectSettings, PathSettings, RayKind, Scratch, Strategy};
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

/// The `direct` integrator's end of a vertex ([`Tail`]): the light and BSDF samples become
/// items to trace, in each path's order.
struct DirectTail<'a> {
    cfg: &'a DirectSettings,
    items: &'a mut Vec<Item>,
}

impl Tail for DirectTail<'_> {
    /// One light and one BSDF sample per hit, the kernels' vertex (see the module comment).
    #[inline(always)]
    fn kernels(&self) -> bool {
        self.cfg.emitter_samples == 1 && self.cfg.bsdf_samples == 1
    }

    /// With throughput 1 and one sample of each kind, the kernels' contribution is
    /// `light_term`'s: `1 · f·Le · (w / pdf)` with `w` the power heuristic of the two densities
    /// (1 for a delta light).
    #[inline(always)]
    fn light(&mut self, _: &mut Batch, i: usize, shadow: Ray, term: Spectrum) {
        self.items.push(Item::Light {
            path: i as u32,
            shadow,
            term,
        });
    }

    #[inline(always)]
    fn bsdf(&mut self, _: &mut Batch, i: usize, s: &Sampled) {
        self.items.push(Item::Bsdf {
            path: i as u32,
            p: s.p,
            ray: s.ray,
            weight: s.weight,
            pdf: s.pdf,
            delta: s.delta,
        });
    }

    /// The scalar estimator's samples ([`crate::integrator::direct::li`] up to its rays).
    fn scalar(&mut self, scene: &Scene, b: &mut Batch, i: usize, arena: &mut BsdfArena) {
        let cfg = self.cfg;
        let ctx = BsdfContext::default();
        let si = &b.surf.get(i);
        let sampler = &mut b.sampler.at(i);
        let Some(bsdf) = scene.bsdf_at(si, arena) else {
            return;
        };
        if takes_light_samples(scene, &bsdf) {
            for _ in 0..cfg.emitter_samples {
                if let Some((ls, shadow)) = prepare_light(scene, si, &bsdf, &ctx, sampler) {
                    self.items.push(Item::Light {
                        path: i as u32,
                        shadow,
                        term: light_term(cfg, &ls),
                    });
                }
            }
        }
        for _ in 0..cfg.bsdf_samples {
            if let Some(bs) = bsdf.sample(&ctx, sampler) {
                self.items.push(Item::Bsdf {
                    path: i as u32,
                    p: si.p,
                    ray: si.spawn_ray(bs.wo),
                    weight: bs.weight,
                    pdf: bs.pdf,
                    delta: bs.lobe.intersects(Lobes::DELTA),
                });
            }
        }
    }
}

/// Runs the `direct` integrator `cfg` on every path of `batch` (camera rays set).
pub(super) fn run_batch(
    scene: &Scene,
    cfg: &DirectSettings,
    batch: &mut Batch,
    scratch: &mut Scratch,
    packets: Packets,
    kernels: &Kernels,
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
    kernels.fill_surfaces(scene, batch, &mut scratch.rays.counters.lanes);

    // Camera emission; the paths that hit a surface go on to the sampling stage.
    batch.clear_scatter();
    for i in 0..batch.len() {
        let ray = &batch.ray[i];
        let si = batch.hit[i].is_hit().then(|| batch.surf.get(i));
        add_camera_emission(cfg, scene, &mut batch.state[i].result, ray, si.as_ref());
        if let Some(si) = si {
            batch.push_scatter(i as u32, scene.shape_material[si.shape as usize]);
        }
    }

    // Every sample of every path, material by material; each path's in its order.
    batch.sort_by_material(None, None);
    items.items.clear();
    // The kernels take a light sample where `takes_light_samples` would: at a smooth BSDF
    // (their material test) when the scene has a light.
    let strategy = if scene.light_sampler.is_empty() {
        Strategy::BsdfOnly
    } else {
        Strategy::Mis
    };
    let path_cfg = PathSettings {
        strategy,
        ..PathSettings::default()
    };
    let mut tail = DirectTail {
        cfg,
        items: &mut items.items,
    };
    super::shade(scene, &path_cfg, batch, scratch, kernels, &mut tail);

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
            rays.intersect_stream(scene, traced, RayKind::Bounce, false, |j, row| {
                hit[ids[j] as usize] = row.get();
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
