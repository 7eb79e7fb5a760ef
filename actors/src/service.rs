//! Service descriptors: a service named once, with its pattern and communication objects, as a
//! typed constant.
//!
//! A component's interface is a list of services, each a pattern plus a communication object.
//! A descriptor is one entry of that list: [`PushTimedService<DistanceScan>`] named
//! `distanceir` says "a Push timed service of `DistanceScan`", and the compiler holds every use
//! to it. Servers declare them ([`Ctx::push_timed_server`](crate::Ctx::push_timed_server)),
//! clients reach them at a component ([`Addr`], from [`on`](PushTimedService::on)), and a
//! wireable port ([`SendPortDesc`]) connects only to a service of its own object. A wrong name,
//! pattern or object type is a compile error, not an `IncompatibleService` at connect time.
//!
//! ```
//! use orsa_actors::service::{Addr, PushTimedService, SendPortDesc, SendService};
//!
//! const SPEED: PushTimedService<f64> = PushTimedService::new("speed");
//! const THROTTLE: SendService<f64> = SendService::new("throttle");
//! const OUT: SendPortDesc<f64> = SendPortDesc::new("out");
//!
//! let speed: Addr<PushTimedService<f64>> = SPEED.on("engine");
//! assert_eq!(speed.to_string(), "engine/speed");
//! assert_eq!(OUT.name(), "out");
//! # let _ = THROTTLE;
//! ```
//!
//! A client of another object type, or a port wired to a service of another object, does not
//! compile:
//!
//! ```compile_fail
//! # use orsa_actors::{Registry, push_timed::PushTimedClient, service::PushTimedService};
//! # fn f(registry: &Registry) {
//! const SPEED: PushTimedService<f64> = PushTimedService::new("speed");
//! let client = PushTimedClient::<u64>::connect(registry, SPEED.on("engine")); // u64 is not f64
//! # }
//! ```
//!
//! ```compile_fail
//! # use orsa_actors::{Registry, push_newest::PushNewestClient, service::PushTimedService};
//! # fn f(registry: &Registry) {
//! const SPEED: PushTimedService<f64> = PushTimedService::new("speed");
//! let client = PushNewestClient::<f64>::connect(registry, SPEED.on("engine")); // not Push newest
//! # }
//! ```
//!
//! ```compile_fail
//! # use orsa_actors::{Registry, wiring::WiringMaster, service::{SendPortDesc, SendService}};
//! # async fn f(registry: &Registry) {
//! const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
//! const COUNT: SendService<u64> = SendService::new("count");
//! WiringMaster::new(registry).connect("behaviour", VEL, COUNT.on("robot")).await; // f64 port, u64 service
//! # }
//! ```
//!
//! Strings remain only where a person types an address (the command line, a config file): there
//! it is parsed once into a [`ServiceAddr`], which every client also accepts and which the
//! registry checks against the descriptor's [`ServiceInfo`] when the client connects.
//!
//! [`PushTimedService<DistanceScan>`]: PushTimedService

use crate::addr::{IntoAddr, PatternKind, ServiceAddr, ServiceInfo};
use crate::comm::CommObject;
use std::fmt;
use std::marker::PhantomData;

/// What every service descriptor tells: its name and what it is.
pub trait Descriptor: Copy + Send + Sync + 'static {
    /// The pattern.
    const PATTERN: PatternKind;
    /// The service's name within its component.
    fn name(&self) -> &'static str;
    /// The pattern and communication object identifiers, as the registry checks them.
    fn info(&self) -> ServiceInfo;
}

/// What service and port descriptors have in common: a name and the types they are of.
macro_rules! named_type {
    (
        $(#[$doc:meta])*
        $name:ident < $($t:ident),+ >, $what:literal
    ) => {
        $(#[$doc])*
        pub struct $name<$($t),+> {
            name: &'static str,
            _types: PhantomData<fn() -> ($($t,)+)>,
        }

        impl<$($t),+> $name<$($t),+> {
            #[doc = concat!("The descriptor of the ", $what, " called `name`.")]
            pub const fn new(name: &'static str) -> Self {
                $name { name, _types: PhantomData }
            }

            #[doc = concat!("The ", $what, "'s name within its component.")]
            pub const fn name(&self) -> &'static str {
                self.name
            }
        }

        impl<$($t),+> Clone for $name<$($t),+> {
            fn clone(&self) -> Self {
                *self
            }
        }

        impl<$($t),+> Copy for $name<$($t),+> {}

        impl<$($t),+> fmt::Debug for $name<$($t),+> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}({})", stringify!($name), self.name)
            }
        }
    };
}

