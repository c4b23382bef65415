//! Edit lists for dynamic meshes: one edit a line, `i X Y` (insert), `d ID` (delete) or
//! `m ID X Y` (move); blank lines and lines starting with `#` are skipped.

use glam::DVec2;

use crate::dynamic::Edit;
use crate::error::Error;

/// The edits of `text`, read from the file named `source_name`.
///
/// # Errors
/// [`Error::Parse`] naming the first line that is not an edit.
pub fn parse_edits(text: &str, source_name: &str) -> Result<Vec<Edit>, Error> {
    let mut edits = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fail = |message: String| Error::Parse {
            source_name: source_name.to_string(),
            line: k + 1,
            message,
        };
        let fields: Vec<&str> = line.split_whitespace().collect();
        let number = |i: usize| {
            fields[i]
                .parse::<f64>()
                .map_err(|_| fail(format!("'{}' is not a number", fields[i])))
        };
        let id = |i: usize| {
            fields[i]
                .parse::<u32>()
                .map_err(|_| fail(format!("'{}' is not a point id", fields[i])))
        };
        let edit = match (fields[0], fields.len()) {
            ("i", 3) => Edit::Insert(DVec2::new(number(1)?, number(2)?)),
            ("d", 2) => Edit::Delete(id(1)?),
            ("m", 4) => Edit::Move(id(1)?, DVec2::new(number(2)?, number(3)?)),
            _ => {
                return Err(fail(format!(
                    "expected `i X Y`, `d ID` or `m ID X Y`, found '{line}'"
                )));
            }
        };
        edits.push(edit);
    }
    Ok(edits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_read_and_bad_lines_are_named() {
        let edits = parse_edits("# start\ni 0.5 0.25\n\nd 3\nm 2 1e-3 0.75\n", "e.txt").unwrap();
        assert_eq!(
            edits,
            [
                Edit::Insert(DVec2::new(0.5, 0.25)),
                Edit::Delete(3),
                Edit::Move(2, DVec2::new(1e-3, 0.75)),
            ]
        );
        for (text, line) in [
            ("i 1\n", 1),
            ("d 1\nd -2\n", 2),
            ("x 1 2\n", 1),
            ("m 1 a 2", 1),
        ] {
            match parse_edits(text, "e.txt") {
                Err(Error::Parse { line: at, .. }) => assert_eq!(at, line, "{text:?}"),
                other => panic!("{text:?}: {other:?}"),
            }
        }
    }
}
