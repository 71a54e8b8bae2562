//! The stream renderer (`--renderer stream`): the `path` integrator run breadth first over
//! batches of paths instead of one path at a time (`docs/design/PERFORMANCE.md` §4, and
//! `docs/design/ARCHITECTURE.md`, "Where the render core is going").
//!
//! Each image block (the same fixed blocks as the scalar renderer) is cut into batches of
//! [`BATCH`] paths in the block's canonical (y, x, sample) order; the batch size is a constant,
//! never derived from the thread count. A batch starts with each path's stream, film position
//! and camera ray (a pinhole camera's 8 at a time in lanes: `camera_rays`). A batch keeps its paths in structure-of-arrays form
//! ([`batch::Batch`], allocated once per worker) and runs, per bounce:
//! 1. **trace** the active paths' rays (camera rays as coherent 8-wide packets; bounce rays too
//!    under tier A, [`Packets`]);
//! 2. **emission**: what each ray sees, MIS-weighted, 8 paths at a time in lanes ([`emission`];
//!    what the lanes do not cover through [`crate::integrator::path::PathState::add_emission`]);
//! 3. **sort** the paths that scatter by material (stable counting sort);
//! 4. **shade** each material's run of paths: light sample up to its shadow ray, BSDF sample,
//!    Russian roulette. A run of ≥ 8 paths of a material with an 8-wide kernel (chosen per
//!    material at load, [`Kernel`]: `diffuse`, [`kernels::diffuse`]; `roughconductor` and
//!    `conductor`, the three dielectrics, `plastic`/`roughplastic` leaves and `diffuse` leaves
//!    (textured parameters included), under `twosided`/classic `normalmap`/`bumpmap`/`mask`,
//!    [`kernels::conductor`]; `blendbsdf` of two such children, bare or under `twosided`,
//!    [`kernels::blend`]; bare `plastic`/`roughplastic`,
//!    [`kernels::plastic`]; the compensated microfacet normal map, [`kernels::mnm`]) goes 8 at a
//!    time through it (AVX2 machines); on AVX-512 machines the `diffuse`, wrapper-chain and
//!    plastic kernels take a run's first multiple of 16 paths 16 at a time (the same functions
//!    instantiated at width 16 through [`crate::lane::Wide`]; `GROOVE_LANES=8` or
//!    [`crate::render::RenderOptions::lanes`] caps the width), then 8; every other material, a
//!    run's last < 8 paths and a machine without AVX2 go through the 1-lane code lane by lane
//!    ([`crate::integrator::path::PathState::scatter`]). The other stages (surface gather,
//!    emission, camera rays, splat) are 8 wide;
//! 5. **shadow rays** of the pending light samples, as the shading stage listed them, adding
//!    the unoccluded ones;
//! 6. **compact** the surviving paths (stable).
//!
//! The `direct` integrator runs on the same batch, camera trace, shading stage (its own
//! [`kernels::tail::Tail`]) and ray counters ([`direct`]).
//!
//! Then every path's radiance goes to the block in the canonical order (8 samples at a time:
//! [`Block::put8_finite_rows`]). Each path draws from its
//! own stream keyed by (seed, pixel, sample) and runs exactly the scalar renderer's per-vertex
//! functions in the same order, so the image equals the scalar renderer's bit for bit at any
//! thread count (`tests/render/stream.rs`).

pub(crate) mod batch;
pub(crate) mod direct;
pub(crate) mod emission;
pub(crate) mod kernels;

use crate::accel::HitRow;
use crate::cancel::Cancel;
use crate::film::Block;
use crate::geometry::Ray;
use crate::integrator::{DirectSettings, PathSettings, RayKind, Rays, Scratch};
use crate::sampler::SamplerDesc;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use batch::Batch;
use glam::Vec2;

/// Paths per batch: 1024 (PERFORMANCE.md §4.1 suggests 512–4096; ~150 KB of path state, which
/// stays in a 512 KB L2). A constant, so the decomposition is the same at any thread count.
pub const BATCH: usize = 1024;

