//! 2:1 balance, cross links, point location and well-separated point cells (BET §3).
//!
//! Planned: the minimal balanced refinement of [`crate::quadtree::Quadtree`], built level by
//! level in parallel.
