//! Delivery accounting: for every service, what was offered, what reached a handler, what the
//! sender was told failed, what a fault plan took away, what arrived twice, and what vanished
//! without anyone being told.
//!
//! Each message a pattern hands to a receiver carries a [`Receipt`] while the registry's
//! [`Ledger`] is enabled ([`Ledger::enable`]; off by default, so the message path costs one
//! atomic load). The receipt is settled exactly once:
//! - **delivered** when a component's handler receives the message (or, for a sink that is not
//!   a component, when the sink takes it);
//! - **duplicate** instead, when the receiver already saw that sequence number from the same
//!   sender (a window of the last [`WINDOW`] numbers per sender);
//! - **failed** when the sender was told: the hand-over returned an error;
//! - **lost** when it is dropped unsettled: the message vanished and its sender believes it
//!   was handed over. A message queued for a component whose instance dies is not lost: the
//!   mailbox hands it to the next instance (see [`Mailbox`](crate::Mailbox)), except a push
//!   update, which is **superseded** (the next update replaces it); it is lost only
//!   if the component leaves the system for good with the message queued, or if a message a
//!   delay fault held back (its sender already told it was handed over) cannot be handed over
//!   when it is let go.
//!
//! Messages a fault plan drops are counted apart ([`DeliveryCounts::dropped`]): they are the
//! plan's, not the system's. What remains unsettled when the counts are read is in flight
//! (queued, or held back by a delay fault).
//!
//! Duplicates are told apart by sender: a Send or Query client (and its clones), a push
//! subscription.
//! Messages that arrive from other processes carry their sender's sequence numbers but not its
//! identity, so they are counted delivered, never duplicate.

use crate::addr::{PatternKind, ServiceAddr};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// How many sequence numbers behind the newest a receiver remembers, per sender.
pub const WINDOW: u64 = 1024;

/// The figures of one service.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DeliveryCounts {
    /// Messages handed to the pattern by senders (a push counts once per subscriber whose
    /// turn it was).
    pub offered: u64,
    /// Extra copies a duplicate fault made.
    pub copies_injected: u64,
    /// Messages that reached a receiver (first arrival).
    pub delivered: u64,
    /// Arrivals of a sequence number the receiver had already seen from that sender.
    pub duplicates: u64,
    /// Messages whose sender was told they could not be handed over (the receiver was
    /// restarting or gone).
    pub failed: u64,
    /// Messages a fault plan dropped on purpose.
    pub dropped: u64,
    /// Messages that vanished while their sender believed them handed over.
    pub lost: u64,
    /// Messages queued for a component instance that died, handed to its next instance.
    pub redelivered: u64,
    /// Push updates queued for a component instance that died, not handed to the next
    /// instance because a newer update replaces them.
    pub superseded: u64,
}

impl DeliveryCounts {
    /// Messages not settled yet: queued, or held back by a delay fault.
    pub fn in_flight(&self) -> u64 {
        (self.offered + self.copies_injected).saturating_sub(
            self.delivered + self.duplicates + self.failed + self.dropped + self.lost + self.superseded,
        )
    }

    /// Adds `other`'s figures to these.
    pub fn add(&mut self, other: &DeliveryCounts) {
        self.offered += other.offered;
        self.copies_injected += other.copies_injected;
        self.delivered += other.delivered;
        self.duplicates += other.duplicates;
        self.failed += other.failed;
        self.dropped += other.dropped;
        self.lost += other.lost;
        self.redelivered += other.redelivered;
        self.superseded += other.superseded;
    }
}

/// The running figures of one service.
#[derive(Debug, Default)]
pub(crate) struct Tally {
    kind: Option<PatternKind>,
    offered: AtomicU64,
    copies_injected: AtomicU64,
    delivered: AtomicU64,
    duplicates: AtomicU64,
    failed: AtomicU64,
    dropped: AtomicU64,
    lost: AtomicU64,
    redelivered: AtomicU64,
    superseded: AtomicU64,
}

