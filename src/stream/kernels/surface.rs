//! The one surface load of the three kernels ([`super::diffuse`], [`super::vertex`],
//! [`super::plastic`]): 8 paths' surface points, true normals, shading frames and incident
//! directions, loaded 8-wide in place from the batch's surface rows
//! ([`crate::stream::batch::Surfaces`], written by the emission stage), one `vgatherdps` per
//! field over the 8 rows. Loads only: the values are the scalar interaction's bits.

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use crate::lane::frame::Frame;
    use crate::lane::vec::V3;
    use crate::lane::{Avx2, F32x8, I32x8, Lane, LaneI32};
    use crate::stream::batch::{cols, Surfaces};
    use crate::stream::kernels::diffuse::Surface;
    use crate::stream::BATCH;

    const N: usize = BATCH * cols::ROW;

    /// The vector whose x is field `c`, in the rows that start at `row` (index of a row's
    /// first float).
    #[inline(always)]
    fn v3(flat: &[f32; N], c: usize, row: I32x8) -> V3<F32x8> {
        // Plain statements, not a closure (a closure would be compiled outside `Avx2::run`'s
        // target features, see `kernels`).
        let (x, y, z) = (
            row.add(row.splat(c as i32)),
            row.add(row.splat(c as i32 + 1)),
            row.add(row.splat(c as i32 + 2)),
        );
        V3::new(
            F32x8::gather::<N>(flat, x),
            F32x8::gather::<N>(flat, y),
            F32x8::gather::<N>(flat, z),
        )
    }

    /// The surfaces of the paths `ids` (each with its interaction in `s`). Call inside
    /// [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn load(avx: Avx2, s: &Surfaces, ids: &[u32; 8]) -> Surface<F32x8> {
        let row = avx.load_i32(&ids.map(|i| (i as usize * cols::ROW) as i32));
        let flat = s.flat();
        Surface {
            p: v3(flat, cols::P, row),
            ng: v3(flat, cols::NG, row),
            frame: Frame {
                s: v3(flat, cols::S, row),
                t: v3(flat, cols::T, row),
                n: v3(flat, cols::N, row),
            },
            wi_world: v3(flat, cols::WI, row),
        }
    }
}