/// Lane use of the 8-wide stages of the stream renderer, summed over a render: for each stage,
/// the lanes that did work and the lanes of the 8-wide chunks they were issued in (a run of n
/// paths takes ⌈n/8⌉ chunks). `used / slots` is the active-lane fraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneCounters {
    pub trace_used: u64,
    pub trace_slots: u64,
    /// Shading, counted per run of one material in the sorted order (what an 8-wide material
    /// kernel would see).
    pub shade_used: u64,
    pub shade_slots: u64,
    pub shadow_used: u64,
    pub shadow_slots: u64,
    /// Paths shaded by an 8-wide material kernel (the rest of `shade_used` went through the
    /// 1-lane code lane by lane).
    pub kernel_lanes: u64,
    /// The part of `kernel_lanes` shaded by the wrapper-chain driver ([`kernels::conductor`],
    /// [`kernels::vertex`]): `roughconductor`/`conductor` leaves, and `plastic`/`roughplastic`
    /// and `diffuse` leaves under `twosided` or classic `normalmap`, and the dielectrics.
    pub conductor_lanes: u64,
    /// The part of `kernel_lanes` shaded by the compensated microfacet normal map's kernel
    /// ([`kernels::mnm`]).
    pub mnm_lanes: u64,
    /// The part of `kernel_lanes` shaded 16 wide (AVX-512; the rest of `kernel_lanes` 8 wide).
    pub kernel_lanes_16: u64,
    /// The part of `kernel_lanes` shaded by the `blendbsdf` kernel ([`kernels::blend`]).
    pub blend_lanes: u64,
    /// Light samples the kernels took in lanes, per kind: area lights on triangle meshes,
    /// rectangles and spheres, then `point`, `spot`, `directional`, `constant`, `envmap`.
    pub kernel_lights: [u64; kernels::light::KINDS],
    /// Hits whose surface interaction the gather stage computed 8-wide
    /// ([`kernels::surface::fill`]; the rest went through `Scene::interaction`).
    pub surface_lanes: u64,
    /// The part of `surface_lanes` computed 16 wide (AVX-512: the one-mesh chunks of meshes of
    /// at most 16 triangles, `kernels::surface::SmallTris`).
    pub surface_lanes_16: u64,
    /// Paths whose emission (what their ray sees) the emission stage computed 8-wide
    /// ([`emission`]; the rest went through `PathState::add_emission` or saw nothing to add).
    pub emission_lanes: u64,
    /// Batches and bounces (trace stages) run.
    pub batches: u64,
    pub bounces: u64,
    /// The part of `emission_lanes` that escaped under an environment map (its (u, v) and
    /// density in lanes, [`emission::env_where`]).
    pub emission_env_lanes: u64,
    /// The part of `emission_lanes` that hit a sphere light (its cone density in lanes,
    /// [`emission::light_pdf`]).
    pub emission_sphere_lanes: u64,
}

impl LaneCounters {
    pub fn add(&mut self, o: &LaneCounters) {
        self.trace_used += o.trace_used;
        self.trace_slots += o.trace_slots;
        self.shade_used += o.shade_used;
        self.shade_slots += o.shade_slots;
        self.shadow_used += o.shadow_used;
        self.shadow_slots += o.shadow_slots;
        self.kernel_lanes += o.kernel_lanes;
        self.conductor_lanes += o.conductor_lanes;
        self.mnm_lanes += o.mnm_lanes;
        self.kernel_lanes_16 += o.kernel_lanes_16;
        self.blend_lanes += o.blend_lanes;
        for (a, b) in self.kernel_lights.iter_mut().zip(o.kernel_lights) {
            *a += b;
        }
        self.surface_lanes += o.surface_lanes;
        self.surface_lanes_16 += o.surface_lanes_16;
        self.emission_lanes += o.emission_lanes;
        self.batches += o.batches;
        self.bounces += o.bounces;
        self.emission_env_lanes += o.emission_env_lanes;
        self.emission_sphere_lanes += o.emission_sphere_lanes;
    }

    /// Active-lane fractions (trace, shade, shadow); NaN for a stage that never ran.
    pub fn fractions(&self) -> (f64, f64, f64) {
        let f = |u: u64, s: u64| u as f64 / s as f64;
        (
            f(self.trace_used, self.trace_slots),
            f(self.shade_used, self.shade_slots),
            f(self.shadow_used, self.shadow_slots),
        )
    }
}

/// Slots of 8-wide chunks that `n` lanes take.
#[inline]
fn slots(n: usize) -> u64 {
    (n as u64).div_ceil(8) * 8
}

/// Which rays the stream renderer traces as 8-wide packets (of consecutive active paths, in
/// path order) rather than one at a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Packets {
    /// Camera rays: 8 samples of one pixel, traced as a coherent packet.
    pub camera: bool,
    /// Bounce rays (incoherent).
    pub bounce: bool,
    /// Shadow rays (incoherent).
    pub shadow: bool,
    /// Bounce and shadow packets go to Embree as one stream per stage
    /// (`rtcIntersect1M`/`rtcOccluded1M`, incoherent) instead of 8-wide packets; camera rays
    /// stay coherent 8-wide packets. Tier A traces 8-wide packets either way.
    pub stream: bool,
}

impl Packets {
    /// Camera rays only (Embree's 8-wide packet traversal pays off for coherent rays only:
    /// `docs/bench/README.md`, "Packet ceilings").
    pub const DEFAULT: Packets = Packets {
        camera: true,
        bounce: false,
        shadow: false,
        stream: false,
    };

    /// Every ray kind: the default under tier A, where a packet is 8 rays against every shape
    /// (fewer instructions and, in a noisy wall-clock test, faster than single rays;
    /// `docs/bench/README.md`, "Stream renderer").
    pub const ALL: Packets = Packets {
        camera: true,
        bounce: true,
        shadow: true,
        stream: false,
    };

    /// Camera rays as coherent 8-wide packets, bounce and shadow rays as one incoherent Embree
    /// stream per stage: the default under Embree (fewer instructions than single rays on the
    /// Cornell box and the million-triangle scene, and faster on the latter in interleaved
    /// pairs: `docs/bench/README.md`, "Issue 18: rays, camera, sampler and film").
    pub const STREAMS: Packets = Packets {
        camera: true,
        bounce: true,
        shadow: true,
        stream: true,
    };

    /// No packets: every ray traced alone.
    pub const NONE: Packets = Packets {
        camera: false,
        bounce: false,
        shadow: false,
        stream: false,
    };

