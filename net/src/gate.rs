//! The link cut: fault injection that cuts this process off from the processes of a role while
//! the zenoh session stays up (see [`ZenohTransport::cut_link`](crate::ZenohTransport::cut_link)).
//!
//! [`ZenohTransport`]'s methods that cut, restore and report the cut are here. [`Gate`] holds
//! the cut roles, the requests held from cut processes and the counts of what the cut kept from
//! crossing. The checks on a message's path, which know a sender by the zenoh id in its
//! attachment and its role by its process token, are methods of [`Inner`] here.

use crate::ZenohTransport;
use crate::serve::Audience;
use crate::session::Inner;
use orsa_actors::addr::ServiceAddr;
use parking_lot::{Mutex, RwLock};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::sync::atomic::{AtomicU64, Ordering};

/// What a link cut (see [`ZenohTransport::cut_link`](crate::ZenohTransport::cut_link)) kept
/// from crossing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkCutStats {
    /// Messages, requests and heartbeats from cut processes dropped on arrival.
    pub dropped_in: u64,
    /// Messages, stream updates, firings and requests to cut processes not sent.
    pub withheld_out: u64,
}

/// The most requests from cut processes held unanswered at once (beyond: answered at once
/// with nothing, which the requester sees as a failed request).
const MAX_HELD_QUERIES: usize = 1024;

/// A link cut: the roles whose processes this process neither hears nor speaks to.
#[derive(Default)]
pub(crate) struct Gate {
    /// Whether any role is cut: the one check on every message's path while nothing is.
    active: std::sync::atomic::AtomicBool,
    roles: RwLock<BTreeSet<String>>,
    /// Requests from cut processes, held unanswered (as a lost request would be) until
    /// their role's link is restored. (role, query).
    held: Mutex<Vec<(String, zenoh::query::Query)>>,
    dropped_in: AtomicU64,
    withheld_out: AtomicU64,
}

impl Gate {
    /// Whether any role is cut.
    pub(crate) fn active(&self) -> bool {
        self.active.load(Ordering::Acquire)
    }

    /// Cuts (`cut = true`) or restores the link to `role`; whether that changed anything.
    pub(crate) fn set(&self, role: &str, cut: bool) -> bool {
        let mut roles = self.roles.write();
        let changed = if cut { roles.insert(role.to_string()) } else { roles.remove(role) };
        self.active.store(!roles.is_empty(), Ordering::Release);
        drop(roles);
        changed
    }

    /// Whether the link to `role` is cut.
    fn cuts(&self, role: &str) -> bool {
        self.roles.read().contains(role)
    }

    /// The roles whose link is cut now.
    pub(crate) fn roles(&self) -> Vec<String> {
        self.roles.read().iter().cloned().collect()
    }

    /// Holds a query of a cut process of `role` unanswered until the role's link is restored
    /// (dropping a query answers it with nothing at once, which a lost request would not do).
    fn hold(&self, role: String, query: zenoh::query::Query) {
        let mut held = self.held.lock();
        if held.len() < MAX_HELD_QUERIES {
            held.push((role, query));
        }
    }

    /// Answers with nothing the requests held from processes of `role` (its link is restored:
    /// the requesters have timed out).
    pub(crate) fn release(&self, role: &str) {
        self.held.lock().retain(|(r, _)| r != role);
    }

    /// Counts a message from a cut process dropped on arrival.
    fn count_dropped(&self) {
        self.dropped_in.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a message to a cut process not sent.
    fn count_withheld(&self) {
        self.withheld_out.fetch_add(1, Ordering::Relaxed);
    }

    /// What the cut kept from crossing so far.
    pub(crate) fn stats(&self) -> LinkCutStats {
        LinkCutStats {
            dropped_in: self.dropped_in.load(Ordering::Relaxed),
            withheld_out: self.withheld_out.load(Ordering::Relaxed),
        }
    }
}

impl ZenohTransport {
    /// Cuts (`cut = true`) or restores the link between this process and every process of
    /// `role` (`executive`, `teleop`, `tool`, ...), while the zenoh session stays up: for fault
    /// injection, a partition that zenoh's lease does not see, since liveliness tokens stay.
    ///
    /// While a role is cut, this process:
    /// - drops on arrival every message, stream update, firing, heartbeat and reply that a
    ///   process of that role sent (known by the sender's zenoh id in the attachment, and its
    ///   role by its process token);
    /// - holds unanswered every request (Query, State, Wiring, subscription and activation
    ///   control) from such a process, as if it were lost: the requester times out;
    /// - does not send what is addressed to a service such a process hosts: a Send message is
    ///   lost, a request fails with [`PatternError::Timeout`](orsa_actors::PatternError::Timeout)
    ///   after its timeout, a subscription or activation request is not sent (it is sent again
    ///   on restore);
    /// - does not publish stream updates and firings whose every subscriber is such a process.
    ///
    /// Limits: the session, its liveliness tokens and zenoh's keep-alives go on (that is the
    /// point); a push stream shared by a cut and an uncut subscriber (same service, same
    /// every-n-th) still reaches both; this process's own heartbeat still goes out to every
    /// peer; a message without the sender's id (a client that is not orsa's) is not gated; a
    /// process whose token this process has not seen is not recognised. The cut is one
    /// process's view: peers of the cut role still talk to each other.
    pub fn cut_link(&self, role: &str, cut: bool) {
        let inner = &self.inner;
        if !inner.gate.set(role, cut) {
            return;
        }
        tracing::info!(role, cut, "link cut");
        if !cut {
            // Requests held while cut are answered with nothing: the requesters have timed out.
            inner.gate.release(role);
            // Subscriptions and activations held at that role's services are asked for again.
            let hosts: BTreeSet<String> = inner
                .processes
                .read()
                .iter()
                .filter(|(_, r)| r.as_str() == role)
                .map(|(z, _)| z.clone())
                .collect();
            let addrs: Vec<ServiceAddr> = inner
                .remote
                .read()
                .values()
                .filter(|a| hosts.contains(&a.host))
                .map(|a| a.addr.clone())
                .collect();
            for a in addrs {
                inner.renew(&a);
            }
        }
    }

