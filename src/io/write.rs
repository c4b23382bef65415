//! Writers. Lines are formatted in parallel blocks and written in order, so the output is the
//! same on any number of threads and tens of millions of lines take a fraction of a second.

use std::io::{self, Write};

use glam::DVec2;
use rayon::prelude::*;

use crate::framework::NONE;
use crate::morton::{Grid, MortonKey};
use crate::options::Input;
use crate::pipeline::{GraphTree, GraphTreeBuild, Tree, TreeBuild};
use crate::quadtree::Leaf;

/// Items formatted per rayon task.
const BLOCK: usize = 1 << 13;
/// Items formatted before their text is written, bounding the memory held at once.
const BATCH: usize = 1 << 20;

/// The header line of [`write_leaves_csv`].
pub const LEAVES_CSV_HEADER: &str = "level,x0,y0,size,point";

/// Writes the leaves of `tree` in Morton order as CSV: the header [`LEAVES_CSV_HEADER`], then
/// `level,x0,y0,size,point` per leaf, where `(x0, y0)` is the lower-left corner and `size` the
/// side of the leaf in input coordinates, and `point` the input index (0-based, in input order)
/// of the point in the leaf, or -1 for an empty leaf.
///
/// Floats are written in Rust's shortest round-trip form, so the output is deterministic and
/// reads back to the exact values. `w` is written in large blocks and needs no buffering.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_leaves_csv<W: Write>(mut w: W, tree: &Tree) -> io::Result<()> {
    writeln!(w, "{LEAVES_CSV_HEADER}")?;
    match tree {
        Tree::Narrow(build) => write_leaves(w, build),
        Tree::Wide(build) => write_leaves(w, build),
    }
}

fn write_leaves<K: MortonKey, W: Write>(w: W, build: &TreeBuild<K>) -> io::Result<()> {
    let order = &build.morton.order;
    leaf_lines(w, &build.morton.grid, &build.final_tree().leaves, |p| {
        order[p as usize]
    })
}

/// Writes the leaves of a graph's separated tree as [`write_leaves_csv`] does; `point` is the
/// index of the leaf's vertex in the cut graph's points
/// ([`crate::pslg::CornerCut::points`]: the input's points, then the cut points), or -1.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_graph_leaves_csv<W: Write>(mut w: W, tree: &GraphTree) -> io::Result<()> {
    writeln!(w, "{LEAVES_CSV_HEADER}")?;
    match tree {
        GraphTree::Narrow(build) => write_graph_leaves(w, build),
        GraphTree::Wide(build) => write_graph_leaves(w, build),
    }
}

fn write_graph_leaves<K: MortonKey, W: Write>(w: W, build: &GraphTreeBuild<K>) -> io::Result<()> {
    let (order, vertices) = (&build.morton.order, &build.vertices);
    leaf_lines(w, &build.morton.grid, &build.tree.tree.leaves, |p| {
        vertices[order[p as usize] as usize]
    })
}

/// One `level,x0,y0,size,point` line per leaf; `point_index` names a leaf's point from its
/// Morton position.
fn leaf_lines<K: MortonKey, W: Write>(
    w: W,
    grid: &Grid,
    leaves: &[Leaf<K>],
    point_index: impl Fn(u32) -> u32 + Sync,
) -> io::Result<()> {
    write_lines(w, leaves, |buf, leaf: &Leaf<K>| {
        let (gx, gy) = leaf.cell.anchor.decode();
        let (corner, size) = grid.cell_rect(gx, gy, leaf.cell.level);
        let point = match leaf.point {
            NONE => -1,
            p => i64::from(point_index(p)),
        };
        writeln!(
            buf,
            "{},{},{},{},{}",
            leaf.cell.level, corner.x, corner.y, size.x, point
        )
    })
}

/// Writes `points` as `x y` lines, in Rust's shortest round-trip float form, so that
/// [`parse_text`](super::parse_text) reads back exactly the same points.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_points<W: Write>(w: W, points: &[DVec2]) -> io::Result<()> {
    write_lines(w, points, |buf, p| writeln!(buf, "{} {}", p.x, p.y))
}

/// Writes `input` as a Triangle `.poly` file that [`parse_poly_input`](super::parse_poly_input)
/// and Triangle read back to the same input: vertices numbered from 0 with no attributes or
/// markers, segments with their markers, the hole seeds, and the regions as
/// `<index> <x> <y> <attribute> <maximum area>` (-1 for no bound). Floats are written in Rust's
/// shortest round-trip form, so they read back exactly. (An input without points gets a header
/// of 0 vertices, which Triangle's format reads as "the vertices are in the `.node` file".)
///
/// # Errors
/// Whatever `w` returns.
pub fn write_input_poly<W: Write>(input: &Input, mut w: W) -> io::Result<()> {
    writeln!(w, "{} 2 0 0", input.points.len())?;
    write_numbered_lines(&mut w, &input.points, |buf, i, p| {
        writeln!(buf, "{i} {} {}", p.x, p.y)
    })?;
    writeln!(w, "{} 1", input.segments.len())?;
    write_numbered_lines(&mut w, &input.segments, |buf, i, s| {
        writeln!(buf, "{i} {} {} {}", s.ends[0], s.ends[1], s.marker)
    })?;
    writeln!(w, "{}", input.holes.len())?;
    write_numbered_lines(&mut w, &input.holes, |buf, i, p| {
        writeln!(buf, "{i} {} {}", p.x, p.y)
    })?;
    writeln!(w, "{}", input.regions.len())?;
    write_numbered_lines(&mut w, &input.regions, |buf, i, r| {
        let area = r.max_area.unwrap_or(-1.0);
        writeln!(buf, "{i} {} {} {} {area}", r.seed.x, r.seed.y, r.attribute)
    })
}

