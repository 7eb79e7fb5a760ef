//! Watching a running robot in Foxglove: `--foxglove [ADDR]` serves the recording's views
//! (see [`crate::record::views`]) live, over the Foxglove WebSocket protocol, with the
//! `foxglove` crate's server.
//!
//! - [`tap`]: the control loop's side: a [`Tap`](orsa_actors::tap::Tap) that hands the
//!   messages the views are made from to a thread of their own, through a bounded queue that
//!   drops (and counts) what the viewer's side is too slow for;
//! - [`sink`]: the views' thread writes to the server's channels ([`sink::LiveSink`], a
//!   [`ViewSink`](crate::record::views::ViewSink) like the MCAP recorder);
//! - [`params`]: the seam for live parameters ([`params::LiveParams`]), mapped onto the
//!   protocol's `getParameters`, `setParameters` and parameter subscriptions: every change a
//!   component of this process makes (whoever asked for it: a Foxglove client, `orsa param
//!   set` from another process, a ROS 2 tool) is pushed to the clients subscribed to it, as
//!   is every change made through this server.
//!
//! The server runs on a tokio runtime of its own (one worker thread), so that neither it nor
//! its clients ever run on the control loop's thread. What it does with a slow client is the
//! SDK's: each client has a queue of [`BACKLOG`] messages whose oldest are dropped when it is
//! full, and a client whose control queue (status, advertisements) fills is disconnected.

pub mod params;
pub mod publish;
pub mod sink;
pub mod tap;

use crate::record::views::ViewSetup;
use foxglove::websocket::{Capability, ChannelView, Client, ClientChannel, ServerListener, Status};
use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;

/// Where `--foxglove` listens when given no address: this host only.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";
/// Messages queued per client before the oldest are dropped (the SDK's setting).
pub const BACKLOG: usize = 1024;
/// How long the server may take to bind.
pub const START_TIMEOUT: Duration = Duration::from_secs(5);
/// How often the parameters clients subscribed to are read again, to push the changes no
/// component of this process reported (those of components in other processes, changed by
/// `orsa param set` or another process's clients). A component of another process has no
/// way to tell this server of its changes (the changes are control events of its own
/// process's tap); reading again costs one query per subscribed component a second.
pub const PARAM_POLL: Duration = Duration::from_secs(1);

/// Why the live server could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// Its runtime or thread could not be made.
    #[error("--foxglove {addr}: cannot start the live server's {what}: {source}")]
    Start {
        /// Where it was to listen.
        addr: SocketAddr,
        /// What could not be made.
        what: &'static str,
        /// Why.
        source: std::io::Error,
    },
    /// The server did not bind.
    #[error("--foxglove {addr}: the live server cannot listen there: {problem}")]
    Bind {
        /// Where it was to listen.
        addr: SocketAddr,
        /// Why.
        problem: String,
    },
}

/// What the server's listener and the views share.
#[derive(Debug, Default)]
pub(crate) struct Shared {
    /// Channel subscriptions of every client.
    pub(crate) subscriptions: AtomicUsize,
    /// Set when a client subscribes: the views write what they write once (the world, the
    /// robot, the path) again.
    pub(crate) rewrite: AtomicBool,
    /// Messages the control loop's side dropped because the views' queue was full.
    pub(crate) dropped: AtomicU64,
    /// Whether the first drop was logged.
    pub(crate) warned: AtomicBool,
    /// The server, once it runs: what pushes parameter updates to the clients subscribed to
    /// them (taken out when it stops).
    pub(crate) server: ServerSlot,
    /// The parameters some client subscribed to, each with the value last pushed or read
    /// (none until first read).
    pub(crate) watched: parking_lot::Mutex<BTreeMap<String, Option<foxglove::websocket::Parameter>>>,
    /// Wakes the poller when a client subscribes to parameters, so that it reads them now.
    pub(crate) poll_now: tokio::sync::Notify,
}

