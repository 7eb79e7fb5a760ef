//! Serving this process's services to peers: the zenoh entities each service is offered
//! through, the every-n-th streams of push services, activations, and the publishers
//! (outlets) everything leaves by.

use crate::control::{ActivateRequest, SubscribeRequest};
use crate::session::{Inner, link};
use futures::FutureExt as _;
use orsa_actors::addr::{ServiceAddr, ServiceInfo};
use orsa_actors::transport::{ByteSink, Served, Subscription};
use orsa_actors::wire::{Reply, decode, encode};
use orsa_actors::{PatternError, PatternKind, PatternResult};
use parking_lot::Mutex;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use zenoh::Wait as _;
use zenoh::qos::CongestionControl;

pub(crate) type ClientKey = (String, u64);
pub(crate) type Clients = Arc<Mutex<BTreeSet<ClientKey>>>;

/// One every-n-th stream of a push service hosted here.
pub(crate) struct Stream {
    /// Shared with the stream's publishing sink, which withholds updates whose every client
    /// is cut off.
    pub(crate) clients: Clients,
    pub(crate) _sub: Subscription,
}

/// A service hosted here and offered to peers.
pub(crate) struct Export {
    pub(crate) served: Arc<dyn Served>,
    /// zenoh entities (subscriber, queryables, token): dropping them undeclares them.
    pub(crate) entities: Mutex<Vec<Entity>>,
    pub(crate) streams: Mutex<BTreeMap<u32, Stream>>,
    pub(crate) activations: Mutex<HashMap<ClientKey, Subscription>>,
}

impl Inner {
    pub(crate) fn export(self: &Arc<Self>, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>) {
        let export = Arc::new(Export {
            served,
            entities: Mutex::new(Vec::new()),
            streams: Mutex::new(BTreeMap::new()),
            activations: Mutex::new(HashMap::new()),
        });
        match self.declare_entities(addr, info, &export) {
            Ok(entities) => {
                export.entities.lock().extend(entities);
                self.exports.lock().insert(addr.clone(), export);
            }
            Err(e) => tracing::error!("cannot offer {addr} to peers: {e}"),
        }
    }

    /// Declares the zenoh entities of a service hosted here. Their callbacks hold weak
    /// references, so dropping the export undeclares everything.
    pub(crate) fn declare_entities(
        self: &Arc<Self>,
        addr: &ServiceAddr,
        info: &ServiceInfo,
        export: &Arc<Export>,
    ) -> Result<Vec<Entity>, zenoh::Error> {
        let mut entities: Vec<Entity> = Vec::new();
        let (wi, we) = (Arc::downgrade(self), Arc::downgrade(export));
        let topic = addr.to_string();
        match info.pattern {
            PatternKind::Send => {
                let sub = self
                    .session
                    .declare_subscriber(self.keys.send(addr))
                    .callback(move |sample| {
                        let (Some(inner), Some(export)) = (wi.upgrade(), we.upgrade()) else { return };
                        inner.arrived(sample.key_expr().as_str(), sample.attachment());
                        if !inner.admit(sample.attachment()) {
                            return;
                        }
                        inner.received.fetch_add(1, Ordering::Relaxed);
                        match export.served.serve_send(&sample.payload().to_bytes()) {
                            Ok(()) => {}
                            Err(PatternError::Decode(m)) => inner.bad(&topic, &m),
                            Err(e) => tracing::debug!("{topic}: {e}"),
                        }
                    })
                    .wait()?;
                entities.push(Box::new(sub));
            }
            PatternKind::Query | PatternKind::State | PatternKind::Wiring => {
                let q = self
                    .session
                    .declare_queryable(self.keys.request(addr))
                    .callback(move |query| {
                        let (Some(inner), Some(export)) = (wi.upgrade(), we.upgrade()) else { return };
                        let Some(query) = inner.admit_query(query) else { return };
                        inner.received.fetch_add(1, Ordering::Relaxed);
                        let payload = query.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                        let mut answer = Arc::clone(&export.served).serve_request(&payload);
                        // A request refused at once (undecodable, say) is answered here and
                        // holds nothing: a stream of them costs no memory, however fast.
                        if let Some(reply) = (&mut answer).now_or_never() {
                            inner.answer(query, &topic, reply);
                            return;
                        }
                        // One a component answers later waits in a task, and at most
                        // MAX_REQUESTS_IN_FLIGHT do.
                        let Ok(permit) = Arc::clone(&inner.requests_in_flight).try_acquire_owned() else {
                            inner.refuse_busy(query, &topic);
                            return;
                        };
                        let topic = topic.clone();
                        inner.runtime.clone().spawn(async move {
                            let reply = answer.await;
                            inner.answer(query, &topic, reply);
                            drop(permit);
                        });
                    })
                    .wait()?;
                entities.push(Box::new(q));
            }
            PatternKind::PushNewest | PatternKind::PushTimed => {
                let key = self.keys.subscribe(addr);
                entities.push(self.control_queryable(
                    key,
                    addr,
                    export,
                    "orsa.SubscribeRequest/1",
                    Inner::handle_subscribe,
                )?);
            }
            PatternKind::Event => {
                let key = self.keys.activate(addr);
                entities.push(self.control_queryable(
                    key,
                    addr,
                    export,
                    "orsa.ActivateRequest/1",
                    Inner::handle_activate,
                )?);
            }
        }
        let token =
            self.session.liveliness().declare_token(self.keys.service_token(&self.zid, addr, info)).wait()?;
        entities.push(Box::new(token));
        Ok(entities)
    }

