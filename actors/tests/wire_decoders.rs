//! Wire decoders never panic: every decoder of bytes from another process is fed arbitrary
//! bytes, well-formed CBOR of the wrong shape, and real encodings with bytes flipped, set,
//! inserted, deleted or cut off. Each must answer a value or an error that names what it
//! expected; a value it answers must survive a re-encoding unchanged. The services are driven
//! through the byte-level face a transport calls (`registry.local(addr).served`), so a peer's
//! bytes take the same path as in a running system, and every request is answered with bytes
//! that decode as a `Reply`.
//!
//! (About 800 lines, over the usual 600: one property, checked for every decoder of the wire,
//! each a short generator and a short check.)
//!
//! Cases run with a fixed seed (so a run is repeatable); set `PROPTEST_RNG_SEED` and
//! `PROPTEST_CASES` to explore further.

use ciborium::value::Value;
use orsa_actors::ServiceAddr;
use orsa_actors::event::{EventMode, EventServer};
use orsa_actors::query::{QueryRequest, QueryServer};
use orsa_actors::send::SendServer;
use orsa_actors::service::{EventService, QueryService, SendService};
use orsa_actors::state::{StateRequest, StateSlave, StateSpec, StateStatus};
use orsa_actors::transport::ByteSink;
use orsa_actors::wire::{
    Reply, WireFailure, WireStamped, decode, decode_reply, decode_stamped, encode, encode_stamped,
};
use orsa_actors::wiring::{PortStatus, WiringRequest, WiringSlave};
use orsa_actors::{Clock, CommObject, PatternError, Registry, Sink, Stamped, Timestamp, comm_object};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::num::NonZeroU32;
use std::sync::{Arc, Mutex};

/// The UNIX time the test clocks start at (2024-01-01), as a live clock's would.
const EPOCH_UNIX_NS: u64 = 1_704_067_200_000_000_000;

/// Poses sent to a robot.
const POSE: SendService<Pose> = SendService::new("pose");
/// The length of a pose's label.
const LABELS: QueryService<Pose, u64> = QueryService::new("labels");
/// Speed commands to a robot: the one target a behaviour's `vel` port can have.
const SPEED: SendService<f64> = SendService::new("speed");
/// Fires to activations whose pose's label is no longer than the state.
const NEAR: EventService<Pose, u64> = EventService::new("near");
/// A plain Send service, for the operations it does not have.
const SEND: SendService<u64> = SendService::new("send");

/// A runner for `cases` cases (unless `PROPTEST_CASES` says otherwise), with a fixed seed
/// unless `PROPTEST_RNG_SEED` gives one, writing no regression files.
fn runner(cases: u32) -> TestRunner {
    let base = Config::default();
    TestRunner::new(Config {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() { base.cases } else { cases },
        failure_persistence: None,
        rng_seed: match base.rng_seed {
            RngSeed::Random => RngSeed::Fixed(0x6f72_7361_7769_7265),
            seed => seed,
        },
        ..base
    })
}

/// Runs `test` on every input of `strategy`; a failing (or panicking) case fails the test with
/// the smallest input proptest found.
fn check<S: Strategy>(cases: u32, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S::Value: std::fmt::Debug,
{
    if let Err(e) = runner(cases).run(&strategy, test) {
        panic!("{e}");
    }
}

fn test_clock() -> Clock {
    Clock::starting_at(tokio::time::Instant::now(), orsa_actors::Timestamp(EPOCH_UNIX_NS))
}

/// A paused runtime: every wait a request makes (a state change's timeout) passes at once.
fn paused_runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread().enable_all().start_paused(true).build().expect("runtime")
}

// ---------------------------------------------------------------------------------------------
// Communication objects

/// What a pose-like communication object looks like: stamps inside the value, an enum, an
/// optional, a list and text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Pose {
    at: Timestamp,
    seen: Option<Timestamp>,
    x_m: f64,
    label: String,
    mode: Mode,
    ranges_m: Vec<f64>,
}
comm_object!(Pose, "orsa.test.Pose/1");

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Mode {
    Idle,
    Drive { v_m_s: f64 },
}

