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

use crate::addr::{IntoAddr, ServiceAddr};
use crate::error::{PatternError, PatternResult};
use crate::registry::{Registry, Resolved};
use crate::service::PortDescriptor;
use crate::state::StateSlave;
use crate::wiring::WiringSlave;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::sync::Arc;
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

/// What a switch needs to know of a component before it changes it.
#[derive(Default)]
struct Before {
    /// Its wiring slave, if the switch changes its ports.
    wiring: Option<Arc<WiringSlave>>,
    /// Its state slave, if the switch sets its state.
    slave: Option<Arc<StateSlave>>,
    /// Per port named: where it was connected.
    ports: Vec<(String, Option<ServiceAddr>)>,
    /// The main state it was in, if the switch sets it.
    state: Option<String>,
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

/// The changes hosted by another process, and which component to address them through.
struct Group {
    via: String,
    changes: Vec<Change>,
}

/// The master side: applies [`Switch`]es to the components of a system, in this process or
/// others.
#[derive(Clone, Debug)]
pub struct SwitchMaster {
    registry: Registry,
    topic: String,
    lease: Duration,
    next: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

impl SwitchMaster {
    /// A switch master for `registry`'s system; `owner` (the component that switches, e.g.
    /// `master`) names the topic its switches are recorded on.
    pub fn new(registry: &Registry, owner: &str) -> Self {
        SwitchMaster {
            registry: registry.clone(),
            topic: format!("{owner}/switch"),
            lease: Duration::from_secs(1),
            next: std::sync::Arc::new(std::sync::atomic::AtomicU64::new(1)),
        }
    }

    /// Sets how long another process holds a prepared switch for its commit (default 1 s):
    /// a commit that arrives later is refused, so a coordinator that lost the link can never
    /// see its switch made after it gave up.
    pub fn lease(mut self, lease: Duration) -> Self {
        self.lease = lease;
        self
    }

    /// Prepares and commits `switch`, or leaves every component as it was and says why.
    pub async fn apply(&self, switch: &Switch) -> Result<(), SwitchError> {
        let result = self.run(switch).await;
        if !self.registry.tap_slot().installed() {
            return result;
        }
        let mut changes = switch.changes.clone();
        changes.sort_by_key(|c| c.rank(&switch.changes));
        let failed = result.as_ref().err().map(SwitchFailure::from);
        let record = SwitchRecord { changes, failed };
        let id = <SwitchRecord as crate::CommObject>::ID;
        self.registry.tap_slot().record(&self.topic, id, self.registry.now(), &record);
        result
    }

