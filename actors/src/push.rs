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
use crate::fault::Verdict;
use crate::ledger::{Account, Stream};
use crate::registry::{PatternKind, Registry, Remote, Resolved, ServiceAddr, ServiceInfo};
use crate::sink::{Sink, Undeliverable};
use crate::stamped::{Stamped, Update};
use crate::state::Cancel;
use crate::transport::{ByteSink, Served, Subscription};
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
    /// What this subscriber has seen of the server's sequence numbers.
    stream: Arc<Stream>,
}

/// What a publication does at each subscriber whose turn it is.
#[derive(Clone, Copy)]
enum Hand {
    /// Hands it over this many times.
    Copies(usize),
    /// Loses it (a fault).
    Drop,
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
    me: std::sync::Weak<PushEndpoint<T>>,
    faults: crate::fault::Faults,
    topic: String,
    tap: crate::tap::TapSlot,
    clock: Clock,
    /// Copy-on-write: a publisher clones the `Arc` and delivers with no lock held, so a sink may
    /// subscribe, unsubscribe or publish without deadlocking.
    subs: RwLock<Arc<Vec<Arc<Subscriber<T>>>>>,
    latest: RwLock<Option<Update<T>>>,
    seq: AtomicU64,
    next_id: AtomicU64,
    delivered: AtomicU64,
    failed: AtomicU64,
    account: Account,
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
        let endpoint = Arc::new_cyclic(|me| PushEndpoint {
            me: me.clone(),
            topic: addr.to_string(),
            tap: registry.tap_slot(),
            addr: addr.clone(),
            faults: registry.faults(),
            clock: registry.clock(),
            subs: RwLock::new(Arc::new(Vec::new())),
            latest: RwLock::new(None),
            seq: AtomicU64::new(0),
            next_id: AtomicU64::new(1),
            delivered: AtomicU64::new(0),
            failed: AtomicU64::new(0),
            account: registry.account(&addr, kind),
            active: watch::Sender::new(active),
        });
        registry.register_service(addr, info::<T>(kind), endpoint.clone(), endpoint.clone())?;
        Ok(endpoint)
    }

    /// Publishes a value to every subscriber whose turn it is; returns how many got it.
    ///
    /// No lock is held while sinks run. Values from concurrent publishers reach a subscriber in
    /// an unspecified order, but "newest" ([`latest`](Self::latest), a client's `get_update`)
    /// only ever moves forward in sequence number.
    pub(crate) fn put(&self, value: T) -> usize {
        let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
        let update = Arc::new(Stamped { seq, stamp: self.clock.now(), value });
        self.tap.record(&self.topic, T::ID, update.stamp, &*update);
        {
            let mut latest = self.latest.write();
            if latest.as_ref().is_none_or(|l| l.seq < seq) {
                *latest = Some(Arc::clone(&update));
            }
        }
        let hand = match self.faults.verdict(&self.addr) {
            Verdict::Deliver => Hand::Copies(1),
            Verdict::Drop => Hand::Drop,
            Verdict::Duplicate => Hand::Copies(2),
            Verdict::Delay(d) => match (tokio::runtime::Handle::try_current(), self.me.upgrade()) {
                (Ok(rt), Some(me)) => {
                    rt.spawn(async move {
                        tokio::time::sleep(d).await;
                        me.deliver(&update, Hand::Copies(1));
                    });
                    return 0;
                }
                _ => Hand::Copies(1),
            },
        };
        self.deliver(&update, hand)
    }

    /// Hands `update` to every subscriber whose turn it is.
    fn deliver(&self, update: &Update<T>, hand: Hand) -> usize {
        let subs = Arc::clone(&self.subs.read());
        let mut delivered = 0;
        let mut closed = Vec::new();
        for s in subs.iter() {
            let n = s.count.fetch_add(1, Ordering::Relaxed) + 1;
            if n % s.every != 0 {
                continue;
            }
            let copies = match hand {
                Hand::Copies(c) => c,
                Hand::Drop => {
                    self.account.dropped();
                    continue;
                }
            };
            let mut result =
                s.sink.deliver_with(Arc::clone(update), self.account.offer(Some(&s.stream), update.seq));
            for _ in 1..copies {
                let copy = self.account.copy(Some(&s.stream), update.seq);
                result = result.and(s.sink.deliver_with(Arc::clone(update), copy));
            }
            match result {
                Ok(()) => delivered += 1,
                Err(Undeliverable::Unavailable) => {
                    self.failed.fetch_add(1, Ordering::Relaxed);
                }
                Err(Undeliverable::Closed) => closed.push(s.id),
            }
        }
        if !closed.is_empty() {
            self.remove_subscribers(&closed);
        }
        self.delivered.fetch_add(delivered as u64, Ordering::Relaxed);
        delivered
    }

    fn remove_subscribers(&self, ids: &[u64]) -> bool {
        let mut subs = self.subs.write();
        if !subs.iter().any(|s| ids.contains(&s.id)) {
            return false;
        }
        *subs = Arc::new(subs.iter().filter(|s| !ids.contains(&s.id)).cloned().collect());
        true
    }

    pub(crate) fn subscribe(&self, every: NonZeroU32, sink: Sink<Update<T>>) -> u64 {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let sub = Arc::new(Subscriber {
            id,
            every: u64::from(every.get()),
            count: AtomicU64::new(0),
            sink,
            stream: Arc::new(Stream::default()),
        });
        let mut subs = self.subs.write();
        let mut next = Vec::with_capacity(subs.len() + 1);
        next.extend(subs.iter().cloned());
        next.push(sub);
        *subs = Arc::new(next);
        id
    }

    pub(crate) fn unsubscribe(&self, id: u64) -> bool {
        self.remove_subscribers(&[id])
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

impl<T: CommObject> Served for PushEndpoint<T> {
    fn clients(&self) -> Option<usize> {
        Some(self.subs.read().len())
    }

    fn serve_subscribe(self: Arc<Self>, every: NonZeroU32, sink: ByteSink) -> PatternResult<Subscription> {
        let clock = self.clock;
        let bytes_sink = Sink::from_fn(move |u: Update<T>| {
            if sink(&crate::wire::encode_stamped(&u, &clock)) { Ok(()) } else { Err(Undeliverable::Closed) }
        });
        let id = PushEndpoint::subscribe(&self, every, bytes_sink);
        struct Unsubscribe<T: CommObject>(std::sync::Weak<PushEndpoint<T>>, u64);
        impl<T: CommObject> Drop for Unsubscribe<T> {
            fn drop(&mut self) {
                if let Some(ep) = self.0.upgrade() {
                    ep.unsubscribe(self.1);
                }
            }
        }
        Ok(Subscription::new(Unsubscribe(Arc::downgrade(&self), id)))
    }
}

enum Via<T> {
    Local(Arc<PushEndpoint<T>>),
    Remote(Remote),
}

enum SubHandle {
    Local(u64),
    Remote(#[allow(dead_code)] Subscription),
}

/// The client half shared by both push patterns.
pub(crate) struct PushClientCore<T> {
    pub(crate) addr: ServiceAddr,
    via: Via<T>,
    /// Whether the server produces; a remote server is taken as producing.
    active: watch::Receiver<bool>,
    sub: Mutex<Option<SubHandle>>,
    /// The newest update received, and the subscription generation (bumped on every subscribe
    /// and unsubscribe, so a waiter learns that its subscription ended).
    newest: Arc<watch::Sender<Option<Update<T>>>>,
    generation: watch::Sender<u64>,
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
        let (via, active) = match registry.resolve::<PushEndpoint<T>>(addr, &info::<T>(kind))? {
            Resolved::Local(e) => {
                let active = e.active.subscribe();
                (Via::Local(e), active)
            }
            Resolved::Remote(r) => (Via::Remote(r), watch::Sender::new(true).subscribe()),
        };
        Ok(PushClientCore {
            addr: addr.clone(),
            via,
            active,
            sub: Mutex::new(None),
            newest: Arc::new(watch::Sender::new(None)),
            generation: watch::Sender::new(0),
            forward,
            cancel,
        })
    }

    fn not_subscribed(&self) -> PatternError {
        PatternError::NotActive(format!("not subscribed to {}", self.addr))
    }

    pub(crate) fn subscribe(&self, every: u32) -> PatternResult<()> {
        let every = NonZeroU32::new(every).ok_or_else(|| {
            PatternError::InvalidArgument("subscribe(every): every must be at least 1".into())
        })?;
        let newest = Arc::clone(&self.newest);
        let forward = self.forward.clone();
        let sink = Sink::with_receipts(move |u: Update<T>, receipt| {
            newest.send_if_modified(|cur| {
                let newer = cur.as_ref().is_none_or(|c| c.seq < u.seq);
                if newer {
                    *cur = Some(Arc::clone(&u));
                }
                // Waking receivers costs eight mutexes (tokio's watch); only `get_update_wait`
                // makes receivers, so with none alive the value changes silently. A waiter
                // that subscribes meanwhile judges by sequence number (see there).
                newer && newest.receiver_count() > 0
            });
            match &forward {
                Some(f) => f.deliver_with(u, receipt),
                None => {
                    crate::ledger::settle::<()>(receipt, &Ok(()));
                    Ok(())
                }
            }
        });
        // Publishers hold no lock while they deliver, so holding ours here cannot deadlock
        // with a sink; the old subscription ends before the new one starts (no duplicate).
        let mut sub = self.sub.lock();
        if let Some(old) = sub.take() {
            self.end(old);
        }
        *sub = Some(match &self.via {
            Via::Local(e) => SubHandle::Local(e.subscribe(every, sink)),
            Via::Remote(r) => {
                let clock = r.registry.clock();
                let remote = r.clone();
                let bytes: ByteSink =
                    Arc::new(move |b: &[u8]| match crate::wire::decode_stamped::<T>(b, T::ID, &clock) {
                        Ok(u) => sink.deliver(Arc::new(u)) != Err(Undeliverable::Closed),
                        Err(e) => {
                            remote.bad_message(&e);
                            true
                        }
                    });
                SubHandle::Remote(r.transport.subscribe(&r.addr, every, bytes)?)
            }
        });
        drop(sub);
        self.generation.send_modify(|g| *g += 1);
        Ok(())
    }

    pub(crate) fn unsubscribe(&self) -> PatternResult<()> {
        let old = self.sub.lock().take().ok_or_else(|| self.not_subscribed())?;
        self.end(old);
        self.generation.send_modify(|g| *g += 1);
        Ok(())
    }

    fn end(&self, sub: SubHandle) {
        match (sub, &self.via) {
            (SubHandle::Local(id), Via::Local(e)) => {
                e.unsubscribe(id);
            }
            (other, _) => drop(other),
        }
    }

    pub(crate) fn is_subscribed(&self) -> bool {
        self.sub.lock().is_some()
    }

    pub(crate) fn get_update(&self) -> PatternResult<Update<T>> {
        if !self.is_subscribed() {
            return Err(self.not_subscribed());
        }
        self.newest.borrow().clone().ok_or(PatternError::NoData)
    }

    /// Waits for an update newer than the newest one now; ends with `NotActive` when the server
    /// stops (push timed) or this subscription ends, with `Timeout` after `timeout`, and with
    /// `Cancelled` when the owning component is deactivated.
    pub(crate) async fn get_update_wait(
        &self,
        timeout: Option<std::time::Duration>,
    ) -> PatternResult<Update<T>> {
        if !self.is_subscribed() {
            return Err(self.not_subscribed());
        }
        let addr = self.addr.clone();
        let mut newest = self.newest.subscribe();
        // What "now" is: values are also stored silently while nobody waits, so compare
        // sequence numbers rather than trusting the version alone.
        let seen = newest.borrow_and_update().as_ref().map_or(0, |u| u.seq);
        let mut active = self.active.clone();
        let mut generation = self.generation.subscribe();
        generation.borrow_and_update();
        let wait = async move {
            loop {
                if !*active.borrow_and_update() {
                    return Err(PatternError::NotActive(format!("{addr} is stopped")));
                }
                tokio::select! {
                    biased;
                    _ = generation.changed() => {
                        return Err(PatternError::NotActive(format!("the subscription to {addr} ended")));
                    }
                    changed = newest.changed() => {
                        if changed.is_err() {
                            return Err(PatternError::NotActive(format!("the subscription to {addr} ended")));
                        }
                        if let Some(u) = newest.borrow_and_update().clone()
                            && u.seq > seen
                        {
                            return Ok(u);
                        }
                    }
                    _ = active.changed() => {}
                }
            }
        };
        let bounded = async move {
            match timeout {
                Some(t) => tokio::time::timeout(t, wait).await.map_err(|_| PatternError::Timeout)?,
                None => wait.await,
            }
        };
        match &self.cancel {
            Some(c) => c.guard(bounded).await,
            None => bounded.await,
        }
    }
}

impl<T> Drop for PushClientCore<T> {
    fn drop(&mut self) {
        if let (Some(SubHandle::Local(id)), Via::Local(e)) = (self.sub.get_mut().take(), &self.via) {
            let mut subs = e.subs.write();
            if subs.iter().any(|s| s.id == id) {
                *subs = Arc::new(subs.iter().filter(|s| s.id != id).cloned().collect());
            }
        }
    }
}
