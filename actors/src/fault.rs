//! Fault injection: break a running system on purpose, and see what it did about it.
//!
//! Every [`Registry`](crate::Registry) has a [`Faults`] switchboard. Through it a test or a fault
//! plan can:
//! - make a component's next handler **panic** or **hang** ([`Faults::arm`]): the instance
//!   fails (a panic is caught by ractor; a hang is caught by the component's handler watchdog,
//!   see [`ComponentHandle::with_handler_timeout`](crate::ComponentHandle::with_handler_timeout))
//!   and its supervisor restarts it;
//! - **kill** a component's running instance ([`Faults::kill`]);
//! - **drop**, **delay** or **duplicate** the messages a service hands over
//!   ([`Faults::set_message_fault`]), where they enter it (the service's door, which every
//!   pattern's messages pass): Send messages, Query requests, push updates and events alike. A
//!   lost request is never answered (its client hears `NoAnswer`); a duplicated one is handled
//!   twice and answered once; a lost or delayed firing still ends a single event activation.
//!
//! It also keeps the log of what happened ([`FaultEvent`]): each injection, the moment the
//! failure was detected (the handler panicked, the watchdog fired, the instance was killed) and
//! the moment the component was back (the first message its new instance handled). With no fault
//! set, the cost on the message path is one atomic load, and on a component's handler two.

use crate::addr::ServiceAddr;
use crate::clock::{Clock, Timestamp};
use parking_lot::{Mutex, RwLock};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

/// What a component's next handler does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HandlerFault {
    /// Panics.
    Panic,
    /// Never returns.
    Hang,
}

/// What happens to the messages a service hands over while the fault is set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MessageFault {
    /// They are lost.
    Drop,
    /// They arrive this much later.
    Delay(Duration),
    /// They arrive twice.
    Duplicate,
}

/// One entry of the fault log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultEvent {
    /// When, on the system's clock.
    pub at: Timestamp,
    /// The component or service.
    pub target: String,
    /// What happened.
    pub what: FaultEventKind,
}

/// What a [`FaultEvent`] records.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultEventKind {
    /// A fault was injected (its kind).
    Injected(String),
    /// The failure was seen: the handler panicked, hung past its timeout, or was killed.
    Detected(String),
    /// The component's new instance handled its first message.
    Recovered,
}

/// Counts of message faults applied, per service.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MessageFaultCounts {
    /// Messages dropped.
    pub dropped: u64,
    /// Messages delayed.
    pub delayed: u64,
    /// Messages duplicated (each counts once).
    pub duplicated: u64,
}

type Killer = Arc<dyn Fn() -> bool + Send + Sync>;

#[derive(Default)]
struct Inner {
    /// Whether any message fault is set (the fast path reads only this).
    any_message: AtomicBool,
    /// Entries in `armed` and `recovering` together, kept under their locks (a handler's fast
    /// path reads only this).
    handler_entries: AtomicUsize,
    armed: Mutex<HashMap<String, HandlerFault>>,
    messages: RwLock<HashMap<ServiceAddr, MessageFault>>,
    counts: Mutex<HashMap<ServiceAddr, MessageFaultCounts>>,
    killers: Mutex<HashMap<String, Killer>>,
    log: Mutex<Vec<FaultEvent>>,
    /// Components whose new instance has not handled a message yet since a detected failure.
    recovering: Mutex<HashMap<String, ()>>,
}

/// The fault switchboard of one system; cheap to clone.
#[derive(Clone)]
pub struct Faults {
    inner: Arc<Inner>,
    clock: Clock,
}

impl std::fmt::Debug for Faults {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Faults").field("events", &self.inner.log.lock().len()).finish_non_exhaustive()
    }
}

/// What the message path does with one message.
pub(crate) enum Verdict {
    /// Hand it over as usual.
    Deliver,
    /// Lose it.
    Drop,
    /// Hand it over after this long.
    Delay(Duration),
    /// Hand it over twice.
    Duplicate,
}

impl Faults {
    pub(crate) fn new(clock: Clock) -> Self {
        Faults { inner: Arc::new(Inner::default()), clock }
    }

    fn log(&self, target: &str, what: FaultEventKind) {
        self.inner.log.lock().push(FaultEvent { at: self.clock.now(), target: target.to_string(), what });
    }

    /// Writes `what` happened to `target` into the log: for faults injected outside the
    /// framework (the simulated world's events), so the log holds every fault of a plan.
    pub fn note(&self, target: &str, what: FaultEventKind) {
        self.log(target, what);
    }

