//! Delivery targets: where a pattern puts what it hands to a component.
//!
//! A [`Sink`] is the receiving half of every pattern: a component's mailbox (through a
//! [`Mailbox`] that survives restarts), a tokio channel, or a plain function.

use crate::ledger::Receipt;
use parking_lot::{Mutex, RwLock};
use ractor::{ActorCell, ActorRef};
use std::fmt;
use std::sync::{Arc, Weak};
use tokio::sync::mpsc;

/// Why a sink did not take a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Undeliverable {
    /// The receiver is gone for good: the sink should be dropped.
    Closed,
    /// The receiver exists but cannot take values now (its actor is restarting).
    Unavailable,
}

/// A place to deliver values of type `T`.
pub struct Sink<T> {
    deliver: Arc<dyn Fn(T, Option<Receipt>) -> Result<(), Undeliverable> + Send + Sync>,
}

impl<T> Clone for Sink<T> {
    fn clone(&self) -> Self {
        Sink { deliver: Arc::clone(&self.deliver) }
    }
}

impl<T> fmt::Debug for Sink<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Sink")
    }
}

impl<T: Send + 'static> Sink<T> {
    /// A sink that calls `f`. `f` must not block: it runs on the sender's task.
    pub fn from_fn(f: impl Fn(T) -> Result<(), Undeliverable> + Send + Sync + 'static) -> Self {
        Sink {
            deliver: Arc::new(move |v, receipt| {
                let result = f(v);
                crate::ledger::settle(receipt, &result);
                result
            }),
        }
    }

    /// A sink that calls `f` with each value and its receipt, which `f` settles or passes on.
    pub(crate) fn with_receipts(
        f: impl Fn(T, Option<Receipt>) -> Result<(), Undeliverable> + Send + Sync + 'static,
    ) -> Self {
        Sink { deliver: Arc::new(f) }
    }

    /// A sink into an unbounded tokio channel; closed when the receiver is dropped.
    pub fn channel(tx: mpsc::UnboundedSender<T>) -> Self {
        Sink::from_fn(move |v| tx.send(v).map_err(|_| Undeliverable::Closed))
    }

    /// A sink into one ractor actor's mailbox, converting each value with `map`.
    pub fn actor<M: ractor::Message>(
        actor: ActorRef<M>,
        map: impl Fn(T) -> M + Send + Sync + 'static,
    ) -> Self {
        Sink::from_fn(move |v| actor.cast(map(v)).map_err(|_| Undeliverable::Closed))
    }

    /// Delivers one value.
    pub fn deliver(&self, value: T) -> Result<(), Undeliverable> {
        (self.deliver)(value, None)
    }

    /// Delivers one value with its delivery receipt (see [`crate::ledger`]).
    pub(crate) fn deliver_with(&self, value: T, receipt: Option<Receipt>) -> Result<(), Undeliverable> {
        (self.deliver)(value, receipt)
    }
}

/// A message on its way to a component instance: the message, its delivery receipt, and the
/// mailbox it was sent to.
///
/// If it is dropped unopened (its instance died with it queued), it goes back to its mailbox,
/// which hands it to the component's next instance: a restart loses the failed handler's
/// message, never the commands, requests and events queued behind it. Push updates and timer
/// ticks are the exception: the next one supersedes them (see [`Mailbox::sink_latest`]).
pub struct Envelope<M> {
    msg: Option<M>,
    receipt: Option<Receipt>,
    /// The mailbox to go back to (empty when superseded by the next message).
    home: Weak<Shared<M>>,
    /// Whether a newer message replaces this one (a push update): it is not handed to the
    /// next instance, which gets the next update instead.
    superseded_by_next: bool,
}

impl<M> Envelope<M> {
    /// An envelope from no mailbox, with no receipt (for tests of what opens it).
    #[cfg(test)]
    pub(crate) fn loose(msg: M) -> Envelope<M> {
        Envelope { msg: Some(msg), receipt: None, home: Weak::new(), superseded_by_next: false }
    }

