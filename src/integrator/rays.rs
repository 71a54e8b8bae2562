//! Ray statistics of one worker thread: every ray an integrator traces goes through [`Rays`],
//! which counts it by kind and, when the render asks for it (`groove bench`'s Embree ceiling),
//! records it. The renderer sums the counters and concatenates the logs per image block, in
//! block order.

use crate::accel::HitRow;
use crate::geometry::{Hit, Ray, SurfaceInteraction};
use crate::scene::Scene;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// Ray counts of one thread, summed by the renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounters {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
    /// Random walks sampled by microfacet normal maps, and their vertices (not rays).
    pub walks: u64,
    pub walk_vertices: u64,
    /// Lane use of the stream renderer's stages (zero under the scalar renderer).
    pub lanes: crate::stream::LaneCounters,
}

impl RayCounters {
    /// Rays traced (camera + bounce + shadow).
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
    pub fn add(&mut self, o: &RayCounters) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
        self.walks += o.walks;
        self.walk_vertices += o.walk_vertices;
        self.lanes.add(&o.lanes);
    }
    /// Mean vertices per sampled microfacet walk (0 without walks).
    pub fn mean_walk_length(&self) -> f64 {
        if self.walks == 0 {
            0.0
        } else {
            self.walk_vertices as f64 / self.walks as f64
        }
    }
}

/// One recorded ray: `shadow` rays only ask for occlusion; `camera` rays leave the sensor (the
/// camera rays of one pixel's samples are consecutive among the camera rays of a log).
#[derive(Clone, Copy, Debug)]
pub struct LoggedRay {
    pub ray: Ray,
    pub shadow: bool,
    pub camera: bool,
}

/// Which counter a nearest-hit query goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    Camera,
    Bounce,
}

/// Recorded rays, drawing on a budget shared by every worker of one render.
struct RayLog {
    rays: Vec<LoggedRay>,
    budget: Arc<AtomicUsize>,
}

impl RayLog {
    /// Keep `ray` while the shared budget lasts (recording is the rare case: off the hot path).
    #[cold]
    fn push(&mut self, ray: &Ray, shadow: bool, camera: bool) {
        let left = self
            .budget
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1));
        if left.is_ok() {
            self.rays.push(LoggedRay {
                ray: *ray,
                shadow,
                camera,
            });
        }
    }
}

/// The per-thread ray counters and the optional ray log.
#[derive(Default)]
pub struct Rays {
    pub counters: RayCounters,
    /// `Some` while recording.
    log: Option<RayLog>,
    /// The ray array of the stream queries, reused.
    buf: crate::accel::RayBuf,
    /// Whether the stream renderer traces its packets 16 rays wide ([`Self::set_packets16`]).
    packets16: bool,
}

impl Rays {
    /// Record rays from now on while `budget` (shared by the render's workers) lasts.
    pub fn record(&mut self, budget: Arc<AtomicUsize>) {
        self.log = Some(RayLog {
            rays: Vec::new(),
            budget,
        });
    }

    /// The rays recorded since the last call (empty when not recording).
    pub fn take_log(&mut self) -> Vec<LoggedRay> {
        match &mut self.log {
            Some(l) => std::mem::take(&mut l.rays),
            None => Vec::new(),
        }
    }

    #[inline]
    fn log(&mut self, ray: &Ray, shadow: bool, camera: bool) {
        if let Some(l) = &mut self.log {
            l.push(ray, shadow, camera);
        }
    }

    /// Nearest surface hit along `ray`, counted as `kind`.
    #[inline]
    pub fn intersect(
        &mut self,
        scene: &Scene,
        ray: &Ray,
        kind: RayKind,
    ) -> Option<SurfaceInteraction> {
        match kind {
            RayKind::Camera => self.counters.camera += 1,
            RayKind::Bounce => self.counters.bounce += 1,
        }
        self.log(ray, false, kind == RayKind::Camera);
        scene.intersect(ray)
    }

    /// The nearest hits of up to 8 rays traced as one packet (`out[i]` for `rays[i]`), counted
    /// as `kind`; camera packets are traced as coherent. Each lane gets the hit a single ray
    /// gets (`tests/scene/packets.rs`).
    #[inline]
    pub fn intersect8(
        &mut self,
        scene: &Scene,
        rays: &[Ray],
        kind: RayKind,
        out: &mut [Option<Hit>; 8],
    ) {
        self.note_packet(rays, 8, Some(kind));
        scene.accel.intersect8(rays, kind == RayKind::Camera, out);
    }