impl Shared {
    /// Pushes `parameters`' values to the clients subscribed to them, and notes them as the
    /// values last pushed (so that the poller does not push them again).
    pub(crate) fn publish_parameters(&self, parameters: Vec<foxglove::websocket::Parameter>) {
        {
            let mut watched = self.watched.lock();
            for p in &parameters {
                if let Some(last) = watched.get_mut(&p.name) {
                    *last = Some(p.clone());
                }
            }
        }
        self.server.publish_parameters(parameters);
    }

    /// Reads the watched parameters of components in other processes every [`PARAM_POLL`]
    /// (and when a client subscribes) and pushes those whose value changed since last pushed
    /// or read; the first read of a name only notes its value (the client read it when it
    /// subscribed). Those of this process's components are pushed by the tap as they change.
    async fn poll_parameters(self: Arc<Self>, params: Arc<dyn params::LiveParams>) {
        loop {
            tokio::select! {
                _ = tokio::time::sleep(PARAM_POLL) => {}
                _ = self.poll_now.notified() => {}
            }
            // Only those no component reports as it changes them: the components of other
            // processes.
            let names: Vec<String> =
                self.watched.lock().keys().filter(|n| !params.reports_changes(n)).cloned().collect();
            if names.is_empty() {
                continue;
            }
            let read = params::ParamBridge::get_values(&*params, names).await;
            let changed: Vec<_> = {
                let mut watched = self.watched.lock();
                read.into_iter()
                    .filter(|p| match watched.get_mut(&p.name) {
                        // Unsubscribed meanwhile.
                        None => false,
                        Some(last @ None) => {
                            *last = Some(p.clone());
                            false
                        }
                        Some(Some(last)) if last == p => false,
                        Some(last) => {
                            *last = Some(p.clone());
                            true
                        }
                    })
                    .collect()
            };
            if !changed.is_empty() {
                tracing::debug!("foxglove: {} subscribed parameters changed elsewhere", changed.len());
                self.server.publish_parameters(changed);
            }
        }
    }
}

/// The live server's handle, shared by [`LiveView`], the tap and the parameter bridge.
#[derive(Default)]
pub(crate) struct ServerSlot(parking_lot::Mutex<Option<foxglove::WebSocketServerHandle>>);

impl std::fmt::Debug for ServerSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.lock().is_some() { "ServerSlot(running)" } else { "ServerSlot(none)" })
    }
}

impl ServerSlot {
    /// Pushes `parameters`' values to every client subscribed to them (the SDK keeps the
    /// subscriptions and sends each client only the ones it asked for).
    pub(crate) fn publish_parameters(&self, parameters: Vec<foxglove::websocket::Parameter>) {
        if let Some(server) = self.0.lock().as_ref() {
            server.publish_parameter_values(parameters);
        }
    }
}

/// Keeps [`Shared`] up to date with the clients' subscriptions, and hands what clients
/// publish to the robot (if it takes it: [`publish`]).
struct Listener(Arc<Shared>, Option<Arc<publish::Teleop>>);

impl ServerListener for Listener {
    fn on_client_advertise(&self, client: Client, channel: &ClientChannel) {
        if self.1.is_none() {
            return;
        }
        match publish::kind_of(&channel.topic, &channel.encoding, &channel.schema_name) {
            Ok(kind) => tracing::info!("foxglove: a client publishes {kind:?} commands on {}", channel.topic),
            Err(why) => {
                tracing::warn!("foxglove: {why}");
                client.send_status(Status::warning(why));
            }
        }
    }

    fn on_message_data(&self, client: Client, channel: &ClientChannel, payload: &[u8]) {
        let Some(teleop) = &self.1 else { return };
        let taken = teleop.take(&channel.topic, &channel.encoding, &channel.schema_name, payload);
        if let Err(why) = taken
            && teleop.tell()
        {
            client.send_status(Status::error(why));
        }
    }

