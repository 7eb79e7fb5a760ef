//! Recording runs as MCAP files that standard robotics tools open without orsa.
//!
//! A [`Recorder`] writes every message it is given to an MCAP file: one channel per topic
//! (`component/service` for pattern traffic such as `nomad200/distanceir`, or a control topic
//! such as `executive/wiring` or `supervision/events`), JSON message encoding, and a JSON Schema
//! per channel (schema encoding `jsonschema`) inferred from the topic's first message. Foxglove,
//! the `mcap` CLI and the `mcap` Python package read the result as is.
//!
//! Chunks are compressed with zstd. Times are robot time: a [`Timestamp`]'s nanoseconds become
//! the message's `log_time` and `publish_time`, so a recording of a paused-clock simulation starts
//! at zero, not at the wall-clock date.
//!
//! Beside them, [`views`] writes channels in Foxglove's well-known schemas (protobuf, schema
//! encoding `protobuf`) that Foxglove draws: the world, the robot, its scans and frames.
//!
//! The hot path (an hour of simulated time is about 300 000 messages) serialises each message
//! into one reused buffer and looks its channel up by `&str`; a topic's first message also
//! builds its schema.

pub mod events;
pub mod meta;
mod schema;
pub mod views;

pub use meta::RunMeta;

#[cfg(test)]
mod tests;

use orsa_actors::Timestamp;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The MCAP message encoding of every channel but the views'.
pub const MESSAGE_ENCODING: &str = "json";
/// The MCAP message and schema encoding of the views' channels (see [`views`]).
pub const VIEW_ENCODING: &str = "protobuf";
/// Channel metadata key that says where a channel's messages came from.
pub const FROM_KEY: &str = "orsa.from";
/// [`FROM_KEY`]'s value on a channel of messages from another process (through the transport).
pub const FROM_REMOTE: &str = "another process";
/// The MCAP schema encoding of every schema.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// The MCAP profile written in the header (none of the well-known profiles applies).
pub const PROFILE: &str = "";
/// Uncompressed bytes per chunk before it is compressed and written.
pub const CHUNK_SIZE_BYTES: u64 = 4 * 1024 * 1024;

/// What went wrong while recording; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be created.
    #[error("cannot create the recording {path}: {source}")]
    Create {
        /// The recording's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The MCAP writer failed (usually an I/O error: disk full, file removed).
    #[error("cannot write the recording {path} ({what}): {source}")]
    Write {
        /// The recording's path.
        path: PathBuf,
        /// What was being written, e.g. `a message on topic nomad200/bumpers`.
        what: String,
        /// The writer's error.
        source: mcap::McapError,
    },
    /// A message could not be turned into JSON (e.g. a map with non-string keys).
    #[error("cannot record a message on topic {topic} in {path}: it does not serialise to JSON: {source}")]
    Serialize {
        /// The recording's path.
        path: PathBuf,
        /// The topic of the message.
        topic: String,
        /// serde_json's error.
        source: serde_json::Error,
    },
    /// A view (a message in one of Foxglove's schemas) could not be encoded.
    #[error("cannot record a message on topic {topic} in {path}: {problem}")]
    Encode {
        /// The recording's path.
        path: PathBuf,
        /// The topic of the message.
        topic: String,
        /// What went wrong.
        problem: String,
    },
}

impl RecordError {
    fn encode(path: &Path, topic: &str, problem: impl std::fmt::Display) -> RecordError {
        RecordError::Encode {
            path: path.to_path_buf(),
            topic: topic.to_owned(),
            problem: problem.to_string(),
        }
    }
}

/// What a finished recording holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordSummary {
    /// The file written.
    pub path: PathBuf,
    /// Messages written per topic.
    pub messages: BTreeMap<String, u64>,
    /// Metadata records written.
    pub metadata: u64,
}

impl RecordSummary {
    /// All messages written, on every topic.
    pub fn total_messages(&self) -> u64 {
        self.messages.values().sum()
    }
}

/// One topic's channel.
#[derive(Debug)]
struct Channel {
    id: u16,
    sequence: u32,
    count: u64,
}

