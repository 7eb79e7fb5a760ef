//! The ROS 2 messages orsa speaks, as serde structs laid out field for field like their `.msg`
//! definitions in ROS 2 Jazzy (`common_interfaces` 5.3, `rcl_interfaces` 2.0, `geometry2` 0.36),
//! so that CDR encodes them as any ROS 2 node does.
//!
//! Each type names itself and its RIHS01 type hash ([`Message`]). The hashes are those of
//! ROS 2 Jazzy: computed per REP-2011 from the type descriptions; `docs/ros2.md` lists them and
//! says where they were checked. Units are ROS's (REP-103): metres, radians, seconds.

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A ROS 2 message type: its name, its DDS name and its type hash.
pub trait Message: Serialize + for<'de> Deserialize<'de> + Send + 'static {
    /// The ROS 2 type name, `package/msg/Type`.
    const NAME: &'static str;
    /// The DDS type name rmw_zenoh puts in key expressions, `package::msg::dds_::Type_`.
    const DDS_NAME: &'static str;
    /// The RIHS01 type hash of the type in ROS 2 Jazzy.
    const HASH: &'static str;
}

/// A ROS 2 service type: its name, its DDS name (what rmw_zenoh puts in key expressions and
/// tokens: the response type's name without `Response_`) and its RIHS01 type hash (the
/// service's own, over its request, response and event messages, REP-2011).
pub trait Service: Send + Sync + 'static {
    /// The request.
    type Request: Serialize + for<'de> Deserialize<'de> + Send + 'static;
    /// The response.
    type Response: Serialize + for<'de> Deserialize<'de> + Send + 'static;
    /// The ROS 2 type name, `package/srv/Type`.
    const NAME: &'static str;
    /// The DDS type name, `package::srv::dds_::Type_`.
    const DDS_NAME: &'static str;
    /// The RIHS01 type hash of the service type in ROS 2 Jazzy.
    const HASH: &'static str;
    /// The largest request served, bytes of CDR: a larger one is refused before it is
    /// decoded (rmw_zenoh caps nothing). 64 KiB holds thousands of parameter names.
    const MAX_REQUEST_BYTES: usize = 64 * 1024;
}

macro_rules! message {
    ($t:ty, $pkg:literal, $name:literal, $hash:literal) => {
        impl $crate::ros2::msg::Message for $t {
            const NAME: &'static str = concat!($pkg, "/msg/", $name);
            const DDS_NAME: &'static str = concat!($pkg, "::msg::dds_::", $name, "_");
            const HASH: &'static str = concat!("RIHS01_", $hash);
        }
    };
}
pub(crate) use message;

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the UNIX epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// The time `ns` nanoseconds after the UNIX epoch (saturated at the largest `sec`).
    pub fn from_nanos(ns: u64) -> Self {
        let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
        Time { sec, nanosec: (ns % 1_000_000_000) as u32 }
    }

    /// Nanoseconds since the UNIX epoch (a negative time gives 0).
    pub fn as_nanos(&self) -> u64 {
        u64::try_from(self.sec).map_or(0, |s| s * 1_000_000_000 + u64::from(self.nanosec))
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame it is expressed in.
    pub frame_id: String,
}

/// `std_msgs/msg/Bool`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Bool {
    /// The value.
    pub data: bool,
}
message!(Bool, "std_msgs", "Bool", "feb91e995ff9ebd09c0cb3d2aed18b11077585839fb5db80193b62d74528f6c9");

/// `sensor_msgs/msg/LaserScan`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Time of the first ray, and the frame of the scan.
    pub header: Header,
    /// Angle of the first ray, rad (counter-clockwise from the frame's x axis).
    pub angle_min: f32,
    /// Angle of the last ray, rad.
    pub angle_max: f32,
    /// Angle between rays, rad.
    pub angle_increment: f32,
    /// Time between rays, s.
    pub time_increment: f32,
    /// Time between scans, s.
    pub scan_time: f32,
    /// Shortest range measured, m.
    pub range_min: f32,
    /// Longest range measured, m.
    pub range_max: f32,
    /// Ranges, m (REP-117: +inf nothing within range, -inf too close, NaN no reading).
    pub ranges: Vec<f32>,
    /// Intensities (may be empty).
    pub intensities: Vec<f32>,
}
message!(
    LaserScan,
    "sensor_msgs",
    "LaserScan",
    "64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828"
);

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Point`.
pub type Point = Vector3;

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// A rotation by `yaw` rad about z.
    pub fn from_yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Quaternion { x: 0.0, y: 0.0, z: s, w: c }
    }

    /// The rotation's yaw about z, rad in [-pi, pi].
    pub fn yaw(&self) -> f64 {
        let siny = 2.0 * (self.w * self.z + self.x * self.y);
        let cosy = 1.0 - 2.0 * (self.y * self.y + self.z * self.z);
        siny.atan2(cosy)
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped`: a pose in a frame, what RViz's "2D Goal Pose" publishes on
/// `/goal_pose`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Header.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}
message!(
    PoseStamped,
    "geometry_msgs",
    "PoseStamped",
    "10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
);

