//! Mitsuba's `serialized` mesh format (versions 3 and 4, as read by Mitsuba 3.9.1's
//! `src/shapes/serialized.cpp`): one or more zlib-compressed indexed triangle meshes in one file.
//!
//! # XML parameters of `<shape type="serialized">`
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `filename` | string | required | the `.serialized` file |
//! | `shape_index` | integer | 0 | which mesh of a multi-mesh file (must be ≥ 0 and below the count) |
//! | `face_normals` | boolean | `false` | discard stored or computed vertex normals: flat shading |
//! | `flip_normals` | boolean | `false` | the mesh is inverted (normals point inwards) |
//! | `to_world` | transform | identity | object-to-world transform (normals by its inverse transpose) |
//!
//! Mitsuba 3.9.1 semantics matched here: stored normals are used (renormalised after the
//! transform) unless `face_normals` is set; a mesh without stored normals gets Mitsuba's
//! angle-weighted vertex normals ([`TriMesh::compute_vertex_normals`], done by
//! [`Shape::from_mesh`](super::Shape::from_mesh)); texture coordinates are used as stored (no
//! `v` flip, unlike OBJ); per-vertex colours are read and discarded; the file's own
//! face-normals flag (`0x0010`) is ignored, as Mitsuba 3.9.1 ignores it (only the XML parameter
//! counts); double-precision data is rounded to `f32`.
//!
//! # File layout (all little endian)
//!
//! Per mesh: `u16` format id `0x041C`, `u16` version (3 or 4), then a zlib stream (RFC 1950/1951)
//! holding `u32` flags (`0x1` normals, `0x2` texcoords, `0x8` colours, `0x10` face normals,
//! `0x1000` single, `0x2000` double precision), for version 4 a NUL-terminated name, `u64` vertex
//! count V, `u64` face count F, then V×3 positions, [V×3 normals], [V×2 uvs], [V×3 colours]
//! (`f32` or `f64`) and F×3 `u32` vertex indices. Meshes are concatenated; the file ends with the
//! byte offset of every mesh (`u32` each in version 3, `u64` in version 4) and a `u32` mesh count,
//! which is how `shape_index` finds its mesh. Mitsuba 0.6 wrote `u64` indices for meshes with more
//! than 2³²−1 vertices; Mitsuba 3 and groove (whose indices are `u32`) reject such meshes.
//!
//! # Hostile input
//!
//! The file is streamed (a `BufReader` and a streaming zlib decoder; no whole-file copy). Counts
//! are checked before anything is allocated: the arrays they imply must fit in what the rest of
//! the file can decompress to (DEFLATE expands at most 1032:1, RFC 1951: a 258-byte match coded in
//! two 1-bit codes), and arrays then grow only as data really arrives. Every failure is an
//! [`Error`] naming the file and a byte offset; nothing panics.

use super::mesh::TriMesh;
use crate::budget::Budget;
use crate::error::{Error, Result};
use flate2::bufread::ZlibDecoder;
use glam::{Vec2, Vec3};
use std::io::{BufRead, BufReader, ErrorKind, Read, Seek, SeekFrom};
use std::path::Path;

/// The format id at the start of every mesh (`MI_FILEFORMAT_HEADER`).
pub const FORMAT_ID: u16 = 0x041C;

/// Flag bits of the per-mesh flag word.
pub mod flags {
    pub const HAS_NORMALS: u32 = 0x0001;
    pub const HAS_TEXCOORDS: u32 = 0x0002;
    pub const HAS_COLORS: u32 = 0x0008;
    pub const FACE_NORMALS: u32 = 0x0010;
    pub const SINGLE_PRECISION: u32 = 0x1000;
    pub const DOUBLE_PRECISION: u32 = 0x2000;
}

