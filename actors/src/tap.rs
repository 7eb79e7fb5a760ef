//! Observing a system: every pattern message and every control event, as it happens.
//!
//! A [`Tap`] installed on a [`Registry`](crate::Registry) sees each message every pattern
//! carries, once, where it enters the pattern: a Send when a client hands it over (also when
//! the server then turns out to be unavailable), a Query's request when it is made and its
//! answer when it is given, a push when it is published (not once per subscriber), an event when
//! it fires, and every change of a component's main state or wiring. Topics are
//! `component/service` (`component/service/answer` for query answers), so a recording reads
//! like the system's own map. `orsa run --record` writes what a tap sees as MCAP.
//!
//! With no tap installed, the cost is one atomic load per message; with one, the message is
//! serialised to JSON once, straight from its type (no intermediate `serde_json::Value`), and
//! the tap gets the bytes.

use crate::clock::Timestamp;
use parking_lot::RwLock;
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Something that wants to see every message.
pub trait Tap: Send + Sync + 'static {
    /// One message on `topic`, of communication object `type_id`, stamped `stamp`, as JSON
    /// (`serde_json::from_slice` reads it back; a recording stores it as is).
    fn record(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]);

    /// As [`record`](Self::record), for a message that came from another process through the
    /// transport (a Send, a query's request) or answers one. A recording keeps them apart,
    /// so that a replay of one process knows what it must not expect its own components to
    /// make. By default, the same as `record`.
    fn record_remote(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        self.record(topic, type_id, stamp, json);
    }

    /// Whether the tap wants the messages on `topic` now: those it does not want are not even
    /// serialised (a live viewer nobody watches wants few). By default, every one.
    fn wants(&self, topic: &str) -> bool {
        let _ = topic;
        true
    }
}

/// The tap shared by a registry and all its endpoints.
#[derive(Clone, Default)]
pub(crate) struct TapSlot(Arc<TapInner>);

/// The tap, and whether there is one: a message with no tap installed costs one atomic load.
#[derive(Default)]
pub(crate) struct TapInner {
    installed: AtomicBool,
    tap: RwLock<Option<Arc<dyn Tap>>>,
}

impl std::fmt::Debug for TapSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.tap.read().is_some() { "TapSlot(installed)" } else { "TapSlot(none)" })
    }
}

impl TapSlot {
    pub(crate) fn set(&self, tap: Option<Arc<dyn Tap>>) {
        let mut slot = self.0.tap.write();
        self.0.installed.store(tap.is_some(), Ordering::Release);
        *slot = tap;
    }

    /// Hands `message` to the tap, if one is installed.
    pub(crate) fn record<T: Serialize + ?Sized>(
        &self,
        topic: &str,
        type_id: &str,
        stamp: Timestamp,
        message: &T,
    ) {
        self.record_from(topic, type_id, stamp, message, false);
    }

    /// Whether a tap is installed (to skip building what only a tap would see).
    pub(crate) fn installed(&self) -> bool {
        self.0.installed.load(Ordering::Acquire)
    }

    /// Hands `message`, from another process if `remote`, to the tap, if one is installed.
    pub(crate) fn record_from<T: Serialize + ?Sized>(
        &self,
        topic: &str,
        type_id: &str,
        stamp: Timestamp,
        message: &T,
        remote: bool,
    ) {
        if !self.0.installed.load(Ordering::Acquire) {
            return;
        }
        let tap = self.0.tap.read().clone();
        let Some(tap) = tap else { return };
        if !tap.wants(topic) {
            return;
        }
        let hand = |json: &mut Vec<u8>| {
            json.clear();
            match serde_json::to_writer(&mut *json, message) {
                Ok(()) if remote => tap.record_remote(topic, type_id, stamp, json),
                Ok(()) => tap.record(topic, type_id, stamp, json),
                Err(e) => tracing::warn!("tap: cannot encode a message on {topic}: {e}"),
            }
        };
        // One buffer per thread, reused: no allocation per message. (A tap that records from
        // inside `record` gets a buffer of its own.)
        BUFFER.with(|b| match b.try_borrow_mut() {
            Ok(mut json) => hand(&mut json),
            Err(_) => hand(&mut Vec::with_capacity(256)),
        });
    }
}

thread_local! {
    /// The JSON of the message being handed to the tap on this thread.
    static BUFFER: std::cell::RefCell<Vec<u8>> = std::cell::RefCell::new(Vec::with_capacity(4096));
}
