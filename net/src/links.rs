//! The delivery ledger across processes: every one-way message this process puts on a link
//! (Send messages, push stream updates, event firings, heartbeats) is numbered per outlet (one
//! zenoh publisher) and carries `<zid>/<outlet>/<n>` as its attachment; the receiving process
//! follows each (sender, outlet) pair's numbers with a [`Sequence`], so a message lost or
//! duplicated between the processes is counted where it should have arrived.
//!
//! Requests are not numbered: their requester is told when one fails (timeout, link error).
//! A message whose attachment is only a zid (a client that is not orsa's, or an older orsa)
//! is accepted as before and counted as `unnumbered`.
//!
//! What the receiver cannot see, the sender's figures tell: an outlet's `sent` against the
//! receiver's `newest` is what was in flight, or lost with the link, when the figures were
//! read; numbers before the receiver's `first` were put while it was not there.

use crate::ZenohTransport;
use crate::session::Inner;
use orsa_actors::ledger::{Arrival, Sequence, SequenceCounts};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The most (sender, outlet) pairs a process follows, and the most outlets of its own whose
/// figures it keeps after they ended. Beyond, new incoming pairs are counted as `untracked`
/// (a peer that forges outlet numbers cannot grow the table), and the oldest ended outlets'
/// figures are forgotten.
pub const MAX_LINK_STREAMS: usize = 1024;

/// The delivery figures across processes of one process: what it put on its links, per
/// outlet, and what it received, per sender's outlet.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkLedger {
    /// This process's outlets (one per key expression it publishes on, made again when a
    /// stream or activation is made again), in the order they were made.
    pub outgoing: Vec<Outgoing>,
    /// What arrived from each peer's outlet.
    pub incoming: Vec<Incoming>,
    /// Numbered messages from pairs beyond [`MAX_LINK_STREAMS`], not followed.
    pub untracked: u64,
    /// Messages that arrived without a number (a foreign client's, an older orsa's).
    pub unnumbered: u64,
}

/// One outlet of this process.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Outgoing {
    /// The key expression it publishes on.
    pub key: String,
    /// Its number in this process (the `<outlet>` of the attachment).
    pub outlet: u64,
    /// Messages numbered and handed to zenoh, or withheld by a link cut (a cut cable loses
    /// what is put on it): the highest number used.
    pub sent: u64,
    /// Of those, the ones zenoh refused at once (the session closing).
    pub failed: u64,
    /// Of those, the ones a link cut withheld.
    pub withheld: u64,
}

/// What arrived from one peer's outlet.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Incoming {
    /// The sender's zenoh id.
    pub from: String,
    /// The sender's role, if its process token was seen (while it was there).
    pub role: Option<String>,
    /// The key expression it arrived on.
    pub key: String,
    /// The sender's outlet number.
    pub outlet: u64,
    /// First and newest numbers, arrivals, duplicates, missing and late ones.
    #[serde(flatten)]
    pub counts: SequenceCounts,
}

impl LinkLedger {
    /// Messages missing on every incoming stream (lost between the processes, as far as this
    /// process can tell).
    pub fn missing(&self) -> u64 {
        self.incoming.iter().map(|i| i.counts.missing).sum()
    }

    /// Messages that arrived more than once.
    pub fn duplicates(&self) -> u64 {
        self.incoming.iter().map(|i| i.counts.duplicates).sum()
    }

    /// Messages received, each once.
    pub fn arrived(&self) -> u64 {
        self.incoming.iter().map(|i| i.counts.arrived).sum()
    }

    /// The outlet `outlet` of this process, if its figures are kept.
    pub fn outgoing(&self, outlet: u64) -> Option<&Outgoing> {
        self.outgoing.iter().find(|o| o.outlet == outlet)
    }
}

/// The running figures of one outlet.
#[derive(Debug, Default)]
pub(crate) struct OutletCounts {
    key: String,
    sent: AtomicU64,
    failed: AtomicU64,
    withheld: AtomicU64,
}