fn pose() -> impl Strategy<Value = Pose> {
    let mode = prop_oneof![Just(Mode::Idle), any::<f64>().prop_map(|v_m_s| Mode::Drive { v_m_s })];
    (
        0..u64::MAX / 2,
        proptest::option::of(0..u64::MAX / 2),
        any::<f64>(),
        ".{0,8}",
        mode,
        vec(any::<f64>(), 0..5),
    )
        .prop_map(|(at, seen, x_m, label, mode, ranges_m)| Pose {
            at: Timestamp(at),
            seen: seen.map(Timestamp),
            x_m,
            label,
            mode,
            ranges_m,
        })
}

/// Equal, with NaN equal to NaN (what a decoder can give back of a float).
fn same_f64(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn same_pose(a: &Pose, b: &Pose) -> bool {
    let modes = match (&a.mode, &b.mode) {
        (Mode::Idle, Mode::Idle) => true,
        (Mode::Drive { v_m_s: x }, Mode::Drive { v_m_s: y }) => same_f64(*x, *y),
        _ => false,
    };
    a.at == b.at
        && a.seen == b.seen
        && same_f64(a.x_m, b.x_m)
        && a.label == b.label
        && modes
        && a.ranges_m.len() == b.ranges_m.len()
        && a.ranges_m.iter().zip(&b.ranges_m).all(|(x, y)| same_f64(*x, *y))
}

// ---------------------------------------------------------------------------------------------
// Inputs: arbitrary bytes, arbitrary CBOR, mutated real encodings

/// One change to a valid encoding.
#[derive(Debug, Clone)]
enum Edit {
    /// Flip one bit of a byte.
    Flip(Index, u8),
    /// Overwrite a byte.
    Set(Index, u8),
    /// Insert a byte.
    Insert(Index, u8),
    /// Delete a byte.
    Delete(Index),
    /// Cut the message off.
    Truncate(Index),
    /// Insert a few bytes.
    Splice(Index, Vec<u8>),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        3 => (any::<Index>(), 0u8..8).prop_map(|(i, bit)| Edit::Flip(i, bit)),
        3 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Insert(i, b)),
        2 => any::<Index>().prop_map(Edit::Delete),
        1 => any::<Index>().prop_map(Edit::Truncate),
        1 => (any::<Index>(), vec(any::<u8>(), 1..9)).prop_map(|(i, b)| Edit::Splice(i, b)),
    ]
}

fn apply(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let len = bytes.len();
        match e {
            Edit::Insert(i, b) => bytes.insert(i.index(len + 1), *b),
            Edit::Splice(i, more) => {
                let at = i.index(len + 1);
                bytes.splice(at..at, more.iter().copied());
            }
            _ if len == 0 => {}
            Edit::Flip(i, bit) => bytes[i.index(len)] ^= 1 << bit,
            Edit::Set(i, b) => bytes[i.index(len)] = *b,
            Edit::Delete(i) => {
                bytes.remove(i.index(len));
            }
            Edit::Truncate(i) => bytes.truncate(i.index(len)),
        }
    }
    bytes
}

/// The keys orsa's messages use, so generated maps often have the right names with the wrong
/// values.
const KEYS: &[&str] = &[
    "seq",
    "stamp_ns",
    "value",
    "op",
    "main",
    "timeout_ms",
    "port",
    "target",
    "ok",
    "err",
    "code",
    "message",
    "detail",
    "at",
    "seen",
    "x_m",
    "label",
    "mode",
    "drive",
    "v_m_s",
    "ranges_m",
    "current",
    "pending",
    "held",
    "main_states",
    "info",
    "pattern",
    "types",
    "component",
    "service",
    "set",
    "try_set",
    "deactivate",
    "status",
    "connect",
    "disconnect",
    "ports",
    "activation",
];

fn key() -> impl Strategy<Value = Value> {
    proptest::sample::select(KEYS).prop_map(|k| Value::Text(k.to_string()))
}

/// Well-formed CBOR of any shape: nested arrays, maps (often with orsa's keys), tags.
fn cbor() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        any::<u64>().prop_map(|n| Value::Integer(n.into())),
        any::<i64>().prop_map(|n| Value::Integer(n.into())),
        any::<f64>().prop_map(Value::Float),
        any::<bool>().prop_map(Value::Bool),
        Just(Value::Null),
        ".{0,10}".prop_map(Value::Text),
        key(),
        vec(any::<u8>(), 0..10).prop_map(Value::Bytes),
    ];
    leaf.prop_recursive(5, 64, 6, |inner| {
        prop_oneof![
            vec(inner.clone(), 0..6).prop_map(Value::Array),
            vec((key(), inner.clone()), 0..7).prop_map(Value::Map),
            vec((inner.clone(), inner.clone()), 0..4).prop_map(Value::Map),
            (any::<u64>(), inner).prop_map(|(t, v)| Value::Tag(t, Box::new(v))),
        ]
    })
}

