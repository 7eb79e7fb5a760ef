//! **Event**: the server fires to a client when the client's condition holds.
//!
//! Semantics: a client [`activate`](EventClient::activate)s an event with parameters (its
//! condition, e.g. "distance below 0.5 m") in one of two modes: [`EventMode::Single`] fires once
//! and then ends the activation, [`EventMode::Continuous`] fires every time the condition holds
//! until the client deactivates it. The server calls [`EventServer::put`] with its new state on
//! every state change; the server's test function is evaluated for each activation against that
//! state, and an event is sent only to activations it matches. An activation made after a
//! state change is tested at the next one. Events carry the activation's id, a sequence number
//! and a timestamp.
//!
//! ```
//! # use orsa_actors::{Registry, event::{EventClient, EventMode, EventServer}, service::EventService};
//! const NEAR: EventService<f64, f64> = EventService::new("near");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! // fire with the distance when it drops below the client's threshold
//! let server = EventServer::<f64, f64, f64>::register(&registry, NEAR.on("nomad200"), |limit: &mut f64, d: &f64| {
//!     (*d < *limit).then_some(*d)
//! })?;
//! let client = EventClient::<f64, f64>::connect(&registry, NEAR.on("nomad200"))?;
//! let mut near = client.activate(EventMode::Single, 0.5)?;
//! server.put(&0.8); // no event
//! server.put(&0.4); // fires once
//! server.put(&0.3); // single-shot: already done
//! assert_eq!(near.next().await?.event.value, 0.4);
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr, ServiceInfo};
use crate::clock::Clock;
use crate::comm::CommObject;
use crate::door::{Door, Duplicate, Pass};
use crate::error::{PatternError, PatternResult};
use crate::registry::{Registry, Remote, Resolved};
use crate::service::EventService;
use crate::sink::{Sink, Undeliverable};
use crate::stamped::Stamped;
use crate::state::Cancel;
pub use crate::transport::EventMode;
use crate::transport::{ByteSink, Served, Subscription};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tokio::sync::mpsc;

pub(crate) fn info<P: CommObject, E: CommObject>() -> ServiceInfo {
    ServiceInfo::new(PatternKind::Event, &[P::ID, E::ID])
}

/// Identifies one activation at one event server.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct ActivationId(pub u64);

/// An event as a client receives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fired<E> {
    /// The activation that matched.
    pub activation: ActivationId,
    /// The stamped event.
    pub event: Stamped<E>,
}

impl<E: Clone> Duplicate for Fired<E> {
    fn duplicate(&self) -> Self {
        self.clone()
    }
}

struct Activation<P, E> {
    mode: EventMode,
    params: P,
    sink: Sink<Fired<E>>,
}

pub(crate) struct EventEndpoint<P, E> {
    /// Where each firing is tapped, faulted and handed over with its receipt.
    door: Door,
    clock: Clock,
    activations: Mutex<BTreeMap<ActivationId, Activation<P, E>>>,
    next_id: AtomicU64,
    seq: AtomicU64,
}

impl<P: CommObject, E: CommObject> EventEndpoint<P, E> {
    fn activate(&self, mode: EventMode, params: P, sink: Sink<Fired<E>>) -> ActivationId {
        let id = ActivationId(self.next_id.fetch_add(1, Ordering::Relaxed));
        self.activations.lock().insert(id, Activation { mode, params, sink });
        id
    }

    fn deactivate(&self, id: ActivationId) -> bool {
        self.activations.lock().remove(&id).is_some()
    }
}

/// A firing on the wire.
#[derive(Serialize, Deserialize)]
struct WireFired<E> {
    activation: u64,
    seq: u64,
    stamp_ns: crate::Timestamp,
    value: E,
}

impl<P: CommObject, E: CommObject> Served for EventEndpoint<P, E> {
    fn clients(&self) -> Option<usize> {
        Some(self.activations.lock().len())
    }