    fn on_subscribe(&self, client: Client, channel: ChannelView<'_>) {
        tracing::debug!("foxglove: client {:?} subscribed to {}", client.id(), channel.topic());
        self.0.subscriptions.fetch_add(1, Ordering::AcqRel);
        self.0.rewrite.store(true, Ordering::Release);
    }

    fn on_unsubscribe(&self, client: Client, channel: ChannelView<'_>) {
        tracing::debug!("foxglove: client {:?} unsubscribed from {}", client.id(), channel.topic());
        let _ = self.0.subscriptions.fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| n.checked_sub(1));
    }

    fn on_parameters_subscribe(&self, names: Vec<String>) {
        let mut watched = self.0.watched.lock();
        for name in names {
            watched.entry(name).or_insert(None);
        }
        drop(watched);
        self.0.poll_now.notify_one();
    }

    fn on_parameters_unsubscribe(&self, names: Vec<String>) {
        let mut watched = self.0.watched.lock();
        for name in names {
            watched.remove(&name);
        }
    }

    fn on_client_connect(&self) {
        tracing::info!("foxglove: a client connected");
    }

    fn on_client_disconnect(&self) {
        tracing::info!("foxglove: a client disconnected");
    }
}

/// A running live server and the tap that feeds it. [`LiveView::finish`] stops it.
pub struct LiveView {
    addr: SocketAddr,
    tap: Arc<tap::LiveTap>,
    shared: Arc<Shared>,
    teleop: Option<Arc<publish::Teleop>>,
    runtime: Option<tokio::runtime::Runtime>,
}

impl std::fmt::Debug for LiveView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveView").field("addr", &self.addr).finish()
    }
}

/// What a live server did, for the report of the command that ran it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LiveSummary {
    /// Messages the control loop handed the views.
    pub handed: u64,
    /// Messages dropped because the views' queue was full.
    pub dropped: u64,
    /// Velocity commands clients published, if the server took them.
    pub published: Option<publish::Published>,
}

/// `N messages made into views, M dropped`, and what clients published if they did.
impl std::fmt::Display for LiveSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} messages made into views, {} dropped", self.handed, self.dropped)?;
        match self.published {
            Some(p) if p.taken + p.refused > 0 => write!(
                f,
                "; {} velocity commands from clients handed to teleop, {} refused",
                p.taken, p.refused
            ),
            _ => Ok(()),
        }
    }
}

