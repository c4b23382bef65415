//! Reading inputs and writing results.
//!
//! Readers accept Triangle's `.node` and `.poly` formats and plain `x y` / `x,y` text. They return
//! the points in file order, so every index the pipeline reports (duplicates, non-finite or
//! inseparable points, the `point` column of the leaves) is a 0-based position in the file,
//! whatever index base a `.node` file uses. Large files are parsed in parallel on the current
//! rayon pool; errors name the earliest bad line whatever the thread count.

mod edits;
mod lines;
mod mesh_write;
mod node;
mod text;
mod write;

use std::path::Path;

use glam::DVec2;

pub use edits::parse_edits;
pub use mesh_write::{
    with_extension_appended, write_edge, write_ele, write_msh, write_neigh, write_node, write_poly,
    write_svg, write_triangle_files, write_vtu,
};
pub use node::{parse_node, parse_poly, parse_poly_input};
pub use text::parse_text;
pub use write::{
    LEAVES_CSV_HEADER, write_graph_leaves_csv, write_input_poly, write_leaves_csv, write_points,
};

use crate::error::Error;
use crate::options::Input;

/// The points of the file at `path`: [`read_input`]'s points (a `.poly` file's segments, holes
/// and regions are read, checked and left out).
///
/// # Errors
/// As [`read_input`].
pub fn read_points(path: &Path) -> Result<Vec<DVec2>, Error> {
    Ok(read_input(path)?.points)
}

/// The input in the file at `path`: a whole planar straight-line graph from a Triangle `.poly`
/// file ([`parse_poly_input`]), points only from a `.node` file ([`parse_node`]) or from plain
/// text ([`parse_text`]); the format goes by the extension, in any case.
///
/// A `.poly` file whose header declares 0 vertices keeps them in the `.node` file of the same
/// base name (Triangle's convention): that file is read for the points, and the segment ends are
/// in its index base.
///
/// # Errors
/// [`Error::Io`] when the file cannot be read, [`Error::Parse`] naming the file and line for
/// invalid UTF-8 or content the format does not allow, and, for a `.poly` file that declares 0
/// vertices, naming its header line when its `.node` file is missing or unreadable (the errors
/// inside the `.node` file name that file).
pub fn read_input(path: &Path) -> Result<Input, Error> {
    let source_name = path.display().to_string();
    let bytes = read_bytes(path)?;
    let text = lines::decode(&bytes, &source_name)?;
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("node") {
        Ok(Input::points(parse_node(text, &source_name)?))
    } else if extension.eq_ignore_ascii_case("poly") {
        node::parse_poly_with(text, &source_name, |line| {
            let node_path = path.with_extension("node");
            let node_name = node_path.display().to_string();
            let node_bytes = read_bytes(&node_path).map_err(|e| {
                let reason = match e {
                    Error::Io { message, .. } => message,
                    other => other.to_string(),
                };
                let message = format!(
                    "the header declares 0 vertices, so they are in {node_name}, which cannot \
                     be read: {reason}"
                );
                lines::parse_error(&source_name, line, message)
            })?;
            let node_text = lines::decode(&node_bytes, &node_name)?;
            node::parse_node_numbered(node_text, &node_name)
        })
    } else {
        Ok(Input::points(parse_text(text, &source_name)?))
    }
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, Error> {
    std::fs::read(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file in the temporary directory, removed when dropped.
    struct TempFile(std::path::PathBuf);

    impl TempFile {
        fn new(name: &str, contents: &[u8]) -> TempFile {
            let path =
                std::env::temp_dir().join(format!("quadmesh-io-{}-{name}", std::process::id()));
            std::fs::write(&path, contents).unwrap();
            TempFile(path)
        }
    }

    impl Drop for TempFile {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    #[test]
    fn dispatches_on_extension() {
        let node = TempFile::new("a.NODE", b"1 2 0 0\n1 0.5 0.25\n");
        assert_eq!(read_points(&node.0).unwrap(), vec![DVec2::new(0.5, 0.25)]);
        let poly = TempFile::new("a.poly", b"1 2 0 0\n1 0.5 0.25\n0 0\n0\n");
        assert_eq!(read_points(&poly.0).unwrap(), vec![DVec2::new(0.5, 0.25)]);
        let text = TempFile::new("a.csv", b"x,y\n0.5,0.25\n");
        assert_eq!(read_points(&text.0).unwrap(), vec![DVec2::new(0.5, 0.25)]);
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let path = std::env::temp_dir().join("quadmesh-io-no-such-file.txt");
        match read_points(&path) {
            Err(Error::Io { path: p, message }) => {
                assert!(p.ends_with("quadmesh-io-no-such-file.txt"));
                assert!(!message.is_empty());
            }
            other => panic!("expected an I/O error, got {other:?}"),
        }
    }

    #[test]
    fn invalid_utf8_is_a_parse_error() {
        let file = TempFile::new("bad-utf8.txt", b"1 2\n\xc3\x28 1\n");
        assert!(matches!(
            read_points(&file.0),
            Err(Error::Parse { line: 2, .. })
        ));
    }

    #[test]
    fn read_input_reads_a_poly_file_whole_and_others_as_points() {
        let poly = TempFile::new(
            "whole.poly",
            b"3 2 0 0\n0 0 0\n1 1 0\n2 0 1\n1 1\n0 0 2 4\n1\n0 0.2 0.2\n",
        );
        let input = read_input(&poly.0).unwrap();
        assert_eq!(input.points.len(), 3);
        assert_eq!(
            input.segments,
            vec![crate::Segment {
                ends: [0, 2],
                marker: 4
            }]
        );
        assert_eq!(input.holes, vec![DVec2::splat(0.2)]);
        let node = TempFile::new("only.node", b"1\n1 0.5 0.25\n");
        assert_eq!(
            read_input(&node.0).unwrap(),
            Input::points(vec![DVec2::new(0.5, 0.25)])
        );
    }

    #[test]
    fn a_poly_file_without_vertices_reads_its_node_file() {
        let dir = std::env::temp_dir().join(format!("quadmesh-io-pair-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let poly = dir.join("pair.poly");
        std::fs::write(
            &poly,
            "# vertices in pair.node\n0 2 0 1\n2 1\n1 0 1 3\n2 1 2 3\n0\n",
        )
        .unwrap();
        // Missing .node file: a parse error on the header line that names it.
        match read_input(&poly) {
            Err(Error::Parse {
                line: 2,
                message,
                source_name,
            }) => {
                assert!(source_name.ends_with("pair.poly"));
                assert!(message.contains("pair.node"), "{message}");
            }
            other => panic!("unexpected {other:?}"),
        }
        // Zero-based vertices in the .node file: the segment ends are zero-based too.
        std::fs::write(dir.join("pair.node"), "3 2 0 0\n0 0 0\n1 1 0\n2 1 1\n").unwrap();
        let input = read_input(&poly).unwrap();
        assert_eq!(input.points.len(), 3);
        let ends: Vec<[u32; 2]> = input.segments.iter().map(|s| s.ends).collect();
        assert_eq!(ends, vec![[0, 1], [1, 2]]);
        assert_eq!(read_points(&poly).unwrap(), input.points);
        // An error inside the .node file names that file.
        std::fs::write(dir.join("pair.node"), "3 2 0 0\n0 0 0\n1 1 x\n2 1 1\n").unwrap();
        match read_input(&poly) {
            Err(Error::Parse {
                line: 3,
                source_name,
                ..
            }) => assert!(source_name.ends_with("pair.node")),
            other => panic!("unexpected {other:?}"),
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
