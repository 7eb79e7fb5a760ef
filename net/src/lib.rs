//! # orsa-net: the patterns across processes and hosts, over zenoh
//!
//! [`ZenohTransport`] implements orsa's [transport seam](orsa_actors::transport): install it on
//! a [`Registry`] and every client of that registry reaches services hosted by other processes
//! with the same API as in-process, while services hosted here become reachable by peers.
//! Peers in the same process keep talking through actor mailboxes; zenoh is used only for what
//! crosses a process boundary.
//!
//! | pattern | zenoh entity | key (under `orsa/v1/svc/<component>/<service>/`) |
//! |---|---|---|
//! | Send | publication (express) | `send` |
//! | Query, State, Wiring | queryable | `request` |
//! | Push newest, Push timed | publication per distinct every-n-th (express, newest wins) + queryable for subscription control | `push/<n>`, `subscribe` |
//! | Event | queryable for activation control; firings published to the client | `activate`, `orsa/v1/fire/<client>/<id>` |
//!
//! Discovery and peer loss use liveliness tokens: one per service
//! (`orsa/v1/alive/svc/<host>/<component>/<service>/<pattern>/<types>`) and one per process
//! (`orsa/v1/alive/proc/<zid>/<role>`). When a process disappears, the streams and activations
//! it held are dropped at the source; when a service reappears (its host restarted), clients
//! subscribe and activate again by themselves.
//!
//! Every subscription's every-n-th is counted at the source: a remote subscriber at n = 10
//! receives a stream published at a tenth of the rate. Remote subscribers with the same n
//! share one stream. The wire format is documented in `docs/wire-format.md`.
//!
//! Every message orsa sends carries its sender's zenoh id as the zenoh attachment, so a
//! receiver knows which process (and so which role) it comes from. That is what
//! [`ZenohTransport::cut_link`] uses to cut this process off from the processes of a role
//! while the zenoh session stays up (fault injection, see [`gate`](ZenohTransport::cut_link)).
//! A process may also publish a heartbeat ([`NetOptions::heartbeat`], [`ZenohTransport::on_heartbeat`])
//! so that a peer notices a silent link faster than zenoh's lease.

mod gate;
mod heartbeat;
mod keys;
mod options;

pub use gate::LinkCutStats;
pub use heartbeat::{Heartbeat, HeartbeatWatch};
pub use keys::{Announced, Keys, Process, pattern_name};
pub use options::{NetError, NetOptions};

use futures::future::BoxFuture;
use gate::Gate;
use orsa_actors::addr::{ServiceAddr, ServiceInfo};
use orsa_actors::event::EventMode;
use orsa_actors::transport::{ByteSink, Served, Subscription, Transport};
use orsa_actors::wire::{Reply, decode, encode};
use orsa_actors::{PatternError, PatternKind, PatternResult, Registry};
use parking_lot::{Mutex, RwLock};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use zenoh::Wait as _;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;

/// Subscription control, sent to `.../subscribe`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum SubscribeRequest {
    /// Start (or keep) the stream of every `every`-th update for this client subscription.
    Subscribe {
        /// Every n-th update.
        every: u32,
        /// The subscriber's zenoh id.
        client: String,
        /// The subscription's id within the client.
        id: u64,
    },
    /// End a client subscription.
    Unsubscribe {
        /// The subscriber's zenoh id.
        client: String,
        /// The subscription's id within the client.
        id: u64,
    },
}

/// Activation control, sent to `.../activate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum ActivateRequest {
    /// Activate with encoded parameters; firings go to `orsa/v1/fire/<client>/<id>`.
    Activate {
        /// `single` or `continuous`.
        mode: EventMode,
        /// The CBOR encoding of the parameter object.
        #[serde(with = "serde_bytes_compat")]
        params: Vec<u8>,
        /// The client's zenoh id.
        client: String,
        /// The activation's id within the client.
        id: u64,
    },
    /// End an activation.
    Deactivate {
        /// The client's zenoh id.
        client: String,
        /// The activation's id within the client.
        id: u64,
    },
}

