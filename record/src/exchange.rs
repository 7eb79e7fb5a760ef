//! Recording what a process exchanges with services in other processes: a [`Transport`] that
//! wraps the real one (zenoh) and notes in the process's recording every Send, request,
//! subscription and activation it makes, and every reply, update and firing that comes back,
//! each when it crosses. `orsa executive --record` installs it, so that `orsa replay` can run
//! the executive's components again on what reached them, when it reached them (see
//! [`crate::replay::exchange`]).

use crate::record::events::{EXCHANGED_TYPE, ExchangeKind, Exchanged};
use crate::recording::McapTap;
use futures::FutureExt as _;
use orsa_actors::transport::{ByteSink, EventMode, Served, Subscription, Transport};
use orsa_actors::{Clock, PatternResult, ServiceAddr, ServiceInfo};
use parking_lot::Mutex;
use std::collections::HashMap;
use std::num::NonZeroU32;
use std::sync::Arc;
use std::time::Duration;

/// The notes shared by the transport and the sinks and futures it hands out.
struct Notes {
    tap: Arc<McapTap>,
    clock: Clock,
    /// The next number of each kind of call to each service.
    next: Mutex<HashMap<(ExchangeKind, ServiceAddr), u64>>,
    /// The last lookup noted for each service.
    looked_up: Mutex<HashMap<ServiceAddr, Option<ServiceInfo>>>,
}

impl Notes {
    fn number(&self, kind: ExchangeKind, addr: &ServiceAddr) -> u64 {
        let mut next = self.next.lock();
        let n = next.entry((kind, addr.clone())).or_insert(0);
        *n += 1;
        *n - 1
    }

    fn note(&self, kind: ExchangeKind, addr: &ServiceAddr, e: &Exchanged) {
        self.tap.note(&kind.topic(addr), EXCHANGED_TYPE, self.clock.now(), e);
    }
}

/// A transport that records the process's exchange through `inner` (see the module docs).
pub struct RecordingTransport {
    inner: Arc<dyn Transport>,
    notes: Arc<Notes>,
}

impl RecordingTransport {
    /// Wraps `inner`, noting into `tap` on `clock`.
    pub fn new(inner: Arc<dyn Transport>, tap: Arc<McapTap>, clock: Clock) -> Self {
        RecordingTransport {
            inner,
            notes: Arc::new(Notes { tap, clock, next: Mutex::default(), looked_up: Mutex::default() }),
        }
    }
}

/// A sink that notes what comes in as `kind` number `n` before handing it on.
fn noting_sink(
    notes: &Arc<Notes>,
    kind: ExchangeKind,
    addr: &ServiceAddr,
    n: u64,
    sink: ByteSink,
) -> ByteSink {
    let (notes, addr) = (Arc::clone(notes), addr.clone());
    Arc::new(move |bytes: &[u8]| {
        notes.note(kind, &addr, &Exchanged { n: Some(n), ..Exchanged::came_in(bytes) });
        sink(bytes)
    })
}

impl Transport for RecordingTransport {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo> {
        let info = self.inner.lookup(addr);
        let mut seen = self.notes.looked_up.lock();
        if seen.get(addr) != Some(&info) {
            seen.insert(addr.clone(), info.clone());
            self.notes.note(
                ExchangeKind::Lookup,
                addr,
                &Exchanged { info: info.clone(), ..Exchanged::default() },
            );
        }
        info
    }

    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> PatternResult<()> {
        let e = Exchanged::sent(&payload);
        self.notes.note(ExchangeKind::Send, addr, &e);
        self.inner.send(addr, payload)
    }

    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> futures::future::BoxFuture<'static, PatternResult<Vec<u8>>> {
        let n = self.notes.number(ExchangeKind::Request, addr);
        let e = Exchanged::request(n, &payload);
        self.notes.note(ExchangeKind::Request, addr, &e);
        let (notes, addr) = (Arc::clone(&self.notes), addr.clone());
        self.inner
            .request(&addr, payload, timeout)
            .map(move |reply| {
                let e = match &reply {
                    Ok(bytes) => Exchanged { n: Some(n), ..Exchanged::came_in(bytes) },
                    Err(error) => Exchanged {
                        n: Some(n),
                        error: Some(error.to_string()),
                        failure: Some(orsa_actors::wire::WireFailure::from_error(error)),
                        ..Exchanged::default()
                    },
                };
                notes.note(ExchangeKind::Reply, &addr, &e);
                reply
            })
            .boxed()
    }

    fn subscribe(
        &self,
        addr: &ServiceAddr,
        every: NonZeroU32,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let n = self.notes.number(ExchangeKind::Subscribe, addr);
        let e = Exchanged::subscription(n, every.get());
        self.notes.note(ExchangeKind::Subscribe, addr, &e);
        let sink = noting_sink(&self.notes, ExchangeKind::Update, addr, n, sink);
        self.inner.subscribe(addr, every, sink)
    }

    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: EventMode,
        params: Vec<u8>,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let n = self.notes.number(ExchangeKind::Activate, addr);
        let e = Exchanged::activation(n, mode, &params);
        self.notes.note(ExchangeKind::Activate, addr, &e);
        let sink = noting_sink(&self.notes, ExchangeKind::Firing, addr, n, sink);
        self.inner.activate(addr, mode, params, sink)
    }

    fn service_added(&self, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>) {
        self.inner.service_added(addr, info, served);
    }

    fn service_removed(&self, addr: &ServiceAddr) {
        self.inner.service_removed(addr);
    }
}
