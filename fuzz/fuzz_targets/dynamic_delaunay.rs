//! Any bytes as an angle bound, initial points and a sequence of edits of a dynamic quality
//! Delaunay mesh on the unit square: after every edit the mesh equals refinement in order of
//! the live points (byte for byte), passes `validate` with the bound and the exact Delaunay
//! check, the triangles the tracked changes report turn the mesh before into the mesh after,
//! and a refused edit leaves it as it was.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::dynamic::DynamicDelaunay;
use quadmesh::mesh::{AngleBounds, Domain};
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{DVec2, Mesh};

#[path = "edit_points.rs"]
mod edit_points;
#[path = "triangle_changes.rs"]
mod triangle_changes;

use edit_points::point;
use triangle_changes::{changed, triangle_set};

/// The mesh refinement in order makes of the live points, if it makes one.
fn rebuilt(dynamic: &DynamicDelaunay, options: &RefineOptions) -> Option<Mesh> {
    refine_points_in_order(&dynamic.live_points(), options)
        .ok()
        .map(|(m, _)| m)
}

fn same(a: &Option<Mesh>, b: &Option<Mesh>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => a.vertices == b.vertices && a.triangles == b.triangles,
        (None, None) => true,
        _ => false,
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&[angle, count], rest)) = data.split_first_chunk::<2>() else {
        return;
    };
    let count = (count % 24) as usize;
    if rest.len() < 4 * count {
        return;
    }
    let (head, tail) = rest.split_at(4 * count);
    let initial: Vec<DVec2> = head.chunks_exact(4).map(point).collect();
    let options = RefineOptions {
        min_angle_deg: f64::from(angle % 31),
        domain: RefineDomain::Rectangle(Domain {
            lo: DVec2::ZERO,
            hi: DVec2::ONE,
        }),
        max_vertices: Some(20_000),
        ..RefineOptions::default()
    };
    let Ok(mut dynamic) = DynamicDelaunay::new(&initial, &options) else {
        return;
    };
    let bounds = AngleBounds {
        min_deg: options.min_angle_deg,
        max_deg: 180.0 - 2.0 * options.min_angle_deg,
    };
    dynamic.track_changes(true);
    let mut issued = initial.len() as u32;
    for chunk in tail.chunks_exact(5).take(16) {
        let live: Vec<u32> = (0..issued)
            .filter(|&id| dynamic.point(id).is_some())
            .collect();
        // A live id mostly, sometimes one that is not.
        let pick = |b: u8| {
            live.get(b as usize % (live.len() + 1))
                .copied()
                .unwrap_or(u32::from(b))
        };
        let before = dynamic.mesh().ok();
        let done = match chunk[0] % 3 {
            0 => dynamic.insert(point(&chunk[1..])).map(|r| {
                issued += 1;
                r.id
            }),
            1 => dynamic.delete(pick(chunk[1])).map(|r| r.id),
            _ => dynamic
                .move_to(pick(chunk[4]), point(&chunk[..4]))
                .map(|r| r[1].id),
        };
        let mesh = dynamic.mesh().ok();
        let changes = dynamic.take_changes().expect("tracked changes");
        if let (Some(before), Some(after)) = (&before, &mesh) {
            assert!(
                changed(before, &changes) == Some(triangle_set(after)),
                "the changes do not turn the old mesh into the new"
            );
        }
        match done {
            Ok(id) => {
                assert!(
                    same(&mesh, &rebuilt(&dynamic, &options)),
                    "edit of {id}: not the rebuilt mesh"
                );
                if let Some(mesh) = mesh {
                    mesh.validate(&dynamic.live_points(), bounds)
                        .unwrap_or_else(|e| panic!("edit of {id}: {e}"));
                    mesh.check_delaunay()
                        .unwrap_or_else(|e| panic!("edit of {id}: not Delaunay: {e}"));
                }
            }
            Err(e) => {
                assert!(!e.to_string().is_empty());
                assert!(
                    same(&mesh, &before),
                    "a refused edit ({e}) changed the mesh"
                );
            }
        }
    }
});
