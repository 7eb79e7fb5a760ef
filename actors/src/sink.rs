//! Delivery targets: where a pattern puts what it hands to a component.
//!
//! A [`Sink`] is the receiving half of every pattern: a component's mailbox (through a
//! [`Mailbox`] that survives restarts), a tokio channel, or a plain function.

use parking_lot::RwLock;
use ractor::ActorRef;
use std::fmt;
use std::sync::Arc;
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
    deliver: Arc<dyn Fn(T) -> Result<(), Undeliverable> + Send + Sync>,
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
        (self.deliver)(value)
    }
}

/// The mailbox of a component: a slot holding its current actor, rebound on every restart.
///
/// Sinks made from a mailbox outlive actor instances, which is what lets a restarted component
/// keep its subscriptions and its services without anyone re-creating them.
pub struct Mailbox<M> {
    slot: Arc<RwLock<Slot<M>>>,
}

struct Slot<M> {
    actor: Option<ActorRef<M>>,
    closed: bool,
}

impl<M> Clone for Mailbox<M> {
    fn clone(&self) -> Self {
        Mailbox { slot: Arc::clone(&self.slot) }
    }
}

impl<M> Default for Mailbox<M> {
    fn default() -> Self {
        Mailbox { slot: Arc::new(RwLock::new(Slot { actor: None, closed: false })) }
    }
}

impl<M: ractor::Message> Mailbox<M> {
    /// An empty mailbox (no actor bound).
    pub fn new() -> Self {
        Self::default()
    }

    /// Binds the mailbox to an actor instance (not once closed).
    pub fn bind(&self, actor: ActorRef<M>) {
        let mut slot = self.slot.write();
        if !slot.closed {
            slot.actor = Some(actor);
        }
    }

    /// Unbinds the mailbox if it is still bound to `actor`.
    pub fn unbind(&self, actor: &ActorRef<M>) {
        let mut slot = self.slot.write();
        if slot.actor.as_ref().map(|a| a.get_id()) == Some(actor.get_id()) {
            slot.actor = None;
        }
    }

    /// Closes the mailbox for good: its component left the system. Sinks made from it report
    /// [`Undeliverable::Closed`], so servers drop them.
    pub fn close(&self) {
        let mut slot = self.slot.write();
        slot.closed = true;
        slot.actor = None;
    }

    /// Whether the mailbox was closed.
    pub fn is_closed(&self) -> bool {
        self.slot.read().closed
    }

    /// The actor instance currently bound, if any. After a failure (panic, error, kill) it may
    /// still be the dead instance until the supervisor restarts the component.
    pub fn current(&self) -> Option<ActorRef<M>> {
        self.slot.read().actor.clone()
    }

    /// Casts a message to the current instance.
    pub fn cast(&self, msg: M) -> Result<(), Undeliverable> {
        let slot = self.slot.read();
        match slot.actor.as_ref() {
            Some(actor) => actor.cast(msg).map_err(|_| Undeliverable::Unavailable),
            None if slot.closed => Err(Undeliverable::Closed),
            None => Err(Undeliverable::Unavailable),
        }
    }

    /// A sink that converts each value with `map` and casts it to the current instance.
    pub fn sink<T: Send + 'static>(&self, map: impl Fn(T) -> M + Send + Sync + 'static) -> Sink<T> {
        let mailbox = self.clone();
        Sink::from_fn(move |v| mailbox.cast(map(v)))
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
