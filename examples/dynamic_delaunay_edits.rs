//! Times single edits of a dynamic quality Delaunay mesh against a rebuild, on uniform points
//! in the unit square: medians over the edits of each kind (insertions where the points are,
//! deletions, moves by a thousandth of the side), the windows replayed and the Steiner points
//! changed, and the triangles the edit changed (`take_changes`) with the time to find them;
//! then batches of moves of 0.1, 1 and 10 % of the points. Usage:
//! `cargo run --release --example dynamic_delaunay_edits -- [points] [edits] [angle] [dist]`
//! (`dist`: uniform, the default, or cluster, kuzmin or grid, scaled into the unit square).

use std::time::Instant;

use quadmesh::DVec2;
use quadmesh::dynamic::{DynamicDelaunay, Edit, RefinedEdit};
use quadmesh::generate::{Distribution2d, points};
use quadmesh::mesh::Domain;
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// `points` scaled and shifted into the unit square, a thousandth clear of its sides.
fn into_unit_square(points: Vec<DVec2>) -> Vec<DVec2> {
    let (lo, hi) = points.iter().fold(
        (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let scale = 0.998 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    points
        .into_iter()
        .map(|p| (p - lo) * scale + 0.001)
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(100_000, |s| s.parse().expect("points"));
    let edits: usize = args.get(2).map_or(200, |s| s.parse().expect("edits"));
    let angle: f64 = args.get(3).map_or(30.0, |s| s.parse().expect("angle"));
    let dist: Distribution2d = args
        .get(4)
        .map_or(Ok(Distribution2d::Uniform), |s| s.parse())
        .expect("a distribution");
    let input = match dist {
        Distribution2d::Uniform => points(dist, n, 1),
        _ => into_unit_square(points(dist, n, 1)),
    };
    let options = RefineOptions {
        min_angle_deg: angle,
        domain: RefineDomain::Rectangle(Domain {
            lo: DVec2::ZERO,
            hi: DVec2::ONE,
        }),
        ..RefineOptions::default()
    };
    let start = Instant::now();
    let (rebuilt, _) = refine_points_in_order(&input, &options).expect("a mesh");
    let rebuild = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let mut dynamic = DynamicDelaunay::new(&input, &options).expect("a dynamic mesh");
    let build = start.elapsed().as_secs_f64();
    println!(
        "{n} {dist:?} points at {angle}°: {} triangles; rebuild {rebuild:.3} s, dynamic build {build:.3} s",
        rebuilt.triangles.len()
    );
    dynamic.track_changes(true);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let mut issued = n as u32;
    let step = 1e-3;
    for kind in ["insert", "delete", "move"] {
        let (mut seconds, mut reports) = (Vec::new(), Vec::<RefinedEdit>::new());
        let (mut change_seconds, mut triangles) = (Vec::new(), Vec::new());
        for _ in 0..edits {
            let id = loop {
                let id = rng.random_range(0..issued);
                if dynamic.point(id).is_some() {
                    break id;
                }
            };
            let at = dynamic.point(id).expect("a live point");
            let jitter = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5) * step;
            let to = (at + jitter).clamp(DVec2::ZERO, DVec2::ONE);
            let start = Instant::now();
            let report = match kind {
                "insert" => dynamic.insert(to).inspect(|_| issued += 1),
                "delete" => dynamic.delete(id),
                _ => dynamic.move_to(id, to).map(|r| r[1]),
            };
            seconds.push(start.elapsed().as_secs_f64());
            reports.extend(report.ok());
            let start = Instant::now();
            let changes = dynamic.take_changes().expect("tracked changes");
            change_seconds.push(start.elapsed().as_secs_f64());
            triangles.push((changes.removed.len() + changes.added.len()) as f64);
        }
        let windows = median(reports.iter().map(|r| f64::from(r.windows)).collect());
        let changed = median(
            reports
                .iter()
                .map(|r| (r.steiner_removed + r.steiner_added) as f64)
                .collect(),
        );
        let rebuilt = reports.iter().filter(|r| r.rebuilt).count();
        let total: f64 = seconds.iter().sum();
        let median_s = median(seconds);
        println!(
            "{kind:6}: median {:.3} ms ({:.0}x faster than a rebuild), windows {windows}, \
             Steiner points removed + added {changed}, {rebuilt} of {} refined all again; \
             all {total:.2} s",
            median_s * 1e3,
            rebuild / median_s,
            reports.len()
        );
        println!(
            "        changes: median {:.3} ms, triangles removed + added {}",
            median(change_seconds) * 1e3,
            median(triangles)
        );
    }
    dynamic.track_changes(false);
    for share in [0.001, 0.01, 0.1] {
        let count = ((n as f64 * share) as usize).max(1);
        let edits: Vec<Edit> = (0..count)
            .filter_map(|_| {
                let id = rng.random_range(0..issued);
                let at = dynamic.point(id)?;
                let jitter = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                Some(Edit::Move(
                    id,
                    (at + jitter * step).clamp(DVec2::ZERO, DVec2::ONE),
                ))
            })
            .collect();
        let start = Instant::now();
        let done = dynamic.apply(&edits);
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "batch of {} moves ({}% of the points): {seconds:.3} s, {:.2} of a rebuild{}",
            edits.len(),
            share * 100.0,
            seconds / rebuild,
            if done.is_ok() { "" } else { " (refused)" }
        );
    }
    let start = Instant::now();
    let mesh = dynamic.mesh().expect("a mesh");
    let mesh_seconds = start.elapsed().as_secs_f64();
    let (check, _) = refine_points_in_order(&dynamic.live_points(), &options).expect("a mesh");
    println!(
        "mesh() {mesh_seconds:.3} s; identical to a rebuild of the live points: {}",
        mesh.vertices == check.vertices && mesh.triangles == check.triangles
    );
}
