//! The closed-loop deployment (`control::closed_loop`) and `tdeploy deploy`:
//! the default truth (μ = 0.2 and 3 mm backlash) deployed by a
//! frictionless controller connects without breaking a limit of the truth
//! at any increment; measurements reach the controller as they should;
//! a problem that cannot connect exits 1; the output files are the same
//! bytes for a seed at any thread count; bad files exit 2 naming file,
//! line and field; the log replays through `compare`.

mod common;

use common::cli::{failed_with, stderr, stdout, succeeded, tdeploy, tdeploy_with, RunOptions};
use common::files::{files, read_json};
use common::fixtures::{
    deploy_frictionless_controller, frictionless_reference_model, reference_structure,
};
use tensegrity_deploy::control::CORRECTIVE_PHASE_GAP_M;
use tensegrity_deploy::control::{
    deploy_closed_loop, DeployObserver, DeployRecord, DeployStart, Deployment,
};
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::model::{EffectKind, Effects};
use tensegrity_deploy::plan::{DeploymentProblem, LimitViolation, PlanStatus, Policy};
use tensegrity_deploy::sim::{default_truth, standard_sensors, CycleSchedule, EffectModel, Sensor};

/// Counts what the observer is shown.
#[derive(Default)]
struct Seen {
    starts: usize,
    commands: Vec<usize>,
}

impl DeployObserver for Seen {
    fn on_start(&mut self, _: &DeployStart) {
        self.starts += 1;
    }
    fn on_command(&mut self, r: &DeployRecord) {
        self.commands.push(r.index);
    }
}

/// The default deployment: reference bridge, default truth, frictionless
/// controller, default problem and policy, with `sensors` (the standard
/// layout when `None`).
fn deploy(sensors: Option<Vec<Sensor>>, observer: &mut dyn DeployObserver) -> Deployment {
    let truth = default_truth(reference_structure());
    let sensors = sensors.unwrap_or_else(|| standard_sensors(&truth.structure));
    let (problem, policy) = (DeploymentProblem::default(), Policy::default());
    deploy_on(&truth, &sensors, &problem, &policy, 1, observer)
}

/// A closed-loop deployment of `truth` read by `sensors`, the controller
/// planning on the frictionless reference model.
fn deploy_on(
    truth: &EffectModel,
    sensors: &[Sensor],
    problem: &DeploymentProblem,
    policy: &Policy,
    seed: u64,
    observer: &mut dyn DeployObserver,
) -> Deployment {
    deploy_frictionless_controller(truth, sensors, problem, policy, None, seed, observer)
}

#[test]
fn the_default_truth_connects_in_closed_loop_within_its_limits_at_every_increment() {
    let mut seen = Seen::default();
    let d = deploy(None, &mut seen);
    assert_eq!(d.status, PlanStatus::Connected, "{}", d.status.describe());
    let n = d.records.len();
    assert!(n >= 2, "{n} commands");
    assert_eq!(seen.starts, 1);
    assert_eq!(seen.commands, (1..=n).collect::<Vec<_>>());
    // One measurement per step.
    assert_eq!(d.readings.len(), n + 1);

    // The truth's limits: every increment was seen and checked, and none
    // broke a limit.
    for r in &d.records {
        assert!(r.truth_increments >= 1, "command {}", r.index);
        assert_eq!(r.truth_increments_checked, r.truth_increments);
        assert!(r.truth_violations.is_empty(), "{:?}", r.truth_violations);
        assert!(r.truth_worst_utilisation > 0.0 && r.truth_worst_utilisation <= 1.0);
    }
    assert_eq!(d.truth_limit_violations, 0);

    // Connected as measured (goal: 30 mm less the 5 mm margin), and truly:
    // the measured gap vectors carry ~1.4 mm of noise per component, well
    // inside the margin.
    let goal = 0.030 - 0.005;
    let last = d.records.last().unwrap();
    for g in &last.measured_gaps_m {
        assert!(g.unwrap() <= goal + 1e-12, "{g:?}");
    }
    for g in &last.true_gaps_m {
        assert!(*g < 0.030, "true gap {g}");
    }
    // ...from a fold about 140 mm apart.
    assert!(d.start.true_gaps_m.iter().all(|g| *g > 0.12));

    // The corrective phase: the first command whose largest measured gap
    // is below 60 mm, and every command after it.
    let k = d.first_below_corrective_gap.unwrap();
    assert!(k >= 1);
    let largest = |r: &DeployRecord| r.largest_measured_gap_m().unwrap();
    assert!(largest(&d.records[k - 1]) < CORRECTIVE_PHASE_GAP_M);
    assert!(d.records[..k - 1]
        .iter()
        .all(|r| largest(r) >= CORRECTIVE_PHASE_GAP_M));
    assert_eq!(d.corrective_commands, Some(n - k));

    // The truth did what the commands say: replaying the fold and the
    // commands through the same truth reproduces its final state exactly
    // (the plant and the replay share their code; no noise is involved).
    let truth = default_truth(reference_structure());
    let positions: Vec<Sensor> = standard_sensors(&truth.structure)
        .into_iter()
        .filter(|s| s.id.ends_with("_x") || s.id.ends_with("_y") || s.id.ends_with("_z"))
        .collect();
    let mut commands = vec![d.start.start_payout_m.clone()];
    commands.extend(d.commands());
    let replay = truth
        .run(
            &[CycleSchedule {
                commands,
                temperature_c: vec![],
            }],
            &positions,
        )
        .unwrap();
    let end = replay[0].last().unwrap();
    for (s, v) in positions.iter().zip(end) {
        let tensegrity_deploy::sim::SensorTarget::Position { node, axis } = s.target else {
            unreachable!()
        };
        assert_eq!(
            *v,
            Some(d.final_true_state.positions_m[node][axis.index()]),
            "{}",
            s.id
        );
    }
}

