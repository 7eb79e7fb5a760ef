//! **Switch**: several Wiring and State changes, on components in this process or others, made
//! as one operation that is all or nothing.
//!
//! A mode switch is a series of wiring and state calls: unwire the behaviour that drove, set the
//! behaviours' states, wire the new one. Made one call at a time, a failure half-way (an
//! incompatible service, a handler that hangs, a component restarting, a lost link) leaves the
//! system half switched. A [`Switch`] names all the changes; [`SwitchMaster::apply`] makes them
//! in two phases:
//!
//! 1. **Prepare**, before anything changes: every component named is asked for its ports and
//!    its state (in its process, wherever that is); every port must exist, every target service
//!    must exist and be of the pattern and objects the port expects, every main state must be
//!    declared, and no port or component may be named twice. A failure here changes nothing.
//! 2. **Commit**, in an order that keeps the usual invariants at every instant: first the state
//!    changes of components the switch does not unwire (the behaviour taking over becomes
//!    active while still unwired), then every disconnect (so two behaviours are never wired to
//!    one target during the switch), then every connect, then the state changes of components
//!    it unwired (the behaviour handing over is set neutral once unwired). A disconnect and the
//!    connect that replaces it are neighbours: the motors go without a driver for one step at
//!    most (two if that step fails and the disconnect is undone), however many states the
//!    switch changes. Each step gets at most the switch's step timeout. If a
//!    step fails or times out, the steps already made are **undone** in reverse order, each
//!    port back on its previous target and each component back in its previous main state, and
//!    the caller gets one [`SwitchError`] naming the change that failed, why, and whether the
//!    undo was complete.
//!
//! **Across processes** the changes on components another process hosts are that process's
//! part, and it makes its part on one message (a two-phase commit whose participants are
//! processes, carried by the components' wiring services; `docs/wire-format.md`, section 6.6):
//!
//! - *prepare*: the process checks its part as above and holds it for a **lease** (1 s by
//!   default, [`SwitchMaster::lease`]); it answers which components it covers, so one message
//!   per process suffices;
//! - *commit*: the process makes its whole part, or undoes what it made of it; a commit that
//!   arrives after the lease is refused, so a coordinator that gave up can never see its switch
//!   made behind its back;
//! - *undo*: puts a committed part back (the coordinator failed elsewhere).
//!
//! So each process is always in its configuration before the switch or after it. A link cut
//! before the commit leaves the old one (the lease runs out); a commit whose answer is lost is
//! undone; if the undo cannot reach the process either, the coordinator cannot know which of the
//! two it is in, and the error says so for every change of that part
//! ([`SwitchError::not_undone`]). In a deployment the robot's link watchdog then unwires its
//! ports and stops the motors on its own when it loses the executive. The other processes'
//! parts are committed first, then this process's.
//!
//! What a switch does not give: isolation from another master changing the same components
//! between the two phases (orsa has one executive per system).
//!
//! Every applied or failed switch is shown to the tap as one control event, a
//! [`SwitchRecord`] on the topic `OWNER/switch`, so a recording shows the whole switch.
//!
//! ```
//! # use orsa_actors::{Registry, Sink, send::SendServer, wiring::WiringSlave, state::{StateSlave, StateSpec}};
//! # use orsa_actors::service::{SendPortDesc, SendService};
//! # use orsa_actors::switch::{Switch, SwitchMaster};
//! const SPEED: SendService<f64> = SendService::new("speed");
//! const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let (tx, _rx) = tokio::sync::mpsc::unbounded_channel();
//! SendServer::register(&registry, SPEED.on("robot"), Sink::channel(tx))?;
//! for b in ["left", "right"] {
//!     WiringSlave::register(&registry, b)?.send_port::<f64>(VEL.name())?;
//!     StateSlave::register(&registry, b, StateSpec::new().main_state("active", &["drive"]))?;
//! }
//! let master = SwitchMaster::new(&registry, "executive");
//! master.apply(&Switch::new().state("left", "active").connect("left", VEL, SPEED.on("robot"))).await?;
//! // Hand the robot from left to right in one operation:
//! let to_right = Switch::new()
//!     .disconnect("left", VEL)
//!     .state("left", "neutral")
//!     .state("right", "active")
//!     .connect("right", VEL, SPEED.on("robot"));
//! master.apply(&to_right).await?;
//! // A switch that cannot be made changes nothing:
//! let bad = Switch::new().disconnect("right", VEL).state("left", "flying");
//! let e = master.apply(&bad).await.expect_err("no such main state");
//! assert!(e.nothing_changed());
//! # Ok(()) }
//! ```

mod master;
mod participant;

