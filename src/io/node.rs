//! Triangle's `.node` and `.poly` files (<https://www.cs.cmu.edu/~quake/triangle.node.html>):
//! a header `<#vertices> <dimension> <#attributes> <#boundary markers>`, then one line per vertex
//! `<index> <x> <y> [attributes...] [marker]`. Only the coordinates are kept.
//!
//! A `.poly` file (<https://www.cs.cmu.edu/~quake/triangle.poly.html>) goes on with its segments
//! (`<#segments> <#boundary markers>`, then `<index> <end> <end> [marker]`), its holes
//! (`<#holes>`, then `<index> <x> <y>`) and, optionally, its regions (`<#regions>`, then
//! `<index> <x> <y> <attribute> [maximum area]`).

use glam::DVec2;

use super::lines::{
    Line, Span, count_lines, nth_line, parse_error, parse_f64, parse_lines, shorten, strip_bom,
};
use crate::error::Error;
use crate::options::{Input, RegionSeed, Segment};

/// What a `.node` header declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    vertices: usize,
    /// Its line number.
    line: usize,
}

/// The vertices of a Triangle `.node` file, in file order.
///
/// Vertex indices may start anywhere (0, 1, ...) and are not checked for order: the returned
/// points, and every index the pipeline reports, count from 0 in file order. As in Triangle, the
/// header's last fields may be left out (dimension 2, no attributes, no markers).
///
/// # Errors
/// [`Error::Parse`] naming the line for a missing or malformed header, a dimension other than 2,
/// a vertex line with fewer than three fields or an unparsable index or coordinate, fewer vertex
/// lines than declared, and any line after the last declared vertex.
pub fn parse_node(text: &str, source_name: &str) -> Result<Vec<DVec2>, Error> {
    Ok(parse_node_numbered(text, source_name)?.0)
}

/// [`parse_node`], with the index base of the file's vertices (see [`parse_poly_input`]).
pub(super) fn parse_node_numbered(
    text: &str,
    source_name: &str,
) -> Result<(Vec<DVec2>, i64), Error> {
    let (header, body) = read_header(strip_bom(text), source_name)?;
    let (points, rest) = read_vertices(body, header, source_name)?;
    if let Some(extra) = rest.significant().next() {
        let message = format!(
            "the header declares {} vertices but the file has more vertex lines",
            header.vertices
        );
        return Err(parse_error(source_name, extra.number, message));
    }
    Ok((points, index_base(body)))
}

/// The vertices of a Triangle `.poly` file, in file order; the segments and holes after them
/// are not read. Indices are as for [`parse_node`].
///
/// # Errors
/// As [`parse_node`], except that lines after the vertices are allowed, plus a header that
/// declares no vertices: such a `.poly` file keeps its vertices in a separate `.node` file.
pub fn parse_poly(text: &str, source_name: &str) -> Result<Vec<DVec2>, Error> {
    let text = strip_bom(text);
    let (header, body) = read_header(text, source_name)?;
    if header.vertices == 0 {
        return Err(no_vertices(source_name, header.line));
    }
    Ok(read_vertices(body, header, source_name)?.0)
}

fn no_vertices(source_name: &str, line: usize) -> Error {
    let message = "the header declares 0 vertices: this .poly file keeps its vertices in a \
                   separate .node file; read it with read_input, which reads that file too";
    parse_error(source_name, line, message)
}

/// A whole Triangle `.poly` file: its vertices, its segments with their markers (0 where the
/// segment header declares none), its holes and its regions.
///
/// Vertex attributes and markers are not kept. The points count from 0 in file order; segment
/// ends are read in the file's index base, which is Triangle's: 0 when the first vertex's index
/// is 0, else 1. A region line is `<index> <x> <y> <attribute> [maximum area]`; a zero or
/// negative area means no bound, and a line without one takes its attribute as its area bound
/// too, as Triangle reads it. The regions section may be left out; the
/// holes section may not (Triangle requires it too). A segment line whose header declares a
/// marker may leave it out (it is then 0, Triangle's rule).
///
/// # Errors
/// [`Error::Parse`] naming the line: everything [`parse_node`] refuses in the header and the
/// vertices; a missing or malformed section header; a segment, hole or region line with too
/// few or too many fields or a field that does not parse; a segment end that names no vertex;
/// a hole or region with a non-finite number; the file ending before a section's declared
/// lines; any line after the last section. A header that declares 0 vertices is refused here:
/// the vertices are then in a `.node` file, which [`crate::io::read_input`] reads.
pub fn parse_poly_input(text: &str, source_name: &str) -> Result<Input, Error> {
    parse_poly_with(text, source_name, |line| {
        Err(no_vertices(source_name, line))
    })
}

