//! Heartbeats: what a process publishes every period when
//! [`NetOptions::heartbeat`](crate::NetOptions::heartbeat) is set, and how a peer watches them
//! ([`ZenohTransport::on_heartbeat`]).

use crate::serve::Entity;
use crate::session::Inner;
use crate::{NetError, ZenohTransport};
use orsa_actors::wire::{decode, encode};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;
use zenoh::qos::CongestionControl;

/// What a process publishes on `orsa/v1/heartbeat/<zid>/<role>` every period (see
/// [`NetOptions::heartbeat`](crate::NetOptions::heartbeat)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Heartbeat {
    /// Counts from 0 at the session's start.
    pub seq: u64,
    /// The period the sender publishes at, ms.
    pub period_ms: u64,
}

/// The heartbeat task: ends when dropped.
struct HeartbeatTask {
    task: tokio::task::JoinHandle<()>,
    _publisher: Arc<zenoh::pubsub::Publisher<'static>>,
}

impl Drop for HeartbeatTask {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Heartbeats being watched (see [`ZenohTransport::on_heartbeat`]); dropping it stops the watch.
pub struct HeartbeatWatch {
    _sub: zenoh::pubsub::Subscriber<()>,
}

impl std::fmt::Debug for HeartbeatWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HeartbeatWatch").finish_non_exhaustive()
    }
}

impl ZenohTransport {
    /// Calls `f(zid, heartbeat)` for every heartbeat of a process of `role` (see
    /// [`NetOptions::heartbeat`](crate::NetOptions::heartbeat)), except from processes whose link is cut. Keep the returned
    /// value: dropping it stops the calls.
    pub async fn on_heartbeat(
        &self,
        role: &str,
        f: impl Fn(&str, &Heartbeat) + Send + Sync + 'static,
    ) -> Result<HeartbeatWatch, NetError> {
        let weak = Arc::downgrade(&self.inner);
        let sub = self
            .inner
            .session
            .declare_subscriber(self.inner.keys.heartbeats(role))
            .callback(move |sample| {
                let Some(inner) = weak.upgrade() else { return };
                let key = sample.key_expr().as_str();
                let Some((zid, _)) = inner.keys.parse_heartbeat(key) else {
                    tracing::warn!("ignoring a heartbeat on a malformed key '{key}'");
                    return;
                };
                inner.arrived(key, sample.attachment());
                if !inner.admit_from(&zid) {
                    return;
                }
                inner.received.fetch_add(1, Ordering::Relaxed);
                match decode::<Heartbeat>(&sample.payload().to_bytes(), "orsa.Heartbeat/1") {
                    Ok(h) => f(&zid, &h),
                    Err(e) => inner.bad(key, &e),
                }
            })
            .await
            .map_err(|e| NetError::Open(e.to_string()))?;
        Ok(HeartbeatWatch { _sub: sub })
    }
}

impl Inner {
    /// Publishes a heartbeat on this process's key every `period`, until the transport is
    /// dropped or the session closed.
    pub(crate) async fn start_heartbeat(
        self: &Arc<Self>,
        role: &str,
        period: std::time::Duration,
    ) -> Result<Entity, NetError> {
        if period.is_zero() || period > Duration::from_secs(60) {
            return Err(NetError::Config(format!(
                "heartbeat period {period:?}: must be more than 0 and at most 60 s"
            )));
        }
        let publisher = self
            .session
            .declare_publisher(self.keys.heartbeat(&self.zid, role))
            .express(true)
            .congestion_control(CongestionControl::Drop)
            .await
            .map_err(|e| NetError::Open(e.to_string()))?;
        let (outlet, counts) = self.links.outlet(publisher.key_expr().as_str());
        let publisher = Arc::new(publisher);
        let weak = Arc::downgrade(self);
        let beat = Arc::clone(&publisher);
        let period_ms = u64::try_from(period.as_millis()).unwrap_or(u64::MAX);
        let task = self.runtime.spawn(async move {
            let mut tick = tokio::time::interval(period);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            for seq in 0u64.. {
                tick.tick().await;
                let Some(inner) = weak.upgrade() else { return };
                let bytes = encode(&Heartbeat { seq, period_ms });
                let from = crate::links::attachment(&inner.zid, outlet, counts.next());
                if let Err(e) = beat.put(bytes).attachment(from).await {
                    counts.failed();
                    tracing::debug!("heartbeat: {e}");
                    if inner.session.is_closed() {
                        return;
                    }
                }
                inner.published.fetch_add(1, Ordering::Relaxed);
            }
        });
        Ok(Box::new(HeartbeatTask { task, _publisher: publisher }))
    }
}
