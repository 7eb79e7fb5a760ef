//! Where ROS 2 entities live on zenoh, as rmw_zenoh (ROS 2 Jazzy) lays them out
//! (`docs/design.md` of ros2/rmw_zenoh, branch `jazzy`; see `docs/ros2.md`):
//!
//! - data: `<domain>/<topic without its leading '/'>/<DDS type>/<RIHS01 hash>`;
//! - liveliness tokens, one per node and per publisher or subscription:
//!   `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/<namespace>/<node>`,
//!   followed for a topic by `/<topic>/<DDS type>/<hash>/<QoS>`, each name with its `/`
//!   written `%` and an empty one written `%`;
//! - every publication's attachment: sequence number (int64), source timestamp (int64, ns since
//!   the UNIX epoch), source gid (16 bytes, after its length 16), little-endian, as zenoh-ext
//!   serialises the three.

use super::msg::{Message, Service};

/// A ROS name, as a liveliness token carries it: `/` written `%`, empty written `%`.
pub(crate) fn mangle(name: &str) -> String {
    if name.is_empty() { "%".to_string() } else { name.replace('/', "%") }
}

/// A ROS 2 name (topic, node, namespace, domain) that is not valid; each names the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    /// Not a valid topic name.
    #[error("'{0}' is not a valid ROS 2 topic name")]
    Topic(String),
    /// Not a valid node name.
    #[error("'{0}' is not a valid ROS 2 node name")]
    Node(String),
    /// Not a valid namespace.
    #[error("'{0}' is not a valid ROS 2 namespace")]
    Namespace(String),
    /// A domain id out of range.
    #[error("ROS domain {0} is out of range (0..=232)")]
    Domain(u32),
}

/// A topic name made absolute under `namespace`, checked: `cmd_vel` under `/` is `/cmd_vel`.
pub fn qualified_topic(namespace: &str, topic: &str) -> Result<String, NameError> {
    let full = if topic.starts_with('/') {
        topic.to_string()
    } else if namespace.is_empty() || namespace == "/" {
        format!("/{topic}")
    } else {
        format!("{}/{topic}", namespace.trim_end_matches('/'))
    };
    let ok = full.len() > 1
        && !full.ends_with('/')
        && !full.contains("//")
        && full[1..].split('/').all(|t| {
            t.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        });
    if ok { Ok(full) } else { Err(NameError::Topic(topic.to_string())) }
}

/// A node's name and namespace, checked.
pub(crate) fn check_node(namespace: &str, name: &str) -> Result<(), NameError> {
    let token = |t: &str| {
        t.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    if !token(name) {
        return Err(NameError::Node(name.to_string()));
    }
    let ns_ok = namespace == "/"
        || namespace.is_empty()
        || (namespace.starts_with('/') && !namespace.ends_with('/') && namespace[1..].split('/').all(token));
    if !ns_ok {
        return Err(NameError::Namespace(namespace.to_string()));
    }
    Ok(())
}

/// The key a topic's messages of type `T` travel on.
pub fn data_key<T: Message>(domain: u32, topic: &str) -> String {
    format!("{domain}/{}/{}/{}", topic.trim_start_matches('/'), T::DDS_NAME, T::HASH)
}

/// The key a service's requests of type `S` are asked on (a topic's layout, with the service
/// type: `<domain>/<service>/<pkg>::srv::dds_::<Type>_/<hash>`).
pub fn service_key<S: Service>(domain: u32, service: &str) -> String {
    format!("{domain}/{}/{}/{}", service.trim_start_matches('/'), S::DDS_NAME, S::HASH)
}

/// Every key a topic's messages travel on, whatever their type.
pub(crate) fn any_type_key(domain: u32, topic: &str) -> String {
    format!("{domain}/{}/*/*", topic.trim_start_matches('/'))
}

/// The DDS type and hash a key of topic `topic` carries (the two chunks after the topic).
pub(crate) fn type_of_key<'k>(key: &'k str, domain: u32, topic: &str) -> Option<(&'k str, &'k str)> {
    let rest = key.strip_prefix(&format!("{domain}/{}/", topic.trim_start_matches('/')))?;
    rest.split_once('/')
}

