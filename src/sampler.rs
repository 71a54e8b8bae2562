//! Deterministic per-path random streams. A [`Sampler`] is keyed by (seed, pixel index, sample
//! index): the same key always gives the same numbers, whichever thread draws them, so a render is
//! bit-identical for a given seed at any thread count.
//!
//! `independent` draws plain uniform numbers. `stratified` (Mitsuba's name) jitters the first two
//! 2-D dimensions of each pixel's samples over a √N × √N grid, using a per-pixel permutation of
//! the strata, and falls back to independent numbers afterwards.

use crate::lane::mix;
use crate::lane::pcg::Pcg;
use crate::lane::{Lane, LaneU64};
use crate::math::rng::{mix64, Pcg32};
use glam::Vec2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    Independent,
    Stratified { jitter: bool },
}

/// The scene's sampler description: kind, samples per pixel, seed.
#[derive(Clone, Debug)]
pub struct SamplerDesc {
    pub kind: SamplerKind,
    pub sample_count: u32,
    pub seed: u64,
}

/// One path's random stream.
#[derive(Clone, Debug)]
pub struct Sampler {
    rng: Pcg32,
    /// Stratum of this sample in the first dimensions (stratified only).
    strata: Option<(u32, u32, bool)>,
    dim2: u32,
}

impl Sampler {
    /// The stream of sample `sample_index` of pixel `pixel_index`.
    pub fn for_sample(desc: &SamplerDesc, pixel_index: u64, sample_index: u32) -> Sampler {
        let key = stream_key(desc.seed, pixel_index);
        Sampler::keyed(
            desc,
            key,
            sample_generator::<f32>(key, sample_index as u64),
            sample_index,
        )
    }

    /// The stream of sample `sample_index` of the pixel whose key is `key` ([`stream_key`]),
    /// once its generator `rng` ([`sample_generator`]) is made: the stratum set-up, shared by
    /// [`Self::for_sample`] and the 8-wide set-up ([`for_samples_x8`]).
    #[inline(always)]
    fn keyed(desc: &SamplerDesc, key: u64, rng: Pcg<f32>, sample_index: u32) -> Sampler {
        let (state, inc) = rng.parts();
        let rng = Pcg32::from_parts(state, inc);
        let strata = grid(desc).map(|(res, jitter)| {
            // Per-pixel random permutation of the strata: a bijective hash of the index.
            (permute(sample_index, res * res, key as u32), res, jitter)
        });
        Sampler {
            rng,
            strata,
            dim2: 0,
        }
    }

    /// A free-standing stream (tests, tools).
    pub fn from_seed(seed: u64, stream: u64) -> Sampler {
        Sampler {
            rng: Pcg32::new(seed, stream),
            strata: None,
            dim2: 0,
        }
    }

    /// The PCG32 (state, increment) of this stream when every number it draws from now on is a
    /// plain PCG32 float (`next_1d` one, `next_2d` two, x then y): always for `independent`,
    /// for `stratified` once its stratified 2-D draws are spent; `None` before that. With
    /// [`Self::resume`], the stream renderer draws 8 paths' numbers 8-wide
    /// (`lane::pcg::Pcg::from_parts`) in each path's scalar order.
    #[inline]
    pub fn plain_parts(&self) -> Option<(u64, u64)> {
        match self.strata {
            Some(_) if self.dim2 < 2 => None,
            _ => Some(self.rng.parts()),
        }
    }

    /// Continues this stream from the raw PCG32 `state` and `inc` that [`Self::plain_parts`]
    /// gave, after drawing from them elsewhere.
    #[inline]
    pub fn resume(&mut self, state: u64, inc: u64) {
        self.rng = Pcg32::from_parts(state, inc);
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        self.rng.next_f32()
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        next_2d(&mut self.rng, self.strata, &mut self.dim2)
    }

    /// A derived independent generator for stochastic BSDF evaluation (random walks): it consumes
    /// one draw of this stream, so it stays deterministic per path.
    pub fn fork(&mut self) -> Pcg32 {
        let a = self.rng.next_u32() as u64;
        let b = self.rng.next_u32() as u64;
        Pcg32::new(mix64(a << 32 | b), 0x2545_F491)
    }
}

