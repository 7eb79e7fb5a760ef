//! What a component author needs, in one `use orsa_actors::prelude::*;`.
//!
//! The [`Component`] trait and its [`Ctx`], the envelope types messages arrive in, the service
//! and port descriptors, the client and server handles a component keeps in its state, and the
//! status values every operation answers with.

pub use crate::clock::{Clock, Timestamp};
pub use crate::comm::{CommObject, Empty};
pub use crate::comm_object;
pub use crate::component::{Component, ComponentError, ComponentHandle, Ctx};
pub use crate::error::{PatternError, PatternResult};
pub use crate::event::{EventClient, EventMode, EventServer, Fired};
pub use crate::push_newest::{PushNewestClient, PushNewestServer};
pub use crate::push_timed::{PushTimedClient, PushTimedServer, Tick};
pub use crate::query::{QueryClient, QueryRequest, QueryServer};
pub use crate::registry::Registry;
pub use crate::send::{SendClient, SendServer};
pub use crate::service::{
    Addr, EventService, PushNewestService, PushTimedService, QueryPortDesc, QueryService, SendPortDesc,
    SendService,
};
pub use crate::stamped::{Stamped, Update};
pub use crate::state::{StateMaster, StateSpec};
pub use crate::wiring::{QueryPort, SendPort, WiringMaster};