    /// Makes `component`'s next handler fail this way (once).
    pub fn arm(&self, component: &str, fault: HandlerFault) {
        {
            let mut armed = self.inner.armed.lock();
            if armed.insert(component.to_string(), fault).is_none() {
                self.inner.handler_entries.fetch_add(1, Ordering::Release);
            }
        }
        let kind = match fault {
            HandlerFault::Panic => "panic",
            HandlerFault::Hang => "hang",
        };
        self.log(component, FaultEventKind::Injected(kind.into()));
    }

    /// Kills `component`'s running instance (its supervisor restarts it); whether one was running.
    pub fn kill(&self, component: &str) -> bool {
        let killer = self.inner.killers.lock().get(component).cloned();
        self.log(component, FaultEventKind::Injected("kill".into()));
        let killed = killer.is_some_and(|k| k());
        if killed {
            self.detected(component, "killed");
        }
        killed
    }

    /// Sets (or with `None` clears) the fault applied to the messages of the service at `addr`.
    pub fn set_message_fault(&self, addr: &ServiceAddr, fault: Option<MessageFault>) {
        let mut messages = self.inner.messages.write();
        match fault {
            Some(f) => {
                messages.insert(addr.clone(), f);
                let kind = match f {
                    MessageFault::Drop => "drop",
                    MessageFault::Delay(_) => "delay",
                    MessageFault::Duplicate => "duplicate",
                };
                self.log(&addr.to_string(), FaultEventKind::Injected(kind.into()));
            }
            None => {
                messages.remove(addr);
            }
        }
        self.inner.any_message.store(!messages.is_empty(), Ordering::Release);
    }

    /// The fault log so far.
    pub fn events(&self) -> Vec<FaultEvent> {
        self.inner.log.lock().clone()
    }

    /// Entries in the fault log so far (without copying it).
    pub fn event_count(&self) -> usize {
        self.inner.log.lock().len()
    }

    /// Message faults applied so far, per service.
    pub fn message_counts(&self) -> Vec<(ServiceAddr, MessageFaultCounts)> {
        let mut v: Vec<_> = self.inner.counts.lock().iter().map(|(a, c)| (a.clone(), *c)).collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    }

    /// What to do with a message of the service at `addr`.
    pub(crate) fn verdict(&self, addr: &ServiceAddr) -> Verdict {
        if !self.inner.any_message.load(Ordering::Acquire) {
            return Verdict::Deliver;
        }
        let Some(fault) = self.inner.messages.read().get(addr).copied() else { return Verdict::Deliver };
        let mut counts = self.inner.counts.lock();
        let c = counts.entry(addr.clone()).or_default();
        match fault {
            MessageFault::Drop => {
                c.dropped += 1;
                Verdict::Drop
            }
            MessageFault::Delay(d) => {
                c.delayed += 1;
                Verdict::Delay(d)
            }
            MessageFault::Duplicate => {
                c.duplicated += 1;
                Verdict::Duplicate
            }
        }
    }

    /// The fault armed for `component`'s next handler, if any (taken).
    pub(crate) fn take_armed(&self, component: &str) -> Option<HandlerFault> {
        if self.inner.handler_entries.load(Ordering::Acquire) == 0 {
            return None;
        }
        let taken = self.inner.armed.lock().remove(component);
        if taken.is_some() {
            self.inner.handler_entries.fetch_sub(1, Ordering::Release);
        }
        taken
    }

    pub(crate) fn register_killer(&self, component: &str, killer: Killer) {
        self.inner.killers.lock().insert(component.to_string(), killer);
    }

    pub(crate) fn unregister(&self, component: &str) {
        self.inner.killers.lock().remove(component);
        if self.inner.armed.lock().remove(component).is_some() {
            self.inner.handler_entries.fetch_sub(1, Ordering::Release);
        }
    }

    /// Records that `component` failed (`how`); its next handled message marks it recovered.
    pub(crate) fn detected(&self, component: &str, how: &str) {
        if self.inner.recovering.lock().insert(component.to_string(), ()).is_none() {
            self.inner.handler_entries.fetch_add(1, Ordering::Release);
        }
        self.log(component, FaultEventKind::Detected(how.into()));
    }

    /// Called as a component handles a message: the first one after a detected failure
    /// marks it recovered.
    pub(crate) fn handled(&self, component: &str) {
        if self.inner.handler_entries.load(Ordering::Acquire) == 0 {
            return;
        }
        let removed = self.inner.recovering.lock().remove(component).is_some();
        if removed {
            self.inner.handler_entries.fetch_sub(1, Ordering::Release);
            self.log(component, FaultEventKind::Recovered);
        }
    }
}
