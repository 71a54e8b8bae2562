//! Sorts the attributes of an OpenEXR file's header(s) by name, in place, so that one image with
//! one metadata gives one file, byte for byte, in every run.
//!
//! The `exr` crate keeps a header's custom attributes in a `HashMap`, whose iteration order
//! changes from one map to the next, so the same render wrote its `groove.*` attributes in a
//! different order each time. OpenEXR gives the order no meaning (OpenEXR file layout: a header
//! is a sequence of attributes, each a NUL-terminated name, a NUL-terminated type name, a 32-bit
//! little-endian size and that many bytes of value, closed by a NUL byte; a multi-part file has
//! one header per part, then an empty one). Sorting keeps each header's length, so the offset
//! tables after the headers stay valid.

use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::ops::Range;

/// The magic number that opens every OpenEXR file (20000630, little-endian).
const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// The version field's flag of a multi-part file.
const MULTI_PART: u32 = 0x1000;
/// The most header bytes read: far beyond any header groove writes (its largest, a part file's,
/// is a few KiB), it bounds the work on a file that is not what it should be.
const MAX_HEADER: u64 = 16 << 20;

/// Sorts the header attributes of the EXR just encoded through `w` (flushed first), rewriting
/// them in place; the file's length and everything after the headers are unchanged.
pub(super) fn sort_written(w: &mut BufWriter<File>) -> Result<(), String> {
    w.flush().map_err(|e| format!("cannot write EXR: {e}"))?;
    sort_file(w.get_mut())
}

/// [`sort_written`] on any readable, writable, seekable file.
pub(super) fn sort_file<F: Read + Write + Seek>(f: &mut F) -> Result<(), String> {
    let io = |e: std::io::Error| format!("cannot reorder the EXR header: {e}");
    let len = f.seek(SeekFrom::End(0)).map_err(io)?;
    let mut want = len.min(64 << 10);
    loop {
        let mut head = vec![0u8; want as usize];
        f.seek(SeekFrom::Start(0)).map_err(io)?;
        f.read_exact(&mut head).map_err(io)?;
        match headers(&head)? {
            Some(list) => {
                let start = list.first().map_or(8, |h| h.start);
                let sorted = sorted_bytes(&head, &list);
                f.seek(SeekFrom::Start(start as u64)).map_err(io)?;
                f.write_all(&sorted).map_err(io)?;
                f.seek(SeekFrom::End(0)).map_err(io)?;
                return Ok(());
            }
            None if want < len.min(MAX_HEADER) => want = (want * 2).min(len.min(MAX_HEADER)),
            None => return Err("cannot reorder the EXR header: it does not end".into()),
        }
    }
}

/// One header: where it starts and the byte range of each attribute in it.
struct Header {
    start: usize,
    attributes: Vec<Range<usize>>,
}

/// The headers of the EXR whose first bytes are `b`, or `None` if `b` ends inside them.
fn headers(b: &[u8]) -> Result<Option<Vec<Header>>, String> {
    if b.len() < 8 {
        return Ok(None);
    }
    if b[..4] != MAGIC {
        return Err("cannot reorder the EXR header: not an OpenEXR file".into());
    }
    let version = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
    let multi = version & MULTI_PART != 0;
    let mut list = Vec::new();
    let mut pos = 8;
    loop {
        let start = pos;
        let mut attributes = Vec::new();
        loop {
            match b.get(pos) {
                None => return Ok(None),
                Some(0) => {
                    pos += 1;
                    break;
                }
                Some(_) => {}
            }
            let Some(end) = attribute_end(b, pos)? else {
                return Ok(None);
            };
            attributes.push(pos..end);
            pos = end;
        }
        list.push(Header { start, attributes });
        if !multi {
            return Ok(Some(list));
        }
        // A multi-part file's headers end with an empty one (a lone NUL).
        match b.get(pos) {
            None => return Ok(None),
            Some(0) => return Ok(Some(list)),
            Some(_) => {}
        }
    }
}

/// The end of the attribute that starts at `pos`, or `None` if `b` ends first.
fn attribute_end(b: &[u8], pos: usize) -> Result<Option<usize>, String> {
    let Some(name) = b[pos..].iter().position(|&c| c == 0) else {
        return Ok(None);
    };
    let ty = pos + name + 1;
    let Some(ty_len) = b.get(ty..).and_then(|r| r.iter().position(|&c| c == 0)) else {
        return Ok(None);
    };
    let size_at = ty + ty_len + 1;
    let Some(size) = b.get(size_at..size_at + 4) else {
        return Ok(None);
    };
    let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
    if size < 0 {
        return Err("cannot reorder the EXR header: an attribute has a negative size".into());
    }
    let end = size_at + 4 + size as usize;
    Ok((end <= b.len()).then_some(end))
}