/// What a decoder is fed: arbitrary bytes, arbitrary CBOR, a valid encoding mutated, or a valid
/// encoding as it is.
fn inputs(valid: BoxedStrategy<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        2 => vec(any::<u8>(), 0..96),
        2 => cbor().prop_map(|v| encode(&v)),
        5 => (valid.clone(), vec(edit(), 1..6)).prop_map(|(b, e)| apply(b, &e)),
        1 => valid,
    ]
}

/// Valid encodings of stamped `T`s, as a peer sends them.
fn stamped_encodings<T: CommObject>(value: impl Strategy<Value = T> + 'static) -> BoxedStrategy<Vec<u8>> {
    (any::<u64>(), 0..u64::MAX / 2, value)
        .prop_map(move |(seq, stamp, value)| {
            encode_stamped(&Stamped { seq, sent_at: Timestamp(stamp), value })
        })
        .boxed()
}

// ---------------------------------------------------------------------------------------------
// Stamped communication objects

/// `bytes` decode as a stamped `T` or fail with an error naming `T`; what decodes re-encodes
/// to bytes that decode to the same message, and that encoding is a fixed point.
fn decodes_stably<T: CommObject>(bytes: &[u8], same: impl Fn(&T, &T) -> bool) -> Result<(), TestCaseError> {
    match decode_stamped::<T>(bytes, T::ID) {
        Ok(msg) => {
            let again = encode_stamped(&msg);
            let back = decode_stamped::<T>(&again, T::ID)
                .map_err(|e| TestCaseError::fail(format!("a re-encoded {} does not decode: {e}", T::ID)))?;
            prop_assert_eq!(back.seq, msg.seq);
            prop_assert_eq!(back.sent_at, msg.sent_at);
            prop_assert!(same(&back.value, &msg.value), "{:?} came back as {:?}", msg.value, back.value);
            prop_assert_eq!(encode_stamped(&back), again, "the encoding is not a fixed point");
            // As the plain envelope, the same bytes decode too.
            prop_assert!(decode::<WireStamped<T>>(bytes, T::ID).is_ok());
        }
        Err(e) => {
            prop_assert_eq!(&e.what, T::ID);
            let text = e.to_string();
            let prefix = format!("cannot decode {}: ", T::ID);
            prop_assert!(text.starts_with(&prefix), "{}", text);
        }
    }
    Ok(())
}

#[test]
fn stamped_u64_decodes_or_fails_naming_its_type() {
    let valid = stamped_encodings(any::<u64>());
    check(1024, inputs(valid), |bytes| decodes_stably::<u64>(&bytes, |a, b| a == b));
}

#[test]
fn stamped_f64_decodes_or_fails_naming_its_type() {
    let valid = stamped_encodings(any::<f64>());
    check(1024, inputs(valid), |bytes| decodes_stably::<f64>(&bytes, |a, b| same_f64(*a, *b)));
}

#[test]
fn stamped_string_decodes_or_fails_naming_its_type() {
    let valid = stamped_encodings(".{0,24}");
    check(1024, inputs(valid), |bytes| decodes_stably::<String>(&bytes, |a, b| a == b));
}

#[test]
fn stamped_struct_with_timestamps_decodes_or_fails_naming_its_type() {
    let valid = stamped_encodings(pose());
    check(1024, inputs(valid), |bytes| decodes_stably::<Pose>(&bytes, same_pose));
}

// ---------------------------------------------------------------------------------------------
// Requests and replies

fn status() -> impl Strategy<Value = StateStatus> {
    let name = prop_oneof![Just("neutral".to_string()), Just("active".to_string()), "[a-z]{0,6}"];
    (
        name.clone(),
        proptest::option::of(name.clone()),
        proptest::collection::btree_map(name.clone(), any::<usize>(), 0..3),
        proptest::collection::btree_map(name.clone(), proptest::collection::btree_set(name, 0..3), 0..3),
    )
        .prop_map(|(current, pending, held, main_states)| StateStatus {
            current,
            pending,
            held,
            main_states,
        })
}