/// [`Sampler::next_2d`] of a stream with generator `rng`, strata `strata` and `dim2`
/// stratified 2-D draws spent (one definition for a [`Sampler`] and for a stream of the
/// [`Samplers`] columns, [`Samplers::next_2d`]): the first two 2-D draws of a stratified
/// stream jittered in its stratum (two PCG32 floats, none without jitter), every other draw two
/// plain PCG32 floats, x then y.
#[inline(always)]
fn next_2d(rng: &mut Pcg32, strata: Option<(u32, u32, bool)>, dim2: &mut u32) -> Vec2 {
    if let Some((stratum, res, jitter)) = strata {
        if *dim2 < 2 {
            *dim2 += 1;
            let sx = stratum % res;
            let sy = stratum / res;
            let (jx, jy) = if jitter {
                (rng.next_f32(), rng.next_f32())
            } else {
                (0.5, 0.5)
            };
            let inv = 1.0 / res as f32;
            return Vec2::new(
                ((sx as f32 + jx) * inv).min(1.0 - f32::EPSILON / 2.0),
                ((sy as f32 + jy) * inv).min(1.0 - f32::EPSILON / 2.0),
            );
        }
    }
    Vec2::new(rng.next_f32(), rng.next_f32())
}

/// A path's source of random numbers as the BSDF samplers draw them: a [`Sampler`], or one
/// stream of a [`Samplers`] drawn on its columns ([`Samplers::stream`], no [`Sampler`] copied
/// out and back). Code generic over it draws the same numbers, in the same order, from either.
pub trait Draw {
    /// [`Sampler::next_1d`].
    fn next_1d(&mut self) -> f32;
    /// [`Sampler::next_2d`].
    fn next_2d(&mut self) -> Vec2;
}

impl Draw for Sampler {
    #[inline(always)]
    fn next_1d(&mut self) -> f32 {
        Sampler::next_1d(self)
    }
    #[inline(always)]
    fn next_2d(&mut self) -> Vec2 {
        Sampler::next_2d(self)
    }
}

/// Stream `i` of a [`Samplers`] to draw from in place ([`Samplers::stream`]): each draw reads
/// and writes the columns.
pub struct Stream<'a> {
    cols: &'a mut Samplers,
    i: usize,
}

impl Draw for Stream<'_> {
    #[inline(always)]
    fn next_1d(&mut self) -> f32 {
        self.cols.next_1d(self.i)
    }
    #[inline(always)]
    fn next_2d(&mut self) -> Vec2 {
        self.cols.next_2d(self.i)
    }
}

/// The random streams of a batch of paths (the stream renderer's `Batch::sampler`) as columns:
/// each path's PCG32 `state` and increment `inc` in two `u64` arrays, the rest of its
/// [`Sampler`] (strata and the count of stratified 2-D draws) in a third. The 8-wide kernels
/// read and write the PCG32 columns in place (`stream::kernels::draws`: one load per lane and
/// column, no `Sampler` row taken apart and put back); the code that draws lane by lane goes
/// through [`Self::at`], a [`Sampler`] rebuilt from the columns and written back when dropped.
/// `strata` tells whether any stream has strata (a stream without them is plain PCG32,
/// [`Sampler::plain_parts`]): never under `independent`, so the kernels skip the per-path test.
#[derive(Clone, Debug, Default)]
pub struct Samplers {
    state: Vec<u64>,
    inc: Vec<u64>,
    /// Each stream's rest, stored only while some stream has strata (`strata`): then one per
    /// stream, else empty. A stream without strata never counts a stratified 2-D draw, so its
    /// rest is always [`Rest::PLAIN`] and is not stored: a batch fill without strata writes
    /// the two PCG32 columns only (`for_samples_x8`; the third column's 8 rows of 16 bytes
    /// cost ~19 instructions a chunk of 8 paths).
    rest: Vec<Rest>,
    strata: bool,
}

/// A [`Sampler`] without its PCG32: its strata and its count of stratified 2-D draws.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rest {
    strata: Option<(u32, u32, bool)>,
    dim2: u32,
}

impl Rest {
    /// The rest of a stream without strata (`independent`, or a grid of one stratum).
    const PLAIN: Rest = Rest {
        strata: None,
        dim2: 0,
    };

    /// Whether a stream with these strata draws plain PCG32 floats ([`Sampler::plain_parts`]).
    #[inline(always)]
    fn plain(self) -> bool {
        !(self.strata.is_some() && self.dim2 < 2)
    }
}

impl Samplers {
    /// Room for `capacity` streams.
    pub fn with_capacity(capacity: usize) -> Samplers {
        Samplers {
            state: Vec::with_capacity(capacity),
            inc: Vec::with_capacity(capacity),
            rest: Vec::with_capacity(capacity),
            strata: false,
        }
    }