    async fn run(&self, switch: &Switch) -> Result<(), SwitchError> {
        let prepare_error = |(change, error): (Change, PatternError)| SwitchError {
            phase: Phase::Prepare,
            change,
            error,
            undone: Vec::new(),
            not_undone: Vec::new(),
        };
        check_once(&switch.changes).map_err(prepare_error)?;
        let step = switch.step_timeout;
        let mut hosted: Vec<(&str, bool)> = Vec::with_capacity(4);
        let mut local: Vec<&Change> = Vec::with_capacity(switch.changes.len());
        let mut remote: Vec<Change> = Vec::new();
        for c in &switch.changes {
            let here = match hosted.iter().find(|(name, _)| *name == c.component()) {
                Some(&(_, here)) => here,
                None => {
                    let here = self.hosted_here(c.component());
                    hosted.push((c.component(), here));
                    here
                }
            };
            if here {
                local.push(c);
            } else {
                remote.push(c.clone());
            }
        }
        // Phase 1: every process with components in the switch checks its changes and holds
        // them; then this process checks its own.
        let txn = TxnId {
            at: if remote.is_empty() { 0 } else { self.registry.now().as_nanos() },
            n: self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        let groups = if remote.is_empty() {
            Vec::new()
        } else {
            self.prepare_remote(txn, &remote, step).await.map_err(prepare_error)?
        };
        let before = self.prepare(local.iter().copied()).map_err(prepare_error)?;
        // Phase 2: the other processes, one commit each, then the changes here.
        let mut committed: Vec<&Group> = Vec::new();
        for g in &groups {
            let wait = self.lease + step * u32::try_from(g.changes.len()).unwrap_or(u32::MAX);
            let reply = self.ask(&g.via, SwitchRequest::SwitchCommit { txn }, wait).await;
            let failure = match reply {
                Ok(SwitchReply { failed: None, .. }) => {
                    committed.push(g);
                    continue;
                }
                Ok(SwitchReply { failed: Some(f), .. }) => f,
                // No answer: the commit may or may not have been made there.
                Err(error) => {
                    let change = g
                        .changes
                        .first()
                        .cloned()
                        .unwrap_or_else(|| Change::State { component: g.via.clone(), main: String::new() });
                    let mut e = SwitchError {
                        phase: Phase::Commit,
                        change,
                        error,
                        undone: Vec::new(),
                        not_undone: Vec::new(),
                    };
                    self.undo_remote(txn, &[g], step, &mut e).await;
                    self.undo_remote(txn, &committed, step, &mut e).await;
                    return Err(e);
                }
            };
            let mut e = SwitchError {
                phase: Phase::Commit,
                change: failure.change,
                error: failure.error.into_error(),
                undone: failure.undone,
                not_undone: failure.not_undone.into_iter().map(|(c, w)| (c, w.into_error())).collect(),
            };
            self.undo_remote(txn, &committed, step, &mut e).await;
            return Err(e);
        }
        let mut plan = local;
        plan.sort_by_key(|c| c.rank(&switch.changes));
        if let Err((i, error)) = self.commit(&plan, &before, step).await {
            // A step that failed may still have taken effect (a reply lost on the way back):
            // it is undone too, which is harmless if it did not.
            let (undone, not_undone) = self.undo(&plan[..=i], &before, step).await;
            let change = plan[i].clone();
            let mut e = SwitchError { phase: Phase::Commit, change, error, undone, not_undone };
            self.undo_remote(txn, &committed, step, &mut e).await;
            return Err(e);
        }
        Ok(())
    }

    fn hosted_here(&self, component: &str) -> bool {
        self.registry.local(&ServiceAddr::new(component, "wiring")).is_some()
            || self.registry.local(&ServiceAddr::new(component, "state")).is_some()
    }

    /// Asks the process hosting `component` (through its wiring service) to take part.
    async fn ask(
        &self,
        component: &str,
        request: SwitchRequest,
        timeout: Duration,
    ) -> PatternResult<SwitchReply> {
        let addr = ServiceAddr::new(component, "wiring");
        let remote = match self.registry.resolve::<crate::wiring::WiringSlave>(&addr, &crate::wiring::info())
        {
            Ok(Resolved::Remote(r)) => r,
            Ok(Resolved::Local(_)) => {
                return Err(PatternError::InvalidArgument(format!("'{component}' is hosted here")));
            }
            Err(PatternError::UnknownService(_)) => {
                return Err(PatternError::UnknownComponent(component.into()));
            }
            Err(e) => return Err(e),
        };
        let bytes = remote.transport.request(&remote.addr, crate::wire::encode(&request), timeout).await?;
        remote.counted(crate::wire::decode_reply::<SwitchReply>(&bytes, &remote.addr, "orsa.SwitchReply/1"))
    }

    /// Prepares the changes on components of other processes: asks the process of the first
    /// component not yet covered, which answers for all the components it hosts.
    async fn prepare_remote(
        &self,
        txn: TxnId,
        remote: &[Change],
        step: Duration,
    ) -> Result<Vec<Group>, (Change, PatternError)> {
        let mut uncovered: Vec<String> = Vec::new();
        for c in remote {
            if !uncovered.iter().any(|u| u == c.component()) {
                uncovered.push(c.component().to_string());
            }
        }
        let mut groups = Vec::new();
        while let Some(first) = uncovered.first().cloned() {
            let on_first = || {
                remote.iter().find(|c| c.component() == first).cloned().unwrap_or_else(|| remote[0].clone())
            };
            let request = SwitchRequest::SwitchPrepare {
                txn,
                changes: remote.to_vec(),
                step_timeout_ms: millis(step),
                lease_ms: millis(self.lease),
            };
            let wait = step * u32::try_from(remote.len() + 1).unwrap_or(u32::MAX);
            let reply = self.ask(&first, request, wait).await.map_err(|e| (on_first(), e))?;
            if let Some(f) = reply.failed {
                return Err((f.change, f.error.into_error()));
            }
            let covers: BTreeSet<String> = reply.covers.into_iter().collect();
            if !covers.contains(&first) {
                let e =
                    PatternError::Remote(format!("the process serving '{first}/wiring' does not host it"));
                return Err((on_first(), e));
            }
            uncovered.retain(|u| !covers.contains(u));
            let changes = remote.iter().filter(|c| covers.contains(c.component())).cloned().collect();
            groups.push(Group { via: first, changes });
        }
        Ok(groups)
    }

    /// Undoes the commits of `groups`, noting the outcome in `e`.
    async fn undo_remote(&self, txn: TxnId, groups: &[&Group], step: Duration, e: &mut SwitchError) {
        for g in groups.iter().rev() {
            let wait = step * u32::try_from(g.changes.len() + 1).unwrap_or(u32::MAX);
            match self.ask(&g.via, SwitchRequest::SwitchUndo { txn }, wait).await {
                Ok(SwitchReply { failed: None, .. }) => e.undone.extend(g.changes.iter().rev().cloned()),
                Ok(SwitchReply { failed: Some(f), .. }) => {
                    e.undone.extend(f.undone);
                    e.not_undone.extend(f.not_undone.into_iter().map(|(c, w)| (c, w.into_error())));
                }
                Err(error) => {
                    let unknown = format!(
                        "its process did not answer the undo ({error}): whether the change is made there is unknown"
                    );
                    e.not_undone
                        .extend(g.changes.iter().map(|c| (c.clone(), PatternError::Link(unknown.clone()))));
                }
            }
        }
    }

    /// The wiring slave of `component`, hosted here.
    fn wiring_slave(&self, component: &str) -> PatternResult<Arc<WiringSlave>> {
        let addr = ServiceAddr::new(component, "wiring");
        self.registry
            .resolve_local::<WiringSlave>(&addr, &crate::wiring::info())?
            .ok_or_else(|| PatternError::UnknownComponent(component.to_string()))
    }

    /// The state slave of `component`, hosted here.
    fn state_slave(&self, component: &str) -> PatternResult<Arc<StateSlave>> {
        let addr = ServiceAddr::new(component, "state");
        self.registry
            .resolve_local::<StateSlave>(&addr, &crate::state::info())?
            .ok_or_else(|| PatternError::UnknownComponent(component.to_string()))
    }

    /// Checks every change (on components hosted here) against the components as they are, and
    /// notes how they are.
    // The refusal is built once per failed switch, on a cold path; boxing it would only move the
    // allocation.
    #[allow(clippy::result_large_err)]
    fn prepare<'c>(
        &self,
        changes: impl IntoIterator<Item = &'c Change>,
    ) -> Result<BTreeMap<String, Before>, (Change, PatternError)> {
        let mut before: BTreeMap<String, Before> = BTreeMap::new();
        for c in changes {
            let fail = |e: PatternError| (c.clone(), e);
            let b = match before.get_mut(c.component()) {
                Some(b) => b,
                None => before.entry(c.component().to_string()).or_default(),
            };
            match c {
                Change::Connect { component, port, .. } | Change::Disconnect { component, port } => {
                    if b.wiring.is_none() {
                        b.wiring = Some(self.wiring_slave(component).map_err(fail)?);
                    }
                    let wiring = b
                        .wiring
                        .as_ref()
                        .ok_or_else(|| fail(PatternError::UnknownComponent(component.clone())))?;
                    let (info, target) = wiring.port_status(port).map_err(fail)?;
                    if let Change::Connect { target, .. } = c {
                        self.registry.check_service(target, &info).map_err(fail)?;
                    }
                    b.ports.push((port.clone(), target));
                }
                Change::State { component, main } => {
                    let slave = self.state_slave(component).map_err(fail)?;
                    slave.check_main(main).map_err(fail)?;
                    b.state = Some(slave.current());
                    b.slave = Some(slave);
                }
            }
        }
        Ok(before)
    }

