//! The random numbers of one path vertex for 8 paths, drawn 8-wide: the one helper of the
//! three kernels ([`super::diffuse`], [`super::vertex`], [`super::plastic`]).
//!
//! A vertex draws, in the scalar renderer's order (`PathState::scatter`): the light selection
//! `u_sel` and the light point `u` (`nee::prepare_light`, when the vertex takes a light sample),
//! then the BSDF's lobe choice `u1` and direction `u2` (`Bsdf::sample`, each when the BSDF
//! draws it). For a path whose stream is plain PCG32 from here on (`Sampler::plain_parts`:
//! always under `independent`, under `stratified` once its stratified 2-D draws are spent)
//! `next_1d` is one PCG32 float and `next_2d` two (x, then y), so the 8 paths' (state,
//! increment) pairs are gathered into one `lane::pcg::Pcg`, the vertex's numbers drawn 8-wide
//! in that order, and the states written back into the batch's columns (`Samplers`): each stream
//! ends where the scalar draws would have left it. A path whose stream is not plain (a `stratified` path at its
//! first vertex) draws its numbers lane by lane from its `Sampler`, in the same order, after
//! the 8-wide draw (its lane of the 8-wide draw is dropped). A path that is not `drawing` (it
//! failed the side test) draws nothing.

/// Which numbers a vertex draws, in this order: `u_sel` and `u` (a light sample), `u1`, `u2`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Draws {
    pub light: bool,
    pub u1: bool,
    pub u2: bool,
}

/// `W` paths' numbers of one vertex, per lane (0 where not drawn).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Numbers<const W: usize = 8> {
    pub u_sel: [f32; W],
    /// The light point's `u` (x, y).
    pub u: [[f32; W]; 2],
    pub u1: [f32; W],
    /// The BSDF's `u2` (x, y).
    pub u2: [[f32; W]; 2],
}

