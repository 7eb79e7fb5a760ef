//! # orsa-net: the patterns across processes and hosts, over zenoh
//!
//! [`ZenohTransport`] implements orsa's [transport seam](orsa_actors::transport): install it on
//! a [`Registry`](orsa_actors::Registry) and every client of that registry reaches services hosted by other processes
//! with the same API as in-process, while services hosted here become reachable by peers.
//! Peers in the same process keep talking through actor mailboxes; zenoh is used only for what
//! crosses a process boundary.
//!
//! | pattern | zenoh entity | key (under `orsa/v1/svc/<component>/<service>/`) |
//! |---|---|---|
//! | Send | publication (express) | `send` |
//! | Query, State, Wiring | queryable | `request` |
//! | Push newest, Push timed | publication per distinct every-n-th (express, newest wins) + queryable for subscription control | `push/<n>`, `subscribe` |
//! | Event | queryable for activation control; firings published to the client | `activate`, `orsa/v1/fire/<client>/<id>` |
//!
//! Discovery and peer loss use liveliness tokens: one per service
//! (`orsa/v1/alive/svc/<host>/<component>/<service>/<pattern>/<types>`) and one per process
//! (`orsa/v1/alive/proc/<zid>/<role>`). When a process disappears, the streams and activations
//! it held are dropped at the source; when a service reappears (its host restarted), clients
//! subscribe and activate again by themselves.
//!
//! Every subscription's every-n-th is counted at the source: a remote subscriber at n = 10
//! receives a stream published at a tenth of the rate. Remote subscribers with the same n
//! share one stream. The wire format is documented in `docs/wire-format.md`.
//!
//! Every message orsa sends carries its sender's zenoh id as the zenoh attachment, so a
//! receiver knows which process (and so which role) it comes from; one-way messages also carry
//! their outlet's number and their own, so a receiver counts what was lost or duplicated on the
//! way ([`LinkLedger`]). That is what
//! [`ZenohTransport::cut_link`] uses to cut this process off from the processes of a role
//! while the zenoh session stays up (fault injection, see [`gate`](ZenohTransport::cut_link)).
//! A process may also publish a heartbeat ([`NetOptions::heartbeat`], [`ZenohTransport::on_heartbeat`])
//! so that a peer notices a silent link faster than zenoh's lease.
//!
//! ## Modules
//!
//! One concern each:
//! - `control`: the control messages peers exchange ([`SubscribeRequest`], [`ActivateRequest`]).
//! - `session`: the zenoh session and discovery ([`ZenohTransport::open`], peers' tokens, [`NetStats`]).
//! - `serve`: offering this process's services to peers (queryables, push streams, activations, outlets).
//! - `transport`: the client side, orsa's `Transport` seam over zenoh (send, request, subscribe, activate).
//! - `gate`: cutting links on purpose ([`ZenohTransport::cut_link`], [`LinkCutStats`]).
//! - `links`: the delivery ledger across processes: numbered messages, counted where they
//!   arrive ([`ZenohTransport::link_ledger`], [`LinkLedger`]).
//! - `heartbeat`: the heartbeat a process publishes and peers watch ([`ZenohTransport::on_heartbeat`]).
//! - `keys`: the key expressions every pattern travels on ([`Keys`]).
//! - `options`: how a process joins the zenoh network ([`NetOptions`], [`NetError`]).
//! - [`ros2`]: ROS 2 topics as rmw_zenoh lays them out (CDR messages, liveliness tokens), so
//!   that an orsa process is also a ROS 2 node ([`ZenohTransport::ros2_node`]).

mod control;
mod gate;
mod heartbeat;
mod keys;
mod links;
mod options;
pub mod ros2;
mod serve;
mod session;
mod transport;

pub use control::{ActivateRequest, SubscribeRequest};
pub use gate::LinkCutStats;
pub use heartbeat::{Heartbeat, HeartbeatWatch};
pub use keys::{Announced, Keys, Process, pattern_name};
pub use links::{Incoming, LinkLedger, MAX_LINK_STREAMS, Outgoing};
pub use options::{NetError, NetOptions};
pub use session::{GONE_RECHECK, NetStats, ZenohTransport};
