//! Plain text points: one `x y` or `x,y` per line, as spreadsheets and scripts write them.

use glam::DVec2;

use super::lines::{Line, Span, parse_error, parse_f64, parse_lines, shorten, strip_bom};
use crate::error::Error;

/// The points of a text file, one per line as `x y` or `x,y`, in file order.
///
/// Fields are separated by whitespace, or by a single comma with optional whitespace around it.
/// `#` starts a comment anywhere on a line; blank lines are skipped. The first significant line
/// is skipped as a column header (such as `x,y`) when none of its fields is a number; a
/// non-numeric line anywhere else is an error. A file without points gives an empty vector.
///
/// # Errors
/// [`Error::Parse`] naming the line for a line without exactly two fields or with a field that
/// is not a number (NaN and infinities parse here; the pipeline refuses them with their index).
pub fn parse_text(text: &str, source_name: &str) -> Result<Vec<DVec2>, Error> {
    let whole = Span {
        text: strip_bom(text),
        first_line: 1,
    };
    let body = match whole.significant().next() {
        Some(first) if is_header(first.content) => whole.after(&first),
        _ => whole,
    };
    parse_lines(&body.pieces(), |line| parse_point(line, source_name))
}

/// Whether a line is a column header: no field of it parses as a number.
fn is_header(content: &str) -> bool {
    fields(content).all(|f| f.parse::<f64>().is_err())
}

/// The fields of a line, split at whitespace and commas (for header detection only).
fn fields(content: &str) -> impl Iterator<Item = &str> {
    content
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
}

/// `x y` or `x,y`.
fn parse_point(line: &Line, source_name: &str) -> Result<DVec2, Error> {
    let Some((x, y)) = split_pair(line.content) else {
        let message = format!(
            "expected two coordinates as `x y` or `x,y`, found '{}'",
            shorten(line.content)
        );
        return Err(parse_error(source_name, line.number, message));
    };
    Ok(DVec2::new(
        parse_f64(x, source_name, line.number)?,
        parse_f64(y, source_name, line.number)?,
    ))
}

/// The two fields of a trimmed line, if it has exactly two.
fn split_pair(content: &str) -> Option<(&str, &str)> {
    let (x, y) = match content.split_once(',') {
        Some((x, y)) => (x.trim(), y.trim()),
        None => content
            .split_once(char::is_whitespace)
            .map(|(x, y)| (x, y.trim()))?,
    };
    let single = |f: &str| !f.is_empty() && !f.contains(|c: char| c == ',' || c.is_whitespace());
    (single(x) && single(y)).then_some((x, y))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    fn parse_err(text: &str) -> (usize, String) {
        match parse_text(text, "t.txt") {
            Err(Error::Parse {
                source_name,
                line,
                message,
            }) => {
                assert_eq!(source_name, "t.txt");
                (line, message)
            }
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn spaces_tabs_and_commas() {
        let text = "1 2\n3\t4\n5,6\n 7 , 8 \n9,\t10\r\n-1e3   +.5\n";
        let expected = pts(&[
            (1., 2.),
            (3., 4.),
            (5., 6.),
            (7., 8.),
            (9., 10.),
            (-1e3, 0.5),
        ]);
        assert_eq!(parse_text(text, "t.txt").unwrap(), expected);
    }

    #[test]
    fn header_comments_and_blank_lines() {
        let text = "# made by hand\n\nx,y\n0.5,0.25 # first\n\n# more\n1,1\n";
        assert_eq!(
            parse_text(text, "t.txt").unwrap(),
            pts(&[(0.5, 0.25), (1., 1.)])
        );
        assert_eq!(parse_text("X Y\n1 2\n", "t.txt").unwrap(), pts(&[(1., 2.)]));
    }

    #[test]
    fn header_only_on_the_first_line() {
        assert_eq!(
            parse_err("1 2\nx,y\n3 4\n"),
            (2, "cannot parse 'x' as a number".into())
        );
        assert_eq!(parse_err("x,y\nx,y\n").0, 2);
    }

    #[test]
    fn numeric_first_line_is_data() {
        assert_eq!(parse_err("1,abc\n").1, "cannot parse 'abc' as a number");
    }

    #[test]
    fn empty_inputs_have_no_points() {
        for text in ["", "\n\n", "# nothing\n", "x,y\n"] {
            assert_eq!(
                parse_text(text, "t.txt").unwrap(),
                Vec::<DVec2>::new(),
                "{text:?}"
            );
        }
    }

    #[test]
    fn non_finite_tokens_parse() {
        let p = parse_text("nan 1\ninf,-inf\n", "t.txt").unwrap();
        assert!(p[0].x.is_nan() && p[1].x == f64::INFINITY && p[1].y == f64::NEG_INFINITY);
    }

    #[test]
    fn wrong_field_counts() {
        for bad in ["1", "1 2 3", "1,2,3", "1, 2 3", "1 2,", ",1", "1,,2", "1;2"] {
            let (line, message) = parse_err(&format!("0 0\n{bad}\n"));
            assert_eq!(line, 2, "{bad}");
            assert!(
                message.starts_with("expected two coordinates"),
                "{bad}: {message}"
            );
        }
    }

    #[test]
    fn bad_numbers_name_line_and_token() {
        assert_eq!(
            parse_err("0 0\n1 1\n2 2x\n"),
            (3, "cannot parse '2x' as a number".into())
        );
        assert_eq!(
            parse_err("x y\n1,5 2\n").1,
            "expected two coordinates as `x y` or `x,y`, found '1,5 2'"
        );
    }

    #[test]
    fn errors_report_the_earliest_line_of_a_large_file() {
        let mut text: String = (0..300_000).map(|i| format!("{i},{i}\n")).collect();
        assert_eq!(parse_text(&text, "t.txt").unwrap().len(), 300_000);
        text.push_str("bad\n");
        let text =
            text.replacen("\n1000,1000\n", "\n1000,oops\n", 1)
                .replacen("\n250000,", "\n?,", 1);
        assert_eq!(
            parse_err(&text),
            (1001, "cannot parse 'oops' as a number".into())
        );
    }
}
