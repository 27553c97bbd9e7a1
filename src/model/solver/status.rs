//! How a solve ended ([`RelaxStatus`]) and what it reports ([`RelaxReport`]).

/// Largest strain `L/L0 − 1` (in magnitude) a strut, cable or
/// continuous-cable segment may have in a converged result: 20 %, ten times
/// the breaking strain of structural steel and beyond any rope. An
/// equilibrium past it is no physical result (a solver artefact, or an
/// input slip such as a strut 1 µm long) and is reported as
/// [`RelaxStatus::ImplausibleStrain`]. Slack (shortened) cables and segments
/// carry nothing and are not limited; springs are exempt, since stretching
/// is their function (the reference bridge's stretch by up to 120 %).
pub const PLAUSIBLE_STRAIN: f64 = 0.2;

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RelaxStatus {
    /// Node out-of-balance forces and joint friction residuals are within
    /// tolerance.
    Converged,
    /// `max_iter` reached before convergence; the state is the last iterate.
    IterationLimit,
    /// A position or force became NaN or infinite; the state is unusable.
    Diverged,
    /// The solve balanced, but a member is strained beyond
    /// [`PLAUSIBLE_STRAIN`]: the equilibrium is not physical.
    ImplausibleStrain,
    /// Nodes moved farther than `max_displacement_rel` allows: the structure
    /// is a mechanism in this configuration (lost prestress, slack cables).
    UnstableMechanism,
}

impl RelaxStatus {
    /// `true` only for [`RelaxStatus::Converged`].
    pub fn is_converged(self) -> bool {
        self == RelaxStatus::Converged
    }

    /// Short name, as in result files: `converged`, `iteration_limit`,
    /// `diverged`, `unstable_mechanism`.
    pub fn as_str(self) -> &'static str {
        match self {
            RelaxStatus::Converged => "converged",
            RelaxStatus::IterationLimit => "iteration_limit",
            RelaxStatus::Diverged => "diverged",
            RelaxStatus::UnstableMechanism => "unstable_mechanism",
            RelaxStatus::ImplausibleStrain => "implausible_strain",
        }
    }

    /// Plain words for the command line.
    pub fn describe(self) -> &'static str {
        match self {
            RelaxStatus::Converged => "converged",
            RelaxStatus::IterationLimit => "iteration limit reached before convergence",
            RelaxStatus::Diverged => "diverged (non-finite positions or forces)",
            RelaxStatus::UnstableMechanism => {
                "unstable mechanism (nodes ran away: prestress lost or cables slack)"
            }
            RelaxStatus::ImplausibleStrain => {
                "implausible strain (a member stretched or a strut crushed by more than 20 % of its rest length: not a physical result)"
            }
        }
    }

    /// Severity order: converged < iteration limit < implausible strain <
    /// mechanism < diverged.
    pub fn severity(self) -> u8 {
        match self {
            RelaxStatus::Converged => 0,
            RelaxStatus::IterationLimit => 1,
            RelaxStatus::ImplausibleStrain => 2,
            RelaxStatus::UnstableMechanism => 3,
            RelaxStatus::Diverged => 4,
        }
    }
}

/// The outcome of one solve, with its final residuals.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RelaxReport {
    /// How it ended.
    pub status: RelaxStatus,
    /// DR iterations taken.
    pub iterations: usize,
    /// Newton iterations taken: before DR, and in the tries from DR
    /// iterates (`RelaxSettings::dr_newton_restart_enable`).
    pub newton_iterations: usize,
    /// Kinetic-damping resets.
    pub resets: usize,
    /// Largest out-of-balance force on a free node at the end, N.
    pub max_residual_n: f64,
    /// Largest unbalanced joint friction (capstan violation) at the end, N.
    pub max_friction_residual_n: f64,
    /// The force tolerance that applied, N.
    pub tolerance_n: f64,
}

#[cfg(test)]
mod tests {
    use super::RelaxStatus;

    #[test]
    fn status_names_match_their_serialised_form() {
        for s in [
            RelaxStatus::Converged,
            RelaxStatus::IterationLimit,
            RelaxStatus::Diverged,
            RelaxStatus::UnstableMechanism,
            RelaxStatus::ImplausibleStrain,
        ] {
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
    }
}