/// CBOR byte strings for `Vec<u8>` (serde would otherwise write an array of integers).
mod serde_bytes_compat {
    use serde::{Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[u8], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(v)
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Vec<u8>;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
                Ok(v.to_vec())
            }
            fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Vec<u8>, E> {
                Ok(v)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut a: A) -> Result<Vec<u8>, A::Error> {
                let mut out = Vec::new();
                while let Some(b) = a.next_element::<u8>()? {
                    out.push(b);
                }
                Ok(out)
            }
        }
        d.deserialize_bytes(V)
    }
}

/// Traffic figures of one transport.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetStats {
    /// Messages published (send, push streams, firings).
    pub published: u64,
    /// Messages received from peers (send, stream updates, firings, requests).
    pub received: u64,
    /// Messages from peers that failed to decode (dropped, counted, logged).
    pub decode_errors: u64,
}

type ClientKey = (String, u64);
type Clients = Arc<Mutex<BTreeSet<ClientKey>>>;

/// One every-n-th stream of a push service hosted here.
struct Stream {
    /// Shared with the stream's publishing sink, which withholds updates whose every client
    /// is cut off.
    clients: Clients,
    _sub: Subscription,
}

/// A service hosted here and offered to peers.
struct Export {
    served: Arc<dyn Served>,
    /// zenoh entities (subscriber, queryables, token): dropping them undeclares them.
    entities: Mutex<Vec<Entity>>,
    streams: Mutex<BTreeMap<u32, Stream>>,
    activations: Mutex<HashMap<ClientKey, Subscription>>,
}

/// A subscription or activation this process holds at a peer, kept to renew it when the
/// service reappears.
struct Held {
    addr: ServiceAddr,
    key: String,
    payload: Vec<u8>,
}

struct Inner {
    session: zenoh::Session,
    keys: Keys,
    zid: String,
    /// This process's zenoh id as the attachment of everything it sends.
    me: zenoh::bytes::ZBytes,
    gate: Gate,
    registry: Registry,
    runtime: tokio::runtime::Handle,
    /// Services announced by peers.
    remote: RwLock<BTreeMap<ServiceAddr, Announced>>,
    /// Processes announced by peers (and this one).
    processes: RwLock<BTreeMap<String, String>>,
    exports: Mutex<BTreeMap<ServiceAddr, Arc<Export>>>,
    senders: Mutex<HashMap<ServiceAddr, Arc<Outlet>>>,
    held: Mutex<BTreeMap<u64, Held>>,
    next_id: AtomicU64,
    published: AtomicU64,
    received: AtomicU64,
    decode_errors: AtomicU64,
    discovery: tokio::sync::watch::Sender<u64>,
    on_process_lost: Mutex<Vec<ProcessLost>>,
    on_process_found: Mutex<Vec<ProcessLost>>,
}

/// orsa's zenoh transport. Cheap to clone.
#[derive(Clone)]
pub struct ZenohTransport {
    inner: Arc<Inner>,
    _entities: Arc<Vec<Box<dyn std::any::Any + Send + Sync>>>,
}

impl std::fmt::Debug for ZenohTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTransport").field("zid", &self.inner.zid).finish_non_exhaustive()
    }
}

fn link(e: impl std::fmt::Display) -> PatternError {
    PatternError::Link(e.to_string())
}

