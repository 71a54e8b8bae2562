//! A mesh's interleaved vertex rows (`TriMesh::vertex_rows`, `lane::Row8`) read in lanes:
//! `Avx2::gather_rows` (the stream's surface gather) and `surface_lanes::row_normal` (the
//! emitter sampling's normals) equal the gathers from the separate arrays bit for bit, for
//! every index (clamped ones included) and every value (±0, subnormals, the largest finite,
//! ±∞, NaN with payloads, random bit patterns).

use glam::{Vec2, Vec3};
use groove::geometry::surface_lanes::row_normal;
use groove::geometry::TriMesh;
use groove::lane::{Lane, Row8};
use groove::math::Pcg32;

/// A value of every kind: the edge cases in turn, then random bit patterns.
fn value(k: usize, r: &mut Pcg32) -> f32 {
    const EDGES: [f32; 10] = [
        0.0,
        -0.0,
        f32::MIN_POSITIVE,
        1e-40,
        -1e-45,
        f32::MAX,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];
    if k.is_multiple_of(2) {
        EDGES[(k / 2) % EDGES.len()]
    } else {
        f32::from_bits(r.next_u32())
    }
}

fn mesh(n: usize, seed: u64) -> TriMesh {
    let mut r = Pcg32::new(seed, 3);
    let mut k = 0;
    let mut f = || {
        k += 1;
        value(k, &mut r)
    };
    let positions = (0..n).map(|_| Vec3::new(f(), f(), f())).collect();
    let normals = (0..n).map(|_| Vec3::new(f(), f(), f())).collect();
    let uvs = (0..n).map(|_| Vec2::new(f(), f())).collect();
    TriMesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        indices: vec![[0, 0, 0]],
    }
}

/// Indices in range, at the ends, and out of range (negative and past the end: both gathers
/// clamp them to the last row).
fn index(r: &mut Pcg32, n: usize) -> i32 {
    match r.next_u32() % 8 {
        0 => 0,
        1 => n as i32 - 1,
        2 => n as i32 + (r.next_u32() % 100) as i32,
        3 => -1 - (r.next_u32() % 1000) as i32,
        _ => (r.next_u32() as usize % n) as i32,
    }
}

fn bits<const K: usize>(v: [[f32; 8]; K]) -> [[u32; 8]; K] {
    v.map(|l| l.map(f32::to_bits))
}

#[test]
fn gather_rows_equals_the_arrays_gathers() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::{Avx2, F32x8};
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2/FMA: the 8-wide row gather is not tested");
            return;
        };
        let mut r = Pcg32::new(5, 9);
        for (n, seed) in [(1, 1), (2, 2), (7, 3), (1000, 4), (4097, 5)] {
            let m = mesh(n, seed);
            let rows = m.vertex_rows();
            let (ns, ts) = (m.normals.as_ref().unwrap(), m.uvs.as_ref().unwrap());
            for _ in 0..2000 {
                let idx: [i32; 8] = std::array::from_fn(|_| index(&mut r, n));
                let (got8, got6, want) = avx.run(|| {
                    let i = avx.load_i32(&idx);
                    let g8 = avx.gather_rows::<8>(&rows.rows, i).map(F32x8::to_array);
                    let g6 = avx.gather_rows::<6>(&rows.rows, i).map(F32x8::to_array);
                    let [px, py, pz] = F32x8::gather3(&m.positions, i);
                    let [nx, ny, nz] = F32x8::gather3(ns, i);
                    let [u, v] = avx.gather2(ts, i);
                    let want = [px, py, pz, nx, ny, nz, u, v].map(F32x8::to_array);
                    (g8, g6, want)
                });
                assert_eq!(bits(got8), bits(want), "n {n}, indices {idx:?}");
                assert_eq!(bits(got6), bits([0, 1, 2, 3, 4, 5].map(|c| want[c])));
                let got_n = avx.run(|| {
                    let i = avx.load_i32(&idx.map(|i| i.clamp(0, n as i32 - 1)));
                    row_normal::<F32x8>(Row8::flatten(&rows.rows), i).map(F32x8::to_array)
                });
                let want_n = [3, 4, 5]
                    .map(|c| idx.map(|i| rows.rows[i.clamp(0, n as i32 - 1) as usize].0[c]));
                assert_eq!(bits(got_n), bits(want_n));
            }
        }
    }
}

/// `row_normal` at width 1 (the scalar instantiation of the emitter sampling) reads the
/// normals array's values.
#[test]
fn row_normal_width_1_reads_the_normals() {
    let m = mesh(333, 8);
    let rows = m.vertex_rows();
    let flat = Row8::flatten(&rows.rows);
    for (i, n) in m.normals.as_ref().unwrap().iter().enumerate() {
        let got = row_normal::<f32>(flat, i as i32).map(f32::to_bits);
        assert_eq!(got, n.to_array().map(f32::to_bits), "vertex {i}");
        let p = <f32 as Lane>::gather3(&m.positions, i as i32).map(f32::to_bits);
        assert_eq!(p, m.positions[i].to_array().map(f32::to_bits));
    }
}
