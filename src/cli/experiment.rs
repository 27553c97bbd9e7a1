//! `tdeploy experiment FILE`: the experiments in `experiments/`, each a TOML
//! file whose `kind` picks the study; results as CSV and SVG, and a table
//! beside the seed's values.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::ArgMatches;

use tensegrity_deploy::design::friction_rig::modelled_slip_ratio;
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::{
    AngleConvention, FrictionCoefficient, JointFriction, RelaxSettings,
};
use tensegrity_deploy::report::drawing::{state_views_svg, DrawnState};
use tensegrity_deploy::studies::{friction_effect, FrictionEffectSettings};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RigExperiment {
    kind: String,
    mu: f64,
    #[serde(default)]
    convention: AngleConvention,
    interior_angles_deg: Vec<f64>,
    tensions_kn: Vec<Vec<f64>>,
    out: PathBuf,
}

/// Runs `tdeploy experiment`.
pub fn experiment(a: &ArgMatches) -> Result<()> {
    let path = a.get_one::<PathBuf>("file").unwrap();
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let kind: toml::Table =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    match kind.get("kind").and_then(|k| k.as_str()) {
        Some("friction-rig") => {
            let e: RigExperiment =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            debug_assert_eq!(e.kind, "friction-rig");
            friction_rig_experiment(&e, path)
        }
        Some("friction-effect") => {
            let e: FrictionEffectExperiment =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            friction_effect_experiment(&e, path)
        }
        Some("friction-vs-measurement") => {
            let e: FrictionVsMeasurementExperiment =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            friction_vs_measurement_experiment(&e, path)
        }
        Some(other) => bail!(
            "{}: field `kind`: unknown experiment \"{other}\" (known: friction-rig, friction-effect, friction-vs-measurement)",
            path.display()
        ),
        None => bail!("{}: field `kind` is missing", path.display()),
    }
}

