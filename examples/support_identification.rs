//! Can the sensors tell how soft the abutment is, during a deployment?
//! (issue 22, item 4.) Each scenario of a distribution is deployed by a
//! policy on the frictionless reference model; then the support
//! compliance is fitted to its midspan position readings
//! (`control::support_compliance`), once on every command and once on the
//! commands up to the first measured largest gap under 60 mm (what an
//! online estimate would know when the controller starts its last, most
//! model-sensitive approach).
//!
//! From the repository root:
//! `cargo run --release --example support_identification -- D.toml SEED N [POLICY]`
//! (POLICY default `policies/qp.toml`) prints one CSV row per scenario:
//! the truth's compliance (0: rigid), each fit's μ, estimate, standard
//! error (empty at the candidates' end), residual standard deviation and
//! payout scales, the run's status, drawn μ and fold, then the optional
//! columns below (empty when not asked for). The truths, sensors and
//! noise are the ones `tdeploy evaluate --distribution D --seed S` draws.
//!
//! Options, by environment variable:
//! - `MU_GRID=0,0.1,0.2,0.3`: the candidate models' joint friction; the
//!   fit with the smallest residual is reported, μ with it (default 0:
//!   frictionless candidates only);
//! - `CALIBRATE=1`: the diagnosis's fit of `support_flexibility` on the
//!   same deployment's log (`measure::calibrate::calibrate_on_log`,
//!   absolute readings from the design on): a second method;
//! - `PLAN=1`: the run deployed again from the same folded truth on the
//!   model over the full fit's estimated supports (as a next cycle on the
//!   same site would; frictionless whatever μ `MU_GRID` found; no run, and
//!   empty columns, where the fit failed), and on the truth's exact
//!   supports.
//!
//! Runs with fewer than 3 commands (the big folds that stop at once,
//! docs/known-limitations.md item 18) carry little to fit; the figures in
//! the docs leave them out (`full_commands` says which).
//!
//! Findings: docs/known-limitations.md, item 20.

