//! Linear floating-point image files, Radiance RGBE (`.hdr`) and PFM, read the way Mitsuba 3.9.1's
//! `Bitmap` reads them (`src/core/bitmap.cpp`, `read_rgbe` / `read_pfm`): the one reading path of
//! the `bitmap` texture and of the `envmap` emitter for these formats.
//!
//! - The format is recognised by content, as Mitsuba's `detect_file_format`: `#?` starts an RGBE
//!   file, `PF` / `Pf` a PFM file (the file name's extension plays no part).
//! - The data is linear (no sRGB decoding, so `raw` changes nothing) and stored as f32.
//! - Reading is in two steps, [`header`] then [`decode`], so the caller checks the image's size
//!   (from the header alone) against its memory budget before any pixel buffer is allocated.
//! - Errors are plain messages (the caller names the file); they give the byte offset where the
//!   data went wrong when it is known.

use super::{pfm, rgbe};

/// The channels of a decoded image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channels {
    /// One value per pixel (PFM `Pf`).
    Grey,
    /// R, G, B per pixel (PFM `PF`; RGBE files, XYZE ones converted to linear sRGB).
    Rgb,
}

impl Channels {
    /// Values per pixel.
    pub fn count(self) -> usize {
        match self {
            Channels::Grey => 1,
            Channels::Rgb => 3,
        }
    }
}

/// Which of the two formats a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Rgbe,
    Pfm,
}

/// What a file's header says, before any pixel is decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header {
    pub kind: Kind,
    pub width: u32,
    pub height: u32,
    pub channels: Channels,
    /// Where the pixel data starts (bytes from the start of the file).
    pub data_start: usize,
    /// RGBE only: the data is CIE XYZ (`FORMAT=32-bit_rle_xyze`), converted to RGB on decoding.
    pub xyz: bool,
    /// PFM only: little-endian data (the scale in the header is negative).
    pub little_endian: bool,
    /// PFM only: the factor every value is multiplied by (the header's |scale|, as Mitsuba does).
    pub scale: f32,
}

impl Header {
    /// Bytes of the decoded pixels (f32 per channel), saturating.
    pub fn decoded_bytes(&self) -> u64 {
        crate::budget::bytes_of(&[
            self.width as u64,
            self.height as u64,
            4 * self.channels.count() as u64,
        ])
    }
}

/// A decoded image: row-major f32 values, `channels.count()` per pixel, row 0 the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct FloatImage {
    pub width: u32,
    pub height: u32,
    pub channels: Channels,
    pub data: Vec<f32>,
}

impl FloatImage {
    /// Pixel `i` (row-major) as RGB (a grey value in all three channels).
    #[inline]
    pub fn rgb(&self, i: usize) -> [f32; 3] {
        match self.channels {
            Channels::Grey => [self.data[i]; 3],
            Channels::Rgb => [self.data[3 * i], self.data[3 * i + 1], self.data[3 * i + 2]],
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// The format of `bytes` if it is one of the two this module reads (Mitsuba's magic numbers).
pub fn detect(bytes: &[u8]) -> Option<Kind> {
    match bytes {
        [b'#', b'?', ..] => Some(Kind::Rgbe),
        [b'P', b'F' | b'f', ..] => Some(Kind::Pfm),
        _ => None,
    }
}

/// Parses the header of an RGBE or PFM file (`None`: the bytes are neither).
pub fn header(bytes: &[u8]) -> Option<Result<Header, String>> {
    Some(match detect(bytes)? {
        Kind::Rgbe => rgbe::header(bytes),
        Kind::Pfm => pfm::header(bytes),
    })
}

/// Decodes the pixels described by `h` (from [`header`] of the same bytes). The caller has
/// checked [`Header::decoded_bytes`] against its budget; nothing larger is allocated here.
pub fn decode(bytes: &[u8], h: &Header) -> Result<FloatImage, String> {
    if h.width == 0 || h.height == 0 {
        return Err(format!("the image is empty ({}x{})", h.width, h.height));
    }
    let data = match h.kind {
        Kind::Rgbe => rgbe::decode(bytes, h)?,
        Kind::Pfm => pfm::decode(bytes, h)?,
    };
    Ok(FloatImage {
        width: h.width,
        height: h.height,
        channels: h.channels,
        data,
    })
}
