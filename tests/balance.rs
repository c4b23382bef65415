//! The parallel balanced tree against the sequential ripple, with its links and point location.

mod common;

use common::{FAMILIES, extreme_wide_keys, on_threads, with_keys};

use quadmesh::DVec2;
use quadmesh::balance::reference::ripple_closure;
use quadmesh::balance::{Links, balance, balance_closure, check_balance, forced_by};
use quadmesh::framework::{NONE, build_framework};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::{Cell, Morton, MortonKey, Side, SortAlgorithm, morton_order};
use quadmesh::quadtree::{Quadtree, expand, from_internal, with_first_points};

fn unbalanced<K: MortonKey>(keys: &[K]) -> Quadtree<K> {
    expand(&build_framework(keys), keys)
}

fn cells<K: MortonKey>(tree: &Quadtree<K>) -> Vec<Cell<K>> {
    tree.internal.iter().map(|s| s.cell).collect()
}

fn assert_balanced_like_the_ripple<K: MortonKey>(keys: &[K]) {
    let tree = unbalanced(keys);
    let balanced = balance(&tree, keys);
    balanced.check(keys).unwrap();
    assert_eq!(
        cells(&balanced.tree),
        ripple_closure(&cells(&tree)),
        "differs from the ripple"
    );
}

fn check_points(pts: &[DVec2]) {
    match morton_order(pts, SortAlgorithm::default()).unwrap() {
        Morton::Narrow(m) => assert_balanced_like_the_ripple(&m.keys),
        Morton::Wide(m) => assert_balanced_like_the_ripple(&m.keys),
    }
}

#[test]
fn every_family_balances_like_the_ripple() {
    for dist in FAMILIES {
        for n in [1, 2, 3, 50, 2000, 30_000] {
            check_points(&points(dist, n, n as u64 + 7));
        }
    }
}

#[test]
fn dyadic_boundaries_and_a_lone_deep_pair() {
    let dyadic: Vec<DVec2> = (0..=8)
        .flat_map(|i| (0..=8).map(move |j| DVec2::new(i as f64 / 8.0, j as f64 / 8.0)))
        .collect();
    check_points(&dyadic);
    let pair = [
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 1.0),
        DVec2::new(0.5, 0.5),
        DVec2::new(0.5 + 1e-9, 0.5),
    ];
    check_points(&pair);
}

#[test]
fn wide_keys_at_the_ends_of_the_key_space_and_below_level_32() {
    let high = 0x9E37_79B9_7F4A_7C15u128 << 64;
    let mut wide = extreme_wide_keys();
    // Keys in one square of level 32, so gaps below it end inside it, and some beside it.
    wide.extend([
        vec![high | 5, high | 9, high | 1 << 40, high | 1 << 63],
        vec![high | 3, high | 1 << 20, (high | 7) + (1 << 64)],
        vec![high - 1, high, high | 1],
    ]);
    for keys in &wide {
        assert_balanced_like_the_ripple(keys);
    }
}

#[test]
fn kuzmin_million_balances() {
    let pts = points(Distribution2d::Kuzmin, 1_000_000, 5);
    let Morton::Wide(m) = morton_order(&pts, SortAlgorithm::default()).unwrap() else {
        panic!("wide grid expected")
    };
    let tree = unbalanced(&m.keys);
    // Squares below level 32, whose anchors need more than 64 bits, and above it.
    assert!(tree.internal.iter().any(|s| s.cell.level > 32));
    let balanced = balance(&tree, &m.keys);
    // The leaves tile the root and hold their points, on both sides of level 32.
    balanced.tree.check(&m.keys).unwrap();
    check_balance(&balanced.tree).unwrap();
    assert_eq!(cells(&balanced.tree), ripple_closure(&cells(&tree)));
    // Links and point location over many chunks; the full check would take too long here.
    let leaves = &balanced.tree.leaves;
    for (p, &j) in balanced.point_leaf.iter().enumerate() {
        assert!(
            (j as usize) < leaves.len() && leaves[j as usize].point == p as u32,
            "point {p} located in {j}"
        );
    }
    for j in (0..leaves.len()).step_by(97) {
        for side in Side::ALL {
            for i in balanced.across(j, side) {
                if i != NONE {
                    assert!(
                        balanced
                            .across(i as usize, side.opposite())
                            .contains(&(j as u32))
                    );
                }
            }
        }
    }
}