#[test]
fn with_noise_free_sensors_the_controller_sees_the_truths_gaps() {
    // Every sensor exact: each measured gap must be the truth's gap (to
    // the rounding of coordinates of a few metres), at the start and
    // after every command.
    let exact: Vec<Sensor> = standard_sensors(&reference_structure())
        .into_iter()
        .map(|s| Sensor { noise_sd: 0.0, ..s })
        .collect();
    let d = deploy(Some(exact), &mut ());
    assert_eq!(d.status, PlanStatus::Connected, "{}", d.status.describe());
    let pairs = std::iter::once((&d.start.measured_gaps_m, &d.start.true_gaps_m)).chain(
        d.records
            .iter()
            .map(|r| (&r.measured_gaps_m, &r.true_gaps_m)),
    );
    for (measured, truth) in pairs {
        for (m, t) in measured.iter().zip(truth) {
            assert!((m.unwrap() - t).abs() < 1e-12, "{m:?} vs {t}");
        }
    }
    // And the controller's model is not the truth: for some command it
    // predicted other gaps than the truth reached, by far more than the
    // 1e-12 m to which the measurement matched (0.8 mm with the planner
    // as of this writing; 0.1 mm is the bar).
    let worst = d
        .records
        .iter()
        .flat_map(|r| r.predicted_gaps_m.iter().zip(&r.true_gaps_m))
        .map(|(p, t)| (p - t).abs())
        .fold(0.0, f64::max);
    assert!(worst > 1e-4, "largest prediction error {worst} m");
}

// --- the command line ---------------------------------------------------

#[test]
fn the_same_seed_gives_the_same_bytes_at_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str, seed: &str, flags: &[&str], options: RunOptions| {
        let mut args = vec!["deploy", "-o", out, "--seed", seed];
        args.extend(flags);
        let o = tdeploy_with(&args, dir.path(), options);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        o
    };
    let inherited = RunOptions::default();
    let one = run("one", "1", &["--threads", "1"], inherited);
    run("two", "1", &["--threads", "2"], inherited);
    run("env", "1", &[], RunOptions::rayon_threads(2));
    let other = run("other", "2", &["--json"], inherited);

    let without_timing = |d: &str| -> Vec<(String, Vec<u8>)> {
        files(&dir.path().join(d))
            .into_iter()
            .filter(|(name, _)| name != "timing.csv")
            .collect()
    };
    let a = without_timing("one");
    let names: Vec<&str> = a.iter().map(|(n, _)| n.as_str()).collect();
    for expected in [
        "commands.csv",
        "deployment.csv",
        "deployment.svg",
        "log/commands.csv",
        "log/log.toml",
        "log/measurements.csv",
        "log/sensors.csv",
        "model.toml",
        "summary.json",
        "truth.toml",
    ] {
        assert!(names.contains(&expected), "{expected} missing: {names:?}");
    }
    assert!(dir.path().join("one/timing.csv").exists());
    assert_eq!(a, without_timing("two"));
    assert_eq!(a, without_timing("env"));
    // Another seed: other noise, so another log.
    let measurements = |d: &str| std::fs::read(dir.path().join(d).join("log/measurements.csv"));
    assert_ne!(measurements("one").unwrap(), measurements("other").unwrap());

    // The lines: one per command, and the verdict.
    let text = stdout(&one);
    let summary = read_json(&dir.path().join("one/summary.json"));
    let commands = summary["commands"].as_u64().unwrap() as usize;
    let command_lines = text.lines().filter(|l| l.contains(": command ")).count();
    assert_eq!(command_lines, commands, "{text}");
    assert!(
        text.contains("connected: largest gap")
            && text.contains(&format!("after {commands} commands")),
        "{text}"
    );
    assert_eq!(summary["connected"], true);
    assert_eq!(summary["outcome"], "connected");
    assert_eq!(summary["truth_limit_violations"], 0);
    // A run that kept every limit did not check the truth as built: null,
    // not an empty list that would read as "within its limits".
    assert!(summary["truth_as_built_broken"].is_null(), "{summary}");
    // --json prints summary.json itself.
    let printed: serde_json::Value = serde_json::from_slice(&other.stdout).unwrap();
    let written = read_json(&dir.path().join("other/summary.json"));
    assert_eq!(printed, written);

    // The log replays through `compare`: with the truth it was made with,
    // the residuals are the sensor noise alone. Over ~400 readings the RMS
    // of N(0, 1) residuals is 1 ± 0.04 (SD 1/√(2N)); ±0.15 is 4 SDs.
    let c = tdeploy(
        &[
            "compare",
            "one/truth.toml",
            "one/log",
            "-o",
            "cmp",
            "--json",
            "cmp.json",
        ],
        dir.path(),
    );
    assert_eq!(c.status.code(), Some(0), "{}", stderr(&c));
    let report = read_json(&dir.path().join("cmp.json"));
    let overall = &report["comparison"]["overall"];
    let count = overall["count"].as_u64().unwrap();
    let rms = overall["rms"].as_f64().unwrap();
    assert!(count >= 300, "{count} readings");
    assert!((rms - 1.0).abs() < 0.15, "RMS {rms} σ over {count}");
    // And the library reads it back: the fold and every command, one
    // reading per sensor at every measured step.
    let log = read_log(&dir.path().join("one/log"), &reference_structure()).unwrap();
    assert_eq!(log.cycles.len(), 1);
    assert_eq!(log.cycles[0].commands.len(), commands + 1);
    assert!(log.cycles[0].readings[0].iter().all(|r| r.is_none()));
    assert!(log.cycles[0].readings[1..].iter().all(|step| step
        .iter()
        .filter(|r| r.is_some())
        .count()
        == log.sensors.len() - 1));

    // The command file replays in `simulate`.
    let s = tdeploy(
        &[
            "simulate",
            "-q",
            "-c",
            "one/commands.csv",
            "--increment",
            "0.01",
            "-o",
            "sim",
        ],
        dir.path(),
    );
    assert_eq!(s.status.code(), Some(0), "{}", stderr(&s));

    // Issue 25: `deploy -o D` over an earlier result (here of another
    // seed) replaced it silently. Now refused, naming the flag, the
    // earlier result kept byte for byte; with --force replaced whole.
    let before = files(&dir.path().join("one"));
    let e = failed_with(
        &tdeploy(&["deploy", "-o", "one", "--seed", "2"], dir.path()),
        2,
    );
    assert!(
        e.contains("earlier run of `tdeploy deploy`") && e.contains("--force"),
        "{e}"
    );
    assert_eq!(files(&dir.path().join("one")), before);
    run("one", "2", &["--force"], inherited);
    assert_eq!(measurements("one").unwrap(), measurements("other").unwrap());
    // Someone else's non-empty folder is refused too.
    std::fs::create_dir(dir.path().join("mine")).unwrap();
    std::fs::write(dir.path().join("mine/notes.txt"), "keep").unwrap();
    let e = failed_with(&tdeploy(&["deploy", "-o", "mine"], dir.path()), 2);
    assert!(e.contains("mine") && e.contains("--force"), "{e}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("mine/notes.txt")).unwrap(),
        "keep"
    );
}

