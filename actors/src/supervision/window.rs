//! The restart intensity: a sliding window of restart instants on tokio's clock.

use std::collections::VecDeque;
use std::time::Duration;
use tokio::time::Instant;

/// At most `intensity` restarts within any `period`, as OTP counts them: a restart at `t` is
/// still counted at `now` while `now - t <= period`.
#[derive(Debug, Clone)]
pub(crate) struct RestartWindow {
    intensity: u32,
    period: Duration,
    restarts: VecDeque<Instant>,
}

impl RestartWindow {
    pub(crate) fn new(intensity: u32, period: Duration) -> Self {
        RestartWindow { intensity, period, restarts: VecDeque::new() }
    }

    /// Records a restart at `now`; `false` if it is one too many (the supervisor gives up).
    pub(crate) fn record(&mut self, now: Instant) -> bool {
        while let Some(&oldest) = self.restarts.front() {
            if now.saturating_duration_since(oldest) > self.period {
                self.restarts.pop_front();
            } else {
                break;
            }
        }
        self.restarts.push_back(now);
        self.restarts.len() <= self.intensity as usize
    }

    /// The restarts currently counted.
    pub(crate) fn count(&self) -> u32 {
        u32::try_from(self.restarts.len()).unwrap_or(u32::MAX)
    }

    pub(crate) fn intensity(&self) -> u32 {
        self.intensity
    }

    pub(crate) fn period(&self) -> Duration {
        self.period
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_counts_restarts_within_the_period_inclusively() {
        let t0 = Instant::now();
        let s = Duration::from_secs(1);
        let mut w = RestartWindow::new(2, 5 * s);
        assert!(w.record(t0));
        assert!(w.record(t0 + s));
        assert!(!w.record(t0 + 5 * s), "t0 is exactly one period ago: still counted");
        let mut w = RestartWindow::new(2, 5 * s);
        assert!(w.record(t0));
        assert!(w.record(t0 + s));
        assert!(w.record(t0 + 5 * s + Duration::from_nanos(1)), "t0 has left the window");
        assert_eq!(w.count(), 2);
    }

    #[test]
    fn zero_intensity_allows_no_restart() {
        let mut w = RestartWindow::new(0, Duration::from_secs(1));
        assert!(!w.record(Instant::now()));
    }
}
