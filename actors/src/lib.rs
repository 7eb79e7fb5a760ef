//! # orsa-actors: the framework core
//!
//! orsa builds robot control software out of supervised actors that talk only through a small
//! set of **communication patterns** with fixed semantics, carrying typed **communication
//! objects**. This crate is that core, on [ractor](https://docs.rs/ractor) and tokio.
//!
//! | pattern | file | what it does |
//! |---|---|---|
//! | Send | [`send`] | one-way command |
//! | Query | [`query`] | request/response, awaited or collected later |
//! | Push newest | [`push_newest`] | every subscriber gets each new value |
//! | Push timed | [`push_timed`] | the server produces on its period; `subscribe(n)` gets every n-th |
//! | Event | [`event`] | the server fires when a client's condition holds |
//! | State | [`state`] | a master sets a slave's main state; activities hold substates |
//! | Wiring | [`wiring`] | a master reconnects a component's client ports at run time |
//!
//! [`switch`] makes several Wiring and State changes, across processes, as one all-or-nothing
//! operation (prepare everywhere, then commit in a safe order, undoing on any failure).
//!
//! Around them:
//! - [`CommObject`]: communication objects and their stable identifiers; [`Stamped`]: the
//!   envelope (sequence number, time sent) every object travels in.
//! - [`component`]: a component is a named actor hosting services, ports, state and
//!   subscriptions; a restarted instance keeps all of them.
//! - [`service`]: typed service and port descriptors (a service named once with its pattern and
//!   objects, so a wrong name or type is a compile error); [`addr`]: untyped addresses
//!   (`component/service`) and what a service is ([`ServiceInfo`]), the run-time half of the type
//!   check for addresses a person typed.
//! - [`Registry`]: the directory of one system that resolves addresses; [`transport`]: the seam
//!   for other processes, and [`wire`]: the CBOR encoding of what crosses it.
//! - [`prelude`]: what a component author needs, in one `use`.
//! - [`ledger`]: the delivery ledger, a receipt per message settled once (delivered, lost, ...).
//! - `push` (private): the core Push newest and Push timed share.
//! - `door` (private): where every pattern's messages enter their service; the one place
//!   that shows them to the tap, applies the fault plan and issues delivery receipts.
//! - [`supervision`]: OTP-style supervisors on ractor.
//! - [`clock`]: every period, timeout and stamp runs on tokio's clock, so a paused clock drives
//!   a whole system deterministically; its time model (UNIX time live, zero-based simulated).
//! - [`tap`]: an observer of every message and control event (what recordings are made of).
//! - [`param`]: live parameters, a component's tunable values read and set while it runs
//!   (a Query service of its own, checked as the config file is).
//! - [`fault`]: fault injection (panics, hangs, kills, lost, late and duplicated messages) and
//!   the log of what failed and when it was back.
//! - [`Sink`]: where patterns deliver (a component's [`Mailbox`], a channel, a function);
//!   [`PatternError`]: the status values of every operation.
//!
//! Public modules are the ones whose documentation says how something behaves (each pattern,
//! supervision, the clock's time model, faults, the tap, the ledger, the transport seam and its
//! wire encoding). The plumbing (`comm`, `error`, `registry`, `sink`, `stamped`, `push`, `door`)
//! is private; what of it a user names is re-exported here at the root.

pub mod addr;
pub mod clock;
mod comm;
pub mod component;
mod door;
mod error;
pub mod event;
pub mod fault;
pub mod ledger;
pub mod logbudget;
pub mod param;
pub mod prelude;
mod push;
pub mod push_newest;
pub mod push_timed;
pub mod query;
mod registry;
pub mod send;
pub mod service;
mod sink;
mod stamped;
pub mod state;
pub mod supervision;
pub mod switch;
pub mod tap;
pub mod transport;
pub mod wire;
pub mod wiring;

pub use addr::{PatternKind, ServiceAddr, ServiceInfo};
pub use clock::{Clock, Timestamp, end_of_instant};
pub use comm::{CommObject, Empty};
pub use component::{Component, ComponentError, ComponentHandle, Ctx};
pub use error::{PatternError, PatternResult};
pub use push::PushStats;
pub use registry::{LocalService, Registry};
pub use sink::{Envelope, Mailbox, Sink, Undeliverable};
pub use stamped::{Stamped, Update};