fn friction_rig_experiment(e: &RigExperiment, path: &Path) -> Result<()> {
    if e.interior_angles_deg.len() != e.tensions_kn.len() {
        bail!(
            "{}: `tensions_kn` needs one list per entry of `interior_angles_deg`",
            path.display()
        );
    }
    let friction = JointFriction::new(FrictionCoefficient::Constant(e.mu), e.convention)?;
    let mut csv = String::from("interior_angle_deg,tension_kn,slip_ratio_model,slip_ratio_formula,slip_load_n,mu_backcalc_interior,mu_backcalc_wrap\n");
    say!(
        "friction rig, true μ = {} ({:?} convention)",
        e.mu,
        e.convention
    );
    say!(
        "{:>6} {:>6} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "θ deg",
        "T kN",
        "ratio model",
        "ratio e^μα",
        "slip load N",
        "μ(θ)",
        "μ(π−θ)"
    );
    for (theta_deg, tensions) in e.interior_angles_deg.iter().zip(&e.tensions_kn) {
        let theta = theta_deg.to_radians();
        for t_kn in tensions {
            let t = 1e3 * t_kn;
            let ratio = modelled_slip_ratio(&friction, theta, t);
            let formula = friction.ratio_bound(theta, false);
            let mu_interior = ratio.ln() / theta;
            let mu_wrap = ratio.ln() / (std::f64::consts::PI - theta);
            let load = t * (ratio - 1.0);
            say!("{theta_deg:>6.0} {t_kn:>6.1} {ratio:>12.6} {formula:>12.6} {load:>12.1} {mu_interior:>10.4} {mu_wrap:>10.4}");
            csv +=
                &format!("{theta_deg},{t_kn},{ratio},{formula},{load},{mu_interior},{mu_wrap}\n");
        }
    }
    std::fs::create_dir_all(&e.out)
        .with_context(|| format!("{}: cannot create", e.out.display()))?;
    let file = e.out.join("friction-rig.csv");
    tensegrity_deploy::io::write_atomically(&file, csv.as_bytes())?;
    say!("The seed back-calculates μ with the interior angle θ; with the wrap angle π−θ the same slips give the μ(π−θ) column.");
    say!("results in {}", file.display());
    Ok(())
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionEffectExperiment {
    #[allow(dead_code)]
    kind: String,
    mu: f64,
    #[serde(default)]
    convention: AngleConvention,
    fold_m: f64,
    deploy_m: f64,
    increment_m: f64,
    force_floor_n: f64,
    out: PathBuf,
}

/// Every `(field, value)` of an experiment file is a finite number above
/// zero (or at least zero, with `zero_allowed`); else an error naming the
/// file and field.
fn check_numbers(path: &Path, fields: &[(&str, f64)], zero_allowed: bool) -> Result<()> {
    for &(field, v) in fields {
        let ok = v.is_finite() && (v > 0.0 || (zero_allowed && v == 0.0));
        if !ok {
            let want = if zero_allowed {
                "non-negative"
            } else {
                "positive"
            };
            bail!(
                "{}: field `{field}`: must be a {want} number, got {v}",
                path.display()
            );
        }
    }
    Ok(())
}

/// The seed's Table 2: midspan node shift with friction, mm (nodes 1–5).
const SEED_TABLE_2_MM: [f64; 5] = [2.0, 2.3, 3.5, 3.6, 3.0];

fn friction_effect_experiment(e: &FrictionEffectExperiment, path: &Path) -> Result<()> {
    check_numbers(
        path,
        &[("fold_m", e.fold_m), ("deploy_m", e.deploy_m)],
        true,
    )?;
    check_numbers(path, &[("increment_m", e.increment_m)], false)?;
    let structure = reference_bridge(&BridgeParameters::default())?;
    let settings = FrictionEffectSettings {
        friction: JointFriction::new(FrictionCoefficient::Constant(e.mu), e.convention)?,
        fold_m: e.fold_m,
        deploy_m: e.deploy_m,
        increment_m: e.increment_m,
        force_floor_n: e.force_floor_n,
        relax: RelaxSettings::default(),
    };
    let r = friction_effect(&structure, &settings)?;
    for (name, run) in [
        ("frictionless", &r.frictionless),
        ("with friction", &r.with_friction),
    ] {
        for (what, rep) in [("fold", &run.fold), ("deploy", &run.deploy)] {
            if !rep.status.is_converged() {
                bail!("{name} run, {what} command: {}", rep.status.describe());
            }
        }
    }
    say!(
        "friction effect: every cable paid out {} cm then reeled in {} cm in {} cm increments; μ = {} ({:?} angle) vs μ = 0",
        100.0 * e.fold_m, 100.0 * e.deploy_m, 100.0 * e.increment_m, e.mu, e.convention
    );
    say!("midspan node shift, half A (the seed reports one half):");
    say!(
        "{:>6} {:>10} {:>10} {:>12} {:>12}",
        "node",
        "ΔL mm",
        "% of 30",
        "seed ΔL mm",
        "seed %"
    );
    let mut csv = String::from("node,shift_m,percent_of_30mm\n");
    let half_a: Vec<_> = r.midspan_shift_m.iter().step_by(2).collect();
    for (k, (node, shift)) in half_a.iter().enumerate() {
        let seed = SEED_TABLE_2_MM.get(k).copied().unwrap_or(f64::NAN);
        say!(
            "{:>6} {:>10.2} {:>10.1} {:>12.1} {:>12.1}",
            structure.nodes[*node].id,
            1e3 * shift,
            100.0 * shift / 0.03,
            seed,
            100.0 * seed / 30.0
        );
    }
    for (node, shift) in &r.midspan_shift_m {
        csv += &format!(
            "{},{shift},{}\n",
            structure.nodes[*node].id,
            100.0 * shift / 0.03
        );
    }
    say!(
        "relative member-force change (members above {} N without friction):",
        e.force_floor_n
    );
    say!(
        "{:>18} {:>8} {:>10} {:>10}",
        "type",
        "members",
        "mean %",
        "max %"
    );
    let mut kinds = String::from("kind,members,mean_relative_change,max_relative_change\n");
    for c in &r.force_change {
        say!(
            "{:>18} {:>8} {:>10.2} {:>10.2}",
            c.kind,
            c.counted,
            100.0 * c.mean_relative,
            100.0 * c.max_relative
        );
        kinds += &format!(
            "{},{},{},{}\n",
            c.kind, c.counted, c.mean_relative, c.max_relative
        );
    }
    say!("seed (Fig. 12): continuous cables change least, discontinuous cables moderately, struts most.");
    let mut members = String::from("member,relative_change\n");
    let n_members = structure.members.len();
    for (i, rel) in &r.member_change {
        let name = match structure.members.get(*i) {
            Some(m) => m.id.clone(),
            None => format!("segment_{}", i - n_members),
        };
        members += &format!("{name},{rel}\n");
    }
    std::fs::create_dir_all(&e.out)
        .with_context(|| format!("{}: cannot create", e.out.display()))?;
    write_atomically(&e.out.join("midspan_shift.csv"), csv.as_bytes())?;
    write_atomically(&e.out.join("force_change_by_type.csv"), kinds.as_bytes())?;
    write_atomically(
        &e.out.join("force_change_by_member.csv"),
        members.as_bytes(),
    )?;
    let svg = state_views_svg(
        &structure,
        DrawnState {
            state: &r.with_friction.state,
            forces: &r.with_friction.forces,
            label: "with friction",
        },
        Some(DrawnState {
            state: &r.frictionless.state,
            forces: &r.frictionless.forces,
            label: "without friction",
        }),
        "Friction effect after a fold-deploy cycle",
    )?;
    write_atomically(&e.out.join("overlay.svg"), svg.as_bytes())?;
    say!("results in {}", e.out.display());
    Ok(())
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionVsMeasurementExperiment {
    #[allow(dead_code)]
    kind: String,
    actuation_m: f64,
    steps: usize,
    model_mu: f64,
    seed: u64,
    increment_m: f64,
    truth: tensegrity_deploy::model::Effects,
    out: PathBuf,
}

/// The seed's finding: friction cut the mean difference by 50 % and the
/// standard deviation by 40 %.
const SEED_CUTS_PERCENT: (f64, f64) = (50.0, 40.0);

fn friction_vs_measurement_experiment(
    e: &FrictionVsMeasurementExperiment,
    path: &Path,
) -> Result<()> {
    use tensegrity_deploy::report::figures::grouped_bars_svg;
    use tensegrity_deploy::studies::friction_study::{
        friction_study, CellComparison, FrictionStudySettings,
    };
    check_numbers(
        path,
        &[
            ("actuation_m", e.actuation_m),
            ("increment_m", e.increment_m),
            ("model_mu", e.model_mu),
        ],
        false,
    )?;
    if e.steps == 0 {
        bail!("{}: field `steps`: must be at least 1", path.display());
    }
    e.truth
        .validate()
        .map_err(|err| anyhow::anyhow!("{}: truth.{err}", path.display()))?;
    let structure = reference_bridge(&BridgeParameters::default())?;
    let study = friction_study(
        &structure,
        &FrictionStudySettings {
            truth_effects: e.truth,
            model_mu: e.model_mu,
            actuation_m: e.actuation_m,
            steps: e.steps,
            seed: e.seed,
            increment_m: e.increment_m,
        },
    )?;
    say!(
        "friction vs measurement: {} cm deployment in {} steps, truth {:?}, simulation with μ = {}",
        100.0 * e.actuation_m,
        e.steps,
        e.truth
            .enabled()
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>(),
        e.model_mu
    );
    say!(
        "{:<14} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "load cell",
        "meas. avg N",
        "no-fr avg N",
        "fric. avg N",
        "|d| no-fr",
        "|d| fric.",
        "sd no-fr",
        "sd fric."
    );
    let mut csv = String::from("sensor,step,measured_n,no_friction_n,friction_n\n");
    for c in &study.cells {
        let (a, b) = (c.no_friction(), c.friction());
        say!(
            "{:<14} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1}",
            c.sensor,
            CellComparison::average(&c.measured_n),
            CellComparison::average(&c.no_friction_n),
            CellComparison::average(&c.friction_n),
            a.mean_abs_n,
            b.mean_abs_n,
            a.sd_n,
            b.sd_n
        );
        for k in 0..c.measured_n.len() {
            csv += &format!(
                "{},{},{},{},{}\n",
                c.sensor,
                k + 1,
                c.measured_n[k],
                c.no_friction_n[k],
                c.friction_n[k]
            );
        }
    }
    let (without, with) = study.differences();
    let cut = |a: f64, b: f64| 100.0 * (1.0 - b / a);
    say!(
        "mean |difference|: {:.1} N without friction, {:.1} N with: {:.0} % less (seed: {:.0} % less)",
        without.mean_abs_n,
        with.mean_abs_n,
        cut(without.mean_abs_n, with.mean_abs_n),
        SEED_CUTS_PERCENT.0
    );
    say!(
        "SD of difference: {:.1} N without friction, {:.1} N with: {:.0} % less (seed: {:.0} % less)",
        without.sd_n,
        with.sd_n,
        cut(without.sd_n, with.sd_n),
        SEED_CUTS_PERCENT.1
    );
    let labels: Vec<String> = study.cells.iter().map(|c| c.sensor.clone()).collect();
    let averages = |f: fn(&CellComparison) -> &Vec<f64>| -> Vec<f64> {
        study
            .cells
            .iter()
            .map(|c| CellComparison::average(f(c)) / 1000.0)
            .collect()
    };
    let svg = grouped_bars_svg(
        &format!(
            "Average tension over a {} cm deployment (seed Fig. 16)",
            100.0 * e.actuation_m
        ),
        "tension, kN",
        &labels,
        &[
            (
                "simulation without friction",
                averages(|c| &c.no_friction_n),
            ),
            ("simulation with friction", averages(|c| &c.friction_n)),
            ("measurement", averages(|c| &c.measured_n)),
        ],
    )?;
    std::fs::create_dir_all(&e.out)
        .with_context(|| format!("{}: cannot create", e.out.display()))?;
    write_atomically(&e.out.join("tensions.csv"), csv.as_bytes())?;
    write_atomically(&e.out.join("average_tension.svg"), svg.as_bytes())?;
    say!("results in {}", e.out.display());
    Ok(())
}
