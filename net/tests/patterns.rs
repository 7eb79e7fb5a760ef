//! Every pattern between two zenoh sessions over loopback TCP, with the in-process client API.
//! (Tests with separate processes live in the root package's tests/net_processes.rs.)

use orsa_actors::event::{EventClient, EventMode, EventServer};
use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::push_timed::{PushTimedClient, PushTimedServer, Tick};
use orsa_actors::query::{QueryClient, QueryRequest, QueryServer};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::{
    EventService, PushNewestService, PushTimedService, QueryService, SendPortDesc, SendService,
};
use orsa_actors::state::{StateMaster, StateSlave, StateSpec};
use orsa_actors::wiring::{WiringMaster, WiringSlave};
use orsa_actors::{PatternError, Registry, ServiceAddr, Sink, Stamped};
use orsa_net::{NetOptions, ZenohTransport};
use std::time::Duration;

/// Speed commands to a robot.
const SPEED: SendService<f64> = SendService::new("speed");
/// Squares a number.
const SQUARE: QueryService<u64, u64> = QueryService::new("square");
/// Odometry ticks.
const TICKS: PushNewestService<u64> = PushNewestService::new("ticks");
/// A timed tick count.
const COUNTER: PushTimedService<u64> = PushTimedService::new("counter");
/// Distances, fired to activations whose threshold they are below.
const NEAR: EventService<f64, f64> = EventService::new("near");
/// A behaviour's speed output.
const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
/// Commands to the robot, across a link that gets cut.
const CMD: SendService<u64> = SendService::new("cmd");
/// Echoes a number, across a link that gets cut.
const ECHO: QueryService<u64, u64> = QueryService::new("echo");
/// The robot's odometry, across a link that gets cut.
const ODO: PushNewestService<u64> = PushNewestService::new("odo");
/// Notes to the executive, across a link that gets cut.
const NOTE: SendService<u64> = SendService::new("note");

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

async fn pair(prefix: &str) -> (Registry, ZenohTransport, Registry, ZenohTransport) {
    let port = free_port();
    let a = Registry::new();
    let b = Registry::new();
    let server = NetOptions {
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        prefix: prefix.into(),
        ..NetOptions::default()
    };
    let client = NetOptions {
        connect: vec![format!("tcp/127.0.0.1:{port}")],
        prefix: prefix.into(),
        ..NetOptions::default()
    };
    let ta = ZenohTransport::open(&a, &server, "robot").await.expect("open a");
    let tb = ZenohTransport::open(&b, &client, "executive").await.expect("open b");
    (a, ta, b, tb)
}