/// A 6x6 covariance, row major (`float64[36]`): a fixed-size array, which CDR writes without a
/// length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, v) in c.iter_mut().enumerate() {
                    *v = seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its covariance.
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/Twist`: what `/cmd_vel` carries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity, m/s (x forward).
    pub linear: Vector3,
    /// Angular velocity, rad/s (z counter-clockwise).
    pub angular: Vector3,
}
message!(Twist, "geometry_msgs", "Twist", "9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a");

/// `geometry_msgs/msg/TwistStamped`: a Twist with a stamp and frame, taken on `/cmd_vel`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Header.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}
message!(
    TwistStamped,
    "geometry_msgs",
    "TwistStamped",
    "5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64"
);

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Its covariance.
    pub covariance: Covariance,
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp, and the frame of the pose (`odom`).
    pub header: Header,
    /// The frame of the twist (`base_link`).
    pub child_frame_id: String,
    /// Pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Velocity in `child_frame_id`.
    pub twist: TwistWithCovariance,
}
message!(
    Odometry,
    "nav_msgs",
    "Odometry",
    "3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
);

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp, and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's pose in the parent's.
    pub transform: Transform,
}

/// `nav_msgs/msg/MapMetaData`: a grid's size, cell and placement.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded.
    pub map_load_time: Time,
    /// The side of a cell, m.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The outer corner of cell (0, 0) in the map frame.
    pub origin: Pose,
}
message!(
    MapMetaData,
    "nav_msgs",
    "MapMetaData",
    "2772d4b2000ef2b35dbaeb80fd3946c1369f817fb4f75677d916d27c17d763c8"
);

/// `nav_msgs/msg/OccupancyGrid`: what `/map` carries (map_server's, transient local). Cells row
/// by row from the origin, -1 unknown, 0 free to 100 occupied.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Header (frame `map`).
    pub header: Header,
    /// Size and placement.
    pub info: MapMetaData,
    /// The cells.
    pub data: Vec<i8>,
}
message!(
    OccupancyGrid,
    "nav_msgs",
    "OccupancyGrid",
    "8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
);

/// `tf2_msgs/msg/TFMessage`: what `/tf` carries.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}
message!(
    TfMessage,
    "tf2_msgs",
    "TFMessage",
    "e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_rmw_zenoh() {
        assert_eq!(Twist::NAME, "geometry_msgs/msg/Twist");
        assert_eq!(Twist::DDS_NAME, "geometry_msgs::msg::dds_::Twist_");
        assert_eq!(TfMessage::DDS_NAME, "tf2_msgs::msg::dds_::TFMessage_");
        for h in [
            Bool::HASH,
            LaserScan::HASH,
            Twist::HASH,
            TwistStamped::HASH,
            Odometry::HASH,
            TfMessage::HASH,
            OccupancyGrid::HASH,
            MapMetaData::HASH,
        ] {
            assert!(h.starts_with("RIHS01_") && h.len() == 7 + 64, "{h}");
            assert!(h[7..].chars().all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase()), "{h}");
        }
    }

    #[test]
    fn times_and_yaws_round_trip() {
        let t = Time::from_nanos(1_700_000_000_123_456_789);
        assert_eq!((t.sec, t.nanosec), (1_700_000_000, 123_456_789));
        assert_eq!(t.as_nanos(), 1_700_000_000_123_456_789);
        assert_eq!(Time { sec: -1, nanosec: 0 }.as_nanos(), 0);
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!((Quaternion::from_yaw(yaw).yaw() - yaw).abs() < 1e-12);
        }
    }
}
