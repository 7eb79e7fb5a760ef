//! The zenoh session and discovery: opening it, announcing this process and its services,
//! following peers' tokens (services and processes appearing and going), renewing what this
//! process holds at a peer when its service comes back, and the transport's traffic figures.

use crate::gate::Gate;
use crate::keys::{Announced, Keys, Process};
use crate::options::{NetError, NetOptions};
use crate::serve::{Export, Outlet};
use orsa_actors::addr::ServiceAddr;
use orsa_actors::wire::{Reply, decode, encode};
use orsa_actors::{PatternError, PatternResult, Registry};
use parking_lot::{Mutex, RwLock};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use zenoh::Wait as _;
use zenoh::sample::SampleKind;

/// Traffic figures of one transport.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetStats {
    /// Messages published (send, push streams, firings).
    pub published: u64,
    /// Messages received from peers (send, stream updates, firings, requests).
    pub received: u64,
    /// Messages from peers that failed to decode (dropped, counted, logged).
    pub decode_errors: u64,
    /// Requests from peers refused because as many as this process serves at once were
    /// waiting for an answer already (absent from older peers' figures: 0).
    #[serde(default)]
    pub refused_busy: u64,
    /// Numbered messages from peers that never arrived, as far as this process can tell (the
    /// sum of [`LinkLedger`](crate::LinkLedger)'s `missing`; absent from older peers: 0).
    #[serde(default)]
    pub missing: u64,
    /// Numbered messages from peers that arrived more than once (absent from older peers: 0).
    #[serde(default)]
    pub duplicated: u64,
}

/// A subscription or activation this process holds at a peer, kept to renew it when the
/// service reappears.
pub(crate) struct Held {
    pub(crate) addr: ServiceAddr,
    pub(crate) key: String,
    pub(crate) payload: Vec<u8>,
}

/// While waiting for a service to go, how often the process announcing it is asked whether
/// it still does ([`ZenohTransport::wait_gone`]).
pub const GONE_RECHECK: Duration = Duration::from_secs(1);

pub(crate) type ProcessLost = Box<dyn Fn(&Process) + Send + Sync>;

pub(crate) struct Inner {
    pub(crate) session: zenoh::Session,
    pub(crate) keys: Keys,
    pub(crate) zid: String,
    /// This process's zenoh id as the attachment of everything it sends.
    pub(crate) me: zenoh::bytes::ZBytes,
    pub(crate) gate: Gate,
    /// The delivery ledger across processes.
    pub(crate) links: crate::links::Links,
    pub(crate) registry: Registry,
    pub(crate) runtime: tokio::runtime::Handle,
    /// Services announced by peers.
    pub(crate) remote: RwLock<BTreeMap<ServiceAddr, Announced>>,
    /// Processes announced by peers (and this one).
    pub(crate) processes: RwLock<BTreeMap<String, String>>,
    pub(crate) exports: Mutex<BTreeMap<ServiceAddr, Arc<Export>>>,
    pub(crate) senders: Mutex<HashMap<ServiceAddr, Arc<Outlet>>>,
    pub(crate) held: Mutex<BTreeMap<u64, Held>>,
    pub(crate) next_id: AtomicU64,
    pub(crate) published: AtomicU64,
    pub(crate) received: AtomicU64,
    pub(crate) decode_errors: AtomicU64,
    /// Requests from peers waiting for a component's answer, at most
    /// [`MAX_REQUESTS_IN_FLIGHT`](crate::serve::MAX_REQUESTS_IN_FLIGHT).
    pub(crate) requests_in_flight: Arc<tokio::sync::Semaphore>,
    pub(crate) refused_busy: AtomicU64,
    /// Lines about malformed messages and tokens: a few a second, the rest counted.
    pub(crate) bad_log: orsa_actors::logbudget::LogBudget,
    pub(crate) discovery: tokio::sync::watch::Sender<u64>,
    pub(crate) on_process_lost: Mutex<Vec<ProcessLost>>,
    pub(crate) on_process_found: Mutex<Vec<ProcessLost>>,
}

/// orsa's zenoh transport. Cheap to clone.
#[derive(Clone)]
pub struct ZenohTransport {
    pub(crate) inner: Arc<Inner>,
    _entities: Arc<Vec<Box<dyn std::any::Any + Send + Sync>>>,
}

impl std::fmt::Debug for ZenohTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTransport").field("zid", &self.inner.zid).finish_non_exhaustive()
    }
}

pub(crate) fn link(e: impl std::fmt::Display) -> PatternError {
    PatternError::Link(e.to_string())
}

