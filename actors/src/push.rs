//! The machinery shared by [Push newest](crate::push_newest) and [Push timed](crate::push_timed):
//! the server's subscriber list and the client's newest-value cell. The two patterns differ in
//! who decides when a value is produced; delivery is the same.
//!
//! Delivery is counted at the source: each subscriber has its own `every` and counter, so a
//! subscriber at `every = 10` receives the 10th, 20th, ... update published after it subscribed,
//! and costs nothing for the other nine. Updates are shared ([`Update`] is an `Arc`), so a fan-out
//! to many subscribers copies a pointer, not the data.

use crate::addr::{PatternKind, ServiceAddr, ServiceInfo};
use crate::clock::Clock;
use crate::comm::CommObject;
use crate::door::{Door, Pass};
use crate::error::{PatternError, PatternResult};
use crate::ledger::Stream;
use crate::registry::{Registry, Remote, Resolved};
use crate::sink::{Sink, Undeliverable};
use crate::stamped::{Stamped, Update};
use crate::state::Cancel;
use crate::transport::{ByteSink, Served, Subscription};
use parking_lot::Mutex;
use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tokio::sync::watch;

mod client;
pub(crate) use client::PushClientCore;

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

impl<T> Subscriber<T> {
    /// Whether this publication is one this subscriber receives (counted).
    fn turn(&self) -> bool {
        // At `every = 1`, every one: no need to count.
        self.every == 1 || (self.count.fetch_add(1, Ordering::Relaxed) + 1).is_multiple_of(self.every)
    }
}

/// What handing one publication over came to.
struct Outcome {
    delivered: usize,
    /// Deliveries not counted in advance (see `Board::counted`).
    uncounted: u64,
    closed: Vec<u64>,
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

/// What a publication reads and writes at once.
struct Board<T> {
    /// The last sequence number given out.
    seq: u64,
    latest: Option<Update<T>>,
    /// Copy-on-write: a publisher clones the `Arc` and delivers with no lock held, so a sink may
    /// subscribe, unsubscribe or publish without deadlocking.
    subs: Subscribers<T>,
    /// The newest-value cells of local clients subscribed at `every = 1`, kept here so that a
    /// publication updates them under the lock it takes anyway (see [`Cell`]).
    cells: Vec<Cell<T>>,
    /// How many subscribers are at `every = 1`.
    ones: u64,
    /// Deliveries counted in advance, under the lock: a publication handed over at once counts
    /// one for each subscriber at `every = 1`, which spares it an atomic counter; a hand-over
    /// that then fails takes its count back (`PushEndpoint::taken_back`).
    counted: u64,
}

/// A local client's newest-value cell, kept by the server for a subscription at `every = 1`.
///
/// Such a subscriber receives every publication the faults let through, so its newest value is
/// nearly always the server's own newest one: the cell then holds only its sequence number and
/// costs a publication no reference count and no lock of its own. When a publication does not
/// reach it (a lost or late message), or the subscription ends, the cell keeps the value it had.
struct Cell<T> {
    /// The subscriber's id.
    id: u64,
    /// The sequence number of the newest update received (0: none).
    seq: u64,
    /// That update, when it is not `Board::latest` (always, once `detached`).
    own: Option<Update<T>>,
    /// Whether the subscription ended at the server (a closed sink): publications pass it by.
    detached: bool,
}

impl<T> Cell<T> {
    /// The newest update received, given the server's newest.
    fn newest(&self, latest: Option<&Update<T>>) -> Option<Update<T>> {
        match (&self.own, latest) {
            (Some(u), _) => Some(Arc::clone(u)),
            (None, Some(l)) if self.seq > 0 && l.seq == self.seq => Some(Arc::clone(l)),
            _ => None,
        }
    }

    /// Keeps the value the cell refers to before `latest` moves on without it.
    fn keep(&mut self, latest: Option<&Update<T>>) {
        if self.own.is_none() {
            self.own = self.newest(latest);
        }
    }

    /// Takes `u` as received (unless it is older than what the cell has).
    fn receive(&mut self, u: &Update<T>) {
        if u.seq > self.seq {
            self.seq = u.seq;
            self.own = Some(Arc::clone(u));
        }
    }
}

type Subscribers<T> = Arc<[Arc<Subscriber<T>>]>;

pub(crate) struct PushEndpoint<T> {
    /// Where each publication is tapped, faulted and handed over with its receipts.
    door: Door,
    me: std::sync::Weak<PushEndpoint<T>>,
    clock: Clock,
    /// The sequence number, the newest update and the subscribers, under one lock: a
    /// publication takes it once.
    board: Mutex<Board<T>>,
    next_id: AtomicU64,
    /// Deliveries not counted in advance (every > 1, late ones).
    delivered: AtomicU64,
    /// Deliveries counted in advance that failed.
    taken_back: AtomicU64,
    failed: AtomicU64,
    /// Whether the server produces (always true for push newest).
    pub(crate) active: watch::Sender<bool>,
}

impl<T> PushEndpoint<T> {
    pub(crate) fn addr(&self) -> &ServiceAddr {
        self.door.addr()
    }

