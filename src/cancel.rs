//! Stopping a render early: a shared request that the render loop checks every 4096 samples of
//! a pixel (at least once per pixel). The CLI raises it from SIGINT and SIGTERM ([`Cancel::on_signals`]); the
//! render then returns [`Error::Cancelled`](crate::Error::Cancelled), writes nothing, and the
//! process exits with 128 + the signal's number (130 for SIGINT, 143 for SIGTERM).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// A cancellation request shared by clones: 0 = keep going, otherwise the reason (a signal
/// number, or any non-zero code a caller chooses).
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicUsize>);

impl Cancel {
    pub fn new() -> Self {
        Self::default()
    }

    /// A request raised by SIGINT or SIGTERM (the signal's number). The handlers only store
    /// into the shared flag (async-signal-safe); everything else happens in the render loop.
    pub fn on_signals() -> std::io::Result<Self> {
        let c = Cancel::new();
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            signal_hook::flag::register_usize(sig, c.0.clone(), sig as usize)?;
        }
        Ok(c)
    }

    /// Ask the render to stop (`code` ≠ 0; 0 is taken as 1).
    pub fn request(&self, code: usize) {
        self.0.store(code.max(1), Ordering::SeqCst);
    }

    /// The request's code, if one was made.
    #[inline]
    pub fn requested(&self) -> Option<usize> {
        match self.0.load(Ordering::Relaxed) {
            0 => None,
            c => Some(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Cancel;

    #[test]
    fn a_request_is_seen_by_every_clone() {
        let a = Cancel::new();
        let b = a.clone();
        assert_eq!(b.requested(), None);
        a.request(15);
        assert_eq!(b.requested(), Some(15));
        let c = Cancel::new();
        c.request(0);
        assert_eq!(c.requested(), Some(1));
    }
}
