//! Any bytes as a `.poly` file: the reader answers with an input or a parse error; a small
//! input is meshed at a bound the bytes choose (crossings split or not, spare vertices
//! removed or not), and a mesh must pass the independent check
//! (against the cleaned input when cleaning changed nothing, else the area and Delaunay
//! checks).
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::mesh::validate_pslg;
use quadmesh::{Error, Options};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, text)) = data.split_first() else {
        return;
    };
    let text = String::from_utf8_lossy(text);
    let Ok(input) = quadmesh::io::parse_poly_input(&text, "fuzz.poly") else {
        return;
    };
    if input.points.len() > 64 || input.segments.len() > 64 || input.regions.len() > 8 {
        return;
    }
    let mut options = Options::default()
        .min_angle(f64::from(choice % 31))
        .max_vertices(20_000);
    if choice & 0x80 != 0 {
        options = options.split_crossings();
    }
    if choice & 0x40 != 0 {
        options = options.remove_spare_vertices();
    }
    match quadmesh::mesh(&input, &options) {
        Ok((mesh, report)) => {
            let clean = report.cleaning.as_ref().is_none_or(|c| c.is_clean());
            if clean && !input.segments.is_empty() {
                validate_pslg(&mesh, &input, options.angle_bounds())
                    .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
            }
            mesh.check_delaunay()
                .unwrap_or_else(|e| panic!("not Delaunay: {e}"));
        }
        Err(
            Error::VertexBudget(partial)
            | Error::RefinementResolution {
                reached: Some(partial),
                ..
            },
        ) => {
            partial
                .mesh
                .check_delaunay()
                .unwrap_or_else(|e| panic!("partial: {e}"));
        }
        Err(_) => {}
    }
});
