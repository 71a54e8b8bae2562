//! Unit tests of the `serialized` reader: round trips through a small encoder written here,
//! multi-mesh files, and corrupt files (each a clear error, no panic, no huge allocation).
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
