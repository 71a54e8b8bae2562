//! Mitsuba 3's `bitmap` texture: an image looked up by uv with bilinear or nearest filtering and
//! repeat / mirror / clamp wrapping.
//!
//! Semantics (Mitsuba 3.9.1 `scalar_rgb`, `src/textures/bitmap.cpp` and Dr.Jit's `Texture`,
//! checked point by point against Mitsuba in `tests/scene/texture.rs` with `tests/data/textures/points.json`):
//! - uv (0, 0) is the first stored row's first pixel (top-left); no v flip here.
//! - `to_uv` maps uv before the lookup (its 2-D affine part).
//! - bilinear: texel centres at ((i + 0.5)/w, (j + 0.5)/h); the four neighbours are wrapped
//!   independently. nearest: texel ⌊u·w⌋, ⌊v·h⌋, wrapped.
//! - 8- and 16-bit PNG/JPEG data is sRGB-encoded unless `raw` (a PNG's gAMA chunk is ignored,
//!   as Mitsuba does) and is decoded with the exact sRGB EOTF; EXR data is linear. Values are not
//!   clamped: an EXR reflectance above 1 is used as is (Mitsuba only warns).
//! - Storage precision (`format`): with `auto`, 8-bit codes decode exactly to f32, while 16-bit
//!   data and half-float EXRs are stored as float16 (Mitsuba stores bitmaps of ≤ 16 bits per
//!   channel in half precision); `variant` keeps f32; `fp16` rounds every texel to float16.
//! - Radiance RGBE (`.hdr`) and PFM files are read by [`super::float_image`] (linear f32 data,
//!   so `raw` changes nothing; stored as f32 under `auto`, as Mitsuba stores 32-bit data).
//! - Grey (Y, YA) images stay one-channel (they evaluate to grey); alpha is ignored for colour.
//! - Images narrower or shorter than 2 pixels are up-sampled to 2 (Mitsuba does so with a tent
//!   filter, which for a single row/column is a copy).

use std::fmt;
use std::path::{Path, PathBuf};

use exr::prelude::f16;
use glam::{Mat3, Vec2, Vec3};

use super::float_image;

mod lanes;
use crate::budget::{bytes_of, Budget};
use crate::error::{Error, Result};
use crate::spectrum::{luminance, Spectrum};

/// How texels are interpolated (`filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterType {
    #[default]
    Bilinear,
    Nearest,
}

impl FilterType {
    pub fn parse(s: &str) -> Option<FilterType> {
        match s {
            "bilinear" => Some(FilterType::Bilinear),
            "nearest" => Some(FilterType::Nearest),
            _ => None,
        }
    }
}

/// What happens outside [0, 1]² (`wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    Mirror,
    Clamp,
}

impl WrapMode {
    pub fn parse(s: &str) -> Option<WrapMode> {
        match s {
            "repeat" => Some(WrapMode::Repeat),
            "mirror" => Some(WrapMode::Mirror),
            "clamp" => Some(WrapMode::Clamp),
            _ => None,
        }
    }

    /// Maps an integer texel coordinate into [0, n).
    #[inline]
    fn apply(self, i: i64, n: i64) -> usize {
        // Inside the image every mode is the identity: skip the integer division.
        if (0..n).contains(&i) {
            return i as usize;
        }
        let r = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                // Period 2n: 0..n-1 forwards, then n-1..0 (so -1 → 0, n → n-1).
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        r as usize
    }
}

/// Texel storage precision (Mitsuba's `format`: `auto`, `variant`, `fp16`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum StorageFormat {
    /// 8-bit data exact, 16-bit data and half EXRs as float16, float EXRs as f32.
    #[default]
    Auto,
    /// Everything as f32.
    Variant,
    /// Everything rounded to float16.
    Fp16,
}

impl StorageFormat {
    pub fn parse(s: &str) -> Option<StorageFormat> {
        match s {
            "auto" => Some(StorageFormat::Auto),
            "variant" => Some(StorageFormat::Variant),
            "fp16" => Some(StorageFormat::Fp16),
            _ => None,
        }
    }
}