    /// Makes the changes of `plan` (in commit order); on a failure, says at which one.
    async fn commit(
        &self,
        plan: &[&Change],
        before: &BTreeMap<String, Before>,
        step: Duration,
    ) -> Result<(), (usize, PatternError)> {
        for (i, change) in plan.iter().enumerate() {
            self.make_prepared(change, before.get(change.component()), step).await.map_err(|e| (i, e))?;
        }
        Ok(())
    }

    /// Makes `change` through the slaves `prepared` found (or finds them).
    async fn make_prepared(
        &self,
        change: &Change,
        prepared: Option<&Before>,
        timeout: Duration,
    ) -> PatternResult<()> {
        match (change, prepared) {
            (Change::Connect { port, target, .. }, Some(Before { wiring: Some(w), .. })) => {
                w.connect(port, target)
            }
            (Change::Disconnect { port, .. }, Some(Before { wiring: Some(w), .. })) => w.disconnect(port),
            (Change::State { main, .. }, Some(Before { slave: Some(slave), .. })) => {
                set_state(slave, main, timeout).await
            }
            _ => self.make(change, timeout).await,
        }
    }

    async fn make(&self, change: &Change, timeout: Duration) -> PatternResult<()> {
        match change {
            Change::Connect { component, port, target } => {
                self.wiring_slave(component)?.connect(port, target)
            }
            Change::Disconnect { component, port } => self.wiring_slave(component)?.disconnect(port),
            Change::State { component, main } => {
                set_state(&*self.state_slave(component)?, main, timeout).await
            }
        }
    }

