//! Friction tables: μ as a function of the interior angle, as tidy CSV.
//!
//! ```csv
//! interior_angle_deg,mu
//! 117,0.14
//! 146,0.10
//! 170,0.05
//! ```
//! Angles in degrees (the file says so in its column name), strictly
//! increasing, within 0–180; μ finite and non-negative. The model
//! interpolates linearly and holds the end values beyond the table.

use std::path::Path;

use super::FileError;
use crate::model::FrictionCoefficient;

/// The header a friction table must have.
pub const FRICTION_TABLE_HEADER: [&str; 2] = ["interior_angle_deg", "mu"];

/// Reads a friction table.
pub fn read_friction_table(path: &Path) -> Result<FrictionCoefficient, FileError> {
    let text = super::read_text(path)?;
    parse_friction_table(&text, path)
}

/// Parses a friction table; `path` names the source in errors.
pub fn parse_friction_table(text: &str, path: &Path) -> Result<FrictionCoefficient, FileError> {
    let field_error =
        |line: usize, field: &str, message: String| FileError::field(path, line, field, message);
    let mut reader = super::csv_with_header(text, path, &FRICTION_TABLE_HEADER)?;
    let (mut angles, mut mus) = (Vec::new(), Vec::new());
    for record in super::csv_records(&mut reader, path) {
        let (line, record) = record?;
        let number = |i: usize, field: &str| {
            record[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    field_error(
                        line,
                        field,
                        format!("\"{}\" is not a finite number", &record[i]),
                    )
                })
        };
        let angle = number(0, "interior_angle_deg")?;
        if !(0.0..=180.0).contains(&angle) {
            return Err(field_error(
                line,
                "interior_angle_deg",
                format!("{angle} is outside 0–180"),
            ));
        }
        if let Some(&last) = angles.last() {
            if angle.to_radians() <= last {
                return Err(field_error(
                    line,
                    "interior_angle_deg",
                    format!("{angle} does not increase on the row before"),
                ));
            }
        }
        let mu = number(1, "mu")?;
        if mu < 0.0 {
            return Err(field_error(line, "mu", format!("{mu} is negative")));
        }
        angles.push(angle.to_radians());
        mus.push(mu);
    }
    if angles.is_empty() {
        return Err(field_error(1, "row", "the table has no rows".into()));
    }
    Ok(FrictionCoefficient::Table {
        interior_angle_rad: angles,
        mu: mus,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_table_in_radians() {
        let t = parse_friction_table(
            "interior_angle_deg,mu\n90,0.2\n180,0.1\n",
            Path::new("t.csv"),
        )
        .unwrap();
        assert!((t.at(std::f64::consts::FRAC_PI_2) - 0.2).abs() < 1e-15);
        assert!((t.at(0.75 * std::f64::consts::PI) - 0.15).abs() < 1e-12);
    }

    #[test]
    fn names_line_and_field_of_a_bad_row() {
        let e = parse_friction_table(
            "interior_angle_deg,mu\n90,0.2\n80,0.1\n",
            Path::new("t.csv"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("t.csv: line 3, field `interior_angle_deg`"),
            "{e}"
        );
        let e = parse_friction_table("interior_angle_deg,mu\n90,-1\n", Path::new("t.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2, field `mu`"), "{e}");
    }
}
