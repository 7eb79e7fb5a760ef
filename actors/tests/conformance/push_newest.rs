use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::service::PushNewestService;
use orsa_actors::{PatternError, Registry, Sink, Update};
use std::time::Duration;
use tokio::sync::mpsc;

/// Odometry ticks.
const TICKS: PushNewestService<u64> = PushNewestService::new("ticks");

#[tokio::test(start_paused = true)]
async fn push_newest_every_subscriber_gets_each_value_in_order() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let mut rxs = Vec::new();
    let mut clients = Vec::new();
    for _ in 0..5 {
        let (tx, rx) = mpsc::unbounded_channel::<Update<u64>>();
        let c = PushNewestClient::connect_to(&registry, TICKS.on("odo"), Sink::channel(tx)).expect("connect");
        c.subscribe().expect("subscribe");
        clients.push(c);
        rxs.push(rx);
    }
    for v in 1..=20 {
        assert_eq!(server.put(v), 5);
    }
    for rx in &mut rxs {
        let mut got = Vec::new();
        while let Ok(u) = rx.try_recv() {
            got.push((u.seq, u.value));
        }
        assert_eq!(got, (1..=20).map(|v| (v, v)).collect::<Vec<_>>());
    }
    assert_eq!(server.stats().delivered, 100);
}

#[tokio::test(start_paused = true)]
async fn push_newest_get_update_is_newest_without_waiting() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let client = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect");
    assert!(matches!(client.get_update(), Err(PatternError::NotActive(_))), "not subscribed yet");
    client.subscribe().expect("subscribe");
    assert_eq!(client.get_update().err(), Some(PatternError::NoData));
    server.put(1);
    server.put(2);
    server.put(3);
    assert_eq!(client.get_update().expect("update").value, 3);
    assert_eq!(client.get_update().expect("update").value, 3, "get_update does not consume");
}

#[tokio::test(start_paused = true)]
async fn push_newest_get_update_wait_waits_for_the_next_value() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let client = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect");
    client.subscribe().expect("subscribe");
    server.put(1);
    let producer = server.clone();
    tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(70)).await;
        producer.put(2);
    });
    let start = tokio::time::Instant::now();
    let u = client.get_update_wait().await.expect("update");
    assert_eq!(
        (u.value, start.elapsed()),
        (2, Duration::from_millis(70)),
        "waits for a new value, not the old"
    );
}

#[tokio::test(start_paused = true)]
async fn push_newest_unsubscribe_and_drop_stop_deliveries() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let a = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect");
    let b = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect");
    a.subscribe().expect("subscribe");
    b.subscribe().expect("subscribe");
    assert_eq!(server.put(1), 2);
    a.unsubscribe().expect("unsubscribe");
    assert!(matches!(a.unsubscribe(), Err(PatternError::NotActive(_))), "twice is an error");
    assert_eq!(server.put(2), 1);
    drop(b);
    assert_eq!(server.put(3), 0);
    assert_eq!(server.stats().subscribers, 0);
}

#[tokio::test(start_paused = true)]
async fn push_newest_rejects_a_timed_client() {
    let registry = Registry::new();
    let _server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    // Untyped, as an address a person typed: the registry, not the compiler, refuses it.
    let err =
        orsa_actors::push_timed::PushTimedClient::<u64>::connect(&registry, TICKS.on("odo").untyped()).err();
    assert!(matches!(err, Some(PatternError::IncompatibleService { .. })), "{err:?}");
}

