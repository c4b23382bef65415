//! Line handling the readers share: comments, blank lines, line numbers, and splitting a text
//! into pieces at line boundaries so large files parse in parallel with exact line numbers.

use rayon::prelude::*;

use crate::error::Error;

/// Bytes per piece of a parallel parse: large enough that rayon's task overhead is small.
const PIECE_BYTES: usize = 1 << 18;

/// A significant line: comment removed, trimmed, not blank.
#[derive(Clone, Copy, Debug)]
pub(super) struct Line<'a> {
    /// 1-based line number in the whole file.
    pub number: usize,
    /// The text before any `#`, trimmed.
    pub content: &'a str,
    /// Byte offset just past the line (its newline included) in its [`Span`].
    pub end: usize,
}

/// A piece of the input that starts at the beginning of a line.
#[derive(Clone, Copy, Debug)]
pub(super) struct Span<'a> {
    /// The text, whole lines only (the last one may lack its newline).
    pub text: &'a str,
    /// 1-based number of its first line.
    pub first_line: usize,
}

impl<'a> Span<'a> {
    /// The significant lines in order; `#` starts a comment anywhere on a line.
    pub fn significant(self) -> impl Iterator<Item = Line<'a>> {
        let mut end = 0;
        self.text
            .split_inclusive('\n')
            .enumerate()
            .filter_map(move |(i, raw)| {
                end += raw.len();
                let content = raw.split_once('#').map_or(raw, |(before, _)| before).trim();
                let number = self.first_line + i;
                (!content.is_empty()).then_some(Line {
                    number,
                    content,
                    end,
                })
            })
    }

    /// The text after `line` (a line of this span), as a span of its own.
    pub fn after(self, line: &Line) -> Span<'a> {
        Span {
            text: &self.text[line.end..],
            first_line: line.number + 1,
        }
    }

    /// The text up to and including `line` (a line of this span).
    pub fn through(self, line: &Line) -> Span<'a> {
        Span {
            text: &self.text[..line.end],
            first_line: self.first_line,
        }
    }

    /// Number of the last line, counting a final line without a newline.
    pub fn last_line(self) -> usize {
        let newlines = bytecount(self.text.as_bytes());
        let unterminated = !self.text.is_empty() && !self.text.ends_with('\n');
        (self.first_line + newlines + usize::from(unterminated))
            .saturating_sub(1)
            .max(1)
    }

    /// Splits the span into pieces at line boundaries, numbering their lines in parallel.
    pub fn pieces(self) -> Vec<Span<'a>> {
        let cuts = piece_ends(self.text.as_bytes());
        let texts: Vec<&'a str> = cuts
            .iter()
            .scan(0, |start, &end| {
                let piece = &self.text[*start..end];
                *start = end;
                Some(piece)
            })
            .collect();
        let newlines: Vec<usize> = texts.par_iter().map(|t| bytecount(t.as_bytes())).collect();
        let mut first_line = self.first_line;
        texts
            .into_iter()
            .zip(newlines)
            .map(|(text, n)| {
                let span = Span { text, first_line };
                first_line += n;
                span
            })
            .collect()
    }
}

/// End offsets of pieces of about [`PIECE_BYTES`], each just past a newline (or at the end).
fn piece_ends(bytes: &[u8]) -> Vec<usize> {
    let mut ends = Vec::with_capacity(bytes.len() / PIECE_BYTES + 1);
    let mut start = 0;
    while start < bytes.len() {
        let probe = (start + PIECE_BYTES).min(bytes.len());
        let end = bytes[probe..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| probe + i + 1);
        ends.push(end);
        start = end;
    }
    ends
}

fn bytecount(bytes: &[u8]) -> usize {
    bytes.iter().filter(|&&b| b == b'\n').count()
}

/// The significant lines of `pieces` parsed by `parse`, in order, in parallel. The error reported
/// is the one on the earliest line, whatever the thread count.
pub(super) fn parse_lines<T, F>(pieces: &[Span], parse: F) -> Result<Vec<T>, Error>
where
    T: Send,
    F: Fn(&Line) -> Result<T, Error> + Sync,
{
    let parts: Vec<Result<Vec<T>, Error>> = pieces
        .par_iter()
        .map(|piece| piece.significant().map(|line| parse(&line)).collect())
        .collect();
    let mut out = Vec::new();
    for part in parts {
        let part = part?;
        if out.is_empty() {
            out = part;
        } else {
            out.extend(part);
        }
    }
    Ok(out)
}

