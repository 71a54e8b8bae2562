//! Image reconstruction: filters, per-thread blocks, the film they merge into, and developed images.
//!
//! Semantics follow Mitsuba 3's `hdrfilm` with its `ImageBlock` (scalar variants): a sample at a
//! continuous film position splats its value, times separable filter weights, into every pixel whose
//! centre lies within the filter radius; weights are *not* normalised per sample (Mitsuba's
//! sampling integrator creates its blocks with `normalize = false`), and developing divides the
//! weighted sum by the summed weights. Contributions to pixels outside the crop window are dropped,
//! as Mitsuba's film storage has no border. A filter of radius ½ is the box filter: the sample goes
//! to the one pixel that contains it, with weight 1.
//!
//! Everything is exact and order-independent: each contribution (w·v, w·v², w, w²) is rounded
//! once to a fixed-point integer ([`sum`]) and the sums are integer sums, so a pixel's value is
//! the same bits whatever the block layout, the thread count, the merge order, or the split of a
//! render into crops and sample ranges (`groove merge`). Positions are taken in full-film
//! coordinates for the same reason. Developing rounds each exact sum once.

use crate::error::{Error, Result};
use crate::math::Vec2;
use crate::spectrum::Spectrum;

#[path = "film_sum.rs"]
pub(crate) mod sum;

/// Resolution of Mitsuba's tabulated filter (`MI_FILTER_RESOLUTION` in `rfilter.h`).
const FILTER_RESOLUTION: usize = 31;

/// Remez fit of exp(-t/2) on t ∈ [0, 16] (degree 9, constant term first), the kernel Mitsuba 3's
/// `gaussian.cpp` evaluates on the CPU instead of `exp`; scaled by 1/stddev^(2i) per term and
/// shifted so that it reaches exactly zero at the radius (4·stddev).
const GAUSSIAN_REMEZ: [f64; 10] = [
    9.992604880e-1,
    -4.977025247e-1,
    1.222248550e-1,
    -1.932406282e-2,
    2.136713061e-3,
    -1.679873860e-4,
    9.202145248e-6,
    -3.329417433e-7,
    7.128382794e-9,
    -6.821193280e-11,
];

/// A reconstruction filter (Mitsuba 3 `rfilter`s `box`, `tent`, `gaussian`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// Radius ½: each sample counts for exactly one pixel.
    Box,
    /// 1 − |x|/radius (Mitsuba default radius 1).
    Tent { radius: f32 },
    /// Mitsuba's truncated Gaussian: default stddev 0.5, and the radius is always 4·stddev
    /// (Mitsuba ignores a `radius` parameter for this filter; the constructor [`Filter::gaussian`]
    /// derives it).
    Gaussian { stddev: f32, radius: f32 },
}

impl Default for Filter {
    /// Mitsuba's `hdrfilm` default: gaussian, stddev 0.5, radius 2.
    fn default() -> Self {
        Filter::gaussian(0.5)
    }
}

impl Filter {
    /// The Gaussian with Mitsuba's radius of 4·stddev.
    pub fn gaussian(stddev: f32) -> Filter {
        Filter::Gaussian {
            stddev,
            radius: 4.0 * stddev,
        }
    }

    /// Support radius in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::Tent { radius } => radius,
            Filter::Gaussian { radius, .. } => radius,
        }
    }

    /// True when Mitsuba would treat this filter as the box filter (radius exactly ½).
    fn is_box(&self) -> bool {
        self.radius() == 0.5
    }

    /// The filter value at offset `x` (pixels) from its centre, as Mitsuba 3 evaluates it.
    pub fn eval(&self, x: f32) -> f32 {
        match *self {
            // box.cpp: 1 on [-0.5, 0.5).
            Filter::Box => {
                if (-0.5..0.5).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            }
            // tent.cpp: max(0, 1 - |x| / radius).
            Filter::Tent { radius } => (1.0 - (x / radius).abs()).max(0.0),
            Filter::Gaussian { stddev, radius } => {
                if x.is_nan() || x.abs() >= radius {
                    return 0.0;
                }
                let c = gaussian_coeffs(stddev, radius);
                (poly(&c, (x as f64) * (x as f64)) as f32).max(0.0)
            }
        }
    }
}

/// The Remez coefficients scaled to `stddev` and shifted to vanish at `radius` (gaussian.cpp).
fn gaussian_coeffs(stddev: f32, radius: f32) -> [f64; 10] {
    let mut c = [0.0f64; 10];
    let mut scale = 1.0f64;
    let s2 = (stddev as f64) * (stddev as f64);
    for (ci, &k) in c.iter_mut().zip(GAUSSIAN_REMEZ.iter()) {
        // Mitsuba rounds the scaled coefficients to f32.
        *ci = (k * scale) as f32 as f64;
        scale /= s2;
    }
    let r = radius as f64;
    c[0] -= poly(&c, r * r);
    c
}

/// Horner evaluation of Σ c_i t^i.
fn poly(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * t + ci)
}

/// Mitsuba's tabulated filter (`ReconstructionFilter::eval_discretized`), which its scalar
/// `ImageBlock::put` uses: 31 values at x = radius·i/31 (left ends of the bins), then 0.
#[derive(Clone, Debug)]
struct FilterTable {
    values: [f32; FILTER_RESOLUTION + 1],
    scale: f32,
    /// The square of the largest |value|, rounded to f32 (+∞ when a value is not finite): a
    /// bound on every product of two weights, |wx·wy| ≤ `max_sq` (rounding is monotonic).
    max_sq: f32,
    /// Every value finite, non-negative and at most 2²⁰, so every weight wx·wy is too: eight
    /// samples' Σw addends then sum without overflow and their saturating sum is the sum of
    /// eight saturating adds ([`Block::splat8_grouped`]).
    groupable: bool,
}

impl FilterTable {
    fn new(filter: &Filter) -> FilterTable {
        let r = filter.radius();
        let mut values = [0.0f32; FILTER_RESOLUTION + 1];
        for (i, v) in values.iter_mut().take(FILTER_RESOLUTION).enumerate() {
            *v = filter.eval(r * i as f32 / FILTER_RESOLUTION as f32);
        }
        let max = values.iter().fold(0.0f32, |m, &v| {
            if v.is_finite() {
                m.max(v.abs())
            } else {
                f32::INFINITY
            }
        });
        FilterTable {
            values,
            scale: FILTER_RESOLUTION as f32 / r,
            max_sq: max * max,
            groupable: values.iter().all(|&v| (0.0..=1_048_576.0).contains(&v)),
        }
    }

    #[inline]
    fn eval(&self, x: f32) -> f32 {
        // `as usize` saturates (and maps NaN to 0); the min keeps the index in the table.
        let i = ((x * self.scale).abs() as usize).min(FILTER_RESOLUTION);
        self.values[i]
    }

    /// [`FilterTable::eval`] in eight lanes, equal to it lane by lane: the same product and
    /// absolute value, then the bin: the truncation below 31, 31 from there up to +∞ (where
    /// `as usize` saturates and the min cuts), 0 for NaN; a gather from the table.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn eval8(&self, avx: crate::lane::Avx2, x: crate::lane::F32x8) -> crate::lane::F32x8 {
        use crate::lane::{F32x8, I32x8, Lane, LaneI32};
        const LAST: i32 = FILTER_RESOLUTION as i32;
        let t = (x * avx.splat(self.scale)).abs();
        let i = t.trunc_i32();
        let big = I32x8::select(t.is_nan(), i.splat(0), i.splat(LAST));
        F32x8::gather(
            &self.values,
            I32x8::select(t.lt(avx.splat(LAST as f32)), i, big),
        )
    }
}

/// The widest union of eight samples' footprints (pixels a side) that
/// [`Block::splat8_grouped`] takes together.
const GROUP_SIDE: usize = 8;
/// The largest union of eight samples' footprints (pixels) that [`Block::splat8_grouped`]
/// takes together: each of its pixels costs about what ~2 single adds cost, so a union of
/// more than ~30 pixels (eight samples over 16 pixels each) is left to the per-sample splat.
const GROUP_AREA: usize = 30;

/// Footprints of up to 8×8 pixels in lanes ([`Block::splat_lanes`]): for a footprint `nx`
/// pixels wide, pixel p (row-major) is column p mod nx and row ⌊p / nx⌋; `FOOT_I[nx − 1][g]`
/// and `FOOT_J[nx − 1][g]` hold them for p = 8g, …, 8g + 7 (lanes past the footprint's end are
/// never added).
const FOOT_I: [[[i32; 8]; 8]; 8] = foot_table(false);
/// See [`FOOT_I`].
const FOOT_J: [[[i32; 8]; 8]; 8] = foot_table(true);

