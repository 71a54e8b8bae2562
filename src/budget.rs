//! One memory budget for a render: what loading the scene (images, meshes, the expanded XML)
//! and rendering it (film, blocks, worker threads) will allocate is estimated from sizes that
//! are known *before* allocating (header dimensions, element counts, file sizes) and checked
//! against one limit, so a hostile or careless input is refused with an estimate instead of
//! aborting the process or swapping the machine to death.
//!
//! The limit defaults to half of the machine's physical memory ([`Budget::default_limit`]):
//! the estimates cover the large arrays only, and the other half is left to the rest of the
//! process, the OS and other programs. `groove render --max-memory GB` raises or lowers it.
//! One [`Budget`] is shared (cheap clones) by the load and the render of one scene.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Used when the machine's memory cannot be read (not Linux): 16 GB.
const FALLBACK_LIMIT: u64 = 16 << 30;

/// A memory limit and what has been reserved against it so far.
#[derive(Clone, Debug)]
pub struct Budget {
    limit: u64,
    used: Arc<AtomicU64>,
}

impl Default for Budget {
    /// A budget with [`Budget::default_limit`].
    fn default() -> Self {
        Budget::new(Budget::default_limit())
    }
}

impl Budget {
    /// A budget of `limit` bytes, nothing reserved.
    pub fn new(limit: u64) -> Budget {
        Budget {
            limit,
            used: Arc::new(AtomicU64::new(0)),
        }
    }

    /// A budget of `gb` gigabytes (2^30 bytes); the `--max-memory` value. `None` when `gb` is
    /// not a positive finite number.
    pub fn from_gb(gb: f64) -> Option<Budget> {
        (gb.is_finite() && gb > 0.0).then(|| Budget::new((gb * (1u64 << 30) as f64) as u64))
    }

    /// Half of the physical memory (`MemTotal` of `/proc/meminfo`), or 16 GB when unknown.
    pub fn default_limit() -> u64 {
        std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|s| {
                let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
                let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
                Some(kb.saturating_mul(1024) / 2)
            })
            .filter(|&b| b > 0)
            .unwrap_or(FALLBACK_LIMIT)
    }

    /// The limit in bytes.
    pub fn limit(&self) -> u64 {
        self.limit
    }

    /// Bytes reserved so far.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Relaxed)
    }

    /// Checks that `bytes` more (a transient peak, e.g. a decoder's buffer) fit beside what is
    /// reserved; `what` describes the allocation in the error ("film 30000×30000").
    pub fn check(&self, bytes: u64, what: &str) -> Result<(), String> {
        let used = self.used();
        if used.saturating_add(bytes) <= self.limit {
            return Ok(());
        }
        let already = if used >= 1 << 20 {
            format!(" (with {} already in use)", gb(used))
        } else {
            String::new()
        };
        Err(format!(
            "{what} needs ~{}{already}, over the {} memory limit; raise it with --max-memory GB",
            gb(bytes),
            gb(self.limit)
        ))
    }

    /// [`Budget::check`], then keeps `bytes` reserved (memory the scene holds until the render
    /// ends: texels, meshes, the film).
    pub fn reserve(&self, bytes: u64, what: &str) -> Result<(), String> {
        self.check(bytes, what)?;
        self.used.fetch_add(bytes, Ordering::Relaxed);
        Ok(())
    }
}

/// `bytes` as "1.5 GB" (2^30), or "12.0 MB" below a gigabyte.
pub fn gb(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GB", b / (1u64 << 30) as f64)
    } else {
        format!("{:.1} MB", b / (1u64 << 20) as f64)
    }
}

/// `a × b × c` saturating (sizes from headers can be anything).
pub fn bytes_of(counts: &[u64]) -> u64 {
    counts.iter().fold(1u64, |a, &c| a.saturating_mul(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_reserve_and_message() {
        let b = Budget::new(1 << 30);
        assert!(b.check(1 << 30, "x").is_ok());
        b.reserve(600 << 20, "a").unwrap();
        let e = b.check(600 << 20, "film 10×10").unwrap_err();
        assert!(e.starts_with("film 10×10 needs ~600.0 MB (with 600.0 MB already in use), over the 1.0 GB memory limit; raise it with --max-memory"), "{e}");
        assert_eq!(b.used(), 600 << 20);
        assert!(Budget::from_gb(0.0).is_none() && Budget::from_gb(f64::NAN).is_none());
        assert_eq!(Budget::from_gb(2.0).unwrap().limit(), 2 << 30);
        assert!(Budget::default_limit() > 0);
        assert_eq!(bytes_of(&[u64::MAX, 3]), u64::MAX);
    }
}