/// DEFLATE's largest expansion factor (output bytes per input byte), RFC 1951.
const MAX_INFLATE_RATIO: u64 = 1032;
/// Longest mesh name accepted (version 4); Mitsuba has no limit, but names are short.
const MAX_NAME_LEN: usize = 1 << 16;
/// Values decoded per chunk while streaming arrays.
const CHUNK_VALUES: usize = 1 << 14;

/// One mesh read from a `.serialized` file, untransformed.
#[derive(Clone, Debug, PartialEq)]
pub struct SerializedMesh {
    /// The stored name (version 4), or `FILE@INDEX` as Mitsuba names it (version 3).
    pub name: String,
    /// The file format version (3 or 4).
    pub version: u16,
    /// The flag word as stored.
    pub flags: u32,
    pub mesh: TriMesh,
}

/// Loads mesh `shape_index` of the file at `path` (untransformed). `keep_normals = false` skips
/// stored normals without keeping them (for `face_normals`, as Mitsuba does). Errors name the
/// file and the byte offset of the problem.
pub fn load_serialized(
    path: &Path,
    shape_index: u32,
    keep_normals: bool,
) -> Result<SerializedMesh> {
    load_serialized_within(path, shape_index, keep_normals, &Budget::default())
}

/// [`load_serialized`] of a regular file, whose mesh (from its stored counts, before
/// anything is allocated) must fit `budget`.
pub fn load_serialized_within(
    path: &Path,
    shape_index: u32,
    keep_normals: bool,
    budget: &Budget,
) -> Result<SerializedMesh> {
    let (file, _) = crate::inputs::open_regular(path)?;
    let fallback_name = format!(
        "{}@{shape_index}",
        path.file_name().map_or("?".into(), |n| n.to_string_lossy())
    );
    read_serialized_within(
        BufReader::new(file),
        shape_index,
        keep_normals,
        &fallback_name,
        budget,
    )
    .map_err(|m| Error::file(path, m))
}

/// Reads mesh `shape_index` from a seekable byte source; errors are plain messages with byte
/// offsets (the caller adds the file name). `fallback_name` names a version 3 mesh.
pub fn read_serialized<R: BufRead + Seek>(
    r: R,
    shape_index: u32,
    keep_normals: bool,
    fallback_name: &str,
) -> std::result::Result<SerializedMesh, String> {
    read_serialized_within(
        r,
        shape_index,
        keep_normals,
        fallback_name,
        &Budget::default(),
    )
}

/// [`read_serialized`] whose mesh must fit `budget` (checked from the stored counts).
pub fn read_serialized_within<R: BufRead + Seek>(
    mut r: R,
    shape_index: u32,
    keep_normals: bool,
    fallback_name: &str,
    budget: &Budget,
) -> std::result::Result<SerializedMesh, String> {
    let file_len = r
        .seek(SeekFrom::End(0))
        .map_err(|e| format!("cannot determine the file size: {e}"))?;
    let (id, version) = read_header(&mut r, 0, file_len)?;
    if id != FORMAT_ID {
        return Err(format!(
            "not a serialized mesh: format id {id:#06x} at offset 0 (expected {FORMAT_ID:#06x})"
        ));
    }
    if version != 3 && version != 4 {
        return Err(format!(
            "unsupported serialized mesh version {version} at offset 2 (versions 3 and 4 are read, \
             as by Mitsuba 3.9.1)"
        ));
    }
    let start = if shape_index == 0 {
        0
    } else {
        let start = dictionary_offset(&mut r, file_len, version, shape_index)?;
        let (id2, v2) = read_header(&mut r, start, file_len)?;
        if id2 != FORMAT_ID || v2 != version {
            return Err(format!(
                "corrupt serialized mesh at offset {start}: mesh {shape_index} starts with id \
                 {id2:#06x} version {v2}, not {FORMAT_ID:#06x} version {version} (bad end-of-file \
                 dictionary?)"
            ));
        }
        start
    };
    let data_start = start + 4;
    r.seek(SeekFrom::Start(data_start))
        .map_err(|e| format!("corrupt serialized mesh at offset {data_start}: {e}"))?;
    let mut z = Inflated {
        z: ZlibDecoder::new(r),
        base: data_start,
    };
    read_mesh(
        &mut z,
        version,
        keep_normals,
        file_len - data_start,
        fallback_name,
        budget,
    )
}

