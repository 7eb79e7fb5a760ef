//! **Send**: a one-way command from any number of clients to one server.
//!
//! Semantics: [`SendClient::send`] stamps the value (sequence number, robot time) and hands it
//! to the server component's mailbox without waiting for it to be handled. It returns an error
//! only if the message cannot be handed over: [`PatternError::Unavailable`] while the server
//! component has no running instance (it is restarting). Messages from one client arrive in the
//! order they were sent. The server receives them as [`Stamped`] values in its own mailbox.
//!
//! ```
//! # use orsa_actors::{Registry, Sink, Stamped, send::{SendClient, SendServer}, service::SendService};
//! const SPEED: SendService<f64> = SendService::new("speed");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
//! let _server = SendServer::register(&registry, SPEED.on("robot"), Sink::channel(tx))?;
//!
//! let client = SendClient::connect(&registry, SPEED.on("robot"))?;
//! client.send(0.25)?;
//! let got = rx.recv().await.expect("delivered");
//! assert_eq!((got.seq, got.value), (1, 0.25));
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr, ServiceInfo};
use crate::comm::CommObject;
use crate::door::{Door, Pass};
use crate::error::{PatternError, PatternResult};
use crate::ledger::Stream;
use crate::registry::{Registry, Remote, Resolved};
use crate::service::SendService;
use crate::sink::{Sink, Undeliverable};
use crate::stamped::Stamped;
use std::marker::PhantomData;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

pub(crate) fn info<T: CommObject>() -> ServiceInfo {
    ServiceInfo::new(PatternKind::Send, &[T::ID])
}

pub(crate) struct SendEndpoint<T> {
    door: Door,
    sink: Sink<Stamped<T>>,
    received: AtomicU64,
}

impl<T: CommObject> SendEndpoint<T> {
    /// Hands `msg` to the server. `from` is the sending client's sequence (for duplicate
    /// detection), unknown for messages from other processes.
    pub(crate) fn accept(&self, msg: Stamped<T>, from: Option<&Arc<Stream>>) -> PatternResult<()> {
        let n = msg.seq;
        // A message with no sender's sequence came through the transport.
        let copies = match self.door.enter_from(T::ID, msg.sent_at, &msg, from.is_none()) {
            Pass::Now(copies) => copies,
            Pass::Lost => {
                self.door.lost();
                return Ok(());
            }
            Pass::Later(delay, rt) => {
                self.door.hand_later(&rt, delay, &self.sink, msg, from, n);
                return Ok(());
            }
        };
        match self.door.hand(&self.sink, msg, from, n, copies) {
            Ok(()) => {
                self.received.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(Undeliverable::Closed | Undeliverable::Unavailable) => {
                Err(PatternError::Unavailable(self.door.addr().clone()))
            }
        }
    }
}

impl<T: CommObject> crate::transport::Served for SendEndpoint<T> {
    fn serve_send(&self, payload: &[u8]) -> PatternResult<()> {
        let msg = crate::wire::decode_stamped::<T>(payload, T::ID)
            .map_err(|e| PatternError::Decode(format!("to {}: {e}", self.door.addr())))?;
        self.accept(msg, None)
    }
}

/// The server side of a Send service. Dropping it does not unregister the service; the
/// component that owns it does when it is removed.
pub struct SendServer<T> {
    endpoint: Arc<SendEndpoint<T>>,
}

impl<T> Clone for SendServer<T> {
    fn clone(&self) -> Self {
        SendServer { endpoint: Arc::clone(&self.endpoint) }
    }
}

impl<T: CommObject> SendServer<T> {
    /// Registers a Send service at `addr` delivering into `sink`.
    pub fn register(
        registry: &Registry,
        addr: impl IntoAddr<SendService<T>>,
        sink: Sink<Stamped<T>>,
    ) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let endpoint = Arc::new(SendEndpoint {
            door: Door::new(registry, &addr, PatternKind::Send),
            sink,
            received: AtomicU64::new(0),
        });
        registry.register_service(addr, info::<T>(), endpoint.clone(), endpoint.clone())?;
        Ok(SendServer { endpoint })
    }

    /// How many messages were handed to the server so far.
    pub fn received(&self) -> u64 {
        self.endpoint.received.load(Ordering::Relaxed)
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        self.endpoint.door.addr()
    }
}

/// The client side of a Send service. Clones share one sequence counter.
pub struct SendClient<T> {
    registry: Registry,
    addr: ServiceAddr,
    endpoint: Via<T>,
    /// The last sequence number used. Numbering and handing over happen under this lock, so
    /// clones sending from several threads still arrive in sequence order.
    seq: Arc<parking_lot::Mutex<u64>>,
    /// What the receiver remembers of this client's sequence numbers.
    stream: Arc<Stream>,
    _t: PhantomData<fn(T)>,
}

impl<T> Clone for SendClient<T> {
    fn clone(&self) -> Self {
        SendClient {
            registry: self.registry.clone(),
            addr: self.addr.clone(),
            endpoint: self.endpoint.clone(),
            seq: Arc::clone(&self.seq),
            stream: Arc::clone(&self.stream),
            _t: PhantomData,
        }
    }
}

enum Via<T> {
    Local(Arc<SendEndpoint<T>>),
    Remote(Remote),
}

impl<T> Clone for Via<T> {
    fn clone(&self) -> Self {
        match self {
            Via::Local(e) => Via::Local(Arc::clone(e)),
            Via::Remote(r) => Via::Remote(r.clone()),
        }
    }
}

impl<T: CommObject> SendClient<T> {
    /// Connects to the Send service at `addr`, checking that it sends `T`.
    pub fn connect(registry: &Registry, addr: impl IntoAddr<SendService<T>>) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let endpoint = match registry.resolve::<SendEndpoint<T>>(&addr, &info::<T>())? {
            Resolved::Local(e) => Via::Local(e),
            Resolved::Remote(r) => Via::Remote(r),
        };
        Ok(SendClient {
            registry: registry.clone(),
            addr,
            endpoint,
            seq: Arc::new(parking_lot::Mutex::new(0)),
            stream: Arc::new(Stream::default()),
            _t: PhantomData,
        })
    }

    /// Sends `value` without waiting for it to be handled.
    pub fn send(&self, value: T) -> PatternResult<()> {
        let mut seq = self.seq.lock();
        *seq += 1;
        self.send_stamped(Stamped { seq: *seq, sent_at: self.registry.now(), value })
    }

    /// Sends an already stamped message unchanged (for forwarding and replay).
    pub fn send_stamped(&self, msg: Stamped<T>) -> PatternResult<()> {
        match &self.endpoint {
            Via::Local(e) => e.accept(msg, Some(&self.stream)),
            Via::Remote(r) => r.transport.send(&r.addr, crate::wire::encode_stamped(&msg)),
        }
    }

    /// The address this client sends to.
    pub fn addr(&self) -> &ServiceAddr {
        &self.addr
    }

    /// Whether the service is hosted by another process.
    pub fn is_remote(&self) -> bool {
        matches!(self.endpoint, Via::Remote(_))
    }

    /// How many messages this client (and its clones) sent.
    pub fn sent(&self) -> u64 {
        *self.seq.lock()
    }
}