/// [`FOOT_I`] (`rows` false) or [`FOOT_J`] (`rows` true).
const fn foot_table(rows: bool) -> [[[i32; 8]; 8]; 8] {
    let mut t = [[[0i32; 8]; 8]; 8];
    let mut nx = 1;
    while nx <= 8 {
        let mut p = 0;
        while p < 64 {
            t[nx - 1][p / 8][p % 8] = if rows { p / nx } else { p % nx } as i32;
            p += 1;
        }
        nx += 1;
    }
    t
}

/// Film geometry and filter: the full film size and the crop window that is rendered.
#[derive(Clone, Debug)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub crop_offset: (u32, u32),
    pub crop_size: (u32, u32),
    pub filter: Filter,
    /// Keep the second moments Σw·v² and Σw² beside Σw·v and Σw: what a variance
    /// ([`Film::develop_variance`]) and a part file (`output::part`) need. Without them a
    /// splat converts and adds half the sums (the image, Σw·v / Σw, is the same bit for bit),
    /// and asking for a variance is an error.
    pub second_moments: bool,
}

impl FilmDesc {
    /// The crop window clamped to the film (a window that sticks out is cut, never a panic):
    /// (x0, y0, width, height).
    pub fn crop_rect(&self) -> (u32, u32, u32, u32) {
        self.crop()
    }

    /// [`FilmDesc::crop_rect`].
    fn crop(&self) -> (u32, u32, u32, u32) {
        let x0 = self.crop_offset.0.min(self.width);
        let y0 = self.crop_offset.1.min(self.height);
        let w = self.crop_size.0.min(self.width - x0);
        let h = self.crop_size.1.min(self.height - y0);
        (x0, y0, w, h)
    }
}

/// Per-pixel sums Σw·v, Σw·v², Σw, Σw², exact in fixed point (see [`sum`]), so that they do not
/// depend on the order or grouping in which contributions arrive. Aligned to 16 bytes, as when
/// the sums were `i128`s: the same size ([`PIXEL_BYTES`]).
///
/// Stored in the order Σw·v (R, G, B), Σw, Σw·v² (R, G, B), Σw² ([`SLOT`]), so that the
/// image's sums are the first four and a film without second moments
/// ([`FilmDesc::second_moments`]) adds them in two registers instead of four
/// ([`crate::lane::Avx2::add_i128x4_biased`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
struct Acc {
    /// Σw·v (R, G, B), Σw, Σw·v² (R, G, B), Σw² (the storage order, [`SLOT`]) as separate
    /// words: `words[0][i]` the low 64-bit word of slot i, stored biased (its top bit flipped,
    /// [`sum::LOW_BIAS`]), `words[1][i]` its high word. Read and written through
    /// [`Acc::sum`], [`Acc::sums`] and [`Acc::from_sums`] outside the 8-wide adds, which add a
    /// contribution's eight addends in four registers with each carry in its lane
    /// ([`crate::lane::Avx2::add_i128x8_biased`]).
    words: [[u64; 8]; 2],
    /// Non-finite colour values seen (they cannot be summed in fixed point): bit c NaN, bit 3+c
    /// +∞, bit 6+c −∞ for channel c. A set of flags does not depend on the order either.
    bad: u16,
}

/// `d[i] += s[i]` for a row of pixels ([`Acc::add`]): in lanes where the CPU has AVX2, each
/// pixel's eight sums added in four registers ([`crate::lane::Avx2::add_i128x8_biased`], the
/// same wrapping and saturating adds), so a merge costs what it did before the sums were
/// stored biased; with `second` false (a film without second moments) only the first four
/// sums, in two registers.
#[cfg(target_arch = "x86_64")]
fn add_row(avx: Option<crate::lane::Avx2>, second: bool, d: &mut [Acc], s: &[Acc]) {
    match avx {
        Some(avx) => avx.run(
            #[inline(always)]
            || {
                for (d, s) in d.iter_mut().zip(s) {
                    d.add_addends(avx, second, &s.unbiased_words());
                    d.bad |= s.bad;
                }
            },
        ),
        None => {
            for (d, s) in d.iter_mut().zip(s) {
                d.add(s);
            }
        }
    }
}

/// The storage slots of an [`Acc`] that saturate (non-negative addends,
/// [`sum::add_unsigned`]): Σw, Σw·v² and Σw², slots 3 to 7 (in [`RawPixel`]'s order too,
/// sums 3 to 7).
#[cfg(target_arch = "x86_64")]
const UNSIGNED_SUMS: u32 = 0b1111_1000;

/// The storage slot of each of [`RawPixel`]'s sums (Σw·v R, G, B, Σw·v² R, G, B, Σw, Σw²) in
/// an [`Acc`]: the first moments and the weight first, then the second moments.
const SLOT: [usize; 8] = [0, 1, 2, 4, 5, 6, 3, 7];

impl Default for Acc {
    /// No contribution: every sum 0 (stored biased).
    fn default() -> Acc {
        Acc {
            words: [[sum::LOW_BIAS as u64; 8], [0; 8]],
            bad: 0,
        }
    }
}

impl Acc {
    /// Sum `i` ([`RawPixel`]'s order) as stored, biased.
    #[inline(always)]
    fn stored(&self, i: usize) -> i128 {
        let k = SLOT[i];
        ((self.words[1][k] as i128) << 64) | self.words[0][k] as i128
    }

    /// Stores the biased sum `s` as sum `i` ([`RawPixel`]'s order).
    #[inline(always)]
    fn store(&mut self, i: usize, s: i128) {
        let k = SLOT[i];
        (self.words[0][k], self.words[1][k]) = (s as u64, (s >> 64) as u64);
    }

    /// Sum `i` ([`RawPixel`]'s order), unbiased.
    #[inline(always)]
    fn sum(&self, i: usize) -> i128 {
        self.stored(i) ^ sum::LOW_BIAS
    }

    /// The eight sums, unbiased.
    #[inline(always)]
    fn sums(&self) -> [i128; 8] {
        core::array::from_fn(|i| self.sum(i))
    }

    /// A pixel of the eight (unbiased) sums `s` and the flags `bad`.
    #[inline(always)]
    fn from_sums(s: [i128; 8], bad: u16) -> Acc {
        let mut a = Acc {
            bad,
            ..Acc::default()
        };
        for (i, s) in s.into_iter().enumerate() {
            a.store(i, s ^ sum::LOW_BIAS);
        }
        a
    }

    /// The eight sums' words, unbiased (the addends of a merge).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn unbiased_words(&self) -> [[u64; 8]; 2] {
        [
            self.words[0].map(|w| w ^ sum::LOW_BIAS as u64),
            self.words[1],
        ]
    }

    /// Adds one contribution's first four addends (Σw·v and Σw, a film without second
    /// moments), given in registers ([`sum::Fixed8::rows4`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn add_row(&mut self, avx: crate::lane::Avx2, row: crate::lane::I128x4) {
        avx.add_i128x4_biased_row::<UNSIGNED_SUMS>(&mut self.words, row);
    }

    /// Adds one contribution's addends `t` (words in the storage order, [`SLOT`]): all eight
    /// sums, or with `second` false only the first four (Σw·v and Σw; the second moments are
    /// not kept then).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn add_addends(&mut self, avx: crate::lane::Avx2, second: bool, t: &crate::lane::Words8) {
        if second {
            avx.add_i128x8_biased::<UNSIGNED_SUMS>(&mut self.words, t);
        } else {
            avx.add_i128x4_biased::<UNSIGNED_SUMS>(&mut self.words, t);
        }
    }

    /// Σw·v of channel `c`.
    #[inline]
    fn wv(&self, c: usize) -> i128 {
        self.sum(c)
    }

    /// Σw·v² of channel `c`.
    #[inline]
    fn wv2(&self, c: usize) -> i128 {
        self.sum(3 + c)
    }

    /// Σw.
    #[inline]
    fn w(&self) -> i128 {
        self.sum(6)
    }

    /// Σw².
    #[inline]
    fn w2(&self) -> i128 {
        self.sum(7)
    }

    #[inline(always)]
    fn add_sample(&mut self, v: [f32; 3], w: f32) {
        let mut first = [0i128; 3];
        let mut second = [0i128; 3];
        for (c, &vc) in v.iter().enumerate() {
            let wv = vc * w;
            if !wv.is_finite() || !vc.is_finite() {
                self.flag(c, if vc.is_finite() { wv } else { vc });
                continue;
            }
            first[c] = sum::fixed(wv);
            second[c] = sum::fixed(wv * vc);
        }
        self.add_fixed(first, second, sum::fixed(w), sum::fixed(w * w));
    }

    /// [`Acc::add_sample`] with weight 1 (the box filter): w·v = v and w·v² = v·v exactly, and
    /// the weight sums take the constant [`sum::ONE`].
    #[inline(always)]
    fn add_unit_sample(&mut self, v: [f32; 3]) {
        let mut first = [0i128; 3];
        let mut second = [0i128; 3];
        for (c, &vc) in v.iter().enumerate() {
            if !vc.is_finite() {
                self.flag(c, vc);
                continue;
            }
            first[c] = sum::fixed(vc);
            second[c] = sum::fixed(vc * vc);
        }
        self.add_fixed(first, second, sum::ONE, sum::ONE);
    }

    /// Adds one contribution's fixed-point addends: Σw·v, Σw·v², w, w² (a skipped, non-finite
    /// channel adds 0), to the biased sums in place.
    #[inline(always)]
    fn add_fixed(&mut self, first: [i128; 3], second: [i128; 3], w: i128, w2: i128) {
        let mut sums: [i128; 8] = core::array::from_fn(|i| self.stored(i));
        let [s0, s1, s2, r, g, b, sw, sw2] = &mut sums;
        for (s, x) in [s0, s1, s2].into_iter().zip(first) {
            sum::add_signed_biased(s, x);
        }
        let x = [second[0], second[1], second[2], w, w2];
        sum::add_unsigned_all_biased([r, g, b, sw, sw2], x);
        for (i, s) in sums.into_iter().enumerate() {
            self.store(i, s);
        }
    }

    /// Records the non-finite value `x` of channel `c`.
    #[cold]
    fn flag(&mut self, c: usize, x: f32) {
        self.bad |= if x.is_nan() {
            1 << c
        } else if x > 0.0 {
            1 << (3 + c)
        } else {
            1 << (6 + c)
        };
    }

    #[inline]
    fn add(&mut self, o: &Acc) {
        let s = o.sums();
        self.add_fixed([s[0], s[1], s[2]], [s[3], s[4], s[5]], s[6], s[7]);
        self.bad |= o.bad;
    }

    /// Σw·v / Σw of channel c (0 without weight; NaN or ±∞ when such values were put).
    fn mean(&self, c: usize) -> f32 {
        let bad = (self.bad >> c) & 0b1001001;
        match (bad & 1 != 0, bad & 8 != 0, bad & 64 != 0) {
            (true, _, _) | (_, true, true) => f32::NAN,
            (_, true, false) => f32::INFINITY,
            (_, false, true) => f32::NEG_INFINITY,
            _ if self.w() == 0 => 0.0,
            // The 2⁻⁶⁴ scale cancels.
            _ => (self.wv(c) as f64 / self.w() as f64) as f32,
        }
    }
}

