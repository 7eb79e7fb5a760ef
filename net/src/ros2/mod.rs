//! ROS 2 over zenoh, natively: orsa's process joins a ROS 2 graph as a node of rmw_zenoh
//! (ROS 2 Jazzy) would, on the same zenoh session as orsa's own traffic, with no bridge.
//!
//! - `msg`: the ROS 2 messages orsa speaks, as serde structs, with their type names and
//!   RIHS01 hashes ([`Message`]).
//! - `cdr`: their encoding, CDR behind the 4-byte encapsulation header ([`encode`], [`decode`]).
//! - `graph`: where they travel: key expressions, liveliness tokens, QoS, attachments.
//! - `node`: a node with its publishers and subscriptions ([`Ros2Node`], [`Ros2Stats`]).
//! - `service`: the services it serves, as rmw_zenoh lays them out ([`Ros2Service`]).
//! - `rcl`: `rcl_interfaces`, a node's parameter services and its log line (`/rosout`).
//!
//! See `docs/ros2.md` for the layout on the wire and what was checked against what.

mod cdr;
mod graph;
pub mod msg;
mod node;
pub mod rcl;
mod service;

pub use cdr::{CDR_LE, CdrError, decode, encode, encode_into};
pub use graph::{NameError, Qos, data_key, qualified_topic, read_attachment, service_key};
pub use msg::{Message, Service};
pub use node::{Either, Ros2Node, Ros2Options, Ros2Publisher, Ros2Stats, Ros2Subscription};
pub use service::{Answer, CallError, Ros2Client, Ros2Service};
