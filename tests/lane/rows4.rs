//! `Avx2::fields4` and `Avx2::rows4` (8 rows of 4 floats to 4 fields in lanes and back, the
//! stream renderer's emission stage reading and writing its paths' radiance and depth) are moves
//! only: lane `k` of field `j` is `rows[k][j]` bit for bit, and `rows4` inverts `fields4`, over
//! random bit patterns, ±0, subnormals, ±`f32::MAX`, ±∞ and NaNs with payloads (signalling ones
//! included) in every position. Skipped, with a note, without AVX2.

use groove::math::Pcg32;

const EDGES: [u32; 12] = [
    0x0000_0000,
    0x8000_0000,
    0x0000_0001,
    0x807f_ffff,
    0x7f7f_ffff,
    0xff7f_ffff,
    0x7f80_0000,
    0xff80_0000,
    0x7fc0_0000,
    0x7fa0_1234,
    0xffc0_0001,
    0xff80_0001,
];

#[test]
fn fields4_and_rows4_move_every_bit() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) =
            crate::harness::avx2_or_skip("fields4/rows4: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(41, 7);
        for round in 0..20_000 {
            let mut v = || {
                let u = r.next_u32();
                f32::from_bits(if u & 3 == 0 {
                    EDGES[(u >> 8) as usize % EDGES.len()]
                } else {
                    u
                })
            };
            let rows: [[f32; 4]; 8] = std::array::from_fn(|_| std::array::from_fn(|_| v()));
            // Fields straight from random lanes, for `rows4` alone.
            let cols: [[f32; 8]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| v()));
            let (fields, back, out) = avx.run(
                #[inline(always)]
                || {
                    let f = avx.fields4(&rows);
                    let fields = f.map(|x| x.to_array());
                    let back = avx.rows4(f);
                    let out = avx.rows4(cols.map(|c| avx.load(&c)));
                    (fields, back, out)
                },
            );
            for k in 0..8 {
                for j in 0..4 {
                    let want = rows[k][j].to_bits();
                    assert_eq!(
                        fields[j][k].to_bits(),
                        want,
                        "fields4 {round}: row {k} field {j}"
                    );
                    assert_eq!(back[k][j].to_bits(), want, "rows4∘fields4 {round}: {k} {j}");
                    let want = cols[j][k].to_bits();
                    assert_eq!(
                        out[k][j].to_bits(),
                        want,
                        "rows4 {round}: row {k} field {j}"
                    );
                }
            }
        }
    }
}