const WAIT: Duration = Duration::from_secs(10);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn send_query_and_push_cross_sessions_with_the_local_api() {
    let (a, _ta, b, tb) = pair("t_sqp").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
    SendServer::<f64>::register(&a, SPEED.on("robot"), Sink::channel(tx)).expect("send server");
    let (qtx, mut qrx) = tokio::sync::mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::<u64, u64>::register(&a, SQUARE.on("calc"), Sink::channel(qtx)).expect("query server");
    tokio::spawn(async move {
        while let Some(q) = qrx.recv().await {
            let n = q.request.value;
            let _ = q.answer(n * n);
        }
    });
    let push = PushNewestServer::<u64>::register(&a, TICKS.on("odo")).expect("push server");
    let addrs = [SPEED.on("robot").untyped(), SQUARE.on("calc").untyped(), TICKS.on("odo").untyped()];
    tb.wait_for(&addrs, WAIT).await.expect("discovered");

    // Send: delivered in order with the sender's sequence numbers.
    let send = SendClient::<f64>::connect(&b, SPEED.on("robot")).expect("remote send client");
    assert!(send.is_remote());
    for v in [0.1, 0.2, 0.3] {
        send.send(v).expect("send");
    }
    for (i, v) in [0.1, 0.2, 0.3].into_iter().enumerate() {
        let got = tokio::time::timeout(WAIT, rx.recv()).await.expect("in time").expect("delivered");
        assert_eq!((got.seq, got.value), (i as u64 + 1, v));
    }

    // Query: answered across the link.
    let query = QueryClient::<u64, u64>::connect(&b, SQUARE.on("calc")).expect("remote query client");
    assert_eq!(query.query(12, Some(WAIT)).await, Ok(144));

    // Wrong types are refused before a byte is sent, as in process (untyped addresses, as a
    // person typed them: the check is the registry's, not the compiler's).
    assert!(matches!(
        SendClient::<u64>::connect(&b, SPEED.on("robot").untyped()),
        Err(PatternError::IncompatibleService { .. })
    ));
    assert!(matches!(
        SendClient::<f64>::connect(&b, ServiceAddr::new("robot", "nothing")),
        Err(PatternError::UnknownService(_))
    ));

    // Push newest with every-n-th counted at the source: n = 3 gets the 3rd, 6th, 9th.
    let client = PushNewestClient::<u64>::connect(&b, TICKS.on("odo")).expect("remote push client");
    let (utx, mut urx) = tokio::sync::mpsc::unbounded_channel();
    let every3 = orsa_actors::push_timed::PushTimedClient::<u64>::connect(&b, TICKS.on("odo").untyped());
    assert!(every3.is_err(), "a push newest service is not a push timed one");
    let forwarded =
        PushNewestClient::<u64>::connect_to(&b, TICKS.on("odo"), Sink::channel(utx)).expect("client");
    client.subscribe().expect("subscribe");
    forwarded.subscribe().expect("subscribe");
    // The subscription reaches the source asynchronously.
    let mut waited = 0;
    while push.stats().subscribers < 1 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        waited += 1;
        assert!(waited < 2000, "the remote subscription never arrived");
    }
    let start = push.stats().published;
    for v in 1..=9 {
        push.put(start + v);
    }
    let mut got = Vec::new();
    while got.len() < 9 {
        let u = tokio::time::timeout(WAIT, urx.recv()).await.expect("in time").expect("update");
        got.push(u.value);
    }
    assert_eq!(got, (start + 1..=start + 9).collect::<Vec<_>>());
    // The other client holds the newest value, as get_update promises.
    let newest = tokio::time::timeout(WAIT, async {
        while client.get_update().map(|u| u.value) != Ok(start + 9) {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
    })
    .await;
    assert!(newest.is_ok(), "get_update gave {:?}", client.get_update().map(|u| u.value));
    // Two remote clients at n = 1 share one stream at the source.
    assert_eq!(push.stats().subscribers, 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn push_timed_every_nth_is_counted_at_the_source() {
    let (a, _ta, b, tb) = pair("t_every").await;
    let (tick_tx, mut ticks) = tokio::sync::mpsc::unbounded_channel::<Tick>();
    let server = PushTimedServer::<u64>::register(
        &a,
        COUNTER.on("nomad200"),
        Duration::from_millis(2),
        Sink::channel(tick_tx),
    )
    .expect("server");
    let producer = server.clone();
    tokio::spawn(async move {
        while let Some(t) = ticks.recv().await {
            producer.put(t.seq);
        }
    });
    tb.wait_for(&[COUNTER.on("nomad200").untyped()], WAIT).await.expect("discovered");
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let client =
        PushTimedClient::<u64>::connect_to(&b, COUNTER.on("nomad200"), Sink::channel(tx)).expect("client");
    client.subscribe(10).expect("subscribe");
    let mut waited = 0;
    while server.stats().subscribers < 1 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        waited += 1;
        assert!(waited < 2000, "the remote subscription never arrived");
    }
    server.start();
    let mut got = Vec::new();
    while got.len() < 5 {
        let u = tokio::time::timeout(WAIT, rx.recv()).await.expect("in time").expect("update");
        got.push(u.value);
    }
    // Consecutive values are 10 apart: only every 10th crossed the link.
    for w in got.windows(2) {
        assert_eq!(w[1] - w[0], 10, "{got:?}");
    }
    let stats = server.stats();
    assert!(stats.delivered * 10 <= stats.published + 10, "{stats:?}");
    drop(client);
    // Dropping the client ends the stream at the source.
    let mut waited = 0;
    while server.stats().subscribers > 0 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        waited += 1;
        assert!(waited < 2000, "the stream outlived its only subscriber");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn events_state_and_wiring_cross_sessions() {
    let (a, _ta, b, tb) = pair("t_esw").await;
    let events =
        EventServer::<f64, f64, f64>::register(&a, NEAR.on("nomad200"), |limit: &mut f64, d: &f64| {
            (*d < *limit).then_some(*d)
        })
        .expect("event server");
    let slave = StateSlave::register(&a, "wallfollow", StateSpec::new().main_state("active", &["drive"]))
        .expect("state slave");
    let wiring = WiringSlave::register(&a, "wallfollow").expect("wiring slave");
    let port = wiring.send_port::<f64>(VEL.name()).expect("port");
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
    SendServer::<f64>::register(&a, SPEED.on("robot"), Sink::channel(tx)).expect("send server");
    let addrs = [
        NEAR.on("nomad200").untyped(),
        ServiceAddr::new("wallfollow", "state"),
        ServiceAddr::new("wallfollow", "wiring"),
    ];
    tb.wait_for(&addrs, WAIT).await.expect("discovered");

    // Event, single shot: fires once, with the client's activation id, then ends.
    let client = EventClient::<f64, f64>::connect(&b, NEAR.on("nomad200")).expect("event client");
    let mut near = client.activate(EventMode::Single, 0.5).expect("activate");
    let mut waited = 0;
    while events.activations() < 1 {
        tokio::time::sleep(Duration::from_millis(5)).await;
        waited += 1;
        assert!(waited < 2000, "the activation never arrived");
    }
    events.put(&0.8);
    events.put(&0.4);
    events.put(&0.3);
    let fired = tokio::time::timeout(WAIT, near.next()).await.expect("in time").expect("fired");
    assert_eq!((fired.activation, fired.event.value), (near.id(), 0.4));
    assert!(matches!(
        tokio::time::timeout(WAIT, near.next()).await.expect("in time"),
        Err(PatternError::NotActive(_))
    ));

    // State: a remote master sets the slave's state and sees Busy while a substate is held.
    let master = StateMaster::connect(&b, "wallfollow").expect("state master");
    master.set_state("active").await.expect("set");
    assert_eq!(master.status().await.expect("status").current, "active");
    let guard = slave.handle().acquire("drive").await.expect("acquire");
    assert_eq!(master.try_set_state("neutral").await, Err(PatternError::Busy(vec!["drive".into()])));
    drop(guard);
    master.try_set_state("neutral").await.expect("released");
    assert!(matches!(
        master.set_state("flying").await,
        Err(PatternError::Unknown { .. }) | Err(PatternError::Remote(_))
    ));

    // Wiring: a remote master wires the slave's port to a service local to the slave.
    let wm = WiringMaster::new(&b);
    assert!(matches!(port.send(0.1), Err(PatternError::Disconnected(_))));
    wm.connect("wallfollow", VEL, SPEED.on("robot")).await.expect("wire");
    port.send(0.25).expect("wired");
    assert_eq!(rx.recv().await.expect("delivered").value, 0.25);
    assert_eq!(
        wm.ports("wallfollow").await.expect("ports")[0].target,
        Some(ServiceAddr::new("robot", "speed"))
    );
    assert_eq!(
        wm.connect_named("wallfollow", "speed", &SPEED.on("robot").untyped()).await,
        Err(PatternError::UnknownPort { component: "wallfollow".into(), port: "speed".into() })
    );
    wm.disconnect("wallfollow", VEL).await.expect("unwire");
    assert!(matches!(port.send(0.1), Err(PatternError::Disconnected(_))));
    assert_eq!(
        wm.connect("ghost", VEL, SPEED.on("robot")).await,
        Err(PatternError::UnknownComponent("ghost".into()))
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn undecodable_messages_are_counted_and_dropped() {
    let (a, ta, _b, tb) = pair("t_bad").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<f64>>();
    SendServer::<f64>::register(&a, SPEED.on("robot"), Sink::channel(tx)).expect("send server");
    tb.wait_for(&[SPEED.on("robot").untyped()], WAIT).await.expect("discovered");
    let key = ta.keys().send(&SPEED.on("robot").untyped());
    use zenoh::Wait as _;
    for garbage in [&b"\xff\x00garbage"[..], b"", b"\xa1\x63seq\x01"] {
        tb.session().put(&key, garbage.to_vec()).wait().expect("put");
    }
    // A good message after the garbage still arrives: nothing crashed, nothing was lost.
    let good = SendClient::<f64>::connect(&_b, SPEED.on("robot")).expect("client");
    good.send(0.5).expect("send");
    let got = tokio::time::timeout(WAIT, rx.recv()).await.expect("in time").expect("delivered");
    assert_eq!(got.value, 0.5);
    assert_eq!(ta.stats().decode_errors, 3);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cut_link_drops_holds_and_withholds_both_ways_while_the_sessions_stay_up() {
    let (a, ta, b, tb) = pair("t_cut").await;
    // Hosted by a (role robot), used by b (role executive).
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&a, CMD.on("robot"), Sink::channel(tx)).expect("send server");
    let (qtx, mut qrx) = tokio::sync::mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::<u64, u64>::register(&a, ECHO.on("robot"), Sink::channel(qtx)).expect("query server");
    tokio::spawn(async move {
        while let Some(q) = qrx.recv().await {
            let n = q.request.value;
            let _ = q.answer(n);
        }
    });
    let push = PushNewestServer::<u64>::register(&a, ODO.on("robot")).expect("push server");
    // Hosted by b, used by a.
    let (btx, mut brx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&b, NOTE.on("exec"), Sink::channel(btx)).expect("send server");
    let addrs = [CMD.on("robot").untyped(), ECHO.on("robot").untyped(), ODO.on("robot").untyped()];
    tb.wait_for(&addrs, WAIT).await.expect("b sees a");
    ta.wait_for(&[NOTE.on("exec").untyped()], WAIT).await.expect("a sees b");
    assert!(ta.wait_for_role("executive", WAIT).await);

    let cmd = SendClient::<u64>::connect(&b, CMD.on("robot")).expect("client");
    let echo = QueryClient::<u64, u64>::connect(&b, ECHO.on("robot")).expect("client");
    let note = SendClient::<u64>::connect(&a, NOTE.on("exec")).expect("client");
    let (otx, mut orx) = tokio::sync::mpsc::unbounded_channel::<orsa_actors::Update<u64>>();
    let odo = PushNewestClient::<u64>::connect_to(&b, ODO.on("robot"), Sink::channel(otx)).expect("client");
    odo.subscribe().expect("subscribe");
    // Everything flows before the cut (the subscription is in place once a value arrives).
    cmd.send(1).expect("send");
    assert_eq!(tokio::time::timeout(WAIT, rx.recv()).await.expect("in time").expect("cmd").value, 1);
    assert_eq!(echo.query(7, Some(WAIT)).await, Ok(7));
    let mut k = 0;
    let first = loop {
        k += 1;
        push.put(k);
        if let Ok(Some(u)) = tokio::time::timeout(Duration::from_millis(200), orx.recv()).await {
            break u.value;
        }
        assert!(k < 50, "the subscription never delivered");
    };
    assert!(first >= 1);

    ta.cut_link("executive", true);
    assert_eq!(ta.cut_roles(), vec!["executive".to_string()]);
    // From b: the message is dropped and the request is held unanswered, so it times out.
    cmd.send(2).expect("a send to a cut peer does not fail: it is lost");
    assert_eq!(echo.query(8, Some(Duration::from_millis(300))).await, Err(PatternError::Timeout));
    // To b: the stream update and the message are withheld.
    push.put(1000);
    note.send(3).expect("lost, not failed");
    let during = ta.link_cut_stats();
    assert!(during.dropped_in >= 2, "{during:?}");
    assert!(during.withheld_out >= 2, "{during:?}");
    // Nothing of the cut ever arrives: after the restore the next values do, and nothing
    // before them (each stream is ordered).
    ta.cut_link("executive", false);
    assert!(ta.cut_roles().is_empty());
    cmd.send(4).expect("send");
    assert_eq!(tokio::time::timeout(WAIT, rx.recv()).await.expect("in time").expect("cmd").value, 4);
    note.send(5).expect("send");
    assert_eq!(tokio::time::timeout(WAIT, brx.recv()).await.expect("in time").expect("note").value, 5);
    push.put(2000);
    let next = tokio::time::timeout(WAIT, async {
        loop {
            let u = orx.recv().await.expect("stream");
            if u.value >= 1000 {
                return u.value;
            }
        }
    })
    .await
    .expect("in time");
    assert_eq!(next, 2000, "the update published while cut was withheld");
    assert_eq!(echo.query(9, Some(WAIT)).await, Ok(9));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heartbeats_are_heard_and_a_cut_link_silences_them() {
    let port = free_port();
    let prefix = "t_beat";
    let (a, b, c) = (Registry::new(), Registry::new(), Registry::new());
    let listen = NetOptions {
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        prefix: prefix.into(),
        ..NetOptions::default()
    };
    let connect = NetOptions {
        connect: vec![format!("tcp/127.0.0.1:{port}")],
        prefix: prefix.into(),
        ..NetOptions::default()
    };
    let ta = ZenohTransport::open(&a, &listen, "robot").await.expect("a");
    let beating = NetOptions { heartbeat: Some(Duration::from_millis(20)), ..connect.clone() };
    let _tb = ZenohTransport::open(&b, &beating, "executive").await.expect("b");
    let tc = ZenohTransport::open(&c, &connect, "test").await.expect("c");
    let (atx, mut arx) = tokio::sync::mpsc::unbounded_channel();
    let _wa = ta
        .on_heartbeat("executive", move |_, h| {
            let _ = atx.send(*h);
        })
        .await
        .expect("watch a");
    let (ctx, mut crx) = tokio::sync::mpsc::unbounded_channel();
    let _wc = tc
        .on_heartbeat("executive", move |_, h| {
            let _ = ctx.send(*h);
        })
        .await
        .expect("watch c");
    let h = tokio::time::timeout(WAIT, arx.recv()).await.expect("in time").expect("a beat");
    assert_eq!(h.period_ms, 20);
    assert!(ta.wait_for_role("executive", WAIT).await);
    ta.cut_link("executive", true);
    // While cut, c (not cut) hears eight beats (160 ms); a drops what arrives meanwhile.
    let mut last = 0;
    for _ in 0..8 {
        last = tokio::time::timeout(WAIT, crx.recv()).await.expect("in time").expect("c beat").seq;
    }
    // What a heard up to now, read while still cut (what arrives after the restore is after).
    let mut before = h.seq;
    while let Ok(h) = arx.try_recv() {
        before = h.seq;
    }
    ta.cut_link("executive", false);
    let after = tokio::time::timeout(WAIT, arx.recv()).await.expect("in time").expect("a beat again").seq;
    // Without the cut a would hear every beat (a gap of 1); beats in flight when the cut began
    // may have got through, so the gap is a little less than eight.
    assert!(after - before >= 4, "a heard up to {before} and then {after}; c heard up to {last}");
    assert!(ta.link_cut_stats().dropped_in >= 2);
}