/// Bytes of one pixel's accumulators in a [`Film`] or [`Block`] (without extra channels).
pub const PIXEL_BYTES: u64 = std::mem::size_of::<Acc>() as u64;

/// One pixel's exact sums as stored in a partial output (`output::part`): Σw·v (R, G, B),
/// Σw·v² (R, G, B), Σw, Σw², integers times 2⁻⁶⁴, and the non-finite flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RawPixel {
    pub sums: [i128; 8],
    pub bad: u16,
}

impl From<&Acc> for RawPixel {
    fn from(a: &Acc) -> RawPixel {
        RawPixel {
            sums: a.sums(),
            bad: a.bad,
        }
    }
}

impl From<&RawPixel> for Acc {
    fn from(r: &RawPixel) -> Acc {
        Acc::from_sums(r.sums, r.bad)
    }
}

/// A rectangle of the film plus a border wide enough for the filter's footprint, filled by one
/// thread and then merged into the [`Film`].
#[derive(Clone, Debug)]
pub struct Block {
    filter: Filter,
    table: FilterTable,
    border: u32,
    /// Full-film pixel coordinates of the storage's top-left pixel (border included).
    ox: i64,
    oy: i64,
    /// Storage size (border included).
    sw: u32,
    sh: u32,
    /// The storage's x and y extents as exact f32 bounds, when they are ([`exact_bounds`]).
    exact: [Option<[f32; 2]>; 2],
    data: Vec<Acc>,
    /// Extra channels per storage pixel (the integrator's AOVs): Σw·a and Σw·a², `nch` each,
    /// exact like the colour sums; a non-finite channel value counts as 0.
    nch: usize,
    extra: Vec<[i128; 2]>,
    /// The 8-wide splats' addends: row k holds lane k's eight fixed-point addends as words,
    /// in [`Acc::words`]' layout (scratch, kept here so that it is not zeroed per call).
    lanes: Box<[[[u64; 8]; 2]; 8]>,
    /// [`FilmDesc::second_moments`]: the 8-wide splats convert and add Σw·v² and Σw² too.
    second: bool,
    /// j·`sw` for j = 0, …, 7 (wrapping): the storage offsets of a footprint's rows.
    rows: [i32; 8],
    /// The AVX2 token when the CPU has it: [`Block::put`] splats in lanes then.
    #[cfg(target_arch = "x86_64")]
    avx: Option<crate::lane::Avx2>,
}

impl Block {
    /// A block for the pixels [x0, x0+w) × [y0, y0+h) of the full film (normally inside the crop),
    /// plus a border of ceil(radius) pixels on each side.
    pub fn new(desc: &FilmDesc, x0: u32, y0: u32, w: u32, h: u32) -> Block {
        Block::with_channels(desc, x0, y0, w, h, 0)
    }

    /// Like [`Block::new`], with `nch` extra channels per pixel (filtered like the image).
    pub fn with_channels(desc: &FilmDesc, x0: u32, y0: u32, w: u32, h: u32, nch: usize) -> Block {
        let filter = desc.filter;
        let radius = filter.radius();
        let border = if radius.is_finite() && radius > 0.0 {
            radius.ceil().min(1024.0) as u32
        } else {
            0
        };
        let mut b = Block {
            filter,
            table: FilterTable::new(&filter),
            border,
            ox: 0,
            oy: 0,
            sw: 0,
            sh: 0,
            exact: [None; 2],
            data: Vec::new(),
            nch,
            extra: Vec::new(),
            lanes: Box::new([[[0; 8]; 2]; 8]),
            second: desc.second_moments,
            rows: [0; 8],
            #[cfg(target_arch = "x86_64")]
            avx: crate::lane::Avx2::detect(),
        };
        b.clear(x0, y0, w, h);
        b
    }

