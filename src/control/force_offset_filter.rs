//! Smoothing of the load-cell offsets across measurements, so that one
//! noisy reading does not move a force limit, and their split into the
//! model's error (a force the bridge really carries) and a load-cell bias
//! (a reading the bridge does not carry).

use nalgebra::{DMatrix, DVector};

use crate::plan::ModelCorrection;

/// Floor of the force filter's model-error standard deviation, N: even a
/// force the model predicts near zero may be off by this much.
pub const FORCE_MODEL_ERROR_FLOOR_N: f64 = 1.0;

/// Smooths the load-cell offsets across measurements and separates the
/// model's force error from a bias common to the load cells.
///
/// A load cell reads to ~7 N while the folded bridge's softest segments
/// carry 10 to 15 N against a 5 N limit: taken raw, the noise of a single
/// reading can put a segment at its limit on paper and stop every
/// command. And a load cell zeroed off (the effect `load_cell_bias`, every
/// reading offset alike, plausibly by ±50 N) reads a folded segment's
/// 10 N as −30 N: taken as the model's error it puts the segment at −30 N
/// on paper, compressive, and stops the deployment at its first command.
///
/// The offsets `z_i = measured_i − F_i` of the read force rows are
/// therefore explained by a linear-Gaussian state: the model's error `b_i`
/// per row, a random walk whose standard deviation per measurement (and
/// at the start) is the model's plausible error `q_i = fraction·|F_i| +
/// 1 N` for a predicted force `F_i`; and, when the bias is estimated, one
/// bias `β` common to the load cells, constant, with prior standard
/// deviation `σ_β`. Each reading observes their sum through its noise `σ`:
///
/// ```text
///     P_ii ← P_ii + q_i²;     z_i = β + b_i + v_i,  v_i ~ N(0, σ²)
/// ```
///
/// updated reading by reading (a Kalman filter; without the bias every
/// row is its own scalar filter). `β` and `b_i` separate because the bias
/// is common and constant while the model's error differs from row to row
/// and grows with the force: at the folded start (forces of 10 N, `q` 3 N)
/// a common offset is read as bias; near the design (forces of 500 N, `q`
/// 100 N) a row's offset is read as that row's model error. Only `b_i`
/// enters the force limits ([`ModelCorrection::force_offsets_n`]); the
/// bias is a property of the sensors.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceOffsetFilter {
    /// Model-error fraction of the predicted force (per measurement), 1.
    error_fraction: f64,
    /// Whether state 0 is the common load-cell bias.
    bias: bool,
    /// State index of each force row (`None` before its first reading).
    index: Vec<Option<usize>>,
    /// The estimate: the bias (when estimated), then the model error of
    /// each row read so far, N.
    x: DVector<f64>,
    /// Its covariance, N².
    p: DMatrix<f64>,
}

impl ForceOffsetFilter {
    /// A filter over `force_rows` rows with the model-error fraction
    /// `error_fraction`, and a common load-cell bias of prior standard
    /// deviation `bias_prior_sd_n` (N; `None`: no bias, every offset is
    /// the model's error). See the type's documentation.
    pub fn new(force_rows: usize, error_fraction: f64, bias_prior_sd_n: Option<f64>) -> Self {
        let bias = bias_prior_sd_n.is_some();
        let mut p = DMatrix::zeros(bias as usize, bias as usize);
        if let Some(sd) = bias_prior_sd_n {
            p[(0, 0)] = sd * sd;
        }
        ForceOffsetFilter {
            error_fraction,
            bias,
            index: vec![None; force_rows],
            x: DVector::zeros(bias as usize),
            p,
        }
    }

    /// The estimated common load-cell bias and its standard deviation, N
    /// (`None` when the bias is not estimated or no load cell was read).
    pub fn bias_n(&self) -> Option<(f64, f64)> {
        // Before any load cell is read the bias is only its prior.
        let read = self.x.len() > self.bias as usize;
        (self.bias && read).then(|| (self.x[0], self.p[(0, 0)].max(0.0).sqrt()))
    }

