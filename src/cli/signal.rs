//! Signals of time for `qpv simulate`: `--input NAME=EXPR` / `--param
//! NAME=EXPR` expressions of t, and `--input-csv FILE` tables with linear
//! interpolation.
//!
//! The expression language is deliberately tiny: numbers, `t`, `pi`,
//! `+ - * / ^` (with `^` binding tightest and associating to the right),
//! unary minus, parentheses and the functions `sin`, `cos`, `exp`, `sqrt`.

use super::input::{read_bounded, CliError};
use std::sync::Arc;

/// A parsed expression of t.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A number (or `pi`).
    Num(f64),
    /// The time t.
    T,
    /// Unary minus.
    Neg(Box<Expr>),
    /// A binary operation: one of `+ - * / ^`.
    Bin(char, Box<Expr>, Box<Expr>),
    /// A function call: `sin`, `cos`, `exp` or `sqrt`.
    Call(&'static str, Box<Expr>),
}

impl Expr {
    /// The expression's value at time `t`.
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            Expr::Num(v) => *v,
            Expr::T => t,
            Expr::Neg(e) => -e.eval(t),
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(t), b.eval(t));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '/' => a / b,
                    _ => a.powf(b),
                }
            }
            Expr::Call(f, e) => {
                let v = e.eval(t);
                match *f {
                    "sin" => v.sin(),
                    "cos" => v.cos(),
                    "exp" => v.exp(),
                    _ => v.sqrt(),
                }
            }
        }
    }
}

/// Deepest nesting of parentheses and unary signs accepted (no stack overflow).
const MAX_DEPTH: usize = 64;

struct Parser<'a> {
    text: &'a str,
    pos: usize,
    depth: usize,
}

impl Parser<'_> {
    fn err(&self, msg: &str) -> String {
        format!("{msg} at column {} of {:?}", self.pos + 1, self.text)
    }

    fn skip_ws(&mut self) {
        while let Some(c) = self.text[self.pos..]
            .chars()
            .next()
            .filter(|c| c.is_whitespace())
        {
            self.pos += c.len_utf8();
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.skip_ws();
        self.text[self.pos..].chars().next()
    }

    fn descend(&mut self) -> Result<(), String> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err("expression nested too deeply"));
        }
        Ok(())
    }

    /// sum := product (("+" | "-") product)*
    fn sum(&mut self) -> Result<Expr, String> {
        let mut e = self.product()?;
        while let Some(op @ ('+' | '-')) = self.peek() {
            self.pos += 1;
            e = Expr::Bin(op, Box::new(e), Box::new(self.product()?));
        }
        Ok(e)
    }

    /// product := unary (("*" | "/") unary)*
    fn product(&mut self) -> Result<Expr, String> {
        let mut e = self.unary()?;
        while let Some(op @ ('*' | '/')) = self.peek() {
            self.pos += 1;
            e = Expr::Bin(op, Box::new(e), Box::new(self.unary()?));
        }
        Ok(e)
    }

    /// unary := "-" unary | "+" unary | power
    fn unary(&mut self) -> Result<Expr, String> {
        match self.peek() {
            Some(c @ ('-' | '+')) => {
                self.pos += 1;
                self.descend()?;
                let e = self.unary()?;
                self.depth -= 1;
                Ok(if c == '-' { Expr::Neg(Box::new(e)) } else { e })
            }
            _ => self.power(),
        }
    }

    /// power := primary ("^" unary)?
    fn power(&mut self) -> Result<Expr, String> {
        let base = self.primary()?;
        if self.peek() == Some('^') {
            self.pos += 1;
            self.descend()?;
            let exp = self.unary()?;
            self.depth -= 1;
            return Ok(Expr::Bin('^', Box::new(base), Box::new(exp)));
        }
        Ok(base)
    }

    /// primary := number | "t" | "pi" | FUNC "(" sum ")" | "(" sum ")"
    fn primary(&mut self) -> Result<Expr, String> {
        let Some(c) = self.peek() else {
            return Err(self.err("expected a number, t, a function or `(`"));
        };
        if c == '(' {
            self.pos += 1;
            self.descend()?;
            let e = self.sum()?;
            self.depth -= 1;
            return self.close(e);
        }
        let rest = &self.text[self.pos..];
        if c.is_ascii_digit() || c == '.' {
            let mut end = rest
                .find(|ch: char| !(ch.is_ascii_digit() || ch == '.'))
                .unwrap_or(rest.len());
            // An exponent: e or E, an optional sign, digits.
            let tail = &rest[end..];
            if tail.starts_with(['e', 'E']) {
                let signed = tail[1..].starts_with(['+', '-']) as usize;
                let digits = tail[1 + signed..]
                    .find(|ch: char| !ch.is_ascii_digit())
                    .unwrap_or(tail.len() - 1 - signed);
                if digits > 0 {
                    end += 1 + signed + digits;
                }
            }
            let v: f64 = rest[..end]
                .parse()
                .map_err(|_| self.err("malformed number"))?;
            if !v.is_finite() {
                return Err(self.err("number out of range"));
            }
            self.pos += end;
            return Ok(Expr::Num(v));
        }
        if c.is_ascii_alphabetic() {
            let end = rest
                .find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '_'))
                .unwrap_or(rest.len());
            let word = &rest[..end];
            let start = self.pos;
            self.pos += end;
            return match word {
                "t" => Ok(Expr::T),
                "pi" => Ok(Expr::Num(std::f64::consts::PI)),
                "sin" | "cos" | "exp" | "sqrt" => {
                    let f: &'static str = match word {
                        "sin" => "sin",
                        "cos" => "cos",
                        "exp" => "exp",
                        _ => "sqrt",
                    };
                    if self.peek() != Some('(') {
                        return Err(self.err(&format!("expected `(` after {f}")));
                    }
                    self.pos += 1;
                    self.descend()?;
                    let e = self.sum()?;
                    self.depth -= 1;
                    Ok(Expr::Call(f, Box::new(self.close(e)?)))
                }
                _ => {
                    self.pos = start;
                    Err(self.err(&format!(
                        "unknown name `{word}` (expressions may use t, pi, sin, cos, exp, sqrt)"
                    )))
                }
            };
        }
        Err(self.err(&format!("unexpected `{c}`")))
    }

    fn close(&mut self, e: Expr) -> Result<Expr, String> {
        if self.peek() != Some(')') {
            return Err(self.err("expected `)`"));
        }
        self.pos += 1;
        Ok(e)
    }
}

