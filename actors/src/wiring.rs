//! **Wiring**: a master reconnects a component's client ports at run time.
//!
//! Semantics: a component declares wireable client ports ([`SendPort`], [`QueryPort`]), each
//! typed by its communication objects and disconnected at first. A master connects a port to a
//! `(component, service)` or disconnects it ([`WiringMaster`]). Connecting checks the target:
//! an unknown port answers [`PatternError::UnknownPort`], an unknown service
//! [`PatternError::UnknownService`] (an unknown component [`PatternError::UnknownComponent`]), a
//! service of another pattern or type
//! [`PatternError::IncompatibleService`] (and the port keeps its old connection). Sending on a
//! disconnected port answers [`PatternError::Disconnected`]. Rewiring while traffic flows never
//! deadlocks, and once [`WiringMaster::disconnect`] (or a reconnect) has returned, no message
//! goes out through the old connection: a send holds the port's connection for the instant it
//! hands its message over, and a rewire waits for that instant to pass.
//!
//! This is how the executive arbitrates behaviours: every behaviour computes all the time and
//! sends on its `vel` port, and the master wires exactly one of those ports to the robot.
//!
//! ```
//! # use orsa_actors::{Registry, Sink, PatternError, send::SendServer, wiring::{WiringMaster, WiringSlave}};
//! # use orsa_actors::service::{SendPortDesc, SendService};
//! const SPEED: SendService<f64> = SendService::new("speed");
//! const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
//! # #[tokio::main(flavor = "current_thread")] async fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let registry = Registry::new();
//! let (tx, _rx) = tokio::sync::mpsc::unbounded_channel();
//! SendServer::register(&registry, SPEED.on("robot"), Sink::channel(tx))?;
//! let wiring = WiringSlave::register(&registry, "behaviour")?;
//! let port = wiring.send_port::<f64>(VEL.name())?;
//!
//! assert!(matches!(port.send(0.1), Err(PatternError::Disconnected(_))));
//! let master = WiringMaster::new(&registry);
//! master.connect("behaviour", VEL, SPEED.on("robot")).await?; // a port of f64 to a service of f64
//! port.send(0.1)?;
//! master.disconnect("behaviour", VEL).await?;
//! assert!(matches!(port.send(0.1), Err(PatternError::Disconnected(_))));
//! # Ok(()) }
//! ```

use crate::addr::{IntoAddr, PatternKind, ServiceAddr, ServiceInfo};
use crate::comm::CommObject;
use crate::error::{PatternError, PatternResult};
use crate::query::{PendingQuery, QueryClient};
use crate::registry::{Registry, Resolved};
use crate::send::SendClient;
use crate::service::PortDescriptor;
use crate::stamped::Stamped;
use crate::state::Cancel;
use crate::transport::{DEFAULT_REQUEST_TIMEOUT, Served};
use parking_lot::RwLock;
use serde::{Deserialize, Serialize};
use std::any::Any;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// A port as a master sees it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PortStatus {
    /// The port's name within its component.
    pub port: String,
    /// The pattern and communication objects the port expects of a service.
    pub info: ServiceInfo,
    /// Where it is connected, if anywhere.
    pub target: Option<ServiceAddr>,
}
crate::comm_object!(PortStatus, "orsa.PortStatus/1");

trait Port: Send + Sync {
    fn info(&self) -> ServiceInfo;
    fn connect(&self, registry: &Registry, target: &ServiceAddr) -> PatternResult<()>;
    fn disconnect(&self);
    fn target(&self) -> Option<ServiceAddr>;
    fn as_any(&self) -> &dyn Any;
}

/// A wireable Send client port.
pub struct SendPort<T> {
    name: String,
    conn: Arc<RwLock<Option<SendClient<T>>>>,
}

impl<T> Clone for SendPort<T> {
    fn clone(&self) -> Self {
        SendPort { name: self.name.clone(), conn: Arc::clone(&self.conn) }
    }
}

impl<T: CommObject> SendPort<T> {
    /// Sends on the port: [`PatternError::Disconnected`] if it is not wired.
    pub fn send(&self, value: T) -> PatternResult<()> {
        match self.conn.read().as_ref() {
            Some(client) => client.send(value),
            None => Err(PatternError::Disconnected(self.name.clone())),
        }
    }

