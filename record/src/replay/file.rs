//! Reading a recording for a replay: its description, and its messages sorted into what the
//! replay feeds (the robot server's side) and what it compares (everything else).
//!
//! The whole file is checked before anything runs: its structure (MCAP magic, records,
//! channels), its `run` metadata and versions, the schema of every channel the replay feeds,
//! and every message it feeds (decoded into its communication object). Each error names the
//! file and, where there is one, the channel and the message's log time.

use super::ReplayError;
use crate::record::RunMeta;
use crate::record::events::{
    EXCHANGED_TYPE, ExchangeKind, Exchanged, FAULTS_STARTED, FAULTS_STARTED_TYPE, LINK_EVENT, LINK_EVENTS,
    LinkEvent, SUPERVISION_EVENTS, SYSTEM_STARTING, SYSTEM_STARTING_TYPE,
};
use crate::record::meta::RUN_METADATA;
use orsa_actors::param::{PARAM, ParamRequest};
use orsa_actors::state::StateStatus;
use orsa_actors::wiring::PortStatus;
use orsa_actors::{CommObject, Stamped, Timestamp};
use orsa_actors::{PatternError, ServiceAddr, ServiceInfo};
use orsa_interfaces::health::Health;
use orsa_interfaces::nomad200::{BaseState, ContactScan, DistanceScan, RobotParams, SafetyCounters};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The MCAP magic that opens and closes a file.
const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// One recorded message the replay compares.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recorded {
    /// Its log time, ns on the recording's clock.
    pub log_time: u64,
    /// Its JSON bytes, as recorded.
    pub data: Vec<u8>,
}

/// What the robot server published, in the order it published it: the replay publishes it
/// again at the same times.
#[derive(Debug, Clone, PartialEq)]
pub enum Published {
    /// An infrared scan (`distanceir`).
    Ir(DistanceScan),
    /// A sonar scan (`distanceson`).
    Sonar(DistanceScan),
    /// The bumpers (`bumpers`); the robot server also tests its `contact` events on them.
    Bumpers(ContactScan),
    /// The base state (`basestate`).
    Base(BaseState),
    /// The sensors' health (`health`); the robot server fires `healthchanges` with it too.
    Health(Health),
}

/// The recorded answers of the robot server's queries, in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Answers {
    /// `robotparams/answer`.
    pub robotparams: std::collections::VecDeque<RobotParams>,
    /// `safety/answer`.
    pub safety: std::collections::VecDeque<SafetyCounters>,
}

/// A control event that came from outside the replayed components, fed back at its recorded
/// time (recordings of `orsa robot`: the remote executive's wiring and state changes, and what
/// the robot's link watchdog did).
#[derive(Debug, Clone, PartialEq)]
pub enum Control {
    /// A behaviour's port was wired as this says.
    Port {
        /// The behaviour.
        component: String,
        /// The port as it then stood.
        status: PortStatus,
    },
    /// A behaviour's state was set (or asked for) as this says.
    State {
        /// The behaviour.
        component: String,
        /// The state as it then stood.
        status: StateStatus,
    },
    /// The link watchdog lost an executive (it unwired the behaviours and commanded zero) or
    /// heard it again.
    Link(LinkEvent),
    /// Someone asked a component for its parameters or set one.
    Param {
        /// The component.
        component: String,
        /// What was asked.
        request: ParamRequest,
        /// How many of the robot's publications came before it in the file: a replay asks
        /// after those and before the next, as it was.
        after: usize,
    },
}

/// A call of this process to a service in another process: the service, and the call's number
/// among this process's calls of its kind to it (from 0).
pub type Call = (ServiceAddr, u64);

/// Messages that came in, each with its arrival time (ns) and its bytes.
pub type Arrivals = Vec<(u64, Vec<u8>)>;

