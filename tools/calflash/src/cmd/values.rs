//! The one place numeric options are checked: every one is parsed by a function here, so
//! that a value outside its domain is refused at parse time with the option named (clap puts
//! `invalid value '...' for '--option'` before the reason).

use clap::ValueEnum;

/// A finite number.
///
/// # Errors
/// Not a number, or NaN or infinite.
pub fn finite(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err("a finite number is expected".into())
    }
}

/// A finite single-precision number (the device's temperature and voltage).
///
/// # Errors
/// As [`finite`], or beyond single precision.
pub fn finite_f32(s: &str) -> Result<f32, String> {
    let v = finite(s)?;
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(format!("{v} is beyond single precision"))
    }
}

/// A finite number above zero.
///
/// # Errors
/// As [`finite`], or zero or negative.
pub fn positive(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err("a number above 0 is expected".into())
    }
}

/// A finite number above zero that single precision holds (and not as zero).
///
/// # Errors
/// As [`positive`], or beyond single precision or below its smallest normal number.
pub fn positive_f32(s: &str) -> Result<f32, String> {
    let v = positive(s)?;
    let f = v as f32;
    if f.is_normal() {
        Ok(f)
    } else {
        Err(format!("{v} is beyond single precision"))
    }
}

/// A finite number, zero or above.
///
/// # Errors
/// As [`finite`], or negative.
pub fn non_negative(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err("a number of 0 or more is expected".into())
    }
}

/// A finite number other than zero (a scale factor may be negative).
///
/// # Errors
/// As [`finite`], or zero.
pub fn non_zero(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v == 0.0 {
        Err("a number other than 0 is expected".into())
    } else {
        Ok(v)
    }
}

/// A finite number from `lo` to `hi`.
///
/// # Errors
/// As [`finite`], or outside `[lo, hi]`.
pub fn in_range(s: &str, lo: f64, hi: f64) -> Result<f64, String> {
    let v = finite(s)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("a number from {lo} to {hi} is expected"))
    }
}

/// A significance level: strictly between 0 and 1.
///
/// # Errors
/// As [`finite`], or outside (0, 1).
pub fn level(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err("a significance level between 0 and 1 (exclusive, e.g. 0.05) is expected".into())
    }
}

/// A duration in seconds, or with the suffix `h` (hours) or `d` (days): `3600`, `12h`, `365d`.
///
/// # Errors
/// Not a finite non-negative number with an optional suffix.
pub fn duration(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let (number, unit) = match t.char_indices().last() {
        Some((i, 'd')) => (&t[..i], 86_400.0),
        Some((i, 'h')) => (&t[..i], 3_600.0),
        Some((i, 's')) => (&t[..i], 1.0),
        _ => (t, 1.0),
    };
    match number.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v * unit),
        _ => Err(format!(
            "`{s}`: a duration is expected: seconds, or a number with h or d (e.g. 365d)"
        )),
    }
}

/// A duration of at most 100 years: an ageing allowance, an age.
///
/// # Errors
/// As [`duration`], or longer than 100 years.
pub fn duration_at_most_a_century(s: &str) -> Result<f64, String> {
    let v = duration(s)?;
    if v > f64::from(spincal::model::MAX_AGEING_S) {
        return Err(format!(
            "`{s}`: at most 100 years (36525d) is expected; a longer allowance means nothing"
        ));
    }
    Ok(v)
}

/// A sample rate the device corrects at: from 0.1 Hz to the firmware's
/// [`spincal::model::MAX_SAMPLE_RATE_HZ`] (100 kHz). No inertial sensor samples outside it.
///
/// # Errors
/// Not a number in that range.
pub fn sample_rate(s: &str) -> Result<f64, String> {
    let (lo, hi) = (*SAMPLE_RATES.start(), *SAMPLE_RATES.end());
    in_range(s, lo, hi).map_err(|_| {
        format!("`{s}`: a sample rate from {lo} Hz to {hi} Hz is expected (Hz, e.g. 2000)")
    })
}

