//! The report of a run: the JSON file and the table set against the original experiment.

use super::metrics::{Metrics, NONE};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The wall-following figures.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct WallFollowFigures {
    /// Mean clearance to the followed wall while wall following, m.
    pub mean_clearance_m: Option<f64>,
    /// Its standard deviation, m.
    pub std_clearance_m: Option<f64>,
}

impl WallFollowFigures {
    /// The figures of `m`.
    pub fn of(m: &Metrics) -> Self {
        WallFollowFigures { mean_clearance_m: m.clearance.mean(), std_clearance_m: m.clearance.std() }
    }
}

/// The center-following figures.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CenterFollowFigures {
    /// Mean |offset| from the corridor centre while center following, m.
    pub mean_abs_offset_m: Option<f64>,
    /// Standard deviation of the signed offset, m.
    pub std_offset_m: Option<f64>,
}

impl CenterFollowFigures {
    /// The figures of `m`.
    pub fn of(m: &Metrics) -> Self {
        CenterFollowFigures { mean_abs_offset_m: m.abs_offset.mean(), std_offset_m: m.offset.std() }
    }
}

/// The sizes of what a long run could pile up, at one moment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sizes {
    /// Components registered.
    pub components: usize,
    /// Services registered.
    pub services: usize,
    /// Subscriptions and activations held on push and event services, all together.
    pub subscriptions: usize,
    /// Services the delivery ledger keeps figures for.
    pub ledger_services: usize,
    /// Tasks alive on the run's tokio runtime (each actor is one).
    pub tasks: usize,
    /// Supervisor events kept for the report: grows with the restarts, by design.
    pub supervisor_events: usize,
    /// Entries of the fault switchboard's log: grows with the faults, by design.
    pub fault_log: usize,
    /// Samples kept for the plot (`Metrics::trajectory`): grows with the run, by design.
    pub trajectory: usize,
}

/// The figures of one sampled span of a run (an hour by default, see
/// `RunOptions::figures_every_s`): what the process holds, what was counted so far, and the
/// span's own measures, computed as the whole run's are.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct HourFigures {
    /// End of the span, simulated s.
    pub end_s: f64,
    /// Its length, s (shorter than the period for the last span of a run that is not a whole
    /// number of periods long).
    pub span_s: f64,
    /// The process's resident memory at the end of the span, KiB (`VmRSS`; `None` off Linux).
    pub rss_kib: Option<u64>,
    /// The process's peak resident memory so far, KiB (`VmHWM`; `None` off Linux).
    pub hwm_kib: Option<u64>,
    /// Component restarts since the start.
    pub restarts: u64,
    /// Contact onsets since the start.
    pub bumps: u64,
    /// Stalls since the start.
    pub stalls: u64,
    /// Distance driven in the span, m.
    pub distance_m: f64,
    /// Fraction of the span each behaviour drove.
    pub behaviour_share: BTreeMap<String, f64>,
    /// Fraction of the span each kind of behaviour drove (the thesis' shares).
    #[serde(default)]
    pub kind_share: BTreeMap<String, f64>,
    /// Wall following in the span.
    pub wallfollow: WallFollowFigures,
    /// Center following in the span.
    pub centerfollow: CenterFollowFigures,
    /// Messages that must arrive (Send, Query, Event) lost in the span.
    pub lost_must_arrive: u64,
    /// Messages lost in the span, push updates included.
    pub lost: u64,
    /// Messages whose sender was told they failed, in the span.
    pub failed: u64,
    /// Arrivals a receiver had already seen, in the span.
    pub duplicates: u64,
    /// Sizes at the end of the span.
    pub sizes: Sizes,
}

impl HourFigures {
    /// The span's measures from `span` (an accumulator that started with the span, see
    /// `Metrics::after`); the counts since the start, memory and sizes are left for the caller.
    pub fn measures(end_s: f64, span_s: f64, span: &Metrics, distance_m: f64) -> Self {
        HourFigures {
            end_s,
            span_s,
            distance_m,
            behaviour_share: span.shares(),
            kind_share: span.kind_shares(),
            wallfollow: WallFollowFigures::of(span),
            centerfollow: CenterFollowFigures::of(span),
            ..Default::default()
        }
    }