use rayon::prelude::*;
use tensegrity_deploy::control::support_compliance::{
    fit_support_compliance, model_on_supports, SupportComplianceFit,
};
use tensegrity_deploy::control::{
    deploy_guided, fold_truth, ClosedLoopSetup, Guidance, CORRECTIVE_PHASE_GAP_M,
};
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::measure::calibrate::{calibrate_on_log, CalibrationMethod, KeepFit};
use tensegrity_deploy::model::{EffectKind, Effects, ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::EffectModel;
use tensegrity_deploy::studies::deployment_log::deployment_log;
use tensegrity_deploy::studies::evaluation::RunResult;

/// Candidate compliances, m/N: rigid, then past the wide distribution's
/// 1e-5–5e-5 so that an estimate at its top is not pinned to the end.
const CANDIDATES: [f64; 8] = [0.0, 1e-5, 2e-5, 3e-5, 4e-5, 5e-5, 6e-5, 7e-5];

fn columns((mu, fit): &(f64, Result<SupportComplianceFit, String>)) -> String {
    match fit {
        Ok(f) => format!(
            "{mu},{:.3e},{},{:.5},{}",
            f.compliance_m_per_n,
            f.standard_error_m_per_n
                .map_or(String::new(), |s| format!("{s:.3e}")),
            f.residual_sd_m,
            f.payout_scale
                .iter()
                .map(|s| format!("{s:.4}"))
                .collect::<Vec<_>>()
                .join(";")
        ),
        Err(e) => format!("{mu},,,,fit failed: {}", e.replace(',', ";")),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(3..=4).contains(&args.len()) {
        return Err("usage: DISTRIBUTION.toml SEED SCENARIOS [POLICY.toml]".into());
    }
    let distribution = read_distribution(std::path::Path::new(&args[0]))?;
    let seed: u64 = args[1].parse()?;
    let count: usize = args[2].parse()?;
    let policy = read_policy(std::path::Path::new(
        args.get(3).map_or("policies/qp.toml", String::as_str),
    ))?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let nominal = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    // Candidate models' joint friction: `MU_GRID=0,0.1,0.2,0.3` fits μ
    // beside the compliance (the best pair by residual); default 0.
    let mu_grid: Vec<f64> = std::env::var("MU_GRID")
        .unwrap_or_else(|_| "0".into())
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let candidate_models: Vec<ForwardModel> = mu_grid
        .iter()
        .map(|&mu| {
            ForwardModel::new(
                bridge.clone(),
                JointFriction::constant(mu)?,
                RelaxSettings::default(),
            )
            .map_err(|e| e.to_string().into())
        })
        .collect::<Result<_, Box<dyn std::error::Error>>>()?;
    let base = DeploymentProblem::default();
    println!(
        "scenario,truth_compliance_m_per_n,\
         full_commands,full_mu,full_estimate,full_se,full_residual_sd_m,full_payout_scale,\
         early_commands,early_mu,early_estimate,early_se,early_residual_sd_m,early_payout_scale,\
         status,succeeded,violations,final_true_gap_m,drawn_mu,fold_m,\
         calibrated_estimate,calibrated_se,calibrated_converged,\
         estimated_c,estimated_status,estimated_succeeded,estimated_violations,estimated_commands,estimated_final_true_gap_m,\
         exact_c,exact_status,exact_succeeded,exact_violations,exact_commands,exact_final_true_gap_m,commands"
    );
    let rows: Vec<String> = (0..count)
        .into_par_iter()
        .map(|i| {
            let s = distribution.draw(seed, i);
            let truth = s.truth(&bridge);
            let compliance = truth
                .effects
                .support_flexibility
                .map_or(0.0, |e| e.compliance_m_per_n);
            let mu = truth.effects.joint_friction.map_or(0.0, |f| f.mu);
            s.with_setup(&bridge, &nominal, &base, &policy, |setup| {
                let folded = fold_truth(setup);
                let deployed = folded.clone().and_then(|mut plant| {
                    deploy_guided(setup, &Guidance::default(), Some(&mut plant), &mut ())
                });
                let Ok(d) = deployed else {
                    // The 36 columns, the fits' and the optional ones empty.
                    return format!(
                        "{i},{compliance:.3e},{}not_started,0,,,{mu:.3},{:.3},{}0",
                        ",".repeat(12),
                        s.fold_m,
                        ",".repeat(15)
                    );
                };
                let r = RunResult::of(i, 0, Some(&d), base.connection_tolerance_m);
                let sent: Vec<Vec<f64>> = d.records.iter().map(|r| r.command_m.clone()).collect();
                let early = d
                    .records
                    .iter()
                    .position(|r| {
                        r.measured_gaps_m
                            .iter()
                            .flatten()
                            .copied()
                            .reduce(f64::max)
                            .is_some_and(|g| g < CORRECTIVE_PHASE_GAP_M)
                    })
                    .map_or(sent.len(), |k| k + 1);
                let fit = |n: usize| {
                    let fits: Vec<_> = candidate_models
                        .iter()
                        .map(|m| {
                            fit_support_compliance(
                                m,
                                setup.problem,
                                policy.increment_m,
                                &CANDIDATES,
                                setup.sensors,
                                &sent[..n],
                                &d.readings[..=n],
                            )
                            .map_err(|e| e.to_string())
                        })
                        .collect();
                    let best = fits
                        .iter()
                        .enumerate()
                        .filter_map(|(k, f)| f.as_ref().ok().map(|f| (k, f.residual_sd_m)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or(0, |b| b.0);
                    (mu_grid[best], fits.into_iter().nth(best).unwrap())
                };
                let full_fit = fit(sent.len());
                // The diagnosis's own fit of the same effect on the same
                // readings (`CALIBRATE=1`): a second method.
                let calibrated = if std::env::var("CALIBRATE").is_ok_and(|v| v == "1") {
                    let log = deployment_log(&d, "reference", setup.sensors.to_vec());
                    let base = EffectModel::for_measurement(bridge.clone(), Effects::default());
                    let method = CalibrationMethod::Fit {
                        effects: vec![EffectKind::SupportFlexibility],
                        keep: KeepFit::IfConverged,
                    };
                    match calibrate_on_log(&base, &log, &method) {
                        Ok(c) => c.fitted.first().map_or(",,".into(), |f| {
                            format!("{:.3e},{:.3e},{}", f.values[0], f.std_errors[0], f.converged)
                        }),
                        Err(e) => format!(",,{}", e.to_string().replace(',', ";")),
                    }
                } else {
                    ",,".into()
                };
                // Planning on the fitted compliance (`PLAN=1`): the run
                // deployed again from the same fold on the model over
                // supports of the full fit's estimate (as a next cycle
                // would, the site's supports being the same), and on the
                // truth's exact compliance.
                let planned = if std::env::var("PLAN").is_ok_and(|v| v == "1") {
                    let (_, full) = &full_fit;
                    let estimate = full.as_ref().ok().map(|f| f.compliance_m_per_n);
                    [estimate, Some(compliance)]
                        .iter()
                        .map(|c| {
                            // No estimate, no run: a rigid model standing in
                            // for a failed fit would read as one.
                            let Some(c) = *c else {
                                return ",,,,,".to_string();
                            };
                            let model = match model_on_supports(&nominal, c) {
                                Ok(m) => m,
                                Err(e) => return format!("{c:.3e},model: {},0,0,0,", e.replace(',', ";")),
                            };
                            let setup = ClosedLoopSetup { model: &model, ..*setup };
                            let run = folded.as_ref().ok().and_then(|plant| {
                                deploy_guided(&setup, &Guidance::default(), Some(&mut plant.clone()), &mut ())
                                    .ok()
                            });
                            let r = RunResult::of(i, 0, run.as_ref(), base.connection_tolerance_m);
                            format!(
                                "{:.3e},{},{},{},{},{}",
                                c,
                                r.status,
                                u8::from(r.succeeded),
                                r.truth_violations,
                                r.commands,
                                r.final_true_gap_m.map_or(String::new(), |g| format!("{g:.4}"))
                            )
                        })
                        .collect::<Vec<_>>()
                        .join(",")
                } else {
                    ",,,,,,,,,,,".into()
                };
                format!(
                    "{i},{compliance:.3e},{},{},{},{},{},{},{},{},{:.3},{:.3},{calibrated},{planned},{}",
                    sent.len(),
                    columns(&full_fit),
                    early,
                    // The same commands give the same fit: not fitted twice.
                    if early == sent.len() {
                        columns(&full_fit)
                    } else {
                        columns(&fit(early))
                    },
                    r.status,
                    u8::from(r.succeeded),
                    r.truth_violations,
                    r.final_true_gap_m.map_or(String::new(), |g| format!("{g:.4}")),
                    mu,
                    s.fold_m,
                    r.commands
                )
            })
        })
        .collect();
    for r in rows {
        println!("{r}");
    }
    Ok(())
}