    fn serve_activate(
        self: Arc<Self>,
        mode: EventMode,
        params: &[u8],
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let params: P = crate::wire::decode(params, P::ID)
            .map_err(|e| PatternError::Decode(format!("activation of {}: {e}", self.door.addr())))?;
        let wire_sink = Sink::from_fn(move |f: Fired<E>| {
            let wire = WireFired {
                activation: f.activation.0,
                seq: f.event.seq,
                stamp_ns: f.event.sent_at,
                value: f.event.value,
            };
            if sink(&crate::wire::encode(&wire)) { Ok(()) } else { Err(Undeliverable::Closed) }
        });
        let id = EventEndpoint::activate(&self, mode, params, wire_sink);
        struct Deactivate<P: CommObject, E: CommObject>(std::sync::Weak<EventEndpoint<P, E>>, ActivationId);
        impl<P: CommObject, E: CommObject> Drop for Deactivate<P, E> {
            fn drop(&mut self) {
                if let Some(ep) = self.0.upgrade() {
                    ep.deactivate(self.1);
                }
            }
        }
        Ok(Subscription::new(Deactivate(Arc::downgrade(&self), id)))
    }
}

/// The server side of an Event service over activation parameters `P`, events `E` and server
/// state `S` (which need not be a communication object: it never leaves the server).
pub struct EventServer<P, E, S> {
    endpoint: Arc<EventEndpoint<P, E>>,
    #[allow(clippy::type_complexity)]
    test: Arc<dyn Fn(&mut P, &S) -> Option<E> + Send + Sync>,
}

impl<P, E, S> Clone for EventServer<P, E, S> {
    fn clone(&self) -> Self {
        EventServer { endpoint: Arc::clone(&self.endpoint), test: Arc::clone(&self.test) }
    }
}

impl<P: CommObject, E: CommObject, S> EventServer<P, E, S> {
    /// Registers an Event service at `addr`. `test(params, state)` returns the event to fire to
    /// an activation with `params`, or `None` if its condition does not hold. It may update the
    /// activation's parameters (as SmartSoft's `testEvent` may), e.g. to remember the last
    /// state and fire only on a change.
    pub fn register(
        registry: &Registry,
        addr: impl IntoAddr<EventService<P, E>>,
        test: impl Fn(&mut P, &S) -> Option<E> + Send + Sync + 'static,
    ) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let endpoint = Arc::new(EventEndpoint {
            door: Door::new(registry, &addr, PatternKind::Event),
            clock: registry.clock(),
            activations: Mutex::new(BTreeMap::new()),
            next_id: AtomicU64::new(1),
            seq: AtomicU64::new(0),
        });
        registry.register_service(addr, info::<P, E>(), endpoint.clone(), endpoint.clone())?;
        Ok(EventServer { endpoint, test: Arc::new(test) })
    }

    /// Tests every activation against the server's new `state` and fires to those that match;
    /// returns how many events were sent.
    pub fn put(&self, state: &S) -> usize {
        let ep = &self.endpoint;
        // Test each activation on a copy of its parameters with no lock held, so the test and
        // the sinks may use this server; then write the parameters back and drop what ended.
        let snapshot: Vec<(ActivationId, EventMode, P, Sink<Fired<E>>)> = ep
            .activations
            .lock()
            .iter()
            .map(|(id, a)| (*id, a.mode, a.params.clone(), a.sink.clone()))
            .collect();
        let mut fired = 0;
        let mut ended = Vec::new();
        let mut updated = Vec::with_capacity(snapshot.len());
        for (id, mode, mut params, sink) in snapshot {
            let event = (self.test)(&mut params, state);
            updated.push((id, params));
            let Some(event) = event else { continue };
            let seq = ep.seq.fetch_add(1, Ordering::Relaxed) + 1;
            let msg = Fired { activation: id, event: Stamped { seq, sent_at: ep.clock.now(), value: event } };
            // A firing the fault plan loses or holds back was still fired: a single activation
            // has had its event.
            let result = match ep.door.enter(E::ID, msg.event.sent_at, &msg) {
                Pass::Now(copies) => ep.door.hand(&sink, msg, None, seq, copies),
                Pass::Lost => {
                    ep.door.lost();
                    Ok(())
                }
                Pass::Later(delay, rt) => {
                    ep.door.hand_later(&rt, delay, &sink, msg, None, seq);
                    Ok(())
                }
            };
            match result {
                Ok(()) => {
                    fired += 1;
                    if mode == EventMode::Single {
                        ended.push(id);
                    }
                }
                Err(Undeliverable::Unavailable) => {}
                Err(Undeliverable::Closed) => ended.push(id),
            }
        }
        let mut activations = ep.activations.lock();
        for (id, params) in updated {
            if let Some(a) = activations.get_mut(&id) {
                a.params = params;
            }
        }
        for id in ended {
            activations.remove(&id);
        }
        fired
    }

    /// How many activations are live.
    pub fn activations(&self) -> usize {
        self.endpoint.activations.lock().len()
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        self.endpoint.door.addr()
    }
}