impl<const W: usize> Default for Numbers<W> {
    fn default() -> Self {
        Numbers {
            u_sel: [0.0; W],
            u: [[0.0; W]; 2],
            u1: [0.0; W],
            u2: [[0.0; W]; 2],
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::lane::pcg::Pcg;
    use crate::lane::{ToArray, Wide};
    use crate::sampler::{Sampler, Samplers};

    /// The numbers `d` of the paths `ids` (indices into `samplers`) where `drawing`, each from
    /// its own stream in the scalar order (see the module doc). The PCG32 states and
    /// increments are read from `samplers`' columns lane by lane (every lane: a padded chunk's
    /// ids are paths of the batch too) and the drawing lanes' states written back in place
    /// (where a path repeats in `ids`, its first lane must be the one that draws, if any: a
    /// padded chunk's copies of its last path draw nothing);
    /// the per-path plain test only when some stream of the batch has strata
    /// (`Samplers::all_plain`: never under `independent`). Call inside [`crate::lane::Avx2::run`].
    #[inline(always)]
    pub(crate) fn draw<T: Wide<W>, const W: usize>(
        avx: T,
        samplers: &mut Samplers,
        ids: &[u32; W],
        drawing: &[bool; W],
        d: Draws,
    ) -> Numbers<W> {
        // Which lanes draw from the 8-wide PCG32: the drawing ones whose stream is plain.
        let all_plain = samplers.all_plain();
        let mut plain = *drawing;
        if !all_plain {
            for (k, &i) in ids.iter().enumerate() {
                plain[k] &= samplers.plain(i as usize);
            }
        }
        let mut n = Numbers::default();
        {
            let (states, incs) = samplers.pcg_mut();
            // The lanes' states and increments gathered from the columns by path index.
            let mut idx = [0i32; W];
            for (d, &i) in idx.iter_mut().zip(ids) {
                *d = i as i32;
            }
            let idx = avx.load_i32(&idx);
            let mut rng = Pcg::<T::F>::gather(states, incs, idx);
            let old = rng.parts().0;
            // Plain statements, not a closure: a closure would be compiled outside
            // `Avx2::run`'s target features (see `kernels`).
            if d.light {
                n.u_sel = rng.next_f32().to_array();
                n.u[0] = rng.next_f32().to_array();
                n.u[1] = rng.next_f32().to_array();
            }
            if d.u1 {
                n.u1 = rng.next_f32().to_array();
            }
            if d.u2 {
                n.u2[0] = rng.next_f32().to_array();
                n.u2[1] = rng.next_f32().to_array();
            }
            // Every lane's state stored, the gathered one where the lane does not draw from
            // the 8-wide PCG32, from the last lane to the first (`Wide::store_u64_at`: no
            // branch or bounds test per lane). A path repeated in `ids` (a padded chunk's
            // extra lanes repeat its last path and draw nothing) keeps its first lane's state.
            avx.store_u64_at(states, idx, avx.mask(&plain), rng.parts().0, old);
        }
        if !all_plain {
            for (k, &i) in ids.iter().enumerate() {
                if drawing[k] && !plain[k] {
                    draw_one(&mut samplers.at(i as usize), d, &mut n, k);
                }
            }
        }
        n
    }

    /// Lane `k`'s numbers `d`, drawn from its `Sampler` (a stream that is not plain).
    #[inline(never)]
    #[cold]
    fn draw_one<const W: usize>(s: &mut Sampler, d: Draws, n: &mut Numbers<W>, k: usize) {
        if d.light {
            n.u_sel[k] = s.next_1d();
            let u = s.next_2d();
            (n.u[0][k], n.u[1][k]) = (u.x, u.y);
        }
        if d.u1 {
            n.u1[k] = s.next_1d();
        }
        if d.u2 {
            let u = s.next_2d();
            (n.u2[0][k], n.u2[1][k]) = (u.x, u.y);
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::sampler::{Sampler, SamplerDesc, SamplerKind, Samplers};

    /// The 8-wide draw gives each drawing path the numbers its `Sampler` gives lane by lane in
    /// the scalar order, leaves its stream where the scalar draws leave it, and leaves the
    /// other paths' streams untouched: under `independent` and `stratified` (plain and
    /// not-plain lanes mixed in one chunk), for every combination of `Draws`.
    #[test]
    fn the_8_wide_draw_equals_the_samplers() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        let mut checked = 0;
        for kind in [
            SamplerKind::Independent,
            SamplerKind::Stratified { jitter: true },
        ] {
            let desc = SamplerDesc {
                kind,
                sample_count: 16,
                seed: 9,
            };
            for bits in 0..8u32 {
                let d = Draws {
                    light: bits & 1 != 0,
                    u1: bits & 2 != 0,
                    u2: bits & 4 != 0,
                };
                // 12 paths, 8 of them in the chunk (out of order), 6 drawing; the odd ones spent
                // their stratified dimensions already, so plain and not-plain lanes are mixed.
                let rows: Vec<Sampler> = (0..12)
                    .map(|s| {
                        let mut sm = Sampler::for_sample(&desc, 40 + s, s as u32);
                        for _ in 0..2 * (s % 2) {
                            sm.next_2d();
                        }
                        sm
                    })
                    .collect();
                // A full chunk, and a padded one (its last lanes repeat path 9, not drawing).
                let chunks = [
                    (
                        [3, 0, 11, 5, 6, 9, 1, 7],
                        [true, true, false, true, true, true, false, true],
                    ),
                    (
                        [3, 0, 11, 5, 6, 9, 9, 9],
                        [true, true, false, true, true, true, false, false],
                    ),
                ];
                for (ids, drawing) in chunks {
                    let mut reference = rows.clone();
                    let mut samplers = Samplers::default();
                    for r in &rows {
                        samplers.push(r);
                    }
                    let n = avx.run(|| x8::draw(avx, &mut samplers, &ids, &drawing, d));
                    for (k, &i) in ids.iter().enumerate() {
                        let s = &mut reference[i as usize];
                        if !drawing[k] {
                            continue;
                        }
                        if d.light {
                            assert_eq!(n.u_sel[k].to_bits(), s.next_1d().to_bits());
                            let u = s.next_2d();
                            assert_eq!([n.u[0][k], n.u[1][k]], [u.x, u.y], "{kind:?} {d:?}");
                        }
                        if d.u1 {
                            assert_eq!(n.u1[k], s.next_1d(), "{kind:?} {d:?}");
                        }
                        if d.u2 {
                            let u = s.next_2d();
                            assert_eq!([n.u2[0][k], n.u2[1][k]], [u.x, u.y], "{kind:?} {d:?}");
                        }
                        checked += 1;
                    }
                    // Every stream continues where the scalar draws left it (untouched if not drawn).
                    for (i, b) in reference.iter_mut().enumerate() {
                        let mut a = samplers.at(i);
                        assert_eq!(a.next_2d(), b.next_2d(), "{kind:?} {d:?}");
                        assert_eq!(a.next_1d(), b.next_1d(), "{kind:?} {d:?}");
                    }
                }
            }
        }
        assert_eq!(checked, 2 * 8 * (6 + 5));
    }
}