impl ZenohTransport {
    /// Opens a zenoh session with `options`, announces this process as `role`, starts
    /// discovery, and installs the transport on `registry` (which offers peers every service
    /// hosted here). Needs a multi-thread tokio runtime.
    pub async fn open(registry: &Registry, options: &NetOptions, role: &str) -> Result<Self, NetError> {
        let keys = Keys::new(&options.prefix).map_err(NetError::Config)?;
        let config = options.zenoh_config()?;
        let session = zenoh::open(config).await.map_err(|e| NetError::Open(e.to_string()))?;
        let zid = session.zid().to_string();
        let runtime = tokio::runtime::Handle::current();
        let inner = Arc::new(Inner {
            session,
            keys,
            me: zenoh::bytes::ZBytes::from(zid.clone()),
            zid,
            gate: Gate::default(),
            registry: registry.clone(),
            runtime,
            remote: RwLock::new(BTreeMap::new()),
            processes: RwLock::new(BTreeMap::new()),
            exports: Mutex::new(BTreeMap::new()),
            senders: Mutex::new(HashMap::new()),
            held: Mutex::new(BTreeMap::new()),
            next_id: AtomicU64::new(1),
            published: AtomicU64::new(0),
            received: AtomicU64::new(0),
            decode_errors: AtomicU64::new(0),
            discovery: tokio::sync::watch::Sender::new(0),
            on_process_lost: Mutex::new(Vec::new()),
            on_process_found: Mutex::new(Vec::new()),
        });
        let mut entities: Vec<Box<dyn std::any::Any + Send + Sync>> = Vec::new();
        // The heartbeat starts before the process token is declared: a peer that sees this
        // process also hears it beat.
        if let Some(period) = options.heartbeat {
            entities.push(Box::new(inner.start_heartbeat(role, period).await?));
        }
        let proc_key = inner.keys.process_token(&inner.zid, role);
        entities.push(Box::new(
            inner
                .session
                .liveliness()
                .declare_token(proc_key)
                .await
                .map_err(|e| NetError::Open(e.to_string()))?,
        ));
        let weak = Arc::downgrade(&inner);
        let services = inner
            .session
            .liveliness()
            .declare_subscriber(inner.keys.all_services())
            .history(true)
            .callback(move |sample| {
                if let Some(inner) = weak.upgrade() {
                    inner.on_service_token(sample.key_expr().as_str(), sample.kind());
                }
            })
            .await
            .map_err(|e| NetError::Open(e.to_string()))?;
        entities.push(Box::new(services));
        let weak = Arc::downgrade(&inner);
        let procs = inner
            .session
            .liveliness()
            .declare_subscriber(inner.keys.all_processes())
            .history(true)
            .callback(move |sample| {
                if let Some(inner) = weak.upgrade() {
                    inner.on_process_token(sample.key_expr().as_str(), sample.kind());
                }
            })
            .await
            .map_err(|e| NetError::Open(e.to_string()))?;
        entities.push(Box::new(procs));
        let weak = Arc::downgrade(&inner);
        let stats = inner
            .session
            .declare_queryable(inner.keys.stats(&inner.zid))
            .callback(move |query| {
                let Some(inner) = weak.upgrade() else { return };
                let Some(query) = inner.admit_query(query) else { return };
                let figures = NetStats {
                    published: inner.published.load(Ordering::Relaxed),
                    received: inner.received.load(Ordering::Relaxed),
                    decode_errors: inner.decode_errors.load(Ordering::Relaxed)
                        + inner.registry.decode_errors(),
                };
                // Reply on this process's own key, so a wildcard query tells the processes apart.
                let key = inner.keys.stats(&inner.zid);
                let bytes = encode(&Reply::from_result(Ok::<_, PatternError>(figures)));
                inner.runtime.spawn(async move {
                    if let Err(e) = query.reply(key, bytes).await {
                        tracing::debug!("cannot reply with the stats: {e}");
                    }
                });
            })
            .await
            .map_err(|e| NetError::Open(e.to_string()))?;
        entities.push(Box::new(stats));
        let transport = ZenohTransport { inner, _entities: Arc::new(entities) };
        registry.set_transport(Arc::new(transport.clone()));
        tracing::info!(zid = %transport.inner.zid, role, "zenoh transport open");
        Ok(transport)
    }

    /// This process's zenoh id.
    pub fn zid(&self) -> &str {
        &self.inner.zid
    }

    /// The key expressions in use.
    pub fn keys(&self) -> &Keys {
        &self.inner.keys
    }

    /// The zenoh session (for raw zenoh traffic beside orsa's, e.g. benchmarks).
    pub fn session(&self) -> &zenoh::Session {
        &self.inner.session
    }

    /// Services announced by peers.
    pub fn remote_services(&self) -> Vec<Announced> {
        self.inner.remote.read().values().cloned().collect()
    }