/// The client side of an Event service.
pub struct EventClient<P, E> {
    addr: ServiceAddr,
    via: Via<P, E>,
    cancel: Option<Cancel>,
}

impl<P, E> Clone for EventClient<P, E> {
    fn clone(&self) -> Self {
        EventClient { addr: self.addr.clone(), via: self.via.clone(), cancel: self.cancel.clone() }
    }
}

type Live = Arc<Mutex<BTreeMap<ActivationId, Subscription>>>;

enum Via<P, E> {
    Local(Arc<EventEndpoint<P, E>>),
    Remote { remote: Remote, next_id: Arc<AtomicU64>, live: Live },
}

impl<P, E> Clone for Via<P, E> {
    fn clone(&self) -> Self {
        match self {
            Via::Local(e) => Via::Local(Arc::clone(e)),
            Via::Remote { remote, next_id, live } => {
                Via::Remote { remote: remote.clone(), next_id: Arc::clone(next_id), live: Arc::clone(live) }
            }
        }
    }
}

enum Guard<P, E> {
    Local(Arc<EventEndpoint<P, E>>),
    Remote(#[allow(dead_code)] Subscription),
}

/// An activation whose events the client reads itself. Dropping it deactivates it.
pub struct EventActivation<P: CommObject, E: CommObject> {
    id: ActivationId,
    guard: Guard<P, E>,
    rx: mpsc::UnboundedReceiver<Fired<E>>,
    cancel: Option<Cancel>,
}

impl<P: CommObject, E: CommObject> EventActivation<P, E> {
    /// The activation's id.
    pub fn id(&self) -> ActivationId {
        self.id
    }

    /// Waits for the next event. A single-shot activation that already fired, or one that was
    /// deactivated, answers [`PatternError::NotActive`].
    pub async fn next(&mut self) -> PatternResult<Fired<E>> {
        let id = self.id;
        let rx = &mut self.rx;
        let wait = async move {
            rx.recv().await.ok_or_else(|| PatternError::NotActive(format!("activation {} has ended", id.0)))
        };
        match &self.cancel {
            Some(c) => c.guard(wait).await,
            None => wait.await,
        }
    }

    /// The next event if one has arrived; `Ok(None)` if not yet.
    pub fn try_next(&mut self) -> PatternResult<Option<Fired<E>>> {
        match self.rx.try_recv() {
            Ok(f) => Ok(Some(f)),
            Err(mpsc::error::TryRecvError::Empty) => Ok(None),
            Err(mpsc::error::TryRecvError::Disconnected) => {
                Err(PatternError::NotActive(format!("activation {} has ended", self.id.0)))
            }
        }
    }

