//! The deployment experiment: several policies, each deploying the same
//! seeded scenarios in closed loop, on truths whose hidden effects are
//! drawn from the plausible ranges of the effects library.
//!
//! Scenario `i` of seed `s` draws its effect parameters from
//! `StdRng::seed_from_u64(scenario_seed(s, i))`, uniformly within each
//! parameter's plausible range ([`crate::model::ParameterSpec`]), in the
//! order the effects are listed; the same number seeds its sensor noise.
//! Every policy meets the same truth and the same noise draws (paired
//! scenarios). The runs are independent and run in parallel; the results
//! come back in scenario order, so they do not depend on the thread count.
//! Planning times are wall-clock and are the one output that varies.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use crate::model::{EffectKind, Effects, ForwardModel, Structure};
use crate::plan::closed_loop::{deploy_closed_loop, ClosedLoopSetup, Deployment};
use crate::plan::{DeploymentProblem, PlanStatus, Policy};
use crate::sim::{standard_sensors, EffectModel};

/// What the experiment runs.
#[derive(Debug, Clone)]
pub struct DeploymentStudySettings {
    /// Number of scenarios.
    pub scenarios: usize,
    /// Seed of the scenario draws.
    pub seed: u64,
    /// Effects hidden in every truth, parameters drawn per scenario.
    pub hidden_effects: Vec<EffectKind>,
    /// The problem every run solves.
    pub problem: DeploymentProblem,
}

/// One scenario: its seed and the truth's drawn effects.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Index, from 0.
    pub index: usize,
    /// Seed of its draws and of its sensor noise.
    pub seed: u64,
    /// The truth's effects.
    pub effects: Effects,
}

/// One policy on one scenario.
#[derive(Debug, Clone)]
pub struct DeploymentRun {
    /// Scenario index.
    pub scenario: usize,
    /// Policy index (in the order given).
    pub policy: usize,
    /// The deployment; `Err` with the reason when it could not start.
    pub outcome: Result<Deployment, String>,
}

impl DeploymentRun {
    /// Connected by the controller's judgement, *and* every true gap
    /// within `tolerance_m`, *and* no truth limit broken. (A policy that
    /// measures nothing judges connection on its model alone; the truth
    /// decides.)
    pub fn succeeded(&self, tolerance_m: f64) -> bool {
        self.outcome.as_ref().is_ok_and(|d| {
            matches!(d.status, PlanStatus::Connected)
                && d.final_true_gap_m().is_some_and(|g| g <= tolerance_m)
                && d.truth_limit_violations == 0
        })
    }

    /// Total cable travel, m: the sum over commands and motors of |u|.
    pub fn cable_travel_m(&self) -> Option<f64> {
        self.outcome.as_ref().ok().map(|d| {
            d.records
                .iter()
                .flat_map(|r| r.command_m.iter())
                .map(|u| u.abs())
                .sum()
        })
    }

    /// Worst truth utilisation over the run.
    pub fn worst_utilisation(&self) -> Option<f64> {
        self.outcome.as_ref().ok().map(|d| {
            d.records
                .iter()
                .map(|r| r.truth_worst_utilisation)
                .fold(0.0, f64::max)
        })
    }

    /// Median planning time per command, s.
    pub fn median_planning_time_s(&self) -> Option<f64> {
        let d = self.outcome.as_ref().ok()?;
        median(d.records.iter().map(|r| r.planning_time_s).collect())
    }
}

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

/// The scenarios of `settings`.
pub fn scenarios(settings: &DeploymentStudySettings) -> Vec<Scenario> {
    (0..settings.scenarios)
        .map(|index| {
            let seed = scenario_seed(settings.seed, index);
            let mut rng = StdRng::seed_from_u64(seed);
            let mut effects = Effects::default();
            for &kind in &settings.hidden_effects {
                let values: Vec<f64> = kind
                    .parameters()
                    .iter()
                    .map(|p| rng.gen_range(p.plausible.0..=p.plausible.1))
                    .collect();
                effects = effects.with_parameters(kind, &values);
            }
            Scenario {
                index,
                seed,
                effects,
            }
        })
        .collect()
}

/// Runs every policy on every scenario, the controller planning on
/// `model` (whose structure is also the truths'), in parallel; `run_done`
/// is called (from any thread, in any order) as each run ends, for a
/// progress bar. The runs come back in (scenario, policy) order whatever
/// the thread count.
pub fn run_deployment_study(
    model: &ForwardModel,
    policies: &[Policy],
    settings: &DeploymentStudySettings,
    run_done: &(dyn Fn() + Sync),
) -> (Vec<Scenario>, Vec<DeploymentRun>) {
    let scenarios = scenarios(settings);
    let structure: &Structure = model.structure();
    let sensors = standard_sensors(structure);
    let jobs: Vec<(usize, usize)> = (0..scenarios.len())
        .flat_map(|s| (0..policies.len()).map(move |p| (s, p)))
        .collect();
    let runs = jobs
        .par_iter()
        .map(|&(s, p)| {
            let scenario = &scenarios[s];
            let truth = EffectModel::for_measurement(structure.clone(), scenario.effects);
            let setup = ClosedLoopSetup {
                model,
                problem: &settings.problem,
                policy: &policies[p],
                truth: &truth,
                sensors: &sensors,
                temperature_c: None,
                seed: scenario.seed,
            };
            let run = DeploymentRun {
                scenario: s,
                policy: p,
                outcome: deploy_closed_loop(&setup, &mut ()).map_err(|e| e.to_string()),
            };
            run_done();
            run
        })
        .collect();
    (scenarios, runs)
}