/// [`parse_poly_input`], with `node` giving the points and their index base when the header
/// declares 0 vertices (it gets the header's line number).
pub(super) fn parse_poly_with(
    text: &str,
    source_name: &str,
    node: impl FnOnce(usize) -> Result<(Vec<DVec2>, i64), Error>,
) -> Result<Input, Error> {
    let (header, body) = read_header(strip_bom(text), source_name)?;
    let (points, base, rest) = if header.vertices == 0 {
        let (points, base) = node(header.line)?;
        (points, base, body)
    } else {
        let (points, rest) = read_vertices(body, header, source_name)?;
        (points, index_base(body), rest)
    };
    let n = points.len();

    // Segments.
    let (line, rest) = section_header(rest, "segment", source_name)?;
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    if fields.len() > 2 {
        let message = format!(
            "the segment header has {} fields; expected `<#segments> <#boundary markers>`",
            fields.len()
        );
        return Err(parse_error(source_name, line.number, message));
    }
    let count = parse_count(fields[0], "segment count", source_name, line.number)?;
    let markers = match fields.get(1) {
        None => false,
        Some(token) => match parse_count(token, "boundary marker count", source_name, line.number)?
        {
            0 => false,
            1 => true,
            m => {
                let message = format!("the boundary marker count is {m}; it must be 0 or 1");
                return Err(parse_error(source_name, line.number, message));
            }
        },
    };
    let (segments, rest) = read_section(
        rest,
        count,
        "the segment header",
        "segments",
        source_name,
        |line| parse_segment(line, source_name, markers, base, n),
    )?;

    // Holes.
    let (line, rest) = section_header(rest, "hole", source_name)?;
    let count = parse_single_count(&line, "hole count", source_name)?;
    let (holes, rest) = read_section(
        rest,
        count,
        "the hole header",
        "holes",
        source_name,
        |line| parse_hole(line, source_name),
    )?;

    // Regions, if any.
    let mut lines = rest.significant();
    let regions = match lines.next() {
        None => Vec::new(),
        Some(line) => {
            let count = parse_single_count(&line, "region count", source_name)?;
            let (regions, rest) = read_section(
                rest.after(&line),
                count,
                "the region header",
                "regions",
                source_name,
                |line| parse_region(line, source_name),
            )?;
            if let Some(extra) = rest.significant().next() {
                let message = "unexpected line after the regions: a .poly file ends with them";
                return Err(parse_error(source_name, extra.number, message));
            }
            regions
        }
    };
    Ok(Input {
        points,
        segments,
        holes,
        regions,
    })
}

/// The index base of a file's vertices, as Triangle decides it: 0 when the first vertex's index
/// is 0, else 1. `body` is the text after the header, already checked.
fn index_base(body: Span) -> i64 {
    let first = body
        .significant()
        .next()
        .and_then(|line| line.content.split_whitespace().next()?.parse::<i64>().ok());
    i64::from(first != Some(0))
}

/// The next significant line, which must be the header of section `what`, and the text after it.
fn section_header<'a>(
    span: Span<'a>,
    what: &str,
    source_name: &str,
) -> Result<(Line<'a>, Span<'a>), Error> {
    match span.significant().next() {
        Some(line) => Ok((line, span.after(&line))),
        None => {
            let message = format!("the file ends before the {what} section's header");
            Err(parse_error(source_name, span.last_line(), message))
        }
    }
}

fn parse_count(token: &str, name: &str, source_name: &str, line: usize) -> Result<usize, Error> {
    token.parse::<usize>().map_err(|_| {
        parse_error(
            source_name,
            line,
            format!("cannot parse '{}' as the {name}", shorten(token)),
        )
    })
}

/// A section header of one field: a count.
fn parse_single_count(line: &Line, name: &str, source_name: &str) -> Result<usize, Error> {
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    if fields.len() != 1 {
        let message = format!("expected the {name} alone, found {} fields", fields.len());
        return Err(parse_error(source_name, line.number, message));
    }
    parse_count(fields[0], name, source_name, line.number)
}