pub use master::SwitchMaster;
pub(crate) use participant::participant;

use crate::addr::{IntoAddr, ServiceAddr};
use crate::error::PatternError;
use crate::service::PortDescriptor;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Duration;

/// How long one step of a switch may take by default: well inside a robot's velocity timeout
/// (0.5 s on the Nomad 200), so a switch that hangs is undone before the motors time out.
pub const DEFAULT_STEP_TIMEOUT: Duration = Duration::from_millis(100);

/// One change a switch makes.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Change {
    /// Connect `component`'s port `port` to the service `target`.
    Connect {
        /// The component whose port is wired.
        component: String,
        /// The port.
        port: String,
        /// The service, `component/service`.
        target: ServiceAddr,
    },
    /// Disconnect `component`'s port `port`.
    Disconnect {
        /// The component.
        component: String,
        /// The port.
        port: String,
    },
    /// Set `component`'s main state to `main`.
    State {
        /// The component.
        component: String,
        /// The main state.
        main: String,
    },
}

impl Change {
    /// The component the change is made on.
    pub fn component(&self) -> &str {
        match self {
            Change::Connect { component, .. }
            | Change::Disconnect { component, .. }
            | Change::State { component, .. } => component,
        }
    }

    /// Commit order, in a switch of the changes `all`: the states of components this switch
    /// does not unwire (the behaviour taking over is made active while still unwired), then every
    /// disconnect, then every connect, then the states of components it unwires (the behaviour
    /// handing over is set neutral once unwired). A disconnect and the connect that replaces it
    /// are neighbours, so the target is without a client for one step at most.
    fn rank(&self, all: &[Change]) -> u8 {
        match self {
            Change::Disconnect { .. } => 1,
            Change::Connect { .. } => 2,
            Change::State { component, .. } => {
                let unwired = all
                    .iter()
                    .any(|c| matches!(c, Change::Disconnect { component: d, .. } if d == component));
                if unwired { 3 } else { 0 }
            }
        }
    }
}

impl fmt::Display for Change {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Change::Connect { component, port, target } => {
                write!(f, "connect {component}.{port} to {target}")
            }
            Change::Disconnect { component, port } => write!(f, "disconnect {component}.{port}"),
            Change::State { component, main } => write!(f, "set {component} to {main}"),
        }
    }
}

/// The changes of one switch, in any order (the commit orders them), and its step timeout.
#[derive(Debug, Clone, PartialEq)]
pub struct Switch {
    changes: Vec<Change>,
    step_timeout: Duration,
}

impl Default for Switch {
    fn default() -> Self {
        Switch { changes: Vec::new(), step_timeout: DEFAULT_STEP_TIMEOUT }
    }
}

impl Switch {
    /// An empty switch.
    pub fn new() -> Self {
        Self::default()
    }

    /// A switch of these changes (for changes a person typed or a tool decoded).
    pub fn of(changes: Vec<Change>) -> Self {
        Switch { changes, ..Self::default() }
    }

    /// Adds: connect `component`'s port to `target`; only a service of the kind the port sends
    /// to compiles.
    pub fn connect<P: PortDescriptor>(
        self,
        component: &str,
        port: P,
        target: impl IntoAddr<P::Target>,
    ) -> Self {
        self.connect_named(component, port.name(), target.into_addr())
    }

    /// Adds: connect `component`'s port named `port` to `target`, as a person typed them.
    pub fn connect_named(mut self, component: &str, port: &str, target: ServiceAddr) -> Self {
        self.changes.push(Change::Connect { component: component.into(), port: port.into(), target });
        self
    }

    /// Adds: disconnect `component`'s port.
    pub fn disconnect(self, component: &str, port: impl PortDescriptor) -> Self {
        self.disconnect_named(component, port.name())
    }

    /// Adds: disconnect `component`'s port named `port`.
    pub fn disconnect_named(mut self, component: &str, port: &str) -> Self {
        self.changes.push(Change::Disconnect { component: component.into(), port: port.into() });
        self
    }

    /// Adds: set `component`'s main state to `main`.
    pub fn state(mut self, component: &str, main: &str) -> Self {
        self.changes.push(Change::State { component: component.into(), main: main.into() });
        self
    }

    /// Sets how long each step (a prepare question, a change, an undo) may take.
    pub fn step_timeout(mut self, timeout: Duration) -> Self {
        self.step_timeout = timeout;
        self
    }

    /// The changes, as given.
    pub fn changes(&self) -> &[Change] {
        &self.changes
    }

    /// Whether the switch changes nothing.
    pub fn is_empty(&self) -> bool {
        self.changes.is_empty()
    }
}