/// Reads the 4-byte header at `at`: (format id, version).
fn read_header<R: Read + Seek>(
    r: &mut R,
    at: u64,
    file_len: u64,
) -> std::result::Result<(u16, u16), String> {
    if file_len < at.saturating_add(4) {
        return Err(format!(
            "corrupt serialized mesh at offset {at}: the file ({file_len} bytes) ends inside the \
             4-byte mesh header"
        ));
    }
    let mut b = [0u8; 4];
    r.seek(SeekFrom::Start(at))
        .and_then(|_| r.read_exact(&mut b))
        .map_err(|e| format!("corrupt serialized mesh at offset {at}: {e}"))?;
    Ok((
        u16::from_le_bytes([b[0], b[1]]),
        u16::from_le_bytes([b[2], b[3]]),
    ))
}

/// Looks `shape_index` up in the end-of-file dictionary: the byte offset of that mesh.
fn dictionary_offset<R: Read + Seek>(
    r: &mut R,
    file_len: u64,
    version: u16,
    shape_index: u32,
) -> std::result::Result<u64, String> {
    let mut read_at = |at: u64, n: usize| -> std::result::Result<u64, String> {
        let mut b = [0u8; 8];
        r.seek(SeekFrom::Start(at))
            .and_then(|_| r.read_exact(&mut b[..n]))
            .map_err(|e| format!("corrupt serialized mesh at offset {at}: {e}"))?;
        Ok(u64::from_le_bytes(b))
    };
    // Header (4) + the count (4) at least.
    if file_len < 8 {
        return Err(format!(
            "corrupt serialized mesh at offset 0: the file ({file_len} bytes) is too short for an \
             end-of-file mesh dictionary"
        ));
    }
    let count_at = file_len - 4;
    let count = read_at(count_at, 4)?;
    if u64::from(shape_index) >= count {
        return Err(format!(
            "shape_index {shape_index} out of range (file holds {count} mesh{}; dictionary count \
             at offset {count_at})",
            if count == 1 { "" } else { "es" }
        ));
    }
    let width: u64 = if version == 4 { 8 } else { 4 };
    let dict_len = width * count; // count < 2^32, so no overflow
    if dict_len > count_at {
        return Err(format!(
            "corrupt serialized mesh at offset {count_at}: a dictionary of {count} meshes does not \
             fit in a {file_len}-byte file"
        ));
    }
    let entry_at = count_at - dict_len + width * u64::from(shape_index);
    let offset = read_at(entry_at, width as usize)?;
    if offset >= count_at - dict_len {
        return Err(format!(
            "corrupt serialized mesh at offset {entry_at}: mesh {shape_index} is said to start at \
             offset {offset}, beyond the mesh data (which ends at {})",
            count_at - dict_len
        ));
    }
    Ok(offset)
}

/// The decompressed stream of one mesh, with the file offset of its first compressed byte, so
/// that errors can say where in the file they happened.
struct Inflated<R: BufRead> {
    z: ZlibDecoder<R>,
    base: u64,
}

impl<R: BufRead> Inflated<R> {
    fn corrupt(&self, what: &str, e: std::io::Error) -> String {
        let at = self.base + self.z.total_in();
        let out = self.z.total_out();
        let why = match e.kind() {
            ErrorKind::UnexpectedEof => "the compressed data ends early".to_string(),
            _ => format!("invalid zlib data ({e})"),
        };
        format!(
            "corrupt serialized mesh at offset {at}: {why} while reading {what} (decompressed byte \
             {out} of the mesh)"
        )
    }

