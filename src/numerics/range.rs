//! The range a number must lie in (a settings field, a value in a file or
//! on the command line), stated once beside what it bounds so that the
//! check and its message agree. Every settings struct declares its
//! fields' ranges with this type, as a table of [`Ranged`] rows right
//! after the struct (`fn ranges(&self)`), and its `validate()` checks the
//! table with [`check_ranges`] and then what relates one field to
//! another; an error names the field ([`FieldError`]).

use std::fmt;

/// An interval of admissible values; every bound is inclusive unless
/// `min_exclusive` or `max_exclusive`. NaN and ±∞ never lie in a range
/// (an infinite `max` leaves the range unbounded above).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumberRange {
    /// Lower bound.
    pub min: f64,
    /// Whether the lower bound itself is excluded (`(0, …]`: positive).
    pub min_exclusive: bool,
    /// Upper bound.
    pub max: f64,
    /// Whether the upper bound itself is excluded (`[…, 1)`: below 1).
    pub max_exclusive: bool,
}

impl NumberRange {
    /// `[min, max]`.
    pub const fn closed(min: f64, max: f64) -> Self {
        NumberRange {
            min,
            min_exclusive: false,
            max,
            max_exclusive: false,
        }
    }

    /// `(min, max)`: strictly between the bounds.
    pub const fn open(min: f64, max: f64) -> Self {
        NumberRange::closed(min, max)
            .excluding_min()
            .excluding_max()
    }

    /// `[min, ∞)`: any finite number from `min` up.
    pub const fn at_least(min: f64) -> Self {
        NumberRange::closed(min, f64::INFINITY)
    }

    /// `(min, ∞)`: any finite number above `min`.
    pub const fn above(min: f64) -> Self {
        NumberRange::at_least(min).excluding_min()
    }

    /// `(0, max]`: a positive number up to `max`.
    pub const fn positive_up_to(max: f64) -> Self {
        NumberRange::closed(0.0, max).excluding_min()
    }

    /// `[0, max]`: a non-negative number up to `max`.
    pub const fn non_negative_up_to(max: f64) -> Self {
        NumberRange::closed(0.0, max)
    }

    /// The same range without its lower bound: `(min, …`.
    pub const fn excluding_min(self) -> Self {
        NumberRange {
            min_exclusive: true,
            ..self
        }
    }

    /// The same range without its upper bound: `…, max)`.
    pub const fn excluding_max(self) -> Self {
        NumberRange {
            max_exclusive: true,
            ..self
        }
    }

    /// Whether `value` is a finite number in the range.
    pub fn contains(&self, value: f64) -> bool {
        let above = if self.min_exclusive {
            value > self.min
        } else {
            value >= self.min
        };
        let below = if self.max_exclusive {
            value < self.max
        } else {
            value <= self.max
        };
        value.is_finite() && above && below
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
        if self.max == f64::INFINITY {
            return write!(f, "{open}{}, ∞)", compact(self.min));
        }
        let close = if self.max_exclusive { ')' } else { ']' };
        write!(
            f,
            "{open}{}, {}{close}",
            compact(self.min),
            compact(self.max)
        )
    }
}

/// A settings field outside its declared range, or failing a check that
/// relates it to another field; named by its path from the settings
/// struct that was checked (`trust_region.shrink`).
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    /// Field path, dotted.
    pub field: String,
    /// What is wrong, e.g. `must be a finite number in (0, 1), got 1.5`.
    pub reason: String,
}

impl FieldError {
    /// `field` with `reason`.
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        FieldError {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// The same error seen from the struct that holds the checked one as
    /// its field `section`: the path gains `section.` in front.
    pub fn within(self, section: &str) -> Self {
        FieldError {
            field: format!("{section}.{}", self.field),
            ..self
        }
    }
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.field, self.reason)
    }
}

impl std::error::Error for FieldError {}

