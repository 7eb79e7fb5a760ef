//! The client side: orsa's [`Transport`] seam over zenoh, which the registry calls to reach
//! services hosted by peers (send, request, subscribe, activate), and the guard that ends what
//! a client holds at a peer.

use crate::control::{ActivateRequest, SubscribeRequest};
use crate::session::{Inner, ZenohTransport, link};
use futures::future::BoxFuture;
use orsa_actors::addr::{ServiceAddr, ServiceInfo};
use orsa_actors::event::EventMode;
use orsa_actors::transport::{ByteSink, Served, Subscription, Transport};
use orsa_actors::wire::encode;
use orsa_actors::{PatternError, PatternResult};
use std::num::NonZeroU32;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;
use zenoh::Wait as _;

/// Ends a subscription or activation held at a peer.
pub(crate) struct Release {
    pub(crate) inner: std::sync::Weak<Inner>,
    pub(crate) addr: ServiceAddr,
    pub(crate) held: u64,
    pub(crate) key: String,
    pub(crate) payload: Vec<u8>,
    pub(crate) _subscriber: zenoh::pubsub::Subscriber<()>,
}

impl Drop for Release {
    fn drop(&mut self) {
        if let Some(inner) = self.inner.upgrade() {
            inner.held.lock().remove(&self.held);
            if tokio::runtime::Handle::try_current().is_ok() {
                inner.control(&self.addr, std::mem::take(&mut self.key), std::mem::take(&mut self.payload));
            }
        }
    }
}

impl Transport for ZenohTransport {
    fn name(&self) -> &str {
        "zenoh"
    }

    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo> {
        self.inner.remote.read().get(addr).map(|a| a.info.clone())
    }

    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> PatternResult<()> {
        let publisher = {
            let mut senders = self.inner.senders.lock();
            match senders.get(addr) {
                Some(p) => Arc::clone(p),
                None => {
                    let p = self.inner.publisher(self.inner.keys.send(addr), false)?;
                    senders.insert(addr.clone(), Arc::clone(&p));
                    p
                }
            }
        };
        // To a cut-off process: lost on the way, as a one-way message is.
        if self.inner.withhold_to(addr) {
            publisher.counts.withheld();
            return Ok(());
        }
        publisher.put(&self.inner.session, payload, &self.inner.zid).map_err(link)?;
        self.inner.published.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> BoxFuture<'static, PatternResult<Vec<u8>>> {
        let inner = Arc::clone(&self.inner);
        let key = self.inner.keys.request(addr);
        let addr = addr.clone();
        Box::pin(async move {
            // To a cut-off process: the request is lost, so its answer never comes.
            if inner.withhold_to(&addr) {
                tokio::time::sleep(timeout).await;
                return Err(PatternError::Timeout);
            }
            let answer = inner.get(&key, payload, timeout).await;
            // Cut off while the request was out: the answer is lost.
            if answer.is_ok() && inner.withhold_to(&addr) {
                return Err(PatternError::Timeout);
            }
            answer
        })
    }

    fn subscribe(
        &self,
        addr: &ServiceAddr,
        every: NonZeroU32,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let inner = &self.inner;
        let weak = Arc::downgrade(inner);
        let subscriber = inner
            .session
            .declare_subscriber(inner.keys.stream(addr, every))
            .callback(move |sample| {
                let Some(inner) = weak.upgrade() else { return };
                inner.arrived(sample.key_expr().as_str(), sample.attachment());
                if !inner.admit(sample.attachment()) {
                    return;
                }
                inner.received.fetch_add(1, Ordering::Relaxed);
                sink(&sample.payload().to_bytes());
            })
            .wait()
            .map_err(link)?;
        let id = inner.next_id.fetch_add(1, Ordering::Relaxed);
        let req = SubscribeRequest::Subscribe { every: every.get(), client: inner.zid.clone(), id };
        let held = inner.hold(id, addr, inner.keys.subscribe(addr), encode(&req));
        let release = SubscribeRequest::Unsubscribe { client: inner.zid.clone(), id };
        Ok(Subscription::new(Release {
            inner: Arc::downgrade(inner),
            addr: addr.clone(),
            held,
            key: inner.keys.subscribe(addr),
            payload: encode(&release),
            _subscriber: subscriber,
        }))
    }

    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: EventMode,
        params: Vec<u8>,
        sink: ByteSink,
    ) -> PatternResult<Subscription> {
        let inner = &self.inner;
        let id = inner.next_id.fetch_add(1, Ordering::Relaxed);
        let weak = Arc::downgrade(inner);
        let subscriber = inner
            .session
            .declare_subscriber(inner.keys.firings(&inner.zid, id))
            .callback(move |sample| {
                let Some(inner) = weak.upgrade() else { return };
                inner.arrived(sample.key_expr().as_str(), sample.attachment());
                if !inner.admit(sample.attachment()) {
                    return;
                }
                inner.received.fetch_add(1, Ordering::Relaxed);
                if !sink(&sample.payload().to_bytes()) {
                    // Ended (single shot fired, or the receiver is gone): do not renew it.
                    inner.held.lock().remove(&id);
                }
            })
            .wait()
            .map_err(link)?;
        let req = ActivateRequest::Activate { mode, params, client: inner.zid.clone(), id };
        let held = inner.hold(id, addr, inner.keys.activate(addr), encode(&req));
        let release = ActivateRequest::Deactivate { client: inner.zid.clone(), id };
        Ok(Subscription::new(Release {
            inner: Arc::downgrade(inner),
            addr: addr.clone(),
            held,
            key: inner.keys.activate(addr),
            payload: encode(&release),
            _subscriber: subscriber,
        }))
    }

    fn service_added(&self, addr: &ServiceAddr, info: &ServiceInfo, served: Arc<dyn Served>) {
        self.inner.export(addr, info, served);
    }

    fn service_removed(&self, addr: &ServiceAddr) {
        self.inner.exports.lock().remove(addr);
    }
}