    fn remove_subscribers(&self, ids: &[u64]) -> bool {
        let mut board = self.board.lock();
        if !board.subs.iter().any(|s| ids.contains(&s.id)) {
            return false;
        }
        let Board { latest, cells, .. } = &mut *board;
        for c in cells.iter_mut().filter(|c| ids.contains(&c.id)) {
            c.keep(latest.as_ref());
            c.detached = true;
        }
        let kept: Subscribers<T> = board.subs.iter().filter(|s| !ids.contains(&s.id)).cloned().collect();
        board.ones = kept.iter().filter(|s| s.every == 1).count() as u64;
        // The old list is dropped after the lock (a sink's drop may do anything).
        let old = std::mem::replace(&mut board.subs, kept);
        drop(board);
        drop(old);
        true
    }

    pub(crate) fn unsubscribe(&self, id: u64) -> bool {
        self.remove_subscribers(&[id])
    }

    /// Ends subscription `id`, which has a cell here; returns the newest update it received.
    fn unsubscribe_cell(&self, id: u64) -> Option<Update<T>> {
        self.remove_subscribers(&[id]);
        let mut board = self.board.lock();
        let i = board.cells.iter().position(|c| c.id == id)?;
        board.cells.swap_remove(i).own
    }

    /// The newest update received by subscription `id`, which has a cell here (`None` if it
    /// has none).
    fn cell_newest(&self, id: u64) -> Option<Option<Update<T>>> {
        let board = self.board.lock();
        board.cells.iter().find(|c| c.id == id).map(|c| c.newest(board.latest.as_ref()))
    }
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
            door: Door::new(registry, &addr, kind),
            clock: registry.clock(),
            board: Mutex::new(Board {
                seq: 0,
                latest: None,
                subs: Arc::new([]),
                cells: Vec::new(),
                ones: 0,
                counted: 0,
            }),
            next_id: AtomicU64::new(1),
            delivered: AtomicU64::new(0),
            taken_back: AtomicU64::new(0),
            failed: AtomicU64::new(0),
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
        let stamp = self.clock.now();
        let pass = self.door.pass();
        let later = match &pass {
            Pass::Later(d, rt) => self.me.upgrade().map(|me| (*d, rt.clone(), me)),
            _ => None,
        };
        // Whether the subscribers at `every = 1` receive it now (so their cells follow).
        let now = later.is_none() && !matches!(pass, Pass::Lost);
        // One lock per publication: the number, the newest value, the cells and the
        // subscribers to hand it to are taken together (so "newest" follows the numbers even
        // with concurrent publishers).
        let (update, subs, previous, replaced) = {
            let mut board = self.board.lock();
            board.seq += 1;
            let seq = board.seq;
            let (mut previous, mut replaced) = (None, None);
            // When the server holds the only reference to its newest update (every subscriber
            // is done with it, the usual case), the new one takes its place in the same
            // allocation. Not when this one is held back: the cells keep the previous one.
            let update = if let Some(latest) = board.latest.as_mut().filter(|_| now)
                && let Some(slot) = Arc::get_mut(latest)
            {
                slot.seq = seq;
                slot.sent_at = stamp;
                replaced = Some(std::mem::replace(&mut slot.value, value));
                Arc::clone(latest)
            } else {
                let update = Arc::new(Stamped { seq, sent_at: stamp, value });
                previous = board.latest.replace(Arc::clone(&update));
                update
            };
            for c in board.cells.iter_mut().filter(|c| !c.detached) {
                if now {
                    c.seq = update.seq;
                    c.own = None;
                } else {
                    c.keep(previous.as_ref());
                }
            }
            if now {
                board.counted += board.ones;
            }
            (update, Arc::clone(&board.subs), previous, replaced)
        };
        // What the publication replaced is dropped with no lock held.
        drop((previous, replaced));
        self.door.show(T::ID, update.sent_at, &*update);
        let hand = match pass {
            Pass::Lost => Hand::Drop,
            Pass::Now(copies) => Hand::Copies(copies),
            Pass::Later(..) => Hand::Copies(1),
        };
        if let Some((d, rt, me)) = later {
            drop(subs);
            rt.spawn(async move {
                tokio::time::sleep(d).await;
                // Whoever subscribes by then receives it.
                let subs = {
                    let mut board = me.board.lock();
                    for c in board.cells.iter_mut().filter(|c| !c.detached) {
                        c.receive(&update);
                    }
                    Arc::clone(&board.subs)
                };
                me.deliver(&subs, update, Hand::Copies(1), false);
            });
            return 0;
        }
        self.deliver(&subs, update, hand, now)
    }

