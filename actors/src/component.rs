//! Components: named, supervised actors that host services, activities, state and wiring.
//!
//! (About 700 lines, over the usual 500: it is one concept, the component's shell, its `Ctx`
//! and the actor that runs its instances, and splitting it would spread one lifecycle over
//! several files.)
//!
//! A component is what the original system called a component: a unit whose interface is a list
//! of services, each a pattern plus a communication object. In orsa it has two parts:
//! - a **shell** that lives as long as the component is part of the system: its name in the
//!   [`Registry`], its [`Mailbox`], its services, its wireable ports, its
//!   [`State`](crate::state) slave and its subscriptions;
//! - an **instance**: a ractor actor running the user's [`Component`] code, which a supervisor
//!   may kill and restart. A new instance re-runs [`Component::setup`], finds its services,
//!   ports and subscriptions where the old one left them (declaring them again gives them back,
//!   with the same wiring and the same `every`), and receives again through the same mailbox.
//!   Nobody has to re-wire or re-subscribe it.
//!
//! Everything a component does with other components goes through its [`Ctx`]: declaring
//! servers, connecting clients, subscribing, declaring ports and states. A component never calls
//! another component's methods.
//!
//! ```
//! use orsa_actors::component::spawn;
//! use orsa_actors::prelude::*;
//!
//! /// The doubler's interface: a service named once, with its pattern and object.
//! const INPUT: SendService<u64> = SendService::new("input");
//! const OUTPUT: PushNewestService<u64> = PushNewestService::new("output");
//!
//! /// Doubles every number sent to `doubler/input` and pushes it on `doubler/output`.
//! struct Doubler;
//! enum Msg { Input(Stamped<u64>) }
//!
//! impl Component for Doubler {
//!     type Msg = Msg;
//!     type State = PushNewestServer<u64>;
//!     async fn setup(&self, ctx: &Ctx<Msg>) -> Result<Self::State, ComponentError> {
//!         ctx.send_server(INPUT, Msg::Input)?;
//!         Ok(ctx.push_newest_server(OUTPUT)?)
//!     }
//!     async fn handle(&self, _ctx: &Ctx<Msg>, out: &mut Self::State, msg: Msg) -> Result<(), ComponentError> {
//!         let Msg::Input(n) = msg;
//!         out.put(n.value * 2);
//!         Ok(())
//!     }
//! }
//!
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let doubler = spawn(&registry, "doubler", Doubler).await?;
//! let out = PushNewestClient::connect(&registry, OUTPUT.on("doubler"))?;
//! out.subscribe()?;
//! SendClient::connect(&registry, INPUT.on("doubler"))?.send(21)?;
//! assert_eq!(out.get_update_wait().await?.value, 42);
//! doubler.stop().await;
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, ServiceAddr};
use crate::clock::{Clock, Timestamp};
use crate::comm::CommObject;
use crate::error::{PatternError, PatternResult};
use crate::event::{EventClient, EventServer};
use crate::fault::HandlerFault;
use crate::push_newest::{PushNewestClient, PushNewestServer};
use crate::push_timed::{PushTimedClient, PushTimedServer, Tick};
use crate::query::{QueryClient, QueryRequest, QueryServer};
use crate::registry::Registry;
use crate::send::{SendClient, SendServer};
use crate::service::{
    Addr, Descriptor, EventService, PushNewestService, PushTimedService, QueryPortDesc, QueryService,
    SendPortDesc, SendService,
};
use crate::sink::{Envelope, Mailbox};
use crate::stamped::{Stamped, Update};
use crate::state::{Cancel, StateHandle, StateSlave, StateSpec};
use crate::supervision::ChildSpec;
use crate::wiring::{QueryPort, SendPort, WiringSlave};
use parking_lot::Mutex;
use ractor::{Actor, ActorCell, ActorProcessingErr, ActorRef};
use std::any::Any;
use std::collections::BTreeMap;
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

/// The error a component's code returns; the instance fails and its supervisor decides.
pub type ComponentError = ActorProcessingErr;

