//! Any bytes as initial points and a sequence of edits of a dynamic warped mesh on the unit
//! square: after every edit the mesh equals a build from scratch of the live points, and a
//! refused edit leaves it as it was.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::dynamic::{DynamicMesh, Edit};
use quadmesh::mesh::Domain;
use quadmesh::{DVec2, Input, Options, Region};

/// A coordinate from two bytes, mostly on a 1/4096 grid of the square (so that points land on
/// sides and close together), sometimes outside it or not finite.
fn coordinate(b: &[u8]) -> f64 {
    let v = u16::from_le_bytes([b[0], b[1]]);
    match v >> 13 {
        0 => f64::from(v & 0x0FFF) / 4096.0 + f64::from(v >> 12) * 1e-9,
        1 => f64::from(v & 0x1FFF) / 8191.0,
        2 if v & 0xFF == 0 => f64::NAN,
        2 => 1.0 + f64::from(v & 0xFF) / 256.0,
        _ => f64::from(v) / 65535.0,
    }
}

fn point(b: &[u8]) -> DVec2 {
    DVec2::new(coordinate(&b[..2]), coordinate(&b[2..4]))
}

fn rebuilt(dynamic: &DynamicMesh) -> Option<quadmesh::Mesh> {
    let (_, points) = dynamic.live_points();
    let options = Options::default()
        .warp()
        .region(Region::Rectangle(dynamic.domain()));
    quadmesh::mesh(&Input::points(points), &options).ok().map(|(m, _)| m)
}

fuzz_target!(|data: &[u8]| {
    let Some((&count, rest)) = data.split_first() else {
        return;
    };
    let count = (count % 16) as usize;
    if rest.len() < 4 * count {
        return;
    }
    let (head, tail) = rest.split_at(4 * count);
    let initial: Vec<DVec2> = head.chunks_exact(4).map(point).collect();
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let Ok(mut dynamic) = DynamicMesh::new(&initial, domain) else {
        return;
    };
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
                if let Some(mesh) = mesh {
                    let (_, points) = dynamic.live_points();
                    mesh.validate(&points, Options::default().warp().angle_bounds())
                        .unwrap_or_else(|e| panic!("{edit:?}: {e}"));
                }
            }
            Err((_, e)) => {
                assert!(!e.to_string().is_empty());
                assert!(dynamic.mesh().ok() == before, "{edit:?} refused but changed the mesh");
            }
        }
    }
});
