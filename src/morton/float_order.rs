//! Morton (Z) order on the floats themselves, without a grid: every pair of distinct finite
//! points is ordered, however close together or widely spread they are.
//!
//! Each coordinate maps to a u64 whose unsigned order is the order of the floats (the sign bit
//! is flipped for positive values, every bit for negative ones, and `-0.0` maps like `0.0`). Two
//! points compare on the axis whose keys differ in the most significant bit, x on a tie, as
//! [`super::interleave`] puts the x bit above the y bit: this is the order of the two keys
//! interleaved into one u128 Morton key, a total order, so the points are put in it by the same
//! radix sort of (key, index) pairs as [`super::morton_order`]'s.
//!
//! The curve is a Z-order on the float bit patterns, not on an affine grid. Within a binade of
//! each axis the mantissa bits are a fixed-point grid and the curve is the usual one (the same
//! orientation as [`super::morton_order`]'s); across binades the exponent bits act as coarser
//! levels on a logarithmic scale. The map is monotone per axis, so each quadrant of bit patterns
//! is an axis-aligned box of the plane, and points close in this order stay close in the plane
//! within a binade; that is all an insertion order for short walks needs.

use glam::DVec2;
use rayon::prelude::*;

use super::{
    Duplicates, MortonKey, Pair, SortAlgorithm, SortPairs, duplicates_of, equal_key_runs,
    validate_points,
};
use crate::error::Error;
use crate::par::collect_indexed;

/// Distinct points in Morton order on their float bit patterns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FloatOrder {
    /// The input index of each distinct point (its first occurrence), in Morton order.
    pub order: Vec<u32>,
    /// The exact duplicates merged away, as [`super::morton_order`] reports them.
    pub duplicates: Duplicates,
}

/// Puts `points` into Morton order on their float bit patterns (see the module documentation),
/// merging exact duplicates into their first occurrence.
///
/// Accepts any distinct finite points: there is no grid, so no two distinct points collide.
/// The result is the same on any number of threads.
///
/// # Errors
/// [`Error::Empty`], [`Error::TooManyPoints`], [`Error::NonFinite`] (the first offending index),
/// as [`validate_points`].
///
/// # Complexity
/// O(n) work for the keys plus a radix sort of n (u128, u32) pairs; all steps run on the current
/// rayon pool.
pub fn float_morton_order(points: &[DVec2]) -> Result<FloatOrder, Error> {
    validate_points(points)?;
    let mut pairs: Vec<Pair<u128>> = collect_indexed(points.len(), |i| {
        let p = points[i];
        Pair::new(u128::encode(float_key(p.x), float_key(p.y)), i as u32)
    });
    // Equal keys (equal points) are put in index order, so the result is unique.
    u128::sort_pairs(&mut pairs, SortAlgorithm::Voracious);
    // Equal points are adjacent, in index order: the first of each run is the one kept.
    let runs = equal_key_runs(&pairs);
    let duplicates = duplicates_of(&pairs, &runs);
    let order = if runs.is_empty() {
        collect_indexed(pairs.len(), |i| pairs[i].idx)
    } else {
        (0..pairs.len())
            .into_par_iter()
            .filter(|&i| i == 0 || pairs[i].key != pairs[i - 1].key)
            .map(|i| pairs[i].idx)
            .collect()
    };
    Ok(FloatOrder { order, duplicates })
}

