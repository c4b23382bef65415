//! R-trees of a graph's points and segments: the searches of the corner cut (nearest features)
//! and of the graph's separation (features in a box).

use glam::DVec2;
use rstar::RTree;
use rstar::primitives::{GeomWithData, Line};

/// A point, by its index.
pub(crate) type IndexedPoint = GeomWithData<[f64; 2], u32>;
/// A segment, by its index.
pub(crate) type IndexedSegment = GeomWithData<Line<[f64; 2]>, u32>;

/// R-trees of `points` and of `segments` (ends indexing `points`), each item carrying its
/// index; bulk loaded, so the same input gives the same trees.
pub(crate) fn graph_rtrees(
    points: &[DVec2],
    segments: &[[u32; 2]],
) -> (RTree<IndexedPoint>, RTree<IndexedSegment>) {
    let point_tree = RTree::bulk_load(
        points
            .iter()
            .enumerate()
            .map(|(i, p)| GeomWithData::new([p.x, p.y], i as u32))
            .collect(),
    );
    let segment_tree = RTree::bulk_load(
        segments
            .iter()
            .enumerate()
            .map(|(i, &[a, b])| {
                let (a, b) = (points[a as usize], points[b as usize]);
                GeomWithData::new(Line::new([a.x, a.y], [b.x, b.y]), i as u32)
            })
            .collect(),
    );
    (point_tree, segment_tree)
}
