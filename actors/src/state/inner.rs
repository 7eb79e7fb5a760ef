//! [`Inner`] keeps its substate list in step with its spec, current and pending states:
//! those change only through its setters, each of which refreshes the list.

use super::StateSpec;
use std::sync::Arc;

pub(super) struct Inner {
    spec: StateSpec,
    current: String,
    pending: Option<String>,
    /// Every substate the spec declares (and any it no longer declares that is still held),
    /// with what `spec`, `current` and `pending` make of it. Holding a substate, which a
    /// behaviour does for every message, reads this short list and allocates nothing,
    /// instead of walking the spec's maps of names.
    subs: Vec<Sub>,
}

/// A substate as [`Inner`] keeps it.
pub(super) struct Sub {
    pub(super) name: Arc<str>,
    /// How many activities hold it.
    pub(super) held: usize,
    /// Whether the spec declares it.
    known: bool,
    /// Whether it may be held now (see [`Inner::allows`]).
    allowed: bool,
}

impl Sub {
    pub(super) fn known(&self) -> bool {
        self.known
    }

    pub(super) fn allowed(&self) -> bool {
        self.allowed
    }
}

impl Inner {
    pub(super) fn new(spec: StateSpec) -> Inner {
        let mut inner = Inner { current: spec.initial.clone(), spec, pending: None, subs: Vec::new() };
        inner.refresh();
        inner
    }

    pub(super) fn spec(&self) -> &StateSpec {
        &self.spec
    }

    pub(super) fn current(&self) -> &str {
        &self.current
    }

    pub(super) fn pending(&self) -> Option<&str> {
        self.pending.as_deref()
    }

    /// The substates, for holding and releasing them (their counts only: what the spec
    /// makes of them is the setters' to change).
    pub(super) fn subs_mut(&mut self) -> &mut Vec<Sub> {
        &mut self.subs
    }

    pub(super) fn subs(&self) -> &[Sub] {
        &self.subs
    }

    /// Takes a new spec; the current state stays if the spec declares it, else it becomes
    /// the spec's initial one.
    pub(super) fn set_spec(&mut self, spec: StateSpec) {
        if !spec.main.contains_key(&self.current) {
            self.current = spec.initial.clone();
        }
        self.spec = spec;
        self.refresh();
    }

    /// Asks for (`Some`) or withdraws (`None`) a change of main state.
    pub(super) fn set_pending(&mut self, pending: Option<String>) {
        self.pending = pending;
        self.refresh();
    }

    /// Enters main state `main`; a change asked for is done (`pending` cleared) if
    /// `settles`.
    pub(super) fn enter(&mut self, main: &str, settles: bool) {
        self.current = main.to_string();
        if settles {
            self.pending = None;
        }
        self.refresh();
    }

    /// Whether `sub` may be held now: the current main state contains it, and so does the
    /// one a pending change goes to.
    pub(super) fn allows(&self, sub: &str) -> bool {
        let contains = |m: &str| self.spec.main.get(m).is_some_and(|s| s.contains(sub));
        contains(&self.current) && self.pending.as_deref().is_none_or(contains)
    }

    /// Brings `subs` in step with `spec`, `current` and `pending`; every setter calls it.
    fn refresh(&mut self) {
        for name in self.spec.main.values().flatten() {
            if !self.subs.iter().any(|s| &*s.name == name.as_str()) {
                self.subs.push(Sub { name: name.as_str().into(), held: 0, known: true, allowed: false });
            }
        }
        let mut subs = std::mem::take(&mut self.subs);
        subs.retain_mut(|s| {
            s.known = self.spec.main.values().any(|set| set.contains(&*s.name));
            s.allowed = s.known && self.allows(&s.name);
            s.known || s.held > 0
        });
        self.subs = subs;
    }

    /// The held substates that `target` does not contain, in name order.
    pub(super) fn blocking(&self, target: &str) -> Vec<String> {
        let allowed = self.spec.main.get(target);
        let mut blocking: Vec<String> = self
            .subs
            .iter()
            .filter(|s| s.held > 0 && !allowed.is_some_and(|a| a.contains(&*s.name)))
            .map(|s| s.name.to_string())
            .collect();
        blocking.sort_unstable();
        blocking
    }
}
