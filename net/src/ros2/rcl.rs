//! `rcl_interfaces` (ROS 2 Jazzy, 2.0): the messages and services of a node's parameters
//! and its log (`/rosout`), laid out field for field like their `.msg` and `.srv` files.
//!
//! The services' RIHS01 hashes are the services' own (REP-2011: the service type described as
//! its request, response and event messages, the event holding Jazzy's
//! `service_msgs/msg/ServiceEventInfo`, whose `client_gid` is `char[16]`). They were computed
//! with `rosbags` (0.11.9) from the Jazzy definitions, the method checked by reproducing the
//! hash ROS 2 Kilted's generated code carries for `GetParameterTypes` (`da199c87...`, with
//! Kilted's `uint8[16]` client gid); `docs/ros2.md` lists them. The test fixture
//! (`tests/python/ros2_node.py`) computes them again on its own.

use super::msg::{Service, Time, message};
use serde::{Deserialize, Serialize};

/// `rcl_interfaces/msg/ParameterType`: what a [`ParameterValue`] holds.
pub mod parameter_type {
    /// No value (a parameter that is not set, or not there).
    pub const NOT_SET: u8 = 0;
    /// `bool_value`.
    pub const BOOL: u8 = 1;
    /// `integer_value`.
    pub const INTEGER: u8 = 2;
    /// `double_value`.
    pub const DOUBLE: u8 = 3;
    /// `string_value`.
    pub const STRING: u8 = 4;
    /// `byte_array_value`.
    pub const BYTE_ARRAY: u8 = 5;
    /// `bool_array_value`.
    pub const BOOL_ARRAY: u8 = 6;
    /// `integer_array_value`.
    pub const INTEGER_ARRAY: u8 = 7;
    /// `double_array_value`.
    pub const DOUBLE_ARRAY: u8 = 8;
    /// `string_array_value`.
    pub const STRING_ARRAY: u8 = 9;
}

/// `rcl_interfaces/msg/ParameterValue`: one value, of the type `kind` says.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterValue {
    /// Which of the fields holds the value ([`parameter_type`]).
    pub kind: u8,
    /// A bool.
    pub bool_value: bool,
    /// An integer.
    pub integer_value: i64,
    /// A float.
    pub double_value: f64,
    /// A string.
    pub string_value: String,
    /// Bytes.
    pub byte_array_value: Vec<u8>,
    /// Bools.
    pub bool_array_value: Vec<bool>,
    /// Integers.
    pub integer_array_value: Vec<i64>,
    /// Floats.
    pub double_array_value: Vec<f64>,
    /// Strings.
    pub string_array_value: Vec<String>,
}

/// `rcl_interfaces/msg/Parameter`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    /// Its name.
    pub name: String,
    /// Its value.
    pub value: ParameterValue,
}

/// `rcl_interfaces/msg/SetParametersResult`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetParametersResult {
    /// Whether the value was set.
    pub successful: bool,
    /// Why not, if it was not.
    pub reason: String,
}

/// `rcl_interfaces/msg/ListParametersResult`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ListParametersResult {
    /// The parameters' names.
    pub names: Vec<String>,
    /// The prefixes of those names (each up to its last `.`).
    pub prefixes: Vec<String>,
}

/// `rcl_interfaces/msg/FloatingPointRange`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FloatingPointRange {
    /// Lowest value.
    pub from_value: f64,
    /// Highest value.
    pub to_value: f64,
    /// Step (0: any).
    pub step: f64,
}

/// `rcl_interfaces/msg/IntegerRange`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct IntegerRange {
    /// Lowest value.
    pub from_value: i64,
    /// Highest value.
    pub to_value: i64,
    /// Step (0: any).
    pub step: u64,
}

/// `rcl_interfaces/msg/ParameterDescriptor`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterDescriptor {
    /// Its name.
    pub name: String,
    /// Its type ([`parameter_type`]).
    pub kind: u8,
    /// What it is.
    pub description: String,
    /// Constraints in words.
    pub additional_constraints: String,
    /// Whether it can be set only at start.
    pub read_only: bool,
    /// Whether its type may change.
    pub dynamic_typing: bool,
    /// Its range, if it is a float with one (at most one).
    pub floating_point_range: Vec<FloatingPointRange>,
    /// Its range, if it is an integer with one (at most one).
    pub integer_range: Vec<IntegerRange>,
}

/// `rcl_interfaces/msg/Log`: one log line, as `/rosout` carries it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Log {
    /// When it was logged.
    pub stamp: Time,
    /// Its level ([`Log::DEBUG`] .. [`Log::FATAL`]).
    pub level: u8,
    /// The logger's name.
    pub name: String,
    /// The line.
    pub msg: String,
    /// The source file it comes from.
    pub file: String,
    /// The function (orsa: the module) it comes from.
    pub function: String,
    /// The source line.
    pub line: u32,
}
message!(Log, "rcl_interfaces", "Log", "e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac");

impl Log {
    /// Debug.
    pub const DEBUG: u8 = 10;
    /// Info.
    pub const INFO: u8 = 20;
    /// Warning.
    pub const WARN: u8 = 30;
    /// Error.
    pub const ERROR: u8 = 40;
    /// Fatal.
    pub const FATAL: u8 = 50;
}

