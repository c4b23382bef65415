//! Graphs separated in the quadtree (Bern, Eppstein and Teng's T_B*): the level-parallel
//! crowding tests against a depth-first brute force, the balanced closure against the ripple,
//! every leaf's reach checked by brute force, the same tree on 1 and 2 threads, and graphs the
//! grid cannot separate refused by name.

mod common;

use common::graphs::{delaunay_graph, fan, segment, sliver};
use quadmesh::balance::reference::{graph_crowded_squares, ripple_closure};
use quadmesh::balance::{CLEARANCE, reach, segment_meets_box};
use quadmesh::morton::{Cell, MortonKey};
use quadmesh::pipeline::{GraphTree, GraphTreeBuild, StageTimes, graph_tree};
use quadmesh::pslg::{CleanOptions, CornerCut, clean, cut_acute_corners};
use quadmesh::warp::finest_resolved_level;
use quadmesh::{DVec2, Error, Input};

fn tree_of(input: &Input, clearance: f64) -> Result<(CornerCut, GraphTree), Error> {
    let cut = cut_acute_corners(input)?;
    let tree = graph_tree(&cut, clearance, &mut StageTimes::default())?;
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
            check_build(&cut, a);
        }
        (GraphTree::Wide(a), GraphTree::Wide(b)) => {
            assert_eq!((&a.morton.keys, &a.tree), (&b.morton.keys, &b.tree));
            check_build(&cut, a);
        }
        _ => panic!("1 and 2 threads chose different grids"),
    }
    (cut, one)
}

/// The tree is a valid balanced tree of the features' keys; its split squares are the ripple
/// closure of the crowded squares the brute force finds; and no leaf is crowded.
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
