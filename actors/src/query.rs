//! **Query**: request/response between any number of clients and one server.
//!
//! Semantics: a client's request is stamped and handed to the server component's mailbox with
//! a [`Responder`]. The server answers through the responder, at once or later (it may keep the
//! responder and handle other messages first). The client either awaits the answer
//! ([`QueryClient::query`], with an optional timeout), or splits the exchange: request now
//! ([`QueryClient::request`] returns a [`PendingQuery`]) and collect later. A server that drops
//! a responder without answering gives the client [`PatternError::NoAnswer`]; a client that gave
//! up makes [`Responder::answer`] return an error. A blocking wait made by a component is aborted
//! with [`PatternError::Cancelled`] when its master deactivates it.
//!
//! ```
//! # use orsa_actors::{Registry, Sink, query::{QueryClient, QueryRequest, QueryServer}, service::QueryService};
//! const SQUARE: QueryService<u64, u64> = QueryService::new("square");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
//! let _server = QueryServer::register(&registry, SQUARE.on("calc"), Sink::channel(tx))?;
//! tokio::spawn(async move {
//!     while let Some(q) = rx.recv().await {
//!         let n = q.request.value;
//!         let _ = q.answer(n * n);
//!     }
//! });
//! let client = QueryClient::connect(&registry, SQUARE.on("calc"))?;
//! assert_eq!(client.query(7, None).await?, 49);
//! let pending = client.request(3)?;          // request now ...
//! assert_eq!(pending.receive(None).await?, 9); // ... collect later
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr, ServiceInfo};
use crate::comm::CommObject;
use crate::door::{Door, Duplicate, Pass};
use crate::error::{PatternError, PatternResult};
use crate::ledger::Stream;
use crate::registry::{Registry, Remote, Resolved};
use crate::service::QueryService;
use crate::sink::Sink;
use crate::stamped::Stamped;
use crate::state::Cancel;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use tokio::sync::oneshot;

pub(crate) fn info<Req: CommObject, Ans: CommObject>() -> ServiceInfo {
    ServiceInfo::new(PatternKind::Query, &[Req::ID, Ans::ID])
}

/// A request as the server receives it, with the means to answer it.
#[derive(Debug)]
pub struct QueryRequest<Req, Ans> {
    /// The stamped request.
    pub request: Stamped<Req>,
    /// Where the answer goes.
    pub responder: Responder<Ans>,
}

impl<Req, Ans: CommObject> QueryRequest<Req, Ans> {
    /// Answers the request now.
    pub fn answer(self, answer: Ans) -> PatternResult<()> {
        self.responder.answer(answer)
    }
}

/// The one-time right to answer a query. It may be kept and used after other messages.
#[derive(Debug)]
pub struct Responder<Ans> {
    tx: oneshot::Sender<PatternResult<Stamped<Ans>>>,
    seq: u64,
    stamp: crate::clock::Clock,
    tap: crate::tap::TapSlot,
    answer_topic: Arc<str>,
    /// Whether the request came from another process.
    remote: bool,
}

impl<Ans: CommObject> Responder<Ans> {
    /// Sends the answer. Fails with [`PatternError::NotActive`] if the client stopped waiting.
    pub fn answer(self, answer: Ans) -> PatternResult<()> {
        let msg = Stamped { seq: self.seq, sent_at: self.stamp.now(), value: answer };
        self.tap.record_from(&self.answer_topic, Ans::ID, msg.sent_at, &msg, self.remote);
        self.tx
            .send(Ok(msg))
            .map_err(|_| PatternError::NotActive("the client no longer waits for this answer".into()))
    }
}

/// A duplicate fault's second copy of a request: the server handles it again, and its answer
/// goes nowhere (the client waits for one answer, which the first copy gives).
impl<Req: Clone, Ans> Duplicate for QueryRequest<Req, Ans> {
    fn duplicate(&self) -> Self {
        let r = &self.responder;
        QueryRequest {
            request: self.request.clone(),
            responder: Responder {
                tx: oneshot::channel().0,
                seq: r.seq,
                stamp: r.stamp,
                tap: r.tap.clone(),
                answer_topic: Arc::clone(&r.answer_topic),
                remote: r.remote,
            },
        }
    }
}

pub(crate) struct QueryEndpoint<Req, Ans> {
    /// Where requests are tapped, faulted and handed over with their receipts.
    door: Door,
    clock: crate::clock::Clock,
    answer_topic: Arc<str>,
    sink: Sink<QueryRequest<Req, Ans>>,
}

