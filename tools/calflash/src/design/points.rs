//! Points a plan can hold: named variables (the observation columns `calflash simulate` writes:
//! `input`, `input_p`, `input_o` for a single axis; `f_x f_y f_z`, `w_x w_y w_z` for triads;
//! `temp`, `volt`; or any name a formula uses), built from the equipment's reach (plan items
//! such as `tumble:24` or `rate:-10:10:21`, chamber temperatures, supply voltages) and from
//! grids `NAME=LO:HI:N`; and plan files (CSV, one point per row, a header naming the variables).

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::DMatrix;

use super::Error;
use crate::columns as col;
use crate::formula::Formula;
use crate::obs::{self, Format};
use crate::sim::plan::{self, Condition};

/// Values of the variables that no point sets: 25 C, 5 V, zero input.
#[must_use]
pub fn default_value(name: &str) -> f64 {
    match name {
        col::TEMP => 25.0,
        col::VOLT => 5.0,
        _ => 0.0,
    }
}

/// `lever_ik` as `(i, k)`.
fn lever_name(name: &str) -> Option<(usize, usize)> {
    let rest = name.strip_prefix("lever_")?.as_bytes();
    let axis = |c: u8| match c {
        b'x' => Some(0),
        b'y' => Some(1),
        b'z' => Some(2),
        _ => None,
    };
    match rest {
        [a, b] => Some((axis(*a)?, axis(*b)?)),
        _ => None,
    }
}

/// A set of points: variable names and one row of values per point.
#[derive(Debug, Clone, PartialEq)]
pub struct Points {
    /// Variable names.
    pub names: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<f64>>,
}

impl Points {
    /// The value of `name` at row `r` (the default when the set lacks the variable). The
    /// lever-arm regressors `lever_ik` (`sensor::lever`) are made from the point's rates and
    /// angular accelerations when the set does not list them.
    #[must_use]
    pub fn value(&self, r: usize, name: &str) -> f64 {
        if let Some(k) = self.names.iter().position(|n| n == name) {
            return self.rows[r][k];
        }
        if let Some((i, k)) = lever_name(name) {
            let get = |names: [&str; 3]| names.map(|n| self.value(r, n));
            let mut e = [0.0; 3];
            e[i] = 1.0;
            return crate::sensor::lever::gradient(&e, &get(col::W), &get(col::DW))[k];
        }
        default_value(name)
    }

    /// True when the set gives `name`: a variable it lists, or a lever-arm regressor it has the
    /// rates for.
    #[must_use]
    pub fn sets(&self, name: &str) -> bool {
        self.names.iter().any(|n| n == name)
            || (lever_name(name).is_some()
                && col::W.iter().all(|w| self.names.iter().any(|n| n == w)))
    }

    /// The model rows of `formula` at every point.
    #[must_use]
    pub fn model_rows(&self, formula: &Formula) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(self.rows.len(), formula.width());
        let mut row = Vec::new();
        for r in 0..self.rows.len() {
            formula.row(|v| self.value(r, v), &mut row);
            for (j, x) in row.iter().enumerate() {
                out[(r, j)] = *x;
            }
        }
        out
    }

    /// The product of two sets (every row of one with every row of the other).
    #[must_use]
    pub fn product(&self, other: &Self) -> Self {
        if self.rows.is_empty() {
            return other.clone();
        }
        if other.rows.is_empty() {
            return self.clone();
        }
        let mut names = self.names.clone();
        names.extend(other.names.iter().cloned());
        let rows = self
            .rows
            .iter()
            .flat_map(|a| {
                other
                    .rows
                    .iter()
                    .map(move |b| a.iter().chain(b).copied().collect())
            })
            .collect();
        Self { names, rows }
    }

    /// The rows of `indices`, in order (repeats kept).
    #[must_use]
    pub fn select(&self, indices: &[usize]) -> Self {
        Self {
            names: self.names.clone(),
            rows: indices.iter().map(|&k| self.rows[k].clone()).collect(),
        }
    }
}

/// What kind of unit the plan items drive (which input a single axis reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// A single accelerometer: `input` is the x specific force.
    SingleAccel,
    /// A single gyro: `input` is the x rate.
    SingleGyro,
    /// A triad or IMU: the full vectors.
    Triad,
}

fn condition_values(c: &Condition, unit: Unit) -> Vec<f64> {
    let mut v = vec![
        c.f[0], c.f[1], c.f[2], c.w[0], c.w[1], c.w[2], c.temp, c.volt,
    ];
    let s = if unit == Unit::SingleGyro { c.w } else { c.f };
    v.extend([s[0], s[1], s[2]]);
    v
}

fn condition_names() -> Vec<String> {
    let mut n: Vec<String> = col::F
        .iter()
        .chain(col::W.iter())
        .map(|s| (*s).to_string())
        .collect();
    n.extend([col::TEMP, col::VOLT, col::INPUT, col::INPUT_P, col::INPUT_O].map(String::from));
    n
}

