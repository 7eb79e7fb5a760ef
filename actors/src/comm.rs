//! Communication objects: the typed data that travels through every pattern (see [`CommObject`]).

use serde::{Serialize, de::DeserializeOwned};
use std::fmt::Debug;

/// A type that can travel through a communication pattern: the typed data of every pattern.
///
/// A communication object is a plain serde struct in SI units with unit-suffixed field names
/// (`distance_m`, `omega_rad_s`). Each type carries a stable identifier, [`CommObject::ID`], that
/// says what the bytes mean independently of the Rust type name. A client and a service agree on
/// type when their identifiers are equal; this is how a peer in another process (or another
/// language) is checked, where no Rust `TypeId` exists.
///
/// ```
/// use orsa_actors::{comm_object, CommObject};
/// use serde::{Deserialize, Serialize};
///
/// /// A target distance for a behaviour.
/// #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// pub struct Setpoint {
///     /// Desired distance to the wall.
///     pub distance_m: f64,
/// }
/// comm_object!(Setpoint, "orsa.example.Setpoint/1");
///
/// assert_eq!(Setpoint::ID, "orsa.example.Setpoint/1");
/// ```
///
/// Implement it with [`comm_object!`](crate::comm_object). The identifier has the form
/// `namespace.Name/version`; bump the version whenever the serialised form changes
/// incompatibly.
pub trait CommObject: Serialize + DeserializeOwned + Clone + Debug + Send + Sync + 'static {
    /// The stable identifier of this type, e.g. `orsa.DistanceScan/1`.
    const ID: &'static str;
}

/// Implements [`CommObject`] for a type with the given stable identifier.
#[macro_export]
macro_rules! comm_object {
    ($ty:ty, $id:expr) => {
        impl $crate::CommObject for $ty {
            const ID: &'static str = $id;
        }
    };
}

/// The empty communication object: the answer of a query that only acknowledges, or the
/// parameter of an event that needs none.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Empty {}
comm_object!(Empty, "orsa.Empty/1");

macro_rules! scalar_comm_objects {
    ($($ty:ty => $id:expr),* $(,)?) => { $( comm_object!($ty, $id); )* };
}
scalar_comm_objects!(
    bool => "orsa.Bool/1",
    u64 => "orsa.U64/1",
    i64 => "orsa.I64/1",
    f64 => "orsa.F64/1",
    String => "orsa.String/1",
);

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<T: CommObject + PartialEq>(v: T) {
        let json = serde_json::to_string(&v).expect("serialise");
        let back: T = serde_json::from_str(&json).expect("deserialise");
        assert_eq!(v, back, "{} did not survive a round trip", T::ID);
    }

    #[test]
    fn scalars_and_empty_round_trip() {
        round_trip(Empty {});
        round_trip(true);
        round_trip(42u64);
        round_trip(-7i64);
        round_trip(0.25f64);
        round_trip(String::from("nomad200"));
    }

    #[test]
    fn identifiers_are_distinct() {
        let ids = [Empty::ID, bool::ID, u64::ID, i64::ID, f64::ID, String::ID];
        let set: std::collections::HashSet<_> = ids.iter().collect();
        assert_eq!(set.len(), ids.len());
    }
}
