//! Radiance RGBE (`.hdr`) images, decoded as Mitsuba 3.9.1's `Bitmap::read_rgbe` does (Greg Ward,
//! "Real Pixels", Graphics Gems II, 1991; the scanline run-length encoding of Radiance's
//! `color.c`).
//!
//! - Header: a first line starting with `#?`, then lines up to the resolution line
//!   `-Y <height> +X <width>` (the only orientation Mitsuba reads: top row first, left to right);
//!   a `FORMAT=32-bit_rle_rgbe` (or `_xyze`) line must come before it. Other lines (`EXPOSURE=`,
//!   comments) are ignored, as in Mitsuba (no exposure is applied).
//! - Pixel (r, g, b, e): 0 when e = 0, else c · 2^(e − 136) per channel (Mitsuba's conversion,
//!   without Radiance's +0.5 offset).
//! - Scanlines of widths 8 to 32767 may be run-length encoded: a scanline starting with the bytes
//!   2, 2 and a width (high byte below 128) holds its four byte planes (r, g, b, e) as runs
//!   (count byte > 128: count − 128 copies of the next byte) and literal spans (count byte
//!   1..=128: that many bytes). A scanline without that start begins flat data for the rest of
//!   the image; narrower and wider images are always flat.
//! - XYZE data is converted to linear sRGB with Mitsuba's `xyz_to_srgb` matrix.

use super::float_image::{Channels, Header, Kind};

/// Mitsuba's XYZ → linear sRGB matrix (`include/mitsuba/core/spectrum.h`, `xyz_to_srgb`), rows.
const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [3.240479, -1.53715, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// Parses the header (see the module documentation).
pub fn header(bytes: &[u8]) -> Result<Header, String> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut next_line = |pos: &mut usize| -> Option<(usize, String)> {
        if *pos >= bytes.len() {
            return None;
        }
        let end = bytes[*pos..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(bytes.len(), |e| *pos + e);
        let line = String::from_utf8_lossy(&bytes[*pos..end]).into_owned();
        *pos = (end + 1).min(bytes.len());
        line_no += 1;
        Some((line_no, line))
    };
    match next_line(&mut pos) {
        Some((_, l)) if l.starts_with("#?") => {}
        _ => return Err("invalid RGBE header (the file must start with '#?')".into()),
    }
    let mut xyz = None;
    loop {
        let Some((n, line)) = next_line(&mut pos) else {
            return Err(
                "the RGBE header ends without a resolution line ('-Y <height> +X <width>')".into(),
            );
        };
        if line.starts_with("FORMAT=32-bit_rle_rgbe") {
            xyz = Some(false);
            continue;
        }
        if line.starts_with("FORMAT=32-bit_rle_xyze") {
            xyz = Some(true);
            continue;
        }
        let t: Vec<&str> = line.split_ascii_whitespace().collect();
        if t.len() != 4 {
            continue;
        }
        let axes = (t[0], t[2]);
        if axes == ("-Y", "+X") {
            let dim = |s: &str| {
                s.parse::<u32>()
                    .map_err(|_| format!("RGBE header line {n}: bad image size '{s}' in '{line}'"))
            };
            let (height, width) = (dim(t[1])?, dim(t[3])?);
            let xyz = xyz.ok_or(
                "unrecognised RGBE format (the header needs FORMAT=32-bit_rle_rgbe or FORMAT=32-bit_rle_xyze before the resolution line)",
            )?;
            return Ok(Header {
                kind: Kind::Rgbe,
                width,
                height,
                channels: Channels::Rgb,
                data_start: pos,
                xyz,
                little_endian: false,
                scale: 1.0,
            });
        }
        let is_axis = |a: &str| matches!(a, "-Y" | "+Y" | "-X" | "+X");
        if is_axis(axes.0) && is_axis(axes.1) {
            return Err(format!(
                "RGBE header line {n}: orientation '{line}' is not supported (Mitsuba 3 reads only '-Y <height> +X <width>')"
            ));
        }
    }
}

/// One pixel's RGBE bytes to linear values.
#[inline]
fn to_float(c: [u8; 4]) -> [f32; 3] {
    if c[3] == 0 {
        return [0.0; 3];
    }
    // 2^(e − 136) is exact in f64 and c · 2^(e − 136) (c < 256) is exact in f32 (subnormals
    // included): Mitsuba's ldexp(1, e − 136) · c.
    let f = 2f64.powi(c[3] as i32 - 136);
    [
        (c[0] as f64 * f) as f32,
        (c[1] as f64 * f) as f32,
        (c[2] as f64 * f) as f32,
    ]
}

/// A cursor over the pixel data that reports where it ran out.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.saturating_add(n);
        let Some(s) = self.bytes.get(self.pos..end) else {
            return Err(format!(
                "truncated RGBE data: {n} more bytes needed at byte offset {} (the file has {})",
                self.pos,
                self.bytes.len()
            ));
        };
        self.pos = end;
        Ok(s)
    }
}

