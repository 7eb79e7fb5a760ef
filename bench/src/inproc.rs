//! In process: orsa's push and query against raw ractor and raw tokio between the same two
//! tasks, on the same runtime, in the same run.
//!
//! Push: a sender task publishes on a Push newest server (`PushNewestServer::put`); the
//! subscriber is a component (its `Ctx::subscribe_newest`), and the latency runs from just
//! before `put` to the first line of the component's handler. The baselines send the same
//! `u64` (the send time) with `ActorRef::cast` to a plain ractor actor, and through a tokio
//! unbounded mpsc channel to a plain task. Query: `QueryClient::query` to a component's query
//! server that answers at once, against `ActorRef::call` (ractor's RPC) and a tokio mpsc plus
//! oneshot, timed around the await.
//!
//! Modes: back-to-back (the next message leaves as soon as the previous one was handled: one in
//! flight, no queueing), at the robot's 25 Hz (one of each every 40 ms, the paths taken in a
//! rotating order), and throughput (a burst of messages, time until the last is handled).

use super::probe::{Probe, ns_since};
use super::{LatencyRow, ThroughputRow, say, stats};
use anyhow::anyhow;
use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::{QueryClient, QueryRequest};
use orsa_actors::service::{Addr, PushNewestService, QueryService};
use orsa_actors::{Component, ComponentError, Ctx, Registry, Update};
use ractor::{Actor, ActorProcessingErr, ActorRef, RpcReplyPort};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, oneshot};

/// The service the in-process push rows publish on.
pub(crate) const PING: PushNewestService<u64> = PushNewestService::new("ping");
/// The service the in-process query rows ask.
const ECHO: QueryService<u64, u64> = QueryService::new("echo");

/// How many messages each mode takes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct InprocSizes {
    /// Back-to-back messages sent and thrown away first, per path.
    pub(crate) warmup: usize,
    /// Back-to-back messages measured, per path.
    pub(crate) back_to_back: usize,
    /// Messages per throughput burst.
    pub(crate) burst: usize,
    /// 25 Hz samples per path (0: skip the mode).
    pub(crate) at_25hz: usize,
}

/// Which tokio runtime the bench runs on: orsa and its baselines always share one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RuntimeKind {
    /// One thread, as `orsa run` runs.
    CurrentThread,
    /// Two worker threads (the machine's cores).
    MultiThread,
}

impl RuntimeKind {
    pub(crate) fn label(self) -> &'static str {
        match self {
            RuntimeKind::CurrentThread => "current-thread",
            RuntimeKind::MultiThread => "multi-thread (2 workers)",
        }
    }

    pub(crate) fn build(self) -> anyhow::Result<tokio::runtime::Runtime> {
        let mut b = match self {
            RuntimeKind::CurrentThread => tokio::runtime::Builder::new_current_thread(),
            RuntimeKind::MultiThread => {
                let mut b = tokio::runtime::Builder::new_multi_thread();
                b.worker_threads(2);
                b
            }
        };
        b.enable_time().build().map_err(|e| anyhow!("cannot start a tokio runtime: {e}"))
    }
}

pub(crate) const ORSA_PUSH: &str = "orsa push newest -> component";
pub(crate) const RACTOR_CAST: &str = "raw ractor cast -> actor";
pub(crate) const TOKIO_MPSC: &str = "raw tokio mpsc -> task";
pub(crate) const ORSA_QUERY: &str = "orsa query <-> component";
pub(crate) const RACTOR_CALL: &str = "raw ractor call <-> actor";
pub(crate) const TOKIO_RPC: &str = "raw tokio mpsc + oneshot <-> task";

/// The baseline each path's ratio is taken against.
pub(crate) fn baseline_of(path: &str) -> Option<&'static str> {
    match path {
        ORSA_PUSH | TOKIO_MPSC => Some(RACTOR_CAST),
        ORSA_QUERY | TOKIO_RPC => Some(RACTOR_CALL),
        _ => None,
    }
}

// ---- the receiving ends -------------------------------------------------------------------

