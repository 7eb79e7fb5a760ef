use orsa_actors::event::{EventClient, EventMode, EventServer};
use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::query::{QueryClient, QueryRequest, QueryServer};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::{EventService, PushNewestService, QueryService, SendPortDesc, SendService};
use orsa_actors::state::{StateMaster, StateSlave, StateSpec};
use orsa_actors::tap::Tap;
use orsa_actors::wiring::{WiringMaster, WiringSlave};
use orsa_actors::{Registry, Sink, Timestamp};
use parking_lot::Mutex;
use std::sync::Arc;
use tokio::sync::mpsc;

/// Speed commands to a robot.
const SPEED: SendService<u64> = SendService::new("speed");
/// Squares a number.
const SQUARE: QueryService<u64, u64> = QueryService::new("square");
/// Odometry ticks.
const TICKS: PushNewestService<u64> = PushNewestService::new("ticks");
/// Values above the activation's limit.
const HIGH: EventService<u64, u64> = EventService::new("high");
/// A behaviour's speed output.
const VEL: SendPortDesc<u64> = SendPortDesc::new("vel");

#[derive(Default)]
struct Log(Mutex<Vec<(String, String, serde_json::Value)>>);
impl Tap for Log {
    fn record(&self, topic: &str, type_id: &str, _stamp: Timestamp, json: &[u8]) {
        let message = serde_json::from_slice(json).expect("the tap gets JSON");
        self.0.lock().push((topic.to_string(), type_id.to_string(), message));
    }
}

/// A tap sees each message of each pattern once, where it enters the pattern, and every state
/// and wiring change; removing the tap stops it.
#[tokio::test(start_paused = true)]
async fn tap_sees_every_pattern_message_once_with_its_topic() {
    let registry = Registry::new();
    let log = Arc::new(Log::default());
    registry.set_tap(Some(log.clone()));

    let (stx, _srx) = mpsc::unbounded_channel();
    SendServer::<u64>::register(&registry, SPEED.on("robot"), Sink::channel(stx)).expect("send");
    SendClient::<u64>::connect(&registry, SPEED.on("robot")).expect("c").send(7).expect("send");

    let (qtx, mut qrx) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(&registry, SQUARE.on("calc"), Sink::channel(qtx)).expect("query");
    tokio::spawn(async move {
        while let Some(q) = qrx.recv().await {
            let n = q.request.value;
            let _ = q.answer(n * n);
        }
    });
    QueryClient::<u64, u64>::connect(&registry, SQUARE.on("calc"))
        .expect("c")
        .query(3, None)
        .await
        .expect("answer");

    let push = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("push");
    let subs: Vec<_> =
        (0..3).map(|_| PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("c")).collect();
    for s in &subs {
        s.subscribe().expect("subscribe");
    }
    push.put(5);

    let ev =
        EventServer::<u64, u64, u64>::register(&registry, HIGH.on("alarm"), |l, v| (*v > *l).then_some(*v))
            .expect("ev");
    let _a = EventClient::<u64, u64>::connect(&registry, HIGH.on("alarm"))
        .expect("c")
        .activate(EventMode::Single, 1)
        .expect("a");
    ev.put(&2);

    StateSlave::register(&registry, "beh", StateSpec::new().main_state("active", &["go"])).expect("state");
    StateMaster::connect(&registry, "beh").expect("m").set_state("active").await.expect("set");
    WiringSlave::register(&registry, "beh2").expect("w").send_port::<u64>(VEL.name()).expect("port");
    WiringMaster::new(&registry).connect("beh2", VEL, SPEED.on("robot")).await.expect("wire");

    registry.set_tap(None);
    push.put(6);

    let got: Vec<(String, String)> = log.0.lock().iter().map(|(t, ty, _)| (t.clone(), ty.clone())).collect();
    let expect = [
        ("robot/speed", "orsa.U64/1"),
        ("calc/square", "orsa.U64/1"),
        ("calc/square/answer", "orsa.U64/1"),
        ("odo/ticks", "orsa.U64/1"),
        ("alarm/high", "orsa.U64/1"),
        ("beh/state", "orsa.StateStatus/1"),
        ("beh2/wiring", "orsa.PortStatus/1"),
    ];
    assert_eq!(got, expect.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect::<Vec<_>>());
    let log = log.0.lock();
    assert_eq!(log[0].2["value"], 7, "the stamped message itself: {}", log[0].2);
    assert_eq!(log[2].2["value"], 9);
    assert_eq!(log[5].2["current"], "active");
    assert_eq!(log[6].2["target"]["service"], "speed");
}
