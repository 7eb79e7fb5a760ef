//! Time for patterns and control code: tokio's clock, read in one place.
//!
//! Every period, timeout and timestamp in orsa comes from tokio's clock, so a runtime started with
//! a paused clock (`#[tokio::test(start_paused = true)]`) drives the whole system
//! deterministically and as fast as the CPU allows. Nothing in pattern or control code reads
//! `std::time::Instant` or `SystemTime`; this module is the only place that asks tokio for
//! "now", and it reports it as a [`Timestamp`].
//!
//! ## The time model
//! A [`Timestamp`] is nanoseconds on the system's **time base**, the same in every process of a
//! system and on the wire, with no conversion anywhere:
//! - a **live** clock ([`Clock::start`], what `orsa robot`, `orsa executive` and teleop use)
//!   starts at the UNIX time it reads once from the system clock, so its stamps are UNIX time
//!   (as ROS 2's and Foxglove's are) and compare across hosts as well as their clocks agree;
//! - a **simulated** clock ([`Clock::simulated`], what `orsa run` and whole-stack tests use)
//!   starts at a time it is given, zero by default, so the same seed gives the same stamps
//!   (like ROS 2's simulated time).
//!
//! "Seconds since the system started" is [`Clock::since_start`], never a stamp's raw value.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Duration;
use tokio::time::Instant;

/// A point in time on the system's time base (see the module docs): nanoseconds since the UNIX
/// epoch on a live clock, since the simulation's chosen origin on a simulated one. It serialises
/// as that plain integer, in every encoding.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Timestamp(pub u64);

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

/// A robot clock: tokio's clock, placed on a time base (see the module docs). Cheap to copy;
/// every component of one system shares it, so their timestamps compare.
#[derive(Debug, Clone, Copy)]
pub struct Clock {
    /// The tokio instant the clock started at.
    epoch: Instant,
    /// The time the clock started at, on the time base.
    origin: Timestamp,
}

impl Clock {
    /// A live clock: it starts now, at the UNIX time the system clock gives. Must be called
    /// inside a tokio runtime.
    pub fn start() -> Self {
        let unix = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        Clock::starting_at(Instant::now(), Timestamp(unix))
    }

    /// A simulated clock: it starts now, at time zero, so runs repeat stamp for stamp. Must be
    /// called inside a tokio runtime.
    pub fn simulated() -> Self {
        Clock::starting_at(Instant::now(), Timestamp::ZERO)
    }

    /// A clock whose tokio instant `epoch` is time `origin` (for replays and tests).
    pub fn starting_at(epoch: Instant, origin: Timestamp) -> Self {
        Clock { epoch, origin }
    }

    /// The time the clock started at.
    pub fn origin(&self) -> Timestamp {
        self.origin
    }

    /// How long after the clock started `t` is (zero for earlier times).
    pub fn since_start(&self, t: Timestamp) -> Duration {
        t.saturating_since(self.origin)
    }

    /// The current time.
    #[inline]
    pub fn now(&self) -> Timestamp {
        self.stamp_of(Instant::now())
    }

    /// The tokio instant of a timestamp of this clock, for `sleep_until` and intervals (the
    /// clock's start for earlier times).
    pub fn instant_of(&self, t: Timestamp) -> Instant {
        self.epoch + self.since_start(t)
    }

    /// The timestamp of a tokio instant (the clock's start for earlier instants).
    #[inline]
    pub fn stamp_of(&self, at: Instant) -> Timestamp {
        let d = at.saturating_duration_since(self.epoch);
        self.origin.after(d)
    }

    /// The clock's start as a tokio instant.
    pub fn epoch(&self) -> Instant {
        self.epoch
    }
}

/// Scheduler rounds [`end_of_instant`] waits: more than any chain of messages, answers and
/// restarts one instant holds.
const SETTLE_ROUNDS: usize = 256;

/// Returns once everything else the system does at this instant is done, on a paused clock.
///
/// Something applied the moment its own timer fires (a fault plan's kill, a handler watchdog
/// failing a hung instance) would race with what else happens at that instant (a behaviour's
/// tick, a push, the steps of a restart), and which came first would depend on the order tokio
/// polls the tasks woken at that instant. That order differs between a run and its replay (the
/// replay's robot is a stand-in with tasks of its own), so a kill of the master at `t` made the
/// restarted master unwire the behaviours before a behaviour's command at `t` in the run and
/// after it in the replay. Yielding puts the caller behind every task that is ready, and a
/// paused clock does not move while one is: after these rounds the instant's chains have
/// ended, and what the caller does next lands at the same place, after all of them, in a run
/// and in its replay. (On a clock that is not paused the rounds take microseconds and order
/// nothing; live recordings are compared within a tolerance.)
pub async fn end_of_instant() {
    for _ in 0..SETTLE_ROUNDS {
        tokio::task::yield_now().await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn paused_clock_advances_exactly() {
        let clock = Clock::simulated();
        assert_eq!(clock.now(), Timestamp::ZERO);
        tokio::time::sleep(Duration::from_millis(40)).await;
        assert_eq!(clock.now(), Timestamp(40_000_000));
        assert_eq!(clock.instant_of(clock.now()), Instant::now());
    }

    #[tokio::test(start_paused = true)]
    async fn a_live_clock_reads_unix_time_and_a_simulated_one_starts_at_its_origin() {
        let before = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).expect("after 1970");
        let live = Clock::start();
        let after = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).expect("after 1970");
        let origin = Duration::from_nanos(live.origin().as_nanos());
        assert!(before <= origin && origin <= after, "{origin:?} not in {before:?}..{after:?}");
        let replay = Clock::starting_at(Instant::now(), Timestamp(5_000_000_000));
        tokio::time::sleep(Duration::from_millis(40)).await;
        assert_eq!(live.since_start(live.now()), Duration::from_millis(40));
        assert_eq!(replay.now(), Timestamp(5_040_000_000));
        assert_eq!(replay.since_start(Timestamp(1)), Duration::ZERO, "before the start is the start");
        assert_eq!(replay.instant_of(Timestamp(0)), replay.epoch());
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
