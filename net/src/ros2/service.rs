//! ROS 2 services a node serves, as rmw_zenoh lays them out (`rmw_service_data.cpp`): a
//! queryable, declared complete, on `<domain>/<service>/<pkg>::srv::dds_::<Type>_/<hash>`,
//! and a liveliness token of kind `SS` with the services' QoS (ROS 2's default profile). A
//! client's request is a query whose payload is the request in CDR and whose attachment is the
//! client's sequence number, source timestamp and gid; the reply carries the response in CDR
//! and an attachment with the client's sequence number and gid and the reply's own timestamp,
//! which is how the client pairs it with its request.
//!
//! A request without that attachment, one that does not decode as the service's request, or
//! one for another type of service on the same name, gets an error reply (zenoh's
//! `reply_err`, which rmw_zenoh's client reports and drops) saying why, and is counted
//! ([`Ros2Stats::requests_refused`](super::Ros2Stats)).

use super::cdr;
use super::graph::{self, Entity, Qos};
use super::msg::Service;
use super::node::Ros2Node;
use crate::options::NetError;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// A service's answer to one request, computed on the runtime the service was declared on.
pub type Answer<R> = Pin<Box<dyn Future<Output = R> + Send + 'static>>;

/// A service this node serves; announced while it lives, withdrawn when dropped.
pub struct Ros2Service {
    _queryable: zenoh::query::Queryable<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

impl std::fmt::Debug for Ros2Service {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Service").finish_non_exhaustive()
    }
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

impl Ros2Node {
    /// The node's fully qualified name (`/orsa`, `/r1/orsa`).
    pub fn fully_qualified_name(&self) -> String {
        let id = &self.inner.id;
        let ns = id.namespace.trim_end_matches('/');
        format!("{ns}/{}", id.name)
    }

    /// Serves service `S` as `name` (`~/x` is under the node's own name, as in rclcpp:
    /// `/orsa/x`; other relative names are under its namespace): `answer` is called with each
    /// request that decodes, and its response is sent back when it is ready (on the tokio
    /// runtime this is called on).
    pub async fn serve<S: Service>(
        &self,
        name: &str,
        answer: impl Fn(S::Request) -> Answer<S::Response> + Send + Sync + 'static,
    ) -> Result<Ros2Service, NetError> {
        let name = match name.strip_prefix("~/") {
            Some(rest) => format!("{}/{rest}", self.fully_qualified_name()),
            None => name.to_string(),
        };
        let name = self.topic(&name)?;
        let domain = self.inner.id.domain;
        let runtime = tokio::runtime::Handle::try_current()
            .map_err(|_| NetError::Open(format!("ROS 2 service {name}: not on a tokio runtime")))?;
        let weak = Arc::downgrade(&self.inner);
        let answer = Arc::new(answer);
        let service = name.clone();
        let queryable = self
            .inner
            .session
            .declare_queryable(graph::any_type_key(domain, &name))
            .complete(true)
            .callback(move |query| {
                let Some(node) = weak.upgrade() else { return };
                let refuse = |why: String| {
                    node.counts.requests_refused.fetch_add(1, Ordering::Relaxed);
                    node.warn(format_args!("ROS 2 service {service}: refused a request: {why}"));
                    use zenoh::Wait as _;
                    let _ = query.reply_err(why).wait();
                };
                let key = query.key_expr().as_str();
                if graph::type_of_key(key, domain, &service) != Some((S::DDS_NAME, S::HASH)) {
                    return refuse(format!("{key}: this service is a {} ({})", S::NAME, S::HASH));
                }
                let Some((seq, _, gid)) =
                    query.attachment().and_then(|a| graph::read_attachment(&a.to_bytes()))
                else {
                    return refuse("no rmw_zenoh attachment (sequence number, timestamp, gid)".into());
                };
                let size = query.payload().map_or(0, |p| p.len());
                if size > S::MAX_REQUEST_BYTES {
                    return refuse(format!(
                        "the request is {size} bytes, more than this service takes ({})",
                        S::MAX_REQUEST_BYTES
                    ));
                }
                let payload = query.payload().map(|p| p.to_bytes()).unwrap_or_default();
                let request = match cdr::decode_named::<S::Request>(&payload, S::NAME) {
                    Ok(r) => r,
                    Err(e) => return refuse(format!("the request does not decode: {e}")),
                };
                let pending = answer(request);
                let node = Arc::clone(&node);
                runtime.spawn(async move {
                    let response = pending.await;
                    let mut bytes = Vec::with_capacity(128);
                    if let Err(e) = cdr::encode_named(&response, S::NAME, &mut bytes) {
                        node.counts.failed.fetch_add(1, Ordering::Relaxed);
                        node.warn(format_args!("ROS 2 service: cannot encode a response: {e}"));
                        let _ = query.reply_err(format!("the response does not encode: {e}")).await;
                        return;
                    }
                    let attachment = graph::attachment(seq, now_ns(), &gid);
                    let key = query.key_expr().clone();
                    match query.reply(key, bytes).attachment(attachment.to_vec()).await {
                        Ok(()) => {
                            node.counts.requests_answered.fetch_add(1, Ordering::Relaxed);
                        }
                        Err(e) => {
                            node.counts.failed.fetch_add(1, Ordering::Relaxed);
                            node.warn(format_args!("ROS 2 service: cannot send a response: {e}"));
                        }
                    }
                });
            })
            .await
            .map_err(|e| NetError::Open(format!("ROS 2 service {name}: {e}")))?;
        let (token, _) = self.token_of(Entity::Service, &name, S::DDS_NAME, S::HASH, Qos::Default).await?;
        Ok(Ros2Service { _queryable: queryable, _token: token })
    }
}

/// Why a service call gave no response.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CallError {
    /// No server answered within the time given.
    #[error("{service}: no response within {within:?}")]
    NoResponse {
        /// The service.
        service: String,
        /// The time given.
        within: std::time::Duration,
    },
    /// The server refused the request (zenoh's error reply), saying why.
    #[error("{service}: refused: {why}")]
    Refused {
        /// The service.
        service: String,
        /// What it said.
        why: String,
    },
    /// The response did not decode, or the request did not encode.
    #[error("{service}: {why}")]
    Bad {
        /// The service.
        service: String,
        /// What was wrong.
        why: String,
    },
}

