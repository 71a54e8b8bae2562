//! Portable Float Map (PFM) images, decoded as Mitsuba 3.9.1's `Bitmap::read_pfm` does (format:
//! Paul Debevec's HDRShop PFM; the Netpbm `pf` documentation).
//!
//! - Header: `PF` (RGB) or `Pf` (grey) and one more byte, then three whitespace-separated tokens,
//!   width, height and scale, and one whitespace byte; the f32 data follows.
//! - A scale ≤ 0 means little-endian data, > 0 big-endian. Mitsuba multiplies every value by
//!   |scale| when it is not 1 (most readers ignore the magnitude); groove does the same.
//! - Rows are stored bottom to top; they are returned top row first. Data after the last row is
//!   ignored.

use super::float_image::{Channels, Header, Kind};

/// The next whitespace-separated token at `*pos` (Mitsuba's `Stream::read_token`: leading
/// whitespace skipped, the one whitespace byte ending the token consumed).
fn token<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let start = *pos;
    while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let t = &bytes[start..*pos];
    if *pos < bytes.len() {
        *pos += 1;
    }
    (!t.is_empty()).then_some(t)
}

/// Parses the header (see the module documentation).
pub fn header(bytes: &[u8]) -> Result<Header, String> {
    let channels = match bytes {
        [b'P', b'F', _, ..] => Channels::Rgb,
        [b'P', b'f', _, ..] => Channels::Grey,
        _ => return Err("invalid PFM header (the file must start with 'PF' or 'Pf')".into()),
    };
    let mut pos = 3;
    let mut field = |what: &str| -> Result<String, String> {
        let at = pos;
        let t = token(bytes, &mut pos)
            .ok_or_else(|| format!("the PFM header ends before its {what}"))?;
        let s = String::from_utf8_lossy(t).into_owned();
        if s.len() > 64 {
            return Err(format!("bad PFM {what} at byte offset {at}"));
        }
        Ok(s)
    };
    let (w, h, s) = (field("width")?, field("height")?, field("scale")?);
    let dim = |v: &str, what: &str| {
        v.parse::<u32>()
            .map_err(|_| format!("bad PFM {what} '{v}' (a whole number up to {})", u32::MAX))
    };
    let (width, height) = (dim(&w, "width")?, dim(&h, "height")?);
    let scale: f32 = s
        .parse()
        .map_err(|_| format!("bad PFM scale '{s}' (a number: its sign gives the byte order)"))?;
    if !scale.is_finite() {
        return Err(format!("bad PFM scale '{s}' (it must be finite)"));
    }
    Ok(Header {
        kind: Kind::Pfm,
        width,
        height,
        channels,
        data_start: pos,
        xyz: false,
        little_endian: scale <= 0.0,
        scale: scale.abs(),
    })
}

/// Decodes the values (top row first) of a file whose header is `h`.
pub fn decode(bytes: &[u8], h: &Header) -> Result<Vec<f32>, String> {
    let row = h.width as usize * h.channels.count();
    let need = row.saturating_mul(h.height as usize).saturating_mul(4);
    let data = bytes.get(h.data_start..).unwrap_or_default();
    if data.len() < need {
        return Err(format!(
            "truncated PFM data: {} bytes from byte offset {}, a {}x{} {} image needs {need}",
            data.len(),
            h.data_start,
            h.width,
            h.height,
            if h.channels == Channels::Rgb {
                "colour"
            } else {
                "grey"
            }
        ));
    }
    let mut out = Vec::with_capacity(need / 4);
    // File row r (counted from the bottom) is image row height − 1 − r.
    for r in (0..h.height as usize).rev() {
        let src = &data[4 * row * r..4 * row * (r + 1)];
        out.extend(src.chunks_exact(4).map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            let v = if h.little_endian {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
            if h.scale != 1.0 {
                v * h.scale
            } else {
                v
            }
        }));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::float_image::{decode as decode_image, header as parse, Channels};

    /// A PFM file: `magic`, `w`×`h`, `scale`, then `vals` (file order: bottom row first).
    fn file(magic: &str, w: u32, h: u32, scale: &str, vals: &[f32]) -> Vec<u8> {
        let mut f = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        for v in vals {
            if scale.starts_with('-') {
                f.extend(v.to_le_bytes());
            } else {
                f.extend(v.to_be_bytes());
            }
        }
        f
    }

    #[test]
    fn both_byte_orders_and_bottom_to_top_rows() {
        // 2x2 colour, bottom row first in the file: (1,2,3) (4,5,6) / (7,8,9) (10,11,12).
        let vals: Vec<f32> = (1..=12).map(|v| v as f32).collect();
        let top_first: Vec<f32> = [7, 8, 9, 10, 11, 12, 1, 2, 3, 4, 5, 6]
            .iter()
            .map(|&v| v as f32)
            .collect();
        for scale in ["-1.0", "1.0"] {
            let f = file("PF", 2, 2, scale, &vals);
            let h = parse(&f).unwrap().unwrap();
            assert_eq!(h.little_endian, scale == "-1.0");
            let img = decode_image(&f, &h).unwrap();
            assert_eq!(img.channels, Channels::Rgb);
            assert_eq!(img.data, top_first, "scale {scale}");
            assert_eq!(img.rgb(1), [10.0, 11.0, 12.0]);
        }
    }

    #[test]
    fn grey_and_scaled() {
        // |scale| multiplies every value, as in Mitsuba.
        let f = file("Pf", 3, 1, "-2.5", &[1.0, 0.5, -4.0]);
        let h = parse(&f).unwrap().unwrap();
        let img = decode_image(&f, &h).unwrap();
        assert_eq!(img.channels, Channels::Grey);
        assert_eq!(img.data, vec![2.5, 1.25, -10.0]);
        assert_eq!(img.rgb(2), [-10.0; 3]);
    }

    #[test]
    fn truncated_and_malformed_files_are_errors() {
        let err = |b: &[u8]| {
            parse(b)
                .unwrap()
                .and_then(|h| decode_image(b, &h))
                .unwrap_err()
        };
        let f = file("PF", 2, 2, "-1", &[0.0; 11]);
        let e = err(&f);
        assert!(e.contains("truncated") && e.contains("needs 48"), "{e}");
        assert!(err(b"PF\n2").contains("ends before its height"));
        assert!(err(b"PF\n2 x -1\n").contains("bad PFM height"));
        assert!(err(b"PF\n2 2 nan\n").contains("finite"));
        assert!(err(b"PF\n2 -3 -1\n").contains("bad PFM height"));
        assert!(err(&file("PF", 0, 2, "-1", &[])).contains("empty"));
        // Hostile dimensions: the header reports them (for the caller's budget check), and
        // decoding a short file fails without allocating the image.
        let f = file("PF", u32::MAX, u32::MAX, "-1", &[1.0]);
        let h = parse(&f).unwrap().unwrap();
        assert!(h.decoded_bytes() > 1 << 60);
        assert!(err(&f).contains("truncated"));
    }
}