    /// Zeroes the block and moves it to another rectangle, reusing its allocation when it fits.
    pub fn clear(&mut self, x0: u32, y0: u32, w: u32, h: u32) {
        self.ox = x0 as i64 - self.border as i64;
        self.oy = y0 as i64 - self.border as i64;
        self.sw = w.saturating_add(2 * self.border);
        self.sh = h.saturating_add(2 * self.border);
        self.rows = core::array::from_fn(|j| (j as i32).wrapping_mul(self.sw as i32));
        self.exact = [
            exact_bounds(self.ox, self.sw),
            exact_bounds(self.oy, self.sh),
        ];
        // With AVX2 the pixels are written under the lanes' target features (four 32-byte
        // stores and a 2-byte one a 144-byte pixel, not nine 16-byte and 2-byte ones: at 2
        // samples a pixel the clear cost ~5.6 instructions a sample on metal_plastic,
        // `docs/bench/README.md`, thirty-seventh session, h2).
        let n = self.sw as usize * self.sh as usize;
        let data = &mut self.data;
        data.clear();
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            avx.run(
                #[inline(always)]
                || data.resize(n, Acc::default()),
            );
        } else {
            data.resize(n, Acc::default());
        }
        #[cfg(not(target_arch = "x86_64"))]
        data.resize(n, Acc::default());
        self.extra.clear();
        self.extra
            .resize(self.sw as usize * self.sh as usize * self.nch, [0; 2]);
    }

    /// Adds the extra channels `a` with weight `w` to storage pixel `idx`.
    #[inline]
    fn add_extra(&mut self, idx: usize, a: &[f32], w: f32) {
        let n = self.nch;
        for (e, &v) in self.extra[idx * n..idx * n + n].iter_mut().zip(a) {
            let wv = v * w;
            if wv.is_finite() {
                sum::add_signed(&mut e[0], sum::fixed(wv));
                sum::add_unsigned(&mut e[1], sum::fixed(wv * v));
            }
        }
    }

    /// Splats `value` at the continuous full-film position `film_pos` (Mitsuba 3
    /// `ImageBlock::put`): every pixel (i, j) whose centre (i+½, j+½) lies within the filter radius
    /// on both axes receives weight wx·wy from the tabulated filter. Positions outside the block
    /// storage only reach the pixels that exist; non-finite positions are ignored. Non-finite
    /// values are recorded per pixel and channel, and the developed pixel shows them (NaN, or
    /// ±∞ when only one sign of infinity arrived).
    ///
    /// With AVX2, the box filter takes [`Block::put_box_lanes`] and the other filters
    /// [`Block::splat_lanes`] (the same sums to the bit: the scalar renderer's splats convert
    /// 8 addends at a time too).
    pub fn put(&mut self, film_pos: Vec2, value: Spectrum) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            if self.filter.is_box() {
                avx.run(
                    #[inline(always)]
                    || self.put_box_lanes(avx, film_pos, value),
                );
            } else {
                avx.run(
                    #[inline(always)]
                    || self.splat_lanes(avx, film_pos, value),
                );
            }
            return;
        }
        self.splat::<false>(film_pos, value, &[]);
    }

    /// [`Block::put`] under the box filter with AVX2: the pixel as [`Block::splat`] finds it;
    /// the sample's eight addends (v and v·v per channel, the same f32 products, then the
    /// weights 1 and 1) converted in one register and joined in four ([`sum::Fixed8::row`])
    /// and added in four ([`crate::lane::Avx2::add_i128x8_biased_regs`]) when every addend is
    /// in `fixed`'s common range or zero (so every value is finite and no flag is due); else
    /// [`Acc::add_unit_sample`], as the scalar splat. Call inside [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn put_box_lanes(&mut self, avx: crate::lane::Avx2, film_pos: Vec2, value: Spectrum) {
        if !film_pos.is_finite() || self.sw == 0 || self.sh == 0 {
            return;
        }
        let px = storage_index(film_pos.x, self.ox, self.sw, self.exact[0]);
        let py = storage_index(film_pos.y, self.oy, self.sh, self.exact[1]);
        let (Some(px), Some(py)) = (px, py) else {
            return;
        };
        let a = &mut self.data[py * self.sw as usize + px];
        let [r, g, b] = value.to_array();
        // The addends r, g, b, 1, r·r, g·g, b·b, 1 (slots 0 to 7) in the row conversion's
        // lane order (`crate::lane::ROW_LANES`: lane l gives the slot i whose
        // `ROW_LANES[i]` is l, slots 0, 1, 4, 5, 2, 3, 6, 7).
        let x = avx.load(&[r, g, r * r, g * g, b, 1.0, b * b, 1.0]);
        match sum::Fixed8::single(avx).row(x) {
            Some(row) if self.second => {
                avx.add_i128x8_biased_regs::<UNSIGNED_SUMS>(&mut a.words, row)
            }
            Some(row) => avx.add_i128x4_biased_regs::<UNSIGNED_SUMS>(&mut a.words, row),
            None => a.add_unit_sample([r, g, b]),
        }
    }

    /// [`Block::put`] of eight samples in turn, with the same sums to the bit. For the box
    /// filter (and finite values) the samples' fixed-point addends, w·v = v and w·v² = v·v per
    /// channel, are computed 8-wide ([`sum::Fixed8::into_columns`]) and added 8 sums at a time,
    /// and so are their pixels where the block's bounds are exact f32s (every real film;
    /// [`storage_index`] in lanes); the addends go to each sample's pixel. Other filters and
    /// non-finite values take [`Block::put`] per sample (their exact weights, unchanged). The
    /// sums are integer sums, so this equals `put` whatever the order ([`sum`]). (The tests'
    /// reference for [`Block::put8_finite`], which the stream renderer calls.)
    #[cfg(all(target_arch = "x86_64", test))]
    pub(crate) fn put8(&mut self, avx: crate::lane::Avx2, pos: &[Vec2; 8], value: &[Spectrum; 8]) {
        avx.run(
            #[inline(always)]
            || {
                let [r, g, b] = columns(avx, value);
                if self.filter.is_box() {
                    self.put8_columns::<true>(avx, pos, [r, g, b]);
                } else {
                    self.put8_columns::<false>(avx, pos, [r, g, b]);
                }
            },
        );
    }

    /// [`Block::put`] of eight samples in turn (the same sums to the bit; the fast paths of
    /// `put8`, the tests' reference), with every non-finite value (any channel NaN or infinite)
    /// replaced by 0, as the renderers drop invalid samples; returns how many were replaced.
    /// The finiteness test and the replacement are 8-wide. (The tests' form of
    /// [`Block::put8_finite_rows`], through it: the values as rows whose fourth float is a NaN,
    /// which it ignores.)
    #[cfg(all(target_arch = "x86_64", test))]
    pub(crate) fn put8_finite(
        &mut self,
        avx: crate::lane::Avx2,
        pos: &[Vec2; 8],
        value: &[Spectrum; 8],
    ) -> u32 {
        let rows = value.map(|v| [v.x, v.y, v.z, f32::NAN]);
        self.put8_finite_rows(avx, pos, &rows)
    }

    /// [`Block::put`] of eight samples in turn, every non-finite value replaced by 0 (returns
    /// how many were replaced), the values given as rows of 4 floats (R, G, B and a float
    /// that is ignored: the stream renderer's path states' radiance rows,
    /// `PathState::result_row`), read into lanes by one 16-byte load per row and two 4×4
    /// transposes ([`crate::lane::Avx2::fields4`]), not 24 scalar loads and stores.
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn put8_finite_rows(
        &mut self,
        avx: crate::lane::Avx2,
        pos: &[Vec2; 8],
        rows: &[[f32; 4]; 8],
    ) -> u32 {
        use crate::lane::{F32x8, Lane, LaneMask};
        // The box splat and the others as two functions (two closures, two `Avx2::run`
        // instances), each compiled with its own registers: in one body, the box splat's rows
        // in registers cost the Gaussian splat ~19 instructions a sample in spills (cbox).
        #[inline(always)]
        fn put<const BOX: bool>(
            block: &mut Block,
            avx: crate::lane::Avx2,
            pos: &[Vec2; 8],
            rows: &[[f32; 4]; 8],
        ) -> u32 {
            let [r, g, b, _] = avx.fields4(rows);
            let ok = r.is_finite() & g.is_finite() & b.is_finite();
            let mut invalid = 0;
            let cols = if ok.all() {
                [r, g, b]
            } else {
                invalid = ok.to_array().iter().filter(|&&f| !f).count() as u32;
                // +0.0, the bits of `Spectrum::ZERO`.
                let z = avx.splat(0.0);
                [r, g, b].map(|c| F32x8::select(ok, c, z))
            };
            block.put8_columns::<BOX>(avx, pos, cols);
            invalid
        }
        if self.filter.is_box() {
            avx.run(
                #[inline(always)]
                || put::<true>(self, avx, pos, rows),
            )
        } else {
            avx.run(
                #[inline(always)]
                || put::<false>(self, avx, pos, rows),
            )
        }
    }

    /// `put8` of the values given as their R, G and B columns, `BOX` saying whether the
    /// block's filter is the box (the caller's test: the two forms compile apart). Call inside
    /// [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn put8_columns<const BOX: bool>(
        &mut self,
        avx: crate::lane::Avx2,
        pos: &[Vec2; 8],
        rgb: [crate::lane::F32x8; 3],
    ) {
        use crate::lane::{I32x8, Lane, LaneI32, LaneMask};
        let [r, g, b] = rgb;
        let finite = (r.is_finite() & g.is_finite() & b.is_finite()).all();
        let bounds = match self.exact {
            [Some(x), Some(y)] => Some((x, y)),
            _ => None,
        };
        let (true, true, Some(([x_lo, x_hi], [y_lo, y_hi]))) =
            (finite, BOX && self.sw != 0 && self.sh != 0, bounds)
        else {
            let (r, g, b) = (r.to_array(), g.to_array(), b.to_array());
            // Finite values under another filter: the eight footprints together when they
            // overlap (a renderer's samples of one pixel), else each footprint in lanes.
            let lanes = finite && !BOX;
            if lanes && self.splat8_grouped(avx, pos, rgb) {
                return;
            }
            for (k, &p) in pos.iter().enumerate() {
                let v = Spectrum::new(r[k], g[k], b[k]);
                if lanes {
                    self.splat_lanes(avx, p, v);
                } else {
                    self.put(p, v);
                }
            }
            return;
        };
        let pairs = self.pairs();
        let fx = sum::Fixed8::new(avx);
        // The addends in slot order: v and the weight 1 (`sum::fixed(1.0)` is `sum::ONE`), then
        // v·v and 1; the second pairs only when the film keeps the second moments. Without
        // them, the lanes' rows in registers when every addend converts 8-wide.
        let one = avx.splat(1.0);
        let rows = if self.second {
            None
        } else {
            fx.rows4([r, g, b, one])
        };
        if rows.is_none() {
            let t = &mut *self.lanes;
            let xs = [r, g, b, one, r * r, g * g, b * b, one];
            for p in 0..pairs {
                fx.into_columns([xs[2 * p], xs[2 * p + 1]], t, 2 * p);
            }
        }
        // `storage_index` with exact bounds, in lanes: inside [lo, hi) on both axes (false for
        // NaN and ±∞, so the scalar path's finiteness test is implied), floor(x) − origin.
        let [x, y] = avx.vec2_columns(pos);
        let inside = x.ge(avx.splat(x_lo))
            & x.lt(avx.splat(x_hi))
            & y.ge(avx.splat(y_lo))
            & y.lt(avx.splat(y_hi));
        let floor = |v: crate::lane::F32x8| {
            let t = v.trunc_i32();
            let up = t.to_f32().gt(v);
            t.sub(I32x8::select(up, t.splat(1), t.splat(0)))
        };
        // Exact bounds hold |origin| <= 2^24: the differences fit an i32.
        let pxv = floor(x).sub(avx.load_i32(&[self.ox as i32; 8]));
        let pyv = floor(y).sub(avx.load_i32(&[self.oy as i32; 8]));
        let (px, py) = (pxv.to_array(), pyv.to_array());
        if !inside.any() {
            return;
        }
        let sw = self.sw as usize;
        let (data, t, second) = (&mut self.data[..], &*self.lanes, self.second);
        // All eight samples on one pixel (a renderer's samples of a pixel come in turn: with 8
        // or more a pixel, most groups): their rows summed in registers and added once. The
        // colour sums wrap and Σw saturates on non-negative addends, both associative, so the
        // sums are those of eight adds.
        let all_inside = rows.is_some() && inside.all();
        let one_pixel = all_inside && (pxv.eq(pxv.splat(px[0])) & pyv.eq(pyv.splat(py[0]))).all();
        // Otherwise each pair of lanes (2j, 2j + 1) on one pixel, and each four (4h to 4h + 3)
        // too (a render at 2 or 4 samples a pixel, whose chunks of eight cover four or two
        // whole pixels): the pair's or the four's rows summed in registers and added once, by
        // the same associativity. Each lane's pixel against lane `idx[k]`'s (`vpermd`), on
        // both axes.
        #[inline(always)]
        fn same_as(avx: crate::lane::Avx2, [x, y]: [I32x8; 2], idx: &[i32; 8]) -> bool {
            let idx = avx.load_i32(idx);
            (x.eq(x.permute(idx)) & y.eq(y.permute(idx))).all()
        }
        let pairs = all_inside && !one_pixel && same_as(avx, [pxv, pyv], &[1, 0, 3, 2, 5, 4, 7, 6]);
        let fours = pairs && same_as(avx, [pxv, pyv], &[2, 3, 0, 1, 6, 7, 4, 5]);
        let inside = inside.to_array();
        let at = |k: usize| py[k] as usize * sw + px[k] as usize;
        use crate::lane::I128x4;
        match rows {
            Some(rows) if one_pixel => {
                let sum = I128x4::sum8(&rows);
                data[at(0)].add_row(avx, sum);
            }
            Some(rows) if fours => {
                for h in 0..2 {
                    let four = [
                        rows[4 * h],
                        rows[4 * h + 1],
                        rows[4 * h + 2],
                        rows[4 * h + 3],
                    ];
                    data[at(4 * h)].add_row(avx, I128x4::sum(&four));
                }
            }
            Some(rows) if pairs => {
                for j in 0..4 {
                    let sum = I128x4::sum(&[rows[2 * j], rows[2 * j + 1]]);
                    data[at(2 * j)].add_row(avx, sum);
                }
            }
            Some(rows) => {
                for (k, row) in rows.into_iter().enumerate() {
                    if inside[k] {
                        data[at(k)].add_row(avx, row);
                    }
                }
            }
            None => {
                for (k, inside) in inside.into_iter().enumerate() {
                    if inside {
                        let a = &mut data[at(k)];
                        a.add_addends(avx, second, &t[k]);
                    }
                }
            }
        }
    }

    /// [`Block::put`] with the values of the block's extra channels (`aovs`, one per channel;
    /// ignored when the block has none), splatted with the same filter weights.
    pub fn put_channels(&mut self, film_pos: Vec2, value: Spectrum, aovs: &[f32]) {
        self.splat::<true>(film_pos, value, aovs);
    }

    /// The splat of [`Block::put`] (`EXTRA` false: the extra channels compiled out of the hot
    /// path) and [`Block::put_channels`].
    #[inline(always)]
    fn splat<const EXTRA: bool>(&mut self, film_pos: Vec2, value: Spectrum, aovs: &[f32]) {
        let aovs = if EXTRA && self.nch > 0 && aovs.len() >= self.nch {
            &aovs[..self.nch]
        } else {
            &[]
        };
        if !film_pos.is_finite() || self.sw == 0 || self.sh == 0 {
            return;
        }
        let v = value.to_array();
        if self.filter.is_box() {
            let px = storage_index(film_pos.x, self.ox, self.sw, self.exact[0]);
            let py = storage_index(film_pos.y, self.oy, self.sh, self.exact[1]);
            if let (Some(px), Some(py)) = (px, py) {
                let idx = py * self.sw as usize + px;
                self.data[idx].add_unit_sample(v);
                if !aovs.is_empty() {
                    self.add_extra(idx, aovs, 1.0);
                }
            }
            return;
        }
        let Some(fp) = self.footprint(film_pos) else {
            return;
        };
        let (nx, ny) = (fp.nx, fp.ny);
        // The footprint is at most 2·border+1 wide; keep the weights on the stack when small.
        let mut wx_buf = [0.0f32; 16];
        let mut wy_buf = [0.0f32; 16];
        let mut wx_heap = Vec::new();
        let mut wy_heap = Vec::new();
        let (wx, wy): (&mut [f32], &mut [f32]) = if nx <= 16 && ny <= 16 {
            (&mut wx_buf[..nx], &mut wy_buf[..ny])
        } else {
            wx_heap.resize(nx, 0.0);
            wy_heap.resize(ny, 0.0);
            (&mut wx_heap[..], &mut wy_heap[..])
        };
        fp.weights(&self.table, wx, wy);
        let (x_lo, y_lo) = (fp.x_lo, fp.y_lo);
        let sw = self.sw as usize;
        for (j, &wyj) in wy.iter().enumerate() {
            let row = (y_lo + j) * sw + x_lo;
            for (i, &wxi) in wx.iter().enumerate() {
                self.data[row + i].add_sample(v, wxi * wyj);
                if !aovs.is_empty() {
                    self.add_extra(row + i, aovs, wxi * wyj);
                }
            }
        }
    }
}

