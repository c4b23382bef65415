//! Morton order: quantize the points onto a fixed-point grid over the root square, interleave
//! the coordinates into keys, sort (key, index) pairs in parallel, merge exact duplicates.
//!
//! The grid has 32 bits per axis (u64 keys) unless two distinct points share a cell on it; then
//! the same code runs again with 64 bits per axis (u128 keys). Points that even that grid cannot
//! separate are an error naming them.

mod cell;
mod float_order;
pub(crate) mod interleave;
mod key;
mod quantize;
mod sort;

use std::ops::Range;

use glam::DVec2;
use rayon::prelude::*;

pub use cell::{Cell, Side};
pub use float_order::{FloatOrder, float_key, float_morton_order};
pub use interleave::has_pdep;
pub use key::MortonKey;
pub(crate) use key::{NARROW_LEVEL, in_width};
pub use quantize::{CELL_ANISOTROPY, DomainCells, GUARD_LEVELS, Grid};
pub use sort::{Pair, SortAlgorithm, SortPairs, equal_key_runs};

use crate::error::Error;
use crate::par::collect_indexed;

/// A given domain's lower-left and upper-right corners, and how the grid lies on it.
pub type DomainFrame = (DVec2, DVec2, DomainLayout);

/// How a grid lies on a given domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DomainLayout {
    /// The root shares the domain's lower-left corner and larger side ([`Grid::on_domain`]).
    Root,
    /// As `Root`, the root widened so that the right side is the grid line of the given
    /// column at the given level ([`Grid::on_domain_columns`]).
    Columns(u32, u64),
    /// The domain cut into nearly square cells whose far sides are grid lines
    /// ([`Grid::on_domain_cells`]).
    Cells(DomainCells),
}

/// How many duplicate pairs a report keeps as examples.
pub const DUPLICATE_EXAMPLES: usize = 8;

/// Exact duplicates that were merged: the first input index of each point is kept.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Duplicates {
    /// How many input points were dropped as copies of an earlier one.
    pub count: usize,
    /// The first few `(kept, dropped)` input indices, in Morton order.
    pub examples: Vec<(u32, u32)>,
}

/// Distinct points in Morton order on one grid.
#[derive(Clone, Debug)]
pub struct MortonOrder<K: Copy> {
    /// Strictly increasing keys, one per distinct point.
    pub keys: Vec<K>,
    /// `order[i]` is the input index of the point with key `keys[i]`.
    pub order: Vec<u32>,
    /// The grid the keys live on.
    pub grid: Grid,
    /// The exact duplicates merged away.
    pub duplicates: Duplicates,
}

/// Morton order on the grid the input needs.
#[derive(Clone, Debug)]
pub enum Morton {
    /// 32 bits per axis, u64 keys.
    Narrow(MortonOrder<u64>),
    /// 64 bits per axis, u128 keys.
    Wide(MortonOrder<u128>),
}

/// Puts `points` into Morton order, choosing the narrowest grid that separates them.
///
/// # Errors
/// [`Error::Empty`], [`Error::TooManyPoints`], [`Error::NonFinite`], [`Error::CoordinateRange`],
/// and [`Error::Inseparable`] for distinct points the 64-bit grid cannot tell apart.
///
/// # Complexity
/// O(n) work for encoding plus the sort's; all steps run on the current rayon pool.
pub fn morton_order(points: &[DVec2], sort: SortAlgorithm) -> Result<Morton, Error> {
    morton_order_on(points, None, sort)
}

/// [`morton_order`] on the grid `domain` gives (its lower-left and upper-right corners, holding
/// every point, and how the grid lies on it, see [`DomainLayout`]), or around the points
/// without one.
///
/// # Errors
/// As [`morton_order`].
pub fn morton_order_on(
    points: &[DVec2],
    domain: Option<DomainFrame>,
    sort: SortAlgorithm,
) -> Result<Morton, Error> {
    let (lo, hi) = validate(points)?;
    let grid = grid_of(lo, hi, domain, u64::AXIS_BITS)?;
    if !sample_collides(points, &grid) {
        let mut narrow: Vec<Pair<u64>> = interleave::encode_all(points, &grid);
        u64::sort_pairs(&mut narrow, sort);
        let runs = equal_key_runs(&narrow);
        if first_collision(points, &narrow, &runs).is_none() {
            return Ok(Morton::Narrow(separated(&narrow, &runs, grid)));
        }
    }
    // A fresh radix sort of wide keys, encoded in input order, is faster than refining the
    // narrow order: that needs a random gather of the points, which measured slower here.
    wide_order(points, lo, hi, domain, sort).map(Morton::Wide)
}