    /// Live processes (zenoh id, role), this one included.
    pub fn processes(&self) -> Vec<Process> {
        self.inner
            .processes
            .read()
            .iter()
            .map(|(zid, role)| Process { zid: zid.clone(), role: role.clone() })
            .collect()
    }

    /// Traffic figures.
    pub fn stats(&self) -> NetStats {
        NetStats {
            published: self.inner.published.load(Ordering::Relaxed),
            received: self.inner.received.load(Ordering::Relaxed),
            decode_errors: self.inner.decode_errors.load(Ordering::Relaxed)
                + self.inner.registry.decode_errors(),
        }
    }

    /// The traffic figures of every live process (this one included), by zenoh id.
    pub async fn all_stats(&self, timeout: Duration) -> BTreeMap<String, NetStats> {
        let mut out = BTreeMap::new();
        let Ok(replies) = self
            .inner
            .session
            .get(self.inner.keys.all_stats())
            .attachment(self.inner.me.clone())
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(timeout)
            .await
        else {
            return out;
        };
        while let Ok(reply) = replies.recv_async().await {
            let Ok(sample) = reply.result() else { continue };
            let zid = sample.key_expr().as_str().rsplit('/').next().unwrap_or_default().to_string();
            if !self.inner.admit_from(&zid) {
                continue;
            }
            match decode::<Reply<NetStats>>(&sample.payload().to_bytes(), "orsa.NetStats/1") {
                Ok(Reply::Ok(s)) => {
                    out.insert(zid, s);
                }
                Ok(Reply::Err(f)) => tracing::warn!("stats of {zid}: {}", f.message),
                Err(e) => self.inner.bad(&zid, &e),
            }
        }
        out
    }

    /// Calls `f` whenever a peer process disappears (its liveliness token is gone).
    pub fn on_process_lost(&self, f: impl Fn(&Process) + Send + Sync + 'static) {
        self.inner.on_process_lost.lock().push(Box::new(f));
    }

    /// Calls `f` whenever a peer process appears.
    pub fn on_process_found(&self, f: impl Fn(&Process) + Send + Sync + 'static) {
        self.inner.on_process_found.lock().push(Box::new(f));
    }

    /// Cuts (`cut = true`) or restores the link between this process and every process of
    /// `role` (`executive`, `teleop`, `tool`, ...), while the zenoh session stays up: for fault
    /// injection, a partition that zenoh's lease does not see, since liveliness tokens stay.
    ///
    /// While a role is cut, this process:
    /// - drops on arrival every message, stream update, firing, heartbeat and reply that a
    ///   process of that role sent (known by the sender's zenoh id in the attachment, and its
    ///   role by its process token);
    /// - holds unanswered every request (Query, State, Wiring, subscription and activation
    ///   control) from such a process, as if it were lost: the requester times out;
    /// - does not send what is addressed to a service such a process hosts: a Send message is
    ///   lost, a request fails with [`PatternError::Timeout`] after its timeout, a
    ///   subscription or activation request is not sent (it is sent again on restore);
    /// - does not publish stream updates and firings whose every subscriber is such a process.
    ///
    /// Limits: the session, its liveliness tokens and zenoh's keep-alives go on (that is the
    /// point); a push stream shared by a cut and an uncut subscriber (same service, same
    /// every-n-th) still reaches both; this process's own heartbeat still goes out to every
    /// peer; a message without the sender's id (a client that is not orsa's) is not gated; a
    /// process whose token this process has not seen is not recognised. The cut is one
    /// process's view: peers of the cut role still talk to each other.
    pub fn cut_link(&self, role: &str, cut: bool) {
        let inner = &self.inner;
        if !inner.gate.set(role, cut) {
            return;
        }
        tracing::info!(role, cut, "link cut");
        if !cut {
            // Requests held while cut are answered with nothing: the requesters have timed out.
            inner.gate.release(role);
            // Subscriptions and activations held at that role's services are asked for again.
            let hosts: BTreeSet<String> = inner
                .processes
                .read()
                .iter()
                .filter(|(_, r)| r.as_str() == role)
                .map(|(z, _)| z.clone())
                .collect();
            let addrs: Vec<ServiceAddr> = inner
                .remote
                .read()
                .values()
                .filter(|a| hosts.contains(&a.host))
                .map(|a| a.addr.clone())
                .collect();
            for a in addrs {
                inner.renew(&a);
            }
        }
    }

