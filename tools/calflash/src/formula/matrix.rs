//! From a formula and a table of observations to a design matrix, and back from a failed fit
//! to a sentence that names the term and says why.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::{Formula, INTERCEPT, Term};
use crate::obs::Table;

/// A model's design matrix and response.
#[derive(Debug, Clone)]
pub struct Design {
    /// Column names: `1` first with an intercept, then the terms.
    pub names: Vec<String>,
    /// Observations by columns.
    pub x: DMatrix<f64>,
    /// The response.
    pub y: Vec<f64>,
    /// Whether column 0 is the intercept.
    pub intercept: bool,
}

impl Formula {
    /// The design matrix of this formula over `table`, which must hold every column of
    /// [`Formula::columns`].
    ///
    /// # Panics
    /// When the table lacks a column (the reader guarantees it does not).
    #[must_use]
    pub fn design(&self, table: &Table) -> Design {
        let n = table.len();
        let col = |name: &str| {
            table
                .column(name)
                .unwrap_or_else(|| panic!("the reader read every model column: {name}"))
        };
        let mut x = DMatrix::zeros(n, self.width());
        let first = usize::from(self.intercept);
        // Column-major: each model column is one contiguous run of `n`, filled on its own core.
        x.as_mut_slice()
            .par_chunks_mut(n.max(1))
            .enumerate()
            .for_each(|(j, c)| {
                c.fill(1.0);
                let Some(t) = j.checked_sub(first).and_then(|k| self.terms.get(k)) else {
                    return;
                };
                for f in &t.factors {
                    for (v, xi) in c.iter_mut().zip(col(&f.var)) {
                        *v *= f.eval(*xi);
                    }
                }
            });
        Design {
            names: self.term_names(),
            x,
            y: col(&self.response).to_vec(),
            intercept: self.intercept,
        }
    }

    /// The term behind model column `j`.
    #[must_use]
    pub fn term_at(&self, j: usize) -> Option<&Term> {
        let k = if self.intercept { j.checked_sub(1)? } else { j };
        self.terms.get(k)
    }

    /// Where a fit of this formula over `table` met a value it cannot square: one sentence
    /// naming the file line, the term and the values behind it. `None` for other failures.
    #[must_use]
    pub fn explain_values(&self, table: &Table, error: &crate::stats::FitError) -> Option<String> {
        use crate::stats::FitError;
        let (row, column) = match *error {
            FitError::NotFinite { row, column } => (row, column),
            FitError::Overflow { row } => (row, None),
            _ => return None,
        };
        let line = table.lines.get(row).copied().unwrap_or(row as u64 + 1);
        let mut vars: Vec<&str> = vec![self.response.as_str()];
        if let Some(t) = column.and_then(|j| self.term_at(j)) {
            vars = t.variables();
        } else {
            for t in &self.terms {
                vars.extend(t.variables());
            }
            vars.dedup();
        }
        let values = vars
            .iter()
            .filter_map(|v| Some(format!("{v} = {:e}", table.column(v)?.get(row)?)))
            .collect::<Vec<_>>()
            .join(", ");
        Some(match (error, column) {
            (FitError::NotFinite { .. }, Some(j)) => format!(
                "line {line}: the term {} overflows to {} ({values}); a value that large is a \
                 misread or a unit error: fix the line or leave it out",
                self.term_names()[j],
                self.design(table).x[(row, j)],
            ),
            (FitError::NotFinite { .. }, None) => {
                format!("line {line}: the response is not finite ({values})")
            }
            _ => format!(
                "the fit overflows: its sums of squares exceed the largest f64, and the largest \
                 value is at line {line} ({values}); a value that large is a misread or a unit \
                 error: fix the line or leave it out"
            ),
        })
    }

