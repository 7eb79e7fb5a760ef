//! Across processes: orsa's push over zenoh against raw zenoh publish/subscribe of the same
//! payload, between the same two processes, on the same two zenoh sessions, in the same run.
//!
//! `orsa-bench` listens on a loopback port picked at run time and starts a second process, the
//! *peer* (this binary, `orsa-bench --peer tcp/127.0.0.1:PORT`, a hidden flag; see
//! [`super::peer`]), which connects to it. Both open orsa's [`ZenohTransport`] (peer mode,
//! explicit endpoints, so multicast scouting is off) on a key prefix named after the port, and
//! both run a two-worker tokio runtime (zenoh needs the multi-thread scheduler).
//!
//! The peer sends, the bench process receives. Each sample is a [`Sample`]: a sequence number,
//! the sender's send time, and padding sized like a `DistanceScan` (16 readings with the same
//! fields). Five paths, each on its own key so that no two subscribers share a delivery:
//!
//! | path | the peer | the bench process |
//! |---|---|---|
//! | [`ORSA_COMPONENT`] | `PushNewestServer::put` | a component subscribed with `Ctx::subscribe_newest`; its handler's first line |
//! | [`ORSA_SINK`] | `PushNewestServer::put` | a remote `PushNewestClient` with a sink (`connect_to`); the sink |
//! | [`RAW_CALLBACK`] | CBOR-encode the sample, `Publisher::put` | a zenoh subscriber callback, after CBOR-decoding |
//! | [`RAW_TASK`] | the same | the callback decodes and hands the sample to a tokio task through an unbounded channel; the task |
//! | [`RAW_ACTOR`] | the same | the callback decodes and casts the sample to a plain ractor actor (what an orsa component's subscription does, without orsa); the actor's handler |
//!
//! The raw publishers are declared as orsa declares its stream publishers (`express(true)`,
//! congestion control `Drop`, which is zenoh's default for publications), on the same session
//! the orsa transport uses. The raw paths encode and decode the same struct with the same codec
//! (CBOR, ciborium), so the ratio is orsa's pattern and envelope, not the serialisation a user
//! of raw zenoh would also need. The send time is taken just before `put` (orsa) or just before
//! the encoding (raw); the sample is built before either. The peer also times that send (orsa's
//! `put`, or the raw encoding and `put`), reported beside each row as the sender's cost.
//!
//! **One-way latency** is the receiver's `SystemTime` (UNIX ns) minus the send time in the
//! sample: both processes read the same kernel clock (`CLOCK_REALTIME`) on one host, so no
//! offset needs estimating. **Back-to-back** means one sample in flight, as in process: the
//! bench process sends a *go* (raw zenoh, express) naming the path and the sequence number,
//! the peer's go callback hands it to a tokio task that sends the sample, and the next go
//! leaves when the sample was received; blocks of samples take the paths in turn, so a noisy
//! moment falls on every path alike. **25 Hz**: the peer sends on its own timer, as a sensor
//! server does: every 10 ms one sample, the paths taking turns, so each path streams at 25 Hz
//! and every sample leaves two idle processes (nothing crossed between them for 10 ms, and
//! nothing from the bench process wakes the peer first). A sample not received within
//! [`LOST_AFTER`] is counted lost; each row says how many were sent and received and whether
//! they arrived in order.
//!
//! Sense to act across processes lives in [`super::sense::across`] and uses the same two
//! processes and sessions.

use super::Launcher;
use super::{CodecCosts, NetLatencyRow, NetReport, say, stats};
use anyhow::{Context as _, anyhow, bail};
use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::QueryClient;
use orsa_actors::service::{PushNewestService, QueryService};
use orsa_actors::{
    CommObject as _, Component, ComponentError, Ctx, Registry, ServiceAddr, Sink, Stamped, Update,
};
use orsa_net::{NetOptions, ZenohTransport};
use parking_lot::Mutex;
use std::future::IntoFuture as _;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use tokio::sync::{Notify, mpsc};

