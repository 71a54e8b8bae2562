//! PCG32 per lane (O'Neill 2014, XSH-RR output of a 64-bit LCG): each lane is its own stream,
//! bit-identical to `math::rng::Pcg32` with the same seed and stream, as `sampler::Sampler`
//! keys it by (seed, pixel, sample).

use super::{Lane, LaneI32, LaneU64};

const MULT: u64 = 6_364_136_223_846_793_005;

/// One PCG32 generator per lane.
#[derive(Clone, Copy, Debug)]
pub struct Pcg<L: Lane> {
    state: L::U64,
    inc: L::U64,
}

impl<L: Lane> Pcg<L> {
    /// Per lane, the generator `Pcg32::new(seed, stream)`.
    #[inline(always)]
    pub fn new(seed: L::U64, stream: L::U64) -> Self {
        let inc = stream.shl::<1>().or(stream.splat(1));
        let mut r = Pcg {
            state: stream.splat(0),
            inc,
        };
        r.next_u32();
        r.state = LaneU64::add(r.state, seed);
        r.next_u32();
        r
    }

    /// Per lane, the generator whose raw LCG state and increment are `state` and `inc` (as
    /// [`Self::parts`] returns them): gathers scalar generators into lanes and back.
    #[inline(always)]
    pub fn from_parts(state: L::U64, inc: L::U64) -> Self {
        Pcg { state, inc }
    }

    /// Per lane `k`, the generator of raw state `states[idx[k]]` and increment `incs[idx[k]]`
    /// (the batch's columns read by path index; each index clamped as in
    /// [`PcgOps::gather_u64`]).
    ///
    /// # Panics
    /// If a column is empty or holds more than `i32::MAX` entries.
    #[inline(always)]
    pub fn gather(states: &[u64], incs: &[u64], idx: L::I32) -> Self {
        Pcg {
            state: L::U64::gather_u64(states, idx),
            inc: L::U64::gather_u64(incs, idx),
        }
    }

    /// The raw LCG state and increment of each lane.
    #[inline(always)]
    pub fn parts(&self) -> (L::U64, L::U64) {
        (self.state, self.inc)
    }

    /// The next 32 random bits of each lane (as `i32` lanes holding the `u32` bits).
    #[inline(always)]
    pub fn next_u32(&mut self) -> L::I32 {
        let old = self.state;
        self.state = old.mul(old.splat(MULT)).add(self.inc);
        old.xsh_rr()
    }

    /// A float uniform in [0, 1) per lane: 24 random bits, exactly representable, never 1.
    #[inline(always)]
    pub fn next_f32(&mut self) -> L {
        let f = self.next_u32().shr::<8>().to_f32();
        f * f.splat(1.0 / 16_777_216.0)
    }

    /// Per lane `k`, the float that [`Self::next_f32`] of the generator of raw state
    /// `states[idx[k]]` returns next, without advancing any state (a look ahead: the XSH-RR
    /// output depends on the state only, not on the increment). Each index clamped as in
    /// [`PcgOps::gather_u64`].
    ///
    /// # Panics
    /// If `states` is empty or holds more than `i32::MAX` entries.
    #[inline(always)]
    pub fn peek_f32(states: &[u64], idx: L::I32) -> L {
        let f = L::U64::gather_u64(states, idx).xsh_rr().shr::<8>().to_f32();
        f * f.splat(1.0 / 16_777_216.0)
    }
}

/// The operations of PCG32 that each lane width writes with its own instructions (at the end of
/// `scalar.rs`, `avx2.rs` and `avx512.rs`): every lane type's `U64` has them (`Lane::U64`).
pub trait PcgOps<I>: Sized {
    /// `table[idx]` per lane (`vpgatherdq` at widths 8 and 16: the batch's state and increment
    /// columns read by path index), each index clamped as in `Lane::gather3`.
    ///
    /// # Panics
    /// If `table` is empty or holds more than `i32::MAX` entries.
    fn gather_u64(table: &[u64], idx: I) -> Self;
    /// PCG32's XSH-RR output of the LCG state `self` per lane (O'Neill 2014, section 6.3.1):
    /// `(((s >> 18) ^ s) >> 27) as u32` rotated right by `s >> 59`, as `i32` bits.
    fn xsh_rr(self) -> I;
}
