//! The live view's cost (`--foxglove`): a Foxglove WebSocket client in this process, on a
//! thread and runtime of its own, that subscribes to every channel the server advertises and
//! reads everything, as the Foxglove app would at real time. It is written from the protocol
//! (`foxglove.websocket.v1`, which the SDK's server calls `foxglove.sdk.v1`, with `tokio-tungstenite`, which the `foxglove` crate's server
//! already brings), not with the SDK.
//!
//! With `publish`, the client also drives as Foxglove's Teleop panel does: it advertises a
//! `/cmd_vel` channel (`geometry_msgs/msg/TwistStamped`, JSON) and publishes on it at 20 Hz
//! (the protocol's client message data: opcode 1, the channel id, the payload). Each command
//! is stamped [`STALE`] in the past, so that it takes the whole path a client's command takes
//! (the frame, the server's listener, the JSON, the robot server's `teleop` service) and is
//! refused there as too old, counted in the robot server's `stale_refused`, leaving the
//! behaviours driving: its cost on their sense to act is what is measured.

use anyhow::{Context as _, anyhow};
use futures::{SinkExt as _, StreamExt as _};
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest as _;

/// How old the published commands' stamps are: far beyond any command timeout.
pub(crate) const STALE: Duration = Duration::from_secs(10);

/// How often the publishing client publishes: a Teleop panel's rate.
const PUBLISH_PERIOD: Duration = Duration::from_millis(50);

/// The channel the publishing client advertises.
const CMD_VEL_CHANNEL: u32 = 1;

/// A client subscribed to everything; [`Client::stop`] ends it.
pub(crate) struct Client {
    stop: Arc<AtomicBool>,
    messages: Arc<AtomicU64>,
    subscribed: Arc<AtomicU64>,
    published: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<()>>>,
}

impl Client {
    /// Connects to the server at `addr` and subscribes to each channel it advertises; with
    /// `publish`, also publishes stale velocity commands (see the module's doc).
    pub(crate) fn start(addr: SocketAddr, publish: bool) -> anyhow::Result<Client> {
        let stop = Arc::new(AtomicBool::new(false));
        let messages = Arc::new(AtomicU64::new(0));
        let subscribed = Arc::new(AtomicU64::new(0));
        let published = Arc::new(AtomicU64::new(0));
        let counts = Counts {
            messages: Arc::clone(&messages),
            subscribed: Arc::clone(&subscribed),
            published: Arc::clone(&published),
        };
        let s = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("bench-foxglove-client".into())
            .spawn(move || {
                let rt = tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                    .context("the client's runtime")?;
                rt.block_on(read_all(addr, &s, &counts, publish))
            })
            .context("the client's thread")?;
        Ok(Client { stop, messages, subscribed, published, thread: Some(thread) })
    }

    /// Channels subscribed to so far.
    pub(crate) fn subscribed(&self) -> u64 {
        self.subscribed.load(Ordering::Relaxed)
    }

    /// Stops reading (and publishing); the messages read and the commands published.
    pub(crate) fn stop(mut self) -> anyhow::Result<(u64, u64)> {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().map_err(|_| anyhow!("the bench's Foxglove client panicked"))??;
        }
        Ok((self.messages.load(Ordering::Relaxed), self.published.load(Ordering::Relaxed)))
    }
}

/// What the client counts.
struct Counts {
    messages: Arc<AtomicU64>,
    subscribed: Arc<AtomicU64>,
    published: Arc<AtomicU64>,
}

/// One client message data frame: a TwistStamped stamped [`STALE`] ago, on the advertised
/// channel.
fn stale_command() -> Vec<u8> {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    let t = now.saturating_sub(STALE);
    let json = serde_json::json!({
        "header": {"stamp": {"sec": t.as_secs(), "nanosec": t.subsec_nanos()}, "frame_id": "base_link"},
        "twist": {"linear": {"x": 0.1, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    });
    let mut frame = vec![0x01];
    frame.extend_from_slice(&CMD_VEL_CHANNEL.to_le_bytes());
    frame.extend_from_slice(json.to_string().as_bytes());
    frame
}

async fn read_all(addr: SocketAddr, stop: &AtomicBool, counts: &Counts, publish: bool) -> anyhow::Result<()> {
    let mut request = format!("ws://{addr}").into_client_request()?;
    request.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.websocket.v1, foxglove.sdk.v1".parse()?);
    let (mut ws, _) =
        tokio_tungstenite::connect_async(request).await.context("connecting to the live server")?;
    if publish {
        let advertise = serde_json::json!({"op": "advertise", "channels": [{
            "id": CMD_VEL_CHANNEL,
            "topic": "/cmd_vel",
            "encoding": "json",
            "schemaName": "geometry_msgs/msg/TwistStamped",
        }]});
        ws.send(Message::text(advertise.to_string())).await?;
    }
    let mut tick = tokio::time::interval(PUBLISH_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut next_id = 1u64;
    while !stop.load(Ordering::Relaxed) {
        let msg = tokio::select! {
            _ = tick.tick() => {
                if publish {
                    ws.send(Message::binary(stale_command())).await.context("publishing to the live server")?;
                    counts.published.fetch_add(1, Ordering::Relaxed);
                }
                continue;
            }
            m = ws.next() => match m {
                None => break,
                Some(m) => m.context("reading from the live server")?,
            },
        };
        match msg {
            Message::Binary(_) => {
                counts.messages.fetch_add(1, Ordering::Relaxed);
            }
            Message::Text(text) => {
                let v: serde_json::Value = serde_json::from_str(text.as_str())?;
                if v["op"] != "advertise" {
                    continue;
                }
                let mut subs = Vec::new();
                for c in v["channels"].as_array().into_iter().flatten() {
                    if let Some(channel) = c["id"].as_u64() {
                        subs.push(serde_json::json!({"id": next_id, "channelId": channel}));
                        next_id += 1;
                    }
                }
                counts.subscribed.fetch_add(subs.len() as u64, Ordering::Relaxed);
                let request = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                ws.send(Message::text(request.to_string())).await?;
            }
            _ => {}
        }
    }
    let _ = ws.close(None).await;
    Ok(())
}
