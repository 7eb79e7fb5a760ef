//! Every decoder of bytes from another process, chosen by the first byte: stamped communication
//! objects (the framework's scalars, a struct with timestamps, the robot's objects), replies,
//! the State and Wiring requests, the transport's control messages, and the services
//! themselves through the byte-level face a transport calls. What decodes must re-encode to a
//! fixed point; an error must name what was expected; every request must be answered with
//! bytes that decode as a reply. Never a panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use orsa_actors::event::{EventMode, EventServer};
use orsa_actors::query::{QueryRequest, QueryServer};
use orsa_actors::addr::ServiceAddr;
use orsa_actors::send::SendServer;
use orsa_actors::state::{StateRequest, StateSlave, StateSpec, StateStatus};
use orsa_actors::transport::{ByteSink, Served};
use orsa_actors::wire::{
    Reply, WireStamped, decode, decode_reply, decode_stamped, encode, encode_stamped,
};
use orsa_actors::wiring::{PortStatus, WiringRequest, WiringSlave};
use orsa_actors::service::{EventService, QueryService, SendService};
use orsa_actors::{Clock, CommObject, Registry, Sink, Timestamp, comm_object};
use orsa_interfaces::nomad200::{BaseState, ContactScan, DistanceScan, NavigationVelocity, RobotParams};
use orsa_net::{ActivateRequest, NetStats, SubscribeRequest};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, OnceLock};

/// The services the fuzzed bytes are served to.
const POSE: SendService<Pose> = SendService::new("pose");
const LABELS: QueryService<Pose, u64> = QueryService::new("labels");
const SPEED: SendService<f64> = SendService::new("speed");
const NEAR: EventService<Pose, u64> = EventService::new("near");

/// A communication object with stamps inside, an enum, an optional, a list and text.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Pose {
    at: Timestamp,
    seen: Option<Timestamp>,
    x_m: f64,
    label: String,
    mode: Mode,
    ranges_m: Vec<f64>,
}
comm_object!(Pose, "orsa.fuzz.Pose/1");

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Mode {
    Idle,
    Drive { v_m_s: f64 },
}

/// An event firing as it crosses the wire.
#[derive(Debug, Serialize, Deserialize)]
struct Fired {
    activation: u64,
    seq: u64,
    stamp_ns: Timestamp,
    value: u64,
}

struct Services {
    rt: tokio::runtime::Runtime,
    send: Arc<dyn Served>,
    query: Arc<dyn Served>,
    state: Arc<dyn Served>,
    wiring: Arc<dyn Served>,
    event: Arc<dyn Served>,
    _keep: Box<dyn std::any::Any + Send + Sync>,
}

fn services() -> &'static Services {
    static SERVICES: OnceLock<Services> = OnceLock::new();
    SERVICES.get_or_init(|| {
        let rt = tokio::runtime::Builder::new_current_thread().enable_time().build().expect("runtime");
        let _enter = rt.enter();
        let registry = Registry::with_clock(Clock::starting_at(
            tokio::time::Instant::now(),
            orsa_actors::Timestamp(1_704_067_200_000_000_000),
        ));
        let served = |addr: &str| {
            let addr: ServiceAddr = addr.parse().expect("address");
            registry.local(&addr).expect("registered").served
        };
        let send = SendServer::<Pose>::register(&registry, POSE.on("robot"), Sink::from_fn(|_| Ok(())))
            .expect("send");
        let answer = Sink::from_fn(|q: QueryRequest<Pose, u64>| {
            let n = q.request.value.label.len() as u64;
            let _ = q.answer(n);
            Ok(())
        });
        let query = QueryServer::<Pose, u64>::register(&registry, LABELS.on("calc"), answer).expect("query");
        let spec = StateSpec::new().main_state("active", &["drive"]).main_state("parked", &[]);
        let state = StateSlave::register(&registry, "slave", spec).expect("state");
        let speed = SendServer::<f64>::register(&registry, SPEED.on("robot"), Sink::from_fn(|_| Ok(())))
            .expect("speed");
        let wiring = WiringSlave::register(&registry, "behaviour").expect("wiring");
        let port = wiring.send_port::<f64>("vel").expect("port");
        let event = EventServer::<Pose, u64, u64>::register(&registry, NEAR.on("robot"), |p: &mut Pose, s: &u64| {
            (p.label.len() as u64 <= *s).then_some(*s)
        })
        .expect("event");
        Services {
            send: served("robot/pose"),
            query: served("calc/labels"),
            state: served("slave/state"),
            wiring: served("behaviour/wiring"),
            event: served("robot/near"),
            _keep: Box::new((registry, send, query, state, speed, wiring, port, event)),
            rt: {
                drop(_enter);
                rt
            },
        }
    })
}