/// The code of a component. Configuration lives in `self`; mutable state in [`Self::State`],
/// built by [`setup`](Self::setup) on every (re)start.
pub trait Component: Send + Sync + Sized + 'static {
    /// The messages the component's services and subscriptions deliver to it.
    type Msg: ractor::Message;
    /// The instance's mutable state.
    type State: Send + 'static;

    /// Declares services, ports, states and subscriptions, and builds the state.
    fn setup(&self, ctx: &Ctx<Self::Msg>)
    -> impl Future<Output = Result<Self::State, ComponentError>> + Send;

    /// Handles one message.
    fn handle(
        &self,
        ctx: &Ctx<Self::Msg>,
        state: &mut Self::State,
        msg: Self::Msg,
    ) -> impl Future<Output = Result<(), ComponentError>> + Send;

    /// Runs when the instance stops normally (not when it fails or is killed).
    fn teardown(&self, ctx: &Ctx<Self::Msg>, state: &mut Self::State) -> impl Future<Output = ()> + Send {
        let _ = (ctx, state);
        async {}
    }
}

struct Shell<M> {
    name: String,
    registry: Registry,
    mailbox: Mailbox<M>,
    state: Arc<StateSlave>,
    wiring: Arc<WiringSlave>,
    declared: Mutex<BTreeMap<String, Arc<dyn Any + Send + Sync>>>,
    stoppers: Mutex<Vec<Box<dyn Fn() + Send + Sync>>>,
    /// Tasks of the running instance, ended when it ends.
    activities: Mutex<Vec<tokio::task::AbortHandle>>,
    removed: std::sync::atomic::AtomicBool,
    /// How long one handler may run before the instance is deemed hung and failed, in
    /// nanoseconds; 0 for no limit (read on every message, so not behind a lock).
    handler_timeout_ns: std::sync::atomic::AtomicU64,
    /// The registry's fault switchboard, kept to spare every message a clone.
    faults: crate::fault::Faults,
}

/// A component's access to the system: everything it declares or connects goes through here.
///
/// Its methods come in five groups, one `impl` block each: who it is and the time
/// ([`name`](Self::name), [`now`](Self::now)); its running instance (states, activities, what
/// outlives a restart); serving (a server per pattern); using others' services (clients,
/// events, subscriptions); and the wireable ports.
pub struct Ctx<M> {
    shell: Arc<Shell<M>>,
}

impl<M> Clone for Ctx<M> {
    fn clone(&self) -> Self {
        Ctx { shell: Arc::clone(&self.shell) }
    }
}

/// Who it is and what time it is.
impl<M: ractor::Message> Ctx<M> {
    fn new(registry: &Registry, name: &str) -> PatternResult<Self> {
        registry.register_component(name)?;
        let made = (|| {
            let state = StateSlave::register(registry, name, StateSpec::new())?;
            let wiring = WiringSlave::register_with_cancel(registry, name, Some(state.cancel_token()))?;
            // Its wiring service also carries the switches other processes make here.
            wiring.serve_also(crate::switch::participant(registry));
            Ok::<_, PatternError>((state, wiring))
        })();
        let (state, wiring) = match made {
            Ok(v) => v,
            Err(e) => {
                registry.unregister_component(name);
                return Err(e);
            }
        };
        Ok(Ctx {
            shell: Arc::new(Shell {
                name: name.to_string(),
                registry: registry.clone(),
                mailbox: Mailbox::new(),
                state,
                wiring,
                declared: Mutex::new(BTreeMap::new()),
                stoppers: Mutex::new(Vec::new()),
                activities: Mutex::new(Vec::new()),
                removed: std::sync::atomic::AtomicBool::new(false),
                handler_timeout_ns: std::sync::atomic::AtomicU64::new(0),
                faults: registry.faults(),
            }),
        })
        .inspect(|ctx: &Ctx<M>| {
            let mailbox = ctx.shell.mailbox.clone();
            registry.faults().register_killer(
                name,
                Arc::new(move || match mailbox.current() {
                    Some(actor) => {
                        actor.kill();
                        true
                    }
                    None => false,
                }),
            );
        })
    }

    /// The component's name.
    pub fn name(&self) -> &str {
        &self.shell.name
    }

