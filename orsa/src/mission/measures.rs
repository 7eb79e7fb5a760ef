//! What a run measures at every tick for its report: the thesis' measures ([`Metrics`]), the
//! report's periodic rows ([`Hours`]) and the integrity watch ([`integrity::Watch`]).

use super::integrity;
use super::metrics::{self, Metrics, Sample};
use super::report::{self, Ended, Report, SafetyFigures};
use super::stack::Stack;
use orsa_actors::supervision::{SupervisorEvent, SupervisorEventKind};
use orsa_hardware::sim::{Side, Truth};
use orsa_interfaces::nomad200::SafetyCounters;
use std::time::Duration;

/// A run's measures, as they are taken.
pub(super) struct Measures {
    sample_period_s: f64,
    metrics: Metrics,
    hours: Hours,
    watch: integrity::Watch,
    /// The behaviours the executive's modes name.
    behaviours: Vec<String>,
    /// Each component's kind, by its name in the system.
    kinds: std::collections::BTreeMap<String, String>,
    /// Ticks between two checks of the clients and the wiring (one a second).
    check_every: u64,
}

impl Measures {
    /// Measures of a run of `opts` (all but its world and catalog, which went to the stack)
    /// on `stack`, from its start.
    pub(super) fn new(opts: &Options<'_>, stack: &Stack) -> Self {
        Measures {
            sample_period_s: opts.sample_period_s,
            metrics: Metrics::new(opts.sample_period_s).keeping_series(opts.keep_series),
            hours: Hours::new(opts.figures_every_s, opts.sample_period_s, &stack.registry),
            watch: integrity::Watch::new(
                stack.board_faults.clone(),
                Duration::from_secs_f64(opts.config.robot().cmd_timeout_s),
            ),
            behaviours: opts.config.executive().behaviours(),
            kinds: opts.config.system.kinds(),
            check_every: ((1.0 / opts.sample_period_s).round() as u64).max(1),
        }
    }

    /// Measures tick `k`, whose truth is `t`, with `driving` driving; returns its sample if
    /// it ends a row of the report's `hours` (to take with [`row`](Self::row)).
    pub(super) async fn tick(
        &mut self,
        k: u64,
        t: &Truth,
        driving: Option<&str>,
        stack: &Stack,
    ) -> Option<Sample> {
        let t_s = k as f64 * self.sample_period_s;
        self.watch.sample(t_s, self.sample_period_s, t.v_m_s, t.omega_rad_s, driving.is_some());
        if k.is_multiple_of(self.check_every) {
            self.watch.check_clients(&stack.registry, t_s);
            let behaviours: Vec<&str> = self.behaviours.iter().map(String::as_str).collect();
            self.watch.check_wiring(&stack.registry, &behaviours, driving, t_s).await;
        }
        let following = driving.is_some();
        let kind = driving.map(|d| self.kinds.get(d).map_or(d, String::as_str));
        let center = kind == Some("centerfollow");
        let sample = Sample {
            t_s,
            x_m: t.x_m,
            y_m: t.y_m,
            travelled_m: t.travelled_m,
            driving: driving.map(str::to_owned),
            kind: kind.map(str::to_owned),
            left_m: following.then(|| super::stack::truth_of(stack).side_nearest(Side::Left)).flatten(),
            right_m: center.then(|| super::stack::truth_of(stack).side_nearest(Side::Right)).flatten(),
            bumps: t.contact_onsets,
        };
        self.metrics.add(&sample);
        self.hours.span.add(&sample);
        k.is_multiple_of(self.hours.every).then_some(sample)
    }

    /// Takes the row that `last` (from [`tick`](Self::tick)) ends, with the supervisor
    /// `events` so far.
    pub(super) fn row(&mut self, last: &Sample, stack: &Stack, events: &[SupervisorEvent]) {
        self.hours.take(last.t_s, &stack.registry, &self.metrics, events, Some(last));
    }

    /// Whether the span since the last row wants a row of its own at `end_s` (a run that is
    /// not a whole number of periods, or that ended early).
    pub(super) fn last_row_due(&self, end_s: f64) -> bool {
        self.hours.rows.last().is_none_or(|h| h.end_s < end_s - 1e-6)
    }

    /// Takes the last row, at `end_s`.
    pub(super) fn last_row(&mut self, end_s: f64, stack: &Stack, events: &[SupervisorEvent]) {
        self.hours.take(end_s, &stack.registry, &self.metrics, events, None);
    }

    /// Ends the measures: whether the stack held together to the end, with `driving` driving
    /// (the stack still up), and what was measured.
    pub(super) async fn finish(
        self,
        stack: &Stack,
        driving: Option<&str>,
    ) -> (integrity::IntegrityReport, Measured) {
        let behaviours: Vec<&str> = self.behaviours.iter().map(String::as_str).collect();
        let held = self.watch.finish(&stack.registry, &behaviours, driving).await;
        (held, Measured { metrics: self.metrics, rows: self.hours.rows })
    }
}