/// Decodes the pixels (RGB, top row first) of a file whose header is `h`.
pub fn decode(bytes: &[u8], h: &Header) -> Result<Vec<f32>, String> {
    let (w, ht) = (h.width as usize, h.height as usize);
    let n = w * ht;
    // The smallest encoding of this size (flat: 4 bytes a pixel; run-length: per scanline 4
    // bytes and a 2-byte run per 127 bytes of each plane): a short file is rejected before the
    // pixels are allocated.
    let least = if (8..=0x7fff).contains(&w) {
        ht.saturating_mul(4 + 8 * w.div_ceil(127))
    } else {
        n.saturating_mul(4)
    };
    let have = bytes.len().saturating_sub(h.data_start);
    if have < least {
        return Err(format!(
            "truncated RGBE data: {have} bytes after the header at byte offset {}, a {w}x{ht} image needs at least {least}",
            h.data_start
        ));
    }
    let mut out: Vec<f32> = Vec::with_capacity(3 * n);
    let mut cur = Cursor {
        bytes,
        pos: h.data_start,
    };
    let flat = |cur: &mut Cursor, out: &mut Vec<f32>, count: usize| -> Result<(), String> {
        for _ in 0..count {
            let p = cur.take(4)?;
            out.extend(to_float([p[0], p[1], p[2], p[3]]));
        }
        Ok(())
    };
    if !(8..=0x7fff).contains(&w) {
        flat(&mut cur, &mut out, n)?;
    } else {
        let mut planes = vec![0u8; 4 * w];
        for y in 0..ht {
            let start = cur.pos;
            let s = cur.take(4)?;
            if s[0] != 2 || s[1] != 2 || s[2] & 0x80 != 0 {
                // Not run-length encoded: the rest of the image is flat, from this pixel on.
                cur.pos = start;
                flat(&mut cur, &mut out, n - y * w)?;
                break;
            }
            let sw = ((s[2] as usize) << 8) | s[3] as usize;
            if sw != w {
                return Err(format!(
                    "RGBE scanline {y} at byte offset {start} has width {sw}, the image {w}"
                ));
            }
            let mut i = 0usize;
            for plane in 0..4 {
                let end = (plane + 1) * w;
                while i < end {
                    let at = cur.pos;
                    let b = cur.take(2)?;
                    let bad =
                        || format!("bad RGBE run-length data in scanline {y} at byte offset {at}");
                    if b[0] > 128 {
                        let count = (b[0] - 128) as usize;
                        if count > end - i {
                            return Err(bad());
                        }
                        planes[i..i + count].fill(b[1]);
                        i += count;
                    } else {
                        let count = b[0] as usize;
                        if count == 0 || count > end - i {
                            return Err(bad());
                        }
                        planes[i] = b[1];
                        let rest = cur.take(count - 1)?;
                        planes[i + 1..i + count].copy_from_slice(rest);
                        i += count;
                    }
                }
            }
            for x in 0..w {
                out.extend(to_float([
                    planes[x],
                    planes[w + x],
                    planes[2 * w + x],
                    planes[3 * w + x],
                ]));
            }
        }
    }
    if h.xyz {
        for p in out.chunks_exact_mut(3) {
            let xyz = [p[0], p[1], p[2]];
            for (o, m) in p.iter_mut().zip(XYZ_TO_SRGB) {
                *o = m[0] * xyz[0] + m[1] * xyz[1] + m[2] * xyz[2];
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::float_image::{decode as decode_image, header as parse};

    /// A header for a `w`×`h` RGBE file, then `body`.
    fn file(w: u32, h: u32, body: &[u8]) -> Vec<u8> {
        let mut f = format!(
            "#?RADIANCE\n# made by a test\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=2.0\n\n-Y {h} +X {w}\n"
        )
        .into_bytes();
        f.extend_from_slice(body);
        f
    }

    fn read(bytes: &[u8]) -> Result<Vec<f32>, String> {
        let h = parse(bytes).unwrap()?;
        decode_image(bytes, &h).map(|i| i.data)
    }

    #[test]
    fn flat_pixels_decode_as_mitsuba() {
        // 2x1: (128, 64, 0, e=129) = (1, 0.5, 0) ; e = 0 is black whatever the mantissas.
        let f = file(2, 1, &[128, 64, 0, 129, 9, 9, 9, 0]);
        assert_eq!(read(&f).unwrap(), vec![1.0, 0.5, 0.0, 0.0, 0.0, 0.0]);
        // The smallest and largest exponents stay exact: 1 · 2^-135 and 255 · 2^119.
        let f = file(2, 1, &[1, 0, 0, 1, 255, 0, 0, 255]);
        let d = read(&f).unwrap();
        assert_eq!(d[0], 2f32.powi(-135));
        assert_eq!(d[3], 255.0 * 2f32.powi(119));
    }

    #[test]
    fn run_length_scanlines() {
        // Width 8, two scanlines: planes as a run (r: 8 × 128), literals (g), mixed (b), run (e).
        let mut body = Vec::new();
        for _ in 0..2 {
            body.extend([2, 2, 0, 8]);
            body.extend([128 + 8, 128]); // r
            body.extend([8, 0, 16, 32, 48, 64, 80, 96, 112]); // g
            body.extend([128 + 4, 200, 4, 1, 2, 3, 4]); // b
            body.extend([128 + 8, 129]); // e
        }
        let d = read(&file(8, 2, &body)).unwrap();
        assert_eq!(d.len(), 48);
        let px = |x: usize, y: usize| &d[3 * (8 * y + x)..3 * (8 * y + x) + 3];
        assert_eq!(px(0, 0), [1.0, 0.0, 200.0 / 128.0]);
        assert_eq!(px(7, 1), [1.0, 112.0 / 128.0, 4.0 / 128.0]);
        // The same image written flat decodes identically.
        let mut flat = Vec::new();
        for _ in 0..2 {
            for x in 0..8usize {
                let b = if x < 4 { 200 } else { x as u8 - 3 };
                flat.extend([128, 16 * x as u8, b, 129]);
            }
        }
        // A flat image of width ≥ 8 starts with a pixel that is not (2, 2, ...).
        assert_eq!(read(&file(8, 2, &flat)).unwrap(), d);
    }

    #[test]
    fn xyz_data_becomes_rgb() {
        let mut f = b"#?RGBE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n".to_vec();
        f.extend([128, 128, 128, 129]); // XYZ = (1, 1, 1)
        let d = read(&f).unwrap();
        let want = [
            3.240479f32 - 1.53715 - 0.498535,
            -0.969256 + 1.875991 + 0.041556,
            0.055648 - 0.204043 + 1.057311,
        ];
        for (a, b) in d.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{d:?}");
        }
    }

    #[test]
    fn bad_headers_and_data_are_errors() {
        let err = |b: &[u8]| {
            parse(b)
                .unwrap()
                .and_then(|h| decode_image(b, &h))
                .unwrap_err()
        };
        assert!(err(b"#?RADIANCE\n\n-Y 1 +X 1\n\0\0\0\0").contains("FORMAT"));
        assert!(err(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n").contains("resolution line"));
        assert!(err(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 1\n").contains("orientation"));
        assert!(
            err(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 99999999999\n")
                .contains("bad image size")
        );
        assert!(err(&file(0, 3, b"")).contains("empty"));
        // Truncated flat and run-length data name the offset.
        let e = err(&file(2, 1, &[1, 2, 3, 4, 5]));
        assert!(e.contains("truncated") && e.contains("offset"), "{e}");
        let e = err(&file(8, 1, &[2, 2, 0, 8, 128 + 8]));
        assert!(e.contains("truncated"), "{e}");
        // Long enough for the smallest encoding, but the runs stop after the first plane.
        let e = err(&file(8, 1, &[2, 2, 0, 8, 128 + 8, 0, 8, 1, 2, 3, 4, 5]));
        assert!(e.contains("truncated") && e.contains("offset"), "{e}");
        // A run longer than the scanline, a zero-length literal, a wrong scanline width.
        let pad = |b: &[u8]| [b, &[0u8; 12][b.len()..]].concat();
        let e = err(&file(8, 1, &pad(&[2, 2, 0, 8, 128 + 9, 0])));
        assert!(
            e.contains("bad RGBE run-length") && e.contains("offset"),
            "{e}"
        );
        assert!(err(&file(8, 1, &pad(&[2, 2, 0, 8, 0, 0]))).contains("bad RGBE run-length"));
        assert!(err(&file(8, 1, &pad(&[2, 2, 0, 9]))).contains("width 9"));
    }

    #[test]
    fn hostile_sizes_are_reported_before_decoding() {
        // The header alone gives the size the caller checks against its budget.
        let f = file(u32::MAX, u32::MAX, b"");
        let h = parse(&f).unwrap().unwrap();
        assert_eq!((h.width, h.height), (u32::MAX, u32::MAX));
        assert!(h.decoded_bytes() > 1 << 60);
    }
}