/// The grid around points with bounding box `[lo, hi]`, or on `domain`.
fn grid_of(
    lo: DVec2,
    hi: DVec2,
    domain: Option<DomainFrame>,
    axis_bits: u32,
) -> Result<Grid, Error> {
    match domain {
        Some((lo, hi, DomainLayout::Root)) => Grid::on_domain(lo, hi, axis_bits),
        Some((lo, hi, DomainLayout::Columns(level, columns))) => {
            Grid::on_domain_columns(lo, hi, axis_bits, (level, columns))
        }
        Some((lo, hi, DomainLayout::Cells(cells))) => {
            Grid::on_domain_cells(lo, hi, axis_bits, cells)
        }
        None => Grid::around(lo, hi, axis_bits),
    }
}

/// Puts `points` into Morton order on the 64-bit-per-axis grid (on `domain` if given), whatever
/// they need.
///
/// # Errors
/// As [`morton_order`].
pub fn morton_order_wide(
    points: &[DVec2],
    domain: Option<DomainFrame>,
    sort: SortAlgorithm,
) -> Result<MortonOrder<u128>, Error> {
    let (lo, hi) = validate(points)?;
    wide_order(points, lo, hi, domain, sort)
}

fn wide_order(
    points: &[DVec2],
    lo: DVec2,
    hi: DVec2,
    domain: Option<DomainFrame>,
    sort: SortAlgorithm,
) -> Result<MortonOrder<u128>, Error> {
    let grid = grid_of(lo, hi, domain, u128::AXIS_BITS)?;
    let mut wide: Vec<Pair<u128>> = interleave::encode_all(points, &grid);
    u128::sort_pairs(&mut wide, sort);
    let runs = equal_key_runs(&wide);
    match first_collision(points, &wide, &runs) {
        None => Ok(separated(&wide, &runs, grid)),
        Some((a, b)) => Err(Error::Inseparable {
            a,
            pa: points[a].into(),
            b,
            pb: points[b].into(),
        }),
    }
}

/// Inputs at least this large first look for narrow-grid collisions in a strided sample: a hit
/// proves the narrow grid too coarse and saves its full sort. Either way the result is the same.
const SAMPLE_FROM: usize = 1 << 20;
const SAMPLE_SIZE: usize = 1 << 16;

fn sample_collides(points: &[DVec2], grid: &Grid) -> bool {
    if points.len() < SAMPLE_FROM {
        return false;
    }
    let step = points.len() / SAMPLE_SIZE;
    let mut sample: Vec<(u64, usize)> = (0..SAMPLE_SIZE)
        .map(|i| {
            let (x, y) = grid.quantize(points[i * step]);
            (u64::encode(x, y), i * step)
        })
        .collect();
    sample.sort_unstable();
    sample
        .windows(2)
        .any(|w| w[0].0 == w[1].0 && points[w[0].1] != points[w[1].1])
}

/// Refuses empty input, too many points and non-finite coordinates.
///
/// # Errors
/// [`Error::Empty`], [`Error::TooManyPoints`], [`Error::NonFinite`].
pub fn validate_points(points: &[DVec2]) -> Result<(), Error> {
    validate(points).map(|_| ())
}

/// Refuses empty input, too many points and non-finite coordinates; returns the bounding box.
fn validate(points: &[DVec2]) -> Result<(DVec2, DVec2), Error> {
    if points.is_empty() {
        return Err(Error::Empty);
    }
    if points.len() >= u32::MAX as usize {
        return Err(Error::TooManyPoints(points.len()));
    }
    let (lo, hi) = bounding_box(points);
    if lo.is_finite() && hi.is_finite() {
        return Ok((lo, hi));
    }
    let index = points
        .par_iter()
        .position_first(|p| !p.is_finite())
        .expect("a non-finite point");
    Err(Error::NonFinite {
        index,
        x: points[index].x,
        y: points[index].y,
    })
}