/// What a run measured.
pub(super) struct Measured {
    metrics: Metrics,
    rows: Vec<report::HourFigures>,
}

impl Measured {
    /// The report of a run that ended so, and its measures (with the series for the plot).
    pub(super) fn report(self, end: End, events: &[SupervisorEvent]) -> (Report, Metrics) {
        let restarts = events.iter().filter(|e| e.kind == SupervisorEventKind::Restarted).count() as u64;
        let safety = SafetyFigures {
            commands_applied: end.safety.applied,
            stale_commands_refused: end.safety.stale_refused,
            command_timeouts: end.safety.timeouts,
            stale_commands_applied: end.safety.stale_applied,
            monitor: end.safety.monitor,
            health: end.safety.health,
        };
        let mut report =
            Report::new(end.world_label, end.seed, end.simulated_s, &self.metrics, restarts, safety);
        report.ended = end.ended;
        report.delivery = end.delivery;
        report.integrity = end.held;
        report.hours = self.rows;
        (report, self.metrics)
    }
}

/// What [`Measures`] read of a run's options.
pub(super) struct Options<'a> {
    pub(super) config: &'a crate::config::Config,
    pub(super) sample_period_s: f64,
    pub(super) figures_every_s: f64,
    pub(super) keep_series: bool,
}

/// How a run ended, for its report.
pub(super) struct End {
    pub(super) world_label: String,
    pub(super) seed: u64,
    pub(super) simulated_s: f64,
    pub(super) ended: Ended,
    pub(super) safety: SafetyCounters,
    pub(super) delivery: integrity::DeliveryReport,
    pub(super) held: integrity::IntegrityReport,
}

/// The report's hourly rows, as a run takes them.
struct Hours {
    /// Metric samples between two rows.
    every: u64,
    sample_period_s: f64,
    /// The current span's measures.
    span: Metrics,
    /// Where the current span started, s, and the distance travelled then, m.
    start: (f64, f64),
    /// The ledger's totals at the start of the span: (lost that must arrive, all).
    ledger_before: (u64, orsa_actors::ledger::DeliveryCounts),
    rows: Vec<report::HourFigures>,
}

impl Hours {
    fn new(every_s: f64, sample_period_s: f64, registry: &orsa_actors::Registry) -> Self {
        let every = ((every_s / sample_period_s).round() as u64).max(1);
        let d = integrity::DeliveryReport::from_ledger(registry);
        Hours {
            every,
            sample_period_s,
            span: Metrics::new(sample_period_s).keeping_series(false),
            start: (0.0, 0.0),
            ledger_before: (d.lost_must_arrive, d.total),
            rows: Vec::new(),
        }
    }

    /// Takes the row of the span ending now, at `end_s`, and starts the next one after `last`
    /// (the sample that ended it; `None` at the end of the run).
    fn take(
        &mut self,
        end_s: f64,
        registry: &orsa_actors::Registry,
        whole: &Metrics,
        events: &[SupervisorEvent],
        last: Option<&Sample>,
    ) {
        let (start_s, start_m) = self.start;
        let mut row =
            report::HourFigures::measures(end_s, end_s - start_s, &self.span, whole.distance_m - start_m);
        (row.rss_kib, row.hwm_kib) = metrics::process_memory();
        row.restarts = events.iter().filter(|e| e.kind == SupervisorEventKind::Restarted).count() as u64;
        row.bumps = whole.bumps;
        row.stalls = whole.stalls;
        let d = integrity::DeliveryReport::from_ledger(registry);
        let (must_before, before) = self.ledger_before;
        row.lost_must_arrive = d.lost_must_arrive.saturating_sub(must_before);
        row.lost = d.total.lost.saturating_sub(before.lost);
        row.failed = d.total.failed.saturating_sub(before.failed);
        row.duplicates = d.total.duplicates.saturating_sub(before.duplicates);
        row.sizes = report::Sizes {
            components: registry.components().len(),
            services: registry.services().len(),
            subscriptions: registry.clients().values().sum(),
            ledger_services: registry.ledger().counts().len(),
            tasks: tokio::runtime::Handle::current().metrics().num_alive_tasks(),
            supervisor_events: events.len(),
            fault_log: registry.faults().event_count(),
            trajectory: whole.trajectory.len(),
        };
        self.rows.push(row);
        self.ledger_before = (d.lost_must_arrive, d.total);
        if let Some(last) = last {
            self.span = Metrics::after(self.sample_period_s, last);
            self.start = (last.t_s, last.travelled_m);
        }
    }
}