    /// Why model column `column` cannot be estimated from `table`, in one sentence naming the
    /// term. `combination` is the fit's approximation of the column by earlier columns.
    #[must_use]
    pub fn explain_rank_deficiency(
        &self,
        table: &Table,
        column: usize,
        combination: &[(usize, f64)],
    ) -> String {
        let names = self.term_names();
        let name = &names[column];
        let design = self.design(table);
        let c = design.x.column(column);
        if c.iter().all(|v| *v == 0.0) {
            return format!("{name} is not observable: it is 0 for every observation");
        }
        let vars_constant = self.term_at(column).is_some_and(|t| {
            t.variables().iter().all(|v| {
                let vals = table.column(v).unwrap_or_default();
                vals.iter().all(|x| Some(x) == vals.first())
            })
        });
        if vars_constant && self.intercept {
            return format!(
                "{name} is not observable: it is constant ({}) over all {} observations, so it \
                 cannot be told apart from the intercept; vary it, or drop the term",
                c[0],
                c.len()
            );
        }
        if let Some(term) = self.term_at(column)
            && let [var] = term.variables()[..]
        {
            // The most terms in this variable alone a polynomial in it can separate is the
            // number of distinct values it takes.
            let values = table.column(var).unwrap_or_default();
            let mut distinct: Vec<f64> = values.to_vec();
            distinct.sort_by(f64::total_cmp);
            distinct.dedup();
            let needed = self.terms.iter().filter(|t| t.variables() == [var]).count()
                + usize::from(self.intercept);
            if distinct.len() < needed {
                let own = term.degree_in(var) as usize + usize::from(self.intercept);
                let why = if needed == own {
                    format!("it needs at least {needed}")
                } else {
                    format!(
                        "the model's {needed} terms in {var}{} need at least {needed}",
                        if self.intercept {
                            " (the intercept included)"
                        } else {
                            ""
                        }
                    )
                };
                return format!(
                    "{name} is not observable: {var} takes only {} distinct value{}; {why}",
                    distinct.len(),
                    if distinct.len() == 1 { "" } else { "s" }
                );
            }
            if term.factors.iter().any(|f| f.abs) && values.iter().all(|v| *v >= 0.0) {
                return format!(
                    "{name} is not observable: {var} is never negative, so abs({var}) is {var} \
                     itself; the odd terms need inputs of both signs"
                );
            }
            if term.factors.iter().any(|f| f.abs) && values.iter().all(|v| *v <= 0.0) {
                return format!(
                    "{name} is not observable: {var} is never positive, so abs({var}) is -{var}; \
                     the odd terms need inputs of both signs"
                );
            }
        }
        let parts: Vec<String> = combination
            .iter()
            .filter(|(_, c)| c.abs() > 1e-12)
            .map(|(k, c)| {
                let term = if names[*k] == INTERCEPT {
                    "1".to_string()
                } else {
                    names[*k].clone()
                };
                format!("{c:.6} * {term}")
            })
            .collect();
        if parts.is_empty() {
            format!(
                "{name} is not observable: it does not vary independently of the terms before it"
            )
        } else {
            format!(
                "{name} is not observable: over these observations it equals {} (a linear \
                 combination of the terms before it); change the observations or drop a term",
                parts.join(" + ")
            )
        }
    }

    /// True when term `inner` is contained in term `outer` (every factor of `inner` is in
    /// `outer` with at least its power): `rate` is in `rate^2` and in `rate:temp`.
    #[must_use]
    pub fn contains(outer: &Term, inner: &Term) -> bool {
        outer != inner
            && inner.factors.iter().all(|fi| {
                outer
                    .factors
                    .iter()
                    .any(|fo| fo.var == fi.var && fo.abs == fi.abs && fo.power >= fi.power)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::super::parse;
    use super::*;
    use crate::stats::{FitError, Options, fit};

    fn table(cols: &[(&str, Vec<f64>)]) -> Table {
        Table {
            path: "t.csv".into(),
            names: cols.iter().map(|(n, _)| n.to_string()).collect(),
            columns: cols.iter().map(|(_, c)| c.clone()).collect(),
            lines: (0..cols[0].1.len() as u64).map(|i| i + 2).collect(),
        }
    }

    fn why(formula: &str, t: &Table) -> String {
        let f = parse(formula).unwrap();
        let d = f.design(t);
        match fit(
            &d.x,
            &d.y,
            d.names.clone(),
            d.intercept,
            &Options::default(),
        ) {
            Err(FitError::RankDeficient {
                column,
                combination,
            }) => f.explain_rank_deficiency(t, column, &combination),
            other => panic!("{formula}: {other:?}"),
        }
    }

    #[test]
    fn the_seed_example_and_friends() {
        let two_rates = table(&[
            ("volts", vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6]),
            ("rate", vec![-100.0, -100.0, -100.0, 100.0, 100.0, 100.0]),
            ("temp", vec![25.0; 6]),
        ]);
        assert_eq!(
            why("volts ~ 1 + rate + rate^2", &two_rates),
            "rate^2 is not observable: rate takes only 2 distinct values; it needs at least 3"
        );
        assert!(
            why("volts ~ rate + temp", &two_rates)
                .starts_with("temp is not observable: it is constant (25) over all 6 observations")
        );
        let positive = table(&[
            ("volts", vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6]),
            ("rate", vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
        ]);
        assert!(why("volts ~ rate^2 + rate:abs(rate)", &positive).contains("never negative"));
        let tied = table(&[
            ("volts", vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6]),
            ("a", vec![1.0, 2.0, 3.0, 4.0, 5.0, 7.0]),
            ("b", vec![2.0, 4.5, 3.0, 1.0, 0.0, 9.0]),
            ("c", vec![3.0, 6.5, 6.0, 5.0, 5.0, 16.0]),
        ]);
        let msg = why("volts ~ a + b + c", &tied);
        assert!(
            msg.starts_with("c is not observable: over these observations it equals"),
            "{msg}"
        );
        assert!(
            msg.contains("1.000000 * a") && msg.contains("1.000000 * b"),
            "{msg}"
        );
    }

    #[test]
    fn containment() {
        let f = parse("y ~ rate + rate^2 + rate:temp + temp").unwrap();
        let [rate, rate2, rate_temp, temp] = [0, 1, 2, 3].map(|i| &f.terms[i]);
        assert!(Formula::contains(rate2, rate));
        assert!(Formula::contains(rate_temp, rate) && Formula::contains(rate_temp, temp));
        assert!(!Formula::contains(rate, rate2) && !Formula::contains(temp, rate));
    }
}