    /// The share of the time behaviours of `kind` drove.
    fn share(&self, kind: &str) -> f64 {
        self.kind_share.get(kind).copied().unwrap_or(0.0)
    }
}

/// What the robot server did with velocity commands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SafetyFigures {
    /// Commands applied to the motors.
    pub commands_applied: u64,
    /// Commands refused as older than the velocity timeout.
    pub stale_commands_refused: u64,
    /// Times the robot was stopped for lack of fresh commands.
    pub command_timeouts: u64,
    /// Commands older than the velocity timeout when the motors took them.
    #[serde(default)]
    pub stale_commands_applied: u64,
    /// What the safety monitor under the motors did: how often and how long it limited or
    /// stopped the robot, by reason, and the distance that cost (`None`: it was off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub monitor: Option<orsa_interfaces::nomad200::MonitorCounters>,
    /// How the robot judged its sensors: per sensor, how often and how long it was judged stale,
    /// stuck, dead or noisy (`None`: nothing judged them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub health: Option<orsa_interfaces::health::HealthCounters>,
}

/// One contact onset: when, where (ground truth), and who drove.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BumpAt {
    /// Simulated time, s.
    pub t_s: f64,
    /// Position, m.
    pub x_m: f64,
    /// Position, m.
    pub y_m: f64,
    /// The behaviour wired to the motors, if any.
    pub driving: Option<String>,
}

/// How a run ended.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "how", rename_all = "snake_case")]
pub enum Ended {
    /// It ran its whole duration.
    #[default]
    Completed,
    /// The top supervisor gave up: restarts went over its intensity. The motors were stopped
    /// and the run ended there.
    GaveUp {
        /// Simulated time it gave up at, s.
        at_s: f64,
        /// The supervisor that gave up.
        supervisor: String,
        /// The child whose failure was one restart too many.
        child: String,
        /// Why that child failed, and the count.
        reason: String,
        /// How long the robot took to come to rest after the motors were stopped, s (`None`:
        /// not within the wait).
        stopped_in_s: Option<f64>,
    },
    /// A signal (Ctrl-C, SIGTERM) ended the run early.
    Interrupted {
        /// Simulated time it ended at, s.
        at_s: f64,
        /// Which signal.
        signal: String,
    },
    /// Its planner's mission ended (a run asked to end with it: `orsa run --goto`).
    MissionEnded {
        /// Simulated time it ended at, s.
        at_s: f64,
        /// How: `completed`, `completed with N of M steps skipped: ...` (steps given up under
        /// the skip policy, each with why), `failed: all M steps skipped: ...`, or
        /// `aborted: ...`.
        result: String,
    },
    /// A fatal error ended it (the command's exit code is 1).
    Failed {
        /// Time it ended at, s.
        at_s: f64,
        /// The error, with its causes.
        error: String,
    },
}

impl Ended {
    /// One line for people.
    pub fn describe(&self) -> String {
        match self {
            Ended::Completed => "completed".into(),
            Ended::GaveUp { at_s, supervisor, child, reason, stopped_in_s } => format!(
                "gave up at {at_s:.1} s: supervisor '{supervisor}' stopped after '{child}' failed once too often \
                 ({reason}); the motors were stopped{}",
                stopped_in_s.map_or(" (the robot was still moving 2 s later)".to_string(), |s| format!(
                    " and the robot was at rest {s:.2} s later"
                ))
            ),
            Ended::Interrupted { at_s, signal } => format!("was interrupted by {signal} at {at_s:.1} s"),
            Ended::MissionEnded { at_s, result } => {
                format!("ended with its mission at {at_s:.1} s: {result}")
            }
            Ended::Failed { at_s, error } => format!("failed at {at_s:.1} s: {error}"),
        }
    }
}

