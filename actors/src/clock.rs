//! Time for patterns and control code: tokio's clock, read in one place.
//!
//! Every period, timeout and timestamp in orsa comes from tokio's clock, so a runtime started with
//! a paused clock (`#[tokio::test(start_paused = true)]`) drives the whole system
//! deterministically and as fast as the CPU allows. Nothing in pattern or control code reads
//! `std::time::Instant` or `SystemTime`; this module is the only place that asks tokio for
//! "now", and it reports it as a [`Timestamp`]: nanoseconds since the clock's epoch.
//!
//! For stamps that leave the process, a clock also knows the UNIX time of its epoch, read once
//! from the system clock when the clock starts ([`Clock::unix_ns`], [`Clock::from_unix_ns`]).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Duration;
use tokio::time::Instant;

/// A point in robot time: nanoseconds since the epoch of the [`Clock`] that stamped it.
///
/// It serialises as a plain integer of nanoseconds since the epoch, except inside the wire
/// encoding ([`crate::wire`]), where every timestamp, wherever it sits in a message, travels as
/// UNIX time in nanoseconds and is mapped back onto the receiver's clock.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp(pub u64);

thread_local! {
    /// The UNIX time of the epoch of the clock whose messages are being encoded or decoded for
    /// the wire on this thread, if any.
    static WIRE_EPOCH: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` (an encoding or decoding for the wire) with timestamps mapped to and from UNIX time
/// through `clock`.
pub(crate) fn on_wire<R>(clock: &Clock, f: impl FnOnce() -> R) -> R {
    let previous = WIRE_EPOCH.with(|e| e.replace(Some(clock.unix_epoch_ns)));
    let result = f();
    WIRE_EPOCH.with(|e| e.set(previous));
    result
}

impl Serialize for Timestamp {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match WIRE_EPOCH.with(std::cell::Cell::get) {
            Some(epoch) => s.serialize_u64(self.0.saturating_add(epoch)),
            None => s.serialize_u64(self.0),
        }
    }
}

impl<'de> Deserialize<'de> for Timestamp {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let raw = u64::deserialize(d)?;
        Ok(match WIRE_EPOCH.with(std::cell::Cell::get) {
            Some(epoch) => Timestamp(raw.saturating_sub(epoch)),
            None => Timestamp(raw),
        })
    }
}

impl Timestamp {
    /// The epoch itself.
    pub const ZERO: Timestamp = Timestamp(0);

    /// A timestamp from seconds since the epoch (negative and non-finite values give zero).
    pub fn from_secs_f64(secs: f64) -> Self {
        if secs.is_finite() && secs > 0.0 { Timestamp((secs * 1e9).round() as u64) } else { Timestamp(0) }
    }

    /// Seconds since the epoch.
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 * 1e-9
    }

    /// Nanoseconds since the epoch.
    pub fn as_nanos(self) -> u64 {
        self.0
    }

    /// The time elapsed from `earlier` to `self`, zero if `earlier` is later.
    pub fn saturating_since(self, earlier: Timestamp) -> Duration {
        Duration::from_nanos(self.0.saturating_sub(earlier.0))
    }

    /// This timestamp moved forward by `d` (saturating).
    pub fn after(self, d: Duration) -> Timestamp {
        Timestamp(self.0.saturating_add(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)))
    }
}

impl fmt::Display for Timestamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3}s", self.as_secs_f64())
    }
}

/// A robot clock: tokio's clock with an epoch. Cheap to copy; every component of one system
/// shares the same epoch, so their timestamps compare.
#[derive(Debug, Clone, Copy)]
pub struct Clock {
    epoch: Instant,
    /// UNIX time of the epoch, in nanoseconds.
    unix_epoch_ns: u64,
}

impl Clock {
    /// A clock whose epoch is tokio's "now". Must be called inside a tokio runtime.
    pub fn start() -> Self {
        let unix = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        Clock { epoch: Instant::now(), unix_epoch_ns: unix }
    }

    /// A clock with a given epoch and the UNIX time of that epoch (for tests and replays).
    pub fn with_unix_epoch_ns(epoch: Instant, unix_epoch_ns: u64) -> Self {
        Clock { epoch, unix_epoch_ns }
    }

    /// The UNIX time, in nanoseconds, of a timestamp of this clock (how stamps cross processes).
    pub fn unix_ns(&self, t: Timestamp) -> u64 {
        self.unix_epoch_ns.saturating_add(t.0)
    }

    /// The timestamp of this clock for a UNIX time in nanoseconds (zero before the epoch).
    pub fn from_unix_ns(&self, unix_ns: u64) -> Timestamp {
        Timestamp(unix_ns.saturating_sub(self.unix_epoch_ns))
    }

    /// The current robot time.
    #[inline]
    pub fn now(&self) -> Timestamp {
        self.stamp_of(Instant::now())
    }

    /// The tokio instant of a timestamp of this clock, for `sleep_until` and intervals.
    pub fn instant_of(&self, t: Timestamp) -> Instant {
        self.epoch + Duration::from_nanos(t.0)
    }

    /// The timestamp of a tokio instant (zero before the epoch).
    #[inline]
    pub fn stamp_of(&self, at: Instant) -> Timestamp {
        let d = at.saturating_duration_since(self.epoch);
        Timestamp(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
    }

    /// The epoch as a tokio instant.
    pub fn epoch(&self) -> Instant {
        self.epoch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn paused_clock_advances_exactly() {
        let clock = Clock::start();
        assert_eq!(clock.now(), Timestamp::ZERO);
        tokio::time::sleep(Duration::from_millis(40)).await;
        assert_eq!(clock.now(), Timestamp(40_000_000));
        assert_eq!(clock.instant_of(clock.now()), Instant::now());
    }

    #[test]
    fn conversions() {
        assert_eq!(Timestamp::from_secs_f64(1.5), Timestamp(1_500_000_000));
        assert_eq!(Timestamp::from_secs_f64(-1.0), Timestamp::ZERO);
        assert_eq!(Timestamp::from_secs_f64(f64::NAN), Timestamp::ZERO);
        assert_eq!(Timestamp(5).saturating_since(Timestamp(9)), Duration::ZERO);
        assert_eq!(Timestamp(1).after(Duration::from_nanos(2)), Timestamp(3));
    }
}
