//! OTP-style supervision on ractor: restart strategies, restart types, restart intensity,
//! escalation and shutdown.
//!
//! ractor tells a parent when a linked child stops or fails and leaves the policy to it; a
//! [`Supervisor`] is that policy, as Erlang/OTP's `supervisor` defines it. Any ractor actor, of
//! any message type, can be a child: a [`ChildSpec`] holds an id, a [`Restart`] type, a
//! [`Shutdown`] and a [`StartFn`] that spawns one instance linked to the supervisor
//! ([`ChildSpec::actor`] builds it from an actor and an argument factory,
//! [`ChildSpec::supervisor`] nests a supervisor).
//!
//! # Semantics
//!
//! - **Start.** Children start one after another in spec order; if one fails to start, those
//!   already started are stopped in reverse order and the supervisor fails to start
//!   ([`StartError`]). Child ids are unique within a supervisor.
//! - **Exits.** A child's exit is *abnormal* if a handler returned an error or panicked
//!   (ractor's `ActorFailed`), or if it was killed (`ActorTerminated` with reason `"killed"`);
//!   any other stop is *normal*. Whether the supervisor restarts it depends on its type:
//!   [`Restart::Permanent`] always, [`Restart::Transient`] only after an abnormal exit,
//!   [`Restart::Temporary`] never (its spec is then removed). A child that is not restarted
//!   stays in the list, not running, until `restart_child` or `delete_child`.
//! - **Strategies.** Children are ordered by start order. When child `c` must be restarted,
//!   [`Strategy::OneForOne`] restarts `c`; [`Strategy::OneForAll`] all children;
//!   [`Strategy::RestForOne`] `c` and every child after it. The affected children still
//!   running are stopped in reverse start order (each honouring its shutdown), then all the
//!   affected children are started in start order, including those that were not running
//!   (as OTP does), except temporary ones, which are stopped and removed.
//! - **Intensity.** Each application of the strategy is one restart, however many children it
//!   starts. The supervisor counts restarts in a sliding window on tokio's clock: a restart at
//!   `t` still counts at `now` while `now - t <= period`. At most `intensity` restarts are
//!   allowed; the one after (the `intensity + 1`-th within the period) makes the supervisor
//!   **give up**: it stops all its children (reverse order, honouring shutdown), emits
//!   [`SupervisorEventKind::GaveUp`] and fails with [`GaveUp`], so that its own parent sees a
//!   failed child and applies *its* policy (escalation). `intensity = 0` allows no restart.
//! - **Start failures during a restart.** If a child fails to start during a restart, the
//!   children after it are left unstarted, a [`SupervisorEventKind::StartFailed`] event is
//!   emitted, and the supervisor retries the restart of that child later, through its own
//!   mailbox (so a shutdown can get in between); each retry counts as one more restart.
//! - **Shutdown.** [`Shutdown::Brutal`] kills the child; [`Shutdown::Timeout`] asks it to stop
//!   and kills it if it has not stopped within the timeout (a handler that ignores the stop
//!   because it hangs, say); [`Shutdown::Infinity`] asks and waits. [`SupervisorRef::shutdown`]
//!   (or any `stop` of the supervisor actor) stops the children in reverse start order this
//!   way, then the supervisor. Exits seen while giving up or shutting down cause no restart.
//! - **Races.** Events are matched to children by `ActorId`: those of an instance the supervisor
//!   has already replaced or stopped are ignored.
//! - **Events.** Every child exit, restart, start failure and give-up is a [`SupervisorEvent`]
//!   (a communication object) handed to the spec's event sink and logged with `tracing`.
//!
//! # Deviations from OTP
//!
//! - A supervisor that gives up *fails* (its parent sees `ActorFailed`, an abnormal exit); in OTP
//!   it exits with reason `shutdown`, which a transient parent would not restart.
//! - A child stopped with any reason, e.g. `stop(Some("error"))`, exits normally; only errors,
//!   panics and kills are abnormal (ractor has no exit reasons beyond that).
//! - Killing a supervisor (rather than stopping it) kills its children at once, as ractor does.
//! - No `significant` children, no auto-shutdown, no dynamic `simple_one_for_one`.
//! - The start function must link the child to the supervisor; one that returns a running child
//!   it did not link gets linked (with a warning), one that returns an unlinked child that
//!   already stopped is never noticed.
//! - Nested supervisor specs without a clock or event sink borrow their parent's.
//!
//! # Example
//!
//! ```
//! use orsa_actors::supervision::{ChildSpec, Strategy, Supervisor, SupervisorEventKind, SupervisorSpec};
//! use ractor::{Actor, ActorProcessingErr, ActorRef};
//! use std::time::Duration;
//!
//! /// Fails on every message.
//! #[derive(Clone)]
//! struct Fragile;
//!
//! impl Actor for Fragile {
//!     type Msg = ();
//!     type State = ();
//!     type Arguments = ();
//!     async fn pre_start(&self, _: ActorRef<()>, _: ()) -> Result<(), ActorProcessingErr> {
//!         Ok(())
//!     }
//!     async fn handle(&self, _: ActorRef<()>, _: (), _: &mut ()) -> Result<(), ActorProcessingErr> {
//!         Err("bad reading".into())
//!     }
//! }
//!
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let (tx, mut events) = tokio::sync::mpsc::unbounded_channel();
//! let spec = SupervisorSpec::new("sensors", Strategy::OneForOne)
//!     .with_intensity(3, Duration::from_secs(10))
//!     .with_child(ChildSpec::actor("sonar", Fragile, || ()))
//!     .with_event_sink(move |e| {
//!         let _ = tx.send(e);
//!     });
//! let sup = Supervisor::start(spec).await?;
//!
//! let first = sup.child("sonar").await?.ok_or("sonar is not running")?;
//! ActorRef::<()>::from(first.clone()).cast(())?;
//!
//! let failed = events.recv().await.ok_or("no event")?;
//! assert_eq!(failed.kind, SupervisorEventKind::ChildFailed);
//! let restarted = events.recv().await.ok_or("no event")?;
//! assert_eq!((restarted.kind, restarted.restart_count), (SupervisorEventKind::Restarted, 1));
//! let second = sup.child("sonar").await?.ok_or("sonar is not running")?;
//! assert_ne!(first.get_id(), second.get_id());
//!
//! sup.shutdown().await;
//! # Ok(())
//! # }
//! ```

mod error;
mod event;
mod handle;
mod policy;
mod server;
mod spec;
mod state;
mod window;

pub use error::{ChildError, GaveUp, StartError};
pub use event::{SupervisorEvent, SupervisorEventKind};
pub use handle::{ChildInfo, RetryRestart, SupervisorMsg, SupervisorRef};
pub use server::Supervisor;
pub use spec::{
    ChildSpec, DEFAULT_WORKER_SHUTDOWN, EventSink, Restart, Shutdown, StartFn, StartFuture, Strategy,
    SupervisorSpec,
};
pub use state::SupervisorState;
