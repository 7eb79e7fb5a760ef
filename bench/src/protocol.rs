//! The protocol between the bench process and its peer: the sample both paths carry, the
//! peer's control requests and replies, and the keys of the raw zenoh path.

use orsa_actors::comm_object;
use serde::{Deserialize, Serialize};
use std::time::{SystemTime, UNIX_EPOCH};

/// One reading of the padding: a `DistanceReading`'s fields, with the stamp as a plain integer
/// (as a `Timestamp` is on the wire, so both payloads are the same size).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Reading {
    pub(crate) sensor_id: u8,
    pub(crate) stamp_ns: u64,
    pub(crate) valid: bool,
    pub(crate) distance_m: f64,
}

/// What both paths carry: sized like a `DistanceScan` (16 readings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Sample {
    /// Per-path sequence number, from 1.
    pub(crate) seq: u64,
    /// The sender's UNIX time just before sending, ns.
    pub(crate) sent_unix_ns: u64,
    /// The padding.
    pub(crate) readings: Vec<Reading>,
}
comm_object!(Sample, "orsa.bench.Sample/1");

impl Sample {
    /// Sixteen readings with realistic values (stamps near now as UNIX ns, so their CBOR is
    /// as long as a real scan's).
    pub(crate) fn padding() -> Vec<Reading> {
        (0..16u8)
            .map(|i| Reading {
                sensor_id: i,
                stamp_ns: 1_763_700_000_000_000_000 + u64::from(i) * 4_000_000,
                valid: i % 5 != 0,
                distance_m: 0.25 + 0.137 * f64::from(i),
            })
            .collect()
    }
}

/// Bench process to peer: send sample `seq` on path `path` now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct Go {
    pub(crate) path: u8,
    pub(crate) seq: u64,
}

/// A step of a behaviour in the peer, with its stamps as UNIX time (see `sense::across`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct WireStep {
    pub(crate) behaviour: String,
    pub(crate) update_unix_ns: u64,
    pub(crate) fired_unix_ns: u64,
    pub(crate) handled_unix_ns: u64,
    pub(crate) done_unix_ns: u64,
    pub(crate) v: f64,
    pub(crate) w: f64,
}

/// Requests to the peer's control service.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub(crate) enum PeerRequest {
    /// Answer `Ok`.
    Ping,
    /// Start both behaviours (traced), driving `robot` in the bench process.
    StartBehaviours { robot: String },
    /// Stop them and answer with their steps.
    StopBehaviours,
    /// Send `per_path` samples on every path on the peer's own timer, one every `spacing_us`,
    /// the paths taking turns (path `k % 4` at tick `k`), path `i`'s numbered from
    /// `first_seq[i]`; answer `Ok` after the last.
    Stream { per_path: u64, first_seq: Vec<u64>, spacing_us: u64 },
    /// Answer how long sending took on each path since the last time asked.
    TakePutCosts,
    /// Answer `Ok` and leave.
    Quit,
}
comm_object!(PeerRequest, "orsa.bench.PeerRequest/1");

/// The peer's answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub(crate) enum PeerReply {
    Ok,
    Steps { steps: Vec<WireStep>, restarts: u64 },
    PutCosts { per_path: Vec<super::Latency> },
    Failed { reason: String },
}
comm_object!(PeerReply, "orsa.bench.PeerReply/1");

/// CBOR, as the raw paths and the go messages use it.
pub(crate) fn cbor<T: Serialize>(value: &T) -> Vec<u8> {
    let mut out = Vec::with_capacity(512);
    // Writing plain structs into a Vec cannot fail.
    let _ = ciborium::into_writer(value, &mut out);
    out
}

/// The value of CBOR bytes.
pub(crate) fn uncbor<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Option<T> {
    ciborium::from_reader(bytes).ok()
}

/// The raw keys of one run, under its prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct RawKeys {
    pub(crate) go: String,
    pub(crate) callback: String,
    pub(crate) task: String,
    pub(crate) actor: String,
}

impl RawKeys {
    pub(crate) fn new(prefix: &str) -> RawKeys {
        RawKeys {
            go: format!("{prefix}/bench/go"),
            callback: format!("{prefix}/bench/raw/callback"),
            task: format!("{prefix}/bench/raw/task"),
            actor: format!("{prefix}/bench/raw/actor"),
        }
    }
}

/// The key prefix of a run, from the endpoint the bench process listens on (the port was free,
/// so two runs on one host do not see each other).
pub(crate) fn prefix_for(endpoint: &str) -> String {
    let port: String =
        endpoint.rsplit(':').next().unwrap_or("").chars().filter(char::is_ascii_digit).collect();
    format!("orsabench{port}")
}

/// UNIX time now, ns.
pub(crate) fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}