/// orsa push to a component in the other process (the headline figure).
pub(crate) const ORSA_COMPONENT: &str = "orsa push newest -> component";
/// orsa push to a remote client's sink, called on zenoh's receiving thread.
pub(crate) const ORSA_SINK: &str = "orsa push newest -> client sink";
/// raw zenoh to a subscriber callback (the baseline).
pub(crate) const RAW_CALLBACK: &str = "raw zenoh put -> subscriber callback";
/// raw zenoh to a callback that hands the sample to a tokio task.
pub(crate) const RAW_TASK: &str = "raw zenoh put -> callback -> tokio task";
/// raw zenoh to a callback that casts the sample to a plain ractor actor: the raw parts an orsa
/// component is built on, put together by hand.
pub(crate) const RAW_ACTOR: &str = "raw zenoh put -> callback -> ractor cast -> actor";
/// The paths, in the order of their path numbers on the wire.
pub(crate) const PATHS: [&str; 5] = [ORSA_COMPONENT, ORSA_SINK, RAW_CALLBACK, RAW_TASK, RAW_ACTOR];

/// The baseline of every path's ratio.
pub(crate) fn baseline_of(path: &str) -> Option<&'static str> {
    (path != RAW_CALLBACK).then_some(RAW_CALLBACK)
}

/// The peer process's component.
pub(crate) const PEER: &str = "benchpeer";
/// The Push newest service the peer publishes on for the component.
pub(crate) const SAMPLE: PushNewestService<Sample> = PushNewestService::new("sample");
/// The Push newest service the peer publishes on for the client sink.
pub(crate) const SAMPLE_SINK: PushNewestService<Sample> = PushNewestService::new("sample_sink");
/// The peer's control Query service.
pub(crate) const CONTROL: QueryService<PeerRequest, PeerReply> = QueryService::new("control");
/// The bench process's role in zenoh (the peer leaves when it disappears).
pub(crate) const BENCH_ROLE: &str = "bench";
/// The peer's role.
pub(crate) const PEER_ROLE: &str = "bench-peer";
/// A sample not received this long after its go is lost.
pub(crate) const LOST_AFTER: Duration = Duration::from_secs(1);
/// In the 25 Hz mode, the time between two samples (of different paths, in turn).
pub(crate) const STREAM_SPACING: Duration = Duration::from_millis(10);

pub(crate) use super::protocol::*;

/// A runtime like `orsa robot`'s: zenoh needs tokio's multi-thread scheduler.
pub(crate) fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start a tokio runtime")
}

// ---- the peer process ------------------------------------------------------------------------

/// This binary, `orsa-bench --peer ENDPOINT`.
pub(crate) fn exe_launcher(endpoint: &str) -> anyhow::Result<Command> {
    super::this_program("--peer", endpoint)
}

/// The peer process, killed when dropped (every exit path of the bench, a panic included). It
/// also leaves by itself when its stdin closes (this process died) or this process's zenoh
/// session disappears.
pub(crate) struct PeerProc {
    child: Child,
    log: PathBuf,
}

impl PeerProc {
    fn spawn(launcher: Launcher, endpoint: &str) -> anyhow::Result<PeerProc> {
        let log = std::env::temp_dir().join(format!(
            "orsa-bench-peer-{}-{}.log",
            std::process::id(),
            prefix_for(endpoint)
        ));
        let file =
            std::fs::File::create(&log).with_context(|| format!("{}: cannot create", log.display()))?;
        let child = launcher(endpoint)?
            .env("RUST_LOG", "warn")
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(file)
            .spawn()
            .context("cannot start the peer process")?;
        Ok(PeerProc { child, log })
    }

    /// The end of the peer's log, for an error message.
    fn log_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    }

    /// Waits up to `limit` for the peer to leave by itself.
    async fn wait_exit(&mut self, limit: Duration) -> bool {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        false
    }
}

impl Drop for PeerProc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

// ---- the receiving end -----------------------------------------------------------------------

/// Where one path's samples land: latency (receiver's UNIX time minus the send time), sequence
/// numbers, and a wake-up for the driver.
#[derive(Default)]
pub(crate) struct Rx {
    got: Mutex<(Vec<u64>, Vec<u64>)>,
    last: AtomicU64,
    want: AtomicU64,
    notify: Notify,
}

impl Rx {
    pub(crate) fn hit(&self, seq: u64, sent_unix_ns: u64) {
        let now = unix_ns();
        {
            let mut got = self.got.lock();
            got.0.push(now.saturating_sub(sent_unix_ns));
            got.1.push(seq);
        }
        self.last.fetch_max(seq, Ordering::AcqRel);
        if seq >= self.want.load(Ordering::Acquire) {
            self.notify.notify_one();
        }
    }