/// A component subscribed to a Push newest service; its handler hits the probe.
pub(crate) struct PushSub {
    pub(crate) probe: Arc<Probe>,
    pub(crate) addr: Addr<PushNewestService<u64>>,
}

/// Messages of [`PushSub`].
pub(crate) enum PushSubMsg {
    Up(Update<u64>),
}

impl Component for PushSub {
    type Msg = PushSubMsg;
    type State = ();

    async fn setup(&self, ctx: &Ctx<PushSubMsg>) -> Result<(), ComponentError> {
        ctx.subscribe_newest::<u64>(&self.addr, PushSubMsg::Up)?;
        Ok(())
    }

    async fn handle(
        &self,
        _ctx: &Ctx<PushSubMsg>,
        _st: &mut (),
        msg: PushSubMsg,
    ) -> Result<(), ComponentError> {
        let PushSubMsg::Up(u) = msg;
        self.probe.hit(u.value);
        Ok(())
    }
}

/// A plain ractor actor whose handler hits the probe.
pub(crate) struct RawSub {
    pub(crate) probe: Arc<Probe>,
}

impl Actor for RawSub {
    type Msg = u64;
    type State = ();
    type Arguments = ();

    async fn pre_start(&self, _me: ActorRef<u64>, _args: ()) -> Result<(), ActorProcessingErr> {
        Ok(())
    }

    async fn handle(&self, _me: ActorRef<u64>, sent: u64, _st: &mut ()) -> Result<(), ActorProcessingErr> {
        self.probe.hit(sent);
        Ok(())
    }
}

/// A component answering `echo` at once.
struct Echo;

enum EchoMsg {
    Q(QueryRequest<u64, u64>),
}

impl Component for Echo {
    type Msg = EchoMsg;
    type State = ();

    async fn setup(&self, ctx: &Ctx<EchoMsg>) -> Result<(), ComponentError> {
        ctx.query_server(ECHO, EchoMsg::Q)?;
        Ok(())
    }

    async fn handle(&self, _ctx: &Ctx<EchoMsg>, _st: &mut (), msg: EchoMsg) -> Result<(), ComponentError> {
        let EchoMsg::Q(q) = msg;
        let v = q.request.value;
        // A client that stopped waiting is not this server's problem.
        let _ = q.answer(v);
        Ok(())
    }
}

/// A plain ractor actor answering calls at once.
struct RawEcho;

enum RawEchoMsg {
    Q(u64, RpcReplyPort<u64>),
}

impl Actor for RawEcho {
    type Msg = RawEchoMsg;
    type State = ();
    type Arguments = ();

    async fn pre_start(&self, _me: ActorRef<RawEchoMsg>, _args: ()) -> Result<(), ActorProcessingErr> {
        Ok(())
    }

    async fn handle(
        &self,
        _me: ActorRef<RawEchoMsg>,
        msg: RawEchoMsg,
        _st: &mut (),
    ) -> Result<(), ActorProcessingErr> {
        let RawEchoMsg::Q(v, reply) = msg;
        let _ = reply.send(v);
        Ok(())
    }
}

// ---- the sending ends ---------------------------------------------------------------------

enum PushPath {
    Orsa(PushNewestServer<u64>),
    Ractor(ActorRef<u64>),
    Tokio(mpsc::UnboundedSender<u64>),
}

impl PushPath {
    fn send(&self, sent_ns: u64) -> anyhow::Result<()> {
        let ok = match self {
            PushPath::Orsa(s) => s.put(sent_ns) == 1,
            PushPath::Ractor(a) => a.cast(sent_ns).is_ok(),
            PushPath::Tokio(tx) => tx.send(sent_ns).is_ok(),
        };
        if ok { Ok(()) } else { Err(anyhow!("a push path lost its receiver")) }
    }
}

enum QueryPath {
    Orsa(QueryClient<u64, u64>),
    Ractor(ActorRef<RawEchoMsg>),
    Tokio(mpsc::UnboundedSender<(u64, oneshot::Sender<u64>)>),
}

