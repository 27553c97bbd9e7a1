//! Smoothing of the load-cell offsets across measurements (a scalar
//! Kalman filter per force row), so that one noisy reading does not move
//! a force limit.

use crate::plan::ModelCorrection;

/// Floor of the force filter's model-error standard deviation, N: even a
/// force the model predicts near zero may be off by this much.
pub const FORCE_MODEL_ERROR_FLOOR_N: f64 = 1.0;

/// Smooths the load-cell offsets across measurements, so that one noisy
/// reading does not move a force limit.
///
/// A load cell reads to ~7 N while the folded bridge's softest segments
/// carry 10 to 15 N against a 5 N limit: taken raw, the noise of a single
/// reading can put a segment at its limit on paper and stop every
/// command. Each measured force row's offset `b` is therefore estimated
/// by a scalar Kalman filter: a random walk whose standard deviation per
/// measurement (and at the start) is the model's plausible error,
/// `fraction·|F| + 1 N` for a predicted force `F`, observed through the
/// reading's noise `σ`:
///
/// ```text
///     P ← P + q²,  q = fraction·|F| + 1 N;   K = P/(P + σ²);
///     b ← b + K·(measured − F − b);          P ← (1 − K)·P.
/// ```
///
/// Where the model's error is small against the noise (a slack-ish
/// folded segment) the offset moves a fraction of the way; where it is
/// large (a kilonewton cable near the design) the offset is the reading.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceOffsetFilter {
    /// Model-error fraction of the predicted force (per measurement), 1.
    error_fraction: f64,
    /// Offset estimate and its variance per force row (`None` before the
    /// row's first reading), (N, N²).
    rows: Vec<Option<(f64, f64)>>,
}

impl ForceOffsetFilter {
    /// A filter over `force_rows` rows with the model-error fraction
    /// `error_fraction` (see the type's documentation).
    pub fn new(force_rows: usize, error_fraction: f64) -> Self {
        ForceOffsetFilter {
            error_fraction,
            rows: vec![None; force_rows],
        }
    }

    /// Replaces `correction`'s raw force offsets (measured − predicted, one
    /// reading) by the filtered ones. `predicted_n` are the model's force
    /// rows at the state the offsets refer to; `noise_sd_n` the reading
    /// noise of each row that was measured this time (`None`: not
    /// measured; its offset stays what it was).
    pub fn filter(
        &mut self,
        correction: &mut ModelCorrection,
        predicted_n: &[f64],
        noise_sd_n: &[Option<f64>],
    ) {
        for (row, slot) in self.rows.iter_mut().enumerate() {
            let model_error = self.error_fraction * predicted_n.get(row).map_or(0.0, |f| f.abs())
                + FORCE_MODEL_ERROR_FLOOR_N;
            let q = model_error * model_error;
            let (mut b, mut p) = slot.unwrap_or((0.0, 0.0));
            p += q;
            if let (Some(Some(sd)), Some(raw)) =
                (noise_sd_n.get(row), correction.force_offsets_n.get(row))
            {
                let r = sd * sd;
                let gain = if r > 0.0 { p / (p + r) } else { 1.0 };
                b += gain * (raw - b);
                p *= 1.0 - gain;
                *slot = Some((b, p));
            } else if slot.is_some() {
                *slot = Some((b, p));
            }
            if let Some(offset) = correction.force_offsets_n.get_mut(row) {
                *offset = slot.map_or(0.0, |(b, _)| b);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filter is the scalar Kalman filter written out: the first
    /// reading of a 10 N row (q = 0.2·10 + 1 = 3 N, σ = 7 N) moves the
    /// offset 9/(9 + 49) of the way; a kilonewton row takes almost all of
    /// it; an unmeasured row keeps zero; a constant bias read many times
    /// is approached.
    #[test]
    fn is_the_scalar_kalman_filter() {
        let mut f = ForceOffsetFilter::new(3, 0.2);
        let mut c = ModelCorrection::none(0, 3);
        c.force_offsets_n = vec![-7.0, 100.0, 0.0];
        f.filter(&mut c, &[10.0, 1000.0, 50.0], &[Some(7.0), Some(7.0), None]);
        assert!((c.force_offsets_n[0] - (-7.0 * 9.0 / 58.0)).abs() < 1e-12);
        let q1 = 201.0f64 * 201.0;
        assert!((c.force_offsets_n[1] - 100.0 * q1 / (q1 + 49.0)).abs() < 1e-9);
        assert_eq!(c.force_offsets_n[2], 0.0);
        for _ in 0..200 {
            c.force_offsets_n = vec![-4.0, 100.0, 0.0];
            f.filter(&mut c, &[10.0, 1000.0, 50.0], &[Some(7.0), Some(7.0), None]);
        }
        assert!((c.force_offsets_n[0] + 4.0).abs() < 1e-6);
    }
}
