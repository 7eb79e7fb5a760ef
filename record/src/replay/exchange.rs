//! The transport of a replayed process: what its components exchanged with services in other
//! processes, played back from the recording (see [`crate::exchange`], which recorded
//! it).
//!
//! Every reply, update and firing comes back at the time it came in the recorded run, to the
//! request, subscription or activation of the same number (the replayed components make them
//! in the same order); every Send, request, subscription and activation the replayed
//! components make is noted as the recording noted it, for the comparison. A request the
//! recording has no reply for gets none (it fails after its timeout, as it would have).

use super::file::ExchangeLog;
use crate::record::events::{ExchangeKind, Exchanged};
use orsa_actors::transport::{ByteSink, EventMode, Served, Subscription, Transport};
use orsa_actors::{Clock, PatternError, PatternResult, ServiceAddr, ServiceInfo, Timestamp};
use parking_lot::Mutex;
use std::collections::HashMap;
use std::num::NonZeroU32;
use std::sync::Arc;
use std::time::Duration;

/// Where the replayed process's own side of the exchange goes: (topic, stamp, JSON).
pub type Note = Arc<dyn Fn(&str, Timestamp, &[u8]) + Send + Sync>;

/// The replay's transport (see the module docs).
pub struct PlaybackTransport {
    log: Arc<ExchangeLog>,
    clock: Clock,
    note: Note,
    next: Mutex<HashMap<(ExchangeKind, ServiceAddr), u64>>,
}

impl PlaybackTransport {
    /// Plays `log` back on `clock`; what the replayed process makes goes to `note`.
    pub fn new(log: Arc<ExchangeLog>, clock: Clock, note: Note) -> Self {
        PlaybackTransport { log, clock, note, next: Mutex::default() }
    }

    fn number(&self, kind: ExchangeKind, addr: &ServiceAddr) -> u64 {
        let mut next = self.next.lock();
        let n = next.entry((kind, addr.clone())).or_insert(0);
        *n += 1;
        *n - 1
    }

    fn made(&self, kind: ExchangeKind, addr: &ServiceAddr, e: &Exchanged) {
        match serde_json::to_vec(e) {
            Ok(json) => (self.note)(&kind.topic(addr), self.clock.now(), &json),
            Err(error) => tracing::warn!("replay: cannot note a {} to {addr}: {error}", kind.name()),
        }
    }

    /// Plays `messages` (arrival ns, bytes) into `sink` at their times, until dropped.
    fn play(&self, messages: Vec<(u64, Vec<u8>)>, sink: ByteSink) -> Subscription {
        let clock = self.clock;
        let task = tokio::spawn(async move {
            for (at, bytes) in messages {
                tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
                if !sink(&bytes) {
                    return;
                }
            }
        });
        Subscription::new(AbortOnDrop(task))
    }
}

/// Ends a playback when the subscription holding it is dropped.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

impl Transport for PlaybackTransport {
    fn name(&self) -> &str {
        "replay"
    }

    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo> {
        let now = self.clock.now().as_nanos();
        let seen = self.log.lookups.get(addr)?;
        // What the transport last said by now; before the first lookup, what it first said.
        let i = seen.partition_point(|(t, _)| *t <= now);
        seen[i.saturating_sub(1)].1.clone()
    }

    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> PatternResult<()> {
        self.made(ExchangeKind::Send, addr, &Exchanged::sent(&payload));
        Ok(())
    }

    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> futures::future::BoxFuture<'static, PatternResult<Vec<u8>>> {
        let n = self.number(ExchangeKind::Request, addr);
        let e = Exchanged::request(n, &payload);
        self.made(ExchangeKind::Request, addr, &e);
        let reply = self.log.replies.get(&(addr.clone(), n)).cloned();
        let clock = self.clock;
        Box::pin(async move {
            match reply {
                Some((at, reply)) => {
                    tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
                    reply
                }
                None => {
                    tokio::time::sleep(timeout).await;
                    Err(PatternError::Timeout)
                }
            }
        })
    }

    fn subscribe(
        &self,
        addr: &ServiceAddr,
        every: NonZeroU32,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let n = self.number(ExchangeKind::Subscribe, addr);
        self.made(ExchangeKind::Subscribe, addr, &Exchanged::subscription(n, every.get()));
        let updates = self.log.updates.get(&(addr.clone(), n)).cloned().unwrap_or_default();
        Ok(self.play(updates, sink))
    }

    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: EventMode,
        params: Vec<u8>,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let n = self.number(ExchangeKind::Activate, addr);
        let e = Exchanged::activation(n, mode, &params);
        self.made(ExchangeKind::Activate, addr, &e);
        let firings = self.log.firings.get(&(addr.clone(), n)).cloned().unwrap_or_default();
        Ok(self.play(firings, sink))
    }

    fn service_added(&self, _addr: &ServiceAddr, _info: &ServiceInfo, _served: Arc<dyn Served>) {}

    fn service_removed(&self, _addr: &ServiceAddr) {}
}