#[test]
fn a_fold_the_motors_cannot_reel_in_is_not_reachable_and_exits_1() {
    // The motors may reel in only 5 cm of the 40 cm fold: the halves stay
    // far apart, and the planner says so.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("short.toml"),
        "format = \"tensegrity-deploy/problem/1\"\nmin_payout_m = 0.35\n",
    )
    .unwrap();
    let out = tdeploy(
        &["deploy", "--problem", "short.toml", "-o", "o"],
        dir.path(),
    );
    let e = failed_with(&out, 1);
    assert!(e.starts_with("goal not reached: not connected: "), "{e}");
    let summary = read_json(&dir.path().join("o/summary.json"));
    assert_eq!(summary["connected"], false);
    let status = summary["status"]["status"].as_str().unwrap();
    assert!(
        status == "not_reachable" || status == "command_limit",
        "{status}"
    );
    assert_eq!(summary["outcome"], status);
    // Issue 22, item 8: a stop because motors or limits bind says so and
    // names them (here the motors' strokes).
    if status == "not_reachable" {
        assert!(
            e.contains("not reachable safely: ") && e.contains(" stroke min"),
            "{e}"
        );
    }
    assert!(summary["largest_final_true_gap_m"].as_f64().unwrap() > 0.06);
    assert_eq!(summary["truth_limit_violations"], 0);
    // The output records the problem it solved: the file given, its
    // values (here the shortened reel-in) with every other field's default.
    assert_eq!(summary["problem"], "short.toml");
    let recorded =
        tensegrity_deploy::io::problem_file::read_problem(&dir.path().join("o/problem.toml"))
            .unwrap();
    let given =
        tensegrity_deploy::io::problem_file::read_problem(&dir.path().join("short.toml")).unwrap();
    assert_eq!(recorded, given);
    assert_eq!(
        recorded.min_payout_m,
        tensegrity_deploy::plan::PerMotor::All(0.35)
    );
}

#[test]
fn bad_policy_and_problem_files_exit_2_naming_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.toml"),
        "format = \"tensegrity-deploy/policy/2\"\nname = \"bad\"\nmax_commands = 0\n",
    )
    .unwrap();
    let e = failed_with(
        &tdeploy(&["deploy", "--policy", "p.toml", "-o", "o"], dir.path()),
        2,
    );
    assert!(e.contains("p.toml: line 3, field `max_commands`"), "{e}");
    std::fs::write(
        dir.path().join("f.toml"),
        "format = \"tensegrity-deploy/problem/1\"\n\nconnection_tolerance_m = -0.03\n",
    )
    .unwrap();
    let e = failed_with(
        &tdeploy(&["deploy", "--problem", "f.toml", "-o", "o"], dir.path()),
        2,
    );
    assert!(
        e.contains("f.toml: line 3, field `connection_tolerance_m`"),
        "{e}"
    );
    // Nothing was written for a run that never started.
    assert!(!dir.path().join("o").exists());
    let e = failed_with(&tdeploy(&["deploy", "--threads", "0"], dir.path()), 2);
    assert!(e.contains("--threads"), "{e}");
}

