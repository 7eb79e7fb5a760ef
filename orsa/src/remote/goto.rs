//! `orsa goto`: sends the robot to a place through the planner, wherever it runs, shows the
//! goal's feedback and ends with its result.

use super::{NetworkOptions, open, runtime, secs, wait_for};
use crate::ending::Outcome;
use anyhow::Context as _;
use orsa_actors::Sink;
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::QueryClient;
use orsa_actors::send::SendClient;
use orsa_actors::{Registry, Update};
use orsa_interfaces::navigation::{
    CANCEL, NAVIGATE, NAVIGATION, NavCancel, NavFeedback, NavGoal, NavReply, NavState, NavTarget,
};
use std::time::Duration;
use tokio::sync::mpsc;

/// Options of `orsa goto`.
#[derive(Debug)]
pub struct GotoOptions {
    /// Where to go: a place named in the robot's world, or a pose in the map.
    pub target: NavTarget,
    /// The planner component that takes goals.
    pub planner: String,
    /// Give the goal up (cancel it) if it has not ended after this many seconds.
    pub timeout: Option<f64>,
    /// One JSON object per line (each feedback, then the result).
    pub json: bool,
    /// How long to wait for the planner.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

/// How long the planner may take to answer a goal (it asks the executive for its mode, which
/// may take a few seconds of switching).
const ANSWER_WITHIN: Duration = Duration::from_secs(15);

/// `orsa goto`: `Completed` when the goal succeeded, `MissionFailed` when it was rejected,
/// aborted, canceled or preempted (or its `--timeout` ran out), `Interrupted` on Ctrl-C (the
/// goal is canceled first).
pub fn goto(args: GotoOptions) -> anyhow::Result<Outcome> {
    let wait = secs(args.wait, "--wait")?;
    let timeout = args.timeout.map(|t| secs(t, "--timeout")).transpose()?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        let navigate = NAVIGATE.on(&args.planner);
        let needed = [navigate.untyped(), NAVIGATION.on(&args.planner).untyped()];
        wait_for(&transport, &needed, wait).await?;
        // Subscribed before the goal is given, so that nothing of its feedback is missed.
        let (tx, mut rx) = mpsc::unbounded_channel::<Update<NavFeedback>>();
        let feedback = PushNewestClient::connect_to(&registry, NAVIGATION.on(&args.planner), Sink::channel(tx))?;
        feedback.subscribe()?;
        let started = tokio::time::Instant::now();
        let reply = QueryClient::connect(&registry, navigate)?
            .query(NavGoal { target: args.target.clone() }, Some(ANSWER_WITHIN))
            .await
            .with_context(|| format!("{}/navigate did not answer the goal", args.planner))?;
        let id = match reply {
            NavReply::Accepted { id } => id,
            NavReply::Rejected { reason } => {
                show(&args, None, &format!("goal to {} rejected: {reason}", args.target));
                transport.close().await;
                return Ok(Outcome::MissionFailed);
            }
        };
        if !args.json {
            crate::output::say(&format!("goal {id} to {} accepted", args.target));
        }
        let cancel = || -> anyhow::Result<()> {
            SendClient::<NavCancel>::connect(&registry, CANCEL.on(&args.planner))?.send(NavCancel { id: Some(id) })?;
            Ok(())
        };
        let deadline = async {
            match timeout {
                Some(t) => tokio::time::sleep_until(started + t).await,
                None => std::future::pending().await,
            }
        };
        tokio::pin!(deadline);
        let outcome = loop {
            tokio::select! {
                _ = tokio::signal::ctrl_c() => {
                    cancel()?;
                    show(&args, None, &format!("goal {id}: interrupted, canceled"));
                    break Outcome::Interrupted;
                }
                () = &mut deadline => {
                    cancel()?;
                    let t = timeout.map_or(0.0, |t| t.as_secs_f64());
                    show(&args, None, &format!("goal {id}: not ended after {t:.0} s (--timeout), canceled"));
                    break Outcome::MissionFailed;
                }
                update = rx.recv() => {
                    let Some(update) = update else {
                        anyhow::bail!("the planner's feedback stopped");
                    };
                    let f = &update.value;
                    if f.id > id && !f.state.is_final() {
                        // A newer goal runs: ours was preempted, whether or not its end came.
                        show(&args, None, &format!("goal {id}: preempted by goal {}", f.id));
                        break Outcome::MissionFailed;
                    }
                    if f.id != id {
                        continue;
                    }
                    let elapsed = started.elapsed().as_secs_f64();
                    show(&args, Some(f), &line(f, elapsed));
                    if f.state.is_final() {
                        break if f.state == NavState::Succeeded { Outcome::Completed } else { Outcome::MissionFailed };
                    }
                }
            }
        };
        // Let a cancel leave before the session closes.
        tokio::time::sleep(Duration::from_millis(100)).await;
        transport.close().await;
        Ok(outcome)
    })
}

/// A feedback as one line of text.
fn line(f: &NavFeedback, elapsed_s: f64) -> String {
    let why = if f.reason.is_empty() { String::new() } else { format!(": {}", f.reason) };
    match f.state {
        NavState::Active => format!(
            "goal {} to {}: {:.1} m left, eta {:.0} s{why}",
            f.id, f.target, f.distance_left_m, f.eta_s
        ),
        state => format!("goal {} to {}: {}{why} after {elapsed_s:.1} s", f.id, f.target, state.name()),
    }
}

/// Prints a feedback (as JSON with `--json`) or a message.
fn show(args: &GotoOptions, f: Option<&NavFeedback>, text: &str) {
    match (args.json, f) {
        (true, Some(f)) => match serde_json::to_string(f) {
            Ok(json) => crate::output::say(&json),
            Err(e) => eprintln!("goto: {e}"),
        },
        (true, None) => crate::output::say(&serde_json::json!({ "message": text }).to_string()),
        (false, _) => crate::output::say(text),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_actors::Timestamp;

    #[test]
    fn feedback_reads_as_a_line() {
        let mut f = NavFeedback {
            stamp: Timestamp(0),
            id: 2,
            target: NavTarget::Place { name: "room-3".into() },
            goal: Some([1.0, 2.0]),
            state: NavState::Active,
            reason: String::new(),
            distance_left_m: 4.26,
            eta_s: 10.6,
            path: Vec::new(),
        };
        assert_eq!(line(&f, 3.0), "goal 2 to room-3: 4.3 m left, eta 11 s");
        f.state = NavState::Aborted;
        f.reason = "no path".into();
        assert_eq!(line(&f, 12.34), "goal 2 to room-3: aborted: no path after 12.3 s");
    }
}