macro_rules! service {
    ($t:ident, $req:ty, $resp:ty, $name:literal, $hash:literal) => {
        #[doc = concat!("`rcl_interfaces/srv/", $name, "`.")]
        #[derive(Debug, Clone, Copy)]
        pub struct $t;
        impl Service for $t {
            type Request = $req;
            type Response = $resp;
            const NAME: &'static str = concat!("rcl_interfaces/srv/", $name);
            const DDS_NAME: &'static str = concat!("rcl_interfaces::srv::dds_::", $name, "_");
            const HASH: &'static str = concat!("RIHS01_", $hash);
        }
    };
}

/// The request of `list_parameters`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ListParametersRequest {
    /// Only names under these (none: every name).
    pub prefixes: Vec<String>,
    /// How many levels below a prefix (0, `DEPTH_RECURSIVE`: all).
    pub depth: u64,
}

/// The response of `list_parameters`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ListParametersResponse {
    /// The names and their prefixes.
    pub result: ListParametersResult,
}

/// The request of `get_parameters`, `describe_parameters` and `get_parameter_types`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NamesRequest {
    /// The parameters.
    pub names: Vec<String>,
}

/// The response of `get_parameters`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetParametersResponse {
    /// One per name asked, in order (`NOT_SET` for one that is not there).
    pub values: Vec<ParameterValue>,
}

/// The request of `set_parameters` and `set_parameters_atomically`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetParametersRequest {
    /// The parameters and their new values.
    pub parameters: Vec<Parameter>,
}

/// The response of `set_parameters`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetParametersResponse {
    /// One per parameter, in order.
    pub results: Vec<SetParametersResult>,
}

/// The response of `set_parameters_atomically`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetParametersAtomicallyResponse {
    /// All were set, or none.
    pub result: SetParametersResult,
}

/// The response of `describe_parameters`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DescribeParametersResponse {
    /// One per name asked, in order.
    pub descriptors: Vec<ParameterDescriptor>,
}

/// The response of `get_parameter_types`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetParameterTypesResponse {
    /// One per name asked ([`parameter_type`]; `NOT_SET` for one that is not there).
    pub types: Vec<u8>,
}

service!(
    ListParameters,
    ListParametersRequest,
    ListParametersResponse,
    "ListParameters",
    "77cd9e25b065d209f959fe4a256238a9c084f779013813dabf820ee61d19569d"
);
service!(
    GetParameters,
    NamesRequest,
    GetParametersResponse,
    "GetParameters",
    "f480322f7e422b77a0443ba06df1c1a19da1a05af3036ce99d7a49463e55e855"
);
service!(
    SetParameters,
    SetParametersRequest,
    SetParametersResponse,
    "SetParameters",
    "775058bdf154f45c0ab006c0cb2aaa2bb9763dd5835be15029de1c2cfe1b8f9f"
);
service!(
    SetParametersAtomically,
    SetParametersRequest,
    SetParametersAtomicallyResponse,
    "SetParametersAtomically",
    "b570fbbe0d6e9ee0d14c7de90321cde7dc6443dbc84b87e1db650bd87fdaded3"
);
service!(
    DescribeParameters,
    NamesRequest,
    DescribeParametersResponse,
    "DescribeParameters",
    "8cbd3c8d1b91530ed2f3126c0d4aa5c6b8715fc18b1e84cf0b422f006e063183"
);
service!(
    GetParameterTypes,
    NamesRequest,
    GetParameterTypesResponse,
    "GetParameterTypes",
    "b04eda09393e9362081284ddc6eaf8720844972a0563044f9bd6d11f93afac23"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::cdr;
    use crate::ros2::msg::Message as _;

    #[test]
    fn names_follow_rmw_zenoh() {
        assert_eq!(ListParameters::DDS_NAME, "rcl_interfaces::srv::dds_::ListParameters_");
        assert_eq!(Log::DDS_NAME, "rcl_interfaces::msg::dds_::Log_");
    }

    /// A `ParameterValue` holding 0.25 as a double, laid out as CDR lays it: the type byte,
    /// the bool, then the int64 and float64 each aligned to 8 from the end of the header,
    /// an empty string (length 1, its NUL) and five empty sequences.
    #[test]
    fn a_parameter_value_encodes_as_cdr_lays_it_out() {
        let v = ParameterValue { kind: parameter_type::DOUBLE, double_value: 0.25, ..Default::default() };
        let mut bytes = Vec::new();
        cdr::encode_named(&v, "ParameterValue", &mut bytes).expect("encodes");
        let mut want = vec![0, 1, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        want.extend(0.25f64.to_le_bytes());
        want.extend([1, 0, 0, 0, 0, 0, 0, 0]);
        for _ in 0..5 {
            want.extend([0, 0, 0, 0]);
        }
        assert_eq!(bytes, want);
        assert_eq!(cdr::decode_named::<ParameterValue>(&bytes, "ParameterValue").expect("decodes"), v);
    }
}
