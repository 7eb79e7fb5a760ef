use crate::{Velocity, drain};
use orsa_actors::send::SendServer;
use orsa_actors::service::{SendPortDesc, SendService};
use orsa_actors::wiring::{WiringMaster, WiringSlave};
use orsa_actors::{PatternError, Registry, ServiceAddr, Sink, Stamped};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use tokio::sync::mpsc;

/// Velocity commands to a robot's base.
const NAVIGATIONVELOCITY: SendService<Velocity> = SendService::new("navigationvelocity");
/// Speed commands to a robot: a Send service of another type.
const SPEED: SendService<f64> = SendService::new("speed");
/// A behaviour's velocity output.
const VEL: SendPortDesc<Velocity> = SendPortDesc::new("vel");

fn motor(
    registry: &Registry,
    name: &str,
) -> (SendServer<Velocity>, mpsc::UnboundedReceiver<Stamped<Velocity>>) {
    let (tx, rx) = mpsc::unbounded_channel();
    let s = SendServer::register(registry, NAVIGATIONVELOCITY.on(name), Sink::channel(tx)).expect("register");
    (s, rx)
}

fn vel(v: f64) -> Velocity {
    Velocity { v_m_s: v, omega_rad_s: 0.0 }
}

#[tokio::test(start_paused = true)]
async fn wiring_connects_disconnects_and_reconnects_a_port() {
    let registry = Registry::new();
    let (_a, mut ra) = motor(&registry, "robot_a");
    let (_b, mut rb) = motor(&registry, "robot_b");
    let slave = WiringSlave::register(&registry, "wallfollow").expect("register");
    let port = slave.send_port::<Velocity>(VEL.name()).expect("port");
    let master = WiringMaster::new(&registry);

    assert_eq!(port.send(vel(0.1)), Err(PatternError::Disconnected("vel".into())));
    master.connect("wallfollow", VEL, NAVIGATIONVELOCITY.on("robot_a")).await.expect("connect");
    port.send(vel(0.1)).expect("send");
    master.connect("wallfollow", VEL, NAVIGATIONVELOCITY.on("robot_b")).await.expect("rewire");
    port.send(vel(0.2)).expect("send");
    assert_eq!(drain(&mut ra).iter().map(|m| m.v_m_s).collect::<Vec<_>>(), vec![0.1]);
    assert_eq!(drain(&mut rb).iter().map(|m| m.v_m_s).collect::<Vec<_>>(), vec![0.2]);
    assert_eq!(
        master.ports("wallfollow").await.expect("ports")[0].target,
        Some(ServiceAddr::new("robot_b", "navigationvelocity"))
    );
    master.disconnect("wallfollow", VEL).await.expect("disconnect");
    assert_eq!(port.send(vel(0.3)), Err(PatternError::Disconnected("vel".into())));
    assert_eq!(master.ports("wallfollow").await.expect("ports")[0].target, None);
}

#[tokio::test(start_paused = true)]
async fn wiring_errors_name_the_port_or_service_and_keep_the_old_connection() {
    let registry = Registry::new();
    let (_a, mut ra) = motor(&registry, "robot");
    let (tx, _rx) = mpsc::unbounded_channel::<Stamped<f64>>();
    SendServer::<f64>::register(&registry, SPEED.on("robot"), Sink::channel(tx)).expect("register");
    let slave = WiringSlave::register(&registry, "wallfollow").expect("register");
    let port = slave.send_port::<Velocity>(VEL.name()).expect("port");
    let master = WiringMaster::new(&registry);
    master.connect("wallfollow", VEL, NAVIGATIONVELOCITY.on("robot")).await.expect("connect");

    // The errors are the slave's run-time checks: names and addresses as a person typed them.
    assert_eq!(
        master.connect_named("wallfollow", "speed", &NAVIGATIONVELOCITY.on("robot").untyped()).await,
        Err(PatternError::UnknownPort { component: "wallfollow".into(), port: "speed".into() })
    );
    assert!(matches!(
        master.connect_named("wallfollow", VEL.name(), &SPEED.on("robot").untyped()).await,
        Err(PatternError::IncompatibleService { .. })
    ));
    assert_eq!(
        master.connect_named("wallfollow", VEL.name(), &ServiceAddr::new("robot", "nothing")).await,
        Err(PatternError::UnknownService(ServiceAddr::new("robot", "nothing")))
    );
    assert_eq!(
        master.connect_named("ghost", VEL.name(), &SPEED.on("robot").untyped()).await,
        Err(PatternError::UnknownComponent("ghost".into()))
    );
    port.send(vel(0.25)).expect("still wired to the old service");
    assert_eq!(drain(&mut ra).len(), 1);
    assert!(slave.send_port::<f64>(VEL.name()).is_err(), "a port keeps its type");
}

/// Senders hammer a port from two threads while the master flips it between two motors and
/// disconnects it. After each disconnect returns, the motor it pointed at must receive nothing
/// more; nothing may deadlock.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wiring_rewiring_under_traffic_never_delivers_after_disconnect() {
    let registry = Registry::new();
    let (a, _ra) = motor(&registry, "robot_a");
    let (b, _rb) = motor(&registry, "robot_b");
    let slave = WiringSlave::register(&registry, "behaviour").expect("register");
    let port = slave.send_port::<Velocity>(VEL.name()).expect("port");
    let master = WiringMaster::new(&registry);
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let mut senders = Vec::new();
    for _ in 0..2 {
        let (port, stop, sent) = (port.clone(), stop.clone(), sent.clone());
        senders.push(std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if port.send(vel(0.1)).is_ok() {
                    sent.fetch_add(1, Ordering::Relaxed);
                }
            }
        }));
    }
    let servers = [(NAVIGATIONVELOCITY.on("robot_a"), &a), (NAVIGATIONVELOCITY.on("robot_b"), &b)];
    for round in 0..400 {
        let (target, server) = &servers[round % 2];
        master.connect("behaviour", VEL, target).await.expect("connect");
        // Let traffic reach the port's new target.
        let before = server.received();
        while server.received() < before + 5 {
            std::thread::yield_now();
        }
        master.disconnect("behaviour", VEL).await.expect("disconnect");
        let after_disconnect = (a.received(), b.received());
        // Senders keep going; none of it may reach either motor.
        for _ in 0..200 {
            std::thread::yield_now();
        }
        assert_eq!(
            (a.received(), b.received()),
            after_disconnect,
            "round {round}: delivered after disconnect"
        );
    }
    stop.store(true, Ordering::Relaxed);
    for s in senders {
        s.join().expect("sender thread");
    }
    assert_eq!(
        sent.load(Ordering::Relaxed),
        a.received() + b.received(),
        "every accepted send reached a motor"
    );
}