    /// The default for `scene`: [`Self::ALL`] when it is traced by tier A; [`Self::STREAMS`]
    /// under Embree, unless the scene has curves or SDF grids, whose packet hits can differ
    /// from single-ray hits in the last bits (measured on curves: `tests/data/scenes/mat_hair.xml`
    /// came out different), which would break the bit-identity with the scalar renderer:
    /// then [`Self::NONE`].
    pub fn default_for(scene: &Scene) -> Packets {
        use crate::geometry::shapes::ShapeKind;
        if scene.accel.tier() == crate::accel::Tier::Brute {
            Self::ALL
        } else if scene
            .shapes
            .iter()
            .any(|s| matches!(s.kind, ShapeKind::Curves(_) | ShapeKind::SdfGrid(_)))
        {
            Self::NONE
        } else {
            Self::STREAMS
        }
    }

    /// The environment variable that overrides [`Self::default_for`] for measurements: a
    /// comma-separated subset of `camera,bounce,shadow,stream`, or `none` (packets forced on a
    /// scene with curves may change the image's last bits).
    pub const ENV: &'static str = "GROOVE_STREAM_PACKETS";

    /// The packets [`Self::ENV`] asks for ([`Self::default_for`] the scene when unset).
    pub fn from_env(scene: &Scene) -> crate::error::Result<Packets> {
        let Ok(v) = std::env::var(Self::ENV) else {
            return Ok(Self::default_for(scene));
        };
        let mut p = Packets::NONE;
        for w in v.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            match w {
                "camera" => p.camera = true,
                "bounce" => p.bounce = true,
                "shadow" => p.shadow = true,
                "stream" => p.stream = true,
                "none" => {}
                _ => {
                    return Err(crate::error::Error::Usage(format!(
                    "{}={v}: expected a comma-separated subset of camera, bounce, shadow, stream, or none",
                    Self::ENV
                )))
                }
            }
        }
        Ok(p)
    }
}

/// The integrators the stream renderer runs: `path` (this module's stages) and `direct`
/// ([`direct`]).
#[derive(Clone, Copy, Debug)]
pub enum StreamIntegrator {
    Path(PathSettings),
    Direct(DirectSettings),
}

/// Per-worker state of the stream renderer: the batch buffers, reused for every batch, and
/// which materials have an 8-wide kernel.
pub struct StreamScratch {
    batch: Batch,
    packets: Packets,
    kernels: Kernels,
    /// The `direct` integrator's samples of a batch.
    direct: direct::Items,
}

/// The 8-wide kernels a scene's materials can use: the AVX2 token (none without AVX2: then
/// every path is shaded lane by lane) and, per material id, the kernel that shades it, if any
/// (decided once, at load, from the material tree).
struct Kernels {
    #[cfg(target_arch = "x86_64")]
    avx: Option<crate::lane::Avx2>,
    /// The AVX-512 token, where the CPU has it and [`Kernels::LANES`] does not cap the width
    /// below 16: then the kernels that run 16 wide ([`kernels::diffuse`]) shade a run's first
    /// multiple of 16 paths 16 at a time, and the next 8 with [`Kernels::avx`].
    #[cfg(target_arch = "x86_64")]
    avx512: Option<crate::lane::Avx512>,
    kinds: Vec<Option<Kernel>>,
    /// Per emitter, how the kernels sample it in lanes.
    lights: Vec<Option<kernels::light::LaneLight>>,
    /// Per shape, how the gather stage reconstructs its hits ([`kernels::surface::fill`]).
    forms: Vec<kernels::surface::Form>,
    /// What rays see of the emitters, for the emission stage in lanes ([`emission`]).
    emission: emission::Lights,
    /// The light selection's split by kind, the material sort's grouping hint
    /// ([`kernels::light::x8::kind_split`], [`Batch::sort_by_material`]).
    #[cfg(target_arch = "x86_64")]
    light_split: Option<f32>,
}

/// Which 8-wide kernel shades a material, with what it needs.
#[derive(Clone, Copy, Debug)]
enum Kernel {
    /// `diffuse` ([`kernels::diffuse`]): its reflectance texture and whether it takes light
    /// samples.
    Diffuse(crate::material::TexId, bool),
    /// `roughconductor` or `conductor`, bare or under `twosided`, classic `normalmap` and
    /// `bumpmap`, `plastic`, `roughplastic` and `diffuse` under them, and `dielectric`,
    /// `roughdielectric`, `thindielectric`, bare or under them; parameters may be
    /// textured ([`kernels::conductor`]).
    Conductor(kernels::conductor::Material),
    /// `plastic` or `roughplastic`, bare (reflectances gathered per lane; [`kernels::plastic`]).
    Plastic(kernels::plastic::Material),
    /// A microfacet `normalmap` with `evaluation = compensated` over a leaf ([`kernels::mnm`]).
    Mnm,
    /// `blendbsdf` of two wrapper-chain children, bare or under `twosided` ([`kernels::blend`]).
    Blend(kernels::blend::Material),
}

impl Kernels {
    /// The gather stage: each hit's surface interaction into its row of `batch.surf`
    /// ([`kernels::surface::fill`]: 8-wide where the shape has a lane form).
    fn fill_surfaces(&self, scene: &Scene, batch: &mut Batch, lanes: &mut LaneCounters) {
        kernels::surface::fill(
            scene,
            &self.forms,
            #[cfg(target_arch = "x86_64")]
            self.avx,
            #[cfg(target_arch = "x86_64")]
            self.avx512,
            batch,
            &mut lanes.surface_lanes,
            &mut lanes.surface_lanes_16,
        );
    }