/// The bounding box of non-empty points (non-finite if any coordinate is NaN or infinite).
pub fn bounding_box(points: &[DVec2]) -> (DVec2, DVec2) {
    // NaN vanishes in min/max, so a zero-times-coordinate sum (0 for finite values, NaN
    // otherwise) is carried along and added at the end.
    let empty = (DVec2::INFINITY, DVec2::NEG_INFINITY, DVec2::ZERO);
    let (lo, hi, poison) = points
        .par_chunks(crate::par::GRAIN)
        .map(|chunk| {
            chunk.iter().fold(empty, |(lo, hi, poison), p| {
                (lo.min(*p), hi.max(*p), poison + *p * 0.0)
            })
        })
        .reduce(|| empty, |(a, b, c), (d, e, f)| (a.min(d), b.max(e), c + f));
    (lo + poison, hi + poison)
}

/// The distinct points of sorted pairs that have no collision.
fn separated<K: MortonKey>(pairs: &[Pair<K>], runs: &[Range<usize>], grid: Grid) -> MortonOrder<K> {
    let duplicates = duplicates_of(pairs, runs);
    let (keys, order) = split_distinct(pairs, !runs.is_empty());
    MortonOrder {
        keys,
        order,
        grid,
        duplicates,
    }
}

/// Two distinct points with equal keys, if any. Runs are in index order, so the first of a run
/// is the point that would be kept.
fn first_collision<K>(
    points: &[DVec2],
    pairs: &[Pair<K>],
    runs: &[Range<usize>],
) -> Option<(usize, usize)> {
    runs.iter().find_map(|run| {
        let kept = pairs[run.start].idx as usize;
        pairs[run.start + 1..run.end]
            .iter()
            .map(|p| p.idx as usize)
            .find(|&i| points[i] != points[kept])
            .map(|other| (kept, other))
    })
}

fn duplicates_of<K>(pairs: &[Pair<K>], runs: &[Range<usize>]) -> Duplicates {
    let count = runs.iter().map(|r| r.len() - 1).sum();
    let examples = runs
        .iter()
        .flat_map(|r| {
            pairs[r.start + 1..r.end]
                .iter()
                .map(|p| (pairs[r.start].idx, p.idx))
        })
        .take(DUPLICATE_EXAMPLES)
        .collect();
    Duplicates { count, examples }
}

