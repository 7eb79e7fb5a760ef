//! **State**: a master configures a slave component by main states made of substates.
//!
//! Semantics (SmartSoft's state pattern):
//! - A component declares its main states, each a set of substates ([`StateSpec`]). `neutral`
//!   always exists and contains no substate; a component starts in its initial state
//!   (`neutral` unless declared otherwise).
//! - Its activities protect critical sections by [`acquire`](StateHandle::acquire)-ing a
//!   substate: this waits until the current main state contains it, and holds it until the
//!   returned guard is dropped.
//! - A master asks for another main state ([`StateMaster::set_state`]). The change takes effect
//!   once every substate the new main state excludes is released; meanwhile no activity can
//!   acquire an excluded substate, so the change cannot be starved. The master waits for it
//!   ([`StateMaster::set_state`], or [`StateMaster::set_state_timeout`] which withdraws the
//!   request on [`PatternError::Timeout`]), or with [`StateMaster::try_set_state`] gets
//!   [`PatternError::Busy`] at once instead. A master that stops waiting withdraws its request.
//! - [`StateMaster::deactivate`] first aborts every blocking call the component is making
//!   (queries, `get_update_wait`, event waits, `acquire`) with [`PatternError::Cancelled`], then
//!   moves it to `neutral`.
//!
//! ```
//! # use orsa_actors::{Registry, state::{StateMaster, StateSlave, StateSpec}};
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let spec = StateSpec::new().main_state("active", &["drive"]);
//! let slave = StateSlave::register(&registry, "wallfollow", spec)?;
//! let master = StateMaster::connect(&registry, "wallfollow")?;
//!
//! assert!(slave.handle().try_acquire("drive").is_err()); // neutral: no driving
//! master.set_state("active").await?;
//! let guard = slave.handle().acquire("drive").await?;    // critical section
//! assert!(master.try_set_state("neutral").await.is_err()); // busy while "drive" is held
//! drop(guard);
//! master.try_set_state("neutral").await?;
//! # Ok(()) }
//! ```

use crate::addr::{PatternKind, ServiceAddr, ServiceInfo};
use crate::comm_object;
use crate::error::{PatternError, PatternResult};
use crate::registry::{Registry, Remote, Resolved};
use crate::transport::{DEFAULT_REQUEST_TIMEOUT, Served};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;

/// The name of the main state every component has, with no substates.
pub const NEUTRAL: &str = "neutral";

/// A token that aborts blocking calls when the component that owns it is deactivated.
#[derive(Debug, Clone)]
pub struct Cancel {
    rx: watch::Receiver<u64>,
}

impl Cancel {
    /// Runs `fut`, aborting it with [`PatternError::Cancelled`] if a deactivation happens first.
    pub async fn guard<T>(&self, fut: impl Future<Output = PatternResult<T>>) -> PatternResult<T> {
        let mut rx = self.rx.clone();
        rx.borrow_and_update();
        let cancelled = async move {
            if rx.changed().await.is_err() {
                // The component is gone: nothing can deactivate it any more.
                std::future::pending::<()>().await;
            }
        };
        tokio::select! {
            biased;
            () = cancelled => Err(PatternError::Cancelled),
            r = fut => r,
        }
    }
}

/// The main states of a component, each a set of substates.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateSpec {
    main: BTreeMap<String, BTreeSet<String>>,
    initial: String,
}

impl Default for StateSpec {
    fn default() -> Self {
        let mut main = BTreeMap::new();
        main.insert(NEUTRAL.to_string(), BTreeSet::new());
        StateSpec { main, initial: NEUTRAL.to_string() }
    }
}

impl StateSpec {
    /// A spec with only `neutral`.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a main state made of `substates`.
    pub fn main_state(mut self, name: &str, substates: &[&str]) -> Self {
        self.main.insert(name.to_string(), substates.iter().map(|s| s.to_string()).collect());
        self
    }

    /// Sets the main state the component starts in (it must be declared).
    pub fn initial(mut self, name: &str) -> Self {
        self.initial = name.to_string();
        self
    }

    fn check(&self) -> PatternResult<()> {
        if self.main.contains_key(&self.initial) {
            Ok(())
        } else {
            Err(PatternError::Unknown { kind: "initial main state", name: self.initial.clone() })
        }
    }
}

/// Where a component's state stands, as a master sees it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateStatus {
    /// The current main state.
    pub current: String,
    /// A main state asked for that waits for substates to be released.
    pub pending: Option<String>,
    /// Substates held now, with how many activities hold each.
    pub held: BTreeMap<String, usize>,
    /// The declared main states and their substates.
    pub main_states: BTreeMap<String, BTreeSet<String>>,
}
comm_object!(StateStatus, "orsa.StateStatus/1");

mod inner;
use inner::Inner;

