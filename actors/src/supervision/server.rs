//! The supervisor actor: starts its children, watches their exits and applies the policy.

use super::error::StartError;
use super::handle::{RetryRestart, SupervisorMsg, SupervisorRef};
use super::policy::Exit;
use super::spec::SupervisorSpec;
use super::state::{Child, SupervisorState};
use super::window::RestartWindow;
use crate::Clock;
use ractor::{Actor, ActorCell, ActorProcessingErr, ActorRef, SpawnErr, SupervisionEvent};
use std::collections::HashSet;

/// The exit reason ractor reports for a killed actor.
const KILLED: &str = "killed";
/// The exit reason ractor reports when an actor's task was cancelled (e.g. its runtime dropped).
const CANCELLED: &str = "actor_task_cancelled";

/// The supervisor actor. Start it with [`Supervisor::start`] or [`Supervisor::start_linked`], or
/// make it a child of another supervisor with [`ChildSpec::supervisor`](super::ChildSpec::supervisor).
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
            retry_delay: spec.retry_delay,
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
                    start_failures: 0,
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
