//! Control events a recording holds that are not pattern messages: what a process did on its
//! own (the robot's link watchdog) and when its fault plan's clock started. A replay feeds them
//! back at their recorded times (see [`crate::replay`]).

use serde::{Deserialize, Serialize};

/// Topic of the supervisors' events (failures, restarts, giving up), as `orsa.SupervisorEvent/1`.
pub const SUPERVISION_EVENTS: &str = "supervision/events";
/// Topic of the robot's link watchdog: an executive lost or back.
pub const LINK_EVENTS: &str = "link/events";
/// Communication object of [`LINK_EVENTS`].
pub const LINK_EVENT: &str = "orsa.LinkEvent/1";
/// Topic with one message, at the instant a process's fault plan started (its `at` 0), when
/// that is not the start of the run (`orsa robot --faults` starts it once on the network).
pub const FAULTS_STARTED: &str = "faults/started";
/// Communication object of [`FAULTS_STARTED`].
pub const FAULTS_STARTED_TYPE: &str = "orsa.FaultsStarted/1";

/// What the robot's link watchdog did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkEvent {
    /// The executive's zenoh id.
    pub executive: String,
    /// Lost (the robot unwired its behaviours and commanded zero), or back.
    pub event: LinkEventKind,
    /// Why, in words.
    pub why: String,
    /// The command it then sent the motors (zero, stamped by the live clock), if any: a replay
    /// sends it again, as it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<orsa_interfaces::nomad200::NavigationVelocity>,
}

/// See [`LinkEvent::event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkEventKind {
    /// The executive was lost: the motors were commanded to zero (the behaviours are unwired
    /// next).
    Lost,
    /// It was heard again.
    Back,
    /// After a loss, the behaviours were unwired and the motors commanded to zero again (in
    /// case a behaviour's command came in between).
    Unwired,
}

/// The message on [`FAULTS_STARTED`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultsStarted {
    /// Faults in the plan.
    pub faults: usize,
}

/// Topic noted just before a process starts its system (a replay starts it then).
pub const SYSTEM_STARTING: &str = "system/starting";
/// Communication object of [`SYSTEM_STARTING`].
pub const SYSTEM_STARTING_TYPE: &str = "orsa.SystemStarting/1";

/// The message on [`SYSTEM_STARTING`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystemStarting {
    /// The components the process starts.
    pub hosted: Vec<String>,
}

/// First segment of the topics of a process's exchange with services in other processes:
/// `exchange/KIND/COMPONENT/SERVICE`, KIND one of [`ExchangeKind`]'s names.
pub const EXCHANGE: &str = "exchange";
/// Communication object of every exchange topic.
pub const EXCHANGED_TYPE: &str = "orsa.Exchanged/1";

/// What crossed between this process and a service in another one, as the transport saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExchangeKind {
    /// A Send to it (made here: compared by a replay).
    Send,
    /// A request to it (made here: compared).
    Request,
    /// Its reply to a request (came in: fed).
    Reply,
    /// A subscription to it (made here: compared).
    Subscribe,
    /// One update of a subscription (came in: fed).
    Update,
    /// An activation of its event (made here: compared).
    Activate,
    /// One firing of an activation (came in: fed).
    Firing,
    /// What the transport said the service is (came in: fed).
    Lookup,
}

impl ExchangeKind {
    /// Every kind.
    pub const ALL: [ExchangeKind; 8] = [
        ExchangeKind::Send,
        ExchangeKind::Request,
        ExchangeKind::Reply,
        ExchangeKind::Subscribe,
        ExchangeKind::Update,
        ExchangeKind::Activate,
        ExchangeKind::Firing,
        ExchangeKind::Lookup,
    ];

