//! Model formulas: `volts ~ 1 + rate + rate^2 + temp + rate:temp`.
//!
//! - `1` is the intercept; it is included unless the formula says `0` or `-1`.
//! - A term is a product (`a:b`) of factors; a factor is a column name, or `abs(name)`, raised
//!   to a whole power (`rate^2`, `abs(rate)^3`). `rate:abs(rate)` is the odd-quadratic form.
//! - Column names that are not plain identifiers are written in backquotes: `` `rate [dps]` ``.
//!
//! Every linear-in-parameters sensor model can be written this way; [`Formula::design`] turns
//! one into a design matrix over a table of observations.

mod matrix;
mod parse;

use std::fmt;

pub use matrix::Design;
pub use parse::{FormulaError, parse};

/// One factor of a term: a column, or its absolute value, to a power.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Factor {
    /// The column name.
    pub var: String,
    /// `abs(var)` rather than `var`.
    pub abs: bool,
    /// The power, at least 1.
    pub power: u32,
}

impl Factor {
    /// The factor's value for a value of its variable.
    #[must_use]
    pub fn eval(&self, x: f64) -> f64 {
        let base = if self.abs { x.abs() } else { x };
        base.powi(self.power as i32)
    }
}

impl fmt::Display for Factor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plain = self
            .var
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
            && self.var.chars().next().is_some_and(|c| !c.is_ascii_digit());
        let name = if plain {
            self.var.clone()
        } else {
            format!("`{}`", self.var)
        };
        match (self.abs, self.power) {
            (false, 1) => write!(f, "{name}"),
            (false, k) => write!(f, "{name}^{k}"),
            (true, 1) => write!(f, "abs({name})"),
            (true, k) => write!(f, "abs({name})^{k}"),
        }
    }
}

/// A term: the product of its factors (never empty; the intercept is not a term).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Term {
    /// The factors, sorted, each variable-and-abs pair at most once.
    pub factors: Vec<Factor>,
}

impl Term {
    /// A term of one plain variable.
    #[must_use]
    pub fn var(name: &str) -> Self {
        Self {
            factors: vec![Factor {
                var: name.into(),
                abs: false,
                power: 1,
            }],
        }
    }

    /// The term's name as it is printed and reported.
    #[must_use]
    pub fn name(&self) -> String {
        self.to_string()
    }

    /// The term's total degree in `var` (powers of `var` and of `abs(var)` together).
    #[must_use]
    pub fn degree_in(&self, var: &str) -> u32 {
        self.factors
            .iter()
            .filter(|f| f.var == var)
            .map(|f| f.power)
            .sum()
    }

    /// The distinct variables of the term.
    #[must_use]
    pub fn variables(&self) -> Vec<&str> {
        let mut v: Vec<&str> = self.factors.iter().map(|f| f.var.as_str()).collect();
        v.dedup();
        v
    }

    /// This term times `var^power` (`power` at least 1), in canonical form.
    #[must_use]
    pub fn times(&self, var: &str, power: u32) -> Self {
        let mut factors = self.factors.clone();
        factors.push(Factor {
            var: var.into(),
            abs: false,
            power,
        });
        Self::normalise(factors)
    }

    /// Multiplies factors into a canonical term: same variable and kind add their powers.
    fn normalise(mut factors: Vec<Factor>) -> Self {
        factors.sort();
        let mut out: Vec<Factor> = Vec::new();
        for f in factors {
            match out.last_mut() {
                Some(last) if last.var == f.var && last.abs == f.abs => last.power += f.power,
                _ => out.push(f),
            }
        }
        Self { factors: out }
    }
}

impl fmt::Display for Term {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, factor) in self.factors.iter().enumerate() {
            if i > 0 {
                f.write_str(":")?;
            }
            write!(f, "{factor}")?;
        }
        Ok(())
    }
}

/// A parsed model formula.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Formula {
    /// The response column.
    pub response: String,
    /// Whether the model has an intercept.
    pub intercept: bool,
    /// The terms, in the order written (duplicates refused).
    pub terms: Vec<Term>,
}

/// The name of the intercept term in reports.
pub const INTERCEPT: &str = "1";

impl Formula {
    /// The names of the model's columns: `1` first when there is an intercept, then the terms.
    #[must_use]
    pub fn term_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.terms.len() + 1);
        if self.intercept {
            names.push(INTERCEPT.to_string());
        }
        names.extend(self.terms.iter().map(Term::name));
        names
    }

    /// Every column the model reads: the response, then the variables in order of appearance.
    #[must_use]
    pub fn columns(&self) -> Vec<String> {
        let mut out = vec![self.response.clone()];
        for t in &self.terms {
            for v in t.variables() {
                if !out.iter().any(|o| o == v) {
                    out.push(v.to_string());
                }
            }
        }
        out
    }

    /// Number of model columns (`p`).
    #[must_use]
    pub fn width(&self) -> usize {
        self.terms.len() + usize::from(self.intercept)
    }

    /// The same formula without the term named `name` (the intercept is `1`).
    #[must_use]
    pub fn without(&self, name: &str) -> Self {
        let mut f = self.clone();
        if name == INTERCEPT {
            f.intercept = false;
        } else {
            f.terms.retain(|t| t.name() != name);
        }
        f
    }

    /// The model's row for one observation, given a lookup of variable values.
    pub fn row(&self, value: impl Fn(&str) -> f64, out: &mut Vec<f64>) {
        out.clear();
        if self.intercept {
            out.push(1.0);
        }
        for t in &self.terms {
            out.push(t.factors.iter().map(|f| f.eval(value(&f.var))).product());
        }
    }
}

impl fmt::Display for Formula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ~ {}",
            self.response,
            if self.intercept { "1" } else { "0" }
        )?;
        for t in &self.terms {
            write!(f, " + {t}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_rows() {
        let f = parse("volts ~ 1 + rate + rate^2 + temp + rate:temp + rate:abs(rate)").unwrap();
        assert_eq!(
            f.term_names(),
            ["1", "rate", "rate^2", "temp", "rate:temp", "rate:abs(rate)"]
        );
        assert_eq!(f.columns(), ["volts", "rate", "temp"]);
        let mut row = Vec::new();
        f.row(|v| if v == "rate" { -2.0 } else { 3.0 }, &mut row);
        assert_eq!(row, [1.0, -2.0, 4.0, 3.0, -6.0, -4.0]);
        assert_eq!(
            f.to_string(),
            "volts ~ 1 + rate + rate^2 + temp + rate:temp + rate:abs(rate)"
        );
        assert_eq!(f.without("rate^2").width(), 5);
        assert!(!f.without("1").intercept);
    }

    #[test]
    fn products_of_the_same_variable_add_powers() {
        let f = parse("y ~ x:x + x:x^2:z").unwrap();
        assert_eq!(f.term_names(), ["1", "x^2", "x^3:z"]);
        assert_eq!(f.terms[1].degree_in("x"), 3);
    }
}
