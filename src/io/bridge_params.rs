//! Bridge-parameter files (TOML) for `tdeploy structure --params`: values
//! overriding the reference bridge's [`BridgeParameters`].
//!
//! ```toml
//! # every key is optional; a missing key keeps its default
//! module_length_m = 1.2
//! ring_radius_m = 0.6
//! continuous_cable_tension_n = 600
//!
//! [topology]
//! ring_twist_deg = 54
//! springs = "interior_rings"   # or "axial_and_shared_ring"
//! ```
//! Keys are the fields of [`BridgeParameters`] and its `topology`
//! ([`crate::design::BridgeTopology`]), with their meaning, units and
//! defaults documented there. Unknown keys are errors. Every number must be
//! finite and lie in the range [`RANGES`] gives (with [`OFFSET_RANGE`] for
//! the topology's ring offsets, 1 to [`MAX_MODULES_PER_HALF`] modules per
//! half (the limit on the bridge's size), a strut wall
//! thinner than half the tube's diameter, and `min_stiffness_n_per_m`
//! either in its range or `-inf`, which drops the stiffness requirement).
//! The ranges are wide: they reject typos and unit slips (mm for m), not
//! unusual bridges; form finding then says whether the bridge exists.

use std::path::Path;

use super::toml_text::{field_error, parse_toml};
use super::FileError;
use crate::design::{BridgeParameters, MAX_MODULES_PER_HALF};
use crate::numerics::NumberRange;

/// The admissible range of every real-valued parameter, by key.
pub const RANGES: [(&str, NumberRange); 21] = [
    ("module_length_m", NumberRange::positive_up_to(100.0)),
    ("ring_radius_m", NumberRange::positive_up_to(100.0)),
    ("strut_outer_diameter_m", NumberRange::positive_up_to(1.0)),
    ("strut_wall_m", NumberRange::positive_up_to(0.5)),
    ("steel_youngs_modulus_pa", NumberRange::positive_up_to(1e13)),
    ("steel_density_kg_per_m3", NumberRange::positive_up_to(1e5)),
    ("cable_ea_n", NumberRange::positive_up_to(1e10)),
    ("cable_mass_kg_per_m", NumberRange::positive_up_to(1e3)),
    ("spring_stiffness_n_per_m", NumberRange::positive_up_to(1e9)),
    ("spring_mass_kg", NumberRange::positive_up_to(1e3)),
    ("joint_mass_kg", NumberRange::positive_up_to(1e3)),
    (
        "continuous_cable_tension_n",
        NumberRange::positive_up_to(1e7),
    ),
    ("cable_min_tension_n", NumberRange::non_negative_up_to(1e7)),
    (
        "cable_target_tension_n",
        NumberRange::non_negative_up_to(1e7),
    ),
    ("spring_min_tension_n", NumberRange::non_negative_up_to(1e7)),
    (
        "spring_target_tension_n",
        NumberRange::non_negative_up_to(1e7),
    ),
    (
        "strut_min_compression_n",
        NumberRange::non_negative_up_to(1e7),
    ),
    ("gravity_m_per_s2", NumberRange::positive_up_to(100.0)),
    ("min_stiffness_n_per_m", NumberRange::closed(-1e9, 1e9)),
    (
        "topology.ring_twist_deg",
        NumberRange::closed(-360.0, 360.0),
    ),
    (
        "topology.middle_ring_radius_ratio",
        NumberRange::positive_up_to(10.0),
    ),
];

/// Range of the topology's ring-index offsets: a pentagon has five nodes,
/// so offsets 0 to 4 name them all.
pub const OFFSET_RANGE: std::ops::RangeInclusive<usize> = 0..=4;

/// Reads and validates a bridge-parameter file.
pub fn read_bridge_parameters(path: &Path) -> Result<BridgeParameters, FileError> {
    let text = super::read_text(path)?;
    parse_bridge_parameters(&text, path)
}