    /// Undoes `made` (changes made, in the order they were made) in reverse order, back to
    /// what `before` saw; says what was undone and what could not be.
    async fn undo(
        &self,
        made: &[&Change],
        before: &BTreeMap<String, Before>,
        timeout: Duration,
    ) -> (Vec<Change>, Vec<(Change, PatternError)>) {
        let mut undone = Vec::new();
        let mut not_undone = Vec::new();
        for &change in made.iter().rev() {
            let undo = undo_of(change, before);
            match self.make_prepared(&undo, before.get(change.component()), timeout).await {
                Ok(()) => undone.push(change.clone()),
                Err(e) => not_undone.push((change.clone(), e)),
            }
        }
        (undone, not_undone)
    }
}

/// Refuses a switch that names a port, or a component's state, twice.
#[allow(clippy::result_large_err)] // cold path, once per refused switch
fn check_once(changes: &[Change]) -> Result<(), (Change, PatternError)> {
    let mut seen_ports = BTreeSet::new();
    let mut seen_states = BTreeSet::new();
    for c in changes {
        let fresh = match c {
            Change::Connect { component, port, .. } | Change::Disconnect { component, port } => {
                seen_ports.insert((component.as_str(), port.as_str()))
            }
            Change::State { component, .. } => seen_states.insert(component.as_str()),
        };
        if !fresh {
            let what = if matches!(c, Change::State { .. }) { "state" } else { "port" };
            return Err((
                c.clone(),
                PatternError::InvalidArgument(format!("the switch changes this {what} twice")),
            ));
        }
    }
    Ok(())
}

/// The change that puts back what `change` changes, as `before` saw it.
fn undo_of(change: &Change, before: &BTreeMap<String, Before>) -> Change {
    let b = before.get(change.component());
    match change {
        Change::Connect { component, port, .. } | Change::Disconnect { component, port } => {
            let previous =
                b.and_then(|b| b.ports.iter().find(|(p, _)| p == port)).and_then(|(_, t)| t.clone());
            match previous {
                Some(target) => Change::Connect { component: component.clone(), port: port.clone(), target },
                None => Change::Disconnect { component: component.clone(), port: port.clone() },
            }
        }
        Change::State { component, main } => {
            let previous = b.and_then(|b| b.state.clone()).unwrap_or_else(|| main.clone());
            Change::State { component: component.clone(), main: previous }
        }
    }
}

/// Sets a main state at once if nothing holds a substate it excludes; else waits, at most
/// `timeout`.
async fn set_state(slave: &StateSlave, main: &str, timeout: Duration) -> PatternResult<()> {
    match slave.try_set(main) {
        Err(PatternError::Busy(_)) => within(timeout, slave.set(main)).await,
        done => done,
    }
}

async fn within<T>(timeout: Duration, fut: impl Future<Output = PatternResult<T>>) -> PatternResult<T> {
    tokio::time::timeout(timeout, fut).await.unwrap_or(Err(PatternError::Timeout))
}

fn millis(d: Duration) -> u64 {
    u64::try_from(d.as_millis()).unwrap_or(u64::MAX)
}

/// One transaction as a participant holds it.
enum Txn {
    /// Checked, waiting for its commit until `deadline`.
    Prepared {
        covers: Vec<String>,
        changes: Vec<Change>,
        before: BTreeMap<String, Before>,
        step: Duration,
        deadline: tokio::time::Instant,
    },
    /// Made (its changes in commit order); kept for an undo.
    Committed { covers: Vec<String>, changes: Vec<Change>, before: BTreeMap<String, Before>, step: Duration },
    /// Being committed or undone right now, or over.
    Busy { covers: Vec<String> },
}

/// How long a participant remembers a committed transaction, for an undo.
const KEEP_COMMITTED: Duration = Duration::from_secs(30);

/// What a component's wiring service answers besides wiring requests: the switch requests of
/// other processes, served for all of this process's components.
pub(crate) fn participant(registry: &Registry) -> crate::wiring::AlsoServed {
    let registry = registry.clone();
    std::sync::Arc::new(move |payload: &[u8]| {
        let request = crate::wire::decode::<SwitchRequest>(payload, "orsa.SwitchRequest/1").ok()?;
        Some(serve(registry.clone(), request))
    })
}

/// The transactions of this process, as the registry keeps them.
struct Txns<'a>(
    parking_lot::MutexGuard<'a, std::collections::HashMap<String, Box<dyn std::any::Any + Send>>>,
);

impl Txns<'_> {
    fn get(&self, txn: &str) -> Option<&Txn> {
        self.0.get(txn).and_then(|t| t.downcast_ref::<Txn>())
    }
    fn remove(&mut self, txn: &str) -> Option<Txn> {
        self.0.remove(txn).and_then(|t| t.downcast::<Txn>().ok()).map(|t| *t)
    }
    fn insert(&mut self, txn: String, t: Txn) {
        self.0.insert(txn, Box::new(t));
    }
}

