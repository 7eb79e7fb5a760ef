//! What a run's report says of its faults: what was injected, detected and restarted, how
//! long recoveries took, and how the robot went through each link cut.

use super::plan::FaultPlan;
use orsa_actors::fault::{FaultEventKind, Faults, MessageFaultCounts};
use orsa_hardware::faulty::BoardFaults;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The `faults` section of a run's report.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FaultsReport {
    /// Occurrences injected, by kind.
    pub injected: BTreeMap<String, u64>,
    /// Failures the system saw (handler panicked, hung, killed, failed), by component.
    pub detected: BTreeMap<String, u64>,
    /// Restarts by the supervisor, by component.
    pub restarts: BTreeMap<String, u64>,
    /// Time from a component's failure to its restarted instance, ms (p50, p99, max), from
    /// the supervisor's events.
    pub restart_ms: Option<[f64; 3]>,
    /// Time from a failure being seen to the component's next handled message, ms (p50, p99,
    /// max over all recoveries): the restart plus the wait for the next message.
    pub recovery_ms: Option<[f64; 3]>,
    /// Recoveries measured.
    pub recoveries: u64,
    /// Failures after which the component never handled a message again within the run.
    pub not_recovered: u64,
    /// Messages dropped, delayed and duplicated, by service.
    pub messages: BTreeMap<String, MessageFaultCounts>,
    /// Reads altered and commands swallowed by hardware faults.
    pub hardware_altered: u64,
    /// Every event, in order (time in s, target, what).
    pub log: Vec<(f64, String, String)>,
    /// Every link cut and what the robot did about it (`orsa robot --faults`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<LinkCutReport>,
    /// What was lost, in short (the whole accounting is the report's `delivery` section;
    /// `orsa run` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loss: Option<LossFigures>,
    /// Whether the robot stayed safe, in short (`orsa run` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub safety: Option<FaultSafety>,
}

/// The loss counts of a fault run, over all services.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LossFigures {
    /// Send, Query and Event messages that vanished while their sender believed them handed
    /// over.
    pub lost_must_arrive: u64,
    /// All messages lost so (push updates included).
    pub lost: u64,
    /// Messages whose sender was told they could not be handed over.
    pub failed: u64,
    /// Arrivals a receiver had already seen.
    pub duplicates: u64,
    /// Messages the plan dropped.
    pub dropped_by_plan: u64,
    /// Push updates left in a dead instance and replaced by the next one.
    pub superseded: u64,
    /// Subscription and wiring checks (each second) that found something other than expected.
    pub subscription_mismatches: u64,
    /// Wiring checks that found a lasting mismatch with the master's decision.
    pub wiring_mismatches: u64,
}

/// The safety figures of a fault run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FaultSafety {
    /// Contact onsets.
    pub bumps: u64,
    /// Simulated seconds driven with nothing wired, beyond the velocity timeout.
    pub driven_unwired_s: f64,
    /// Simulated seconds driven on a command older than the velocity timeout (motor side).
    pub driven_on_stale_command_s: f64,
    /// Commands older than the velocity timeout when the motors took them.
    pub stale_commands_applied: u64,
}

/// One link cut as the robot lived it; times in seconds on the robot's clock (from the start
/// of its process), like the log's.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkCutReport {
    /// The role cut off.
    pub role: String,
    /// When the link was cut.
    pub cut_at_s: f64,
    /// When it was restored (none: still cut at the end).
    pub restored_at_s: Option<f64>,
    /// When the robot declared a process of that role lost (the executive's heartbeat lease).
    pub lost_at_s: Option<f64>,
    /// When the robot, having lost its executive, unwired the behaviours and commanded zero.
    pub stop_commanded_at_s: Option<f64>,
    /// The first base state at rest (no translation, no rotation) at or after the cut.
    pub at_rest_at_s: Option<f64>,
    /// When the lost process was heard again and given back what it drove.
    pub back_at_s: Option<f64>,
    /// The first base state moving after the link was restored.
    pub moving_again_at_s: Option<f64>,
}

/// Restarts by child and each restart's duration in ms, from a supervisor's events.
pub fn restarts_of(
    events: &[orsa_actors::supervision::SupervisorEvent],
) -> (BTreeMap<String, u64>, Vec<f64>) {
    use orsa_actors::supervision::SupervisorEventKind;
    let mut by_child = BTreeMap::new();
    let mut failed_at: BTreeMap<&str, f64> = BTreeMap::new();
    let mut restart_ms = Vec::new();
    for e in events {
        match e.kind {
            SupervisorEventKind::ChildFailed => {
                failed_at.insert(e.child.as_str(), e.at.as_secs_f64());
            }
            SupervisorEventKind::Restarted => {
                *by_child.entry(e.child.clone()).or_insert(0u64) += 1;
                if let Some(t) = failed_at.remove(e.child.as_str()) {
                    restart_ms.push((e.at.as_secs_f64() - t) * 1e3);
                }
            }
            _ => {}
        }
    }
    (by_child, restart_ms)
}

impl FaultsReport {
    /// The section for a run of `end_s` seconds with `plan`, whose switchboard is `faults` on
    /// `clock` (the log's times are seconds since it started), with the supervisor's restarts by
    /// component and each restart's duration in ms.
    pub fn new(
        plan: &FaultPlan,
        end_s: f64,
        faults: &Faults,
        clock: &orsa_actors::Clock,
        boards: &BoardFaults,
        restarts: BTreeMap<String, u64>,
        mut restart_ms: Vec<f64>,
    ) -> Self {
        let events = faults.events();
        let mut report = FaultsReport {
            restarts,
            hardware_altered: boards.altered(),
            restart_ms: percentiles(&mut restart_ms),
            ..Default::default()
        };
        for (t, f) in plan.occurrences(end_s) {
            if t < end_s {
                *report.injected.entry(f.kind.clone()).or_default() += 1;
            }
        }
        let mut pending: BTreeMap<String, f64> = BTreeMap::new();
        let mut recoveries = Vec::new();
        for e in &events {
            let t = clock.since_start(e.at).as_secs_f64();
            let what = match &e.what {
                FaultEventKind::Injected(k) => format!("injected {k}"),
                FaultEventKind::Detected(how) => {
                    *report.detected.entry(e.target.clone()).or_default() += 1;
                    pending.insert(e.target.clone(), t);
                    format!("detected: {how}")
                }
                FaultEventKind::Recovered => {
                    if let Some(since) = pending.remove(&e.target) {
                        recoveries.push((t - since) * 1e3);
                    }
                    "recovered".to_string()
                }
            };
            report.log.push((t, e.target.clone(), what));
        }
        report.not_recovered = pending.len() as u64;
        report.recoveries = recoveries.len() as u64;
        report.recovery_ms = percentiles(&mut recoveries);
        for (addr, c) in faults.message_counts() {
            report.messages.insert(addr.to_string(), c);
        }
        report
    }
}

/// p50, p99 and max (nearest rank), if there are values.
fn percentiles(v: &mut [f64]) -> Option<[f64; 3]> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some([at(0.5), at(0.99), v[v.len() - 1]])
}