    /// The roles whose link is cut now.
    pub fn cut_roles(&self) -> Vec<String> {
        self.inner.gate.roles()
    }

    /// What link cuts kept from crossing so far.
    pub fn link_cut_stats(&self) -> LinkCutStats {
        self.inner.gate.stats()
    }

    /// Waits until no peer announces `addr` any more, at most `timeout`; whether it is gone.
    pub async fn wait_gone(&self, addr: &ServiceAddr, timeout: Duration) -> bool {
        let mut changes = self.inner.discovery.subscribe();
        let present = || self.inner.remote.read().contains_key(addr);
        let wait = async {
            while present() {
                if changes.changed().await.is_err() {
                    return;
                }
            }
        };
        tokio::time::timeout(timeout, wait).await.is_ok() && !present()
    }

    /// Waits until every address in `addrs` is announced by a peer (or hosted here), at most
    /// `timeout`; answers the ones still missing on timeout.
    pub async fn wait_for(&self, addrs: &[ServiceAddr], timeout: Duration) -> Result<(), Vec<ServiceAddr>> {
        let mut changes = self.inner.discovery.subscribe();
        let missing = || -> Vec<ServiceAddr> {
            addrs
                .iter()
                .filter(|a| {
                    self.inner.registry.local(a).is_none() && !self.inner.remote.read().contains_key(*a)
                })
                .cloned()
                .collect()
        };
        let wait = async {
            loop {
                if missing().is_empty() {
                    return;
                }
                if changes.changed().await.is_err() {
                    return;
                }
            }
        };
        match tokio::time::timeout(timeout, wait).await {
            Ok(()) if missing().is_empty() => Ok(()),
            _ => Err(missing()),
        }
    }

    /// Waits until a process with `role` is live, at most `timeout`.
    pub async fn wait_for_role(&self, role: &str, timeout: Duration) -> bool {
        let mut changes = self.inner.discovery.subscribe();
        let present = || self.inner.processes.read().values().any(|r| r == role);
        let wait = async {
            while !present() {
                if changes.changed().await.is_err() {
                    return;
                }
            }
        };
        tokio::time::timeout(timeout, wait).await.is_ok() && present()
    }

    /// Closes the session: peers see this process's tokens disappear.
    pub async fn close(self) {
        if let Err(e) = self.inner.session.close().await {
            tracing::warn!("closing the zenoh session: {e}");
        }
    }
}

impl Inner {
    fn bad(&self, from: &str, e: &dyn std::fmt::Display) {
        self.decode_errors.fetch_add(1, Ordering::Relaxed);
        tracing::warn!("dropped an undecodable message on {from}: {e}");
    }

    fn on_service_token(self: &Arc<Self>, key: &str, kind: SampleKind) {
        let Some(a) = self.keys.parse_service_token(key) else {
            tracing::warn!("ignoring a malformed service token '{key}'");
            return;
        };
        if a.host == self.zid {
            return;
        }
        let addr = a.addr.clone();
        match kind {
            SampleKind::Put => {
                self.remote.write().insert(addr.clone(), a);
                self.renew(&addr);
            }
            SampleKind::Delete => {
                let mut remote = self.remote.write();
                if remote.get(&addr).is_some_and(|r| r.host == a.host) {
                    remote.remove(&addr);
                }
            }
        }
        self.discovery.send_modify(|v| *v += 1);
    }