/// The slave side of the State pattern: one per component, registered as `component/state`.
pub struct StateSlave {
    addr: ServiceAddr,
    topic: String,
    tap: crate::tap::TapSlot,
    clock: crate::clock::Clock,
    inner: Mutex<Inner>,
    version: watch::Sender<u64>,
    cancel: watch::Sender<u64>,
    change: tokio::sync::Mutex<()>,
}

/// Held substate: released when dropped.
#[must_use = "the substate is released when the guard is dropped"]
pub struct SubstateGuard {
    slave: Arc<StateSlave>,
    sub: Arc<str>,
}

impl std::fmt::Debug for SubstateGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SubstateGuard({})", self.sub)
    }
}

impl Drop for SubstateGuard {
    fn drop(&mut self) {
        // Only a main-state change waiting for substates to be released needs to hear of it;
        // it set `pending` under the same lock before it looked at what is held.
        let released_for_change = {
            let mut inner = self.slave.inner.lock();
            let mut last = false;
            let subs = inner.subs_mut();
            if let Some(i) = subs.iter().position(|s| Arc::ptr_eq(&s.name, &self.sub)) {
                let sub = &mut subs[i];
                sub.held = sub.held.saturating_sub(1);
                last = sub.held == 0;
                if last && !sub.known() {
                    subs.swap_remove(i); // declared no more, and now released
                }
            }
            last && inner.pending().is_some()
        };
        if released_for_change {
            self.slave.bump();
        }
    }
}

pub(crate) fn info() -> ServiceInfo {
    ServiceInfo::new(PatternKind::State, &[StateStatus::ID])
}
use crate::CommObject as _;

impl StateSlave {
    /// Registers the state service of `component` with its main states.
    pub fn register(registry: &Registry, component: &str, spec: StateSpec) -> PatternResult<Arc<Self>> {
        spec.check()?;
        let addr = ServiceAddr::new(component, "state");
        let slave = Arc::new(StateSlave {
            topic: addr.to_string(),
            tap: registry.tap_slot(),
            clock: registry.clock(),
            addr: addr.clone(),
            inner: Mutex::new(Inner::new(spec)),
            version: watch::Sender::new(0),
            cancel: watch::Sender::new(0),
            change: tokio::sync::Mutex::new(()),
        });
        registry.register_service(addr, info(), slave.clone(), slave.clone())?;
        Ok(slave)
    }

    /// Replaces the declared main states (a component re-declaring them after a restart). The
    /// current state is kept if it still exists.
    pub fn declare(&self, spec: StateSpec) -> PatternResult<()> {
        spec.check()?;
        let mut inner = self.inner.lock();
        inner.set_spec(spec);
        drop(inner);
        self.bump();
        Ok(())
    }

    /// The activity-side handle.
    pub fn handle(self: &Arc<Self>) -> StateHandle {
        StateHandle { slave: Arc::clone(self) }
    }

    /// A token that aborts blocking calls on deactivation.
    pub fn cancel_token(&self) -> Cancel {
        Cancel { rx: self.cancel.subscribe() }
    }

    /// Shows the tap the state as it now stands (topic `component/state`).
    fn record(&self) {
        let status = self.status();
        self.tap.record(&self.topic, StateStatus::ID, self.clock.now(), &status);
    }

    /// The current main state.
    pub(crate) fn current(&self) -> String {
        self.inner.lock().current().to_string()
    }

    fn bump(&self) {
        self.version.send_modify(|v| *v += 1);
    }

    fn status(&self) -> StateStatus {
        let inner = self.inner.lock();
        StateStatus {
            current: inner.current().to_string(),
            pending: inner.pending().map(str::to_string),
            held: inner.subs().iter().filter(|s| s.held > 0).map(|s| (s.name.to_string(), s.held)).collect(),
            main_states: inner.spec().main.clone(),
        }
    }

    pub(crate) fn check_main(&self, name: &str) -> PatternResult<()> {
        if self.inner.lock().spec().main.contains_key(name) {
            Ok(())
        } else {
            Err(PatternError::Unknown {
                kind: "main state",
                name: format!("{name}' of '{}", self.addr.component),
            })
        }
    }

    pub(crate) async fn set(&self, main: &str) -> PatternResult<()> {
        self.check_main(main)?;
        let _one_change_at_a_time = self.change.lock().await;
        {
            let mut inner = self.inner.lock();
            inner.set_pending(Some(main.to_string()));
        }
        self.bump();
        // If the master stops waiting (timeout, select, abort), the change is withdrawn, so
        // substates it would have excluded can be acquired again.
        let mut withdraw = Withdraw { slave: self, armed: true };
        loop {
            let mut version = self.version.subscribe();
            {
                let mut inner = self.inner.lock();
                if inner.blocking(main).is_empty() {
                    inner.enter(main, true);
                    drop(inner);
                    withdraw.armed = false;
                    self.bump();
                    self.record();
                    return Ok(());
                }
            }
            if version.changed().await.is_err() {
                return Err(PatternError::Unavailable(self.addr.clone()));
            }
        }
    }