    /// The address of one of this component's services.
    pub fn addr<D: Descriptor>(&self, service: D) -> Addr<D> {
        Addr::new(self.shell.name.clone(), service)
    }

    fn untyped(&self, service: impl Descriptor) -> ServiceAddr {
        ServiceAddr::new(self.shell.name.clone(), service.name())
    }

    /// The system's registry.
    pub fn registry(&self) -> &Registry {
        &self.shell.registry
    }

    /// The system's clock.
    pub fn clock(&self) -> Clock {
        self.shell.registry.clock()
    }

    /// The current robot time.
    pub fn now(&self) -> Timestamp {
        self.shell.registry.now()
    }
}

/// Its running instance: the mailbox, the main states its master sets, the activities
/// that die with the instance, and what outlives it.
impl<M: ractor::Message> Ctx<M> {
    /// The component's mailbox (bound to the running instance).
    pub fn mailbox(&self) -> &Mailbox<M> {
        &self.shell.mailbox
    }

    /// The running instance, if any.
    pub fn myself(&self) -> Option<ActorCell> {
        self.shell.mailbox.current()
    }

    /// The activity-side handle of the component's State slave.
    pub fn state(&self) -> StateHandle {
        self.shell.state.handle()
    }

    /// Declares the component's main states (see [`crate::state`]).
    pub fn declare_states(&self, spec: StateSpec) -> PatternResult<()> {
        self.shell.state.declare(spec)
    }

    /// The token that aborts this component's blocking calls when its master deactivates it.
    pub fn cancel(&self) -> Cancel {
        self.shell.state.cancel_token()
    }

    /// Runs `activity` as a task of the current instance: it is aborted when the instance
    /// stops, fails or is killed, so a restarted component never runs it twice.
    pub fn spawn_activity(&self, activity: impl Future<Output = ()> + Send + 'static) {
        let handle = tokio::spawn(activity).abort_handle();
        let mut activities = self.shell.activities.lock();
        activities.retain(|a| !a.is_finished());
        activities.push(handle);
    }

    fn end_activities(&self) {
        for a in self.shell.activities.lock().drain(..) {
            a.abort();
        }
    }

    /// Something of the component's that outlives its instances: made by `make` the first time,
    /// given back (the same value, e.g. an `Arc<Mutex<_>>`) to every later instance. This is where
    /// a component keeps what a restart must not forget (a master's current goal).
    pub fn keep<X: Clone + Send + Sync + 'static>(
        &self,
        key: &str,
        make: impl FnOnce() -> X,
    ) -> PatternResult<X> {
        self.declared(format!("kept {key}"), || Ok(make()))
    }

    /// Gets back what `key` declared before (same type), or makes and records it.
    fn declared<X: Clone + Send + Sync + 'static>(
        &self,
        key: String,
        make: impl FnOnce() -> PatternResult<X>,
    ) -> PatternResult<X> {
        let mut declared = self.shell.declared.lock();
        if let Some(existing) = declared.get(&key) {
            return existing.downcast_ref::<X>().cloned().ok_or_else(|| {
                PatternError::AlreadyRegistered(format!("{key} of '{}' with another type", self.shell.name))
            });
        }
        let made = make()?;
        declared.insert(key, Arc::new(made.clone()));
        Ok(made)
    }
}

/// Serving: the server side of each communication pattern, declared once and given back to
/// every later instance.
impl<M: ractor::Message> Ctx<M> {
    /// Declares a Send service; each message arrives as `map(message)`.
    pub fn send_server<T: CommObject>(
        &self,
        service: SendService<T>,
        map: impl Fn(Stamped<T>) -> M + Send + Sync + 'static,
    ) -> PatternResult<SendServer<T>> {
        self.declared(format!("service {}", service.name()), || {
            SendServer::register(&self.shell.registry, self.untyped(service), self.shell.mailbox.sink(map))
        })
    }