/// The first `count` significant lines of `span` parsed by `parse` in parallel, and the text
/// after them. `header` and `what` name the section in the error for a file that ends early.
fn read_section<'a, T, F>(
    span: Span<'a>,
    count: usize,
    header: &str,
    what: &str,
    source_name: &str,
    parse: F,
) -> Result<(Vec<T>, Span<'a>), Error>
where
    T: Send,
    F: Fn(&Line) -> Result<T, Error> + Sync,
{
    if count == 0 {
        return Ok((Vec::new(), span));
    }
    let pieces = span.pieces();
    let counts = count_lines(&pieces);
    let Some((k, last)) = nth_line(&pieces, &counts, count - 1) else {
        let found: usize = counts.iter().sum();
        let message = format!("{header} declares {count} {what} but the file ends after {found}");
        return Err(parse_error(source_name, span.last_line(), message));
    };
    let mut section = pieces[..k].to_vec();
    section.push(pieces[k].through(&last));
    let values = parse_lines(&section, parse)?;
    let offset = pieces[..k].iter().map(|p| p.text.len()).sum::<usize>() + last.end;
    let rest = Span {
        text: &span.text[offset..],
        first_line: last.number + 1,
    };
    Ok((values, rest))
}

/// `<index> <end> <end> [marker]`, the ends in index base `base` among `points` vertices.
fn parse_segment(
    line: &Line,
    source_name: &str,
    markers: bool,
    base: i64,
    points: usize,
) -> Result<Segment, Error> {
    let error = |message: String| parse_error(source_name, line.number, message);
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    if fields.len() < 3 || fields.len() > 3 + usize::from(markers) {
        let expected = if markers {
            "`<index> <end> <end> <marker>`"
        } else {
            "`<index> <end> <end>` (the segment header declares no markers)"
        };
        return Err(error(format!(
            "expected {expected}, found {} field(s)",
            fields.len()
        )));
    }
    if fields[0].parse::<i64>().is_err() {
        let message = format!("cannot parse '{}' as a segment index", shorten(fields[0]));
        return Err(error(message));
    }
    let mut ends = [0u32; 2];
    for (end, token) in ends.iter_mut().zip(&fields[1..3]) {
        let index = token.parse::<i64>().map_err(|_| {
            error(format!(
                "cannot parse '{}' as a vertex index",
                shorten(token)
            ))
        })?;
        let i = index
            .checked_sub(base)
            .filter(|&i| i >= 0 && (i as u64) < points as u64);
        *end = match i.and_then(|i| u32::try_from(i).ok()) {
            Some(i) => i,
            None if points == 0 => {
                return Err(error(format!(
                    "segment end {index} names no vertex: there are none"
                )));
            }
            None => {
                let last = base + points as i64 - 1;
                return Err(error(format!(
                    "segment end {index} names no vertex: the vertices are numbered {base} to {last}"
                )));
            }
        };
    }
    let marker = match fields.get(3) {
        None => 0,
        Some(token) => token.parse::<i32>().map_err(|_| {
            error(format!(
                "cannot parse '{}' as a boundary marker",
                shorten(token)
            ))
        })?,
    };
    Ok(Segment { ends, marker })
}

/// A finite number of a hole or region line.
fn parse_finite(token: &str, what: &str, source_name: &str, line: usize) -> Result<f64, Error> {
    let value = parse_f64(token, source_name, line)?;
    if value.is_finite() {
        Ok(value)
    } else {
        let message = format!("the {what} is {value}; it must be finite");
        Err(parse_error(source_name, line, message))
    }
}

/// `<index> <x> <y>`.
fn parse_hole(line: &Line, source_name: &str) -> Result<DVec2, Error> {
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    let error = |message: String| parse_error(source_name, line.number, message);
    if fields.len() != 3 {
        return Err(error(format!(
            "expected `<index> <x> <y>` for a hole, found {} field(s)",
            fields.len()
        )));
    }
    if fields[0].parse::<i64>().is_err() {
        return Err(error(format!(
            "cannot parse '{}' as a hole index",
            shorten(fields[0])
        )));
    }
    Ok(DVec2::new(
        parse_finite(fields[1], "hole's x", source_name, line.number)?,
        parse_finite(fields[2], "hole's y", source_name, line.number)?,
    ))
}

/// `<index> <x> <y> <attribute> [maximum area]`.
fn parse_region(line: &Line, source_name: &str) -> Result<RegionSeed, Error> {
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    let error = |message: String| parse_error(source_name, line.number, message);
    if !(4..=5).contains(&fields.len()) {
        return Err(error(format!(
            "expected `<index> <x> <y> <attribute> [maximum area]` for a region, found {} \
             field(s)",
            fields.len()
        )));
    }
    if fields[0].parse::<i64>().is_err() {
        return Err(error(format!(
            "cannot parse '{}' as a region index",
            shorten(fields[0])
        )));
    }
    let number = |i: usize, what: &str| parse_finite(fields[i], what, source_name, line.number);
    let seed = DVec2::new(number(1, "region's x")?, number(2, "region's y")?);
    let attribute = number(3, "region's attribute")?;
    // Triangle reads a line with one value after the seed as both attribute and area bound.
    let max_area = match fields.get(4) {
        Some(_) => number(4, "region's maximum area")?,
        None => attribute,
    };
    let max_area = Some(max_area).filter(|&a| a > 0.0);
    Ok(RegionSeed {
        seed,
        attribute,
        max_area,
    })
}

/// The header and the text after it.
fn read_header<'a>(text: &'a str, source_name: &str) -> Result<(Header, Span<'a>), Error> {
    let whole = Span {
        text,
        first_line: 1,
    };
    let Some(line) = whole.significant().next() else {
        let message = "no header: expected `<#vertices> 2 <#attributes> <#boundary markers>`";
        return Err(parse_error(source_name, whole.last_line(), message));
    };
    let header = parse_header(&line, source_name)?;
    Ok((header, whole.after(&line)))
}