/// Parses and validates a bridge-parameter file; `path` names it in errors.
pub fn parse_bridge_parameters(text: &str, path: &Path) -> Result<BridgeParameters, FileError> {
    let p: BridgeParameters = parse_toml(text, path)?;
    let error = |key: &str, message: String| field_error(text, path, key, message);
    for (key, range) in RANGES {
        let value = real_value(&p, key);
        if key == "min_stiffness_n_per_m" && value == f64::NEG_INFINITY {
            continue;
        }
        range.check(value).map_err(|m| error(key, m))?;
    }
    if !(1..=MAX_MODULES_PER_HALF).contains(&p.modules_per_half) {
        return Err(error(
            "modules_per_half",
            format!(
                "must be 1 to {MAX_MODULES_PER_HALF} (the limit on the bridge's size), got {}",
                p.modules_per_half
            ),
        ));
    }
    if 2.0 * p.strut_wall_m >= p.strut_outer_diameter_m {
        return Err(error(
            "strut_wall_m",
            format!(
                "must be less than half of strut_outer_diameter_m ({} m), got {} m",
                p.strut_outer_diameter_m, p.strut_wall_m
            ),
        ));
    }
    let t = &p.topology;
    for (key, offset) in [
        ("topology.second_strut_offset", t.second_strut_offset),
        ("topology.long_strut_offset", t.long_strut_offset),
        ("topology.axial_offset", t.axial_offset),
        ("topology.cable_ring_offset", t.cable_ring_offset),
    ] {
        if !OFFSET_RANGE.contains(&offset) {
            return Err(error(key, format!("must be 0 to 4, got {offset}")));
        }
    }
    Ok(p)
}

/// The value of the real-valued parameter `key` of [`RANGES`].
fn real_value(p: &BridgeParameters, key: &str) -> f64 {
    match key {
        "module_length_m" => p.module_length_m,
        "ring_radius_m" => p.ring_radius_m,
        "strut_outer_diameter_m" => p.strut_outer_diameter_m,
        "strut_wall_m" => p.strut_wall_m,
        "steel_youngs_modulus_pa" => p.steel_youngs_modulus_pa,
        "steel_density_kg_per_m3" => p.steel_density_kg_per_m3,
        "cable_ea_n" => p.cable_ea_n,
        "cable_mass_kg_per_m" => p.cable_mass_kg_per_m,
        "spring_stiffness_n_per_m" => p.spring_stiffness_n_per_m,
        "spring_mass_kg" => p.spring_mass_kg,
        "joint_mass_kg" => p.joint_mass_kg,
        "continuous_cable_tension_n" => p.continuous_cable_tension_n,
        "cable_min_tension_n" => p.cable_min_tension_n,
        "cable_target_tension_n" => p.cable_target_tension_n,
        "spring_min_tension_n" => p.spring_min_tension_n,
        "spring_target_tension_n" => p.spring_target_tension_n,
        "strut_min_compression_n" => p.strut_min_compression_n,
        "gravity_m_per_s2" => p.gravity_m_per_s2,
        "min_stiffness_n_per_m" => p.min_stiffness_n_per_m,
        "topology.ring_twist_deg" => p.topology.ring_twist_deg,
        "topology.middle_ring_radius_ratio" => p.topology.middle_ring_radius_ratio,
        // Every key of RANGES is listed above (a unit test checks it).
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(text: &str) -> String {
        parse_bridge_parameters(text, Path::new("p.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn an_empty_file_is_the_default_bridge_and_every_range_admits_it() {
        let p = parse_bridge_parameters("", Path::new("p.toml")).unwrap();
        assert_eq!(p, BridgeParameters::default());
        for (key, range) in RANGES {
            assert!(range.contains(real_value(&p, key)), "{key}");
        }
    }

    #[test]
    fn overrides_and_minus_infinity_are_read() {
        let p = parse_bridge_parameters(
            "ring_radius_m = 0.6\nmin_stiffness_n_per_m = -inf\n[topology]\nring_twist_deg = 36\n",
            Path::new("p.toml"),
        )
        .unwrap();
        assert_eq!(p.ring_radius_m, 0.6);
        assert_eq!(p.min_stiffness_n_per_m, f64::NEG_INFINITY);
        assert_eq!(p.topology.ring_twist_deg, 36.0);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        assert_eq!(
            error("ring_radius_m = 0.5\nmodule_length_m = -1\n"),
            "p.toml: line 2, field `module_length_m`: must be a finite number in (0, 100], got -1"
        );
        assert_eq!(
            error("[topology]\n\nmiddle_ring_radius_ratio = nan\n"),
            "p.toml: line 3, field `topology.middle_ring_radius_ratio`: must be a finite number in (0, 10], got NaN"
        );
        assert!(
            error("strut_wall_m = 0.02\n").starts_with("p.toml: line 1, field `strut_wall_m`"),
            "{}",
            error("strut_wall_m = 0.02\n")
        );
        assert!(error("[topology]\naxial_offset = 7\n")
            .starts_with("p.toml: line 2, field `topology.axial_offset`: must be 0 to 4"));
        let e = error("ring_radius = 0.5\n");
        assert!(
            e.starts_with("p.toml:1:1: ") && e.contains("ring_radius"),
            "{e}"
        );
        let e = error("ring_radius_m = 0.5\nmodule_length_m = 1 2\n");
        assert!(e.starts_with("p.toml:2:"), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