/// Deploys a truth hiding `effects` (parameters per kind, in the effects
/// library's order) with the default controller, or with `policy`.
fn deploy_hidden(effects: &[(EffectKind, &[f64])], policy: &Policy) -> Deployment {
    let mut hidden = Effects::default();
    for (kind, values) in effects {
        hidden = hidden.with_parameters(*kind, values);
    }
    let truth = EffectModel::for_measurement(reference_structure(), hidden);
    let sensors = standard_sensors(&truth.structure);
    deploy_on(
        &truth,
        &sensors,
        &DeploymentProblem::default(),
        policy,
        9,
        &mut (),
    )
}

fn broken_limits(d: &Deployment) -> usize {
    d.records.iter().map(|r| r.truth_violations.len()).sum()
}

/// Scenario 9 of `experiments/deployment.toml`: drums that reel 4.3 % more
/// than commanded and cables 19 % softer. Without the payout-scale
/// estimate the controller's model stayed where its commands put it (11 mm
/// of payout short of the design) while the truth was reeled past its
/// designed state (6 mm beyond), and its axial cables went slack (8 limits
/// broken on the 8th command). The fix moves the model to where the
/// measured motion says the cables went, and scales the commands to suit:
/// checked here directly, the controller's model ends within 3 mm of the
/// truth's payout on every motor (the slip alone is 17 mm over the
/// deployment's 40 cm). The estimator itself is unit-tested on known
/// slips (`control::estimation`).
#[test]
fn negative_drum_slip_does_not_reel_the_truth_past_its_design() {
    let effects: [(EffectKind, &[f64]); 4] = [
        (EffectKind::JointFriction, &[0.057]),
        (EffectKind::Motor, &[-0.0425, 0.0012]),
        (EffectKind::StiffnessError, &[1.043, 0.811, 1.078]),
        (EffectKind::JointMassError, &[0.836]),
    ];
    let d = deploy_hidden(&effects, &Policy::default());
    assert_eq!(d.status, PlanStatus::Connected, "{}", d.status.describe());
    assert_eq!(broken_limits(&d), 0);
    assert!(d.final_true_gap_m().unwrap() <= 0.030);
    let model = &d.final_model_state.payout_m;
    let truth = &d.final_true_state.payout_m;
    for (m, (believed, actual)) in model.iter().zip(truth).enumerate() {
        assert!(
            (believed - actual).abs() < 0.003,
            "motor {m}: the model at {believed} m of payout, the truth at {actual} m"
        );
    }
}

/// Scenario 26: drums that reel 4.2 % less than commanded and cables 32 %
/// softer. The model believed itself at the designed state after 40 cm
/// of commands, with the truth's gaps still 39 mm open, and refused to
/// reel further ("not reachable").
#[test]
fn positive_drum_slip_and_soft_cables_still_connect() {
    let effects: [(EffectKind, &[f64]); 4] = [
        (EffectKind::JointFriction, &[0.023]),
        (EffectKind::Motor, &[0.0423, 0.0038]),
        (EffectKind::StiffnessError, &[0.801, 0.680, 1.163]),
        (EffectKind::JointMassError, &[1.043]),
    ];
    let d = deploy_hidden(&effects, &Policy::default());
    assert_eq!(d.status, PlanStatus::Connected, "{}", d.status.describe());
    assert_eq!(broken_limits(&d), 0);
    assert!(d.final_true_gap_m().unwrap() <= 0.030);
}

/// The evaluation (what `tdeploy evaluate` and the deployment experiment
/// run) gives the same runs at 1 and 2 threads and shard by shard, and
/// reports each run once to the progress callback.
#[test]
fn the_evaluation_is_the_same_at_any_thread_count_and_sharding() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use tensegrity_deploy::studies::evaluation::{
        evaluate, EvaluationSetup, RunResult, ScenarioDistribution, Shard,
    };
    let model = frictionless_reference_model();
    let distribution =
        ScenarioDistribution::plausible(&[EffectKind::JointFriction, EffectKind::Motor]);
    let policies = [Policy::default()];
    let problem = DeploymentProblem::default();
    let setup = EvaluationSetup {
        bridge: model.structure(),
        model: &model,
        policies: &policies,
        distribution: &distribution,
        problem: &problem,
        seed: 3,
        cycles: 1,
        truth_slip_event_substeps: false,
    };
    // Planning times are wall clock: the one value allowed to differ.
    let timeless = |mut r: RunResult| {
        r.planning_time_median_s = None;
        r
    };
    let run = |threads: usize, indices: &[usize]| {
        let done = AtomicUsize::new(0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let (scenarios, results) = pool.install(|| {
            evaluate(&setup, indices, &|| {
                done.fetch_add(1, Ordering::Relaxed);
            })
        });
        assert_eq!(done.into_inner(), indices.len());
        (
            scenarios,
            results.into_iter().map(timeless).collect::<Vec<_>>(),
        )
    };
    let whole = run(1, &[0, 1, 2]);
    assert_eq!(whole, run(2, &[0, 1, 2]));
    let mut sharded: Vec<RunResult> = (1..=2)
        .flat_map(|k| run(2, &Shard { index: k, count: 2 }.scenarios(3)).1)
        .collect();
    sharded.sort_by_key(|r| r.scenario);
    assert_eq!(whole.1, sharded);
}

