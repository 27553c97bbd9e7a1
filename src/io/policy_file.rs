//! Policy files (TOML): which planner, its steps, trust region, weights,
//! margins, command budget and measurements. `policies/` holds the three
//! shipped ones, each commented.
//!
//! ```toml
//! format = "tensegrity-deploy/policy/1"
//! name = "qp"
//! planner = "qp"                  # "nominal", "greedy_tree" or "qp"
//! max_commands = 40
//! [trust_region]
//! initial_m = 0.05
//! [weights]
//! gap = [1.0]
//! ```
//! Every field may be left out (the default of [`crate::plan::Policy`]
//! applies); unknown keys are errors. Errors name file, line and field.

use std::path::Path;

use super::problem_file::{field_line, parse_versioned};
use super::FileError;
use crate::plan::Policy;

/// The `format` a policy file must declare.
pub const POLICY_FORMAT: &str = "tensegrity-deploy/policy/1";

/// Reads and validates a policy file.
pub fn read_policy(path: &Path) -> Result<Policy, FileError> {
    let text = super::read_text(path)?;
    parse_policy(&text, path)
}

/// Parses a policy file; `path` names it in errors.
pub fn parse_policy(text: &str, path: &Path) -> Result<Policy, FileError> {
    let policy: Policy = parse_versioned(text, path, POLICY_FORMAT)?;
    policy
        .validate()
        .map_err(|e| FileError::field(path, field_line(text, e.field), e.field, e.reason))?;
    Ok(policy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_policies_parse() {
        for (name, text) in [
            ("nominal", include_str!("../../policies/nominal.toml")),
            (
                "greedy-tree",
                include_str!("../../policies/greedy-tree.toml"),
            ),
            ("qp", include_str!("../../policies/qp.toml")),
            ("memory", include_str!("../../policies/memory.toml")),
        ] {
            let p = parse_policy(text, Path::new(name)).unwrap_or_else(|e| panic!("{e}"));
            assert!(!p.name.is_empty());
        }
    }
}
