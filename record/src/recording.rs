//! A run recorded as MCAP: every pattern message and control event the registry's tap sees,
//! plus the supervisor's events and the run's description as metadata.
//!
//! The file is written on a thread of its own. On the control loop's thread the tap only
//! serialises each message to JSON (straight from its type) and appends it to a batch; every
//! [`BATCH`] messages the batch goes to the writer thread, which puts each message in its
//! channel, compresses the chunks and writes them. At most [`QUEUED`] batches wait, so a disk
//! slower than the run slows the run rather than filling memory. A write error stops the
//! recording (the writer drains the queue from then on, so the run never waits on a dead file)
//! and is reported by [`McapTap::finish`].
//!
//! Given a [`ViewSetup`], the writer thread also makes the recording's views (channels that
//! Foxglove draws, see [`crate::record::views`]) from the messages it writes and from the
//! ground-truth samples the run hands it ([`McapTap::truth`]).

use crate::record::views::{Input, TruthSample, ViewSetup, Views};
use crate::record::{RecordError, RecordSummary, Recorder};
use orsa_actors::Timestamp;
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::tap::Tap;
use parking_lot::Mutex;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::mpsc;

/// Messages per batch handed to the writer thread.
pub const BATCH: usize = 1024;
/// Batches waiting for the writer at most (a few MB).
pub const QUEUED: usize = 8;

/// One message of a batch: its topic's number, its stamp, and where its JSON ends.
struct Item {
    topic: u32,
    stamp: Timestamp,
    end: usize,
}

/// Messages on their way to the writer.
#[derive(Default)]
struct Batch {
    /// Topics first seen in this batch: number, topic, communication object, and whether
    /// its messages came from another process.
    new_topics: Vec<(u32, String, String, bool)>,
    items: Vec<Item>,
    /// Every message's JSON, one after the other.
    json: Vec<u8>,
    /// Ground-truth samples for the views, each with the number of items before it.
    truth: Vec<(usize, TruthSample)>,
    /// Metadata records, written after the batch's messages.
    metadata: Vec<(String, BTreeMap<String, String>)>,
}

/// The control loop's side: topic numbers and the batch being filled.
struct Producer {
    /// Topic numbers of this process's messages, and of those from other processes.
    topics: [HashMap<String, u32>; 2],
    batch: Batch,
    queue: Option<mpsc::SyncSender<Batch>>,
}

impl Producer {
    fn push(&mut self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8], remote: bool) {
        let next = (self.topics[0].len() + self.topics[1].len()) as u32;
        let topics = &mut self.topics[usize::from(remote)];
        let id = match topics.get(topic) {
            Some(id) => *id,
            None => {
                topics.insert(topic.to_owned(), next);
                self.batch.new_topics.push((next, topic.to_owned(), type_id.to_owned(), remote));
                next
            }
        };
        self.batch.json.extend_from_slice(json);
        self.batch.items.push(Item { topic: id, stamp, end: self.batch.json.len() });
        if self.batch.items.len() >= BATCH {
            self.flush();
        }
    }

    fn flush(&mut self) {
        if self.batch.items.is_empty()
            && self.batch.new_topics.is_empty()
            && self.batch.truth.is_empty()
            && self.batch.metadata.is_empty()
        {
            return;
        }
        let capacity = self.batch.json.capacity();
        let full = std::mem::replace(
            &mut self.batch,
            Batch {
                new_topics: Vec::new(),
                items: Vec::with_capacity(BATCH),
                json: Vec::with_capacity(capacity),
                truth: Vec::new(),
                metadata: Vec::new(),
            },
        );
        if let Some(queue) = &self.queue {
            // The writer lives until the queue closes.
            let _ = queue.send(full);
        }
    }
}

/// A tap that writes what it sees into an MCAP file.
pub struct McapTap {
    path: PathBuf,
    producer: Mutex<Producer>,
    writer: Mutex<Option<std::thread::JoinHandle<Result<RecordSummary, RecordError>>>>,
}

impl McapTap {
    /// A recording to `path`, with the run's description as metadata named `run`, and with
    /// views (channels that Foxglove draws) if `views` says what they need.
    pub fn create(
        path: &Path,
        metadata: BTreeMap<String, String>,
        views: Option<ViewSetup>,
    ) -> Result<McapTap, RecordError> {
        let mut recorder = Recorder::create(path)?;
        recorder.write_metadata(crate::record::meta::RUN_METADATA, metadata)?;
        let (tx, rx) = mpsc::sync_channel::<Batch>(QUEUED);
        let views = views.map(Views::new);
        let writer = std::thread::Builder::new()
            .name("orsa-recorder".into())
            .spawn(move || write_all(recorder, views, rx))
            .map_err(|source| RecordError::Create { path: path.to_path_buf(), source })?;
        let producer = Producer { topics: Default::default(), batch: Batch::default(), queue: Some(tx) };
        Ok(McapTap {
            path: path.to_path_buf(),
            producer: Mutex::new(producer),
            writer: Mutex::new(Some(writer)),
        })
    }

    /// Records a supervisor event on `supervision/events`.
    pub fn supervisor_event(&self, e: &SupervisorEvent) {
        self.note(crate::record::events::SUPERVISION_EVENTS, "orsa.SupervisorEvent/1", e.at, e);
    }

