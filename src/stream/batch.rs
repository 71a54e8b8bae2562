//! A batch of paths in structure-of-arrays form, allocated once per worker and reused for every
//! batch it renders (no allocation per ray), with the two list operations of the scheduler: the
//! stable counting sort of the active paths by material and the stable compaction; the surface
//! interactions of the paths that scatter as columns ([`Surfaces`]).

use super::BATCH;
use crate::accel::HitRow;
use crate::geometry::{Ray, SurfaceInteraction};
use crate::integrator::path::PathState;
use crate::material::MatId;
use crate::math::Frame;
use crate::sampler::{Sampler, SamplerDesc, Samplers, WHOLE_DS, WHOLE_DX};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// The AVX2 token of the 8-wide set-up (none on other architectures).
#[cfg(target_arch = "x86_64")]
type Avx = crate::lane::Avx2;
#[cfg(not(target_arch = "x86_64"))]
type Avx = core::convert::Infallible;

/// The per-path arrays of one batch, indexed by the path's position in the batch (its place in
/// the block's canonical (y, x, sample) order), and the lists of path ids the stages walk.
pub(crate) struct Batch {
    /// Film position of each path's camera sample.
    pub pos: Vec<Vec2>,
    /// Each path's random stream, keyed by (seed, pixel, sample) as in the scalar renderer, as
    /// columns (the PCG32 states read and written 8-wide by the kernels' draws).
    pub sampler: Samplers,
    pub state: Vec<PathState>,
    /// The ray each path traces next.
    pub ray: Vec<Ray>,
    /// What the last trace found, one 32-byte row per path ([`HitRow`]: tier A's packets
    /// write it in lanes).
    pub hit: Vec<HitRow>,
    /// Whether the last trace hit, as a column: 1 where it did, 0 where the ray escaped.
    /// Written for every active path by the gather stage (`kernels::surface::fill`, which
    /// walks the hits), so that the emission stage's first pass reads 8 paths' flags with one
    /// gather (`emission::x8`).
    pub hit_flag: Vec<u32>,
    /// The surface each path scatters at (set by the emission stage for the paths that go on).
    pub surf: Surfaces,
    /// Whether the path goes on after the shading stage, as a stamp: the path goes on when its
    /// entry equals [`Self::round`] (the shading stage writes `round` for the paths that go
    /// on; the entries of the others are older rounds), so no stage clears the flags.
    pub alive: Vec<u32>,
    /// The stamp of the current bounce's `alive` flags ([`Self::next_round`]): it only grows
    /// over the batch buffers' life, so every older entry of `alive` is below it.
    pub round: u32,
    /// The material of each run of `sorted`, in order (written by the sort: the runs'
    /// driver reads it).
    pub run_materials: Vec<MatId>,
    /// Ids of the paths to trace, ascending.
    pub active: Vec<u32>,
    /// Ids of the paths that scatter at this bounce, ascending (before the sort).
    pub scatter: Ids,
    /// The materials of `scatter`'s paths, in its order (the sort key, appended with each id:
    /// [`Self::push_scatter`], or by the emission stage's first pass in lanes).
    pub scatter_material: Ids,
    /// The emission stage's lists of the paths whose ray shows emission (ascending): escaped
    /// rays, hits on area lights of constant radiance (both in lanes), and the paths that go
    /// through `PathState::add_emission` one by one ([`crate::stream::emission`]).
    pub escaped: Ids,
    pub on_lights: Ids,
    pub one_by_one: Ids,
    /// `scatter` stably sorted by material.
    pub sorted: Vec<u32>,
    /// The shadow rays of the light samples pending at this bounce (the first
    /// `pending_lights`), in the order the shading stage met them (material by material),
    /// each beside its path and contribution in `shadow_adds` ([`Self::push_light`], or a
    /// kernel's chunk at once): the shadow stage traces them as they lie, with no walk over
    /// the scattering paths and no copy into a packet. Fixed at [`BATCH`] + [`LIGHT_SLACK`]
    /// entries, so that a chunk of up to 16 lanes may write a row in every lane past the
    /// pending ones and keep only the passing ones (no per-lane test, no growth check).
    pub shadow_rays: Box<[Ray]>,
    /// Per entry of `shadow_rays`: the path and the contribution its radiance gains when
    /// nothing blocks the ray.
    pub shadow_adds: Box<[PendingAdd]>,
    /// How many entries of `shadow_rays` and `shadow_adds` are pending samples.
    pub pending_lights: usize,
    /// Counting-sort bins: one per material id, plus one. After a sort that binned
    /// (`binned`), `bins[m]` is the end of material `m`'s run in `sorted`.
    bins: Vec<u32>,
    /// Whether the last sort went through the bins (else `sorted` is one material's run).
    binned: bool,
    /// The ids of a run at or above the light split while [`Self::split_runs`] partitions it.
    split_hi: Box<[u32; BATCH + 8]>,
    /// Light points the 8-wide kernels sampled in lanes since the shading stage last took
    /// them, per kind (`LaneCounters::kernel_lights`).
    pub light_lanes: [u64; crate::stream::kernels::light::KINDS],
    /// The shading stage's light gathers of width 8 and 16 (the diffuse and wrapper-chain
    /// kernels'), made at the first run that takes one and kept for every later stage and
    /// batch of the render (a batch serves one scene): made per stage, their ~2 KB of columns
    /// cleared and the scene's light selection built cost ~0.9 M instructions on
    /// metal_plastic at 2 spp (~12 a sample). With them, made the same way, the microfacet
    /// normal map kernel's arrays of the random walk's light-sample queries
    /// (`walk_pdf_lanes::WalkEvalsBuf`, ~3.4 KB, reset per chunk).
    pub gathers: Gathers,
}

/// The entries of [`Batch::shadow_rays`] past [`BATCH`]: room for a chunk of the widest
/// kernels (16 lanes) to write every lane after the pending samples.
pub(crate) const LIGHT_SLACK: usize = 16;

/// A pending light sample's path and contribution, beside its shadow ray in
/// [`Batch::shadow_rays`] (16 bytes: the shadow stage reads one per ray it traces; in this
/// order, so that the kernels' transposed rows of (path, contribution) store whole).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct PendingAdd {
    pub path: u32,
    pub contribution: Spectrum,
}