fn failure() -> impl Strategy<Value = WireFailure> {
    let code = prop_oneof![
        proptest::sample::select(vec![
            "unknown_service",
            "unknown_component",
            "incompatible_service",
            "already_registered",
            "unknown_port",
            "disconnected",
            "unavailable",
            "no_answer",
            "timeout",
            "cancelled",
            "no_data",
            "not_active",
            "busy",
            "unknown",
            "invalid_argument",
            "decode",
            "link",
            "remote",
        ])
        .prop_map(str::to_string),
        ".{0,8}",
    ];
    let detail = prop_oneof![Just("a/b".to_string()), Just("a".to_string()), ".{0,8}"];
    (code, ".{0,12}", vec(detail, 0..4)).prop_map(|(code, message, detail)| WireFailure {
        code,
        message,
        detail,
    })
}

fn reply<T: std::fmt::Debug>(ok: impl Strategy<Value = T>) -> impl Strategy<Value = Reply<T>> {
    prop_oneof![ok.prop_map(Reply::Ok), failure().prop_map(Reply::Err)]
}

/// `bytes` decode as a `Reply<T>` or fail naming `what`; the answer of `decode_reply` agrees:
/// a reply that does not decode is a `Decode` error naming the service and the type, one that
/// does is its value or the error it carries.
fn reply_decodes_stably<T>(bytes: &[u8], what: &str) -> Result<(), TestCaseError>
where
    T: serde::de::DeserializeOwned + Serialize + PartialEq + std::fmt::Debug,
{
    let addr = ServiceAddr::new("peer", "service");
    let raw = decode::<Reply<T>>(bytes, what);
    let result = decode_reply::<T>(bytes, &addr, what);
    match raw {
        Ok(reply) => {
            let again = encode(&reply);
            let back = decode::<Reply<T>>(&again, what)
                .map_err(|e| TestCaseError::fail(format!("a re-encoded reply does not decode: {e}")))?;
            prop_assert_eq!(&back, &reply);
            prop_assert_eq!(encode(&back), again, "the encoding is not a fixed point");
            match reply {
                Reply::Ok(v) => prop_assert_eq!(result, Ok(v)),
                Reply::Err(f) => prop_assert_eq!(result, Err(f.into_error())),
            }
        }
        Err(e) => {
            prop_assert_eq!(&e.what, what);
            let expected = format!("reply from peer/service: cannot decode {what}: ");
            match result {
                Err(PatternError::Decode(m)) => prop_assert!(m.starts_with(&expected), "{}", m),
                other => prop_assert!(false, "an undecodable reply gave {:?}", other),
            }
        }
    }
    Ok(())
}

#[test]
fn state_status_reply_decodes_or_fails_naming_its_type() {
    let valid = reply(status()).prop_map(move |r| encode(&r)).boxed();
    check(1024, inputs(valid), |bytes| reply_decodes_stably::<StateStatus>(&bytes, "orsa.StateStatus/1"));
}

#[test]
fn query_answer_reply_decodes_or_fails_naming_its_type() {
    let answer = (any::<u64>(), 0..u64::MAX / 2, any::<u64>()).prop_map(|(seq, stamp, value)| WireStamped {
        seq,
        stamp_ns: Timestamp(stamp),
        value,
    });
    let valid = reply(answer).prop_map(move |r| encode(&r)).boxed();
    check(1024, inputs(valid), |bytes| reply_decodes_stably::<WireStamped<u64>>(&bytes, "orsa.U64/1"));
}

#[test]
fn port_list_reply_decodes_or_fails_naming_its_type() {
    let port = ("[a-z]{1,6}", any::<bool>(), proptest::option::of(("[a-z]{1,6}", "[a-z]{1,6}"))).prop_map(
        |(port, query, target)| PortStatus {
            port,
            info: if query {
                orsa_actors::ServiceInfo::new(orsa_actors::PatternKind::Query, &["orsa.U64/1", "orsa.F64/1"])
            } else {
                orsa_actors::ServiceInfo::new(orsa_actors::PatternKind::Send, &["orsa.F64/1"])
            },
            target: target.map(|(c, s)| ServiceAddr::new(c, s)),
        },
    );
    let valid = reply(vec(port, 0..3)).prop_map(move |r| encode(&r)).boxed();
    check(1024, inputs(valid), |bytes| {
        reply_decodes_stably::<Vec<PortStatus>>(&bytes, "orsa.PortStatus/1 list")
    });
}

