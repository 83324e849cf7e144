//! The formula parser: `response ~ term (+ term)*`, with `1`, `0` and `- 1` for the intercept.

use super::{Factor, Formula, Term};

/// A formula that cannot be parsed: the column (1-based character position) and what was
/// expected there.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("model: {message} at column {column} of `{formula}`")]
pub struct FormulaError {
    /// The formula as given.
    pub formula: String,
    /// 1-based character position.
    pub column: usize,
    /// What was expected or found.
    pub message: String,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Name(String),
    Int(u32),
    Tilde,
    Plus,
    Minus,
    Colon,
    Caret,
    Open,
    Close,
    Star,
    End,
}

struct Lexer<'a> {
    src: &'a str,
    chars: Vec<(usize, char)>,
    pos: usize,
}

impl<'a> Lexer<'a> {
    fn new(src: &'a str) -> Self {
        Self {
            src,
            chars: src.chars().enumerate().collect(),
            pos: 0,
        }
    }

    fn err(&self, column: usize, message: impl Into<String>) -> FormulaError {
        FormulaError {
            formula: self.src.to_string(),
            column,
            message: message.into(),
        }
    }

    /// The next token and its 1-based column.
    fn next(&mut self) -> Result<(Tok, usize), FormulaError> {
        while self
            .chars
            .get(self.pos)
            .is_some_and(|(_, c)| c.is_whitespace())
        {
            self.pos += 1;
        }
        let Some(&(i, c)) = self.chars.get(self.pos) else {
            return Ok((Tok::End, self.chars.len() + 1));
        };
        let col = i + 1;
        self.pos += 1;
        let tok = match c {
            '~' => Tok::Tilde,
            '+' => Tok::Plus,
            '-' => Tok::Minus,
            ':' => Tok::Colon,
            '^' => Tok::Caret,
            '(' => Tok::Open,
            ')' => Tok::Close,
            '*' => Tok::Star,
            '`' => {
                let start = self.pos;
                while self.chars.get(self.pos).is_some_and(|(_, c)| *c != '`') {
                    self.pos += 1;
                }
                if self.pos >= self.chars.len() {
                    return Err(self.err(col, "unclosed backquote"));
                }
                let name: String = self.chars[start..self.pos].iter().map(|(_, c)| c).collect();
                self.pos += 1;
                if name.is_empty() {
                    return Err(self.err(col, "empty column name"));
                }
                Tok::Name(name)
            }
            c if c.is_ascii_digit() => {
                let start = self.pos - 1;
                while self
                    .chars
                    .get(self.pos)
                    .is_some_and(|(_, c)| c.is_ascii_alphanumeric() || *c == '.' || *c == '_')
                {
                    self.pos += 1;
                }
                let text: String = self.chars[start..self.pos].iter().map(|(_, c)| c).collect();
                Tok::Int(text.parse().map_err(|_| {
                    self.err(col, format!("`{text}` is not a whole number (a column name must not start with a digit; quote it in backquotes)"))
                })?)
            }
            c if c.is_alphabetic() || c == '_' || c == '.' => {
                let start = self.pos - 1;
                while self
                    .chars
                    .get(self.pos)
                    .is_some_and(|(_, c)| c.is_alphanumeric() || *c == '_' || *c == '.')
                {
                    self.pos += 1;
                }
                Tok::Name(self.chars[start..self.pos].iter().map(|(_, c)| c).collect())
            }
            other => return Err(self.err(col, format!("unexpected `{other}`"))),
        };
        Ok((tok, col))
    }
}

struct Parser<'a> {
    lex: Lexer<'a>,
    tok: Tok,
    col: usize,
}

impl<'a> Parser<'a> {
    fn bump(&mut self) -> Result<(), FormulaError> {
        (self.tok, self.col) = self.lex.next()?;
        Ok(())
    }

    fn err(&self, message: impl Into<String>) -> FormulaError {
        self.lex.err(self.col, message)
    }

    fn factor(&mut self) -> Result<Factor, FormulaError> {
        let (var, abs) =
            match self.tok.clone() {
                Tok::Name(name) if name == "abs" => {
                    self.bump()?;
                    if self.tok != Tok::Open {
                        return Err(self.err("expected `(` after abs"));
                    }
                    self.bump()?;
                    let Tok::Name(var) = self.tok.clone() else {
                        return Err(self.err("expected a column name inside abs( )"));
                    };
                    self.bump()?;
                    if self.tok != Tok::Close {
                        return Err(self.err("expected `)`"));
                    }
                    (var, true)
                }
                Tok::Name(var) => (var, false),
                Tok::Int(_) => return Err(self.err(
                    "a number cannot be a factor (only `1`, `0` or `-1` alone, for the intercept)",
                )),
                Tok::End => return Err(self.err("expected a term, found the end of the formula")),
                _ => return Err(self.err("expected a column name or abs(name)")),
            };
        self.bump()?;
        let mut power = 1;
        if self.tok == Tok::Caret {
            self.bump()?;
            let Tok::Int(k) = self.tok else {
                return Err(self.err("expected a whole power after `^`"));
            };
            if k == 0 {
                return Err(self.err("a power of 0 is the intercept; write 1"));
            }
            if k > 16 {
                return Err(self.err(format!(
                    "a power of {k} is beyond any sensor model (at most 16)"
                )));
            }
            power = k;
            self.bump()?;
        }
        Ok(Factor { var, abs, power })
    }

