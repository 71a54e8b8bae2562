//! Width 8: software prefetches of the table rows that lanes name, so that a stage can ask for
//! the lines of a later chunk's gathers while it computes an earlier chunk (the stream's mesh
//! gather, `stream::kernels::surface`). A prefetch is a hint: it changes no value the program
//! reads and never faults (Intel SDM vol. 2, `PREFETCHh`; AMD APM vol. 3, `PREFETCHlevel`).
//!
//! A child of `avx2` (it reads the private field of [`I32x8`]); the same soundness argument:
//! the [`Avx2`] token and its values exist only when the CPU has AVX2.

use super::{Avx2, I32x8};
use core::arch::x86_64::*;

/// Which caches a prefetch fills: `prefetcht0` (every level), `prefetcht1` (the second level
/// and out), `prefetchnta` (close to the core, kept out of the outer levels where the CPU can).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hint {
    T0,
    T1,
    Nta,
}

impl Avx2 {
    /// Asks for the cache line holding `p` (a hint: no value changes, and an address outside
    /// the program's memory does not fault).
    #[inline(always)]
    fn prefetch_ptr(self, p: *const i8, hint: Hint) {
        // SAFETY: a prefetch reads nothing into the program and never faults, whatever `p`.
        unsafe {
            match hint {
                Hint::T0 => _mm_prefetch::<_MM_HINT_T0>(p),
                Hint::T1 => _mm_prefetch::<_MM_HINT_T1>(p),
                Hint::Nta => _mm_prefetch::<_MM_HINT_NTA>(p),
            }
        }
    }

    /// Asks for the cache line holding the start of `r`.
    #[inline(always)]
    pub fn prefetch<T>(self, r: &T, hint: Hint) {
        self.prefetch_ptr((r as *const T).cast(), hint);
    }

    /// Per lane, asks for the line holding the start of row `min(idx as u32, len − 1)` of each
    /// of `tables` (`len` the shortest table's length): the row [`Avx2::gather3_u32`] and
    /// `gather3` read for that lane when the tables are as long. Nothing when a table is empty.
    #[inline(always)]
    pub fn prefetch_rows<T, const K: usize>(self, tables: [&[T]; K], idx: I32x8, hint: Hint) {
        let mut len = usize::MAX;
        for t in &tables {
            len = len.min(t.len());
        }
        if len == 0 {
            return;
        }
        let last = (len - 1).min(u32::MAX as usize) as u32;
        let mut rows = [0u32; 8];
        // SAFETY: the token proves AVX2; the store writes the 32 bytes of `rows`.
        unsafe {
            let i = _mm256_min_epu32(idx.0, _mm256_set1_epi32(last as i32));
            _mm256_storeu_si256(rows.as_mut_ptr().cast(), i);
        }
        for &j in &rows {
            for t in &tables {
                // `j ≤ len − 1`: the pointer stays inside each table.
                self.prefetch_ptr(t.as_ptr().wrapping_add(j as usize).cast(), hint);
            }
        }
    }
}