/// A wire failure of any code and details becomes an error, never a panic, and that error
/// keeps its variant when it crosses the wire again.
#[test]
fn wire_failures_become_errors_that_keep_their_variant() {
    check(1024, failure(), |f| {
        let e = f.into_error();
        let again = WireFailure::from_error(&e).into_error();
        prop_assert_eq!(std::mem::discriminant(&again), std::mem::discriminant(&e));
        if !matches!(e, PatternError::Remote(_)) {
            prop_assert_eq!(again, e);
        }
        Ok(())
    });
}

fn state_request() -> impl Strategy<Value = StateRequest> {
    let main = prop_oneof![Just("neutral".to_string()), Just("active".to_string()), ".{0,8}"];
    prop_oneof![
        (main.clone(), any::<u64>()).prop_map(|(main, timeout_ms)| StateRequest::Set { main, timeout_ms }),
        main.prop_map(|main| StateRequest::TrySet { main }),
        any::<u64>().prop_map(|timeout_ms| StateRequest::Deactivate { timeout_ms }),
        Just(StateRequest::Status),
    ]
}

fn wiring_request() -> impl Strategy<Value = WiringRequest> {
    let port = prop_oneof![Just("vel".to_string()), ".{0,6}"];
    let target = prop_oneof![
        Just("robot/speed".to_string()),
        Just("robot/pose".to_string()),
        Just("slave/state".to_string()),
        ".{0,12}",
    ];
    prop_oneof![
        (port.clone(), target).prop_map(|(port, target)| WiringRequest::Connect { port, target }),
        port.prop_map(|port| WiringRequest::Disconnect { port }),
        Just(WiringRequest::Ports),
    ]
}

/// `bytes` decode as `T` or fail naming `what`; what decodes re-encodes to itself.
fn plain_decodes_stably<T>(bytes: &[u8], what: &str) -> Result<(), TestCaseError>
where
    T: serde::de::DeserializeOwned + Serialize + PartialEq + std::fmt::Debug,
{
    match decode::<T>(bytes, what) {
        Ok(v) => {
            let again = encode(&v);
            prop_assert_eq!(decode::<T>(&again, what).ok(), Some(v));
        }
        Err(e) => {
            prop_assert_eq!(&e.what, what);
            prop_assert!(e.to_string().starts_with(&format!("cannot decode {what}: ")), "{}", e);
        }
    }
    Ok(())
}

#[test]
fn state_request_decodes_or_fails_naming_its_type() {
    let valid = state_request().prop_map(|r| encode(&r)).boxed();
    check(1024, inputs(valid), |bytes| plain_decodes_stably::<StateRequest>(&bytes, "orsa.StateRequest/1"));
}

#[test]
fn wiring_request_decodes_or_fails_naming_its_type() {
    let valid = wiring_request().prop_map(|r| encode(&r)).boxed();
    check(1024, inputs(valid), |bytes| plain_decodes_stably::<WiringRequest>(&bytes, "orsa.WiringRequest/1"));
}

// ---------------------------------------------------------------------------------------------
// Through real services, as a transport calls them

fn served(registry: &Registry, addr: &str) -> Arc<dyn orsa_actors::transport::Served> {
    let addr: ServiceAddr = addr.parse().expect("address");
    registry.local(&addr).expect("the service is registered").served
}

/// A `Decode` error about `addr` that names `what`.
fn is_decode_error(e: &PatternError, addr: &str, what: &str) -> bool {
    matches!(e, PatternError::Decode(m) if m.contains(addr) && m.contains(&format!("cannot decode {what}: ")))
}