/// A QoS profile, the few policies orsa uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qos {
    /// Reliable, volatile, keep last 10: ROS 2's default (`/cmd_vel`, `/odom`, `/tf`).
    Default,
    /// Best effort, volatile, keep last 5: ROS 2's sensor data profile (`/scan`).
    SensorData,
    /// Reliable, transient local, keep last 1000: `/rosout` (rcl's profile, without its 10 s
    /// lifespan: a late joiner gets the last 1000 lines, however old).
    Rosout,
    /// Reliable, transient local, keep last 100: `/tf_static` as tf2_ros listens to it.
    StaticTf,
    /// Reliable, transient local, keep last 1: `/map` as Nav2's map_server publishes it (a late
    /// joiner, RViz or a planner, gets the map at once).
    Map,
}

impl Qos {
    /// The profile as rmw_zenoh writes it in liveliness tokens: `<reliability>:<durability>:
    /// <history>,<depth>:<deadline>:<lifespan>:<liveliness>`, each policy left empty where it is
    /// the default one (reliable, volatile, keep last, infinite, automatic).
    pub fn token(self) -> &'static str {
        match self {
            Qos::Default => "::,10:,:,:,,",
            Qos::SensorData => "2::,5:,:,:,,",
            Qos::Rosout => ":1:,1000:,:,:,,",
            Qos::StaticTf => ":1:,100:,:,:,,",
            Qos::Map => ":1:,1:,:,:,,",
        }
    }
}

impl Qos {
    /// The history a transient local publisher keeps for late joiners, and a transient local
    /// subscription asks for; `None` for a volatile profile.
    pub fn history(self) -> Option<usize> {
        match self {
            Qos::Default | Qos::SensorData => None,
            Qos::Rosout => Some(1000),
            Qos::StaticTf => Some(100),
            Qos::Map => Some(1),
        }
    }
}

/// The kind of entity a liveliness token announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Entity {
    Node,
    Publisher,
    Subscription,
    /// A service server.
    Service,
    /// A service client.
    Client,
}

impl Entity {
    fn code(self) -> &'static str {
        match self {
            Entity::Node => "NN",
            Entity::Publisher => "MP",
            Entity::Subscription => "MS",
            Entity::Service => "SS",
            Entity::Client => "SC",
        }
    }
}

/// Who a node is, for its tokens.
#[derive(Debug, Clone)]
pub(crate) struct NodeId {
    pub(crate) domain: u32,
    pub(crate) zid: String,
    pub(crate) node_id: u32,
    pub(crate) namespace: String,
    pub(crate) name: String,
}

impl NodeId {
    /// The liveliness token of the node itself (`entity` = `Node`, no topic) or of one of its
    /// publishers or subscriptions.
    pub(crate) fn token(
        &self,
        entity: Entity,
        entity_id: u32,
        topic: Option<(&str, &str, &str, Qos)>,
    ) -> String {
        let ns = if self.namespace == "/" { "" } else { &self.namespace };
        let mut t = format!(
            "@ros2_lv/{}/{}/{}/{}/{}/%/{}/{}",
            self.domain,
            self.zid,
            self.node_id,
            entity_id,
            entity.code(),
            mangle(ns),
            self.name
        );
        if let Some((topic, dds, hash, qos)) = topic {
            t.push_str(&format!("/{}/{dds}/{hash}/{}", mangle(topic), qos.token()));
        }
        t
    }
}

