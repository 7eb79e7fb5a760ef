//! A ROS 2 node on orsa's zenoh session: its liveliness token, its publishers and its
//! subscriptions, each announced by a token of its own as rmw_zenoh does, and the counts of
//! what it sent and what it refused.

use super::cdr::{self, CdrError};
use super::graph::{self, Entity, NameError, NodeId, Qos};
use super::msg::Message;
use crate::ZenohTransport;
use crate::options::NetError;
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;
use std::sync::Arc;
use std::sync::atomic::{AtomicI64, AtomicU32, AtomicU64, Ordering};
use zenoh::Wait as _;
use zenoh::qos::CongestionControl;
use zenoh_ext::{AdvancedPublisherBuilderExt as _, AdvancedSubscriberBuilderExt as _};

/// Who the node is on the ROS 2 graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2Options {
    /// The ROS domain id (`ROS_DOMAIN_ID`), 0..=232.
    pub domain: u32,
    /// The node's namespace, `/` for none.
    pub namespace: String,
    /// The node's name.
    pub name: String,
}

impl Ros2Options {
    /// Checks the domain, the namespace and the name.
    pub fn validate(&self) -> Result<(), NameError> {
        if self.domain > 232 {
            return Err(NameError::Domain(self.domain));
        }
        graph::check_node(&self.namespace, &self.name)
    }
}

/// What a ROS 2 node sent and what it refused, since it started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ros2Stats {
    /// Messages published.
    pub published: u64,
    /// Messages received and decoded.
    pub received: u64,
    /// Messages received that did not decode as their topic's type (dropped).
    pub undecodable: u64,
    /// Messages received on a subscribed topic with another type or type hash (dropped).
    pub wrong_type: u64,
    /// Messages that could not be encoded or put on the session.
    pub failed: u64,
    /// Service requests answered.
    #[serde(default)]
    pub requests_answered: u64,
    /// Service requests refused with an error reply (no rmw_zenoh attachment, not CDR of the
    /// request type, another service type).
    #[serde(default)]
    pub requests_refused: u64,
}

#[derive(Default)]
pub(super) struct Counts {
    published: AtomicU64,
    received: AtomicU64,
    undecodable: AtomicU64,
    wrong_type: AtomicU64,
    pub(super) failed: AtomicU64,
    pub(super) requests_answered: AtomicU64,
    pub(super) requests_refused: AtomicU64,
}

pub(super) struct NodeInner {
    pub(super) session: zenoh::Session,
    pub(super) id: NodeId,
    next_entity: AtomicU32,
    pub(super) counts: Counts,
    bad_log: orsa_actors::logbudget::LogBudget,
    _token: zenoh::liveliness::LivelinessToken,
}

/// A ROS 2 node: publishes and subscribes to ROS 2 topics on this transport's zenoh session, as
/// a node of rmw_zenoh would. Cheap to clone.
#[derive(Clone)]
pub struct Ros2Node {
    pub(super) inner: Arc<NodeInner>,
}

impl std::fmt::Debug for Ros2Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Node").field("name", &self.inner.id.name).finish_non_exhaustive()
    }
}

impl ZenohTransport {
    /// A ROS 2 node on this transport's session (announced by its liveliness token).
    pub async fn ros2_node(&self, options: &Ros2Options) -> Result<Ros2Node, NetError> {
        options.validate().map_err(|e| NetError::Config(e.to_string()))?;
        let session = self.inner.session.clone();
        let id = NodeId {
            domain: options.domain,
            zid: session.zid().to_string(),
            node_id: 0,
            namespace: options.namespace.clone(),
            name: options.name.clone(),
        };
        let token = session
            .liveliness()
            .declare_token(id.token(Entity::Node, 0, None))
            .await
            .map_err(|e| NetError::Open(format!("ROS 2 node token: {e}")))?;
        Ok(Ros2Node {
            inner: Arc::new(NodeInner {
                session,
                id,
                next_entity: AtomicU32::new(1),
                counts: Counts::default(),
                bad_log: orsa_actors::logbudget::LogBudget::hostile_input(),
                _token: token,
            }),
        })
    }
}

