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
//! 2. **Commit**, in an order that keeps the usual invariants at every instant: first every
//!    disconnect (so two behaviours are never wired to one target during the switch), then the
//!    state changes, then every connect. Each step gets at most the switch's step timeout. If a
//!    step fails or times out, the steps already made are **undone** in reverse order, each
//!    port back on its previous target and each component back in its previous main state, and
//!    the caller gets one [`SwitchError`] naming the change that failed, why, and whether the
//!    undo was complete.
//!
//! What a switch does not give: isolation from another master changing the same components
//! between the two phases (orsa has one executive per system), and an undo of a step whose
//! component cannot be reached any more. A participant that becomes unreachable during the
//! commit is reported in [`SwitchError::not_undone`]; across processes, the robot's link
//! watchdog then unwires its ports and stops the motors on its own when the executive is lost.
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

use crate::addr::{IntoAddr, ServiceAddr};
use crate::error::{PatternError, PatternResult};
use crate::registry::Registry;
use crate::service::PortDescriptor;
use crate::state::{StateMaster, StateStatus};
use crate::wiring::{PortStatus, WiringMaster};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
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

    /// Commit order: disconnects, then states, then connects.
    fn rank(&self) -> u8 {
        match self {
            Change::Disconnect { .. } => 0,
            Change::State { .. } => 1,
            Change::Connect { .. } => 2,
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

/// What a switch needs to know of a component before it changes it.
#[derive(Default)]
struct Before {
    ports: BTreeMap<String, PortStatus>,
    state: Option<StateStatus>,
}

/// The master side: applies [`Switch`]es to the components of a system, in this process or
/// others.
#[derive(Clone, Debug)]
pub struct SwitchMaster {
    registry: Registry,
    wiring: WiringMaster,
    topic: String,
}

impl SwitchMaster {
    /// A switch master for `registry`'s system; `owner` (the component that switches, e.g.
    /// `master`) names the topic its switches are recorded on.
    pub fn new(registry: &Registry, owner: &str) -> Self {
        SwitchMaster {
            registry: registry.clone(),
            wiring: WiringMaster::new(registry),
            topic: format!("{owner}/switch"),
        }
    }

    /// Prepares and commits `switch`, or leaves every component as it was and says why.
    pub async fn apply(&self, switch: &Switch) -> Result<(), SwitchError> {
        let result = self.run(switch).await;
        let mut changes = switch.changes.clone();
        changes.sort_by_key(Change::rank);
        let failed = result.as_ref().err().map(|e| SwitchFailure {
            phase: e.phase,
            change: e.change.clone(),
            error: e.error.to_string(),
            undone: e.undone.clone(),
            not_undone: e.not_undone.iter().map(|(c, e)| (c.clone(), e.to_string())).collect(),
        });
        let record = SwitchRecord { changes, failed };
        self.registry.tap_slot().record(
            &self.topic,
            <SwitchRecord as crate::CommObject>::ID,
            self.registry.now(),
            &record,
        );
        result
    }

    async fn run(&self, switch: &Switch) -> Result<(), SwitchError> {
        let before = self.prepare(switch).await.map_err(|(change, error)| SwitchError {
            phase: Phase::Prepare,
            change,
            error,
            undone: Vec::new(),
            not_undone: Vec::new(),
        })?;
        let mut plan: Vec<&Change> = switch.changes.iter().collect();
        plan.sort_by_key(|c| c.rank());
        let mut made: Vec<(Change, Change)> = Vec::new();
        for change in plan {
            let undo = undo_of(change, &before);
            if let Err(error) = self.make(change, switch.step_timeout).await {
                // A step that failed may still have taken effect (a reply lost on the way back):
                // undo it too, which is harmless if it did not.
                made.push((change.clone(), undo));
                let (undone, not_undone) = self.undo(made, switch.step_timeout).await;
                return Err(SwitchError {
                    phase: Phase::Commit,
                    change: change.clone(),
                    error,
                    undone,
                    not_undone,
                });
            }
            made.push((change.clone(), undo));
        }
        Ok(())
    }

    /// Checks every change against the components as they are, and notes how they are.
    async fn prepare(&self, switch: &Switch) -> Result<BTreeMap<String, Before>, (Change, PatternError)> {
        let mut seen_ports = BTreeSet::new();
        let mut seen_states = BTreeSet::new();
        for c in &switch.changes {
            let fresh = match c {
                Change::Connect { component, port, .. } | Change::Disconnect { component, port } => {
                    seen_ports.insert((component.as_str(), port.as_str()))
                }
                Change::State { component, .. } => seen_states.insert(component.as_str()),
            };
            if !fresh {
                let what = if matches!(c, Change::State { .. }) { "state" } else { "port" };
                let e = PatternError::InvalidArgument(format!("the switch changes this {what} twice"));
                return Err((c.clone(), e));
            }
        }
        let timeout = switch.step_timeout;
        let mut before: BTreeMap<String, Before> = BTreeMap::new();
        for c in &switch.changes {
            let component = c.component().to_string();
            let b = before.entry(component.clone()).or_default();
            let fail = |e: PatternError| (c.clone(), e);
            match c {
                Change::Connect { port, .. } | Change::Disconnect { port, .. } => {
                    if b.ports.is_empty() {
                        let ports = within(timeout, self.wiring.ports(&component)).await.map_err(fail)?;
                        b.ports = ports.into_iter().map(|p| (p.port.clone(), p)).collect();
                    }
                    let Some(status) = b.ports.get(port) else {
                        return Err(fail(PatternError::UnknownPort { component, port: port.clone() }));
                    };
                    if let Change::Connect { target, .. } = c {
                        let found = self.registry.service_info(target).map_err(fail)?;
                        crate::registry::check(&found, target, &status.info).map_err(fail)?;
                    }
                }
                Change::State { main, .. } => {
                    if b.state.is_none() {
                        let master = StateMaster::connect(&self.registry, &component).map_err(fail)?;
                        b.state = Some(within(timeout, master.status()).await.map_err(fail)?);
                    }
                    let declared = b.state.as_ref().is_some_and(|s| s.main_states.contains_key(main));
                    if !declared {
                        let name = format!("{main}' of '{component}");
                        return Err(fail(PatternError::Unknown { kind: "main state", name }));
                    }
                }
            }
        }
        Ok(before)
    }

    async fn make(&self, change: &Change, timeout: Duration) -> PatternResult<()> {
        match change {
            Change::Connect { component, port, target } => {
                within(timeout, self.wiring.connect_named(component, port, target)).await
            }
            Change::Disconnect { component, port } => {
                within(timeout, self.wiring.disconnect_named(component, port)).await
            }
            Change::State { component, main } => {
                let master = StateMaster::connect(&self.registry, component)?;
                master.set_state_timeout(main, timeout).await
            }
        }
    }

    /// Undoes `made` in reverse order; says what was undone and what could not be.
    async fn undo(
        &self,
        made: Vec<(Change, Change)>,
        timeout: Duration,
    ) -> (Vec<Change>, Vec<(Change, PatternError)>) {
        let mut undone = Vec::new();
        let mut not_undone = Vec::new();
        for (change, undo) in made.into_iter().rev() {
            match self.make(&undo, timeout).await {
                Ok(()) => undone.push(change),
                Err(e) => not_undone.push((change, e)),
            }
        }
        (undone, not_undone)
    }
}

/// The change that puts back what `change` changes, as `before` saw it.
fn undo_of(change: &Change, before: &BTreeMap<String, Before>) -> Change {
    let b = before.get(change.component());
    match change {
        Change::Connect { component, port, .. } | Change::Disconnect { component, port } => {
            let previous = b.and_then(|b| b.ports.get(port)).and_then(|p| p.target.clone());
            match previous {
                Some(target) => Change::Connect { component: component.clone(), port: port.clone(), target },
                None => Change::Disconnect { component: component.clone(), port: port.clone() },
            }
        }
        Change::State { component, main } => {
            let previous =
                b.and_then(|b| b.state.as_ref()).map_or_else(|| main.clone(), |s| s.current.clone());
            Change::State { component: component.clone(), main: previous }
        }
    }
}

async fn within<T>(timeout: Duration, fut: impl Future<Output = PatternResult<T>>) -> PatternResult<T> {
    tokio::time::timeout(timeout, fut).await.unwrap_or(Err(PatternError::Timeout))
}