fn txns(registry: &Registry) -> Txns<'_> {
    Txns(registry.switches().lock())
}

/// Serves a switch request from another process (it came to one of this process's wiring
/// services).
fn serve(registry: Registry, request: SwitchRequest) -> futures::future::BoxFuture<'static, Vec<u8>> {
    Box::pin(async move {
        let reply = match request {
            SwitchRequest::SwitchPrepare { txn, changes, step_timeout_ms, lease_ms } => {
                serve_prepare(
                    &registry,
                    txn.to_string(),
                    changes,
                    Duration::from_millis(step_timeout_ms),
                    Duration::from_millis(lease_ms),
                )
                .await
            }
            SwitchRequest::SwitchCommit { txn } => serve_commit(&registry, &txn.to_string()).await,
            SwitchRequest::SwitchUndo { txn } => serve_undo(&registry, &txn.to_string()).await,
        };
        crate::wire::encode(&crate::wire::Reply::from_result(reply))
    })
}

fn failure(
    change: Change,
    error: &PatternError,
    undone: Vec<Change>,
    not_undone: Vec<(Change, PatternError)>,
) -> RemoteFailure {
    RemoteFailure {
        change,
        error: crate::wire::WireFailure::from_error(error),
        undone,
        not_undone: not_undone
            .iter()
            .map(|(c, e)| (c.clone(), crate::wire::WireFailure::from_error(e)))
            .collect(),
    }
}

