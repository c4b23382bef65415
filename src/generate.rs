//! Seeded generators for tests, benches and `quadmesh bench`.
//!
//! Point sets: uniform, Gaussian clusters (sigma down to 1e-6) and Kuzmin (the PBBS distribution,
//! spread ~1e12 at a million points). Planar straight-line graphs: nested wavy rings
//! ([`nested_curves`]) and a block with rectangular holes ([`block_with_holes`]); these are
//! computed with additions, multiplications, divisions and square roots alone, so the same
//! arguments give the same bits on every machine.

use std::f64::consts::TAU;
use std::str::FromStr;

use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::options::{Input, RegionSeed, Segment};

/// A point distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution2d {
    /// Uniform in the unit square.
    Uniform,
    /// Gaussian clusters with centres uniform in the unit square and sigmas from 1e-2 to 1e-6.
    Cluster,
    /// Kuzmin's disc: radius `sqrt(1 / (1 - u)^2 - 1)`, uniform direction.
    Kuzmin,
    /// Points of the integer lattice (a random subset of a square grid).
    Grid,
}

impl Distribution2d {
    /// Every distribution.
    pub const ALL: [Distribution2d; 4] = [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
        Distribution2d::Grid,
    ];
}

impl FromStr for Distribution2d {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "uniform" => Ok(Self::Uniform),
            "cluster" | "clustered" => Ok(Self::Cluster),
            "kuzmin" => Ok(Self::Kuzmin),
            "grid" => Ok(Self::Grid),
            _ => Err(format!(
                "unknown distribution '{s}' (uniform, cluster, kuzmin, grid)"
            )),
        }
    }
}

/// `n` points of `dist` from `seed`; the same arguments give the same points on every machine.
pub fn points(dist: Distribution2d, n: usize, seed: u64) -> Vec<DVec2> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    match dist {
        Distribution2d::Uniform => (0..n)
            .map(|_| DVec2::new(rng.random(), rng.random()))
            .collect(),
        Distribution2d::Cluster => clusters(n, &mut rng),
        Distribution2d::Kuzmin => (0..n).map(|_| kuzmin(&mut rng)).collect(),
        Distribution2d::Grid => lattice(n, &mut rng),
    }
}