/// What came back to a process from services in other processes, as its transport saw it
/// (recordings of `orsa executive`): a replay's transport plays it back.
#[derive(Debug, Clone, Default)]
pub struct ExchangeLog {
    /// Per service: what each lookup said, from when (ns).
    pub lookups: HashMap<ServiceAddr, Vec<(u64, Option<ServiceInfo>)>>,
    /// Per service and request number: when the reply came, and its bytes or why none came.
    pub replies: HashMap<Call, (u64, Result<Vec<u8>, PatternError>)>,
    /// Per service and subscription number: each update, when it came, and its bytes.
    pub updates: HashMap<Call, Arrivals>,
    /// Per service and activation number: each firing, when it came, and its bytes.
    pub firings: HashMap<Call, Arrivals>,
}

impl ExchangeLog {
    /// Messages in it.
    pub fn len(&self) -> usize {
        self.lookups.values().map(Vec::len).sum::<usize>()
            + self.replies.len()
            + self.updates.values().map(Vec::len).sum::<usize>()
            + self.firings.values().map(Vec::len).sum::<usize>()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A recording, read and checked.
#[derive(Debug)]
pub struct Recording {
    /// The file.
    pub path: PathBuf,
    /// What it says about the run that made it.
    pub meta: RunMeta,
    /// What the robot server published, at its log time (ns), in file order.
    pub published: Vec<(u64, Published)>,
    /// The robot server's recorded answers.
    pub answers: Answers,
    /// Every other message, per topic, in file order: what the replay compares.
    pub outputs: BTreeMap<Arc<str>, Vec<Recorded>>,
    /// Control events from outside the replayed components, at their log times (ns).
    pub controls: Vec<(u64, Control)>,
    /// For each of `controls`, how many of the robot's publications came before it in the
    /// file: the replay keeps that order, whatever the timer's resolution (a live recording's
    /// log times are finer than the timer's millisecond).
    pub controls_after: Vec<usize>,
    /// For each control, in order: the outputs recorded before it of what it acts on (the
    /// component whose port or state it sets, its topics; for the link watchdog's command, the
    /// robot's velocity commands), per topic. A live replay applies a control once those are
    /// out, and not later: where a control came between a scan and a behaviour's step on it,
    /// the step sees it as it did.
    pub controls_outputs: Vec<Vec<(Arc<str>, usize)>>,
    /// For each control, in order: whether it went before the step of what it acts on, on the
    /// last publication before it (see the replay's `sequence` module). Live, a control can land between
    /// a scan and a behaviour's step on it, on another thread, or after that step; the
    /// recording shows which by what the behaviour made between the control and the next
    /// publication: an output there came from a step after the control (wiring, activation),
    /// and none after a deactivation says the step came after it too.
    pub controls_early: Vec<bool>,
    /// When the process's fault plan started, if not at the start (ns).
    pub plan_started: Option<u64>,
    /// When the process started its system, if not at the start (ns).
    pub system_starting: Option<u64>,
    /// What came back from services in other processes (recordings of `orsa executive`).
    pub exchange: ExchangeLog,
    /// Messages that came from outside the recording process and that nothing replayed
    /// makes (a teleop's commands, a tool's queries): neither fed nor compared.
    pub outside: u64,
    /// Messages of the views for Foxglove (protobuf channels): neither fed nor compared.
    pub views: u64,
    /// Supervisor events about the robot server (its own failures and restarts): the
    /// stand-in that replaces it has none, so they are neither fed nor compared.
    pub robot_events: u64,
    /// The schema name of each topic.
    pub schemas: BTreeMap<Arc<str>, String>,
    /// Every message's log time ends at or before this (ns).
    pub last_log_time: u64,
    /// When the run ended, before its components were shut down, if the recording says
    /// ([`RunEnded`](crate::record::meta::RunEnded)); it may lie well after the last message.
    pub ended: Option<crate::record::meta::RunEnded>,
    /// Messages read, in all.
    pub messages: u64,
}

/// Which of the robot server's topics the replay feeds, and how to decode them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Feed {
    Health,
    Ir,
    Sonar,
    Bumpers,
    Base,
    ParamsAnswer,
    SafetyAnswer,
    /// Made again by the replayed robot side (its events and its own control topics): neither
    /// fed nor compared.
    Remade,
    /// A behaviour's wiring, fed (process recordings).
    Port,
    /// A behaviour's state, fed (process recordings).
    State,
    /// A request to a replayed component's parameters (from a tool or the live server), fed;
    /// its answer and the change it made are compared.
    Param,
    /// The link watchdog's events (process recordings).
    Link,
    /// The fault plan's start.
    PlanStart,
    /// The system's start.
    SystemStarting,
    /// What came back to the process from another one's service.
    Exchange(ExchangeKind),
    /// From another process, and made by nothing replayed.
    Outside,
    /// A view for Foxglove (protobuf, see [`crate::record::views`]): made from what is fed
    /// and compared, so neither fed nor compared itself.
    View,
}

impl Feed {
    /// What `service` (a topic of the robot server, without its name) is to a replay, or
    /// `None` if it is a message *to* the robot (a Send or a query request: compared).
    fn of(service: &str) -> Option<Feed> {
        Some(match service {
            "distanceir" => Feed::Ir,
            "distanceson" => Feed::Sonar,
            "bumpers" => Feed::Bumpers,
            "basestate" => Feed::Base,
            "health" => Feed::Health,
            "robotparams/answer" => Feed::ParamsAnswer,
            "safety/answer" => Feed::SafetyAnswer,
            "contact" | "healthchanges" | "state" | "wiring" => Feed::Remade,
            _ => return None,
        })
    }

