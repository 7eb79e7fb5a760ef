//! Fault injection: panics, hangs and kills restart the component under its supervisor and are
//! logged with the moment they were seen and the moment the component was back; message faults
//! lose, delay or duplicate exactly the messages they should.

use orsa_actors::component::ComponentHandle;
use orsa_actors::event::{EventClient, EventMode, EventServer};
use orsa_actors::fault::{FaultEventKind, HandlerFault, MessageFault};
use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::query::{QueryClient, QueryRequest, QueryServer};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::{EventService, PushNewestService, QueryService, SendService};
use orsa_actors::supervision::{
    Strategy, Supervisor, SupervisorEvent, SupervisorEventKind, SupervisorRef, SupervisorSpec,
};
use orsa_actors::{Component, ComponentError, Ctx, PatternError, Registry, Sink, Stamped};
use std::time::Duration;
use tokio::sync::mpsc;

/// The numbers the echo component is sent.
const INPUT: SendService<u64> = SendService::new("input");
/// Speed commands to a robot.
const SPEED: SendService<u64> = SendService::new("speed");
/// Odometry ticks.
const TICKS: PushNewestService<u64> = PushNewestService::new("ticks");

/// Echoes every number it is sent to a channel.
struct Echo(mpsc::UnboundedSender<u64>);
impl Component for Echo {
    type Msg = Stamped<u64>;
    type State = ();
    async fn setup(&self, ctx: &Ctx<Stamped<u64>>) -> Result<(), ComponentError> {
        ctx.send_server(INPUT, |m| m)?;
        Ok(())
    }
    async fn handle(&self, _: &Ctx<Stamped<u64>>, _: &mut (), m: Stamped<u64>) -> Result<(), ComponentError> {
        let _ = self.0.send(m.value);
        Ok(())
    }
}

/// The component, its echo channel, its supervisor's events, and the supervisor.
type Rig = (
    Registry,
    ComponentHandle<Echo>,
    mpsc::UnboundedReceiver<u64>,
    mpsc::UnboundedReceiver<SupervisorEvent>,
    SupervisorRef,
);

async fn supervised_echo() -> Rig {
    let registry = Registry::new();
    let (tx, rx) = mpsc::unbounded_channel();
    let echo = ComponentHandle::new(&registry, "echo", Echo(tx))
        .expect("add")
        .with_handler_timeout(Duration::from_millis(100));
    let (etx, events) = mpsc::unbounded_channel();
    let spec = SupervisorSpec::new("sup", Strategy::OneForOne)
        .with_intensity(10, Duration::from_secs(10))
        .with_clock(registry.clock())
        .with_event_sink(move |e| {
            let _ = etx.send(e);
        })
        .with_child(echo.child_spec());
    let sup = Supervisor::start(spec).await.expect("supervisor");
    (registry, echo, rx, events, sup)
}

async fn restarted(events: &mut mpsc::UnboundedReceiver<SupervisorEvent>) {
    loop {
        let e = events.recv().await.expect("supervisor events");
        if e.kind == SupervisorEventKind::Restarted {
            return;
        }
    }
}

fn kinds(registry: &Registry) -> Vec<(String, FaultEventKind)> {
    registry.faults().events().into_iter().map(|e| (e.target, e.what)).collect()
}

#[tokio::test(start_paused = true)]
async fn fault_a_hung_handler_is_detected_by_its_watchdog_and_restarted() {
    let (registry, echo, mut out, mut events, _sup) = supervised_echo().await;
    let client = SendClient::<u64>::connect(&registry, INPUT.on("echo")).expect("client");
    let first = echo.instance().expect("running").get_id();
    registry.faults().arm("echo", HandlerFault::Hang);
    let armed_at = registry.now();
    client.send(1).expect("send"); // this one hangs
    restarted(&mut events).await;
    assert_ne!(echo.instance().expect("running again").get_id(), first);
    let hung =
        registry.faults().events().into_iter().find(|e| e.what == FaultEventKind::Detected("hung".into()));
    let hung = hung.expect("the watchdog saw the hang");
    assert_eq!(
        hung.at.saturating_since(armed_at),
        Duration::from_millis(100),
        "exactly at the handler timeout"
    );
    client.send(2).expect("send");
    assert_eq!(out.recv().await, Some(2), "the new instance handles the next message");
    assert_eq!(
        kinds(&registry),
        vec![
            ("echo".into(), FaultEventKind::Injected("hang".into())),
            ("echo".into(), FaultEventKind::Detected("hung".into())),
            ("echo".into(), FaultEventKind::Recovered),
        ]
    );
}

