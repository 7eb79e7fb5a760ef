//! The envelope every communication object travels in: a sequence number and a timestamp.

use crate::clock::Timestamp;
use serde::{Deserialize, Serialize};
use std::ops::Deref;
use std::sync::Arc;

/// A communication object with the sender's sequence number and the robot time it was sent.
///
/// Sequence numbers count per sending endpoint from 1, so a receiver can tell a lost or
/// duplicated message from a delivered one.
///
/// The envelope's time is [`sent_at`](Self::sent_at): when the pattern carried the message,
/// not when what it describes happened. Many objects have a `stamp` of their own (a scan's is
/// when its newest reading was taken), and `Stamped` derefs to the object, so `update.stamp` is
/// the object's stamp and `update.sent_at` the envelope's: the two names can never be confused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stamped<T> {
    /// Per-sender sequence number, starting at 1.
    pub seq: u64,
    /// When the message was sent, on the robot clock (on the wire and in recordings: `stamp`).
    #[serde(rename = "stamp")]
    pub sent_at: Timestamp,
    /// The communication object.
    pub value: T,
}

impl<T> Deref for Stamped<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.value
    }
}

/// A pushed update: shared, so a fan-out to many subscribers copies a pointer, not the data.
pub type Update<T> = Arc<Stamped<T>>;