/// The points of plan items (as `calflash simulate --plan` takes them) at every temperature and
/// voltage, `repeat` times.
///
/// # Errors
/// A plan item that cannot be read.
pub fn from_items(
    items: &[String],
    temps: &[f64],
    volts: &[f64],
    repeat: usize,
    unit: Unit,
) -> Result<Points, Error> {
    let conds = plan::plan(items, temps, volts, repeat, unit != Unit::Triad)?;
    Ok(Points {
        names: condition_names(),
        rows: conds.iter().map(|c| condition_values(c, unit)).collect(),
    })
}

/// A grid `NAME=LO:HI:N` (N evenly spaced values, both ends included).
///
/// # Errors
/// A malformed grid.
pub fn grid(text: &str) -> Result<Points, Error> {
    let bad = |why: &str| Error::Grid {
        text: text.to_string(),
        why: why.to_string(),
    };
    let (name, spec) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
    let parts: Vec<&str> = spec.split(':').collect();
    let [lo, hi, n] = parts[..] else {
        return Err(bad("not three fields after `=`"));
    };
    let num = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
    let (Some(lo), Some(hi)) = (num(lo), num(hi)) else {
        return Err(bad("LO and HI must be numbers"));
    };
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| bad("N must be a whole number"))?;
    if n > plan::MAX_CONDITIONS {
        return Err(bad(&format!("N is at most {}", plan::MAX_CONDITIONS)));
    }
    if n == 0 || (n == 1 && lo != hi) || lo > hi {
        return Err(bad(
            "N must be at least 2 (1 when LO = HI) and LO at most HI",
        ));
    }
    let name = name.trim();
    if name.is_empty() {
        return Err(bad("no variable name"));
    }
    let rows = (0..n)
        .map(|k| {
            vec![if n == 1 {
                lo
            } else {
                lo + (hi - lo) * k as f64 / (n - 1) as f64
            }]
        })
        .collect();
    Ok(Points {
        names: vec![name.to_string()],
        rows,
    })
}

/// Reads a plan file: the columns `names` (each must be present) from a CSV or whitespace file
/// with a header.
///
/// # Errors
/// The reader's error, naming the file, line and column.
pub fn read(path: &Path, names: &[String]) -> Result<Points, Error> {
    let table = obs::read_columns(path, names, Format::Auto)?;
    let rows = (0..table.len())
        .map(|r| {
            names
                .iter()
                .map(|n| table.column(n).map_or(0.0, |c| c[r]))
                .collect()
        })
        .collect();
    Ok(Points {
        names: names.to_vec(),
        rows,
    })
}

/// The plan as CSV: the variables of `keep` (in order) that the points set, then a `repeat`
/// count per distinct point when `collapse`.
#[must_use]
pub fn to_csv(points: &Points, keep: &[String]) -> String {
    let cols: Vec<usize> = keep
        .iter()
        .filter_map(|k| points.names.iter().position(|n| n == k))
        .collect();
    let mut out = cols
        .iter()
        .map(|&c| points.names[c].clone())
        .collect::<Vec<_>>()
        .join(",");
    out.push('\n');
    for r in &points.rows {
        out.push_str(
            &cols
                .iter()
                .map(|&c| format!("{}", r[c]))
                .collect::<Vec<_>>()
                .join(","),
        );
        out.push('\n');
    }
    out
}

/// Distinct rows (equal to 12 significant digits) and how often each occurs, in first-seen
/// order.
#[must_use]
pub fn tally(points: &Points) -> Vec<(Vec<f64>, usize)> {
    let mut seen: BTreeMap<Vec<String>, usize> = BTreeMap::new();
    let mut out: Vec<(Vec<f64>, usize)> = Vec::new();
    for r in &points.rows {
        // Equal to 12 significant digits: cos(135 deg) and cos(225 deg) are one point.
        let key: Vec<String> = r
            .iter()
            .map(|v| format!("{:.11e}", if v.abs() < 1e-12 { 0.0 } else { *v }))
            .collect();
        match seen.get(&key) {
            Some(&k) => out[k].1 += 1,
            None => {
                seen.insert(key, out.len());
                out.push((r.clone(), 1));
            }
        }
    }
    out
}

/// An operating point `NAME=VALUE[,NAME=VALUE...]` (`design predict --at`): variables and
/// their finite values, in the order given.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatingPoint {
    /// The text it was read from.
    pub text: String,
    /// The variables and values.
    pub values: Vec<(String, f64)>,
}