/// Parses an expression of t; the error names the column.
pub fn parse_expr(text: &str) -> Result<Expr, String> {
    let mut p = Parser {
        text,
        pos: 0,
        depth: 0,
    };
    let e = p.sum()?;
    if p.peek().is_some() {
        return Err(p.err("unexpected text after the expression"));
    }
    Ok(e)
}

/// Splits `NAME=EXPR` of flag `flag` and parses the expression.
pub fn parse_assignment(flag: &str, arg: &str) -> Result<(String, Expr), CliError> {
    let (name, expr) = arg.split_once('=').ok_or_else(|| {
        CliError::Input(format!(
            "{flag} {arg:?}: expected NAME=EXPR, e.g. u=sin(2*pi*t)"
        ))
    })?;
    let e = parse_expr(expr).map_err(|m| CliError::Input(format!("{flag} {arg:?}: {m}")))?;
    Ok((name.trim().to_string(), e))
}

/// A table of signals: times (strictly increasing) and one column per name.
#[derive(Debug, Clone)]
pub struct Table {
    /// Column names after `t`.
    pub names: Vec<String>,
    t: Vec<f64>,
    columns: Vec<Vec<f64>>,
}

/// Largest CSV table accepted by `--input-csv` (bytes): the limit of the
/// JSON inputs.
pub const MAX_TABLE_BYTES: u64 = super::input::JSON_LIMIT;

impl Table {
    /// Reads a CSV file: a header `t,NAME,...`, then rows of numbers with
    /// strictly increasing t. Errors name the line. Read like every input
    /// ([`read_bounded`]: at most [`MAX_TABLE_BYTES`], so /dev/zero or an
    /// endless pipe is refused; a byte-order mark is skipped).
    pub fn read(path: &std::path::Path) -> Result<Table, CliError> {
        let text = read_bounded(path, MAX_TABLE_BYTES, "--input-csv tables")?;
        Table::parse(&text).map_err(|m| CliError::Input(format!("{}:{m}", path.display())))
    }