    /// A queryable for a control message `R` of a service hosted here, answered at once with
    /// `{ok: null}` or the error.
    pub(crate) fn control_queryable<R: serde::de::DeserializeOwned + 'static>(
        self: &Arc<Self>,
        key: String,
        addr: &ServiceAddr,
        export: &Arc<Export>,
        what: &'static str,
        handle: fn(&Arc<Inner>, &ServiceAddr, &Arc<Export>, R) -> PatternResult<()>,
    ) -> Result<Entity, zenoh::Error> {
        let (wi, we) = (Arc::downgrade(self), Arc::downgrade(export));
        let addr = addr.clone();
        let q = self
            .session
            .declare_queryable(key)
            .callback(move |query| {
                let (Some(inner), Some(export)) = (wi.upgrade(), we.upgrade()) else { return };
                let Some(query) = inner.admit_query(query) else { return };
                inner.received.fetch_add(1, Ordering::Relaxed);
                let payload = query.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                let result = match decode::<R>(&payload, what) {
                    Ok(req) => {
                        let r = handle(&inner, &addr, &export, req);
                        // The request decoded but what it carries (event parameters) did not.
                        if let Err(PatternError::Decode(m)) = &r {
                            inner.bad(&addr.to_string(), m);
                        }
                        r
                    }
                    Err(e) => {
                        inner.bad(&addr.to_string(), &e);
                        Err(PatternError::Decode(e.to_string()))
                    }
                };
                reply_now(query, result);
            })
            .wait()?;
        Ok(Box::new(q))
    }

    /// A publisher: sensor streams and Send messages drop under congestion (the newest value
    /// wins); event firings (`must_arrive`) block instead, since a lost firing is not sent again.
    pub(crate) fn publisher(&self, key: String, must_arrive: bool) -> PatternResult<Arc<Outlet>> {
        let congestion = if must_arrive { CongestionControl::Block } else { CongestionControl::Drop };
        let publisher = self
            .session
            .declare_publisher(key)
            .express(true)
            .congestion_control(congestion)
            .wait()
            .map_err(link)?;
        let (id, counts) = self.links.outlet(publisher.key_expr().as_str());
        Ok(Arc::new(Outlet {
            publisher,
            congestion,
            matched: std::sync::atomic::AtomicBool::new(false),
            id,
            counts,
        }))
    }

    pub(crate) fn publishing_sink(self: &Arc<Self>, publisher: Arc<Outlet>, audience: Audience) -> ByteSink {
        let weak = Arc::downgrade(self);
        Arc::new(move |bytes: &[u8]| {
            let Some(inner) = weak.upgrade() else { return false };
            if inner.withhold_to_audience(&audience) {
                publisher.counts.withheld();
                return true;
            }
            match publisher.put(&inner.session, bytes.to_vec(), &inner.zid) {
                Ok(()) => {
                    inner.published.fetch_add(1, Ordering::Relaxed);
                    true
                }
                Err(e) => {
                    tracing::debug!("publish on {}: {e}", publisher.key_expr());
                    true
                }
            }
        })
    }

    pub(crate) fn handle_subscribe(
        self: &Arc<Self>,
        addr: &ServiceAddr,
        export: &Arc<Export>,
        req: SubscribeRequest,
    ) -> PatternResult<()> {
        match req {
            SubscribeRequest::Subscribe { every, client, id } => {
                let n = NonZeroU32::new(every)
                    .ok_or_else(|| PatternError::InvalidArgument("every must be at least 1".into()))?;
                let mut streams = export.streams.lock();
                if let Some(s) = streams.get_mut(&every) {
                    s.clients.lock().insert((client, id));
                    return Ok(());
                }
                if streams.len() >= MAX_STREAMS {
                    return Err(PatternError::InvalidArgument(format!(
                        "{addr} already serves {MAX_STREAMS} distinct every-n-th streams"
                    )));
                }
                let publisher = self.publisher(self.keys.stream(addr, n), false)?;
                let clients: Clients = Arc::new(Mutex::new(BTreeSet::from([(client, id)])));
                let sink = self.publishing_sink(publisher, Audience::Clients(Arc::clone(&clients)));
                let sub = Arc::clone(&export.served).serve_subscribe(n, sink)?;
                streams.insert(every, Stream { clients, _sub: sub });
                Ok(())
            }
            SubscribeRequest::Unsubscribe { client, id } => {
                let key = (client, id);
                export.streams.lock().retain(|_, s| {
                    let mut clients = s.clients.lock();
                    clients.remove(&key);
                    !clients.is_empty()
                });
                Ok(())
            }
        }
    }

    pub(crate) fn handle_activate(
        self: &Arc<Self>,
        _addr: &ServiceAddr,
        export: &Arc<Export>,
        req: ActivateRequest,
    ) -> PatternResult<()> {
        match req {
            ActivateRequest::Activate { mode, params, client, id } => {
                let mut acts = export.activations.lock();
                let key = (client, id);
                if acts.contains_key(&key) {
                    return Ok(());
                }
                let publisher = self.publisher(self.keys.firings(&key.0, key.1), true)?;
                let sink = self.publishing_sink(publisher, Audience::Client(key.0.clone()));
                let sub = Arc::clone(&export.served).serve_activate(mode, &params, sink)?;
                acts.insert(key, sub);
                Ok(())
            }
            ActivateRequest::Deactivate { client, id } => {
                export.activations.lock().remove(&(client, id));
                Ok(())
            }
        }
    }
}