    /// Declares a Query service; each request arrives as `map(request)`.
    pub fn query_server<Req: CommObject, Ans: CommObject>(
        &self,
        service: QueryService<Req, Ans>,
        map: impl Fn(QueryRequest<Req, Ans>) -> M + Send + Sync + 'static,
    ) -> PatternResult<QueryServer<Req, Ans>> {
        self.declared(format!("service {}", service.name()), || {
            QueryServer::register(&self.shell.registry, self.untyped(service), self.shell.mailbox.sink(map))
        })
    }

    /// Declares a Push newest service.
    pub fn push_newest_server<T: CommObject>(
        &self,
        service: PushNewestService<T>,
    ) -> PatternResult<PushNewestServer<T>> {
        self.declared(format!("service {}", service.name()), || {
            PushNewestServer::register(&self.shell.registry, self.untyped(service))
        })
    }

    /// Declares a Push timed service producing every `period`; each tick arrives as `map(tick)`.
    /// It starts stopped: call [`PushTimedServer::start`] (starting again is harmless).
    pub fn push_timed_server<T: CommObject>(
        &self,
        service: PushTimedService<T>,
        period: Duration,
        map: impl Fn(Tick) -> M + Send + Sync + 'static,
    ) -> PatternResult<PushTimedServer<T>> {
        self.declared(format!("service {}", service.name()), || {
            let server = PushTimedServer::register(
                &self.shell.registry,
                self.untyped(service),
                period,
                self.shell.mailbox.sink_latest(map),
            )?;
            let stopper = server.clone();
            self.shell.stoppers.lock().push(Box::new(move || stopper.stop()));
            Ok(server)
        })
    }

    /// Declares an Event service with its condition test (see [`EventServer::register`]).
    pub fn event_server<P: CommObject, E: CommObject, S: 'static>(
        &self,
        service: EventService<P, E>,
        test: impl Fn(&mut P, &S) -> Option<E> + Send + Sync + 'static,
    ) -> PatternResult<EventServer<P, E, S>> {
        self.declared(format!("service {}", service.name()), || {
            EventServer::register(&self.shell.registry, self.untyped(service), test)
        })
    }
}

/// Using others' services: clients, event activations and subscriptions (the latter two
/// belong to the component and survive restarts of its instance).
impl<M: ractor::Message> Ctx<M> {
    /// A Send client to `addr`.
    pub fn send_client<T: CommObject>(
        &self,
        addr: impl IntoAddr<SendService<T>>,
    ) -> PatternResult<SendClient<T>> {
        SendClient::connect(&self.shell.registry, addr)
    }

    /// A Query client to `addr`, whose waits this component's deactivation aborts.
    pub fn query_client<Req: CommObject, Ans: CommObject>(
        &self,
        addr: impl IntoAddr<QueryService<Req, Ans>>,
    ) -> PatternResult<QueryClient<Req, Ans>> {
        Ok(QueryClient::connect(&self.shell.registry, addr)?.with_cancel(self.cancel()))
    }

    /// An Event client to `addr`, whose waits this component's deactivation aborts.
    pub fn event_client<P: CommObject, E: CommObject>(
        &self,
        addr: impl IntoAddr<EventService<P, E>>,
    ) -> PatternResult<EventClient<P, E>> {
        Ok(EventClient::connect(&self.shell.registry, addr)?.with_cancel(self.cancel()))
    }

    /// Activates an event at the Event service `addr`; each firing arrives as `map(fired)`.
    /// The activation belongs to the component: declaring it again after a restart gives back
    /// the same activation (no duplicate), and it lives until the component leaves the system
    /// or [`EventClient::deactivate`] ends it (a single-shot one ends when it fires).
    pub fn activate_event<P: CommObject, E: CommObject>(
        &self,
        addr: impl IntoAddr<EventService<P, E>>,
        mode: crate::event::EventMode,
        params: P,
        map: impl Fn(crate::event::Fired<E>) -> M + Send + Sync + 'static,
    ) -> PatternResult<crate::event::ActivationId> {
        let addr = IntoAddr::<EventService<P, E>>::into_addr(addr);
        self.declared(format!("activation {addr}"), || {
            let client = EventClient::<P, E>::connect(&self.shell.registry, &addr)?;
            client.activate_to(mode, params, self.shell.mailbox.sink(map))
        })
    }

