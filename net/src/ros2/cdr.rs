//! CDR, the encoding of every ROS 2 message payload: a 4-byte encapsulation header (the
//! representation identifier, `00 01` for little-endian plain CDR, `00 00` for big-endian, then
//! two option bytes), then the message in CDR as the `cdr-encoding` crate writes and reads it,
//! aligned from the end of the header.

use super::msg::Message;
use byteorder::{BigEndian, LittleEndian};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The encapsulation header orsa writes: plain CDR, little-endian, no options.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a payload is not a message of the expected type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    /// Shorter than the encapsulation header.
    #[error("{len} bytes: too short for the 4-byte CDR encapsulation header")]
    Short {
        /// The payload's length.
        len: usize,
    },
    /// An encapsulation this decoder does not read (XCDR2, parameter lists).
    #[error("encapsulation {0:#06x} is not plain CDR (0x0000 or 0x0001)")]
    Encapsulation(u16),
    /// The body does not decode as the type.
    #[error("not a {type_name}: {reason}")]
    Body {
        /// The expected type.
        type_name: &'static str,
        /// What the decoder said.
        reason: String,
    },
    /// The message could not be encoded (a sequence longer than CDR's 32-bit length).
    #[error("cannot encode a {type_name}: {reason}")]
    Encode {
        /// The type.
        type_name: &'static str,
        /// What the encoder said.
        reason: String,
    },
}

/// Encodes `msg` into `out` (cleared first): header and body.
pub fn encode_into<T: Message>(msg: &T, out: &mut Vec<u8>) -> Result<(), CdrError> {
    encode_named(msg, T::NAME, out)
}

/// Encodes `msg` (a message, or a service's request or response, named `type_name` in errors)
/// into `out` (cleared first): header and body.
pub(crate) fn encode_named<T: Serialize>(
    msg: &T,
    type_name: &'static str,
    out: &mut Vec<u8>,
) -> Result<(), CdrError> {
    out.clear();
    out.extend_from_slice(&CDR_LE);
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut *out, msg)
        .map_err(|e| CdrError::Encode { type_name, reason: e.to_string() })
}

/// Encodes `msg`: header and body.
pub fn encode<T: Message>(msg: &T) -> Result<Vec<u8>, CdrError> {
    let mut out = Vec::with_capacity(64);
    encode_into(msg, &mut out)?;
    Ok(out)
}

/// Decodes a payload (header and body) as a `T`. Bytes after the message (padding) are ignored.
pub fn decode<T: Message>(payload: &[u8]) -> Result<T, CdrError> {
    decode_named(payload, T::NAME)
}

/// Decodes a payload (header and body) as a `T` named `type_name` in errors.
pub(crate) fn decode_named<T: DeserializeOwned>(
    payload: &[u8],
    type_name: &'static str,
) -> Result<T, CdrError> {
    let Some((header, body)) = payload.split_first_chunk::<4>() else {
        return Err(CdrError::Short { len: payload.len() });
    };
    let body_err = |e: cdr_encoding::Error| CdrError::Body { type_name, reason: e.to_string() };
    match u16::from_be_bytes([header[0], header[1]]) {
        0x0001 => cdr_encoding::from_bytes::<T, LittleEndian>(body).map(|(t, _)| t).map_err(body_err),
        0x0000 => cdr_encoding::from_bytes::<T, BigEndian>(body).map(|(t, _)| t).map_err(body_err),
        other => Err(CdrError::Encapsulation(other)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::msg::*;

    fn scan() -> LaserScan {
        LaserScan {
            header: Header { stamp: Time { sec: 12, nanosec: 34 }, frame_id: "base_link".into() },
            angle_min: 0.0,
            angle_max: 5.89,
            angle_increment: std::f32::consts::FRAC_PI_8,
            time_increment: 0.004,
            scan_time: 0.064,
            range_min: 0.15,
            range_max: 6.5,
            ranges: vec![1.0, f32::INFINITY, f32::NAN, 2.5],
            intensities: vec![],
        }
    }

    /// A Twist is 48 bytes of doubles after the header, aligned from the header's end.
    #[test]
    fn a_twist_is_its_six_doubles() {
        let t = Twist {
            linear: Vector3 { x: 0.25, y: 0.0, z: 0.0 },
            angular: Vector3 { x: 0.0, y: 0.0, z: -0.5 },
        };
        let b = encode(&t).expect("encode");
        assert_eq!(b.len(), 4 + 48);
        assert_eq!(b[..4], CDR_LE);
        assert_eq!(b[4..12], 0.25f64.to_le_bytes());
        assert_eq!(b[44..52], (-0.5f64).to_le_bytes());
        assert_eq!(decode::<Twist>(&b).expect("decode"), t);
    }

    #[test]
    fn messages_round_trip() {
        let s = scan();
        let back = decode::<LaserScan>(&encode(&s).expect("encode")).expect("decode");
        assert_eq!(back.header, s.header);
        assert_eq!(back.ranges.len(), 4);
        assert!(back.ranges[2].is_nan() && back.ranges[1] == f32::INFINITY);
        let mut o = Odometry { child_frame_id: "base_link".into(), ..Default::default() };
        o.pose.covariance.0[35] = 0.1;
        o.pose.pose.orientation = Quaternion::from_yaw(1.0);
        assert_eq!(decode::<Odometry>(&encode(&o).expect("encode")).expect("decode"), o);
        let tf = TfMessage {
            transforms: vec![TransformStamped { child_frame_id: "base_link".into(), ..Default::default() }],
        };
        assert_eq!(decode::<TfMessage>(&encode(&tf).expect("encode")).expect("decode"), tf);
    }

    /// Truncated, garbled, empty and foreign payloads are errors, never panics.
    #[test]
    fn bad_payloads_are_errors() {
        assert_eq!(decode::<Twist>(&[]), Err(CdrError::Short { len: 0 }));
        assert!(matches!(decode::<Twist>(&[0, 7, 0, 0, 1]), Err(CdrError::Encapsulation(7))));
        let full = encode(&scan()).expect("encode");
        for cut in 4..full.len() - 1 {
            let _ = decode::<LaserScan>(&full[..cut]);
        }
        assert!(decode::<Twist>(&full[..20]).is_err());
        // A sequence claiming four thousand million elements.
        let mut huge = CDR_LE.to_vec();
        huge.extend_from_slice(&[0; 8]);
        huge.extend_from_slice(&[1, 0, 0, 0, b'x', 0, 0, 0]);
        huge.extend_from_slice(&[0xff; 64]);
        assert!(decode::<LaserScan>(&huge).is_err());
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for len in 0..400 {
            let mut b = CDR_LE.to_vec();
            for _ in 0..len {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                b.push(x as u8);
            }
            let _ = decode::<LaserScan>(&b);
            let _ = decode::<Odometry>(&b);
            let _ = decode::<TfMessage>(&b);
        }
    }
}