impl Ros2Node {
    /// What the node sent and refused so far.
    pub fn stats(&self) -> Ros2Stats {
        let c = &self.inner.counts;
        Ros2Stats {
            published: c.published.load(Ordering::Relaxed),
            received: c.received.load(Ordering::Relaxed),
            undecodable: c.undecodable.load(Ordering::Relaxed),
            wrong_type: c.wrong_type.load(Ordering::Relaxed),
            failed: c.failed.load(Ordering::Relaxed),
            requests_answered: c.requests_answered.load(Ordering::Relaxed),
            requests_refused: c.requests_refused.load(Ordering::Relaxed),
        }
    }

    /// The topic's absolute name under the node's namespace, checked.
    pub(super) fn topic(&self, topic: &str) -> Result<String, NetError> {
        graph::qualified_topic(&self.inner.id.namespace, topic).map_err(|e| NetError::Config(e.to_string()))
    }

    async fn token<T: Message>(
        &self,
        entity: Entity,
        topic: &str,
        qos: Qos,
    ) -> Result<(zenoh::liveliness::LivelinessToken, String), NetError> {
        self.token_of(entity, topic, T::DDS_NAME, T::HASH, qos).await
    }

    pub(super) async fn token_of(
        &self,
        entity: Entity,
        topic: &str,
        dds: &str,
        hash: &str,
        qos: Qos,
    ) -> Result<(zenoh::liveliness::LivelinessToken, String), NetError> {
        let n = self.inner.next_entity.fetch_add(1, Ordering::Relaxed);
        let key = self.inner.id.token(entity, n, Some((topic, dds, hash, qos)));
        let token = self
            .inner
            .session
            .liveliness()
            .declare_token(key.clone())
            .await
            .map_err(|e| NetError::Open(format!("ROS 2 token of {topic}: {e}")))?;
        Ok((token, key))
    }

    /// A publisher of `T` on `topic` (relative names are under the node's namespace).
    pub async fn publisher<T: Message>(&self, topic: &str, qos: Qos) -> Result<Ros2Publisher<T>, NetError> {
        let topic = self.topic(topic)?;
        let key = graph::data_key::<T>(self.inner.id.domain, &topic);
        let open = |e: zenoh::Error| NetError::Open(format!("ROS 2 publisher of {topic}: {e}"));
        let builder = self.inner.session.declare_publisher(key).congestion_control(CongestionControl::Drop);
        // Transient local, as rmw_zenoh makes it: zenoh-ext's advanced publisher, keeping the
        // last `depth` samples for late joiners and announcing itself to them.
        let publisher = match qos.history() {
            None => Put::Plain(builder.await.map_err(open)?),
            Some(depth) => Put::Advanced(
                builder
                    .cache(zenoh_ext::CacheConfig::default().max_samples(depth))
                    .publisher_detection()
                    .await
                    .map_err(open)?,
            ),
        };
        let (token, token_key) = self.token::<T>(Entity::Publisher, &topic, qos).await?;
        Ok(Ros2Publisher {
            node: Arc::clone(&self.inner),
            publisher,
            gid: graph::gid(&token_key),
            seq: AtomicI64::new(0),
            size: Mutex::new(64),
            _token: token,
            _t: PhantomData,
        })
    }

    /// Subscribes to `topic`: `on` gets every message of type `T` that decodes, with its source
    /// timestamp (ns since the UNIX epoch) if its attachment has one. Messages of another type
    /// on the same topic, and messages that do not decode, are dropped and counted.
    pub async fn subscribe<T: Message>(
        &self,
        topic: &str,
        qos: Qos,
        on: impl Fn(T, Option<i64>) + Send + Sync + 'static,
    ) -> Result<Ros2Subscription, NetError> {
        let types = [(T::NAME, T::DDS_NAME, T::HASH)];
        self.subscribe_types(topic, qos, &types, move |_, bytes, stamp| {
            on(cdr::decode::<T>(bytes)?, stamp);
            Ok(())
        })
        .await
    }