    /// Forwards an already stamped message unchanged.
    pub fn send_stamped(&self, msg: Stamped<T>) -> PatternResult<()> {
        match self.conn.read().as_ref() {
            Some(client) => client.send_stamped(msg),
            None => Err(PatternError::Disconnected(self.name.clone())),
        }
    }

    /// Where the port is connected.
    pub fn target(&self) -> Option<ServiceAddr> {
        self.conn.read().as_ref().map(|c| c.addr().clone())
    }

    /// The port's name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

impl<T: CommObject> Port for SendPort<T> {
    fn info(&self) -> ServiceInfo {
        crate::send::info::<T>()
    }
    fn connect(&self, registry: &Registry, target: &ServiceAddr) -> PatternResult<()> {
        let client = SendClient::<T>::connect(registry, target)?;
        *self.conn.write() = Some(client);
        Ok(())
    }
    fn disconnect(&self) {
        *self.conn.write() = None;
    }
    fn target(&self) -> Option<ServiceAddr> {
        SendPort::target(self)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// A wireable Query client port.
pub struct QueryPort<Req, Ans> {
    name: String,
    conn: Arc<RwLock<Option<QueryClient<Req, Ans>>>>,
    cancel: Option<Cancel>,
}

impl<Req, Ans> Clone for QueryPort<Req, Ans> {
    fn clone(&self) -> Self {
        QueryPort { name: self.name.clone(), conn: Arc::clone(&self.conn), cancel: self.cancel.clone() }
    }
}

impl<Req: CommObject, Ans: CommObject> QueryPort<Req, Ans> {
    /// Sends a request on the port now; collect the answer later.
    pub fn request(&self, request: Req) -> PatternResult<PendingQuery<Ans>> {
        match self.conn.read().as_ref() {
            Some(client) => client.request(request),
            None => Err(PatternError::Disconnected(self.name.clone())),
        }
    }

    /// Queries on the port and waits for the answer, at most `timeout` if given. The request
    /// goes out on the connection current when it is made; a rewire meanwhile does not move it.
    pub async fn query(&self, request: Req, timeout: Option<Duration>) -> PatternResult<Ans> {
        self.request(request)?.receive(timeout).await
    }

    /// Where the port is connected.
    pub fn target(&self) -> Option<ServiceAddr> {
        self.conn.read().as_ref().map(|c| c.addr().clone())
    }
}

impl<Req: CommObject, Ans: CommObject> Port for QueryPort<Req, Ans> {
    fn info(&self) -> ServiceInfo {
        crate::query::info::<Req, Ans>()
    }
    fn connect(&self, registry: &Registry, target: &ServiceAddr) -> PatternResult<()> {
        let mut client = QueryClient::<Req, Ans>::connect(registry, target)?;
        if let Some(c) = &self.cancel {
            client = client.with_cancel(c.clone());
        }
        *self.conn.write() = Some(client);
        Ok(())
    }
    fn disconnect(&self) {
        *self.conn.write() = None;
    }
    fn target(&self) -> Option<ServiceAddr> {
        QueryPort::target(self)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

pub(crate) fn info() -> ServiceInfo {
    ServiceInfo::new(PatternKind::Wiring, &[PortStatus::ID])
}

/// The slave side of Wiring: a component's table of ports, registered as `component/wiring`.
pub struct WiringSlave {
    component: String,
    topic: String,
    tap: crate::tap::TapSlot,
    registry: Registry,
    ports: RwLock<BTreeMap<String, Arc<dyn Port>>>,
    cancel: Option<Cancel>,
    also: RwLock<Option<AlsoServed>>,
}

/// More requests a wiring service answers for its process (a component's wiring service also
/// carries the switches of `crate::switch`): given a request, the answer's future, or `None`
/// if the request is not one of them.
pub(crate) type AlsoServed =
    Arc<dyn Fn(&[u8]) -> Option<futures::future::BoxFuture<'static, Vec<u8>>> + Send + Sync>;

impl WiringSlave {
    /// Registers the wiring service of `component`.
    pub fn register(registry: &Registry, component: &str) -> PatternResult<Arc<Self>> {
        Self::register_with_cancel(registry, component, None)
    }

    pub(crate) fn register_with_cancel(
        registry: &Registry,
        component: &str,
        cancel: Option<Cancel>,
    ) -> PatternResult<Arc<Self>> {
        let slave = Arc::new(WiringSlave {
            component: component.to_string(),
            topic: format!("{component}/wiring"),
            tap: registry.tap_slot(),
            registry: registry.clone(),
            ports: RwLock::new(BTreeMap::new()),
            cancel,
            also: RwLock::new(None),
        });
        registry.register_service(
            ServiceAddr::new(component, "wiring"),
            info(),
            slave.clone(),
            slave.clone(),
        )?;
        Ok(slave)
    }

    fn declare<P: Port + Clone + 'static>(&self, name: &str, make: impl FnOnce() -> P) -> PatternResult<P> {
        if !crate::addr::valid_name(name) {
            return Err(PatternError::InvalidArgument(format!("'{name}' is not a valid port name")));
        }
        let mut ports = self.ports.write();
        if let Some(existing) = ports.get(name) {
            // Declaring again (after a restart) gives back the same, still wired, port.
            return existing.as_any().downcast_ref::<P>().cloned().ok_or_else(|| {
                PatternError::AlreadyRegistered(format!(
                    "port '{name}' of '{}' with another type",
                    self.component
                ))
            });
        }
        let port = make();
        ports.insert(name.to_string(), Arc::new(port.clone()));
        Ok(port)
    }

    /// Declares (or gets back) a wireable Send port.
    pub fn send_port<T: CommObject>(&self, name: &str) -> PatternResult<SendPort<T>> {
        self.declare(name, || SendPort { name: name.to_string(), conn: Arc::new(RwLock::new(None)) })
    }

    /// Declares (or gets back) a wireable Query port.
    pub fn query_port<Req: CommObject, Ans: CommObject>(
        &self,
        name: &str,
    ) -> PatternResult<QueryPort<Req, Ans>> {
        let cancel = self.cancel.clone();
        self.declare(name, || QueryPort { name: name.to_string(), conn: Arc::new(RwLock::new(None)), cancel })
    }

    /// What port `name` expects of a service, and where it is connected.
    pub(crate) fn port_status(&self, name: &str) -> PatternResult<(ServiceInfo, Option<ServiceAddr>)> {
        let port = self.port(name)?;
        Ok((port.info(), port.target()))
    }

    fn port(&self, name: &str) -> PatternResult<Arc<dyn Port>> {
        self.ports.read().get(name).cloned().ok_or_else(|| PatternError::UnknownPort {
            component: self.component.clone(),
            port: name.to_string(),
        })
    }

    /// Connects port `name` to `target`.
    pub fn connect(&self, name: &str, target: &ServiceAddr) -> PatternResult<()> {
        let port = self.port(name)?;
        port.connect(&self.registry, target)?;
        self.record(name, port.as_ref());
        Ok(())
    }

    /// Disconnects port `name`.
    pub fn disconnect(&self, name: &str) -> PatternResult<()> {
        let port = self.port(name)?;
        port.disconnect();
        self.record(name, port.as_ref());
        Ok(())
    }

    /// Shows the tap a port as it now stands (topic `component/wiring`).
    fn record(&self, name: &str, port: &dyn Port) {
        let status = PortStatus { port: name.to_string(), info: port.info(), target: port.target() };
        self.tap.record(&self.topic, PortStatus::ID, self.registry.now(), &status);
    }

    /// Lets the service answer more requests from other processes (see [`AlsoServed`]).
    pub(crate) fn serve_also(&self, also: AlsoServed) {
        *self.also.write() = Some(also);
    }

    /// Every port with its connection.
    pub fn ports(&self) -> Vec<PortStatus> {
        self.ports
            .read()
            .iter()
            .map(|(name, p)| PortStatus { port: name.clone(), info: p.info(), target: p.target() })
            .collect()
    }
}

/// A master's request to a wiring slave in another process; every one is answered with the
/// slave's ports after it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum WiringRequest {
    /// Connect `port` to the service `target` (`component/service`).
    Connect {
        /// The port.
        port: String,
        /// The service.
        target: String,
    },
    /// Disconnect `port`.
    Disconnect {
        /// The port.
        port: String,
    },
    /// Only the ports.
    Ports,
}

impl Served for WiringSlave {
    fn serve_request(self: Arc<Self>, payload: &[u8]) -> futures::future::BoxFuture<'static, Vec<u8>> {
        let also = self.also.read().clone();
        if let Some(answer) = also.and_then(|also| also(payload)) {
            return answer;
        }
        let done = match crate::wire::decode::<WiringRequest>(payload, "orsa.WiringRequest/1") {
            Err(e) => Err(PatternError::Decode(format!("to {}: {e}", self.topic))),
            Ok(WiringRequest::Connect { port, target }) => {
                parse_target(&target).and_then(|t| self.connect(&port, &t))
            }
            Ok(WiringRequest::Disconnect { port }) => self.disconnect(&port),
            Ok(WiringRequest::Ports) => Ok(()),
        };
        let reply = crate::wire::encode(&crate::wire::Reply::from_result(done.map(|()| self.ports())));
        Box::pin(async move { reply })
    }
}

/// The master side of Wiring: reconnects ports of any component in the system, hosted in this
/// process or another.
#[derive(Clone, Debug)]
pub struct WiringMaster {
    registry: Registry,
}

impl WiringMaster {
    /// A wiring master for the components of `registry`.
    pub fn new(registry: &Registry) -> Self {
        WiringMaster { registry: registry.clone() }
    }

