//! Errors and warnings with positions: every diagnostic points at the byte span
//! of the text that caused it and renders as `line:column` plus a caret excerpt.

use std::fmt;

/// A byte range `start..end` in the source text a diagnostic refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
pub struct Span {
    /// First byte of the offending text.
    pub start: usize,
    /// One past the last byte of the offending text.
    pub end: usize,
}

impl Span {
    /// A span covering `start..end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }
}

/// 1-based line and column (in characters) of a byte offset in `src`.
/// A line ends at `\n`, `\r\n` or a lone `\r` (old Mac files), as in
/// [`source_lines`].
pub fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(src.len());
    let mut line = 1;
    let mut col = 1;
    let mut chars = src.char_indices().peekable();
    while let Some((i, ch)) = chars.next() {
        if i >= offset {
            break;
        }
        let lf_follows = chars.peek().is_some_and(|&(_, c)| c == '\n');
        if ch == '\n' || (ch == '\r' && !lf_follows) {
            line += 1;
            col = 1;
        } else if ch != '\r' {
            col += 1;
        }
    }
    (line, col)
}

/// The lines of `src`, each without its ending: a line ends at `\n`,
/// `\r\n` or a lone `\r` (the line numbers of [`line_col`]).
pub fn source_lines(src: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(src);
    std::iter::from_fn(move || {
        let s = rest?;
        match s.find(['\n', '\r']) {
            Some(i) => {
                let skip = if s[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = Some(&s[i + skip..]).filter(|r| !r.is_empty());
                Some(&s[..i])
            }
            None => {
                rest = None;
                Some(s)
            }
        }
    })
}

/// An error in a model text: what went wrong, what was expected, and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct Error {
    /// Human-readable message: what is wrong and what was expected instead.
    pub message: String,
    /// Where in the source the problem is.
    pub span: Span,
    /// 1-based line of `span.start`.
    pub line: usize,
    /// 1-based column of `span.start`.
    pub column: usize,
    /// The source line containing the error, for the caret excerpt.
    pub excerpt: String,
}

impl Error {
    /// Builds an error at `span` of `src`, computing line, column and excerpt.
    pub fn new(src: &str, span: Span, message: impl Into<String>) -> Self {
        let (line, column) = line_col(src, span.start);
        let excerpt = source_lines(src).nth(line - 1).unwrap_or("").to_string();
        Error {
            message: message.into(),
            span,
            line,
            column,
            excerpt,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}:{}: {}", self.line, self.column, self.message)?;
        writeln!(f, "  | {}", self.excerpt)?;
        let pad: String = self
            .excerpt
            .chars()
            .take(self.column.saturating_sub(1))
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        // underline the span as far as it stays on this line
        let rest = self.excerpt.chars().count().saturating_sub(self.column - 1);
        let width = self.span.end.saturating_sub(self.span.start);
        let carets = "^".repeat(width.min(rest).max(1));
        write!(f, "  | {pad}{carets}")
    }
}

/// A non-fatal remark about a model (an unused parameter, an automatic
/// transformation) that a tool should show to the user.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Warning {
    /// What was noticed and what it means for the design.
    pub message: String,
    /// Where in the source it was noticed.
    pub span: Span,
}

/// An error before it is placed in the source: the builder stages produce
/// these, and [`Diag::into_error`] adds line, column and excerpt at the end.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Diag {
    pub span: Span,
    pub message: String,
}

impl Diag {
    pub(crate) fn new(span: Span, message: impl Into<String>) -> Self {
        Diag {
            span,
            message: message.into(),
        }
    }

    pub(crate) fn into_error(self, src: &str) -> Error {
        Error::new(src, self.span, self.message)
    }
}

impl Span {
    /// The smallest span covering both `self` and `other`.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    /// The text this span covers in `src` (empty if out of range).
    pub fn text(self, src: &str) -> &str {
        src.get(self.start..self.end).unwrap_or("")
    }
}

/// Edit distance between two short words (for "did you mean" hints).
pub(crate) fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let cost = usize::from(ca != *cb);
            cur[j + 1] = (prev[j] + cost).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The closest of `candidates` to `word` within edit distance 2, if any.
pub(crate) fn suggest<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (levenshtein(word, c), c))
        .filter(|(d, c)| *d <= 2 && *d < c.len().max(word.len()))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// A number to `digits` significant digits, the one form the command line
/// prints measured figures in: fixed-point for magnitudes in [1e-3, 1e5),
/// scientific outside (`2.44e296`, never hundreds of digits), and zero as
/// `0` (not `0.0000e0`).
pub fn fmt_sig(v: f64, digits: usize) -> String {
    let digits = digits.max(1);
    let a = v.abs();
    if a == 0.0 || !v.is_finite() {
        // 0, -0, inf, NaN as themselves
        format!("{}", if a == 0.0 { 0.0 } else { v })
    } else if (1e-3..1e5).contains(&a) {
        let d = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.*e}", digits - 1)
    }
}

/// Shortest round-trip text of a number: plain decimal for magnitudes in
/// [1e-5, 1e16) (and 0), scientific otherwise (`1e-320`, `1e308`, never
/// hundreds of digits).
pub fn fmt_num(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !v.is_finite() || (1e-5..1e16).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}
