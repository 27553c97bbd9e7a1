//! The range a number must lie in (a settings field, a value in a file or
//! on the command line), stated once beside what it bounds so that the
//! check and its message agree. Every settings struct declares its
//! fields' ranges with this type and checks them in its `validate()`.

use std::fmt;

/// An interval of admissible values; every bound is inclusive unless
/// `min_exclusive`. NaN and ±∞ never lie in a range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumberRange {
    /// Lower bound.
    pub min: f64,
    /// Whether the lower bound itself is excluded (`(0, …]`: positive).
    pub min_exclusive: bool,
    /// Upper bound (inclusive).
    pub max: f64,
}

impl NumberRange {
    /// `[min, max]`.
    pub const fn closed(min: f64, max: f64) -> Self {
        NumberRange {
            min,
            min_exclusive: false,
            max,
        }
    }

    /// `(0, max]`: a positive number up to `max`.
    pub const fn positive_up_to(max: f64) -> Self {
        NumberRange {
            min: 0.0,
            min_exclusive: true,
            max,
        }
    }

    /// `[0, max]`: a non-negative number up to `max`.
    pub const fn non_negative_up_to(max: f64) -> Self {
        NumberRange::closed(0.0, max)
    }

    /// Whether `value` is a finite number in the range.
    pub fn contains(&self, value: f64) -> bool {
        let above = if self.min_exclusive {
            value > self.min
        } else {
            value >= self.min
        };
        value.is_finite() && above && value <= self.max
    }

    /// `[min, max]` for a count (`check_count` reads it as whole numbers).
    pub const fn count(min: usize, max: usize) -> Self {
        NumberRange::closed(min as f64, max as f64)
    }

    /// `Ok` if `value` lies in the range, else the sentence saying so, e.g.
    /// `must be a finite number in (0, 0.1], got -1`.
    pub fn check(&self, value: f64) -> Result<(), String> {
        if self.contains(value) {
            Ok(())
        } else {
            Err(format!(
                "must be a finite number in {self}, got {}",
                compact(value)
            ))
        }
    }
}

impl NumberRange {
    /// `Ok` if the count `value` lies in the range, else the sentence
    /// saying so, e.g. `must be a whole number in [1, 10000], got 0`.
    pub fn check_count(&self, value: usize) -> Result<(), String> {
        if self.contains(value as f64) {
            Ok(())
        } else {
            Err(format!("must be a whole number in {self}, got {value}"))
        }
    }
}

/// `value` as a short literal: plain decimals between 1e-4 and 1e6 (as
/// people write them), else scientific, so that `1e300` does not print as
/// three hundred digits in a one-line error.
pub fn compact(value: f64) -> String {
    let magnitude = value.abs();
    if !value.is_finite() || magnitude == 0.0 || (1e-4..1e6).contains(&magnitude) {
        value.to_string()
    } else {
        format!("{value:e}")
    }
}

impl fmt::Display for NumberRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let open = if self.min_exclusive { '(' } else { '[' };
        write!(f, "{open}{}, {}]", compact(self.min), compact(self.max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_non_finite_values() {
        let r = NumberRange::positive_up_to(0.1);
        assert!(!r.contains(0.0) && r.contains(1e-300) && r.contains(0.1));
        assert!(!r.contains(0.1 + 1e-12) && !r.contains(f64::NAN));
        let c = NumberRange::closed(-1.0, f64::MAX);
        assert!(c.contains(-1.0) && !c.contains(f64::INFINITY));
        assert_eq!(
            r.check(-1.0).unwrap_err(),
            "must be a finite number in (0, 0.1], got -1"
        );
        assert_eq!(
            NumberRange::closed(-1e9, 1e9).check(1e300).unwrap_err(),
            "must be a finite number in [-1e9, 1e9], got 1e300"
        );
        assert_eq!(compact(-0.0), "-0");
        assert_eq!(compact(1.5e-7), "1.5e-7");
        let n = NumberRange::count(1, 10_000);
        assert!(n.check_count(1).is_ok() && n.check_count(10_000).is_ok());
        assert_eq!(
            n.check_count(0).unwrap_err(),
            "must be a whole number in [1, 10000], got 0"
        );
    }
}