    /// Waits until sample `seq` (or a later one) arrived.
    async fn wait(&self, seq: u64) {
        // A stale permit only makes the loop look once more.
        while self.last.load(Ordering::Acquire) < seq {
            self.notify.notified().await;
        }
    }

    /// Latencies and sequence numbers received so far, leaving none.
    pub(crate) fn take(&self) -> (Vec<u64>, Vec<u64>) {
        std::mem::take(&mut *self.got.lock())
    }
}

/// Whether sequence numbers only grow.
pub(crate) fn in_order(seqs: &[u64]) -> bool {
    seqs.windows(2).all(|w| w[0] < w[1])
}

/// The component at the end of [`ORSA_COMPONENT`].
struct NetSub {
    rx: Arc<Rx>,
}

enum NetSubMsg {
    Up(Update<Sample>),
}

impl Component for NetSub {
    type Msg = NetSubMsg;
    type State = ();

    async fn setup(&self, ctx: &Ctx<NetSubMsg>) -> Result<(), ComponentError> {
        ctx.subscribe_newest(SAMPLE.on(PEER), NetSubMsg::Up)?;
        Ok(())
    }

    async fn handle(
        &self,
        _ctx: &Ctx<NetSubMsg>,
        _st: &mut (),
        msg: NetSubMsg,
    ) -> Result<(), ComponentError> {
        let NetSubMsg::Up(u) = msg;
        self.rx.hit(u.value.seq, u.value.sent_unix_ns);
        Ok(())
    }
}

/// The plain ractor actor at the end of [`RAW_ACTOR`].
struct RawNetSub {
    rx: Arc<Rx>,
}

impl ractor::Actor for RawNetSub {
    type Msg = Sample;
    type State = ();
    type Arguments = ();

    async fn pre_start(
        &self,
        _me: ractor::ActorRef<Sample>,
        _args: (),
    ) -> Result<(), ractor::ActorProcessingErr> {
        Ok(())
    }

    async fn handle(
        &self,
        _me: ractor::ActorRef<Sample>,
        v: Sample,
        _st: &mut (),
    ) -> Result<(), ractor::ActorProcessingErr> {
        self.rx.hit(v.seq, v.sent_unix_ns);
        Ok(())
    }
}

type GoFn = Box<dyn Fn(Go) -> bool + Send + Sync>;

/// Sends gos and waits for the samples.
struct Driver {
    go: GoFn,
    rx: Vec<Arc<Rx>>,
    seq: Vec<u64>,
    sent: Vec<u64>,
}

impl Driver {
    /// One sample on path `i`; whether it arrived within `limit`.
    async fn once(&mut self, i: usize, limit: Duration) -> bool {
        self.seq[i] += 1;
        let seq = self.seq[i];
        let rx = &self.rx[i];
        rx.want.store(seq, Ordering::Release);
        let path = u8::try_from(i).unwrap_or(u8::MAX);
        if !(self.go)(Go { path, seq }) {
            return false;
        }
        tokio::time::timeout(limit, rx.wait(seq)).await.is_ok()
    }

    /// One measured sample on path `i` (a lost one is counted by the row, not an error, up to
    /// a point).
    async fn measured(&mut self, i: usize) -> anyhow::Result<()> {
        self.sent[i] += 1;
        if !self.once(i, LOST_AFTER).await {
            let received = self.rx[i].got.lock().0.len() as u64;
            if self.sent[i].saturating_sub(received) > 20 {
                bail!("{}: more than 20 samples lost", PATHS[i]);
            }
        }
        Ok(())
    }

    /// Until a sample on every path arrives (subscriptions reach the peer asynchronously).
    async fn connect(&mut self, limit: Duration) -> anyhow::Result<()> {
        let end = Instant::now() + limit;
        for (i, path) in PATHS.iter().enumerate() {
            while !self.once(i, Duration::from_millis(100)).await {
                if Instant::now() > end {
                    bail!("{path}: no sample arrived in {limit:?}");
                }
            }
        }
        Ok(())
    }

