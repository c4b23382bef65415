//! Warping the balanced quadtree onto the points and triangulating its leaves by templates.
//!
//! Planned: BEG's warp with max-min templates (angles in [22.5°, 112.5°]).