fn clusters(n: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<DVec2> {
    let count = (n / 1000).clamp(1, 1000);
    let centres: Vec<(DVec2, f64)> = (0..count)
        .map(|_| {
            let sigma = 10f64.powf(-rng.random_range(2.0..=6.0));
            (DVec2::new(rng.random(), rng.random()), sigma)
        })
        .collect();
    (0..n)
        .map(|_| {
            let (c, sigma) = centres[rng.random_range(0..count)];
            let normal = Normal::new(0.0, sigma).expect("positive sigma");
            c + DVec2::new(normal.sample(rng), normal.sample(rng))
        })
        .collect()
}

fn kuzmin(rng: &mut Xoshiro256PlusPlus) -> DVec2 {
    let angle = rng.random_range(0.0..std::f64::consts::TAU);
    let s: f64 = rng.random();
    let r = (1.0 / ((1.0 - s) * (1.0 - s)) - 1.0).sqrt();
    DVec2::new(angle.cos(), angle.sin()) * r
}

fn lattice(n: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<DVec2> {
    let side = ((2 * n) as f64).sqrt().ceil().max(2.0) as u64;
    let mut picked = std::collections::BTreeSet::new();
    while picked.len() < n {
        picked.insert((rng.random_range(0..side), rng.random_range(0..side)));
    }
    let mut pts: Vec<DVec2> = picked
        .into_iter()
        .map(|(x, y)| DVec2::new(x as f64, y as f64))
        .collect();
    // Shuffle so the input order carries no Morton order.
    for i in (1..pts.len()).rev() {
        pts.swap(i, rng.random_range(0..=i));
    }
    pts
}

/// Rings of [`nested_curves`] at most.
const MAX_RINGS: usize = 6;
/// A ring's mean radius over the next inner one's.
const RING_RATIO: f64 = 1.5;
/// A ring's radius stays within this fraction of its mean. With [`RING_RATIO`] an outer ring's
/// smallest radius is 1.5 × 0.9 = 1.35 times its inner neighbour's mean, against the inner
/// ring's largest 1.1: a gap of a fifth of the outer mean radius, which chords of rings with at
/// least [`MIN_RING_SEGMENTS`] segments cannot cross.
const RING_WAVE: f64 = 0.1;
/// Harmonics 2, 3, … of a ring's radial perturbation.
const RING_MODES: usize = 8;
/// Fewest segments on a ring: its chords stay close to the curve.
const MIN_RING_SEGMENTS: usize = 16;
/// Dense samples per segment when a ring is measured and sampled by arc length.
const OVERSAMPLE: usize = 8;
/// Dense samples for the perimeters that share the segments out among the rings.
const PERIMETER_SAMPLES: usize = 4096;

/// About `segments` segments (exactly, from [`MIN_RING_SEGMENTS`] = 16 up) on up to six nested
/// closed curves around the origin, the outermost of mean radius 1.
///
/// Each ring is star-shaped: radius `mean × (1 + Σ aₘ cos(mθ + φₘ))` over harmonics 2 to 9 with
/// random phases and amplitudes (`Σ |aₘ| = 0.1`), mean radii a factor 1.5 apart, so no ring
/// touches the next. The rings share the segments in proportion to their lengths and are
/// sampled evenly by arc length, so all segments have about the same length. Ring `k`
/// (0 innermost) has marker `k + 1`. The areas between rings alternate from the outermost
/// annulus, a region, inwards: every other annulus (and the inner disc, by parity) is a hole,
/// with one hole seed; each other area is a region with attribute `k + 1` for the area inside
/// ring `k`, and no area bound. Rings are added while the innermost still gets at least 24
/// segments.
///
/// The same arguments give the same bits on every machine. No two segments cross or touch
/// except consecutive segments of a ring at their shared end.
///
/// # Complexity
/// O(segments), the curve evaluations in parallel on the current rayon pool.
///
/// # Panics
/// If `segments` is below 16.
pub fn nested_curves(segments: usize, seed: u64) -> Input {
    assert!(
        segments >= MIN_RING_SEGMENTS,
        "nested_curves needs at least {MIN_RING_SEGMENTS} segments, got {segments}"
    );
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let rings = random_rings(ring_count(segments), &mut rng);
    let perimeters: Vec<f64> = rings
        .iter()
        .map(|r| polyline_length(&r.trace(PERIMETER_SAMPLES)))
        .collect();
    let mut input = Input::default();
    for (k, (ring, n)) in rings.iter().zip(share(segments, &perimeters)).enumerate() {
        let marker = k as i32 + 1;
        push_loop(&mut input, ring.sample(n), marker);
    }
    let outermost = rings.len() - 1;
    for area in 0..rings.len() {
        let seed = area_seed(&rings, area, &mut rng);
        if (outermost - area) % 2 == 1 {
            input.holes.push(seed);
        } else {
            input.regions.push(RegionSeed {
                seed,
                attribute: (area + 1) as f64,
                max_area: None,
            });
        }
    }
    input
}

/// The most rings (up to [`MAX_RINGS`]) for which the innermost gets 1.5 × [`MIN_RING_SEGMENTS`]
/// segments by mean radius; its length differs from that estimate by well under a third.
fn ring_count(segments: usize) -> usize {
    let (mut count, mut total, mut mean) = (1, 1.0, 1.0);
    while count < MAX_RINGS {
        mean *= RING_RATIO;
        if segments as f64 / (total + mean) < 1.5 * MIN_RING_SEGMENTS as f64 {
            break;
        }
        total += mean;
        count += 1;
    }
    count
}

/// `count` rings, innermost first, the outermost of mean radius 1.
fn random_rings(count: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<Ring> {
    let mut means = vec![1.0; count];
    for k in (0..count.saturating_sub(1)).rev() {
        means[k] = means[k + 1] / RING_RATIO;
    }
    means
        .into_iter()
        .map(|mean| Ring::random(mean, rng))
        .collect()
}

/// `total` split among the parts in proportion to `weights`, by cumulative rounding.
fn share(total: usize, weights: &[f64]) -> Vec<usize> {
    let sum: f64 = weights.iter().sum();
    let mut before = 0.0;
    let mut given = 0;
    weights
        .iter()
        .map(|w| {
            before += w;
            let upto = ((total as f64) * before / sum).round() as usize;
            let upto = upto.min(total);
            let n = upto - given;
            given = upto;
            n
        })
        .collect()
}

/// A point strictly inside area `area` (the disc inside ring 0, or the annulus between rings
/// `area - 1` and `area`): the origin, or halfway between the two rings at a random angle.
fn area_seed(rings: &[Ring], area: usize, rng: &mut Xoshiro256PlusPlus) -> DVec2 {
    if area == 0 {
        return DVec2::ZERO;
    }
    let theta = rng.random_range(0.0..TAU);
    let r = 0.5 * (rings[area - 1].radius(theta) + rings[area].radius(theta));
    let (s, c) = sin_cos(theta);
    DVec2::new(c, s) * r
}

/// A star-shaped closed curve around the origin.
struct Ring {
    mean: f64,
    /// Amplitude (relative to `mean`) and phase of harmonic `m + 2`.
    modes: [(f64, f64); RING_MODES],
}

impl Ring {
    /// Random phases, amplitudes falling as `1/m` with a random factor, summing to
    /// [`RING_WAVE`].
    fn random(mean: f64, rng: &mut Xoshiro256PlusPlus) -> Ring {
        let mut modes = [(0.0, 0.0); RING_MODES];
        for (i, mode) in modes.iter_mut().enumerate() {
            let amplitude = rng.random_range(0.5..1.0) / (i + 2) as f64;
            *mode = (amplitude, rng.random_range(0.0..TAU));
        }
        let sum: f64 = modes.iter().map(|m| m.0).sum();
        for mode in &mut modes {
            mode.0 *= RING_WAVE / sum;
        }
        Ring { mean, modes }
    }

    fn radius(&self, theta: f64) -> f64 {
        let wave: f64 = (self.modes.iter().enumerate())
            .map(|(i, &(a, phase))| a * sin_cos((i + 2) as f64 * theta + phase).1)
            .sum();
        self.mean * (1.0 + wave)
    }

    fn point(&self, theta: f64) -> DVec2 {
        let (s, c) = sin_cos(theta);
        DVec2::new(c, s) * self.radius(theta)
    }

    /// The curve at `n + 1` equally spaced angles, from 0 to 2π inclusive.
    fn trace(&self, n: usize) -> Vec<DVec2> {
        (0..=n)
            .into_par_iter()
            .map(|j| self.point(angle(j, n)))
            .collect()
    }

    /// `n` points evenly spaced by arc length (measured on a dense trace), at increasing angles
    /// from 0.
    fn sample(&self, n: usize) -> Vec<DVec2> {
        let dense = n * OVERSAMPLE;
        let trace = self.trace(dense);
        let mut along = Vec::with_capacity(trace.len());
        along.push(0.0);
        for pair in trace.windows(2) {
            along.push(along[along.len() - 1] + pair[0].distance(pair[1]));
        }
        let total = along[dense];
        let mut j = 0;
        let thetas: Vec<f64> = (0..n)
            .map(|i| {
                let target = total * i as f64 / n as f64;
                while along[j + 1] <= target {
                    j += 1;
                }
                let t = (target - along[j]) / (along[j + 1] - along[j]);
                angle(j, dense) + t * (angle(j + 1, dense) - angle(j, dense))
            })
            .collect();
        thetas.into_par_iter().map(|t| self.point(t)).collect()
    }
}

/// Angle `j` of `n` equal steps around the circle.
fn angle(j: usize, n: usize) -> f64 {
    TAU * j as f64 / n as f64
}

fn polyline_length(points: &[DVec2]) -> f64 {
    points.windows(2).map(|p| p[0].distance(p[1])).sum()
}

/// Appends `loop_points` as a closed loop of segments with `marker`.
fn push_loop(input: &mut Input, loop_points: Vec<DVec2>, marker: i32) {
    let first = input.points.len() as u32;
    let n = loop_points.len() as u32;
    input.points.extend(loop_points);
    input.segments.extend((0..n).map(|i| Segment {
        ends: [first + i, first + (i + 1) % n],
        marker,
    }));
}

/// `(sin x, cos x)` from additions, multiplications and divisions alone, so that every machine
/// gets the same bits (platform math libraries round differently). Within a few units in the
/// last place for |x| up to about 10⁵.
fn sin_cos(x: f64) -> (f64, f64) {
    // π/2 in two parts (fdlibm's pio2_1 and pio2_1t): quadrant × PIO2_HI is exact.
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    let quadrant = (x / PIO2_HI).round();
    let r = (x - quadrant * PIO2_HI) - quadrant * PIO2_LO;
    let z = r * r;
    // Taylor series to r¹⁷ and r¹⁸ in nested form; |r| ≤ π/4 keeps the rest below 1e-19.
    let (mut s, mut c) = (1.0, 1.0);
    for k in (1..=9u32).rev() {
        if k <= 8 {
            s = 1.0 - z / f64::from(2 * k * (2 * k + 1)) * s;
        }
        c = 1.0 - z / f64::from((2 * k - 1) * (2 * k)) * c;
    }
    let s = r * s;
    match (quadrant as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Coordinates of [`block_with_holes`] are multiples of 1/64: exact in binary, short in decimal.
const QUANTUM: f64 = 1.0 / 64.0;
/// Quanta per grid cell (a cell is the unit square).
const CELL_QUANTA: u32 = 64;
/// Fewest quanta between a hole and its cell's sides: holes in neighbouring cells stay at least
/// a quarter cell apart, and away from the block's sides.
const HOLE_MARGIN: u32 = 8;
/// A hole's sides span this many quanta (0.25 to 0.625 of a cell).
const HOLE_SIDE_QUANTA: std::ops::RangeInclusive<u32> = 16..=40;
/// The block's sides are split into pieces of half a cell, about a hole's side.
const OUTER_PIECES_PER_CELL: usize = 2;

/// A square block `[0, g]²`, `g = ⌈√holes⌉`, with `holes` axis-parallel rectangular holes, one
/// in each of `holes` cells of the unit grid picked at random, of random size (0.25 to 0.625 of
/// a cell per side) and jittered position, at least 1/8 from the cell's sides.
///
/// The block's sides are split into pieces of length 1/2 with marker 1; hole `h` has its four
/// sides as segments with marker `h + 2`, and one hole seed at its centre. There are no
/// regions. Every coordinate is a multiple of 1/64, so it is exact and short in decimal. The
/// same arguments give the same bits on every machine; no two segments cross or touch except
/// consecutive segments of a loop at their shared end.
///
/// # Complexity
/// O(g²) = O(holes).
pub fn block_with_holes(holes: usize, seed: u64) -> Input {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let side = grid_side(holes);
    let mut input = Input::default();
    push_loop(&mut input, square_outline(side), 1);
    for (h, cell) in pick_cells(side * side, holes, &mut rng)
        .into_iter()
        .enumerate()
    {
        let corner = DVec2::new((cell % side) as f64, (cell / side) as f64);
        let (lo, hi) = random_hole(&mut rng);
        let (lo, hi) = (corner + lo, corner + hi);
        let outline = vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
        push_loop(&mut input, outline, h as i32 + 2);
        input.holes.push(0.5 * (lo + hi));
    }
    input
}

/// The smallest `g ≥ 1` with `g² ≥ holes`.
fn grid_side(holes: usize) -> usize {
    let mut side = ((holes as f64).sqrt() as usize).max(1);
    while side * side < holes {
        side += 1;
    }
    side
}

/// The outline of `[0, side]²`, counter-clockwise from the origin, in pieces of
/// `1 / OUTER_PIECES_PER_CELL`.
fn square_outline(side: usize) -> Vec<DVec2> {
    let pieces = side * OUTER_PIECES_PER_CELL;
    let step = 1.0 / OUTER_PIECES_PER_CELL as f64;
    let s = side as f64;
    let along = |i: usize| i as f64 * step;
    let bottom = (0..pieces).map(|i| DVec2::new(along(i), 0.0));
    let right = (0..pieces).map(|i| DVec2::new(s, along(i)));
    let top = (0..pieces).map(|i| DVec2::new(s - along(i), s));
    let left = (0..pieces).map(|i| DVec2::new(0.0, s - along(i)));
    bottom.chain(right).chain(top).chain(left).collect()
}

/// `count` distinct cells of `0..cells` (a partial Fisher–Yates shuffle), in increasing order.
fn pick_cells(cells: usize, count: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<usize> {
    let mut all: Vec<usize> = (0..cells).collect();
    for i in 0..count {
        let j = rng.random_range(i..cells);
        all.swap(i, j);
    }
    all.truncate(count);
    all.sort_unstable();
    all
}

/// Lower-left and upper-right corners of a hole in the unit cell.
fn random_hole(rng: &mut Xoshiro256PlusPlus) -> (DVec2, DVec2) {
    let mut axis = || {
        let length = rng.random_range(HOLE_SIDE_QUANTA);
        let start = rng.random_range(HOLE_MARGIN..=CELL_QUANTA - HOLE_MARGIN - length);
        (start, start + length)
    };
    let (x0, x1) = axis();
    let (y0, y1) = axis();
    let at = |q: u32| f64::from(q) * QUANTUM;
    (DVec2::new(at(x0), at(y0)), DVec2::new(at(x1), at(y1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_and_sized() {
        for dist in Distribution2d::ALL {
            let a = points(dist, 500, 7);
            assert_eq!(a.len(), 500);
            assert_eq!(a, points(dist, 500, 7));
            assert_ne!(a, points(dist, 500, 8));
            assert!(a.iter().all(|p| p.is_finite()));
        }
    }

    /// Asserts that `input` needs no cleaning: no repeated points or segments, no point inside
    /// a segment, no crossing.
    fn assert_clean(input: &Input) {
        let (_, report) = crate::pslg::clean(input, crate::pslg::CleanOptions::default())
            .expect("no crossing segments");
        assert!(report.is_clean(), "{report:?}");
    }

    /// Whether `p` is inside the closed polygon `outline` (crossing number).
    fn inside(outline: &[DVec2], p: DVec2) -> bool {
        let mut crossings = 0;
        for (i, &a) in outline.iter().enumerate() {
            let b = outline[(i + 1) % outline.len()];
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                crossings += usize::from(x > p.x);
            }
        }
        crossings % 2 == 1
    }

    /// The loops of `input` with `marker`, as point lists.
    fn loop_with(input: &Input, marker: i32) -> Vec<DVec2> {
        (input.segments.iter())
            .filter(|s| s.marker == marker)
            .map(|s| input.points[s.ends[0] as usize])
            .collect()
    }

    #[test]
    fn sin_cos_matches_the_library() {
        for i in -20_000..20_000 {
            let x = f64::from(i) * 0.013_7;
            let (s, c) = sin_cos(x);
            assert!(
                (s - x.sin()).abs() < 1e-14 && (c - x.cos()).abs() < 1e-14,
                "{x}"
            );
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }

    #[test]
    fn nested_curves_are_clean_nested_and_seeded() {
        for (segments, seed) in [(16, 1), (60, 2), (300, 3), (2_000, 4), (30_000, 5)] {
            let input = nested_curves(segments, seed);
            assert_eq!(input.segments.len(), segments);
            assert_eq!(input.points.len(), segments);
            assert_eq!(input, nested_curves(segments, seed));
            assert_clean(&input);
            let rings = input.holes.len() + input.regions.len();
            let loops: Vec<Vec<DVec2>> = (1..=rings as i32).map(|m| loop_with(&input, m)).collect();
            assert!(loops.iter().all(|l| l.len() >= MIN_RING_SEGMENTS));
            // Each seed is inside its ring and outside the next inner one.
            let seeds = (input.holes.iter().copied()).chain(input.regions.iter().map(|r| r.seed));
            for seed in seeds {
                let area = loops.iter().position(|l| inside(l, seed)).expect("inside");
                let hole = input.holes.contains(&seed);
                assert_eq!(
                    hole,
                    (rings - 1 - area) % 2 == 1,
                    "seed {seed} in area {area}"
                );
            }
        }
        assert_eq!(nested_curves(200_000, 1).holes.len(), MAX_RINGS / 2);
        assert_ne!(nested_curves(300, 1), nested_curves(300, 2));
    }

    #[test]
    fn segments_of_a_nested_curve_are_about_equally_long() {
        let input = nested_curves(20_000, 9);
        let lengths: Vec<f64> = (input.segments.iter())
            .map(|s| input.points[s.ends[0] as usize].distance(input.points[s.ends[1] as usize]))
            .collect();
        let (lo, hi) = lengths
            .iter()
            .fold((f64::MAX, 0.0f64), |(lo, hi), &l| (lo.min(l), hi.max(l)));
        assert!(hi < 1.5 * lo, "{lo} .. {hi}");
    }

    #[test]
    fn blocks_with_holes_are_clean_and_exact() {
        for (holes, seed) in [(0, 1), (1, 2), (7, 3), (50, 4), (400, 5)] {
            let input = block_with_holes(holes, seed);
            let side = grid_side(holes);
            assert_eq!(input.holes.len(), holes);
            assert_eq!(
                input.segments.len(),
                4 * OUTER_PIECES_PER_CELL * side + 4 * holes
            );
            assert_eq!(input, block_with_holes(holes, seed));
            assert_clean(&input);
            for (h, &seed) in input.holes.iter().enumerate() {
                assert!(inside(&loop_with(&input, h as i32 + 2), seed));
            }
            let coordinates = input.points.iter().flat_map(|p| [p.x, p.y]);
            assert!(coordinates.into_iter().all(|c| (c * 64.0).fract() == 0.0));
        }
        assert_ne!(block_with_holes(50, 1), block_with_holes(50, 2));
    }
}
