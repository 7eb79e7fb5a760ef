//! Ending the executive process: how it ended (unwiring the behaviours first when its
//! supervisor gave up), saying so, and its report.

use super::ExecutiveReport;
use super::setup::{LinkLog, Recording};
use crate::config::Config;
use crate::ending::Stop;
use crate::mission::report::Ended;
use anyhow::{Context as _, bail};
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::{Registry, Timestamp};
use orsa_hardware::faulty::BoardFaults;
use std::path::Path;
use std::time::Duration;

/// How the run that stopped so at `at_s` ended, and whether every behaviour is unwired (it is
/// only tried when the supervisor gave up).
pub(super) async fn ended(
    run: anyhow::Result<Stop>,
    registry: &Registry,
    config: &Config,
    at_s: f64,
) -> (Ended, bool) {
    match run {
        Ok(Stop::GaveUp(e)) => {
            // The master is gone: no behaviour may go on driving without it. The robot
            // stops its motors when this process leaves, and its watchdog stays armed.
            crate::say!(
                "executive",
                "[{at_s:.3} s] supervisor '{}' gave up ({}): unwiring the behaviours",
                e.supervisor,
                e.reason
            );
            let unwired_all = unwire_all(registry, config).await;
            (crate::ending::ended(Stop::GaveUp(e), at_s, None), unwired_all)
        }
        Ok(stop) => (crate::ending::ended(stop, at_s, None), true),
        Err(e) => (Ended::Failed { at_s, error: format!("{e:#}") }, true),
    }
}

/// Disconnects every behaviour's velocity port; whether all of them were.
async fn unwire_all(registry: &Registry, config: &Config) -> bool {
    let wiring = orsa_actors::wiring::WiringMaster::new(registry);
    let mut all_unwired = true;
    for b in config.executive().behaviours() {
        let unwired = tokio::time::timeout(
            Duration::from_secs(1),
            wiring.disconnect(&b, orsa_interfaces::behaviour::VEL),
        )
        .await;
        if !matches!(unwired, Ok(Ok(()))) {
            all_unwired = false;
            crate::say!("executive", "cannot unwire {b}: the robot stops when this process leaves");
        }
    }
    all_unwired
}

/// Says how the process ended, unless it completed.
pub(super) fn tell(ended: &Ended, unwired_all: bool) {
    match ended {
        Ended::Completed => {}
        // The executive stops no motors itself (its report's `stopped_in_s` stays empty):
        // the robot does, when it sees it go.
        Ended::GaveUp { at_s, supervisor, child, reason, .. } => crate::say!(
            "executive",
            "gave up at {at_s:.1} s: supervisor '{supervisor}' stopped after '{child}' failed \
             once too often ({reason}); {}the robot stops as this process leaves",
            if unwired_all {
                "the behaviours were unwired and "
            } else {
                "not every behaviour could be unwired; "
            }
        ),
        other => crate::say!("executive", "{}", other.describe()),
    }
}

/// What the fault plan did, if there was one (started at `plan_started_at`, if it was), for a
/// process that ended at `end_s`.
pub(super) struct PlanRun<'a> {
    pub(super) plan: Option<&'a crate::faults::FaultPlan>,
    pub(super) started_at: Option<Timestamp>,
    pub(super) link_log: &'a LinkLog,
    pub(super) boards: &'a BoardFaults,
}

/// The report of a process that ended so at `end_s`, with what its transport counted.
pub(super) fn report(
    ended: &Ended,
    end_s: f64,
    registry: &Registry,
    events: &[SupervisorEvent],
    plan: PlanRun<'_>,
    link: orsa_net::LinkCutStats,
    links: orsa_net::LinkLedger,
) -> ExecutiveReport {
    let (restarts, restart_ms) = crate::faults::restarts_of(events);
    let total_restarts = restarts.values().sum();
    let faults = plan.plan.map(|p| {
        let plan_end =
            end_s - plan.started_at.map_or(end_s, |t| registry.clock().since_start(t).as_secs_f64());
        let mut report = crate::faults::FaultsReport::new(
            p,
            plan_end,
            &registry.faults(),
            &registry.clock(),
            plan.boards,
            restarts,
            restart_ms,
        );
        report.log.extend(plan.link_log.lock().iter().cloned());
        report.log.sort_by(|a, b| a.0.total_cmp(&b.0));
        report
    });
    ExecutiveReport { ended: ended.clone(), duration_s: end_s, restarts: total_restarts, link, links, faults }
}

/// Writes `report` to `path`, if given.
pub(super) fn write_report(path: Option<&Path>, report: &ExecutiveReport) -> anyhow::Result<()> {
    let Some(p) = path else { return Ok(()) };
    std::fs::write(p, serde_json::to_string_pretty(report)?)
        .with_context(|| format!("{}: cannot write the report", p.display()))?;
    crate::say!("executive", "report: {}", p.display());
    Ok(())
}

/// Closes the recording, if any, and says what it holds.
pub(super) fn finish_recording(recording: Recording) -> anyhow::Result<()> {
    let Some(tap) = recording else { return Ok(()) };
    match tap.finish() {
        Ok(Some(r)) => {
            let total: u64 = r.messages.values().sum();
            crate::say!(
                "executive",
                "record: {} ({total} messages on {} topics)",
                r.path.display(),
                r.messages.len()
            );
        }
        Ok(None) => {}
        Err(e) => bail!("the executive stopped, but its recording failed: {e}"),
    }
    Ok(())
}
