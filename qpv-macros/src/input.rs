//! The macro input: Rust tokens → model text, plus a table that maps byte
//! offsets of that text back to token spans, so a DSL error lands on the token
//! that caused it.
//!
//! Two forms are accepted:
//!
//! * inline: `qpv! { model NAME { ... } }` — the tokens are printed back to
//!   text (one space between tokens, none after a joint punctuation such as
//!   the `-` of `->` or after `.`, so `.5` stays a number); comments never
//!   reach the macro (rustc strips them);
//! * `qpv!(include "path/to/file.qpv")` — the file is read relative to the
//!   calling crate's `CARGO_MANIFEST_DIR`; every error points at the string
//!   literal and quotes `file:line:column` in its message.

use proc_macro2::{Delimiter, Literal, Span, TokenStream, TokenTree};
use std::path::PathBuf;

/// Where the model text came from.
pub enum Source {
    /// Written inline as Rust tokens.
    Inline,
    /// Read from a file named by `include "..."`.
    File {
        /// The path as the user wrote it (for messages).
        written: String,
        /// The absolute path that was read (for `include_str!`).
        absolute: PathBuf,
        /// The span of the string literal.
        literal: Span,
    },
}

/// The model text with a way back from text offsets to token spans.
pub struct Input {
    /// The text handed to the DSL parser.
    pub text: String,
    /// Where the text came from.
    pub source: Source,
    /// `(start, end, span)` of every printed token, sorted by `start`.
    table: Vec<(usize, usize, Span)>,
    /// The path through which the generated code calls `libm` (`::libm`
    /// unless the invocation came through the `qpv` facade).
    pub libm: TokenStream,
}

/// An error found before the DSL sees the text (bad `include`, unreadable file).
#[derive(Debug)]
pub struct InputError {
    /// The span to report at.
    pub span: Span,
    /// What is wrong and what is expected instead.
    pub message: String,
}

impl Input {
    /// Reads the macro input: an `include "file"` or inline model text.
    pub fn from_tokens(tokens: TokenStream) -> Result<Input, InputError> {
        let trees: Vec<TokenTree> = tokens.clone().into_iter().collect();
        if let Some(TokenTree::Ident(id)) = trees.first() {
            if id == "include" {
                return Self::include(id.span(), &trees[1..]);
            }
        }
        if trees.is_empty() {
            return Err(InputError {
                span: Span::call_site(),
                message: "empty qpv! block: expected `model NAME { ... }` or \
                          `include \"file.qpv\"`"
                    .into(),
            });
        }
        let mut input = Input {
            text: String::new(),
            source: Source::Inline,
            table: Vec::new(),
            libm: quote::quote!(::libm),
        };
        input.print(tokens);
        Ok(input)
    }