    pub(crate) fn try_set(&self, main: &str) -> PatternResult<()> {
        self.check_main(main)?;
        let Ok(_one_change_at_a_time) = self.change.try_lock() else {
            return Err(PatternError::Busy(vec!["(another state change is in progress)".into()]));
        };
        let mut inner = self.inner.lock();
        let blocking = inner.blocking(main);
        if !blocking.is_empty() {
            return Err(PatternError::Busy(blocking));
        }
        inner.enter(main, false);
        drop(inner);
        self.bump();
        self.record();
        Ok(())
    }

    async fn deactivate(&self) -> PatternResult<()> {
        self.cancel.send_modify(|v| *v += 1);
        self.set(NEUTRAL).await
    }
}

/// Withdraws a pending main-state change whose master stopped waiting.
struct Withdraw<'a> {
    slave: &'a StateSlave,
    armed: bool,
}

impl Drop for Withdraw<'_> {
    fn drop(&mut self) {
        if self.armed {
            let mut inner = self.slave.inner.lock();
            inner.set_pending(None);
            drop(inner);
            self.slave.bump();
        }
    }
}

/// What a component's activities use: acquire and release substates, read the state.
#[derive(Clone)]
pub struct StateHandle {
    slave: Arc<StateSlave>,
}

impl StateHandle {
    /// Waits until the current main state contains `substate`, then holds it until the guard
    /// is dropped. Aborted with [`PatternError::Cancelled`] by a deactivation.
    pub async fn acquire(&self, substate: &str) -> PatternResult<SubstateGuard> {
        let cancel = self.slave.cancel_token();
        cancel
            .guard(async {
                loop {
                    let mut version = self.slave.version.subscribe();
                    if let Some(guard) = self.grab(substate)? {
                        return Ok(guard);
                    }
                    if version.changed().await.is_err() {
                        return Err(PatternError::Unavailable(self.slave.addr.clone()));
                    }
                }
            })
            .await
    }

    /// Holds `substate` if the current main state allows it now; `NotActive` otherwise.
    pub fn try_acquire(&self, substate: &str) -> PatternResult<SubstateGuard> {
        self.grab(substate)?.ok_or_else(|| {
            PatternError::NotActive(format!("substate '{substate}' is not part of the current main state"))
        })
    }

    fn grab(&self, substate: &str) -> PatternResult<Option<SubstateGuard>> {
        let mut inner = self.slave.inner.lock();
        let Some(sub) = inner.subs_mut().iter_mut().find(|s| s.known() && &*s.name == substate) else {
            return Err(PatternError::Unknown { kind: "substate", name: substate.to_string() });
        };
        if !sub.allowed() {
            return Ok(None);
        }
        sub.held += 1;
        Ok(Some(SubstateGuard { slave: Arc::clone(&self.slave), sub: Arc::clone(&sub.name) }))
    }

    /// The current main state.
    pub fn current(&self) -> String {
        self.slave.inner.lock().current().to_string()
    }

    /// Whether the current main state contains `substate`.
    pub fn is_active(&self, substate: &str) -> bool {
        self.slave.inner.lock().allows(substate)
    }

    /// The token that aborts this component's blocking calls on deactivation.
    pub fn cancel_token(&self) -> Cancel {
        self.slave.cancel_token()
    }

    /// Waits until the main state changes, then returns the new one.
    pub async fn changed(&self) -> String {
        let mut version = self.slave.version.subscribe();
        let before = self.current();
        loop {
            if version.changed().await.is_err() {
                return self.current();
            }
            let now = self.current();
            if now != before {
                return now;
            }
        }
    }
}

/// A master's request to a state slave in another process; every one is answered with the
/// slave's [`StateStatus`] after it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum StateRequest {
    /// Ask for a main state and wait at most `timeout_ms` for it to take effect.
    Set {
        /// The main state.
        main: String,
        /// How long to wait, in milliseconds.
        timeout_ms: u64,
    },
    /// Switch at once or answer `busy`.
    TrySet {
        /// The main state.
        main: String,
    },
    /// Abort blocking calls, then move to `neutral` (waiting at most `timeout_ms`).
    Deactivate {
        /// How long to wait, in milliseconds.
        timeout_ms: u64,
    },
    /// Only the status.
    Status,
}

