//! **Push timed**: the server produces on its own period; each subscriber gets every n-th value.
//!
//! Semantics: the server has a period and is started or stopped by its owner. While started, a
//! tick arrives in the server component's mailbox every period (on tokio's clock: exact on a
//! paused clock); the component reads its hardware and [`put`](PushTimedServer::put)s the value.
//! A client [`subscribe`](PushTimedClient::subscribe)s with `n` and receives the n-th, 2n-th, ...
//! value published after it subscribed: the original system subscribed with 10 to a 40 ms
//! infrared stream to get one scan per 400 ms. Counting is done at the server, so skipped values
//! cost nothing. [`get_update`](PushTimedClient::get_update) and
//! [`get_update_wait`](PushTimedClient::get_update_wait) behave as for push newest, except that
//! waiting on a stopped server answers [`PatternError::NotActive`](crate::PatternError::NotActive).
//!
//! ```
//! # use std::time::Duration;
//! # use orsa_actors::{Registry, Sink, push_timed::{PushTimedClient, PushTimedServer, Tick}, service::PushTimedService};
//! const COUNTER: PushTimedService<u64> = PushTimedService::new("counter");
//! # #[tokio::main(flavor = "current_thread", start_paused = true)] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let (tick_tx, mut ticks) = tokio::sync::mpsc::unbounded_channel::<Tick>();
//! let server = PushTimedServer::<u64>::register(
//!     &registry, COUNTER.on("nomad200"), Duration::from_millis(40), Sink::channel(tick_tx))?;
//! let producer = server.clone();
//! tokio::spawn(async move { while let Some(t) = ticks.recv().await { producer.put(t.seq); } });
//!
//! let client = PushTimedClient::connect(&registry, COUNTER.on("nomad200"))?;
//! client.subscribe(10)?;
//! server.start();
//! assert_eq!(client.get_update_wait().await?.value, 10); // the 10th tick, after 400 ms
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr};
use crate::clock::Timestamp;
use crate::comm::CommObject;
use crate::error::PatternResult;
use crate::push::{PushClientCore, PushEndpoint, PushStats};
use crate::registry::Registry;
use crate::service::PushTimedService;
use crate::sink::{Sink, Undeliverable};
use crate::stamped::Update;
use crate::state::Cancel;
use parking_lot::Mutex;
use std::sync::{Arc, Weak};
use std::time::Duration;
use tokio::task::JoinHandle;
use tokio::time::MissedTickBehavior;

/// The longest period a push timed server accepts (a day).
pub const MAX_PERIOD: Duration = Duration::from_secs(86_400);

/// The server's period has come: produce a value now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tick {
    /// Tick count since the server was first started, from 1.
    pub seq: u64,
    /// The scheduled time of this tick.
    pub stamp: Timestamp,
}

struct Timer {
    period: Duration,
    tick: Sink<Tick>,
    count: u64,
    task: Option<JoinHandle<()>>,
    missed: u64,
    /// Bumped by every start and stop: a tick of an older generation is not delivered.
    generation: u64,
}

/// The server side of a Push timed service. Clones control the same service.
pub struct PushTimedServer<T> {
    endpoint: Arc<PushEndpoint<T>>,
    timer: Arc<Mutex<Timer>>,
    runtime: tokio::runtime::Handle,
}

impl<T> Clone for PushTimedServer<T> {
    fn clone(&self) -> Self {
        PushTimedServer {
            endpoint: Arc::clone(&self.endpoint),
            timer: Arc::clone(&self.timer),
            runtime: self.runtime.clone(),
        }
    }
}

impl<T: CommObject> PushTimedServer<T> {
    /// Registers a Push timed service at `addr` producing every `period`; each tick is delivered
    /// into `tick`. The server starts stopped.
    pub fn register(
        registry: &Registry,
        addr: impl IntoAddr<PushTimedService<T>>,
        period: Duration,
        tick: Sink<Tick>,
    ) -> PatternResult<Self> {
        if period.is_zero() || period > MAX_PERIOD {
            return Err(crate::PatternError::InvalidArgument(format!(
                "a push timed period must be positive and at most {MAX_PERIOD:?}, not {period:?}"
            )));
        }
        let runtime = tokio::runtime::Handle::try_current().map_err(|_| {
            crate::PatternError::InvalidArgument(
                "a push timed server must be registered inside a tokio runtime".into(),
            )
        })?;
        let endpoint = PushEndpoint::register(registry, addr.into_addr(), PatternKind::PushTimed, false)?;
        let timer =
            Arc::new(Mutex::new(Timer { period, tick, count: 0, task: None, missed: 0, generation: 0 }));
        Ok(PushTimedServer { endpoint, timer, runtime })
    }