    fn new(scene: &Scene, lanes: Option<usize>) -> Kernels {
        use crate::material::MaterialNode;
        let kinds = (0..scene.materials.node_count())
            .map(|m| match scene.materials.nodes()[m] {
                MaterialNode::Diffuse { reflectance } => Some(Kernel::Diffuse(
                    reflectance,
                    scene.materials.lobes(m as u32).is_smooth(),
                )),
                _ if kernels::mnm::qualifies(&scene.materials, m as u32) => Some(Kernel::Mnm),
                // A bare plastic leaf goes to the plastic kernel (which gathers textured
                // reflectances); a constant one under wrappers to the wrapper-chain driver.
                _ => kernels::plastic::material(scene, m as u32)
                    .map(Kernel::Plastic)
                    .or_else(|| {
                        kernels::conductor::Material::of(&scene.materials, m as u32)
                            .map(Kernel::Conductor)
                    })
                    .or_else(|| {
                        kernels::blend::Material::of(&scene.materials, m as u32).map(Kernel::Blend)
                    }),
            })
            .collect();
        let off = std::env::var_os(Self::ENV).is_some_and(|v| v == "0");
        let lanes = lanes.unwrap_or_else(Self::max_lanes);
        let lights = kernels::light::LaneLight::table(scene);
        Kernels {
            #[cfg(target_arch = "x86_64")]
            avx: if off || lanes < 8 {
                None
            } else {
                crate::lane::Avx2::detect()
            },
            #[cfg(target_arch = "x86_64")]
            avx512: if off || lanes < 16 {
                None
            } else {
                crate::lane::Avx512::detect()
            },
            kinds,
            #[cfg(target_arch = "x86_64")]
            light_split: kernels::light::x8::kind_split(scene, &lights),
            lights,
            forms: kernels::surface::Form::table(scene),
            emission: emission::Lights::new(scene),
        }
    }

    /// The material sort's AVX2 token and light split ([`Batch::sort_by_material`]): no split
    /// without the kernels (the lane-by-lane code gains nothing from the grouping) or without
    /// a split by kind.
    #[cfg(target_arch = "x86_64")]
    fn sort_key(&self) -> (Option<crate::lane::Avx2>, Option<f32>) {
        (self.avx, self.avx.and(self.light_split))
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn sort_key(&self) -> (Option<core::convert::Infallible>, Option<f32>) {
        (None, None)
    }

    /// Set to `0`, the environment variable turns the 8-wide kernels off (every path shaded
    /// lane by lane, as before them), for measurements.
    const ENV: &'static str = "GROOVE_STREAM_KERNELS";

    /// The widest lanes the stream renderer may use: `1`, `8` or `16` (the default: the widest
    /// the CPU has). `8` keeps an AVX-512 machine on the AVX2 path (valgrind 3.19 cannot run
    /// AVX-512 instructions; the tests compare the widths); `1` turns the lanes off. The image
    /// is the same at every width.
    pub const LANES: &'static str = "GROOVE_LANES";

    /// Whether material `m`'s kernel runs 16 wide (then a run's first multiple of 16 paths;
    /// [`shade_kernel`]).
    fn sixteen_wide(&self, m: crate::material::MatId) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx512.is_some() {
            return matches!(
                self.kinds.get(m as usize),
                Some(Some(
                    Kernel::Diffuse(..) | Kernel::Conductor(..) | Kernel::Plastic(..)
                ))
            );
        }
        let _ = m;
        false
    }

    /// [`Self::LANES`] as a number (16 when unset or not a number).
    fn max_lanes() -> usize {
        std::env::var(Self::LANES)
            .ok()
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(16)
    }
}

impl StreamScratch {
    /// Buffers for the scene's materials; the lanes at most `lanes` wide
    /// ([`crate::render::RenderOptions::lanes`]).
    pub fn new(scene: &Scene, packets: Packets, lanes: Option<usize>) -> StreamScratch {
        let materials = scene
            .shape_material
            .iter()
            .map(|&m| m as usize + 1)
            .max()
            .unwrap_or(0);
        StreamScratch {
            batch: Batch::new(BATCH, materials),
            packets,
            kernels: Kernels::new(scene, lanes),
            direct: direct::Items::default(),
        }
    }
}

/// Renders samples `samples` of the pixels `rect` (x0, y0, width, height; full-film pixels)
/// of one block with the integrator `cfg`; returns the number of invalid (NaN or
/// infinite) samples, which are dropped. Stops at the next batch once `cancel` is raised.
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_block(
    scene: &Scene,
    cfg: &StreamIntegrator,
    sampler_desc: &SamplerDesc,
    film_width: u32,
    block: &mut Block,
    rect: (u32, u32, u32, u32),
    samples: (u32, u32),
    scratch: &mut Scratch,
    stream: &mut StreamScratch,
    cancel: Option<&Cancel>,
) -> u64 {
    let (_, _, w, h) = rect;
    let (s_lo, s_hi) = samples;
    let spp = s_hi.saturating_sub(s_lo) as u64;
    let total = w as u64 * h as u64 * spp;
    let batch = &mut stream.batch;
    let packets = stream.packets;
    let kernels = &stream.kernels;
    scratch.rays.set_packets16(packets16(scene, kernels));
    let mut invalid = 0;
    let mut k = 0u64;
    while k < total {
        if cancel.is_some_and(|c| c.requested().is_some()) {
            return invalid;
        }
        let end = (k + BATCH as u64).min(total);
        batch.clear();
        #[cfg(target_arch = "x86_64")]
        let avx = kernels.avx;
        #[cfg(not(target_arch = "x86_64"))]
        let avx = None;
        batch.fill(sampler_desc, film_width, rect, samples, k, end, avx);
        camera_rays(scene, kernels, batch);
        batch.start(avx);
        match cfg {
            StreamIntegrator::Path(cfg) => run_batch(scene, cfg, batch, scratch, packets, kernels),
            StreamIntegrator::Direct(cfg) => direct::run_batch(
                scene,
                cfg,
                batch,
                scratch,
                packets,
                kernels,
                &mut stream.direct,
            ),
        }
        splat(block, batch, kernels, &mut invalid);
        k = end;
    }
    invalid
}