#[tokio::test(start_paused = true)]
async fn fault_a_panicking_handler_and_a_killed_instance_are_restarted() {
    let (registry, echo, mut out, mut events, _sup) = supervised_echo().await;
    let client = SendClient::<u64>::connect(&registry, INPUT.on("echo")).expect("client");
    registry.faults().arm("echo", HandlerFault::Panic);
    client.send(1).expect("send"); // lost with the panicking instance
    restarted(&mut events).await;
    client.send(2).expect("send");
    assert_eq!(out.recv().await, Some(2));
    let before = echo.instance().expect("running").get_id();
    assert!(registry.faults().kill("echo"), "a running instance was killed");
    restarted(&mut events).await;
    assert_ne!(echo.instance().expect("running").get_id(), before);
    client.send(3).expect("send");
    assert_eq!(out.recv().await, Some(3));
    let log = kinds(&registry);
    assert_eq!(log.iter().filter(|(_, k)| *k == FaultEventKind::Recovered).count(), 2, "{log:?}");
    assert!(log.contains(&("echo".into(), FaultEventKind::Detected("panicked".into()))));
    assert!(log.contains(&("echo".into(), FaultEventKind::Detected("killed".into()))));
    assert!(!registry.faults().kill("nobody"), "an unknown component has nothing to kill");
}

#[tokio::test(start_paused = true)]
async fn fault_messages_are_dropped_delayed_and_duplicated_exactly_while_set() {
    let registry = Registry::new();
    let (tx, mut rx) = mpsc::unbounded_channel::<Stamped<u64>>();
    SendServer::<u64>::register(&registry, SPEED.on("robot"), Sink::channel(tx)).expect("server");
    let client = SendClient::<u64>::connect(&registry, SPEED.on("robot")).expect("client");
    let speed = SPEED.on("robot").untyped();
    let faults = registry.faults();
    let drain = |rx: &mut mpsc::UnboundedReceiver<Stamped<u64>>| {
        std::iter::from_fn(|| rx.try_recv().ok()).map(|m| m.value).collect::<Vec<_>>()
    };

    faults.set_message_fault(&speed, Some(MessageFault::Drop));
    client.send(1).expect("a dropped message still looks sent");
    faults.set_message_fault(&speed, Some(MessageFault::Duplicate));
    client.send(2).expect("send");
    faults.set_message_fault(&speed, Some(MessageFault::Delay(Duration::from_millis(50))));
    client.send(3).expect("send");
    faults.set_message_fault(&speed, None);
    client.send(4).expect("send");
    assert_eq!(drain(&mut rx), vec![2, 2, 4]);
    tokio::time::sleep(Duration::from_millis(49)).await;
    assert_eq!(drain(&mut rx), Vec::<u64>::new(), "not before 50 ms");
    tokio::time::sleep(Duration::from_millis(2)).await;
    assert_eq!(drain(&mut rx), vec![3], "the delayed one arrives 50 ms late");
    let counts = faults.message_counts();
    assert_eq!(counts.len(), 1);
    assert_eq!((counts[0].1.dropped, counts[0].1.duplicated, counts[0].1.delayed), (1, 1, 1));

    // Push updates: a dropped update reaches no subscriber and "newest" still moves on.
    let push = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("push");
    let (utx, mut urx) = mpsc::unbounded_channel();
    let sub =
        PushNewestClient::<u64>::connect_to(&registry, TICKS.on("odo"), Sink::channel(utx)).expect("client");
    sub.subscribe().expect("subscribe");
    let ticks = TICKS.on("odo").untyped();
    faults.set_message_fault(&ticks, Some(MessageFault::Drop));
    push.put(1);
    faults.set_message_fault(&ticks, Some(MessageFault::Duplicate));
    push.put(2);
    faults.set_message_fault(&ticks, None);
    push.put(3);
    let got: Vec<u64> = std::iter::from_fn(|| urx.try_recv().ok()).map(|u| u.value).collect();
    assert_eq!(got, vec![2, 2, 3]);
    assert_eq!(push.latest().map(|u| u.value), Some(3));
}

#[tokio::test(start_paused = true)]
async fn fault_a_client_newest_value_skips_lost_updates_and_survives_its_subscription() {
    let registry = Registry::new();
    let faults = registry.faults();
    let push = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("push");
    let client = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("client");
    let ticks = TICKS.on("odo").untyped();
    client.subscribe().expect("subscribe");
    push.put(1);
    assert_eq!(client.get_update().expect("update").value, 1);
    // A lost update is not the client's newest, although it is the server's.
    faults.set_message_fault(&ticks, Some(MessageFault::Drop));
    push.put(2);
    push.put(3);
    assert_eq!(push.latest().map(|u| u.value), Some(3));
    assert_eq!(client.get_update().expect("update").value, 1);
    // A late one becomes the newest when it arrives, unless a newer one came first.
    faults.set_message_fault(&ticks, Some(MessageFault::Delay(Duration::from_millis(50))));
    push.put(4);
    faults.set_message_fault(&ticks, None);
    assert_eq!(client.get_update().expect("update").value, 1);
    tokio::time::sleep(Duration::from_millis(60)).await;
    assert_eq!(client.get_update().expect("update").seq, 4);
    push.put(5);
    faults.set_message_fault(&ticks, Some(MessageFault::Delay(Duration::from_millis(50))));
    push.put(6);
    faults.set_message_fault(&ticks, None);
    push.put(7);
    tokio::time::sleep(Duration::from_millis(60)).await;
    assert_eq!(client.get_update().expect("update").value, 7, "a late 6 does not replace 7");
    // Unsubscribed, the client answers nothing; subscribed again, it still has its newest
    // value until the next update arrives.
    client.unsubscribe().expect("unsubscribe");
    push.put(8);
    assert!(matches!(client.get_update(), Err(PatternError::NotActive(_))));
    client.subscribe().expect("subscribe again");
    assert_eq!(client.get_update().expect("update").value, 7);
    push.put(9);
    assert_eq!(client.get_update().expect("update").value, 9);
    // Waiting: the next update, not the one already there.
    let waiter = async { client.get_update_wait().await.expect("update").value };
    let (got, ()) = tokio::join!(waiter, async {
        tokio::time::sleep(Duration::from_millis(10)).await;
        push.put(10);
    });
    assert_eq!(got, 10);
}