/// The phase a switch failed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Checking, before anything changed.
    Prepare,
    /// Making the changes.
    Commit,
}

/// Why a switch was not made, and what it left behind.
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchError {
    /// When it failed.
    pub phase: Phase,
    /// The change that failed (for a switch that names a port or a component twice, the second).
    pub change: Change,
    /// Why.
    pub error: PatternError,
    /// Changes that had been made and were undone, in the order they were undone.
    pub undone: Vec<Change>,
    /// Changes that had been made and could not be undone, with why: these components are not
    /// where they were before the switch.
    pub not_undone: Vec<(Change, PatternError)>,
}

impl SwitchError {
    /// Whether every component is as it was before the switch (nothing was made, or everything
    /// made was undone).
    pub fn nothing_changed(&self) -> bool {
        self.not_undone.is_empty()
    }
}

impl fmt::Display for SwitchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let phase = match self.phase {
            Phase::Prepare => "preparing",
            Phase::Commit => "committing",
        };
        write!(f, "switch failed {phase} '{}': {}", self.change, self.error)?;
        match (self.phase, self.undone.len(), self.not_undone.as_slice()) {
            (Phase::Prepare, ..) => write!(f, "; nothing was changed"),
            (_, 0, []) => write!(f, "; nothing had been changed"),
            (_, n, []) => write!(f, "; the {n} change(s) made were undone"),
            (_, _, left) => {
                write!(f, "; could not undo:")?;
                for (c, e) in left {
                    write!(f, " '{c}' ({e})")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for SwitchError {}

/// What a switch did, as a control event (topic `OWNER/switch`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwitchRecord {
    /// The changes, in commit order.
    pub changes: Vec<Change>,
    /// `None` if it was made; otherwise why not.
    pub failed: Option<SwitchFailure>,
}
crate::comm_object!(SwitchRecord, "orsa.SwitchRecord/1");

/// A failed switch, as recorded.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SwitchFailure {
    /// When it failed.
    pub phase: Phase,
    /// The change that failed.
    pub change: Change,
    /// Why, as text.
    pub error: String,
    /// Changes undone.
    pub undone: Vec<Change>,
    /// Changes left made, with why.
    pub not_undone: Vec<(Change, String)>,
}

impl From<&SwitchError> for SwitchFailure {
    fn from(e: &SwitchError) -> Self {
        SwitchFailure {
            phase: e.phase,
            change: e.change.clone(),
            error: e.error.to_string(),
            undone: e.undone.clone(),
            not_undone: e.not_undone.iter().map(|(c, e)| (c.clone(), e.to_string())).collect(),
        }
    }
}

impl SwitchFailure {
    /// Whether every component is as it was before the switch.
    pub fn nothing_changed(&self) -> bool {
        self.not_undone.is_empty()
    }
}
/// A switch's identity: when its coordinator began it (a reading of the system's clock, ns)
/// and its number among that coordinator's switches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct TxnId {
    /// When the coordinator began the switch, ns on the system's time base.
    pub at: u64,
    /// The coordinator's count of its switches.
    pub n: u64,
}

impl fmt::Display for TxnId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}-{}", self.at, self.n)
    }
}

/// A switch request to another process, sent to the wiring service of one of its components
/// (`docs/wire-format.md`, section 6.6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum SwitchRequest {
    /// Check the changes on the components the process hosts and hold them, for `lease_ms`,
    /// until a commit.
    SwitchPrepare {
        /// The transaction.
        txn: TxnId,
        /// All the changes of the switch; the process takes those on components it hosts.
        changes: Vec<Change>,
        /// How long each step may take, in milliseconds.
        step_timeout_ms: u64,
        /// How long the prepared changes wait for the commit, in milliseconds.
        lease_ms: u64,
    },
    /// Make the prepared changes of `txn`, all or nothing.
    SwitchCommit {
        /// The transaction.
        txn: TxnId,
    },
    /// Undo the committed changes of `txn` (the coordinator failed elsewhere).
    SwitchUndo {
        /// The transaction.
        txn: TxnId,
    },
}

/// A switch's answer from another process (to a prepare, a commit or an undo).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwitchReply {
    /// The components of the switch that process hosts (the ones its answer is for).
    pub covers: Vec<String>,
    /// `None` if it did what was asked.
    pub failed: Option<RemoteFailure>,
}

/// How a switch failed in another process.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RemoteFailure {
    /// The change that failed.
    pub change: Change,
    /// Why.
    pub error: crate::wire::WireFailure,
    /// Changes of that process undone there.
    pub undone: Vec<Change>,
    /// Changes of that process that could not be undone, with why.
    pub not_undone: Vec<(Change, crate::wire::WireFailure)>,
}
