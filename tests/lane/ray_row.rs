//! `Avx2::ray_row` (one ray as a row of 8 floats: tier A's packets read the stream renderer's
//! rays in place) against the fields read one by one: every bit moved (edge floats: ±0, ±∞,
//! NaN payloads, subnormals, random bits), and 8 rows transposed equal `Avx2::ray_fields` of
//! the same rays.

use crate::harness::edge_or_bits;
use groove::geometry::Ray;
use groove::lane::F32x8;
use groove::math::Pcg32;

/// `n` rays whose every float is an edge value or random bits ([`edge_or_bits`]).
fn edge_rays(r: &mut Pcg32, n: usize) -> Vec<Ray> {
    let mut f = || edge_or_bits(r);
    (0..n)
        .map(|_| Ray {
            o: glam::Vec3::new(f(), f(), f()),
            d: glam::Vec3::new(f(), f(), f()),
            tmin: f(),
            tmax: f(),
        })
        .collect()
}

#[test]
fn ray_row_reads_each_field() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the ray row test is skipped") else {
        return;
    };
    let mut r = Pcg32::new(30, 1);
    let rays = edge_rays(&mut r, 64);
    for round in 0..100 {
        let ids: [u32; 8] = std::array::from_fn(|_| r.next_u32() % rays.len() as u32);
        let (rows, fields) = avx.run(
            #[inline(always)]
            || {
                let rows: [F32x8; 8] = std::array::from_fn(|k| avx.ray_row(&rays[ids[k] as usize]));
                (
                    rows.map(|x| x.to_array()),
                    avx.ray_fields(&rays, &ids).map(|x| x.to_array()),
                )
            },
        );
        for k in 0..8 {
            let ray = &rays[ids[k] as usize];
            let want = fields_of(ray);
            for f in 0..8 {
                let ctx = format!("round {round} lane {k} field {f}");
                assert_eq!(rows[k][f].to_bits(), want[f].to_bits(), "{ctx}: row");
                // The transpose of the rows: field f's lanes.
                assert_eq!(
                    fields[f][k].to_bits(),
                    want[f].to_bits(),
                    "{ctx}: ray_fields"
                );
            }
        }
    }
}

/// `Avx512::ray_fields16_at` (tier A's 16-ray packets read in place, two rows joined per
/// register) against the fields read one by one and against `Avx512::ray_fields16` of the same
/// rays copied: every bit (edge floats, NaN payloads, random bits), ids repeated and in any
/// order.
#[test]
fn ray_fields16_at_reads_each_field() {
    let Some(avx) = groove::lane::Avx512::detect() else {
        eprintln!("no AVX-512: the 16-wide ray row test is skipped");
        return;
    };
    let mut r = Pcg32::new(31, 1);
    let rays = edge_rays(&mut r, 64);
    for round in 0..100 {
        let ids: [u32; 16] = std::array::from_fn(|_| r.next_u32() % rays.len() as u32);
        let copied: [Ray; 16] = ids.map(|i| rays[i as usize]);
        let (at, packed) = avx.run(
            #[inline(always)]
            || {
                (
                    avx.ray_fields16_at(|k| &rays[ids[k] as usize])
                        .map(|x| x.to_array()),
                    avx.ray_fields16(&copied).map(|x| x.to_array()),
                )
            },
        );
        for k in 0..16 {
            let ray = &rays[ids[k] as usize];
            let want = fields_of(ray);
            for f in 0..8 {
                let ctx = format!("round {round} lane {k} field {f}");
                assert_eq!(at[f][k].to_bits(), want[f].to_bits(), "{ctx}: in place");
                assert_eq!(packed[f][k].to_bits(), want[f].to_bits(), "{ctx}: copied");
            }
        }
    }
}

