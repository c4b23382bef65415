//! What a mesh run reports: counts, the angle summary both meshing modes fill, and the time of
//! each stage.

use std::time::{Duration, Instant};

use glam::DVec2;

use super::Mesh;

/// Smallest and largest angle (degrees) and the count of angles per 10° bin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleQuality {
    /// Smallest angle.
    pub min: f64,
    /// Largest angle.
    pub max: f64,
    /// `histogram[i]` counts angles in `[10 i, 10 (i + 1))` degrees.
    pub histogram: [u64; 18],
}

impl AngleQuality {
    pub(crate) fn empty() -> Self {
        AngleQuality {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            histogram: [0; 18],
        }
    }

    pub(crate) fn add(&mut self, angle: f64, count: u64) {
        self.min = self.min.min(angle);
        self.max = self.max.max(angle);
        self.histogram[((angle / 10.0) as usize).min(17)] += count;
    }

    /// The same angles `count` times over.
    pub(crate) fn repeated(mut self, count: u64) -> Self {
        self.histogram.iter_mut().for_each(|h| *h *= count);
        self
    }

    pub(crate) fn merge(mut self, other: Self) -> Self {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
        for (h, o) in self.histogram.iter_mut().zip(other.histogram) {
            *h += o;
        }
        self
    }
}

/// An [`AngleQuality`] filled triangle by triangle with the same angles
/// [`super::angles_deg`] measures, but that calls `atan2` only for an angle a cosine cannot
/// place: one that may be a new smallest or largest, or lies within [`Self::MARGIN`] of a bin's
/// edge. The others fall strictly inside a bin, and their exact value changes nothing else.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AngleTally {
    quality: AngleQuality,
    /// Cosines of the smallest and largest angle so far.
    cos_min: f64,
    cos_max: f64,
}

/// `cos(10 k°)` for the bins' inner edges, k = 1..=17.
const BIN_EDGE_COS: [f64; 17] = {
    // cos by its Taylor series in radians: exact enough for an edge that a margin surrounds.
    let mut edges = [0.0; 17];
    let mut k = 0;
    while k < 17 {
        let x = (k + 1) as f64 * 10.0 * std::f64::consts::PI / 180.0;
        let (mut term, mut sum, mut i) = (1.0, 1.0, 1);
        while i < 40 {
            term = -term * x * x / ((2 * i - 1) * (2 * i)) as f64;
            sum += term;
            i += 1;
        }
        edges[k] = sum;
        k += 1;
    }
    edges
};

impl AngleTally {
    /// How near (in cosine) a bin's edge or an extreme an angle must be for `atan2` to decide
    /// it: far above the cosine's own rounding (about 1e-15).
    const MARGIN: f64 = 1e-9;

    pub(crate) fn new() -> Self {
        AngleTally {
            quality: AngleQuality::empty(),
            cos_min: f64::NEG_INFINITY,
            cos_max: f64::INFINITY,
        }
    }

    /// Adds the three angles of triangle `a, b, c`; returns their cosines
    /// ([`super::corner_cosines`]).
    #[inline]
    pub(crate) fn add_triangle(&mut self, a: DVec2, b: DVec2, c: DVec2) -> [f64; 3] {
        let cosines = super::corner_cosines(a, b, c);
        self.add_measured(a, b, c, cosines);
        cosines
    }

    /// Adds the three angles of triangle `a, b, c`, whose cosines `cosines`
    /// ([`super::corner_cosines`]) were measured already.
    #[inline]
    pub(crate) fn add_measured(&mut self, a: DVec2, b: DVec2, c: DVec2, cosines: [f64; 3]) {
        for ((u, v), cos) in super::corner_sides(a, b, c).into_iter().zip(cosines) {
            self.add_cosine(cos, || super::angle_deg(u, v));
        }
    }

    /// Adds an angle whose cosine, as [`super::cosine`] computes it, is `cos`; `exact` gives it
    /// in degrees as [`super::angle_deg`] measures it.
    #[inline]
    fn add_cosine(&mut self, cos: f64, exact: impl FnOnce() -> f64) {
        // The edges are falling: those above `cos` are the bins the angle is past.
        let mut bin = 0;
        for e in BIN_EDGE_COS {
            bin += usize::from(cos < e);
        }
        let near_edge = (bin > 0 && BIN_EDGE_COS[bin - 1] - cos <= Self::MARGIN)
            || (bin < BIN_EDGE_COS.len() && cos - BIN_EDGE_COS[bin] <= Self::MARGIN);
        let extreme = cos >= self.cos_min - Self::MARGIN || cos <= self.cos_max + Self::MARGIN;
        if near_edge || extreme || !cos.is_finite() {
            self.add_exact(exact());
        } else {
            self.quality.histogram[bin] += 1;
        }
    }

    fn add_exact(&mut self, angle: f64) {
        let (min, max) = (self.quality.min, self.quality.max);
        self.quality.add(angle, 1);
        if self.quality.min != min {
            self.cos_min = self.quality.min.to_radians().cos();
        }
        if self.quality.max != max {
            self.cos_max = self.quality.max.to_radians().cos();
        }
    }