/// A Send server hands on exactly what the bytes decode to, and answers a `Decode` error
/// naming itself and the type (handing on nothing) when they do not decode.
#[test]
fn send_server_delivers_what_decodes_and_refuses_the_rest() {
    let rt = paused_runtime();
    let _enter = rt.enter();
    let registry = Registry::with_clock(test_clock());
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<Pose>>();
    let _server =
        SendServer::<Pose>::register(&registry, POSE.on("robot"), Sink::channel(tx)).expect("server");
    let served = served(&registry, "robot/pose");
    let rx = Mutex::new(rx);
    let valid = stamped_encodings(pose());
    check(512, inputs(valid), |bytes| {
        let mut rx = rx.lock().expect("receiver");
        let expected = decode_stamped::<Pose>(&bytes, Pose::ID);
        match served.serve_send(&bytes) {
            Ok(()) => {
                let got = rx.try_recv().map_err(|_| TestCaseError::fail("accepted but not delivered"))?;
                let want =
                    expected.map_err(|e| TestCaseError::fail(format!("accepted bytes that fail: {e}")))?;
                prop_assert_eq!(got.seq, want.seq);
                prop_assert_eq!(got.sent_at, want.sent_at);
                prop_assert!(same_pose(&got.value, &want.value));
            }
            Err(e) => {
                prop_assert!(is_decode_error(&e, "robot/pose", Pose::ID), "{:?}", e);
                prop_assert!(expected.is_err(), "refused bytes that decode");
            }
        }
        prop_assert!(rx.try_recv().is_err(), "delivered more than one message");
        Ok(())
    });
}

/// A Query server answers every request with a reply: the answer to what decodes, a `decode`
/// failure naming the request type to the rest.
#[test]
fn query_server_answers_every_request_with_a_reply() {
    let rt = paused_runtime();
    let registry = rt.block_on(async { Registry::with_clock(test_clock()) });
    let answer = Sink::from_fn(|q: QueryRequest<Pose, u64>| {
        let n = q.request.value.label.chars().count() as u64;
        let _ = q.answer(n);
        Ok(())
    });
    let _server = QueryServer::<Pose, u64>::register(&registry, LABELS.on("calc"), answer).expect("server");
    let served = served(&registry, "calc/labels");
    let valid = stamped_encodings(pose());
    check(512, inputs(valid), |bytes| {
        let request = decode_stamped::<Pose>(&bytes, Pose::ID);
        let bytes_out = rt.block_on(Arc::clone(&served).serve_request(&bytes));
        let reply = decode::<Reply<WireStamped<u64>>>(&bytes_out, "reply")
            .map_err(|e| TestCaseError::fail(format!("the reply does not decode: {e}")))?;
        match (request, reply) {
            (Ok(req), Reply::Ok(ans)) => {
                prop_assert_eq!(ans.seq, req.seq);
                prop_assert_eq!(ans.value, req.value.label.chars().count() as u64);
            }
            (Err(_), Reply::Err(f)) => {
                prop_assert_eq!(&f.code, "decode");
                prop_assert!(is_decode_error(&f.into_error(), "calc/labels", Pose::ID));
            }
            (req, reply) => prop_assert!(false, "request {:?} got {:?}", req, reply),
        }
        // A query service has no one-way face.
        prop_assert!(matches!(served.serve_send(&bytes), Err(PatternError::InvalidArgument(_))));
        Ok(())
    });
}

