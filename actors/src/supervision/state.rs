//! The supervisor's state: its children in start order and the requests on them.

use super::error::ChildError;
use super::event::{SupervisorEvent, SupervisorEventKind};
use super::handle::ChildInfo;
use super::policy::terminate;
use super::server::start_child_supervisor;
use super::spec::{ChildSpec, EventSink, Restart, Strategy};
use super::window::RestartWindow;
use crate::Clock;
use futures::FutureExt;
use ractor::{ActorCell, ActorStatus, SpawnErr};
use std::any::Any;
use std::panic::AssertUnwindSafe;

/// The state of a running supervisor (opaque).
pub struct SupervisorState {
    pub(super) name: String,
    pub(super) strategy: Strategy,
    pub(super) window: RestartWindow,
    pub(super) retry_delay: std::time::Duration,
    /// In start order.
    pub(super) children: Vec<Child>,
    pub(super) clock: Clock,
    pub(super) sink: Option<EventSink>,
    /// Set once the supervisor is giving up or shutting down: exits no longer cause restarts.
    pub(super) stopping: bool,
}

impl std::fmt::Debug for SupervisorState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SupervisorState")
            .field("name", &self.name)
            .field("children", &self.children.len())
            .field("stopping", &self.stopping)
            .finish_non_exhaustive()
    }
}

pub(super) struct Child {
    pub(super) spec: ChildSpec,
    /// The running instance; events from any other instance are ignored.
    pub(super) cell: Option<ActorCell>,
    pub(super) restarts: u32,
    /// A restart of this child failed to start it and a retry is pending.
    pub(super) retry_pending: bool,
    /// Failed starts in a row (the retry delay doubles with each).
    pub(super) start_failures: u32,
}

impl SupervisorState {
    pub(super) fn index_of(&self, id: &str) -> Option<usize> {
        self.children.iter().position(|c| c.spec.id == id)
    }

    /// Starts one instance of `spec`, linked to the supervisor `me`.
    pub(super) async fn start_instance(&self, me: &ActorCell, spec: &ChildSpec) -> Result<ActorCell, String> {
        let started = match &spec.nested {
            Some(nested) => {
                let mut nested = (**nested).clone();
                nested.clock.get_or_insert(self.clock);
                if nested.event_sink.is_none() {
                    nested.event_sink = self.sink.clone();
                }
                start_child_supervisor(nested, me.clone()).boxed()
            }
            None => match std::panic::catch_unwind(AssertUnwindSafe(|| (spec.start)(me.clone()))) {
                Ok(fut) => fut,
                Err(panic) => return Err(panic_text(panic)),
            },
        };
        match AssertUnwindSafe(started).catch_unwind().await {
            Ok(Ok(cell)) => {
                let alive = matches!(cell.get_status(), ActorStatus::Starting | ActorStatus::Running);
                if alive && cell.try_get_supervisor().is_none() {
                    tracing::warn!(supervisor = %self.name, child = %spec.id,
                        "the start function did not link the child; linking it now");
                    cell.link(me.clone());
                }
                Ok(cell)
            }
            Ok(Err(SpawnErr::StartupFailed(inner))) => Err(inner.to_string()),
            Ok(Err(e)) => Err(e.to_string()),
            Err(panic) => Err(panic_text(panic)),
        }
    }

    pub(super) async fn start_new_child(
        &mut self,
        me: &ActorCell,
        spec: ChildSpec,
    ) -> Result<ActorCell, ChildError> {
        if self.index_of(&spec.id).is_some() {
            return Err(ChildError::AlreadyPresent { supervisor: self.name.clone(), child: spec.id });
        }
        match self.start_instance(me, &spec).await {
            Ok(cell) => {
                self.children.push(Child {
                    spec,
                    cell: Some(cell.clone()),
                    restarts: 0,
                    retry_pending: false,
                    start_failures: 0,
                });
                Ok(cell)
            }
            Err(reason) => Err(ChildError::Start { supervisor: self.name.clone(), child: spec.id, reason }),
        }
    }

