//! What every latency bench shares: a clock origin and a probe that handlers hit.

use parking_lot::Mutex;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use tokio::sync::Notify;

/// Nanoseconds since `base` (wall clock, not tokio's: these benches never pause it).
pub(crate) fn ns_since(base: Instant) -> u64 {
    u64::try_from(base.elapsed().as_nanos()).unwrap_or(u64::MAX)
}

/// Where receiving handlers report: each hit records its latency (now minus the send time the
/// message carries) and counts; the sender waits for a count.
pub(crate) struct Probe {
    base: Instant,
    lat: Mutex<Vec<u64>>,
    count: AtomicU64,
    target: AtomicU64,
    done: Notify,
}

impl Probe {
    pub(crate) fn new(base: Instant) -> Arc<Probe> {
        Arc::new(Probe {
            base,
            lat: Mutex::new(Vec::new()),
            count: AtomicU64::new(0),
            target: AtomicU64::new(u64::MAX),
            done: Notify::new(),
        })
    }

    /// A handler received a message sent at `sent_ns` (since the base).
    pub(crate) fn hit(&self, sent_ns: u64) {
        let now = ns_since(self.base);
        self.lat.lock().push(now.saturating_sub(sent_ns));
        let n = self.count.fetch_add(1, Ordering::AcqRel) + 1;
        if n == self.target.load(Ordering::Acquire) {
            self.done.notify_one();
        }
    }

    /// Messages received so far.
    pub(crate) fn count(&self) -> u64 {
        self.count.load(Ordering::Acquire)
    }

    /// Announces the count the next [`wait`](Self::wait) waits for; call before sending.
    pub(crate) fn expect(&self, target: u64) {
        self.target.store(target, Ordering::Release);
    }

    /// Waits until `target` messages have been received in all. (No timer here: arming one
    /// per message would delay the receiver on a current-thread runtime; each bench as a whole
    /// runs under one time limit instead.)
    pub(crate) async fn wait(&self, target: u64) {
        self.expect(target);
        // A stale permit only makes the loop look once more.
        while self.count() < target {
            self.done.notified().await;
        }
    }

    /// The latencies recorded so far, leaving none.
    pub(crate) fn take(&self) -> Vec<u64> {
        std::mem::take(&mut *self.lat.lock())
    }
}