    /// `include "path"`: reads the file relative to `CARGO_MANIFEST_DIR`.
    fn include(keyword: Span, rest: &[TokenTree]) -> Result<Input, InputError> {
        let lit = match rest {
            [TokenTree::Literal(lit)] => lit,
            [TokenTree::Literal(lit), TokenTree::Punct(p)] if p.as_char() == ';' => lit,
            [] => {
                return Err(InputError {
                    span: keyword,
                    message: "expected a file name after `include`, e.g. \
                              `include \"examples/paper.qpv\"`"
                        .into(),
                })
            }
            [first, ..] => {
                let span = match rest.get(1) {
                    Some(t) if matches!(first, TokenTree::Literal(_)) => t.span(),
                    _ => first.span(),
                };
                return Err(InputError {
                    span,
                    message: "expected exactly one string literal after `include`, \
                              e.g. `include \"examples/paper.qpv\"`"
                        .into(),
                });
            }
        };
        let written = string_value(lit).ok_or_else(|| InputError {
            span: lit.span(),
            message: "expected a string literal with the model file's path, \
                      relative to the crate's Cargo.toml"
                .into(),
        })?;
        let base = std::env::var_os("CARGO_MANIFEST_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from("."));
        let path = base.join(&written);
        let absolute = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        let text = std::fs::read_to_string(&path).map_err(|e| InputError {
            span: lit.span(),
            message: format!(
                "cannot read model file `{written}` ({}): the path is relative to the \
                 directory of the calling crate's Cargo.toml",
                io_reason(&e)
            ),
        })?;
        Ok(Input {
            text,
            source: Source::File {
                written,
                absolute,
                literal: lit.span(),
            },
            table: Vec::new(),
            libm: quote::quote!(::libm),
        })
    }

    /// Appends `s` to the text and records that it came from `span`.
    fn push(&mut self, s: &str, span: Span) {
        let start = self.text.len();
        self.text.push_str(s);
        self.table.push((start, self.text.len(), span));
    }

    /// Prints a token stream back to text, recording every token's span.
    fn print(&mut self, tokens: TokenStream) {
        let mut joint = false;
        for tt in tokens {
            if !joint && !self.text.is_empty() && !self.text.ends_with(' ') {
                self.text.push(' ');
            }
            joint = false;
            match tt {
                TokenTree::Group(g) => {
                    let (open, close) = match g.delimiter() {
                        Delimiter::Parenthesis => ("(", ")"),
                        Delimiter::Brace => ("{", "}"),
                        Delimiter::Bracket => ("[", "]"),
                        Delimiter::None => ("", ""),
                    };
                    if !open.is_empty() {
                        self.push(open, g.span_open());
                    }
                    let inner = g.stream();
                    let empty = inner.is_empty();
                    self.print(inner);
                    if !close.is_empty() {
                        if !empty {
                            self.text.push(' ');
                        }
                        self.push(close, g.span_close());
                    }
                }
                TokenTree::Punct(p) => {
                    let mut buf = [0u8; 4];
                    self.push(p.as_char().encode_utf8(&mut buf), p.span());
                    // `.5` reaches us as `.` then `5`: keep it one number
                    joint = p.spacing() == proc_macro2::Spacing::Joint || p.as_char() == '.';
                }
                TokenTree::Ident(i) => self.push(&i.to_string(), i.span()),
                TokenTree::Literal(l) => self.push(&l.to_string(), l.span()),
            }
        }
    }

    /// The `(first, last)` token spans covering the text range `start..end`.
    ///
    /// For a file include every range maps to the string literal. An empty or
    /// out-of-range span maps to the nearest token (the end of the block for
    /// "unexpected end of input").
    pub fn spans(&self, start: usize, end: usize) -> (Span, Span) {
        if let Source::File { literal, .. } = &self.source {
            return (*literal, *literal);
        }
        match self.token_range(start, end) {
            Some((a, b)) => (self.table[a].2, self.table[b].2),
            None => (Span::call_site(), Span::call_site()),
        }
    }

    /// Indices into the table of the first and last token covering
    /// `start..end` (see [`Input::spans`]); `None` only for an empty table.
    fn token_range(&self, start: usize, end: usize) -> Option<(usize, usize)> {
        let n = self.table.len();
        if n == 0 {
            return None;
        }
        // first token that ends after `start`
        let first = self.table.partition_point(|t| t.1 <= start);
        if first >= n {
            return Some((n - 1, n - 1));
        }
        if end <= start {
            return Some((first, first));
        }
        // last token that starts before `end`
        let after = self.table.partition_point(|t| t.0 < end);
        let last = if after > first { after - 1 } else { first };
        Some((first, last))
    }

    /// Prefixes a DSL message with `file:line:column` for an included file
    /// (the span points at the literal, so the position must be in the text).
    pub fn locate(&self, start: usize, message: &str) -> String {
        match &self.source {
            Source::Inline => message.to_string(),
            Source::File { written, .. } => {
                let (line, col) = qpv_dsl::diagnostic::line_col(&self.text, start);
                let excerpt = self.text.lines().nth(line.saturating_sub(1)).unwrap_or("");
                let pad: String = excerpt
                    .chars()
                    .take(col.saturating_sub(1))
                    .map(|c| if c == '\t' { '\t' } else { ' ' })
                    .collect();
                format!("{written}:{line}:{col}: {message}\n  | {excerpt}\n  | {pad}^")
            }
        }
    }
}

/// The value of a plain string literal token (`"..."` without escapes beyond
/// `\\` and `\"`, or a raw string `r"..."`), or `None` for anything else.
fn string_value(lit: &Literal) -> Option<String> {
    let s = lit.to_string();
    if let Some(raw) = s.strip_prefix('r') {
        let hashes = raw.len() - raw.trim_start_matches('#').len();
        let body = raw.get(hashes..raw.len().checked_sub(hashes)?)?;
        return body
            .strip_prefix('"')?
            .strip_suffix('"')
            .map(str::to_string);
    }
    let body = s.strip_prefix('"')?.strip_suffix('"')?;
    let mut out = String::with_capacity(body.len());
    let mut chars = body.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next()? {
                '\\' => out.push('\\'),
                '"' => out.push('"'),
                '\'' => out.push('\''),
                'n' => out.push('\n'),
                't' => out.push('\t'),
                _ => return None,
            }
        } else {
            out.push(c);
        }
    }
    Some(out)
}

