//! What a mesh run reports: counts, the angle summary both meshing modes fill, and the time of
//! each stage.

use std::time::{Duration, Instant};

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
    }
}
