//! The supervisor actor: starts its children, watches their exits and applies the policy.

use super::error::{ChildError, GaveUp, StartError};
use super::event::{SupervisorEvent, SupervisorEventKind};
use super::handle::{ChildInfo, RetryRestart, SupervisorMsg, SupervisorRef};
use super::spec::{ChildSpec, EventSink, Restart, Shutdown, Strategy, SupervisorSpec};
use super::window::RestartWindow;
use crate::Clock;
use futures::FutureExt;
use ractor::{
    Actor, ActorCell, ActorId, ActorProcessingErr, ActorRef, ActorStatus, SpawnErr, SupervisionEvent,
};
use std::any::Any;
use std::collections::HashSet;
use std::panic::AssertUnwindSafe;
use tokio::time::Instant;

/// The exit reason ractor reports for a killed actor.
const KILLED: &str = "killed";
/// The exit reason ractor reports when an actor's task was cancelled (e.g. its runtime dropped).
const CANCELLED: &str = "actor_task_cancelled";
/// The stop reason a supervisor gives its children.
const SHUTDOWN: &str = "shutdown";

/// The supervisor actor. Start it with [`Supervisor::start`] or [`Supervisor::start_linked`], or
/// make it a child of another supervisor with [`ChildSpec::supervisor`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Supervisor;

impl Supervisor {
    /// Starts a supervisor without a parent and all its children, in order.
    pub async fn start(spec: SupervisorSpec) -> Result<SupervisorRef, StartError> {
        let name = spec.name.clone();
        match Actor::spawn(None, Supervisor, spec).await {
            Ok((actor, _join)) => Ok(SupervisorRef::new(actor, &name)),
            Err(e) => Err(start_error(&name, e)),
        }
    }

    /// Starts a supervisor linked to `parent` (which then sees it fail when it gives up).
    pub async fn start_linked(spec: SupervisorSpec, parent: ActorCell) -> Result<SupervisorRef, StartError> {
        let name = spec.name.clone();
        match Actor::spawn_linked(None, Supervisor, spec, parent).await {
            Ok((actor, _join)) => Ok(SupervisorRef::new(actor, &name)),
            Err(e) => Err(start_error(&name, e)),
        }
    }
}

/// The start function of a nested supervisor.
pub(crate) async fn start_child_supervisor(
    spec: SupervisorSpec,
    parent: ActorCell,
) -> Result<ActorCell, SpawnErr> {
    let (actor, _join) = Actor::spawn_linked(None, Supervisor, spec, parent).await?;
    Ok(actor.get_cell())
}

fn start_error(name: &str, e: SpawnErr) -> StartError {
    match e {
        SpawnErr::StartupFailed(inner) => match inner.downcast::<StartError>() {
            Ok(typed) => *typed,
            Err(other) => StartError::Spawn { supervisor: name.into(), reason: other.to_string() },
        },
        other => StartError::Spawn { supervisor: name.into(), reason: other.to_string() },
    }
}

/// The state of a running supervisor (opaque).
pub struct SupervisorState {
    name: String,
    strategy: Strategy,
    window: RestartWindow,
    children: Vec<Child>,
    clock: Clock,
    sink: Option<EventSink>,
    /// Set once the supervisor is giving up or shutting down: exits no longer cause restarts.
    stopping: bool,
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

struct Child {
    spec: ChildSpec,
    /// The running instance; events from any other instance are ignored.
    cell: Option<ActorCell>,
    restarts: u32,
    /// A restart of this child failed to start it and a retry is pending.
    retry_pending: bool,
}

impl Actor for Supervisor {
    type Msg = SupervisorMsg;
    type State = SupervisorState;
    type Arguments = SupervisorSpec;

    async fn pre_start(
        &self,
        myself: ActorRef<SupervisorMsg>,
        spec: SupervisorSpec,
    ) -> Result<SupervisorState, ActorProcessingErr> {
        let mut seen = HashSet::new();
        for child in &spec.children {
            if !seen.insert(child.id.as_str()) {
                return Err(Box::new(StartError::DuplicateChild {
                    supervisor: spec.name.clone(),
                    child: child.id.clone(),
                }));
            }
        }
        let mut state = SupervisorState {
            window: RestartWindow::new(spec.intensity, spec.period),
            strategy: spec.strategy,
            children: Vec::with_capacity(spec.children.len()),
            clock: spec.clock.unwrap_or_else(Clock::start),
            sink: spec.event_sink,
            name: spec.name,
            stopping: false,
        };
        let me = myself.get_cell();
        for child in spec.children {
            match state.start_instance(&me, &child).await {
                Ok(cell) => state.children.push(Child {
                    spec: child,
                    cell: Some(cell),
                    restarts: 0,
                    retry_pending: false,
                }),
                Err(reason) => {
                    state.stopping = true;
                    state.terminate_all().await;
                    return Err(Box::new(StartError::ChildStart {
                        supervisor: state.name,
                        child: child.id,
                        reason,
                    }));
                }
            }
        }
        tracing::debug!(supervisor = %state.name, children = state.children.len(), "started");
        Ok(state)
    }

