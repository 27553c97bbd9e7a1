//! How well each kind of payout response predicts the moves the QP
//! planner proposes on a model with joint friction: the measurement behind
//! the choice of `[planner] sensitivities` on a friction model (issue 22,
//! item 6).
//!
//! `cargo run --release --example friction_responses [-- MU [STATES]]`
//!
//! From the 40 cm fold of the reference bridge with joint friction μ
//! (default 0.2), states along a deployment (the fold, then after each
//! uniform 5 cm reel-in of every motor; STATES of them, default 7). At each
//! state, moves like those the QP proposes (a collective 5 cm and 2 cm
//! reel-in, a 4 cm reel-in with per-motor differences up to ±1 cm, one
//! half 5 cm and the other 2.5 cm, small mixed corrections), each
//! re-solved through the friction model; every candidate response
//! predicts the gap vectors' and the force rows' change linearly. Printed:
//! per candidate, the relative error of the predicted gap change
//! `‖Δg_pred − Δg‖/‖Δg‖` (median and worst over states and moves), the
//! worst force-row error, N, the reduction ratio ρ of the gap merit that
//! the trust region would see (median, and the least), and the time to
//! compute the response.
//!
//! Measured at μ = 0.2 with 5 states (table in docs/controller.md,
//! "Planning on a model with friction"): the sliding-limit tangent
//! (`PayoutResponse::sliding_tangent`, what `sensitivities = "auto"` uses
//! on a friction model) has the smallest force errors of the cheap
//! responses; the slip-onset tangent predicts these moves as well on the
//! gaps but, deciding each joint's slide per motor, misleads the QP on
//! commands that mix motors (it stalled the closed loop on the default
//! truth).

use std::time::Instant;

use nalgebra::Vector3;
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{
    DeploymentState, ForwardModel, JointFriction, RelaxSettings, SlipOnset, Workspace,
};
use tensegrity_deploy::plan::limits::force_rows;
use tensegrity_deploy::plan::response::IndependentParts;
use tensegrity_deploy::plan::{folded_start, DeploymentProblem, PayoutResponse, Policy};

const INCREMENT_M: f64 = 0.01;

/// Deterministic numbers in [0, 1) (a fixed LCG: the moves are the same
/// on every run).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn solve(model: &ForwardModel, state: &DeploymentState, u: &[f64]) -> Option<DeploymentState> {
    let mut s = state.clone();
    let r = model
        .apply_payout(&mut s, &mut Workspace::default(), u, INCREMENT_M, &mut ())
        .ok()?;
    r.status.is_converged().then_some(s)
}

fn gaps(model: &ForwardModel, s: &DeploymentState) -> Vec<Vector3<f64>> {
    model
        .structure()
        .midspan_pairs
        .iter()
        .map(|[a, b]| s.positions_m[*a] - s.positions_m[*b])
        .collect()
}

/// The collective response: per half, its motors' columns sum to the
/// secant of the half moved together by `step_m` (one solve per
/// direction moves both halves), split between the motors as `base`
/// splits it (the per-motor differences come from `base`).
fn collective(
    model: &ForwardModel,
    state: &DeploymentState,
    base: &PayoutResponse,
    step_m: f64,
) -> Option<PayoutResponse> {
    let parts = IndependentParts::of(model);
    let n = state.payout_m.len();
    let mut out = base.clone();
    let x0 = &state.positions_m;
    let f0 = force_rows(model, state);
    for sign in [1.0, -1.0] {
        let moved = solve(model, state, &vec![sign * step_m; n])?;
        let f1 = force_rows(model, &moved);
        let cols = if sign > 0.0 {
            &mut out.pay_out
        } else {
            &mut out.reel_in
        };
        let mut halves: Vec<Option<usize>> = parts.of_cable.clone();
        halves.sort();
        halves.dedup();
        for part in halves.into_iter().flatten() {
            let motors: Vec<usize> = (0..n)
                .filter(|&m| parts.of_cable[m] == Some(part))
                .collect();
            let k = motors.len() as f64;
            // Secant of the whole half per metre (on its own nodes/rows).
            for (node, x) in x0.iter().enumerate() {
                if parts.of_node[node] != Some(part) {
                    continue;
                }
                let secant = (moved.positions_m[node] - x) / (sign * step_m);
                let sum: Vector3<f64> = motors
                    .iter()
                    .map(|&m| cols[m].positions_m_per_m[node])
                    .sum();
                for &m in &motors {
                    cols[m].positions_m_per_m[node] += (secant - sum) / k;
                }
            }
            for r in 0..f0.len() {
                if parts.of_force_row[r] != Some(part) {
                    continue;
                }
                let secant = (f1[r] - f0[r]) / (sign * step_m);
                let sum: f64 = motors.iter().map(|&m| cols[m].force_n_per_m[r]).sum();
                for &m in &motors {
                    cols[m].force_n_per_m[r] += (secant - sum) / k;
                }
            }
        }
    }
    Some(out)
}