/// A State slave answers every request with a reply carrying its status or why not; an
/// undecodable request is a `decode` failure naming `orsa.StateRequest/1`. Half the cases run
/// with an activity holding a substate, so changes that exclude it wait out their timeout.
#[test]
fn state_slave_answers_every_request_with_a_reply() {
    let rt = paused_runtime();
    let registry = rt.block_on(async { Registry::with_clock(test_clock()) });
    let spec = StateSpec::new().main_state("active", &["drive"]).main_state("parked", &[]);
    let slave = StateSlave::register(&registry, "slave", spec).expect("slave");
    let served = served(&registry, "slave/state");
    let valid = state_request().prop_map(|r| encode(&r)).boxed();
    let declared: BTreeSet<String> = ["neutral", "active", "parked"].into_iter().map(String::from).collect();
    check(512, (inputs(valid), any::<bool>()), |(bytes, hold)| {
        let request = decode::<StateRequest>(&bytes, "orsa.StateRequest/1");
        // On a paused clock tokio walks a far deadline in steps of its timer wheel's top level
        // (2^36 ms), so a change blocked for u64::MAX ms would cost minutes of CPU to time out:
        // hold the substate only for waits that end within about 35 years.
        let wait_ms = match &request {
            Ok(StateRequest::Set { timeout_ms, .. } | StateRequest::Deactivate { timeout_ms }) => *timeout_ms,
            _ => 0,
        };
        let hold = hold && wait_ms <= 1 << 40;
        let reply = rt.block_on(async {
            // Held only while the slave is active (after a request made it so).
            let _guard = if hold { slave.handle().try_acquire("drive").ok() } else { None };
            Arc::clone(&served).serve_request(&bytes).await
        });
        let reply = decode::<Reply<StateStatus>>(&reply, "orsa.StateStatus/1")
            .map_err(|e| TestCaseError::fail(format!("the reply does not decode: {e}")))?;
        match (request, reply) {
            (Ok(_), Reply::Ok(status)) => {
                prop_assert!(declared.contains(&status.current), "{:?}", status);
                prop_assert_eq!(
                    status.main_states.keys().cloned().collect::<BTreeSet<_>>(),
                    declared.clone()
                );
                prop_assert_eq!(status.pending, None);
            }
            (Ok(_), Reply::Err(f)) => prop_assert_ne!(&f.code, "decode"),
            (Err(_), Reply::Err(f)) => {
                prop_assert_eq!(&f.code, "decode");
                prop_assert!(is_decode_error(&f.into_error(), "slave/state", "orsa.StateRequest/1"));
            }
            (Err(e), Reply::Ok(s)) => prop_assert!(false, "undecodable {} answered {:?}", e, s),
        }
        Ok(())
    });
}