impl QueryPath {
    async fn round_trip(&self, v: u64) -> anyhow::Result<()> {
        let back = match self {
            QueryPath::Orsa(c) => c.query(v, None).await.map_err(|e| anyhow!("orsa query: {e}"))?,
            QueryPath::Ractor(a) => match a.call(|r| RawEchoMsg::Q(v, r), None).await {
                Ok(ractor::rpc::CallResult::Success(x)) => x,
                _ => anyhow::bail!("ractor call failed"),
            },
            QueryPath::Tokio(tx) => {
                let (rtx, rrx) = oneshot::channel();
                tx.send((v, rtx)).map_err(|_| anyhow!("tokio echo task gone"))?;
                rrx.await.map_err(|_| anyhow!("tokio echo task dropped the answer"))?
            }
        };
        anyhow::ensure!(back == v, "an echo answered {back} to {v}");
        Ok(())
    }
}

struct Pushes {
    paths: Vec<(&'static str, PushPath, Arc<Probe>)>,
}

struct Queries {
    paths: Vec<(&'static str, QueryPath)>,
}

struct Rig {
    base: Instant,
    pushes: Pushes,
    queries: Queries,
    sub: ComponentHandle<PushSub>,
    echo: ComponentHandle<Echo>,
    raw_sub: ActorRef<u64>,
    raw_echo: ActorRef<RawEchoMsg>,
    sent: Vec<u64>,
}

impl Rig {
    async fn start(base: Instant) -> anyhow::Result<Rig> {
        let registry = Registry::new();
        let server = PushNewestServer::<u64>::register(&registry, PING.on("bench"))?;
        let orsa_probe = Probe::new(base);
        let sub = spawn(&registry, "sub", PushSub { probe: Arc::clone(&orsa_probe), addr: PING.on("bench") })
            .await?;
        let ractor_probe = Probe::new(base);
        let (raw_sub, _) = Actor::spawn(None, RawSub { probe: Arc::clone(&ractor_probe) }, ())
            .await
            .map_err(|e| anyhow!("cannot spawn a ractor actor: {e}"))?;
        let tokio_probe = Probe::new(base);
        let (tx, mut rx) = mpsc::unbounded_channel::<u64>();
        let p = Arc::clone(&tokio_probe);
        tokio::spawn(async move {
            while let Some(sent) = rx.recv().await {
                p.hit(sent);
            }
        });

        let echo = spawn(&registry, "echo", Echo).await?;
        let client = QueryClient::<u64, u64>::connect(&registry, ECHO.on("echo"))?;
        let (raw_echo, _) =
            Actor::spawn(None, RawEcho, ()).await.map_err(|e| anyhow!("cannot spawn a ractor actor: {e}"))?;
        let (qtx, mut qrx) = mpsc::unbounded_channel::<(u64, oneshot::Sender<u64>)>();
        tokio::spawn(async move {
            while let Some((v, reply)) = qrx.recv().await {
                let _ = reply.send(v);
            }
        });
        Ok(Rig {
            base,
            pushes: Pushes {
                paths: vec![
                    (ORSA_PUSH, PushPath::Orsa(server), orsa_probe),
                    (RACTOR_CAST, PushPath::Ractor(raw_sub.clone()), ractor_probe),
                    (TOKIO_MPSC, PushPath::Tokio(tx), tokio_probe),
                ],
            },
            queries: Queries {
                paths: vec![
                    (ORSA_QUERY, QueryPath::Orsa(client)),
                    (RACTOR_CALL, QueryPath::Ractor(raw_echo.clone())),
                    (TOKIO_RPC, QueryPath::Tokio(qtx)),
                ],
            },
            sub,
            echo,
            raw_sub,
            raw_echo,
            sent: vec![0; 3],
        })
    }

    /// One push on path `i`, waiting until it was handled.
    async fn push_once(&mut self, i: usize) -> anyhow::Result<()> {
        let (_, path, probe) = &self.pushes.paths[i];
        self.sent[i] += 1;
        let target = self.sent[i];
        probe.expect(target);
        path.send(ns_since(self.base))?;
        probe.wait(target).await;
        Ok(())
    }

