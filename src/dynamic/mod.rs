//! Keeping the quadtree and mesh current under point insertions and deletions by re-running the
//! stages on the Morton intervals an edit touches.
//!
//! Planned.
