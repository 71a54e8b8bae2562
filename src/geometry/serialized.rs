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
use crate::error::{Error, Result};
use flate2::bufread::ZlibDecoder;
use glam::{Vec2, Vec3};
use std::fs::File;
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
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let fallback_name = format!(
        "{}@{shape_index}",
        path.file_name().map_or("?".into(), |n| n.to_string_lossy())
    );
    read_serialized(
        BufReader::new(file),
        shape_index,
        keep_normals,
        &fallback_name,
    )
    .map_err(|m| Error::file(path, m))
}

/// Reads mesh `shape_index` from a seekable byte source; errors are plain messages with byte
/// offsets (the caller adds the file name). `fallback_name` names a version 3 mesh.
pub fn read_serialized<R: BufRead + Seek>(
    mut r: R,
    shape_index: u32,
    keep_normals: bool,
    fallback_name: &str,
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
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use flate2::Compression;
    use std::io::{Cursor, Write};

    /// A test encoder: one mesh's header and zlib stream, with optional colours.
    #[derive(Clone)]
    struct Enc {
        version: u16,
        double: bool,
        mesh: TriMesh,
        colors: bool,
        name: String,
    }

    impl Enc {
        fn new(mesh: TriMesh) -> Enc {
            Enc {
                version: 4,
                double: false,
                mesh,
                colors: false,
                name: "mesh".into(),
            }
        }

        /// The uncompressed stream content (flag word onwards).
        fn raw(&self) -> Vec<u8> {
            let m = &self.mesh;
            let mut f = if self.double {
                flags::DOUBLE_PRECISION
            } else {
                flags::SINGLE_PRECISION
            };
            if m.normals.is_some() {
                f |= flags::HAS_NORMALS;
            }
            if m.uvs.is_some() {
                f |= flags::HAS_TEXCOORDS;
            }
            if self.colors {
                f |= flags::HAS_COLORS;
            }
            let mut b = f.to_le_bytes().to_vec();
            if self.version == 4 {
                b.extend(self.name.as_bytes());
                b.push(0);
            }
            b.extend((m.positions.len() as u64).to_le_bytes());
            b.extend((m.indices.len() as u64).to_le_bytes());
            let dbl = self.double;
            let put = |b: &mut Vec<u8>, x: f32| {
                if dbl {
                    b.extend((x as f64).to_le_bytes())
                } else {
                    b.extend(x.to_le_bytes())
                }
            };
            for p in &m.positions {
                p.to_array().iter().for_each(|&x| put(&mut b, x));
            }
            for n in m.normals.iter().flatten() {
                n.to_array().iter().for_each(|&x| put(&mut b, x));
            }
            for t in m.uvs.iter().flatten() {
                t.to_array().iter().for_each(|&x| put(&mut b, x));
            }
            if self.colors {
                for i in 0..m.positions.len() {
                    [0.25, 0.5, i as f32].iter().for_each(|&x| put(&mut b, x));
                }
            }
            for t in &m.indices {
                t.iter().for_each(|i| b.extend(i.to_le_bytes()));
            }
            b
        }

        fn header(&self) -> Vec<u8> {
            let mut b = FORMAT_ID.to_le_bytes().to_vec();
            b.extend(self.version.to_le_bytes());
            b
        }

        fn encode(&self) -> Vec<u8> {
            let mut b = self.header();
            b.extend(zlib(&self.raw()));
            b
        }
    }

    fn zlib(data: &[u8]) -> Vec<u8> {
        let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    /// A file of several meshes with the end-of-file dictionary (all of one version).
    fn file(meshes: &[Enc]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for m in meshes {
            offsets.push(out.len() as u64);
            out.extend(m.encode());
        }
        for o in offsets {
            if meshes[0].version == 4 {
                out.extend(o.to_le_bytes());
            } else {
                out.extend((o as u32).to_le_bytes());
            }
        }
        out.extend((meshes.len() as u32).to_le_bytes());
        out
    }

    fn read(bytes: &[u8], index: u32) -> std::result::Result<SerializedMesh, String> {
        read_serialized(Cursor::new(bytes), index, true, "test@0")
    }

    /// A small closed-ish mesh: a tetrahedron with normals and uvs.
    fn tetra(normals: bool, uvs: bool) -> TriMesh {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.5),
        ];
        TriMesh {
            normals: normals.then(|| positions.iter().map(|p| (*p - 0.25).normalize()).collect()),
            uvs: uvs.then(|| {
                positions
                    .iter()
                    .map(|p| Vec2::new(p.x, p.y + 0.5))
                    .collect()
            }),
            positions,
            indices: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    /// A grid of `n`×`n` quads, for a mesh bigger than one streaming chunk.
    fn grid(n: u32) -> TriMesh {
        let mut m = TriMesh::default();
        for y in 0..=n {
            for x in 0..=n {
                m.positions
                    .push(Vec3::new(x as f32 * 0.1, y as f32 * 0.3, 0.0));
            }
        }
        for y in 0..n {
            for x in 0..n {
                let i = y * (n + 1) + x;
                m.indices.push([i, i + 1, i + n + 2]);
                m.indices.push([i, i + n + 2, i + n + 1]);
            }
        }
        m.uvs = Some(m.positions.iter().map(|p| p.truncate()).collect());
        m
    }

    #[test]
    fn round_trip_versions_precisions_and_attributes() {
        for version in [3, 4] {
            for double in [false, true] {
                for (n, uv, c) in [
                    (false, false, false),
                    (true, false, false),
                    (false, true, false),
                    (true, true, true),
                    (false, false, true),
                ] {
                    let mut e = Enc::new(tetra(n, uv));
                    e.version = version;
                    e.double = double;
                    e.colors = c;
                    e.name = "tetra".into();
                    let got = read(&file(&[e.clone()]), 0)
                        .unwrap_or_else(|m| panic!("v{version} dp={double} n={n} uv={uv}: {m}"));
                    assert_eq!(
                        got.mesh, e.mesh,
                        "v{version} dp={double} n={n} uv={uv} c={c}"
                    );
                    assert_eq!(got.version, version);
                    assert_eq!(got.name, if version == 4 { "tetra" } else { "test@0" });
                    assert_eq!(got.flags & flags::DOUBLE_PRECISION != 0, double);
                }
            }
        }
    }

    #[test]
    fn double_precision_is_rounded_to_f32() {
        let mut m = tetra(false, false);
        m.positions[3].z = 0.1; // not exact in binary: f64 → f32 rounding, as Mitsuba
        let mut e = Enc::new(m);
        e.double = true;
        let got = read(&e.encode(), 0).unwrap();
        assert_eq!(got.mesh.positions[3].z, 0.1f32);
    }

    #[test]
    fn face_normals_skips_the_stored_normals() {
        let e = Enc::new(tetra(true, true));
        let got = read_serialized(Cursor::new(e.encode()), 0, false, "x").unwrap();
        assert!(got.mesh.normals.is_none());
        assert_eq!(got.mesh.uvs, e.mesh.uvs);
        assert_eq!(got.mesh.positions, e.mesh.positions);
    }

    #[test]
    fn meshes_larger_than_a_chunk_stream_through() {
        let mut e = Enc::new(grid(120)); // 14641 vertices, 28800 faces
        e.double = true;
        let got = read(&e.encode(), 0).unwrap();
        assert_eq!(got.mesh, e.mesh);
    }

    #[test]
    fn shape_index_selects_meshes_in_both_dictionary_widths() {
        for version in [3, 4] {
            let meshes: Vec<Enc> = (0..3)
                .map(|i| {
                    let mut m = tetra(i != 1, i == 2);
                    m.positions.iter_mut().for_each(|p| p.x += i as f32);
                    let mut e = Enc::new(m);
                    e.version = version;
                    e.name = format!("m{i}");
                    e
                })
                .collect();
            let f = file(&meshes);
            for (i, e) in meshes.iter().enumerate() {
                let got = read(&f, i as u32).unwrap();
                assert_eq!(got.mesh, e.mesh, "v{version} mesh {i}");
                if version == 4 {
                    assert_eq!(got.name, format!("m{i}"));
                }
            }
            let err = read(&f, 3).unwrap_err();
            assert!(
                err.contains("shape_index 3 out of range (file holds 3 meshes"),
                "{err}"
            );
        }
    }

    fn assert_corrupt(bytes: &[u8], index: u32, expect: &str) {
        match read(bytes, index) {
            Ok(_) => panic!("accepted a corrupt file (expected `{expect}`)"),
            Err(m) => assert!(m.contains(expect), "`{m}` lacks `{expect}`"),
        }
    }

    #[test]
    fn bad_header_id_and_version() {
        let good = file(&[Enc::new(tetra(true, true))]);
        let mut b = good.clone();
        b[0] = 0x1D;
        assert_corrupt(&b, 0, "format id 0x041d at offset 0");
        let mut b = good.clone();
        b[2] = 5;
        assert_corrupt(&b, 0, "unsupported serialized mesh version 5 at offset 2");
        assert_corrupt(&good[..3], 0, "at offset 0: the file (3 bytes) ends inside");
        assert_corrupt(&[], 0, "ends inside");
    }

    #[test]
    fn truncated_files_name_the_offset() {
        let good = Enc::new(grid(20)).encode();
        for cut in [5, 12, good.len() / 2, good.len() - 3, good.len() - 1] {
            let err = read(&good[..cut], 0).unwrap_err();
            assert!(
                err.starts_with("corrupt serialized mesh at offset "),
                "{cut}: {err}"
            );
            let at: u64 = err["corrupt serialized mesh at offset ".len()..]
                .split(':')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!(at <= cut as u64, "offset {at} beyond the cut {cut}: {err}");
        }
    }

    #[test]
    fn wrong_zlib_data_is_an_error() {
        let e = Enc::new(grid(10));
        // Not zlib at all.
        let mut b = e.header();
        b.extend(e.raw());
        assert_corrupt(&b, 0, "invalid zlib data");
        // A flipped bit in the Adler-32 checksum at the end of the stream.
        let mut b = e.encode();
        let n = b.len();
        b[n - 1] ^= 0x40;
        assert_corrupt(&b, 0, "invalid zlib data");
        // Raw deflate without the zlib header.
        let mut b = e.header();
        let mut d = flate2::write::DeflateEncoder::new(Vec::new(), Compression::default());
        d.write_all(&e.raw()).unwrap();
        b.extend(d.finish().unwrap());
        assert_corrupt(
            &b,
            0,
            "invalid zlib data (corrupt deflate stream) while reading the flag word",
        );
    }

    #[test]
    fn huge_counts_are_refused_before_allocating() {
        let e = Enc::new(tetra(true, false));
        let raw = e.raw();
        let counts_at = 4 + e.name.len() + 1;
        for (nv, nf, expect) in [
            (1u64 << 40, 4u64, "exceed the 2^32-1"),
            (4, 1 << 63, "more than 2^64"),
            (1 << 31, 4, "decompress to at most"),
            (4, 1 << 33, "decompress to at most"),
        ] {
            let mut r = raw.clone();
            r[counts_at..counts_at + 8].copy_from_slice(&nv.to_le_bytes());
            r[counts_at + 8..counts_at + 16].copy_from_slice(&nf.to_le_bytes());
            let mut b = e.header();
            b.extend(zlib(&r));
            assert_corrupt(&b, 0, expect);
        }
        // A plausible-but-false count: the data runs out, with an offset, no huge allocation.
        let mut r = raw.clone();
        r[counts_at..counts_at + 8].copy_from_slice(&400u64.to_le_bytes());
        let mut b = e.header();
        b.extend(zlib(&r));
        assert_corrupt(
            &b,
            0,
            "the compressed data ends early while reading the vertex positions",
        );
    }

    #[test]
    fn bad_indices_extra_data_and_bad_dictionaries() {
        let mut m = tetra(false, false);
        m.indices[2] = [0, 1, 9];
        assert_corrupt(&Enc::new(m).encode(), 0, "triangle 2 uses vertex index 9");
        // Flags claim no normals, but the stream holds them: data left over.
        let e = Enc::new(tetra(true, false));
        let mut r = e.raw();
        r[0] &= !(flags::HAS_NORMALS as u8);
        let mut b = e.header();
        b.extend(zlib(&r));
        assert!(read(&b, 0).is_err());
        // Dictionary pointing into nowhere / at a non-header, and a count of 0.
        let meshes = [Enc::new(tetra(true, true)), Enc::new(tetra(false, false))];
        let good = file(&meshes);
        let n = good.len();
        let mut b = good.clone();
        b[n - 12..n - 4].copy_from_slice(&(n as u64 * 2).to_le_bytes());
        assert_corrupt(&b, 1, "beyond the mesh data");
        let mut b = good.clone();
        b[n - 12..n - 4].copy_from_slice(&7u64.to_le_bytes());
        assert_corrupt(
            &b,
            1,
            "corrupt serialized mesh at offset 7: mesh 1 starts with",
        );
        let mut b = good.clone();
        b[n - 4..].copy_from_slice(&0u32.to_le_bytes());
        assert_corrupt(&b, 1, "shape_index 1 out of range (file holds 0 meshes");
        let mut b = good.clone();
        b[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_corrupt(&b, 1, "does not fit");
        // Mesh 0 of a file needs no dictionary.
        assert_eq!(read(&meshes[0].encode(), 0).unwrap().mesh, meshes[0].mesh);
    }

    #[test]
    fn load_names_the_file() {
        let dir = std::env::temp_dir().join(format!("groove_ser_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("two.serialized");
        std::fs::write(&p, file(&[Enc::new(tetra(true, true))])).unwrap();
        assert_eq!(load_serialized(&p, 0, true).unwrap().name, "mesh");
        let err = load_serialized(&p, 5, true).unwrap_err().to_string();
        assert!(
            err.contains("two.serialized")
                && err.contains("shape_index 5 out of range (file holds 1 mesh;"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]
        /// Random byte mutations (and truncations) of a valid two-mesh file never panic, and
        /// whatever is accepted satisfies the mesh invariants.
        #[test]
        fn mutations_never_panic(
            edits in proptest::collection::vec((0usize..4096, proptest::prelude::any::<u8>()), 1..6),
            cut in 0usize..4096,
            version in 3u16..5,
            index in 0u32..3,
        ) {
            let mut a = Enc::new(grid(4));
            a.version = version;
            a.double = true;
            let mut b = Enc::new(tetra(true, true));
            b.version = version;
            b.colors = true;
            let mut bytes = file(&[a, b]);
            for (at, v) in edits {
                let n = bytes.len();
                bytes[at % n] = v;
            }
            if cut < bytes.len() && cut % 3 == 0 {
                bytes.truncate(cut);
            }
            if let Ok(m) = read(&bytes, index) {
                proptest::prop_assert!(m.mesh.validate().is_ok());
            }
        }
    }
}