/// The camera rays of the batch's paths (their film positions in `batch.pos`) into
/// `batch.ray`: a pinhole `perspective` camera's 8 at a time in lanes with AVX2
/// ([`crate::camera::Perspective::ray_lanes`], bit for bit its `generate_ray`; it draws no lens
/// sample), every other camera and the tail through `Camera::sample_ray` per path.
fn camera_rays(scene: &Scene, kernels: &Kernels, batch: &mut Batch) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let (Some(avx), crate::camera::Camera::Perspective(c)) = (kernels.avx, &scene.camera) {
        let (pos, rays) = (&batch.pos, &mut batch.ray);
        avx.run(
            #[inline(always)]
            || {
                let o = c.position();
                let (ox, oy, oz) = (avx.splat(o.x), avx.splat(o.y), avx.splat(o.z));
                for pos in pos.chunks_exact(8) {
                    let pos: &[Vec2; 8] = pos.try_into().expect("8 positions");
                    let [x, y] = avx.vec2_columns(pos);
                    let (d, tmin, tmax) = c.ray_lanes(x, y);
                    // The 8 rays whole from their fields (a transpose and 8 row stores, not
                    // 64 scalar moves), then one capacity check.
                    let r = avx.ray_rows([ox, oy, oz, d.x, d.y, d.z, tmin, tmax]);
                    rays.extend_from_slice(&r);
                }
            },
        );
        done = batch.ray.len();
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = kernels;
    for j in done..batch.pos.len() {
        let ray = scene
            .camera
            .sample_ray(batch.pos[j], &mut batch.sampler.at(j));
        batch.ray.push(ray);
    }
}

