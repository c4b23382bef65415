//! Well-separated point cells: the parallel rounds against the brute-force fixed point.

mod common;

use common::{FAMILIES, on_threads, with_keys};

use quadmesh::DVec2;
use quadmesh::balance::reference::{
    corner_separated_closure, corner_separated_closure_in, separated_closure,
};
use quadmesh::balance::{
    DomainSides, Separation, check_corner_separated, check_corner_separated_in, check_separated,
    separate, separate_in, separate_with,
};
use quadmesh::framework::build_framework;
use quadmesh::generate::{Distribution2d, points};
use quadmesh::morton::MortonKey;
use quadmesh::quadtree::{Cell, expand};

fn separated_like_brute_force<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let separated = separate(&tree, keys);
    separated.check(keys).unwrap();
    check_separated(&separated.tree, keys).unwrap();
    let cells: Vec<Cell<K>> = separated.tree.internal.iter().map(|s| s.cell).collect();
    assert_eq!(
        cells,
        separated_closure(keys),
        "differs from the brute-force fixed point"
    );
}

#[test]
fn small_inputs_match_the_brute_force_fixed_point() {
    for dist in FAMILIES {
        for n in [1, 2, 3, 10, 120] {
            with_keys!(points(dist, n, n as u64 + 1), separated_like_brute_force);
        }
    }
    let dyadic: Vec<DVec2> = (0..=6)
        .flat_map(|i| (0..=6).map(move |j| DVec2::new(i as f64 / 6.0, j as f64 / 8.0)))
        .collect();
    with_keys!(dyadic, separated_like_brute_force);
    let close = [
        DVec2::ZERO,
        DVec2::ONE,
        DVec2::new(0.5, 0.5),
        DVec2::new(0.5 + 1e-7, 0.5),
    ];
    with_keys!(close, separated_like_brute_force);
}

fn large_and_thread_independent<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let one = on_threads(1, || separate(&tree, keys));
    let two = on_threads(2, || separate(&tree, keys));
    assert_eq!(one, two, "1 and 2 threads differ");
    one.check(keys).unwrap();
    check_separated(&one.tree, keys).unwrap();
}

#[test]
fn larger_inputs_are_separated_identically_on_one_and_two_threads() {
    for dist in [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
    ] {
        with_keys!(points(dist, 20_000, 9), large_and_thread_independent);
    }
}

fn balanced_is_not_separated<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let balanced = quadmesh::balance::balance(&tree, keys);
    assert!(
        check_separated(&balanced.tree, keys).is_err(),
        "a merely balanced tree passed"
    );
}

#[test]
fn the_separation_checker_refuses_a_merely_balanced_tree() {
    with_keys!(
        points(Distribution2d::Uniform, 500, 3),
        balanced_is_not_separated
    );
}

/// Keys from grid coordinates, sorted and distinct.
fn keys_of(coords: impl Iterator<Item = (u64, u64)>) -> Vec<u64> {
    let mut keys: Vec<u64> = coords.map(|(x, y)| u64::encode(x, y)).collect();
    keys.sort_unstable();
    keys.dedup();
    keys
}

#[test]
fn a_chain_of_forced_splits_needs_a_round_per_point_and_still_matches() {
    // Each point's split forces its ring, whose splits crowd the next point's block.
    let row = (0..120u64).map(|i| ((1 << 30) + 3 * i * 4096 + 2048, (1 << 31) + 2048));
    let partner = std::iter::once(((1 << 30) + 2048 + 64, (1 << 31) + 2048));
    separated_like_brute_force(&keys_of(row.chain(partner)));
}

#[test]
fn keys_closer_than_the_guard_levels_do_not_panic() {
    let keys = keys_of([(1 << 31, 1 << 31), ((1 << 31) + 1, 1 << 31)].into_iter());
    let tree = expand(&build_framework(&keys), &keys);
    let separated = separate(&tree, &keys);
    separated.check(&keys).unwrap();
    assert!(
        separated
            .tree
            .leaves
            .iter()
            .all(|l| (l.cell.level as u32) <= u64::AXIS_BITS)
    );
}

fn corner_separated_like_brute_force<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let separated = separate_with(&tree, keys, Separation::Corner);
    separated.check(keys).unwrap();
    check_corner_separated(&separated.tree, keys).unwrap();
    let cells: Vec<Cell<K>> = separated.tree.internal.iter().map(|s| s.cell).collect();
    assert_eq!(
        cells,
        corner_separated_closure(keys),
        "differs from the brute-force fixed point"
    );
}

