//! The coordinator of a switch, [`SwitchMaster`]: it prepares the changes (here, and through
//! the participants of the other processes), commits them in order, and undoes what it made
//! when a step fails.

use super::{
    Change, Phase, Switch, SwitchError, SwitchFailure, SwitchRecord, SwitchReply, SwitchRequest, TxnId,
};
use crate::addr::ServiceAddr;
use crate::error::{PatternError, PatternResult};
use crate::registry::{Registry, Resolved};
use crate::state::StateSlave;
use crate::wiring::WiringSlave;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

/// What a switch needs to know of a component before it changes it.
#[derive(Default)]
pub(super) struct Before {
    /// Its wiring slave, if the switch changes its ports.
    wiring: Option<Arc<WiringSlave>>,
    /// Its state slave, if the switch sets its state.
    slave: Option<Arc<StateSlave>>,
    /// Per port named: where it was connected.
    ports: Vec<(String, Option<ServiceAddr>)>,
    /// The main state it was in, if the switch sets it.
    state: Option<String>,
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

    pub(super) fn hosted_here(&self, component: &str) -> bool {
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
    pub(super) fn prepare<'c>(
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
    pub(super) async fn commit(
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
    pub(super) async fn undo(
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
pub(super) fn check_once(changes: &[Change]) -> Result<(), (Change, PatternError)> {
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