    /// One query round trip on path `i`; its latency.
    async fn query_once(&self, i: usize, v: u64) -> anyhow::Result<u64> {
        let t0 = Instant::now();
        self.queries.paths[i].1.round_trip(v).await?;
        Ok(u64::try_from(t0.elapsed().as_nanos()).unwrap_or(u64::MAX))
    }

    /// A burst of `n` pushes on path `i`; messages per second until the last was handled.
    async fn push_burst(&mut self, i: usize, n: usize) -> anyhow::Result<(f64, f64)> {
        let (_, path, probe) = &self.pushes.paths[i];
        let target = self.sent[i] + n as u64;
        probe.expect(target);
        let t0 = Instant::now();
        for _ in 0..n {
            path.send(ns_since(self.base))?;
        }
        probe.wait(target).await;
        let wall = t0.elapsed().as_secs_f64();
        self.sent[i] = target;
        probe.take();
        Ok((wall, n as f64 / wall))
    }

    /// `n` query round trips back-to-back on path `i` (each waits for its answer).
    async fn query_run(&self, i: usize, n: usize) -> anyhow::Result<(f64, Vec<u64>)> {
        let mut lat = Vec::with_capacity(n);
        let t0 = Instant::now();
        for k in 0..n {
            lat.push(self.query_once(i, k as u64).await?);
        }
        Ok((t0.elapsed().as_secs_f64(), lat))
    }