/// Seed 1 scenario 904 of `tdeploy evaluate`, deployed as the evaluation
/// deploys it, with `policy`.
fn scenario_904(policy: &Policy) -> Deployment {
    use tensegrity_deploy::studies::evaluation::ScenarioDistribution;
    let model = frictionless_reference_model();
    let scenario = ScenarioDistribution::default().draw(1, 904);
    scenario.with_setup(
        model.structure(),
        &model,
        &DeploymentProblem::default(),
        policy,
        |setup| deploy_closed_loop(setup, &mut ()).expect("deployment starts"),
    )
}

/// Issue 10: on seed 1 scenario 904 (drums 4 % short, cables 19 % stiffer,
/// springs 19 % softer) the unmeasured axial cables start the last
/// approach command ~28 % below the model's tension and lose ~400 N in it
/// on the model; without a margin on that fall the truth's went to 0 N.
/// With the default policy's margin (0.4 × the fall) the deployment
/// connects and keeps every truth limit. (Since issue 22's second session
/// it keeps them without the margin too: the margin is redundant here,
/// not yet in general.) The margin's rule itself is
/// checked on the model alone in `tests/planner.rs`
/// (`a_command_leaving_an_unmeasured_tension_within_its_fall_margin_is_refused`).
#[test]
fn unmeasured_axial_cables_keep_their_tension_on_scenario_904() {
    let with_margin = scenario_904(&Policy::default());
    assert!(
        matches!(with_margin.status, PlanStatus::Connected),
        "{:?}",
        with_margin.status
    );
    assert_eq!(broken_limits(&with_margin), 0);
}

/// Issue 22, item 1: a run that connected but broke truth limits is not
/// "connected". The fixture is a truth the controller cannot yet deploy
/// within limits: μ = 0.2 and the drum of `A_cc1` zeroed 15 mm off (its
/// cable slack at the start), seed 1: the controller connects, and
/// `A_cc1`'s segments fall back below 5 N near the design (47
/// violations). (Until this session's changes the fixture was scenario
/// 904 without the unmeasured-fall margin; the controller now keeps its
/// limits there too.) Its verdict (what `deploy`, `plan`, `evaluate`,
/// `cycles` and the experiment report) is `limits_broken`, and its words
/// name each broken limit with the command and increment that first
/// broke it.
#[test]
fn a_run_that_broke_limits_is_not_connected() {
    use tensegrity_deploy::io::model_file::parse_model;
    use tensegrity_deploy::studies::evaluation::RunResult;
    let truth = parse_model(
        "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n\
         [effects.joint_friction]\nmu = 0.2\n\
         [faults.drum_zero_error]\nmotor = \"A_cc1\"\noffset_m = 0.015\n",
        std::path::Path::new("truth.toml"),
    )
    .unwrap()
    .measurement_model()
    .unwrap();
    let sensors = standard_sensors(&truth.structure);
    let d = deploy_on(
        &truth,
        &sensors,
        &DeploymentProblem::default(),
        &Policy::default(),
        1,
        &mut (),
    );
    let tolerance_m = DeploymentProblem::default().connection_tolerance_m;
    assert!(broken_limits(&d) > 0, "{}", d.status.describe());
    let v = d.verdict(tolerance_m);
    assert!(!v.is_connected());
    assert_eq!(v.label(), "limits_broken");
    assert_eq!(v.violations, broken_limits(&d));
    assert_eq!(
        v.broken.iter().map(|b| b.increments).sum::<usize>(),
        v.violations
    );
    let words = v.describe();
    if d.status.is_connected() && d.final_true_gap_m().is_some_and(|g| g <= tolerance_m) {
        assert!(words.starts_with("connected, but "), "{words}");
    }
    for b in v.broken.iter().take(5) {
        let record = &d.records[b.command - 1];
        assert!(b.increment >= 1 && b.increment <= record.truth_increments);
        assert!(record.truth_violations.contains(&b.violation));
        assert!(
            words.contains(&format!(
                "in command {} (increment {}",
                b.command, b.increment
            )),
            "{words}"
        );
    }
    let r = RunResult::of(0, 0, Some(&d), tolerance_m);
    assert_eq!((r.status.as_str(), r.succeeded), ("limits_broken", false));
    // How far it went: the drum zeroed off slackens its cable, 0 N
    // against the 5 N minimum, the whole of the bound.
    let largest = d.largest_force_breach_n().expect("a force bound broken");
    let minimum = DeploymentProblem::default().min_tension_n;
    assert!((largest - minimum).abs() < 1e-9, "{largest}");
    assert_eq!(r.largest_force_breach_n, Some(largest));
}