    fn on_process_token(self: &Arc<Self>, key: &str, kind: SampleKind) {
        let Some(p) = self.keys.parse_process_token(key) else {
            tracing::warn!("ignoring a malformed process token '{key}'");
            return;
        };
        match kind {
            SampleKind::Put => {
                let new = self.processes.write().insert(p.zid.clone(), p.role.clone()).is_none();
                if new && p.zid != self.zid {
                    for f in self.on_process_found.lock().iter() {
                        f(&p);
                    }
                }
            }
            SampleKind::Delete => {
                self.processes.write().remove(&p.zid);
                // What the lost process held here ends now.
                let exports: Vec<Arc<Export>> = self.exports.lock().values().cloned().collect();
                for e in exports {
                    e.streams.lock().retain(|_, s| {
                        let mut clients = s.clients.lock();
                        clients.retain(|(c, _)| *c != p.zid);
                        !clients.is_empty()
                    });
                    e.activations.lock().retain(|(c, _), _| *c != p.zid);
                }
                tracing::info!(zid = %p.zid, role = %p.role, "peer process lost");
                for f in self.on_process_lost.lock().iter() {
                    f(&p);
                }
            }
        }
        self.discovery.send_modify(|v| *v += 1);
    }

    /// Sends again the subscriptions and activations held at `addr` (its host restarted or
    /// was just discovered). The source treats a repeated request as the same one.
    fn renew(self: &Arc<Self>, addr: &ServiceAddr) {
        let again: Vec<(String, Vec<u8>)> = self
            .held
            .lock()
            .values()
            .filter(|h| h.addr == *addr)
            .map(|h| (h.key.clone(), h.payload.clone()))
            .collect();
        for (key, payload) in again {
            self.control(addr, key, payload);
        }
    }

    /// Sends a control request in the background; failures are logged (renewal repeats it
    /// when the service reappears).
    /// Not sent while the service's host is cut off (it is sent again when the link is
    /// restored).
    fn control(self: &Arc<Self>, addr: &ServiceAddr, key: String, payload: Vec<u8>) {
        if self.withhold_to(addr) {
            return;
        }
        let inner = Arc::clone(self);
        self.runtime.spawn(async move {
            match inner.get(&key, payload, Duration::from_secs(5)).await {
                Ok(bytes) => {
                    if let Err(e) = orsa_actors::wire::decode_reply::<()>(
                        &inner.registry.clock(),
                        &bytes,
                        &ServiceAddr::new("peer", "control"),
                        "control reply",
                    ) {
                        tracing::warn!("{key}: {e}");
                    }
                }
                Err(e) => tracing::debug!("{key}: {e}"),
            }
        });
    }

    async fn get(&self, key: &str, payload: Vec<u8>, timeout: Duration) -> PatternResult<Vec<u8>> {
        let replies = self
            .session
            .get(key)
            .payload(payload)
            .attachment(self.me.clone())
            .timeout(timeout)
            .await
            .map_err(link)?;
        match replies.recv_async().await {
            Ok(reply) => match reply.result() {
                Ok(sample) => {
                    self.received.fetch_add(1, Ordering::Relaxed);
                    Ok(sample.payload().to_bytes().into_owned())
                }
                Err(e) => {
                    let why = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                    // zenoh answers a query whose timeout ran out while its queryable held it
                    // with an error reply saying so: that is a timeout, not a broken link.
                    if why == "Timeout" {
                        Err(PatternError::Timeout)
                    } else {
                        Err(PatternError::Link(format!("{key}: {why}")))
                    }
                }
            },
            // No reply before the timeout: nobody serves the key, or it took too long.
            Err(_) => Err(PatternError::Timeout),
        }
    }