fn parse_header(line: &Line, source_name: &str) -> Result<Header, Error> {
    let fields: Vec<&str> = line.content.split_whitespace().collect();
    let error = |message: String| parse_error(source_name, line.number, message);
    if fields.len() > 4 {
        return Err(error(format!(
            "the header has {} fields; expected `<#vertices> 2 <#attributes> <#boundary markers>`",
            fields.len()
        )));
    }
    let mut values = [0, 2, 0, 0];
    const NAMES: [&str; 4] = [
        "vertex count",
        "dimension",
        "attribute count",
        "boundary marker count",
    ];
    for ((value, name), token) in values.iter_mut().zip(NAMES).zip(&fields) {
        *value = token
            .parse::<usize>()
            .map_err(|_| error(format!("cannot parse '{}' as the {name}", shorten(token))))?;
    }
    let [vertices, dimension, _, markers] = values;
    if dimension != 2 {
        return Err(error(format!(
            "the dimension is {dimension}; only 2 is supported"
        )));
    }
    if markers > 1 {
        return Err(error(format!(
            "the boundary marker count is {markers}; it must be 0 or 1"
        )));
    }
    Ok(Header {
        vertices,
        line: line.number,
    })
}

/// Parses the first `header.vertices` significant lines after the header as vertices, and
/// returns the text after them.
fn read_vertices<'a>(
    body: Span<'a>,
    header: Header,
    source_name: &str,
) -> Result<(Vec<DVec2>, Span<'a>), Error> {
    read_section(
        body,
        header.vertices,
        "the header",
        "vertices",
        source_name,
        |line| parse_vertex(line, source_name),
    )
}

