//! The description of one parameter of an effect or a local fault: name,
//! unit, neutral value, plausible and admissible ranges.

/// One parameter of an effect ([`super::effects`]) or a local fault
/// ([`super::faults`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterSpec {
    /// Name, as in model files.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// The value that leaves the model as without the effect.
    pub neutral: f64,
    /// Plausible range for the real structure (a fit outside it is
    /// suspect; a synthetic truth draws from it).
    pub plausible: (f64, f64),
    /// Physically admissible range (what [`super::Effects::validate`] and
    /// [`super::Faults::validate`] accept).
    pub admissible: (f64, f64),
}

/// The search range's widening a fit uses by default (half the plausible
/// width each side; `FitSettings::search_widening` in `crate::measure`),
/// and so the range of values a model learnt between cycles may hold.
pub const DEFAULT_SEARCH_WIDENING: f64 = 0.5;

/// Smallest width a parameter's scale takes: a plausible range of zero
/// width would make the scaled search divide by zero. A definition.
const SCALE_FLOOR: f64 = 1e-12;

impl ParameterSpec {
    /// The scale a search works in: the plausible range's width.
    pub fn scale(&self) -> f64 {
        (self.plausible.1 - self.plausible.0).abs().max(SCALE_FLOOR)
    }

    /// The range a fit searches: the plausible range widened by `widening`
    /// of its width on each side, always holding the neutral value (a
    /// range that excludes it forces every fit onto a bound: thermal
    /// expansion's plausible range does not reach zero), within the
    /// admissible range.
    pub fn search_range(&self, widening: f64) -> (f64, f64) {
        let s = self.scale();
        (
            (self.plausible.0 - widening * s)
                .min(self.neutral)
                .max(self.admissible.0),
            (self.plausible.1 + widening * s)
                .max(self.neutral)
                .min(self.admissible.1),
        )
    }

    /// Whether the neutral value is also an end of the admissible range
    /// (μ = 0, a backlash of 0): the effect can only be added on one side,
    /// and a fit stopped there says the effect lacks this part.
    pub fn neutral_ends_admissible_range(&self) -> bool {
        self.neutral == self.admissible.0 || self.neutral == self.admissible.1
    }

    /// Why `value` is not admissible ([`Self::admissible`], and finite);
    /// `None` if it is.
    pub fn admissible_reason(&self, value: f64) -> Option<String> {
        let (lo, hi) = self.admissible;
        if !value.is_finite() {
            Some(format!("must be a finite number, got {value}"))
        } else if value < lo || value > hi {
            Some(match (lo.is_finite(), hi.is_finite()) {
                (true, true) => format!("must lie in [{lo}, {hi}], got {value}"),
                (true, false) => format!("must be ≥ {lo}, got {value}"),
                _ => format!("must be ≤ {hi}, got {value}"),
            })
        } else {
            None
        }
    }
}