    /// Number of streams.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.state.len()
    }

    /// Whether there is no stream.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }

    /// Before streams with strata join (`strata`: whether any does): where none had strata
    /// yet, the rest column starts ([`Self::start_rest`]).
    #[inline(always)]
    fn note_strata(&mut self, strata: bool) {
        if strata && !self.strata {
            self.start_rest();
        }
    }

    /// The rest column started: [`Rest::PLAIN`] for each stream so far (see `rest`), and
    /// `strata` set. Out of line and cold (once per batch of a stratified render at most):
    /// the code that draws lane by lane inlines [`Self::set`] into the kernels.
    #[cold]
    #[inline(never)]
    fn start_rest(&mut self) {
        self.rest.clear();
        self.rest.resize(self.state.len(), Rest::PLAIN);
        self.strata = true;
    }

    /// Removes every stream (capacities are kept).
    pub fn clear(&mut self) {
        self.state.clear();
        self.inc.clear();
        self.rest.clear();
        self.strata = false;
    }

    /// Appends `s`.
    #[inline(always)]
    pub fn push(&mut self, s: &Sampler) {
        let (state, inc) = s.rng.parts();
        let rest = Rest {
            strata: s.strata,
            dim2: s.dim2,
        };
        self.note_strata(rest.strata.is_some());
        self.state.push(state);
        self.inc.push(inc);
        if self.strata {
            self.rest.push(rest);
        }
    }

    /// Appends `s`, column by column (one capacity check per column, not per stream).
    #[inline(always)]
    pub fn extend_from(&mut self, s: &[Sampler]) {
        self.note_strata(s.iter().any(|s| s.strata.is_some()));
        self.state.extend(s.iter().map(|s| s.rng.parts().0));
        self.inc.extend(s.iter().map(|s| s.rng.parts().1));
        if self.strata {
            let rest = s.iter().map(|s| Rest {
                strata: s.strata,
                dim2: s.dim2,
            });
            self.rest.extend(rest);
        }
    }

    /// Appends 8 streams without strata from their PCG32 states and increments in lanes
    /// ([`crate::lane::Avx2::append_u64`]: each column's 8 lanes stored straight into its
    /// spare room; no rest stored unless some stream has strata).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn append_plain_x8(
        &mut self,
        avx: crate::lane::Avx2,
        state: crate::lane::U64x8,
        inc: crate::lane::U64x8,
    ) {
        avx.append_u64(&mut self.state, state);
        avx.append_u64(&mut self.inc, inc);
        if self.strata {
            self.rest.extend_from_slice(&[Rest::PLAIN; 8]);
        }
    }

    /// Stream `i`, as a [`Sampler`].
    #[inline(always)]
    pub fn get(&self, i: usize) -> Sampler {
        let rest = self.rest_of(i);
        Sampler {
            rng: Pcg32::from_parts(self.state[i], self.inc[i]),
            strata: rest.strata,
            dim2: rest.dim2,
        }
    }

    /// Stream `i`'s rest ([`Rest::PLAIN`] where no stream has strata: not stored, see `rest`).
    #[inline(always)]
    fn rest_of(&self, i: usize) -> Rest {
        if self.strata {
            self.rest[i]
        } else {
            assert!(i < self.state.len(), "stream {i} of {}", self.state.len());
            Rest::PLAIN
        }
    }

    /// Makes stream `i` continue as `s`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, s: &Sampler) {
        let rest = Rest {
            strata: s.strata,
            dim2: s.dim2,
        };
        self.note_strata(rest.strata.is_some());
        (self.state[i], self.inc[i]) = s.rng.parts();
        if self.strata {
            self.rest[i] = rest;
        } else {
            debug_assert!(
                rest == Rest::PLAIN,
                "a stream without strata has the plain rest"
            );
        }
    }

    /// Stream `i` as a [`Sampler`] to draw from, written back into the columns when the
    /// returned guard is dropped (for `&mut Sampler` arguments: `&mut samplers.at(i)`).
    #[inline(always)]
    pub fn at(&mut self, i: usize) -> SamplerAt<'_> {
        SamplerAt {
            s: self.get(i),
            i,
            cols: self,
        }
    }

    /// Whether every stream is plain PCG32 from here on ([`Sampler::plain_parts`] `Some`)
    /// because none has strata (`false` does not say that some stream is not plain).
    #[inline(always)]
    pub fn all_plain(&self) -> bool {
        !self.strata
    }

    /// Whether stream `i` is plain PCG32 from here on ([`Sampler::plain_parts`] `Some`).
    #[inline(always)]
    pub fn plain(&self, i: usize) -> bool {
        self.rest_of(i).plain()
    }

    /// Every stream's PCG32 state (to read ahead without drawing: the material sort's hint,
    /// `stream::batch::Batch::sort_by_material`).
    #[inline(always)]
    pub fn states(&self) -> &[u64] {
        &self.state
    }

    /// The PCG32 columns: every stream's state (to read and write) and increment.
    #[inline(always)]
    pub fn pcg_mut(&mut self) -> (&mut [u64], &[u64]) {
        (&mut self.state[..], &self.inc[..])
    }

    /// `next_1d` of stream `i` (one PCG32 float whatever the stream's strata), on the columns.
    #[inline(always)]
    pub fn next_1d(&mut self, i: usize) -> f32 {
        let mut rng = Pcg32::from_parts(self.state[i], self.inc[i]);
        let u = rng.next_f32();
        self.state[i] = rng.parts().0;
        u
    }

    /// `next_2d` of stream `i` ([`Sampler::next_2d`]: its strata while stratified 2-D draws
    /// are pending, then two plain PCG32 floats), on the columns. Where no stream has strata
    /// ([`Self::all_plain`]) the stream's strata are not read.
    #[inline(always)]
    pub fn next_2d(&mut self, i: usize) -> Vec2 {
        let mut rng = Pcg32::from_parts(self.state[i], self.inc[i]);
        let u = if self.strata {
            let rest = &mut self.rest[i];
            next_2d(&mut rng, rest.strata, &mut rest.dim2)
        } else {
            Vec2::new(rng.next_f32(), rng.next_f32())
        };
        self.state[i] = rng.parts().0;
        u
    }

    /// Stream `i` to draw from in place, through [`Draw`] (its `next_1d` and `next_2d` are
    /// [`Self::next_1d`] and [`Self::next_2d`] of `i`).
    #[inline(always)]
    pub fn stream(&mut self, i: usize) -> Stream<'_> {
        Stream { cols: self, i }
    }
}