/// Writes a run to an MCAP file. Call [`Recorder::finish`] to write the summary and learn of any
/// error; dropping an unfinished recorder finishes it too, logging (not panicking on) errors.
pub struct Recorder {
    path: PathBuf,
    /// `None` only after `finish` took it.
    writer: Option<mcap::Writer<BufWriter<File>>>,
    /// Per topic, and whether its messages came from another process (they get a channel of
    /// their own on the same topic, with [`FROM_KEY`] in its metadata).
    channels: HashMap<(String, bool), Channel>,
    /// The reused serialisation buffer.
    buf: Vec<u8>,
    metadata: u64,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("path", &self.path)
            .field("channels", &self.channels.len())
            .field("finished", &self.writer.is_none())
            .finish()
    }
}

impl Recorder {
    /// Creates (or truncates) the MCAP file at `path` and writes its header.
    pub fn create(path: &Path) -> Result<Recorder, RecordError> {
        let file =
            File::create(path).map_err(|source| RecordError::Create { path: path.to_path_buf(), source })?;
        let options = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(concat!("orsa ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(1)
            .chunk_size(Some(CHUNK_SIZE_BYTES))
            // The recorder runs on a thread of its own (see `mission::recording`): no extra
            // compressing threads.
            .compression_threads(0);
        let writer = options.create(BufWriter::with_capacity(1 << 16, file)).map_err(|source| {
            RecordError::Write { path: path.to_path_buf(), what: "the header".into(), source }
        })?;
        Ok(Recorder {
            path: path.to_path_buf(),
            writer: Some(writer),
            channels: HashMap::new(),
            buf: Vec::with_capacity(4096),
            metadata: 0,
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Records `msg` on `topic` at robot time `log_time` (when it was seen), published at
    /// `publish_time` (when its sender stamped it). A topic's first message creates its channel
    /// and its schema named `schema_name`, inferred from that message; later messages on the
    /// topic keep that channel whatever `schema_name` they pass.
    pub fn write<T: Serialize + ?Sized>(
        &mut self,
        topic: &str,
        schema_name: &str,
        log_time: Timestamp,
        publish_time: Timestamp,
        msg: &T,
    ) -> Result<(), RecordError> {
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, msg).map_err(|source| RecordError::Serialize {
            path: self.path.clone(),
            topic: topic.to_owned(),
            source,
        })?;
        let json = std::mem::take(&mut self.buf);
        let written = self.write_json(topic, schema_name, log_time, publish_time, &json);
        self.buf = json;
        written
    }

    /// As [`write`](Self::write), for a message already serialised as JSON (what a
    /// [`Tap`](orsa_actors::tap::Tap) gets).
    pub fn write_json(
        &mut self,
        topic: &str,
        schema_name: &str,
        log_time: Timestamp,
        publish_time: Timestamp,
        json: &[u8],
    ) -> Result<(), RecordError> {
        self.write_json_from(topic, schema_name, log_time, publish_time, json, false)
    }

    /// As [`write_json`](Self::write_json), for a message that came from another process if
    /// `remote`: it goes to the topic's channel for such messages, whose metadata says
    /// [`FROM_KEY`] = [`FROM_REMOTE`] (viewers show both channels as one topic).
    pub fn write_json_from(
        &mut self,
        topic: &str,
        schema_name: &str,
        log_time: Timestamp,
        publish_time: Timestamp,
        json: &[u8],
        remote: bool,
    ) -> Result<(), RecordError> {
        let Some(writer) = self.writer.as_mut() else {
            // Unreachable: `finish` consumes the recorder.
            return Ok(());
        };
        let key = (topic.to_owned(), remote);
        let channel = match self.channels.get_mut(&key) {
            Some(channel) => channel,
            None => {
                let id = add_channel(writer, &self.path, topic, schema_name, json, remote)?;
                self.channels.entry(key).or_insert(Channel { id, sequence: 0, count: 0 })
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.sequence,
            log_time: log_time.as_nanos(),
            publish_time: publish_time.as_nanos(),
        };
        writer.write_to_known_channel(&header, json).map_err(|source| RecordError::Write {
            path: self.path.clone(),
            what: format!("a message on topic {topic}"),
            source,
        })?;
        channel.sequence = channel.sequence.wrapping_add(1);
        channel.count += 1;
        Ok(())
    }

    /// Records `msg`, a message of one of Foxglove's well-known schemas (or anything else the
    /// `foxglove` crate can encode), on `topic` at `log_time`. A topic's first message creates
    /// its channel, with the message's own schema and encoding (`protobuf`).
    pub fn write_view<T: foxglove::Encode>(
        &mut self,
        topic: &str,
        log_time: Timestamp,
        msg: &T,
    ) -> Result<(), RecordError> {
        let Some(writer) = self.writer.as_mut() else {
            return Ok(());
        };
        self.buf.clear();
        msg.encode(&mut self.buf).map_err(|e| RecordError::encode(&self.path, topic, e))?;
        let key = (topic.to_owned(), false);
        let channel = match self.channels.get_mut(&key) {
            Some(channel) => channel,
            None => {
                let Some(schema) = T::get_schema() else {
                    return Err(RecordError::encode(&self.path, topic, "its message type has no schema"));
                };
                let write_error =
                    |what: String, source| RecordError::Write { path: self.path.clone(), what, source };
                let schema_id =
                    writer.add_schema(&schema.name, &schema.encoding, &schema.data).map_err(|source| {
                        write_error(format!("the schema {} of topic {topic}", schema.name), source)
                    })?;
                let id = writer
                    .add_channel(schema_id, topic, &T::get_message_encoding(), &BTreeMap::new())
                    .map_err(|source| write_error(format!("the channel of topic {topic}"), source))?;
                self.channels.entry(key).or_insert(Channel { id, sequence: 0, count: 0 })
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.sequence,
            log_time: log_time.as_nanos(),
            publish_time: log_time.as_nanos(),
        };
        writer.write_to_known_channel(&header, &self.buf).map_err(|source| RecordError::Write {
            path: self.path.clone(),
            what: format!("a message on topic {topic}"),
            source,
        })?;
        channel.sequence = channel.sequence.wrapping_add(1);
        channel.count += 1;
        Ok(())
    }

    /// Records a metadata record `name` (e.g. `run` with world, seed, duration, orsa version).
    pub fn write_metadata(
        &mut self,
        name: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), RecordError> {
        let Some(writer) = self.writer.as_mut() else {
            return Ok(());
        };
        writer.write_metadata(&mcap::records::Metadata { name: name.to_owned(), metadata }).map_err(
            |source| RecordError::Write {
                path: self.path.clone(),
                what: format!("the metadata record {name}"),
                source,
            },
        )?;
        self.metadata += 1;
        Ok(())
    }

    /// Writes the last chunk, the summary and the footer, and flushes the file.
    pub fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.finish_file()?;
        let mut messages = BTreeMap::new();
        for ((topic, _), c) in &self.channels {
            *messages.entry(topic.clone()).or_insert(0) += c.count;
        }
        Ok(RecordSummary { path: self.path.clone(), messages, metadata: self.metadata })
    }

    fn finish_file(&mut self) -> Result<(), RecordError> {
        let Some(mut writer) = self.writer.take() else {
            return Ok(());
        };
        let error =
            |what: &str, source| RecordError::Write { path: self.path.clone(), what: what.into(), source };
        writer.finish().map_err(|source| error("the summary", source))?;
        let mut file = writer.into_inner();
        std::io::Write::flush(&mut file).map_err(|source| error("the end of the file", source.into()))?;
        Ok(())
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Err(error) = self.finish_file() {
            tracing::error!("recording left unfinished: {error}");
        }
    }
}

/// Adds the schema inferred from `first` (a topic's first message, as JSON) and the channel.
fn add_channel(
    writer: &mut mcap::Writer<BufWriter<File>>,
    path: &Path,
    topic: &str,
    schema_name: &str,
    first: &[u8],
    remote: bool,
) -> Result<u16, RecordError> {
    let serde_error =
        |source| RecordError::Serialize { path: path.to_path_buf(), topic: topic.to_owned(), source };
    let value: serde_json::Value = serde_json::from_slice(first).map_err(serde_error)?;
    let schema = serde_json::to_vec(&schema::infer(schema_name, &value)).map_err(serde_error)?;
    let write_error = |what: String, source| RecordError::Write { path: path.to_path_buf(), what, source };
    let schema_id = writer
        .add_schema(schema_name, SCHEMA_ENCODING, &schema)
        .map_err(|source| write_error(format!("the schema {schema_name} of topic {topic}"), source))?;
    let mut metadata = BTreeMap::new();
    if remote {
        metadata.insert(FROM_KEY.to_string(), FROM_REMOTE.to_string());
    }
    writer
        .add_channel(schema_id, topic, MESSAGE_ENCODING, &metadata)
        .map_err(|source| write_error(format!("the channel of topic {topic}"), source))
}