    /// The roles whose link is cut now.
    pub fn cut_roles(&self) -> Vec<String> {
        self.inner.gate.roles()
    }

    /// What link cuts kept from crossing so far.
    pub fn link_cut_stats(&self) -> LinkCutStats {
        self.inner.gate.stats()
    }
}

impl Inner {
    /// The role of process `zid` if its link is cut.
    fn cut_role_of(&self, zid: &str) -> Option<String> {
        if !self.gate.active() {
            return None;
        }
        let role = self.processes.read().get(zid)?.clone();
        self.gate.cuts(&role).then_some(role)
    }

    /// Whether the link to process `zid` is cut.
    fn is_cut(&self, zid: &str) -> bool {
        self.cut_role_of(zid).is_some()
    }

    /// The role of the sender of a message with this attachment, if its link is cut.
    fn cut_sender(&self, attachment: Option<&zenoh::bytes::ZBytes>) -> Option<String> {
        if !self.gate.active() {
            return None;
        }
        let bytes = attachment?.to_bytes();
        self.cut_role_of(crate::links::sender(&bytes)?.0)
    }

    /// Whether a message with this attachment may be delivered (its sender is not cut off);
    /// counts it if not.
    pub(crate) fn admit(&self, attachment: Option<&zenoh::bytes::ZBytes>) -> bool {
        if self.cut_sender(attachment).is_some() {
            self.gate.count_dropped();
            return false;
        }
        true
    }

    /// Whether a message from process `zid` may be delivered (its link is not cut); counts it
    /// if not.
    pub(crate) fn admit_from(&self, zid: &str) -> bool {
        if self.is_cut(zid) {
            self.gate.count_dropped();
            return false;
        }
        true
    }

    /// The query, if its sender is not cut off; otherwise it is held unanswered.
    pub(crate) fn admit_query(&self, query: zenoh::query::Query) -> Option<zenoh::query::Query> {
        match self.cut_sender(query.attachment()) {
            None => Some(query),
            Some(role) => {
                self.gate.count_dropped();
                self.gate.hold(role, query);
                None
            }
        }
    }

    /// The query, if its sender is not cut off now, so that it may be answered; otherwise the
    /// answer is withheld (and counted) and the query held unanswered.
    pub(crate) fn answerable(&self, query: zenoh::query::Query) -> Option<zenoh::query::Query> {
        match self.cut_sender(query.attachment()) {
            None => Some(query),
            Some(role) => {
                self.gate.count_withheld();
                self.gate.hold(role, query);
                None
            }
        }
    }

    /// Whether the process hosting `addr` is cut off; counts a withheld message if so.
    pub(crate) fn withhold_to(&self, addr: &ServiceAddr) -> bool {
        if !self.gate.active() {
            return false;
        }
        let host = self.remote.read().get(addr).map(|a| a.host.clone());
        if host.is_some_and(|h| self.is_cut(&h)) {
            self.gate.count_withheld();
            return true;
        }
        false
    }

    /// Whether every process a publishing sink's message is for is cut off (a stream with no
    /// client is not); counts a withheld message if so.
    pub(crate) fn withhold_to_audience(&self, audience: &Audience) -> bool {
        if !self.gate.active() {
            return false;
        }
        let all_cut = match audience {
            Audience::Clients(c) => {
                let c = c.lock();
                !c.is_empty() && c.iter().all(|(zid, _)| self.is_cut(zid))
            }
            Audience::Client(zid) => self.is_cut(zid),
        };
        if all_cut {
            self.gate.count_withheld();
        }
        all_cut
    }
}
