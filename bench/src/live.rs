//! The live view's cost (`--foxglove`): a Foxglove WebSocket client in this process, on a
//! thread and runtime of its own, that subscribes to every channel the server advertises and
//! reads everything, as the Foxglove app would at real time. It is written from the protocol
//! (`foxglove.websocket.v1`, which the SDK's server calls `foxglove.sdk.v1`, with `tokio-tungstenite`, which the `foxglove` crate's server
//! already brings), not with the SDK.

use anyhow::{Context as _, anyhow};
use futures::{SinkExt as _, StreamExt as _};
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest as _;

/// A client subscribed to everything; [`Client::stop`] ends it.
pub(crate) struct Client {
    stop: Arc<AtomicBool>,
    messages: Arc<AtomicU64>,
    subscribed: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<()>>>,
}

impl Client {
    /// Connects to the server at `addr` and subscribes to each channel it advertises.
    pub(crate) fn start(addr: SocketAddr) -> anyhow::Result<Client> {
        let stop = Arc::new(AtomicBool::new(false));
        let messages = Arc::new(AtomicU64::new(0));
        let subscribed = Arc::new(AtomicU64::new(0));
        let (s, m, n) = (Arc::clone(&stop), Arc::clone(&messages), Arc::clone(&subscribed));
        let thread = std::thread::Builder::new()
            .name("bench-foxglove-client".into())
            .spawn(move || {
                let rt = tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                    .context("the client's runtime")?;
                rt.block_on(read_all(addr, &s, &m, &n))
            })
            .context("the client's thread")?;
        Ok(Client { stop, messages, subscribed, thread: Some(thread) })
    }

    /// Channels subscribed to so far.
    pub(crate) fn subscribed(&self) -> u64 {
        self.subscribed.load(Ordering::Relaxed)
    }

    /// Stops reading; the messages read.
    pub(crate) fn stop(mut self) -> anyhow::Result<u64> {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().map_err(|_| anyhow!("the bench's Foxglove client panicked"))??;
        }
        Ok(self.messages.load(Ordering::Relaxed))
    }
}

async fn read_all(
    addr: SocketAddr,
    stop: &AtomicBool,
    messages: &AtomicU64,
    subscribed: &AtomicU64,
) -> anyhow::Result<()> {
    let mut request = format!("ws://{addr}").into_client_request()?;
    request.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.websocket.v1, foxglove.sdk.v1".parse()?);
    let (mut ws, _) =
        tokio_tungstenite::connect_async(request).await.context("connecting to the live server")?;
    let mut next_id = 1u64;
    while !stop.load(Ordering::Relaxed) {
        let msg = match tokio::time::timeout(Duration::from_millis(100), ws.next()).await {
            Err(_) => continue,
            Ok(None) => break,
            Ok(Some(m)) => m.context("reading from the live server")?,
        };
        match msg {
            Message::Binary(_) => {
                messages.fetch_add(1, Ordering::Relaxed);
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
                subscribed.fetch_add(subs.len() as u64, Ordering::Relaxed);
                let request = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                ws.send(Message::text(request.to_string())).await?;
            }
            _ => {}
        }
    }
    let _ = ws.close(None).await;
    Ok(())
}
