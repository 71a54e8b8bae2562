//! `Avx2::ray_row` (one ray as a row of 8 floats: tier A's packets read the stream renderer's
//! rays in place) against the fields read one by one: every bit moved (edge floats: ±0, ±∞,
//! NaN payloads, subnormals, random bits), and 8 rows transposed equal `Avx2::ray_fields` of
//! the same rays.

use crate::harness::edge_or_bits;
use groove::geometry::Ray;
use groove::lane::F32x8;
use groove::math::Pcg32;

#[test]
fn ray_row_reads_each_field() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the ray row test is skipped") else {
        return;
    };
    let mut r = Pcg32::new(30, 1);
    let rays: Vec<Ray> = (0..64)
        .map(|_| Ray {
            o: glam::Vec3::new(
                edge_or_bits(&mut r),
                edge_or_bits(&mut r),
                edge_or_bits(&mut r),
            ),
            d: glam::Vec3::new(
                edge_or_bits(&mut r),
                edge_or_bits(&mut r),
                edge_or_bits(&mut r),
            ),
            tmin: edge_or_bits(&mut r),
            tmax: edge_or_bits(&mut r),
        })
        .collect();
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
    let mut f = || edge_or_bits(&mut r);
    let rays: Vec<Ray> = (0..64)
        .map(|_| Ray {
            o: glam::Vec3::new(f(), f(), f()),
            d: glam::Vec3::new(f(), f(), f()),
            tmin: f(),
            tmax: f(),
        })
        .collect();
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

/// A ray's eight fields in row order: o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax.
fn fields_of(ray: &Ray) -> [f32; 8] {
    [
        ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, ray.tmin, ray.tmax,
    ]
}