impl Tally {
    fn counts(&self) -> DeliveryCounts {
        let l = |a: &AtomicU64| a.load(Ordering::Relaxed);
        DeliveryCounts {
            offered: l(&self.offered),
            copies_injected: l(&self.copies_injected),
            delivered: l(&self.delivered),
            duplicates: l(&self.duplicates),
            failed: l(&self.failed),
            dropped: l(&self.dropped),
            lost: l(&self.lost),
            redelivered: l(&self.redelivered),
            superseded: l(&self.superseded),
        }
    }
}

/// What one receiver remembers of one sender's sequence numbers: the newest, and which of the
/// [`WINDOW`] before it arrived.
#[derive(Debug, Default)]
pub(crate) struct Stream {
    seen: Mutex<Window>,
}

#[derive(Debug, Default)]
struct Window {
    newest: u64,
    /// A ring: bit `m % 64` of word `(m / 64) % (WINDOW / 64)` says whether number `m` arrived,
    /// for `m` from `newest - WINDOW + 1` to `newest`. A number arriving in order touches one
    /// word (a window shifted along would rewrite all of them).
    bits: [u64; (WINDOW / 64) as usize],
}

impl Window {
    fn slot(m: u64) -> (usize, u64) {
        (((m / 64) % (WINDOW / 64)) as usize, 1 << (m % 64))
    }

    /// Forgets numbers `from` to `to - 1`, whose places in the ring now stand for newer ones.
    fn clear(&mut self, mut from: u64, to: u64) {
        if to - from >= WINDOW {
            self.bits = [0; (WINDOW / 64) as usize];
            return;
        }
        while from < to {
            let (word, first) = Window::slot(from);
            let span = (64 - from % 64).min(to - from);
            let mask = if span == 64 { u64::MAX } else { ((1u64 << span) - 1) * first };
            self.bits[word] &= !mask;
            from += span;
        }
    }
}

impl Stream {
    /// Records that `n` arrived; whether it had arrived before. Numbers older than the window
    /// are taken as first arrivals.
    fn arrived(&self, n: u64) -> bool {
        let mut w = self.seen.lock();
        if n > w.newest {
            // The places of the numbers now in the window, but for `n`, held older ones.
            let from = w.newest + 1;
            w.clear(from, n);
            w.newest = n;
            let (word, bit) = Window::slot(n);
            w.bits[word] |= bit;
            return false;
        }
        if w.newest - n >= WINDOW {
            return false;
        }
        let (word, bit) = Window::slot(n);
        let before = w.bits[word] & bit != 0;
        w.bits[word] |= bit;
        before
    }
}

/// What a receiver saw of one sender's numbered stream of messages from another process,
/// whose numbers count every message the sender put on the link (1, 2, 3, ...): which arrived,
/// which arrived twice, and which never came.
///
/// A receiver sees only what arrives, so it counts from the first number it receives (what the
/// sender put before, while this receiver was not there, is not its loss) up to the newest; a
/// number skipped is **missing** until it arrives **late** (out of order). Always:
/// `newest - first + 1 == arrived + missing`, where `arrived` counts each number once and
/// `duplicates` counts the extra arrivals. What the sender put after the newest is in flight,
/// or was lost when the link ended: only the sender's count tells (see the net crate).
#[derive(Debug, Default)]
pub struct Sequence {
    state: Mutex<SequenceState>,
}

#[derive(Debug, Default)]
struct SequenceState {
    window: Window,
    counts: SequenceCounts,
}

/// The figures of a [`Sequence`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SequenceCounts {
    /// The first number received (0: none yet).
    pub first: u64,
    /// The highest number received.
    pub newest: u64,
    /// Numbers received, each once.
    pub arrived: u64,
    /// Arrivals of a number already received.
    pub duplicates: u64,
    /// Numbers between the first and the newest never received.
    pub missing: u64,
    /// Numbers received after a higher one (counted missing until then).
    pub late: u64,
}

/// What an arrival was, by its number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arrival {
    /// Its first arrival.
    New,
    /// It had arrived before.
    Again,
    /// 0 is not a message number: not counted.
    Invalid,
}