/// The headers' bytes from the first one's start to the last one's end (its closing NUL
/// included), each header's attributes sorted by name.
fn sorted_bytes(b: &[u8], list: &[Header]) -> Vec<u8> {
    let mut out = Vec::new();
    for h in list {
        let mut attrs: Vec<&Range<usize>> = h.attributes.iter().collect();
        let name = |r: &Range<usize>| {
            let a = &b[r.clone()];
            &a[..a.iter().position(|&c| c == 0).unwrap_or(a.len())]
        };
        attrs.sort_by(|x, y| name(x).cmp(name(y)));
        for r in attrs {
            out.extend_from_slice(&b[r.clone()]);
        }
        out.push(0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// One attribute's bytes.
    fn attr(name: &str, ty: &str, value: &[u8]) -> Vec<u8> {
        let mut v = Vec::new();
        v.extend_from_slice(name.as_bytes());
        v.push(0);
        v.extend_from_slice(ty.as_bytes());
        v.push(0);
        v.extend_from_slice(&(value.len() as i32).to_le_bytes());
        v.extend_from_slice(value);
        v
    }

    fn file(version: u32, headers: &[Vec<Vec<u8>>], tail: &[u8]) -> Vec<u8> {
        let mut v = MAGIC.to_vec();
        v.extend_from_slice(&version.to_le_bytes());
        for h in headers {
            for a in h {
                v.extend_from_slice(a);
            }
            v.push(0);
        }
        if version & MULTI_PART != 0 {
            v.push(0);
        }
        v.extend_from_slice(tail);
        v
    }

    #[test]
    fn sorts_a_single_part_header_and_keeps_the_rest() {
        let (c, a, b) = (
            attr("c", "string", b"3"),
            attr("a", "string", b"one"),
            attr("b", "int", &[0, 1, 2, 3]),
        );
        let tail = [9u8, 8, 7, 0, 0, 6];
        let mut f = Cursor::new(file(2, &[vec![c.clone(), a.clone(), b.clone()]], &tail));
        sort_file(&mut f).unwrap();
        assert_eq!(f.into_inner(), file(2, &[vec![a, b, c]], &tail));
    }

    #[test]
    fn sorts_each_header_of_a_multi_part_file() {
        let h1 = vec![attr("z", "string", b""), attr("y", "string", b"x")];
        let h2 = vec![attr("n", "int", &[1; 4]), attr("m", "int", &[2; 4])];
        let v = MULTI_PART | 2;
        let mut f = Cursor::new(file(v, &[h1.clone(), h2.clone()], &[5, 5]));
        sort_file(&mut f).unwrap();
        let want = file(
            v,
            &[
                vec![h1[1].clone(), h1[0].clone()],
                vec![h2[1].clone(), h2[0].clone()],
            ],
            &[5, 5],
        );
        assert_eq!(f.into_inner(), want);
    }

    #[test]
    fn a_header_beyond_the_first_read_is_read_whole() {
        let big = vec![7u8; 100 << 10];
        let (a, b) = (attr("b", "string", &big), attr("a", "string", b"s"));
        let mut f = Cursor::new(file(2, &[vec![a.clone(), b.clone()]], &[1]));
        sort_file(&mut f).unwrap();
        assert_eq!(f.into_inner(), file(2, &[vec![b, a]], &[1]));
    }

    #[test]
    fn broken_files_are_errors() {
        let mut not_exr = Cursor::new(b"P6\n1 1\n255\n\0\0\0\0\0\0".to_vec());
        assert!(sort_file(&mut not_exr).is_err());
        let mut unended = Cursor::new(file(2, &[], &[])[..8].to_vec());
        unended.get_mut().extend_from_slice(b"name\0string\0");
        assert!(sort_file(&mut unended).is_err());
        let mut negative = Cursor::new(MAGIC.to_vec());
        negative.get_mut().extend_from_slice(&2u32.to_le_bytes());
        negative.get_mut().extend_from_slice(b"a\0int\0");
        negative.get_mut().extend_from_slice(&(-4i32).to_le_bytes());
        negative.get_mut().extend_from_slice(&[0; 8]);
        assert!(sort_file(&mut negative).is_err());
    }

    /// The real writers: the same image and metadata written twice (each write builds its own
    /// `HashMap` of attributes, so before the sort the order differed between the two with high
    /// probability for ten keys) give the same bytes, the header's names in order, and the
    /// metadata reads back.
    #[test]
    fn the_same_image_is_the_same_file() {
        use crate::film::Image;
        use crate::output::{read_exr, write_image, write_image_channels, Metadata};
        let dir = std::env::temp_dir().join(format!("groove-header-order-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(3, 2);
        img.data[4] = [0.5, 1.0, 2.0];
        let meta = Metadata(
            (0..10)
                .map(|i| (format!("k{i}"), format!("v{i}")))
                .collect(),
        );
        let extra = vec![("depth.T".to_string(), vec![1.0f32; 6])];
        for (n, channels) in [(0, false), (1, true)] {
            let (a, b) = (dir.join(format!("a{n}.exr")), dir.join(format!("b{n}.exr")));
            for p in [&a, &b] {
                if channels {
                    write_image_channels(p, &img, &extra, &meta).unwrap();
                } else {
                    write_image(p, &img, &meta).unwrap();
                }
            }
            let (fa, fb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
            assert_eq!(fa, fb);
            let list = headers(&fa).unwrap().unwrap();
            let names: Vec<&[u8]> = list[0]
                .attributes
                .iter()
                .map(|r| fa[r.start..].split(|&c| c == 0).next().unwrap())
                .collect();
            assert!(names.windows(2).all(|w| w[0] < w[1]), "{names:?}");
            assert!(names.len() >= 16, "{}", names.len());
            let (back, got) = read_exr(&a).unwrap();
            assert_eq!(back.data, img.data);
            assert_eq!(got, meta);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
