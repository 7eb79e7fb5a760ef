use orsa_actors::component::spawn;
use orsa_actors::push_timed::{PushTimedClient, PushTimedServer, Tick};
use orsa_actors::service::PushTimedService;
use orsa_actors::{Component, ComponentError, Ctx, PatternError, Registry, Sink, Update};
use std::time::Duration;
use tokio::sync::mpsc;

/// The ir sensor's scans (here its tick count).
const DISTANCEIR: PushTimedService<u64> = PushTimedService::new("distanceir");
/// A timed service the test drives by hand.
const T: PushTimedService<u64> = PushTimedService::new("t");
/// A timed service whose period is refused.
const Y: PushTimedService<u64> = PushTimedService::new("y");

/// A sensor server pushing its tick count every 40 ms; it leaves its server handle in `.0`.
#[derive(Default)]
struct Ir(std::sync::Arc<parking_lot::Mutex<Option<PushTimedServer<u64>>>>);
impl Component for Ir {
    type Msg = Tick;
    type State = PushTimedServer<u64>;
    async fn setup(&self, ctx: &Ctx<Tick>) -> Result<Self::State, ComponentError> {
        let s = ctx.push_timed_server(DISTANCEIR, Duration::from_millis(40), |t| t)?;
        s.start();
        *self.0.lock() = Some(s.clone());
        Ok(s)
    }
    async fn handle(&self, _: &Ctx<Tick>, s: &mut Self::State, t: Tick) -> Result<(), ComponentError> {
        s.put(t.seq);
        Ok(())
    }
}

fn counted(registry: &Registry, every: u32) -> (PushTimedClient<u64>, mpsc::UnboundedReceiver<Update<u64>>) {
    let (tx, rx) = mpsc::unbounded_channel();
    let c = PushTimedClient::connect_to(registry, DISTANCEIR.on("ir"), Sink::channel(tx)).expect("connect");
    c.subscribe(every).expect("subscribe");
    (c, rx)
}

fn values(rx: &mut mpsc::UnboundedReceiver<Update<u64>>) -> Vec<u64> {
    let mut out = Vec::new();
    while let Ok(u) = rx.try_recv() {
        out.push(u.value);
    }
    out
}

#[tokio::test(start_paused = true)]
async fn push_timed_every_nth_counts_are_exact() {
    let registry = Registry::new();
    let ir = spawn(&registry, "ir", Ir::default()).await.expect("spawn");
    let (_c1, mut r1) = counted(&registry, 1);
    let (_c10, mut r10) = counted(&registry, 10);
    let (_c3, mut r3) = counted(&registry, 3);
    // 4 s of 40 ms ticks = 100 updates (plus half a period so the 100th is handled).
    tokio::time::sleep(Duration::from_millis(4020)).await;
    assert_eq!(values(&mut r1), (1..=100).collect::<Vec<_>>());
    assert_eq!(values(&mut r10), (1..=10).map(|k| 10 * k).collect::<Vec<_>>());
    assert_eq!(values(&mut r3).len(), 33);
    ir.stop().await;
}

#[tokio::test(start_paused = true)]
async fn push_timed_first_update_comes_one_period_after_start_with_its_stamp() {
    let registry = Registry::new();
    let _ir = spawn(&registry, "ir", Ir::default()).await.expect("spawn");
    let (c, _r) = counted(&registry, 10);
    let start = tokio::time::Instant::now();
    let u = c.get_update_wait().await.expect("update");
    assert_eq!(u.value, 10);
    assert_eq!(
        start.elapsed(),
        Duration::from_millis(400),
        "the original's 10 x 40 ms = one scan per 400 ms"
    );
    assert_eq!(registry.clock().since_start(u.sent_at), Duration::from_millis(400));
}

#[tokio::test(start_paused = true)]
async fn push_timed_stop_and_start() {
    let registry = Registry::new();
    let (tick_tx, mut ticks) = mpsc::unbounded_channel::<Tick>();
    let server = PushTimedServer::<u64>::register(
        &registry,
        T.on("s"),
        Duration::from_millis(100),
        Sink::channel(tick_tx),
    )
    .expect("register");
    let producer = server.clone();
    tokio::spawn(async move {
        while let Some(t) = ticks.recv().await {
            producer.put(t.seq);
        }
    });
    let client = PushTimedClient::<u64>::connect(&registry, T.on("s")).expect("connect");
    client.subscribe(1).expect("subscribe");
    assert!(!server.is_active());
    assert!(matches!(client.get_update_wait().await, Err(PatternError::NotActive(_))), "stopped server");

    server.start();
    tokio::time::sleep(Duration::from_millis(350)).await;
    assert_eq!(client.get_update().expect("update").value, 3);

    // Stopping while a client waits answers NotActive; no ticks while stopped.
    let stopper = server.clone();
    tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(20)).await;
        stopper.stop();
    });
    assert!(matches!(client.get_update_wait().await, Err(PatternError::NotActive(_))));
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert_eq!(server.stats().published, 3);

    server.start();
    assert_eq!(client.get_update_wait().await.expect("update").value, 4, "tick count carries on");
}

