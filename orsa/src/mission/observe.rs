//! What watches a run without being the run: its recording, its live view, its fault plan, its
//! progress reports, and whatever a program attaches with
//! [`RunOptions::observe`](super::RunOptions::observe).
//!
//! A run is one loop (bring the [`Stack`] up, tick the sampling clock, end on the duration, an
//! interrupt or the top supervisor giving up, shut down); a [`RunObserver`] is told of each
//! step, in this order:
//!
//! 1. [`tap`](RunObserver::tap), before the stack comes up: a [`RunTap`] that sees every
//!    message and supervisor event as it happens, on the stack's own tasks;
//! 2. [`on_start`](RunObserver::on_start), once the stack is up;
//! 3. [`on_tick`](RunObserver::on_tick) at every sampling period, and
//!    [`on_supervisor_event`](RunObserver::on_supervisor_event) for each supervisor event, in
//!    order, at the first tick after it (and at the end for the last ones);
//! 4. [`on_stop`](RunObserver::on_stop) when the loop ends, with the stack still up;
//! 5. [`on_end`](RunObserver::on_end) with the run's outcome, once the stack is down.
//!
//! Observers are told in the order they were attached; the built-in ones (fault plan, the
//! options' `on_start`, recording, live view, progress) come first.

use super::Stack;
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::tap::Tap;
use orsa_hardware::sim::Truth;
use std::sync::Arc;

/// A [`Tap`] that is also told of the supervisors' events as they happen.
pub trait RunTap: Tap {
    /// A supervisor's event, on the supervisor's task: it must not block. By default, ignored.
    fn supervisor_event(&self, e: &SupervisorEvent) {
        let _ = e;
    }
}

impl RunTap for super::recording::McapTap {
    fn supervisor_event(&self, e: &SupervisorEvent) {
        super::recording::McapTap::supervisor_event(self, e);
    }
}

impl RunTap for crate::live::tap::LiveTap {
    fn supervisor_event(&self, e: &SupervisorEvent) {
        crate::live::tap::LiveTap::supervisor_event(self, e);
    }
}

/// One tick of a run's sampling clock.
pub struct Tick<'a> {
    /// Which tick, from 1.
    pub k: u64,
    /// Simulated time since the start of the run, s (`k` sampling periods).
    pub t_s: f64,
    /// Ground truth, read at this tick.
    pub truth: &'a Truth,
    /// The behaviour driving the motors, as the executive last said.
    pub driving: Option<&'a str>,
    /// The running stack.
    pub stack: &'a Stack,
}

/// Something attached to a run that is told what happens in it (see the [module](self) for
/// when each method is called). Every method does nothing by default.
///
/// An observer does not change the run: what it is given is to read (a tap and a registry can
/// do more; the built-in observers only watch, except the fault plan, whose business it is).
pub trait RunObserver: Send {
    /// What sees every message and supervisor event as it happens, installed before the
    /// first component starts.
    fn tap(&self) -> Option<Arc<dyn RunTap>> {
        None
    }

    /// The stack is up (nothing was sampled yet).
    fn on_start(&mut self, stack: &Stack) {
        let _ = stack;
    }

    /// A tick of the sampling clock, before the run's own measures of it.
    fn on_tick(&mut self, tick: &Tick<'_>) {
        let _ = tick;
    }

    /// A supervisor's event, in the order they happened (`e.at` says when), at the first tick
    /// after it or at the end.
    fn on_supervisor_event(&mut self, e: &SupervisorEvent) {
        let _ = e;
    }

    /// The sampling loop ended at `at_s` simulated seconds (at its duration, or early); the
    /// stack is still up and the report's last measures are yet to be taken.
    fn on_stop(&mut self, stack: &Stack, at_s: f64) {
        let _ = (stack, at_s);
    }

    /// The run's outcome, once the stack is down; an observer may add what it made (the
    /// recording's summary, the fault plan's report).
    fn on_end(&mut self, outcome: &mut super::RunOutcome) {
        let _ = outcome;
    }
}

/// The ground truth `t` and the people `truth` knows of, for the recording's views.
fn truth_sample(t: &Truth, truth: &orsa_hardware::sim::SimTruth) -> crate::record::views::TruthSample {
    let people = truth
        .movers()
        .into_iter()
        .map(|m| crate::record::views::Person {
            x_m: m.x_m,
            y_m: m.y_m,
            radius_m: m.radius_m,
            yielding: m.yielding,
        })
        .collect();
    crate::record::views::TruthSample {
        at: t.stamp,
        x_m: t.x_m,
        y_m: t.y_m,
        heading_rad: t.heading_rad,
        people,
    }
}

/// The truth the views get as the run starts.
fn start_sample(stack: &Stack) -> crate::record::views::TruthSample {
    let truth = super::stack::truth_of(stack);
    truth_sample(&truth.truth(), truth)
}