/// A publisher's gid, as rmw_zenoh derives it (`Entity`'s constructor,
/// `rmw_zenoh_cpp/src/detail/liveliness_utils.cpp`, since its PR #298): the XXH3 128-bit hash
/// of the entity's whole liveliness token (which holds the session's zid and the entity's id),
/// its low 64 bits then its high 64 bits, each little-endian (the host order of every platform
/// ROS 2 ships on). So `message_info.publisher_gid` is what `ros2 topic info -v` shows.
pub(crate) fn gid(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut out = [0u8; 16];
    out[..8].copy_from_slice(&(h as u64).to_le_bytes());
    out[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    out
}

/// The attachment of a publication: `seq` (int64), `stamp_ns` (int64), then the gid after its
/// length (16, one byte as zenoh-ext writes small lengths).
pub(crate) fn attachment(seq: i64, stamp_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&seq.to_le_bytes());
    a[8..16].copy_from_slice(&stamp_ns.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

/// The sequence number, source timestamp and gid of an attachment, if it is one.
pub fn read_attachment(a: &[u8]) -> Option<(i64, i64, [u8; 16])> {
    if a.len() != 33 || a[16] != 16 {
        return None;
    }
    let seq = i64::from_le_bytes(a[..8].try_into().ok()?);
    let stamp = i64::from_le_bytes(a[8..16].try_into().ok()?);
    Some((seq, stamp, a[17..].try_into().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::msg::{LaserScan, Twist};

    #[test]
    fn keys_and_tokens_are_rmw_zenohs() {
        assert_eq!(
            data_key::<Twist>(0, "/cmd_vel"),
            "0/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
        );
        let key = data_key::<LaserScan>(7, "/robot/scan");
        assert_eq!(type_of_key(&key, 7, "/robot/scan"), Some((LaserScan::DDS_NAME, LaserScan::HASH)));
        assert_ne!(type_of_key(&key, 7, "/robot").map(|t| t.0), Some(LaserScan::DDS_NAME));
        assert_eq!(any_type_key(7, "/robot/scan"), "7/robot/scan/*/*");
        let n =
            NodeId { domain: 0, zid: "ab12".into(), node_id: 0, namespace: "/".into(), name: "orsa".into() };
        assert_eq!(n.token(Entity::Node, 0, None), "@ros2_lv/0/ab12/0/0/NN/%/%/orsa");
        assert_eq!(
            n.token(
                Entity::Publisher,
                3,
                Some(("/scan", LaserScan::DDS_NAME, LaserScan::HASH, Qos::SensorData))
            ),
            format!(
                "@ros2_lv/0/ab12/0/3/MP/%/%/orsa/%scan/{}/{}/2::,5:,:,:,,",
                LaserScan::DDS_NAME,
                LaserScan::HASH
            )
        );
        assert_eq!(
            service_key::<crate::ros2::rcl::GetParameters>(0, "/orsa/get_parameters"),
            "0/orsa/get_parameters/rcl_interfaces::srv::dds_::GetParameters_/RIHS01_f480322f7e422b77a0443ba06df1c1a19da1a05af3036ce99d7a49463e55e855"
        );
        let n = NodeId { namespace: "/r1".into(), ..n };
        assert!(n.token(Entity::Subscription, 4, None).contains("/MS/%/%r1/orsa"));
    }

    #[test]
    fn names_are_checked() {
        assert_eq!(qualified_topic("/", "cmd_vel").as_deref(), Ok("/cmd_vel"));
        assert_eq!(qualified_topic("/r1", "scan").as_deref(), Ok("/r1/scan"));
        assert_eq!(qualified_topic("/r1", "/odom").as_deref(), Ok("/odom"));
        for bad in ["", "/", "a//b", "9a", "a b", "a/", "a/*"] {
            assert!(qualified_topic("/", bad).is_err(), "{bad}");
        }
        assert!(check_node("/", "orsa").is_ok());
        assert!(check_node("/r1/x", "orsa_2").is_ok());
        assert!(check_node("r1", "orsa").is_err());
        assert!(check_node("/", "or sa").is_err());
    }

    /// The gid of "abc" as the reference XXH3 (the C library, through Python's `xxhash`)
    /// hashes it: low 64 bits then high 64 bits, little-endian.
    #[test]
    fn gids_are_the_xxh3_128_of_the_token_low_half_first() {
        let expected =
            [0x50, 0x39, 0x2f, 0x89, 0x94, 0x5f, 0xaf, 0x78, 0x85, 0x61, 0x3a, 0x73, 0xb6, 0x5a, 0xb0, 0x06];
        assert_eq!(gid("abc"), expected);
    }

    #[test]
    fn attachments_round_trip() {
        let g = gid("@ros2_lv/0/ab/0/1/MP");
        assert_ne!(g, gid("@ros2_lv/0/ab/0/2/MP"));
        let a = attachment(42, 1_700_000_000_000_000_000, &g);
        assert_eq!(read_attachment(&a), Some((42, 1_700_000_000_000_000_000, g)));
        assert_eq!(read_attachment(&a[..32]), None);
    }
}
