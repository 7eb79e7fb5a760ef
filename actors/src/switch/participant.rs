//! The participant side of a switch across processes: a process serves the switch requests of
//! other processes' coordinators (prepare, commit, undo; `docs/wire-format.md`, section 6.6)
//! on its components' wiring services, and keeps their transactions meanwhile.

use super::master::{Before, SwitchMaster, check_once};
use super::{Change, RemoteFailure, SwitchReply, SwitchRequest};
use crate::error::{PatternError, PatternResult};
use crate::registry::Registry;
use std::collections::BTreeMap;
use std::time::Duration;

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