fn same_on_one_and_two_threads<K: MortonKey>(keys: &[K]) {
    let tree = unbalanced(keys);
    assert_eq!(
        on_threads(1, || balance(&tree, keys)),
        on_threads(2, || balance(&tree, keys))
    );
}

#[test]
fn one_and_two_threads_balance_identically() {
    for dist in [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
    ] {
        with_keys!(points(dist, 100_000, 3), same_on_one_and_two_threads);
    }
}

fn every_added_split_is_needed<K: MortonKey>(keys: &[K]) {
    let original = cells(&unbalanced(keys));
    let closed = balance_closure(&original);
    assert!(
        closed.len() > original.len(),
        "the input should need balancing"
    );
    for (i, cell) in closed.iter().enumerate() {
        if original.contains(cell) {
            continue;
        }
        // Every added split square is forced by a finer split square of the closure.
        let forced = closed
            .iter()
            .any(|finer| finer.level == cell.level + 1 && forced_by(*finer).contains(&Some(*cell)));
        assert!(forced, "split square {i} {cell:?} is not forced");
        // Removing an added square with no split children leaves an unbalanced tree.
        if !closed
            .iter()
            .any(|c| c.level == cell.level + 1 && c.parent() == *cell)
        {
            let fewer: Vec<Cell<K>> = closed.iter().copied().filter(|c| c != cell).collect();
            let tree = from_internal(with_first_points(&fewer, keys), keys);
            assert!(
                check_balance(&tree).is_err(),
                "removing {cell:?} keeps balance"
            );
        }
    }
}

#[test]
fn no_split_of_the_balanced_tree_can_be_undone() {
    with_keys!(
        points(Distribution2d::Cluster, 3000, 2),
        every_added_split_is_needed
    );
    with_keys!(
        points(Distribution2d::Kuzmin, 2000, 2),
        every_added_split_is_needed
    );
}

fn checkers_catch_corruption<K: MortonKey>(keys: &[K]) {
    let tree = unbalanced(keys);
    assert!(
        check_balance(&tree).is_err(),
        "Kuzmin's unbalanced tree is not balanced"
    );
    let mut balanced = balance(&tree, keys);
    // Leaf 3 made its own west neighbour.
    balanced.links[3] = Links::new([
        [3, NONE],
        balanced.across(3, Side::East),
        balanced.across(3, Side::South),
        balanced.across(3, Side::North),
    ]);
    assert!(balanced.check(keys).is_err(), "corrupted link");
    // Links and locations past the leaves are reported, not followed.
    let past = balanced.tree.leaves.len() as u32;
    for pair in [[past, NONE], [past - 1, past], [past + 7, past + 8]] {
        let mut balanced = balance(&tree, keys);
        let mut sides = Side::ALL.map(|side| balanced.across(3, side));
        sides[3] = pair;
        balanced.links[3] = Links::new(sides);
        assert!(balanced.check(keys).is_err(), "link to {pair:?}");
    }
    let mut balanced = balance(&tree, keys);
    balanced.point_leaf[1] = NONE;
    assert!(balanced.check(keys).is_err(), "unlocated point");
    let mut balanced = balance(&tree, keys);
    balanced.point_leaf.swap(0, 1);
    assert!(balanced.check(keys).is_err(), "swapped point location");
}

#[test]
fn the_checkers_catch_corruption() {
    with_keys!(
        points(Distribution2d::Kuzmin, 2000, 1),
        checkers_catch_corruption
    );
}