impl Sequence {
    /// Records that number `n` arrived.
    pub fn arrive(&self, n: u64) -> Arrival {
        if n == 0 {
            return Arrival::Invalid;
        }
        let mut s = self.state.lock();
        let SequenceState { window, counts: c } = &mut *s;
        if c.arrived == 0 {
            c.first = n;
            c.newest = n;
            c.arrived = 1;
            window.newest = n;
            let (word, bit) = Window::slot(n);
            window.bits[word] |= bit;
            return Arrival::New;
        }
        if n > c.newest {
            c.missing = c.missing.saturating_add(n - c.newest - 1);
            c.newest = n;
        } else if n < c.first {
            // Sent before the first one received, and overtaken by it.
            c.missing = c.missing.saturating_add(c.first - n - 1);
            c.first = n;
            c.late += 1;
        } else if c.newest - n >= WINDOW {
            // Too old to tell: taken as a late first arrival.
            c.missing = c.missing.saturating_sub(1);
            c.late += 1;
            c.arrived += 1;
            return Arrival::New;
        } else {
            let (word, bit) = Window::slot(n);
            if window.bits[word] & bit != 0 {
                c.duplicates += 1;
                return Arrival::Again;
            }
            c.missing = c.missing.saturating_sub(1);
            c.late += 1;
        }
        c.arrived += 1;
        // The window remembers the numbers up to `newest` (this one included).
        let from = window.newest + 1;
        if c.newest > window.newest {
            window.clear(from, c.newest);
            window.newest = c.newest;
        }
        if c.newest - n < WINDOW {
            let (word, bit) = Window::slot(n);
            window.bits[word] |= bit;
        }
        Arrival::New
    }

    /// The figures so far.
    pub fn counts(&self) -> SequenceCounts {
        self.state.lock().counts
    }
}

/// A message's claim on its service's figures, settled once (see the module docs).
#[derive(Debug)]
pub struct Receipt {
    tally: Arc<Tally>,
    stream: Option<Arc<Stream>>,
    n: u64,
    live: bool,
    /// Whether a failure to hand the message over is a loss: its sender was already told it
    /// was handed over (a delay fault held it back).
    silent: bool,
    /// Whether the message's sender hears if it vanishes (a query's client does).
    reported: bool,
}

impl Receipt {
    /// This receipt, for a message whose sender hears if it vanishes.
    pub(crate) fn reported(mut self) -> Self {
        self.reported = true;
        self
    }

    /// This receipt, for a message whose sender was already told it was handed over.
    pub(crate) fn silent(mut self) -> Self {
        self.silent = true;
        self
    }