impl Served for StateSlave {
    fn serve_request(self: Arc<Self>, payload: &[u8]) -> futures::future::BoxFuture<'static, Vec<u8>> {
        let request = crate::wire::decode::<StateRequest>(payload, "orsa.StateRequest/1");
        Box::pin(async move {
            let done = match request {
                Err(e) => Err(PatternError::Decode(format!("to {}: {e}", self.addr))),
                Ok(StateRequest::Set { main, timeout_ms }) => {
                    tokio::time::timeout(Duration::from_millis(timeout_ms), self.set(&main))
                        .await
                        .unwrap_or(Err(PatternError::Timeout))
                }
                Ok(StateRequest::TrySet { main }) => self.try_set(&main),
                Ok(StateRequest::Deactivate { timeout_ms }) => {
                    tokio::time::timeout(Duration::from_millis(timeout_ms), self.deactivate())
                        .await
                        .unwrap_or(Err(PatternError::Timeout))
                }
                Ok(StateRequest::Status) => Ok(()),
            };
            crate::wire::encode(&crate::wire::Reply::from_result(done.map(|()| self.status())))
        })
    }
}

#[derive(Clone)]
enum Via {
    Local(Arc<StateSlave>),
    Remote(Remote),
}

/// The master side of the State pattern, for one slave component, in this process or another.
#[derive(Clone)]
pub struct StateMaster {
    component: String,
    via: Via,
}

fn millis(d: Duration) -> u64 {
    u64::try_from(d.as_millis()).unwrap_or(u64::MAX)
}

impl StateMaster {
    /// Connects to the state service of `component`.
    pub fn connect(registry: &Registry, component: &str) -> PatternResult<Self> {
        let addr = ServiceAddr::new(component, "state");
        let via = match registry.resolve::<StateSlave>(&addr, &info())? {
            Resolved::Local(s) => Via::Local(s),
            Resolved::Remote(r) => Via::Remote(r),
        };
        Ok(StateMaster { component: component.to_string(), via })
    }

    async fn remote(r: &Remote, request: StateRequest, timeout: Duration) -> PatternResult<StateStatus> {
        // The slave bounds its own wait; the link gets a second more to bring the answer back.
        let bytes = r
            .transport
            .request(&r.addr, crate::wire::encode(&request), timeout + Duration::from_secs(1))
            .await?;
        r.counted(crate::wire::decode_reply::<StateStatus>(&bytes, &r.addr, "orsa.StateStatus/1"))
    }

    /// Asks for main state `main` and waits until it takes effect (for a slave in another
    /// process, at most [`DEFAULT_REQUEST_TIMEOUT`]).
    pub async fn set_state(&self, main: &str) -> PatternResult<()> {
        match &self.via {
            Via::Local(s) => s.set(main).await,
            Via::Remote(_) => self.set_state_timeout(main, DEFAULT_REQUEST_TIMEOUT).await,
        }
    }

    /// Asks for main state `main` and waits at most `timeout` for it to take effect; on
    /// [`PatternError::Timeout`] the request is withdrawn and the state is unchanged.
    pub async fn set_state_timeout(&self, main: &str, timeout: Duration) -> PatternResult<()> {
        match &self.via {
            Via::Local(s) => {
                tokio::time::timeout(timeout, s.set(main)).await.map_err(|_| PatternError::Timeout)?
            }
            Via::Remote(r) => {
                let req = StateRequest::Set { main: main.to_string(), timeout_ms: millis(timeout) };
                Self::remote(r, req, timeout).await.map(|_| ())
            }
        }
    }

    /// Switches to `main` at once, or answers [`PatternError::Busy`] with the held substates it
    /// excludes (and changes nothing).
    pub async fn try_set_state(&self, main: &str) -> PatternResult<()> {
        match &self.via {
            Via::Local(s) => s.try_set(main),
            Via::Remote(r) => {
                let req = StateRequest::TrySet { main: main.to_string() };
                Self::remote(r, req, DEFAULT_REQUEST_TIMEOUT).await.map(|_| ())
            }
        }
    }

    /// Aborts the component's blocking calls with `Cancelled`, then moves it to `neutral`.
    pub async fn deactivate(&self) -> PatternResult<()> {
        match &self.via {
            Via::Local(s) => s.deactivate().await,
            Via::Remote(r) => {
                let req = StateRequest::Deactivate { timeout_ms: millis(DEFAULT_REQUEST_TIMEOUT) };
                Self::remote(r, req, DEFAULT_REQUEST_TIMEOUT).await.map(|_| ())
            }
        }
    }

    /// The slave's current state, pending change, held substates and declared main states.
    pub async fn status(&self) -> PatternResult<StateStatus> {
        match &self.via {
            Via::Local(s) => Ok(s.status()),
            Via::Remote(r) => Self::remote(r, StateRequest::Status, DEFAULT_REQUEST_TIMEOUT).await,
        }
    }

    /// The component this master configures.
    pub fn component(&self) -> &str {
        &self.component
    }
}