    /// Counts the `n` rays `ray(0)`, … `ray(n − 1)` of one packet as `kind` and logs them when
    /// a log is kept (the packets read in place, [`Self::intersect8_scatter`],
    /// [`Self::intersect8_rows`] and [`Self::intersect16_with`]).
    #[inline(always)]
    fn count_packet<'r>(&mut self, n: usize, kind: RayKind, ray: &impl Fn(usize) -> &'r Ray) {
        match kind {
            RayKind::Camera => self.counters.camera += n as u64,
            RayKind::Bounce => self.counters.bounce += n as u64,
        }
        if self.log.is_some() {
            for k in 0..n {
                self.log(ray(k), false, kind == RayKind::Camera);
            }
        }
    }

    /// [`Self::intersect8`] of the rays `rays[ids[k]]`, `k < ids.len()` (at most 8), each read
    /// where it lies, ray `k`'s hit stored as a [`HitRow`] in `hit[ids[k]]`
    /// ([`crate::accel::Accel::intersect8_scatter`]: the stream renderer's packets of active
    /// paths, read from and written to its path columns, without a packet of rays or of hits
    /// in between).
    #[inline]
    pub fn intersect8_scatter(
        &mut self,
        scene: &Scene,
        kind: RayKind,
        ids: &[u32],
        rays: &[Ray],
        hit: &mut [HitRow],
    ) {
        let ids = &ids[..ids.len().min(8)];
        self.count_packet(ids.len(), kind, &|k| &rays[ids[k] as usize]);
        scene
            .accel
            .intersect8_scatter(&mut self.buf, kind == RayKind::Camera, ids, rays, hit);
    }

    /// [`Self::intersect8_scatter`] of a full packet, `rays[k]`'s hit stored in `rows[k]`
    /// ([`crate::accel::Accel::intersect8_rows`]: the stream renderer's camera packets, whose
    /// rays and hits are 8 consecutive paths' own).
    #[inline]
    pub fn intersect8_rows(
        &mut self,
        scene: &Scene,
        kind: RayKind,
        rays: &[Ray; 8],
        rows: &mut [HitRow; 8],
    ) {
        self.count_packet(8, kind, &|k| &rays[k]);
        scene
            .accel
            .intersect8_rows(&mut self.buf, kind == RayKind::Camera, rays, rows);
    }

    /// The nearest hit of one ray as the accelerator reports it (no surface interaction yet),
    /// counted as `kind`.
    #[inline]
    pub fn intersect_hit(&mut self, scene: &Scene, ray: &Ray, kind: RayKind) -> Option<Hit> {
        match kind {
            RayKind::Camera => self.counters.camera += 1,
            RayKind::Bounce => self.counters.bounce += 1,
        }
        self.log(ray, false, kind == RayKind::Camera);
        scene.accel.intersect(ray)
    }

    /// The nearest hits of many rays traced as one stream (`out(k, row)` for the `k`-th ray,
    /// in order, its hit as a [`HitRow`]), counted as `kind`; `coherent` tells Embree the rays
    /// start together and point alike. Each ray gets the hit a single ray gets
    /// (`tests/scene/packets.rs`).
    #[inline]
    pub fn intersect_stream<'r>(
        &mut self,
        scene: &Scene,
        rays: impl Iterator<Item = &'r Ray>,
        kind: RayKind,
        coherent: bool,
        out: impl FnMut(usize, HitRow),
    ) {
        self.fill_stream(rays);
        self.intersect_filled(scene, kind, coherent, out);
    }

    /// [`Self::intersect_stream`] with each ray's hit row stored in place: the `k`-th ray's in
    /// `rows[ids[k]]` ([`crate::accel::Accel::intersect_filled_into`]: the stream renderer's
    /// bounce rays, `ids` its active paths and `rows` its hit column).
    #[inline]
    pub fn intersect_stream_into<'r>(
        &mut self,
        scene: &Scene,
        rays: impl Iterator<Item = &'r Ray>,
        kind: RayKind,
        coherent: bool,
        ids: &[u32],
        rows: &mut [HitRow],
    ) {
        self.fill_stream(rays);
        self.log_stream(false, kind == RayKind::Camera);
        let n = self.buf_len();
        scene
            .accel
            .intersect_filled_into(coherent, &mut self.buf, ids, rows);
        match kind {
            RayKind::Camera => self.counters.camera += n,
            RayKind::Bounce => self.counters.bounce += n,
        }
    }

    /// [`Self::occluded`] of many shadow rays traced as one stream: `out(k, blocked)` for the
    /// `k`-th ray, in order (`coherent` as for [`Self::intersect_stream`]).
    #[inline]
    pub fn occluded_stream<'r>(
        &mut self,
        scene: &Scene,
        rays: impl Iterator<Item = &'r Ray>,
        coherent: bool,
        out: impl FnMut(usize, bool),
    ) {
        self.fill_stream(rays);
        self.occluded_filled(scene, coherent, out);
    }

    /// The first step of a stream query: `rays` into the stream buffer (nothing traced or
    /// counted yet); returns how many. The caller may note what it puts in as the iterator
    /// runs (the stream renderer's shadow stage lists its pending paths in the same pass).
    #[inline]
    pub fn fill_stream<'r>(&mut self, rays: impl Iterator<Item = &'r Ray>) -> usize {
        self.buf.fill(rays)
    }

    /// The second step: [`Self::intersect_stream`] of the rays [`Self::fill_stream`] put in.
    #[inline]
    pub fn intersect_filled(
        &mut self,
        scene: &Scene,
        kind: RayKind,
        coherent: bool,
        out: impl FnMut(usize, HitRow),
    ) {
        self.log_stream(false, kind == RayKind::Camera);
        let n = self.buf_len();
        scene.accel.intersect_filled(coherent, &mut self.buf, out);
        match kind {
            RayKind::Camera => self.counters.camera += n,
            RayKind::Bounce => self.counters.bounce += n,
        }
    }

    /// The second step: [`Self::occluded_stream`] of the rays [`Self::fill_stream`] put in.
    #[inline]
    pub fn occluded_filled(&mut self, scene: &Scene, coherent: bool, out: impl FnMut(usize, bool)) {
        self.log_stream(true, false);
        let n = self.buf_len();
        scene.accel.occluded_filled(coherent, &mut self.buf, out);
        self.counters.shadow += n;
    }

    /// How many rays the stream buffer holds.
    #[inline(always)]
    fn buf_len(&self) -> u64 {
        self.buf.len() as u64
    }

    /// Logs the stream buffer's rays when a log is on (before the query changes them).
    #[inline(always)]
    fn log_stream(&mut self, shadow: bool, camera: bool) {
        if let Some(l) = &mut self.log {
            for r in self.buf.rays() {
                l.push(&r, shadow, camera);
            }
        }
    }

    /// [`Self::occluded`] of up to 8 shadow rays traced as one packet: bit `i` for `rays[i]`.
    #[inline]
    pub fn occluded8(&mut self, scene: &Scene, rays: &[Ray]) -> u8 {
        self.note_packet(rays, 8, None);
        scene.accel.occluded8(rays)
    }

    /// Counts the rays of one packet of at most `width` (as `kind`, or as shadow rays when
    /// `None`) and logs each of them when a log is on: the bookkeeping every packet query shares.
    #[inline(always)]
    fn note_packet(&mut self, rays: &[Ray], width: usize, kind: Option<RayKind>) {
        let n = rays.len().min(width) as u64;
        match kind {
            Some(RayKind::Camera) => self.counters.camera += n,
            Some(RayKind::Bounce) => self.counters.bounce += n,
            None => self.counters.shadow += n,
        }
        if self.log.is_some() {
            for r in rays {
                self.log(r, kind.is_none(), kind == Some(RayKind::Camera));
            }
        }
    }

    /// Lets the stream renderer trace 16-ray packets ([`Self::intersect16`],
    /// [`Self::occluded16`]) instead of 8-ray ones: set per block, on when its lanes may be 16
    /// wide and the scene's accelerator traces 16 rays as one packet
    /// ([`crate::accel::Accel::packets16`]).
    pub(crate) fn set_packets16(&mut self, on: bool) {
        self.packets16 = on;
    }

    /// Whether [`Self::set_packets16`] turned the 16-ray packets on.
    #[inline]
    pub(crate) fn packets16(&self) -> bool {
        self.packets16
    }

    /// [`Self::intersect8`] of up to 16 rays (`out[i]` for `rays[i]`), one packet under tier A
    /// on AVX-512 ([`crate::accel::Accel::intersect16`]).
    #[inline]
    pub fn intersect16(
        &mut self,
        scene: &Scene,
        rays: &[Ray],
        kind: RayKind,
        out: &mut [Option<Hit>; 16],
    ) {
        self.note_packet(rays, 16, Some(kind));
        scene.accel.intersect16(rays, kind == RayKind::Camera, out);
    }

    /// [`Self::intersect16`] of the `n` (at most 16) rays `ray(0)`, … `ray(n − 1)`, each hit
    /// handed to `out(k, row)` in lane order as a [`HitRow`]
    /// ([`Self::intersect8_scatter`]'s reads at width 16: tier A's 16-ray packets read the stream
    /// renderer's rays in place and write its hit rows,
    /// [`crate::accel::Accel::intersect16_with`]).
    #[inline]
    pub fn intersect16_with<'r>(
        &mut self,
        scene: &Scene,
        n: usize,
        kind: RayKind,
        ray: impl Fn(usize) -> &'r Ray,
        out: impl FnMut(usize, HitRow),
    ) {
        let n = n.min(16);
        self.count_packet(n, kind, &ray);
        scene
            .accel
            .intersect16_with(&mut self.buf, n, kind == RayKind::Camera, ray, out);
    }

    /// [`Self::occluded8`] of up to 16 shadow rays: bit `i` for `rays[i]`.
    #[inline]
    pub fn occluded16(&mut self, scene: &Scene, rays: &[Ray]) -> u16 {
        self.note_packet(rays, 16, None);
        scene.accel.occluded16(rays)
    }

    /// True when something blocks the shadow ray `ray`.
    #[inline]
    pub fn occluded(&mut self, scene: &Scene, ray: &Ray) -> bool {
        self.counters.shadow += 1;
        self.log(ray, true, false);
        scene.occluded(ray)
    }
}