/// [`Batch::gathers`]' type (nothing off x86-64, where no kernel runs).
#[cfg(target_arch = "x86_64")]
pub(crate) type Gathers = (
    Option<Box<crate::stream::kernels::light::x8::Gather<8>>>,
    Option<Box<crate::stream::kernels::light::x8::Gather<16>>>,
    Option<Box<crate::bsdf::mnm::walk_pdf_lanes::WalkEvalsBuf>>,
);
#[cfg(not(target_arch = "x86_64"))]
pub(crate) type Gathers = ();

/// Every state of `state` a path leaving the camera, four at a time as one block
/// ([`Batch::start`]).
#[inline(always)]
fn fresh_states(state: &mut [PathState]) {
    const FRESH4: [PathState; 4] = [PathState::NEW; 4];
    let (blocks, rest) = state.as_chunks_mut::<4>();
    for b in blocks {
        *b = FRESH4;
    }
    rest.fill(PathState::NEW);
}

/// At most this many materials are counted one material at a time over the whole list, 8
/// lanes at a time ([`count_materials`]).
const FEW_MATERIALS: usize = 8;

/// The counting sort's counts: `bins[m + 1]` = how many of `mats` are material `m`, `bins[0]`
/// = 0 (`bins` holds one entry per material, plus one). With `avx` and at most
/// [`FEW_MATERIALS`] materials, one pass over `mats` per material, each a compare and a
/// subtract per 8 materials (which the compiler vectorises under the AVX2 token): on
/// metal_plastic (4 materials) the one increment per path through its bin (a load, a bounds
/// test and a read-modify-write, ~4.5 instructions a path) cost more than the four passes.
#[inline(always)]
fn count_materials(avx: Option<Avx>, mats: &[MatId], bins: &mut [u32]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = avx.filter(|_| bins.len() <= FEW_MATERIALS + 1) {
        return avx.run(
            #[inline(always)]
            || {
                bins[0] = 0;
                for (k, b) in bins[1..].iter_mut().enumerate() {
                    let mut c = 0u32;
                    for &m in mats {
                        c += (m == k as MatId) as u32;
                    }
                    *b = c;
                }
            },
        );
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = avx;
    bins.fill(0);
    for &m in mats {
        bins[m as usize + 1] += 1;
    }
}

/// [`Batch::run_end`] from the sort's parts (`binned`, `bins` and the number `n` of sorted
/// paths), for the walks that hold `sorted` mutably ([`Batch::split_runs`]).
#[inline(always)]
fn run_end_of(binned: bool, bins: &[u32], n: usize, m: MatId) -> usize {
    if binned {
        bins[m as usize] as usize
    } else {
        n
    }
}

impl Batch {
    /// Buffers for batches of up to `capacity` (at most [`BATCH`]) paths over materials
    /// `0..materials`.
    pub fn new(capacity: usize, materials: usize) -> Batch {
        assert!(capacity <= BATCH, "a batch holds at most {BATCH} paths");
        Batch {
            pos: Vec::with_capacity(capacity),
            sampler: Samplers::with_capacity(capacity),
            state: Vec::with_capacity(capacity),
            ray: Vec::with_capacity(capacity),
            hit: Vec::with_capacity(capacity),
            hit_flag: Vec::with_capacity(capacity),
            surf: Surfaces::new(),
            alive: Vec::with_capacity(capacity),
            round: 0,
            run_materials: Vec::with_capacity(materials.max(1)),
            active: Vec::with_capacity(capacity),
            scatter: Ids::new(),
            scatter_material: Ids::new(),
            escaped: Ids::new(),
            on_lights: Ids::new(),
            one_by_one: Ids::new(),
            sorted: Vec::with_capacity(capacity),
            shadow_rays: vec![Ray::new(Vec3::ZERO, Vec3::Z); BATCH + LIGHT_SLACK].into(),
            shadow_adds: vec![
                PendingAdd {
                    path: 0,
                    contribution: Spectrum::ZERO,
                };
                BATCH + LIGHT_SLACK
            ]
            .into(),
            pending_lights: 0,
            bins: vec![0; materials + 1],
            binned: false,
            split_hi: Box::new([0; BATCH + 8]),
            light_lanes: [0; crate::stream::kernels::light::KINDS],
            gathers: Default::default(),
        }
    }

    /// Empties the batch (capacities are kept). `state`, `hit`, `hit_flag` and `alive` keep
    /// their contents: [`Self::start`] overwrites the states and only sizes the others (see
    /// there).
    pub fn clear(&mut self) {
        self.pos.clear();
        self.sampler.clear();
        self.ray.clear();
        self.active.clear();
        self.scatter.clear();
        self.scatter_material.clear();
        self.escaped.clear();
        self.on_lights.clear();
        self.one_by_one.clear();
        self.sorted.clear();
        self.clear_lights();
    }

    /// Fills `pos` and `sampler` with paths `k..end` (at most [`BATCH`]) of a block: the pixels
    /// of `rect` (x0, y0, width, height) of a film `film_width` pixels wide, each with the samples
    /// `samples` (lo..hi), in the canonical (y, x, sample) order; each path's stream is
    /// `Sampler::for_sample` of its (pixel, sample) and its film position the pixel's corner plus
    /// the stream's first 2-D draw. With `avx`, 8 paths' streams at a time in lanes
    /// (`sampler::for_samples_x8`, bit for bit the same streams).
    #[allow(clippy::too_many_arguments)]
    pub fn fill(
        &mut self,
        desc: &SamplerDesc,
        film_width: u32,
        rect: (u32, u32, u32, u32),
        samples: (u32, u32),
        k: u64,
        end: u64,
        avx: Option<Avx>,
    ) {
        assert!(
            end >= k && end - k <= BATCH as u64,
            "a batch holds at most {BATCH} paths"
        );
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = avx {
            return avx.run(
                #[inline(always)]
                || self.fill_with(desc, film_width, rect, samples, k, end, Some(avx)),
            );
        }
        self.fill_with(desc, film_width, rect, samples, k, end, None);
    }

    /// [`Self::fill`]'s loop, with or without lanes.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn fill_with(
        &mut self,
        desc: &SamplerDesc,
        film_width: u32,
        rect: (u32, u32, u32, u32),
        samples: (u32, u32),
        k: u64,
        end: u64,
        avx: Option<Avx>,
    ) {
        let (x0, y0, w, _) = rect;
        let (s_lo, s_hi) = samples;
        let spp = s_hi.saturating_sub(s_lo) as u64;
        // (pixel, sample) advanced from the batch's first path (one division per batch).
        let p = k / spp;
        let (mut s, mut x, mut y) = (
            s_lo + (k % spp) as u32,
            x0 + (p % w as u64) as u32,
            y0 + (p / w as u64) as u32,
        );
        let mut left = (end - k) as usize;
        while left > 0 {
            let m = left.min(8);
            // The pixels' corners as x and y columns (added to the first draws in lanes).
            let (mut pixel, mut sample) = ([0u64; 8], [0u32; 8]);
            let (mut cx, mut cy) = ([0.0f32; 8], [y as f32; 8]);
            if m == 8 && s_hi - s >= 8 {
                // Eight samples of one pixel (every chunk at 8 or more samples per pixel, a
                // multiple of 8): no per-path stepping.
                pixel = [y as u64 * film_width as u64 + x as u64; 8];
                cx = [x as f32; 8];
                for (j, sj) in sample.iter_mut().enumerate() {
                    *sj = s + j as u32;
                }
                advance((&mut s, &mut x, &mut y), 8, samples, (x0, w));
            } else if let Some(sh) = whole_pixels(m, s, samples, x, x0 + w) {
                // 8 / spp whole pixels of one row (spp 1, 2 or 4, the chunk starting at a
                // pixel's first sample): path j is sample j mod spp of the row's pixel x + j / spp,
                // so no per-path stepping either. With the lanes, the paths' pixels, samples and
                // corners are made in registers from the steps' tables and the chunk's streams
                // set up from them (`for_whole_pixels_x8`: at 2 or 4 samples a pixel, one key a
                // pixel); else the steps from the tables, path by path.
                let px = y as u64 * film_width as u64 + x as u64;
                #[cfg(target_arch = "x86_64")]
                let lanes = match avx {
                    Some(avx) if x <= i32::MAX as u32 - 7 => {
                        crate::sampler::for_whole_pixels_x8(
                            avx,
                            desc,
                            (px, x, y),
                            sh,
                            s_lo,
                            &mut self.sampler,
                            &mut self.pos,
                        );
                        true
                    }
                    _ => false,
                };
                #[cfg(not(target_arch = "x86_64"))]
                let lanes = false;
                if !lanes {
                    let (dx, ds) = (&WHOLE_DX[sh as usize], &WHOLE_DS[sh as usize]);
                    for j in 0..8 {
                        pixel[j] = px + dx[j] as u64;
                        sample[j] = s_lo + ds[j] as u32;
                        cx[j] = (x + dx[j] as u32) as f32;
                    }
                }
                x += 8 >> sh;
                if x == x0 + w {
                    x = x0;
                    y += 1;
                }
                if lanes {
                    left -= 8;
                    continue;
                }
            } else {
                for j in 0..m {
                    pixel[j] = y as u64 * film_width as u64 + x as u64;
                    sample[j] = s;
                    (cx[j], cy[j]) = (x as f32, y as f32);
                    advance((&mut s, &mut x, &mut y), 1, samples, (x0, w));
                }
            }
            left -= m;
            #[cfg(target_arch = "x86_64")]
            if let (Some(avx), 8) = (avx, m) {
                // The streams' columns and the positions appended from the lanes (one
                // capacity check per column, not one per path; no copy through the stack).
                let corner = (&cx, &cy);
                crate::sampler::for_samples_x8(
                    avx,
                    desc,
                    &pixel,
                    &sample,
                    corner,
                    &mut self.sampler,
                    &mut self.pos,
                );
                continue;
            }
            #[cfg(not(target_arch = "x86_64"))]
            let _ = avx;
            for j in 0..m {
                let mut sm = Sampler::for_sample(desc, pixel[j], sample[j]);
                self.pos.push(Vec2::new(cx[j], cy[j]) + sm.next_2d());
                self.sampler.push(&sm);
            }
        }
    }

    /// Once `pos`, `sampler` and `ray` hold the batch's paths (at most [`BATCH`]), sets every
    /// path's state to a path leaving the camera (one fill, not a push per path) and sizes the
    /// other per-path arrays. Those keep what the previous batch left in them: each is written
    /// for a path before the path's stages read it in a bounce (`hit` by the trace of every
    /// active path, `hit_flag` by the gather stage for every active path and `alive` by the
    /// emission stage for every active path), so filling them would only cost a pass over
    /// ~60 KB per batch.
    ///
    /// The states are overwritten in place four at a time, as one block of the fresh state
    /// (`FRESH4`, 208 bytes: with `avx`, 32-byte stores under the lanes' target features):
    /// `clear` keeps them, so that only a batch longer than the last one appends states. On
    /// metal_plastic the fill's loop of 16-byte and scalar stores per path cost 6.5
    /// instructions a path, appending blocks of four (`extend_from_slice`: its capacity test
    /// and length each time) 4.25, the blocks in place ~2 (`docs/bench/README.md`,
    /// thirty-third session, h1).
    pub fn start(&mut self, avx: Option<Avx>) {
        let n = self.pos.len();
        assert!(
            n <= BATCH && self.sampler.len() == n && self.ray.len() == n,
            "a batch holds at most {BATCH} paths, each with its stream and ray"
        );
        self.state.truncate(n);
        self.state.resize(n, PathState::NEW);
        let state = &mut self.state[..];
        #[cfg(target_arch = "x86_64")]
        match avx {
            Some(avx) => avx.run(
                #[inline(always)]
                || fresh_states(state),
            ),
            None => fresh_states(state),
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = avx;
            fresh_states(state);
        }
        self.hit.resize(n, HitRow::NONE);
        self.hit_flag.resize(n, 0);
        self.alive.resize(n, 0);
    }

    /// A new stamp for the `alive` flags of the bounce about to be shaded: every path counts
    /// as ending until the shading stage marks it ([`Self::set_alive`]), with no flag cleared.
    /// When the stamps run out (after 2³² − 1 bounces) the flags are cleared once and the
    /// stamps start over.
    pub fn next_round(&mut self) {
        if self.round == u32::MAX {
            self.alive.fill(0);
            self.round = 0;
        }
        self.round += 1;
    }

    /// Marks path `i` as going on after this bounce's shading stage.
    #[inline(always)]
    pub fn set_alive(&mut self, i: usize) {
        self.alive[i] = self.round;
    }

    /// Whether path `i` goes on after this bounce's shading stage (tests; the compaction
    /// compares the stamps itself).
    #[cfg(test)]
    pub fn is_alive(&self, i: usize) -> bool {
        self.alive[i] == self.round
    }

    /// Empties the pending light samples (`shadow_rays`, `shadow_adds`) for a new shading
    /// stage.
    #[inline(always)]
    pub fn clear_lights(&mut self) {
        self.pending_lights = 0;
    }

    /// Appends path `i`'s pending light sample: its shadow ray and the contribution its
    /// radiance gains when nothing blocks it (`PendingLight`'s two fields; a path has at most
    /// one a bounce).
    #[inline(always)]
    pub fn push_light(&mut self, i: u32, shadow: Ray, contribution: Spectrum) {
        let n = self.pending_lights;
        self.shadow_rays[n] = shadow;
        self.shadow_adds[n] = PendingAdd {
            path: i,
            contribution,
        };
        self.pending_lights = n + 1;
    }

    /// Empties `scatter` and its materials (`scatter_material`) for a new emission stage.
    #[inline(always)]
    pub fn clear_scatter(&mut self) {
        self.scatter.clear();
        self.scatter_material.clear();
    }

    /// Appends path `i`, which scatters at a surface of material `m`, to `scatter`.
    #[inline(always)]
    pub fn push_scatter(&mut self, i: u32, m: MatId) {
        self.scatter.push(i);
        self.scatter_material.push(m);
    }

    /// Adds a path whose camera ray is `ray` (at most [`BATCH`] paths; tests).
    #[cfg(test)]
    pub fn push(&mut self, pos: Vec2, sampler: Sampler, ray: Ray) {
        assert!(
            self.pos.len() < BATCH,
            "a batch holds at most {BATCH} paths"
        );
        // `clear` keeps the last batch's states: the paths' own start after `pos`'s.
        self.state.truncate(self.pos.len());
        self.pos.push(pos);
        self.sampler.push(&sampler);
        self.state.push(PathState::new());
        self.ray.push(ray);
        self.hit.push(HitRow::NONE);
        self.hit_flag.push(0);
        self.alive.push(0);
    }

    /// Number of paths in the batch.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Sorts `scatter` by `material` into `sorted`, stably (a counting sort: equal materials keep
    /// their ascending path order), and lists each run's material in `run_materials`. Returns
    /// whether `sorted` holds more than one material.
    ///
    /// With `avx` (the AVX2 token) and `light` (the light selection's split by kind,
    /// `kernels::light::x8::kind_split`), each run of more than 8 paths is then partitioned
    /// stably ([`Self::split_runs`]): first its paths whose stream's next number (`u_sel`,
    /// the first number a vertex that takes a light sample draws, `kernels::draws`) is below
    /// the split, then the others. A run keeps its paths, its material and its end
    /// (`run_materials`, [`Self::run_end`]), in another order: each path is shaded by the same
    /// per-lane arithmetic whatever its chunk, and its light sample and radiance are its own
    /// (the shadow stage adds each pending sample to its path, the compaction keeps `active`
    /// ascending, the splat reads the paths in the canonical order), so the image does not
    /// change. What changes is that most chunks' lanes then sample one kind of light, and the
    /// light gather's `finish` runs only the kinds some lane picked (on metal_plastic at 16
    /// spp a chunk was one pixel's eight samples, which picked the rectangle light and the sky
    /// in nearly every chunk). The look ahead is a hint only: a stream that is not plain PCG32,
    /// or a vertex that draws no light sample, only makes the grouping worse.
    ///
    /// With `avx`, the counting sort counts the materials of a scene with few of them 8 lanes
    /// at a time ([`count_materials`]); `light` without `avx` is not used.
    pub fn sort_by_material(&mut self, avx: Option<Avx>, light: Option<f32>) -> bool {
        let many = self.sort_runs(avx);
        if let (Some(avx), Some(split)) = (avx, light) {
            self.split_runs(avx, split);
        }
        many
    }

    /// [`Self::sort_by_material`]'s counting sort.
    #[inline(always)]
    fn sort_runs(&mut self, avx: Option<Avx>) -> bool {
        self.sorted.clear();
        self.run_materials.clear();
        self.binned = false;
        let n = self.scatter.len();
        let (ids, mats) = (&self.scatter[..], &self.scatter_material[..n]);
        let Some(&m0) = mats.first() else {
            return false;
        };
        // The materials are read from their list in order (not through each path's id). Each
        // run's material is listed once (`run_materials`), not written per path: its only
        // readers are the run's driver and its kernels, which take it from the run.
        // Whether every material is the first: a branch-free compare per 16 (which the
        // compiler vectorises), the walk stopping at the first block that differs (a test
        // and a branch per material cost ~6 instructions a path on metal_plastic).
        if mats
            .chunks(16)
            .all(|c| c.iter().fold(true, |same, &m| same & (m == m0)))
        {
            self.sorted.extend_from_slice(ids);
            self.run_materials.push(m0);
            return false;
        }
        let bins = &mut self.bins[..];
        count_materials(avx, mats, bins);
        // The runs' materials in ascending order (the order of the runs in `sorted`), from
        // the counts, then the counts' prefix sums.
        for k in 1..bins.len() {
            if bins[k] != 0 {
                self.run_materials.push((k - 1) as MatId);
            }
            bins[k] += bins[k - 1];
        }
        self.sorted.resize(n, 0);
        let sorted = &mut self.sorted[..];
        for (&i, &m) in ids.iter().zip(mats) {
            let b = &mut bins[m as usize];
            sorted[*b as usize] = i;
            *b += 1;
        }
        self.binned = true;
        true
    }

    /// Partitions each run of more than 8 paths of `sorted` stably by the side of `split` its
    /// paths' next PCG32 float lies on ([`crate::lane::pcg::Pcg::peek_f32`], read from the
    /// state column without drawing: nothing drawn, no stream changed): 8 ids at a time, their
    /// floats by one gather of states, the ids below the split compressed in place to the
    /// run's front (the write position never passes the read one), the others to
    /// `split_hi` and copied after them; a run's last `len % 8` ids one by one.
    #[cfg(target_arch = "x86_64")]
    fn split_runs(&mut self, avx: Avx, split: f32) {
        use crate::lane::{pcg::Pcg, F32x8, Lane};
        let states = self.sampler.states();
        let (binned, bins, n) = (self.binned, &self.bins, self.sorted.len());
        let (sorted, hi) = (&mut self.sorted[..], &mut self.split_hi[..]);
        avx.run(
            #[inline(always)]
            || {
                let t = avx.splat(split);
                let mut start = 0;
                for &m in &self.run_materials {
                    let end = run_end_of(binned, bins, n, m);
                    let run = &mut sorted[start..end];
                    start = end;
                    if run.len() <= 8 {
                        continue;
                    }
                    let (mut lo, mut h, mut r) = (0, 0, 0);
                    while r + 8 <= run.len() {
                        let ids: &[u32; 8] = run[r..r + 8].try_into().expect("8 ids");
                        let idv = avx.load_u32(ids);
                        let up = Pcg::<F32x8>::peek_f32(states, idv).ge(t);
                        h = avx.compress_store(idv, up, hi, h);
                        lo = avx.compress_store(idv, !up, run, lo);
                        r += 8;
                    }
                    for r in r..run.len() {
                        let i = run[r];
                        let mut rng = crate::math::rng::Pcg32::from_parts(states[i as usize], 0);
                        let up = rng.next_f32() >= split;
                        (run[lo], hi[h]) = (i, i);
                        lo += !up as usize;
                        h += up as usize;
                    }
                    run[lo..].copy_from_slice(&hi[..h]);
                }
            },
        );
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn split_runs(&mut self, avx: Avx, _: f32) {
        match avx {}
    }

    /// The end in `sorted` of the run of material `m` (the material of the path at the run's
    /// start) after [`Self::sort_by_material`]: where the sort's bins left it, without walking
    /// the run.
    #[inline]
    pub fn run_end(&self, m: MatId) -> usize {
        run_end_of(self.binned, &self.bins, self.sorted.len(), m)
    }

    /// Keeps in `active` the paths still alive, in ascending order (stable compaction).
    pub fn compact(&mut self) {
        compact_from(&mut self.active, &self.alive, self.round, 0, 0);
    }

    /// [`Self::compact`] 8 ids at a time with AVX2: each chunk's `alive` stamps by one gather
    /// ([`crate::lane::LaneI32::gather_u32`]) compared with the round's, and its kept ids
    /// appended by one compress
    /// ([`crate::lane::Avx2::compress_store`]: its 8 stores never pass the chunk, which is
    /// already read); the last `len % 8` ids as `compact` does. The same list (the path-by-path
    /// pass cost ~11 instructions a path on metal_plastic).
    #[cfg(target_arch = "x86_64")]
    pub fn compact_x8(&mut self, avx: Avx) {
        use crate::lane::LaneI32;
        let (active, alive, round) = (&mut self.active, &self.alive[..], self.round);
        if alive.is_empty() {
            return self.compact();
        }
        avx.run(
            #[inline(always)]
            || {
                // The list as a slice held in a local: its pointer and length stay in
                // registers (through the vector, the compress's stores may alias its
                // fields, as far as the compiler knows, and both were reloaded and tested
                // again for every chunk).
                let ids_in = &mut active[..];
                let len = ids_in.len();
                let (mut kept, mut r) = (0, 0);
                let now = avx.load_u32(&[round; 8]);
                while r + 8 <= len {
                    let ids: &[u32; 8] = ids_in[r..r + 8].try_into().expect("8 ids");
                    let idv = avx.load_u32(ids);
                    let keep = crate::lane::I32x8::gather_u32(alive, idv).eq(now);
                    kept = avx.compress_store(idv, keep, ids_in, kept);
                    r += 8;
                }
                compact_from(active, alive, round, r, kept);
            },
        );
    }
}

/// The compaction of `active` from read position `r` and write position `kept` (`kept` ≤ `r`,
/// the ids before `kept` already kept): in place and branch-free, every id is written at the
/// write position, which advances past the alive ones only (it never passes the read
/// position); the list then ends at the write position.
#[inline(always)]
fn compact_from(active: &mut Vec<u32>, alive: &[u32], round: u32, r: usize, mut kept: usize) {
    for r in r..active.len() {
        let i = active[r];
        active[kept] = i;
        kept += (alive[i as usize] == round) as usize;
    }
    active.truncate(kept);
}

/// A list of path ids of one batch (at most [`BATCH`]) in a buffer of `BATCH` ids allocated
/// once: appending is a store and an add, and [`Ids::put`] appends without a branch (a stage
/// that keeps some of the ids it walks writes each one and advances past the kept ones), where
/// `Vec::push` tests the capacity per id (measured in the emission stage: `docs/bench/README.md`,
/// seventeenth session, h3).
pub(crate) struct Ids {
    /// Room for [`BATCH`] ids and 8 slots past them, so that an 8-lane store at any length up
    /// to `BATCH` fits ([`Ids::buf_mut`]).
    buf: Box<[u32; BATCH + 8]>,
    len: usize,
}

impl Ids {
    fn new() -> Ids {
        Ids {
            buf: vec![0; BATCH + 8]
                .into_boxed_slice()
                .try_into()
                .expect("BATCH + 8 ids"),
            len: 0,
        }
    }

    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Appends `i`.
    ///
    /// # Panics
    /// If the list holds [`BATCH`] ids.
    #[inline(always)]
    pub fn push(&mut self, i: u32) {
        self.put(i, true);
    }

    /// Appends `i` when `keep` (the slot past the end is written either way).
    ///
    /// # Panics
    /// If the list holds [`BATCH`] ids.
    #[inline(always)]
    pub fn put(&mut self, i: u32, keep: bool) {
        // The first `BATCH` slots only (the 8 past them are for `buf_mut`'s compresses): a
        // full list panics here.
        self.buf[..BATCH][self.len] = i;
        self.len += keep as usize;
    }

    /// The whole buffer, for a pass that appends to several lists with their lengths in
    /// registers (the emission stage's first pass, `emission::x8::classify`): it writes
    /// `buf[len]` itself, then sets the length with [`Ids::set_len`]. [`BATCH`] + 8 slots: a
    /// compress of 8 lanes at a length below [`BATCH`] (taken `% BATCH`) fits without a bounds
    /// test.
    #[inline(always)]
    pub fn buf_mut(&mut self) -> &mut [u32; BATCH + 8] {
        &mut self.buf
    }

    /// The list is `buf[..len]` (after appending through [`Ids::buf_mut`]).
    ///
    /// # Panics
    /// If `len` is more than [`BATCH`].
    #[inline(always)]
    pub fn set_len(&mut self, len: usize) {
        assert!(len <= BATCH, "a list holds at most {BATCH} ids");
        self.len = len;
    }
}

impl core::ops::Deref for Ids {
    type Target = [u32];
    #[inline(always)]
    fn deref(&self) -> &[u32] {
        &self.buf[..self.len]
    }
}

/// The fields of a [`Surfaces`] row: each vector takes three consecutive floats (x, y, z), named
/// by its first.
pub(crate) mod cols {
    /// The hit point.
    pub const P: usize = 0;
    /// The true normal.
    pub const NG: usize = 3;
    /// The shading frame's `s`, `t`, `n`.
    pub const S: usize = 6;
    pub const T: usize = 9;
    pub const N: usize = 12;
    /// The direction toward the previous vertex.
    pub const WI: usize = 15;
    /// uv (two floats).
    pub const UV: usize = 18;
    pub const DPDU: usize = 20;
    pub const DPDV: usize = 23;
    /// The ray distance to the hit.
    pub const DIST: usize = 26;
    /// The shape and primitive indices (their bits).
    pub const SHAPE: usize = 27;
    pub const PRIM: usize = 28;
    /// Floats per row (29 used; a row is 128 bytes).
    pub const ROW: usize = 32;
}

/// The surface interactions of the paths that scatter at this bounce, one row of
/// [`cols::ROW`] floats per path id: the emission stage writes a row ([`Self::set`], one
/// contiguous store of the interaction's fields), the 8-wide kernels load the fields they need
/// in place, one `vgatherdps` per field over 8 rows (`kernels::surface`), the 1-lane code and the
/// kernels' lane-by-lane parts rebuild the interaction ([`Self::get`]; inlined, the fields a
/// caller does not read are not loaded). A row layout rather than one array per field: the
/// emission stage writes one path at a time, and 29 stores into 29 arrays cost ~73
/// instructions per path against ~30 into one row (measured: +71 instructions per sample on
/// metal_plastic with per-field arrays). Fixed at [`BATCH`] rows (128 KB), allocated once per
/// worker.
pub(crate) struct Surfaces {
    /// Every row, flat: field `c` of path `i` is at `i · ROW + c`.
    flat: Box<[f32; BATCH * cols::ROW]>,
}

impl Surfaces {
    fn new() -> Surfaces {
        Surfaces {
            flat: vec![0.0; BATCH * cols::ROW]
                .into_boxed_slice()
                .try_into()
                .expect("BATCH rows"),
        }
    }

    /// Every row, flat: field `c` of path `i` is at `i · ROW + c`.
    #[inline(always)]
    pub fn flat(&self) -> &[f32; BATCH * cols::ROW] {
        &self.flat
    }

    /// Path `i`'s row as four groups of 8 floats, for the 8-wide gather stage's transposed
    /// stores (`kernels::surface::x8::store`, which writes the fields [`Self::set`] writes).
    /// `i` is taken modulo [`BATCH`]: a batch's path ids are below it ([`Batch::start`]
    /// asserts so), so that is `i` itself, and the row needs no bounds test (one `and` and
    /// one address, not a product and two tests per row).
    #[inline(always)]
    pub fn row_groups_mut(&mut self, i: usize) -> &mut [[f32; 8]; 4] {
        debug_assert!(i < BATCH, "path id {i} outside the batch");
        const { assert!(cols::ROW == 32) };
        let rows: &mut [[[f32; 8]; 4]] = self.flat.as_chunks_mut::<8>().0.as_chunks_mut::<4>().0;
        &mut rows[i % BATCH]
    }

    /// Stores path `i`'s interaction.
    #[inline(always)]
    pub fn set(&mut self, i: usize, si: &SurfaceInteraction) {
        let r: &mut [f32; cols::ROW] = (&mut self.flat[i * cols::ROW..(i + 1) * cols::ROW])
            .try_into()
            .expect("a row");
        let mut set3 = |c: usize, v: Vec3| {
            r[c] = v.x;
            r[c + 1] = v.y;
            r[c + 2] = v.z;
        };
        set3(cols::P, si.p);
        set3(cols::NG, si.ng);
        set3(cols::S, si.sh.s);
        set3(cols::T, si.sh.t);
        set3(cols::N, si.sh.n);
        set3(cols::WI, si.wi);
        set3(cols::DPDU, si.dpdu);
        set3(cols::DPDV, si.dpdv);
        r[cols::UV] = si.uv.x;
        r[cols::UV + 1] = si.uv.y;
        r[cols::DIST] = si.t;
        r[cols::SHAPE] = f32::from_bits(si.shape);
        r[cols::PRIM] = f32::from_bits(si.prim);
    }

    /// Path `i`'s interaction, as [`Self::set`] stored it.
    #[inline(always)]
    pub fn get(&self, i: usize) -> SurfaceInteraction {
        let r: &[f32; cols::ROW] = self.flat[i * cols::ROW..(i + 1) * cols::ROW]
            .try_into()
            .expect("a row");
        let v3 = |c: usize| Vec3::new(r[c], r[c + 1], r[c + 2]);
        SurfaceInteraction {
            p: v3(cols::P),
            t: r[cols::DIST],
            ng: v3(cols::NG),
            sh: Frame {
                s: v3(cols::S),
                t: v3(cols::T),
                n: v3(cols::N),
            },
            uv: Vec2::new(r[cols::UV], r[cols::UV + 1]),
            dpdu: v3(cols::DPDU),
            dpdv: v3(cols::DPDV),
            shape: r[cols::SHAPE].to_bits(),
            prim: r[cols::PRIM].to_bits(),
            wi: v3(cols::WI),
        }
    }
}

/// When a chunk of `m` paths whose first is sample `s` of the row's pixel `x` (`row_end`: one
/// past the block's last column) is 8 / spp whole pixels of that row, at spp = 1, 2 or 4 (its
/// first path a pixel's first sample, its pixels all in the row): log2(spp), for
/// [`Batch::fill`]'s per-pixel fill. `None` otherwise.
#[inline(always)]
fn whole_pixels(m: usize, s: u32, (s_lo, s_hi): (u32, u32), x: u32, row_end: u32) -> Option<u32> {
    let spp = s_hi.wrapping_sub(s_lo);
    let sh = match spp {
        1 => 0,
        2 => 1,
        4 => 2,
        _ => return None,
    };
    (m == 8 && s == s_lo && x + (8 >> sh) <= row_end).then_some(sh)
}

/// Moves the block's (sample, x, y) cursor on by `n` samples of one pixel (`n` no more than the
/// pixel's samples left in `samples`): after the pixel's last sample, to the next pixel of the
/// block's rows (`x0`, `w`: the block's first column and width).
#[inline(always)]
fn advance(
    (s, x, y): (&mut u32, &mut u32, &mut u32),
    n: u32,
    (s_lo, s_hi): (u32, u32),
    (x0, w): (u32, u32),
) {
    *s += n;
    if *s == s_hi {
        *s = s_lo;
        *x += 1;
        if *x == x0 + w {
            *x = x0;
            *y += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn batch(n: usize) -> Batch {
        let mut b = Batch::new(n, 8);
        for _ in 0..n {
            b.push(
                Vec2::ZERO,
                Sampler::from_seed(1, 1),
                Ray::new(Vec3::ZERO, Vec3::Z),
            );
        }
        b
    }

    /// The sort keeps each material's paths in ascending order, ends each run where its bins
    /// say, and lists each run's material in the runs' order (`run_materials`).
    #[test]
    fn the_material_sort_is_stable() {
        let mats = [3, 1, 3, 0, 1, 7, 3];
        let mut b = batch(mats.len());
        for i in [0, 1, 2, 4, 5, 6] {
            b.push_scatter(i, mats[i as usize]);
        }
        assert!(b.sort_by_material(None, None));
        assert_eq!(b.sorted, [1, 4, 0, 2, 6, 5]);
        // Each run's end, from its material.
        let ends: Vec<usize> = [1, 3, 7].iter().map(|&m| b.run_end(m)).collect();
        assert_eq!(ends, [2, 5, 6]);
        assert_eq!(b.run_materials, [1, 3, 7]);
        b.scatter.clear();
        b.scatter_material.clear();
        for i in [0, 2, 6] {
            b.push_scatter(i, mats[i as usize]);
        }
        assert!(!b.sort_by_material(None, None));
        assert_eq!(b.sorted, [0, 2, 6]);
        assert_eq!(b.run_end(3), 3);
        assert_eq!(b.run_materials, [3]);
        // A block of 16 equal materials, then another: binned, two runs.
        b.scatter.clear();
        b.scatter_material.clear();
        for i in 0..17 {
            b.push_scatter(i, if i < 16 { 0 } else { 1 });
        }
        assert!(b.sort_by_material(None, None));
        assert_eq!(b.run_materials, [0, 1]);
        assert_eq!((b.run_end(0), b.run_end(1)), (16, 17));
        // No path: no run.
        b.scatter.clear();
        b.scatter_material.clear();
        assert!(!b.sort_by_material(None, None));
        assert!(b.run_materials.is_empty());
    }

    /// With a light split, each material's run of more than 8 paths holds the same paths as
    /// without, first those whose stream's next float is below the split, then the others,
    /// each part in ascending order (a shorter run as without); the runs' materials and ends
    /// are as without, and no stream moves (over 8-wide blocks and a rest, one material and
    /// several, every path on one side, runs of 8 and fewer).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_light_split_orders_each_run_by_side() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        let n = 61;
        let mut b = Batch::new(n, 8);
        for i in 0..n as u64 {
            let s = Sampler::from_seed(7 + i, 3 * i + 1);
            b.push(Vec2::ZERO, s, Ray::new(Vec3::ZERO, Vec3::Z));
        }
        let next: Vec<f32> = (0..n).map(|i| b.sampler.get(i).next_1d()).collect();
        let states = b.sampler.states().to_vec();
        let cases: [(&[MatId], f32); 5] = [
            (&[2, 0, 5, 2], 0.5),
            (&[4], 0.3),
            (&[1, 3], 0.0),
            (&[6, 6, 0], 0.7),
            (&[6, 6, 6, 6, 6, 6, 0], 0.4),
        ];
        for (pattern, split) in cases {
            b.clear_scatter();
            let ids: Vec<u32> = (0..n as u32).filter(|i| i % 5 != 3).collect();
            let mat = |i: u32| pattern[i as usize % pattern.len()];
            for &i in &ids {
                b.push_scatter(i, mat(i));
            }
            let mut mats: Vec<MatId> = ids.iter().map(|&i| mat(i)).collect();
            mats.sort();
            mats.dedup();
            b.sort_by_material(Some(avx), Some(split));
            assert_eq!(b.run_materials, mats, "{pattern:?}");
            let mut start = 0;
            for &m in &mats {
                let side = |hi: bool| -> Vec<u32> {
                    let on = |&i: &u32| mat(i) == m && (next[i as usize] >= split) == hi;
                    ids.iter().copied().filter(on).collect()
                };
                let mut want = side(false);
                want.extend(side(true));
                if want.len() <= 8 {
                    want.sort();
                }
                let end = b.run_end(m);
                assert_eq!(
                    b.sorted[start..end],
                    want,
                    "{pattern:?} {split} material {m}"
                );
                start = end;
            }
            assert_eq!(start, ids.len());
            assert_eq!(b.sampler.states(), states);
        }
    }

    /// `start` leaves exactly the batch's paths, each a path leaving the camera, whatever the
    /// last batch left in the kept states (more of them, or fewer; changed), with and without
    /// the AVX2 token, at lengths around the blocks of four.
    #[test]
    fn start_resets_the_kept_states() {
        let fresh = format!("{:?}", PathState::new());
        let mut tokens = vec![None];
        #[cfg(target_arch = "x86_64")]
        tokens.extend(crate::lane::Avx2::detect().map(Some));
        for avx in tokens {
            for n in [0, 1, 3, 4, 5, 8, 9] {
                for kept in [0, n / 2, n, n + 3] {
                    let mut b = batch(n);
                    let mut used = PathState::new();
                    used.depth = 7;
                    used.eta = 2.5;
                    used.result = Vec3::splat(-1.0);
                    b.state.clear();
                    b.state.resize(kept, used);
                    b.start(avx);
                    assert_eq!(b.state.len(), n, "{n} paths, {kept} kept");
                    for s in &b.state {
                        assert_eq!(format!("{s:?}"), fresh, "{n} paths, {kept} kept");
                    }
                }
            }
        }
    }

    /// A path is alive only in the round it was marked in; when the stamps run out, the flags
    /// start over cleared.
    #[test]
    fn alive_stamps_last_one_round() {
        let mut b = batch(4);
        b.next_round();
        b.set_alive(1);
        assert!(b.is_alive(1) && !b.is_alive(0));
        b.next_round();
        assert!(!b.is_alive(1));
        b.set_alive(2);
        b.round = u32::MAX;
        b.set_alive(3);
        assert!(b.is_alive(3));
        b.next_round();
        assert_eq!(b.round, 1);
        assert!((0..4).all(|i| !b.is_alive(i)));
    }

    /// `put` keeps exactly the ids it is told to keep, in order, and a full list refuses more.
    #[test]
    fn id_lists_keep_what_they_are_told() {
        let mut l = Ids::new();
        for i in 0..BATCH as u32 {
            l.put(i, i % 3 != 1);
        }
        let want: Vec<u32> = (0..BATCH as u32).filter(|i| i % 3 != 1).collect();
        assert_eq!(&l[..], &want[..]);
        l.clear();
        assert!(l.is_empty());
        for i in 0..BATCH as u32 {
            l.push(i);
        }
        assert_eq!(l.len(), BATCH);
        let full = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| l.put(0, false)));
        assert!(full.is_err(), "a full list takes no more ids");
    }

    /// `fill` gives every path the stream and film position of its (pixel, sample), found
    /// here by division from its index in the block, with and without lanes: over sample
    /// counts 1 to 9 and 16 (the whole-pixel chunks of 1, 2 and 4, the one-pixel chunks of 8
    /// and 16, and the per-path stepping of the others), sample ranges that do not start at 0,
    /// blocks whose rows end inside a chunk, and batches that start mid-pixel.
    #[test]
    fn fill_gives_each_path_its_pixel_and_sample() {
        use crate::sampler::SamplerKind;
        #[cfg(target_arch = "x86_64")]
        let avx = crate::lane::Avx2::detect();
        #[cfg(not(target_arch = "x86_64"))]
        let avx = None;
        let mut checked = 0;
        for kind in [
            SamplerKind::Independent,
            SamplerKind::Stratified { jitter: true },
        ] {
            for (spp, s_lo) in [1, 2, 3, 4, 5, 6, 7, 8, 9, 16]
                .iter()
                .flat_map(|&n| [(n, 0), (n, 3)])
            {
                let desc = SamplerDesc {
                    kind,
                    sample_count: spp + s_lo,
                    seed: 5,
                };
                let samples = (s_lo, s_lo + spp);
                for rect in [(3, 2, 5, 3), (0, 0, 8, 2), (7, 1, 12, 2)] {
                    let (x0, y0, w, h) = rect;
                    let total = (w * h * spp) as u64;
                    for first in [0, 1, 5] {
                        for lanes in [None, avx] {
                            let mut b = Batch::new(BATCH, 1);
                            let end = total.min(first + 40);
                            b.fill(&desc, 31, rect, samples, first, end, lanes);
                            assert_eq!(b.len() as u64, end - first);
                            for (j, k) in (first..end).enumerate() {
                                let p = (k / spp as u64) as u32;
                                let s = s_lo + (k % spp as u64) as u32;
                                let (x, y) = (x0 + p % w, y0 + p / w);
                                let mut want = Sampler::for_sample(&desc, (y * 31 + x) as u64, s);
                                let pos = Vec2::new(x as f32, y as f32) + want.next_2d();
                                let ctx = (kind, spp, s_lo, rect, first, k);
                                assert_eq!(
                                    b.pos[j].to_array().map(f32::to_bits),
                                    pos.to_array().map(f32::to_bits),
                                    "{ctx:?}"
                                );
                                let mut got = b.sampler.at(j);
                                assert_eq!(got.next_2d(), want.next_2d(), "{ctx:?}");
                                assert_eq!(got.next_1d(), want.next_1d(), "{ctx:?}");
                                checked += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn compaction_keeps_the_order() {
        let mut b = batch(6);
        b.active.extend([0, 1, 2, 3, 4, 5]);
        b.next_round();
        b.alive[3] = b.round - 1;
        for i in [1, 2, 5] {
            b.set_alive(i);
        }
        b.compact();
        assert_eq!(b.active, [1, 2, 5]);
    }

    /// The compaction in lanes keeps the list the path-by-path one keeps: lists of 0 to 100
    /// ascending ids (every chunk's mask pattern in turn, a tail of 0 to 7), random flags.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn compaction_in_lanes_equals_the_loop() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        let mut r = crate::math::Pcg32::new(28, 3);
        let mut b = batch(300);
        for round in 0..2000 {
            let len = round % 101;
            let mut ids: Vec<u32> = (0..300)
                .filter(|_| r.next_u32().is_multiple_of(3))
                .collect();
            ids.truncate(len);
            b.next_round();
            let now = b.round;
            for (k, a) in b.alive.iter_mut().enumerate() {
                // Every chunk's 8 flags from the round's pattern, or random; the others
                // stamped with an older round (or 0), or a newer one (never written, but not
                // alive either).
                let on = if round % 2 == 0 {
                    (round / 2) >> (k % 8) & 1 == 1
                } else {
                    r.next_u32().is_multiple_of(2)
                };
                *a = if on {
                    now
                } else {
                    [0, now - 1, now + 1][k % 3]
                };
            }
            b.active.clear();
            b.active.extend(&ids);
            b.compact();
            let want = b.active.clone();
            b.active.clear();
            b.active.extend(&ids);
            b.compact_x8(avx);
            assert_eq!(b.active, want, "round {round}");
        }
    }

    /// `get` returns what `set` stored, bit for bit, in every field (the 1-lane code and the
    /// kernels' textures see the emission stage's interaction).
    #[test]
    fn surfaces_round_trip() {
        let mut s = Surfaces::new();
        let v = |k: f32| Vec3::new(k, -k * 0.5, k + 0.25);
        let si = |k: f32| SurfaceInteraction {
            p: v(k),
            t: k * 3.0,
            ng: v(k + 1.0),
            sh: Frame {
                s: v(k + 2.0),
                t: v(k + 3.0),
                n: v(k + 4.0),
            },
            uv: Vec2::new(k * 0.1, -k),
            dpdu: v(k + 5.0),
            dpdv: v(k + 6.0),
            shape: k as u32,
            prim: 7 * k as u32,
            wi: v(-k),
        };
        for i in [0, 5, BATCH - 1] {
            s.set(i, &si(i as f32 + 0.5));
        }
        for i in [0, 5, BATCH - 1] {
            let (a, b) = (s.get(i), si(i as f32 + 0.5));
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
        }
    }
}