    async fn run(&self, component: &str, request: WiringRequest) -> PatternResult<Vec<PortStatus>> {
        let addr = ServiceAddr::new(component, "wiring");
        let resolved = match self.registry.resolve::<WiringSlave>(&addr, &info()) {
            Ok(r) => r,
            Err(PatternError::UnknownService(_)) => {
                return Err(PatternError::UnknownComponent(component.to_string()));
            }
            Err(e) => return Err(e),
        };
        match resolved {
            Resolved::Local(slave) => {
                match request {
                    WiringRequest::Connect { port, target } => {
                        slave.connect(&port, &parse_target(&target)?)?
                    }
                    WiringRequest::Disconnect { port } => slave.disconnect(&port)?,
                    WiringRequest::Ports => {}
                }
                Ok(slave.ports())
            }
            Resolved::Remote(r) => {
                let bytes = r
                    .transport
                    .request(&r.addr, crate::wire::encode(&request), DEFAULT_REQUEST_TIMEOUT)
                    .await?;
                r.counted(crate::wire::decode_reply::<Vec<PortStatus>>(
                    &bytes,
                    &r.addr,
                    "orsa.PortStatus/1 list",
                ))
            }
        }
    }

    /// Connects `component`'s port `port` to the service `target`: only a service of the kind
    /// the port sends to compiles.
    pub async fn connect<P: PortDescriptor>(
        &self,
        component: &str,
        port: P,
        target: impl IntoAddr<P::Target>,
    ) -> PatternResult<()> {
        self.connect_named(component, port.name(), &target.into_addr()).await
    }

