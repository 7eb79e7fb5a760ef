//! orsa-actors: the framework core (work in progress this session).
pub mod clock;
pub mod comm;
pub mod supervision;
pub use clock::{Clock, Timestamp};
pub use comm::{CommObject, Empty};
