use orsa_actors::event::{EventClient, EventMode, EventServer};
use orsa_actors::service::EventService;
use orsa_actors::{PatternError, Registry, Sink};
use tokio::sync::mpsc;

/// Distances, fired to activations whose threshold they are below.
const NEAR: EventService<f64, f64> = EventService::new("near");
/// Bumper states, fired to activations whose parameters say so.
const BUMPED: EventService<OnChange, bool> = EventService::new("bumped");

/// Fires the distance when it is below the activation's threshold.
fn near(registry: &Registry) -> EventServer<f64, f64, f64> {
    EventServer::register(registry, NEAR.on("nomad200"), |limit: &mut f64, d: &f64| {
        (*d < *limit).then_some(*d)
    })
    .expect("register")
}

#[tokio::test(start_paused = true)]
async fn event_single_fires_once_then_ends() {
    let registry = Registry::new();
    let server = near(&registry);
    let client = EventClient::<f64, f64>::connect(&registry, NEAR.on("nomad200")).expect("connect");
    let mut a = client.activate(EventMode::Single, 0.5).expect("activate");
    assert_eq!(server.put(&0.9), 0);
    assert_eq!(server.put(&0.4), 1);
    assert_eq!(server.put(&0.3), 0);
    assert_eq!(server.activations(), 0);
    let fired = a.next().await.expect("fired");
    assert_eq!((fired.activation, fired.event.value), (a.id(), 0.4));
    assert!(matches!(a.next().await, Err(PatternError::NotActive(_))));
}

#[tokio::test(start_paused = true)]
async fn event_continuous_fires_on_every_match_until_deactivated() {
    let registry = Registry::new();
    let server = near(&registry);
    let client = EventClient::<f64, f64>::connect(&registry, NEAR.on("nomad200")).expect("connect");
    let (tx, mut rx) = mpsc::unbounded_channel();
    let id = client.activate_to(EventMode::Continuous, 0.5, Sink::channel(tx)).expect("activate");
    for d in [0.6, 0.4, 0.45, 0.7, 0.1] {
        server.put(&d);
    }
    client.deactivate(id).expect("deactivate");
    server.put(&0.2);
    let mut got = Vec::new();
    while let Ok(f) = rx.try_recv() {
        got.push((f.event.seq, f.event.value));
    }
    assert_eq!(got, vec![(1, 0.4), (2, 0.45), (3, 0.1)]);
    assert!(matches!(client.deactivate(id), Err(PatternError::Unknown { .. })), "twice is an error");
}

#[tokio::test(start_paused = true)]
async fn event_fires_only_to_the_activations_whose_condition_holds() {
    let registry = Registry::new();
    let server = near(&registry);
    let c = EventClient::<f64, f64>::connect(&registry, NEAR.on("nomad200")).expect("connect");
    let mut close = c.activate(EventMode::Continuous, 0.2).expect("activate");
    let mut far = c.activate(EventMode::Continuous, 1.0).expect("activate");
    assert_eq!(server.put(&0.5), 1);
    assert_eq!(server.put(&0.1), 2);
    assert_eq!(far.try_next().expect("ok").map(|f| f.event.value), Some(0.5));
    assert_eq!(far.try_next().expect("ok").map(|f| f.event.value), Some(0.1));
    assert_eq!(close.try_next().expect("ok").map(|f| f.event.value), Some(0.1));
    assert_eq!(close.try_next().expect("ok"), None);
    drop(far);
    assert_eq!(server.activations(), 1, "dropping an activation deactivates it");
}

#[tokio::test(start_paused = true)]
async fn event_client_type_is_checked() {
    let registry = Registry::new();
    let _server = near(&registry);
    // Untyped, as an address a person typed: the registry, not the compiler, refuses it.
    let err = EventClient::<u64, f64>::connect(&registry, NEAR.on("nomad200").untyped()).err();
    assert!(matches!(err, Some(PatternError::IncompatibleService { .. })), "{err:?}");
}

/// The activation's parameters are the test's memory: fire only when the bumper state changes.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
struct OnChange {
    last: Option<bool>,
}
orsa_actors::comm_object!(OnChange, "orsa.test.OnChange/1");

#[tokio::test(start_paused = true)]
async fn event_test_may_keep_state_in_its_parameters_to_fire_on_change() {
    let registry = Registry::new();
    let server =
        EventServer::<OnChange, bool, bool>::register(&registry, BUMPED.on("nomad200"), |p, pressed| {
            let changed = p.last != Some(*pressed);
            p.last = Some(*pressed);
            changed.then_some(*pressed)
        })
        .expect("register");
    let client = EventClient::<OnChange, bool>::connect(&registry, BUMPED.on("nomad200")).expect("connect");
    let mut a = client.activate(EventMode::Continuous, OnChange::default()).expect("activate");
    let fired: usize = [false, false, true, true, true, false, false].iter().map(|s| server.put(s)).sum();
    assert_eq!(fired, 3, "first state, press, release");
    let mut got = Vec::new();
    while let Ok(Some(f)) = a.try_next() {
        got.push(f.event.value);
    }
    assert_eq!(got, vec![false, true, false]);
}

#[tokio::test(start_paused = true)]
async fn event_sinks_and_tests_may_use_the_server_without_deadlock() {
    let registry = Registry::new();
    let server = near(&registry);
    let client = EventClient::<f64, f64>::connect(&registry, NEAR.on("nomad200")).expect("connect");
    let inner = server.clone();
    let c2 = client.clone();
    let sink = Sink::from_fn(move |f: orsa_actors::event::Fired<f64>| {
        // A sink that looks at the server and deactivates itself: must not deadlock.
        assert!(inner.activations() >= 1);
        c2.deactivate(f.activation).map_err(|_| orsa_actors::Undeliverable::Closed)
    });
    client.activate_to(EventMode::Continuous, 0.5, sink).expect("activate");
    assert_eq!(server.put(&0.1), 1);
    assert_eq!(server.activations(), 0);
}
