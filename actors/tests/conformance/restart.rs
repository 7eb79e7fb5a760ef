use crate::Velocity;
use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::event::{EventMode, EventServer};
use orsa_actors::push_timed::{PushTimedServer, Tick};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::service::{EventService, PushTimedService, SendPortDesc, SendService};
use orsa_actors::supervision::{Strategy, Supervisor, SupervisorEvent, SupervisorEventKind, SupervisorSpec};
use orsa_actors::wiring::{SendPort, WiringMaster};
use orsa_actors::{Component, ComponentError, Ctx, Empty, Sink, Stamped, Update};
use std::time::Duration;
use tokio::sync::mpsc;

/// The counter's tick count.
const COUNT: PushTimedService<u64> = PushTimedService::new("count");
/// Makes a component panic.
const CRASH: SendService<Empty> = SendService::new("crash");
/// Velocity commands to a robot's base.
const NAVIGATIONVELOCITY: SendService<Velocity> = SendService::new("navigationvelocity");
/// A behaviour's velocity output.
const VEL: SendPortDesc<Velocity> = SendPortDesc::new("vel");
/// Values above the activation's limit.
const HIGH: EventService<u64, u64> = EventService::new("high");

/// Pushes its tick count every 10 ms.
struct Counter;
impl Component for Counter {
    type Msg = Tick;
    type State = PushTimedServer<u64>;
    async fn setup(&self, ctx: &Ctx<Tick>) -> Result<Self::State, ComponentError> {
        let s = ctx.push_timed_server(COUNT, Duration::from_millis(10), |t| t)?;
        s.start();
        Ok(s)
    }
    async fn handle(&self, _: &Ctx<Tick>, s: &mut Self::State, t: Tick) -> Result<(), ComponentError> {
        s.put(t.seq);
        Ok(())
    }
}

/// A behaviour: every 5th count goes out on its `vel` port; `crash` makes it panic.
struct Behaviour;
enum BehaviourMsg {
    Count(Update<u64>),
    Crash,
}
impl Component for Behaviour {
    type Msg = BehaviourMsg;
    type State = SendPort<Velocity>;
    async fn setup(&self, ctx: &Ctx<BehaviourMsg>) -> Result<Self::State, ComponentError> {
        ctx.subscribe_timed(COUNT.on("counter"), 5, BehaviourMsg::Count)?;
        ctx.send_server(CRASH, |_| BehaviourMsg::Crash)?;
        Ok(ctx.send_port(VEL)?)
    }
    async fn handle(
        &self,
        _: &Ctx<BehaviourMsg>,
        vel: &mut Self::State,
        msg: BehaviourMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            BehaviourMsg::Count(c) => {
                let _ = vel.send(Velocity { v_m_s: c.value as f64, omega_rad_s: 0.0 });
                Ok(())
            }
            BehaviourMsg::Crash => panic!("injected fault"),
        }
    }
}

#[tokio::test(start_paused = true)]
async fn supervision_restart_restores_wiring_and_subscriptions() {
    let registry = orsa_actors::Registry::new();
    let (mtx, mut motor) = mpsc::unbounded_channel::<Stamped<Velocity>>();
    SendServer::<Velocity>::register(&registry, NAVIGATIONVELOCITY.on("nomad200"), Sink::channel(mtx))
        .expect("motor");
    let _counter = spawn(&registry, "counter", Counter).await.expect("spawn counter");

    let behaviour = ComponentHandle::new(&registry, "wallfollow", Behaviour).expect("add");
    let (etx, mut events) = mpsc::unbounded_channel::<SupervisorEvent>();
    let spec = SupervisorSpec::new("reactive", Strategy::OneForOne)
        .with_intensity(3, Duration::from_secs(10))
        .with_clock(registry.clock())
        .with_event_sink(move |e| {
            let _ = etx.send(e);
        })
        .with_child(behaviour.child_spec());
    let sup = Supervisor::start(spec).await.expect("supervisor");
    let first = behaviour.instance().expect("running").get_id();
    WiringMaster::new(&registry)
        .connect("wallfollow", VEL, NAVIGATIONVELOCITY.on("nomad200"))
        .await
        .expect("wire");

    tokio::time::sleep(Duration::from_millis(105)).await;
    let mut got: Vec<f64> = std::iter::from_fn(|| motor.try_recv().ok()).map(|m| m.v_m_s).collect();
    assert_eq!(got, vec![5.0, 10.0]);

    SendClient::<Empty>::connect(&registry, CRASH.on("wallfollow"))
        .expect("connect")
        .send(Empty {})
        .expect("send");
    let failed = events.recv().await.expect("event");
    assert_eq!((failed.kind, failed.child.as_str()), (SupervisorEventKind::ChildFailed, "wallfollow"));
    assert!(failed.reason.contains("injected fault"), "{}", failed.reason);
    let restarted = events.recv().await.expect("event");
    assert_eq!((restarted.kind, restarted.restart_count), (SupervisorEventKind::Restarted, 1));
    assert_eq!(
        registry.clock().since_start(restarted.at),
        std::time::Duration::from_millis(105),
        "restarted at once, on the robot clock"
    );
    assert_ne!(behaviour.instance().expect("running").get_id(), first);

    tokio::time::sleep(Duration::from_millis(100)).await;
    got = std::iter::from_fn(|| motor.try_recv().ok()).map(|m| m.v_m_s).collect();
    // Same every-5th rhythm, same wiring: nobody re-subscribed or re-wired it.
    assert_eq!(got, vec![15.0, 20.0]);
    let ports = WiringMaster::new(&registry).ports("wallfollow").await.expect("ports");
    assert_eq!(
        ports[0].target.as_ref().map(|t| t.to_string()).as_deref(),
        Some("nomad200/navigationvelocity")
    );
    sup.shutdown().await;
    assert!(behaviour.instance().is_none(), "shutdown stops the component's instance");
}