/// Options of a bitmap texture; the defaults are Mitsuba's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BitmapOptions {
    /// Keep the stored values (no sRGB decoding): normal maps, roughness maps.
    pub raw: bool,
    pub filter: FilterType,
    pub wrap: WrapMode,
    /// Affine map applied to uv before the lookup.
    pub to_uv: Mat3,
    pub format: StorageFormat,
}

impl Default for BitmapOptions {
    fn default() -> Self {
        BitmapOptions {
            raw: false,
            filter: FilterType::Bilinear,
            wrap: WrapMode::Repeat,
            to_uv: Mat3::IDENTITY,
            format: StorageFormat::Auto,
        }
    }
}

/// Texel storage: linear f32 RGB, or the 8-bit codes of an 8-bit image with their decoding
/// table. An 8-bit channel holds one of 256 values (c/255, sRGB-decoded unless raw), so the codes
/// give exactly the f32 texels in a quarter of the memory: a 256² normal map is 256 KiB instead
/// of 768 KiB and its random lookups stay in the L2 cache (measured: the glass benchmark spent
/// ~7 % of its render in bilinear lookups of a 768 KiB map, ~4 % with a 48 KiB one).
#[derive(Clone)]
enum Texels {
    /// RGB rows (plain arrays, so that the lane form gathers from them: [`Lane::gather3`]).
    ///
    /// [`Lane::gather3`]: crate::lane::Lane::gather3
    F32(Vec<[f32; 3]>),
    U8 {
        /// RGB codes, padded to 4 bytes (grey: the code three times).
        codes: Vec<[u8; 4]>,
        lut: Box<[f32; 256]>,
    },
}

impl Texels {
    fn len(&self) -> usize {
        match self {
            Texels::F32(t) => t.len(),
            Texels::U8 { codes, .. } => codes.len(),
        }
    }

    #[inline]
    fn get(&self, i: usize) -> Vec3 {
        match self {
            Texels::F32(t) => Vec3::from_array(t[i]),
            Texels::U8 { codes, lut } => {
                let c = codes[i];
                Vec3::new(lut[c[0] as usize], lut[c[1] as usize], lut[c[2] as usize])
            }
        }
    }

    /// Mitsuba's up-sampling of 1-pixel sides (a copy for a single row or column).
    fn upsample(&mut self, width: &mut u32, height: &mut u32) {
        fn double<T: Copy>(t: &mut Vec<T>, width: &mut u32, height: &mut u32) {
            if *width < 2 {
                *t = t.iter().flat_map(|&x| [x, x]).collect();
                *width = 2;
            }
            if *height < 2 {
                *t = [t.clone(), t.clone()].concat();
                *height = 2;
            }
        }
        match self {
            Texels::F32(t) => double(t, width, height),
            Texels::U8 { codes, .. } => double(codes, width, height),
        }
    }
}

/// A decoded bitmap texture. Texels are linear RGB (grey images repeat their value in all three
/// channels), row-major, row 0 = the image's first stored row = v in [0, 1/h).
#[derive(Clone)]
pub struct BitmapTexture {
    width: u32,
    height: u32,
    texels: Texels,
    grey: bool,
    filter: FilterType,
    wrap: WrapMode,
    to_uv: Mat3,
    identity_uv: bool,
    mean: Spectrum,
    /// Where the data came from (for messages).
    source: PathBuf,
    /// Width and/or height were 1 and have been doubled.
    upsampled: bool,
    raw: bool,
}

impl fmt::Debug for BitmapTexture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("BitmapTexture")
            .field("source", &self.source)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("grey", &self.grey)
            .field("filter", &self.filter)
            .field("wrap", &self.wrap)
            .field("to_uv", &self.to_uv)
            .field("mean", &self.mean)
            .finish()
    }
}

/// The sRGB EOTF: an sRGB-encoded value in [0, 1] to linear.
#[inline]
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Rounds to the nearest float16 value (ties to even), as stored by a half-precision texture.
#[inline]
pub fn round_to_f16(x: f32) -> f32 {
    f16::from_f32(x).to_f32()
}

/// Bytes per pixel an 8- or 16-bit image's decoder may hold (RGBA, 16 bits) besides the texels.
const LDR_DECODE_BYTES: u64 = 8;
/// Bytes per texel a bitmap texture keeps (RGB f32, the widest storage) and the decoded copy
/// it is made from.
const TEXEL_BYTES: u64 = 12;