    pub(crate) fn quality(&self) -> AngleQuality {
        self.quality
    }
}

/// Counts, angles and timings of a mesh run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshReport {
    /// Distinct input points meshed.
    pub points: usize,
    /// Exact duplicates merged into an earlier point.
    pub duplicates: usize,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Smallest angle, degrees.
    pub min_angle: f64,
    /// Largest angle, degrees.
    pub max_angle: f64,
    /// Count of angles per 10° bin: `histogram[i]` counts angles in `[10 i, 10 (i + 1))`.
    pub histogram: [u64; 18],
    /// Wall-clock time of each stage.
    pub stages: Vec<(&'static str, Duration)>,
    /// What cleaning a planar straight-line graph changed (none for a point set).
    pub cleaning: Option<crate::pslg::CleanReport>,
    /// Free vertices (Steiner points on no segment) that refinement deleted from segments'
    /// diametral circles before splitting the segments, as Triangle does (a graph's Delaunay
    /// mode, in its sequential loop).
    pub free_vertices_deleted: usize,
    /// Steiner vertices on no segment taken out after refinement where the mesh left still
    /// met the bounds ([`crate::Options::remove_spare_vertices`]).
    pub spare_vertices_removed: usize,
    /// The angles the mode guarantees, outside input corners narrower than the smallest
    /// ([`crate::Options::angle_bounds_of`]); `None` from the stages called on their own.
    pub angle_bounds: Option<super::AngleBounds>,
}

impl MeshReport {
    /// Sum of the stage times.
    pub fn total(&self) -> Duration {
        self.stages.iter().map(|(_, d)| *d).sum()
    }
}

/// Wall-clock time of each stage, in the order they ran.
#[derive(Clone, Debug, Default)]
pub struct StageTimes(pub Vec<(&'static str, Duration)>);

impl StageTimes {
    /// Runs `f`, recording its wall-clock time under `stage`.
    pub fn time<T>(&mut self, stage: &'static str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.0.push((stage, start.elapsed()));
        out
    }

    /// Sum of all stages.
    pub fn total(&self) -> Duration {
        self.0.iter().map(|(_, d)| *d).sum()
    }
}

/// The report of a finished mesh of `points` distinct points.
pub(crate) fn report_of(
    mesh: &Mesh,
    points: usize,
    duplicates: usize,
    quality: &AngleQuality,
    times: StageTimes,
) -> MeshReport {
    MeshReport {
        points,
        duplicates,
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        min_angle: quality.min,
        max_angle: quality.max,
        histogram: quality.histogram,
        stages: times.0,
        cleaning: None,
        free_vertices_deleted: 0,
        spare_vertices_removed: 0,
        angle_bounds: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::angles_deg;
    use rand::{Rng as _, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn exact(triangles: &[[DVec2; 3]]) -> AngleQuality {
        let mut q = AngleQuality::empty();
        for &[a, b, c] in triangles {
            angles_deg(a, b, c).into_iter().for_each(|x| q.add(x, 1));
        }
        q
    }

    #[test]
    fn a_tally_counts_as_the_measured_angles_do() {
        let mut triangles = vec![
            // Right, 45°, 60°, 30° and flat angles: on bin edges.
            [DVec2::ZERO, DVec2::X, DVec2::Y],
            [DVec2::ZERO, DVec2::X, DVec2::new(0.5, 3f64.sqrt() / 2.0)],
            [
                DVec2::ZERO,
                DVec2::new(3f64.sqrt(), 0.0),
                DVec2::new(0.0, 1.0),
            ],
            [DVec2::ZERO, DVec2::X, DVec2::new(2.0, 0.0)],
            [DVec2::ZERO, DVec2::X, DVec2::ZERO],
            [
                DVec2::splat(1e300),
                DVec2::new(-1e300, 1e300),
                DVec2::new(1e300, -1e300),
            ],
        ];
        // Angles within a hair of every bin edge, on both sides, then random triangles.
        for k in 1..18 {
            for hair in [-1e-12, 0.0, 1e-12, 1e-7] {
                let t = (10.0 * k as f64 + hair).to_radians();
                triangles.push([DVec2::ZERO, DVec2::X, DVec2::new(t.cos(), t.sin())]);
            }
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        for _ in 0..20_000 {
            triangles.push(std::array::from_fn(|_| {
                DVec2::new(rng.random(), rng.random())
            }));
        }
        let mut tally = AngleTally::new();
        for &[a, b, c] in &triangles {
            tally.add_triangle(a, b, c);
        }
        let (got, want) = (tally.quality(), exact(&triangles));
        assert_eq!(got.histogram, want.histogram);
        assert_eq!(got.min.to_bits(), want.min.to_bits());
        assert_eq!(got.max.to_bits(), want.max.to_bits());
    }

    #[test]
    fn the_bin_edges_are_the_cosines_of_multiples_of_ten_degrees() {
        for (k, e) in BIN_EDGE_COS.iter().enumerate() {
            let want = (10.0 * (k + 1) as f64).to_radians().cos();
            assert!((e - want).abs() < 1e-14, "{k}: {e} against {want}");
        }
    }
}