/// A short human reason for an I/O error.
fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".into(),
        std::io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::str::FromStr;

    fn inline(src: &str) -> Input {
        Input::from_tokens(TokenStream::from_str(src).expect("valid tokens")).expect("inline input")
    }

    #[test]
    fn prints_tokens_with_single_spaces() {
        let i = inline("model m { param th1 in [0, 1]; A = [-4 - th1]; }");
        assert_eq!(
            i.text,
            "model m { param th1 in [ 0 , 1 ] ; A = [ - 4 - th1 ] ; }"
        );
    }

    #[test]
    fn joint_punctuation_stays_together() {
        let i = inline("a -> b <= c");
        assert_eq!(i.text, "a -> b <= c");
    }

    #[test]
    fn a_leading_dot_number_stays_one_number() {
        assert_eq!(inline("x = .5;").text, "x = .5 ;");
    }

    #[test]
    fn every_token_is_in_the_table() {
        let i = inline("model m { x = [1, 2]; }");
        // model m { x = [ 1 , 2 ] ; }  → 12 tokens
        assert_eq!(i.table.len(), 12);
        for w in i.table.windows(2) {
            assert!(w[0].1 <= w[1].0, "table sorted and disjoint");
        }
        for &(s, e, _) in &i.table {
            assert!(!i.text[s..e].contains(' '));
        }
    }

    #[test]
    fn include_needs_a_string_literal() {
        let toks = TokenStream::from_str("include paper").expect("tokens");
        let e = Input::from_tokens(toks).err().expect("an error");
        assert!(e.message.contains("string literal"), "{}", e.message);
        let toks = TokenStream::from_str("include").expect("tokens");
        let e = Input::from_tokens(toks).err().expect("an error");
        assert!(e.message.contains("file name"), "{}", e.message);
    }

    #[test]
    fn missing_include_file_is_reported() {
        let toks = TokenStream::from_str("include \"no/such/file.qpv\"").expect("tokens");
        let e = Input::from_tokens(toks).err().expect("an error");
        assert!(e.message.contains("no such file"), "{}", e.message);
    }

    #[test]
    fn string_values() {
        let lit = |s: &str| match TokenStream::from_str(s).expect("tokens").into_iter().next() {
            Some(TokenTree::Literal(l)) => l,
            _ => panic!("not a literal"),
        };
        assert_eq!(
            string_value(&lit("\"a/b.qpv\"")).as_deref(),
            Some("a/b.qpv")
        );
        assert_eq!(string_value(&lit("r#\"a\"b\"#")).as_deref(), Some("a\"b"));
        assert_eq!(string_value(&lit("12")), None);
    }

    #[test]
    fn empty_input_is_an_error() {
        let e = Input::from_tokens(TokenStream::new())
            .err()
            .expect("an error");
        assert!(e.message.contains("model NAME"));
    }

    #[test]
    fn errors_in_an_included_file_quote_file_line_column() {
        let input = Input {
            text: "model m {\n    state x1 x2;\n}\n".into(),
            source: Source::File {
                written: "models/m.qpv".into(),
                absolute: PathBuf::from("/abs/models/m.qpv"),
                literal: Span::call_site(),
            },
            table: Vec::new(),
            libm: quote::quote!(::libm),
        };
        let at = input.text.find("x2").expect("x2 in text");
        let msg = input.locate(at, "expected `,` or `;`, found `x2`");
        assert_eq!(
            msg,
            "models/m.qpv:2:14: expected `,` or `;`, found `x2`\n  |     state x1 x2;\n  |              ^"
        );
    }

    #[test]
    fn text_ranges_map_to_tokens() {
        let i = inline("model m { }");
        // "model m { }": model 0..5, m 6..7, { 8..9, } 10..11
        assert_eq!(i.token_range(6, 7), Some((1, 1)));
        assert_eq!(i.token_range(2, 9), Some((0, 2)));
        assert_eq!(
            i.token_range(5, 6),
            Some((1, 1)),
            "a space maps to the next token"
        );
        assert_eq!(
            i.token_range(7, 7),
            Some((2, 2)),
            "empty span: the next token"
        );
        assert_eq!(
            i.token_range(100, 120),
            Some((3, 3)),
            "past the end: the last token"
        );
        assert_eq!(i.token_range(0, 11), Some((0, 3)));
    }
}