/// Checks a `w`×`h` image's decoding (`decode` bytes per pixel for the decoder, two texel
/// arrays) against `budget`, then reserves the texels the texture keeps.
fn reserve_texels(budget: &Budget, w: u64, h: u64, decode: u64) -> Result<(), String> {
    let what = format!("image {w}×{h}");
    budget.check(bytes_of(&[w, h, decode + 2 * TEXEL_BYTES]), &what)?;
    budget.reserve(bytes_of(&[w, h, TEXEL_BYTES]), &what)
}

/// Decoded image data before texture options are applied.
struct Decoded {
    width: u32,
    height: u32,
    grey: bool,
    texels: Vec<Vec3>,
    /// 8-bit images: their codes as a [`Texels::U8`] (`texels` holds the decoded values).
    codes: Option<Texels>,
    /// Stored as float16 by Mitsuba's `auto` format (16-bit integers, half EXRs).
    half_by_default: bool,
}

impl BitmapTexture {
    /// Loads an image file (PNG, JPEG or OpenEXR, recognised by content). Errors name the file.
    pub fn load(path: &Path, opts: &BitmapOptions) -> Result<BitmapTexture> {
        Self::load_within(path, opts, &Budget::default())
    }

    /// [`BitmapTexture::load`] of a regular file whose decoding (estimated from the image
    /// header's dimensions, before decoding) fits `budget`; the texels stay reserved.
    pub fn load_within(
        path: &Path,
        opts: &BitmapOptions,
        budget: &Budget,
    ) -> Result<BitmapTexture> {
        let bytes = crate::inputs::read_regular(path, budget)?;
        let dec = if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
            decode_exr(&bytes, budget)
        } else if let Some(header) = float_image::header(&bytes) {
            decode_float(&bytes, header, budget)
        } else {
            decode_ldr(&bytes, opts.raw, budget)
        }
        .map_err(|msg| Error::file(path, msg))?;
        let quantize = match opts.format {
            StorageFormat::Auto => dec.half_by_default,
            StorageFormat::Variant => false,
            StorageFormat::Fp16 => true,
        };
        let mut texels = dec.texels;
        if quantize {
            for t in &mut texels {
                *t = Vec3::new(round_to_f16(t.x), round_to_f16(t.y), round_to_f16(t.z));
            }
        }
        let w = dec.width as usize;
        if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
            return Err(Error::file(
                path,
                format!(
                    "texel ({}, {}) is not a finite number ({}); textures must not contain NaN or infinity",
                    i % w,
                    i / w,
                    texels[i]
                ),
            ));
        }
        let store = match dec.codes {
            Some(codes) if !quantize => codes,
            _ => Texels::F32(texels.iter().map(|t| t.to_array()).collect()),
        };
        let mut t = BitmapTexture::from_storage(dec.width, dec.height, store, dec.grey, opts);
        t.source = path.to_path_buf();
        Ok(t)
    }

    /// A texture from linear texels (row-major, row 0 at v = 0). `grey` marks one-channel data
    /// (every texel's three components equal). Images with a side of 1 pixel are up-sampled to 2
    /// as Mitsuba does.
    ///
    /// # Panics
    /// If a side is 0 or `texels.len() != width * height` (a programming error, not bad input).
    pub fn from_texels(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        grey: bool,
        opts: &BitmapOptions,
    ) -> BitmapTexture {
        let rows = texels.iter().map(|t| t.to_array()).collect();
        Self::from_storage(width, height, Texels::F32(rows), grey, opts)
    }

    fn from_storage(
        width: u32,
        height: u32,
        texels: Texels,
        grey: bool,
        opts: &BitmapOptions,
    ) -> BitmapTexture {
        assert!(width > 0 && height > 0, "empty bitmap");
        assert_eq!(texels.len(), width as usize * height as usize);
        let (mut width, mut height, mut texels) = (width, height, texels);
        let upsampled = width < 2 || height < 2;
        texels.upsample(&mut width, &mut height);
        let sum: Vec3 = (0..texels.len())
            .fold(glam::DVec3::ZERO, |a, i| a + texels.get(i).as_dvec3())
            .as_vec3();
        let mean = sum / texels.len() as f32;
        BitmapTexture {
            width,
            height,
            texels,
            grey,
            filter: opts.filter,
            wrap: opts.wrap,
            to_uv: opts.to_uv,
            identity_uv: opts.to_uv == Mat3::IDENTITY,
            mean,
            source: PathBuf::new(),
            upsampled,
            raw: opts.raw,
        }
    }

    /// Width and height in texels (after Mitsuba's up-sampling of 1-pixel sides).
    pub fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// One-channel (grey) data.
    pub fn is_grey(&self) -> bool {
        self.grey
    }

    /// Texel (x, y), x < width, y < height; y = 0 is the first stored row.
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        self.texels
            .get(y as usize * self.width as usize + x as usize)
    }

    /// All texels, row-major.
    pub fn texels(&self) -> Vec<Vec3> {
        (0..self.texels.len()).map(|i| self.texels.get(i)).collect()
    }

    /// Per-channel mean of the texels. `luminance(mean)` is Mitsuba's `BitmapTexture::mean()`.
    pub fn mean(&self) -> Spectrum {
        self.mean
    }

    pub fn filter(&self) -> FilterType {
        self.filter
    }

    pub fn wrap(&self) -> WrapMode {
        self.wrap
    }

    pub fn to_uv(&self) -> Mat3 {
        self.to_uv
    }

    /// The file the texture was loaded from (empty for [`BitmapTexture::from_texels`]).
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// Remarks Mitsuba logs as warnings when loading this texture.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let name = self.source.display();
        if self.upsampled {
            w.push(format!(
                "bitmap '{name}' is narrower than 2 pixels; up-sampled to {}x{} as Mitsuba 3 does",
                self.width, self.height
            ));
        }
        // Mitsuba checks each texel's luminance (or grey value) against [0, 1] unless raw.
        if !self.raw
            && (0..self.texels.len()).any(|i| {
                let t = self.texels.get(i);
                let l = if self.grey { t.x } else { luminance(t) };
                !(0.0..=1.0).contains(&l)
            })
        {
            w.push(format!(
                "bitmap '{name}' contains texels outside [0, 1]; they are used unclamped, as in Mitsuba 3"
            ));
        }
        w
    }

    /// The texture value at `uv` (after `to_uv`, filtering and wrapping).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let p = if self.identity_uv {
            uv
        } else {
            self.to_uv.transform_point2(uv)
        };
        let (w, h) = (self.width as i64, self.height as i64);
        match self.filter {
            FilterType::Nearest => {
                let x = crate::math::floor(p.x * self.width as f32) as i64;
                let y = crate::math::floor(p.y * self.height as f32) as i64;
                let (x, y) = (self.wrap.apply(x, w), self.wrap.apply(y, h));
                self.texels.get(y * self.width as usize + x)
            }
            FilterType::Bilinear => {
                // Texel centres sit at integer + 0.5 (Dr.Jit's `tex_eval`).
                let x = p.x * self.width as f32 - 0.5;
                let y = p.y * self.height as f32 - 0.5;
                let (xf, yf) = (crate::math::floor(x), crate::math::floor(y));
                let (wx1, wy1) = (x - xf, y - yf);
                let (wx0, wy0) = (1.0 - wx1, 1.0 - wy1);
                let (x0, y0) = (xf as i64, yf as i64);
                let xa = self.wrap.apply(x0, w);
                let xb = self.wrap.apply(x0.saturating_add(1), w);
                let ra = self.wrap.apply(y0, h) * self.width as usize;
                let rb = self.wrap.apply(y0.saturating_add(1), h) * self.width as usize;
                let t = &self.texels;
                t.get(ra + xa) * (wx0 * wy0)
                    + t.get(ra + xb) * (wx1 * wy0)
                    + t.get(rb + xa) * (wx0 * wy1)
                    + t.get(rb + xb) * (wx1 * wy1)
            }
        }
    }
}

