//! Graphs separated in the quadtree (Bern, Eppstein and Teng's T_B*): the level-parallel
//! crowding tests against a depth-first brute force, the balanced closure against the ripple,
//! every leaf's reach checked by brute force, the same tree on 1 and 2 threads, and graphs the
//! grid cannot separate refused by name.

mod common;

use common::graphs::{delaunay_graph, fan, segment, sliver};
use quadmesh::balance::reference::{graph_crowded_squares, ripple_closure};
use quadmesh::balance::{CLEARANCE, reach, segment_meets_box};
use quadmesh::morton::{Cell, MortonKey};
use quadmesh::pipeline::{GraphTree, GraphTreeBuild, GraphTreeOptions, StageTimes, graph_tree};
use quadmesh::pslg::{CleanOptions, CornerCut, clean, cut_acute_corners};
use quadmesh::warp::{finest_resolved_level, square_box};
use quadmesh::{DVec2, Error, Input};

fn tree_of(input: &Input, clearance: f64) -> Result<(CornerCut, GraphTree), Error> {
    let cut = cut_acute_corners(input)?;
    let options = GraphTreeOptions {
        clearance,
        max_squares: None,
    };
    let tree = graph_tree(&cut, options, &mut StageTimes::default())?;
    Ok((cut, tree))
}

/// Builds on one and two threads, checks both agree and every property; returns the build.
fn tree_checked(input: &Input) -> (CornerCut, GraphTree) {
    tree_checked_at(input, CLEARANCE)
}

/// [`tree_checked`] with reaches of `clearance` sides.
fn tree_checked_at(input: &Input, clearance: f64) -> (CornerCut, GraphTree) {
    let (cut, one) = common::on_threads(1, || tree_of(input, clearance)).expect("a tree");
    let (_, two) = common::on_threads(2, || tree_of(input, clearance)).expect("a tree");
    match (&one, &two) {
        (GraphTree::Narrow(a), GraphTree::Narrow(b)) => {
            assert_eq!((&a.morton.keys, &a.tree), (&b.morton.keys, &b.tree));
            assert_eq!(a.pieces, b.pieces);
            check_build(&cut, a);
        }
        (GraphTree::Wide(a), GraphTree::Wide(b)) => {
            assert_eq!((&a.morton.keys, &a.tree), (&b.morton.keys, &b.tree));
            assert_eq!(a.pieces, b.pieces);
            check_build(&cut, a);
        }
        _ => panic!("1 and 2 threads chose different grids"),
    }
    (cut, one)
}

/// The tree is a valid balanced tree of the features' keys; its split squares are the ripple
/// closure of the crowded squares the brute force finds; no leaf is crowded; and the edges'
/// pieces are right.
fn check_build<K: MortonKey>(cut: &CornerCut, build: &GraphTreeBuild<K>) {
    let points: Vec<DVec2> = build
        .vertices
        .iter()
        .map(|&v| cut.points[v as usize])
        .collect();
    // Every cut graph edge is an edge of the features, and only the enclosed vertices are left
    // out.
    assert_eq!(build.edges.len(), cut.edges.len());
    for (e, f) in build.edges.iter().zip(&cut.edges) {
        assert_eq!(e.map(|v| build.vertices[v as usize]), f.ends);
    }
    assert_eq!(build.vertices.len() + cut.enclosed.len(), cut.points.len());
    build
        .tree
        .check(&build.morton.keys)
        .expect("a valid balanced tree");
    check_pieces(&points, build);
    let grid = &build.morton.grid;
    let finest = finest_resolved_level::<K>(false);
    let clearance = (build.clearance, finest);
    let crowded = graph_crowded_squares::<K>(grid, &points, &build.edges, clearance)
        .expect("separable by the brute force too");
    assert_eq!(build.crowded, crowded.len());
    let split: Vec<Cell<K>> = build.tree.tree.internal.iter().map(|s| s.cell).collect();
    assert_eq!(split, ripple_closure(&crowded), "not the balanced closure");
    for leaf in &build.tree.tree.leaves {
        let (lo, hi) = reach(grid, leaf.cell, build.clearance);
        let inside: Vec<u32> = (0..points.len() as u32)
            .filter(|&v| points[v as usize].cmpge(lo).all() && points[v as usize].cmple(hi).all())
            .collect();
        let met: Vec<[u32; 2]> = build
            .edges
            .iter()
            .copied()
            .filter(|&[a, b]| segment_meets_box(points[a as usize], points[b as usize], lo, hi))
            .collect();
        let cell = leaf.cell;
        for (i, e) in met.iter().enumerate() {
            for f in &met[i + 1..] {
                assert!(
                    e.iter().any(|v| f.contains(v)),
                    "leaf {cell:?} sees edges {e:?} and {f:?}"
                );
            }
        }
        match inside[..] {
            [] => {}
            [v] => assert!(
                met.iter().all(|e| e.contains(&v)),
                "leaf {cell:?} sees vertex {v} and edges {met:?}"
            ),
            _ => panic!("leaf {cell:?} sees vertices {inside:?}"),
        }
    }
}