/// A u64 whose unsigned order is the order of the finite float `v`; `-0.0` and `0.0` map alike.
#[inline(always)]
pub fn float_key(v: f64) -> u64 {
    // Adding +0.0 turns -0.0 into 0.0 and leaves every other value as it is.
    let bits = (v + 0.0).to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

#[cfg(test)]
mod tests {
    use std::cmp::Ordering;

    use super::*;
    use crate::generate::{Distribution2d, points as generate};
    use crate::morton::{DUPLICATE_EXAMPLES, Morton, morton_order, morton_order_on};

    /// Whether the most significant bit of `a` is below that of `b`.
    fn less_msb(a: u64, b: u64) -> bool {
        a < b && a < (a ^ b)
    }

    /// Morton order of two `(x key, y key, index)` triples, then index order: a comparator to
    /// check the sorted output against, independent of the interleaving.
    fn z_cmp(a: &(u64, u64, u32), b: &(u64, u64, u32)) -> Ordering {
        let (dx, dy) = (a.0 ^ b.0, a.1 ^ b.1);
        let by_key = if less_msb(dx, dy) {
            a.1.cmp(&b.1)
        } else {
            a.0.cmp(&b.0)
        };
        by_key.then(a.2.cmp(&b.2))
    }

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    /// The (key, index) pairs of the points' interleaved float keys, sorted.
    fn interleaved_order(points: &[DVec2]) -> Vec<Pair<u128>> {
        let mut v: Vec<Pair<u128>> = points
            .par_iter()
            .enumerate()
            .map(|(i, q)| Pair::new(u128::encode(float_key(q.x), float_key(q.y)), i as u32))
            .collect();
        u128::sort_pairs(&mut v, SortAlgorithm::default());
        v
    }

    /// The order and the duplicates of either grid's result.
    fn grid_order(m: &Morton) -> (&[u32], &Duplicates) {
        match m {
            Morton::Narrow(m) => (&m.order, &m.duplicates),
            Morton::Wide(m) => (&m.order, &m.duplicates),
        }
    }

    /// Each point appears once, no two listed points are equal, every input point equals a
    /// listed one, and the list is sorted under the comparator.
    fn assert_valid(points: &[DVec2], f: &FloatOrder) {
        let mut seen = vec![false; points.len()];
        for &i in &f.order {
            assert!(!std::mem::replace(&mut seen[i as usize], true), "{i} twice");
        }
        let key = |i: u32| {
            let p = points[i as usize];
            (float_key(p.x), float_key(p.y), i)
        };
        for w in f.order.windows(2) {
            assert_eq!(z_cmp(&key(w[0]), &key(w[1])), Ordering::Less, "{w:?}");
            assert_ne!(points[w[0] as usize], points[w[1] as usize]);
        }
        assert_eq!(f.order.len() + f.duplicates.count, points.len());
    }

    #[test]
    fn keys_follow_the_float_order() {
        let values = [
            f64::MIN,
            -1e300,
            -1.0,
            -1e-300,
            -f64::MIN_POSITIVE,
            -5e-324,
            0.0,
            5e-324,
            f64::MIN_POSITIVE,
            1e-19,
            0.5,
            1.0,
            f64::MAX,
        ];
        for w in values.windows(2) {
            assert!(float_key(w[0]) < float_key(w[1]), "{w:?}");
        }
        assert_eq!(float_key(-0.0), float_key(0.0));
    }

    #[test]
    fn equals_the_grid_order_within_a_binade() {
        // On [1, 2)^2 the mantissa bits are the grid of the domain [1, 2]^2, so both curves are
        // one and the same, orientation included.
        let p: Vec<DVec2> = generate(Distribution2d::Uniform, 4000, 7)
            .into_iter()
            .map(|q| q + 1.0)
            .filter(|q| q.x < 2.0 && q.y < 2.0)
            .collect();
        let domain = Some((
            DVec2::ONE,
            DVec2::splat(2.0),
            crate::morton::DomainLayout::Root,
        ));
        let m = morton_order_on(&p, domain, SortAlgorithm::default()).unwrap();
        let f = float_morton_order(&p).unwrap();
        assert_eq!(f.order, grid_order(&m).0);
        assert_eq!(f.duplicates.count, 0);
    }

    #[test]
    fn unit_square_order_is_a_sorted_permutation() {
        // On [0, 1]^2 the grid spans the points' extent while the float curve follows the
        // binades of each coordinate (0.25 <= x < 0.5 is one quadrant of bit patterns, but not
        // one of the grid), so the two orders legitimately differ; both are Z curves.
        let p = generate(Distribution2d::Uniform, 5000, 3);
        let f = float_morton_order(&p).unwrap();
        assert_valid(&p, &f);
        assert_eq!(f.order.len(), p.len());
        // Same orientation: the four corners in N order, x bit above y bit.
        let corners = pts(&[(1.0, 1.0), (1.0, 0.0), (0.0, 1.0), (0.0, 0.0)]);
        let f = float_morton_order(&corners).unwrap();
        assert_eq!(f.order, vec![3, 2, 1, 0]);
        let m = morton_order(&corners, SortAlgorithm::default()).unwrap();
        assert_eq!(f.order, grid_order(&m).0);
    }

    #[test]
    fn equals_a_sort_of_the_interleaved_keys() {
        // The comparator is the order of the two keys interleaved into 128 bits, x bit first.
        let mut p = generate(Distribution2d::Cluster, 20_000, 9);
        p.extend_from_within(..500);
        p.push(DVec2::new(-3.0, 1e-300));
        let f = float_morton_order(&p).unwrap();
        let mut sorted = interleaved_order(&p);
        sorted.dedup_by_key(|q| q.key);
        assert_eq!(f.order, sorted.iter().map(|q| q.idx).collect::<Vec<_>>());
        assert_eq!(f.duplicates.count, 500);
        assert_valid(&p, &f);
    }

    #[test]
    fn duplicates_merge_into_the_first_occurrence() {
        let p = pts(&[
            (1.0, 1.0),
            (0.0, 0.0),
            (1.0, 1.0),
            (0.5, 0.25),
            (0.0, 0.0),
            (1.0, 1.0),
        ]);
        let f = float_morton_order(&p).unwrap();
        let m = morton_order(&p, SortAlgorithm::default()).unwrap();
        let (order, duplicates) = grid_order(&m);
        assert_eq!(f.order, order);
        assert_eq!(&f.duplicates, duplicates);
        assert_eq!(f.duplicates.count, 3);
        assert_eq!(f.duplicates.examples, vec![(1, 4), (0, 2), (0, 5)]);
        assert_valid(&p, &f);

        // More duplicates than examples, on random points.
        let mut p = generate(Distribution2d::Uniform, 3000, 5);
        p.extend_from_within(100..1100);
        let f = float_morton_order(&p).unwrap();
        let m = morton_order(&p, SortAlgorithm::default()).unwrap();
        assert_eq!(f.duplicates.count, 1000);
        assert_eq!(f.duplicates.examples.len(), DUPLICATE_EXAMPLES);
        assert_eq!(f.duplicates.count, grid_order(&m).1.count);
        for &(kept, dropped) in &f.duplicates.examples {
            assert_eq!(dropped, kept + 2900);
            assert_eq!(p[kept as usize], p[dropped as usize]);
        }
        assert_valid(&p, &f);
        let mut kept = f.order.clone();
        kept.sort_unstable();
        assert_eq!(kept, (0..3000).collect::<Vec<u32>>());
    }

    #[test]
    fn points_no_grid_separates_are_ordered() {
        // 1e-19 apart around 0, next to points at distance 1.
        let mut p = pts(&[(1.0, 1.0), (-1.0, 0.5)]);
        p.extend(
            (-20..20)
                .flat_map(|i| (-3..3).map(move |j| DVec2::new(i as f64 * 1e-19, j as f64 * 1e-19))),
        );
        assert!(matches!(
            morton_order(&p, SortAlgorithm::default()),
            Err(Error::Inseparable { .. })
        ));
        let f = float_morton_order(&p).unwrap();
        assert_eq!(f.order.len(), p.len());
        assert_eq!(f.duplicates.count, 0);
        assert_valid(&p, &f);

        // A logarithmic spiral from radius 1 down to 1e-19.
        let turns = 10.0;
        let n = 20_000;
        let t_end = 1e-19f64.ln().abs();
        let p: Vec<DVec2> = (0..n)
            .map(|i| {
                let t = t_end * i as f64 / (n - 1) as f64;
                let angle = std::f64::consts::TAU * turns * t / t_end;
                (-t).exp() * DVec2::new(angle.cos(), angle.sin())
            })
            .collect();
        assert!(matches!(
            morton_order(&p, SortAlgorithm::default()),
            Err(Error::Inseparable { .. })
        ));
        let f = float_morton_order(&p).unwrap();
        assert_eq!(f.order.len(), n);
        assert_valid(&p, &f);
    }

    #[test]
    fn negative_and_positive_zero_are_one_point() {
        let p = pts(&[
            (0.0, 1.0),
            (-0.0, 1.0),
            (0.5, -0.0),
            (0.5, 0.0),
            (-0.0, -0.0),
        ]);
        let f = float_morton_order(&p).unwrap();
        assert_eq!(f.duplicates.count, 2);
        let mut kept = f.order.clone();
        kept.sort_unstable();
        assert_eq!(kept, vec![0, 2, 4]);
        assert!(f.duplicates.examples.contains(&(0, 1)));
        assert!(f.duplicates.examples.contains(&(2, 3)));
    }

    #[test]
    fn the_same_on_any_thread_count() {
        let mut p = generate(Distribution2d::Cluster, 100_000, 11);
        p.extend_from_within(5000..7000);
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| float_morton_order(&p).unwrap())
        };
        let one = on(1);
        assert_eq!(one, on(3));
        assert_eq!(one, on(8));
        assert_eq!(one.duplicates.count, 2000);
        assert_valid(&p, &one);
    }

    #[test]
    fn bad_input_gives_typed_errors() {
        assert_eq!(float_morton_order(&[]).unwrap_err(), Error::Empty);
        for value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let p = pts(&[(0.0, 0.0), (1.0, 1.0), (value, 1.0), (1.0, value)]);
            assert!(matches!(
                float_morton_order(&p),
                Err(Error::NonFinite { index: 2, .. })
            ));
            let p = pts(&[(0.0, 0.0), (1.0, value)]);
            assert!(matches!(
                float_morton_order(&p),
                Err(Error::NonFinite { index: 1, .. })
            ));
        }
    }

    /// `cargo test --release --lib float_order_timing -- --ignored --nocapture`
    #[test]
    #[ignore = "timing, run by hand in release"]
    fn float_order_timing() {
        use std::time::Instant;
        let p = generate(Distribution2d::Uniform, 1_000_000, 1);
        let best = |f: &dyn Fn()| {
            (0..7)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed().as_secs_f64() * 1e3
                })
                .fold(f64::INFINITY, f64::min)
        };
        let grid = best(&|| {
            std::hint::black_box(morton_order(&p, SortAlgorithm::default()).unwrap());
        });
        let float = best(&|| {
            std::hint::black_box(float_morton_order(&p).unwrap());
        });
        // The same order by the radix sort of the interleaved keys, for comparison.
        let radix = best(&|| {
            std::hint::black_box(interleaved_order(&p));
        });
        println!(
            "1e6 uniform, {} threads: morton_order {grid:.1} ms, float_morton_order {float:.1} ms, \
             radix sort of interleaved float keys {radix:.1} ms",
            rayon::current_num_threads()
        );
    }
}