/// The sample rates the device corrects at, Hz ([`sample_rate`]).
pub const SAMPLE_RATES: std::ops::RangeInclusive<f64> =
    0.1..=spincal::model::MAX_SAMPLE_RATE_HZ as f64;

/// A count from `lo` to `hi`.
///
/// # Errors
/// Not a whole number, or outside `[lo, hi]`.
pub fn count_in(s: &str, lo: usize, hi: usize) -> Result<usize, String> {
    let v: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("a count from {lo} to {hi} is expected"))
    }
}

/// A count of at least 1 (and at most 10^9).
///
/// # Errors
/// As [`count_in`].
pub fn at_least_one(s: &str) -> Result<usize, String> {
    count_in(s, 1, 1_000_000_000)
}

/// A number, or a fraction `A/B` of two (a datasheet's `1/16384`).
#[must_use]
pub fn number_of(s: &str) -> Option<f64> {
    let t = s.trim();
    match t.split_once('/') {
        Some((a, b)) => Some(a.trim().parse::<f64>().ok()? / b.trim().parse::<f64>().ok()?),
        None => t.parse().ok(),
    }
}

/// The converter's code format: `unsigned16` (also offset binary), `signed16` (two's
/// complement), any width from 8 to 32 bits; or the rails `LO:HI` of another converter.
///
/// # Errors
/// Anything else, with the forms that are understood.
pub fn codes(s: &str) -> Result<spincal::model::Rails, String> {
    use spincal::model::Rails;
    let expected = "expected unsigned16, signed16 (any width from 8 to 32 bits; unsigned is \
                    also offset binary) or the rails LO:HI";
    let t = s.trim();
    let width = |w: &str| {
        w.parse::<u32>()
            .ok()
            .filter(|b| (8..=32).contains(b))
            .ok_or_else(|| format!("`{s}`: {expected}"))
    };
    if let Some(w) = t.strip_prefix("unsigned") {
        let bits = width(w)?;
        // The rails are i32: a 32-bit unsigned converter's top half is beyond them.
        return if bits == 32 {
            Err(format!(
                "`{s}`: unsigned codes of up to 31 bits are supported"
            ))
        } else {
            Ok(Rails::unsigned(bits))
        };
    }
    if let Some(w) = t.strip_prefix("signed") {
        return Ok(Rails::signed(width(w)?));
    }
    if let Some((lo, hi)) = t.split_once(':') {
        let (Ok(lo), Ok(hi)) = (lo.trim().parse::<i32>(), hi.trim().parse::<i32>()) else {
            return Err(format!("`{s}`: {expected}"));
        };
        return if lo < hi {
            Ok(Rails::new(lo, hi))
        } else {
            Err(format!("`{s}`: the low rail must be below the high one"))
        };
    }
    Err(format!("`{s}`: {expected}"))
}

/// The sensor of a workflow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SensorKind {
    /// Single-axis accelerometer (columns input, output).
    SingleAccel,
    /// Single-axis gyro.
    SingleGyro,
    /// Accelerometer triad (f_*, a_*).
    Accel,
    /// Gyro triad (w_*, g_*; f_* for g-sensitivity).
    Gyro,
    /// IMU (f_*, w_*, a_*, g_*).
    Imu,
}

/// `LO:HI`, two numbers, the first not above the second (`what` names the option).
///
/// # Errors
/// Not two numbers, or LO above HI.
pub fn pair(text: &str, what: &str) -> Result<(f64, f64), String> {
    let (a, b) = text
        .split_once(':')
        .ok_or_else(|| format!("{what}: `{text}` is not LO:HI"))?;
    let n = |s: &str| {
        s.trim()
            .parse::<f64>()
            .map_err(|_| format!("{what}: `{s}` is not a number"))
    };
    let (a, b) = (n(a)?, n(b)?);
    if a > b {
        return Err(format!("{what}: {a} is above {b}"));
    }
    Ok((a, b))
}