/// One stream of a [`Samplers`] as a [`Sampler`] ([`Samplers::at`]); written back on drop.
pub struct SamplerAt<'a> {
    s: Sampler,
    i: usize,
    cols: &'a mut Samplers,
}

impl core::ops::Deref for SamplerAt<'_> {
    type Target = Sampler;
    #[inline(always)]
    fn deref(&self) -> &Sampler {
        &self.s
    }
}

impl core::ops::DerefMut for SamplerAt<'_> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut Sampler {
        &mut self.s
    }
}

impl Drop for SamplerAt<'_> {
    #[inline(always)]
    fn drop(&mut self) {
        self.cols.set(self.i, &self.s);
    }
}

/// The resolution of the strata grid and whether to jitter, when `desc` stratifies the first 2-D
/// draws (`stratified` with a square sample count above 1).
#[inline]
fn grid(desc: &SamplerDesc) -> Option<(u32, bool)> {
    match desc.kind {
        SamplerKind::Independent => None,
        SamplerKind::Stratified { jitter } => {
            let res = (desc.sample_count as f64).sqrt().floor() as u32;
            (res * res == desc.sample_count && res > 1).then_some((res, jitter))
        }
    }
}

/// The key of pixel `pixel`'s streams under seed `seed`, per lane: `mix64(seed ^
/// mix64(pixel · 0x9E3779B9 ^ 0x5851F42D))` (one definition for the 1- and 8-lane set-ups).
#[inline(always)]
pub fn stream_key<U: LaneU64>(seed: U, pixel: U) -> U {
    let h = pixel
        .mul(pixel.splat(0x9E37_79B9))
        .xor(pixel.splat(0x5851_F42D));
    mix::mix64(seed.xor(mix::mix64(h)))
}

/// The PCG32 generator of sample `sample` (as a 64-bit lane) of the pixel keyed `key`, per lane:
/// seed `key`, stream `2·sample + 1`.
#[inline(always)]
pub fn sample_generator<L: Lane>(key: L::U64, sample: L::U64) -> Pcg<L> {
    Pcg::new(key, sample.shl::<1>().or(sample.splat(1)))
}

/// The streams of 8 paths (pixel `pixel[k]`, sample `sample[k]`), appended to `out` in lane
/// order, and each one's film position appended to `pos`: its pixel corner (`corner`: the x and y columns) plus
/// its first 2-D draw (`next_2d`; the streams in `out` are past it), bit for bit
/// [`Sampler::for_sample`] then `corner + next_2d()` per path: the keys and the generators
/// 8-wide (two 64-bit multiplies per `mix64`, two PCG steps), the strata per path, the first
/// draw and the sums 8-wide when no path has strata (else per path). Call it inside
/// [`crate::lane::Avx2::run`] (the stream renderer's batch fill, `stream::batch`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn for_samples_x8(
    avx: crate::lane::Avx2,
    desc: &SamplerDesc,
    pixel: &[u64; 8],
    sample: &[u32; 8],
    corner: (&[f32; 8], &[f32; 8]),
    out: &mut Samplers,
    pos: &mut Vec<Vec2>,
) {
    // Eight samples of one pixel (every chunk of a render at 8 or more samples per pixel, a
    // multiple of 8): one key, the 1-lane function's, in every lane.
    let key = if pixel.iter().all(|&p| p == pixel[0]) {
        avx.load_u64(&[stream_key(desc.seed, pixel[0]); 8])
    } else {
        stream_key(avx.load_u64(&[desc.seed; 8]), avx.load_u64(pixel))
    };
    let sample = avx.load_u64(&sample.map(|s| s as u64));
    let corner = (avx.load(corner.0), avx.load(corner.1));
    streams_x8(avx, desc, key, sample, corner, out, pos);
}