    /// Every path's rows for one mode, leaving nothing received; `put` is what sending cost in
    /// the peer, per path.
    fn rows(&mut self, mode: &str, put: &[super::Latency]) -> Vec<NetLatencyRow> {
        let got: Vec<(Vec<u64>, Vec<u64>)> = self.rx.iter().map(|r| r.take()).collect();
        let sent = std::mem::replace(&mut self.sent, vec![0; self.rx.len()]);
        let lat: Vec<super::Latency> = got.iter().map(|(l, _)| stats::summarize(l.clone())).collect();
        PATHS
            .iter()
            .enumerate()
            .map(|(i, path)| {
                let base = baseline_of(path).and_then(|b| PATHS.iter().position(|p| *p == b)).map(|j| lat[j]);
                NetLatencyRow {
                    mode: mode.to_string(),
                    path: path.to_string(),
                    baseline: baseline_of(path).map(str::to_string),
                    latency: lat[i],
                    p50_ratio: base.and_then(|b| stats::ratio(lat[i].p50_ns, b.p50_ns)),
                    p99_ratio: base.and_then(|b| stats::ratio(lat[i].p99_ns, b.p99_ns)),
                    sent: sent[i],
                    received: got[i].0.len() as u64,
                    in_order: in_order(&got[i].1),
                    sender_put: put.get(i).copied().unwrap_or_default(),
                }
            })
            .collect()
    }

    /// `per_path` samples on every path from the peer's timer, one every `spacing`.
    async fn stream(
        &mut self,
        control: &QueryClient<PeerRequest, PeerReply>,
        per_path: u64,
        spacing: Duration,
    ) -> anyhow::Result<()> {
        let first_seq: Vec<u64> = self.seq.iter().map(|s| s + 1).collect();
        for (i, rx) in self.rx.iter().enumerate() {
            self.seq[i] += per_path;
            self.sent[i] += per_path;
            rx.want.store(self.seq[i], Ordering::Release);
        }
        let spacing_us = u64::try_from(spacing.as_micros()).unwrap_or(u64::MAX);
        let takes = spacing * u32::try_from(per_path * self.rx.len() as u64).unwrap_or(u32::MAX);
        let request = PeerRequest::Stream { per_path, first_seq, spacing_us };
        match control.query(request, Some(takes + Duration::from_secs(10))).await {
            Ok(PeerReply::Ok) => {}
            other => bail!("the peer answered {other:?} to streaming"),
        }
        for (i, rx) in self.rx.iter().enumerate() {
            // The last ones may still be on their way; a missing one is counted by the row.
            let _ = tokio::time::timeout(LOST_AFTER, rx.wait(self.seq[i])).await;
        }
        Ok(())
    }

    fn clear(&mut self) {
        for r in &self.rx {
            r.take();
        }
        self.sent = vec![0; self.rx.len()];
    }
}

/// How many samples each mode takes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NetSizes {
    /// Back-to-back samples per path, thrown away first.
    pub(crate) warmup: usize,
    /// Back-to-back samples measured per path.
    pub(crate) back_to_back: usize,
    /// 25 Hz samples per path (0: skip the mode).
    pub(crate) at_25hz: usize,
    /// Sense to act across processes, measured seconds (0: skip, and skip the mode switch).
    pub(crate) sense_s: f64,
    /// Mode switches of each kind across processes, after sense to act.
    pub(crate) switch_rounds: usize,
}

/// CBOR costs of the sample, raw and in orsa's envelope, in this process: where a difference
/// between the paths could come from.
fn codec_costs(n: usize) -> CodecCosts {
    use std::hint::black_box;
    let clock = orsa_actors::Clock::start();
    let sample = Sample { seq: 1, sent_unix_ns: unix_ns(), readings: Sample::padding() };
    let stamped = Stamped { seq: 1, sent_at: clock.now(), value: sample.clone() };
    let raw = cbor(&sample);
    let orsa = orsa_actors::wire::encode_stamped(&stamped);
    // The median of five rounds' means.
    let time = |f: &dyn Fn()| -> f64 {
        let rounds = 5;
        let per = (n / rounds).max(1);
        let mut means: Vec<f64> = (0..rounds)
            .map(|_| {
                let t0 = Instant::now();
                for _ in 0..per {
                    f();
                }
                t0.elapsed().as_nanos() as f64 / per as f64
            })
            .collect();
        means.sort_by(f64::total_cmp);
        means[rounds / 2]
    };
    CodecCosts {
        raw_bytes: raw.len(),
        orsa_bytes: orsa.len(),
        raw_encode_ns: time(&|| {
            black_box(cbor(black_box(&sample)));
        }),
        raw_decode_ns: time(&|| {
            black_box(uncbor::<Sample>(black_box(&raw)));
        }),
        orsa_encode_ns: time(&|| {
            black_box(orsa_actors::wire::encode_stamped(black_box(&stamped)));
        }),
        orsa_decode_ns: time(&|| {
            let _ = black_box(orsa_actors::wire::decode_stamped::<Sample>(black_box(&orsa), Sample::ID));
        }),
    }
}