impl BitmapTexture {
    /// The scalar value's gradient `(∂/∂u, ∂/∂v)` at `uv`, as Mitsuba 3.9.1's `eval_1_grad`
    /// (checked numerically in tests/scene/texture.rs): the exact derivative of the bilinear
    /// interpolation inside the texel cell (per texel: the grey value, or the luminance of an RGB
    /// texel), chained through `to_uv` (∇_uv = Aᵀ ∇_p for p = A·uv + b). Nearest filtering gives 0.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        if self.filter == FilterType::Nearest {
            return Vec2::ZERO;
        }
        let p = if self.identity_uv {
            uv
        } else {
            self.to_uv.transform_point2(uv)
        };
        let (w, h) = (self.width as i64, self.height as i64);
        let x = p.x * self.width as f32 - 0.5;
        let y = p.y * self.height as f32 - 0.5;
        let (xf, yf) = (crate::math::floor(x), crate::math::floor(y));
        let (wx, wy) = (x - xf, y - yf);
        let (x0, y0) = (xf as i64, yf as i64);
        let xa = self.wrap.apply(x0, w);
        let xb = self.wrap.apply(x0.saturating_add(1), w);
        let ra = self.wrap.apply(y0, h) * self.width as usize;
        let rb = self.wrap.apply(y0.saturating_add(1), h) * self.width as usize;
        let v = |i: usize| {
            let t = self.texels.get(i);
            if self.grey {
                t.x
            } else {
                luminance(t)
            }
        };
        let (f00, f10, f01, f11) = (v(ra + xa), v(ra + xb), v(rb + xa), v(rb + xb));
        // Derivatives in texel units, then per unit of p.
        let dx = (1.0 - wy) * (f10 - f00) + wy * (f11 - f01);
        let dy = (1.0 - wx) * (f01 - f00) + wx * (f11 - f10);
        let gp = Vec2::new(dx * self.width as f32, dy * self.height as f32);
        if self.identity_uv {
            return gp;
        }
        let a = self.to_uv;
        // Columns x_axis, y_axis of the affine 2D map: p = x_axis·u + y_axis·v + z_axis.
        Vec2::new(
            a.x_axis.x * gp.x + a.x_axis.y * gp.y,
            a.y_axis.x * gp.x + a.y_axis.y * gp.y,
        )
    }
}