/// Each edge's pieces cover it from end to end, one starting exactly where the one before
/// ends, each inside its leaf's box (up to rounding); two pieces in one leaf belong to edges
/// with a common end.
fn check_pieces<K: MortonKey>(points: &[DVec2], build: &GraphTreeBuild<K>) {
    let pieces = &build.pieces;
    assert_eq!(pieces.at.len(), build.edges.len() + 1);
    let mut in_leaf: Vec<Vec<usize>> = vec![Vec::new(); build.tree.tree.leaves.len()];
    for (e, &[a, b]) in build.edges.iter().enumerate() {
        let (a, b) = (points[a as usize], points[b as usize]);
        let row = pieces.of(e);
        assert!(!row.is_empty(), "edge {e} has no piece");
        assert_eq!((row[0].from, row[row.len() - 1].to), (0.0, 1.0), "edge {e}");
        for (i, piece) in row.iter().enumerate() {
            assert!(piece.from < piece.to, "edge {e}: an empty piece");
            if i > 0 {
                assert_eq!(
                    row[i - 1].to,
                    piece.from,
                    "edge {e}: pieces {} and {i} part",
                    i - 1
                );
            }
            let (lo, hi) = square_box(
                &build.morton.grid,
                build.tree.tree.leaves[piece.leaf as usize].cell,
            );
            let slack = DVec2::splat(8.0 * f64::EPSILON * lo.abs().max(hi.abs()).max_element());
            for t in [piece.from, piece.to] {
                let p = a + (b - a) * t;
                assert!(
                    p.cmpge(lo - slack).all() && p.cmple(hi + slack).all(),
                    "edge {e}: piece {i} at {p} leaves its leaf [{lo}, {hi}]"
                );
            }
            in_leaf[piece.leaf as usize].push(e);
        }
    }
    for (leaf, edges) in in_leaf.iter().enumerate() {
        for (i, &e) in edges.iter().enumerate() {
            for &f in &edges[i + 1..] {
                let (e, f) = (build.edges[e], build.edges[f]);
                assert!(
                    e.iter().any(|v| f.contains(v)),
                    "leaf {leaf} holds {e:?} and {f:?}"
                );
            }
        }
    }
}

fn leaves(tree: &GraphTree) -> usize {
    match tree {
        GraphTree::Narrow(b) => b.tree.tree.leaves.len(),
        GraphTree::Wide(b) => b.tree.tree.leaves.len(),
    }
}

#[test]
fn cut_graphs_separate_as_the_brute_force_says() {
    for input in [
        delaunay_graph(3, 1),
        delaunay_graph(60, 2),
        fan(5),
        fan(16),
        sliver(30.0),
        sliver(1.0),
        quadmesh::generate::block_with_holes(12, 3),
        quadmesh::generate::nested_curves(200, 4),
    ] {
        let (_, tree) = tree_checked(&input);
        assert!(matches!(tree, GraphTree::Narrow(_)));
        // A smaller clearance asks for fewer squares.
        let (_, near) = tree_checked_at(&input, 1.0);
        assert!(leaves(&near) > 4 && leaves(&near) <= leaves(&tree));
    }
}