/// `<index> <x> <y> [attributes...] [marker]`; attributes and markers are not read.
fn parse_vertex(line: &Line, source_name: &str) -> Result<DVec2, Error> {
    let mut fields = line.content.split_whitespace();
    let (Some(index), Some(x), Some(y)) = (fields.next(), fields.next(), fields.next()) else {
        let found = line.content.split_whitespace().count();
        let message =
            format!("expected `<index> <x> <y> [attributes...] [marker]`, found {found} field(s)");
        return Err(parse_error(source_name, line.number, message));
    };
    if index.parse::<i64>().is_err() {
        let message = format!("cannot parse '{}' as a vertex index", shorten(index));
        return Err(parse_error(source_name, line.number, message));
    }
    Ok(DVec2::new(
        parse_f64(x, source_name, line.number)?,
        parse_f64(y, source_name, line.number)?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_err(text: &str) -> (usize, String) {
        match parse_node(text, "t.node") {
            Err(Error::Parse {
                source_name,
                line,
                message,
            }) => {
                assert_eq!(source_name, "t.node");
                (line, message)
            }
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn reads_one_based_vertices_with_attributes_and_markers() {
        let text = "# a square\n4 2 1 1\n1 0 0 7.5 1\n2 1.5 0 7.5 0 # right\n\n3 1.5 2 7.5 1\n4 0 2 7.5 1\n";
        let p = parse_node(text, "t.node").unwrap();
        let expected = [(0.0, 0.0), (1.5, 0.0), (1.5, 2.0), (0.0, 2.0)];
        assert_eq!(p, expected.map(|(x, y)| DVec2::new(x, y)));
    }

    #[test]
    fn any_index_base_and_short_header() {
        let p = parse_node("2\n10 1e-3 -2\n11 inf nan\n", "t.node").unwrap();
        assert_eq!(p[0], DVec2::new(1e-3, -2.0));
        assert!(p[1].x.is_infinite() && p[1].y.is_nan());
        assert_eq!(
            parse_node("0 2 0 0\n", "t.node").unwrap(),
            Vec::<DVec2>::new()
        );
    }

    #[test]
    fn missing_header() {
        let (line, message) = parse_err("# only a comment\n\n");
        assert_eq!(line, 2);
        assert!(message.contains("no header"), "{message}");
        assert!(parse_err("").1.contains("no header"));
    }

    #[test]
    fn malformed_header() {
        assert_eq!(
            parse_err("\nfour 2 0 0\n"),
            (2, "cannot parse 'four' as the vertex count".into())
        );
        assert_eq!(
            parse_err("3 2 x 0\n").1,
            "cannot parse 'x' as the attribute count"
        );
        assert_eq!(
            parse_err("-3 2 0 0\n").1,
            "cannot parse '-3' as the vertex count"
        );
        assert!(parse_err("3 2 0 0 9\n").1.contains("5 fields"));
        assert!(parse_err("3 2 0 2\n").1.contains("must be 0 or 1"));
    }

    #[test]
    fn dimension_must_be_two() {
        assert_eq!(
            parse_err("1 3 0 0\n1 0 0 0\n"),
            (1, "the dimension is 3; only 2 is supported".into())
        );
    }

    #[test]
    fn too_few_vertex_lines() {
        let (line, message) = parse_err("3 2 0 0\n1 0 0\n2 1 1\n");
        assert_eq!(line, 3);
        assert!(
            message.contains("declares 3 vertices but the file ends after 2"),
            "{message}"
        );
    }

    #[test]
    fn too_many_vertex_lines() {
        let (line, message) = parse_err("2 2 0 0\n1 0 0\n2 1 1\n# c\n3 2 2\n");
        assert_eq!(line, 5);
        assert!(message.contains("more vertex lines"), "{message}");
    }

    #[test]
    fn too_few_fields() {
        let (line, message) = parse_err("2 2 0 0\n1 0 0\n2 1\n");
        assert_eq!(line, 3);
        assert!(message.contains("found 2 field(s)"), "{message}");
    }

    #[test]
    fn bad_numbers_are_named() {
        assert_eq!(
            parse_err("2 2 0 0\n1 0 0\n2 1 1,5\n"),
            (3, "cannot parse '1,5' as a number".into())
        );
        assert_eq!(
            parse_err("1 2 0 0\n1 x 0\n").1,
            "cannot parse 'x' as a number"
        );
        assert_eq!(
            parse_err("1 2 0 0\n1.5 0 0\n").1,
            "cannot parse '1.5' as a vertex index"
        );
    }

    #[test]
    fn poly_reads_vertices_only() {
        let text = "3 2 0 1\n0 0 0 1\n1 1 0 1\n2 0 1 1\n3 1\n0 0 1 1\n1 1 2 1\n2 2 0 1\n0\n";
        let p = parse_poly(text, "t.poly").unwrap();
        assert_eq!(p, vec![DVec2::ZERO, DVec2::X, DVec2::Y]);
    }

    #[test]
    fn poly_without_vertices_points_to_the_node_file() {
        match parse_poly("# c\n0 2 0 1\n3 1\n", "t.poly") {
            Err(Error::Parse {
                line: 2, message, ..
            }) => assert!(message.contains(".node file"), "{message}"),
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn poly_errors_like_node() {
        assert!(matches!(
            parse_poly("", "t.poly"),
            Err(Error::Parse { line: 1, .. })
        ));
        assert!(matches!(
            parse_poly("2 2 0 0\n0 0 0\n", "t.poly"),
            Err(Error::Parse { line: 2, .. })
        ));
        assert!(matches!(
            parse_poly("1 2 0 0\n0 0 y\n", "t.poly"),
            Err(Error::Parse { line: 2, .. })
        ));
    }

    #[test]
    fn large_files_parse_in_parallel_with_exact_line_numbers() {
        let n = 200_000;
        let mut text = format!("{n} 2 0 0\n");
        for i in 0..n {
            text.push_str(&format!("{i} {i} {}\n", i * 2));
        }
        let p = parse_node(&text, "t.node").unwrap();
        assert_eq!(p.len(), n);
        assert!(
            p.iter()
                .enumerate()
                .all(|(i, q)| *q == DVec2::new(i as f64, 2.0 * i as f64))
        );
        let broken = text.replacen("150000 150000", "150000 oops", 1);
        assert_eq!(
            parse_err(&broken),
            (150_002, "cannot parse 'oops' as a number".into())
        );
    }

    fn poly_err(text: &str) -> (usize, String) {
        match parse_poly_input(text, "t.poly") {
            Err(Error::Parse {
                source_name,
                line,
                message,
            }) => {
                assert_eq!(source_name, "t.poly");
                (line, message)
            }
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    const SQUARE: &str = "# square with a hole and two regions\n\
        4 2 1 1\n\
        1 0 0 0.5 1\n2 4 0 0.5 1\n3 4 4 0.5 1\n4 0 4 0.5 1\n\
        4 1 # segments\n\
        1 1 2 5\n2 2 3 0\n3 3 4 -7\n4 4 1 1\n\
        1\n1 2 2\n\
        2\n1 1 1 3.5 0.25\n2 3 3 -1 -1\n";

    #[test]
    fn a_region_line_with_one_value_takes_it_as_attribute_and_area_bound() {
        let text = SQUARE.replace(
            "2\n1 1 1 3.5 0.25\n2 3 3 -1 -1\n",
            "2\n1 1 1 0.5\n2 3 3 -2\n",
        );
        let input = parse_poly_input(&text, "t.poly").unwrap();
        let read: Vec<(f64, Option<f64>)> = input
            .regions
            .iter()
            .map(|r| (r.attribute, r.max_area))
            .collect();
        assert_eq!(read, vec![(0.5, Some(0.5)), (-2.0, None)]);
    }

    #[test]
    fn poly_input_reads_every_section() {
        let input = parse_poly_input(SQUARE, "t.poly").unwrap();
        assert_eq!(input.points.len(), 4);
        let ends: Vec<[u32; 2]> = input.segments.iter().map(|s| s.ends).collect();
        assert_eq!(ends, vec![[0, 1], [1, 2], [2, 3], [3, 0]]);
        let markers: Vec<i32> = input.segments.iter().map(|s| s.marker).collect();
        assert_eq!(markers, vec![5, 0, -7, 1]);
        assert_eq!(input.holes, vec![DVec2::new(2.0, 2.0)]);
        assert_eq!(
            input.regions,
            vec![
                RegionSeed {
                    seed: DVec2::ONE,
                    attribute: 3.5,
                    max_area: Some(0.25)
                },
                RegionSeed {
                    seed: DVec2::splat(3.0),
                    attribute: -1.0,
                    max_area: None
                },
            ]
        );
    }

    #[test]
    fn poly_input_zero_based_without_markers_or_regions() {
        let text = "3 2\n0 0 0\n1 1 0\n2 0 1\n3 0\n0 0 1\n1 1 2\n2 2 0\n0\n";
        let input = parse_poly_input(text, "t.poly").unwrap();
        let ends: Vec<[u32; 2]> = input.segments.iter().map(|s| s.ends).collect();
        assert_eq!(ends, vec![[0, 1], [1, 2], [2, 0]]);
        assert!(input.segments.iter().all(|s| s.marker == 0));
        assert!(input.holes.is_empty() && input.regions.is_empty());
        // A missing marker is 0 even when the header declares markers; a region with one value
        // takes it as its area bound too.
        let text = "2\n1 0 0\n2 1 0\n1 1\n1 1 2\n0\n1\n1 0.5 0 2\n";
        let input = parse_poly_input(text, "t.poly").unwrap();
        assert_eq!(input.segments[0].marker, 0);
        assert_eq!(input.regions[0].max_area, Some(2.0));
    }

    #[test]
    fn poly_input_errors_name_their_line() {
        let cases: &[(&str, usize, &str)] = &[
            // 0 vertices: the .node file holds them.
            ("0 2 0 1\n0 0\n0\n", 1, ".node file"),
            // Truncated before each section.
            ("1\n1 0 0\n", 2, "before the segment section"),
            ("1\n1 0 0\n0 0\n", 3, "before the hole section"),
            (
                "2\n1 0 0\n2 1 0\n2 0\n1 1 2\n",
                5,
                "declares 2 segments but the file ends after 1",
            ),
            (
                "1\n1 0 0\n0\n2\n1 0 0\n",
                5,
                "declares 2 holes but the file ends after 1",
            ),
            (
                "1\n1 0 0\n0\n0\n3\n1 0 0 1\n",
                6,
                "declares 3 regions but the file ends after 1",
            ),
            // Section headers.
            (
                "1\n1 0 0\nx 0\n0\n",
                3,
                "cannot parse 'x' as the segment count",
            ),
            ("1\n1 0 0\n0 2\n0\n", 3, "must be 0 or 1"),
            ("1\n1 0 0\n0 0 0\n0\n", 3, "3 fields"),
            (
                "1\n1 0 0\n0\n-1\n",
                4,
                "cannot parse '-1' as the hole count",
            ),
            ("1\n1 0 0\n0\n1 1\n", 4, "hole count alone"),
            (
                "1\n1 0 0\n0\n0\nmany\n",
                5,
                "cannot parse 'many' as the region count",
            ),
            // Segment lines.
            ("2\n1 0 0\n2 1 0\n1 0\n1 1\n0\n", 5, "found 2 field(s)"),
            (
                "2\n1 0 0\n2 1 0\n1 0\n1 1 2 3\n0\n",
                5,
                "declares no markers",
            ),
            (
                "2\n1 0 0\n2 1 0\n1 1\n1 1 2 3 4\n0\n",
                5,
                "found 5 field(s)",
            ),
            (
                "2\n1 0 0\n2 1 0\n1 0\n1 1 b\n0\n",
                5,
                "cannot parse 'b' as a vertex index",
            ),
            ("2\n1 0 0\n2 1 0\n1 0\ns 1 2\n0\n", 5, "as a segment index"),
            (
                "2\n1 0 0\n2 1 0\n1 1\n1 1 2 m\n0\n",
                5,
                "as a boundary marker",
            ),
            (
                "2\n1 0 0\n2 1 0\n1 0\n1 1 3\n0\n",
                5,
                "segment end 3 names no vertex: the vertices are numbered 1 to 2",
            ),
            (
                "2\n1 0 0\n2 1 0\n1 0\n1 0 1\n0\n",
                5,
                "segment end 0 names no vertex",
            ),
            ("2\n0 0 0\n1 1 0\n1 0\n1 0 2\n0\n", 5, "numbered 0 to 1"),
            // Hole and region lines.
            ("1\n1 0 0\n0\n1\n1 0\n", 5, "found 2 field(s)"),
            ("1\n1 0 0\n0\n1\n1 0 nan\n", 5, "hole's y is NaN"),
            ("1\n1 0 0\n0\n1\n1 0 z\n", 5, "cannot parse 'z' as a number"),
            ("1\n1 0 0\n0\n0\n1\n1 0 0\n", 6, "found 3 field(s)"),
            ("1\n1 0 0\n0\n0\n1\n1 0 0 1 inf\n", 6, "maximum area is inf"),
            (
                "1\n1 0 0\n0\n0\n1\n1 0 0 a 1\n",
                6,
                "cannot parse 'a' as a number",
            ),
            // Lines after the last section; vertex errors as in .node files.
            ("1\n1 0 0\n0\n0\n0\n# end\n7\n", 7, "after the regions"),
            ("2\n1 0 0\n0\n0\n", 3, "found 1 field(s)"),
            (
                "2 2 0 0\n1 0 0\n",
                2,
                "declares 2 vertices but the file ends after 1",
            ),
        ];
        for &(text, line, message) in cases {
            let (l, m) = poly_err(text);
            assert!(
                l == line && m.contains(message),
                "{text:?}: got line {l} '{m}', expected line {line} '{message}'"
            );
        }
    }
}
