//! 8-bit sRGB PNG output.

use std::io::Write;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::film::Image;

/// The sRGB opto-electronic transfer function (IEC 61966-2-1) of a linear value, clamped to
/// [0, 1] first (NaN becomes 0), quantised to 8 bits with round-to-nearest.
pub(crate) fn srgb_u8(linear: f32) -> u8 {
    let x = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0) as f64
    };
    let s = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Encodes `img` as an 8-bit RGB PNG.
pub(super) fn write<W: Write>(w: W, img: &Image) -> Result<(), String> {
    let bytes: Vec<u8> = img
        .data
        .iter()
        .flat_map(|p| [srgb_u8(p[0]), srgb_u8(p[1]), srgb_u8(p[2])])
        .collect();
    PngEncoder::new(w)
        .write_image(&bytes, img.width, img.height, ExtendedColorType::Rgb8)
        .map_err(|e| format!("cannot encode PNG: {e}"))
}

#[cfg(test)]
mod tests {
    use super::srgb_u8;

    #[test]
    fn srgb_values() {
        assert_eq!(srgb_u8(0.0), 0);
        assert_eq!(srgb_u8(1.0), 255);
        assert_eq!(srgb_u8(0.5), 188);
        assert_eq!(srgb_u8(-3.0), 0);
        assert_eq!(srgb_u8(7.0), 255);
        assert_eq!(srgb_u8(f32::NAN), 0);
        assert_eq!(srgb_u8(f32::INFINITY), 255);
        // Linear segment up to 0.0031308: 12.92·0.0031308·255 = 10.31 → 10, both sides agree.
        assert_eq!(srgb_u8(0.0031308), 10);
        assert_eq!(srgb_u8(0.0031309), 10);
        assert_eq!(srgb_u8(0.002), 7);
        assert_eq!(srgb_u8(0.18), 118);
    }
}