/// The truth the views get at a tick.
fn tick_sample(tick: &Tick<'_>) -> crate::record::views::TruthSample {
    truth_sample(tick.truth, super::stack::truth_of(tick.stack))
}

/// Records the run to an MCAP file ([`RunOptions::record`](super::RunOptions::record)).
pub(super) struct Recorder(pub(super) Arc<super::recording::McapTap>);

impl RunObserver for Recorder {
    fn tap(&self) -> Option<Arc<dyn RunTap>> {
        Some(self.0.clone())
    }

    fn on_start(&mut self, stack: &Stack) {
        self.0.truth(start_sample(stack));
    }

    fn on_tick(&mut self, tick: &Tick<'_>) {
        self.0.truth(tick_sample(tick));
    }

    fn on_end(&mut self, outcome: &mut super::RunOutcome) {
        outcome.recording = self.0.finish().transpose();
    }
}

/// Serves the run's views live ([`RunOptions::live`](super::RunOptions::live)); the caller
/// finishes it.
pub(super) struct LiveView(pub(super) Arc<crate::live::tap::LiveTap>);

impl RunObserver for LiveView {
    fn tap(&self) -> Option<Arc<dyn RunTap>> {
        Some(self.0.clone())
    }

    fn on_start(&mut self, stack: &Stack) {
        self.0.truth(start_sample(stack));
    }

    fn on_tick(&mut self, tick: &Tick<'_>) {
        self.0.truth(tick_sample(tick));
    }
}

/// Runs the fault plan from the start of the run to the end of its loop, and reports it
/// ([`RunOptions::faults`](super::RunOptions::faults)).
pub(super) struct FaultPlanRun {
    plan: crate::faults::FaultPlan,
    duration_s: f64,
    task: Option<tokio::task::JoinHandle<usize>>,
    /// What the report reads: the actors' fault switch, the clock and the boards' switch.
    seen: Option<(orsa_actors::fault::Faults, orsa_actors::Clock, orsa_hardware::faulty::BoardFaults)>,
}

impl FaultPlanRun {
    pub(super) fn new(plan: crate::faults::FaultPlan, duration_s: f64) -> Self {
        FaultPlanRun { plan, duration_s, task: None, seen: None }
    }
}

impl RunObserver for FaultPlanRun {
    fn on_start(&mut self, stack: &Stack) {
        let targets = crate::faults::FaultTargets {
            faults: stack.registry.faults(),
            boards: stack.board_faults.clone(),
            link: None,
            stage: stack.robot.truth.as_ref().map(|t| t.stage()),
        };
        self.task = Some(tokio::spawn(crate::faults::run_plan(self.plan.clone(), targets, self.duration_s)));
        self.seen = Some((stack.registry.faults(), stack.registry.clock(), stack.board_faults.clone()));
    }

    fn on_stop(&mut self, _stack: &Stack, _at_s: f64) {
        if let Some(task) = self.task.take() {
            task.abort();
        }
    }

    fn on_end(&mut self, outcome: &mut super::RunOutcome) {
        let Some((faults, clock, boards)) = &self.seen else { return };
        let (by_child, restart_ms) = crate::faults::restarts_of(&outcome.supervisor_events);
        let report = &mut outcome.report;
        let mut f = crate::faults::FaultsReport::new(
            &self.plan,
            self.duration_s,
            faults,
            clock,
            boards,
            by_child,
            restart_ms,
        );
        let (d, i) = (&report.delivery, &report.integrity);
        f.loss = Some(crate::faults::LossFigures {
            lost_must_arrive: d.lost_must_arrive,
            lost: d.total.lost,
            failed: d.total.failed,
            duplicates: d.total.duplicates,
            dropped_by_plan: d.total.dropped,
            superseded: d.total.superseded,
            subscription_mismatches: i.client_mismatches,
            wiring_mismatches: i.wiring_mismatches,
        });
        f.safety = Some(crate::faults::FaultSafety {
            bumps: report.bumps,
            driven_unwired_s: i.driven_unwired_s,
            driven_on_stale_command_s: i.driven_on_stale_command_s,
            stale_commands_applied: report.safety.stale_commands_applied,
        });
        report.faults = Some(f);
    }
}

/// Calls [`RunOptions::on_start`](super::RunOptions::on_start) with the registry.
pub(super) struct StartHook(pub(super) Option<super::OnStart>);

impl RunObserver for StartHook {
    fn on_start(&mut self, stack: &Stack) {
        if let Some(f) = self.0.take() {
            f(&stack.registry);
        }
    }
}

/// Calls [`RunOptions::progress`](super::RunOptions::progress) every so many ticks.
pub(super) struct Progress {
    pub(super) report: Arc<dyn Fn(f64) + Send + Sync>,
    /// Ticks between two calls.
    pub(super) every: u64,
}

impl RunObserver for Progress {
    fn on_tick(&mut self, tick: &Tick<'_>) {
        if tick.k.is_multiple_of(self.every) {
            (self.report)(tick.t_s);
        }
    }
}
