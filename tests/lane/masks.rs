//! Masks from and to bits through `lane::Wide` (`mask`, `mask_bits`, `bits`), at width 8 and
//! 16 (the 16-wide half skipped, with a note, without AVX-512), against the booleans written
//! out: every pattern of the lanes' bits, bits above the width set (ignored), and masks used
//! by a select and negated, so that a lane set by bits or by booleans selects as a lane set by
//! a compare.

use groove::lane::wide::{ToArray, Wide};
use groove::lane::{Lane, LaneMask};

fn check<T: Wide<W>, const W: usize>(avx: T) {
    let all = if W >= 32 { u32::MAX } else { (1u32 << W) - 1 };
    // Every pattern at width 8; at width 16 every pattern too (65 536, cheap).
    for m in 0..=all {
        let want: [bool; W] = std::array::from_fn(|k| m >> k & 1 == 1);
        let junk = m.rotate_left(7) & !all | if W < 32 { 0xdead_0000 & !all } else { 0 };
        let (from_bits, from_bools, round, any, sel, sel_b, not_b) = avx.run(
            #[inline(always)]
            || {
                let a = avx.mask_bits(m | junk);
                let b = avx.mask(&want);
                let x: [f32; W] = std::array::from_fn(|k| k as f32);
                let s = T::F::select(a, avx.load(&x), avx.splat(-1.0)).to_array();
                let sb = T::F::select(b, avx.load(&x), avx.splat(-1.0)).to_array();
                (
                    a.to_array(),
                    T::bits(b),
                    T::bits(a),
                    a.any(),
                    s,
                    sb,
                    T::bits(!b),
                )
            },
        );
        assert_eq!(from_bits, want, "mask_bits {m:#x} width {W}");
        assert_eq!(from_bools, m, "mask {m:#x} width {W}");
        assert_eq!(round, m, "bits of mask_bits {m:#x} width {W}");
        assert_eq!(any, m != 0, "any {m:#x} width {W}");
        assert_eq!(not_b, !m & all, "not of mask {m:#x} width {W}");
        for k in 0..W {
            let w = if want[k] { k as f32 } else { -1.0 };
            assert_eq!(
                sel[k].to_bits(),
                w.to_bits(),
                "select {m:#x} lane {k} width {W}"
            );
            assert_eq!(
                sel_b[k].to_bits(),
                w.to_bits(),
                "select by the booleans' mask {m:#x} lane {k} width {W}"
            );
        }
    }
}

crate::at_8_and_16!(
    masks_from_and_to_bits_8,
    masks_from_and_to_bits_16,
    "masks",
    check
);