/// What one policy did over all scenarios.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicySummary {
    /// Runs.
    pub runs: usize,
    /// Runs that connected with no truth limit broken.
    pub successes: usize,
    /// Wilson 95 % interval of the success rate.
    pub success_interval: (f64, f64),
    /// Median and 95th percentile of commands to connection (successes).
    pub commands_median: Option<f64>,
    /// 95th percentile of commands to connection (successes).
    pub commands_p95: Option<f64>,
    /// Median corrective commands (successes).
    pub corrective_median: Option<f64>,
    /// Median final largest true gap over all runs that started, m.
    pub final_gap_median_m: Option<f64>,
    /// 95th percentile of the final largest true gap, m.
    pub final_gap_p95_m: Option<f64>,
    /// Median total cable travel, m.
    pub travel_median_m: Option<f64>,
    /// Worst truth utilisation over all runs.
    pub worst_utilisation: f64,
    /// Truth limit violations over all runs (must be 0).
    pub violations: usize,
    /// Median over runs of the median planning time per command, s.
    pub planning_time_median_s: Option<f64>,
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
    let n = only_first + only_second;
    if n == 0 {
        return 1.0;
    }
    let k = only_first.min(only_second);
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

/// Paired outcome of policies `a` and `b` over the same scenarios:
/// (both succeeded, only `a`, only `b`, neither).
pub fn paired_outcomes(
    runs: &[DeploymentRun],
    a: usize,
    b: usize,
    tolerance_m: f64,
) -> (usize, usize, usize, usize) {
    let success = |policy: usize, scenario: usize| {
        runs.iter()
            .find(|r| r.policy == policy && r.scenario == scenario)
            .map(|r| r.succeeded(tolerance_m))
    };
    let scenarios: std::collections::BTreeSet<usize> = runs.iter().map(|r| r.scenario).collect();
    let mut counts = (0, 0, 0, 0);
    for s in scenarios {
        match (success(a, s), success(b, s)) {
            (Some(true), Some(true)) => counts.0 += 1,
            (Some(true), Some(false)) => counts.1 += 1,
            (Some(false), Some(true)) => counts.2 += 1,
            (Some(false), Some(false)) => counts.3 += 1,
            // A scenario one policy did not run is not a pair.
            _ => {}
        }
    }
    counts
}

/// The summary of policy `policy` over `runs`; success needs every true
/// gap within `tolerance_m`.
pub fn summarise(runs: &[DeploymentRun], policy: usize, tolerance_m: f64) -> PolicySummary {
    let mine: Vec<&DeploymentRun> = runs.iter().filter(|r| r.policy == policy).collect();
    let ok: Vec<&Deployment> = mine
        .iter()
        .filter(|r| r.succeeded(tolerance_m))
        .filter_map(|r| r.outcome.as_ref().ok())
        .collect();
    let started: Vec<&Deployment> = mine
        .iter()
        .filter_map(|r| r.outcome.as_ref().ok())
        .collect();
    PolicySummary {
        runs: mine.len(),
        successes: ok.len(),
        success_interval: wilson_interval(ok.len(), mine.len()),
        commands_median: median(ok.iter().map(|d| d.records.len() as f64).collect()),
        commands_p95: percentile(ok.iter().map(|d| d.records.len() as f64).collect(), 0.95),
        corrective_median: median(
            ok.iter()
                .filter_map(|d| d.corrective_commands.map(|c| c as f64))
                .collect(),
        ),
        final_gap_median_m: median(
            started
                .iter()
                .filter_map(|d| d.final_true_gap_m())
                .collect(),
        ),
        final_gap_p95_m: percentile(
            started
                .iter()
                .filter_map(|d| d.final_true_gap_m())
                .collect(),
            0.95,
        ),
        travel_median_m: median(mine.iter().filter_map(|r| r.cable_travel_m()).collect()),
        worst_utilisation: mine
            .iter()
            .filter_map(|r| r.worst_utilisation())
            .fold(0.0, f64::max),
        violations: started.iter().map(|d| d.truth_limit_violations).sum(),
        planning_time_median_s: median(
            mine.iter()
                .filter_map(|r| r.median_planning_time_s())
                .collect(),
        ),
    }
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

    #[test]
    fn scenarios_draw_within_plausible_ranges_and_repeat_by_seed() {
        let settings = DeploymentStudySettings {
            scenarios: 20,
            seed: 7,
            hidden_effects: vec![EffectKind::JointFriction, EffectKind::Motor],
            problem: DeploymentProblem::default(),
        };
        let a = scenarios(&settings);
        assert_eq!(a, scenarios(&settings));
        for s in &a {
            for kind in &settings.hidden_effects {
                let values = s.effects.parameters(*kind).unwrap();
                for (v, p) in values.iter().zip(kind.parameters()) {
                    assert!(p.plausible.0 <= *v && *v <= p.plausible.1);
                }
            }
        }
        assert_ne!(a[0].effects, a[1].effects);
    }
}