/// The splat: every path's radiance (0 for a non-finite one, counted in `invalid`) to the
/// block in the canonical order, 8 samples at a time through [`Block::put8_finite_rows`] with
/// AVX2 (the same sums as [`Block::put`] one by one, which takes the rest).
fn splat(block: &mut Block, batch: &Batch, kernels: &Kernels, invalid: &mut u64) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = kernels.avx {
        // The finiteness test and the zeroing in lanes too (`Block::put8_finite_rows`).
        let chunks = batch.pos.chunks_exact(8).zip(batch.state.chunks_exact(8));
        for (pos, state) in chunks {
            let pos: &[Vec2; 8] = pos.try_into().expect("8 positions");
            // The radiance rows (radiance and depth: one 16-byte copy per path).
            let rows: [[f32; 4]; 8] = core::array::from_fn(|j| state[j].result_row());
            *invalid += block.put8_finite_rows(avx, pos, &rows) as u64;
            done += 8;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = kernels;
    for i in done..batch.len() {
        let l = batch.state[i].result;
        let v = if crate::spectrum::is_finite(l) {
            l
        } else {
            *invalid += 1;
            Spectrum::ZERO
        };
        block.put(batch.pos[i], v);
    }
}

/// Runs every path of `batch` to its end, bounce by bounce.
fn run_batch(
    scene: &Scene,
    cfg: &PathSettings,
    batch: &mut Batch,
    scratch: &mut Scratch,
    packets: Packets,
    kernels: &Kernels,
) {
    scratch.rays.counters.lanes.batches += 1;
    if cfg.max_depth == 0 {
        return;
    }
    batch.active.clear();
    batch.active.extend(0..batch.len() as u32);
    let mut kind = RayKind::Camera;
    while !batch.active.is_empty() {
        let packet = match kind {
            RayKind::Camera => packets.camera,
            RayKind::Bounce => packets.bounce,
        };
        trace(
            scene,
            batch,
            kind,
            packet.then_some(packets.stream),
            &mut scratch.rays,
        );
        kind = RayKind::Bounce;

        // The surface rows of the hits (8-wide where a shape has a lane form).
        kernels.fill_surfaces(scene, batch, &mut scratch.rays.counters.lanes);

        // Emission; the paths that scatter go on to the shading stage, each counted as
        // ending until it is shaded and goes on (a new stamp of the `alive` flags).
        batch.next_round();
        emit(scene, cfg, batch, kernels, &mut scratch.rays.counters.lanes);

        // Shading, material by material in the stable order (each material's paths grouped
        // by the kind of light they will sample, where the scene's selection splits by kind).
        let (avx, split) = kernels.sort_key();
        batch.sort_by_material(avx, split);
        shade(
            scene,
            cfg,
            batch,
            scratch,
            kernels,
            &mut kernels::tail::PathTail { cfg },
        );

        shadows(
            scene,
            batch,
            packets.shadow.then_some(packets.stream),
            &mut scratch.rays,
        );

        #[cfg(target_arch = "x86_64")]
        match kernels.avx {
            Some(avx) => batch.compact_x8(avx),
            None => batch.compact(),
        }
        #[cfg(not(target_arch = "x86_64"))]
        batch.compact();
    }
}

/// The emission stage: what each active path's ray sees, added to its radiance (8 paths at a
/// time in lanes with AVX2, [`emission`]; else, and for what the lanes do not cover, lane by
/// lane through [`crate::integrator::path::PathState::add_emission`]); the paths that scatter
/// at their hit are listed in `batch.scatter` (ascending) with their materials
/// (`batch.scatter_material`).
fn emit(
    scene: &Scene,
    cfg: &PathSettings,
    batch: &mut Batch,
    kernels: &Kernels,
    lanes: &mut LaneCounters,
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = kernels.avx {
        let lights = &kernels.emission;
        let c = avx.run(
            #[inline(always)]
            || emission::x8::stage(avx, scene, cfg, lights, batch),
        );
        lanes.emission_lanes += c.lanes;
        lanes.emission_env_lanes += c.env_map;
        lanes.emission_sphere_lanes += c.sphere;
        return;
    }
    let _ = (kernels, lanes);
    batch.clear_scatter();
    for r in 0..batch.active.len() {
        let i = batch.active[r] as usize;
        let ray = &batch.ray[i];
        let si = batch.hit[i].is_hit().then(|| batch.surf.get(i));
        if batch.state[i].add_emission(cfg, scene, ray, si.as_ref()) {
            if let Some(si) = si {
                batch.push_scatter(i as u32, scene.shape_material[si.shape as usize]);
            }
        }
    }
}

/// The shading stage: each run of one material in `batch.sorted` through its 8-wide kernel 8
/// paths at a time where it has one, the rest (and every other material) lane by lane; each
/// vertex ends in `tail` (the integrator's). `cfg`'s strategy says where the kernels take a
/// light sample.
fn shade<T: kernels::tail::Tail>(
    scene: &Scene,
    cfg: &PathSettings,
    batch: &mut Batch,
    scratch: &mut Scratch,
    kernels: &Kernels,
    tail: &mut T,
) {
    // The light gathers of the diffuse and wrapper-chain kernels, one per width for the whole
    // render (not one per run or stage: each builds the scene's light selection once), kept
    // in the batch and moved out for the stage (two pointers).
    let mut gathers = core::mem::take(&mut batch.gathers);
    let mut start = 0;
    // The runs' materials in the runs' order (`Batch::sort_by_material`).
    let mut run = 0;
    while start < batch.sorted.len() {
        let m = batch.run_materials[run];
        run += 1;
        let end = batch.run_end(m);
        let (done, driver) = if tail.kernels() {
            shade_kernel(
                scene,
                cfg,
                batch,
                start..end,
                kernels,
                m,
                &mut scratch.arena,
                &mut gathers,
                tail,
            )
        } else {
            (0, false)
        };
        let lanes = &mut scratch.rays.counters.lanes;
        lanes.shade_used += (end - start) as u64;
        lanes.shade_slots += slots(end - start);
        lanes.kernel_lanes += done as u64;
        if driver {
            lanes.conductor_lanes += done as u64;
        }
        match kernels.kinds.get(m as usize) {
            Some(Some(Kernel::Mnm)) => lanes.mnm_lanes += done as u64,
            Some(Some(Kernel::Blend(_))) => lanes.blend_lanes += done as u64,
            _ => {}
        }
        if kernels.sixteen_wide(m) {
            lanes.kernel_lanes_16 += (done / 16 * 16) as u64;
        }
        for (a, b) in lanes.kernel_lights.iter_mut().zip(&mut batch.light_lanes) {
            *a += std::mem::take(b);
        }
        for k in start + done..end {
            let i = batch.sorted[k] as usize;
            tail.scalar(scene, batch, i, &mut scratch.arena);
        }
        start = end;
    }
    batch.gathers = gathers;
}

/// Shades the first multiple of 8 paths of the run `batch.sorted[run]` (material `m`) with
/// `m`'s 8-wide kernel; returns how many it shaded (0 without a kernel or AVX2) and whether the
/// wrapper-chain driver shaded them. Each vertex ends in `tail`. `gathers`: the stage's light
/// gathers of width 8 and 16 (the diffuse and wrapper-chain kernels'), made when first needed.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
fn shade_kernel<T: kernels::tail::Tail>(
    scene: &Scene,
    cfg: &PathSettings,
    batch: &mut Batch,
    run: std::ops::Range<usize>,
    kernels: &Kernels,
    m: crate::material::MatId,
    arena: &mut crate::bsdf::BsdfArena,
    gathers: &mut batch::Gathers,
    tail: &mut T,
) -> (usize, bool) {
    let (Some(avx), Some(&Some(kind))) = (kernels.avx, kernels.kinds.get(m as usize)) else {
        return (0, false);
    };
    let n = run.len() / 8 * 8;
    // The conductor, diffuse, plastic and microfacet normal map kernels also take a run's
    // last `PAD_MIN` to 7 paths, as one padded chunk (`kernels::vertex::x8::padded`).
    let pad_min = kernels::vertex::x8::PAD_MIN;
    let pads = matches!(
        kind,
        Kernel::Conductor(_) | Kernel::Diffuse(..) | Kernel::Plastic(_) | Kernel::Mnm
    );
    if n == 0 && !(pads && run.len() >= pad_min) {
        return (0, false);
    }
    let chunks = (run.start..run.start + n).step_by(8);
    match kind {
        Kernel::Diffuse(tex, smooth) => {
            use kernels::diffuse::x8;
            let mat = x8::Material {
                reflectance: &scene.materials.textures[tex as usize],
                smooth,
                lights: &kernels.lights,
            };
            // 16 paths at a time where AVX-512 is on, then 8 (the same functions at both
            // widths, so the same numbers: only the chunking differs), then the rest padded.
            use kernels::vertex::x8::Chunks;
            let mut c = run.start;
            if let Some(w16) = kernels.avx512 {
                let mut chunks = Chunks::<16>::new(c..run.end, usize::MAX);
                let g16 = gathers
                    .1
                    .get_or_insert_with(|| Box::new(kernels::light::x8::Gather::new()));
                w16.run(
                    #[inline(always)]
                    || {
                        while let Some((ids, live)) = chunks.next(&batch.sorted) {
                            x8::shade(w16, scene, cfg, batch, &ids, live, mat, g16, tail);
                        }
                    },
                );
                c = chunks.at();
            }
            let mut chunks = Chunks::<8>::new(c..run.end, pad_min);
            let g8 = gathers
                .0
                .get_or_insert_with(|| Box::new(kernels::light::x8::Gather::new()));
            avx.run(
                #[inline(always)]
                || {
                    while let Some((ids, live)) = chunks.next(&batch.sorted) {
                        x8::shade(avx, scene, cfg, batch, &ids, live, mat, g8, tail);
                    }
                },
            );
            (chunks.at() - run.start, false)
        }
        Kernel::Conductor(mat) => {
            use kernels::vertex::x8;
            let lights = &kernels.lights;
            let mut c = run.start;
            if let Some(w16) = kernels.avx512 {
                let r = c..run.end;
                let g16 = gathers
                    .1
                    .get_or_insert_with(|| Box::new(kernels::light::x8::Gather::new()));
                c = w16.run(
                    #[inline(always)]
                    || {
                        let max = usize::MAX;
                        x8::shade_run(w16, scene, cfg, batch, r, max, &mat, lights, g16, tail)
                    },
                );
            }
            let r = c..run.end;
            let g8 = gathers
                .0
                .get_or_insert_with(|| Box::new(kernels::light::x8::Gather::new()));
            c = avx.run(
                #[inline(always)]
                || x8::shade_run(avx, scene, cfg, batch, r, pad_min, &mat, lights, g8, tail),
            );
            (c - run.start, true)
        }
        Kernel::Plastic(mat) => {
            use kernels::plastic::x8;
            let lights = &kernels.lights;
            let mut c = run.start;
            if let Some(w16) = kernels.avx512 {
                let r = c..run.end;
                c += x8::shade_run(w16, scene, cfg, batch, r, usize::MAX, mat, lights, tail);
            }
            c += x8::shade_run(
                avx,
                scene,
                cfg,
                batch,
                c..run.end,
                pad_min,
                mat,
                lights,
                tail,
            );
            (c - run.start, false)
        }
        Kernel::Blend(mat) => {
            use kernels::blend::x8;
            avx.run(
                #[inline(always)]
                || x8::shade_run(avx, scene, cfg, batch, chunks, &mat, &kernels.lights, tail),
            );
            (n, false)
        }
        Kernel::Mnm => {
            use kernels::mnm::x8;
            let mut chunks = kernels::vertex::x8::Chunks::<8>::new(run.clone(), pad_min);
            // The walk's light-sample queries' arrays, once for the render (`Batch::gathers`).
            let walk_evals = gathers.2.get_or_insert_with(Default::default);
            avx.run(
                #[inline(always)]
                || {
                    let mut gather = kernels::light::x8::Gather::new();
                    while let Some((ids, live)) = chunks.next(&batch.sorted) {
                        let lights = &kernels.lights;
                        x8::shade(
                            avx,
                            scene,
                            cfg,
                            batch,
                            m,
                            &ids,
                            live,
                            lights,
                            &mut gather,
                            walk_evals,
                            arena,
                            tail,
                        );
                    }
                },
            );
            (chunks.at() - run.start, false)
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[allow(clippy::too_many_arguments)]
fn shade_kernel<T: kernels::tail::Tail>(
    _: &Scene,
    _: &PathSettings,
    _: &mut Batch,
    _: std::ops::Range<usize>,
    _: &Kernels,
    _: crate::material::MatId,
    _: &mut crate::bsdf::BsdfArena,
    _: &mut (),
    _: &mut T,
) -> (usize, bool) {
    (0, false)
}

/// Traces the pending light samples' shadow rays (`batch.shadow_rays`, in the order the
/// shading stage appended them) and adds the samples that nothing blocks; one by one, or
/// grouped when `packet` is `Some(stream)`: as 8-wide packets of consecutive pending rays
/// (16-wide where [`Rays::packets16`] says so), or (`stream`) as one Embree stream. Each ray's
/// answer is the one it gets alone (`tests/scene/packets.rs`) and a path has at most one
/// pending sample, so the grouping and the order leave every path's radiance as the scalar
/// renderer's. Empties the pending samples.
fn shadows(scene: &Scene, batch: &mut Batch, packet: Option<bool>, rays: &mut Rays) {
    let n = batch.pending_lights;
    rays.counters.lanes.shadow_used += n as u64;
    rays.counters.lanes.shadow_slots += slots(n);
    let (shadow, adds) = (&batch.shadow_rays[..n], &batch.shadow_adds[..n]);
    let state = &mut batch.state;
    match packet {
        Some(true) => rays.occluded_stream(scene, shadow.iter(), false, |k, blocked| {
            if !blocked {
                add_light(state, &adds[k]);
            }
        }),
        Some(false) if rays.packets16() => shadow_packets::<16>(shadow, adds, state, |p| {
            u32::from(rays.occluded16(scene, p))
        }),
        Some(false) => {
            shadow_packets::<8>(shadow, adds, state, |p| u32::from(rays.occluded8(scene, p)))
        }
        None => {
            for (r, a) in shadow.iter().zip(adds) {
                if !rays.occluded(scene, r) {
                    add_light(state, a);
                }
            }
        }
    }
    batch.clear_lights();
}

/// `PathState::add_light` of a pending sample: its path's radiance gains its contribution.
#[inline(always)]
fn add_light(state: &mut [crate::integrator::path::PathState], a: &batch::PendingAdd) {
    state[a.path as usize].add_unblocked(a.contribution);
}

/// [`shadows`] as packets of `N` consecutive pending rays (the last one shorter), each traced
/// by `occluded` (bit `k` set when ray `k` is blocked) straight from the pending rays' list.
#[inline(always)]
fn shadow_packets<const N: usize>(
    shadow: &[Ray],
    adds: &[batch::PendingAdd],
    state: &mut [crate::integrator::path::PathState],
    mut occluded: impl FnMut(&[Ray]) -> u32,
) {
    for (p, a) in shadow.chunks(N).zip(adds.chunks(N)) {
        let blocked = occluded(p);
        for (k, a) in a.iter().enumerate() {
            if blocked >> k & 1 == 0 {
                add_light(state, a);
            }
        }
    }
}

/// Traces the rays of the active paths into `batch.hit`, one at a time or grouped when
/// `packet` is `Some(stream)`: 8-wide packets of consecutive active paths (coherent for camera
/// rays: samples of one pixel; 16-wide where [`Rays::packets16`] says so, tier A on AVX-512: the
/// same hits), or (`stream`, bounce rays) one Embree stream.
fn trace(scene: &Scene, batch: &mut Batch, kind: RayKind, packet: Option<bool>, rays: &mut Rays) {
    rays.counters.lanes.bounces += 1;
    rays.counters.lanes.trace_used += batch.active.len() as u64;
    rays.counters.lanes.trace_slots += slots(batch.active.len());
    // Camera rays go as coherent 8-wide packets in either case: as one coherent stream they
    // cost more (million.xml: +8 % of the trace's instructions).
    if let (Some(true), RayKind::Bounce) = (packet, kind) {
        let (active, hit) = (&batch.active, &mut batch.hit);
        // The ray column as a slice moved into the map: captured as `&Vec`, its pointer and
        // length were reloaded from the batch for each ray of the stream's fill.
        let ray: &[Ray] = &batch.ray;
        let traced = active.iter().map(move |&i| &ray[i as usize]);
        rays.intersect_stream_into(scene, traced, kind, false, active, hit);
    } else if packet.is_some() && rays.packets16() {
        // 16-ray packets (tier A on AVX-512), read from and written to the path columns as
        // the 8-wide ones below.
        let (active, ray, hit) = (&batch.active, &batch.ray, &mut batch.hit);
        for chunk in active.chunks(16) {
            let ray = |k: usize| &ray[chunk[k] as usize];
            rays.intersect16_with(scene, chunk.len(), kind, ray, |k, h| {
                hit[chunk[k] as usize] = h;
            });
        }
    } else if packet.is_some() {
        // Each packet's rays read from, and its hits written to, the path columns directly
        // (Embree's packet, or tier A's rows loaded in place and its hits' rows built in
        // lanes).
        let (active, ray, hit) = (&batch.active, &batch.ray, &mut batch.hit);
        // Every path active (the camera rays): `active` is ascending and distinct, so as
        // long as the batch it is 0, 1, … in order, and its full packets of 8 read their rays
        // from, and store their hits' rows into, the columns' own 8 consecutive entries.
        let whole = if active.len() == ray.len() {
            ray.len().min(hit.len()) / 8 * 8
        } else {
            0
        };
        for (r, h) in ray[..whole]
            .chunks_exact(8)
            .zip(hit[..whole].chunks_exact_mut(8))
        {
            let r: &[Ray; 8] = r.try_into().expect("8 rays");
            let h: &mut [HitRow; 8] = h.try_into().expect("8 rows");
            rays.intersect8_rows(scene, kind, r, h);
        }
        for chunk in active[whole..].chunks(8) {
            rays.intersect8_scatter(scene, kind, chunk, ray, hit);
        }
    } else {
        for &i in &batch.active {
            let i = i as usize;
            batch.hit[i] = HitRow::new(rays.intersect_hit(scene, &batch.ray[i], kind));
        }
    }
}

/// Whether [`trace`] and [`shadow_packets`] send 16-ray packets ([`Rays::set_packets16`]): the
/// lanes may be 16 wide (the AVX-512 token of [`Kernels`], which [`Kernels::LANES`] caps) and
/// the scene's accelerator traces 16 rays as one packet (tier A on AVX-512; Embree keeps 8).
fn packets16(scene: &Scene, kernels: &Kernels) -> bool {
    #[cfg(target_arch = "x86_64")]
    return kernels.avx512.is_some() && scene.accel.packets16();
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (scene, kernels);
        false
    }
}