/// Everything `report.json` says about a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// How the run ended (its figures cover the time up to then).
    #[serde(default)]
    pub ended: Ended,
    /// The world's name and where it came from.
    pub world: String,
    /// The seed.
    pub seed: u64,
    /// Simulated duration, s.
    pub sim_seconds: f64,
    /// Wall-clock duration, s (with the memory in `hours`, the only figures that differ between
    /// two runs of one seed: see [`Report::of_the_run`]).
    pub wall_seconds: f64,
    /// Distance driven, m.
    pub distance_m: f64,
    /// Contact onsets.
    pub bumps: u64,
    /// Where and when each contact began, and which behaviour drove then.
    #[serde(default)]
    pub bumps_at: Vec<BumpAt>,
    /// 60 s windows with less than 0.10 m travelled.
    pub stalls: u64,
    /// Fraction of the time each behaviour was wired to the motors (`none`: nothing was).
    pub behaviour_share: BTreeMap<String, f64>,
    /// The same by kind of behaviour, whatever the components are named: the thesis' "time
    /// center following" is the share of kind `centerfollow`.
    #[serde(default)]
    pub kind_share: BTreeMap<String, f64>,
    /// Wall following.
    pub wallfollow: WallFollowFigures,
    /// Center following.
    pub centerfollow: CenterFollowFigures,
    /// Component restarts by the supervisor.
    pub restarts: u64,
    /// What a fault plan broke and how the stack came back (runs with `--faults`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faults: Option<crate::faults::FaultsReport>,
    /// The robot server's command safety figures.
    pub safety: SafetyFigures,
    /// What every service delivered, and what it lost.
    #[serde(default)]
    pub delivery: super::integrity::DeliveryReport,
    /// Whether the stack held together: driving unwired or on stale commands, subscriptions
    /// and wiring.
    #[serde(default)]
    pub integrity: super::integrity::IntegrityReport,
    /// Where the robot was sent and how it went (runs with the navigation components).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub navigation: Option<super::navigation::NavigationReport>,
    /// The figures sampled every hour (`RunOptions::figures_every_s`), and at the end: memory,
    /// restarts, each hour's measures and the sizes of what could pile up.
    #[serde(default)]
    pub hours: Vec<HourFigures>,
}

impl Report {
    /// A report from a run's metrics.
    pub fn new(
        world: String,
        seed: u64,
        sim_seconds: f64,
        m: &Metrics,
        restarts: u64,
        safety: SafetyFigures,
    ) -> Self {
        Report {
            ended: Ended::Completed,
            world,
            seed,
            sim_seconds,
            wall_seconds: 0.0,
            distance_m: m.distance_m,
            bumps: m.bumps,
            bumps_at: m
                .bump_points
                .iter()
                .zip(&m.bump_drivers)
                .map(|(&(t_s, x_m, y_m), driving)| BumpAt { t_s, x_m, y_m, driving: driving.clone() })
                .collect(),
            stalls: m.stalls,
            behaviour_share: m.shares(),
            kind_share: m.kind_shares(),
            wallfollow: WallFollowFigures::of(m),
            centerfollow: CenterFollowFigures::of(m),
            restarts,
            faults: None,
            safety,
            delivery: Default::default(),
            integrity: Default::default(),
            navigation: None,
            hours: Vec::new(),
        }
    }

    /// The share of the time behaviours of `kind` drove.
    fn share(&self, kind: &str) -> f64 {
        self.kind_share.get(kind).copied().unwrap_or(0.0)
    }

    /// This report without what the process measured rather than the run: the wall-clock
    /// duration and the memory of each row of `hours`. Two runs of one seed give the same.
    pub fn of_the_run(&self) -> Report {
        let mut r = self.clone();
        r.wall_seconds = 0.0;
        for h in &mut r.hours {
            (h.rss_kib, h.hwm_kib) = (None, None);
        }
        r
    }