    fn bytes(&mut self, buf: &mut [u8], what: &str) -> std::result::Result<(), String> {
        self.z.read_exact(buf).map_err(|e| self.corrupt(what, e))
    }

    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        let mut b = [0u8; 4];
        self.bytes(&mut b, what)?;
        Ok(u32::from_le_bytes(b))
    }

    fn u64(&mut self, what: &str) -> std::result::Result<u64, String> {
        let mut b = [0u8; 8];
        self.bytes(&mut b, what)?;
        Ok(u64::from_le_bytes(b))
    }

    fn cstring(&mut self) -> std::result::Result<String, String> {
        let mut s = Vec::new();
        loop {
            let mut b = [0u8; 1];
            self.bytes(&mut b, "the mesh name")?;
            if b[0] == 0 {
                return Ok(String::from_utf8_lossy(&s).into_owned());
            }
            if s.len() >= MAX_NAME_LEN {
                return Err(format!(
                    "corrupt serialized mesh at offset {}: the mesh name is longer than {} bytes \
                     (no terminating NUL)",
                    self.base + self.z.total_in(),
                    MAX_NAME_LEN
                ));
            }
            s.push(b[0]);
        }
    }

    /// Streams `n` records of `D` floats (`f64` rounded to `f32` when `double`) into `out`
    /// through `make`, or discards them when `out` is `None`. Memory grows with the data read.
    fn records<const D: usize, T>(
        &mut self,
        n: usize,
        double: bool,
        what: &str,
        mut out: Option<&mut Vec<T>>,
        make: impl Fn([f32; D]) -> T,
    ) -> std::result::Result<(), String> {
        let size = if double { 8 } else { 4 };
        let per_chunk = (CHUNK_VALUES / D).max(1);
        let mut buf = vec![0u8; per_chunk * D * size];
        let mut left = n;
        while left > 0 {
            let k = left.min(per_chunk);
            let bytes = &mut buf[..k * D * size];
            self.bytes(bytes, what)?;
            if let Some(out) = out.as_deref_mut() {
                out.reserve(k);
                for rec in bytes.chunks_exact(D * size) {
                    let mut v = [0f32; D];
                    for (j, x) in v.iter_mut().enumerate() {
                        let b = &rec[j * size..(j + 1) * size];
                        *x = if double {
                            f64::from_le_bytes(b.try_into().unwrap_or_default()) as f32
                        } else {
                            f32::from_le_bytes(b.try_into().unwrap_or_default())
                        };
                    }
                    out.push(make(v));
                }
            }
            left -= k;
        }
        Ok(())
    }

    /// Streams `n` triangles of three `u32` vertex indices.
    fn faces(&mut self, n: usize) -> std::result::Result<Vec<[u32; 3]>, String> {
        let per_chunk = CHUNK_VALUES / 3;
        let mut buf = vec![0u8; per_chunk * 12];
        let mut out = Vec::new();
        let mut left = n;
        while left > 0 {
            let k = left.min(per_chunk);
            let bytes = &mut buf[..k * 12];
            self.bytes(bytes, "the face indices")?;
            out.reserve(k);
            for t in bytes.chunks_exact(12) {
                let i = |j: usize| u32::from_le_bytes([t[j], t[j + 1], t[j + 2], t[j + 3]]);
                out.push([i(0), i(4), i(8)]);
            }
            left -= k;
        }
        Ok(out)
    }
}

