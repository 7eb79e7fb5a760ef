use crate::{Velocity, drain};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::SendService;
use orsa_actors::{PatternError, PatternKind, Registry, ServiceAddr, Sink, Stamped};
use tokio::sync::mpsc;

/// Velocity commands to a robot's base.
const NAVIGATIONVELOCITY: SendService<Velocity> = SendService::new("navigationvelocity");
/// Numbered messages from many clients.
const IN: SendService<Pair> = SendService::new("in");

fn server(registry: &Registry) -> (SendServer<Velocity>, mpsc::UnboundedReceiver<Stamped<Velocity>>) {
    let (tx, rx) = mpsc::unbounded_channel();
    let s = SendServer::register(registry, NAVIGATIONVELOCITY.on("nomad200"), Sink::channel(tx))
        .expect("register");
    (s, rx)
}

#[tokio::test(start_paused = true)]
async fn send_delivers_in_order_with_sequence_numbers_and_stamps() {
    let registry = Registry::new();
    let (srv, mut rx) = server(&registry);
    let client =
        SendClient::<Velocity>::connect(&registry, NAVIGATIONVELOCITY.on("nomad200")).expect("connect");
    for i in 0..5 {
        client.send(Velocity { v_m_s: f64::from(i) * 0.1, omega_rad_s: 0.0 }).expect("send");
        tokio::time::advance(std::time::Duration::from_millis(10)).await;
    }
    let got = drain(&mut rx);
    assert_eq!(got.iter().map(|m| m.seq).collect::<Vec<_>>(), vec![1, 2, 3, 4, 5]);
    assert_eq!(
        got.iter().map(|m| registry.clock().since_start(m.sent_at).as_millis()).collect::<Vec<_>>(),
        vec![0, 10, 20, 30, 40]
    );
    assert_eq!(got[3].v_m_s, 0.30000000000000004);
    assert_eq!(srv.received(), 5);
    assert_eq!(client.sent(), 5);
}

#[tokio::test(start_paused = true)]
async fn send_to_unknown_component_or_service_names_it() {
    let registry = Registry::new();
    let (_srv, _rx) = server(&registry);
    let err = SendClient::<Velocity>::connect(&registry, NAVIGATIONVELOCITY.on("nomad201")).err();
    assert_eq!(err, Some(PatternError::UnknownComponent("nomad201".into())));
    let err = SendClient::<Velocity>::connect(&registry, ServiceAddr::new("nomad200", "velocity")).err();
    assert_eq!(err, Some(PatternError::UnknownService(ServiceAddr::new("nomad200", "velocity"))));
    // A malformed address is refused where it is typed, naming the text: no client takes a string.
    let err = "not an address".parse::<ServiceAddr>().expect_err("malformed");
    assert!(err.to_string().contains("'not an address' is not a service address"), "{err}");
}

#[tokio::test(start_paused = true)]
async fn send_with_another_type_is_an_incompatible_service() {
    let registry = Registry::new();
    let (_srv, _rx) = server(&registry);
    // Untyped, as an address a person typed: the registry, not the compiler, refuses it.
    match SendClient::<f64>::connect(&registry, NAVIGATIONVELOCITY.on("nomad200").untyped()) {
        Err(PatternError::IncompatibleService { expected, found, found_pattern, .. }) => {
            assert_eq!(expected, "orsa.F64/1");
            assert_eq!(found, "orsa.test.Velocity/1");
            assert_eq!(found_pattern, PatternKind::Send);
        }
        other => panic!("expected IncompatibleService, got {:?}", other.err()),
    }
    // Same type, other pattern.
    match orsa_actors::query::QueryClient::<Velocity, Velocity>::connect(
        &registry,
        NAVIGATIONVELOCITY.on("nomad200").untyped(),
    ) {
        Err(PatternError::IncompatibleService { expected_pattern, found_pattern, .. }) => {
            assert_eq!((expected_pattern, found_pattern), (PatternKind::Query, PatternKind::Send));
        }
        other => panic!("expected IncompatibleService, got {:?}", other.err()),
    }
}

#[tokio::test(start_paused = true)]
async fn send_to_a_gone_receiver_is_unavailable() {
    let registry = Registry::new();
    let (_srv, rx) = server(&registry);
    let client =
        SendClient::<Velocity>::connect(&registry, NAVIGATIONVELOCITY.on("nomad200")).expect("connect");
    drop(rx);
    let err = client.send(Velocity { v_m_s: 0.0, omega_rad_s: 0.0 }).err();
    assert_eq!(err, Some(PatternError::Unavailable(ServiceAddr::new("nomad200", "navigationvelocity"))));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn send_from_many_clients_at_once_keeps_each_clients_order() {
    let registry = Registry::new();
    let (tx, mut rx) = mpsc::unbounded_channel::<Stamped<Pair>>();
    SendServer::<Pair>::register(&registry, IN.on("sink"), Sink::channel(tx)).expect("register");
    let mut tasks = Vec::new();
    for c in 0..16u64 {
        let client = SendClient::<Pair>::connect(&registry, IN.on("sink")).expect("connect");
        tasks.push(tokio::spawn(async move {
            for i in 0..500u64 {
                client.send(Pair(c, i)).expect("send");
                if i % 50 == 0 {
                    tokio::task::yield_now().await;
                }
            }
        }));
    }
    for t in tasks {
        t.await.expect("task");
    }
    let mut next = [0u64; 16];
    let mut total = 0;
    while let Ok(m) = rx.try_recv() {
        let Pair(c, i) = m.value;
        assert_eq!(i, next[c as usize], "client {c} out of order");
        assert_eq!(m.seq, i + 1, "each client numbers its own messages");
        next[c as usize] += 1;
        total += 1;
    }
    assert_eq!(total, 16 * 500);
}

/// (client, index) of a message.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Pair(u64, u64);
orsa_actors::comm_object!(Pair, "orsa.test.Pair/1");
