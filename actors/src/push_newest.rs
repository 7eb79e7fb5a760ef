//! **Push newest**: the server publishes whenever it has a new value; every subscriber gets
//! each one.
//!
//! Semantics: [`PushNewestServer::put`] stamps a value and hands it to every subscriber at once
//! (in the subscriber's mailbox or sink, in publish order). A client subscribes, then either
//! receives updates in its sink or reads them: [`PushNewestClient::get_update`] returns the
//! newest value received without waiting ([`PatternError::NoData`](crate::PatternError::NoData) before the first),
//! [`PushNewestClient::get_update_wait`] waits for the next one. A subscriber whose component is
//! restarting misses the values published meanwhile (they are counted as failed deliveries) and
//! receives again once its component is back, without re-subscribing.
//!
//! ```
//! # use orsa_actors::{Registry, push_newest::{PushNewestClient, PushNewestServer}, service::PushNewestService};
//! const TICKS: PushNewestService<u64> = PushNewestService::new("ticks");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let server = PushNewestServer::register(&registry, TICKS.on("odometry"))?;
//! let client = PushNewestClient::connect(&registry, TICKS.on("odometry"))?;
//! client.subscribe()?;
//! server.put(41);
//! server.put(42);
//! assert_eq!(client.get_update()?.value, 42);
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr};
use crate::comm::CommObject;
use crate::error::PatternResult;
use crate::push::{PushClientCore, PushEndpoint, PushStats};
use crate::registry::Registry;
use crate::service::PushNewestService;
use crate::sink::Sink;
use crate::stamped::Update;
use crate::state::Cancel;
use std::sync::Arc;

/// The server side of a Push newest service.
pub struct PushNewestServer<T> {
    endpoint: Arc<PushEndpoint<T>>,
}

impl<T> Clone for PushNewestServer<T> {
    fn clone(&self) -> Self {
        PushNewestServer { endpoint: Arc::clone(&self.endpoint) }
    }
}

impl<T: CommObject> PushNewestServer<T> {
    /// Registers a Push newest service at `addr`.
    pub fn register(registry: &Registry, addr: impl IntoAddr<PushNewestService<T>>) -> PatternResult<Self> {
        let endpoint = PushEndpoint::register(registry, addr.into_addr(), PatternKind::PushNewest, true)?;
        Ok(PushNewestServer { endpoint })
    }

    /// Publishes a value to every subscriber; returns how many received it.
    pub fn put(&self, value: T) -> usize {
        self.endpoint.put(value)
    }

    /// The newest value published.
    pub fn latest(&self) -> Option<Update<T>> {
        self.endpoint.latest()
    }

    /// Delivery figures.
    pub fn stats(&self) -> PushStats {
        self.endpoint.stats()
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        self.endpoint.addr()
    }
}

/// The client side of a Push newest service. Dropping it unsubscribes.
pub struct PushNewestClient<T> {
    core: PushClientCore<T>,
}

impl<T: CommObject> PushNewestClient<T> {
    /// Connects to the Push newest service at `addr` (not yet subscribed).
    pub fn connect(registry: &Registry, addr: impl IntoAddr<PushNewestService<T>>) -> PatternResult<Self> {
        Self::build(registry, addr, None, None)
    }

    /// Connects, forwarding every received update into `sink` as well.
    pub fn connect_to(
        registry: &Registry,
        addr: impl IntoAddr<PushNewestService<T>>,
        sink: Sink<Update<T>>,
    ) -> PatternResult<Self> {
        Self::build(registry, addr, Some(sink), None)
    }

    pub(crate) fn build(
        registry: &Registry,
        addr: impl IntoAddr<PushNewestService<T>>,
        sink: Option<Sink<Update<T>>>,
        cancel: Option<Cancel>,
    ) -> PatternResult<Self> {
        let core =
            PushClientCore::connect(registry, &addr.into_addr(), PatternKind::PushNewest, sink, cancel)?;
        Ok(PushNewestClient { core })
    }

    /// Subscribes: from now on every published value arrives.
    pub fn subscribe(&self) -> PatternResult<()> {
        self.core.subscribe(1)
    }

    /// Stops the updates. [`PatternError::NotActive`](crate::PatternError::NotActive) if not
    /// subscribed.
    pub fn unsubscribe(&self) -> PatternResult<()> {
        self.core.unsubscribe()
    }

    /// The newest value received, without waiting.
    pub fn get_update(&self) -> PatternResult<Update<T>> {
        self.core.get_update()
    }

    /// Waits for the next value.
    pub async fn get_update_wait(&self) -> PatternResult<Update<T>> {
        self.core.get_update_wait(None).await
    }

    /// Waits for the next value at most `timeout`: [`PatternError::Timeout`](crate::PatternError::Timeout) after.
    pub async fn get_update_wait_timeout(&self, timeout: std::time::Duration) -> PatternResult<Update<T>> {
        self.core.get_update_wait(Some(timeout)).await
    }

    /// Whether the client is subscribed.
    pub fn is_subscribed(&self) -> bool {
        self.core.is_subscribed()
    }

    /// The service's address.
    pub fn addr(&self) -> &ServiceAddr {
        &self.core.addr
    }
}