    /// Subscribes to a Push newest service; each update arrives as `map(update)`. The
    /// subscription belongs to the component and survives restarts of its instance.
    pub fn subscribe_newest<T: CommObject>(
        &self,
        addr: impl IntoAddr<PushNewestService<T>>,
        map: impl Fn(Update<T>) -> M + Send + Sync + 'static,
    ) -> PatternResult<Arc<PushNewestClient<T>>> {
        let addr = IntoAddr::<PushNewestService<T>>::into_addr(addr);
        self.declared(format!("subscription {addr}"), || {
            let client = PushNewestClient::build(
                &self.shell.registry,
                &addr,
                Some(self.shell.mailbox.sink_latest(map)),
                Some(self.cancel()),
            )?;
            client.subscribe()?;
            Ok(Arc::new(client))
        })
    }

    /// Subscribes to every `every`-th update of a Push timed service; each arrives as
    /// `map(update)`. The subscription belongs to the component and survives restarts of its
    /// instance; declaring it again with another `every` re-subscribes with that one.
    pub fn subscribe_timed<T: CommObject>(
        &self,
        addr: impl IntoAddr<PushTimedService<T>>,
        every: u32,
        map: impl Fn(Update<T>) -> M + Send + Sync + 'static,
    ) -> PatternResult<Arc<PushTimedClient<T>>> {
        let addr = IntoAddr::<PushTimedService<T>>::into_addr(addr);
        let client: Arc<PushTimedClient<T>> = self.declared(format!("subscription {addr}"), || {
            let client = PushTimedClient::build(
                &self.shell.registry,
                &addr,
                Some(self.shell.mailbox.sink_latest(map)),
                Some(self.cancel()),
            )?;
            Ok(Arc::new(client))
        })?;
        let key = format!("every {addr}");
        let mut declared = self.shell.declared.lock();
        let same = declared.get(&key).and_then(|e| e.downcast_ref::<u32>().copied()) == Some(every);
        if !same || !client.is_subscribed() {
            client.subscribe(every)?;
            declared.insert(key, Arc::new(every));
        }
        Ok(client)
    }
}

/// The ports a master wires to another component's service at run time.
impl<M: ractor::Message> Ctx<M> {
    /// Declares (or gets back, still wired) a wireable Send port.
    pub fn send_port<T: CommObject>(&self, port: SendPortDesc<T>) -> PatternResult<SendPort<T>> {
        self.shell.wiring.send_port(port.name())
    }

    /// Declares (or gets back, still wired) a wireable Query port.
    pub fn query_port<Req: CommObject, Ans: CommObject>(
        &self,
        port: QueryPortDesc<Req, Ans>,
    ) -> PatternResult<QueryPort<Req, Ans>> {
        self.shell.wiring.query_port(port.name())
    }
}

struct Instance<C: Component> {
    component: Arc<C>,
    ctx: Ctx<C::Msg>,
}

impl<C: Component> Instance<C> {
    /// One message through the component's handler, under its fault hooks and handler timeout.
    async fn run(&self, msg: C::Msg, state: &mut C::State) -> Result<(), ActorProcessingErr> {
        let faults = &self.ctx.shell.faults;
        let name = self.ctx.name();
        let work = async {
            match faults.take_armed(name) {
                Some(HandlerFault::Panic) => {
                    faults.detected(name, "panicked");
                    panic!("injected fault: a handler of '{name}' panics");
                }
                Some(HandlerFault::Hang) => std::future::pending::<()>().await,
                None => {}
            }
            faults.handled(name);
            self.component.handle(&self.ctx, state, msg).await
        };
        let timeout = match self.ctx.shell.handler_timeout_ns.load(std::sync::atomic::Ordering::Relaxed) {
            0 => None,
            ns => Some(Duration::from_nanos(ns)),
        };
        let result = match timeout {
            // The watchdog fails the instance once the instant its timeout ends at is over, so
            // the restart lands at the same place in a run and in its replay (see
            // `end_of_instant`).
            Some(t) => tokio::select! {
                biased;
                r = work => r,
                () = async {
                    tokio::time::sleep(t).await;
                    crate::clock::end_of_instant().await;
                } => {
                    faults.detected(name, "hung");
                    return Err(
                        format!("a handler of '{name}' ran longer than {t:?}: failing the instance").into()
                    );
                }
            },
            None => work.await,
        };
        if result.is_err() {
            faults.detected(name, "failed");
        }
        result
    }
}

