//! Points for the dynamic edit targets: two bytes a coordinate, mostly on a 1/4096 grid of the
//! unit square (so that points land on sides and close together), sometimes outside it or not
//! finite.

use quadmesh::DVec2;

/// A coordinate from two bytes.
pub fn coordinate(b: &[u8]) -> f64 {
    let v = u16::from_le_bytes([b[0], b[1]]);
    match v >> 13 {
        0 => f64::from(v & 0x0FFF) / 4096.0 + f64::from(v >> 12) * 1e-9,
        1 => f64::from(v & 0x1FFF) / 8191.0,
        2 if v & 0xFF == 0 => f64::NAN,
        2 => 1.0 + f64::from(v & 0xFF) / 256.0,
        _ => f64::from(v) / 65535.0,
    }
}

/// A point from four bytes.
pub fn point(b: &[u8]) -> DVec2 {
    DVec2::new(coordinate(&b[..2]), coordinate(&b[2..4]))
}