impl OutletCounts {
    /// The next number: the message is about to be put.
    pub(crate) fn next(&self) -> u64 {
        self.sent.fetch_add(1, Ordering::Relaxed) + 1
    }

    pub(crate) fn failed(&self) {
        self.failed.fetch_add(1, Ordering::Relaxed);
    }

    /// A message a link cut kept from crossing: it uses its number, as a message put on a cut
    /// cable would.
    pub(crate) fn withheld(&self) {
        self.next();
        self.withheld.fetch_add(1, Ordering::Relaxed);
    }
}

struct Followed {
    key: String,
    /// The sender's role, once its process token was seen (kept after it is gone).
    role: Mutex<Option<String>>,
    sequence: Sequence,
}

/// The ledger's tables, in [`Inner`].
#[derive(Default)]
pub(crate) struct Links {
    next_outlet: AtomicU64,
    outlets: Mutex<BTreeMap<u64, Arc<OutletCounts>>>,
    /// By sender's zid, then outlet (looked up by `&str`: no allocation per message).
    incoming: Mutex<HashMap<String, HashMap<u64, Arc<Followed>>>>,
    /// How many (sender, outlet) pairs `incoming` holds.
    followed: std::sync::atomic::AtomicUsize,
    untracked: AtomicU64,
    unnumbered: AtomicU64,
}

impl Links {
    /// A new outlet's number and figures.
    pub(crate) fn outlet(&self, key: &str) -> (u64, Arc<OutletCounts>) {
        let id = self.next_outlet.fetch_add(1, Ordering::Relaxed) + 1;
        let counts = Arc::new(OutletCounts { key: key.to_string(), ..OutletCounts::default() });
        let mut outlets = self.outlets.lock();
        if outlets.len() >= MAX_LINK_STREAMS {
            // Forget the oldest outlet that has ended (only the table still holds it).
            let ended = outlets.iter().find(|(_, c)| Arc::strong_count(c) == 1).map(|(id, _)| *id);
            if let Some(old) = ended {
                outlets.remove(&old);
            }
        }
        outlets.insert(id, Arc::clone(&counts));
        (id, counts)
    }
}

/// The attachment of a numbered message: `<zid>/<outlet>/<n>`.
pub(crate) fn attachment(zid: &str, outlet: u64, n: u64) -> zenoh::bytes::ZBytes {
    zenoh::bytes::ZBytes::from(format!("{zid}/{outlet}/{n}"))
}

/// A message's sender as its attachment gives it: its zid, and its outlet and number if it is
/// numbered. `None` if there is no attachment or it is not UTF-8.
pub(crate) fn sender(attachment: &[u8]) -> Option<(&str, Option<(u64, u64)>)> {
    let text = std::str::from_utf8(attachment).ok()?;
    let mut parts = text.splitn(3, '/');
    let zid = parts.next()?;
    let numbered = match (parts.next(), parts.next()) {
        (Some(o), Some(n)) => o.parse().ok().zip(n.parse().ok()),
        _ => None,
    };
    Some((zid, numbered))
}

impl Inner {
    /// Records the arrival of a message on `key` with this attachment.
    pub(crate) fn arrived(&self, key: &str, attachment: Option<&zenoh::bytes::ZBytes>) {
        let Some(bytes) = attachment.map(|a| a.to_bytes()) else {
            self.links.unnumbered.fetch_add(1, Ordering::Relaxed);
            return;
        };
        let Some((zid, Some((outlet, n)))) = sender(&bytes) else {
            self.links.unnumbered.fetch_add(1, Ordering::Relaxed);
            return;
        };
        let followed = {
            let mut incoming = self.links.incoming.lock();
            match incoming.get(zid).and_then(|o| o.get(&outlet)) {
                Some(f) => Arc::clone(f),
                None => {
                    if self.links.followed.load(Ordering::Relaxed) >= MAX_LINK_STREAMS {
                        // Make room by forgetting the pairs of a process that is gone, if any.
                        let procs = self.processes.read();
                        let gone = incoming.keys().find(|z| !procs.contains_key(z.as_str())).cloned();
                        drop(procs);
                        match gone.and_then(|z| incoming.remove(&z)) {
                            Some(forgotten) => {
                                self.links.followed.fetch_sub(forgotten.len(), Ordering::Relaxed);
                            }
                            None => {
                                self.links.untracked.fetch_add(1, Ordering::Relaxed);
                                return;
                            }
                        }
                    }
                    let role = self.processes.read().get(zid).cloned();
                    let f = Arc::new(Followed {
                        key: key.to_string(),
                        role: Mutex::new(role),
                        sequence: Sequence::default(),
                    });
                    incoming.entry(zid.to_string()).or_default().insert(outlet, Arc::clone(&f));
                    self.links.followed.fetch_add(1, Ordering::Relaxed);
                    f
                }
            }
        };
        if followed.sequence.arrive(n) == Arrival::Invalid {
            self.links.unnumbered.fetch_add(1, Ordering::Relaxed);
        }
    }

