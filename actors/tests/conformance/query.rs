use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::query::{QueryClient, QueryRequest, QueryServer, Responder};
use orsa_actors::service::{Addr, QueryService, SendService};
use orsa_actors::state::StateMaster;
use orsa_actors::{Component, ComponentError, Ctx, PatternError, Registry, ServiceAddr, Sink};
use std::time::Duration;
use tokio::sync::mpsc;

/// Squares a number.
const SQUARE: QueryService<u64, u64> = QueryService::new("square");
/// Never answers.
const NEVER: QueryService<u64, u64> = QueryService::new("never");
/// Drops every request unanswered.
const RUDE: QueryService<u64, u64> = QueryService::new("rude");
/// Answers each request with the sum of it and the next.
const PAIR: QueryService<u64, u64> = QueryService::new("pair");
/// Squares a number plus one, by asking `square`.
const PLUS_ONE_SQUARED: QueryService<u64, u64> = QueryService::new("plus_one_squared");
/// Starts the blocked component's query.
const GO: SendService<orsa_actors::Empty> = SendService::new("go");

/// Answers `n` with `n * n` at once.
fn squarer(registry: &Registry, at: Addr<QueryService<u64, u64>>) {
    let (tx, mut rx) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(registry, at, Sink::channel(tx)).expect("register");
    tokio::spawn(async move {
        while let Some(q) = rx.recv().await {
            let n = q.request.value;
            let _ = q.answer(n * n);
        }
    });
}

#[tokio::test(start_paused = true)]
async fn query_answers_the_request() {
    let registry = Registry::new();
    squarer(&registry, SQUARE.on("calc"));
    let client = QueryClient::<u64, u64>::connect(&registry, SQUARE.on("calc")).expect("connect");
    assert_eq!(client.query(12, None).await, Ok(144));
    assert_eq!(client.query(3, Some(Duration::from_millis(5))).await, Ok(9));
}

#[tokio::test(start_paused = true)]
async fn query_times_out_exactly_on_the_paused_clock() {
    let registry = Registry::new();
    let (tx, _keep) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(&registry, NEVER.on("calc"), Sink::channel(tx)).expect("register");
    let client = QueryClient::<u64, u64>::connect(&registry, NEVER.on("calc")).expect("connect");
    let start = tokio::time::Instant::now();
    assert_eq!(client.query(1, Some(Duration::from_millis(250))).await, Err(PatternError::Timeout));
    assert_eq!(start.elapsed(), Duration::from_millis(250));
}

#[tokio::test(start_paused = true)]
async fn query_request_now_collect_later_in_any_order() {
    let registry = Registry::new();
    squarer(&registry, SQUARE.on("calc"));
    let client = QueryClient::<u64, u64>::connect(&registry, SQUARE.on("calc")).expect("connect");
    let mut a = client.request(2).expect("request");
    let b = client.request(3).expect("request");
    assert_eq!(a.try_receive(), Ok(None), "nothing has run yet");
    assert_eq!(b.receive(None).await, Ok(9));
    assert_eq!(a.receive(None).await, Ok(4));
}

#[tokio::test(start_paused = true)]
async fn query_dropped_without_answer_is_no_answer() {
    let registry = Registry::new();
    let (tx, mut rx) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(&registry, RUDE.on("calc"), Sink::channel(tx)).expect("register");
    tokio::spawn(async move {
        while let Some(q) = rx.recv().await {
            drop(q);
        }
    });
    let client = QueryClient::<u64, u64>::connect(&registry, RUDE.on("calc")).expect("connect");
    assert_eq!(client.query(1, None).await, Err(PatternError::NoAnswer(ServiceAddr::new("calc", "rude"))));
}