    /// The message, settling its receipt as arrived.
    pub(crate) fn open(mut self) -> Option<M> {
        if let Some(r) = self.receipt.take() {
            r.arrived();
        }
        self.msg.take()
    }

    /// Takes the message out, so dropping the envelope does not send it back; returns the
    /// receipt (dropping it unsettled counts the message lost).
    fn discard(mut self) -> Option<Receipt> {
        self.msg = None;
        self.receipt.take()
    }
}

impl<M> fmt::Debug for Envelope<M> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Envelope")
    }
}

impl<M> Drop for Envelope<M> {
    fn drop(&mut self) {
        let Some(msg) = self.msg.take() else { return };
        if self.superseded_by_next {
            if let Some(r) = self.receipt.take() {
                r.superseded();
            }
            return;
        }
        let Some(home) = self.home.upgrade() else { return };
        if let Some(r) = &self.receipt {
            r.redelivered();
        }
        (home.redeliver)(
            &home,
            Envelope {
                msg: Some(msg),
                receipt: self.receipt.take(),
                home: self.home.clone(),
                superseded_by_next: false,
            },
        );
    }
}

/// The mailbox of a component: a slot holding its current actor, rebound on every restart.
///
/// Sinks made from a mailbox outlive actor instances, which is what lets a restarted component
/// keep its subscriptions and its services without anyone re-creating them. Messages queued for
/// an instance that dies are handed to the next one, before anything sent after it started
/// (the message whose handler failed is not: it was handled).
pub struct Mailbox<M> {
    shared: Arc<Shared<M>>,
}

struct Shared<M> {
    slot: RwLock<Slot<M>>,
    /// Messages that came back from a dead instance before the next one was bound. Its lock
    /// also orders rebinding against redelivery.
    orphans: Mutex<Vec<Envelope<M>>>,
    /// [`Shared::redeliver`], stored where `M` is known to be a message, so an envelope's
    /// `Drop` (which cannot require it) can call it.
    redeliver: fn(&Shared<M>, Envelope<M>),
}

struct Slot<M> {
    actor: Option<ActorRef<Envelope<M>>>,
    closed: bool,
}

impl<M: ractor::Message> Shared<M> {
    fn redeliver(&self, env: Envelope<M>) {
        let mut orphans = self.orphans.lock();
        let actor = self.slot.read().actor.clone();
        let env = match actor {
            Some(actor) => match actor.cast(env) {
                Ok(()) => return,
                Err(ractor::MessagingErr::SendErr(env)) => env,
                Err(_) => return,
            },
            None => env,
        };
        if self.slot.read().closed {
            // The component left the system: the message is lost (its receipt says so).
            drop(env.discard());
            return;
        }
        orphans.push(env);
    }
}

impl<M> Clone for Mailbox<M> {
    fn clone(&self) -> Self {
        Mailbox { shared: Arc::clone(&self.shared) }
    }
}

impl<M: ractor::Message> Default for Mailbox<M> {
    fn default() -> Self {
        Mailbox {
            shared: Arc::new(Shared {
                slot: RwLock::new(Slot { actor: None, closed: false }),
                orphans: Mutex::new(Vec::new()),
                redeliver: Shared::redeliver,
            }),
        }
    }
}

impl<M: ractor::Message> Mailbox<M> {
    /// An empty mailbox (no actor bound).
    pub fn new() -> Self {
        Self::default()
    }

    /// Binds the mailbox to an actor instance (not once closed), handing it first the
    /// messages left queued by the previous one.
    pub(crate) fn bind(&self, actor: ActorRef<Envelope<M>>) {
        let mut orphans = self.shared.orphans.lock();
        if self.shared.slot.read().closed {
            return;
        }
        for env in std::mem::take(&mut *orphans) {
            if let Err(ractor::MessagingErr::SendErr(env)) = actor.cast(env) {
                orphans.push(env);
            }
        }
        let old = self.shared.slot.write().actor.replace(actor);
        drop(orphans);
        drop(old);
    }