impl<Req: CommObject, Ans: CommObject> QueryEndpoint<Req, Ans> {
    /// Hands a stamped request to the server; the answer (or why there is none) arrives on
    /// the returned channel.
    /// `from` is the requesting client's sequence (for duplicate detection), unknown for
    /// requests from other processes.
    fn deliver(
        &self,
        request: Stamped<Req>,
        from: Option<&Arc<Stream>>,
    ) -> PatternResult<oneshot::Receiver<PatternResult<Stamped<Ans>>>> {
        let (tx, rx) = oneshot::channel();
        let seq = request.seq;
        // A request with no client's sequence came through the transport.
        let remote = from.is_none();
        let pass = self.door.enter_from(Req::ID, request.sent_at, &request, remote);
        let msg = QueryRequest {
            request,
            responder: Responder {
                tx,
                seq,
                stamp: self.clock,
                tap: self.door.tap().clone(),
                answer_topic: Arc::clone(&self.answer_topic),
                remote,
            },
        };
        // A request that vanishes (lost, or its server gone) drops its responder, so its client
        // always hears: `NoAnswer`.
        match pass {
            Pass::Now(copies) => self
                .door
                .hand(&self.sink, msg, from, seq, copies)
                .map_err(|_| PatternError::Unavailable(self.door.addr().clone()))?,
            Pass::Lost => self.door.lost(),
            Pass::Later(delay, rt) => self.door.hand_later(&rt, delay, &self.sink, msg, from, seq),
        }
        Ok(rx)
    }
}

impl<Req: CommObject, Ans: CommObject> crate::transport::Served for QueryEndpoint<Req, Ans> {
    fn serve_request(self: Arc<Self>, payload: &[u8]) -> futures::future::BoxFuture<'static, Vec<u8>> {
        let addr = self.door.addr().clone();
        let rx = crate::wire::decode_stamped::<Req>(payload, Req::ID)
            .map_err(|e| PatternError::Decode(format!("request to {addr}: {e}")))
            .and_then(|request| self.deliver(request, None));
        Box::pin(async move {
            let answer = match rx {
                Ok(rx) => rx.await.unwrap_or_else(|_| Err(PatternError::NoAnswer(addr))),
                Err(e) => Err(e),
            };
            let wire = answer.map(crate::wire::WireStamped::from);
            crate::wire::encode(&crate::wire::Reply::from_result(wire))
        })
    }
}

/// The server side of a Query service.
pub struct QueryServer<Req, Ans> {
    endpoint: Arc<QueryEndpoint<Req, Ans>>,
}

impl<Req, Ans> Clone for QueryServer<Req, Ans> {
    fn clone(&self) -> Self {
        QueryServer { endpoint: Arc::clone(&self.endpoint) }
    }
}

impl<Req: CommObject, Ans: CommObject> QueryServer<Req, Ans> {
    /// Registers a Query service at `addr` delivering requests into `sink`.
    pub fn register(
        registry: &Registry,
        addr: impl IntoAddr<QueryService<Req, Ans>>,
        sink: Sink<QueryRequest<Req, Ans>>,
    ) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let endpoint = Arc::new(QueryEndpoint {
            door: Door::new(registry, &addr, PatternKind::Query),
            answer_topic: format!("{addr}/answer").into(),
            clock: registry.clock(),
            sink,
        });
        registry.register_service(addr, info::<Req, Ans>(), endpoint.clone(), endpoint.clone())?;
        Ok(QueryServer { endpoint })
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        self.endpoint.door.addr()
    }
}

/// The client side of a Query service. Cheap to clone; usable from many tasks at once.
pub struct QueryClient<Req, Ans> {
    registry: Registry,
    addr: ServiceAddr,
    endpoint: Via<Req, Ans>,
    seq: Arc<AtomicU64>,
    /// What the server remembers of this client's sequence numbers (to tell a duplicate).
    stream: Arc<Stream>,
    cancel: Option<Cancel>,
}

impl<Req, Ans> Clone for QueryClient<Req, Ans> {
    fn clone(&self) -> Self {
        QueryClient {
            registry: self.registry.clone(),
            addr: self.addr.clone(),
            endpoint: self.endpoint.clone(),
            seq: Arc::clone(&self.seq),
            stream: Arc::clone(&self.stream),
            cancel: self.cancel.clone(),
        }
    }
}

enum Via<Req, Ans> {
    Local(Arc<QueryEndpoint<Req, Ans>>),
    Remote(Remote),
}

impl<Req, Ans> Clone for Via<Req, Ans> {
    fn clone(&self) -> Self {
        match self {
            Via::Local(e) => Via::Local(Arc::clone(e)),
            Via::Remote(r) => Via::Remote(r.clone()),
        }
    }
}

/// An answer requested but not yet collected.
#[derive(Debug)]
pub struct PendingQuery<Ans> {
    addr: ServiceAddr,
    rx: oneshot::Receiver<PatternResult<Stamped<Ans>>>,
    cancel: Option<Cancel>,
}