/// One number of a settings struct with the range declared for it: a row
/// of the table a settings struct keeps beside its fields, which its
/// `validate()` checks with [`check_ranges`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranged {
    field: &'static str,
    value: RangedValue,
    range: NumberRange,
}

/// The value of a [`Ranged`] row.
#[derive(Debug, Clone, Copy, PartialEq)]
enum RangedValue {
    Real(f64),
    Count(usize),
    /// A setting that may be switched off (`None`: nothing to check).
    Optional(Option<f64>),
}

impl Ranged {
    /// A real-valued field.
    pub const fn real(field: &'static str, value: f64, range: NumberRange) -> Self {
        Ranged {
            field,
            value: RangedValue::Real(value),
            range,
        }
    }

    /// A count, checked as a whole number ([`NumberRange::check_count`]).
    pub const fn count(field: &'static str, value: usize, range: NumberRange) -> Self {
        Ranged {
            field,
            value: RangedValue::Count(value),
            range,
        }
    }

    /// A field that may be switched off (`None`, always admissible); when
    /// on, its value must lie in `range`, and the error says it may be
    /// `"off"` instead.
    pub const fn optional(field: &'static str, value: Option<f64>, range: NumberRange) -> Self {
        Ranged {
            field,
            value: RangedValue::Optional(value),
            range,
        }
    }

    /// The field's name.
    pub fn field(&self) -> &'static str {
        self.field
    }

    /// The range declared for it.
    pub fn range(&self) -> NumberRange {
        self.range
    }

    /// `Ok` if the value lies in its range, else the error naming the field.
    pub fn check(&self) -> Result<(), FieldError> {
        match self.value {
            RangedValue::Real(v) => self.range.check(v),
            RangedValue::Count(n) => self.range.check_count(n),
            RangedValue::Optional(Some(v)) if !self.range.contains(v) => Err(format!(
                "must be a finite number in {} or \"off\", got {}",
                self.range,
                compact(v)
            )),
            RangedValue::Optional(_) => Ok(()),
        }
        .map_err(|reason| FieldError::new(self.field, reason))
    }
}

/// Checks `fields` in order; the first outside its range is the error.
pub fn check_ranges(fields: &[Ranged]) -> Result<(), FieldError> {
    fields.iter().try_for_each(Ranged::check)
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
        let open = NumberRange::open(0.0, 1.0);
        assert!(!open.contains(0.0) && open.contains(0.5) && !open.contains(1.0));
        assert_eq!(open.to_string(), "(0, 1)");
        let unbounded = NumberRange::at_least(1.0);
        assert!(unbounded.contains(f64::MAX) && !unbounded.contains(f64::INFINITY));
        assert_eq!(unbounded.to_string(), "[1, ∞)");
        assert_eq!(NumberRange::above(0.0).to_string(), "(0, ∞)");
        let n = NumberRange::count(1, 10_000);
        assert!(n.check_count(1).is_ok() && n.check_count(10_000).is_ok());
        assert_eq!(
            n.check_count(0).unwrap_err(),
            "must be a whole number in [1, 10000], got 0"
        );
    }

    #[test]
    fn a_table_of_ranges_names_its_first_bad_field() {
        let unit = NumberRange::closed(0.0, 1.0);
        let table = [
            Ranged::real("a", 0.5, unit),
            Ranged::optional("b", None, unit),
            Ranged::count("c", 0, NumberRange::count(1, 3)),
            Ranged::optional("d", Some(2.0), unit),
        ];
        let e = check_ranges(&table).unwrap_err();
        assert_eq!(e.field, "c");
        assert_eq!(e.reason, "must be a whole number in [1, 3], got 0");
        let e = check_ranges(&table[3..]).unwrap_err().within("s");
        assert_eq!(
            e.to_string(),
            "`s.d`: must be a finite number in [0, 1] or \"off\", got 2"
        );
        assert!(check_ranges(&table[..2]).is_ok());
    }
}
