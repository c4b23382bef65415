//! Reading points and writing results.
//!
//! Readers accept Triangle's `.node` and `.poly` formats and plain `x y` / `x,y` text. They return
//! the points in file order, so every index the pipeline reports (duplicates, non-finite or
//! inseparable points, the `point` column of the leaves) is a 0-based position in the file,
//! whatever index base a `.node` file uses. Large files are parsed in parallel on the current
//! rayon pool; errors name the earliest bad line whatever the thread count.

mod lines;
mod mesh_write;
mod node;
mod text;
mod write;

use std::path::Path;

use glam::DVec2;

pub use mesh_write::{
    with_extension_appended, write_edge, write_ele, write_msh, write_neigh, write_node, write_svg,
    write_triangle_files, write_vtu,
};
pub use node::{parse_node, parse_poly};
pub use text::parse_text;
pub use write::{LEAVES_CSV_HEADER, write_leaves_csv, write_points};

use crate::error::Error;

/// The points of the file at `path`: Triangle `.node` or `.poly` by extension (any case),
/// plain text otherwise. See [`parse_node`], [`parse_poly`] and [`parse_text`].
///
/// # Errors
/// [`Error::Io`] when the file cannot be read, [`Error::Parse`] naming the line for invalid
/// UTF-8 or content the format does not allow.
pub fn read_points(path: &Path) -> Result<Vec<DVec2>, Error> {
    let source_name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::Io {
        path: source_name.clone(),
        message: e.to_string(),
    })?;
    let text = lines::decode(&bytes, &source_name)?;
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("node") {
        parse_node(text, &source_name)
    } else if extension.eq_ignore_ascii_case("poly") {
        parse_poly(text, &source_name)
    } else {
        parse_text(text, &source_name)
    }
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
        let poly = TempFile::new("a.poly", b"1 2 0 0\n1 0.5 0.25\n0 0\n");
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
}
