//! The wire encoding of communication objects and of the patterns' control messages.
//!
//! Everything that leaves a process is CBOR (RFC 8949), made from the same serde definitions
//! the process uses in memory: structs are maps with their field names as text keys, enums
//! with data are maps tagged by an `op` (control messages) or by their variant name, so any
//! language with a CBOR decoder reads them. `docs/wire-format.md` lists every message.
//!
//! Stamps (`stamp_ns`, and every [`Timestamp`](crate::Timestamp) inside an object) cross as
//! they are: nanoseconds on the system's time base, which for the live clocks of processes that
//! talk over a network is **UNIX time** (see [`crate::clock`]). Nothing is converted on the way,
//! so an encoding is the same on every thread and in every process. Hosts must keep their clocks
//! synchronised (NTP or PTP) for stamps to compare.
//!
//! Decoding never panics: bad bytes give a [`WireError`] that names what was expected.

use crate::addr::ServiceAddr;
#[cfg(test)]
use crate::clock::Timestamp;
use crate::error::{PatternError, PatternResult};
use crate::stamped::Stamped;
use serde::{Deserialize, Serialize, de::DeserializeOwned};

/// The version of the wire format described in `docs/wire-format.md`; carried in every key
/// expression (`orsa/v1/...`).
pub const WIRE_VERSION: u32 = 1;

/// A message that could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot decode {what}: {reason}")]
pub struct WireError {
    /// What was expected (a communication object identifier or a control message name).
    pub what: String,
    /// Why it failed.
    pub reason: String,
}

/// Encodes a value as CBOR.
pub fn encode<T: Serialize + ?Sized>(value: &T) -> Vec<u8> {
    let mut out = Vec::with_capacity(64);
    // Writing into a Vec cannot fail, and every orsa type serialises (no maps with non-text
    // keys that CBOR could refuse); an error here would be a bug in a serde impl.
    if let Err(e) = ciborium::into_writer(value, &mut out) {
        tracing::error!("CBOR encoding failed: {e}");
        out.clear();
    }
    out
}

/// Decodes a CBOR value; `what` names the expected type in the error.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], what: &str) -> Result<T, WireError> {
    ciborium::from_reader(bytes).map_err(|e| WireError { what: what.to_string(), reason: e.to_string() })
}

/// A stamped communication object on the wire: `{"seq", "stamp_ns", "value"}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WireStamped<T> {
    /// The sender's sequence number (from 1).
    pub seq: u64,
    /// When it was sent (on the system's time base: UNIX time for a live clock).
    pub stamp_ns: crate::Timestamp,
    /// The communication object.
    pub value: T,
}

impl<T> From<Stamped<T>> for WireStamped<T> {
    fn from(m: Stamped<T>) -> Self {
        WireStamped { seq: m.seq, stamp_ns: m.sent_at, value: m.value }
    }
}

impl<T> From<WireStamped<T>> for Stamped<T> {
    fn from(w: WireStamped<T>) -> Self {
        Stamped { seq: w.seq, sent_at: w.stamp_ns, value: w.value }
    }
}

/// Encodes a stamped value, borrowing it.
pub fn encode_stamped<T: Serialize>(msg: &Stamped<T>) -> Vec<u8> {
    #[derive(Serialize)]
    struct Ref<'a, T> {
        seq: u64,
        stamp_ns: crate::Timestamp,
        value: &'a T,
    }
    encode(&Ref { seq: msg.seq, stamp_ns: msg.sent_at, value: &msg.value })
}

/// Decodes a stamped value.
pub fn decode_stamped<T: DeserializeOwned>(bytes: &[u8], what: &str) -> Result<Stamped<T>, WireError> {
    decode::<WireStamped<T>>(bytes, what).map(Stamped::from)
}

/// A pattern error as it crosses the wire: a stable code, a message, and the details some codes
/// carry.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireFailure {
    /// A stable code: `unknown_service`, `unknown_component`, `incompatible_service`,
    /// `already_registered`, `unknown_port`, `disconnected`, `unavailable`, `no_answer`,
    /// `timeout`, `cancelled`, `no_data`, `not_active`, `busy`, `unknown`, `invalid_argument`,
    /// `decode`, `link`, `remote`.
    pub code: String,
    /// The error as text.
    pub message: String,
    /// Code-specific details: the held substates for `busy`; the component and port for
    /// `unknown_port`; the address for the service codes.
    #[serde(default)]
    pub detail: Vec<String>,
}

impl WireFailure {
    /// The wire form of an error.
    pub fn from_error(e: &PatternError) -> Self {
        let (code, detail): (&str, Vec<String>) = match e {
            PatternError::UnknownService(a) => ("unknown_service", vec![a.to_string()]),
            PatternError::UnknownComponent(c) => ("unknown_component", vec![c.clone()]),
            PatternError::IncompatibleService { addr, .. } => {
                ("incompatible_service", vec![addr.to_string()])
            }
            PatternError::AlreadyRegistered(n) => ("already_registered", vec![n.clone()]),
            PatternError::UnknownPort { component, port } => {
                ("unknown_port", vec![component.clone(), port.clone()])
            }
            PatternError::Disconnected(p) => ("disconnected", vec![p.clone()]),
            PatternError::Unavailable(a) => ("unavailable", vec![a.to_string()]),
            PatternError::NoAnswer(a) => ("no_answer", vec![a.to_string()]),
            PatternError::Timeout => ("timeout", vec![]),
            PatternError::Cancelled => ("cancelled", vec![]),
            PatternError::NoData => ("no_data", vec![]),
            PatternError::NotActive(m) => ("not_active", vec![m.clone()]),
            PatternError::Busy(subs) => ("busy", subs.clone()),
            PatternError::Unknown { name, .. } => ("unknown", vec![name.clone()]),
            PatternError::InvalidArgument(m) => ("invalid_argument", vec![m.clone()]),
            PatternError::Decode(m) => ("decode", vec![m.clone()]),
            PatternError::Remote(m) => ("remote", vec![m.clone()]),
            PatternError::Link(m) => ("link", vec![m.clone()]),
        };
        WireFailure { code: code.to_string(), message: e.to_string(), detail }
    }