#[tokio::test(start_paused = true)]
async fn push_timed_rejects_zero_every_and_zero_period() {
    let registry = Registry::new();
    let _ir = spawn(&registry, "ir", Ir::default()).await.expect("spawn");
    let c = PushTimedClient::<u64>::connect(&registry, DISTANCEIR.on("ir")).expect("connect");
    assert!(matches!(c.subscribe(0), Err(PatternError::InvalidArgument(_))));
    let (tx, _rx) = mpsc::unbounded_channel();
    let err = PushTimedServer::<u64>::register(&registry, Y.on("x"), Duration::ZERO, Sink::channel(tx)).err();
    assert!(matches!(err, Some(PatternError::InvalidArgument(_))));
}

#[tokio::test(start_paused = true)]
async fn push_timed_many_subscribers_each_at_their_own_rate() {
    let registry = Registry::new();
    let _ir = spawn(&registry, "ir", Ir::default()).await.expect("spawn");
    let subs: Vec<_> = (1..=40).map(|n| counted(&registry, n)).collect();
    tokio::time::sleep(Duration::from_millis(40 * 120 + 20)).await;
    for (n, (_c, rx)) in (1..=40u64).zip(subs) {
        let mut rx = rx;
        let got = values(&mut rx);
        assert_eq!(got.len() as u64, 120 / n, "subscriber at every {n}");
        assert!(got.iter().all(|v| v % n == 0));
    }
}

#[tokio::test(start_paused = true)]
async fn push_timed_a_tick_handler_may_stop_its_own_server() {
    let registry = Registry::new();
    let slot: std::sync::Arc<parking_lot::Mutex<Option<PushTimedServer<u64>>>> = Default::default();
    let s2 = slot.clone();
    let sink = Sink::from_fn(move |t: Tick| {
        if t.seq == 3
            && let Some(s) = s2.lock().as_ref()
        {
            s.stop();
        }
        Ok(())
    });
    let server = PushTimedServer::<u64>::register(&registry, T.on("s"), Duration::from_millis(10), sink)
        .expect("register");
    *slot.lock() = Some(server.clone());
    server.start();
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert!(!server.is_active());
    assert_eq!(server.missed_ticks(), 0);
}

#[tokio::test(start_paused = true)]
async fn push_timed_rejects_a_period_too_long_to_schedule() {
    let registry = Registry::new();
    let (tx, _rx) = mpsc::unbounded_channel();
    let err = PushTimedServer::<u64>::register(&registry, Y.on("x"), Duration::MAX, Sink::channel(tx)).err();
    assert!(matches!(err, Some(PatternError::InvalidArgument(m)) if m.contains("at most")));
}

/// Subscribes to the ir pushes with every 1 and counts what arrives.
struct Listener;
impl Component for Listener {
    type Msg = Update<u64>;
    type State = ();
    async fn setup(&self, ctx: &Ctx<Update<u64>>) -> Result<(), ComponentError> {
        ctx.subscribe_timed(DISTANCEIR.on("ir"), 1, |u| u)?;
        Ok(())
    }
    async fn handle(&self, _: &Ctx<Update<u64>>, _: &mut (), _: Update<u64>) -> Result<(), ComponentError> {
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn push_timed_a_removed_subscriber_is_dropped_by_the_server() {
    let registry = Registry::new();
    let slot = Ir::default();
    let server = slot.0.clone();
    let _ir = spawn(&registry, "ir", slot).await.expect("spawn");
    let listener = spawn(&registry, "listener", Listener).await.expect("spawn");
    tokio::time::sleep(Duration::from_millis(100)).await;
    let stats = || server.lock().as_ref().expect("server").stats();
    assert_eq!(stats().subscribers, 1);
    listener.stop().await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let stats = stats();
    assert_eq!(stats.subscribers, 0, "the stopped component's subscription ended");
    assert_eq!(stats.failed, 0, "and nothing was sent to it after");
}