impl Block {
    /// The pairs of addend columns an 8-wide splat converts: the four slots of Σw·v and Σw,
    /// and the four of the second moments when the film keeps them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn pairs(&self) -> usize {
        if self.second {
            4
        } else {
            2
        }
    }

    /// The pixels that a splat at `film_pos` reaches under a filter other than the box, cut to
    /// the storage; `None` when it reaches none.
    #[inline(always)]
    fn footprint(&self, film_pos: Vec2) -> Option<Footprint> {
        let r = self.filter.radius();
        // Position in full-film pixel-centre coordinates: the footprint and its weights must
        // not depend on where the block lies (a split render puts blocks elsewhere).
        let pxf = film_pos.x - 0.5;
        let pyf = film_pos.y - 0.5;
        // Footprint in full-film pixels, then cut to the storage.
        let lo = [(pxf - r).ceil() as i64, (pyf - r).ceil() as i64];
        let hi = [
            crate::math::floor(pxf + r) as i64,
            crate::math::floor(pyf + r) as i64,
        ];
        self.cut_footprint(lo, hi, pxf, pyf)
    }

    /// [`Block::footprint`] where every bound (the position ± the radius, in pixel-centre
    /// coordinates) is below 2²³ in magnitude, as on every film a renderer makes: the two
    /// ceilings and two floors as one truncation in lanes and a correction by one where the
    /// truncation lies on the wrong side (exact: such floats convert to integers exactly),
    /// where the scalar form takes four saturating conversions and their range tests. Any
    /// other position (NaN, huge) takes `footprint`. Call inside [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn footprint_lanes(&self, avx: crate::lane::Avx2, film_pos: Vec2) -> Option<Footprint> {
        use crate::lane::{I32x8, Lane, LaneI32, LaneMask};
        let r = self.filter.radius();
        let (pxf, pyf) = (film_pos.x - 0.5, film_pos.y - 0.5);
        let v = avx.load(&[pxf - r, pyf - r, pxf + r, pyf + r, 0.0, 0.0, 0.0, 0.0]);
        // False for NaN too.
        if !v.abs().lt(avx.splat(8_388_608.0)).all() {
            return self.footprint(film_pos);
        }
        let t = v.trunc_i32();
        let tf = t.to_f32();
        let (one, zero) = (t.splat(1), t.splat(0));
        let ceil = t.add(I32x8::select(tf.lt(v), one, zero)).to_array();
        let floor = t.sub(I32x8::select(tf.gt(v), one, zero)).to_array();
        self.cut_footprint(
            [ceil[0] as i64, ceil[1] as i64],
            [floor[2] as i64, floor[3] as i64],
            pxf,
            pyf,
        )
    }

    /// The footprint whose full-film pixel bounds are `lo` to `hi` (inclusive, x then y), cut
    /// to the storage; `pxf`, `pyf` the splat position in pixel-centre coordinates.
    #[inline(always)]
    fn cut_footprint(&self, lo: [i64; 2], hi: [i64; 2], pxf: f32, pyf: f32) -> Option<Footprint> {
        let fx_lo = lo[0].max(self.ox);
        let fy_lo = lo[1].max(self.oy);
        let fx_hi = hi[0].min(self.ox + self.sw as i64 - 1);
        let fy_hi = hi[1].min(self.oy + self.sh as i64 - 1);
        if fx_lo > fx_hi || fy_lo > fy_hi {
            return None;
        }
        Some(Footprint {
            x_lo: (fx_lo - self.ox) as usize,
            y_lo: (fy_lo - self.oy) as usize,
            nx: (fx_hi - fx_lo + 1) as usize,
            ny: (fy_hi - fy_lo + 1) as usize,
            rel_x: fx_lo as f32 - pxf,
            rel_y: fy_lo as f32 - pyf,
        })
    }

    /// [`Block::put`] of one value with finite channels under a filter other than the box, the
    /// footprint's pixels 8 at a time: each pixel's weight w = wx·wy and its addends w·v, w·v²
    /// (per channel), w and w² are the same f32 products as [`Block::splat`]'s, turned into
    /// fixed point 8-wide ([`sum::Fixed8::into_columns`], equal to [`sum::fixed`] lane by lane), so the sums
    /// are the scalar splat's to the bit. A footprint of up to 8×8 pixels is laid out in lanes: the weights
    /// of each axis in one register ([`FilterTable::eval8`]), and each group of 8 pixels takes
    /// its wx, wy and storage index by lane permutes ([`FOOT_I`], [`FOOT_J`]). A footprint of up
    /// to 16×16 takes the weights one by one; a wider one, or one where some w·v could be
    /// non-finite (which `put` records as a flag), takes the scalar splat. Call inside
    /// [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn splat_lanes(&mut self, avx: crate::lane::Avx2, film_pos: Vec2, value: Spectrum) {
        use crate::lane::LaneI32;
        if !film_pos.is_finite() || self.sw == 0 || self.sh == 0 {
            return;
        }
        let Some(fp) = self.footprint_lanes(avx, film_pos) else {
            return;
        };
        let v = value.to_array();
        // Every weight wx·wy is at most `max_sq` in magnitude, so a finite |v|·max_sq on every
        // channel means every w·v is finite (rounding is monotonic). Storage indices are i32s.
        let wmax = self.table.max_sq;
        let finite = v.iter().all(|&c| (c.abs() * wmax).is_finite());
        if !finite || fp.nx > 16 || fp.ny > 16 || self.data.len() > i32::MAX as usize {
            self.splat::<false>(film_pos, value, &[]);
            return;
        }
        let sw = self.sw as usize;
        let base = ((fp.y_lo * sw) + fp.x_lo) as i32;
        let fx = sum::Fixed8::new(avx);
        if fp.nx <= 8 && fp.ny <= 8 {
            let iota = avx.load(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
            let wx = self.table.eval8(avx, avx.splat(fp.rel_x) + iota);
            let wy = self.table.eval8(avx, avx.splat(fp.rel_y) + iota);
            let rows = avx.load_i32(&self.rows).add(avx.load_i32(&[base; 8]));
            let n = fp.nx * fp.ny;
            let (ti, tj) = (&FOOT_I[fp.nx - 1], &FOOT_J[fp.nx - 1]);
            for (g, (fi, fj)) in ti.iter().zip(tj).enumerate().take(n.div_ceil(8)) {
                let (i, j) = (avx.load_i32(fi), avx.load_i32(fj));
                let w = wx.permute(i) * wy.permute(j);
                let at = rows.permute(j).add(i).to_array();
                self.add8(avx, fx, w, &at, (n - 8 * g).min(8), v);
            }
            return;
        }
        let (mut wx, mut wy) = ([0.0f32; 16], [0.0f32; 16]);
        let (wx, wy) = (&mut wx[..fp.nx], &mut wy[..fp.ny]);
        fp.weights(&self.table, wx, wy);
        let (mut w, mut at, mut n) = ([0.0f32; 8], [0i32; 8], 0);
        for (j, &wyj) in wy.iter().enumerate() {
            let row = base + (j * sw) as i32;
            for (i, &wxi) in wx.iter().enumerate() {
                w[n] = wxi * wyj;
                at[n] = row + i as i32;
                n += 1;
                if n == 8 {
                    self.add8(avx, fx, avx.load(&w), &at, 8, v);
                    n = 0;
                }
            }
        }
        if n > 0 {
            self.add8(avx, fx, avx.load(&w), &at, n, v);
        }
    }

    /// [`Block::put`] of eight values with finite channels under a filter other than the box,
    /// the eight footprints taken together: over the union of the footprints (at most
    /// [`GROUP_SIDE`] pixels a side and [`GROUP_AREA`] pixels, as when the eight samples lie in
    /// one pixel, whose 4×4 Gaussian footprints cover 5×5), each pixel takes the eight
    /// samples' weights in lanes, lane k sample k's: w = wx·wy with wx, wy the same table
    /// values at the same f32 offsets `rel + i` as [`Block::splat_lanes`] takes them (the
    /// sample's own footprint start and index), and 0 where the pixel is outside the sample's
    /// footprint. Its addends w·v and w (the same f32 products) are converted 8-wide as rows
    /// ([`sum::Fixed8::rows4`]), summed in registers ([`crate::lane::I128x4::sum8`]) and added
    /// to the pixel once, instead of eight samples × 16 pixels of single adds. A lane with
    /// weight 0 adds 0 (`fixed(±0) = 0`); the colour sums wrap and Σw saturates on
    /// non-negative addends whose eight-sum cannot overflow ([`FilterTable::groupable`]),
    /// both associative, so every pixel's sums are the per-sample splat's to the bit. A pixel
    /// where some addend is outside the conversion's common range takes its lanes' addends
    /// one by one ([`sum::fixed`]). Returns false, having added nothing, where this does not
    /// apply: a film with second moments, a wider union, a position or value that the
    /// per-sample splat treats specially. Call inside [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn splat8_grouped(
        &mut self,
        avx: crate::lane::Avx2,
        pos: &[Vec2; 8],
        rgb: [crate::lane::F32x8; 3],
    ) -> bool {
        use crate::lane::{F32x8, I128x4, I32x8, Lane, LaneI32, LaneMask};
        if self.second
            || !self.table.groupable
            || self.sw == 0
            || self.sh == 0
            || self.data.len() > i32::MAX as usize
        {
            return false;
        }
        // The union is at least (span + 2·radius − 1) pixels a side: a chunk of samples
        // spread over several pixels of a row (a render at 1 sample a pixel) is declined here,
        // before its footprints are computed (an estimate: the exact test follows).
        let [x, y] = avx.vec2_columns(pos);
        let rad = self.filter.radius();
        let (xa, ya) = (x.to_array(), y.to_array());
        let (mut lo, mut hi) = ([xa[0], ya[0]], [xa[0], ya[0]]);
        for k in 1..8 {
            (lo[0], hi[0]) = (lo[0].min(xa[k]), hi[0].max(xa[k]));
            (lo[1], hi[1]) = (lo[1].min(ya[k]), hi[1].max(ya[k]));
        }
        let side = [0, 1].map(|d| hi[d] - lo[d] + 2.0 * rad - 1.0);
        let area = side[0] * side[1];
        if area.is_nan() || area > GROUP_AREA as f32 {
            return false;
        }
        let [r, g, b] = rgb;
        // `splat_lanes`' test that every w·v is finite, lane by lane.
        let wmax = avx.splat(self.table.max_sq);
        let finite = (r.abs() * wmax).is_finite()
            & (g.abs() * wmax).is_finite()
            & (b.abs() * wmax).is_finite();
        if !finite.all() {
            return false;
        }
        // `footprint_lanes` in lanes of samples: the bounds below 2²³ (false for NaN and
        // ±∞, `splat_lanes`' finiteness test), the ceilings and floors by truncation.
        let (rad, half) = (avx.splat(rad), avx.splat(0.5));
        let p = [x - half, y - half];
        let ends = [p[0] - rad, p[1] - rad, p[0] + rad, p[1] + rad];
        let big = avx.splat(8_388_608.0);
        let near = ends[0].abs().lt(big)
            & ends[1].abs().lt(big)
            & ends[2].abs().lt(big)
            & ends[3].abs().lt(big);
        if !near.all() {
            return false;
        }
        /// The ceiling (`up`) or the floor of each lane, exact below 2²³ (a function, not a
        /// closure: a closure may be compiled out of line, without AVX2).
        #[inline(always)]
        fn round(v: F32x8, up: bool) -> [i32; 8] {
            let t = v.trunc_i32();
            let (one, zero) = (t.splat(1), t.splat(0));
            if up {
                t.add(I32x8::select(t.to_f32().lt(v), one, zero))
            } else {
                t.sub(I32x8::select(t.to_f32().gt(v), one, zero))
            }
            .to_array()
        }
        let lo = [round(ends[0], true), round(ends[1], true)];
        let hi = [round(ends[2], false), round(ends[3], false)];
        // `cut_footprint` per sample; the union of the footprints that reach the storage.
        let org = [self.ox, self.oy];
        let end = [self.ox + self.sw as i64 - 1, self.oy + self.sh as i64 - 1];
        let mut cut = [[[0i64; 2]; 2]; 8];
        let mut reach = [false; 8];
        let (mut u_lo, mut u_hi) = ([i64::MAX; 2], [i64::MIN; 2]);
        for k in 0..8 {
            let a = [0, 1].map(|d| (lo[d][k] as i64).max(org[d]));
            let z = [0, 1].map(|d| (hi[d][k] as i64).min(end[d]));
            if a[0] > z[0] || a[1] > z[1] {
                continue;
            }
            (cut[k], reach[k]) = ([a, z], true);
            for d in 0..2 {
                u_lo[d] = u_lo[d].min(a[d]);
                u_hi[d] = u_hi[d].max(z[d]);
            }
        }
        if !reach.iter().any(|&f| f) {
            return true;
        }
        let n = [0, 1].map(|d| (u_hi[d] - u_lo[d] + 1) as usize);
        if n[0] > GROUP_SIDE || n[1] > GROUP_SIDE || n[0] * n[1] > GROUP_AREA {
            return false;
        }
        // Per axis and union column (row) c, lane k's weight: the table at the sample's
        // `rel + i`, i = c − (its footprint's start − the union's), where 0 ≤ i < its width;
        // else 0. A sample that reaches no pixel has width 0.
        let zero = avx.splat(0.0);
        let mut w = [[zero; GROUP_SIDE]; 2];
        for d in 0..2 {
            let start: [i32; 8] = core::array::from_fn(|k| (cut[k][0][d] - u_lo[d]) as i32);
            let width: [i32; 8] = core::array::from_fn(|k| {
                if reach[k] {
                    (cut[k][1][d] - cut[k][0][d] + 1) as i32
                } else {
                    0
                }
            });
            let first: [f32; 8] = core::array::from_fn(|k| cut[k][0][d] as f32);
            let (start, width) = (avx.load_i32(&start), avx.load_i32(&width));
            let rel = avx.load(&first) - p[d];
            for (c, wc) in w[d].iter_mut().enumerate().take(n[d]) {
                let i = start.splat(c as i32).sub(start);
                let on = i.gt(i.splat(-1)) & width.gt(i);
                *wc = F32x8::select(on, self.table.eval8(avx, rel + i.to_f32()), zero);
            }
        }
        let [wx, wy] = w;
        let fx = sum::Fixed8::new(avx);
        let sw = self.sw as usize;
        let base = (u_lo[1] - self.oy) as usize * sw + (u_lo[0] - self.ox) as usize;
        for (j, &wyj) in wy.iter().enumerate().take(n[1]) {
            for (i, &wxi) in wx.iter().enumerate().take(n[0]) {
                let w8 = wxi * wyj;
                let on = w8.ne(zero);
                if !on.any() {
                    continue;
                }
                let xs = [r * w8, g * w8, b * w8, w8];
                let a = &mut self.data[base + j * sw + i];
                match fx.rows4_small(xs) {
                    Some(rows) => a.add_row(avx, I128x4::sum8(&rows)),
                    None => {
                        let xs = [
                            xs[0].to_array(),
                            xs[1].to_array(),
                            xs[2].to_array(),
                            xs[3].to_array(),
                        ];
                        for (k, on) in on.to_array().into_iter().enumerate() {
                            if on {
                                let mut t = [[0u64; 8]; 2];
                                for (c, x) in xs.iter().enumerate() {
                                    let v = sum::fixed(x[k]);
                                    (t[0][c], t[1][c]) = (v as u64, (v >> 64) as u64);
                                }
                                a.add_addends(avx, false, &t);
                            }
                        }
                    }
                }
            }
        }
        true
    }

    /// Adds the first `n` of eight weighted contributions of the value `v` (weights `w`, to
    /// the storage pixels `at`): [`Acc::add_sample`] with the addends converted 8-wide. Call
    /// inside [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn add8(
        &mut self,
        avx: crate::lane::Avx2,
        fx: sum::Fixed8,
        w8: crate::lane::F32x8,
        at: &[i32; 8],
        n: usize,
        v: [f32; 3],
    ) {
        let (r, g, b) = (avx.splat(v[0]), avx.splat(v[1]), avx.splat(v[2]));
        let (wr, wg, wb) = (r * w8, g * w8, b * w8);
        // The addends' columns in slot order, converted two at a time in a loop (one pair's
        // code, its constants held once: `sum::Fixed8`): w·v and w, then w·v·v and w·w only
        // when the film keeps the second moments.
        // (The rows in registers, `sum::Fixed8::rows4`, as the box splat takes them: 17
        // instructions a sample more on cbox, its 16 registers of words spilled around the
        // adds; the per-lane table stays here.)
        let xs = [wr, wg, wb, w8, wr * r, wg * g, wb * b, w8 * w8];
        let pairs = self.pairs();
        let (data, t, second) = (&mut self.data[..], &mut *self.lanes, self.second);
        for p in 0..pairs {
            fx.into_columns([xs[2 * p], xs[2 * p + 1]], t, 2 * p);
        }
        for (k, &a) in at.iter().enumerate().take(n) {
            data[a as usize].add_addends(avx, second, &t[k]);
        }
    }
}

