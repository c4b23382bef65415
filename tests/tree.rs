//! The parallel Morton order, framework and unbalanced quadtree against the sequential
//! reference, on every input family, on one and two threads.

mod common;

use common::{FAMILIES, extreme_wide_keys, on_threads};

use proptest::prelude::*;
use quadmesh::balance::point_leaves;
use quadmesh::framework::{self, Framework, NONE};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::{Morton, MortonKey, SortAlgorithm, morton_order};
use quadmesh::quadtree::index::{LEAF, children, path_to};
use quadmesh::quadtree::reference::build_reference;
use quadmesh::quadtree::{Cell, Quadtree, expand, indexed_from_internal, points_in};
use quadmesh::{DVec2, Tree, TreeOptions, build_tree};

/// The framework read off the reference tree: internal squares with two or more non-empty
/// children, each linked to its deepest such ancestor.
fn reference_framework<K: MortonKey>(
    tree: &Quadtree<K>,
    keys: &[K],
) -> Vec<(Cell<K>, Option<Cell<K>>)> {
    let branching = |c: &Cell<K>| {
        let held = points_in(*c, keys);
        keys[held.start].cell_anchor(c.level + 1) != keys[held.end - 1].cell_anchor(c.level + 1)
    };
    let nodes: Vec<Cell<K>> = tree
        .internal
        .iter()
        .map(|s| s.cell)
        .filter(branching)
        .collect();
    nodes
        .iter()
        .map(|c| {
            let parent = (0..c.level)
                .rev()
                .map(|l| Cell::containing(c.anchor, l))
                .find(|a| nodes.contains(a));
            (*c, parent)
        })
        .collect()
}

fn framework_pairs<K: MortonKey>(fw: &Framework<K>) -> Vec<(Cell<K>, Option<Cell<K>>)> {
    let cell = |u: usize| fw.nodes[u].cell;
    (0..fw.len())
        .map(|u| {
            (
                cell(u),
                (fw.parent[u] != NONE).then(|| cell(fw.parent[u] as usize)),
            )
        })
        .collect()
}

fn assert_matches_reference<K: MortonKey>(keys: &[K]) {
    let fw = framework::build_framework(keys);
    framework::check(&fw, keys).unwrap();
    let tree = expand(&fw, keys);
    tree.check_unbalanced(keys).unwrap();
    let reference = build_reference(keys);
    reference.check_unbalanced(keys).unwrap();
    assert_eq!(tree, reference, "quadtree differs from the reference");
    assert_index_matches(&tree, keys);
    assert_eq!(
        framework_pairs(&fw),
        reference_framework(&reference, keys),
        "framework differs"
    );
}

/// The children and point location written with the leaves equal those found from the tree
/// afterwards, and say what they claim: each child lies in its quadrant of its parent, each
/// point in its leaf.
fn assert_index_matches<K: MortonKey>(tree: &Quadtree<K>, keys: &[K]) {
    let indexed = indexed_from_internal(tree.internal.clone(), keys);
    assert_eq!(&indexed.tree, tree);
    assert_eq!(indexed.point_leaf, point_leaves(tree));
    if tree.internal.is_empty() {
        assert!(indexed.children.is_empty());
        return;
    }
    assert_eq!(indexed.children, children(tree));
    for (i, row) in indexed.children.iter().enumerate() {
        let parent = tree.internal[i].cell;
        for (q, &child) in row.iter().enumerate() {
            let cell = if child & LEAF != 0 {
                tree.leaves[(child & !LEAF) as usize].cell
            } else {
                tree.internal[child as usize].cell
            };
            assert_eq!(cell, parent.child(q as u32), "child {q} of square {i}");
        }
    }
    for (p, &j) in indexed.point_leaf.iter().enumerate() {
        assert!(tree.leaves[j as usize].cell.contains(keys[p]), "point {p}");
    }
    // The path to a square names its ancestors, for squares spread over the tree.
    let step = (tree.internal.len() / 97).max(1);
    for i in (0..tree.internal.len()).step_by(step) {
        let cell = tree.internal[i].cell;
        let path = path_to(tree, i);
        for level in 0..cell.level {
            let ancestor = tree.internal[path[level as usize] as usize].cell;
            assert_eq!(ancestor, Cell::containing(cell.anchor, level), "square {i}");
        }
    }
}

fn check_points(pts: &[DVec2]) {
    match morton_order(pts, SortAlgorithm::default()).unwrap() {
        Morton::Narrow(m) => assert_matches_reference(&m.keys),
        Morton::Wide(m) => assert_matches_reference(&m.keys),
    }
}

