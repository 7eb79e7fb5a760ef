//! The machinery shared by [Push newest](crate::push_newest) and [Push timed](crate::push_timed):
//! the server's subscriber list and the client's newest-value cell. The two patterns differ in
//! who decides when a value is produced; delivery is the same.
//!
//! Delivery is counted at the source: each subscriber has its own `every` and counter, so a
//! subscriber at `every = 10` receives the 10th, 20th, ... update published after it subscribed,
//! and costs nothing for the other nine. Updates are shared ([`Update`] is an `Arc`), so a fan-out
//! to many subscribers copies a pointer, not the data.

use crate::clock::Clock;
use crate::comm::CommObject;
use crate::error::{PatternError, PatternResult};
use crate::registry::{PatternKind, Registry, ServiceAddr, ServiceInfo};
use crate::sink::{Sink, Undeliverable};
use crate::stamped::{Stamped, Update};
use crate::state::Cancel;
use parking_lot::{Mutex, RwLock};
use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tokio::sync::watch;

pub(crate) fn info<T: CommObject>(kind: PatternKind) -> ServiceInfo {
    ServiceInfo::new(kind, &[T::ID])
}

struct Subscriber<T> {
    id: u64,
    every: u64,
    count: AtomicU64,
    sink: Sink<Update<T>>,
}

/// Delivery figures of one push service.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PushStats {
    /// Values published.
    pub published: u64,
    /// Deliveries handed to subscribers.
    pub delivered: u64,
    /// Deliveries that failed because the subscriber was not running (restarting).
    pub failed: u64,
    /// Current number of subscribers.
    pub subscribers: usize,
}

pub(crate) struct PushEndpoint<T> {
    pub(crate) addr: ServiceAddr,
    clock: Clock,
    subs: RwLock<Vec<Subscriber<T>>>,
    latest: RwLock<Option<Update<T>>>,
    seq: AtomicU64,
    next_id: AtomicU64,
    delivered: AtomicU64,
    failed: AtomicU64,
    /// Whether the server produces (always true for push newest).
    pub(crate) active: watch::Sender<bool>,
}

impl<T: CommObject> PushEndpoint<T> {
    pub(crate) fn register(
        registry: &Registry,
        addr: ServiceAddr,
        kind: PatternKind,
        active: bool,
    ) -> PatternResult<Arc<Self>> {
        let endpoint = Arc::new(PushEndpoint {
            addr: addr.clone(),
            clock: registry.clock(),
            subs: RwLock::new(Vec::new()),
            latest: RwLock::new(None),
            seq: AtomicU64::new(0),
            next_id: AtomicU64::new(1),
            delivered: AtomicU64::new(0),
            failed: AtomicU64::new(0),
            active: watch::Sender::new(active),
        });
        registry.register_service(addr, info::<T>(kind), endpoint.clone())?;
        Ok(endpoint)
    }