/// Squares numbers.
const SQUARE: QueryService<u64, u64> = QueryService::new("square");
/// Distances, fired to activations whose threshold they are below.
const NEAR: EventService<f64, f64> = EventService::new("near");

#[tokio::test(start_paused = true)]
async fn fault_query_requests_pass_the_same_door_as_every_message() {
    let registry = Registry::new();
    registry.ledger().enable(true);
    let (tx, mut requests) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(&registry, SQUARE.on("calc"), Sink::channel(tx)).expect("server");
    let handled = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let h = handled.clone();
    tokio::spawn(async move {
        while let Some(q) = requests.recv().await {
            h.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let n = q.request.value;
            // The copy a duplicate fault made has nobody waiting for its answer.
            let _ = q.answer(n * n);
        }
    });
    let client = QueryClient::<u64, u64>::connect(&registry, SQUARE.on("calc")).expect("client");
    let square = SQUARE.on("calc").untyped();
    let faults = registry.faults();

    faults.set_message_fault(&square, Some(MessageFault::Drop));
    let lost = client.query(2, None).await;
    assert!(matches!(lost, Err(PatternError::NoAnswer(_))), "a lost request is never answered: {lost:?}");
    assert_eq!(handled.load(std::sync::atomic::Ordering::Relaxed), 0);

    faults.set_message_fault(&square, Some(MessageFault::Duplicate));
    assert_eq!(client.query(3, None).await.expect("answered"), 9);
    tokio::task::yield_now().await;
    assert_eq!(handled.load(std::sync::atomic::Ordering::Relaxed), 2, "the server handled both copies");

    faults.set_message_fault(&square, Some(MessageFault::Delay(Duration::from_millis(50))));
    let start = tokio::time::Instant::now();
    assert_eq!(client.query(4, None).await.expect("answered"), 16);
    assert_eq!(start.elapsed(), Duration::from_millis(50), "answered once the request arrived, 50 ms late");
    faults.set_message_fault(&square, None);
    assert_eq!(client.query(5, None).await.expect("answered"), 25);

    let counts = faults.message_counts();
    assert_eq!((counts[0].1.dropped, counts[0].1.duplicated, counts[0].1.delayed), (1, 1, 1));
    let (_, _, ledger) = registry.ledger().counts().into_iter().find(|(a, ..)| *a == square).expect("ledger");
    assert_eq!((ledger.offered, ledger.dropped, ledger.copies_injected), (4, 1, 1), "{ledger:?}");
    assert_eq!(
        (ledger.delivered, ledger.duplicates),
        (3, 1),
        "the second copy is told from the first: {ledger:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn fault_events_pass_the_same_door_as_every_message() {
    let registry = Registry::new();
    let server = EventServer::register(&registry, NEAR.on("robot"), |limit: &mut f64, d: &f64| {
        (*d < *limit).then_some(*d)
    })
    .expect("server");
    let client = EventClient::<f64, f64>::connect(&registry, NEAR.on("robot")).expect("client");
    let (tx, mut rx) = mpsc::unbounded_channel();
    client.activate_to(EventMode::Continuous, 0.5, Sink::channel(tx)).expect("activate");
    let single = client.activate(EventMode::Single, 0.5).expect("activate");
    let near = NEAR.on("robot").untyped();
    let faults = registry.faults();
    let drain = |rx: &mut mpsc::UnboundedReceiver<orsa_actors::event::Fired<f64>>| {
        std::iter::from_fn(|| rx.try_recv().ok()).map(|f| f.event.value).collect::<Vec<_>>()
    };

    faults.set_message_fault(&near, Some(MessageFault::Drop));
    assert_eq!(server.put(&0.1), 2, "both activations fired; the faults lost both events");
    assert_eq!(server.activations(), 1, "a single activation has had its event, lost or not");
    drop(single);
    faults.set_message_fault(&near, Some(MessageFault::Duplicate));
    server.put(&0.2);
    faults.set_message_fault(&near, Some(MessageFault::Delay(Duration::from_millis(50))));
    server.put(&0.3);
    faults.set_message_fault(&near, None);
    server.put(&0.4);
    assert_eq!(drain(&mut rx), vec![0.2, 0.2, 0.4]);
    tokio::time::sleep(Duration::from_millis(51)).await;
    assert_eq!(drain(&mut rx), vec![0.3], "the delayed one arrives 50 ms late");
}