/// Splits sorted pairs into keys and input indices, keeping the first pair of each key.
fn split_distinct<K: MortonKey>(pairs: &[Pair<K>], has_duplicates: bool) -> (Vec<K>, Vec<u32>) {
    if !has_duplicates {
        return (
            collect_indexed(pairs.len(), |i| pairs[i].key),
            collect_indexed(pairs.len(), |i| pairs[i].idx),
        );
    }
    let key = |j: usize| pairs[j].key;
    let first_of_key = |i: &usize| *i == 0 || key(*i) != key(*i - 1);
    let kept: Vec<usize> = (0..pairs.len())
        .into_par_iter()
        .filter(first_of_key)
        .collect();
    (
        collect_indexed(kept.len(), |i| pairs[kept[i]].key),
        collect_indexed(kept.len(), |i| pairs[kept[i]].idx),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    #[test]
    fn errors_on_bad_input() {
        assert_eq!(
            morton_order(&[], SortAlgorithm::default()).unwrap_err(),
            Error::Empty
        );
        let e = morton_order(
            &pts(&[(0.0, 0.0), (f64::NAN, 1.0)]),
            SortAlgorithm::default(),
        );
        assert!(matches!(e, Err(Error::NonFinite { index: 1, .. })));
        let e = morton_order(
            &pts(&[(0.0, 0.0), (1.0, f64::INFINITY)]),
            SortAlgorithm::default(),
        );
        assert!(matches!(e, Err(Error::NonFinite { index: 1, .. })));
    }

    #[test]
    fn non_finite_points_are_found_in_any_chunk() {
        let n = 3 * crate::par::GRAIN + 5;
        for bad in [0, 100, crate::par::GRAIN, 2 * crate::par::GRAIN + 1, n - 1] {
            for value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut p: Vec<DVec2> = (0..n).map(|i| DVec2::new(i as f64, 1.0)).collect();
                p[bad] = DVec2::new(value, 1.0);
                let e = morton_order(&p, SortAlgorithm::default());
                assert!(
                    matches!(e, Err(Error::NonFinite { index, .. }) if index == bad),
                    "{bad} {value}"
                );
            }
        }
    }

    #[test]
    fn duplicates_are_merged_and_reported() {
        let p = pts(&[
            (1.0, 1.0),
            (0.0, 0.0),
            (1.0, 1.0),
            (0.5, 0.25),
            (0.0, 0.0),
            (1.0, 1.0),
        ]);
        let Morton::Narrow(m) = morton_order(&p, SortAlgorithm::default()).unwrap() else {
            panic!("narrow grid expected")
        };
        assert_eq!(m.keys.len(), 3);
        assert_eq!(m.duplicates.count, 3);
        let mut kept: Vec<u32> = m.order.clone();
        kept.sort();
        assert_eq!(kept, vec![0, 1, 3]);
        assert!(m.duplicates.examples.contains(&(0, 2)));
        assert!(m.duplicates.examples.contains(&(1, 4)));
    }

    #[test]
    fn close_points_widen_the_grid() {
        let p = pts(&[(0.0, 0.0), (1.0, 1.0), (0.5, 0.5), (0.5 + 1e-12, 0.5)]);
        assert!(matches!(
            morton_order(&p, SortAlgorithm::default()).unwrap(),
            Morton::Wide(_)
        ));
    }

    #[test]
    fn wide_order_equals_a_plain_sort_of_wide_keys() {
        let mut p = crate::generate::points(crate::generate::Distribution2d::Cluster, 30_000, 2);
        p.extend_from_within(..3000);
        let Morton::Wide(m) = morton_order(&p, SortAlgorithm::default()).unwrap() else {
            panic!("clusters down to sigma 1e-6 need the wide grid")
        };
        let mut all: Vec<Pair<u128>> = interleave::encode_all(&p, &m.grid);
        all.sort();
        all.dedup_by_key(|q| q.key);
        assert_eq!(m.keys, all.iter().map(|q| q.key).collect::<Vec<_>>());
        assert_eq!(m.order, all.iter().map(|q| q.idx).collect::<Vec<_>>());
        assert_eq!(m.duplicates.count, 3000);
    }

    #[test]
    fn a_sample_with_collisions_goes_straight_to_the_wide_grid() {
        let p = crate::generate::points(
            crate::generate::Distribution2d::Kuzmin,
            SAMPLE_FROM + 1000,
            4,
        );
        let (lo, hi) = validate(&p).unwrap();
        assert!(sample_collides(&p, &Grid::around(lo, hi, 32).unwrap()));
        let Morton::Wide(m) = morton_order(&p, SortAlgorithm::default()).unwrap() else {
            panic!("wide grid expected")
        };
        let mut all: Vec<Pair<u128>> = interleave::encode_all(&p, &m.grid);
        all.sort();
        assert_eq!(m.keys, all.iter().map(|q| q.key).collect::<Vec<_>>());
        let uniform =
            crate::generate::points(crate::generate::Distribution2d::Uniform, SAMPLE_FROM, 4);
        let (lo, hi) = validate(&uniform).unwrap();
        assert!(!sample_collides(
            &uniform,
            &Grid::around(lo, hi, 32).unwrap()
        ));
    }

    #[test]
    fn inseparable_points_are_named() {
        let p = pts(&[(0.0, 0.0), (1.0, 1.0), (0.0, 0.5), (1e-30, 0.5)]);
        match morton_order(&p, SortAlgorithm::default()) {
            Err(Error::Inseparable { a, b, .. }) => assert_eq!((a.min(b), a.max(b)), (2, 3)),
            other => panic!("expected Inseparable, got {other:?}"),
        }
    }
}