impl ZenohTransport {
    /// Opens a zenoh session with `options`, announces this process as `role`, starts
    /// discovery, and installs the transport on `registry` (which offers peers every service
    /// hosted here). Needs a multi-thread tokio runtime.
    pub async fn open(registry: &Registry, options: &NetOptions, role: &str) -> Result<Self, NetError> {
        let keys = Keys::new(&options.prefix).map_err(|e| NetError::Config(e.to_string()))?;
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
            links: crate::links::Links::default(),
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
            requests_in_flight: Arc::new(tokio::sync::Semaphore::new(crate::serve::MAX_REQUESTS_IN_FLIGHT)),
            refused_busy: AtomicU64::new(0),
            bad_log: orsa_actors::logbudget::LogBudget::hostile_input(),
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
        // This process is announced after it follows the others' tokens: a peer that reacts to
        // its arrival (a robot stopping its fallback master for a new executive) withdraws
        // tokens this session is already following, not ones it is still being told about.
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
        let stats = inner
            .session
            .declare_queryable(inner.keys.stats(&inner.zid))
            .callback(move |query| {
                let Some(inner) = weak.upgrade() else { return };
                let Some(query) = inner.admit_query(query) else { return };
                let figures = inner.stats();
                // Reply on this process's own key, so a wildcard query tells the processes apart.
                let key = inner.keys.stats(&inner.zid);
                let bytes = encode(&Reply::from_result(Ok::<_, PatternError>(figures)));
                if let Err(e) = query.reply(key, bytes).wait() {
                    tracing::debug!("cannot reply with the stats: {e}");
                }
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
        self.inner.stats()
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

    /// Waits until no peer announces `addr` any more, at most `timeout`; whether it is gone.
    ///
    /// What this process knows of peers' services comes from zenoh's liveliness notifications.
    /// A token withdrawn while this session was still learning the tokens already declared
    /// (it had just opened) can be notified gone and then present: zenoh then shows it live
    /// for good. So while it waits, every [`GONE_RECHECK`] this asks the announcing process what it
    /// announces now (a liveliness query), and forgets the service if that process answers
    /// without it.
    pub async fn wait_gone(&self, addr: &ServiceAddr, timeout: Duration) -> bool {
        let mut changes = self.inner.discovery.subscribe();
        let present = || self.inner.remote.read().contains_key(addr);
        let wait = async {
            let mut recheck =
                tokio::time::interval_at(tokio::time::Instant::now() + GONE_RECHECK, GONE_RECHECK);
            recheck.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            while present() {
                tokio::select! {
                    changed = changes.changed() => if changed.is_err() { return },
                    _ = recheck.tick() => self.inner.recheck(addr, GONE_RECHECK).await,
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
    pub(crate) fn stats(&self) -> NetStats {
        let links = self.link_ledger();
        NetStats {
            published: self.published.load(Ordering::Relaxed),
            received: self.received.load(Ordering::Relaxed),
            decode_errors: self.decode_errors.load(Ordering::Relaxed) + self.registry.decode_errors(),
            refused_busy: self.refused_busy.load(Ordering::Relaxed),
            missing: links.missing(),
            duplicated: links.duplicates(),
        }
    }

    pub(crate) fn bad(&self, from: &str, e: &dyn std::fmt::Display) {
        self.decode_errors.fetch_add(1, Ordering::Relaxed);
        self.bad_log.warn(|| format!("dropped an undecodable message on {from}: {e}"));
    }

    pub(crate) fn on_service_token(self: &Arc<Self>, key: &str, kind: SampleKind) {
        let Some(a) = self.keys.parse_service_token(key) else {
            self.bad_log.warn(|| format!("ignoring a malformed service token '{key}'"));
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

    /// Asks the process that announced `addr` which tokens it holds now (at most `timeout`);
    /// forgets `addr` if that process answers (its process token among the replies) and
    /// `addr` is not among them, and nothing about `addr` changed meanwhile. A process that
    /// does not answer proves nothing: the announcement stays.
    pub(crate) async fn recheck(self: &Arc<Self>, addr: &ServiceAddr, timeout: Duration) {
        let Some(host) = self.remote.read().get(addr).map(|a| a.host.clone()) else { return };
        let version = *self.discovery.borrow();
        let query = self.session.liveliness().get(self.keys.tokens_of(&host)).timeout(timeout);
        let Ok(replies) = query.await else { return };
        let (mut answered, mut still) = (false, false);
        while let Ok(reply) = replies.recv_async().await {
            let Ok(sample) = reply.result() else { continue };
            let key = sample.key_expr().as_str();
            if self.keys.parse_process_token(key).is_some_and(|p| p.zid == host) {
                answered = true;
            } else if self.keys.parse_service_token(key).is_some_and(|a| a.host == host && a.addr == *addr) {
                still = true;
            }
        }
        if !answered || still {
            return;
        }
        let mut remote = self.remote.write();
        if *self.discovery.borrow() != version || remote.get(addr).is_none_or(|a| a.host != host) {
            return;
        }
        remote.remove(addr);
        drop(remote);
        tracing::warn!(%addr, %host, "zenoh still showed this service, which its process no longer announces: forgotten");
        self.discovery.send_modify(|v| *v += 1);
    }

    pub(crate) fn on_process_token(self: &Arc<Self>, key: &str, kind: SampleKind) {
        let Some(p) = self.keys.parse_process_token(key) else {
            self.bad_log.warn(|| format!("ignoring a malformed process token '{key}'"));
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
    pub(crate) fn renew(self: &Arc<Self>, addr: &ServiceAddr) {
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
    pub(crate) fn control(self: &Arc<Self>, addr: &ServiceAddr, key: String, payload: Vec<u8>) {
        if self.withhold_to(addr) {
            return;
        }
        let inner = Arc::clone(self);
        self.runtime.spawn(async move {
            match inner.get(&key, payload, Duration::from_secs(5)).await {
                Ok(bytes) => {
                    if let Err(e) = orsa_actors::wire::decode_reply::<()>(
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

    pub(crate) async fn get(&self, key: &str, payload: Vec<u8>, timeout: Duration) -> PatternResult<Vec<u8>> {
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

    pub(crate) fn hold(self: &Arc<Self>, id: u64, addr: &ServiceAddr, key: String, payload: Vec<u8>) -> u64 {
        self.held.lock().insert(id, Held { addr: addr.clone(), key: key.clone(), payload: payload.clone() });
        self.control(addr, key, payload);
        id
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_actors::send::SendServer;
    use orsa_actors::service::SendService;
    use orsa_actors::{Sink, Stamped};

    const SPEED: SendService<f64> = SendService::new("speed");

    async fn pair(prefix: &str) -> (Registry, ZenohTransport, ZenohTransport) {
        let port =
            std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
        let a = Registry::new();
        let server = NetOptions {
            listen: vec![format!("tcp/127.0.0.1:{port}")],
            prefix: prefix.into(),
            ..NetOptions::default()
        };
        let client = NetOptions {
            connect: vec![format!("tcp/127.0.0.1:{port}")],
            prefix: prefix.into(),
            ..NetOptions::default()
        };
        let ta = ZenohTransport::open(&a, &server, "robot").await.expect("open a");
        let tb = ZenohTransport::open(&Registry::new(), &client, "executive").await.expect("open b");
        (a, ta, tb)
    }

    /// What zenoh leaves behind when a token's withdrawal overtakes its declaration: `addr`
    /// shown as announced by `host` in `t`'s picture of the network.
    fn left_behind(t: &ZenohTransport, host: &str, addr: &ServiceAddr) {
        let like = t.inner.remote.read().values().next().cloned().expect("something announced");
        let stale = Announced { host: host.to_string(), addr: addr.clone(), info: like.info };
        t.inner.remote.write().insert(addr.clone(), stale);
    }

    /// A service shown as announced by a live process that no longer announces it is
    /// forgotten by `wait_gone` within about one recheck; one it still announces, or one shown
    /// for a process that does not answer, is not.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn wait_gone_forgets_what_the_announcing_process_no_longer_announces() {
        let (a, ta, tb) = pair("t_gone").await;
        let (tx, _rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
        SendServer::<f64>::register(&a, SPEED.on("robot"), Sink::channel(tx)).expect("send server");
        let speed = SPEED.on("robot").untyped();
        tb.wait_for(std::slice::from_ref(&speed), Duration::from_secs(10)).await.expect("discovered");

        let ghost = ServiceAddr::new("fallback", "goal");
        left_behind(&tb, ta.zid(), &ghost);
        assert!(tb.remote_services().iter().any(|s| s.addr == ghost), "shown as announced");
        let t0 = tokio::time::Instant::now();
        assert!(tb.wait_gone(&ghost, 4 * GONE_RECHECK).await, "forgotten: its process answers without it");
        assert!(t0.elapsed() < 3 * GONE_RECHECK, "within about one recheck: {:?}", t0.elapsed());

        assert!(!tb.wait_gone(&speed, 3 * GONE_RECHECK).await, "still announced: kept");
        left_behind(&tb, "0123456789abcdef0123456789abcdef", &ghost);
        assert!(!tb.wait_gone(&ghost, 3 * GONE_RECHECK).await, "its process does not answer: proves nothing");
        drop(ta);
    }
}
