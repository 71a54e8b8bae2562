//! The text of a scene file from its bytes: UTF-8 or UTF-16 by byte-order mark, every invalid
//! sequence an error at its line and column (XML 1.0 §4.3.3 allows both encodings).

use crate::error::{Error, Result, SourceLoc};
use std::path::Path;

/// The text of a scene file: UTF-8 (a byte-order mark is skipped) or UTF-16 with a byte-order
/// mark (as XML 1.0 §4.3.3 allows). Invalid UTF-8 or UTF-16 is an error at its line and column.
pub fn decode_text(bytes: &[u8], path: &Path) -> Result<String> {
    let utf16 = |be: bool| -> Result<String> {
        let body = &bytes[2..];
        let pairs = body.chunks_exact(2);
        let odd = !pairs.remainder().is_empty();
        let units = pairs.map(|c| {
            if be {
                u16::from_be_bytes([c[0], c[1]])
            } else {
                u16::from_le_bytes([c[0], c[1]])
            }
        });
        let mut out = String::with_capacity(body.len() / 2);
        // Code units decoded so far (a surrogate pair is two).
        let mut at = 0;
        for r in char::decode_utf16(units) {
            match r {
                Ok(c) => {
                    out.push(c);
                    at += c.len_utf16();
                }
                Err(e) => {
                    return Err(bad_encoding(
                        &out,
                        path,
                        &format!(
                            "invalid UTF-16 (unpaired surrogate 0x{:04X} at byte offset {})",
                            e.unpaired_surrogate(),
                            2 + 2 * at
                        ),
                    ))
                }
            }
        }
        if odd {
            return Err(bad_encoding(
                &out,
                path,
                "UTF-16 text ends in the middle of a character (odd byte count)",
            ));
        }
        Ok(out)
    };
    match bytes {
        [0xFF, 0xFE, ..] => utf16(false),
        [0xFE, 0xFF, ..] => utf16(true),
        _ => {
            let b = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(bytes);
            match std::str::from_utf8(b) {
                Ok(s) => {
                    if let Some(i) = s.find('\0') {
                        let hint = if b.len() > 1 && (b[0] == 0 || b[1] == 0) {
                            " (UTF-16 without a byte-order mark? save it as UTF-8)"
                        } else {
                            ""
                        };
                        return Err(bad_encoding(
                            &s[..i],
                            path,
                            &format!("NUL character at byte offset {i}{hint}"),
                        ));
                    }
                    Ok(s.to_string())
                }
                Err(e) => {
                    let ok = e.valid_up_to();
                    let good = std::str::from_utf8(&b[..ok]).unwrap_or_default();
                    Err(bad_encoding(
                        good,
                        path,
                        &format!(
                            "invalid UTF-8 (byte 0x{:02X} at byte offset {}); scene files must be UTF-8 or UTF-16 with a byte-order mark",
                            b[ok],
                            ok + (bytes.len() - b.len())
                        ),
                    ))
                }
            }
        }
    }
}

/// An encoding error just after the valid text `good`: located at the line and column where
/// `good` ends.
fn bad_encoding(good: &str, path: &Path, msg: &str) -> Error {
    let line = good.matches('\n').count() + 1;
    let col = good.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    Error::scene(&SourceLoc::new(path, line as u32, col as u32), msg)
}