impl<C: Component> Actor for Instance<C> {
    type Msg = Envelope<C::Msg>;
    type State = C::State;
    type Arguments = ();

    async fn pre_start(
        &self,
        myself: ActorRef<Envelope<C::Msg>>,
        _: (),
    ) -> Result<C::State, ActorProcessingErr> {
        if self.ctx.shell.removed.load(std::sync::atomic::Ordering::Acquire) {
            return Err(format!("component '{}' was removed from the system", self.ctx.name()).into());
        }
        // A failed or killed instance does not run post_stop: end its activities here.
        self.ctx.end_activities();
        self.ctx.shell.mailbox.bind(myself);
        self.component.setup(&self.ctx).await
    }

    /// The future ractor keeps for a message is a pointer to the handler's own, boxed. ractor
    /// moves a handler's future by value more than once per message (into its select with the
    /// signal port, then into the actor's task), and each move copies the whole type, not just
    /// the state in use. Inline, with the handler timeout and the component's own future, an
    /// actor's loop future was 1.1 KB for a trivial component, 1.4 KB for a behaviour, 2.3 KB
    /// for the robot server and 4.2 KB for the master; now it is 752 bytes for every component
    /// (ractor's own part). The allocation costs about what it saves for a trivial handler and
    /// less for the robot's; at many robots, where the copied lines were cold, much less
    /// (BENCHMARKS.md).
    fn handle(
        &self,
        _myself: ActorRef<Envelope<C::Msg>>,
        envelope: Envelope<C::Msg>,
        state: &mut C::State,
    ) -> impl Future<Output = Result<(), ActorProcessingErr>> + Send {
        // A superseded update is dropped here, with nothing allocated.
        let work = envelope.open().map(|msg| Box::pin(self.run(msg, state)));
        async move {
            match work {
                Some(work) => work.await,
                None => Ok(()),
            }
        }
    }

    async fn post_stop(
        &self,
        myself: ActorRef<Envelope<C::Msg>>,
        state: &mut C::State,
    ) -> Result<(), ActorProcessingErr> {
        self.ctx.end_activities();
        self.component.teardown(&self.ctx, state).await;
        self.ctx.shell.mailbox.unbind(&myself);
        Ok(())
    }
}

/// A component that is part of a system: its shell and the way to start instances of it.
pub struct ComponentHandle<C: Component> {
    component: Arc<C>,
    ctx: Ctx<C::Msg>,
}

impl<C: Component> Clone for ComponentHandle<C> {
    fn clone(&self) -> Self {
        ComponentHandle { component: Arc::clone(&self.component), ctx: self.ctx.clone() }
    }
}

impl<C: Component> ComponentHandle<C> {
    /// Adds a component named `name` to the system without starting it: its state and wiring
    /// services exist from now on.
    pub fn new(registry: &Registry, name: &str, component: C) -> PatternResult<Self> {
        Ok(ComponentHandle { component: Arc::new(component), ctx: Ctx::new(registry, name)? })
    }

    /// Fails the running instance (so its supervisor restarts it) when one handler runs longer
    /// than `timeout`: the watchdog for hung handlers. Off unless set.
    pub fn with_handler_timeout(self, timeout: Duration) -> Self {
        let ns = u64::try_from(timeout.as_nanos()).unwrap_or(u64::MAX).max(1);
        self.ctx.shell.handler_timeout_ns.store(ns, std::sync::atomic::Ordering::Relaxed);
        self
    }

    /// Starts an instance, linked to `supervisor` if given. A supervisor calls this again to
    /// restart the component.
    pub async fn start(&self, supervisor: Option<ActorCell>) -> Result<ActorCell, ractor::SpawnErr> {
        let instance = Instance { component: Arc::clone(&self.component), ctx: self.ctx.clone() };
        let (actor, _join) = match supervisor {
            Some(sup) => Actor::spawn_linked(None, instance, (), sup).await?,
            None => Actor::spawn(None, instance, ()).await?,
        };
        Ok(actor.get_cell())
    }

