//! What every behaviour offers: the wireable velocity port a master connects to the motors,
//! the status it publishes, and the main state in which it computes.
//!
//! | name | kind | object |
//! |---|---|---|
//! | [`VEL`] | wireable Send port | [`NavigationVelocity`], to [`nomad200::NAVIGATIONVELOCITY`](crate::nomad200::NAVIGATIONVELOCITY) when wired |
//! | [`STATUS`] | Push newest | [`BehaviourStatus`]: what it saw and decided at each step |
//! | [`ACTIVE`] | main state | it computes only while a master keeps it there |
//! | [`COMPUTE`] | substate of [`ACTIVE`] | held for the instant of each step (a critical section) |
//!
//! The behaviours in the default configuration are called [`WALLFOLLOW`] and [`CENTERFOLLOW`].

use crate::nomad200::NavigationVelocity;
use orsa_actors::service::{PushNewestService, SendPortDesc};
use orsa_actors::{Timestamp, comm_object};
use serde::{Deserialize, Serialize};

/// Wall following's name in the default configuration.
pub const WALLFOLLOW: &str = "wallfollow";
/// Center following's name in the default configuration.
pub const CENTERFOLLOW: &str = "centerfollow";

/// Every behaviour's wireable velocity port.
pub const VEL: SendPortDesc<NavigationVelocity> = SendPortDesc::new("vel");
/// What a behaviour saw and decided at each step.
pub const STATUS: PushNewestService<BehaviourStatus> = PushNewestService::new("status");

/// The main state in which a behaviour computes.
pub const ACTIVE: &str = "active";
/// The substate a behaviour holds while it computes and sends.
pub const COMPUTE: &str = "compute";

/// What a behaviour saw and decided at one step (service [`STATUS`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BehaviourStatus {
    /// Stamp of the sensor data the step used.
    pub stamp: Timestamp,
    /// The command it computed.
    pub cmd: NavigationVelocity,
    /// Estimated distance to the followed wall (wall following), m.
    pub wall_m: Option<f64>,
    /// Estimated offset from the corridor centre, positive left of it (center following), m.
    pub offset_m: Option<f64>,
    /// The wall angle the step used, rad.
    pub alpha_rad: f64,
    /// Whether the command left through a wired port.
    pub delivered: bool,
    /// Why it holds back, if it does: an input too old, or from a sensor judged unhealthy
    /// (the behaviour then slows, or stops when none of its inputs is left).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub holding: Option<String>,
}
comm_object!(BehaviourStatus, "orsa.reactive.BehaviourStatus/1");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_round_trips() {
        let status = BehaviourStatus {
            stamp: Timestamp(40_000_000),
            cmd: NavigationVelocity { stamp: Timestamp(40_000_000), v_m_s: 0.25, omega_rad_s: -0.1 },
            wall_m: Some(0.2),
            offset_m: None,
            alpha_rad: 0.05,
            delivered: true,
            holding: Some("infrared judged stuck".into()),
        };
        let json = serde_json::to_string(&status).expect("serialise");
        assert_eq!(serde_json::from_str::<BehaviourStatus>(&json).expect("deserialise"), status);
    }
}