/// A client of a ROS 2 service, as rmw_zenoh's (`rmw_client_data.cpp`): announced by a token
/// of kind `SC`; each call is a query on the service's key targeting every complete
/// queryable, carrying the request in CDR and the client's attachment (its sequence number,
/// the time, its gid).
pub struct Ros2Client<S: Service> {
    node: Arc<super::node::NodeInner>,
    name: String,
    key: String,
    gid: [u8; 16],
    seq: std::sync::atomic::AtomicI64,
    _token: zenoh::liveliness::LivelinessToken,
    _s: std::marker::PhantomData<fn(S)>,
}

impl<S: Service> std::fmt::Debug for Ros2Client<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Client").field("service", &self.name).finish_non_exhaustive()
    }
}

impl Ros2Node {
    /// A client of service `name` (named as in [`serve`](Self::serve)) of type `S`.
    pub async fn client<S: Service>(&self, name: &str) -> Result<Ros2Client<S>, NetError> {
        let name = self.topic(name)?;
        let key = graph::service_key::<S>(self.inner.id.domain, &name);
        let (token, token_key) =
            self.token_of(Entity::Client, &name, S::DDS_NAME, S::HASH, Qos::Default).await?;
        Ok(Ros2Client {
            node: Arc::clone(&self.inner),
            name,
            key,
            gid: graph::gid(&token_key),
            seq: std::sync::atomic::AtomicI64::new(0),
            _token: token,
            _s: std::marker::PhantomData,
        })
    }
}

impl<S: Service> Ros2Client<S> {
    /// Calls the service: the first response within `within`, or why there is none.
    pub async fn call(
        &self,
        request: &S::Request,
        within: std::time::Duration,
    ) -> Result<S::Response, CallError> {
        let bad = |why: String| CallError::Bad { service: self.name.clone(), why };
        let mut bytes = Vec::with_capacity(64);
        cdr::encode_named(request, S::NAME, &mut bytes).map_err(|e| bad(e.to_string()))?;
        let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
        let attachment = graph::attachment(seq, now_ns(), &self.gid);
        let replies = self
            .node
            .session
            .get(&self.key)
            .payload(bytes)
            .attachment(attachment.to_vec())
            .target(zenoh::query::QueryTarget::AllComplete)
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(within)
            .await
            .map_err(|e| bad(format!("cannot ask: {e}")))?;
        match replies.recv_async().await {
            Ok(reply) => match reply.result() {
                Ok(sample) => cdr::decode_named::<S::Response>(&sample.payload().to_bytes(), S::NAME)
                    .map_err(|e| bad(format!("the response does not decode: {e}"))),
                Err(e) => Err(CallError::Refused {
                    service: self.name.clone(),
                    why: String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
                }),
            },
            Err(_) => Err(CallError::NoResponse { service: self.name.clone(), within }),
        }
    }
}
