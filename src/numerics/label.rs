//! Labels: the names a user gives a policy (or another setting) that the
//! tools print in tables and write into CSV cells and JSON.
//!
//! A label is one line of 1 to [`MAX_LABEL_CHARS`] printable characters
//! with no white space at either end. A newline would split a row of
//! `runs.csv` and of the printed table over two lines; an empty label
//! leaves a column blank, which reads as a missing value; other control
//! characters move the terminal's cursor.

use super::range::FieldError;

/// Longest label, in characters: a table column stays readable.
pub const MAX_LABEL_CHARS: usize = 64;

/// `Ok` if `value` is a label (see the module notes), else the error on
/// `field` saying what is wrong.
pub fn check_label(field: &str, value: &str) -> Result<(), FieldError> {
    let reason = if value.is_empty() {
        Some("must not be empty".to_string())
    } else if let Some(c) = value.chars().find(|c| c.is_control()) {
        Some(format!(
            "must be one line of printable characters, got {value:?} (holds {c:?})"
        ))
    } else if value.trim() != value {
        Some(format!(
            "must not start or end with white space, got {value:?}"
        ))
    } else if value.chars().count() > MAX_LABEL_CHARS {
        Some(format!(
            "must be at most {MAX_LABEL_CHARS} characters, got {}",
            value.chars().count()
        ))
    } else {
        None
    };
    match reason {
        Some(r) => Err(FieldError::new(field, r)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_one_printable_line() {
        for ok in [
            "qp",
            "frictionless μ=0",
            "a b",
            &"x".repeat(MAX_LABEL_CHARS),
        ] {
            check_label("name", ok).unwrap();
        }
        for (bad, says) in [
            ("", "must not be empty"),
            ("x\ny", "one line of printable characters, got \"x\\ny\""),
            ("x\ty", "holds '\\t'"),
            ("\u{1b}[2Jx", "holds '\\u{1b}'"),
            (" x", "white space"),
            ("x ", "white space"),
        ] {
            let e = check_label("name", bad).unwrap_err();
            assert_eq!(e.field, "name");
            assert!(e.reason.contains(says), "{bad:?}: {}", e.reason);
        }
        let long = "x".repeat(MAX_LABEL_CHARS + 1);
        assert!(check_label("name", &long)
            .unwrap_err()
            .reason
            .contains("at most 64"));
    }
}