    fn term(&mut self) -> Result<Term, FormulaError> {
        let mut factors = vec![self.factor()?];
        while self.tok == Tok::Colon {
            self.bump()?;
            factors.push(self.factor()?);
        }
        if self.tok == Tok::Star {
            return Err(self.err(
                "use `a:b` for a product term (`a*b` would also add a and b; write them out)",
            ));
        }
        Ok(Term::normalise(factors))
    }
}

/// Parses a formula.
///
/// # Errors
/// A [`FormulaError`] naming the column and what was expected.
pub fn parse(src: &str) -> Result<Formula, FormulaError> {
    let mut p = Parser {
        lex: Lexer::new(src),
        tok: Tok::End,
        col: 0,
    };
    p.bump()?;
    let Tok::Name(response) = p.tok.clone() else {
        return Err(p.err("expected the response column before `~`"));
    };
    p.bump()?;
    if p.tok != Tok::Tilde {
        return Err(p.err("expected `~` after the response"));
    }
    p.bump()?;
    let mut intercept = None::<bool>;
    let mut terms: Vec<Term> = Vec::new();
    let mut sign_plus = true;
    if p.tok == Tok::Minus {
        sign_plus = false;
        p.bump()?;
    }
    loop {
        let col = p.col;
        match p.tok {
            Tok::Int(1) | Tok::Int(0) => {
                let one = p.tok == Tok::Int(1);
                let has = if sign_plus {
                    one
                } else if one {
                    false
                } else {
                    return Err(p.err(
                        "`- 0` means nothing; write `0` or `- 1` to leave the intercept out",
                    ));
                };
                if intercept.is_some_and(|i| i != has) {
                    return Err(p.err("the intercept is both included and left out"));
                }
                intercept = Some(has);
                p.bump()?;
            }
            Tok::Int(k) => {
                return Err(p.err(format!(
                    "`{k}` is not a term (only 1, 0 and -1 stand alone)"
                )));
            }
            _ if !sign_plus => {
                return Err(p.err(
                    "only the intercept can be removed, with `- 1`; leave the term out instead",
                ));
            }
            _ => {
                let t = p.term()?;
                if terms.contains(&t) {
                    return Err(FormulaError {
                        formula: src.into(),
                        column: col,
                        message: format!("the term {t} appears twice"),
                    });
                }
                if t.factors.iter().any(|f| f.var == response) {
                    return Err(FormulaError {
                        formula: src.into(),
                        column: col,
                        message: format!("the response {response} cannot also be a term"),
                    });
                }
                terms.push(t);
            }
        }
        match p.tok {
            Tok::Plus => sign_plus = true,
            Tok::Minus => sign_plus = false,
            Tok::End => break,
            _ => return Err(p.err("expected `+`, `-` or the end of the formula")),
        }
        p.bump()?;
    }
    let intercept = intercept.unwrap_or(true);
    if terms.is_empty() && !intercept {
        return Err(FormulaError {
            formula: src.into(),
            column: 1,
            message: "the model has no terms".into(),
        });
    }
    Ok(Formula {
        response,
        intercept,
        terms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intercept_forms() {
        assert!(parse("y ~ x").unwrap().intercept);
        assert!(parse("y ~ 1 + x").unwrap().intercept);
        assert!(!parse("y ~ 0 + x").unwrap().intercept);
        assert!(!parse("y ~ x - 1").unwrap().intercept);
        assert!(!parse("y ~ -1 + x").unwrap().intercept);
        assert_eq!(parse("y ~ 1").unwrap().width(), 1);
        assert_eq!(
            parse("`out [V]` ~ `rate [dps]`^2").unwrap().term_names(),
            ["1", "`rate [dps]`^2"]
        );
    }

    #[test]
    fn errors_name_the_column() {
        let cases = [
            ("y ~ x +", 8, "end of the formula"),
            ("y x", 3, "`~`"),
            ("~ x", 1, "response"),
            ("y ~ x^", 7, "whole power"),
            ("y ~ x^0", 7, "intercept"),
            ("y ~ x*z", 6, "a:b"),
            ("y ~ x - z", 9, "only the intercept"),
            ("y ~ x + x", 9, "twice"),
            ("y ~ abs x", 9, "`(`"),
            ("y ~ 2", 5, "not a term"),
            ("y ~ x $ z", 7, "unexpected `$`"),
            ("y ~ 0", 1, "no terms"),
            ("y ~ y + x", 5, "response"),
            ("y ~ 1 - 1", 9, "both"),
            ("y ~ `x", 5, "backquote"),
        ];
        for (src, col, what) in cases {
            let e = parse(src).expect_err(src);
            assert_eq!(e.column, col, "{src}: {e}");
            assert!(e.message.contains(what), "{src}: {e}");
        }
    }
}
