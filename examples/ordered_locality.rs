//! How far one edit reaches in refinement in order, against the default refinement: for each of
//! a number of single-point insertions and deletions, the Steiner points that differ between
//! the meshes before and after, and the distance of the farthest from the edit in units of the
//! local mesh size there (the distance from the edit to the nearest other vertex of the mesh
//! before). Usage:
//! `cargo run --release --example ordered_locality -- [points] [edits] [angle] [dist]`.

use std::collections::HashSet;

use quadmesh::generate::{Distribution2d, points};
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points, refine_points_in_order};
use quadmesh::{DVec2, Domain, Error, Mesh};

type Refine = fn(&[DVec2], &RefineOptions) -> Result<(Mesh, quadmesh::MeshReport), Error>;

fn steiner_points(mesh: &Mesh) -> HashSet<(u64, u64)> {
    mesh.vertices
        .iter()
        .zip(&mesh.vertex_input)
        .filter(|&(_, &input)| input == u32::MAX)
        .map(|(p, _)| (p.x.to_bits(), p.y.to_bits()))
        .collect()
}

/// The Steiner points that differ and the farthest of them from `at`.
fn difference(before: &Mesh, after: &Mesh, at: DVec2) -> (usize, f64) {
    let (a, b) = (steiner_points(before), steiner_points(after));
    let changed: Vec<_> = a.symmetric_difference(&b).collect();
    let farthest = changed
        .iter()
        .map(|&&(x, y)| DVec2::new(f64::from_bits(x), f64::from_bits(y)).distance(at))
        .fold(0.0, f64::max);
    (changed.len(), farthest)
}

/// The distance from `at` to the nearest vertex of `mesh` other than `at` itself.
fn local_size(mesh: &Mesh, at: DVec2) -> f64 {
    mesh.vertices
        .iter()
        .filter(|&&v| v != at)
        .map(|v| v.distance(at))
        .fold(f64::MAX, f64::min)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(20_000, |s| s.parse().expect("points"));
    let edits: usize = args.get(2).map_or(20, |s| s.parse().expect("edits"));
    let angle: f64 = args.get(3).map_or(30.0, |s| s.parse().expect("angle"));
    let dist: Distribution2d = args
        .get(4)
        .map_or(Distribution2d::Uniform, |s| s.parse().expect("dist"));
    let input = points(dist, n, 7);
    let (lo, hi) = input.iter().fold(
        (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let margin = (hi - lo).max_element() * 0.01;
    let options = RefineOptions {
        min_angle_deg: angle,
        domain: RefineDomain::Rectangle(Domain {
            lo: lo - margin,
            hi: hi + margin,
        }),
        ..RefineOptions::default()
    };
    // Insertions between an input point and its nearest input neighbour (a little off the
    // line), where the points are, as in a simulation whose points move.
    let extra: Vec<DVec2> = (0..edits)
        .map(|k| {
            let p = input[k * (n / edits) + 1];
            let q = *input
                .iter()
                .filter(|&&q| q != p)
                .min_by(|a, b| a.distance(p).total_cmp(&b.distance(p)))
                .expect("two points");
            p + (q - p) * 0.5 + (q - p).perp() * 0.1
        })
        .collect();
    let refiners: [(&str, Refine); 2] = [
        ("in order", refine_points_in_order),
        ("default", refine_points),
    ];
    for (name, refine) in refiners {
        let (base, _) = refine(&input, &options).expect("base mesh");
        let steiner = steiner_points(&base).len();
        for kind in ["insert", "delete"] {
            let (mut counts, mut reach) = (Vec::new(), Vec::new());
            for (k, &new) in extra.iter().enumerate() {
                let (edited, at) = if kind == "insert" {
                    let mut e = input.clone();
                    e.push(new);
                    (e, new)
                } else {
                    let mut e = input.clone();
                    let at = e.remove(k * (n / edits));
                    (e, at)
                };
                let (after, _) = refine(&edited, &options).expect("edited mesh");
                let spacing = local_size(&base, at);
                let (count, farthest) = difference(&base, &after, at);
                counts.push(count as f64);
                reach.push(farthest / spacing);
            }
            let max = counts.iter().copied().fold(0.0, f64::max);
            println!(
                "{name:8} {kind}: {n} points, {steiner} Steiner points; changed per edit: \
                 median {}, max {max}; farthest change: median {:.1}, max {:.1} local sizes",
                median(counts),
                median(reach.clone()),
                reach.iter().copied().fold(0.0, f64::max),
            );
        }
    }
}