/// A Wiring slave answers every request with a reply carrying its ports or why not; an
/// undecodable request is a `decode` failure naming `orsa.WiringRequest/1`.
#[test]
fn wiring_slave_answers_every_request_with_a_reply() {
    let rt = paused_runtime();
    let registry = rt.block_on(async { Registry::with_clock(test_clock()) });
    let (tx, _rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
    let _speed =
        SendServer::<f64>::register(&registry, SPEED.on("robot"), Sink::channel(tx)).expect("server");
    let slave = WiringSlave::register(&registry, "behaviour").expect("slave");
    let _vel = slave.send_port::<f64>("vel").expect("port");
    let served = served(&registry, "behaviour/wiring");
    let valid = wiring_request().prop_map(|r| encode(&r)).boxed();
    check(512, inputs(valid), |bytes| {
        let request = decode::<WiringRequest>(&bytes, "orsa.WiringRequest/1");
        let reply = rt.block_on(Arc::clone(&served).serve_request(&bytes));
        let reply = decode::<Reply<Vec<PortStatus>>>(&reply, "orsa.PortStatus/1 list")
            .map_err(|e| TestCaseError::fail(format!("the reply does not decode: {e}")))?;
        match (request, reply) {
            (Ok(req), Reply::Ok(ports)) => {
                prop_assert_eq!(ports.len(), 1);
                prop_assert_eq!(&ports[0].port, "vel");
                // Only the one Send service of the port's type can be its target.
                let target = ports[0].target.as_ref().map(ToString::to_string);
                prop_assert!(target.is_none() || target.as_deref() == Some("robot/speed"), "{:?}", target);
                if let WiringRequest::Connect { port, target } = &req {
                    prop_assert!(port == "vel" && target == "robot/speed", "{:?} succeeded", req);
                }
            }
            (Ok(req), Reply::Err(f)) => {
                prop_assert_ne!(&f.code, "decode");
                prop_assert!(!matches!(req, WiringRequest::Ports), "asking for the ports failed: {:?}", f);
            }
            (Err(_), Reply::Err(f)) => {
                prop_assert_eq!(&f.code, "decode");
                prop_assert!(is_decode_error(&f.into_error(), "behaviour/wiring", "orsa.WiringRequest/1"));
            }
            (Err(e), Reply::Ok(p)) => prop_assert!(false, "undecodable {} answered {:?}", e, p),
        }
        Ok(())
    });
}

/// A firing as it crosses the wire (`docs/wire-format.md`).
#[derive(Debug, Deserialize)]
struct FiredOnWire {
    activation: u64,
    seq: u64,
    #[allow(dead_code)]
    stamp_ns: Timestamp,
    value: u64,
}

/// An Event server activates with what the parameters decode to, and refuses the rest with a
/// `Decode` error naming itself and the parameter type; an activation it took fires, encoded,
/// until it is dropped.
#[test]
fn event_server_activates_what_decodes_and_refuses_the_rest() {
    let rt = paused_runtime();
    let _enter = rt.enter();
    let registry = Registry::with_clock(test_clock());
    let server =
        EventServer::<Pose, u64, u64>::register(&registry, NEAR.on("robot"), |p: &mut Pose, s: &u64| {
            (p.label.len() as u64 <= *s).then_some(*s)
        })
        .expect("server");
    let served = served(&registry, "robot/near");
    let valid = (0..u64::MAX / 2, ".{0,8}", any::<f64>())
        .prop_map(move |(at, label, x_m)| {
            let p = Pose { at: Timestamp(at), seen: None, x_m, label, mode: Mode::Idle, ranges_m: vec![] };
            encode(&p)
        })
        .boxed();
    let mode = prop_oneof![Just(EventMode::Single), Just(EventMode::Continuous)];
    check(512, (inputs(valid), mode), |(bytes, mode)| {
        let params = decode::<Pose>(&bytes, Pose::ID);
        let frames: Arc<Mutex<Vec<Vec<u8>>>> = Arc::default();
        let sink: ByteSink = {
            let frames = Arc::clone(&frames);
            Arc::new(move |b: &[u8]| {
                frames.lock().expect("frames").push(b.to_vec());
                true
            })
        };
        match Arc::clone(&served).serve_activate(mode, &bytes, sink) {
            Ok(activation) => {
                let params = params
                    .map_err(|e| TestCaseError::fail(format!("activated with bytes that fail: {e}")))?;
                prop_assert_eq!(server.activations(), 1);
                let state = u64::MAX;
                prop_assert_eq!(server.put(&state), 1);
                let fired = frames.lock().expect("frames").clone();
                prop_assert_eq!(fired.len(), 1);
                let f = decode::<FiredOnWire>(&fired[0], "firing")
                    .map_err(|e| TestCaseError::fail(format!("a firing does not decode: {e}")))?;
                prop_assert!(f.activation >= 1 && f.seq >= 1);
                prop_assert_eq!(f.value, state);
                drop(activation);
                prop_assert!(params.label.len() as u64 <= state);
                prop_assert_eq!(server.activations(), 0);
                prop_assert_eq!(server.put(&state), 0);
            }
            Err(e) => {
                prop_assert!(is_decode_error(&e, "robot/near", Pose::ID), "{:?}", e);
                prop_assert!(params.is_err(), "refused parameters that decode");
                prop_assert_eq!(server.activations(), 0);
            }
        }
        // An event service has no request face: it answers a reply all the same.
        let reply = rt.block_on(Arc::clone(&served).serve_request(&bytes));
        prop_assert!(matches!(decode::<Reply<()>>(&reply, "reply"), Ok(Reply::Err(_))));
        Ok(())
    });
}

/// The faces a pattern does not have answer errors, never panic, whatever they are fed.
#[test]
fn operations_a_service_does_not_have_are_refused() {
    let rt = paused_runtime();
    let _enter = rt.enter();
    let registry = Registry::with_clock(test_clock());
    let (tx, _rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&registry, SEND.on("a"), Sink::channel(tx)).expect("send");
    StateSlave::register(&registry, "a", StateSpec::new()).expect("state");
    let served_send = served(&registry, "a/send");
    let served_state = served(&registry, "a/state");
    let every = NonZeroU32::MIN;
    let sink: ByteSink = Arc::new(|_: &[u8]| true);
    check(256, vec(any::<u8>(), 0..32), |bytes| {
        prop_assert!(Arc::clone(&served_send).serve_subscribe(every, Arc::clone(&sink)).is_err());
        prop_assert!(
            Arc::clone(&served_send).serve_activate(EventMode::Single, &bytes, Arc::clone(&sink)).is_err()
        );
        prop_assert!(served_state.serve_send(&bytes).is_err());
        let reply = rt.block_on(Arc::clone(&served_send).serve_request(&bytes));
        prop_assert!(matches!(decode::<Reply<()>>(&reply, "reply"), Ok(Reply::Err(_))));
        Ok(())
    });
}