    /// A child spec that makes a supervisor start (and restart) this component; the child's id
    /// is the component's name. Permanent, with a 5 s shutdown timeout, unless changed with the
    /// spec's `with_restart` / `with_shutdown`.
    pub fn child_spec(&self) -> ChildSpec {
        let handle = self.clone();
        ChildSpec::new(self.name().to_string(), move |sup: ActorCell| {
            let handle = handle.clone();
            Box::pin(async move { handle.start(Some(sup)).await })
        })
    }

    /// The component's name.
    pub fn name(&self) -> &str {
        self.ctx.name()
    }

    /// The component's context (as its instances see it).
    pub fn ctx(&self) -> &Ctx<C::Msg> {
        &self.ctx
    }

    /// The running instance, if any.
    pub fn instance(&self) -> Option<ActorCell> {
        self.ctx.myself()
    }

    /// Removes the component from the system and stops its running instance gracefully. A
    /// supervisor cannot start it again: to stop a supervised component for a while, use the
    /// supervisor's `terminate_child`.
    pub async fn stop(&self) {
        let running = self.ctx.myself();
        self.remove();
        if let Some(actor) = running {
            // An instance that is already gone has nothing to stop.
            let _ = actor.stop_and_wait(None, None).await;
        }
    }

    /// Removes the component from the system: no instance can start any more, its timed
    /// services stop, its subscriptions and event activations end, its services are
    /// unregistered and its mailbox is closed. The running instance, if any, is not touched.
    pub fn remove(&self) {
        let shell = &self.ctx.shell;
        shell.removed.store(true, std::sync::atomic::Ordering::Release);
        for stop in shell.stoppers.lock().iter() {
            stop();
        }
        shell.declared.lock().clear();
        shell.registry.faults().unregister(self.ctx.name());
        shell.registry.unregister_component(self.ctx.name());
        shell.mailbox.close();
    }
}

/// Adds a component to the system and starts one unsupervised instance of it.
pub async fn spawn<C: Component>(
    registry: &Registry,
    name: &str,
    component: C,
) -> PatternResult<ComponentHandle<C>> {
    let handle = ComponentHandle::new(registry, name, component)?;
    if let Err(e) = handle.start(None).await {
        handle.remove();
        return Err(PatternError::Unavailable(ServiceAddr::new(name, format!("(start failed: {e})"))));
    }
    Ok(handle)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A component whose handler keeps 4 KiB across an await, so its future is that large.
    struct Big;

    impl Component for Big {
        type Msg = u8;
        type State = u64;

        async fn setup(&self, _ctx: &Ctx<u8>) -> Result<u64, ComponentError> {
            Ok(0)
        }

        async fn handle(&self, _ctx: &Ctx<u8>, sum: &mut u64, msg: u8) -> Result<(), ComponentError> {
            let buf = [msg; 4096];
            tokio::task::yield_now().await;
            *sum += std::hint::black_box(&buf).iter().map(|&b| u64::from(b)).sum::<u64>();
            Ok(())
        }
    }

    #[tokio::test]
    async fn the_future_ractor_moves_per_message_is_small_whatever_the_handler() {
        let registry = Registry::new();
        let handle = ComponentHandle::new(&registry, "big", Big).expect("component");
        let cell = handle.start(None).await.expect("started");
        let me = ActorRef::<Envelope<u8>>::from(cell.clone());
        let instance = Instance { component: Arc::clone(&handle.component), ctx: handle.ctx.clone() };
        let mut sum = 0u64;
        let work = instance.handle(me, Envelope::loose(2), &mut sum);
        let size = std::mem::size_of_val(&work);
        assert!(size <= 64, "ractor would copy {size} bytes per move of this handler's future");
        work.await.expect("handled");
        assert_eq!(sum, 2 * 4096, "the handler ran to its end");
        cell.stop(None);
    }
}
