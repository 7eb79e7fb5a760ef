//! Delivery accounting and what a restart does to queued messages: commands queued behind a
//! failing handler reach the next instance, stale push updates do not; the ledger counts what arrived, what arrived twice,
//! what a fault dropped, what the sender was told failed, and what vanished.

use orsa_actors::component::ComponentHandle;
use orsa_actors::fault::{HandlerFault, MessageFault};
use orsa_actors::ledger::DeliveryCounts;
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::send::SendClient;
use orsa_actors::service::{Addr, Descriptor, PushNewestService, SendService};
use orsa_actors::supervision::{Strategy, Supervisor, SupervisorEvent, SupervisorEventKind, SupervisorSpec};
use orsa_actors::{Component, ComponentError, Ctx, Registry, Stamped, Update};
use std::time::Duration;
use tokio::sync::mpsc;

/// The numbers the sink component is sent.
const INPUT: SendService<u64> = SendService::new("input");
/// The sensor's readings.
const READING: PushNewestService<u64> = PushNewestService::new("reading");

enum Msg {
    Input(Stamped<u64>),
    Reading(Update<u64>),
}

/// Reports every number it is sent, and every reading it subscribed to.
struct Sink2(mpsc::UnboundedSender<(char, u64)>);
impl Component for Sink2 {
    type Msg = Msg;
    type State = ();
    async fn setup(&self, ctx: &Ctx<Msg>) -> Result<(), ComponentError> {
        ctx.send_server(INPUT, Msg::Input)?;
        ctx.subscribe_newest(READING.on("sensor"), Msg::Reading)?;
        Ok(())
    }
    async fn handle(&self, _: &Ctx<Msg>, _: &mut (), m: Msg) -> Result<(), ComponentError> {
        let _ = match m {
            Msg::Input(m) => self.0.send(('i', m.value)),
            Msg::Reading(u) => self.0.send(('r', u.value)),
        };
        Ok(())
    }
}

struct Rig {
    registry: Registry,
    handle: ComponentHandle<Sink2>,
    out: mpsc::UnboundedReceiver<(char, u64)>,
    events: mpsc::UnboundedReceiver<SupervisorEvent>,
    sensor: PushNewestServer<u64>,
    input: SendClient<u64>,
}

async fn rig() -> Rig {
    let registry = Registry::new();
    registry.ledger().enable(true);
    let sensor = PushNewestServer::<u64>::register(&registry, READING.on("sensor")).expect("sensor");
    let (tx, out) = mpsc::unbounded_channel();
    let handle = ComponentHandle::new(&registry, "sink", Sink2(tx))
        .expect("add")
        .with_handler_timeout(Duration::from_millis(100));
    let (etx, events) = mpsc::unbounded_channel();
    let spec = SupervisorSpec::new("sup", Strategy::OneForOne)
        .with_intensity(10, Duration::from_secs(10))
        .with_clock(registry.clock())
        .with_event_sink(move |e| {
            let _ = etx.send(e);
        })
        .with_child(handle.child_spec());
    // The supervisor lives as long as the runtime: the test ends it.
    std::mem::forget(Supervisor::start(spec).await.expect("supervisor"));
    let input = SendClient::<u64>::connect(&registry, INPUT.on("sink")).expect("client");
    Rig { registry, handle, out, events, sensor, input }
}

fn counts<D: Descriptor>(registry: &Registry, service: Addr<D>) -> DeliveryCounts {
    let addr = service.untyped();
    registry.ledger().counts().into_iter().find(|(a, _, _)| *a == addr).map(|(_, _, c)| c).unwrap_or_default()
}

async fn restarted(events: &mut mpsc::UnboundedReceiver<SupervisorEvent>) {
    while events.recv().await.expect("supervisor events").kind != SupervisorEventKind::Restarted {}
}

async fn take(out: &mut mpsc::UnboundedReceiver<(char, u64)>, n: usize) -> Vec<(char, u64)> {
    let mut got = Vec::new();
    for _ in 0..n {
        got.push(out.recv().await.expect("handled"));
    }
    got
}

