use crate::Velocity;
use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::push_timed::{PushTimedServer, Tick};
use orsa_actors::send::{SendClient, SendServer};
use orsa_actors::wiring::{SendPort, WiringMaster};
use orsa_actors::{Component, ComponentError, Ctx, Empty, Sink, Stamped, Update};
use ractor::{Actor, ActorProcessingErr, ActorRef, SupervisionEvent};
use std::time::Duration;
use tokio::sync::mpsc;

/// Pushes its tick count every 10 ms.
struct Counter;
impl Component for Counter {
    type Msg = Tick;
    type State = PushTimedServer<u64>;
    async fn setup(&self, ctx: &Ctx<Tick>) -> Result<Self::State, ComponentError> {
        let s = ctx.push_timed_server::<u64>("count", Duration::from_millis(10), |t| t)?;
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
        ctx.subscribe_timed::<u64>("counter/count", 5, BehaviourMsg::Count)?;
        ctx.send_server::<Empty>("crash", |_| BehaviourMsg::Crash)?;
        Ok(ctx.send_port::<Velocity>("vel")?)
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

/// A bare ractor parent that reports its children's supervision events.
struct Parent(mpsc::UnboundedSender<&'static str>);
impl Actor for Parent {
    type Msg = ();
    type State = ();
    type Arguments = ();
    async fn pre_start(&self, _: ActorRef<()>, _: ()) -> Result<(), ActorProcessingErr> {
        Ok(())
    }
    async fn handle_supervisor_evt(
        &self,
        _: ActorRef<()>,
        evt: SupervisionEvent,
        _: &mut (),
    ) -> Result<(), ActorProcessingErr> {
        let kind = match evt {
            SupervisionEvent::ActorFailed(..) => "failed",
            SupervisionEvent::ActorTerminated(..) => "terminated",
            _ => return Ok(()),
        };
        let _ = self.0.send(kind);
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn supervision_restart_restores_wiring_and_subscriptions() {
    let registry = orsa_actors::Registry::new();
    let (mtx, mut motor) = mpsc::unbounded_channel::<Stamped<Velocity>>();
    SendServer::<Velocity>::register(&registry, "nomad200/navigationvelocity", Sink::channel(mtx))
        .expect("motor");
    let _counter = spawn(&registry, "counter", Counter).await.expect("spawn counter");
    let (etx, mut events) = mpsc::unbounded_channel();
    let (parent, _) = Actor::spawn(None, Parent(etx), ()).await.expect("parent");

    let behaviour = ComponentHandle::new(&registry, "wallfollow", Behaviour).expect("add");
    let first = behaviour.start(Some(parent.get_cell())).await.expect("start");
    WiringMaster::new(&registry).connect("wallfollow", "vel", "nomad200/navigationvelocity").expect("wire");

    tokio::time::sleep(Duration::from_millis(105)).await;
    let mut got: Vec<f64> = std::iter::from_fn(|| motor.try_recv().ok()).map(|m| m.v_m_s).collect();
    assert_eq!(got, vec![5.0, 10.0]);

    SendClient::<Empty>::connect(&registry, "wallfollow/crash")
        .expect("connect")
        .send(Empty {})
        .expect("send");
    assert_eq!(events.recv().await, Some("failed"));
    assert!(behaviour.instance().is_none_or(|i| i.get_id() == first.get_id()), "nothing restarted it yet");

    // Counts published while no instance runs are lost to it (and counted as failed).
    tokio::time::sleep(Duration::from_millis(50)).await;
    let second = behaviour.start(Some(parent.get_cell())).await.expect("restart");
    assert_ne!(second.get_id(), first.get_id());
    tokio::time::sleep(Duration::from_millis(100)).await;
    got = std::iter::from_fn(|| motor.try_recv().ok()).map(|m| m.v_m_s).collect();
    // Same every-5th rhythm, same wiring, nobody re-subscribed or re-wired it.
    assert_eq!(got, vec![20.0, 25.0]);
    let ports = WiringMaster::new(&registry).ports("wallfollow").expect("ports");
    assert_eq!(
        ports[0].target.as_ref().map(|t| t.to_string()).as_deref(),
        Some("nomad200/navigationvelocity")
    );
}
