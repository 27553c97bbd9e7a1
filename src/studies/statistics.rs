//! Statistics of deployment studies: scenario seeds, order statistics,
//! the Wilson interval of a success rate and McNemar's test of two
//! policies on paired scenarios. Pure functions of numbers.

/// The seed of scenario `index` of an experiment seeded `seed`: SplitMix64
/// of their combination, so neighbouring scenarios draw unrelated streams.
pub fn scenario_seed(seed: u64, index: usize) -> u64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(index as u64 + 1);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The median of `v` (`None` when empty).
pub fn median(v: Vec<f64>) -> Option<f64> {
    percentile(v, 0.5)
}

/// The `q`-quantile of `v` by linear interpolation between order
/// statistics (`None` when empty).
pub fn percentile(mut v: Vec<f64>, q: f64) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    Some(v[lo] + (v[hi] - v[lo]) * (pos - lo as f64))
}

/// Wilson score interval for `k` successes in `n` trials, 95 %.
pub fn wilson_interval(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = 1.959_963_984_540_054;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let denom = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denom;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / denom;
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// Exact two-sided McNemar test of two policies on the same (paired)
/// scenarios: `only_first` scenarios where only the first succeeded,
/// `only_second` where only the second did. Under the null hypothesis
/// (equal success rates) each discordant pair is a fair coin, so the
/// p-value is `min(1, 2·P[X ≤ min(b, c)])` for `X ~ Binomial(b + c, ½)`;
/// 1 when there is no discordant pair. Exact rather than the χ²
/// approximation, which is poor for the few discordant pairs of a
/// 50-scenario study.
pub fn mcnemar_exact_p(only_first: usize, only_second: usize) -> f64 {
    exact_sign_test_p(only_first, only_second)
}

/// Exact two-sided sign test of paired differences: `below` pairs whose
/// difference is negative, `above` positive (ties left out), against a
/// median difference of 0. McNemar's exact test ([`mcnemar_exact_p`]) is
/// this test on the discordant pairs.
pub fn exact_sign_test_p(below: usize, above: usize) -> f64 {
    let n = below + above;
    if n == 0 {
        return 1.0;
    }
    let k = below.min(above);
    // Σ_{i ≤ k} C(n, i) / 2ⁿ, summed in logs so that n in the thousands
    // neither overflows nor underflows term by term.
    let ln_half_n = n as f64 * std::f64::consts::LN_2;
    let mut ln_c = 0.0; // ln C(n, 0)
    let mut tail = 0.0;
    for i in 0..=k {
        if i > 0 {
            ln_c += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        tail += (ln_c - ln_half_n).exp();
    }
    (2.0 * tail).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mcnemar_matches_the_binomial_tail_by_hand() {
        // b = 1, c = 9: 2·(C(10,0) + C(10,1))/2¹⁰ = 22/1024.
        assert!((mcnemar_exact_p(1, 9) - 22.0 / 1024.0).abs() < 1e-15);
        assert_eq!(mcnemar_exact_p(9, 1), mcnemar_exact_p(1, 9));
        // b = 0, c = 22 (the deployment experiment's QP against the
        // nominal policy): 2/2²² = 4.77e-7.
        assert!((mcnemar_exact_p(0, 22) - 2.0 / 4_194_304.0).abs() < 1e-20);
        // Balanced discordance is no evidence; none at all neither.
        assert_eq!(mcnemar_exact_p(5, 5), 1.0);
        assert_eq!(mcnemar_exact_p(0, 0), 1.0);
        // Large n stays finite and symmetric: b = 480, c = 520 gives the
        // two-sided normal approximation's p ≈ 0.218 to 2 digits.
        let p = mcnemar_exact_p(480, 520);
        assert!((p - 0.218).abs() < 0.01, "{p}");
    }

    #[test]
    fn wilson_interval_matches_hand_values() {
        // 45 of 50: p = 0.9; Wilson 95 % (z = 1.96) is 0.786 to 0.957
        // (Newcombe 1998's method 3, computed by hand).
        let (lo, hi) = wilson_interval(45, 50);
        assert!(
            (lo - 0.7864).abs() < 1e-3 && (hi - 0.9565).abs() < 1e-3,
            "{lo} {hi}"
        );
        // All successes: the upper bound is 1, the lower n/(n + z²).
        let (lo, hi) = wilson_interval(50, 50);
        assert!((lo - 50.0 / (50.0 + 1.96f64.powi(2))).abs() < 1e-3 && hi == 1.0);
    }

    #[test]
    fn percentiles_interpolate_order_statistics() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(percentile(vec![0.0, 10.0], 0.95), Some(9.5));
        assert_eq!(median(vec![]), None);
    }
}