    /// Replaces `correction`'s raw force offsets (measured − predicted, one
    /// reading) by the filtered model errors. `predicted_n` are the
    /// model's force rows at the state the offsets refer to; `noise_sd_n`
    /// the reading noise of each row that was measured this time (`None`:
    /// not measured; its offset stays what it was).
    pub fn filter(
        &mut self,
        correction: &mut ModelCorrection,
        predicted_n: &[f64],
        noise_sd_n: &[Option<f64>],
    ) {
        let read = |row: usize| {
            matches!(noise_sd_n.get(row), Some(Some(_)))
                && correction.force_offsets_n.get(row).is_some()
        };
        // A row read for the first time joins the state at 0.
        for row in 0..self.index.len() {
            if self.index[row].is_none() && read(row) {
                let k = self.x.len();
                self.x = self.x.clone().insert_row(k, 0.0);
                self.p = self.p.clone().insert_row(k, 0.0).insert_column(k, 0.0);
                self.index[row] = Some(k);
            }
        }
        // The model's error walks by its plausible size per measurement.
        for (row, k) in self.index.iter().enumerate() {
            if let Some(k) = *k {
                let q = self.error_fraction * predicted_n.get(row).map_or(0.0, |f| f.abs())
                    + FORCE_MODEL_ERROR_FLOOR_N;
                self.p[(k, k)] += q * q;
            }
        }
        for row in 0..self.index.len() {
            let (Some(k), Some(Some(sd)), Some(raw)) = (
                self.index[row],
                noise_sd_n.get(row),
                correction.force_offsets_n.get(row),
            ) else {
                continue;
            };
            // h = e_k (+ e_0 for the bias).
            let mut ph = self.p.column(k).into_owned();
            let mut predicted = self.x[k];
            if self.bias {
                ph += self.p.column(0);
                predicted += self.x[0];
            }
            let hph = ph[k] + if self.bias { ph[0] } else { 0.0 };
            let s = hph + sd * sd;
            // A reading that is not a number would spread through the
            // shared bias to every row: skipped.
            if !(s > 0.0 && s.is_finite() && raw.is_finite()) {
                continue;
            }
            let gain = &ph / s;
            self.x += &gain * (raw - predicted);
            self.p -= &gain * ph.transpose();
            // Kept symmetric to the last bit.
            self.p = (&self.p + self.p.transpose()) * 0.5;
        }
        for (row, offset) in correction.force_offsets_n.iter_mut().enumerate() {
            *offset = self
                .index
                .get(row)
                .copied()
                .flatten()
                .map_or(0.0, |k| self.x[k]);
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
        let mut f = ForceOffsetFilter::new(3, 0.2, None);
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

    /// A common bias of −40 N on four load cells of folded segments
    /// (10 N predicted, the model right): read at the start it is taken
    /// as bias, not as four segments at −30 N; the model errors stay
    /// within a few newtons and the bias is found within 3 standard
    /// deviations. Where one row near the design (1000 N) is really 150 N
    /// off, that row's offset takes it and the bias stays.
    #[test]
    fn a_common_load_cell_bias_is_not_read_as_the_models_error() {
        let sd = 7.0;
        let mut f = ForceOffsetFilter::new(4, 0.2, Some(28.9));
        let mut c = ModelCorrection::none(0, 4);
        let readings = [[-43.0, -37.0, -45.0, -36.0], [-39.0, -41.0, -34.0, -46.0]];
        for r in readings {
            c.force_offsets_n = r.to_vec();
            f.filter(&mut c, &[10.0; 4], &[Some(sd); 4]);
        }
        let (bias, bias_sd) = f.bias_n().unwrap();
        assert!((bias + 40.0).abs() < 3.0 * bias_sd, "{bias} ± {bias_sd}");
        assert!(bias_sd < 6.0, "{bias_sd}");
        for o in &c.force_offsets_n {
            assert!(o.abs() < 5.0, "{:?}", c.force_offsets_n);
        }
        // Without the bias state the same readings are the model's error.
        let mut plain = ForceOffsetFilter::new(4, 0.2, None);
        for r in readings {
            c.force_offsets_n = r.to_vec();
            plain.filter(&mut c, &[10.0; 4], &[Some(sd); 4]);
        }
        assert!(
            c.force_offsets_n.iter().all(|o| *o < -4.0),
            "{:?}",
            c.force_offsets_n
        );
        // Near the design, row 0 carries 150 N more than its 1000 N.
        for _ in 0..5 {
            c.force_offsets_n = vec![110.0, -40.0, -40.0, -40.0];
            f.filter(&mut c, &[1000.0, 10.0, 10.0, 10.0], &[Some(sd); 4]);
        }
        assert!(
            (c.force_offsets_n[0] - 150.0).abs() < 10.0,
            "{:?}",
            c.force_offsets_n
        );
        let (bias, _) = f.bias_n().unwrap();
        assert!((bias + 40.0).abs() < 5.0, "{bias}");
    }
}