    /// Subscribes to `topic` taking either of two types (announced as a subscription of
    /// each, as a node with one subscription per type is): `on` gets each message that decodes
    /// as its type, as [`Either`]. Messages of any other type, and messages that do not decode,
    /// are dropped and counted.
    pub async fn subscribe_either<A: Message, B: Message>(
        &self,
        topic: &str,
        qos: Qos,
        on: impl Fn(Either<A, B>, Option<i64>) + Send + Sync + 'static,
    ) -> Result<Ros2Subscription, NetError> {
        let types = [(A::NAME, A::DDS_NAME, A::HASH), (B::NAME, B::DDS_NAME, B::HASH)];
        self.subscribe_types(topic, qos, &types, move |i, bytes, stamp| {
            let msg = if i == 0 {
                Either::A(cdr::decode::<A>(bytes)?)
            } else {
                Either::B(cdr::decode::<B>(bytes)?)
            };
            on(msg, stamp);
            Ok(())
        })
        .await
    }

    /// The subscription of [`subscribe`](Self::subscribe) and
    /// [`subscribe_either`](Self::subscribe_either): `take` gets the index in `types` (name,
    /// DDS name, hash) of each message's type, its bytes and its source timestamp.
    async fn subscribe_types(
        &self,
        topic: &str,
        qos: Qos,
        types: &[(&'static str, &'static str, &'static str)],
        take: impl Fn(usize, &[u8], Option<i64>) -> Result<(), CdrError> + Send + Sync + 'static,
    ) -> Result<Ros2Subscription, NetError> {
        let topic = self.topic(topic)?;
        let domain = self.inner.id.domain;
        let weak = Arc::downgrade(&self.inner);
        let name = topic.clone();
        let accepted = types.to_vec();
        let on_sample = move |sample: zenoh::sample::Sample| {
            let Some(node) = weak.upgrade() else { return };
            let key = sample.key_expr().as_str();
            let found = graph::type_of_key(key, domain, &name);
            let Some(i) = accepted.iter().position(|&(_, dds, hash)| found == Some((dds, hash))) else {
                node.counts.wrong_type.fetch_add(1, Ordering::Relaxed);
                let names: Vec<String> = accepted.iter().map(|(n, _, h)| format!("{n} ({h})")).collect();
                node.warn(format_args!(
                    "ROS 2 {name}: dropped a message on {key}: the topic takes {}",
                    names.join(" or ")
                ));
                return;
            };
            let stamp = sample.attachment().and_then(|a| graph::read_attachment(&a.to_bytes()).map(|a| a.1));
            match take(i, &sample.payload().to_bytes(), stamp) {
                Ok(()) => {
                    node.counts.received.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => {
                    node.counts.undecodable.fetch_add(1, Ordering::Relaxed);
                    node.warn(format_args!("ROS 2 {name}: dropped a message that does not decode: {e}"));
                }
            }
        };
        let open = |e: zenoh::Error| NetError::Open(format!("ROS 2 subscription to {topic}: {e}"));
        let builder = self.inner.session.declare_subscriber(graph::any_type_key(domain, &topic));
        // Transient local, as rmw_zenoh makes it: zenoh-ext's advanced subscriber, which asks
        // the caching publishers for their history, those that join later too.
        let subscriber = match qos.history() {
            None => Take::Plain(builder.callback(on_sample).await.map_err(open)?),
            Some(depth) => Take::Advanced(
                builder
                    .history(zenoh_ext::HistoryConfig::default().detect_late_publishers().max_samples(depth))
                    .subscriber_detection()
                    .callback(on_sample)
                    .await
                    .map_err(open)?,
            ),
        };
        let mut tokens = Vec::new();
        for (_, dds, hash) in types {
            tokens.push(self.token_of(Entity::Subscription, &topic, dds, hash, qos).await?.0);
        }
        Ok(Ros2Subscription { _subscriber: subscriber, _tokens: tokens })
    }
}

/// A message of one of two types (see [`Ros2Node::subscribe_either`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Either<A, B> {
    /// Of the first type.
    A(A),
    /// Of the second.
    B(B),
}

impl NodeInner {
    /// A line about bad input, within the budget for hostile input.
    pub(super) fn warn(&self, line: std::fmt::Arguments<'_>) {
        if let orsa_actors::logbudget::Verdict::Log { suppressed } =
            self.bad_log.judge(std::time::Instant::now())
        {
            tracing::warn!(suppressed, "{line}");
        }
    }
}

/// A volatile publisher, or a transient local one (zenoh-ext's, with its cache).
enum Put {
    Plain(zenoh::pubsub::Publisher<'static>),
    Advanced(zenoh_ext::AdvancedPublisher<'static>),
}

impl Put {
    fn key_expr(&self) -> &str {
        match self {
            Put::Plain(p) => p.key_expr().as_str(),
            Put::Advanced(p) => p.key_expr().as_str(),
        }
    }

    fn put(&self, bytes: Vec<u8>, attachment: Vec<u8>) -> zenoh::Result<()> {
        match self {
            Put::Plain(p) => p.put(bytes).attachment(attachment).wait(),
            Put::Advanced(p) => p.put(bytes).attachment(attachment).wait(),
        }
    }
}

/// A publisher of ROS 2 messages of type `T` on one topic; announced while it lives.
pub struct Ros2Publisher<T> {
    node: Arc<NodeInner>,
    publisher: Put,
    gid: [u8; 16],
    seq: AtomicI64,
    /// The size of the last message encoded, to allocate the next one at once.
    size: Mutex<usize>,
    _token: zenoh::liveliness::LivelinessToken,
    _t: PhantomData<fn(T)>,
}

impl<T> std::fmt::Debug for Ros2Publisher<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Publisher").field("key", &self.publisher.key_expr()).finish_non_exhaustive()
    }
}

impl<T: Message> Ros2Publisher<T> {
    /// Publishes `msg`, taken at `stamp_ns` (ns since the UNIX epoch, the attachment's source
    /// timestamp). A message that cannot be encoded or sent is counted and logged, not returned:
    /// a publisher keeps publishing.
    pub fn publish(&self, msg: &T, stamp_ns: u64) {
        if let Err(e) = self.try_publish(msg, stamp_ns) {
            self.node.counts.failed.fetch_add(1, Ordering::Relaxed);
            self.node.warn(format_args!("ROS 2 {}: cannot publish: {e}", self.publisher.key_expr()));
        }
    }

    fn try_publish(&self, msg: &T, stamp_ns: u64) -> Result<(), String> {
        let mut bytes = Vec::with_capacity(*self.size.lock());
        cdr::encode_into(msg, &mut bytes).map_err(|e: CdrError| e.to_string())?;
        *self.size.lock() = bytes.len();
        let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
        let stamp = i64::try_from(stamp_ns).unwrap_or(i64::MAX);
        let attachment = graph::attachment(seq, stamp, &self.gid);
        self.publisher.put(bytes, attachment.to_vec()).map_err(|e| e.to_string())?;
        self.node.counts.published.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// Messages this publisher has sent.
    pub fn sent(&self) -> u64 {
        u64::try_from(self.seq.load(Ordering::Relaxed)).unwrap_or(0)
    }
}

/// A volatile subscription, or a transient local one (zenoh-ext's, asking for history).
enum Take {
    Plain(#[allow(dead_code)] zenoh::pubsub::Subscriber<()>),
    Advanced(#[allow(dead_code)] zenoh_ext::AdvancedSubscriber<()>),
}

/// A subscription to a ROS 2 topic; announced while it lives, ended when dropped.
pub struct Ros2Subscription {
    _subscriber: Take,
    /// One per type taken.
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl std::fmt::Debug for Ros2Subscription {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Subscription").finish_non_exhaustive()
    }
}