/// Issue 22, item 1: a limit the truth's start already breaks is not
/// widened away. With a 10 N minimum tension the folded default truth has
/// members below it; each is listed with its start and end force and
/// restored only where the end meets the 10 N; until restored it is held
/// to its start value, and the verdict is connected only if every one was
/// restored.
#[test]
fn a_limit_broken_at_the_start_is_reported_with_whether_the_run_restored_it() {
    let truth = default_truth(reference_structure());
    let sensors = standard_sensors(&truth.structure);
    let problem = DeploymentProblem {
        min_tension_n: 10.0,
        ..DeploymentProblem::default()
    };
    let d = deploy_on(&truth, &sensors, &problem, &Policy::default(), 1, &mut ());
    assert!(!d.truth_start_broken.is_empty());
    let end = tensegrity_deploy::plan::limits::force_rows(
        &truth.forward_model().unwrap(),
        &d.final_true_state,
    );
    let s = &truth.structure;
    for l in &d.truth_start_broken {
        assert!(l.lower && l.start_n < 10.0 && l.limit_n == 10.0, "{l:?}");
        let r = (0..end.len())
            .find(|&r| tensegrity_deploy::plan::limits::force_row_name(s, r) == l.member)
            .unwrap();
        assert_eq!(l.end_n, end[r]);
        assert_eq!(l.restored, end[r] >= 10.0 - 1e-3, "{l:?}");
    }
    let v = d.verdict(problem.connection_tolerance_m);
    let all_restored = d.truth_start_broken.iter().all(|l| l.restored);
    if v.broken.is_empty() && v.status.is_connected() && v.gap_within_tolerance() {
        assert_eq!(v.is_connected(), all_restored, "{}", v.describe());
    }
    if all_restored {
        assert!(v.describe().contains("broken at the start, all restored"));
    } else {
        assert!(v.describe().contains("broken at the start not restored"));
    }
}

/// Issue 22, items 3, 7 and 8: folds of 48 and 50 cm leave both `cc1`
/// cables of the folded default truth slack, and the controller stopped
/// "not reachable" after its first command (a trial found a segment below
/// its start value and the trust region collapsed). With the slack taken
/// up first, every run either connects with every start-broken limit
/// restored and no truth limit broken, or stops "not reachable safely"
/// naming what binds, also without breaking a truth limit; the 48 cm fold
/// connects on all three seeds. The 50 cm fold connected on seed 1 until
/// the load-cell bias estimate (issue 22, second session): now a slack
/// `cc1` segment's corrected force sits 0.1 N below the 0 N start value
/// the planner holds it to, and all three seeds stop safely. Taking the
/// start value from the corrected forces (`Limits::start_from`, tried)
/// connected all six here, but on the wide distribution it let folds of
/// 50–60 cm go on and break limits (runs with broken limits 16 → 28, 13
/// → 23, 11 → 21 on seeds 101, 102, 401), so it is not in.
#[test]
fn folds_of_48_and_50_cm_connect_or_stop_safely_without_breaking_a_limit() {
    let truth = default_truth(reference_structure());
    let sensors = standard_sensors(&truth.structure);
    let policy = Policy::default();
    for (fold_m, seed, must_connect) in [
        (0.48, 1, true),
        (0.48, 2, true),
        (0.48, 3, true),
        (0.50, 1, false),
        (0.50, 2, false),
        (0.50, 3, false),
    ] {
        let problem = DeploymentProblem {
            start_payout_m: tensegrity_deploy::plan::PerMotor::All(fold_m),
            max_payout_m: tensegrity_deploy::plan::PerMotor::All(0.7),
            ..DeploymentProblem::default()
        };
        let d = deploy_on(&truth, &sensors, &problem, &policy, seed, &mut ());
        let v = d.verdict(problem.connection_tolerance_m);
        let words = format!("fold {fold_m} seed {seed}: {}", v.describe());
        assert_eq!(v.violations, 0, "{words}");
        assert!(
            d.truth_start_broken
                .iter()
                .any(|l| l.member.starts_with("segment A_cc1")),
            "{words}"
        );
        if must_connect {
            assert!(v.is_connected(), "{words}");
        } else {
            assert!(
                v.is_connected() || v.describe().contains("not reachable safely: "),
                "{words}"
            );
        }
    }
}

/// The uneven fold of the lab (half A folded 45 cm, half B 33 cm) on the
/// default truth. The gaps-only QP closed the gaps by paying half B out
/// towards half A, and its cables went slack in the truth (147 violations
/// on seed 1, 127–146 on seeds 2–3, ending "not reachable"); planning
/// towards the design (`weights.design_position`) connects on every seed
/// without breaking a limit. The gaps-only planner is run on seed 1 too,
/// so that this test fails if the fold stops exercising the flaw.
#[test]
fn an_uneven_fold_connects_without_breaking_a_limit() {
    let truth = default_truth(reference_structure());
    let sensors = standard_sensors(&truth.structure);
    let mut fold = vec![0.45; 5];
    fold.extend([0.33; 5]);
    let problem = DeploymentProblem {
        start_payout_m: tensegrity_deploy::plan::PerMotor::Each(fold),
        ..DeploymentProblem::default()
    };
    let policy = Policy::default();
    for seed in 1..=3 {
        let d = deploy_on(&truth, &sensors, &problem, &policy, seed, &mut ());
        let v = d.verdict(problem.connection_tolerance_m);
        assert!(v.is_connected(), "seed {seed}: {}", v.describe());
        assert_eq!(v.violations, 0, "seed {seed}: {}", v.describe());
    }
    let mut gaps_only = Policy::default();
    if let tensegrity_deploy::plan::PlannerSettings::Qp(q) = &mut gaps_only.planner {
        q.weights.design_position = 0.0;
    }
    let d = deploy_on(&truth, &sensors, &problem, &gaps_only, 1, &mut ());
    let v = d.verdict(problem.connection_tolerance_m);
    assert!(v.violations > 10, "gaps only: {}", v.describe());
}