/// A plus whose arms lie on grid lines of the square around it (x = 0.5 and y = 0.5 of
/// [-0.5, 1.5]²), and a diagonal through grid vertices: pieces on leaves' sides and through
/// their corners.
fn on_grid_lines() -> Input {
    let points = [
        (0.5, 0.5),
        (0.0, 0.5),
        (1.0, 0.5),
        (0.5, 0.0),
        (0.5, 1.0),
        (0.0, 0.0),
        (0.25, 0.25),
    ];
    Input {
        points: points.iter().map(|&(x, y)| DVec2::new(x, y)).collect(),
        segments: [[0, 1], [0, 2], [0, 3], [0, 4], [5, 6]]
            .map(segment)
            .to_vec(),
        ..Input::default()
    }
}

#[test]
fn edges_on_grid_lines_and_through_grid_vertices_are_cut_once() {
    let input = on_grid_lines();
    let (cut, tree) = tree_checked(&input);
    assert!(cut.caps.is_empty(), "right angles are not cut");
    let GraphTree::Narrow(build) = tree else {
        panic!("the narrow grid resolves it");
    };
    let grid = &build.morton.grid;
    assert_eq!(grid.vertex(1u128 << 30, 0).x, 0.0, "x = 0 is a grid line");
    // An arm on the line y = 0.5 lies in the leaves above it, never below.
    for e in 0..2 {
        for piece in build.pieces.of(e) {
            let (lo, _) = square_box(grid, build.tree.tree.leaves[piece.leaf as usize].cell);
            assert_eq!(lo.y, 0.5, "arm {e} in a leaf from {lo}");
        }
    }
}

#[test]
fn loose_points_and_a_lone_segment_separate_too() {
    let points = Input {
        points: vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.3),
            DVec2::new(0.2, 0.9),
        ],
        ..Input::default()
    };
    tree_checked(&points);
    let lone = Input {
        points: vec![DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.3)],
        segments: vec![segment([0, 1])],
        ..Input::default()
    };
    tree_checked(&lone);
}

#[test]
fn triangle_examples_separate() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("skipped: the Python package `triangle` is not installed");
        return;
    };
    for name in ["A", "face", "double_hex", "box"] {
        let text = std::fs::read_to_string(dir.join(format!("{name}.poly"))).expect("the example");
        let read = quadmesh::io::parse_poly_input(&text, name).expect("a graph");
        let (input, _) = clean(&read, CleanOptions::default()).expect("a clean graph");
        tree_checked(&input);
    }
}

/// A vertex `gap` above the middle of a segment it does not end, a unit away from the rest.
fn vertex_over_segment(gap: f64) -> Input {
    Input {
        points: vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.5, gap),
        ],
        segments: vec![segment([0, 1])],
        ..Input::default()
    }
}

#[test]
fn features_too_close_for_the_narrow_grid_go_to_the_wide_one() {
    let (_, tree) = tree_checked(&vertex_over_segment(1e-11));
    assert!(matches!(tree, GraphTree::Wide(_)));
}

#[test]
fn features_too_close_for_the_wide_grid_are_refused_by_name() {
    match tree_of(&vertex_over_segment(1e-25), CLEARANCE) {
        Err(Error::Inseparable { a, b, .. }) => {
            let mut pair = [a, b];
            pair.sort_unstable();
            assert_eq!(
                pair,
                [0, 2],
                "the segment (by its first end) and the vertex"
            );
        }
        other => panic!("expected the pair refused, got {other:?}"),
    }
}

#[test]
fn a_tree_past_its_square_budget_is_refused() {
    // Beyond the cap at its 0.1° tip, the sliver's long sides must be kept apart all along.
    let cut = cut_acute_corners(&sliver(0.1)).expect("a cut");
    let free = graph_tree(
        &cut,
        GraphTreeOptions::default(),
        &mut StageTimes::default(),
    )
    .expect("a tree");
    let crowded = match &free {
        GraphTree::Narrow(b) => b.crowded,
        GraphTree::Wide(b) => b.crowded,
    };
    assert!(crowded > 10_000, "{crowded} crowded squares");
    for (limit, refused) in [(crowded - 1, true), (crowded, false), (1_000, true)] {
        let options = GraphTreeOptions {
            max_squares: Some(limit),
            ..GraphTreeOptions::default()
        };
        match graph_tree(&cut, options, &mut StageTimes::default()) {
            Err(Error::SquareBudget { limit: l, .. }) => assert!(refused && l == limit),
            Ok(_) => assert!(!refused, "{limit} squares allowed, {crowded} needed"),
            Err(e) => panic!("unexpected {e}"),
        }
    }
}