/// How long sending took in the peer, per path, since the last time asked.
async fn put_costs(control: &QueryClient<PeerRequest, PeerReply>) -> anyhow::Result<Vec<super::Latency>> {
    match control.query(PeerRequest::TakePutCosts, Some(Duration::from_secs(10))).await {
        Ok(PeerReply::PutCosts { per_path }) if per_path.len() == PATHS.len() => Ok(per_path),
        other => bail!("the peer answered {other:?} to asking for its sending costs"),
    }
}

fn free_port() -> anyhow::Result<u16> {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").context("cannot bind a loopback port")?;
    Ok(listener.local_addr()?.port())
}

/// Runs the cross-process bench (latency, then sense to act) with the peer `launcher` starts,
/// under one time limit.
pub(crate) fn run(sizes: NetSizes, launcher: Launcher) -> anyhow::Result<NetReport> {
    let rt = runtime()?;
    let limit = Duration::from_secs(120)
        + Duration::from_millis(45 * 4 * sizes.at_25hz as u64)
        + Duration::from_millis(4 * (sizes.warmup + sizes.back_to_back) as u64)
        + Duration::from_secs_f64(sizes.sense_s.clamp(0.0, 3600.0));
    let out = rt.block_on(async move {
        let driver = tokio::spawn(tokio::time::timeout(limit, bench(sizes, launcher)));
        match driver.await {
            Ok(Ok(result)) => result,
            Ok(Err(_)) => Err(anyhow!("the cross-process bench did not finish in {limit:?}")),
            Err(e) => Err(anyhow!("the cross-process bench failed: {e}")),
        }
    });
    rt.shutdown_timeout(Duration::from_secs(2));
    out
}

async fn bench(sizes: NetSizes, launcher: Launcher) -> anyhow::Result<NetReport> {
    let t0 = Instant::now();
    let endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
    let prefix = prefix_for(&endpoint);
    let registry = Registry::new();
    let options =
        NetOptions { listen: vec![endpoint.clone()], prefix: prefix.clone(), ..NetOptions::default() };
    let transport = ZenohTransport::open(&registry, &options, BENCH_ROLE).await?;
    let mut peer = PeerProc::spawn(launcher, &endpoint)?;
    say(format!("  across processes: peer started on {endpoint}"));
    let out = with_peer(&registry, &transport, &prefix, sizes, t0).await;
    let out = match out {
        Ok(report) => {
            // The peer leaves on Quit; the guard kills it if it does not.
            peer.wait_exit(Duration::from_secs(3)).await;
            Ok(report)
        }
        Err(e) => Err(e.context(format!("the peer's log ends with:\n{}", peer.log_tail()))),
    };
    drop(peer);
    transport.close().await;
    out
}

