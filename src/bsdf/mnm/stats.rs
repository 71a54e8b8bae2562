//! Walk-length counters for `groove bench`: every sampled random walk records its number of
//! vertices (facet scatterings, mirror-wall reflections included) in a per-thread counter, which
//! the render loop drains per image block. A thread-local cell costs a few instructions per walk
//! and needs no synchronisation; a block is rendered by one thread from start to end.

use std::cell::Cell;

/// Sampled walks and their vertices since the last [`take`] on this thread.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    pub walks: u64,
    pub vertices: u64,
}

thread_local! {
    static COUNTS: Cell<WalkCounts> = const { Cell::new(WalkCounts { walks: 0, vertices: 0 }) };
}

/// Record one sampled walk of `vertices` vertices.
#[inline]
pub fn record(vertices: u32) {
    COUNTS.with(|c| {
        let mut v = c.get();
        v.walks += 1;
        v.vertices += vertices as u64;
        c.set(v);
    });
}

/// This thread's counts since the last call, and reset them.
pub fn take() -> WalkCounts {
    COUNTS.with(|c| c.replace(WalkCounts::default()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_accumulate_and_reset() {
        let _ = take();
        record(3);
        record(1);
        assert_eq!(
            take(),
            WalkCounts {
                walks: 2,
                vertices: 4
            }
        );
        assert_eq!(take(), WalkCounts::default());
    }
}