    fn schema(self) -> Option<&'static str> {
        Some(match self {
            Feed::Ir | Feed::Sonar => DistanceScan::ID,
            Feed::Bumpers => ContactScan::ID,
            Feed::Base => BaseState::ID,
            Feed::Health => Health::ID,
            Feed::ParamsAnswer => RobotParams::ID,
            Feed::SafetyAnswer => SafetyCounters::ID,
            Feed::Port => PortStatus::ID,
            Feed::State => StateStatus::ID,
            Feed::Param => ParamRequest::ID,
            Feed::Link => LINK_EVENT,
            Feed::PlanStart => FAULTS_STARTED_TYPE,
            Feed::SystemStarting => SYSTEM_STARTING_TYPE,
            Feed::Exchange(_) => EXCHANGED_TYPE,
            Feed::Remade | Feed::Outside | Feed::View => return None,
        })
    }

    /// What `topic` is to a replay of the recording `meta` describes, or `None` if it is
    /// compared (and nothing else).
    ///
    /// In a recording of the whole stack (`orsa run`) every component ran in the recording
    /// process, so only the robot server's side is fed. In a recording of `orsa robot`, the
    /// executive ran elsewhere: the wiring and state changes of the behaviours are fed, all of
    /// them, as they were recorded (a change that changed nothing included; one that a restart
    /// made is made twice, which changes nothing again), and not compared; what they made the
    /// behaviours do is. What the link watchdog did is fed,
    /// and what reached the process from components it did not host (teleop, tools, a fallback
    /// master's own services) is neither fed nor compared. Requests to the robot server are
    /// then compared only for its velocity commands: its queries come from outside as well.
    fn classify(meta: &RunMeta, topic: &str) -> Option<Feed> {
        if topic == LINK_EVENTS {
            return Some(Feed::Link);
        }
        if topic == FAULTS_STARTED {
            return Some(Feed::PlanStart);
        }
        if topic == SYSTEM_STARTING {
            return Some(Feed::SystemStarting);
        }
        if let Some((kind, _)) = ExchangeKind::of_topic(topic) {
            return kind.came_in().then_some(Feed::Exchange(kind));
        }
        let (component, service) = topic.split_once('/')?;
        let process = meta.process != "run";
        if component == meta.robot {
            return Feed::of(service)
                .or_else(|| (process && service != "navigationvelocity").then_some(Feed::Outside));
        }
        let hosted = !process || meta.hosted.iter().any(|h| h == component);
        if service == PARAM.name() && hosted {
            return Some(Feed::Param);
        }
        if !process || component == "supervision" {
            return None;
        }
        if !meta.hosted.iter().any(|h| h == component) {
            return Some(Feed::Outside);
        }
        match service {
            "wiring" => Some(Feed::Port),
            "state" => Some(Feed::State),
            _ => None,
        }
    }
}

