//! Carrying a fault plan out: the task that breaks and mends, at the plan's times, what the
//! plan names.

use super::plan::{Action, FaultPlan};
use orsa_actors::fault::{FaultEventKind, Faults, HandlerFault};
use orsa_hardware::faulty::BoardFaults;
use std::time::Duration;

/// Cuts (`true`) or restores (`false`) the link to the processes of a role.
pub type LinkSwitch = std::sync::Arc<dyn Fn(&str, bool) + Send + Sync>;

/// Where a running fault plan acts.
#[derive(Clone)]
pub struct FaultTargets {
    /// The framework's switchboard (components and services).
    pub faults: Faults,
    /// The robot's boards.
    pub boards: BoardFaults,
    /// Cuts (true) and restores (false) the link to processes of a role, where there are any.
    pub link: Option<LinkSwitch>,
    /// The simulated world, for its events (`box_placed`, `kidnap`); `None` where the robot is
    /// not simulated (each event is then skipped with a warning).
    pub stage: Option<orsa_hardware::sim::SimStage>,
}

fn apply(targets: &FaultTargets, action: &Action, on: bool) {
    match action {
        Action::Panic { component } if on => targets.faults.arm(component, HandlerFault::Panic),
        Action::Hang { component } if on => targets.faults.arm(component, HandlerFault::Hang),
        Action::Kill { component } if on => {
            targets.faults.kill(component);
        }
        Action::Panic { .. } | Action::Hang { .. } | Action::Kill { .. } => {}
        Action::Message { service, fault } => targets.faults.set_message_fault(service, on.then_some(*fault)),
        Action::Sensor { ring, fault } => targets.boards.set_sensor(*ring, on.then_some(*fault)),
        Action::MotorStall => targets.boards.set_motor_stall(on),
        Action::LinkCut { role } => {
            if let Some(cut) = &targets.link {
                cut(role, on);
            }
        }
        Action::BoxPlaced { min, max } => {
            let Some(stage) = &targets.stage else { return not_simulated("box_placed") };
            let what = format!("box [{}, {}]-[{}, {}]", min[0], min[1], max[0], max[1]);
            if on {
                match stage.place_box(*min, *max) {
                    Ok(()) => {
                        targets.faults.note("world", FaultEventKind::Injected(format!("box_placed: {what}")))
                    }
                    Err(e) => {
                        tracing::warn!("fault plan: box_placed not carried out: {e}");
                        targets
                            .faults
                            .note("world", FaultEventKind::Injected(format!("box_placed refused: {e}")));
                    }
                }
            } else if stage.remove_box(*min, *max) {
                targets.faults.note("world", FaultEventKind::Recovered);
                tracing::info!("fault plan: took the {what} away");
            }
        }
        Action::Kidnap { x, y, heading_deg } if on => {
            let Some(stage) = &targets.stage else { return not_simulated("kidnap") };
            match stage.carry_to(*x, *y, heading_deg.to_radians()) {
                Ok(()) => targets.faults.note(
                    "robot",
                    FaultEventKind::Injected(format!(
                        "kidnap: set down at ({x}, {y}) facing {heading_deg} deg"
                    )),
                ),
                Err(e) => {
                    tracing::warn!("fault plan: kidnap not carried out: {e}");
                    targets.faults.note("robot", FaultEventKind::Injected(format!("kidnap refused: {e}")));
                }
            }
        }
        Action::Kidnap { .. } => {}
    }
}

/// A world event where the robot is not simulated (a real or ROS 2 robot): nothing to act on.
fn not_simulated(kind: &str) {
    tracing::warn!(
        "fault plan: '{kind}' changes a simulated world, and this robot is not simulated: skipped"
    );
}

/// Runs `plan` against `targets` on tokio's clock, from now until `end_s` simulated seconds.
/// Returns the number of occurrences injected.
pub async fn run_plan(plan: FaultPlan, targets: FaultTargets, end_s: f64) -> usize {
    let start = tokio::time::Instant::now();
    // Every start and every end of an occurrence, in time order (ends first at equal times).
    let mut timeline: Vec<(f64, bool, Action)> = Vec::new();
    let occurrences = plan.occurrences(end_s);
    for (t, f) in &occurrences {
        timeline.push((*t, true, f.action.clone()));
        if let Some(d) = f.duration_s {
            timeline.push((t + d, false, f.action.clone()));
        }
    }
    timeline.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    for (t, on, action) in timeline {
        tokio::time::sleep_until(start + Duration::from_secs_f64(t)).await;
        // Lands after everything else the system does at this instant (see the function).
        orsa_actors::end_of_instant().await;
        apply(&targets, &action, on);
    }
    occurrences.len()
}
