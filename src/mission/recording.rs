//! A run recorded as MCAP: every pattern message and control event the registry's tap sees,
//! plus the supervisor's events and the run's parameters as metadata.

use crate::record::{RecordError, RecordSummary, Recorder};
use orsa_actors::Timestamp;
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::tap::Tap;
use parking_lot::Mutex;
use std::collections::BTreeMap;
use std::path::Path;

/// A tap that writes what it sees into an MCAP file.
pub struct McapTap {
    recorder: Mutex<Option<Recorder>>,
    first_error: Mutex<Option<RecordError>>,
}

impl McapTap {
    /// A recording to `path`, with the run's parameters as metadata named `run`.
    pub fn create(path: &Path, metadata: BTreeMap<String, String>) -> Result<McapTap, RecordError> {
        let mut recorder = Recorder::create(path)?;
        recorder.write_metadata("run", metadata)?;
        Ok(McapTap { recorder: Mutex::new(Some(recorder)), first_error: Mutex::new(None) })
    }

    fn write<T: serde::Serialize + ?Sized>(&self, topic: &str, type_id: &str, stamp: Timestamp, msg: &T) {
        let mut guard = self.recorder.lock();
        let Some(rec) = guard.as_mut() else { return };
        if let Err(e) = rec.write(topic, type_id, stamp, stamp, msg) {
            // The first failure is kept for the end of the run; recording stops there.
            tracing::error!("recording stopped: {e}");
            *self.first_error.lock() = Some(e);
            *guard = None;
        }
    }

    /// Records a supervisor event on `supervision/events`.
    pub fn supervisor_event(&self, e: &SupervisorEvent) {
        self.write("supervision/events", "orsa.SupervisorEvent/1", e.at, e);
    }

    /// Closes the file: its summary, or the first error met while writing.
    pub fn finish(&self) -> Result<Option<RecordSummary>, RecordError> {
        if let Some(e) = self.first_error.lock().take() {
            return Err(e);
        }
        match self.recorder.lock().take() {
            Some(rec) => rec.finish().map(Some),
            None => Ok(None),
        }
    }
}

impl Tap for McapTap {
    fn record(&self, topic: &str, type_id: &str, stamp: Timestamp, message: serde_json::Value) {
        self.write(topic, type_id, stamp, &message);
    }
}