/// Activates a continuous event in setup; panics on demand.
struct Watcher;
enum WatcherMsg {
    Fired,
    Crash,
}
impl Component for Watcher {
    type Msg = WatcherMsg;
    type State = ();
    async fn setup(&self, ctx: &Ctx<WatcherMsg>) -> Result<(), ComponentError> {
        ctx.activate_event(HIGH.on("alarm"), EventMode::Continuous, 10, |_| WatcherMsg::Fired)?;
        ctx.send_server(CRASH, |_| WatcherMsg::Crash)?;
        Ok(())
    }
    async fn handle(&self, _: &Ctx<WatcherMsg>, _: &mut (), msg: WatcherMsg) -> Result<(), ComponentError> {
        match msg {
            WatcherMsg::Fired => Ok(()),
            WatcherMsg::Crash => panic!("injected fault"),
        }
    }
}

#[tokio::test(start_paused = true)]
async fn supervision_restart_keeps_event_activations_without_duplicates() {
    let registry = orsa_actors::Registry::new();
    let alarm = EventServer::<u64, u64, u64>::register(&registry, HIGH.on("alarm"), |limit, v| {
        (*v > *limit).then_some(*v)
    })
    .expect("register");
    let watcher = ComponentHandle::new(&registry, "watcher", Watcher).expect("add");
    let (etx, mut events) = mpsc::unbounded_channel::<SupervisorEvent>();
    let spec = SupervisorSpec::new("s", Strategy::OneForOne)
        .with_intensity(5, Duration::from_secs(10))
        .with_event_sink(move |e| {
            let _ = etx.send(e);
        })
        .with_child(watcher.child_spec());
    let _sup = Supervisor::start(spec).await.expect("supervisor");
    assert_eq!(alarm.activations(), 1);
    for _ in 0..3 {
        SendClient::<Empty>::connect(&registry, CRASH.on("watcher"))
            .expect("c")
            .send(Empty {})
            .expect("send");
        assert_eq!(events.recv().await.map(|e| e.kind), Some(SupervisorEventKind::ChildFailed));
        assert_eq!(events.recv().await.map(|e| e.kind), Some(SupervisorEventKind::Restarted));
    }
    assert_eq!(alarm.activations(), 1, "three restarts, still one activation");
    assert_eq!(alarm.put(&11), 1);
}

#[tokio::test(start_paused = true)]
async fn supervision_a_stopped_component_is_not_restarted_as_a_zombie() {
    let registry = orsa_actors::Registry::new();
    let _counter = spawn(&registry, "counter", Counter).await.expect("spawn counter");
    let behaviour = ComponentHandle::new(&registry, "wallfollow", Behaviour).expect("add");
    let (etx, mut events) = mpsc::unbounded_channel::<SupervisorEvent>();
    let spec = SupervisorSpec::new("s", Strategy::OneForOne)
        .with_intensity(5, Duration::from_secs(10))
        .with_event_sink(move |e| {
            let _ = etx.send(e);
        })
        .with_child(behaviour.child_spec());
    let sup = Supervisor::start(spec).await.expect("supervisor");
    behaviour.stop().await;
    assert!(!registry.has_component("wallfollow"));
    // A permanent child's normal exit makes the supervisor try to restart it; a removed
    // component refuses to start, so no instance runs outside the registry.
    let mut kinds = Vec::new();
    while let Ok(Some(e)) = tokio::time::timeout(Duration::from_secs(1), events.recv()).await {
        kinds.push(e.kind);
    }
    assert!(kinds.contains(&SupervisorEventKind::ChildExited), "{kinds:?}");
    assert!(!kinds.contains(&SupervisorEventKind::Restarted), "{kinds:?}");
    assert!(behaviour.instance().is_none());
    sup.shutdown().await;
}