    /// The message reached its receiver.
    pub(crate) fn arrived(mut self) {
        self.live = false;
        let again = self.stream.as_ref().is_some_and(|s| s.arrived(self.n));
        let counter = if again { &self.tally.duplicates } else { &self.tally.delivered };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// The sender was told the message could not be handed over.
    pub(crate) fn failed(mut self) {
        self.live = false;
        let counter = if self.silent { &self.tally.lost } else { &self.tally.failed };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// The message was replaced by a newer one before its receiver handled it.
    pub(crate) fn superseded(mut self) {
        self.live = false;
        self.tally.superseded.fetch_add(1, Ordering::Relaxed);
    }

    /// The message is being handed to another instance of its receiver.
    pub(crate) fn redelivered(&self) {
        self.tally.redelivered.fetch_add(1, Ordering::Relaxed);
    }
}

impl Drop for Receipt {
    fn drop(&mut self) {
        if self.live {
            let counter = if self.reported { &self.tally.failed } else { &self.tally.lost };
            counter.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The figures of one service, as a sender sees them: makes receipts and counts what never
/// gets one.
#[derive(Debug, Clone)]
pub(crate) struct Account {
    enabled: Arc<AtomicBool>,
    tally: Arc<Tally>,
}

impl Account {
    /// Whether messages are being accounted (one atomic load).
    pub(crate) fn on(&self) -> bool {
        self.enabled.load(Ordering::Relaxed)
    }

    /// One message offered, with its receipt (`None` while accounting is off). `stream` and
    /// `n` identify it for duplicate detection.
    pub(crate) fn offer(&self, stream: Option<&Arc<Stream>>, n: u64) -> Option<Receipt> {
        self.on().then(|| {
            self.tally.offered.fetch_add(1, Ordering::Relaxed);
            self.receipt(stream, n)
        })
    }

    /// The receipt of an extra copy a duplicate fault made of message `n`.
    pub(crate) fn copy(&self, stream: Option<&Arc<Stream>>, n: u64) -> Option<Receipt> {
        self.on().then(|| {
            self.tally.copies_injected.fetch_add(1, Ordering::Relaxed);
            self.receipt(stream, n)
        })
    }

    /// One message offered that a fault plan dropped.
    pub(crate) fn dropped(&self) {
        if self.on() {
            self.tally.offered.fetch_add(1, Ordering::Relaxed);
            self.tally.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn receipt(&self, stream: Option<&Arc<Stream>>, n: u64) -> Receipt {
        Receipt {
            tally: Arc::clone(&self.tally),
            stream: stream.cloned(),
            n,
            live: true,
            silent: false,
            reported: false,
        }
    }
}

/// Settles `receipt` by the outcome of a hand-over to a sink that is not a component.
pub(crate) fn settle<E>(receipt: Option<Receipt>, result: &Result<(), E>) {
    if let Some(r) = receipt {
        match result {
            Ok(()) => r.arrived(),
            Err(_) => r.failed(),
        }
    }
}

/// The delivery figures of one system, per service (see the module docs).
#[derive(Clone, Default)]
pub struct Ledger {
    enabled: Arc<AtomicBool>,
    tallies: Arc<Mutex<BTreeMap<ServiceAddr, Arc<Tally>>>>,
}

impl std::fmt::Debug for Ledger {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ledger")
            .field("enabled", &self.enabled.load(Ordering::Relaxed))
            .finish_non_exhaustive()
    }
}

impl Ledger {
    /// Starts (or stops) accounting for messages offered from now on.
    pub fn enable(&self, on: bool) {
        self.enabled.store(on, Ordering::Relaxed);
    }

    /// Whether messages are being accounted.
    pub fn is_enabled(&self) -> bool {
        self.enabled.load(Ordering::Relaxed)
    }

    /// The account of the service at `addr` (made on first use; a service registered again
    /// under the same address keeps adding to the same figures).
    pub(crate) fn account(&self, addr: &ServiceAddr, kind: PatternKind) -> Account {
        let tally = Arc::clone(
            self.tallies
                .lock()
                .entry(addr.clone())
                .or_insert_with(|| Arc::new(Tally { kind: Some(kind), ..Tally::default() })),
        );
        Account { enabled: Arc::clone(&self.enabled), tally }
    }

    /// The figures so far, per service, with each service's pattern.
    pub fn counts(&self) -> Vec<(ServiceAddr, PatternKind, DeliveryCounts)> {
        self.tallies.lock().iter().filter_map(|(a, t)| t.kind.map(|k| (a.clone(), k, t.counts()))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn account() -> (Ledger, Account) {
        let ledger = Ledger::default();
        ledger.enable(true);
        let addr = ServiceAddr::new("a", "b");
        let account = ledger.account(&addr, PatternKind::Send);
        (ledger, account)
    }

    #[test]
    fn every_receipt_is_settled_once_and_the_unsettled_are_lost() {
        let (ledger, acc) = account();
        let s = Arc::new(Stream::default());
        acc.offer(Some(&s), 1).expect("on").arrived();
        acc.offer(Some(&s), 2).expect("on").failed();
        drop(acc.offer(Some(&s), 3));
        acc.dropped();
        let held = acc.offer(Some(&s), 4);
        let c = ledger.counts()[0].2;
        assert_eq!((c.offered, c.delivered, c.failed, c.lost, c.dropped), (5, 1, 1, 1, 1));
        assert_eq!(c.in_flight(), 1, "the held receipt");
        drop(held);
        assert_eq!(ledger.counts()[0].2.in_flight(), 0);
    }

    #[test]
    fn a_number_seen_again_from_the_same_sender_is_a_duplicate() {
        let (ledger, acc) = account();
        let (s1, s2) = (Arc::new(Stream::default()), Arc::new(Stream::default()));
        acc.offer(Some(&s1), 7).expect("on").arrived();
        acc.copy(Some(&s1), 7).expect("on").arrived();
        acc.offer(Some(&s2), 7).expect("on").arrived();
        acc.offer(None, 7).expect("on").arrived();
        acc.offer(None, 7).expect("on").arrived();
        let c = ledger.counts()[0].2;
        assert_eq!((c.delivered, c.duplicates, c.copies_injected), (4, 1, 1));
        assert_eq!(c.in_flight(), 0);
    }

    #[test]
    fn the_window_remembers_out_of_order_numbers_and_forgets_the_oldest() {
        let s = Stream::default();
        for n in [5, 3, 9, 4] {
            assert!(!s.arrived(n), "{n} is new");
        }
        for n in [5, 3, 9, 4] {
            assert!(s.arrived(n), "{n} was seen");
        }
        assert!(!s.arrived(8));
        assert!(!s.arrived(9 + 63));
        assert!(s.arrived(9), "63 behind: still in the first word");
        assert!(!s.arrived(9 + 64 + 130));
        assert!(s.arrived(9), "194 behind: across words");
        assert!(s.arrived(72), "carried across the word boundary");
        assert!(!s.arrived(7), "never seen");
        assert!(!s.arrived(5000));
        assert!(!s.arrived(9), "beyond the window: taken as new");
    }

    /// The ring against the plainest model of the window: every number kept, the window's
    /// rule applied on lookup. Runs of steps of every size, in and out of order.
    #[test]
    fn the_window_agrees_with_a_model_that_keeps_every_number() {
        let s = Stream::default();
        let mut seen = std::collections::BTreeSet::new();
        let mut newest = 0u64;
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut n = 1u64;
        for i in 0..200_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            n = match x % 16 {
                0..=6 => n + 1,
                7..=8 => n + 1 + x % 70,
                9 => n + 1 + (x >> 8) % 3000,
                10..=12 => n.saturating_sub(x % 40),
                13..=14 => n.saturating_sub((x >> 8) % 1100),
                _ => n,
            };
            let model = if n > newest { false } else { newest - n < WINDOW && seen.contains(&n) };
            newest = newest.max(n);
            seen.insert(n);
            assert_eq!(s.arrived(n), model, "step {i}: number {n}, newest {newest}");
        }
    }

    /// A sequence against a model that keeps every number: arrived + missing always spans
    /// first..=newest, a number twice is a duplicate, a gap filled later is late.
    #[test]
    fn a_sequence_counts_what_arrived_what_arrived_twice_and_what_never_came() {
        let s = Sequence::default();
        assert_eq!(s.arrive(0), Arrival::Invalid);
        for n in [5, 6, 9, 7, 7, 12, 3] {
            s.arrive(n);
        }
        let c = s.counts();
        // Received 3, 5, 6, 7, 9, 12 of 3..=12; 7 twice; 7 and 3 came after higher ones.
        assert_eq!((c.first, c.newest, c.arrived, c.duplicates, c.late), (3, 12, 6, 1, 2));
        assert_eq!(c.missing, 4, "4, 8, 10, 11");

        let s = Sequence::default();
        let mut seen = std::collections::BTreeSet::new();
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut n = 1000u64;
        for i in 0..100_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            n = match x % 10 {
                // Forward on the whole, back at most 30: always inside the window.
                0..=6 => n + 1,
                7 => n + 1 + x % 50,
                8 => n.saturating_sub(x % 30).max(1),
                _ => n,
            };
            let again = seen.contains(&n);
            seen.insert(n);
            let got = s.arrive(n);
            assert_eq!(got == Arrival::Again, again, "step {i}: {n}");
            let c = s.counts();
            let (first, newest) = (*seen.first().expect("one"), *seen.last().expect("one"));
            assert_eq!((c.first, c.newest), (first, newest));
            assert_eq!(c.arrived, seen.len() as u64);
            assert_eq!(c.arrived + c.missing, newest - first + 1, "step {i}");
        }
    }

    #[test]
    fn nothing_is_counted_while_off() {
        let (ledger, acc) = account();
        ledger.enable(false);
        assert!(acc.offer(None, 1).is_none());
        acc.dropped();
        assert_eq!(ledger.counts()[0].2, DeliveryCounts::default());
    }
}
