//! Any bytes as up to 64 points (raw f64 bits) and options: every mode answers with a mesh that
//! passes `validate` (`validate_nonobtuse` in the nonobtuse mode; in the Delaunay mode, the exact
//! Delaunay check too) or a typed error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::{DVec2, Error, Input, Mode, Options, Region};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, rest)) = data.split_first() else {
        return;
    };
    let points: Vec<DVec2> = rest
        .chunks_exact(16)
        .take(64)
        .map(|c| {
            let x = f64::from_le_bytes(c[..8].try_into().unwrap());
            let y = f64::from_le_bytes(c[8..].try_into().unwrap());
            DVec2::new(x, y)
        })
        .collect();
    let mut options = if choice & 1 == 0 {
        Options::default()
            .min_angle(f64::from((choice >> 1) % 34))
            .max_vertices(20_000)
    } else if choice & 0x80 == 0 {
        Options::default().warp()
    } else {
        Options::default().nonobtuse()
    };
    if choice & 0x40 != 0 {
        options = options.region(Region::Square);
    }
    match quadmesh::mesh(&Input::points(points.clone()), &options) {
        Ok((mesh, _)) => {
            let checked = if options.mode() == Mode::Nonobtuse {
                mesh.validate_nonobtuse(&points)
            } else {
                mesh.validate(&points, options.angle_bounds())
            };
            checked.unwrap_or_else(|e| panic!("invalid mesh: {e}"));
            if choice & 1 == 0 {
                mesh.check_delaunay().unwrap_or_else(|e| panic!("not Delaunay: {e}"));
            }
        }
        Err(Error::VertexBudget(partial)) => {
            partial.mesh.check_delaunay().unwrap_or_else(|e| panic!("partial: {e}"));
        }
        Err(_) => {}
    }
});