impl<Ans: CommObject> PendingQuery<Ans> {
    /// Waits for the answer, at most `timeout` if given.
    pub async fn receive(self, timeout: Option<Duration>) -> PatternResult<Ans> {
        self.receive_stamped(timeout).await.map(|s| s.value)
    }

    /// Waits for the stamped answer, at most `timeout` if given.
    pub async fn receive_stamped(self, timeout: Option<Duration>) -> PatternResult<Stamped<Ans>> {
        let addr = self.addr;
        let answer = async move { self.rx.await.unwrap_or(Err(PatternError::NoAnswer(addr))) };
        let bounded = async move {
            match timeout {
                Some(t) => tokio::time::timeout(t, answer).await.map_err(|_| PatternError::Timeout)?,
                None => answer.await,
            }
        };
        match self.cancel {
            Some(cancel) => cancel.guard(bounded).await,
            None => bounded.await,
        }
    }

    /// Takes the answer if it has arrived: `Ok(None)` if not yet.
    pub fn try_receive(&mut self) -> PatternResult<Option<Ans>> {
        match self.rx.try_recv() {
            Ok(s) => s.map(|s| Some(s.value)),
            Err(oneshot::error::TryRecvError::Empty) => Ok(None),
            Err(oneshot::error::TryRecvError::Closed) => Err(PatternError::NoAnswer(self.addr.clone())),
        }
    }
}

impl<Req: CommObject, Ans: CommObject> QueryClient<Req, Ans> {
    /// Connects to the Query service at `addr`, checking its request and answer types.
    pub fn connect(registry: &Registry, addr: impl IntoAddr<QueryService<Req, Ans>>) -> PatternResult<Self> {
        let addr = addr.into_addr();
        let endpoint = match registry.resolve::<QueryEndpoint<Req, Ans>>(&addr, &info::<Req, Ans>())? {
            Resolved::Local(e) => Via::Local(e),
            Resolved::Remote(r) => Via::Remote(r),
        };
        Ok(QueryClient {
            registry: registry.clone(),
            addr,
            endpoint,
            seq: Arc::new(AtomicU64::new(0)),
            stream: Arc::new(Stream::default()),
            cancel: None,
        })
    }

    /// This client, with its blocking waits aborted by `cancel` (a component's deactivation).
    pub fn with_cancel(mut self, cancel: Cancel) -> Self {
        self.cancel = Some(cancel);
        self
    }

    /// Sends a request now; collect the answer later from the returned [`PendingQuery`].
    pub fn request(&self, request: Req) -> PatternResult<PendingQuery<Ans>> {
        self.request_within(request, crate::transport::DEFAULT_REQUEST_TIMEOUT)
    }

    /// As [`request`](Self::request); a request to another process gives up after `timeout`
    /// (an in-process request waits as long as its receiver does).
    fn request_within(&self, request: Req, timeout: Duration) -> PatternResult<PendingQuery<Ans>> {
        let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
        let clock = self.registry.clock();
        let stamped = Stamped { seq, sent_at: clock.now(), value: request };
        let rx = match &self.endpoint {
            Via::Local(ep) => ep.deliver(stamped, Some(&self.stream))?,
            Via::Remote(r) => {
                let runtime = tokio::runtime::Handle::try_current().map_err(|_| {
                    PatternError::InvalidArgument("a remote query needs a tokio runtime".into())
                })?;
                let (tx, rx) = oneshot::channel();
                let reply = r.transport.request(&r.addr, crate::wire::encode_stamped(&stamped), timeout);
                let addr = r.addr.clone();
                let registry = r.registry.clone();
                runtime.spawn(async move {
                    let answer = reply.await.and_then(|bytes| {
                        crate::wire::decode_reply::<crate::wire::WireStamped<Ans>>(&bytes, &addr, Ans::ID)
                    });
                    if let Err(PatternError::Decode(m)) = &answer {
                        registry.note_decode_error(&addr, m);
                    }
                    let _ = tx.send(answer.map(Stamped::from));
                });
                rx
            }
        };
        Ok(PendingQuery { addr: self.addr.clone(), rx, cancel: self.cancel.clone() })
    }

    /// Sends a request and waits for its answer, at most `timeout` if given.
    pub async fn query(&self, request: Req, timeout: Option<Duration>) -> PatternResult<Ans> {
        let within = timeout.unwrap_or(crate::transport::DEFAULT_REQUEST_TIMEOUT);
        self.request_within(request, within)?.receive(timeout).await
    }

    /// The address this client queries.
    pub fn addr(&self) -> &ServiceAddr {
        &self.addr
    }
}
