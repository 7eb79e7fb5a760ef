//! The door of a service: the one layer every pattern's messages pass on their way in.
//!
//! Each served endpoint (Send, Query, Push newest, Push timed, Event) owns one [`Door`]. The
//! pattern decides *when* a message moves and *to whom* (a Send to its server, a push to the
//! subscribers whose turn it is, an event to the activations whose condition holds); the door
//! does the same three things to every message, whatever its pattern:
//!
//! 1. shows it to the system's [tap](crate::tap), once, on the service's topic;
//! 2. asks the [fault switchboard](crate::fault) what becomes of it ([`Pass`]): handed over,
//!    lost, handed over late, or handed over twice;
//! 3. hands it over with a [receipt](crate::ledger) per copy, so the delivery ledger settles
//!    each one exactly once.
//!
//! A pattern never touches the tap, the faults or the ledger itself: they are all here, so a
//! new pattern (or a change to how faults work) is made in one place.
//!
//! Costs with no tap, no fault and no ledger: one atomic load each, as before the door.

use crate::addr::{PatternKind, ServiceAddr};
use crate::clock::Timestamp;
use crate::fault::{Faults, Verdict};
use crate::ledger::{Account, Receipt, Stream};
use crate::registry::Registry;
use crate::sink::{Sink, Undeliverable};
use crate::tap::TapSlot;
use serde::Serialize;
use std::sync::Arc;
use std::time::Duration;

/// What the fault plan makes of one message.
pub(crate) enum Pass {
    /// Hand it over this many times (two under a duplicate fault).
    Now(usize),
    /// Lose it.
    Lost,
    /// Hand it over after this long, on this runtime.
    Later(Duration, tokio::runtime::Handle),
}

/// What a duplicate fault makes of a message: the copy a second hand-over carries.
pub(crate) trait Duplicate {
    /// The second copy.
    fn duplicate(&self) -> Self;
}

impl<T: Clone> Duplicate for crate::stamped::Stamped<T> {
    fn duplicate(&self) -> Self {
        self.clone()
    }
}

impl<T> Duplicate for Arc<T> {
    fn duplicate(&self) -> Self {
        Arc::clone(self)
    }
}

/// Where one service's messages enter it (see the module docs).
pub(crate) struct Door {
    addr: ServiceAddr,
    topic: Arc<str>,
    tap: TapSlot,
    faults: Faults,
    account: Account,
    /// Whether a message's sender hears when it vanishes (a query's client does: its answer
    /// never comes), so that a vanished message counts as failed, not lost.
    reported: bool,
}

impl Door {
    /// The door of the service of pattern `kind` at `addr`.
    pub(crate) fn new(registry: &Registry, addr: &ServiceAddr, kind: PatternKind) -> Door {
        Door {
            addr: addr.clone(),
            topic: addr.to_string().into(),
            tap: registry.tap_slot(),
            faults: registry.faults(),
            account: registry.account(addr, kind),
            reported: kind == PatternKind::Query,
        }
    }

    /// The service's address.
    pub(crate) fn addr(&self) -> &ServiceAddr {
        &self.addr
    }

    /// The tap, for what leaves the service on another topic (a query's answers).
    pub(crate) fn tap(&self) -> &TapSlot {
        &self.tap
    }

    /// Shows a message (of communication object `type_id`, sent at `sent_at`) to the tap.
    #[inline]
    pub(crate) fn show<M: Serialize + ?Sized>(&self, type_id: &str, sent_at: Timestamp, msg: &M) {
        self.tap.record(&self.topic, type_id, sent_at, msg);
    }

    /// Shows a message that came from another process if `remote` to the tap.
    #[inline]
    pub(crate) fn show_from<M: Serialize + ?Sized>(
        &self,
        type_id: &str,
        sent_at: Timestamp,
        msg: &M,
        remote: bool,
    ) {
        self.tap.record_from(&self.topic, type_id, sent_at, msg, remote);
    }

    /// What the fault plan makes of the next message. A delay with no runtime to wait on is
    /// no delay.
    #[inline]
    pub(crate) fn pass(&self) -> Pass {
        match self.faults.verdict(&self.addr) {
            Verdict::Deliver => Pass::Now(1),
            Verdict::Duplicate => Pass::Now(2),
            Verdict::Drop => Pass::Lost,
            Verdict::Delay(d) => match tokio::runtime::Handle::try_current() {
                Ok(rt) => Pass::Later(d, rt),
                Err(_) => Pass::Now(1),
            },
        }
    }

    /// Shows a message to the tap, then asks the fault plan what becomes of it.
    #[inline]
    pub(crate) fn enter<M: Serialize + ?Sized>(&self, type_id: &str, sent_at: Timestamp, msg: &M) -> Pass {
        self.show(type_id, sent_at, msg);
        self.pass()
    }

    /// As [`enter`](Self::enter), for a message from another process if `remote`.
    #[inline]
    pub(crate) fn enter_from<M: Serialize + ?Sized>(
        &self,
        type_id: &str,
        sent_at: Timestamp,
        msg: &M,
        remote: bool,
    ) -> Pass {
        self.show_from(type_id, sent_at, msg, remote);
        self.pass()
    }

    /// Hands `msg`, number `n` of `from`'s sequence (for duplicate detection; `None` when the
    /// sender is unknown), to `sink` `copies` times, each with its receipt.
    #[inline]
    pub(crate) fn hand<M: Duplicate + Send + 'static>(
        &self,
        sink: &Sink<M>,
        msg: M,
        from: Option<&Arc<Stream>>,
        n: u64,
        copies: usize,
    ) -> Result<(), Undeliverable> {
        if copies <= 1 {
            return sink.deliver_with(msg, self.offer(from, n));
        }
        let mut result = sink.deliver_with(msg.duplicate(), self.offer(from, n));
        for _ in 2..copies {
            result = result.and(sink.deliver_with(msg.duplicate(), self.account.copy(from, n)));
        }
        result.and(sink.deliver_with(msg, self.account.copy(from, n)))
    }

    /// Hands `msg` to `sink` after `delay` on `rt` (a delay fault). Its sender was told it was
    /// handed over, so if the hand-over then fails the message is lost (unless its sender hears,
    /// see [`Door::new`]).
    pub(crate) fn hand_later<M: Send + 'static>(
        &self,
        rt: &tokio::runtime::Handle,
        delay: Duration,
        sink: &Sink<M>,
        msg: M,
        from: Option<&Arc<Stream>>,
        n: u64,
    ) {
        let receipt = self.offer(from, n).map(|r| if self.reported { r } else { r.silent() });
        let sink = sink.clone();
        rt.spawn(async move {
            tokio::time::sleep(delay).await;
            let _ = sink.deliver_with(msg, receipt);
        });
    }

    /// One message the fault plan lost, at one receiver.
    #[inline]
    pub(crate) fn lost(&self) {
        self.account.dropped();
    }

    #[inline]
    fn offer(&self, from: Option<&Arc<Stream>>, n: u64) -> Option<Receipt> {
        let receipt = self.account.offer(from, n);
        if self.reported { receipt.map(Receipt::reported) } else { receipt }
    }
}