/// The pixels a splat reaches (in storage coordinates) and the offsets of its first pixel
/// centre from the splat position along each axis, which the filter weights are taken at.
struct Footprint {
    x_lo: usize,
    y_lo: usize,
    nx: usize,
    ny: usize,
    rel_x: f32,
    rel_y: f32,
}

impl Footprint {
    /// The filter weights along each axis (`wx` of length `nx`, `wy` of length `ny`).
    #[inline(always)]
    fn weights(&self, table: &FilterTable, wx: &mut [f32], wy: &mut [f32]) {
        for (i, w) in wx.iter_mut().enumerate() {
            *w = table.eval(self.rel_x + i as f32);
        }
        for (j, w) in wy.iter_mut().enumerate() {
            *w = table.eval(self.rel_y + j as f32);
        }
    }
}

/// The R, G and B columns of eight values (the tests' `put8`). Call inside
/// [`crate::lane::Avx2::run`].
#[cfg(all(target_arch = "x86_64", test))]
#[inline(always)]
fn columns(avx: crate::lane::Avx2, value: &[Spectrum; 8]) -> [crate::lane::F32x8; 3] {
    [0, 1, 2].map(|c| avx.load(&core::array::from_fn(|k| value[k][c])))
}

/// The storage column (or row) of the pixel that holds the coordinate `x`, floor(x) − `origin`,
/// when it lies in [0, `size`). `exact` holds origin and origin + size as f32 when both are
/// exact (below 2²⁴ in magnitude, every real film): floor(x) ∈ [o, n) ⟺ x ∈ [o, n) for
/// integers o, n, so the test is two float comparisons and the floor is taken only of an x
/// known to fit an i32.
#[inline(always)]
fn storage_index(x: f32, origin: i64, size: u32, exact: Option<[f32; 2]>) -> Option<usize> {
    if let Some([lo, hi]) = exact {
        if !(x >= lo && x < hi) {
            return None;
        }
        let t = x as i32;
        let floor = t - (t as f32 > x) as i32;
        Some((floor as i64 - origin) as usize)
    } else {
        let p = (crate::math::floor(x) as i64).saturating_sub(origin);
        (p >= 0 && p < size as i64).then_some(p as usize)
    }
}