/// Formats `items` with `line` in parallel blocks and writes the blocks in order, then flushes.
fn write_lines<T, W, F>(w: W, items: &[T], line: F) -> io::Result<()>
where
    T: Sync,
    W: Write,
    F: Fn(&mut Vec<u8>, &T) -> io::Result<()> + Sync,
{
    write_numbered_lines(w, items, |buf, _, item| line(buf, item))
}

/// [`write_lines`], with each item's index in `items` passed to `line`.
fn write_numbered_lines<T, W, F>(mut w: W, items: &[T], line: F) -> io::Result<()>
where
    T: Sync,
    W: Write,
    F: Fn(&mut Vec<u8>, usize, &T) -> io::Result<()> + Sync,
{
    for (b, batch) in items.chunks(BATCH).enumerate() {
        let blocks: Vec<io::Result<Vec<u8>>> = batch
            .par_chunks(BLOCK)
            .enumerate()
            .map(|(k, block)| {
                let first = b * BATCH + k * BLOCK;
                let mut buf = Vec::with_capacity(block.len() * 48);
                (block.iter().enumerate())
                    .try_for_each(|(i, item)| line(&mut buf, first + i, item))?;
                Ok(buf)
            })
            .collect();
        for block in blocks {
            w.write_all(&block?)?;
        }
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_tree;

    fn csv_of(points: &[DVec2]) -> String {
        let (tree, _) = build_tree(points, &crate::TreeOptions::default()).unwrap();
        let mut out = Vec::new();
        write_leaves_csv(&mut out, &tree).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn single_point_is_the_root_leaf() {
        let csv = csv_of(&[DVec2::new(3.0, 4.0)]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], LEAVES_CSV_HEADER);
        assert_eq!(lines.len(), 2);
        assert!(
            lines[1].starts_with("0,") && lines[1].ends_with(",0"),
            "{}",
            lines[1]
        );
    }

    #[test]
    fn two_points_split_the_root_and_name_input_indices() {
        let csv = csv_of(&[DVec2::new(1.0, 1.0), DVec2::new(0.0, 0.0)]);
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
            .collect();
        let mut points: Vec<f64> = rows.iter().map(|r| r[4]).filter(|&p| p >= 0.0).collect();
        points.sort_by(f64::total_cmp);
        assert_eq!(points, vec![0.0, 1.0]);
        // The root has side 2 (twice the extent) and the points lie in different quadrants.
        assert_eq!(rows.len(), 4);
        assert!(rows.iter().all(|r| r[0] == 1.0 && r[3] == 1.0));
        for r in &rows {
            if r[4] == 0.0 {
                assert!(r[1] <= 1.0 && 1.0 < r[1] + r[3] && r[2] <= 1.0 && 1.0 < r[2] + r[3]);
            }
        }
    }

    #[test]
    fn points_round_trip_through_text() {
        let points = crate::generate::points(crate::generate::Distribution2d::Kuzmin, 3000, 5);
        let mut out = Vec::new();
        write_points(&mut out, &points).unwrap();
        let back = super::super::parse_text(std::str::from_utf8(&out).unwrap(), "t").unwrap();
        assert_eq!(back, points);
    }

    #[test]
    fn inputs_round_trip_through_poly() {
        use crate::generate::{block_with_holes, nested_curves};
        use crate::options::RegionSeed;
        let mut bounded = block_with_holes(5, 2);
        bounded.regions.push(RegionSeed {
            seed: DVec2::new(0.1, 0.1),
            attribute: -2.5,
            max_area: Some(0.125),
        });
        for input in [nested_curves(3 * BLOCK, 1), bounded] {
            let mut out = Vec::new();
            write_input_poly(&input, &mut out).unwrap();
            let text = std::str::from_utf8(&out).unwrap();
            let back = super::super::parse_poly_input(text, "t").unwrap();
            assert_eq!(back, input);
        }
    }

    #[test]
    fn many_blocks_are_written_in_order() {
        let points: Vec<DVec2> = (0..3 * BLOCK + 7)
            .map(|i| DVec2::new(i as f64, 0.5))
            .collect();
        let mut out = Vec::new();
        write_points(&mut out, &points).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.lines()
                .enumerate()
                .all(|(i, l)| l == format!("{i} 0.5"))
        );
    }
}
