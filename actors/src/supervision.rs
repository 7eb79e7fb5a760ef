//! OTP-style supervision on ractor (being written).