/// [`storage_index`]'s `exact` bounds of a storage axis from `origin` to `origin + size`.
fn exact_bounds(origin: i64, size: u32) -> Option<[f32; 2]> {
    const EXACT: i64 = 1 << 24;
    let end = origin + size as i64;
    (origin.abs() <= EXACT && end.abs() <= EXACT).then_some([origin as f32, end as f32])
}

/// The accumulated film: the crop window's pixels with their weighted sums.
#[derive(Clone, Debug)]
pub struct Film {
    desc: FilmDesc,
    /// Crop window in full-film pixels: (x0, y0, w, h).
    crop: (u32, u32, u32, u32),
    data: Vec<Acc>,
    /// Extra channels (see [`Block`]): Σw·a and Σw·a², `nch` per pixel.
    nch: usize,
    extra: Vec<[i128; 2]>,
}

impl Film {
    /// An empty film for `desc`'s crop window.
    pub fn new(desc: FilmDesc) -> Film {
        Film::with_channels(desc, 0)
    }

    /// An empty film with `nch` extra channels per pixel.
    pub fn with_channels(desc: FilmDesc, nch: usize) -> Film {
        let crop = desc.crop();
        let n = crop.2 as usize * crop.3 as usize;
        Film {
            data: vec![Acc::default(); n],
            nch,
            extra: vec![[0; 2]; n * nch],
            desc,
            crop,
        }
    }