async fn serve_prepare(
    registry: &Registry,
    txn: String,
    changes: Vec<Change>,
    step: Duration,
    lease: Duration,
) -> PatternResult<SwitchReply> {
    check_once(&changes).map_err(|(_, e)| e)?;
    let master = SwitchMaster::new(registry, "switch");
    let mut mine: Vec<Change> =
        changes.iter().filter(|c| master.hosted_here(c.component())).cloned().collect();
    // Kept in commit order: the commit and an undo walk it as it is.
    mine.sort_by_key(|c| c.rank(&changes));
    let mut covers: Vec<String> = mine.iter().map(|c| c.component().to_string()).collect();
    covers.sort();
    covers.dedup();
    if let Some(t) = txns(registry).get(&txn) {
        // Asked again through another of this process's components: one answer for all.
        let covers = match t {
            Txn::Prepared { covers, .. } | Txn::Committed { covers, .. } | Txn::Busy { covers } => {
                covers.clone()
            }
        };
        return Ok(SwitchReply { covers, failed: None });
    }
    if mine.is_empty() {
        return Ok(SwitchReply { covers, failed: None });
    }
    let before = match master.prepare(&mine) {
        Ok(b) => b,
        Err((change, e)) => {
            return Ok(SwitchReply { covers, failed: Some(failure(change, &e, vec![], vec![])) });
        }
    };
    let deadline = tokio::time::Instant::now() + lease;
    let prepared = Txn::Prepared { covers: covers.clone(), changes: mine, before, step, deadline };
    txns(registry).insert(txn.clone(), prepared);
    // A commit that never comes: forget the transaction (nothing was changed for it).
    let keep = registry.clone();
    tokio::spawn(async move {
        tokio::time::sleep(lease).await;
        let mut txns = txns(&keep);
        if matches!(txns.get(&txn), Some(Txn::Prepared { .. })) {
            txns.remove(&txn);
        }
    });
    Ok(SwitchReply { covers, failed: None })
}

async fn serve_commit(registry: &Registry, txn: &str) -> PatternResult<SwitchReply> {
    let taken = {
        let mut txns = txns(registry);
        match txns.remove(txn) {
            Some(Txn::Prepared { covers, changes, before, step, deadline }) => {
                txns.insert(txn.to_string(), Txn::Busy { covers: covers.clone() });
                Some((covers, changes, before, step, deadline))
            }
            Some(other) => {
                txns.insert(txn.to_string(), other);
                None
            }
            None => None,
        }
    };
    let Some((covers, changes, before, step, deadline)) = taken else {
        return Err(PatternError::Unknown { kind: "prepared switch", name: txn.to_string() });
    };
    if tokio::time::Instant::now() > deadline {
        txns(registry).remove(txn);
        return Err(PatternError::Unknown {
            kind: "prepared switch (its lease ran out)",
            name: txn.to_string(),
        });
    }
    let master = SwitchMaster::new(registry, "switch");
    let plan: Vec<&Change> = changes.iter().collect();
    match master.commit(&plan, &before, step).await {
        Ok(()) => {
            drop(plan);
            let committed = Txn::Committed { covers: covers.clone(), changes, before, step };
            txns(registry).insert(txn.to_string(), committed);
            let keep = registry.clone();
            let txn = txn.to_string();
            tokio::spawn(async move {
                tokio::time::sleep(KEEP_COMMITTED).await;
                txns(&keep).remove(&txn);
            });
            Ok(SwitchReply { covers, failed: None })
        }
        Err((i, e)) => {
            let (undone, not_undone) = master.undo(&plan[..=i], &before, step).await;
            let change = plan[i].clone();
            txns(registry).remove(txn);
            Ok(SwitchReply { covers, failed: Some(failure(change, &e, undone, not_undone)) })
        }
    }
}

async fn serve_undo(registry: &Registry, txn: &str) -> PatternResult<SwitchReply> {
    let taken = {
        let mut txns = txns(registry);
        match txns.remove(txn) {
            Some(Txn::Committed { covers, changes, before, step }) => Some((covers, changes, before, step)),
            Some(Txn::Prepared { covers, .. }) => return Ok(SwitchReply { covers, failed: None }),
            Some(busy @ Txn::Busy { .. }) => {
                txns.insert(txn.to_string(), busy);
                return Err(PatternError::Busy(vec!["(the switch's commit is in progress)".into()]));
            }
            None => None,
        }
    };
    let Some((covers, changes, before, step)) = taken else {
        // Never committed here (or long forgotten): nothing to undo.
        return Ok(SwitchReply { covers: Vec::new(), failed: None });
    };
    let master = SwitchMaster::new(registry, "switch");
    let plan: Vec<&Change> = changes.iter().collect();
    let (_, not_undone) = master.undo(&plan, &before, step).await;
    let failed = not_undone.first().map(|(c, e)| failure(c.clone(), e, vec![], not_undone.clone()));
    Ok(SwitchReply { covers, failed })
}