#[test]
fn corner_separation_matches_its_brute_force_fixed_point() {
    for dist in FAMILIES {
        for n in [1, 2, 3, 10, 120] {
            with_keys!(
                points(dist, n, n as u64 + 1),
                corner_separated_like_brute_force
            );
        }
    }
    // Points on the middle lines of their squares, where the nearest corner is a tie.
    let dyadic: Vec<DVec2> = (0..=6)
        .flat_map(|i| (0..=6).map(move |j| DVec2::new(i as f64 / 6.0, j as f64 / 8.0)))
        .collect();
    with_keys!(dyadic, corner_separated_like_brute_force);
    let close = [
        DVec2::ZERO,
        DVec2::ONE,
        DVec2::new(0.5, 0.5),
        DVec2::new(0.5 + 1e-7, 0.5),
    ];
    with_keys!(close, corner_separated_like_brute_force);
    let row = (0..120u64).map(|i| ((1 << 30) + 3 * i * 4096 + 2048, (1 << 31) + 2048));
    corner_separated_like_brute_force(&keys_of(row));
}

fn corner_separated_on_any_thread_count<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let one = on_threads(1, || separate_with(&tree, keys, Separation::Corner));
    let two = on_threads(2, || separate_with(&tree, keys, Separation::Corner));
    assert_eq!(one, two, "1 and 2 threads differ");
    one.check(keys).unwrap();
    check_corner_separated(&one.tree, keys).unwrap();
    let block = separate(&tree, keys);
    assert!(
        one.tree.leaves.len() * 2 < block.tree.leaves.len(),
        "{} leaves by corners, {} by blocks",
        one.tree.leaves.len(),
        block.tree.leaves.len()
    );
}

#[test]
fn larger_inputs_are_corner_separated_identically_on_one_and_two_threads() {
    for dist in [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
    ] {
        with_keys!(
            points(dist, 20_000, 9),
            corner_separated_on_any_thread_count
        );
    }
}

fn balanced_is_not_corner_separated<K: MortonKey>(keys: &[K]) {
    let tree = expand(&build_framework(keys), keys);
    let balanced = quadmesh::balance::balance(&tree, keys);
    assert!(
        check_corner_separated(&balanced.tree, keys).is_err(),
        "a merely balanced tree passed"
    );
}

#[test]
fn the_corner_checker_refuses_a_merely_balanced_tree() {
    with_keys!(
        points(Distribution2d::Uniform, 500, 3),
        balanced_is_not_corner_separated
    );
}

/// Points on the sides and corners of the unit square and near them, with their keys on the
/// grid of that square: the corner tree cut at the sides, against its brute-force fixed point.
fn corner_separated_on_the_square_like_brute_force(points: &[DVec2]) {
    use quadmesh::SortAlgorithm;
    use quadmesh::morton::{Morton, morton_order_on};
    let frame = Some((
        DVec2::ZERO,
        DVec2::ONE,
        quadmesh::morton::DomainLayout::Root,
    ));
    let Morton::Narrow(m) = morton_order_on(points, frame, SortAlgorithm::default()).unwrap()
    else {
        panic!("narrow grid expected")
    };
    let sides = DomainSides::of(points, &m.order, &m.grid).expect("a given domain");
    assert!(sides.on.iter().any(|&on| on != 0), "no point on a side");
    let tree = expand(&build_framework(&m.keys), &m.keys);
    let (one, band) = on_threads(1, || {
        separate_in(&tree, &m.keys, Some(&sides), u8::MAX, Separation::Corner).unwrap()
    });
    let (two, _) = on_threads(2, || {
        separate_in(&tree, &m.keys, Some(&sides), u8::MAX, Separation::Corner).unwrap()
    });
    assert!(band.is_none());
    assert_eq!(one, two, "1 and 2 threads differ");
    one.check(&m.keys).unwrap();
    check_corner_separated_in(&one.tree, &m.keys, Some(&sides)).unwrap();
    // Without the sides, a block at a side sticks out of the root.
    assert!(check_corner_separated(&one.tree, &m.keys).is_err());
    let cells: Vec<Cell<u64>> = one.tree.internal.iter().map(|s| s.cell).collect();
    assert_eq!(
        cells,
        corner_separated_closure_in(&m.keys, &sides.on),
        "differs from the brute-force fixed point"
    );
}

#[test]
fn corner_separation_on_a_square_cuts_blocks_at_the_sides_the_points_lie_on() {
    let corners = [DVec2::ZERO, DVec2::ONE, DVec2::X, DVec2::Y];
    corner_separated_on_the_square_like_brute_force(&corners);
    for (n, seed) in [(3, 1), (12, 2), (40, 3)] {
        let mut pts = points(Distribution2d::Uniform, n, seed);
        for (k, p) in pts.clone().iter().enumerate().take(n / 2) {
            // Half of them pushed onto a side, some nearly onto one.
            let q = match k % 5 {
                0 => DVec2::new(0.0, p.y),
                1 => DVec2::new(1.0, p.y),
                2 => DVec2::new(p.x, 0.0),
                3 => DVec2::new(p.x, 1.0),
                _ => DVec2::new(p.x, 1e-3),
            };
            pts[k] = q;
        }
        pts.extend(corners);
        pts.extend([
            DVec2::new(0.0, 0.5),
            DVec2::new(1e-3, 0.5),
            DVec2::new(0.0, 0.5 + 1e-3),
        ]);
        corner_separated_on_the_square_like_brute_force(&pts);
    }
}
