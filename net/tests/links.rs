//! The delivery ledger across processes, between two zenoh sessions over loopback TCP: what a
//! sender put on the link and what arrived are counted on both sides, and what was lost on the
//! way is counted where it should have arrived.

use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::{PushNewestService, SendService};
use orsa_actors::{Registry, Sink, Stamped, Update};
use orsa_net::{Incoming, LinkLedger, NetOptions, ZenohTransport};
use std::time::Duration;
use zenoh::Wait as _;

/// Commands to the robot.
const CMD: SendService<u64> = SendService::new("cmd");
/// The robot's odometry.
const ODO: PushNewestService<u64> = PushNewestService::new("odo");

const WAIT: Duration = Duration::from_secs(10);

async fn pair(prefix: &str) -> (Registry, ZenohTransport, Registry, ZenohTransport) {
    let port = std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let (a, b) = (Registry::new(), Registry::new());
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

/// The stream that arrived from `from` on a key ending with `suffix`.
fn incoming<'a>(ledger: &'a LinkLedger, from: &str, suffix: &str) -> &'a Incoming {
    let found: Vec<_> =
        ledger.incoming.iter().filter(|i| i.from == from && i.key.ends_with(suffix)).collect();
    assert_eq!(found.len(), 1, "one stream from {from} on *{suffix}: {ledger:#?}");
    found[0]
}