    fn export(self: &Arc<Self>, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>) {
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
    fn declare_entities(
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
                        let answer = Arc::clone(&export.served).serve_request(&payload);
                        let topic = topic.clone();
                        inner.runtime.clone().spawn(async move {
                            let reply = answer.await;
                            if let Ok(Reply::Err(f)) = decode::<Reply<serde::de::IgnoredAny>>(&reply, "reply")
                                && f.code == "decode"
                            {
                                inner.bad(&topic, &f.message);
                            }
                            // Cut off while the request was being served: the answer is lost.
                            let Some(query) = inner.answerable(query) else { return };
                            if let Err(e) = query.reply(query.key_expr().clone(), reply).await {
                                tracing::debug!("{topic}: cannot reply: {e}");
                            }
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
    fn control_queryable<R: serde::de::DeserializeOwned + 'static>(
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
                reply_now(&inner, query, result);
            })
            .wait()?;
        Ok(Box::new(q))
    }

    /// A publisher: sensor streams and Send messages drop under congestion (the newest value
    /// wins); event firings (`must_arrive`) block instead, since a lost firing is not sent again.
    fn publisher(&self, key: String, must_arrive: bool) -> PatternResult<Arc<Outlet>> {
        let congestion = if must_arrive { CongestionControl::Block } else { CongestionControl::Drop };
        let publisher = self
            .session
            .declare_publisher(key)
            .express(true)
            .congestion_control(congestion)
            .wait()
            .map_err(link)?;
        Ok(Arc::new(Outlet { publisher, congestion, matched: std::sync::atomic::AtomicBool::new(false) }))
    }

    fn publishing_sink(self: &Arc<Self>, publisher: Arc<Outlet>, audience: Audience) -> ByteSink {
        let weak = Arc::downgrade(self);
        Arc::new(move |bytes: &[u8]| {
            let Some(inner) = weak.upgrade() else { return false };
            if inner.withhold_to_audience(&audience) {
                return true;
            }
            match publisher.put(&inner.session, bytes.to_vec(), &inner.me) {
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

    fn handle_subscribe(
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

    fn handle_activate(
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

    fn hold(self: &Arc<Self>, id: u64, addr: &ServiceAddr, key: String, payload: Vec<u8>) -> u64 {
        self.held.lock().insert(id, Held { addr: addr.clone(), key: key.clone(), payload: payload.clone() });
        self.control(addr, key, payload);
        id
    }
}

type Entity = Box<dyn std::any::Any + Send + Sync>;

/// Who a publishing sink's messages are for: the clients of a stream, or one client.
enum Audience {
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
/// matched within microseconds; see the queue size in [`NetOptions::zenoh_config`].)
struct Outlet {
    publisher: zenoh::pubsub::Publisher<'static>,
    congestion: CongestionControl,
    matched: std::sync::atomic::AtomicBool,
}

impl Outlet {
    fn put(
        &self,
        session: &zenoh::Session,
        payload: Vec<u8>,
        from: &zenoh::bytes::ZBytes,
    ) -> zenoh::Result<()> {
        if !self.matched.load(Ordering::Acquire) {
            if self.publisher.matching_status().wait().is_ok_and(|m| m.matching()) {
                self.matched.store(true, Ordering::Release);
            } else {
                return session
                    .put(self.publisher.key_expr().clone(), payload)
                    .attachment(from.clone())
                    .express(true)
                    .congestion_control(self.congestion)
                    .wait();
            }
        }
        self.publisher.put(payload).attachment(from.clone()).wait()
    }

    fn key_expr(&self) -> &zenoh::key_expr::KeyExpr<'static> {
        self.publisher.key_expr()
    }
}

/// The most distinct every-n-th streams one push service serves to peers (each is a publisher).
const MAX_STREAMS: usize = 64;
type ProcessLost = Box<dyn Fn(&Process) + Send + Sync>;

fn reply_now<T: Serialize>(inner: &Arc<Inner>, query: zenoh::query::Query, result: PatternResult<T>) {
    let bytes = encode(&Reply::from_result(result));
    inner.runtime.spawn(async move {
        if let Err(e) = query.reply(query.key_expr().clone(), bytes).await {
            tracing::debug!("cannot reply: {e}");
        }
    });
}

/// Ends a subscription or activation held at a peer.
struct Release {
    inner: std::sync::Weak<Inner>,
    addr: ServiceAddr,
    held: u64,
    key: String,
    payload: Vec<u8>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

impl Drop for Release {
    fn drop(&mut self) {
        if let Some(inner) = self.inner.upgrade() {
            inner.held.lock().remove(&self.held);
            if tokio::runtime::Handle::try_current().is_ok() {
                inner.control(&self.addr, std::mem::take(&mut self.key), std::mem::take(&mut self.payload));
            }
        }
    }
}

impl Transport for ZenohTransport {
    fn name(&self) -> &str {
        "zenoh"
    }

    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo> {
        self.inner.remote.read().get(addr).map(|a| a.info.clone())
    }

    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> PatternResult<()> {
        // To a cut-off process: lost on the way, as a one-way message is.
        if self.inner.withhold_to(addr) {
            return Ok(());
        }
        let publisher = {
            let mut senders = self.inner.senders.lock();
            match senders.get(addr) {
                Some(p) => Arc::clone(p),
                None => {
                    let p = self.inner.publisher(self.inner.keys.send(addr), false)?;
                    senders.insert(addr.clone(), Arc::clone(&p));
                    p
                }
            }
        };
        publisher.put(&self.inner.session, payload, &self.inner.me).map_err(link)?;
        self.inner.published.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> BoxFuture<'static, PatternResult<Vec<u8>>> {
        let inner = Arc::clone(&self.inner);
        let key = self.inner.keys.request(addr);
        let addr = addr.clone();
        Box::pin(async move {
            // To a cut-off process: the request is lost, so its answer never comes.
            if inner.withhold_to(&addr) {
                tokio::time::sleep(timeout).await;
                return Err(PatternError::Timeout);
            }
            let answer = inner.get(&key, payload, timeout).await;
            // Cut off while the request was out: the answer is lost.
            if answer.is_ok() && inner.withhold_to(&addr) {
                return Err(PatternError::Timeout);
            }
            answer
        })
    }

    fn subscribe(
        &self,
        addr: &ServiceAddr,
        every: NonZeroU32,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let inner = &self.inner;
        let weak = Arc::downgrade(inner);
        let subscriber = inner
            .session
            .declare_subscriber(inner.keys.stream(addr, every))
            .callback(move |sample| {
                let Some(inner) = weak.upgrade() else { return };
                if !inner.admit(sample.attachment()) {
                    return;
                }
                inner.received.fetch_add(1, Ordering::Relaxed);
                sink(&sample.payload().to_bytes());
            })
            .wait()
            .map_err(link)?;
        let id = inner.next_id.fetch_add(1, Ordering::Relaxed);
        let req = SubscribeRequest::Subscribe { every: every.get(), client: inner.zid.clone(), id };
        let held = inner.hold(id, addr, inner.keys.subscribe(addr), encode(&req));
        let release = SubscribeRequest::Unsubscribe { client: inner.zid.clone(), id };
        Ok(Subscription::new(Release {
            inner: Arc::downgrade(inner),
            addr: addr.clone(),
            held,
            key: inner.keys.subscribe(addr),
            payload: encode(&release),
            _subscriber: subscriber,
        }))
    }

    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: EventMode,
        params: Vec<u8>,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let inner = &self.inner;
        let id = inner.next_id.fetch_add(1, Ordering::Relaxed);
        let weak = Arc::downgrade(inner);
        let subscriber = inner
            .session
            .declare_subscriber(inner.keys.firings(&inner.zid, id))
            .callback(move |sample| {
                let Some(inner) = weak.upgrade() else { return };
                if !inner.admit(sample.attachment()) {
                    return;
                }
                inner.received.fetch_add(1, Ordering::Relaxed);
                if !sink(&sample.payload().to_bytes()) {
                    // Ended (single shot fired, or the receiver is gone): do not renew it.
                    inner.held.lock().remove(&id);
                }
            })
            .wait()
            .map_err(link)?;
        let req = ActivateRequest::Activate { mode, params, client: inner.zid.clone(), id };
        let held = inner.hold(id, addr, inner.keys.activate(addr), encode(&req));
        let release = ActivateRequest::Deactivate { client: inner.zid.clone(), id };
        Ok(Subscription::new(Release {
            inner: Arc::downgrade(inner),
            addr: addr.clone(),
            held,
            key: inner.keys.activate(addr),
            payload: encode(&release),
            _subscriber: subscriber,
        }))
    }

    fn service_added(&self, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>) {
        self.inner.export(addr, info, served);
    }

    fn service_removed(&self, addr: &ServiceAddr) {
        self.inner.exports.lock().remove(addr);
    }
}
