//! The transport seam: how a registry reaches services hosted in other processes, and how it
//! offers its own services to them.
//!
//! A client resolves its address in the [`Registry`](crate::Registry) first. A service hosted
//! in the same process answers with its in-process endpoint, so local peers talk through actor
//! mailboxes and never pay a network hop. Only an address no local component hosts is asked of
//! the installed [`Transport`], and the client then talks through it with the same API and the
//! same semantics, in bytes encoded by [`crate::wire`].
//!
//! The seam has two halves:
//! - [`Transport`]: the byte-level operations of each pattern, as a client in this process
//!   needs them (send, request, subscribe with every-n-th, activate an event).
//! - [`Served`]: the byte-level face of each service hosted here, which the transport calls
//!   when a peer uses it. Every service registers one; the registry hands it to the transport
//!   (see [`Transport::service_added`]).
//!
//! This module is the one place where another process enters: the zenoh transport (crate
//! `orsa-net`) implements [`Transport`], and no other module of this crate names zenoh.

use crate::addr::{ServiceAddr, ServiceInfo};
use crate::error::{PatternError, PatternResult};
use futures::future::BoxFuture;
use std::num::NonZeroU32;
use std::sync::Arc;
use std::time::Duration;

/// How often an Event activation fires (part of the seam's vocabulary: activations cross it;
/// the Event pattern re-exports it as `event::EventMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventMode {
    /// Once, then the activation ends.
    Single,
    /// Every time the condition holds, until deactivated.
    Continuous,
}

/// Where a transport delivers bytes that arrive for a subscription or an activation. It
/// answers `false` when its receiver is gone for good (the transport may then end the stream).
pub type ByteSink = Arc<dyn Fn(&[u8]) -> bool + Send + Sync>;

/// A live subscription or activation held through a transport: dropping it ends it.
pub struct Subscription {
    _guard: Box<dyn Send + Sync>,
}

impl Subscription {
    /// A subscription that ends when `guard` is dropped.
    pub fn new(guard: impl Send + Sync + 'static) -> Self {
        Subscription { _guard: Box::new(guard) }
    }
}

impl std::fmt::Debug for Subscription {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Subscription")
    }
}

/// Access to services hosted by other processes.
pub trait Transport: Send + Sync + 'static {
    /// A short name for messages and logs, e.g. `zenoh`.
    fn name(&self) -> &str;

    /// What the remote service at `addr` is, if a reachable peer hosts it.
    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo>;

    /// Hands a one-way message (an encoded [`WireStamped`](crate::wire::WireStamped)) to the
    /// Send service at `addr`, without waiting.
    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> PatternResult<()>;

    /// Sends a request to the service at `addr` (Query, State or Wiring) and resolves to the
    /// encoded [`Reply`](crate::wire::Reply), or to an error after `timeout`.
    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> BoxFuture<'static, PatternResult<Vec<u8>>>;

    /// Subscribes to every `every`-th update of the push service at `addr`, counted at the
    /// source, delivering each encoded update into `sink`.
    fn subscribe(&self, addr: &ServiceAddr, every: NonZeroU32, sink: ByteSink)
    -> PatternResult<Subscription>;

    /// Activates the event service at `addr` with encoded parameters, delivering each encoded
    /// firing into `sink`.
    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: EventMode,
        params: Vec<u8>,
        sink: ByteSink,
    ) -> PatternResult<Subscription>;

    /// A service was registered in this process: offer it to peers. Called for every service
    /// already registered when the transport is installed, then for each new one.
    fn service_added(&self, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>);

    /// A service of this process was removed.
    fn service_removed(&self, addr: &ServiceAddr);
}

/// The byte-level face of a service hosted here, for the transport. Each method belongs to
/// one family of patterns; the others answer [`PatternError::InvalidArgument`].
pub trait Served: Send + Sync + 'static {
    /// Send: one encoded `WireStamped` message.
    fn serve_send(&self, payload: &[u8]) -> PatternResult<()> {
        let _ = payload;
        Err(wrong("send"))
    }

    /// Query, State and Wiring: one encoded request; resolves to the encoded reply.
    fn serve_request(self: Arc<Self>, payload: &[u8]) -> BoxFuture<'static, Vec<u8>> {
        let _ = payload;
        let reply = crate::wire::encode(&crate::wire::Reply::<()>::from_result(Err(wrong("request"))));
        Box::pin(async move { reply })
    }

    /// Push: every `every`-th update, encoded, into `sink`, until the subscription is dropped.
    fn serve_subscribe(self: Arc<Self>, every: NonZeroU32, sink: ByteSink) -> PatternResult<Subscription> {
        let _ = (every, sink);
        Err(wrong("subscribe"))
    }

    /// Event: an activation with encoded parameters; firings, encoded, into `sink`, until the
    /// activation is dropped (or, in single mode, after it fired once).
    fn serve_activate(
        self: Arc<Self>,
        mode: EventMode,
        params: &[u8],
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let _ = (mode, params, sink);
        Err(wrong("activate"))
    }

    /// How many clients hold a subscription (push) or an activation (event) here now; `None`
    /// for patterns without them.
    fn clients(&self) -> Option<usize> {
        None
    }
}

fn wrong(op: &str) -> PatternError {
    PatternError::InvalidArgument(format!("this service's pattern has no '{op}' operation"))
}

/// How long a remote request waits when its caller gave no timeout.
pub const DEFAULT_REQUEST_TIMEOUT: Duration = Duration::from_secs(30);
