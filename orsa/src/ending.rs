//! How a long-running command ends, and what it does on the way out: `orsa run`, `orsa robot`
//! and `orsa executive` end when their time is up, on Ctrl-C or SIGTERM, when their top
//! supervisor gives up, or on a fatal error; each writes its report on every one of those paths
//! and says how it ended ([`Ended`]), and the command's exit code tells them apart
//! ([`Outcome`]).

use crate::mission::report::Ended;
use orsa_actors::supervision::{SupervisorEvent, SupervisorEventKind};
use std::time::Duration;
use tokio::sync::watch;

/// What ended a process's main loop.
#[derive(Debug, Clone)]
pub enum Stop {
    /// Its time was up.
    Time,
    /// A signal, by name.
    Signal(String),
    /// Its top supervisor gave up.
    GaveUp(SupervisorEvent),
}

/// Watches a system's supervisor events for its top supervisor (`top`) giving up.
#[derive(Debug, Clone)]
pub struct TopWatch {
    top: String,
    tx: std::sync::Arc<watch::Sender<Option<SupervisorEvent>>>,
}

impl TopWatch {
    /// A watch on the supervisor named `top`.
    pub fn new(top: &str) -> Self {
        TopWatch { top: top.to_string(), tx: std::sync::Arc::new(watch::channel(None).0) }
    }

    /// Hands it one supervisor event (call it from the system's event sink).
    pub fn see(&self, e: &SupervisorEvent) {
        if e.kind == SupervisorEventKind::GaveUp && e.supervisor == self.top {
            self.tx.send_replace(Some(e.clone()));
        }
    }

    /// Resolves with the event of the top giving up (never, if it does not).
    pub async fn gave_up(&self) -> SupervisorEvent {
        let mut rx = self.tx.subscribe();
        match rx.wait_for(Option::is_some).await {
            Ok(e) => match e.clone() {
                Some(e) => e,
                None => std::future::pending().await,
            },
            Err(_) => std::future::pending().await,
        }
    }
}

/// Resolves with what ends the process: `duration` (if any) passing, Ctrl-C or SIGTERM, or
/// the top supervisor giving up.
pub async fn until_end(duration: Option<Duration>, top: &TopWatch) -> Stop {
    let limit = async {
        match duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        () = limit => Stop::Time,
        signal = interrupted() => Stop::Signal(signal),
        e = top.gave_up() => Stop::GaveUp(e),
    }
}

/// How long a process that gave up waits for the robot to come to rest.
pub const STOP_WAIT: Duration = Duration::from_secs(2);

/// The [`Ended`] of a process stopped by `stop` at `at_s` (seconds on its clock); a give-up's
/// `stopped_in_s` is how long the robot took to come to rest, if the process drives one.
pub fn ended(stop: Stop, at_s: f64, stopped_in_s: Option<f64>) -> Ended {
    match stop {
        Stop::Time => Ended::Completed,
        Stop::Signal(signal) => Ended::Interrupted { at_s, signal },
        Stop::GaveUp(e) => {
            Ended::GaveUp { at_s, supervisor: e.supervisor, child: e.child, reason: e.reason, stopped_in_s }
        }
    }
}

/// Runs `run` (a process's start-up and main loop), ending it early with
/// [`Stop::Signal`] on Ctrl-C or SIGTERM, start-up included.
pub async fn or_signal(run: impl std::future::Future<Output = anyhow::Result<Stop>>) -> anyhow::Result<Stop> {
    tokio::select! {
        r = run => r,
        signal = interrupted() => Ok(Stop::Signal(signal)),
    }
}

/// Makes the panics a fault plan injects print one debug line instead of a message and a
/// backtrace (the fault log and the supervisor report them); any other panic prints as usual.
pub fn quiet_injected_panics() {
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("injected fault") {
            tracing::debug!("{message}");
        } else {
            default_hook(info);
        }
    }));
}

/// How a command ended, when it did not fail: each has its exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It did what it was asked (exit code 0).
    Completed,
    /// The system gave up: its top supervisor went over its restart intensity; the motors were
    /// stopped and the report written (exit code 3).
    GaveUp,
    /// Ctrl-C or SIGTERM ended it early; the report was written (exit code 130).
    Interrupted,
    /// A run of a mission of places (`orsa run --goto`) that did not reach them all: a step
    /// was skipped (a place rejected, a goal aborted), the mission was aborted, or its time ran
    /// out first; the report says which and why. Or a goal of `orsa goto` that was not reached:
    /// rejected, aborted, canceled or preempted, or its `--timeout` ran out (exit code 4).
    MissionFailed,
}

impl Outcome {
    /// The outcome of a command that ended so; a fatal error (whose report was written) is the
    /// command's error (exit code 1).
    pub fn of(ended: &Ended) -> anyhow::Result<Outcome> {
        match ended {
            Ended::Completed => Ok(Outcome::Completed),
            // The planner's result is `completed` only when every step was done.
            Ended::MissionEnded { result, .. } if result == "completed" => Ok(Outcome::Completed),
            Ended::MissionEnded { .. } => Ok(Outcome::MissionFailed),
            Ended::GaveUp { .. } => Ok(Outcome::GaveUp),
            Ended::Interrupted { .. } => Ok(Outcome::Interrupted),
            Ended::Failed { at_s, error } => Err(anyhow::anyhow!("failed at {at_s:.1} s: {error}")),
        }
    }

    /// The process's exit code (an error is 1, a command line error 2).
    pub fn exit_code(self) -> u8 {
        match self {
            Outcome::Completed => 0,
            Outcome::GaveUp => 3,
            Outcome::Interrupted => 130,
            Outcome::MissionFailed => 4,
        }
    }
}

/// Ctrl-C or SIGTERM, by name (on systems without SIGTERM, Ctrl-C only).
pub fn interrupted() -> futures::future::BoxFuture<'static, String> {
    Box::pin(async {
        #[cfg(unix)]
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).ok();
        #[cfg(unix)]
        let term = async move {
            match term.as_mut() {
                Some(t) => {
                    t.recv().await;
                }
                None => std::future::pending::<()>().await,
            }
        };
        #[cfg(not(unix))]
        let term = std::future::pending::<()>();
        tokio::select! {
            r = tokio::signal::ctrl_c() => match r {
                Ok(()) => "SIGINT (Ctrl-C)".to_string(),
                Err(_) => std::future::pending().await,
            },
            () = term => "SIGTERM".to_string(),
        }
    })
}