    pub(crate) fn link_ledger(&self) -> LinkLedger {
        let outgoing = self
            .links
            .outlets
            .lock()
            .iter()
            .map(|(id, c)| Outgoing {
                key: c.key.clone(),
                outlet: *id,
                sent: c.sent.load(Ordering::Relaxed),
                failed: c.failed.load(Ordering::Relaxed),
                withheld: c.withheld.load(Ordering::Relaxed),
            })
            .collect();
        let procs = self.processes.read().clone();
        let mut incoming: Vec<Incoming> = self
            .links
            .incoming
            .lock()
            .iter()
            .flat_map(|(zid, outlets)| outlets.iter().map(move |(outlet, f)| (zid, outlet, f)))
            .map(|(zid, outlet, f)| Incoming {
                from: zid.clone(),
                role: {
                    let mut role = f.role.lock();
                    if role.is_none() {
                        *role = procs.get(zid).cloned();
                    }
                    role.clone()
                },
                key: f.key.clone(),
                outlet: *outlet,
                counts: f.sequence.counts(),
            })
            .collect();
        incoming.sort_by(|a, b| (&a.from, a.outlet).cmp(&(&b.from, b.outlet)));
        LinkLedger {
            outgoing,
            incoming,
            untracked: self.links.untracked.load(Ordering::Relaxed),
            unnumbered: self.links.unnumbered.load(Ordering::Relaxed),
        }
    }
}

impl ZenohTransport {
    /// The delivery ledger across processes: what this process put on its links and what
    /// arrived from each peer's outlet (see the module docs).
    pub fn link_ledger(&self) -> LinkLedger {
        self.inner.link_ledger()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_attachment_gives_the_sender_and_its_number_if_it_has_one() {
        assert_eq!(sender(b"ab12/3/7"), Some(("ab12", Some((3, 7)))));
        assert_eq!(sender(b"ab12"), Some(("ab12", None)));
        assert_eq!(sender(b"ab12/x/7"), Some(("ab12", None)));
        assert_eq!(sender(b"ab12/3"), Some(("ab12", None)));
        assert_eq!(sender(b"ab12/3/7/9"), Some(("ab12", None)), "a number with a slash in it");
        assert_eq!(sender(&[0xff, 0xfe]), None);
        let a = attachment("ab12", 3, 7);
        assert_eq!(sender(&a.to_bytes()), Some(("ab12", Some((3, 7)))));
    }

    #[test]
    fn the_oldest_ended_outlet_is_forgotten_when_the_table_is_full() {
        let links = Links::default();
        let live: Vec<_> = (0..MAX_LINK_STREAMS / 2).map(|i| links.outlet(&format!("k{i}"))).collect();
        for i in 0..MAX_LINK_STREAMS {
            drop(links.outlet(&format!("ended{i}")));
        }
        let outlets = links.outlets.lock();
        assert_eq!(outlets.len(), MAX_LINK_STREAMS);
        for (id, _) in &live {
            assert!(outlets.contains_key(id), "a live outlet is kept");
        }
    }
}