/// Per log2(spp) (0, 1, 2) of a chunk of 8 / spp whole pixels of one row
/// ([`for_whole_pixels_x8`]): path `j`'s pixel after the chunk's first, `j / spp`, and its
/// sample after the pixel's first, `j mod spp`.
pub(crate) const WHOLE_DX: [[i32; 8]; 3] = [
    [0, 1, 2, 3, 4, 5, 6, 7],
    [0, 0, 1, 1, 2, 2, 3, 3],
    [0, 0, 0, 0, 1, 1, 1, 1],
];
pub(crate) const WHOLE_DS: [[i32; 8]; 3] = [
    [0, 0, 0, 0, 0, 0, 0, 0],
    [0, 1, 0, 1, 0, 1, 0, 1],
    [0, 1, 2, 3, 0, 1, 2, 3],
];

/// Per log2(spp) − 1 (spp 2 and 4): the 32-bit words of a register of four keys (pixel i's
/// key in lane i: words 2i and 2i + 1) that give each path's key, `WHOLE_DX`'s pixel, in the
/// two registers of a [`crate::lane::U64x8`] ([`crate::lane::U64x4::spread`]).
#[cfg(target_arch = "x86_64")]
const WHOLE_KEY_WORDS: [[[i32; 8]; 2]; 2] = [
    [[0, 1, 0, 1, 2, 3, 2, 3], [4, 5, 4, 5, 6, 7, 6, 7]],
    [[0, 1, 0, 1, 0, 1, 0, 1], [2, 3, 2, 3, 2, 3, 2, 3]],
];

/// [`for_samples_x8`] of a chunk that is 8 / spp whole pixels of one row at spp = 2^`sh` (1, 2
/// or 4): path j is sample `s_lo + j mod spp` of pixel `first + j / spp`, whose corner is
/// (`x + j / spp`, `y`) (`first`: the pixel index of column `x` of row `y`). The same streams
/// and positions bit for bit, but the paths' pixels, samples and corners made in lanes from
/// [`WHOLE_DX`] and [`WHOLE_DS`] (not stepped path by path and loaded), and at 2 or 4 samples a
/// pixel the keys of the chunk's four or two pixels made in one register
/// ([`crate::lane::U64x4`]: `stream_key` per lane is the same function at every width) and
/// spread to their paths: on metal_plastic at 2 spp the per-path columns cost ~75 instructions
/// a chunk and the eight keys ~70 (`docs/bench/README.md`, thirty-seventh session, h2).
///
/// # Panics
/// If `sh` > 2 or `x` + 7 > `i32::MAX` (the corners are converted as `i32`s; the caller keeps
/// to smaller columns).
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn for_whole_pixels_x8(
    avx: crate::lane::Avx2,
    desc: &SamplerDesc,
    (first, x, y): (u64, u32, u32),
    sh: u32,
    s_lo: u32,
    out: &mut Samplers,
    pos: &mut Vec<Vec2>,
) {
    use crate::lane::{LaneI32, U64x4, U64x8};
    assert!(
        sh <= 2 && x <= i32::MAX as u32 - 7,
        "a chunk of whole pixels at 1, 2 or 4 samples a pixel, in the first 2^31 − 8 columns"
    );
    let sh = sh as usize;
    let dx = avx.load_i32(&WHOLE_DX[sh]);
    let ds = avx.load_i32(&WHOLE_DS[sh]);
    // `(x + dx) as f32` of each path: the sums are below 2^31, where the i32 conversion
    // (`vcvtdq2ps`) rounds as the u32 one does.
    let corner = (dx.add(dx.splat(x as i32)).to_f32(), avx.splat(y as f32));
    let key = if sh == 0 {
        let pixel = U64x8::from_u32(dx).add(avx.load_u64(&[first; 8]));
        stream_key(avx.load_u64(&[desc.seed; 8]), pixel)
    } else {
        let next = |i: u64| first.wrapping_add(i);
        let pixel = U64x4::load(avx, &[first, next(1), next(2), next(3)]);
        stream_key(pixel.splat(desc.seed), pixel).spread(avx, &WHOLE_KEY_WORDS[sh - 1])
    };
    let sample = U64x8::from_u32(ds.add(ds.splat(s_lo as i32)));
    streams_x8(avx, desc, key, sample, corner, out, pos);
}

