//! What a supervisor is told: its strategy and intensity, and one [`ChildSpec`] per child.

use super::event::SupervisorEvent;
use crate::Clock;
use futures::FutureExt;
use futures::future::BoxFuture;
use ractor::{Actor, ActorCell, SpawnErr};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::Arc;
use std::time::Duration;

/// The future a [`StartFn`] returns: the started, linked child, or why it did not start.
pub type StartFuture = BoxFuture<'static, Result<ActorCell, SpawnErr>>;

/// How a supervisor starts one instance of a child.
///
/// It is given the supervisor's [`ActorCell`] and must spawn the child **linked** to it
/// (`Actor::spawn_linked(name, handler, args, supervisor)`), so that ractor reports the child's
/// exit to the supervisor. It is called again for every restart, so it must build a fresh handler
/// and fresh arguments each time. Any ractor actor, whatever its message type, fits behind it.
pub type StartFn = Arc<dyn Fn(ActorCell) -> StartFuture + Send + Sync>;

/// Where a supervisor delivers its [`SupervisorEvent`]s. Called on the supervisor's task: keep it
/// short and non-blocking (push into a channel).
pub type EventSink = Arc<dyn Fn(SupervisorEvent) + Send + Sync>;

/// Which children a supervisor restarts when one of them must be restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// Only the child that exited.
    OneForOne,
    /// Every child: all are stopped (in reverse start order) and started again (in start order).
    OneForAll,
    /// The child that exited and every child started after it.
    RestForOne,
}

/// When a child that exited is restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Restart {
    /// Always.
    Permanent,
    /// Only after an abnormal exit: a failure (handler error or panic) or a kill.
    Transient,
    /// Never; the child's spec is removed from the supervisor when it exits.
    Temporary,
}

/// How a supervisor stops a child (on restarts of siblings, `terminate_child` and shutdown).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shutdown {
    /// Kill at once: the running handler is cancelled and `post_stop` is not run.
    Brutal,
    /// Ask the child to stop; kill it if it has not stopped after this long.
    Timeout(Duration),
    /// Ask the child to stop and wait as long as it takes (meant for nested supervisors, whose
    /// own children's shutdown specs bound their stop).
    Infinity,
}

/// The default [`Shutdown`] of a worker child, as in OTP.
pub const DEFAULT_WORKER_SHUTDOWN: Shutdown = Shutdown::Timeout(Duration::from_secs(5));

/// One child of a supervisor: an id unique within the supervisor, a restart type, a shutdown
/// and a start function.
#[derive(Clone)]
pub struct ChildSpec {
    pub(crate) id: String,
    pub(crate) restart: Restart,
    pub(crate) shutdown: Shutdown,
    pub(crate) start: StartFn,
    /// Set for nested supervisors, so that the parent can lend them its clock and event sink.
    pub(crate) nested: Option<Arc<SupervisorSpec>>,
}

impl ChildSpec {
    /// A child started by `start`; [`Restart::Permanent`], [`DEFAULT_WORKER_SHUTDOWN`].
    pub fn new<F>(id: impl Into<String>, start: F) -> Self
    where
        F: Fn(ActorCell) -> StartFuture + Send + Sync + 'static,
    {
        ChildSpec {
            id: id.into(),
            restart: Restart::Permanent,
            shutdown: DEFAULT_WORKER_SHUTDOWN,
            start: Arc::new(start),
            nested: None,
        }
    }

    /// A ractor actor as a child: every start spawns a clone of `actor`, linked to the
    /// supervisor and unnamed, with arguments from `args`.
    pub fn actor<A, F>(id: impl Into<String>, actor: A, args: F) -> Self
    where
        A: Actor + Clone,
        F: Fn() -> A::Arguments + Send + Sync + 'static,
    {
        Self::new(id, move |supervisor| {
            let handler = actor.clone();
            let args = args();
            async move {
                let (child, _join) = A::spawn_linked(None, handler, args, supervisor).await?;
                Ok(child.get_cell())
            }
            .boxed()
        })
    }

    /// A nested supervisor as a child, with [`Shutdown::Infinity`] as in OTP.
    ///
    /// If `spec` has no clock or no event sink, the parent lends it its own when it starts it,
    /// so that a whole tree shares one epoch and one event stream.
    pub fn supervisor(id: impl Into<String>, spec: SupervisorSpec) -> Self {
        let nested = Arc::new(spec);
        let own = Arc::clone(&nested);
        let mut child = Self::new(id, move |parent| {
            let spec = (*own).clone();
            async move { super::server::start_child_supervisor(spec, parent).await }.boxed()
        });
        child.shutdown = Shutdown::Infinity;
        child.nested = Some(nested);
        child
    }