/// Whether a replay of the recording `meta` describes compares what it makes on `topic` with
/// the recording (the robot's side, what came from other processes and the recording's own
/// notes are fed or left alone, not compared).
pub fn is_compared(meta: &RunMeta, topic: &str) -> bool {
    Feed::classify(meta, topic).is_none()
}

/// A channel as the file declares it.
struct Channel {
    topic: Arc<str>,
    feed: Option<Feed>,
}

impl Recording {
    /// Reads and checks the recording at `path`.
    pub fn open(path: &Path) -> Result<Recording, ReplayError> {
        let bytes =
            std::fs::read(path).map_err(|source| ReplayError::Read { path: path.to_path_buf(), source })?;
        Recording::parse(path, &bytes)
    }

    /// Reads and checks a recording from its bytes; `path` names it in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<Recording, ReplayError> {
        let corrupt = |problem: String| ReplayError::Corrupt { path: path.to_path_buf(), problem };
        if !bytes.starts_with(MAGIC) {
            return Err(corrupt("it is not an MCAP file (it does not start with MCAP's magic bytes)".into()));
        }
        if !bytes.ends_with(MAGIC) || bytes.len() < 2 * MAGIC.len() {
            return Err(corrupt(format!(
                "it is truncated: its {} bytes do not end with MCAP's closing magic (was the recording \
                 interrupted before it was finished?)",
                bytes.len()
            )));
        }
        // The description first: it is a top-level record, found without decompressing chunks.
        let mut metadata: Option<BTreeMap<String, String>> = None;
        let mut ended = None;
        for record in mcap::read::LinearReader::new(bytes).map_err(|e| corrupt(e.to_string()))? {
            if let mcap::records::Record::Metadata(m) = record.map_err(|e| corrupt(e.to_string()))? {
                if m.name == RUN_METADATA {
                    metadata = Some(m.metadata);
                } else if m.name == crate::record::meta::RUN_ENDED_METADATA {
                    let e = crate::record::meta::RunEnded::from_metadata(&m.metadata)
                        .map_err(|problem| ReplayError::Metadata { path: path.to_path_buf(), problem })?;
                    ended = Some(e);
                }
            }
        }
        let Some(metadata) = metadata else {
            return Err(ReplayError::NoMetadata { path: path.to_path_buf() });
        };
        let meta = RunMeta::from_metadata(&metadata)
            .map_err(|e| ReplayError::Metadata { path: path.to_path_buf(), problem: e.to_string() })?;
        meta.check_versions()
            .map_err(|e| ReplayError::Version { path: path.to_path_buf(), problem: e.to_string() })?;
        let mut rec = Recording {
            path: path.to_path_buf(),
            meta,
            published: Vec::new(),
            answers: Answers::default(),
            outputs: BTreeMap::new(),
            controls: Vec::new(),
            controls_after: Vec::new(),
            controls_outputs: Vec::new(),
            controls_early: Vec::new(),
            plan_started: None,
            system_starting: None,
            exchange: ExchangeLog::default(),
            outside: 0,
            views: 0,
            robot_events: 0,
            schemas: BTreeMap::new(),
            last_log_time: 0,
            ended,
            messages: 0,
        };

