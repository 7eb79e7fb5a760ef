//! Recording runs as MCAP (being written).