    /// Hands `update` to every subscriber whose turn it is; `counted`: its deliveries to the
    /// subscribers at `every = 1` were counted in advance.
    fn deliver(&self, subs: &[Arc<Subscriber<T>>], update: Update<T>, hand: Hand, counted: bool) -> usize {
        let copies = match hand {
            Hand::Copies(c) => c,
            Hand::Drop => {
                for s in subs {
                    if s.turn() {
                        self.door.lost();
                    }
                }
                return 0;
            }
        };
        let mut outcome = Outcome { delivered: 0, uncounted: 0, closed: Vec::new() };
        // The last subscriber gets the update itself, the others a clone: one reference count
        // less per publication.
        let mut pending: Option<&Subscriber<T>> = None;
        for s in subs {
            if !s.turn() {
                continue;
            }
            if let Some(p) = pending.replace(s) {
                self.hand_to(p, Arc::clone(&update), copies, counted && p.every == 1, &mut outcome);
            }
        }
        if let Some(p) = pending {
            self.hand_to(p, update, copies, counted && p.every == 1, &mut outcome);
        }
        if !outcome.closed.is_empty() {
            self.remove_subscribers(&outcome.closed);
        }
        if outcome.uncounted > 0 {
            self.delivered.fetch_add(outcome.uncounted, Ordering::Relaxed);
        }
        outcome.delivered
    }

    /// Hands `copies` copies of `update` to `s`; `counted`: counted in advance as delivered.
    fn hand_to(
        &self,
        s: &Subscriber<T>,
        update: Update<T>,
        copies: usize,
        counted: bool,
        outcome: &mut Outcome,
    ) {
        let seq = update.seq;
        let result = self.door.hand(&s.sink, update, Some(&s.stream), seq, copies);
        if counted && result.is_err() {
            self.taken_back.fetch_add(1, Ordering::Relaxed);
        }
        match result {
            Ok(()) => {
                outcome.delivered += 1;
                outcome.uncounted += u64::from(!counted);
            }
            Err(Undeliverable::Unavailable) => {
                self.failed.fetch_add(1, Ordering::Relaxed);
            }
            Err(Undeliverable::Closed) => outcome.closed.push(s.id),
        }
    }

    pub(crate) fn subscribe(&self, every: NonZeroU32, sink: Sink<Update<T>>) -> u64 {
        self.subscribe_as(every, sink, None)
    }

    /// Subscribes at `every = 1` with a newest-value cell kept here, starting at `seed` (the
    /// client's newest value so far).
    fn subscribe_with_cell(&self, sink: Sink<Update<T>>, seed: Option<Update<T>>) -> u64 {
        self.subscribe_as(NonZeroU32::MIN, sink, Some(seed))
    }

    fn subscribe_as(&self, every: NonZeroU32, sink: Sink<Update<T>>, cell: Option<Option<Update<T>>>) -> u64 {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let sub = Arc::new(Subscriber {
            id,
            every: u64::from(every.get()),
            count: AtomicU64::new(0),
            sink,
            stream: Arc::new(Stream::default()),
        });
        let mut board = self.board.lock();
        if let Some(seed) = cell {
            board.cells.push(Cell {
                id,
                seq: seed.as_ref().map_or(0, |u| u.seq),
                own: seed,
                detached: false,
            });
        }
        board.ones += u64::from(sub.every == 1);
        let next: Subscribers<T> = board.subs.iter().cloned().chain(std::iter::once(sub)).collect();
        board.subs = next;
        id
    }

    pub(crate) fn clock(&self) -> Clock {
        self.clock
    }

    pub(crate) fn latest(&self) -> Option<Update<T>> {
        self.board.lock().latest.clone()
    }

    pub(crate) fn stats(&self) -> PushStats {
        let (published, subscribers, counted) = {
            let board = self.board.lock();
            (board.seq, board.subs.len(), board.counted)
        };
        let delivered = counted + self.delivered.load(Ordering::Relaxed);
        PushStats {
            published,
            delivered: delivered.saturating_sub(self.taken_back.load(Ordering::Relaxed)),
            failed: self.failed.load(Ordering::Relaxed),
            subscribers,
        }
    }
}

impl<T: CommObject> Served for PushEndpoint<T> {
    fn clients(&self) -> Option<usize> {
        Some(self.board.lock().subs.len())
    }

    fn serve_subscribe(self: Arc<Self>, every: NonZeroU32, sink: ByteSink) -> PatternResult<Subscription> {
        let bytes_sink = Sink::from_fn(move |u: Update<T>| {
            if sink(&crate::wire::encode_stamped(&u)) { Ok(()) } else { Err(Undeliverable::Closed) }
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