pub(crate) type Entity = Box<dyn std::any::Any + Send + Sync>;

/// Who a publishing sink's messages are for: the clients of a stream, or one client.
pub(crate) enum Audience {
    Clients(Clients),
    Client(String),
}

/// A declared publisher, and whether zenoh has matched it with a subscriber yet.
///
/// A declared publisher filters on the writer's side: until the peer's answer to the interest
/// it sends when declared comes back, it believes nobody listens and drops what it is given.
/// So the first message sent right after discovering a service could be lost. Until the
/// publisher is matched, puts go through the session instead, which does not filter; after
/// that, through the publisher. (The first Sends and pushes still lost now and then after
/// discovery were dropped by zenoh's congestion control, not by the filter: the publisher was
/// matched within microseconds; see the queue size in
/// [`NetOptions::zenoh_config`](crate::NetOptions::zenoh_config).)
pub(crate) struct Outlet {
    pub(crate) publisher: zenoh::pubsub::Publisher<'static>,
    pub(crate) congestion: CongestionControl,
    pub(crate) matched: std::sync::atomic::AtomicBool,
    /// Its number in this process, and its figures in the ledger across processes.
    pub(crate) id: u64,
    pub(crate) counts: Arc<crate::links::OutletCounts>,
}

impl Outlet {
    pub(crate) fn put(&self, session: &zenoh::Session, payload: Vec<u8>, zid: &str) -> zenoh::Result<()> {
        let from = crate::links::attachment(zid, self.id, self.counts.next());
        let result = self.put_as(session, payload, from);
        if result.is_err() {
            self.counts.failed();
        }
        result
    }