/// A date `YYYY-MM-DD` (UTC) as Unix seconds at its midnight.
///
/// # Errors
/// Anything else, named.
pub fn date(s: &str) -> Result<i64, String> {
    let bad = || format!("`{s}`: expected a date YYYY-MM-DD");
    let mut parts = s.trim().splitn(3, '-');
    let mut next = |lo: i64, hi: i64| -> Result<i64, String> {
        let v: i64 = parts.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(bad())
        }
    };
    let (y, m, d) = (next(1970, 9999)?, next(1, 12)?, next(1, 31)?);
    let leap = y % 4 == 0 && (y % 100 != 0 || y % 400 == 0);
    let days = match m {
        2 if leap => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    };
    if d > days {
        return Err(format!(
            "`{s}`: there is no such day ({y}-{m:02} has {days} days); expected a date YYYY-MM-DD"
        ));
    }
    // Days from civil (Howard Hinnant's algorithm).
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = if m > 2 { m - 3 } else { m + 9 };
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    Ok((era * 146_097 + doe - 719_468) * 86_400)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        assert_eq!(date("2026-11-24"), Ok(1_795_478_400));
        assert_eq!(date("2000-02-29"), Ok(951_782_400));
        for no_such_day in ["2026-02-30", "2026-02-29", "2100-02-29", "2026-04-31"] {
            assert!(
                date(no_such_day).unwrap_err().contains("no such day"),
                "{no_such_day}"
            );
        }
        assert_eq!(date("1970-01-01"), Ok(0));
        for bad in ["2026-13-01", "26-11-24", "2026/11/24", "x"] {
            assert!(date(bad).unwrap_err().contains("YYYY-MM-DD"), "{bad}");
        }
    }

    #[test]
    fn each_domain_refuses_what_is_outside_it() {
        assert_eq!(finite("-3.5"), Ok(-3.5));
        for bad in ["nan", "inf", "-inf", "x", ""] {
            assert!(finite(bad).is_err(), "{bad}");
        }
        assert!(positive("0").is_err() && positive("-1").is_err() && positive("1e-9").is_ok());
        assert!(non_negative("-0.1").is_err() && non_negative("0").is_ok());
        assert!(non_zero("0").is_err() && non_zero("-408").is_ok());
        for bad in ["0", "1", "2", "-1", "nan"] {
            assert!(level(bad).is_err(), "{bad}");
        }
        assert_eq!(level("0.05"), Ok(0.05));
        assert!(finite_f32("1e39").is_err() && finite_f32("25").is_ok());
        assert_eq!(count_in("3", 1, 5), Ok(3));
        assert!(count_in("0", 1, 5).is_err() && count_in("-1", 1, 5).is_err());
        assert!(at_least_one("0").is_err());
    }

    use spincal::model::Rails;

    #[test]
    fn code_formats_read_and_name_themselves() {
        assert_eq!(codes("signed16"), Ok(Rails::new(-32768, 32767)));
        assert_eq!(codes("unsigned12"), Ok(Rails::new(0, 4095)));
        assert_eq!(codes("signed32"), Ok(Rails::new(i32::MIN, i32::MAX)));
        assert_eq!(codes("signed8"), Ok(Rails::new(-128, 127)));
        assert_eq!(codes("-100:100"), Ok(Rails::new(-100, 100)));
        for bad in [
            "signed7",
            "unsigned33",
            "unsigned32",
            "16",
            "5:5",
            "x:1",
            "int16",
        ] {
            assert!(codes(bad).is_err(), "{bad}");
        }
        for name in [
            "signed16",
            "unsigned16",
            "signed24",
            "unsigned12",
            "-100:100",
        ] {
            assert_eq!(crate::obs::codes::name(codes(name).unwrap()), name);
        }
    }
}
