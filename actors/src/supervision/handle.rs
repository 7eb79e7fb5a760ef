//! Talking to a running supervisor: its messages and [`SupervisorRef`], which sends them.

use super::error::ChildError;
use super::spec::{ChildSpec, Restart, Shutdown};
use ractor::rpc::CallResult;
use ractor::{ActorCell, ActorRef, MessagingErr, RpcReplyPort};
use std::sync::Arc;

/// One child as [`SupervisorRef::which_children`] reports it, in start order.
#[derive(Debug, Clone)]
pub struct ChildInfo {
    /// The child's id.
    pub id: String,
    /// The running instance, `None` if the child is not running (terminated, exited without
    /// restart, or waiting for a retried restart).
    pub cell: Option<ActorCell>,
    /// The child's restart type.
    pub restart: Restart,
    /// How the child is stopped.
    pub shutdown: Shutdown,
    /// How many times the supervisor has started this child again after its first start.
    pub restart_count: u32,
    /// The nested supervisor's name, if the child is one.
    pub(crate) supervisor_name: Option<String>,
}

impl ChildInfo {
    /// A handle on the child if it is a running nested supervisor (made by
    /// [`ChildSpec::supervisor`]).
    pub fn supervisor(&self) -> Option<SupervisorRef> {
        let name = self.supervisor_name.as_deref()?;
        let cell = self.cell.clone()?;
        Some(SupervisorRef::new(ActorRef::from(cell), name))
    }
}

/// The messages of a supervisor actor. Each request carries a ractor reply port, so it can be
/// sent with `ActorRef::call` (or through [`SupervisorRef`], which does exactly that).
#[derive(Debug)]
pub enum SupervisorMsg {
    /// Add a child after the others and start it; replies with the started instance. A child
    /// that fails to start is not added.
    StartChild(ChildSpec, RpcReplyPort<Result<ActorCell, ChildError>>),
    /// Stop a child (honouring its shutdown) without restarting it; a temporary child's spec is
    /// removed, the others stay (not running) until `RestartChild` or `DeleteChild`.
    TerminateChild(String, RpcReplyPort<Result<(), ChildError>>),
    /// Start a child that is not running; replies with the new instance.
    RestartChild(String, RpcReplyPort<Result<ActorCell, ChildError>>),
    /// Remove the spec of a child that is not running.
    DeleteChild(String, RpcReplyPort<Result<(), ChildError>>),
    /// Report every child, in start order.
    WhichChildren(RpcReplyPort<Vec<ChildInfo>>),
    /// Internal: a restart whose start failed is tried again (only the supervisor can build it).
    #[doc(hidden)]
    Retry(RetryRestart),
}

/// Internal retry token of [`SupervisorMsg::Retry`]; cannot be built outside this module.
#[derive(Debug)]
pub struct RetryRestart {
    pub(crate) child: String,
}

/// A handle on a running supervisor: its actor and typed requests.
#[derive(Debug, Clone)]
pub struct SupervisorRef {
    actor: ActorRef<SupervisorMsg>,
    name: Arc<str>,
}

impl SupervisorRef {
    pub(crate) fn new(actor: ActorRef<SupervisorMsg>, name: &str) -> Self {
        SupervisorRef { actor, name: Arc::from(name) }
    }

    /// The supervisor's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The supervisor's actor.
    pub fn actor(&self) -> &ActorRef<SupervisorMsg> {
        &self.actor
    }

    /// The supervisor's cell, e.g. to wait for it or link it elsewhere.
    pub fn cell(&self) -> ActorCell {
        self.actor.get_cell()
    }

    /// Adds a child after the others and starts it.
    pub async fn start_child(&self, child: ChildSpec) -> Result<ActorCell, ChildError> {
        self.call(|reply| SupervisorMsg::StartChild(child, reply)).await?
    }

    /// Stops a child (honouring its shutdown) without restarting it.
    pub async fn terminate_child(&self, id: &str) -> Result<(), ChildError> {
        let id = id.to_string();
        self.call(|reply| SupervisorMsg::TerminateChild(id, reply)).await?
    }

    /// Starts a child that is not running.
    pub async fn restart_child(&self, id: &str) -> Result<ActorCell, ChildError> {
        let id = id.to_string();
        self.call(|reply| SupervisorMsg::RestartChild(id, reply)).await?
    }

    /// Removes the spec of a child that is not running.
    pub async fn delete_child(&self, id: &str) -> Result<(), ChildError> {
        let id = id.to_string();
        self.call(|reply| SupervisorMsg::DeleteChild(id, reply)).await?
    }

    /// Every child, in start order.
    pub async fn which_children(&self) -> Result<Vec<ChildInfo>, ChildError> {
        self.call(SupervisorMsg::WhichChildren).await
    }

    /// The running instance of one child, `None` if it is not running or unknown.
    pub async fn child(&self, id: &str) -> Result<Option<ActorCell>, ChildError> {
        let children = self.which_children().await?;
        Ok(children.into_iter().find(|c| c.id == id).and_then(|c| c.cell))
    }

    /// Stops the supervisor cleanly: its children are stopped in reverse start order, each
    /// honouring its shutdown, then the supervisor stops. Returns once it has stopped (at once
    /// if it had already stopped or failed).
    pub async fn shutdown(&self) {
        let cell = self.actor.get_cell();
        cell.stop(None);
        // Waiting without a timeout is bounded by the children's shutdown specs.
        let _ = cell.wait(None).await;
    }

    async fn call<R, F>(&self, build: F) -> Result<R, ChildError>
    where
        R: Send + 'static,
        F: FnOnce(RpcReplyPort<R>) -> SupervisorMsg,
    {
        let unreachable =
            |reason: String| ChildError::Unreachable { supervisor: self.name.to_string(), reason };
        match self.actor.call(build, None).await {
            Ok(CallResult::Success(r)) => Ok(r),
            Ok(CallResult::Timeout) => Err(unreachable("no reply in time".into())),
            Ok(CallResult::SenderError) => Err(unreachable("it stopped before replying".into())),
            Err(MessagingErr::SendErr(_) | MessagingErr::ChannelClosed) => {
                Err(unreachable("it has stopped".into()))
            }
            Err(e) => Err(unreachable(e.to_string())),
        }
    }
}