    /// Publishes a value to every subscriber whose turn it is; returns how many got it.
    pub(crate) fn put(&self, value: T) -> usize {
        let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
        let update = Arc::new(Stamped { seq, stamp: self.clock.now(), value });
        *self.latest.write() = Some(Arc::clone(&update));
        let mut delivered = 0;
        let mut closed = Vec::new();
        {
            let subs = self.subs.read();
            for s in subs.iter() {
                let n = s.count.fetch_add(1, Ordering::Relaxed) + 1;
                if n % s.every != 0 {
                    continue;
                }
                match s.sink.deliver(Arc::clone(&update)) {
                    Ok(()) => delivered += 1,
                    Err(Undeliverable::Unavailable) => {
                        self.failed.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(Undeliverable::Closed) => closed.push(s.id),
                }
            }
        }
        if !closed.is_empty() {
            self.subs.write().retain(|s| !closed.contains(&s.id));
        }
        self.delivered.fetch_add(delivered as u64, Ordering::Relaxed);
        delivered
    }

    pub(crate) fn subscribe(&self, every: NonZeroU32, sink: Sink<Update<T>>) -> u64 {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        self.subs.write().push(Subscriber {
            id,
            every: u64::from(every.get()),
            count: AtomicU64::new(0),
            sink,
        });
        id
    }

    pub(crate) fn unsubscribe(&self, id: u64) -> bool {
        let mut subs = self.subs.write();
        let before = subs.len();
        subs.retain(|s| s.id != id);
        subs.len() != before
    }

    pub(crate) fn clock(&self) -> Clock {
        self.clock
    }

    pub(crate) fn latest(&self) -> Option<Update<T>> {
        self.latest.read().clone()
    }

    pub(crate) fn stats(&self) -> PushStats {
        PushStats {
            published: self.seq.load(Ordering::Relaxed),
            delivered: self.delivered.load(Ordering::Relaxed),
            failed: self.failed.load(Ordering::Relaxed),
            subscribers: self.subs.read().len(),
        }
    }
}

/// The client half shared by both push patterns.
pub(crate) struct PushClientCore<T> {
    pub(crate) endpoint: Arc<PushEndpoint<T>>,
    sub: Mutex<Option<u64>>,
    newest: Arc<watch::Sender<Option<Update<T>>>>,
    forward: Option<Sink<Update<T>>>,
    cancel: Option<Cancel>,
}

impl<T: CommObject> PushClientCore<T> {
    pub(crate) fn connect(
        registry: &Registry,
        addr: &ServiceAddr,
        kind: PatternKind,
        forward: Option<Sink<Update<T>>>,
        cancel: Option<Cancel>,
    ) -> PatternResult<Self> {
        let endpoint = registry
            .resolve_local::<PushEndpoint<T>>(addr, &info::<T>(kind))?
            .ok_or_else(|| registry.not_found(addr))?;
        Ok(PushClientCore {
            endpoint,
            sub: Mutex::new(None),
            newest: Arc::new(watch::Sender::new(None)),
            forward,
            cancel,
        })
    }

    pub(crate) fn subscribe(&self, every: u32) -> PatternResult<()> {
        let every = NonZeroU32::new(every).ok_or_else(|| {
            PatternError::InvalidArgument("subscribe(every): every must be at least 1".into())
        })?;
        let newest = Arc::clone(&self.newest);
        let forward = self.forward.clone();
        let sink = Sink::from_fn(move |u: Update<T>| {
            newest.send_replace(Some(Arc::clone(&u)));
            match &forward {
                Some(f) => f.deliver(u),
                None => Ok(()),
            }
        });
        let mut sub = self.sub.lock();
        if let Some(old) = sub.take() {
            self.endpoint.unsubscribe(old);
        }
        *sub = Some(self.endpoint.subscribe(every, sink));
        Ok(())
    }

    pub(crate) fn unsubscribe(&self) -> PatternResult<()> {
        match self.sub.lock().take() {
            Some(id) => {
                self.endpoint.unsubscribe(id);
                Ok(())
            }
            None => Err(PatternError::NotActive(format!("not subscribed to {}", self.endpoint.addr))),
        }
    }

    pub(crate) fn is_subscribed(&self) -> bool {
        self.sub.lock().is_some()
    }

    pub(crate) fn get_update(&self) -> PatternResult<Update<T>> {
        if !self.is_subscribed() {
            return Err(PatternError::NotActive(format!("not subscribed to {}", self.endpoint.addr)));
        }
        self.newest.borrow().clone().ok_or(PatternError::NoData)
    }

    pub(crate) async fn get_update_wait(&self) -> PatternResult<Update<T>> {
        if !self.is_subscribed() {
            return Err(PatternError::NotActive(format!("not subscribed to {}", self.endpoint.addr)));
        }
        let addr = self.endpoint.addr.clone();
        let mut newest = self.newest.subscribe();
        let mut active = self.endpoint.active.subscribe();
        let wait = async move {
            loop {
                if !*active.borrow_and_update() {
                    return Err(PatternError::NotActive(format!("{addr} is stopped")));
                }
                tokio::select! {
                    biased;
                    changed = newest.changed() => {
                        // The sender lives in `self`, which outlives this future.
                        if changed.is_err() {
                            return Err(PatternError::NotActive(format!("unsubscribed from {addr}")));
                        }
                        if let Some(u) = newest.borrow_and_update().clone() {
                            return Ok(u);
                        }
                    }
                    _ = active.changed() => {}
                }
            }
        };
        match &self.cancel {
            Some(c) => c.guard(wait).await,
            None => wait.await,
        }
    }
}

impl<T> Drop for PushClientCore<T> {
    fn drop(&mut self) {
        if let Some(id) = self.sub.get_mut().take() {
            let mut subs = self.endpoint.subs.write();
            subs.retain(|s| s.id != id);
        }
    }
}