/// A component that keeps each request and answers it when the next one arrives, with the sum
/// of both: the server answers later, after handling another message.
struct Deferred;
enum DeferredMsg {
    Ask(QueryRequest<u64, u64>),
}
impl Component for Deferred {
    type Msg = DeferredMsg;
    type State = Option<(u64, Responder<u64>)>;
    async fn setup(&self, ctx: &Ctx<DeferredMsg>) -> Result<Self::State, ComponentError> {
        ctx.query_server(PAIR, DeferredMsg::Ask)?;
        Ok(None)
    }
    async fn handle(
        &self,
        _ctx: &Ctx<DeferredMsg>,
        held: &mut Self::State,
        msg: DeferredMsg,
    ) -> Result<(), ComponentError> {
        let DeferredMsg::Ask(q) = msg;
        match held.take() {
            None => *held = Some((q.request.value, q.responder)),
            Some((first, responder)) => {
                let sum = first + q.request.value;
                responder.answer(sum)?;
                q.answer(sum)?;
            }
        }
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn query_server_may_answer_later_after_other_messages() {
    let registry = Registry::new();
    let _c = spawn(&registry, "deferred", Deferred).await.expect("spawn");
    let client = QueryClient::<u64, u64>::connect(&registry, PAIR.on("deferred")).expect("connect");
    let first = client.request(40).expect("request");
    tokio::time::advance(Duration::from_millis(100)).await;
    let second = client.query(2, Some(Duration::from_secs(1))).await;
    assert_eq!(second, Ok(42));
    assert_eq!(first.receive(Some(Duration::ZERO)).await, Ok(42));
}

/// Answers by asking another component: a nested call from inside a handler.
struct Forwarder;
enum ForwarderMsg {
    Ask(QueryRequest<u64, u64>),
}
impl Component for Forwarder {
    type Msg = ForwarderMsg;
    type State = QueryClient<u64, u64>;
    async fn setup(&self, ctx: &Ctx<ForwarderMsg>) -> Result<Self::State, ComponentError> {
        ctx.query_server(PLUS_ONE_SQUARED, ForwarderMsg::Ask)?;
        Ok(ctx.query_client(SQUARE.on("calc"))?)
    }
    async fn handle(
        &self,
        _ctx: &Ctx<ForwarderMsg>,
        square: &mut Self::State,
        msg: ForwarderMsg,
    ) -> Result<(), ComponentError> {
        let ForwarderMsg::Ask(q) = msg;
        let sq = square.query(q.request.value + 1, Some(Duration::from_secs(1))).await?;
        q.answer(sq)?;
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn query_nested_inside_a_handler_and_from_many_clients() {
    let registry = Registry::new();
    squarer(&registry, SQUARE.on("calc"));
    let _f = spawn(&registry, "fwd", Forwarder).await.expect("spawn");
    let mut waits = Vec::new();
    for i in 0..50u64 {
        let client =
            QueryClient::<u64, u64>::connect(&registry, PLUS_ONE_SQUARED.on("fwd")).expect("connect");
        waits.push(tokio::spawn(async move { (i, client.query(i, Some(Duration::from_secs(5))).await) }));
    }
    for w in waits {
        let (i, answer) = w.await.expect("task");
        assert_eq!(answer, Ok((i + 1) * (i + 1)));
    }
}

/// A component whose activity blocks in a query to a server that never answers.
struct Blocked {
    result: mpsc::UnboundedSender<Result<u64, PatternError>>,
}
enum BlockedMsg {
    Go,
}
impl Component for Blocked {
    type Msg = BlockedMsg;
    type State = ();
    async fn setup(&self, ctx: &Ctx<BlockedMsg>) -> Result<(), ComponentError> {
        ctx.send_server(GO, |_| BlockedMsg::Go)?;
        Ok(())
    }
    async fn handle(
        &self,
        ctx: &Ctx<BlockedMsg>,
        _: &mut (),
        _msg: BlockedMsg,
    ) -> Result<(), ComponentError> {
        let client = ctx.query_client(NEVER.on("calc"))?;
        let _ = self.result.send(client.query(1, None).await);
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn query_blocked_in_a_component_is_cancelled_by_deactivation() {
    let registry = Registry::new();
    let (qtx, _keep) = mpsc::unbounded_channel::<QueryRequest<u64, u64>>();
    QueryServer::register(&registry, NEVER.on("calc"), Sink::channel(qtx)).expect("register");
    let (tx, mut rx) = mpsc::unbounded_channel();
    let c: ComponentHandle<Blocked> =
        spawn(&registry, "blocked", Blocked { result: tx }).await.expect("spawn");
    orsa_actors::send::SendClient::connect(&registry, GO.on("blocked"))
        .expect("connect")
        .send(orsa_actors::Empty {})
        .expect("send");
    tokio::time::sleep(Duration::from_secs(10)).await;
    assert!(rx.try_recv().is_err(), "still blocked after 10 s");
    StateMaster::connect(&registry, "blocked").expect("master").deactivate().await.expect("deactivate");
    assert_eq!(rx.recv().await, Some(Err(PatternError::Cancelled)));
    c.stop().await;
}