/// Decodes a PNG or JPEG. 8-bit codes c become c/255, 16-bit codes c/65535; then the sRGB EOTF
/// unless `raw`.
fn decode_ldr(bytes: &[u8], raw: bool, budget: &Budget) -> Result<Decoded, String> {
    use image::DynamicImage as D;
    let open = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("cannot read image: {e}"))
    };
    let mut reader = open()?;
    let format = reader.format().ok_or_else(|| {
        "unrecognised image format (bitmap textures read PNG, JPEG, OpenEXR, Radiance RGBE and PFM files)".to_string()
    })?;
    // The header's dimensions, before anything is decoded.
    let (w, h) = open()?
        .into_dimensions()
        .map_err(|e| format!("cannot read the image header: {e}"))?;
    reserve_texels(budget, w as u64, h as u64, LDR_DECODE_BYTES)?;
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(budget.limit().saturating_sub(budget.used()).max(1));
    reader.limits(limits);
    let img = reader.decode().map_err(|e| {
        let name = format!("{format:?}").to_uppercase();
        format!("cannot decode {name} image: {e}")
    })?;
    let (width, height) = (img.width(), img.height());
    if width == 0 || height == 0 {
        return Err("the image is empty".into());
    }
    let lut8: Vec<f32> = (0..256u32)
        .map(|c| {
            // Dr.Jit normalises 8-bit codes as c · (1/255) in f32.
            let v = c as f32 * (1.0 / 255.0);
            if raw {
                v
            } else {
                srgb_to_linear(c as f64 / 255.0) as f32
            }
        })
        .collect();
    let conv16 = |c: u16| -> f32 {
        let v = c as f64 / 65535.0;
        (if raw { v } else { srgb_to_linear(v) }) as f32
    };
    let lut: Box<[f32; 256]> = Box::new(std::array::from_fn(|c| lut8[c]));
    let codes: Option<Vec<[u8; 4]>> = match &img {
        D::ImageLuma8(b) => Some(b.pixels().map(|p| [p.0[0], p.0[0], p.0[0], 0]).collect()),
        D::ImageLumaA8(b) => Some(b.pixels().map(|p| [p.0[0], p.0[0], p.0[0], 0]).collect()),
        D::ImageRgb8(b) => Some(b.pixels().map(|p| [p.0[0], p.0[1], p.0[2], 0]).collect()),
        D::ImageRgba8(b) => Some(b.pixels().map(|p| [p.0[0], p.0[1], p.0[2], 0]).collect()),
        _ => None,
    };
    let (grey, half, texels): (bool, bool, Vec<Vec3>) = match &img {
        D::ImageLuma8(b) => (
            true,
            false,
            b.pixels()
                .map(|p| Vec3::splat(lut8[p.0[0] as usize]))
                .collect(),
        ),
        D::ImageLumaA8(b) => (
            true,
            false,
            b.pixels()
                .map(|p| Vec3::splat(lut8[p.0[0] as usize]))
                .collect(),
        ),
        D::ImageRgb8(b) => (false, false, b.pixels().map(|p| rgb8(&lut8, p.0)).collect()),
        D::ImageRgba8(b) => (
            false,
            false,
            b.pixels()
                .map(|p| rgb8(&lut8, [p.0[0], p.0[1], p.0[2]]))
                .collect(),
        ),
        D::ImageLuma16(b) => (
            true,
            true,
            b.pixels().map(|p| Vec3::splat(conv16(p.0[0]))).collect(),
        ),
        D::ImageLumaA16(b) => (
            true,
            true,
            b.pixels().map(|p| Vec3::splat(conv16(p.0[0]))).collect(),
        ),
        D::ImageRgb16(b) => (
            false,
            true,
            b.pixels()
                .map(|p| Vec3::new(conv16(p.0[0]), conv16(p.0[1]), conv16(p.0[2])))
                .collect(),
        ),
        D::ImageRgba16(b) => (
            false,
            true,
            b.pixels()
                .map(|p| Vec3::new(conv16(p.0[0]), conv16(p.0[1]), conv16(p.0[2])))
                .collect(),
        ),
        other => {
            return Err(format!(
                "unsupported pixel layout {:?} (expected grey, grey+alpha, RGB or RGBA)",
                other.color()
            ))
        }
    };
    Ok(Decoded {
        width,
        height,
        grey,
        texels,
        codes: codes.map(|codes| Texels::U8 { codes, lut }),
        half_by_default: half,
    })
}