#[tokio::test(start_paused = true)]
async fn ledger_messages_queued_behind_a_hung_handler_reach_the_next_instance() {
    let mut r = rig().await;
    let first = r.handle.instance().expect("running").get_id();
    r.registry.faults().arm("sink", HandlerFault::Hang);
    r.input.send(1).expect("send"); // its handler hangs
    tokio::task::yield_now().await;
    for v in 2..=6 {
        r.input.send(v).expect("queued behind the hung handler");
        r.sensor.put(100 + v);
    }
    restarted(&mut r.events).await;
    assert_ne!(r.handle.instance().expect("running").get_id(), first);
    r.input.send(7).expect("send");
    r.sensor.put(107);
    let got = take(&mut r.out, 7).await;
    let inputs: Vec<u64> = got.iter().filter(|(k, _)| *k == 'i').map(|(_, v)| *v).collect();
    let readings: Vec<u64> = got.iter().filter(|(k, _)| *k == 'r').map(|(_, v)| *v).collect();
    assert_eq!(inputs, vec![2, 3, 4, 5, 6, 7], "queued commands first, in order, then the new one");
    assert_eq!(readings, vec![107], "stale readings are superseded by the next one, not replayed");
    let c = counts(&r.registry, INPUT.on("sink"));
    assert_eq!((c.offered, c.delivered, c.lost, c.failed, c.duplicates), (7, 7, 0, 0, 0), "{c:?}");
    assert_eq!(c.redelivered, 5, "2 to 6 went to the next instance");
    let c = counts(&r.registry, READING.on("sensor"));
    assert_eq!((c.offered, c.delivered, c.superseded, c.lost, c.redelivered), (6, 1, 5, 0, 0), "{c:?}");
}

#[tokio::test(start_paused = true)]
async fn ledger_a_killed_instance_loses_nothing_queued_and_a_restarting_one_refuses_openly() {
    let mut r = rig().await;
    for v in 1..=3 {
        r.input.send(v).expect("send");
    }
    assert!(r.registry.faults().kill("sink"), "killed with three messages queued");
    // Until the supervisor restarts it, the sender is told.
    let refused = r.input.send(4);
    restarted(&mut r.events).await;
    r.input.send(5).expect("send");
    let got: Vec<u64> = take(&mut r.out, 4).await.into_iter().map(|(_, v)| v).collect();
    let c = counts(&r.registry, INPUT.on("sink"));
    match refused {
        Err(_) => {
            assert_eq!(got, vec![1, 2, 3, 5]);
            assert_eq!((c.offered, c.delivered, c.failed, c.lost), (5, 4, 1, 0), "{c:?}");
        }
        Ok(()) => {
            assert_eq!(got, vec![1, 2, 3, 4], "taken while dying: handed to the next instance");
            assert_eq!(take(&mut r.out, 1).await, vec![('i', 5)]);
            let c = counts(&r.registry, INPUT.on("sink"));
            assert_eq!((c.offered, c.delivered, c.failed, c.lost), (5, 5, 0, 0), "{c:?}");
        }
    }
}

#[tokio::test(start_paused = true)]
async fn ledger_the_receiver_tells_duplicates_and_the_plan_owns_its_drops() {
    let mut r = rig().await;
    let addr = INPUT.on("sink").untyped();
    r.registry.faults().set_message_fault(&addr, Some(MessageFault::Duplicate));
    r.input.send(1).expect("send");
    r.registry.faults().set_message_fault(&addr, Some(MessageFault::Drop));
    r.input.send(2).expect("send");
    r.registry.faults().set_message_fault(&addr, Some(MessageFault::Delay(Duration::from_millis(50))));
    r.input.send(3).expect("send");
    r.registry.faults().set_message_fault(&addr, None);
    r.input.send(4).expect("send");
    // A replayed message (same sender, same number) is a duplicate too.
    r.input.send_stamped(Stamped { seq: 4, sent_at: r.registry.now(), value: 4 }).expect("send");
    let got: Vec<u64> = take(&mut r.out, 5).await.into_iter().map(|(_, v)| v).collect();
    assert_eq!(got, vec![1, 1, 4, 4, 3], "the delayed one last");
    let c = counts(&r.registry, INPUT.on("sink"));
    assert_eq!(
        (c.offered, c.copies_injected, c.delivered, c.duplicates, c.dropped, c.lost, c.in_flight()),
        (5, 1, 3, 2, 1, 0, 0),
        "{c:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn ledger_messages_queued_when_a_component_leaves_are_counted_lost() {
    let mut r = rig().await;
    r.registry.faults().arm("sink", HandlerFault::Hang);
    r.input.send(1).expect("send"); // hangs
    tokio::task::yield_now().await;
    r.input.send(2).expect("queued");
    r.input.send(3).expect("queued");
    r.handle.remove();
    let instance = r.handle.instance();
    assert!(instance.is_none(), "removing closes the mailbox");
    // The hung instance fails at its handler timeout and drops what it held.
    while r.events.recv().await.expect("supervisor events").kind != SupervisorEventKind::ChildFailed {}
    let c = counts(&r.registry, INPUT.on("sink"));
    assert_eq!((c.offered, c.delivered, c.lost), (3, 1, 2), "{c:?}");
}

#[tokio::test(start_paused = true)]
async fn ledger_counts_nothing_unless_enabled() {
    let r = rig().await;
    r.registry.ledger().enable(false);
    r.input.send(1).expect("send");
    r.sensor.put(1);
    assert_eq!(counts(&r.registry, INPUT.on("sink")), DeliveryCounts::default());
    assert_eq!(counts(&r.registry, READING.on("sensor")), DeliveryCounts::default());
}
