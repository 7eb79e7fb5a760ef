//! The policy: what a child's exit does (restart by strategy, give up, escalate).

use super::error::GaveUp;
use super::event::SupervisorEventKind;
use super::handle::{RetryRestart, SupervisorMsg};
use super::spec::{Restart, Shutdown, Strategy};
use super::state::SupervisorState;
use ractor::{ActorCell, ActorId, ActorProcessingErr};
use tokio::time::Instant;

/// The stop reason a supervisor gives its children.
const SHUTDOWN: &str = "shutdown";

/// How a child ended, as the policy sees it.
pub(super) enum Exit {
    Normal(String),
    Abnormal(String),
}

impl SupervisorState {
    /// Handles the exit of the child instance `id` (ignored if it is not a current instance).
    pub(super) async fn child_exited(
        &mut self,
        me: &ActorCell,
        id: ActorId,
        exit: Exit,
    ) -> Result<(), ActorProcessingErr> {
        let current = self.children.iter().position(|c| c.cell.as_ref().is_some_and(|c| c.get_id() == id));
        let Some(i) = current else {
            tracing::trace!(supervisor = %self.name, actor = %id, "exit of a former child instance ignored");
            return Ok(());
        };
        if self.stopping {
            return Ok(());
        }
        self.children[i].cell = None;
        let (kind, abnormal, reason) = match exit {
            Exit::Normal(r) => (SupervisorEventKind::ChildExited, false, r),
            Exit::Abnormal(r) => (SupervisorEventKind::ChildFailed, true, r),
        };
        self.emit(i, kind, &reason);
        match self.children[i].spec.restart {
            Restart::Temporary => {
                self.children.remove(i);
                Ok(())
            }
            Restart::Transient if !abnormal => Ok(()),
            Restart::Permanent | Restart::Transient => self.restart(me, i, &reason).await,
        }
    }

    /// Applies the strategy to child `i`, which is not running: counts one restart, stops the
    /// affected running siblings in reverse start order, then starts the affected children in
    /// start order. Fails (the supervisor gives up) when the intensity is exceeded.
    pub(super) async fn restart(
        &mut self,
        me: &ActorCell,
        i: usize,
        reason: &str,
    ) -> Result<(), ActorProcessingErr> {
        let trigger = self.children[i].spec.id.clone();
        if !self.window.record(Instant::now()) {
            return Err(self.give_up(i, reason).await);
        }
        let affected = match self.strategy {
            Strategy::OneForOne => i..i + 1,
            Strategy::OneForAll => 0..self.children.len(),
            Strategy::RestForOne => i..self.children.len(),
        };
        let ids: Vec<String> = self.children[affected.clone()].iter().map(|c| c.spec.id.clone()).collect();
        for child in self.children[affected].iter_mut().rev() {
            if let Some(cell) = child.cell.take() {
                terminate(&cell, child.spec.shutdown).await;
            }
        }
        // Temporary siblings are stopped but never restarted: they leave.
        self.children.retain(|c| !(c.spec.restart == Restart::Temporary && ids.contains(&c.spec.id)));
        for id in ids {
            let Some(j) = self.index_of(&id) else { continue };
            let spec = self.children[j].spec.clone();
            match self.start_instance(me, &spec).await {
                Ok(cell) => {
                    let child = &mut self.children[j];
                    child.cell = Some(cell);
                    child.restarts = child.restarts.saturating_add(1);
                    child.retry_pending = false;
                    child.start_failures = 0;
                    let why = if id == trigger {
                        reason.to_string()
                    } else {
                        format!("{:?} restart after `{trigger}` exited", self.strategy)
                    };
                    self.emit(j, SupervisorEventKind::Restarted, &why);
                }
                Err(why) => {
                    // As OTP: leave the rest unstarted and try again later (counting a restart),
                    // so that requests such as a shutdown get through meanwhile.
                    let child = &mut self.children[j];
                    child.retry_pending = true;
                    child.start_failures = child.start_failures.saturating_add(1);
                    let delay = self.retry_delay * (1u32 << (child.start_failures - 1).min(4));
                    self.emit(j, SupervisorEventKind::StartFailed, &why);
                    let retry = SupervisorMsg::Retry(RetryRestart { child: id });
                    if delay.is_zero() {
                        let _ = me.send_message(retry);
                    } else {
                        let me = me.clone();
                        tokio::spawn(async move {
                            tokio::time::sleep(delay).await;
                            // A supervisor that is gone has nothing to retry.
                            let _ = me.send_message(retry);
                        });
                    }
                    break;
                }
            }
        }
        Ok(())
    }

    pub(super) async fn give_up(&mut self, i: usize, reason: &str) -> ActorProcessingErr {
        self.emit(i, SupervisorEventKind::GaveUp, reason);
        let err = GaveUp {
            supervisor: self.name.clone(),
            child: self.children[i].spec.id.clone(),
            reason: reason.to_string(),
            intensity: self.window.intensity(),
            period: self.window.period(),
        };
        tracing::error!(supervisor = %self.name, "{err}");
        self.stopping = true;
        self.terminate_all().await;
        Box::new(err)
    }

    /// Stops every running child in reverse start order, honouring its shutdown.
    pub(super) async fn terminate_all(&mut self) {
        for child in self.children.iter_mut().rev() {
            if let Some(cell) = child.cell.take() {
                terminate(&cell, child.spec.shutdown).await;
            }
        }
    }
}

/// Stops one child as its shutdown says and waits until it has stopped.
pub(super) async fn terminate(cell: &ActorCell, shutdown: Shutdown) {
    match shutdown {
        Shutdown::Brutal => cell.kill(),
        Shutdown::Timeout(timeout) => {
            cell.stop(Some(SHUTDOWN.into()));
            if cell.wait(Some(timeout)).await.is_ok() {
                return;
            }
            tracing::warn!(actor = %cell.get_id(), "did not stop within {timeout:?}; killing it");
            cell.kill();
        }
        Shutdown::Infinity => cell.stop(Some(SHUTDOWN.into())),
    }
    let _ = cell.wait(None).await;
}