    /// This spec with another restart type.
    pub fn with_restart(mut self, restart: Restart) -> Self {
        self.restart = restart;
        self
    }

    /// This spec with another shutdown.
    pub fn with_shutdown(mut self, shutdown: Shutdown) -> Self {
        self.shutdown = shutdown;
        self
    }

    /// The child's id.
    pub fn id(&self) -> &str {
        &self.id
    }

    /// The child's restart type.
    pub fn restart(&self) -> Restart {
        self.restart
    }

    /// How the child is stopped.
    pub fn shutdown(&self) -> Shutdown {
        self.shutdown
    }

    /// Whether the child is a nested supervisor made by [`ChildSpec::supervisor`].
    pub fn is_supervisor(&self) -> bool {
        self.nested.is_some()
    }
}

impl fmt::Debug for ChildSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ChildSpec")
            .field("id", &self.id)
            .field("restart", &self.restart)
            .field("shutdown", &self.shutdown)
            .field("supervisor", &self.nested.is_some())
            .finish_non_exhaustive()
    }
}

/// A supervisor: its name (in events and logs), strategy, restart intensity, children in start
/// order, clock and event sink.
#[derive(Clone)]
pub struct SupervisorSpec {
    /// Name used in events, logs and errors (not registered with ractor).
    pub name: String,
    /// Which children a restart affects.
    pub strategy: Strategy,
    /// At most this many restarts within `period`; one more and the supervisor gives up.
    pub intensity: u32,
    /// The sliding window of the restart intensity, on tokio's clock.
    pub period: Duration,
    /// How long to wait before trying again to start a child whose restart failed to start
    /// it, doubled at each failure in a row (at most 16 times this); zero, as in OTP: at once.
    /// A start that fails because something outside is briefly unreachable (a robot process
    /// frozen for a moment) then does not use up the intensity in one instant.
    pub retry_delay: Duration,
    /// The children, in start order.
    pub children: Vec<ChildSpec>,
    /// The clock of event timestamps; `None` lends the parent's (nested) or starts one.
    pub clock: Option<Clock>,
    /// Where events go; `None` lends the parent's (nested) or only logs.
    pub event_sink: Option<EventSink>,
}

impl SupervisorSpec {
    /// A supervisor without children, with OTP's default intensity: 1 restart in 5 s.
    pub fn new(name: impl Into<String>, strategy: Strategy) -> Self {
        SupervisorSpec {
            name: name.into(),
            strategy,
            intensity: 1,
            period: Duration::from_secs(5),
            retry_delay: Duration::ZERO,
            children: Vec::new(),
            clock: None,
            event_sink: None,
        }
    }

    /// This spec with another restart intensity: at most `intensity` restarts within `period`.
    pub fn with_intensity(mut self, intensity: u32, period: Duration) -> Self {
        self.intensity = intensity;
        self.period = period;
        self
    }

    /// This spec with a delay before retrying a failed start (see [`SupervisorSpec::retry_delay`]).
    pub fn with_retry_delay(mut self, delay: Duration) -> Self {
        self.retry_delay = delay;
        self
    }

    /// This spec with one more child, started after the others.
    pub fn with_child(mut self, child: ChildSpec) -> Self {
        self.children.push(child);
        self
    }

    /// This spec with the given clock for event timestamps.
    pub fn with_clock(mut self, clock: Clock) -> Self {
        self.clock = Some(clock);
        self
    }

    /// This spec with an event sink.
    pub fn with_event_sink<F>(mut self, sink: F) -> Self
    where
        F: Fn(SupervisorEvent) + Send + Sync + 'static,
    {
        self.event_sink = Some(Arc::new(sink));
        self
    }
}

impl fmt::Debug for SupervisorSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SupervisorSpec")
            .field("name", &self.name)
            .field("strategy", &self.strategy)
            .field("intensity", &self.intensity)
            .field("period", &self.period)
            .field("retry_delay", &self.retry_delay)
            .field("children", &self.children)
            .field("clock", &self.clock)
            .field("event_sink", &self.event_sink.is_some())
            .finish()
    }
}