/// The rest of [`for_samples_x8`] and [`for_whole_pixels_x8`], from the paths' keys, sample
/// indices (below 2³²) and pixel corners in lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn streams_x8(
    avx: crate::lane::Avx2,
    desc: &SamplerDesc,
    key: crate::lane::U64x8,
    sample: crate::lane::U64x8,
    corner: (crate::lane::F32x8, crate::lane::F32x8),
    out: &mut Samplers,
    pos: &mut Vec<Vec2>,
) {
    let mut rng: Pcg<crate::lane::F32x8> = sample_generator(key, sample);
    if grid(desc).is_none() {
        // `Vec2`'s add, component by component, in lanes; the points appended whole.
        let (x, y) = (rng.next_f32(), rng.next_f32());
        avx.append_vec2_rows(pos, corner.0 + x, corner.1 + y);
        // `Sampler::keyed` without a grid: no strata, no 2-D draw spent; the PCG32 columns
        // as they are, stored from the lanes.
        let (state, inc) = rng.parts();
        out.append_plain_x8(avx, state, inc);
        return;
    }
    let (keys, sample) = (key.to_array(), sample.to_array());
    let (cx, cy) = (corner.0.to_array(), corner.1.to_array());
    let (state, inc) = rng.parts();
    let (state, inc) = (state.to_array(), inc.to_array());
    let mut s: [Sampler; 8] = core::array::from_fn(|k| {
        Sampler::keyed(
            desc,
            keys[k],
            Pcg::from_parts(state[k], inc[k]),
            sample[k] as u32,
        )
    });
    for (k, s) in s.iter_mut().enumerate() {
        pos.push(Vec2::new(cx[k], cy[k]) + s.next_2d());
    }
    out.extend_from(&s);
}