    pub(super) async fn terminate_child(&mut self, id: &str) -> Result<(), ChildError> {
        let i = self.find(id)?;
        let child = &mut self.children[i];
        child.retry_pending = false;
        if let Some(cell) = child.cell.take() {
            terminate(&cell, child.spec.shutdown).await;
        }
        if child.spec.restart == Restart::Temporary {
            self.children.remove(i);
        }
        Ok(())
    }

    pub(super) async fn restart_child(&mut self, me: &ActorCell, id: &str) -> Result<ActorCell, ChildError> {
        let i = self.find(id)?;
        if self.children[i].cell.is_some() {
            return Err(ChildError::Running { supervisor: self.name.clone(), child: id.into() });
        }
        let spec = self.children[i].spec.clone();
        match self.start_instance(me, &spec).await {
            Ok(cell) => {
                let child = &mut self.children[i];
                child.cell = Some(cell.clone());
                child.restarts = child.restarts.saturating_add(1);
                child.retry_pending = false;
                // As after an automatic restart: the next failed start waits the first delay.
                child.start_failures = 0;
                self.emit(i, SupervisorEventKind::Restarted, "restart_child");
                Ok(cell)
            }
            Err(reason) => Err(ChildError::Start { supervisor: self.name.clone(), child: id.into(), reason }),
        }
    }

    pub(super) fn delete_child(&mut self, id: &str) -> Result<(), ChildError> {
        let i = self.find(id)?;
        if self.children[i].cell.is_some() {
            return Err(ChildError::Running { supervisor: self.name.clone(), child: id.into() });
        }
        self.children.remove(i);
        Ok(())
    }

    pub(super) fn which_children(&self) -> Vec<ChildInfo> {
        self.children
            .iter()
            .map(|c| ChildInfo {
                id: c.spec.id.clone(),
                cell: c.cell.clone(),
                restart: c.spec.restart,
                shutdown: c.spec.shutdown,
                restart_count: c.restarts,
                supervisor_name: c.spec.nested.as_ref().map(|n| n.name.clone()),
            })
            .collect()
    }

    pub(super) fn find(&self, id: &str) -> Result<usize, ChildError> {
        self.index_of(id)
            .ok_or_else(|| ChildError::NotFound { supervisor: self.name.clone(), child: id.into() })
    }

    /// Logs an event about child `i` and hands it to the sink.
    pub(super) fn emit(&self, i: usize, kind: SupervisorEventKind, reason: &str) {
        let child = &self.children[i];
        let event = SupervisorEvent {
            supervisor: self.name.clone(),
            child: child.spec.id.clone(),
            kind,
            reason: reason.to_string(),
            restart_count: child.restarts,
            restarts_in_period: self.window.count(),
            at: self.clock.now(),
        };
        match kind {
            SupervisorEventKind::ChildExited | SupervisorEventKind::Restarted => {
                tracing::info!(supervisor = %self.name, child = %event.child, "{event}");
            }
            SupervisorEventKind::ChildFailed | SupervisorEventKind::StartFailed => {
                tracing::warn!(supervisor = %self.name, child = %event.child, "{event}");
            }
            SupervisorEventKind::GaveUp => {
                tracing::error!(supervisor = %self.name, child = %event.child, "{event}");
            }
        }
        if let Some(sink) = &self.sink
            && std::panic::catch_unwind(AssertUnwindSafe(|| sink(event))).is_err()
        {
            tracing::error!(supervisor = %self.name, "the event sink panicked");
        }
    }
}

fn panic_text(panic: Box<dyn Any + Send>) -> String {
    match panic.downcast::<String>() {
        Ok(s) => format!("panicked: {s}"),
        Err(panic) => match panic.downcast::<&str>() {
            Ok(s) => format!("panicked: {s}"),
            Err(_) => "panicked".to_string(),
        },
    }
}