macro_rules! descriptor {
    (
        $(#[$doc:meta])*
        $name:ident < $($t:ident),+ >, $kind:expr
    ) => {
        named_type!($(#[$doc])* $name<$($t),+>, "service");

        impl<$($t),+> $name<$($t),+> {
            /// This service hosted by `component`: the typed address a client connects to.
            pub fn on(self, component: impl Into<String>) -> Addr<Self> {
                Addr { component: component.into(), service: self }
            }
        }

        impl<$($t: CommObject),+> Descriptor for $name<$($t),+> {
            const PATTERN: PatternKind = $kind;
            fn name(&self) -> &'static str {
                self.name
            }
            fn info(&self) -> ServiceInfo {
                ServiceInfo::new($kind, &[$($t::ID),+])
            }
        }
    };
}

descriptor!(
    /// A Send service taking `T` (one-way commands).
    SendService<T>, PatternKind::Send
);
descriptor!(
    /// A Query service answering `Req` with `Ans`.
    QueryService<Req, Ans>, PatternKind::Query
);
descriptor!(
    /// A Push newest service of `T`.
    PushNewestService<T>, PatternKind::PushNewest
);
descriptor!(
    /// A Push timed service of `T`.
    PushTimedService<T>, PatternKind::PushTimed
);
descriptor!(
    /// An Event service: activations carry the parameter `P`, firings the event `E`.
    EventService<P, E>, PatternKind::Event
);

/// A service of kind `D` at a named component: a typed address.
///
/// Made by a descriptor's `on(component)`; every client of kind `D` takes it, and only it (or
/// an untyped [`ServiceAddr`] from outside the program, checked at run time).
#[derive(Clone, PartialEq, Eq)]
pub struct Addr<D> {
    component: String,
    service: D,
}

impl<D: Descriptor> Addr<D> {
    /// The service `service` hosted by `component` (the same as `service.on(component)`).
    pub fn new(component: impl Into<String>, service: D) -> Self {
        Addr { component: component.into(), service }
    }

    /// The component hosting the service.
    pub fn component(&self) -> &str {
        &self.component
    }

    /// The service's descriptor.
    pub fn service(&self) -> D {
        self.service
    }

    /// The untyped address, as it is printed, registered and sent on the wire.
    pub fn untyped(&self) -> ServiceAddr {
        ServiceAddr::new(self.component.clone(), self.service.name())
    }
}

impl<D: Descriptor> fmt::Display for Addr<D> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.component, self.service.name())
    }
}

impl<D: Descriptor> fmt::Debug for Addr<D> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Addr({self})")
    }
}

impl<D: Descriptor> IntoAddr<D> for Addr<D> {
    fn into_addr(self) -> ServiceAddr {
        self.untyped()
    }
}

impl<D: Descriptor> IntoAddr<D> for &Addr<D> {
    fn into_addr(self) -> ServiceAddr {
        self.untyped()
    }
}

/// What a wireable port's descriptor tells: its name and the kind of service it connects to.
pub trait PortDescriptor: Copy + Send + Sync + 'static {
    /// The service descriptor a port of this kind can be wired to.
    type Target: Descriptor;
    /// The port's name within its component.
    fn name(&self) -> &'static str;
}

macro_rules! port_descriptor {
    (
        $(#[$doc:meta])*
        $name:ident < $($t:ident),+ > => $target:ident
    ) => {
        named_type!($(#[$doc])* $name<$($t),+>, "port");

        impl<$($t: CommObject),+> PortDescriptor for $name<$($t),+> {
            type Target = $target<$($t),+>;
            fn name(&self) -> &'static str {
                self.name
            }
        }
    };
}

port_descriptor!(
    /// A wireable port that sends `T`: it connects to a [`SendService<T>`] and no other.
    SendPortDesc<T> => SendService
);
port_descriptor!(
    /// A wireable port that queries `Req` for `Ans`: it connects to a [`QueryService<Req, Ans>`].
    QueryPortDesc<Req, Ans> => QueryService
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::Empty;

    #[test]
    fn descriptors_carry_the_pattern_and_identifiers_the_registry_checks() {
        const GOAL: QueryService<String, u64> = QueryService::new("goal");
        const FIRE: EventService<Empty, bool> = EventService::new("fire");
        assert_eq!(GOAL.info(), ServiceInfo::new(PatternKind::Query, &["orsa.String/1", "orsa.U64/1"]));
        assert_eq!(FIRE.info(), ServiceInfo::new(PatternKind::Event, &["orsa.Empty/1", "orsa.Bool/1"]));
        assert_ne!(
            PushNewestService::<u64>::new("x").info(),
            PushTimedService::<u64>::new("x").info(),
            "the pattern is part of what a client checks"
        );
    }

    #[test]
    fn a_typed_address_prints_and_unwraps_as_the_untyped_one() {
        const SPEED: PushTimedService<f64> = PushTimedService::new("speed");
        let addr = SPEED.on("engine");
        assert_eq!(addr.untyped(), ServiceAddr::new("engine", "speed"));
        assert_eq!(addr.to_string(), "engine/speed");
        assert_eq!(IntoAddr::<PushTimedService<f64>>::into_addr(&addr), addr.untyped());
        assert_eq!(addr.component(), "engine");
        assert_eq!(addr.service().name(), "speed");
    }
}