    /// Unbinds the mailbox if it is still bound to `actor`.
    pub(crate) fn unbind(&self, actor: &ActorRef<Envelope<M>>) {
        let old = {
            let mut slot = self.shared.slot.write();
            if slot.actor.as_ref().map(|a| a.get_id()) == Some(actor.get_id()) {
                slot.actor.take()
            } else {
                None
            }
        };
        drop(old);
    }

    /// Closes the mailbox for good: its component left the system. Sinks made from it report
    /// [`Undeliverable::Closed`], so servers drop them; messages still queued are lost.
    pub fn close(&self) {
        let old = {
            let mut slot = self.shared.slot.write();
            slot.closed = true;
            slot.actor.take()
        };
        drop(old);
        let orphans = std::mem::take(&mut *self.shared.orphans.lock());
        for env in orphans {
            // Its receipt, still unsettled, counts it lost.
            drop(env.discard());
        }
    }

    /// Whether the mailbox was closed.
    pub fn is_closed(&self) -> bool {
        self.shared.slot.read().closed
    }

    /// The actor instance currently bound, if any. After a failure (panic, error, kill) it may
    /// still be the dead instance until the supervisor restarts the component.
    pub fn current(&self) -> Option<ActorCell> {
        self.shared.slot.read().actor.as_ref().map(|a| a.get_cell())
    }

    /// Casts a message to the current instance.
    pub fn cast(&self, msg: M) -> Result<(), Undeliverable> {
        self.cast_with(msg, None, false)
    }

    fn cast_with(
        &self,
        msg: M,
        receipt: Option<Receipt>,
        superseded_by_next: bool,
    ) -> Result<(), Undeliverable> {
        // A superseded message never goes home (see the envelope's `Drop`): it needs no
        // reference to its mailbox, which spares a push update two atomic operations.
        let home = if superseded_by_next { Weak::new() } else { Arc::downgrade(&self.shared) };
        let env = Envelope { msg: Some(msg), receipt, home, superseded_by_next };
        let slot = self.shared.slot.read();
        let refused = match slot.actor.as_ref() {
            Some(actor) => match actor.cast(env) {
                Ok(()) => return Ok(()),
                Err(ractor::MessagingErr::SendErr(env)) => Some(env),
                Err(_) => None,
            },
            None => Some(env),
        };
        let closed = slot.closed;
        drop(slot);
        // Refused: the sender is told, so the envelope must not come back as an orphan.
        if let Some(r) = refused.and_then(Envelope::discard) {
            r.failed();
        }
        Err(if closed { Undeliverable::Closed } else { Undeliverable::Unavailable })
    }

    /// A sink that converts each value with `map` and casts it to the current instance.
    /// What the instance had not handled when it died goes to the next one.
    pub fn sink<T: Send + 'static>(&self, map: impl Fn(T) -> M + Send + Sync + 'static) -> Sink<T> {
        self.sink_as(map, false)
    }

    /// A sink like [`sink`](Self::sink) for values that the next one replaces (push updates,
    /// timer ticks): what the instance had not handled when it died is not handed to the next
    /// one, which acts on fresh values instead of stale ones.
    pub fn sink_latest<T: Send + 'static>(&self, map: impl Fn(T) -> M + Send + Sync + 'static) -> Sink<T> {
        self.sink_as(map, true)
    }

    fn sink_as<T: Send + 'static>(
        &self,
        map: impl Fn(T) -> M + Send + Sync + 'static,
        superseded_by_next: bool,
    ) -> Sink<T> {
        let mailbox = self.clone();
        Sink { deliver: Arc::new(move |v, receipt| mailbox.cast_with(map(v), receipt, superseded_by_next)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_sink_reports_closed_after_receiver_drops() {
        let (tx, rx) = mpsc::unbounded_channel::<u32>();
        let sink = Sink::channel(tx);
        assert_eq!(sink.deliver(1), Ok(()));
        drop(rx);
        assert_eq!(sink.deliver(2), Err(Undeliverable::Closed));
    }

    #[test]
    fn unbound_mailbox_is_unavailable() {
        let mailbox: Mailbox<u32> = Mailbox::new();
        let sink = mailbox.sink(|v: u32| v);
        assert_eq!(sink.deliver(1), Err(Undeliverable::Unavailable));
    }
}