/// The exact tangent at the state moved collectively by `step_m` each way
/// (reel-in columns from the reeled-in state, pay-out from the paid-out).
fn tangent_at_moved(
    model: &ForwardModel,
    state: &DeploymentState,
    step_m: f64,
) -> Option<PayoutResponse> {
    let n = state.payout_m.len();
    let out_state = solve(model, state, &vec![step_m; n])?;
    let in_state = solve(model, state, &vec![-step_m; n])?;
    let a = PayoutResponse::tangent(model, &out_state).ok()?;
    let b = PayoutResponse::tangent(model, &in_state).ok()?;
    Some(PayoutResponse {
        pay_out: a.pay_out,
        reel_in: b.reel_in,
    })
}

struct Stats {
    name: String,
    gap_err: Vec<f64>,
    force_err: Vec<f64>,
    ratio: Vec<f64>,
    time_ms: Vec<f64>,
    failed: usize,
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mu: f64 = args.first().map_or(Ok(0.2), |a| a.parse())?;
    let n_states: usize = args.get(1).map_or(Ok(7), |a| a.parse())?;
    let structure = reference_bridge(&BridgeParameters::default())?;
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::constant(mu)?,
        RelaxSettings::default(),
    )?;
    let problem = DeploymentProblem::default();
    let policy = Policy::default();
    let start = folded_start(&model, &problem, policy.increment_m)?;
    let n = start.payout_m.len();
    let half = n / 2;
    let mut states = vec![start];
    while states.len() < n_states {
        let next = solve(&model, states.last().unwrap(), &vec![-0.05; n]).ok_or("reel-in")?;
        states.push(next);
    }
    let names = [
        "secant, one motor ±5 cm (today)",
        "exact tangent",
        "slip-onset tangent",
        "sliding-limit tangent (friction removed, relaxed; planner's auto)",
        "collective 5 cm + slip-onset differences",
        "collective 5 cm + exact tangent at moved state",
        "collective 5 cm + exact-tangent differences",
        "kept: slip-onset at previous state, Broyden-updated",
        "kept: collective+onset at previous state, Broyden-updated",
    ];
    let mut stats: Vec<Stats> = names
        .iter()
        .map(|n| Stats {
            name: n.to_string(),
            gap_err: vec![],
            force_err: vec![],
            ratio: vec![],
            time_ms: vec![],
            failed: 0,
        })
        .collect();
    let mut rng = Lcg(22);
    let mut previous: Option<(PayoutResponse, PayoutResponse)> = None;
    println!("μ = {mu}; per state: candidate, gap error of the collective 5 cm reel-in, ρ");
    for (k, state) in states.iter().enumerate() {
        let mut moves: Vec<(String, Vec<f64>)> = vec![
            ("all −5 cm".into(), vec![-0.05; n]),
            ("all −2 cm".into(), vec![-0.02; n]),
        ];
        let mut u: Vec<f64> = (0..n).map(|_| -0.04 + 0.02 * (rng.next() - 0.5)).collect();
        moves.push(("−4 ± 1 cm".into(), u.clone()));
        for (c, v) in u.iter_mut().enumerate() {
            *v = if c < half { -0.05 } else { -0.025 };
        }
        moves.push(("A −5, B −2.5 cm".into(), u));
        let u: Vec<f64> = (0..n).map(|_| -0.015 + 0.02 * rng.next()).collect();
        moves.push(("mixed −1.5..+0.5 cm".into(), u));
        let truth: Vec<Option<DeploymentState>> =
            moves.iter().map(|(_, u)| solve(&model, state, u)).collect();
        let g0 = gaps(&model, state);
        let f0 = force_rows(&model, state);
        // The candidates.
        let mut responses: Vec<(Option<PayoutResponse>, f64)> = Vec::new();
        let t = Instant::now();
        let secant = PayoutResponse::finite_difference(&model, state, 0.05, INCREMENT_M).ok();
        responses.push((secant, t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let exact = PayoutResponse::tangent(&model, state).ok();
        responses.push((exact.clone(), t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let onset = PayoutResponse::tangent_with(&model, state, SlipOnset::Loaded).ok();
        responses.push((onset.clone(), t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let sliding = PayoutResponse::sliding_tangent(&model, state).ok();
        responses.push((sliding, t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let c_onset = onset
            .as_ref()
            .and_then(|b| collective(&model, state, b, 0.05));
        responses.push((c_onset.clone(), t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let moved = tangent_at_moved(&model, state, 0.05);
        responses.push((moved, t.elapsed().as_secs_f64() * 1e3));
        let t = Instant::now();
        let c_exact = exact
            .as_ref()
            .and_then(|b| collective(&model, state, b, 0.05));
        responses.push((c_exact, t.elapsed().as_secs_f64() * 1e3));
        // Kept: the previous state's response updated by the uniform 5 cm
        // reel-in that led here.
        let kept = |r: Option<PayoutResponse>| {
            r.map(|mut r| {
                let prev = &states[k - 1];
                let dx: Vec<Vector3<f64>> = state
                    .positions_m
                    .iter()
                    .zip(&prev.positions_m)
                    .map(|(a, b)| a - b)
                    .collect();
                let df: Vec<f64> = f0
                    .iter()
                    .zip(force_rows(&model, prev))
                    .map(|(a, b)| a - b)
                    .collect();
                r.broyden_update(&vec![-0.05; n], &dx, &df);
                r
            })
        };
        let (kept_onset, kept_collective) = match previous.take() {
            Some((a, b)) => (kept(Some(a)), kept(Some(b))),
            None => (None, None),
        };
        responses.push((kept_onset, 0.0));
        responses.push((kept_collective, 0.0));
        if let (Some(a), Some(b)) = (onset, c_onset) {
            previous = Some((a, b));
        }
        let mut line = format!("state {k} (reeled {} cm):", 5 * k);
        for (i, (response, ms)) in responses.iter().enumerate() {
            let Some(response) = response else {
                if k > 0 || i < 7 {
                    stats[i].failed += 1;
                    line += &format!(" [{i}] failed;");
                }
                continue;
            };
            stats[i].time_ms.push(*ms);
            for (m, ((_, u), truth)) in moves.iter().zip(&truth).enumerate() {
                let Some(truth) = truth else { continue };
                let (dx, df) = response.predicted_change(u);
                let g1 = gaps(&model, truth);
                let pairs = &model.structure().midspan_pairs;
                let mut num = 0.0;
                let mut den = 0.0;
                let mut merit_pred = 0.0;
                for (p, [a, b]) in pairs.iter().enumerate() {
                    let pred = dx[*a] - dx[*b];
                    let actual = g1[p] - g0[p];
                    num += (pred - actual).norm_squared();
                    den += actual.norm_squared();
                    merit_pred += (g0[p] + pred).norm_squared();
                }
                let merit0: f64 = g0.iter().map(|g| g.norm_squared()).sum();
                let merit1: f64 = g1.iter().map(|g| g.norm_squared()).sum();
                let rho = (merit0 - merit1) / (merit0 - merit_pred);
                let e = (num / den).sqrt();
                let f1 = force_rows(&model, truth);
                let fe = f1
                    .iter()
                    .zip(&f0)
                    .zip(&df)
                    .map(|((a, b), d)| (a - b - d).abs())
                    .fold(0.0, f64::max);
                stats[i].gap_err.push(e);
                stats[i].force_err.push(fe);
                stats[i].ratio.push(rho);
                if m == 0 {
                    line += &format!(" [{i}] {:.0}% ρ {:.2};", 100.0 * e, rho);
                }
            }
        }
        println!("{line}");
    }
    println!();
    println!("| candidate | gap error median / worst | force error median / worst, N | ρ median / least | ms to compute (median) | failed |");
    println!("|---|---|---|---|---|---|");
    for s in &stats {
        println!(
            "| {} | {:.0} % / {:.0} % | {:.0} / {:.0} | {:.2} / {:.2} | {:.1} | {} |",
            s.name,
            100.0 * median(&s.gap_err),
            100.0 * s.gap_err.iter().copied().fold(0.0, f64::max),
            median(&s.force_err),
            s.force_err.iter().copied().fold(0.0, f64::max),
            median(&s.ratio),
            s.ratio.iter().copied().fold(f64::INFINITY, f64::min),
            median(&s.time_ms),
            s.failed,
        );
    }
    Ok(())
}