/// Issue 25: `deploy --slip-event-substeps` judges the run on a truth that
/// splits its increments at its joints' slip events, whose path does not
/// depend on the 1 cm increment. On the uneven fold of the test above
/// (seed 1) that truth shows what the 1 cm truth hides (known limitations,
/// item 15): the first command reverses every joint of half A, the joints
/// stick before they slide back, and reeling in tensions the segments next
/// to the motor while those beyond fall: `A_cc1[2]`, below its 5 N minimum
/// since the fold (4.8 N), to 4.3 N, and `A_cc1[3]` to 4.4 N, a dip the
/// frictionless controller cannot see. The plain truth maps each reversal at its
/// increment's end and the same run keeps every limit. The summary names
/// the truth it was judged on.
#[test]
fn a_truth_split_at_slip_events_shows_the_reversal_dip_after_an_uneven_fold() {
    let dir = tempfile::tempdir().unwrap();
    write_uneven_fold_problem(dir.path());
    succeeded(&tdeploy(
        &["deploy", "--problem", "uneven.toml", "-o", "plain"],
        dir.path(),
    ));
    let e = failed_with(
        &tdeploy(
            &[
                "deploy",
                "--problem",
                "uneven.toml",
                "--slip-event-substeps",
                "-o",
                "split",
            ],
            dir.path(),
        ),
        1,
    );
    assert!(e.contains("A_cc1[2]") && e.contains("command 1"), "{e}");
    let summary = read_json(&dir.path().join("split/summary.json"));
    assert_eq!(summary["outcome"], "limits_broken");
    assert!(
        summary["truth"]
            .as_str()
            .unwrap()
            .ends_with("increments split at slip events"),
        "{}",
        summary["truth"]
    );
}

/// Writes `uneven.toml` into `dir`: a problem file with half A folded
/// 45 cm and half B 33 cm (the uneven fold of issue 22).
fn write_uneven_fold_problem(dir: &std::path::Path) {
    std::fs::write(
        dir.join("uneven.toml"),
        "format = \"tensegrity-deploy/problem/1\"\nstart_payout_m = [0.45, 0.45, 0.45, 0.45, 0.45, 0.33, 0.33, 0.33, 0.33, 0.33]\n",
    )
    .unwrap();
}

/// A deploy's `truth.toml` is the truth it ran: with
/// `--slip-event-substeps` it records `[solver] slip_event_substeps`, so
/// deploying that file again (no flag) splits the increments again and
/// gives the same deployment, limits broken and all. Before the `[solver]`
/// table the file left the split out and the rerun deployed the plain
/// truth, which connects on this fold.
#[test]
fn a_deploys_truth_file_records_the_split_and_reruns_the_same_deployment() {
    let dir = tempfile::tempdir().unwrap();
    write_uneven_fold_problem(dir.path());
    let split = |extra: &[&str], out: &str| {
        let mut args = vec!["deploy", "--problem", "uneven.toml", "-o", out];
        args.extend_from_slice(extra);
        failed_with(&tdeploy(&args, dir.path()), 1)
    };
    split(&["--slip-event-substeps"], "split");
    let truth = std::fs::read_to_string(dir.path().join("split/truth.toml")).unwrap();
    assert!(
        truth.contains("[solver]\nslip_event_substeps = true"),
        "{truth}"
    );
    split(&["--truth", "split/truth.toml"], "again");
    for file in ["deployment.csv", "commands.csv"] {
        assert_eq!(
            std::fs::read(dir.path().join("split").join(file)).unwrap(),
            std::fs::read(dir.path().join("again").join(file)).unwrap(),
            "{file}"
        );
    }
    let summary = read_json(&dir.path().join("again/summary.json"));
    assert_eq!(summary["outcome"], "limits_broken");
}

/// A controller's model file with `[solver] slip_event_substeps` is
/// planned on with its increments split (known limitations 19): on the
/// uneven fold and the split truth, a μ = 0.2 model whose trials are split
/// sees the reversal dip and stops safely, naming `A_cc1[3]`, where the
/// same model stepping whole 1 cm increments misses it and its first
/// command breaks `A_cc1[2]` and `A_cc1[3]`. The deploy's `model.toml`
/// keeps the table.
#[test]
fn a_controller_model_asking_for_slip_event_substeps_sees_the_reversal_dip() {
    let dir = tempfile::tempdir().unwrap();
    write_uneven_fold_problem(dir.path());
    let model = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n\n[effects.joint_friction]\nmu = 0.2\n";
    std::fs::write(dir.path().join("plain.toml"), model).unwrap();
    std::fs::write(
        dir.path().join("split.toml"),
        format!("{model}\n[solver]\nslip_event_substeps = true\n"),
    )
    .unwrap();
    let deploy = |model: &str, out: &str| {
        let args = [
            "deploy",
            "--problem",
            "uneven.toml",
            "--slip-event-substeps",
            "--model",
            model,
            "-o",
            out,
        ];
        failed_with(&tdeploy(&args, dir.path()), 1);
        read_json(&dir.path().join(out).join("summary.json"))
    };
    let plain = deploy("plain.toml", "plain");
    assert_eq!(plain["outcome"], "limits_broken");
    let split = deploy("split.toml", "split");
    assert_eq!(split["outcome"], "not_reachable", "{split}");
    assert_eq!(split["truth_limit_violations"], 0, "{split}");
    let kept = std::fs::read_to_string(dir.path().join("split/model.toml")).unwrap();
    assert!(
        kept.contains("[solver]\nslip_event_substeps = true"),
        "{kept}"
    );
}

