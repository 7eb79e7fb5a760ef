//! Reading a recording for a replay: its description, and its messages sorted into what the
//! replay feeds (the robot server's side) and what it compares (everything else).
//!
//! The whole file is checked before anything runs: its structure (MCAP magic, records,
//! channels), its `run` metadata and versions, the schema of every channel the replay feeds,
//! and every message it feeds (decoded into its communication object). Each error names the
//! file and, where there is one, the channel and the message's log time.

use super::ReplayError;
use crate::record::RunMeta;
use crate::record::meta::RUN_METADATA;
use orsa_actors::{CommObject, Stamped, Timestamp};
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
}

/// The recorded answers of the robot server's queries, in order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Answers {
    /// `robotparams/answer`.
    pub robotparams: std::collections::VecDeque<RobotParams>,
    /// `safety/answer`.
    pub safety: std::collections::VecDeque<SafetyCounters>,
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
    /// The schema name of each topic.
    pub schemas: BTreeMap<Arc<str>, String>,
    /// Every message's log time ends at or before this (ns).
    pub last_log_time: u64,
    /// Messages read, in all.
    pub messages: u64,
}

/// Which of the robot server's topics the replay feeds, and how to decode them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Feed {
    Ir,
    Sonar,
    Bumpers,
    Base,
    ParamsAnswer,
    SafetyAnswer,
    /// Made again by the replayed robot side (its events and its own control topics): neither
    /// fed nor compared.
    Remade,
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
            "robotparams/answer" => Feed::ParamsAnswer,
            "safety/answer" => Feed::SafetyAnswer,
            "contact" | "state" | "wiring" => Feed::Remade,
            _ => return None,
        })
    }

    fn schema(self) -> Option<&'static str> {
        Some(match self {
            Feed::Ir | Feed::Sonar => DistanceScan::ID,
            Feed::Bumpers => ContactScan::ID,
            Feed::Base => BaseState::ID,
            Feed::ParamsAnswer => RobotParams::ID,
            Feed::SafetyAnswer => SafetyCounters::ID,
            Feed::Remade => return None,
        })
    }
}

/// Whether the robot server's topic `service` (without the server's name) is the robot's
/// side of the conversation: fed from the recording, or made again by the stand-in. Messages
/// *to* the robot (commands, query requests) are not: the replayed components make them.
pub fn is_robot_side(service: &str) -> bool {
    Feed::of(service).is_some()
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
        for record in mcap::read::LinearReader::new(bytes).map_err(|e| corrupt(e.to_string()))? {
            if let mcap::records::Record::Metadata(m) = record.map_err(|e| corrupt(e.to_string()))?
                && m.name == RUN_METADATA
            {
                metadata = Some(m.metadata);
            }
        }
        let Some(metadata) = metadata else {
            return Err(ReplayError::NoMetadata { path: path.to_path_buf() });
        };
        let meta = RunMeta::from_metadata(&metadata)
            .map_err(|problem| ReplayError::Metadata { path: path.to_path_buf(), problem })?;
        meta.check_versions()
            .map_err(|problem| ReplayError::Version { path: path.to_path_buf(), problem })?;
        let prefix = format!("{}/", meta.robot);
        let mut rec = Recording {
            path: path.to_path_buf(),
            meta,
            published: Vec::new(),
            answers: Answers::default(),
            outputs: BTreeMap::new(),
            schemas: BTreeMap::new(),
            last_log_time: 0,
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
                    if c.message_encoding != crate::record::MESSAGE_ENCODING {
                        return Err(mismatch(format!(
                            "its messages are encoded as '{}', not '{}'",
                            c.message_encoding,
                            crate::record::MESSAGE_ENCODING
                        )));
                    }
                    let feed = c.topic.strip_prefix(prefix.as_str()).and_then(Feed::of);
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
            Some(Feed::ParamsAnswer) => {
                self.answers.robotparams.push_back(value(&data).map_err(decode)?);
                return Ok(());
            }
            Some(Feed::SafetyAnswer) => {
                self.answers.safety.push_back(value(&data).map_err(decode)?);
                return Ok(());
            }
            Some(Feed::Remade) => return Ok(()),
            None => {
                self.outputs.entry(c.topic.clone()).or_default().push(Recorded { log_time, data });
                return Ok(());
            }
        };
        self.published.push((log_time, published));
        Ok(())
    }

    /// The number of messages the replay compares.
    pub fn compared(&self) -> usize {
        self.outputs.values().map(Vec::len).sum()
    }
}

/// The communication object inside a recorded message (`{"seq", "stamp", "value"}`).
fn value<T: CommObject>(data: &[u8]) -> Result<T, String> {
    serde_json::from_slice::<Stamped<T>>(data)
        .map(|s| s.value)
        .map_err(|e| format!("it does not decode as a {}: {e}", T::ID))
}