/// The `n`-th (0-based) significant line of `pieces`, with the index of its piece, given each
/// piece's number of significant lines.
pub(super) fn nth_line<'a>(
    pieces: &[Span<'a>],
    counts: &[usize],
    mut n: usize,
) -> Option<(usize, Line<'a>)> {
    for (k, (&piece, &count)) in pieces.iter().zip(counts).enumerate() {
        if n < count {
            return piece.significant().nth(n).map(|line| (k, line));
        }
        n -= count;
    }
    None
}

/// How many significant lines each piece has.
pub(super) fn count_lines(pieces: &[Span]) -> Vec<usize> {
    pieces.par_iter().map(|p| p.significant().count()).collect()
}

/// The input as text: UTF-8 without a byte-order mark; invalid bytes are a parse error on
/// their line.
pub(super) fn decode<'a>(bytes: &'a [u8], source_name: &str) -> Result<&'a str, Error> {
    match std::str::from_utf8(bytes) {
        Ok(text) => Ok(strip_bom(text)),
        Err(e) => {
            let valid = &bytes[..e.valid_up_to()];
            let line = bytecount(valid) + 1;
            let column =
                valid.len() - valid.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1) + 1;
            Err(parse_error(
                source_name,
                line,
                format!("byte {column} of the line is not valid UTF-8"),
            ))
        }
    }
}

/// The text without a leading byte-order mark, which some editors write.
pub(super) fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// A parse error on one line.
pub(super) fn parse_error(source_name: &str, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        source_name: source_name.to_owned(),
        line,
        message: message.into(),
    }
}

/// A coordinate; NaN and infinities parse here and are refused later by the pipeline.
pub(super) fn parse_f64(token: &str, source_name: &str, line: usize) -> Result<f64, Error> {
    token.parse().map_err(|_| {
        parse_error(
            source_name,
            line,
            format!("cannot parse '{}' as a number", shorten(token)),
        )
    })
}

/// A token or line cut to a length that keeps an error message on one screen line.
pub(super) fn shorten(s: &str) -> String {
    const MAX_CHARS: usize = 40;
    match s.char_indices().nth(MAX_CHARS) {
        Some((cut, _)) => format!("{}...", &s[..cut]),
        None => s.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(text: &str) -> Span<'_> {
        Span {
            text,
            first_line: 1,
        }
    }

    #[test]
    fn comments_and_blank_lines_are_skipped() {
        let lines: Vec<(usize, &str)> = span("# c\n\n 1 2 # tail\r\n\t\n3 4")
            .significant()
            .map(|l| (l.number, l.content))
            .collect();
        assert_eq!(lines, vec![(3, "1 2"), (5, "3 4")]);
    }

    #[test]
    fn pieces_keep_line_numbers() {
        let text: String = (1..=100_000).map(|i| format!("{i}\n")).collect();
        let pieces = span(&text).pieces();
        assert!(pieces.len() > 1);
        for piece in &pieces {
            for line in piece.significant() {
                assert_eq!(line.content, line.number.to_string());
            }
        }
        assert_eq!(
            pieces.iter().map(|p| p.text.len()).sum::<usize>(),
            text.len()
        );
    }

    #[test]
    fn last_line_counts_an_unterminated_line() {
        assert_eq!(span("a\nb\n").last_line(), 2);
        assert_eq!(span("a\nb").last_line(), 2);
        assert_eq!(span("").last_line(), 1);
    }

    #[test]
    fn invalid_utf8_names_its_line() {
        let e = decode(b"1 2\n3 \xff\n", "f").unwrap_err();
        assert_eq!(
            e,
            parse_error("f", 2, "byte 3 of the line is not valid UTF-8")
        );
        assert_eq!(decode("\u{feff}1 2".as_bytes(), "f").unwrap(), "1 2");
    }

    #[test]
    fn long_tokens_are_shortened() {
        let long = "x".repeat(100);
        assert_eq!(shorten(&long).len(), 43);
        assert_eq!(shorten("abc"), "abc");
    }
}
