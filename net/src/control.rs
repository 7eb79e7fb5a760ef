//! Control messages between peers: subscribing to a push service's stream and activating an
//! event, as they travel (CBOR; see `docs/wire-format.md`).

use orsa_actors::event::EventMode;
use serde::{Deserialize, Serialize};

/// Subscription control, sent to `.../subscribe`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum SubscribeRequest {
    /// Start (or keep) the stream of every `every`-th update for this client subscription.
    Subscribe {
        /// Every n-th update.
        every: u32,
        /// The subscriber's zenoh id.
        client: String,
        /// The subscription's id within the client.
        id: u64,
    },
    /// End a client subscription.
    Unsubscribe {
        /// The subscriber's zenoh id.
        client: String,
        /// The subscription's id within the client.
        id: u64,
    },
}

/// Activation control, sent to `.../activate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum ActivateRequest {
    /// Activate with encoded parameters; firings go to `orsa/v1/fire/<client>/<id>`.
    Activate {
        /// `single` or `continuous`.
        mode: EventMode,
        /// The CBOR encoding of the parameter object.
        #[serde(with = "serde_bytes_compat")]
        params: Vec<u8>,
        /// The client's zenoh id.
        client: String,
        /// The activation's id within the client.
        id: u64,
    },
    /// End an activation.
    Deactivate {
        /// The client's zenoh id.
        client: String,
        /// The activation's id within the client.
        id: u64,
    },
}

/// CBOR byte strings for `Vec<u8>` (serde would otherwise write an array of integers).
mod serde_bytes_compat {
    use serde::{Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &[u8], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(v)
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Vec<u8>;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
                Ok(v.to_vec())
            }
            fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Vec<u8>, E> {
                Ok(v)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut a: A) -> Result<Vec<u8>, A::Error> {
                let mut out = Vec::new();
                while let Some(b) = a.next_element::<u8>()? {
                    out.push(b);
                }
                Ok(out)
            }
        }
        d.deserialize_bytes(V)
    }
}