/// Reads the flag word, name, counts and arrays of one mesh from its decompressed stream.
/// `compressed_left` is the number of file bytes from the stream's start to the end of the file.
fn read_mesh<R: BufRead>(
    z: &mut Inflated<R>,
    version: u16,
    keep_normals: bool,
    compressed_left: u64,
    fallback_name: &str,
    budget: &Budget,
) -> std::result::Result<SerializedMesh, String> {
    let flags = z.u32("the flag word")?;
    let name = if version == 4 {
        z.cstring()?
    } else {
        fallback_name.to_string()
    };
    let counts_at = z.z.total_out();
    let nv = z.u64("the vertex count")?;
    let nf = z.u64("the face count")?;
    let double = flags & flags::DOUBLE_PRECISION != 0;
    let has_n = flags & flags::HAS_NORMALS != 0;
    let has_uv = flags & flags::HAS_TEXCOORDS != 0;
    let has_c = flags & flags::HAS_COLORS != 0;

    // The budget: what the counts imply must fit in what the rest of the file can inflate to.
    let lanes = 3 + 3 * u64::from(has_n) + 2 * u64::from(has_uv) + 3 * u64::from(has_c);
    let fsize: u64 = if double { 8 } else { 4 };
    let need = nv
        .checked_mul(lanes * fsize)
        .and_then(|v| nf.checked_mul(12).and_then(|f| v.checked_add(f)));
    let can = compressed_left.saturating_mul(MAX_INFLATE_RATIO);
    let too_big = |why: String| {
        format!(
            "corrupt serialized mesh at offset {}: {why} (vertex and face counts stored at \
             decompressed byte {counts_at} of mesh `{name}`)",
            z.base + z.z.total_in()
        )
    };
    if nv > u64::from(u32::MAX) {
        return Err(too_big(format!(
            "{nv} vertices exceed the 2^32-1 that 32-bit vertex indices can address"
        )));
    }
    match need {
        Some(need) if need <= can => {}
        _ => {
            return Err(too_big(format!(
                "{nv} vertices and {nf} faces need {} bytes of mesh data, but the remaining \
                 {compressed_left} bytes of the file decompress to at most {can}",
                need.map_or("more than 2^64".into(), |n| n.to_string())
            )))
        }
    }
    // What the arrays take once read as f32 (positions, normals, uvs) and u32 triangles.
    let keep = nv
        .saturating_mul(12 + 12 * u64::from(has_n) + 8 * u64::from(has_uv))
        .saturating_add(nf.saturating_mul(12));
    budget.check(keep, &format!("mesh `{name}` ({nv} vertices, {nf} faces)"))?;
    let (nv, nf) = (nv as usize, nf as usize);

    let mut positions = Vec::new();
    z.records(
        nv,
        double,
        "the vertex positions",
        Some(&mut positions),
        Vec3::from,
    )?;
    let mut normals = Vec::new();
    if has_n {
        let out = keep_normals.then_some(&mut normals);
        z.records(nv, double, "the vertex normals", out, Vec3::from)?;
    }
    let mut uvs = Vec::new();
    if has_uv {
        z.records(
            nv,
            double,
            "the texture coordinates",
            Some(&mut uvs),
            Vec2::from,
        )?;
    }
    if has_c {
        z.records::<3, Vec3>(nv, double, "the vertex colours", None, Vec3::from)?;
    }
    let indices = z.faces(nf)?;
    // The stream must end here (this also verifies its Adler-32 checksum).
    let mut extra = [0u8; 1];
    match z.z.read(&mut extra) {
        Ok(0) => {}
        Ok(_) => {
            return Err(format!(
                "corrupt serialized mesh at offset {}: the compressed stream holds more data than \
                 flags {flags:#06x} and the counts ({nv} vertices, {nf} faces) describe",
                z.base + z.z.total_in()
            ))
        }
        Err(e) => return Err(z.corrupt("the end of the compressed stream", e)),
    }
    let mesh = TriMesh {
        positions,
        normals: (has_n && keep_normals).then_some(normals),
        uvs: has_uv.then_some(uvs),
        indices,
    };
    mesh.validate()
        .map_err(|m| format!("mesh `{name}` (offset {}): {m}", z.base - 4))?;
    Ok(SerializedMesh {
        name,
        version,
        flags,
        mesh,
    })
}

#[cfg(test)]
#[path = "serialized_tests.rs"]
mod tests;