        // Then every message, decoded (what is fed) or kept (what is compared) as it comes. Each
        // chunk's CRC is checked before any of its messages is yielded, so a damaged chunk is
        // reported as damage, not as a message that does not decode.
        let options =
            mcap::sans_io::linear_reader::LinearReaderOptions::default().with_prevalidate_chunk_crcs(true);
        let mut reader = mcap::sans_io::linear_reader::LinearReader::new_with_options(options);
        let mut input = bytes;
        let mut schemas: HashMap<u16, String> = HashMap::new();
        let mut channels: HashMap<u16, Channel> = HashMap::new();
        while let Some(event) = reader.next_event() {
            let damaged = |e: mcap::McapError, rec: &Recording| {
                corrupt(format!(
                    "{e}, after {} messages (the last at log time {})",
                    rec.messages,
                    Timestamp(rec.last_log_time)
                ))
            };
            let (opcode, data) = match event.map_err(|e| damaged(e, &rec))? {
                mcap::sans_io::linear_reader::LinearReadEvent::ReadRequest(need) => {
                    let n = need.min(input.len());
                    reader.insert(n).copy_from_slice(&input[..n]);
                    reader.notify_read(n);
                    input = &input[n..];
                    continue;
                }
                mcap::sans_io::linear_reader::LinearReadEvent::Record { opcode, data } => (opcode, data),
            };
            let record = mcap::parse_record(opcode, data).map_err(|e| damaged(e, &rec))?;
            match record {
                mcap::records::Record::Schema { header, .. } => {
                    schemas.insert(header.id, header.name);
                }
                mcap::records::Record::Channel(c) => {
                    let schema = schemas.get(&c.schema_id).cloned().ok_or_else(|| {
                        corrupt(format!(
                            "channel '{}' names schema {} that the file never defined",
                            c.topic, c.schema_id
                        ))
                    })?;
                    let mismatch = |problem: String| ReplayError::Schema {
                        path: path.to_path_buf(),
                        topic: c.topic.clone(),
                        problem,
                    };
                    let view = c.message_encoding == crate::record::VIEW_ENCODING;
                    if !view && c.message_encoding != crate::record::MESSAGE_ENCODING {
                        return Err(mismatch(format!(
                            "its messages are encoded as '{}', not '{}'",
                            c.message_encoding,
                            crate::record::MESSAGE_ENCODING
                        )));
                    }
                    // What came from another process is not made again by anything replayed.
                    let remote = c.metadata.get(crate::record::FROM_KEY).map(String::as_str)
                        == Some(crate::record::FROM_REMOTE);
                    let feed = if view {
                        Some(Feed::View)
                    } else if remote {
                        Some(Feed::Outside)
                    } else {
                        Feed::classify(&rec.meta, &c.topic)
                    };
                    if let Some(expected) = feed.and_then(Feed::schema)
                        && schema != expected
                    {
                        return Err(mismatch(format!(
                            "its schema is '{schema}', and the robot's service carries '{expected}'"
                        )));
                    }
                    let topic: Arc<str> = c.topic.as_str().into();
                    rec.schemas.insert(topic.clone(), schema);
                    channels.insert(c.id, Channel { topic, feed });
                }
                mcap::records::Record::Message { header, data } => {
                    let Some(c) = channels.get(&header.channel_id) else {
                        return Err(corrupt(format!(
                            "message {} at log time {} is on channel {}, which the file never defined",
                            rec.messages + 1,
                            Timestamp(header.log_time),
                            header.channel_id
                        )));
                    };
                    rec.messages += 1;
                    rec.last_log_time = rec.last_log_time.max(header.log_time);
                    rec.sort(path, c, header.log_time, data.into_owned())?;
                }
                _ => {}
            }
        }
        Ok(rec)
    }

    /// Files a control at `log_time`, with what the recording has before it: the robot's
    /// publications, and the outputs of what it acts on (see [`Recording::controls_outputs`]).
    fn control(&mut self, log_time: u64, control: Control) {
        let touched = self.acts_on(&control);
        let before = (self.outputs.iter())
            .filter(|(topic, _)| topic.starts_with(touched.as_str()))
            .map(|(topic, list)| (topic.clone(), list.len()))
            .collect();
        self.controls.push((log_time, control));
        self.controls_after.push(self.published.len());
        self.controls_outputs.push(before);
        self.controls_early.push(false);
    }

    /// The prefix of the topics of what `control` acts on: the component whose port, state or
    /// parameters it sets (`component/`), or for the link watchdog's command the robot's
    /// velocity commands.
    pub(super) fn acts_on(&self, control: &Control) -> String {
        match control {
            Control::Port { component, .. }
            | Control::State { component, .. }
            | Control::Param { component, .. } => format!("{component}/"),
            Control::Link(_) => {
                format!("{}/{}", self.meta.robot, orsa_interfaces::nomad200::NAVIGATIONVELOCITY.name())
            }
        }
    }

    /// The outputs of what control `j` acts on, recorded so far.
    fn outputs_of(&self, j: usize) -> usize {
        let touched = self.acts_on(&self.controls[j].1);
        (self.outputs.iter())
            .filter(|(topic, _)| topic.starts_with(touched.as_str()))
            .map(|(_, l)| l.len())
            .sum()
    }

    /// Before a publication is filed: settles whether each control since the last publication
    /// went before the step on that publication ([`Recording::controls_early`]).
    fn settle_controls(&mut self) {
        let n = self.published.len();
        let first = self.controls_after.partition_point(|&after| after < n);
        for j in first..self.controls.len() {
            let before: usize = self.controls_outputs[j].iter().map(|(_, c)| c).sum();
            let made = self.outputs_of(j) > before;
            // A state that does not compute (no substates) stops the steps: none made after it
            // says it went first.
            let stops = match &self.controls[j].1 {
                Control::State { status, .. } => {
                    let wanted = status.pending.as_ref().unwrap_or(&status.current);
                    status.main_states.get(wanted).is_some_and(std::collections::BTreeSet::is_empty)
                }
                _ => false,
            };
            self.controls_early[j] = made != stops;
        }
    }

    /// Files one message: decoded into what the stand-in plays back, or kept for comparison.
    fn sort(&mut self, path: &Path, c: &Channel, log_time: u64, data: Vec<u8>) -> Result<(), ReplayError> {
        let decode = |problem| ReplayError::Decode {
            path: path.to_path_buf(),
            topic: c.topic.to_string(),
            log_time: Timestamp(log_time),
            problem,
        };
        let published = match c.feed {
            Some(Feed::Ir) => Published::Ir(value(&data).map_err(decode)?),
            Some(Feed::Sonar) => Published::Sonar(value(&data).map_err(decode)?),
            Some(Feed::Bumpers) => Published::Bumpers(value(&data).map_err(decode)?),
            Some(Feed::Base) => Published::Base(value(&data).map_err(decode)?),
            Some(Feed::Health) => Published::Health(value(&data).map_err(decode)?),
            Some(Feed::ParamsAnswer) => {
                self.answers.robotparams.push_back(value(&data).map_err(decode)?);
                return Ok(());
            }
            Some(Feed::SafetyAnswer) => {
                self.answers.safety.push_back(value(&data).map_err(decode)?);
                return Ok(());
            }
            Some(Feed::Remade) => return Ok(()),
            Some(Feed::Outside) => {
                self.outside += 1;
                return Ok(());
            }
            Some(Feed::View) => {
                self.views += 1;
                return Ok(());
            }
            Some(Feed::PlanStart) => {
                self.plan_started = Some(log_time);
                return Ok(());
            }
            Some(Feed::SystemStarting) => {
                self.system_starting = Some(log_time);
                return Ok(());
            }
            Some(Feed::Exchange(kind)) => {
                let e = bare::<Exchanged>(&data, EXCHANGED_TYPE).map_err(decode)?;
                let service = ExchangeKind::of_topic(&c.topic)
                    .and_then(|(_, s)| s.parse::<ServiceAddr>().ok())
                    .ok_or_else(|| decode(format!("'{}' does not name a service", c.topic)))?;
                let numbered = |e: &Exchanged| e.n.ok_or_else(|| decode("it has no number 'n'".into()));
                let log = &mut self.exchange;
                match kind {
                    ExchangeKind::Lookup => log.lookups.entry(service).or_default().push((log_time, e.info)),
                    ExchangeKind::Reply => {
                        let n = numbered(&e)?;
                        let reply = match (&e.failure, &e.error) {
                            (Some(failure), _) => Err(failure.clone().into_error()),
                            // A recording from before failures were kept whole: the
                            // request went unanswered.
                            (None, Some(_)) => Err(PatternError::NoAnswer(service.clone())),
                            (None, None) => Ok(e.bytes().map_err(|e| decode(e.to_string()))?),
                        };
                        log.replies.insert((service, n), (log_time, reply));
                    }
                    ExchangeKind::Update | ExchangeKind::Firing => {
                        let n = numbered(&e)?;
                        let bytes = e.bytes().map_err(|e| decode(e.to_string()))?;
                        let list =
                            if kind == ExchangeKind::Update { &mut log.updates } else { &mut log.firings };
                        list.entry((service, n)).or_default().push((log_time, bytes));
                    }
                    _ => {}
                }
                return Ok(());
            }
            Some(Feed::Link) => {
                let e = bare::<LinkEvent>(&data, LINK_EVENT).map_err(decode)?;
                self.control(log_time, Control::Link(e));
                return Ok(());
            }
            Some(Feed::Port) => {
                let status = bare::<PortStatus>(&data, PortStatus::ID).map_err(decode)?;
                let component = component_of(&c.topic);
                self.control(log_time, Control::Port { component, status });
                return Ok(());
            }
            Some(Feed::Param) => {
                let request = value::<ParamRequest>(&data).map_err(decode)?;
                let component = component_of(&c.topic);
                let after = self.published.len();
                self.control(log_time, Control::Param { component, request, after });
                return Ok(());
            }
            Some(Feed::State) => {
                let status = bare::<StateStatus>(&data, StateStatus::ID).map_err(decode)?;
                let component = component_of(&c.topic);
                self.control(log_time, Control::State { component, status });
                return Ok(());
            }
            None => {
                // The robot server's own failures and restarts are its own, like what it
                // published: the stand-in that replaces it has none, and they are not compared.
                if &*c.topic == SUPERVISION_EVENTS && supervises(&data, &self.meta.robot) {
                    self.robot_events += 1;
                    return Ok(());
                }
                self.outputs.entry(c.topic.clone()).or_default().push(Recorded { log_time, data });
                return Ok(());
            }
        };
        self.settle_controls();
        self.published.push((log_time, published));
        Ok(())
    }

    /// The number of messages the replay compares.
    pub fn compared(&self) -> usize {
        self.outputs.values().map(Vec::len).sum()
    }
}

/// The component a topic belongs to (its first segment).
fn component_of(topic: &str) -> String {
    topic.split_once('/').map_or(topic, |(c, _)| c).to_string()
}

/// A control event recorded as it is (no envelope).
fn bare<T: serde::de::DeserializeOwned>(data: &[u8], id: &str) -> Result<T, String> {
    serde_json::from_slice::<T>(data).map_err(|e| format!("it does not decode as a {id}: {e}"))
}

/// The communication object inside a recorded message (`{"seq", "stamp", "value"}`).
fn value<T: CommObject>(data: &[u8]) -> Result<T, String> {
    serde_json::from_slice::<Stamped<T>>(data)
        .map(|s| s.value)
        .map_err(|e| format!("it does not decode as a {}: {e}", T::ID))
}

/// Whether `event` (a recorded `orsa.SupervisorEvent/1`) is about the component `child`.
fn supervises(event: &[u8], child: &str) -> bool {
    #[derive(serde::Deserialize)]
    struct Child<'a> {
        #[serde(borrow)]
        child: Option<std::borrow::Cow<'a, str>>,
    }
    serde_json::from_slice::<Child<'_>>(event).is_ok_and(|e| e.child.as_deref() == Some(child))
}