/// Everything the pipeline produces, as bytes, for comparing runs.
fn fingerprint(tree: &Tree) -> String {
    match tree {
        Tree::Narrow(b) => format!(
            "{:?}{:?}{:?}{:?}",
            b.morton.keys, b.morton.order, b.framework, b.quadtree
        ),
        Tree::Wide(b) => format!(
            "{:?}{:?}{:?}{:?}",
            b.morton.keys, b.morton.order, b.framework, b.quadtree
        ),
    }
}

/// Keys whose gaps shrink or grow geometrically in ramps give long chains of nested squares,
/// and gaps drawn from a few sizes give squares derived by several pairs; at 20 000 keys many
/// chains run across the blocks the framework is built in.
#[test]
fn long_chains_across_blocks_match_the_reference() {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut random_exponent = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % 21) as u32
    };
    let gaps: [Box<dyn FnMut(u64) -> u32>; 3] = [
        Box::new(|i| 20 - (i % 21) as u32),
        Box::new(|i| (i % 21) as u32),
        Box::new(move |_| random_exponent()),
    ];
    for mut exponent in gaps {
        let mut key = 0u64;
        let keys: Vec<u64> = (0..20_000u64)
            .map(|i| {
                key += 1 << (2 * exponent(i));
                key
            })
            .collect();
        assert_matches_reference(&keys);
    }
}

#[test]
fn every_family_matches_the_reference() {
    for dist in FAMILIES {
        for n in [2, 3, 10, 1000, 20_000] {
            check_points(&points(dist, n, n as u64));
        }
    }
}

#[test]
fn kuzmin_at_a_million_needs_and_gets_the_wide_grid() {
    let pts = points(Distribution2d::Kuzmin, 1_000_000, 3);
    let (tree, _) = build_tree(&pts, &TreeOptions::default()).unwrap();
    let Tree::Wide(b) = &tree else {
        panic!("Kuzmin 1e6 should need 64 bits per axis")
    };
    assert_eq!(b.morton.keys.len(), pts.len());
    framework::check(&b.framework, &b.morton.keys).unwrap();
    b.quadtree.check_unbalanced(&b.morton.keys).unwrap();
}

#[test]
fn one_and_two_threads_give_identical_trees() {
    for dist in [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
    ] {
        let pts = points(dist, 200_000, 11);
        let one = on_threads(1, || build_tree(&pts, &TreeOptions::default()).unwrap().0);
        let two = on_threads(2, || build_tree(&pts, &TreeOptions::default()).unwrap().0);
        assert_eq!(fingerprint(&one), fingerprint(&two), "{dist:?}");
    }
}

#[test]
fn all_sorts_give_the_same_tree() {
    let mut pts = points(Distribution2d::Cluster, 50_000, 5);
    pts.extend_from_within(..5000);
    let runs: Vec<String> = [
        SortAlgorithm::Radsort,
        SortAlgorithm::Voracious,
        SortAlgorithm::RayonUnstable,
    ]
    .into_iter()
    .map(|s| fingerprint(&build_tree(&pts, &TreeOptions::default().sort(s)).unwrap().0))
    .collect();
    assert_eq!(runs[0], runs[1]);
    assert_eq!(runs[0], runs[2]);
}

#[test]
fn single_point_is_a_root_leaf() {
    let (tree, _) = build_tree(&[DVec2::new(3.0, -2.0)], &TreeOptions::default()).unwrap();
    let Tree::Narrow(b) = tree else {
        panic!("narrow grid expected")
    };
    assert!(b.framework.is_empty() && b.quadtree.internal.is_empty());
    assert_eq!(b.quadtree.leaves.len(), 1);
    assert_eq!({ b.quadtree.leaves[0].point }, 0);
    b.quadtree.check(&b.morton.keys).unwrap();
}

#[test]
fn all_duplicates_collapse_to_one_point() {
    let pts = vec![DVec2::new(1.0, 1.0); 100];
    let (tree, _) = build_tree(&pts, &TreeOptions::default()).unwrap();
    assert_eq!(tree.duplicates().count, 99);
    let Tree::Narrow(b) = tree else {
        panic!("narrow grid expected")
    };
    assert_eq!(b.quadtree.leaves.len(), 1);
}