    async fn stop(self) {
        self.sub.stop().await;
        self.echo.stop().await;
        self.raw_sub.stop(None);
        self.raw_echo.stop(None);
    }
}

/// What one runtime's in-process bench measured.
pub(crate) struct InprocResult {
    pub(crate) latency: Vec<LatencyRow>,
    pub(crate) throughput: Vec<ThroughputRow>,
}

fn rows(runtime: &str, mode: &str, measured: Vec<(&'static str, Vec<u64>)>) -> Vec<LatencyRow> {
    let summaries: Vec<(&str, super::Latency)> =
        measured.into_iter().map(|(p, v)| (p, stats::summarize(v))).collect();
    summaries
        .iter()
        .map(|(path, lat)| {
            let base = baseline_of(path).and_then(|b| summaries.iter().find(|(p, _)| *p == b));
            LatencyRow {
                runtime: runtime.to_string(),
                mode: mode.to_string(),
                path: path.to_string(),
                baseline: base.map(|(p, _)| p.to_string()),
                p50_ratio: base.and_then(|(_, b)| stats::ratio(lat.p50_ns, b.p50_ns)),
                p99_ratio: base.and_then(|(_, b)| stats::ratio(lat.p99_ns, b.p99_ns)),
                latency: *lat,
            }
        })
        .collect()
}

fn throughput_rows(runtime: &str, measured: Vec<(&'static str, usize, f64, f64)>) -> Vec<ThroughputRow> {
    measured
        .iter()
        .map(|&(path, n, wall, per_s)| {
            let how = if [ORSA_QUERY, RACTOR_CALL, TOKIO_RPC].contains(&path) {
                "round trips, one in flight"
            } else {
                "burst, handled"
            };
            let base = baseline_of(path).and_then(|b| measured.iter().find(|m| m.0 == b));
            ThroughputRow {
                runtime: runtime.to_string(),
                path: path.to_string(),
                how: how.to_string(),
                messages: n as u64,
                wall_s: wall,
                per_s,
                baseline: base.map(|m| m.0.to_string()),
                ratio: base.and_then(|m| stats::ratio(per_s, m.3)),
            }
        })
        .collect()
}

async fn bench(sizes: InprocSizes, runtime: &'static str) -> anyhow::Result<InprocResult> {
    let base = Instant::now();
    let mut rig = Rig::start(base).await?;
    let np = rig.pushes.paths.len();
    let nq = rig.queries.paths.len();

    // Warm-up: every path, interleaved, thrown away.
    for _ in 0..sizes.warmup {
        for i in 0..np {
            rig.push_once(i).await?;
        }
        for i in 0..nq {
            rig.query_once(i, 0).await?;
        }
    }
    for (_, _, p) in &rig.pushes.paths {
        p.take();
    }

    // Back-to-back, in blocks that take the paths in turn, so that a noisy moment of the
    // machine falls on every path alike; within a block caches stay warm for its path.
    say(format!("  {runtime}: back-to-back, {} messages per path", sizes.back_to_back));
    let block = (sizes.back_to_back / 20).clamp(1, 5_000);
    let mut qlat: Vec<Vec<u64>> = vec![Vec::with_capacity(sizes.back_to_back); nq];
    let mut qwall = vec![0.0f64; nq];
    let mut done = 0;
    while done < sizes.back_to_back {
        let m = block.min(sizes.back_to_back - done);
        for i in 0..np {
            for _ in 0..m {
                rig.push_once(i).await?;
            }
        }
        for (i, lat) in qlat.iter_mut().enumerate() {
            let (wall, l) = rig.query_run(i, m).await?;
            qwall[i] += wall;
            lat.extend(l);
        }
        done += m;
    }
    let push_b2b: Vec<_> = rig.pushes.paths.iter().map(|(n, _, p)| (*n, p.take())).collect();
    let mut throughput = Vec::new();
    let mut query_b2b = Vec::new();
    for (i, lat) in qlat.into_iter().enumerate() {
        let name = rig.queries.paths[i].0;
        throughput.push((name, sizes.back_to_back, qwall[i], sizes.back_to_back as f64 / qwall[i]));
        query_b2b.push((name, lat));
    }

    say(format!("  {runtime}: throughput, bursts of {} pushes", sizes.burst));
    for i in 0..np {
        let (wall, per_s) = rig.push_burst(i, sizes.burst).await?;
        throughput.push((rig.pushes.paths[i].0, sizes.burst, wall, per_s));
    }

    let mut latency = rows(runtime, "back-to-back", push_b2b);
    latency.extend(rows(runtime, "back-to-back", query_b2b));

    if sizes.at_25hz > 0 {
        say(format!(
            "  {runtime}: 25 Hz, {} samples per path ({:.0} s)",
            sizes.at_25hz,
            sizes.at_25hz as f64 * 0.04
        ));
        let mut ticks = tokio::time::interval(Duration::from_millis(40));
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut qlat: Vec<Vec<u64>> = vec![Vec::with_capacity(sizes.at_25hz); nq];
        for k in 0..sizes.at_25hz {
            ticks.tick().await;
            // Rotate which path goes first: the first one after an idle wake-up pays for it.
            for j in 0..np + nq {
                let i = (j + k) % (np + nq);
                if i < np {
                    rig.push_once(i).await?;
                } else {
                    qlat[i - np].push(rig.query_once(i - np, k as u64).await?);
                }
            }
        }
        let pushes: Vec<_> = rig.pushes.paths.iter().map(|(n, _, p)| (*n, p.take())).collect();
        latency.extend(rows(runtime, "25 Hz", pushes));
        let queries: Vec<_> = rig.queries.paths.iter().map(|(n, _)| *n).zip(qlat).collect();
        latency.extend(rows(runtime, "25 Hz", queries));
    }
    rig.stop().await;
    Ok(InprocResult { latency, throughput: throughput_rows(runtime, throughput) })
}

/// Runs the in-process bench on a runtime of `kind`, under a time limit.
pub(crate) fn run(kind: RuntimeKind, sizes: InprocSizes) -> anyhow::Result<InprocResult> {
    let rt = kind.build()?;
    let label = kind.label();
    let limit = Duration::from_secs(60) + Duration::from_millis(45 * sizes.at_25hz as u64 * 6);
    // The driver is a task: on a multi-thread runtime, `block_on`'s own future would run on
    // the calling thread, not on a worker.
    let out = rt.block_on(async move {
        let driver = tokio::spawn(tokio::time::timeout(limit, bench(sizes, label)));
        match driver.await {
            Ok(Ok(result)) => result,
            Ok(Err(_)) => Err(anyhow!("the in-process bench on {label} did not finish in {limit:?}")),
            Err(e) => Err(anyhow!("the in-process bench on {label} failed: {e}")),
        }
    });
    rt.shutdown_timeout(Duration::from_secs(1));
    out
}