    /// Connects `component`'s port named `port` to `target`, both as a person typed them (the
    /// command line, a config file): the slave checks the port and the service's type.
    pub async fn connect_named(
        &self,
        component: &str,
        port: &str,
        target: &ServiceAddr,
    ) -> PatternResult<()> {
        let target = target.to_string();
        self.run(component, WiringRequest::Connect { port: port.to_string(), target }).await.map(|_| ())
    }

    /// Disconnects `component`'s port `port`. When this returns, nothing more goes out on it.
    pub async fn disconnect(&self, component: &str, port: impl PortDescriptor) -> PatternResult<()> {
        self.disconnect_named(component, port.name()).await
    }

    /// Disconnects `component`'s port named `port`, as a person typed it.
    pub async fn disconnect_named(&self, component: &str, port: &str) -> PatternResult<()> {
        self.run(component, WiringRequest::Disconnect { port: port.to_string() }).await.map(|_| ())
    }

    /// The ports of `component` with their connections.
    pub async fn ports(&self, component: &str) -> PatternResult<Vec<PortStatus>> {
        self.run(component, WiringRequest::Ports).await
    }
}

/// The target of a wiring request as it travels (`component/service`), parsed.
fn parse_target(target: &str) -> PatternResult<ServiceAddr> {
    target.parse().map_err(|e: crate::addr::BadAddr| PatternError::InvalidArgument(e.to_string()))
}