impl LiveView {
    /// Starts a server on `addr` serving the views `setup` describes, the parameters of
    /// `params` if given (only then does the server say it has parameters), and taking the
    /// velocity commands clients publish to `teleop` if given (only then does it say it takes
    /// client messages).
    pub fn start(
        addr: SocketAddr,
        setup: ViewSetup,
        params: Option<Arc<dyn params::LiveParams>>,
        teleop: Option<Arc<publish::Teleop>>,
    ) -> Result<LiveView, LiveError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("orsa-foxglove")
            .enable_io()
            .enable_time()
            .build()
            .map_err(|source| LiveError::Start { addr, what: "runtime", source })?;
        let context = foxglove::Context::new();
        let shared = Arc::new(Shared::default());
        let mut server = context
            .websocket_server()
            .name(concat!("orsa ", env!("CARGO_PKG_VERSION")))
            .bind(addr.ip().to_string(), addr.port())
            .message_backlog_size(BACKLOG)
            .listener(Arc::new(Listener(Arc::clone(&shared), teleop.clone())))
            .tokio_runtime(runtime.handle());
        if teleop.is_some() {
            server =
                server.capabilities([Capability::ClientPublish]).supported_encodings([publish::ENCODING]);
        }
        if let Some(params) = params {
            runtime.spawn(Arc::clone(&shared).poll_parameters(Arc::clone(&params)));
            let bridge =
                params::ParamBridge::new(params, runtime.handle().clone()).publishing(Arc::clone(&shared));
            server = server.parameter_handler(Arc::new(bridge));
        }
        // Started on its own runtime, waited for here without blocking on a runtime (the
        // caller may be on one).
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        runtime.spawn(async move {
            let _ = tx.send(server.start().await);
        });
        let server = match rx.recv_timeout(START_TIMEOUT) {
            Ok(Ok(server)) => server,
            Ok(Err(e)) => return Err(LiveError::Bind { addr, problem: e.to_string() }),
            Err(_) => {
                return Err(LiveError::Bind {
                    addr,
                    problem: format!("it did not start within {} s", START_TIMEOUT.as_secs()),
                });
            }
        };
        let bound = SocketAddr::new(addr.ip(), server.port());
        *shared.server.0.lock() = Some(server);
        let tap = tap::LiveTap::start(setup, context, Arc::clone(&shared))
            .map_err(|source| LiveError::Start { addr, what: "views thread", source })?;
        Ok(LiveView { addr: bound, tap: Arc::new(tap), shared, teleop, runtime: Some(runtime) })
    }

    /// Where it listens (the port chosen if `0` was asked for).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The tap to install on the registry (beside a recording's, see [`tap::both`]).
    pub fn tap(&self) -> Arc<tap::LiveTap> {
        Arc::clone(&self.tap)
    }

    /// Stops the views' thread and the server; what it did.
    pub fn finish(mut self) -> LiveSummary {
        self.stop()
    }

    fn stop(&mut self) -> LiveSummary {
        let mut summary = self.tap.finish();
        summary.published = self.teleop.as_ref().map(|t| t.published());
        let server = self.shared.server.0.lock().take();
        if let Some(server) = server {
            // Dropping the shutdown handle aborts the clients' tasks at once.
            drop(server.stop());
        }
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_background();
        }
        summary
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        self.stop();
    }
}

/// For `orsa robot` and `orsa executive` (process `who`): if `addr` is given, starts a live
/// view of `setup` there and installs its tap on `registry`, beside `recording`'s if any.
/// Clients may publish velocity commands, and goals for `planner` if it is given.
pub fn serve_process(
    registry: &orsa_actors::Registry,
    addr: Option<SocketAddr>,
    who: &str,
    setup: ViewSetup,
    recording: Option<Arc<dyn orsa_actors::tap::Tap>>,
    components: Vec<String>,
    planner: Option<&str>,
) -> Result<Option<LiveView>, LiveError> {
    let Some(addr) = addr else { return Ok(None) };
    let params = crate::system::live_params::ParamDirectory::new(registry, components);
    let teleop = Arc::new(publish::Teleop::new(registry, &setup.robot).with_planner(planner));
    let live = LiveView::start(addr, setup, Some(Arc::new(params)), Some(teleop))?;
    registry.set_tap(tap::both(recording, Some(live.tap() as Arc<dyn orsa_actors::tap::Tap>)));
    eprintln!("{who}: foxglove: serving this process's views on ws://{}", live.addr());
    Ok(Some(live))
}

/// `--foxglove`'s value: an address to listen on, `host:port`.
pub fn parse_addr(s: &str) -> Result<SocketAddr, BadAddr> {
    s.parse::<SocketAddr>().map_err(|_| BadAddr(s.to_string()))
}

/// `--foxglove`'s value is not an address to listen on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{0}' is not an address to listen on: give IP:PORT, e.g. {DEFAULT_ADDR} or 0.0.0.0:8765")]
pub struct BadAddr(pub String);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_or_say_what_to_give() {
        assert_eq!(parse_addr("0.0.0.0:9000").map(|a| a.port()), Ok(9000));
        assert!(parse_addr(DEFAULT_ADDR).is_ok());
        let e = parse_addr("localhost").expect_err("not IP:PORT");
        assert!(e.to_string().contains("IP:PORT"), "{e}");
    }
}