/// Issue 22, item 7: scenario 34 of `scenarios/wide.toml`, seed 777 (half
/// A folded 46 cm, half B 57 cm, μ 0.08, the halves' stiffnesses and
/// joint masses apart). Half B's fold leaves `B_cc0` slack in the
/// controller's model; the first command reeled every other cable in by
/// 5 cm and held `B_cc0`, whose force rows read 0 N before and after, and
/// the truth's `B_cc0`, still taut at 2–4 N, went slack in all four
/// segments (36 truth limits broken before the deployment connected). A
/// trial that slackens a cable the model has slack is now refused
/// (`plan::slack`): the trust region shrinks until the first command
/// reels `B_cc0` in with the others, and that command keeps every truth
/// limit. The deployment connects; since the tenth session (the truth's
/// folded start settled on the cable seats, each command judged where the
/// seats settle) it breaks one `B_cc0` segment's minimum by under 0.3 N in
/// its second command, the take-up of `B_cc1`, which restored the segment
/// to 5 N at the first command's end and lowers it again (the
/// frictionless model cannot see a neighbour's segment that low fall:
/// known limitations, item 18). Nothing else breaks.
#[test]
fn the_first_command_does_not_slacken_a_cable_the_fold_left_slack() {
    use tensegrity_deploy::io::evaluation_files::read_distribution;
    use tensegrity_deploy::plan::slack::cable_slack_m;
    let distribution = read_distribution(&common::repo_path("scenarios/wide.toml")).unwrap();
    let scenario = distribution.draw(777, 34);
    let model = frictionless_reference_model();
    let cables = &model.structure().continuous_cables;
    let motor = |id: &str| cables.iter().position(|c| c.id == id).unwrap();
    let d = scenario.with_setup(
        model.structure(),
        &model,
        &DeploymentProblem::default(),
        &Policy::default(),
        |setup| {
            // The premise: the fold leaves half B's `cc0` and `cc1` slack
            // in the controller's model (a change to the distribution
            // that loses it would make this test test nothing).
            let policy = Policy::default();
            let start =
                tensegrity_deploy::plan::folded_start(&model, setup.problem, policy.increment_m)
                    .unwrap();
            let slack = cable_slack_m(&model, &start);
            for id in ["B_cc0", "B_cc1"] {
                assert!(
                    slack[motor(id)] > 1e-3,
                    "{id} slack by {} m",
                    slack[motor(id)]
                );
            }
            deploy_closed_loop(setup, &mut ()).expect("deployment starts")
        },
    );
    let first = &d.records[0].command_m;
    for id in ["B_cc0", "B_cc1"] {
        assert!(
            first[motor(id)] < -0.01,
            "{id} held on the first command: {first:?}"
        );
    }
    assert!(
        d.records[0].truth_violations.is_empty(),
        "{:?}",
        d.records[0].truth_violations
    );
    assert!(broken_limits(&d) <= 2, "{}", broken_limits(&d));
    for r in &d.records {
        for v in &r.truth_violations {
            let ok = r.index == 2
                && matches!(v, LimitViolation::BelowLower { member, force_n, lower_n }
                    if member.starts_with("segment B_cc0[") && lower_n - force_n < 0.3);
            assert!(ok, "command {}: {}", r.index, v.describe());
        }
    }
    assert!(matches!(d.status, PlanStatus::Connected), "{:?}", d.status);
}

/// Regression (issue 22, sixth session): scenario 27 of
/// `scenarios/wide.toml`, seed 777 (a 55 cm fold, μ = 0.24), with the
/// controller planning on the reference bridge with the truth's own
/// friction. Its first command's trials on the sliding-limit tangent and
/// on the secants were all refused (a segment the fold left at 0.5 N
/// falling to 0 N), and the exact tangent, tried last, could not be
/// computed: the run stopped "solver failure: unstable tangent", naming
/// no limit. The stop now names the member whose limit refused the
/// trials.
#[test]
fn a_friction_aware_stop_names_the_limit_not_the_last_fallbacks_failure() {
    use tensegrity_deploy::io::evaluation_files::read_distribution;
    use tensegrity_deploy::model::{ForwardModel, RelaxSettings};
    use tensegrity_deploy::plan::{NotReachable, TrialFailure, TrialRejection};
    let distribution = read_distribution(&common::repo_path("scenarios/wide.toml")).unwrap();
    let scenario = distribution.draw(777, 27);
    let bridge = frictionless_reference_model().structure().clone();
    let model = ForwardModel::new(
        bridge.clone(),
        scenario.effects.joint_friction(),
        RelaxSettings::default(),
    )
    .unwrap();
    let d = scenario.with_setup(
        &bridge,
        &model,
        &DeploymentProblem::default(),
        &Policy::default(),
        |setup| deploy_closed_loop(setup, &mut ()).expect("deployment starts"),
    );
    match &d.status {
        PlanStatus::NotReachable {
            cause:
                NotReachable::TrustRegionCollapsed {
                    last_trial: TrialRejection::Inadmissible(TrialFailure::Limit(v)),
                    ..
                },
        } => assert!(v.describe().contains("segment"), "{}", v.describe()),
        other => panic!("{other:?}"),
    }
}