    /// Starts producing: the first tick comes one period from now. Starting a started server
    /// does nothing.
    pub fn start(&self) {
        let mut timer = self.timer.lock();
        if timer.task.is_some() {
            return;
        }
        timer.generation += 1;
        let generation = timer.generation;
        let period = timer.period;
        let weak: Weak<Mutex<Timer>> = Arc::downgrade(&self.timer);
        let clock = self.endpoint.clock();
        timer.task = Some(self.runtime.spawn(async move {
            let Some(first) = tokio::time::Instant::now().checked_add(period) else { return };
            let mut interval = tokio::time::interval_at(first, period);
            interval.set_missed_tick_behavior(MissedTickBehavior::Skip);
            loop {
                let at = interval.tick().await;
                let Some(timer) = weak.upgrade() else { return };
                // Take what the tick needs and let go of the lock before delivering, so a tick
                // handler may call stop() or start() on this server.
                let (tick, sink) = {
                    let mut timer = timer.lock();
                    if timer.generation != generation {
                        return; // stopped (and maybe restarted) since this tick was scheduled
                    }
                    timer.count += 1;
                    (Tick { seq: timer.count, stamp: clock.stamp_of(at) }, timer.tick.clone())
                };
                match sink.deliver(tick) {
                    Ok(()) => {}
                    Err(Undeliverable::Unavailable) => timer.lock().missed += 1,
                    Err(Undeliverable::Closed) => return,
                }
            }
        }));
        drop(timer);
        self.endpoint.active.send_replace(true);
    }

    /// Stops producing. Clients waiting in `get_update_wait` get `NotActive`.
    pub fn stop(&self) {
        let mut timer = self.timer.lock();
        timer.generation += 1;
        if let Some(task) = timer.task.take() {
            task.abort();
        }
        drop(timer);
        self.endpoint.active.send_replace(false);
    }

    /// Whether the server is started.
    pub fn is_active(&self) -> bool {
        self.timer.lock().task.is_some()
    }

    /// The production period.
    pub fn period(&self) -> Duration {
        self.timer.lock().period
    }

    /// Ticks that could not be delivered because the server component was not running.
    pub fn missed_ticks(&self) -> u64 {
        self.timer.lock().missed
    }

    /// Publishes a value to every subscriber whose turn it is; returns how many received it.
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

/// The client side of a Push timed service. Dropping it unsubscribes.
pub struct PushTimedClient<T> {
    core: PushClientCore<T>,
}

impl<T: CommObject> PushTimedClient<T> {
    /// Connects to the Push timed service at `addr` (not yet subscribed).
    pub fn connect(registry: &Registry, addr: impl IntoAddr<PushTimedService<T>>) -> PatternResult<Self> {
        Self::build(registry, addr, None, None)
    }

    /// Connects, forwarding every received update into `sink` as well.
    pub fn connect_to(
        registry: &Registry,
        addr: impl IntoAddr<PushTimedService<T>>,
        sink: Sink<Update<T>>,
    ) -> PatternResult<Self> {
        Self::build(registry, addr, Some(sink), None)
    }

    pub(crate) fn build(
        registry: &Registry,
        addr: impl IntoAddr<PushTimedService<T>>,
        sink: Option<Sink<Update<T>>>,
        cancel: Option<Cancel>,
    ) -> PatternResult<Self> {
        let core =
            PushClientCore::connect(registry, &addr.into_addr(), PatternKind::PushTimed, sink, cancel)?;
        Ok(PushTimedClient { core })
    }

    /// Subscribes to every `every`-th value (1 for all). Subscribing again replaces the old
    /// subscription and restarts the count.
    pub fn subscribe(&self, every: u32) -> PatternResult<()> {
        self.core.subscribe(every)
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

    /// Waits for the next value; `NotActive` if the server is or becomes stopped.
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