#[test]
fn collinear_and_dyadic_boundary_points() {
    let line: Vec<DVec2> = (0..500).map(|i| DVec2::new(i as f64, 0.0)).collect();
    check_points(&line);
    let diagonal: Vec<DVec2> = (0..500).map(|i| DVec2::splat(i as f64 / 512.0)).collect();
    check_points(&diagonal);
    // Points on the lines that split the root into dyadic squares, and their corners.
    let dyadic: Vec<DVec2> = (0..=16)
        .flat_map(|i| (0..=16).map(move |j| DVec2::new(i as f64 / 16.0, j as f64 / 16.0)))
        .collect();
    check_points(&dyadic);
}

#[test]
fn tiny_cluster_far_from_the_rest() {
    let mut pts = points(Distribution2d::Uniform, 1000, 9);
    pts.extend((0..1000).map(|i| DVec2::new(0.3 + i as f64 * 1e-13, 0.7 - i as f64 * 3e-14)));
    check_points(&pts);
}

fn coords() -> impl Strategy<Value = Vec<(f64, f64)>> {
    let coordinate = prop_oneof![
        (0u32..64).prop_map(|v| v as f64),
        (-1.0f64..1.0),
        (0.0f64..1e-6).prop_map(|v| 0.25 + v),
    ];
    prop::collection::vec((coordinate.clone(), coordinate), 1..300)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn random_inputs_match_the_reference(raw in coords()) {
        let mut pts: Vec<DVec2> = raw.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
        pts.extend_from_within(..pts.len() / 3);
        check_points(&pts);
    }
}

#[test]
fn the_checkers_catch_corruption() {
    let pts = points(Distribution2d::Uniform, 2000, 4);
    let Morton::Narrow(m) = morton_order(&pts, SortAlgorithm::default()).unwrap() else {
        panic!("narrow grid expected")
    };
    let keys = &m.keys;
    let fw = framework::build_framework(keys);
    let tree = expand(&fw, keys);

    let mut bad = fw.clone();
    let u = (1..fw.len()).find(|&u| fw.parent[u] != 0).unwrap();
    bad.parent[u] = 0;
    assert!(framework::check(&bad, keys).is_err(), "wrong parent");
    let mut bad = fw.clone();
    let leafy = (1..fw.len())
        .rev()
        .find(|&u| !fw.parent.contains(&(u as u32)))
        .unwrap();
    bad.nodes.remove(leafy);
    bad.parent.remove(leafy);
    for p in bad.parent.iter_mut() {
        if *p != NONE && *p as usize > leafy {
            *p -= 1;
        }
    }
    assert!(framework::check(&bad, keys).is_err(), "missing node");
    let mut bad = fw.clone();
    bad.nodes[7].end -= 1;
    assert!(framework::check(&bad, keys).is_err(), "short interval");
    let mut bad = fw.clone();
    bad.nodes.swap(3, 4);
    assert!(framework::check(&bad, keys).is_err(), "preorder");

    let mut bad = tree.clone();
    bad.leaves.remove(10);
    assert!(bad.check(keys).is_err(), "missing leaf");
    let mut bad = tree.clone();
    let j = bad.leaves.iter().position(|l| l.point != NONE).unwrap();
    bad.leaves[j].point = NONE;
    assert!(bad.check(keys).is_err(), "lost point");
    let mut bad = tree.clone();
    bad.internal.pop();
    assert!(bad.check(keys).is_err(), "missing internal square");
    let mut split_empty = tree.clone();
    let empty_leaf = split_empty
        .leaves
        .iter()
        .position(|l| l.point == NONE)
        .unwrap();
    let cell = split_empty.leaves[empty_leaf].cell;
    split_empty
        .internal
        .push(quadmesh::quadtree::Internal { cell, first: 0 });
    split_empty
        .internal
        .sort_by_key(|s| (s.cell.anchor, s.cell.level));
    assert!(
        split_empty.check_unbalanced(keys).is_err(),
        "needless split"
    );
}

#[test]
fn extreme_keys_match_the_reference() {
    let narrow: Vec<Vec<u64>> = vec![
        vec![0, u64::MAX],
        vec![u64::MAX - 1, u64::MAX],
        vec![0, 1],
        vec![0, 1, 2, 3],
        vec![u64::MAX - 3, u64::MAX - 2, u64::MAX - 1, u64::MAX],
        std::iter::once(0)
            .chain((0..32).map(|k| 1u64 << (2 * k)))
            .collect(),
        (0..65_536u64).collect(),
    ];
    for keys in &narrow {
        assert_matches_reference(keys);
    }
    let mut wide = extreme_wide_keys();
    wide.push((0..4096u128).map(|i| u128::MAX - 4095 + i).collect());
    for keys in &wide {
        assert_matches_reference(keys);
    }
}