    /// Parses CSV text (see [`Table::read`]); errors start with `LINE: `.
    pub fn parse(text: &str) -> Result<Table, String> {
        // A line ends at LF, CRLF or a lone CR, as in model files.
        let mut lines = qpv_dsl::diagnostic::source_lines(text)
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines
            .next()
            .ok_or("1: empty file (expected a header t,NAME,...)")?;
        let cells: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
        if cells.first().map(String::as_str) != Some("t") || cells.len() < 2 {
            return Err(format!(
                "1: the header must be `t,NAME,...` (got {header:?})"
            ));
        }
        let names = cells[1..].to_vec();
        let mut t = Vec::new();
        let mut columns = vec![Vec::new(); names.len()];
        for (i, line) in lines {
            let row: Result<Vec<f64>, _> = line.split(',').map(|c| c.trim().parse()).collect();
            let row = row.map_err(|e| format!("{}: {e} in {line:?}", i + 1))?;
            if row.len() != names.len() + 1 {
                return Err(format!(
                    "{}: {} values, expected {}",
                    i + 1,
                    row.len(),
                    names.len() + 1
                ));
            }
            if row.iter().any(|v| !v.is_finite()) {
                return Err(format!("{}: values must be finite", i + 1));
            }
            if t.last().is_some_and(|&last| row[0] <= last) {
                return Err(format!("{}: t must increase strictly", i + 1));
            }
            t.push(row[0]);
            for (c, v) in columns.iter_mut().zip(&row[1..]) {
                c.push(*v);
            }
        }
        if t.is_empty() {
            return Err("2: no rows".into());
        }
        Ok(Table { names, t, columns })
    }

    /// Column `k` at time `t`: linear interpolation, held constant outside
    /// the table's time range.
    pub fn at(&self, k: usize, t: f64) -> f64 {
        let col = &self.columns[k];
        let i = self.t.partition_point(|&s| s <= t);
        if i == 0 {
            return col[0];
        }
        if i == self.t.len() {
            return col[i - 1];
        }
        let (t0, t1) = (self.t[i - 1], self.t[i]);
        let w = (t - t0) / (t1 - t0);
        col[i - 1] + w * (col[i] - col[i - 1])
    }
}

/// A scalar function of time, shareable with the integrator's signals.
pub type TimeFn = Arc<dyn Fn(f64) -> f64 + Send + Sync>;

/// The signal of an expression.
pub fn expr_signal(e: Expr) -> TimeFn {
    Arc::new(move |t| e.eval(t))
}

/// The signal of column `k` of a table.
pub fn table_signal(table: &Arc<Table>, k: usize) -> TimeFn {
    let table = Arc::clone(table);
    Arc::new(move |t| table.at(k, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_follow_the_usual_precedence() {
        let e = |s: &str, t: f64| parse_expr(s).expect(s).eval(t);
        assert_eq!(e("1 + 2*3", 0.0), 7.0);
        assert_eq!(e("-2^2", 0.0), -4.0);
        assert_eq!(e("2^3^2", 0.0), 512.0);
        assert_eq!(e("(1 + t)/2", 3.0), 2.0);
        assert_eq!(e("1e-3*t", 2.0), 2e-3);
        assert!((e("sin(pi/2) + cos(0) + exp(0) + sqrt(4)", 0.0) - 5.0).abs() < 1e-15);
    }

    #[test]
    fn bad_expressions_say_where() {
        let m = parse_expr("2*x").unwrap_err();
        assert!(
            m.contains("unknown name `x`") && m.contains("column 3"),
            "{m}"
        );
        assert!(parse_expr("sin 2").unwrap_err().contains("expected `(`"));
        assert!(parse_expr("(1").unwrap_err().contains("expected `)`"));
        assert!(parse_expr("1 2")
            .unwrap_err()
            .contains("after the expression"));
        assert!(parse_expr(&"(".repeat(1000))
            .unwrap_err()
            .contains("deeply"));
    }

    #[test]
    fn tables_interpolate_linearly_and_hold_their_ends() {
        let tab = Table::parse("t,u\n0,0\n1,2\n3,0\n").expect("table");
        assert_eq!(tab.at(0, -1.0), 0.0);
        assert_eq!(tab.at(0, 0.5), 1.0);
        assert_eq!(tab.at(0, 2.0), 1.0);
        assert_eq!(tab.at(0, 9.0), 0.0);
        assert!(Table::parse("t,u\n0,0\n0,1\n")
            .unwrap_err()
            .starts_with("3:"));
        assert!(Table::parse("x,u\n").unwrap_err().starts_with("1:"));
    }
}