impl Points {
    /// The operating points `at` as a set of points, each over variables the model reads
    /// (`vars`), all over the same ones.
    ///
    /// # Errors
    /// No point, a variable the model does not read, or points over different variables.
    pub fn operating(at: &[OperatingPoint], vars: &[String]) -> Result<Self, Error> {
        let mut points = Self {
            names: Vec::new(),
            rows: Vec::new(),
        };
        for point in at {
            let spec = &point.text;
            if let Some((k, _)) = point.values.iter().find(|(k, _)| !vars.contains(k)) {
                return Err(Error::OperatingVariable {
                    spec: spec.clone(),
                    name: k.clone(),
                    reads: vars.join(", "),
                });
            }
            let names: Vec<String> = point.values.iter().map(|(k, _)| k.clone()).collect();
            if points.rows.is_empty() {
                points.names = names;
            } else if points.names != names {
                return Err(Error::OperatingVariables {
                    spec: spec.clone(),
                    first: points.names.join(", "),
                });
            }
            points
                .rows
                .push(point.values.iter().map(|(_, v)| *v).collect());
        }
        if points.rows.is_empty() {
            return Err(Error::NoOperatingPoint);
        }
        Ok(points)
    }
}

impl std::str::FromStr for OperatingPoint {
    type Err = Error;

    fn from_str(spec: &str) -> Result<Self, Error> {
        let values = spec
            .split(',')
            .map(|kv| {
                let (k, v) = kv
                    .split_once('=')
                    .ok_or_else(|| Error::OperatingPoint(spec.to_string()))?;
                let v = v
                    .trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| Error::OperatingValue {
                        spec: spec.to_string(),
                        value: v.trim().to_string(),
                    })?;
                Ok((k.trim().to_string(), v))
            })
            .collect::<Result<_, Error>>()?;
        Ok(Self {
            text: spec.to_string(),
            values,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operating_points_are_over_the_models_variables_and_the_same_ones() {
        let vars = ["input".to_string(), "temp".to_string()];
        let at = |specs: &[&str]| -> Vec<OperatingPoint> {
            specs.iter().map(|s| s.parse().unwrap()).collect()
        };
        let p = Points::operating(&at(&["input=5,temp=20", "input=-9,temp=20"]), &vars).unwrap();
        assert_eq!(p.names, ["input", "temp"]);
        assert_eq!(p.rows, [[5.0, 20.0], [-9.0, 20.0]]);
        let e = Points::operating(&at(&["volt=5"]), &vars).unwrap_err();
        assert!(
            matches!(&e, Error::OperatingVariable { name, .. } if name == "volt"),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "--at `volt=5`: the model reads no `volt`; it reads input, temp"
        );
        let e = Points::operating(&at(&["input=5", "temp=3"]), &vars).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--at `temp=3`: every operating point must name the same variables (input)"
        );
        assert!(matches!(
            Points::operating(&[], &vars),
            Err(Error::NoOperatingPoint)
        ));
    }

    #[test]
    fn an_operating_point_reads_names_and_finite_values() {
        let p: OperatingPoint = "rate = 2.5, temp=-40".parse().unwrap();
        assert_eq!(p.values, [("rate".into(), 2.5), ("temp".into(), -40.0)]);
        assert_eq!(
            "rate".parse::<OperatingPoint>().unwrap_err().to_string(),
            "--at `rate`: expected NAME=VALUE[,NAME=VALUE...]"
        );
        assert_eq!(
            "rate=1,temp=NaN"
                .parse::<OperatingPoint>()
                .unwrap_err()
                .to_string(),
            "--at `rate=1,temp=NaN`: `NaN` is not a finite number"
        );
    }

    #[test]
    fn grids_items_and_products() {
        let g = grid("rate=-1:1:3").unwrap();
        assert_eq!(g.rows, [vec![-1.0], vec![0.0], vec![1.0]]);
        assert_eq!(
            grid("rate=1:0:3").unwrap_err().to_string(),
            "grid `rate=1:0:3`: N must be at least 2 (1 when LO = HI) and LO at most HI; expected NAME=LO:HI:N, for example rate=-10:10:21"
        );
        let t = grid("temp=-40:85:2").unwrap();
        let p = g.product(&t);
        assert_eq!(p.rows.len(), 6);
        assert_eq!(p.value(5, "temp"), 85.0);
        assert_eq!(p.value(0, "volt"), 5.0);
        let tumble = from_items(&["tumble:6".into()], &[25.0], &[5.0], 1, Unit::Triad).unwrap();
        assert_eq!(tumble.rows.len(), 6);
        let f = crate::formula::parse("y ~ 1 + f_x + f_y + f_z").unwrap();
        let x = tumble.model_rows(&f);
        assert_eq!(x.shape(), (6, 4));
        assert_eq!(
            tally(&p.select(&[0, 0, 1])),
            [(vec![-1.0, -40.0], 2), (vec![-1.0, 85.0], 1)]
        );
    }
}
