//! How many Steiner points and triangles an edit of a dynamic quality Delaunay mesh changes,
//! as the spread of the points grows: uniform points in the unit square with a cluster of
//! side 2^-s in it, for growing s. Each edit moves a point by a hundredth of the spacing
//! around it (half of them in the cluster); the Steiner points changed are those of the mesh
//! after and not before, and the other way round. Usage:
//! `cargo run --release --example steiner_changes_by_spread -- [points] [edits]`.

use std::collections::HashSet;

use quadmesh::DVec2;
use quadmesh::dynamic::DynamicDelaunay;
use quadmesh::generate::{Distribution2d, points};
use quadmesh::mesh::Domain;
use quadmesh::refine::{RefineDomain, RefineOptions};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The mesh's vertices as bits.
fn vertex_set(dynamic: &DynamicDelaunay) -> HashSet<[u64; 2]> {
    let mesh = dynamic.mesh().expect("a mesh");
    mesh.vertices
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits()])
        .collect()
}

/// The spread: the domain's side over the closest pair's distance.
fn spread(points: &[DVec2]) -> f64 {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.x.total_cmp(&b.x));
    let mut closest = f64::INFINITY;
    for (i, p) in sorted.iter().enumerate() {
        for q in &sorted[i + 1..] {
            if q.x - p.x >= closest {
                break;
            }
            closest = closest.min(p.distance(*q));
        }
    }
    1.0 / closest
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(20_000, |s| s.parse().expect("points"));
    let edits: usize = args.get(2).map_or(60, |s| s.parse().expect("edits"));
    let options = RefineOptions {
        min_angle_deg: 30.0,
        domain: RefineDomain::Rectangle(Domain {
            lo: DVec2::ZERO,
            hi: DVec2::ONE,
        }),
        ..RefineOptions::default()
    };
    println!("s  log2(spread)  steiner  changed (median, mean)  triangles changed (median)");
    for s in [4, 8, 12, 16, 20, 24] {
        let cluster = n / 20;
        let side = 0.5f64.powi(s);
        let centre = DVec2::new(0.37, 0.61);
        let mut input = points(Distribution2d::Uniform, n - cluster, 1);
        let first_in_cluster = input.len() as u32;
        input.extend(
            points(Distribution2d::Uniform, cluster, 2)
                .into_iter()
                .map(|p| centre + (p - 0.5) * side),
        );
        let log_spread = spread(&input).log2();
        let mut dynamic = DynamicDelaunay::new(&input, &options).expect("a dynamic mesh");
        dynamic.track_changes(true);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(s as u64);
        let (mut changed, mut triangles) = (Vec::new(), Vec::new());
        let mut before = vertex_set(&dynamic);
        for k in 0..edits {
            let (id, step) = if k % 2 == 0 {
                (
                    first_in_cluster + rng.random_range(0..cluster as u32),
                    side / (cluster as f64).sqrt(),
                )
            } else {
                (
                    rng.random_range(0..first_in_cluster),
                    1.0 / (n as f64).sqrt(),
                )
            };
            let at = dynamic.point(id).expect("a live point");
            let jitter = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let to = (at + jitter * step * 0.01).clamp(DVec2::ZERO, DVec2::ONE);
            if dynamic.move_to(id, to).is_err() {
                continue;
            }
            let after = vertex_set(&dynamic);
            // The moved point itself is not a Steiner point.
            changed.push((before.symmetric_difference(&after).count() - 2) as f64);
            let change = dynamic.take_changes().expect("tracked changes");
            triangles.push((change.removed.len() + change.added.len()) as f64);
            before = after;
        }
        let mean = changed.iter().sum::<f64>() / changed.len() as f64;
        println!(
            "{s:2} {log_spread:12.1}  {:7}  {:7} {:7.1}  {:7}",
            dynamic.steiner_count(),
            median(changed),
            mean,
            median(triangles)
        );
    }
}
