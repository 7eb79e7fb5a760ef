//! A budget for log lines about hostile or broken input: at most a few lines per window, and a
//! count of those left out, so that a stream of malformed messages costs a counter increment
//! each, not a log line each.
//!
//! ```
//! use orsa_actors::logbudget::{LogBudget, Verdict};
//! use std::time::{Duration, Instant};
//!
//! let budget = LogBudget::new(2, Duration::from_secs(1));
//! let t0 = Instant::now();
//! assert_eq!(budget.judge(t0), Verdict::Log { suppressed: 0 });
//! assert_eq!(budget.judge(t0), Verdict::Log { suppressed: 0 });
//! assert_eq!(budget.judge(t0), Verdict::Suppress);
//! // The next window's first line says how many were left out.
//! assert_eq!(budget.judge(t0 + Duration::from_secs(1)), Verdict::Log { suppressed: 1 });
//! ```

use parking_lot::Mutex;
use std::time::{Duration, Instant};

/// What to do with one more line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Log it, saying how many lines were left out since the last one logged.
    Log {
        /// Lines suppressed before this one.
        suppressed: u64,
    },
    /// Leave it out (it is counted).
    Suppress,
}

/// At most `lines` log lines per `window` (wall time: logs are for people, not for the
/// robot's clock).
#[derive(Debug)]
pub struct LogBudget {
    lines: u32,
    window: Duration,
    state: Mutex<State>,
}

#[derive(Debug)]
struct State {
    start: Option<Instant>,
    logged: u32,
    suppressed: u64,
}

/// The budget for lines about malformed input from other processes: 10 per second.
pub const HOSTILE_INPUT: (u32, Duration) = (10, Duration::from_secs(1));

impl LogBudget {
    /// A budget of `lines` per `window`.
    pub fn new(lines: u32, window: Duration) -> Self {
        LogBudget { lines, window, state: Mutex::new(State { start: None, logged: 0, suppressed: 0 }) }
    }

    /// The budget for malformed input ([`HOSTILE_INPUT`]).
    pub fn hostile_input() -> Self {
        Self::new(HOSTILE_INPUT.0, HOSTILE_INPUT.1)
    }

    /// Whether a line at `now` is logged.
    pub fn judge(&self, now: Instant) -> Verdict {
        let mut s = self.state.lock();
        if s.start.is_none_or(|start| now.saturating_duration_since(start) >= self.window) {
            s.start = Some(now);
            s.logged = 0;
        }
        if s.logged < self.lines {
            s.logged += 1;
            Verdict::Log { suppressed: std::mem::take(&mut s.suppressed) }
        } else {
            s.suppressed += 1;
            Verdict::Suppress
        }
    }

    /// Logs `line` as a warning if the budget allows it now, with how many were left out.
    pub fn warn(&self, line: impl FnOnce() -> String) {
        match self.judge(Instant::now()) {
            Verdict::Log { suppressed: 0 } => tracing::warn!("{}", line()),
            Verdict::Log { suppressed } => {
                tracing::warn!("{} ({suppressed} more like it were not logged)", line())
            }
            Verdict::Suppress => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream of 20,000 lines in 2 s logs 10 a second, and the first line of each new window
    /// counts exactly what the previous one left out.
    #[test]
    fn a_stream_logs_a_bounded_number_of_lines_and_counts_the_rest() {
        let b = LogBudget::hostile_input();
        let t0 = Instant::now();
        let mut logged = Vec::new();
        let mut suppressed = 0u64;
        for i in 0..20_000u64 {
            let now = t0 + Duration::from_micros(i * 100);
            match b.judge(now) {
                Verdict::Log { suppressed: n } => logged.push((i, n)),
                Verdict::Suppress => suppressed += 1,
            }
        }
        assert_eq!(logged.len(), 20);
        assert_eq!(suppressed, 19_980);
        // The 11th line of the first second is the first left out; the second window opens at
        // line 10,000 and reports the 9,990 before it.
        assert_eq!(logged[10], (10_000, 9_990));
        assert_eq!(logged.iter().map(|(_, n)| n).sum::<u64>(), 9_990);
    }
}