    async fn handle(
        &self,
        myself: ActorRef<SupervisorMsg>,
        message: SupervisorMsg,
        state: &mut SupervisorState,
    ) -> Result<(), ActorProcessingErr> {
        let me = myself.get_cell();
        match message {
            SupervisorMsg::StartChild(spec, reply) => {
                let _ = reply.send(state.start_new_child(&me, spec).await);
            }
            SupervisorMsg::TerminateChild(id, reply) => {
                let _ = reply.send(state.terminate_child(&id).await);
            }
            SupervisorMsg::RestartChild(id, reply) => {
                let _ = reply.send(state.restart_child(&me, &id).await);
            }
            SupervisorMsg::DeleteChild(id, reply) => {
                let _ = reply.send(state.delete_child(&id));
            }
            SupervisorMsg::WhichChildren(reply) => {
                let _ = reply.send(state.which_children());
            }
            SupervisorMsg::Retry(RetryRestart { child }) => {
                let pending = state.index_of(&child).filter(|&i| state.children[i].retry_pending);
                if let (Some(i), false) = (pending, state.stopping) {
                    state.restart(&me, i, "retrying a restart whose start failed").await?;
                }
            }
        }
        Ok(())
    }

    async fn handle_supervisor_evt(
        &self,
        myself: ActorRef<SupervisorMsg>,
        event: SupervisionEvent,
        state: &mut SupervisorState,
    ) -> Result<(), ActorProcessingErr> {
        let (id, exit) = match event {
            SupervisionEvent::ActorFailed(cell, err) => (cell.get_id(), Exit::Abnormal(err.to_string())),
            SupervisionEvent::ActorTerminated(cell, _, reason) => {
                let exit = match reason {
                    Some(r) if r == KILLED || r == CANCELLED => Exit::Abnormal(r),
                    Some(r) => Exit::Normal(r),
                    None => Exit::Normal("normal".into()),
                };
                (cell.get_id(), exit)
            }
            _ => return Ok(()),
        };
        state.child_exited(&myself.get_cell(), id, exit).await
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<SupervisorMsg>,
        state: &mut SupervisorState,
    ) -> Result<(), ActorProcessingErr> {
        if !state.stopping {
            state.stopping = true;
            state.terminate_all().await;
            tracing::debug!(supervisor = %state.name, "shut down");
        }
        Ok(())
    }
}

/// How a child ended, as the policy sees it.
enum Exit {
    Normal(String),
    Abnormal(String),
}

impl SupervisorState {
    fn index_of(&self, id: &str) -> Option<usize> {
        self.children.iter().position(|c| c.spec.id == id)
    }

    async fn child_exited(
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
    async fn restart(&mut self, me: &ActorCell, i: usize, reason: &str) -> Result<(), ActorProcessingErr> {
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
                    self.children[j].retry_pending = true;
                    self.emit(j, SupervisorEventKind::StartFailed, &why);
                    let _ = me.send_message(SupervisorMsg::Retry(RetryRestart { child: id }));
                    break;
                }
            }
        }
        Ok(())
    }

    async fn give_up(&mut self, i: usize, reason: &str) -> ActorProcessingErr {
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
    async fn terminate_all(&mut self) {
        for child in self.children.iter_mut().rev() {
            if let Some(cell) = child.cell.take() {
                terminate(&cell, child.spec.shutdown).await;
            }
        }
    }

    /// Starts one instance of `spec`, linked to the supervisor `me`.
    async fn start_instance(&self, me: &ActorCell, spec: &ChildSpec) -> Result<ActorCell, String> {
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

    async fn start_new_child(&mut self, me: &ActorCell, spec: ChildSpec) -> Result<ActorCell, ChildError> {
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
                });
                Ok(cell)
            }
            Err(reason) => Err(ChildError::Start { supervisor: self.name.clone(), child: spec.id, reason }),
        }
    }

    async fn terminate_child(&mut self, id: &str) -> Result<(), ChildError> {
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

    async fn restart_child(&mut self, me: &ActorCell, id: &str) -> Result<ActorCell, ChildError> {
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
                self.emit(i, SupervisorEventKind::Restarted, "restart_child");
                Ok(cell)
            }
            Err(reason) => Err(ChildError::Start { supervisor: self.name.clone(), child: id.into(), reason }),
        }
    }

    fn delete_child(&mut self, id: &str) -> Result<(), ChildError> {
        let i = self.find(id)?;
        if self.children[i].cell.is_some() {
            return Err(ChildError::Running { supervisor: self.name.clone(), child: id.into() });
        }
        self.children.remove(i);
        Ok(())
    }

    fn which_children(&self) -> Vec<ChildInfo> {
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

    fn find(&self, id: &str) -> Result<usize, ChildError> {
        self.index_of(id)
            .ok_or_else(|| ChildError::NotFound { supervisor: self.name.clone(), child: id.into() })
    }

    /// Logs an event about child `i` and hands it to the sink.
    fn emit(&self, i: usize, kind: SupervisorEventKind, reason: &str) {
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

/// Stops one child as its shutdown says and waits until it has stopped.
async fn terminate(cell: &ActorCell, shutdown: Shutdown) {
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

fn panic_text(panic: Box<dyn Any + Send>) -> String {
    match panic.downcast::<String>() {
        Ok(s) => format!("panicked: {s}"),
        Err(panic) => match panic.downcast::<&str>() {
            Ok(s) => format!("panicked: {s}"),
            Err(_) => "panicked".to_string(),
        },
    }
}