    /// Number of extra channels.
    pub fn channel_count(&self) -> usize {
        self.nch
    }

    /// The description the film was made with.
    pub fn desc(&self) -> &FilmDesc {
        &self.desc
    }

    /// Adds a block, border included, into the film; contributions outside the crop window are
    /// dropped. Merging the same blocks in the same order gives a bit-identical film.
    pub fn merge(&mut self, block: &Block) {
        let (cx, cy, cw, ch) = self.crop;
        let (cx, cy, cw, ch) = (cx as i64, cy as i64, cw as i64, ch as i64);
        // The block's storage clipped to the crop, in storage (i, j) and crop (x, y) pixels.
        let i_lo = (cx - block.ox).max(0);
        let i_hi = (cx + cw - block.ox).min(block.sw as i64);
        let j_lo = (cy - block.oy).max(0);
        let j_hi = (cy + ch - block.oy).min(block.sh as i64);
        if i_lo >= i_hi || j_lo >= j_hi {
            return;
        }
        let n = (i_hi - i_lo) as usize;
        let (sw, cw) = (block.sw as usize, cw as usize);
        let x0 = (block.ox + i_lo - cx) as usize;
        #[cfg(target_arch = "x86_64")]
        let avx = crate::lane::Avx2::detect();
        for j in j_lo..j_hi {
            let si = j as usize * sw + i_lo as usize;
            let di = (block.oy + j - cy) as usize * cw + x0;
            let (d, s) = (&mut self.data[di..di + n], &block.data[si..si + n]);
            #[cfg(target_arch = "x86_64")]
            add_row(avx, self.desc.second_moments, d, s);
            #[cfg(not(target_arch = "x86_64"))]
            for (d, s) in d.iter_mut().zip(s) {
                d.add(s);
            }
            let k = self.nch.min(block.nch);
            if k == 0 {
                continue;
            }
            for p in 0..n {
                let src = &block.extra[(si + p) * block.nch..][..k];
                let dst = &mut self.extra[(di + p) * self.nch..][..k];
                for (d, e) in dst.iter_mut().zip(src) {
                    sum::add_signed(&mut d[0], e[0]);
                    sum::add_unsigned(&mut d[1], e[1]);
                }
            }
        }
    }

    /// The crop window in full-film pixels: (x0, y0, width, height).
    pub fn crop_rect(&self) -> (u32, u32, u32, u32) {
        self.crop
    }

    /// The exact sums of crop pixel `i` (row-major in the crop window). Panics when out of range.
    pub fn raw_pixel(&self, i: usize) -> RawPixel {
        RawPixel::from(&self.data[i])
    }

    /// The exact sums Σw·a, Σw·a² of extra channel `c` of crop pixel `i`. Panics when out of
    /// range.
    pub fn raw_extra(&self, i: usize, c: usize) -> [i128; 2] {
        self.extra[i * self.nch + c]
    }

    /// Adds exact sums to crop pixel `i` (`extra`: one pair per extra channel, the surplus
    /// ignored): how a merge of partial outputs adds them. Panics when `i` is out of range.
    pub fn add_raw(&mut self, i: usize, px: &RawPixel, extra: &[[i128; 2]]) {
        self.data[i].add(&Acc::from(px));
        for (d, e) in self.extra[i * self.nch..(i + 1) * self.nch]
            .iter_mut()
            .zip(extra)
        {
            sum::add_signed(&mut d[0], e[0]);
            sum::add_unsigned(&mut d[1], e[1]);
        }
    }

    /// The pixel estimates Σw·v / Σw of the crop window (0 where no sample landed).
    pub fn develop(&self) -> Image {
        let data = self
            .data
            .iter()
            .map(|a| [a.mean(0), a.mean(1), a.mean(2)])
            .collect();
        Image {
            width: self.crop.2,
            height: self.crop.3,
            data,
        }
    }

    /// Extra channel `c` developed like the image (Σw·a / Σw, 0 where no sample landed): one
    /// value per crop pixel, row-major. Empty when `c` is out of range.
    pub fn develop_channel(&self, c: usize) -> Vec<f32> {
        if c >= self.nch {
            return Vec::new();
        }
        self.data
            .iter()
            .enumerate()
            .map(|(i, a)| {
                if a.w() == 0 {
                    0.0
                } else {
                    (self.extra[i * self.nch + c][0] as f64 / a.w() as f64) as f32
                }
            })
            .collect()
    }

    /// The variance of extra channel `c`'s pixel estimates, by the estimator of
    /// [`Film::develop_variance`]. Empty when `c` is out of range; an error when the film keeps
    /// no second moments.
    pub fn develop_channel_variance(&self, c: usize) -> Result<Vec<f32>> {
        self.need_second_moments()?;
        if c >= self.nch {
            return Ok(Vec::new());
        }
        Ok(self
            .data
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let e = self.extra[i * self.nch + c];
                variance_of_mean(
                    sum::to_f64(a.w()),
                    sum::to_f64(a.w2()),
                    sum::to_f64(e[0]),
                    sum::to_f64(e[1]),
                )
            })
            .collect())
    }

    /// Whether the film keeps Σw·v² and Σw² ([`FilmDesc::second_moments`]).
    pub fn has_second_moments(&self) -> bool {
        self.desc.second_moments
    }

    /// An error unless the film keeps its second moments.
    fn need_second_moments(&self) -> Result<()> {
        if self.desc.second_moments {
            Ok(())
        } else {
            Err(Error::Usage(
                "this film was rendered without second moments (Σw·v², Σw²): it has no \
                 variance; render with `RenderOptions::second_moments` (a part file keeps them)"
                    .into(),
            ))
        }
    }

    /// Per-pixel variance of the pixel estimate (its squared standard error), per channel.
    ///
    /// Estimator: with W = Σw, W₂ = Σw², μ = Σw·v / W, the filter weights are treated as fixed
    /// and the samples as independent with a common variance σ², so Var(μ) = σ²·W₂/W². σ² is
    /// estimated without bias by the reliability-weighted sample variance
    /// (Σw·v²/W − μ²)·W²/(W² − W₂), giving
    ///
    /// Var(μ) ≈ (Σw·v²/W − μ²) · W₂ / (W² − W₂).
    ///
    /// With the box filter (w = 1) this is exactly the sample variance divided by n. A pixel
    /// without samples gets 0; a pixel with a single effective sample (W² ≤ W₂, e.g. one sample
    /// with the box filter) has no variance estimate and gets +∞.
    ///
    /// An error when the film keeps no second moments ([`FilmDesc::second_moments`]).
    pub fn develop_variance(&self) -> Result<Image> {
        self.need_second_moments()?;
        let data = self
            .data
            .iter()
            .map(|a| {
                let (w, w2) = (sum::to_f64(a.w()), sum::to_f64(a.w2()));
                [0, 1, 2]
                    .map(|c| variance_of_mean(w, w2, sum::to_f64(a.wv(c)), sum::to_f64(a.wv2(c))))
            })
            .collect();
        Ok(Image {
            width: self.crop.2,
            height: self.crop.3,
            data,
        })
    }
}

/// The variance of a weighted mean from its sums W = Σw, W₂ = Σw², Σw·v and Σw·v² (see
/// [`Film::develop_variance`]): 0 without samples, +∞ with a single effective sample.
fn variance_of_mean(w: f64, w2: f64, wv: f64, wv2: f64) -> f32 {
    if w == 0.0 {
        return 0.0;
    }
    let denom = w * w - w2;
    let mu = wv / w;
    let s = (wv2 / w - mu * mu).max(0.0);
    if denom <= 1e-12 * w * w {
        f32::INFINITY
    } else {
        (s * w2 / denom) as f32
    }
}

/// A developed RGB float image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            data: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Per-channel mean over all pixels, summed in f64 (0 for an empty image).
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for p in &self.data {
            for c in 0..3 {
                s[c] += p[c] as f64;
            }
        }
        let n = self.data.len().max(1) as f64;
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// True when any component is NaN or infinite.
    pub fn has_non_finite(&self) -> bool {
        self.data.iter().any(|p| p.iter().any(|v| !v.is_finite()))
    }

    /// The pixel at column `x`, row `y` (row 0 on top). Panics when out of range.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(x < self.width && y < self.height, "pixel out of range");
        self.data[y as usize * self.width as usize + x as usize]
    }
}

#[cfg(test)]
#[path = "film_tests.rs"]
mod tests;