/// `Avx2::ids_below` (one bounds check for 8 ids) against the ids compared one by one: random
/// ids and lengths, and the edges: a length of 0, 1 and `u32::MAX`, past `u32::MAX` (every id
/// below it), ids equal to the length and one less, and ids with the top bit set (an unsigned
/// compare, not a signed one).
#[test]
fn ids_below_checks_every_id() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the ids_below test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(36, 1);
    let edges = [
        0u32,
        1,
        2,
        7,
        8,
        0x7fff_ffff,
        0x8000_0000,
        0x8000_0001,
        u32::MAX - 1,
        u32::MAX,
    ];
    let mut lens: Vec<usize> = edges.iter().map(|&e| e as usize).collect();
    lens.extend([u32::MAX as usize + 1, usize::MAX]);
    for round in 0..4000 {
        let len = if round % 2 == 0 {
            lens[round / 2 % lens.len()]
        } else {
            (r.next_u32() % 64) as usize
        };
        let near = |r: &mut Pcg32| {
            let l = len.min(u32::MAX as usize) as u32;
            match r.next_u32() % 4 {
                0 => l,
                1 => l.wrapping_sub(1),
                2 => edges[(r.next_u32() % edges.len() as u32) as usize],
                _ => r.next_u32() % 70,
            }
        };
        let ids: [u32; 8] = std::array::from_fn(|_| near(&mut r));
        let want = ids.iter().all(|&i| (i as usize) < len);
        let got = avx.run(
            #[inline(always)]
            || avx.ids_below(&ids, len),
        );
        assert_eq!(got, want, "round {round}: ids {ids:?} below {len}");
    }
}

/// `Avx2::ray_rows_through` (tier A's full packets from and to the path columns): the traced
/// fields are exactly `Avx2::ray_fields` of the same ids (every bit), the `trace` output's
/// rows land at `hit[ids[k]]` in lane order (a repeated id keeps its last lane's row), every
/// other entry stays as it was; an id past either column panics before anything is stored.
#[test]
fn ray_rows_through_reads_and_stores_each_row() {
    use groove::accel::HitRow;
    let Some(avx) =
        crate::harness::avx2_or_skip("no AVX2/FMA: the ray_rows_through test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(36, 2);
    let rays = edge_rays(&mut r, 40);
    let kept = |j: usize| HitRow([j as u32 ^ 0xdead_beef; 8]);
    for round in 0..200 {
        // Ids over the first 24 entries (repeats likely in some rounds), or all distinct.
        let ids: [u32; 8] = if round % 3 == 0 {
            std::array::from_fn(|k| (round as u32 + 5 * k as u32) % 40)
        } else {
            std::array::from_fn(|_| r.next_u32() % 24)
        };
        let mut hit: Vec<HitRow> = (0..40).map(kept).collect();
        let mut seen = None;
        avx.run(
            #[inline(always)]
            || {
                avx.ray_rows_through(
                    &rays,
                    &ids,
                    &mut hit,
                    #[inline(always)]
                    |fields| {
                        seen = Some(fields.map(|x| x.to_array()));
                        // The fields reversed, so that a row's words are its ray's in reverse.
                        std::array::from_fn(|j| fields[7 - j])
                    },
                );
            },
        );
        let want_fields = avx.run(
            #[inline(always)]
            || avx.ray_fields(&rays, &ids).map(|x| x.to_array()),
        );
        let seen = seen.expect("trace runs once");
        for (j, row) in hit.iter().enumerate() {
            let Some(k) = ids.iter().rposition(|&i| i as usize == j) else {
                assert_eq!(*row, kept(j), "round {round}: entry {j} named by no id");
                continue;
            };
            let want = fields_of(&rays[j]);
            for w in 0..8 {
                assert_eq!(
                    row.0[w],
                    want[7 - w].to_bits(),
                    "round {round}: entry {j} (lane {k}) word {w}"
                );
            }
        }
        for k in 0..8 {
            for w in 0..8 {
                assert_eq!(
                    seen[w][k].to_bits(),
                    want_fields[w][k].to_bits(),
                    "round {round}: traced lane {k} field {w}"
                );
            }
        }
    }
    // Out of range: an id equal to either column's length panics, nothing stored.
    for (nr, nh) in [(8, 9), (9, 8)] {
        let ids = [0, 1, 2, 3, 4, 5, 6, 8];
        let mut hit: Vec<HitRow> = (0..nh).map(kept).collect();
        let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            avx.run(
                #[inline(always)]
                || avx.ray_rows_through(&rays[..nr], &ids, &mut hit, |f| f),
            )
        }))
        .is_err();
        assert!(panicked, "{nr} rays, {nh} rows: id 8 accepted");
        assert!(
            hit.iter().enumerate().all(|(j, row)| *row == kept(j)),
            "{nr} rays, {nh} rows: a row stored before the panic"
        );
    }
}

/// A ray's eight fields in row order: o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax.
fn fields_of(ray: &Ray) -> [f32; 8] {
    [
        ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, ray.tmin, ray.tmax,
    ]
}