#[inline]
fn rgb8(lut: &[f32], c: [u8; 3]) -> Vec3 {
    Vec3::new(lut[c[0] as usize], lut[c[1] as usize], lut[c[2] as usize])
}

/// Decodes a Radiance RGBE or PFM file (linear f32 data, stored as f32 by Mitsuba's `auto`).
fn decode_float(
    bytes: &[u8],
    header: Result<float_image::Header, String>,
    budget: &Budget,
) -> Result<Decoded, String> {
    let h = header?;
    reserve_texels(
        budget,
        h.width as u64,
        h.height as u64,
        4 * h.channels.count() as u64,
    )?;
    let img = float_image::decode(bytes, &h)?;
    let texels = (0..img.pixel_count())
        .map(|i| Vec3::from_array(img.rgb(i)))
        .collect();
    Ok(Decoded {
        width: img.width,
        height: img.height,
        grey: img.channels == float_image::Channels::Grey,
        texels,
        codes: None,
        half_by_default: false,
    })
}

/// Decodes the first layer of an OpenEXR file: channels R, G, B (alpha ignored) or Y (grey).
fn decode_exr(bytes: &[u8], budget: &Budget) -> Result<Decoded, String> {
    use exr::prelude::{read, FlatSamples, ReadChannels, ReadLayers};
    let (w, h, nch) = crate::output::exr_size(std::io::Cursor::new(bytes))?;
    reserve_texels(budget, w, h, 4 * nch)?;
    let image = crate::output::exr_guarded(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(std::io::Cursor::new(bytes))
    })?
    .map_err(|e| format!("cannot read EXR: {e}"))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    let channels = &layer.channel_data.list;
    let find = |name: &str| {
        channels
            .iter()
            .find(|c| c.name.eq_case_insensitive(name))
            .map(|c| &c.sample_data)
    };
    let half = |s: &FlatSamples| matches!(s, FlatSamples::F16(_));
    let n = w * h;
    if let Some(c) = channels.iter().find(|c| c.sample_data.len() != n) {
        return Err(format!(
            "EXR channel '{}' is subsampled ({} samples for {w}x{h} pixels); not supported",
            c.name,
            c.sample_data.len()
        ));
    }
    let (grey, half_by_default, texels) = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => (
            false,
            half(r) && half(g) && half(b),
            (0..n)
                .map(|i| {
                    Vec3::new(
                        r.value_by_flat_index(i).to_f32(),
                        g.value_by_flat_index(i).to_f32(),
                        b.value_by_flat_index(i).to_f32(),
                    )
                })
                .collect(),
        ),
        (_, _, _, Some(y)) => (
            true,
            half(y),
            (0..n)
                .map(|i| Vec3::splat(y.value_by_flat_index(i).to_f32()))
                .collect(),
        ),
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(format!(
                "unsupported EXR channels [{}] (a bitmap texture needs R, G, B or Y)",
                names.join(", ")
            ));
        }
    };
    Ok(Decoded {
        width: w as u32,
        height: h as u32,
        grey,
        texels,
        codes: None,
        half_by_default,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes_map_integer_coordinates() {
        // n = 4: ... -5 -4 -3 -2 -1 | 0 1 2 3 | 4 5 6 7 8 ...
        let n = 4;
        let repeat: Vec<usize> = (-5..9).map(|i| WrapMode::Repeat.apply(i, n)).collect();
        assert_eq!(repeat, [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]);
        let mirror: Vec<usize> = (-5..9).map(|i| WrapMode::Mirror.apply(i, n)).collect();
        assert_eq!(mirror, [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
        let clamp: Vec<usize> = (-5..9).map(|i| WrapMode::Clamp.apply(i, n)).collect();
        assert_eq!(clamp, [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]);
        // Extreme coordinates (huge or NaN uvs) must not overflow or panic.
        for w in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            assert!(w.apply(i64::MAX, n) < 4 && w.apply(i64::MIN, n) < 4);
        }
    }

    #[test]
    fn float16_rounding() {
        assert_eq!(round_to_f16(1.0), 1.0);
        assert_eq!(round_to_f16(0.1), 0.099975586);
        assert_eq!(round_to_f16(1.0 + 1.0 / 4096.0), 1.0); // tie → even
        assert_eq!(round_to_f16(1e-7), 1.1920929e-7); // subnormal half
        assert_eq!(round_to_f16(1e6), f32::INFINITY);
    }

    #[test]
    fn srgb_curve_is_nearly_continuous_at_the_threshold() {
        // The standard's constants leave a jump of ~1e-8 at 0.04045.
        let a = srgb_to_linear(0.04045);
        let b = srgb_to_linear(0.04045 + 1e-12);
        assert!((a - b).abs() < 1e-7, "{a} {b}");
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn lookups_survive_non_finite_and_huge_uvs() {
        let t =
            BitmapTexture::from_texels(2, 2, vec![Vec3::ONE; 4], false, &BitmapOptions::default());
        for uv in [
            Vec2::new(f32::NAN, 0.5),
            Vec2::new(f32::INFINITY, f32::NEG_INFINITY),
            Vec2::new(1e30, -1e30),
        ] {
            let _ = t.eval(uv);
        }
        let n = BitmapTexture::from_texels(
            2,
            2,
            vec![Vec3::ONE; 4],
            false,
            &BitmapOptions {
                filter: FilterType::Nearest,
                ..Default::default()
            },
        );
        assert_eq!(n.eval(Vec2::new(f32::NAN, 1e30)), Vec3::ONE);
    }

    #[test]
    fn one_pixel_images_become_two_by_two() {
        let t = BitmapTexture::from_texels(
            1,
            1,
            vec![Vec3::new(0.25, 0.5, 0.75)],
            false,
            &BitmapOptions::default(),
        );
        assert_eq!(t.resolution(), (2, 2));
        assert!(t
            .eval(Vec2::new(0.3, 0.9))
            .abs_diff_eq(Vec3::new(0.25, 0.5, 0.75), 1e-6));
        assert_eq!(t.mean(), Vec3::new(0.25, 0.5, 0.75));
        assert_eq!(t.warnings().len(), 1);
    }
}