/// A stamped `T`: what decodes re-encodes to a fixed point; an error names `T`.
fn stamped<T: CommObject>(bytes: &[u8]) {
    match decode_stamped::<T>(bytes, T::ID) {
        Ok(msg) => {
            let again = encode_stamped(&msg);
            let back = decode_stamped::<T>(&again, T::ID).expect("a re-encoded message decodes");
            assert_eq!(encode_stamped(&back), again, "the encoding is not a fixed point");
        }
        Err(e) => assert_eq!(e.what, T::ID),
    }
}

/// A message without stamps: what decodes re-encodes to a fixed point; an error names `what`.
fn plain<T: DeserializeOwned + Serialize>(bytes: &[u8], what: &str) -> Option<T> {
    match decode::<T>(bytes, what) {
        Ok(v) => {
            let again = encode(&v);
            let back = decode::<T>(&again, what).expect("a re-encoded message decodes");
            assert_eq!(encode(&back), again, "the encoding is not a fixed point");
            Some(back)
        }
        Err(e) => {
            assert_eq!(e.what, what);
            None
        }
    }
}

/// A reply to a request: `decode_reply` never panics and agrees with the plain decoding.
fn reply<T: DeserializeOwned + Serialize>(bytes: &[u8], what: &str) {
    let addr = ServiceAddr::new("peer", "service");
    let raw = decode::<Reply<T>>(bytes, what);
    let result = decode_reply::<T>(bytes, &addr, what);
    match raw {
        Ok(r) => {
            let again = encode(&r);
            let back = decode::<Reply<T>>(&again, what).expect("a re-encoded reply decodes");
            assert_eq!(encode(&back), again, "the encoding is not a fixed point");
            assert_eq!(result.is_ok(), matches!(r, Reply::Ok(_)));
        }
        Err(_) => assert!(matches!(result, Err(orsa_actors::PatternError::Decode(_)))),
    }
}

fn activate(s: &Services, mode: EventMode, params: &[u8]) {
    let sink: ByteSink = Arc::new(|b: &[u8]| {
        assert!(decode::<Fired>(b, "firing").is_ok());
        true
    });
    let _ = Arc::clone(&s.event).serve_activate(mode, params, sink);
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else { return };
    let s = services();
    match which % 24 {
        0 => stamped::<u64>(bytes),
        1 => stamped::<f64>(bytes),
        2 => stamped::<String>(bytes),
        3 => stamped::<Pose>(bytes),
        4 => stamped::<NavigationVelocity>(bytes),
        5 => stamped::<DistanceScan>(bytes),
        6 => stamped::<BaseState>(bytes),
        7 => stamped::<ContactScan>(bytes),
        8 => reply::<WireStamped<RobotParams>>(bytes, RobotParams::ID),
        9 => reply::<StateStatus>(bytes, "orsa.StateStatus/1"),
        10 => reply::<Vec<PortStatus>>(bytes, "orsa.PortStatus/1 list"),
        11 => reply::<WireStamped<u64>>(bytes, "orsa.U64/1"),
        12 => {
            let _ = plain::<StateRequest>(bytes, "orsa.StateRequest/1");
        }
        13 => {
            let _ = plain::<WiringRequest>(bytes, "orsa.WiringRequest/1");
        }
        14 => {
            let _ = plain::<SubscribeRequest>(bytes, "orsa.SubscribeRequest/1");
        }
        15 => {
            // As the transport handles an activation: the request, then its parameters.
            if let Some(ActivateRequest::Activate { mode, params, .. }) =
                plain::<ActivateRequest>(bytes, "orsa.ActivateRequest/1")
            {
                activate(s, mode, &params);
            }
        }
        16 => {
            let _ = plain::<Reply<NetStats>>(bytes, "orsa.NetStats/1");
        }
        17 => {
            let _ = decode::<Fired>(bytes, "firing");
        }
        18 => {
            let _ = s.send.serve_send(bytes);
        }
        19 => {
            let r = s.rt.block_on(Arc::clone(&s.query).serve_request(bytes));
            decode::<Reply<WireStamped<u64>>>(&r, "reply").expect("a query reply decodes");
        }
        20 => {
            let r = s.rt.block_on(Arc::clone(&s.state).serve_request(bytes));
            decode::<Reply<StateStatus>>(&r, "reply").expect("a state reply decodes");
        }
        21 => {
            let r = s.rt.block_on(Arc::clone(&s.wiring).serve_request(bytes));
            decode::<Reply<Vec<PortStatus>>>(&r, "reply").expect("a wiring reply decodes");
        }
        22 => activate(s, EventMode::Single, bytes),
        _ => activate(s, EventMode::Continuous, bytes),
    }
});