/// Waits until `value` arrives. The tests send each message once the one before has arrived:
/// zenoh drops an express message when no batch frees up within 1 ms, which a burst on a
/// loaded machine (tests running side by side) meets, and these tests count losses exactly.
async fn receive(rx: &mut tokio::sync::mpsc::UnboundedReceiver<Stamped<u64>>, value: u64) {
    tokio::time::timeout(WAIT, async { while rx.recv().await.expect("open").value != value {} })
        .await
        .expect("in time");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn messages_lost_on_the_way_are_counted_where_they_should_have_arrived() {
    let (a, ta, b, tb) = pair("t_ledger").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&a, CMD.on("robot"), Sink::channel(tx)).expect("send server");
    tb.wait_for(&[CMD.on("robot").untyped()], WAIT).await.expect("b sees a");
    assert!(tb.wait_for_role("robot", WAIT).await);
    let cmd = SendClient::<u64>::connect(&b, CMD.on("robot")).expect("client");
    // A second client in the same process shares the process's outlet to the service: the
    // receiver tells the two apart by nothing, and needs not to.
    let cmd2 = cmd.clone();
    for v in 1..=100 {
        if v % 2 == 0 { cmd.send(v) } else { cmd2.send(v) }.expect("send");
        receive(&mut rx, v).await;
    }
    // The link is cut at the sender: what it puts meanwhile is lost on the way, as on a cut
    // cable, and its sender is not told.
    tb.cut_link("robot", true);
    for v in 101..=120 {
        cmd.send(v).expect("lost, not failed");
    }
    tb.cut_link("robot", false);
    for v in 121..=150 {
        cmd.send(v).expect("send");
        receive(&mut rx, v).await;
    }

    let got = ta.link_ledger();
    let sent = tb.link_ledger();
    let on_a = incoming(&got, tb.zid(), "/cmd/send");
    assert_eq!(on_a.role.as_deref(), Some("executive"));
    let c = on_a.counts;
    assert_eq!((c.first, c.newest, c.arrived, c.missing, c.duplicates, c.late), (1, 150, 130, 20, 0, 0));
    let out = sent.outgoing(on_a.outlet).expect("the sender's outlet");
    assert!(out.key.ends_with("/cmd/send"), "{out:?}");
    assert_eq!((out.sent, out.withheld, out.failed), (150, 20, 0));
    assert_eq!(
        c.missing, out.withheld,
        "every message lost on the way is counted where it should have arrived"
    );
    assert_eq!(ta.stats().missing, 20);
    assert_eq!(ta.stats().duplicated, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_push_stream_is_numbered_at_its_outlet_and_counted_at_its_subscriber() {
    let (a, ta, b, tb) = pair("t_ledger_push").await;
    let push = PushNewestServer::<u64>::register(&a, ODO.on("robot")).expect("push server");
    tb.wait_for(&[ODO.on("robot").untyped()], WAIT).await.expect("b sees a");
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Update<u64>>();
    let odo = PushNewestClient::<u64>::connect_to(&b, ODO.on("robot"), Sink::channel(tx)).expect("client");
    odo.subscribe().expect("subscribe");
    // Updates before the subscription reaches a are published to nobody.
    let mut k = 0;
    loop {
        k += 1;
        push.put(k);
        if let Ok(Some(_)) = tokio::time::timeout(Duration::from_millis(200), rx.recv()).await {
            break;
        }
        assert!(k < 50, "the subscription never delivered");
    }
    // Each update once the one before has arrived (see `receive`).
    let mut received = 1;
    for v in k + 1..=k + 200 {
        push.put(v);
        tokio::time::timeout(WAIT, async {
            loop {
                received += 1;
                if rx.recv().await.expect("open").value == v {
                    break;
                }
            }
        })
        .await
        .expect("in time");
    }

    let got = tb.link_ledger();
    let on_b = incoming(&got, ta.zid(), "/odo/push/1");
    assert_eq!(on_b.role.as_deref(), Some("robot"));
    let c = on_b.counts;
    assert_eq!(c.arrived, received, "every update delivered was counted once: {c:?}");
    assert_eq!((c.missing, c.duplicates), (0, 0), "nothing lost on loopback: {c:?}");
    let out = ta.link_ledger();
    let out = out.outgoing(on_b.outlet).expect("the publisher's outlet");
    assert_eq!(out.sent, c.newest, "the last one put is the last one that arrived");
    assert_eq!(c.newest - c.first + 1, c.arrived);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_message_without_a_number_is_delivered_and_counted_unnumbered() {
    let (a, ta, _b, tb) = pair("t_ledger_foreign").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&a, CMD.on("robot"), Sink::channel(tx)).expect("send server");
    tb.wait_for(&[CMD.on("robot").untyped()], WAIT).await.expect("b sees a");
    let key = tb.keys().send(&CMD.on("robot").untyped());
    let msg =
        orsa_actors::wire::encode_stamped(&Stamped { seq: 1, sent_at: Default::default(), value: 7u64 });
    // As a foreign client writes it: the zid alone, or nothing, or a number that is not one.
    for attachment in [Some(tb.zid().to_string()), None, Some(format!("{}/1/x", tb.zid()))] {
        let put = tb.session().put(key.clone(), msg.clone());
        match attachment {
            Some(a) => put.attachment(a).wait(),
            None => put.wait(),
        }
        .expect("put");
        receive(&mut rx, 7).await;
    }
    let ledger = ta.link_ledger();
    assert_eq!(ledger.unnumbered, 3, "{ledger:#?}");
    assert!(ledger.incoming.is_empty(), "{ledger:#?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_peer_that_forges_outlet_numbers_cannot_grow_the_receivers_table() {
    let (a, ta, _b, tb) = pair("t_ledger_forged").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&a, CMD.on("robot"), Sink::channel(tx)).expect("send server");
    tb.wait_for(&[CMD.on("robot").untyped()], WAIT).await.expect("b sees a");
    assert!(ta.wait_for_role("executive", WAIT).await);
    let key = tb.keys().send(&CMD.on("robot").untyped());
    let extra = 300;
    let total = orsa_net::MAX_LINK_STREAMS as u64 + extra;
    for outlet in 1..=total {
        let msg = orsa_actors::wire::encode_stamped(&Stamped {
            seq: outlet,
            sent_at: Default::default(),
            value: outlet,
        });
        tb.session()
            .put(key.clone(), msg)
            .attachment(format!("{}/{outlet}/1", tb.zid()))
            .wait()
            .expect("put");
        receive(&mut rx, outlet).await;
    }
    let ledger = ta.link_ledger();
    assert_eq!(ledger.incoming.len(), orsa_net::MAX_LINK_STREAMS);
    assert_eq!(ledger.untracked, extra, "the sender is alive: nothing of it is forgotten");
    assert_eq!(ledger.arrived(), orsa_net::MAX_LINK_STREAMS as u64);
}
