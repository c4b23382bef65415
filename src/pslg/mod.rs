//! Planar straight-line graphs: cutting acute corners, separating edges, splitting edges at
//! square sides (BET §5).
//!
//! Planned.
