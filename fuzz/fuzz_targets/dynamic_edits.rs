//! Any bytes as initial points and a sequence of edits of a dynamic warped mesh on the unit
//! square (or, compact, a 1 × 1.41 rectangle), or on one four times as large with the points in
//! its corner, compact or block-warped as the first byte's top bit says: after every edit the mesh equals a build from scratch of the live points, the
//! triangles the tracked changes report turn the mesh before into the mesh after, and a refused
//! edit leaves it as it was.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::balance::Separation;
use quadmesh::dynamic::{DynamicMesh, Edit};
use quadmesh::mesh::Domain;
use quadmesh::{DVec2, Input, Mode, Options, Region};

#[path = "edit_points.rs"]
mod edit_points;
#[path = "triangle_changes.rs"]
mod triangle_changes;

use edit_points::point;
use triangle_changes::{changed, triangle_set};

/// The options of a build from scratch in the dynamic mesh's warp.
fn options_of(dynamic: &DynamicMesh) -> Options {
    let mode = match dynamic.separation() {
        Separation::Corner => Mode::CompactWarp,
        Separation::Block => Mode::BlockWarp,
    };
    Options::default()
        .with_mode(mode)
        .region(Region::Rectangle(dynamic.domain()))
}

fn rebuilt(dynamic: &DynamicMesh) -> Option<quadmesh::Mesh> {
    let (_, points) = dynamic.live_points();
    quadmesh::mesh(&Input::points(points), &options_of(dynamic))
        .ok()
        .map(|(m, _)| m)
}

fuzz_target!(|data: &[u8]| {
    let Some((&count, rest)) = data.split_first() else {
        return;
    };
    let separation = if count & 0x80 == 0 {
        Separation::Corner
    } else {
        Separation::Block
    };
    let rectangle = count & 0x40 != 0;
    let count = (count % 16) as usize;
    if rest.len() < 4 * count {
        return;
    }
    let (head, tail) = rest.split_at(4 * count);
    let initial: Vec<DVec2> = head.chunks_exact(4).map(point).collect();
    // The corner tree may also keep a rectangle cut into nearly square cells (5 × 7 of them).
    let top = if rectangle && separation == Separation::Corner {
        1.41
    } else {
        1.0
    };
    // Or room around the points (which lie in the unit square): four times as wide and tall.
    let room = if count & 0x20 != 0 { 4.0 } else { 1.0 };
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(room, room * top),
    };
    let Ok(mut dynamic) = DynamicMesh::with_separation(&initial, domain, separation) else {
        return;
    };
    dynamic.track_changes(true);
    for chunk in tail.chunks_exact(5).take(32) {
        let (ids, _) = dynamic.live_points();
        let pick = |b: u8| {
            // A live id mostly, sometimes one that is not.
            ids.get(b as usize % (ids.len() + 1))
                .copied()
                .unwrap_or(u32::from(b))
        };
        let edit = match chunk[0] % 3 {
            0 => Edit::Insert(point(&chunk[1..])),
            1 => Edit::Delete(pick(chunk[1])),
            _ => Edit::Move(pick(chunk[4]), point(&chunk[..4])),
        };
        let before = dynamic.mesh().ok();
        match dynamic.apply(&[edit]) {
            Ok(_) => {
                let mesh = dynamic.mesh().ok();
                assert!(mesh == rebuilt(&dynamic), "{edit:?}: not the rebuilt mesh");
                let changes = dynamic.take_changes();
                if let (Some(before), Some(after), Ok(changes)) = (&before, &mesh, &changes) {
                    assert!(
                        changed(before, changes) == Some(triangle_set(after)),
                        "{edit:?}: the changes do not turn the old mesh into the new"
                    );
                }
                if let Some(mesh) = mesh {
                    let (_, points) = dynamic.live_points();
                    mesh.validate(&points, options_of(&dynamic).angle_bounds())
                        .unwrap_or_else(|e| panic!("{edit:?}: {e}"));
                }
            }
            Err((_, e)) => {
                assert!(!e.to_string().is_empty());
                // A refused edit changes no triangle.
                if let Ok(changes) = dynamic.take_changes() {
                    assert!(
                        changes.removed.is_empty() && changes.added.is_empty(),
                        "{edit:?} refused but reported changes"
                    );
                }
                assert!(
                    dynamic.mesh().ok() == before,
                    "{edit:?} refused but changed the mesh"
                );
            }
        }
    }
});