    /// Ends the activation now.
    pub fn deactivate(self) {}
}

impl<P: CommObject, E: CommObject> Drop for EventActivation<P, E> {
    fn drop(&mut self) {
        if let Guard::Local(e) = &self.guard {
            e.deactivate(self.id);
        }
    }
}

impl<P: CommObject, E: CommObject> EventClient<P, E> {
    /// Connects to the Event service at `addr`, checking its parameter and event types.
    pub fn connect(registry: &Registry, addr: impl IntoAddr<EventService<P, E>>) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let via = match registry.resolve::<EventEndpoint<P, E>>(&addr, &info::<P, E>())? {
            Resolved::Local(e) => Via::Local(e),
            Resolved::Remote(remote) => Via::Remote {
                remote,
                next_id: Arc::new(AtomicU64::new(1)),
                live: Arc::new(Mutex::new(BTreeMap::new())),
            },
        };
        Ok(EventClient { addr, via, cancel: None })
    }

    /// This client, with its blocking waits aborted by `cancel` (a component's deactivation).
    pub fn with_cancel(mut self, cancel: Cancel) -> Self {
        self.cancel = Some(cancel);
        self
    }

    /// Activates an event; read its firings from the returned activation.
    pub fn activate(&self, mode: EventMode, params: P) -> PatternResult<EventActivation<P, E>> {
        let (tx, rx) = mpsc::unbounded_channel();
        let (id, guard) = match &self.via {
            Via::Local(e) => (e.activate(mode, params, Sink::channel(tx)), Guard::Local(Arc::clone(e))),
            Via::Remote { remote, next_id, .. } => {
                let id = ActivationId(next_id.fetch_add(1, Ordering::Relaxed));
                (id, Guard::Remote(remote_activate(remote, id, mode, &params, Sink::channel(tx))?))
            }
        };
        Ok(EventActivation { id, guard, rx, cancel: self.cancel.clone() })
    }

    /// Activates an event whose firings go into `sink` (a component's mailbox). It lives until
    /// [`deactivate`](Self::deactivate)d, or fired once in single mode.
    pub fn activate_to(
        &self,
        mode: EventMode,
        params: P,
        sink: Sink<Fired<E>>,
    ) -> PatternResult<ActivationId> {
        match &self.via {
            Via::Local(e) => Ok(e.activate(mode, params, sink)),
            Via::Remote { remote, next_id, live } => {
                let id = ActivationId(next_id.fetch_add(1, Ordering::Relaxed));
                let sub = remote_activate(remote, id, mode, &params, sink)?;
                live.lock().insert(id, sub);
                Ok(id)
            }
        }
    }

    /// Ends an activation made with [`activate_to`](Self::activate_to).
    pub fn deactivate(&self, id: ActivationId) -> PatternResult<()> {
        let known = match &self.via {
            Via::Local(e) => e.deactivate(id),
            Via::Remote { live, .. } => live.lock().remove(&id).is_some(),
        };
        if known { Ok(()) } else { Err(PatternError::Unknown { kind: "activation", name: id.0.to_string() }) }
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        &self.addr
    }
}

/// Activates a remote event: firings are decoded, renumbered with the client's activation id,
/// and delivered into `sink`; a single-shot activation delivers at most one.
fn remote_activate<P: CommObject, E: CommObject>(
    remote: &Remote,
    id: ActivationId,
    mode: EventMode,
    params: &P,
    sink: Sink<Fired<E>>,
) -> PatternResult<Subscription> {
    let slot = Mutex::new(Some(sink));
    let r = remote.clone();
    let bytes: ByteSink = Arc::new(move |b: &[u8]| {
        let wire = match crate::wire::decode::<WireFired<E>>(b, E::ID) {
            Ok(w) => w,
            Err(e) => {
                r.bad_message(&e);
                return true;
            }
        };
        let mut slot = slot.lock();
        let Some(sink) = slot.as_ref() else { return false };
        let fired = Fired {
            activation: id,
            event: Stamped { seq: wire.seq, sent_at: wire.stamp_ns, value: wire.value },
        };
        let open = sink.deliver(fired) != Err(Undeliverable::Closed);
        if !open || mode == EventMode::Single {
            *slot = None;
            return false;
        }
        true
    });
    remote.transport.activate(&remote.addr, mode, crate::wire::encode(params), bytes)
}