async fn with_peer(
    registry: &Registry,
    transport: &ZenohTransport,
    prefix: &str,
    sizes: NetSizes,
    t0: Instant,
) -> anyhow::Result<NetReport> {
    let needed: Vec<ServiceAddr> =
        vec![SAMPLE.on(PEER).untyped(), SAMPLE_SINK.on(PEER).untyped(), CONTROL.on(PEER).untyped()];
    if let Err(missing) = transport.wait_for(&needed, Duration::from_secs(30)).await {
        bail!("the peer did not offer {missing:?} within 30 s");
    }
    let control = QueryClient::<PeerRequest, PeerReply>::connect(registry, CONTROL.on(PEER))?;
    let keys = RawKeys::new(prefix);
    let rx: Vec<Arc<Rx>> = PATHS.iter().map(|_| Arc::new(Rx::default())).collect();

    // The receiving ends, one per path.
    let sub: ComponentHandle<NetSub> = spawn(registry, "benchsub", NetSub { rx: Arc::clone(&rx[0]) }).await?;
    let r = Arc::clone(&rx[1]);
    let sink_client = PushNewestClient::<Sample>::connect_to(
        registry,
        SAMPLE_SINK.on(PEER),
        Sink::from_fn(move |u: Update<Sample>| {
            r.hit(u.value.seq, u.value.sent_unix_ns);
            Ok(())
        }),
    )?;
    sink_client.subscribe()?;
    let session = transport.session();
    let r = Arc::clone(&rx[2]);
    let raw_callback = session
        .declare_subscriber(keys.callback.clone())
        .callback(move |s| {
            if let Some(v) = uncbor::<Sample>(&s.payload().to_bytes()) {
                r.hit(v.seq, v.sent_unix_ns);
            }
        })
        .await
        .map_err(|e| anyhow!("raw subscriber: {e}"))?;
    let (ttx, mut trx) = mpsc::unbounded_channel::<Sample>();
    let raw_task = session
        .declare_subscriber(keys.task.clone())
        .callback(move |s| {
            if let Some(v) = uncbor::<Sample>(&s.payload().to_bytes()) {
                let _ = ttx.send(v);
            }
        })
        .await
        .map_err(|e| anyhow!("raw subscriber: {e}"))?;
    let r = Arc::clone(&rx[3]);
    let task = tokio::spawn(async move {
        while let Some(v) = trx.recv().await {
            r.hit(v.seq, v.sent_unix_ns);
        }
    });
    let (raw_sub, _) = ractor::Actor::spawn(None, RawNetSub { rx: Arc::clone(&rx[4]) }, ())
        .await
        .map_err(|e| anyhow!("cannot spawn a ractor actor: {e}"))?;
    let to_actor = raw_sub.clone();
    let raw_actor = session
        .declare_subscriber(keys.actor.clone())
        .callback(move |s| {
            if let Some(v) = uncbor::<Sample>(&s.payload().to_bytes()) {
                let _ = to_actor.cast(v);
            }
        })
        .await
        .map_err(|e| anyhow!("raw subscriber: {e}"))?;
    let go_pub = session
        .declare_publisher(keys.go.clone())
        .express(true)
        .await
        .map_err(|e| anyhow!("go publisher: {e}"))?;
    let go: GoFn = Box::new(move |g: Go| go_pub.put(cbor(&g)).into_future().into_inner().is_ok());
    let n = PATHS.len();
    let mut d = Driver { go, rx, seq: vec![0; n], sent: vec![0; n] };

    d.connect(Duration::from_secs(20)).await?;
    let startup_s = t0.elapsed().as_secs_f64();
    for _ in 0..sizes.warmup {
        for i in 0..n {
            d.once(i, LOST_AFTER).await;
        }
    }
    d.clear();
    put_costs(&control).await?;

    say(format!("  across processes: back-to-back, {} samples per path", sizes.back_to_back));
    let block = (sizes.back_to_back / 20).clamp(1, 1_000);
    let mut done = 0;
    while done < sizes.back_to_back {
        let m = block.min(sizes.back_to_back - done);
        for i in 0..n {
            for _ in 0..m {
                d.measured(i).await?;
            }
        }
        done += m;
    }
    let mut latency = d.rows("back-to-back", &put_costs(&control).await?);

    if sizes.at_25hz > 0 {
        say(format!(
            "  across processes: 25 Hz from the peer's timer, {} samples per path ({:.0} s)",
            sizes.at_25hz,
            sizes.at_25hz as f64 * 0.04
        ));
        d.stream(&control, sizes.at_25hz as u64, STREAM_SPACING).await?;
        latency.extend(d.rows("25 Hz", &put_costs(&control).await?));
    }
    let codec = codec_costs(20_000);

    let (sense_to_act, switch) = if sizes.sense_s > 0.0 {
        let (sense, switch) =
            super::sense::across(registry, transport, &control, sizes.sense_s, sizes.switch_rounds).await?;
        (Some(sense), Some(switch))
    } else {
        (None, None)
    };

    match control.query(PeerRequest::Quit, Some(Duration::from_secs(5))).await {
        Ok(PeerReply::Ok) => {}
        other => tracing::warn!("the peer did not acknowledge quitting: {other:?}"),
    }
    drop(raw_callback);
    drop(raw_task);
    drop(raw_actor);
    raw_sub.stop(None);
    drop(sink_client);
    task.abort();
    sub.stop().await;
    Ok(NetReport {
        runtime: "multi-thread (2 workers), in both processes".into(),
        transport: "zenoh, peer to peer over TCP on loopback; express, congestion control drop".into(),
        startup_s,
        latency,
        codec,
        sense_to_act,
        switch,
    })
}