    /// Records a control event that is not a pattern message (a supervisor's, a link
    /// watchdog's, a fault plan's) on `topic`, as `type_id`, at `at`.
    pub fn note<T: serde::Serialize + ?Sized>(&self, topic: &str, type_id: &str, at: Timestamp, value: &T) {
        match serde_json::to_vec(value) {
            Ok(json) => self.producer.lock().push(topic, type_id, at, &json, false),
            Err(e) => tracing::warn!("recording: an event on {topic} does not serialise: {e}"),
        }
    }

    /// Hands the views a ground-truth sample (ignored by a recording without views).
    pub fn truth(&self, sample: TruthSample) {
        let mut p = self.producer.lock();
        let before = p.batch.items.len();
        p.batch.truth.push((before, sample));
    }

    /// Says when and how the run ended (the [`RUN_ENDED_METADATA`](crate::record::meta::RUN_ENDED_METADATA)
    /// record, written with what is recorded until [`McapTap::finish`]): `at` is the moment
    /// the run ended, before its components were shut down.
    pub fn ended(&self, at: Timestamp, how: &str) {
        let ended = crate::record::meta::RunEnded { at_ns: at.as_nanos(), how: how.to_owned() };
        let name = crate::record::meta::RUN_ENDED_METADATA.to_owned();
        self.producer.lock().batch.metadata.push((name, ended.to_metadata()));
    }

    /// Closes the file once everything recorded is written: its summary, or the first error
    /// met while writing. Later messages are not recorded.
    pub fn finish(&self) -> Result<Option<RecordSummary>, RecordError> {
        {
            let mut p = self.producer.lock();
            p.flush();
            p.queue = None;
        }
        let Some(writer) = self.writer.lock().take() else { return Ok(None) };
        writer
            .join()
            .unwrap_or_else(|_| {
                Err(RecordError::Create {
                    path: self.path.clone(),
                    source: std::io::Error::other("the recording thread panicked"),
                })
            })
            .map(Some)
    }
}

/// What the views of a process hosting the robot server of `config` need; `world` if it
/// simulates one, `truth` if it hands the recording ground-truth samples.
pub fn view_setup(
    config: &crate::config::Config,
    world: Option<orsa_hardware::world::World>,
    truth: bool,
) -> ViewSetup {
    ViewSetup {
        robot: config.robot_name().to_string(),
        master: orsa_interfaces::executive::NAME.to_owned(),
        world,
        body_radius_m: config.sim.body.radius_m,
        truth,
        kinds: config.system.kinds(),
    }
}

/// One topic as the writer knows it.
struct Topic {
    topic: String,
    type_id: String,
    remote: bool,
    /// What its messages are to the views, if anything.
    view: Option<Input>,
}

/// The writer thread: every batch, in order, until the queue closes.
fn write_all(
    mut recorder: Recorder,
    mut views: Option<Views>,
    queue: mpsc::Receiver<Batch>,
) -> Result<RecordSummary, RecordError> {
    let mut topics: Vec<Topic> = Vec::new();
    for batch in queue.iter() {
        if let Err(error) = write_batch(&mut recorder, views.as_mut(), &mut topics, batch) {
            tracing::error!("recording stopped: {error}");
            // Drain what is still coming, so the run never waits on a dead file.
            for _ in queue.iter() {}
            return Err(error);
        }
    }
    recorder.finish()
}

/// Writes one batch's messages, and their views with the truth samples among them.
fn write_batch(
    recorder: &mut Recorder,
    mut views: Option<&mut Views>,
    topics: &mut Vec<Topic>,
    batch: Batch,
) -> Result<(), RecordError> {
    for (id, topic, type_id, remote) in batch.new_topics {
        debug_assert_eq!(id as usize, topics.len());
        let view = if remote { None } else { views.as_ref().and_then(|v| v.input_of(&topic)) };
        topics.push(Topic { topic, type_id, remote, view });
    }
    let mut truth = batch.truth.iter().peekable();
    let mut start = 0;
    for (i, item) in batch.items.iter().enumerate() {
        if let Some(views) = views.as_deref_mut() {
            while let Some((_, sample)) = truth.next_if(|(before, _)| *before <= i) {
                views.truth(recorder, sample)?;
            }
        }
        let t = &topics[item.topic as usize];
        let json = &batch.json[start..item.end];
        start = item.end;
        recorder.write_json_from(&t.topic, &t.type_id, item.stamp, item.stamp, json, t.remote)?;
        if let (Some(views), Some(input)) = (views.as_deref_mut(), t.view) {
            views.message(recorder, input, &t.topic, item.stamp, json)?;
        }
    }
    if let Some(views) = views {
        for (_, sample) in truth {
            views.truth(recorder, sample)?;
        }
    }
    for (name, metadata) in batch.metadata {
        recorder.write_metadata(&name, metadata)?;
    }
    Ok(())
}

impl Tap for McapTap {
    fn record(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        self.producer.lock().push(topic, type_id, stamp, json, false);
    }

    fn record_remote(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        self.producer.lock().push(topic, type_id, stamp, json, true);
    }
}