    /// The error this failure stands for. Codes whose details are missing or unknown codes
    /// become [`PatternError::Remote`] with the message.
    pub fn into_error(self) -> PatternError {
        let addr = self.detail.first().and_then(|a| a.parse::<ServiceAddr>().ok());
        let first = self.detail.first().cloned();
        match (self.code.as_str(), addr, first) {
            ("unknown_service", Some(a), _) => PatternError::UnknownService(a),
            ("unavailable", Some(a), _) => PatternError::Unavailable(a),
            ("no_answer", Some(a), _) => PatternError::NoAnswer(a),
            ("unknown_component", _, Some(c)) => PatternError::UnknownComponent(c),
            ("unknown_port", _, Some(component)) if self.detail.len() == 2 => {
                PatternError::UnknownPort { component, port: self.detail[1].clone() }
            }
            ("disconnected", _, Some(p)) => PatternError::Disconnected(p),
            ("timeout", ..) => PatternError::Timeout,
            ("cancelled", ..) => PatternError::Cancelled,
            ("no_data", ..) => PatternError::NoData,
            ("not_active", _, m) => PatternError::NotActive(m.unwrap_or(self.message)),
            ("busy", ..) => PatternError::Busy(self.detail),
            ("invalid_argument", _, m) => PatternError::InvalidArgument(m.unwrap_or(self.message)),
            ("decode", _, m) => PatternError::Decode(m.unwrap_or(self.message)),
            ("link", _, m) => PatternError::Link(m.unwrap_or(self.message)),
            _ => PatternError::Remote(self.message),
        }
    }
}

/// The answer to every request on the wire: `{"ok": value}` or `{"err": failure}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reply<T> {
    /// Success, with the value.
    Ok(T),
    /// Failure.
    Err(WireFailure),
}

impl<T> Reply<T> {
    /// The reply for a result.
    pub fn from_result(r: PatternResult<T>) -> Self {
        match r {
            Ok(v) => Reply::Ok(v),
            Err(e) => Reply::Err(WireFailure::from_error(&e)),
        }
    }

    /// The result this reply stands for.
    pub fn into_result(self) -> PatternResult<T> {
        match self {
            Reply::Ok(v) => Ok(v),
            Reply::Err(f) => Err(f.into_error()),
        }
    }
}

/// Decodes a reply to a request to `addr`; an undecodable reply is a [`PatternError::Decode`].
pub fn decode_reply<T: DeserializeOwned>(bytes: &[u8], addr: &ServiceAddr, what: &str) -> PatternResult<T> {
    decode::<Reply<T>>(bytes, what)
        .map_err(|e| PatternError::Decode(format!("reply from {addr}: {e}")))?
        .into_result()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_cross_as_they_are_on_every_thread() {
        const UNIX: u64 = 1_763_000_000_123_456_789;
        let msg = Stamped { seq: 3, sent_at: Timestamp(UNIX), value: Timestamp(UNIX + 5) };
        let bytes = encode_stamped(&msg);
        let back: Stamped<Timestamp> = decode_stamped(&bytes, "orsa.Timestamp").expect("decodes");
        assert_eq!(back, msg);
        // The same bytes from another thread: an encoding depends on nothing but the value.
        let elsewhere = std::thread::spawn(move || encode_stamped(&msg)).join().expect("thread");
        assert_eq!(elsewhere, bytes);
        // CBOR's unsigned integer, as JSON's: the raw nanoseconds.
        assert_eq!(decode::<serde_json::Value>(&encode(&Timestamp(UNIX)), "u64").expect("decodes"), UNIX);
        assert_eq!(serde_json::to_string(&Timestamp(7)).expect("json"), "7");
    }

    #[test]
    fn failures_keep_their_variant() {
        let errors = vec![
            PatternError::UnknownService(ServiceAddr::new("a", "b")),
            PatternError::UnknownComponent("a".into()),
            PatternError::UnknownPort { component: "a".into(), port: "vel".into() },
            PatternError::Disconnected("vel".into()),
            PatternError::Unavailable(ServiceAddr::new("a", "b")),
            PatternError::NoAnswer(ServiceAddr::new("a", "b")),
            PatternError::Timeout,
            PatternError::Cancelled,
            PatternError::NoData,
            PatternError::NotActive("stopped".into()),
            PatternError::Busy(vec!["compute".into()]),
            PatternError::InvalidArgument("every".into()),
            PatternError::Decode("bad".into()),
        ];
        for e in errors {
            let bytes = encode(&Reply::<()>::from_result(Err(e.clone())));
            let back = decode::<Reply<()>>(&bytes, "reply").expect("decodes").into_result();
            assert_eq!(back, Err(e));
        }
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        for bytes in [&b""[..], b"\xff\xff", b"\xa1\x63seq", b"not cbor at all"] {
            let r = decode_stamped::<f64>(bytes, "orsa.F64/1");
            let e = r.expect_err("garbage must not decode");
            assert!(e.to_string().contains("orsa.F64/1"), "{e}");
        }
    }
}
