//! Any bytes as a `.node` file, a text file of points, an edit list or a `.poly` file, as the
//! first byte picks. Each reader answers with its content or with a parse error naming a line
//! of the file; what it reads, written back by the crate's writers (or, for edits, in their
//! one-line form), reads back to the same bits; a few points read from a file mesh to a mesh
//! that passes `validate`, or end in a typed error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::dynamic::Edit;
use quadmesh::io::{parse_edits, parse_node, parse_poly_input, parse_text};
use quadmesh::io::{write_input_poly, write_points};
use quadmesh::{DVec2, Error, Input, Options};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, bytes)) = data.split_first() else {
        return;
    };
    let text = String::from_utf8_lossy(bytes);
    match choice % 4 {
        0 => points_read(&text, parse_node(&text, "fuzz.node")),
        1 => points_read(&text, parse_text(&text, "fuzz.txt")),
        2 => edits_read(&text, parse_edits(&text, "fuzz.edits")),
        _ => poly_read(&text, parse_poly_input(&text, "fuzz.poly")),
    }
});

/// A reader's error must be a parse error naming a line of the file (or the line after its
/// last, for a file that ends early).
fn check_error(text: &str, error: Error) {
    let Error::Parse { line, .. } = error else {
        panic!("a reader answered with {error:?}");
    };
    let lines = text.split('\n').count();
    assert!(
        (1..=lines + 1).contains(&line),
        "line {line} named in a file of {lines} lines"
    );
}

fn points_read(text: &str, read: Result<Vec<DVec2>, Error>) {
    let points = match read {
        Ok(points) => points,
        Err(error) => return check_error(text, error),
    };
    let mut written = Vec::new();
    write_points(&mut written, &points).unwrap();
    let again = parse_text(std::str::from_utf8(&written).unwrap(), "again.txt")
        .unwrap_or_else(|e| panic!("written points do not read back: {e}"));
    assert_eq!(
        debug(&points),
        debug(&again),
        "points changed through a text file"
    );
    if !points.is_empty() {
        let input = Input::points(points.clone());
        assert_eq!(
            debug(&input),
            debug(&poly_round_trip(&input)),
            "points changed through a .poly file"
        );
    }
    if points.len() <= 24 {
        mesh_points(&points);
    }
}

/// A few points from a file: a valid mesh or a typed error.
fn mesh_points(points: &[DVec2]) {
    let options = Options::default().max_vertices(20_000);
    match quadmesh::mesh(&Input::points(points.to_vec()), &options) {
        Ok((mesh, _)) => {
            mesh.validate(points, options.angle_bounds())
                .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
            mesh.check_delaunay()
                .unwrap_or_else(|e| panic!("not Delaunay: {e}"));
        }
        Err(Error::VertexBudget(partial)) => partial
            .mesh
            .check_delaunay()
            .unwrap_or_else(|e| panic!("partial mesh not Delaunay: {e}")),
        Err(_) => {}
    }
}

fn edits_read(text: &str, read: Result<Vec<Edit>, Error>) {
    let edits = match read {
        Ok(edits) => edits,
        Err(error) => return check_error(text, error),
    };
    let written: String = edits.iter().map(edit_line).collect();
    let again = parse_edits(&written, "again.edits")
        .unwrap_or_else(|e| panic!("written edits do not read back: {e}"));
    assert_eq!(debug(&edits), debug(&again), "edits changed through a file");
}

fn edit_line(edit: &Edit) -> String {
    match edit {
        Edit::Insert(p) => format!("i {} {}\n", p.x, p.y),
        Edit::Delete(id) => format!("d {id}\n"),
        Edit::Move(id, p) => format!("m {id} {} {}\n", p.x, p.y),
    }
}

fn poly_read(text: &str, read: Result<Input, Error>) {
    let input = match read {
        Ok(input) => input,
        Err(error) => return check_error(text, error),
    };
    assert_eq!(
        debug(&input),
        debug(&poly_round_trip(&input)),
        "a .poly input changed through the writer"
    );
}

/// `input` written as a `.poly` file and read back.
fn poly_round_trip(input: &Input) -> Input {
    let mut written = Vec::new();
    write_input_poly(input, &mut written).unwrap();
    parse_poly_input(std::str::from_utf8(&written).unwrap(), "again.poly")
        .unwrap_or_else(|e| panic!("a written .poly does not read back: {e}"))
}

/// Debug forms compare floats by their shortest round-trip text: bit for bit, NaN equal to NaN.
fn debug(value: &impl std::fmt::Debug) -> String {
    format!("{value:?}")
}