#[tokio::test(start_paused = true)]
async fn push_newest_wait_ends_when_the_subscription_ends() {
    let registry = Registry::new();
    let _server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let client =
        std::sync::Arc::new(PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect"));
    client.subscribe().expect("subscribe");
    let waiter = {
        let c = client.clone();
        tokio::spawn(async move { c.get_update_wait().await.map(|u| u.value) })
    };
    tokio::time::sleep(Duration::from_secs(1)).await;
    client.unsubscribe().expect("unsubscribe");
    assert!(matches!(waiter.await.expect("task"), Err(PatternError::NotActive(_))));
    client.subscribe().expect("subscribe");
    let start = tokio::time::Instant::now();
    assert_eq!(
        client.get_update_wait_timeout(Duration::from_millis(300)).await.err(),
        Some(PatternError::Timeout)
    );
    assert_eq!(start.elapsed(), Duration::from_millis(300));
}

#[tokio::test(start_paused = true)]
async fn push_newest_a_sink_may_unsubscribe_while_values_are_delivered() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let holder: std::sync::Arc<parking_lot::Mutex<Option<PushNewestClient<u64>>>> = Default::default();
    let h = holder.clone();
    let sink = Sink::from_fn(move |u: Update<u64>| {
        if u.value == 2 {
            // Dropping the client from inside its own delivery unsubscribes it: no deadlock.
            h.lock().take();
        }
        Ok(())
    });
    let client = PushNewestClient::connect_to(&registry, TICKS.on("odo"), sink).expect("connect");
    client.subscribe().expect("subscribe");
    *holder.lock() = Some(client);
    assert_eq!(server.put(1), 1);
    assert_eq!(server.put(2), 1);
    assert_eq!(server.put(3), 0);
    assert_eq!(server.stats().subscribers, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn push_newest_newest_only_moves_forward_under_concurrent_publishers() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let client = PushNewestClient::<u64>::connect(&registry, TICKS.on("odo")).expect("connect");
    client.subscribe().expect("subscribe");
    let threads: Vec<_> = (0..4)
        .map(|_| {
            let s = server.clone();
            std::thread::spawn(move || {
                for i in 0..5000 {
                    s.put(i);
                }
            })
        })
        .collect();
    for t in threads {
        t.join().expect("publisher");
    }
    assert_eq!(client.get_update().expect("update").seq, 20_000);
    assert_eq!(server.latest().expect("latest").seq, 20_000);
}

#[tokio::test(start_paused = true)]
async fn push_newest_stats_count_what_reached_each_subscriber() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let (tx, mut rx) = mpsc::unbounded_channel::<Update<u64>>();
    let open = PushNewestClient::connect_to(&registry, TICKS.on("odo"), Sink::channel(tx)).expect("connect");
    open.subscribe().expect("subscribe");
    let (tx, rx_closed) = mpsc::unbounded_channel::<Update<u64>>();
    let closing =
        PushNewestClient::connect_to(&registry, TICKS.on("odo"), Sink::channel(tx)).expect("connect");
    closing.subscribe().expect("subscribe");
    let refusing = PushNewestClient::connect_to(
        &registry,
        TICKS.on("odo"),
        Sink::from_fn(|_: Update<u64>| Err(orsa_actors::Undeliverable::Unavailable)),
    )
    .expect("connect");
    refusing.subscribe().expect("subscribe");
    assert_eq!(server.put(1), 2);
    drop(rx_closed);
    assert_eq!(server.put(2), 1, "the closed one is dropped, the refusing one fails");
    assert_eq!(server.put(3), 1);
    let stats = server.stats();
    assert_eq!((stats.published, stats.delivered, stats.failed, stats.subscribers), (3, 4, 3, 2));
    assert_eq!(std::iter::from_fn(|| rx.try_recv().ok()).count(), 3);
}

/// A publication reuses the newest update's allocation once every subscriber is done with it,
/// and never changes an update that someone still holds.
#[tokio::test(start_paused = true)]
async fn push_newest_reuses_an_update_nobody_holds_and_never_changes_a_held_one() {
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, TICKS.on("odo")).expect("register");
    let (tx, mut rx) = mpsc::unbounded_channel::<Update<u64>>();
    let client =
        PushNewestClient::connect_to(&registry, TICKS.on("odo"), Sink::channel(tx)).expect("connect");
    client.subscribe().expect("subscribe");

    server.put(1);
    let held = rx.try_recv().expect("first update");
    server.put(2);
    let second = rx.try_recv().expect("second update");
    assert_eq!((held.seq, held.value), (1, 1), "an update held stays as it was");
    assert!(!std::sync::Arc::ptr_eq(&held, &second), "held: the next one is a new allocation");

    let at = std::sync::Arc::as_ptr(&second);
    drop((held, second));
    server.put(3);
    let third = rx.try_recv().expect("third update");
    assert_eq!((third.seq, third.value), (3, 3));
    assert_eq!(std::sync::Arc::as_ptr(&third), at, "nobody held the second: its allocation was reused");
    assert_eq!(server.latest().map(|u| (u.seq, u.value)), Some((3, 3)));
}
