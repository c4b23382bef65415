//! Writes the planar straight-line graphs on which peer meshers fail (the cases of
//! `tests/peer_failures.rs`) as `.poly` files, for `scripts/peer_failures.py` to mesh with
//! quadmesh and Triangle. Usage:
//! `cargo run --release --example peer_failure_cases -- DIR`; prints one line per case: the
//! file, and `split` where its crossings are to be split.

use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

#[allow(dead_code)]
#[path = "../tests/common/peer_cases.rs"]
mod peer_cases;

fn main() -> std::io::Result<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "peer_cases".into()),
    );
    std::fs::create_dir_all(&dir)?;
    for case in peer_cases::peer_failure_cases() {
        let path = dir.join(format!("{}.poly", case.name));
        if case.name == "nested_holes_zero_based" {
            // As written by hand, numbered from zero.
            std::fs::write(&path, peer_cases::NESTED_HOLES_POLY)?;
        } else {
            quadmesh::io::write_input_poly(&case.input, BufWriter::new(File::create(&path)?))?;
        }
        let split = if case.split_crossings { " split" } else { "" };
        println!("{}{split}", path.display());
    }
    Ok(())
}