    /// Its name in topics.
    pub fn name(self) -> &'static str {
        match self {
            ExchangeKind::Send => "send",
            ExchangeKind::Request => "request",
            ExchangeKind::Reply => "reply",
            ExchangeKind::Subscribe => "subscribe",
            ExchangeKind::Update => "update",
            ExchangeKind::Activate => "activate",
            ExchangeKind::Firing => "firing",
            ExchangeKind::Lookup => "lookup",
        }
    }

    /// Whether it came in from the other process (a replay feeds it) rather than was made
    /// here (a replay compares it).
    pub fn came_in(self) -> bool {
        matches!(
            self,
            ExchangeKind::Reply | ExchangeKind::Update | ExchangeKind::Firing | ExchangeKind::Lookup
        )
    }

    /// The topic of this kind of exchange with `service`.
    pub fn topic(self, service: &orsa_actors::ServiceAddr) -> String {
        format!("{EXCHANGE}/{}/{service}", self.name())
    }

    /// The kind and service of an exchange topic.
    pub fn of_topic(topic: &str) -> Option<(ExchangeKind, &str)> {
        let rest = topic.strip_prefix(EXCHANGE)?.strip_prefix('/')?;
        let (kind, service) = rest.split_once('/')?;
        ExchangeKind::ALL.into_iter().find(|k| k.name() == kind).map(|k| (k, service))
    }
}

/// One message of a process's exchange with another process's service (see [`ExchangeKind`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Exchanged {
    /// Which request (`Request`, `Reply`) or subscription or activation (`Subscribe`,
    /// `Update`, `Activate`, `Firing`) of this process to the service it belongs to, from 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n: Option<u64>,
    /// A subscription's every-n-th.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub every: Option<u32>,
    /// An activation's mode.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<orsa_actors::transport::EventMode>,
    /// The payload, decoded from CBOR (for people, and what a replay compares).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decoded: Option<serde_json::Value>,
    /// The payload as it crossed, CBOR in base64 (what a replay feeds back).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cbor: Option<String>,
    /// A request that got no reply: why, for people.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// A request that got no reply: the failure in its wire form (what a replay feeds back, so
    /// a replayed caller sees the same error as the recorded one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<orsa_actors::wire::WireFailure>,
    /// What the service is (`Lookup`; none: no peer offers it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub info: Option<orsa_actors::ServiceInfo>,
}

impl Exchanged {
    /// A payload, decoded for people (`None` if it is not CBOR that JSON can hold).
    pub fn decode(payload: &[u8]) -> Option<serde_json::Value> {
        orsa_actors::wire::decode::<serde_json::Value>(payload, "a payload").ok()
    }

    // What a process makes: one definition, so that a replay notes exactly what the recording
    // noted.

    /// A Send of `payload`.
    pub fn sent(payload: &[u8]) -> Exchanged {
        Exchanged { decoded: Exchanged::decode(payload), ..Exchanged::default() }
    }

    /// Request number `n`, of `payload`.
    pub fn request(n: u64, payload: &[u8]) -> Exchanged {
        Exchanged { n: Some(n), decoded: Exchanged::decode(payload), ..Exchanged::default() }
    }

    /// Subscription number `n`, to every `every`-th update.
    pub fn subscription(n: u64, every: u32) -> Exchanged {
        Exchanged { n: Some(n), every: Some(every), ..Exchanged::default() }
    }

    /// Activation number `n`, in `mode`, with `params`.
    pub fn activation(n: u64, mode: orsa_actors::transport::EventMode, params: &[u8]) -> Exchanged {
        Exchanged { n: Some(n), mode: Some(mode), decoded: Exchanged::decode(params), ..Exchanged::default() }
    }

    /// A payload that came in: decoded, and its bytes.
    pub fn came_in(payload: &[u8]) -> Exchanged {
        use base64::Engine as _;
        Exchanged {
            decoded: Exchanged::decode(payload),
            cbor: Some(base64::engine::general_purpose::STANDARD.encode(payload)),
            ..Exchanged::default()
        }
    }

    /// The bytes of a payload that came in.
    pub fn bytes(&self) -> Result<Vec<u8>, BadPayload> {
        use base64::Engine as _;
        let text = self.cbor.as_deref().ok_or_else(|| BadPayload("it has no 'cbor' payload".into()))?;
        base64::engine::general_purpose::STANDARD
            .decode(text)
            .map_err(|e| BadPayload(format!("its 'cbor' is not base64: {e}")))
    }
}

/// A recorded payload whose bytes cannot be read back (what is wrong with it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct BadPayload(pub String);
