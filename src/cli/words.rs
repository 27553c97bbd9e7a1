//! The numbers and sentences the commands print, in one place: every
//! subcommand that shows a length in mm, a command per motor, a fitted
//! value or where a model fails says it the same way.

use tensegrity_deploy::control::{DeployRecord, DeployStart};
use tensegrity_deploy::measure::comparison_verdict::WhereItFails;
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::measure::outliers::Outlier;
use tensegrity_deploy::measure::settings::OutlierSettings;
use tensegrity_deploy::model::effects::ParameterSpec;

/// A length in m as mm with one decimal, `-` when unknown.
pub fn mm(x: Option<f64>) -> String {
    x.map_or("-".into(), |x| format!("{:.1}", 1e3 * x))
}

/// Lengths in m as a list in mm, one decimal.
pub fn mm_list(v: &[f64]) -> String {
    v.iter()
        .map(|g| format!("{:.1}", 1e3 * g))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Command per motor in mm, runs of equal values folded: `-50.0×10`.
pub fn compact_mm(command_m: &[f64]) -> String {
    let mut runs: Vec<(String, usize)> = Vec::new();
    for c in command_m {
        let text = format!("{:.1}", 1e3 * c);
        match runs.last_mut() {
            Some((t, n)) if *t == text => *n += 1,
            _ => runs.push((text, 1)),
        }
    }
    runs.iter()
        .map(|(t, n)| {
            if *n > 1 {
                format!("{t}×{n}")
            } else {
                t.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `n command(s)`.
pub fn commands_count(n: usize) -> String {
    format!("{n} command{}", if n == 1 { "" } else { "s" })
}

/// `x` with `decimals` decimals, or in scientific notation (four
/// significant figures) where that would print more than ten digits or
/// show nothing but zeros: a sensor with a bad noise SD must not print a
/// number hundreds of digits long.
pub fn number(x: f64, decimals: usize) -> String {
    let small = x != 0.0 && x.abs() < 0.5 * 10f64.powi(-(decimals as i32));
    if x.is_finite() && x.abs() < 1e5 && !small {
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

/// [`number`] with its sign always shown.
pub fn signed_number(x: f64, decimals: usize) -> String {
    let text = number(x, decimals);
    if text.starts_with('-') || x.is_nan() {
        text
    } else {
        format!("+{text}")
    }
}

/// `name = value ± error unit` of one fitted parameter (no unit for
/// dimensionless ones).
pub fn fitted_parameter(spec: &ParameterSpec, value: f64, std_error: f64) -> String {
    let unit = if spec.unit == "1" {
        String::new()
    } else {
        format!(" {}", spec.unit)
    };
    format!(
        "{} = {}{unit}",
        spec.name,
        value_with_error(value, std_error)
    )
}

/// A fitted value with its standard error, to four significant figures
/// whatever the unit's scale (a compliance of 3e-5 m/N must not print as
/// 0.0000).
fn value_with_error(value: f64, std_error: f64) -> String {
    let magnitude = value.abs().max(std_error.abs());
    if magnitude == 0.0 || (1e-2..1e4).contains(&magnitude) {
        format!("{value:.4} ± {std_error:.2e}")
    } else {
        format!("{value:.4e} ± {std_error:.2e}")
    }
}

/// A sentence naming the `outliers` of `log`, found with `settings`
/// (`None` if there are none).
pub fn outliers_in_words(
    log: &MeasurementLog,
    outliers: &[Outlier],
    settings: &OutlierSettings,
) -> Option<String> {
    if outliers.is_empty() {
        return None;
    }
    let named: Vec<String> = outliers
        .iter()
        .map(|o| {
            let cycle = &log.cycles[o.cycle];
            let step = match o.step {
                0 => 0,
                k => cycle.step_labels.get(k - 1).copied().unwrap_or(k as u64),
            };
            format!(
                "{} (cycle {}, step {step}, z {})",
                log.sensors[o.sensor].id,
                cycle.label,
                signed_number(o.z, 1)
            )
        })
        .collect();
    Some(format!(
        "outliers: {} reading(s) beyond {} robust SDs of their sensor's median, left out of the tests: {}",
        outliers.len(),
        settings.limit_robust_sds,
        named.join(", ")
    ))
}

/// Where the model fails worst, in words.
pub fn where_it_fails_in_words(log: &MeasurementLog, w: &WhereItFails) -> String {
    let sensor = log
        .sensors
        .get(w.sensor)
        .map(|s| s.id.as_str())
        .unwrap_or("-");
    let direction = w.direction.map(|d| d.as_str()).unwrap_or("-");
    let feature = match &w.feature {
        Some(f) => format!(
            "its residual correlates most with {f} (r = {:+.2})",
            w.correlation
        ),
        None => "its residual correlates with no feature".into(),
    };
    format!(
        "the model fails worst at {sensor} (RMS {} σ, mean {} σ; {} per-sensor tests reject noise), most in the {direction} direction (RMS {} σ); {feature}",
        number(w.sensor_rms_z, 1),
        signed_number(w.sensor_mean_z, 1),
        w.significant_tests,
        number(w.direction_rms_z, 1)
    )
}

/// The line `deploy` prints once the start is measured.
pub fn deployment_start_line(s: &DeployStart) -> String {
    format!(
        "start: gaps measured {} mm (true {} mm, controller's model {} mm)",
        s.measured_gaps_m
            .iter()
            .map(|g| mm(*g))
            .collect::<Vec<_>>()
            .join(", "),
        mm_list(&s.true_gaps_m),
        mm_list(&s.model_gaps_m)
    )
}

/// The line `deploy` prints after each command.
pub fn deployment_command_line(r: &DeployRecord) -> String {
    format!(
        "{:>3}: command {} mm; largest gap {} mm; truth utilisation {:.2}{}; {}; {:.0} ms",
        r.index,
        compact_mm(&r.command_m),
        mm(r.largest_measured_gap_m()),
        r.truth_worst_utilisation,
        if r.truth_violations.is_empty() {
            String::new()
        } else {
            format!(" ({} LIMITS BROKEN)", r.truth_violations.len())
        },
        r.qp_status
            .map(|s| format!("QP {}", s.as_str()))
            .unwrap_or_else(|| "no QP".into()),
        1e3 * r.planning_time_s
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_print_to_four_figures_at_any_scale() {
        assert_eq!(value_with_error(0.1234567, 0.001), "0.1235 ± 1.00e-3");
        assert_eq!(value_with_error(3.2e-5, 1e-6), "3.2000e-5 ± 1.00e-6");
    }

    #[test]
    fn large_and_tiny_numbers_print_in_scientific_notation() {
        assert_eq!(number(4.23991, 4), "4.2399");
        assert_eq!(number(-0.0001, 4), "-0.0001");
        assert_eq!(number(0.0, 2), "0.00");
        assert_eq!(number(1.0e300, 2), "1.000e300");
        assert_eq!(number(-3.0e-7, 4), "-3.000e-7");
        assert_eq!(number(f64::INFINITY, 2), "inf");
        assert_eq!(signed_number(1.25, 1), "+1.2");
        assert_eq!(signed_number(-1.0e9, 1), "-1.000e9");
    }

    #[test]
    fn commands_fold_runs_of_equal_values() {
        assert_eq!(compact_mm(&[-0.05, -0.05, -0.05, 0.01]), "-50.0×3 10.0");
        assert_eq!(mm(None), "-");
        assert_eq!(mm(Some(0.01234)), "12.3");
    }
}