    /// The original experiment's table beside this run's.
    pub fn table(&self) -> String {
        let cm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1} cm", v * 100.0));
        let pct = |v: f64| format!("{:.1} %", v * 100.0);
        let mut rows: Vec<(String, String, String)> = vec![
            ("time center following".into(), "91.3 %".into(), pct(self.share("centerfollow"))),
            ("time wall following".into(), "8.7 %".into(), pct(self.share("wallfollow"))),
        ];
        // Behaviours of kinds the thesis did not have, each by its kind.
        for (kind, share) in &self.kind_share {
            if !matches!(kind.as_str(), "centerfollow" | "wallfollow" | NONE) {
                rows.push((format!("time {kind} driving"), "-".into(), pct(*share)));
            }
        }
        if self.share(NONE) > 0.0 {
            rows.push(("time with nothing wired".into(), "-".into(), pct(self.share(NONE))));
        }
        rows.extend([
            ("bumps".to_string(), "2".to_string(), self.bumps.to_string()),
            (
                "wall clearance, mean (target 20 cm)".into(),
                "18.3 cm".into(),
                cm(self.wallfollow.mean_clearance_m),
            ),
            ("wall clearance, std".into(), "-".into(), cm(self.wallfollow.std_clearance_m)),
            ("offset from centre, mean |.|".into(), "9.3 cm".into(), cm(self.centerfollow.mean_abs_offset_m)),
            ("offset from centre, std".into(), "-".into(), cm(self.centerfollow.std_offset_m)),
            ("stalls (60 s under 10 cm)".into(), "-".into(), self.stalls.to_string()),
            ("distance driven".into(), "-".into(), format!("{:.0} m", self.distance_m)),
        ]);
        if let Some(m) = &self.safety.monitor {
            rows.push((
                "safety monitor: limited (held)".into(),
                "-".into(),
                format!("{:.1} s ({:.1} s), {:.1} m lost", m.limited_s, m.stopped_s, m.distance_lost_m),
            ));
        }
        if let Some(h) = &self.safety.health {
            let judged: Vec<String> = orsa_interfaces::health::SENSORS
                .iter()
                .filter_map(|name| h.of(name).map(|t| (name, t)))
                .filter(|(_, t)| t.episodes > 0)
                .map(|(name, t)| format!("{name} {:.1} s ({}x)", t.unhealthy_s(), t.episodes))
                .collect();
            let text = if judged.is_empty() { "none".into() } else { judged.join(", ") };
            rows.push(("sensors judged unhealthy".into(), "-".into(), text));
        }
        let head = ("", "thesis (2004)", format!("orsa (seed {})", self.seed));
        let w0 = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
        let w1 = head.1.len().max(rows.iter().map(|r| r.1.len()).max().unwrap_or(0));
        let mut out = String::new();
        let _ = writeln!(out, "{:w0$}  {:>w1$}  {}", head.0, head.1, head.2);
        for (a, b, c) in &rows {
            let _ = writeln!(out, "{a:w0$}  {b:>w1$}  {c}");
        }
        let _ = write!(
            out,
            "{:.1} simulated s in {:.1} wall s ({:.0}x real time), {} restarts",
            self.sim_seconds,
            self.wall_seconds,
            if self.wall_seconds > 0.0 { self.sim_seconds / self.wall_seconds } else { 0.0 },
            self.restarts
        );
        if self.ended != Ended::Completed {
            let _ = write!(out, "\nthe run {}", self.ended.describe());
        }
        if self.hours.len() > 1 {
            let _ = write!(out, "\n\n{}", self.hours_table());
        }
        out
    }

    /// The hourly rows, one line each (restarts, bumps and stalls since the start; the
    /// shares, clearance, offset, distance and losses of the hour; memory and sizes at its end).
    pub fn hours_table(&self) -> String {
        let mib = |v: Option<u64>| v.map_or("-".to_string(), |v| format!("{:.1}", v as f64 / 1024.0));
        let cm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1}", v * 100.0));
        let mut out = String::from(
            "   hour  RSS MiB  HWM MiB  restarts  bumps  stalls  center %  wall %  clear cm  |off| cm  \
             dist m  lost    dup  tasks  subs  sup ev  fault log\n",
        );
        for h in &self.hours {
            let _ = writeln!(
                out,
                "{:>7.2}  {:>7}  {:>7}  {:>8}  {:>5}  {:>6}  {:>8.1}  {:>6.1}  {:>8}  {:>8}  {:>6.0}  {:>4}  {:>5}  \
                 {:>5}  {:>4}  {:>6}  {:>9}",
                h.end_s / 3600.0,
                mib(h.rss_kib),
                mib(h.hwm_kib),
                h.restarts,
                h.bumps,
                h.stalls,
                h.share("centerfollow") * 100.0,
                h.share("wallfollow") * 100.0,
                cm(h.wallfollow.mean_clearance_m),
                cm(h.centerfollow.mean_abs_offset_m),
                h.distance_m,
                h.lost,
                h.duplicates,
                h.sizes.tasks,
                h.sizes.subscriptions,
                h.sizes.supervisor_events,
                h.sizes.fault_log,
            );
        }
        out.pop();
        out
    }
}