    fn put_as(
        &self,
        session: &zenoh::Session,
        payload: Vec<u8>,
        from: zenoh::bytes::ZBytes,
    ) -> zenoh::Result<()> {
        if !self.matched.load(Ordering::Acquire) {
            if self.publisher.matching_status().wait().is_ok_and(|m| m.matching()) {
                self.matched.store(true, Ordering::Release);
            } else {
                return session
                    .put(self.publisher.key_expr().clone(), payload)
                    .attachment(from)
                    .express(true)
                    .congestion_control(self.congestion)
                    .wait();
            }
        }
        self.publisher.put(payload).attachment(from).wait()
    }

    pub(crate) fn key_expr(&self) -> &zenoh::key_expr::KeyExpr<'static> {
        self.publisher.key_expr()
    }
}

/// The most distinct every-n-th streams one push service serves to peers (each is a publisher).
pub(crate) const MAX_STREAMS: usize = 64;
/// Answers `query` with `result` now, on the calling thread (zenoh's own `reply().await` does
/// the same work: a task would only add a queue that a flood of requests could fill).
pub(crate) fn reply_now<T: Serialize>(query: zenoh::query::Query, result: PatternResult<T>) {
    let bytes = encode(&Reply::from_result(result));
    if let Err(e) = query.reply(query.key_expr().clone(), bytes).wait() {
        tracing::debug!("cannot reply: {e}");
    }
}

/// The most requests from peers that wait for a component's answer at once. Each waits in a
/// task holding the request (about 1 KB with zenoh's share); beyond this, a request is refused
/// at once (`refused_busy` in the stats). A robot's peers have a few requests out at a time.
pub(crate) const MAX_REQUESTS_IN_FLIGHT: usize = 256;

impl Inner {
    /// Answers a request to `topic` with the reply bytes a service produced, counting a
    /// decode error; unless the requester was cut off meanwhile.
    pub(crate) fn answer(&self, query: zenoh::query::Query, topic: &str, reply: Vec<u8>) {
        if let Ok(Reply::Err(f)) = decode::<Reply<serde::de::IgnoredAny>>(&reply, "reply")
            && f.code == "decode"
        {
            self.bad(topic, &f.message);
        }
        // Cut off while the request was being served: the answer is lost.
        let Some(query) = self.answerable(query) else { return };
        if let Err(e) = query.reply(query.key_expr().clone(), reply).wait() {
            tracing::debug!("{topic}: cannot reply: {e}");
        }
    }

    /// Refuses a request to `topic` because [`MAX_REQUESTS_IN_FLIGHT`] are waiting already.
    pub(crate) fn refuse_busy(&self, query: zenoh::query::Query, topic: &str) {
        self.refused_busy.fetch_add(1, Ordering::Relaxed);
        let why = format!(
            "{topic} refused the request: {MAX_REQUESTS_IN_FLIGHT} requests from peers are being served already"
        );
        self.bad_log.warn(|| why.clone());
        let failure =
            orsa_actors::wire::WireFailure { code: "overloaded".into(), message: why, detail: Vec::new() };
        let bytes = encode(&Reply::<()>::Err(failure));
        if let Err(e) = query.reply(query.key_expr().clone(), bytes).wait() {
            tracing::debug!("{topic}: cannot reply: {e}");
        }
    }
}
