//! Triangle's `.node` and `.poly` files (<https://www.cs.cmu.edu/~quake/triangle.node.html>):
//! a header `<#vertices> <dimension> <#attributes> <#boundary markers>`, then one line per vertex
//! `<index> <x> <y> [attributes...] [marker]`. Only the coordinates are kept.

use glam::DVec2;

use super::lines::{
    Line, Span, count_lines, nth_line, parse_error, parse_f64, parse_lines, shorten, strip_bom,
};
use crate::error::Error;

/// What a `.node` header declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    vertices: usize,
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
    let (header, body) = read_header(strip_bom(text), source_name)?;
    let pieces = body.pieces();
    let counts = count_lines(&pieces);
    let points = read_vertices(&pieces, &counts, header, body, source_name)?;
    if let Some((_, extra)) = nth_line(&pieces, &counts, header.vertices) {
        let message = format!(
            "the header declares {} vertices but the file has more vertex lines",
            header.vertices
        );
        return Err(parse_error(source_name, extra.number, message));
    }
    Ok(points)
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
        let line = body.first_line - 1;
        let message = "the header declares 0 vertices: this .poly file keeps its vertices in a \
                       separate .node file; read that file instead";
        return Err(parse_error(source_name, line, message));
    }
    let pieces = body.pieces();
    let counts = count_lines(&pieces);
    read_vertices(&pieces, &counts, header, body, source_name)
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
    Ok(Header { vertices })
}

/// Parses the first `header.vertices` significant lines after the header as vertices.
fn read_vertices(
    pieces: &[Span],
    counts: &[usize],
    header: Header,
    body: Span,
    source_name: &str,
) -> Result<Vec<DVec2>, Error> {
    if header.vertices == 0 {
        return Ok(Vec::new());
    }
    let Some((k, last)) = nth_line(pieces, counts, header.vertices - 1) else {
        let found: usize = counts.iter().sum();
        let message = format!(
            "the header declares {} vertices but the file ends after {found}",
            header.vertices
        );
        return Err(parse_error(source_name, body.last_line(), message));
    };
    let mut vertex_pieces = pieces[..k].to_vec();
    vertex_pieces.push(pieces[k].through(&last));
    parse_lines(&vertex_pieces, |line| parse_vertex(line, source_name))
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
}