/// A bijective permutation of `0..n` selected by `seed` (Kensler 2013, "Correlated Multi-Jittered
/// Sampling", the cycle-walking hash).
fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= seed;
        i = i.wrapping_mul(0xe170893d);
        i ^= seed >> 16;
        i ^= (i & w) >> 4;
        i ^= seed >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= seed >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | seed >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    (i.wrapping_add(seed)) % n
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn same_key_same_numbers() {
        let d = SamplerDesc {
            kind: SamplerKind::Independent,
            sample_count: 4,
            seed: 3,
        };
        let mut a = Sampler::for_sample(&d, 10, 2);
        let mut b = Sampler::for_sample(&d, 10, 2);
        let mut c = Sampler::for_sample(&d, 10, 3);
        let xa: Vec<f32> = (0..8).map(|_| a.next_1d()).collect();
        let xb: Vec<f32> = (0..8).map(|_| b.next_1d()).collect();
        let xc: Vec<f32> = (0..8).map(|_| c.next_1d()).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
    }

    /// `plain_parts` is `None` exactly while stratified 2-D draws are pending; drawing from the
    /// parts gives the sampler's own numbers (`next_1d`, then `next_2d` x and y), and `resume`
    /// continues the stream from there.
    #[test]
    fn plain_parts_continue_the_stream() {
        for (kind, pending) in [
            (SamplerKind::Independent, 0),
            (SamplerKind::Stratified { jitter: true }, 2),
        ] {
            let d = SamplerDesc {
                kind,
                sample_count: 16,
                seed: 5,
            };
            let mut s = Sampler::for_sample(&d, 3, 7);
            let mut n = 0;
            while s.plain_parts().is_none() {
                s.next_2d();
                n += 1;
            }
            assert_eq!(n, pending, "{kind:?}");
            let (state, inc) = s.plain_parts().expect("plain");
            let mut r = Pcg32::from_parts(state, inc);
            let mut t = s.clone();
            let drawn = [r.next_f32(), r.next_f32(), r.next_f32()];
            let (x, v) = (t.next_1d(), t.next_2d());
            assert_eq!(drawn, [x, v.x, v.y], "{kind:?}");
            s.resume(r.parts().0, inc);
            assert_eq!(s.next_2d(), t.next_2d(), "{kind:?}");
        }
    }

    #[test]
    fn stratified_covers_every_stratum_once() {
        let d = SamplerDesc {
            kind: SamplerKind::Stratified { jitter: true },
            sample_count: 16,
            seed: 0,
        };
        let mut seen = [0u32; 16];
        for s in 0..16 {
            let mut sm = Sampler::for_sample(&d, 77, s);
            let u = sm.next_2d();
            let cell = (u.x * 4.0) as usize + 4 * (u.y * 4.0) as usize;
            seen[cell] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
    }

    /// (seed, pixel, sample) triples over the ranges the renderers use and their edges.
    fn triples() -> Vec<(u64, u64, u32)> {
        let mut r = Pcg32::new(9, 11);
        let mut v = vec![
            (0, 0, 0),
            (u64::MAX, u64::MAX, u32::MAX),
            (1, u32::MAX as u64, 1 << 31),
            (1 << 63, 1 << 32, 7),
        ];
        for _ in 0..2048 {
            let seed = match r.next_u32() % 3 {
                0 => r.next_u32() as u64 % 4,
                1 => (r.next_u32() as u64) << 32 | r.next_u32() as u64,
                _ => r.next_u32() as u64,
            };
            let pixel = if r.next_u32().is_multiple_of(2) {
                r.next_u32() as u64 % 4_000_000
            } else {
                (r.next_u32() as u64) << 32 | r.next_u32() as u64
            };
            let sample = if r.next_u32().is_multiple_of(2) {
                r.next_u32() % 1024
            } else {
                r.next_u32()
            };
            v.push((seed, pixel, sample));
        }
        v
    }

    fn descs(seed: u64) -> [SamplerDesc; 4] {
        let d = |kind, sample_count| SamplerDesc {
            kind,
            sample_count,
            seed,
        };
        [
            d(SamplerKind::Independent, 16),
            d(SamplerKind::Stratified { jitter: true }, 16),
            d(SamplerKind::Stratified { jitter: false }, 64),
            d(SamplerKind::Stratified { jitter: true }, 8),
        ]
    }

    /// The columns behave as a `Vec<Sampler>`: streams pushed, drawn from through `at`,
    /// `next_1d` and `next_2d` on the columns, `stream` and `set` give the numbers the rows
    /// give, and `all_plain` / `plain` follow each
    /// stream's `plain_parts` as stratified streams spend their 2-D draws (`all_plain` only
    /// where no stream has strata).
    #[test]
    fn the_columns_are_the_samplers() {
        for d in descs(7) {
            let mut rows: Vec<Sampler> = (0..12)
                .map(|s| Sampler::for_sample(&d, 3 + s, s as u32))
                .collect();
            let mut cols = Samplers::with_capacity(4);
            cols.push(&rows[0]);
            cols.extend_from(&rows[1..]);
            let check = |cols: &Samplers, rows: &[Sampler]| {
                assert_eq!(cols.len(), rows.len());
                for (i, r) in rows.iter().enumerate() {
                    assert_eq!(cols.plain(i), r.plain_parts().is_some(), "{:?}", d.kind);
                    assert_eq!(cols.get(i).plain_parts(), r.plain_parts());
                    assert_eq!(format!("{:?}", cols.get(i)), format!("{r:?}"));
                }
                let none = rows.iter().all(|r| r.strata.is_none());
                assert_eq!(cols.all_plain(), none, "{:?}", d.kind);
                if cols.all_plain() {
                    assert!(rows.iter().all(|r| r.plain_parts().is_some()));
                }
            };
            check(&cols, &rows);
            let mut r = Pcg32::new(1, 2);
            let bits = |u: Vec2| u.to_array().map(f32::to_bits);
            for step in 0..300 {
                let i = r.next_u32() as usize % rows.len();
                match step % 6 {
                    0 => assert_eq!(cols.at(i).next_2d(), rows[i].next_2d()),
                    1 => assert_eq!(cols.next_1d(i).to_bits(), rows[i].next_1d().to_bits()),
                    4 => assert_eq!(bits(cols.next_2d(i)), bits(rows[i].next_2d()), "{d:?}"),
                    5 => {
                        // Through `Draw`, generic as the BSDF samplers draw.
                        fn two<D: Draw>(s: &mut D) -> (f32, Vec2, f32) {
                            (s.next_1d(), s.next_2d(), s.next_1d())
                        }
                        let (a, u, b) = two(&mut cols.stream(i));
                        let (x, v, y) = two(&mut rows[i]);
                        assert_eq!((a.to_bits(), b.to_bits()), (x.to_bits(), y.to_bits()));
                        assert_eq!(bits(u), bits(v), "{d:?}");
                    }
                    _ => {
                        let mut s = rows[(i + 1) % rows.len()].clone();
                        s.next_2d();
                        cols.set(i, &s);
                        rows[i] = s;
                    }
                }
                check(&cols, &rows);
            }
            cols.clear();
            assert!(cols.is_empty() && cols.all_plain());
        }
    }

    /// `next_2d` on the columns (and through [`Samplers::stream`]) equals each stream's
    /// `Sampler::next_2d` where plain and stratified streams are mixed in one batch (the
    /// stratified ones' first two draws in their strata, jittered or at the centres, then
    /// plain; a plain stream's draws whatever the others have), interleaved with `next_1d`.
    #[test]
    fn the_columns_draw_2d_as_the_samplers_do() {
        let mut r = Pcg32::new(3, 4);
        for round in 0..64u64 {
            let mut rows: Vec<Sampler> = (0..10)
                .map(|s| {
                    let d = &descs(round)[(r.next_u32() % 4) as usize];
                    Sampler::for_sample(d, 5 + s + round, r.next_u32() % 64)
                })
                .collect();
            rows.push(Sampler::from_seed(round, 9));
            let mut cols = Samplers::default();
            cols.extend_from(&rows);
            for _ in 0..80 {
                let i = r.next_u32() as usize % rows.len();
                let (got, want) = match r.next_u32() % 3 {
                    0 => (cols.next_2d(i), rows[i].next_2d()),
                    1 => (Draw::next_2d(&mut cols.stream(i)), rows[i].next_2d()),
                    _ => {
                        let u = Vec2::splat(cols.next_1d(i));
                        (u, Vec2::splat(rows[i].next_1d()))
                    }
                };
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "round {round}, stream {i}"
                );
            }
            for (i, s) in rows.iter().enumerate() {
                assert_eq!(format!("{:?}", cols.get(i)), format!("{s:?}"));
            }
        }
    }

    /// Width 1: the stream key and generator written out with `u64` operations and `Pcg32`.
    #[test]
    fn for_sample_is_the_keyed_pcg() {
        for (seed, pixel, sample) in triples() {
            let key = mix64(seed ^ mix64(pixel.wrapping_mul(0x9E37_79B9) ^ 0x5851_F42D));
            let mut want = Pcg32::new(key, (sample as u64) << 1 | 1);
            let d = &descs(seed)[0];
            let mut got = Sampler::for_sample(d, pixel, sample);
            for _ in 0..4 {
                assert_eq!(got.next_1d().to_bits(), want.next_f32().to_bits());
            }
        }
    }

    /// Width 8: every lane's stream and film position equal `for_sample` then the corner plus
    /// `next_2d`, for every sampler kind, eight pixels or eight samples of one (corners with
    /// fractions, so that the sums round), and the streams go on identically.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_wide_set_up_equals_for_sample() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2/FMA: skipping the 8-wide half");
            return;
        };
        let t = triples();
        for chunk in t.chunks_exact(8) {
            let seed = chunk[0].0;
            let pixels: [u64; 8] = core::array::from_fn(|k| chunk[k].1);
            let sample: [u32; 8] = core::array::from_fn(|k| chunk[k].2);
            // Eight pixels, and eight samples of one pixel (the one-key case).
            for (pixel, d) in [pixels, [pixels[0]; 8]]
                .into_iter()
                .flat_map(|p| descs(seed).into_iter().map(move |d| (p, d)))
            {
                let d = &d;
                // Appended after what `got` holds.
                let mut cols = Samplers::default();
                cols.push(&Sampler::from_seed(1, 2));
                let cx: [f32; 8] = core::array::from_fn(|k| (pixel[k] % 977) as f32 + 0.3);
                let cy: [f32; 8] = core::array::from_fn(|k| (sample[k] % 13) as f32 * 1e-3);
                let corner = (&cx, &cy);
                let mut first = vec![Vec2::NAN];
                avx.run(|| for_samples_x8(avx, d, &pixel, &sample, corner, &mut cols, &mut first));
                assert_eq!((cols.len(), first.len()), (9, 9));
                let first = &first[1..];
                let mut got: Vec<Sampler> = (1..9).map(|i| cols.get(i)).collect();
                for k in 0..8 {
                    let mut want = Sampler::for_sample(d, pixel[k], sample[k]);
                    let u = Vec2::new(cx[k], cy[k]) + want.next_2d();
                    let ctx = (d.kind, seed, pixel[k], sample[k]);
                    assert_eq!(
                        first[k].to_array().map(f32::to_bits),
                        u.to_array().map(f32::to_bits),
                        "{ctx:?}"
                    );
                    assert_eq!(got[k].plain_parts(), want.plain_parts(), "{ctx:?}");
                    for _ in 0..3 {
                        assert_eq!(got[k].next_2d(), want.next_2d(), "{ctx:?}");
                        assert_eq!(got[k].next_1d(), want.next_1d(), "{ctx:?}");
                    }
                }
            }
        }
    }
}
