//! The learning curve: deployment-fold cycles on a fixed truth, with and
//! without the case memory (`studies::cycles`, `tdeploy cycles`).

mod common;

use std::path::Path;
use std::process::Output;

use common::cli::{stderr, succeeded, tdeploy};
use common::fixtures::{
    dir_with, frictionless_reference_model, reference_structure, REFERENCE_MODEL,
};
use common::{repo_path, repo_root};
use tensegrity_deploy::control::{ClosedLoopSetup, Deployment};
use tensegrity_deploy::io::memory_file::read_memory;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::learn::{Case, CaseMemory};
use tensegrity_deploy::model::{ForwardModel, Structure};
use tensegrity_deploy::plan::response::IndependentParts;
use tensegrity_deploy::plan::{DeploymentProblem, Policy};
use tensegrity_deploy::sim::{default_truth, standard_sensors, EffectModel, Sensor};
use tensegrity_deploy::studies::cycles::{run_cycles, CycleObserver, CycleResult};
use tensegrity_deploy::studies::evaluation::ScenarioDistribution;

/// `tdeploy cycles --cycles N --memory MEMORY -o OUT`.
fn cycles_command(cycles: &str, memory: &Path, out: &Path) -> Output {
    tdeploy(
        &[
            "cycles",
            "--cycles",
            cycles,
            "--memory",
            memory.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        repo_root(),
    )
}

/// The reference bridge, the controller's frictionless model of it and
/// its standard sensors.
fn bridge() -> (Structure, ForwardModel, Vec<Sensor>) {
    let structure = reference_structure();
    let model = frictionless_reference_model();
    let sensors = standard_sensors(&structure);
    (structure, model, sensors)
}

fn cycles(policy: &str, n: usize) -> Vec<CycleResult> {
    cycles_on(policy, n, default_truth(reference_structure()))
}

fn cycles_on(policy: &str, n: usize, truth: EffectModel) -> Vec<CycleResult> {
    cycles_compared(policy, n, truth, None)
}

/// [`cycles_on`], each cycle's readings compared with `planning`.
fn cycles_compared(
    policy: &str,
    n: usize,
    truth: EffectModel,
    planning: Option<&EffectModel>,
) -> Vec<CycleResult> {
    let policy = read_policy(&repo_path(policy)).unwrap();
    cycles_of(&policy, n, truth, planning, 1)
}

/// `n` cycles of `policy` on `truth` with sensor-noise seed `seed`,
/// learning into `memory`, each cycle's readings compared with `planning`
/// (the controller's model file, also the base of a learnt model), every
/// cycle reported to `observer`.
fn run_on_bridge(
    policy: &Policy,
    n: usize,
    truth: &EffectModel,
    memory: &mut CaseMemory,
    planning: Option<&EffectModel>,
    seed: u64,
    observer: &mut dyn CycleObserver,
) -> Vec<CycleResult> {
    let (_, model, sensors) = bridge();
    let problem = DeploymentProblem::default();
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy,
        truth,
        sensors: &sensors,
        temperature_c: None,
        seed,
    };
    let end = run_cycles(&setup, n, memory, planning, observer).unwrap();
    assert_eq!(end.stopped, None);
    end.results
}

/// `n` cycles of `policy` on `truth` with sensor-noise seed `seed`, each
/// cycle's readings compared with `planning`.
fn cycles_of(
    policy: &Policy,
    n: usize,
    truth: EffectModel,
    planning: Option<&EffectModel>,
    seed: u64,
) -> Vec<CycleResult> {
    let mut memory = CaseMemory::default();
    run_on_bridge(policy, n, &truth, &mut memory, planning, seed, &mut ())
}

/// On the default truth (μ = 0.2, 3 mm backlash; fixed), the memory
/// policy's first cycle is the memoryless controller's; from then on the
/// ILC update of the last cycle's commands brings the bridge nearer its
/// connection. The true gap after the first approach (the gap a
/// perfect sensor would read) falls at least 3× by cycle 4 and stays
/// there; the measured one cannot fall as far: the largest of five 3-D
/// gap readings with 1 mm sensor noise is about 3.5 mm when the true gap
/// is 0. Corrective commands stay at most 1 and no limit breaks.
#[test]
fn the_memory_policy_learns_the_approach_on_a_fixed_truth() {
    let r = cycles("policies/memory.toml", 6);
    assert!(r
        .iter()
        .all(|c| c.status == "connected" && c.truth_limit_violations == 0));
    assert_eq!(r[0].learnt_from_case, None);
    assert_eq!(r[1].learnt_from_case, Some(0));
    // Here every learnt approach is sent whole: the ILC's prediction is
    // for the approach the truth went through (`learnt_commands`).
    for c in &r[1..] {
        assert_eq!(c.learnt_commands, c.approach_commands, "cycle {}", c.cycle);
    }
    let true_gap = |c: &CycleResult| c.final_true_gap_m.unwrap();
    let first = true_gap(&r[0]);
    assert!(first > 0.008, "cycle 1 true gap {first}");
    for c in &r[3..] {
        assert!(
            true_gap(c) < first / 3.0,
            "cycle {}: {} vs {first}",
            c.cycle,
            true_gap(c)
        );
        assert!(c.corrective_commands.unwrap() <= 1);
        assert!(c.approach_gap_m.unwrap() < r[0].approach_gap_m.unwrap() / 2.0);
    }
}

/// Issue 24: on a truth with heavy joints, soft cables and drum slip
/// −5 % (`experiments/truths/heavy-joints-soft-cables.toml`), the first
/// cycle needs two corrective commands after its approach (seed 1), and
/// the memory replayed them as commands of their own in every later
/// cycle: two corrective commands each time, where the memoryless
/// controller needed one. The learnt approach now merges the case's
/// trailing corrections into one command (`merged_tail`): one command
/// fewer, and at most one correction.
#[test]
fn a_learnt_approach_does_not_replay_the_cases_corrections() {
    let r = cycles_on("policies/memory.toml", 2, heavy_joints_truth());
    // The scenario still exercises the flaw: a first cycle with two
    // corrections after its approach.
    assert_eq!(r[0].corrective_commands, Some(2), "{:?}", r[0]);
    assert_eq!(r[1].learnt_from_case, Some(0));
    assert_eq!(r[1].learnt_commands, Some(r[0].commands - 1), "{:?}", r[1]);
    assert!(
        matches!(r[1].corrective_commands, Some(0 | 1)),
        "{:?}",
        r[1]
    );
    assert!(r.iter().all(|c| c.truth_limit_violations == 0));
}

/// The heavy-joints truth of `experiments/truths/`.
fn heavy_joints_truth() -> EffectModel {
    let file = tensegrity_deploy::io::model_file::read_model(&repo_path(
        "experiments/truths/heavy-joints-soft-cables.toml",
    ))
    .unwrap();
    EffectModel::for_measurement(reference_structure(), file.effects)
}

/// Issue 24: on the heavy-joints truth (seed 2) the second cycle's learnt
/// approach "overshot" by 60 mm where the ILC predicted 4.9 mm: the
/// model refused its last learnt command (an unmeasured axial cable would
/// keep less than `unmeasured_force_fall` of its fall above its limit),
/// the feedforward ended one command short, and the planner needed two
/// more commands. Halved up to twice (`feedforward_splits`), the learnt
/// command is sent in parts: the whole learnt approach is sent and ends
/// within the connection tolerance; a cut approach's gap is no measure of
/// the ILC's prediction, so `ilc_error_m` is reported only for a whole
/// one.
#[test]
fn a_learnt_command_the_model_refuses_whole_is_sent_in_parts_not_cut() {
    let mut policy = read_policy(&repo_path("policies/memory.toml")).unwrap();
    let r = cycles_of(&policy, 2, heavy_joints_truth(), None, 2);
    let learnt = r[1].learnt_commands.unwrap();
    assert!(r[1].approach_commands.unwrap() > learnt, "{:?}", r[1]);
    assert!(r[1].approach_gap_m.unwrap() < 0.03, "{:?}", r[1]);
    assert!(r[1].ilc_error_m.is_some(), "{:?}", r[1]);
    assert!(r.iter().all(|c| c.truth_limit_violations == 0));
    // The scenario still exercises the flaw: without halving, the approach
    // is cut before its last learnt command, far from the connection.
    policy.memory.as_mut().unwrap().feedforward_splits = 0;
    let cut = cycles_of(&policy, 2, heavy_joints_truth(), None, 2);
    assert!(cut[1].approach_commands.unwrap() < learnt, "{:?}", cut[1]);
    assert!(cut[1].approach_gap_m.unwrap() > 0.03, "{:?}", cut[1]);
    assert_eq!(cut[1].ilc_error_m, None);
}

/// A cycle that does not connect says why on its line, as `deploy`'s
/// verdict does: before, `cycles` printed only the status label. On a
/// truth with one drum zeroed 15 mm off (`A_cc1` slack at the start, μ =
/// 0.2) no cycle ends connected within every limit, and each line gives
/// the verdict's reason and names the cable. (Until the thirteenth
/// session the test used the held-out truth
/// `experiments/truths/light-friction-stiff-cables.toml`, whose stops
/// came from the cable seats followed only at each command's end; with
/// the arcs following the geometry increment by increment it connects in
/// both cycles within every limit.)
#[test]
fn a_cycle_that_does_not_connect_says_what_binds() {
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("drum.toml");
    std::fs::write(
        &truth,
        "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n\
         [effects.joint_friction]\nmu = 0.2\n\
         [faults.drum_zero_error]\nmotor = \"A_cc1\"\noffset_m = 0.015\n",
    )
    .unwrap();
    let out = tdeploy(
        &[
            "cycles",
            "--truth",
            truth.to_str().unwrap(),
            "--policy",
            repo_path("policies/qp.toml").to_str().unwrap(),
            "--cycles",
            "2",
            "-o",
            dir.path().join("c").to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let text = common::cli::stdout(&out);
    let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("cycle ")).collect();
    assert_eq!(lines.len(), 2, "{text}");
    for line in lines {
        assert!(!line.contains(": connected after "), "{line}");
        // The verdict's reason: a stop short of the connection says what
        // it left broken or what bound it; a connection that broke limits
        // counts them; either names the cable.
        let stopped = line.contains(" (not connected: ")
            && (line.contains("not restored") || line.contains(" binds"));
        let broke = line.contains(" (connected, but ") && line.contains("truth limit");
        assert!((stopped || broke) && line.contains("A_cc1"), "{line}");
    }
}

/// The memoryless policy on the same truth and noise does not learn: its
/// gap stays within noise of its first cycle's, and every later cycle of
/// the memory policy ends nearer the connection than the memoryless one.
#[test]
fn without_memory_the_gap_does_not_fall_and_the_memory_policy_ends_nearer() {
    let plain = cycles("policies/qp.toml", 5);
    let learnt = cycles("policies/memory.toml", 5);
    assert!(plain.iter().all(|c| c.learnt_from_case.is_none()));
    for (p, m) in plain.iter().zip(&learnt).skip(2) {
        assert!(p.final_true_gap_m.unwrap() > 0.005, "{p:?}");
        assert!(
            m.final_true_gap_m.unwrap() < p.final_true_gap_m.unwrap(),
            "{m:?} {p:?}"
        );
    }
}

/// `tdeploy cycles` writes the curve and the memory, appends to a given
/// memory file, and refuses a corrupted one without touching it.
#[test]
fn the_cycles_command_writes_the_curve_and_appends_to_the_memory() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let memory = dir.path().join("bridge.tdm");
    succeeded(&cycles_command("2", &memory, &out));
    let table = std::fs::read_to_string(out.join("cycles.csv")).unwrap();
    assert_eq!(table.lines().count(), 3, "{table}");
    assert!(std::fs::read_to_string(out.join("cycles.svg"))
        .unwrap()
        .contains("<svg"));
    assert_eq!(read_memory(&memory).unwrap().cases.len(), 2);
    // A second run learns from the two stored cases and adds one.
    let again = dir.path().join("again");
    succeeded(&cycles_command("1", &memory, &again));
    let table = std::fs::read_to_string(again.join("cycles.csv")).unwrap();
    let column = |name: &str| {
        let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
        let at = header.iter().position(|h| *h == name).unwrap();
        table
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(at)
            .unwrap()
            .to_string()
    };
    assert_eq!(column("learnt_from_case"), "1", "{table}");
    assert_eq!(read_memory(&memory).unwrap().cases.len(), 3);
    // One flipped byte: refused, named, and the file left as it was.
    let mut bytes = std::fs::read(&memory).unwrap();
    let at = bytes.len() / 2;
    bytes[at] ^= 0x01;
    std::fs::write(&memory, &bytes).unwrap();
    let o = cycles_command("1", &memory, &dir.path().join("bad"));
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("bridge.tdm"), "{err}");
    assert_eq!(std::fs::read(&memory).unwrap(), bytes);
}

/// Paired with the memoryless policy on the same drawn truths (the first
/// eight scenarios of the default distribution, seed 1: friction up to
/// μ = 0.3, slip up to ±5 %, stiffness and mass errors) and the same
/// noise, over three cycles each: wherever the memoryless policy connects
/// without breaking a limit, so does the memory policy (McNemar's
/// discordant count "only memoryless" is 0).
#[test]
fn the_memory_policy_is_never_worse_than_the_memoryless_one_on_paired_scenarios() {
    let structure = reference_structure();
    let distribution = ScenarioDistribution::default();
    let ok = |c: &CycleResult| c.status == "connected" && c.truth_limit_violations == 0;
    let mut only_memoryless = Vec::new();
    let mut both = 0;
    for i in 0..8 {
        let effects = distribution.draw(1, i).effects;
        let truth = || EffectModel::for_measurement(structure.clone(), effects.clone());
        let plain = cycles_on("policies/qp.toml", 3, truth());
        let learnt = cycles_on("policies/memory.toml", 3, truth());
        for (p, m) in plain.iter().zip(&learnt) {
            if ok(p) && !ok(m) {
                only_memoryless.push((i, p.cycle));
            }
            both += usize::from(ok(p) && ok(m));
        }
    }
    assert!(only_memoryless.is_empty(), "{only_memoryless:?}");
    assert!(both >= 20, "{both} of 24 runs connected under both");
}

/// The feedforward of a guidance is sent exactly as learnt; a command the
/// drum cannot make (beyond its 5 cm step), or one the model says would
/// take an unmeasured tension too near its limit, is refused before it is
/// sent, and the planner takes over from where the bridge is.
#[test]
fn a_feedforward_is_sent_as_learnt_and_a_refused_one_hands_over_to_the_planner() {
    use tensegrity_deploy::control::{deploy_guided, Guidance};
    use tensegrity_deploy::plan::PerMotor;
    let (structure, model, sensors) = bridge();
    let truth = default_truth(structure);
    let policy = Policy::default();
    // A 15 cm fold: two learnt 5 cm commands, then the planner.
    let problem = DeploymentProblem {
        start_payout_m: PerMotor::All(0.15),
        ..DeploymentProblem::default()
    };
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy: &policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c: None,
        seed: 3,
    };
    let guided_by = |learnt: &[Vec<f64>]| Guidance {
        feedforward_m: learnt.to_vec(),
        ..Guidance::default()
    };
    let learnt = vec![vec![-0.05; 10], vec![-0.05; 10]];
    let d = deploy_guided(&setup, &guided_by(&learnt), None, &mut ()).unwrap();
    assert_eq!(d.approach_commands, Some(2));
    assert_eq!(d.commands()[..2], learnt[..]);
    let beyond_step = guided_by(&[vec![-0.06; 10], vec![-0.06; 10]]);
    let d = deploy_guided(&setup, &beyond_step, None, &mut ()).unwrap();
    assert_eq!(d.approach_commands, Some(0));
    assert!(d
        .commands()
        .iter()
        .flatten()
        .all(|u| u.abs() <= 0.05 + 1e-12));
    assert_eq!(d.status.label(), "connected");
    // From a 10 cm fold a learnt last approach of 4.8 cm leaves an
    // unmeasured tension on the model less than 0.4 of its fall in the
    // command above its limit: the model refuses it
    // (`margins.unmeasured_force_fall`), the first learnt command is sent
    // as learnt, and the planner connects within every truth limit.
    let short_fold = DeploymentProblem {
        start_payout_m: PerMotor::All(0.10),
        ..DeploymentProblem::default()
    };
    let setup = ClosedLoopSetup {
        problem: &short_fold,
        ..setup
    };
    let learnt = vec![vec![-0.05; 10], vec![-0.048; 10]];
    let guided = guided_by(&learnt);
    let d = deploy_guided(&setup, &guided, None, &mut ()).unwrap();
    assert_eq!(d.approach_commands, Some(1));
    assert_eq!(d.commands()[0], learnt[0]);
    assert_ne!(d.commands()[1], learnt[1]);
    assert_eq!(d.status.label(), "connected");
    assert_eq!(d.truth_limit_violations, 0);
    // Allowed to halve it (`feedforward_splits`, issue 24: on the
    // heavy-joints truth the learnt approach was cut one command short,
    // 52–60 mm from the connection), the model takes it in parts: every
    // part of it is sent, one after the other, each half or quarter of
    // the learnt command, and they add up to it.
    let in_parts = Guidance {
        feedforward_splits: 2,
        ..guided.clone()
    };
    let d = deploy_guided(&setup, &in_parts, None, &mut ()).unwrap();
    let parts = d.approach_commands.unwrap() - 1;
    assert!((2..=4).contains(&parts), "{:?}", d.commands());
    assert_eq!(d.commands()[0], learnt[0]);
    for m in 0..10 {
        let sent: f64 = d.commands()[1..=parts].iter().map(|u| u[m]).sum();
        assert!((sent - learnt[1][m]).abs() < 1e-15, "motor {m}: {sent}");
        for u in &d.commands()[1..=parts] {
            let fraction = u[m] / learnt[1][m];
            assert!(fraction == 0.5 || fraction == 0.25, "{fraction}");
        }
    }
    assert_eq!(d.learnt_approach_completed, Some(true));
    assert_eq!(d.status.label(), "connected");
    assert_eq!(d.truth_limit_violations, 0);
    // Without the margin the same learnt command is sent whole.
    let mut no_margin = policy.clone();
    no_margin.margins.unmeasured_force_fall = None;
    let setup = ClosedLoopSetup {
        policy: &no_margin,
        ..setup
    };
    let d = deploy_guided(&setup, &guided, None, &mut ()).unwrap();
    assert_eq!(d.approach_commands, Some(2));
    assert_eq!(d.commands()[..2], learnt[..]);
}

/// `evaluate` with several cycles per scenario reports, for each run, the
/// last cycle of the cycles study on the scenario's truth, sensors and
/// fold (the same deployments run a second way, through `run_cycles`),
/// with the violations of every cycle.
#[test]
fn evaluate_with_cycles_reports_the_last_cycle_of_each_scenarios_cycles() {
    use tensegrity_deploy::studies::evaluation::{evaluate, EvaluationSetup};
    let (_, model, _) = bridge();
    let policies = [
        read_policy(&repo_path("policies/qp.toml")).unwrap(),
        read_policy(&repo_path("policies/memory.toml")).unwrap(),
    ];
    let distribution = ScenarioDistribution::default();
    let problem = DeploymentProblem::default();
    let setup = EvaluationSetup {
        bridge: model.structure(),
        model: &model,
        policies: &policies,
        distribution: &distribution,
        problem: &problem,
        seed: 1,
        cycles: 2,
        truth_slip_event_substeps: false,
    };
    let (scenarios, results) = evaluate(&setup, &[0, 3], &|| {});
    assert_eq!(results.len(), 4);
    for r in &results {
        let scenario = scenarios.iter().find(|s| s.index == r.scenario).unwrap();
        let end = scenario.with_setup(
            model.structure(),
            &model,
            &problem,
            &policies[r.policy],
            |run| run_cycles(run, 2, &mut CaseMemory::default(), None, &mut ()).unwrap(),
        );
        assert_eq!(end.stopped, None);
        let last = end.results.last().unwrap();
        assert_eq!(r.status, last.status);
        assert_eq!(r.commands, last.commands);
        assert_eq!(r.corrective_commands, last.corrective_commands);
        assert_eq!(r.approach_gap_m, last.approach_gap_m);
        assert_eq!(r.final_true_gap_m, last.final_true_gap_m);
        let violations: usize = end.results.iter().map(|c| c.truth_limit_violations).sum();
        assert_eq!(r.truth_violations, violations);
    }
    // The memory policy's second cycle learnt from its first: it differs
    // from the memoryless one's somewhere.
    let memoryless: Vec<_> = results.iter().filter(|r| r.policy == 0).collect();
    let memory: Vec<_> = results.iter().filter(|r| r.policy == 1).collect();
    assert!(memoryless
        .iter()
        .zip(&memory)
        .any(|(a, b)| a.approach_gap_m != b.approach_gap_m));
}

/// Five cycles of `policy` on drawn scenario `index` of `seed`, set up as
/// `tdeploy evaluate --cycles 5` sets it up (the scenario's truth,
/// sensors, fold, temperature and noise seed), each shown to `observer`.
fn scenario_cycles(
    policy: &Policy,
    seed: u64,
    index: usize,
    observer: &mut dyn CycleObserver,
) -> Vec<CycleResult> {
    let (_, model, _) = bridge();
    let scenario = ScenarioDistribution::default().draw(seed, index);
    scenario.with_setup(
        model.structure(),
        &model,
        &DeploymentProblem::default(),
        policy,
        |setup| {
            let end = run_cycles(setup, 5, &mut CaseMemory::default(), None, observer).unwrap();
            assert_eq!(end.stopped, None);
            end.results
        },
    )
}

/// Each motor's total payout change over `commands`, m.
fn totals(commands: &[Vec<f64>]) -> Vec<f64> {
    (0..commands[0].len())
        .map(|m| commands.iter().map(|u| u[m]).sum())
        .collect()
}

/// What the memory learnt, cycle by cycle: for each cycle that sent the
/// whole of its learnt feedforward (a feedforward is sent exactly as
/// learnt), each motor's total over the case it learnt from and over the
/// feedforward.
#[derive(Default)]
struct LearntTotals {
    /// Each case stored so far (index = its index in the memory): its
    /// command count and totals.
    cases: Vec<(usize, Vec<f64>)>,
    /// Per such cycle: the totals of the case, and of the feedforward.
    sent_whole: Vec<(Vec<f64>, Vec<f64>)>,
}

impl CycleObserver for LearntTotals {
    fn on_cycle(&mut self, result: &CycleResult, deployment: &Deployment, case: &Case) {
        if let Some(i) = result.learnt_from_case {
            // The ILC keeps the case's command count.
            let (count, case_totals) = &self.cases[i];
            if deployment.approach_commands == Some(*count) {
                let feedforward = totals(&deployment.commands()[..*count]);
                self.sent_whole.push((case_totals.clone(), feedforward));
            }
        }
        self.cases
            .push((case.commands_m.len(), totals(&case.commands_m)));
    }
}

/// The two drawn truths on which the memory policy broke a limit that the
/// memoryless one kept (seed 2 scenario 15: μ = 0.30; seed 3 scenario
/// 25: cables 0.61× as stiff as the model's). There the ILC update, free
/// to move each motor on its own, spread the motors of one half up to
/// 7 mm apart to fit the gaps' lateral components, and the half's axial
/// cable, which no sensor reads, went to 0 N (the memoryless runs keep it
/// above 29 N). The fix bounds the spread (`ilc_max_spread_m`, 1 mm by
/// default): checked directly, every learnt feedforward keeps the totals
/// of a half's motors within 1 mm of each other, or no further apart than
/// in the case it learnt from (the ILC's own formulation is unit-tested in
/// `learn::ilc`). And on these truths every cycle connects with no limit
/// broken, with the bound alone (the planner's margin on unmeasured
/// tensions off, as it guards the same cables) and with the default
/// policy's margin on.
#[test]
fn keeping_a_halfs_motors_together_keeps_the_unmeasured_axial_cables_taut() {
    let bounded = read_policy(&repo_path("policies/memory.toml")).unwrap();
    let max_spread_m = bounded.memory.as_ref().unwrap().ilc_max_spread_m;
    assert_eq!(max_spread_m, 0.001);
    let mut alone = bounded.clone();
    alone.margins.unmeasured_force_fall = None;
    let half = IndependentParts::of(&frictionless_reference_model()).of_cable;
    let pairs: Vec<(usize, usize)> = (0..half.len())
        .flat_map(|a| (a + 1..half.len()).map(move |b| (a, b)))
        .filter(|&(a, b)| half[a].is_some() && half[a] == half[b])
        .collect();
    assert_eq!(pairs.len(), 2 * 10, "two halves of five motors");
    for (seed, index) in [(2, 15), (3, 25)] {
        for policy in [&alone, &bounded] {
            let mut learnt = LearntTotals::default();
            let kept: Vec<usize> = scenario_cycles(policy, seed, index, &mut learnt)
                .iter()
                .map(|c| {
                    assert_eq!(c.status, "connected", "seed {seed} scenario {index}");
                    c.truth_limit_violations
                })
                .collect();
            assert!(
                kept.iter().all(|v| *v == 0),
                "seed {seed} scenario {index}: {kept:?}"
            );
            assert!(
                !learnt.sent_whole.is_empty(),
                "seed {seed} scenario {index}: no feedforward was sent whole"
            );
            for (case, feedforward) in &learnt.sent_whole {
                for &(a, b) in &pairs {
                    let before = (case[a] - case[b]).abs();
                    let after = (feedforward[a] - feedforward[b]).abs();
                    // The QP's tolerance is ~1e-10 m.
                    assert!(
                        after <= max_spread_m.max(before) + 1e-7,
                        "seed {seed} scenario {index}: motors {a} and {b} {after} m apart, \
                         {before} m in the case"
                    );
                }
            }
        }
    }
}

/// Regression (issue 22, sixth session, found in review): `tdeploy cycles
/// --model M` built its default truth on M's structure, so a calibrated
/// stiffness error in M was applied to the bridge a second time. The
/// truth, and so its measured start (same noise seed), must not depend
/// on what the controller plans on.
#[test]
fn cycles_with_a_calibrated_model_deploys_the_same_default_truth() {
    let calibrated = format!("{REFERENCE_MODEL}[effects.stiffness_error]\ncable_scale = 0.8\n");
    let tmp = dir_with(&[("calibrated.toml", &calibrated)]);
    let model = tmp.path().join("calibrated.toml");
    let start_gap = |extra: &[&str], name: &str| {
        let out = tmp.path().join(name);
        let mut args = vec!["cycles", "--cycles", "1", "--policy", "policies/qp.toml"];
        args.extend(extra);
        args.extend(["-o", out.to_str().unwrap()]);
        let run = tdeploy(&args, repo_root());
        succeeded(&run);
        let memory = read_memory(&out.join("memory.tdm")).unwrap();
        memory.cases[0].conditions.start_gap_m.unwrap()
    };
    let nominal = start_gap(&[], "nominal");
    let calibrated = start_gap(&["--model", model.to_str().unwrap()], "calibrated");
    assert_eq!(
        nominal.to_bits(),
        calibrated.to_bits(),
        "{nominal} vs {calibrated}"
    );
}

/// Issue 24, item 2 (the measurement the learning curve needs): each
/// cycle's readings against the model it was planned on. The frictionless
/// model misses the default truth's friction and backlash in every cycle;
/// the truth's own model, replayed from the design, explains them to the
/// noise (about 1), the check that the column measures the model and
/// not the replay.
#[test]
fn each_cycle_reports_its_readings_against_the_model_it_was_planned_on() {
    let structure = reference_structure();
    let truth = default_truth(structure.clone());
    let rms = |planning: &EffectModel| -> Vec<f64> {
        cycles_compared("policies/qp.toml", 2, truth.clone(), Some(planning))
            .iter()
            .map(|r| r.planning_model_rms.unwrap())
            .collect()
    };
    let frictionless = rms(&EffectModel::for_measurement(
        structure.clone(),
        Default::default(),
    ));
    let exact = rms(&truth);
    for (f, e) in frictionless.iter().zip(&exact) {
        assert!(*f > 1.5, "frictionless {frictionless:?}");
        assert!(*e < 1.3, "the truth's own model {exact:?}");
    }
}

/// `policies/memory-model.toml`: `policies/memory.toml` learning its
/// model between cycles, and nothing else changed.
fn model_learning_policy() -> Policy {
    let policy = read_policy(&repo_path("policies/memory-model.toml")).unwrap();
    let mut plain = read_policy(&repo_path("policies/memory.toml")).unwrap();
    let learning = policy.memory.unwrap();
    assert!(learning.model_learning_enable);
    let memory = plain.memory.as_mut().unwrap();
    memory.model_learning_enable = true;
    memory.model_learning_rounds = learning.model_learning_rounds;
    plain.name = policy.name.clone();
    assert_eq!(plain, policy);
    policy
}

/// `n` cycles of [`model_learning_policy`] on `truth`, the controller's
/// model file the frictionless reference bridge: the results and the
/// cases stored.
fn learning_cycles(n: usize, truth: EffectModel) -> (Vec<CycleResult>, Vec<Case>) {
    let nominal = EffectModel::for_measurement(reference_structure(), Default::default());
    let mut memory = CaseMemory::default();
    let policy = model_learning_policy();
    let r = run_on_bridge(&policy, n, &truth, &mut memory, Some(&nominal), 1, &mut ());
    (r, memory.cases)
}

/// Issue 24, items 1 and 2: the controller learns its model between
/// cycles. On the default truth (μ = 0.2, 3 mm backlash, fixed) the
/// frictionless model reads cycle 1 at about 2 σ; the self-diagnosis
/// after cycles 1 and 2 finds the friction and the backlash, and cycle
/// 3's readings, which no fit saw, are explained to the 1.2 σ.
/// The learnt values are the truth's within 10 % of μ and 0.5 mm of
/// backlash (their standard errors are about 0.006 and 0.2 mm: three of
/// them, and the bias a 2-cycle log leaves). Each case stores the model
/// the next cycle carries, and an update is accepted only where it
/// lowered the held-out residual.
#[test]
fn the_model_learnt_between_cycles_explains_the_next_cycle_to_its_noise() {
    let (r, cases) = learning_cycles(3, default_truth(reference_structure()));
    let rms: Vec<f64> = r.iter().map(|c| c.planning_model_rms.unwrap()).collect();
    assert!(rms[0] > 1.5, "{rms:?}");
    assert!(rms[2] <= 1.2, "{rms:?}");
    for (c, case) in r.iter().zip(&cases) {
        let u = c.model_update.as_ref().unwrap();
        let stored = case.model.as_ref().unwrap();
        assert_eq!(u.accepted, stored.accepted);
        assert_eq!(
            u.accepted,
            u.fitted_rms < u.planned_rms,
            "cycle {}",
            c.cycle
        );
        stored.validate().unwrap();
    }
    let learnt = &cases[1].model.as_ref().unwrap().effects;
    let value = |name: &str, k: usize| {
        learnt
            .iter()
            .find(|e| e.effect == name)
            .unwrap_or_else(|| panic!("{name} not learnt: {learnt:?}"))
            .values[k]
    };
    assert!(
        (value("joint_friction", 0) - 0.2).abs() < 0.02,
        "{learnt:?}"
    );
    assert!((value("motor", 1) - 0.003).abs() < 0.0005, "{learnt:?}");
}

/// Where the planner takes what was learnt: a truth whose joints are 30 %
/// heavier than the controller's frictionless model, nothing else hidden.
/// The first cycle's self-diagnosis finds the joint-mass error within
/// 0.05 of 1.3 (its standard error is under 0.01: the search's search
/// range is 0.3–1.9); the second cycle plans on it (the planner takes
/// it, its commands are not those of the policy without model learning)
/// and its readings, which no fit saw, are explained to 1.2 σ, where the
/// model file read the first at 1.35 σ.
#[test]
fn a_learnt_structural_effect_is_planned_on() {
    let structure = reference_structure();
    let truth = EffectModel::for_measurement(
        structure,
        tensegrity_deploy::model::Effects::default()
            .with_parameters(tensegrity_deploy::model::EffectKind::JointMassError, &[1.3]),
    );
    let (r, cases) = learning_cycles(2, truth.clone());
    let u = r[0].model_update.as_ref().unwrap();
    assert_eq!(u.outcome(), "accepted", "{u:?}");
    assert!(u.planner_takes.contains("joint_mass_error"), "{u:?}");
    let learnt = &cases[0].model.as_ref().unwrap().effects;
    let mass = learnt
        .iter()
        .find(|e| e.effect == "joint_mass_error")
        .unwrap_or_else(|| panic!("{learnt:?}"))
        .values[0];
    assert!((mass - 1.3).abs() < 0.05, "{mass}");
    let rms: Vec<f64> = r.iter().map(|c| c.planning_model_rms.unwrap()).collect();
    assert!(rms[0] > 1.3 && rms[1] <= 1.2, "{rms:?}");
    let plain = cycles_on("policies/memory.toml", 2, truth);
    assert_eq!(r[0].commands, plain[0].commands);
    assert_ne!(
        (cases[1].commands_m.len(), r[1].final_true_gap_m),
        (plain[1].commands, plain[1].final_true_gap_m),
        "the second cycle planned as on the model file"
    );
}

/// Issue 24 (tenth session): a structural effect the log cannot tell from
/// another is not planned on. On μ 0.15 (wrap) with cables 15 % softer
/// (seed 7; the ninth session's held-out truth) the first cycle's
/// self-diagnosis learns the friction and joints about 10 % heavier, which
/// explain the log to its noise as softer cables would, and the planner
/// planned the second cycle on heavier joints. The joint-mass error is
/// now marked as explained alike by a stiffness error, kept in the model
/// error figure, and the second cycle is planned as on the model file:
/// the same commands and gap as `policies/memory.toml`'s. (The joints
/// 30 % heavier of `a_learnt_structural_effect_is_planned_on` have no
/// such rival and are planned on.)
#[test]
fn a_structural_effect_the_log_cannot_tell_from_another_is_not_planned_on() {
    use tensegrity_deploy::model::{EffectKind, Effects};
    let truth = EffectModel::for_measurement(
        reference_structure(),
        Effects::default()
            .with_parameters(EffectKind::JointFriction, &[0.15])
            .with_parameters(EffectKind::StiffnessError, &[1.0, 0.85, 1.0]),
    );
    let nominal = EffectModel::for_measurement(reference_structure(), Default::default());
    let mut memory = CaseMemory::default();
    let r = run_on_bridge(
        &model_learning_policy(),
        2,
        &truth,
        &mut memory,
        Some(&nominal),
        7,
        &mut (),
    );
    let learnt = &memory.cases[0].model.as_ref().unwrap().effects;
    let structural: Vec<_> = learnt
        .iter()
        .filter(|e| e.effect == "joint_mass_error" || e.effect == "stiffness_error")
        .collect();
    assert!(!structural.is_empty(), "{learnt:?}");
    assert!(structural.iter().all(|e| e.rival.is_some()), "{learnt:?}");
    let u = r[0].model_update.as_ref().unwrap();
    assert_eq!(u.outcome(), "accepted", "{u:?}");
    assert_eq!(u.planner_takes, "none", "{u:?}");
    let mut plain_memory = CaseMemory::default();
    let plain = run_on_bridge(
        &read_policy(&repo_path("policies/memory.toml")).unwrap(),
        2,
        &truth,
        &mut plain_memory,
        None,
        7,
        &mut (),
    );
    assert_eq!(memory.cases[1].commands_m, plain_memory.cases[1].commands_m);
    assert_eq!(r[1].final_true_gap_m, plain[1].final_true_gap_m);
}

/// A truth with nothing hidden (the controller's own model, read with
/// noise): the self-diagnosis finds nothing, the model is never replaced
/// and the planner plans on the model file every cycle, as the policy
/// without model learning does (the same commands).
#[test]
fn a_truth_the_model_already_explains_leaves_the_learnt_model_empty() {
    let structure = reference_structure();
    let truth = EffectModel::for_measurement(structure, Default::default());
    let (r, cases) = learning_cycles(2, truth.clone());
    for c in &r {
        let u = c.model_update.as_ref().unwrap();
        assert_eq!(u.outcome(), "nothing_learnt", "cycle {}: {u:?}", c.cycle);
        assert_eq!(u.carried, "none");
    }
    let plain = cycles_on("policies/memory.toml", 2, truth);
    for ((case, c), p) in cases.iter().zip(&r).zip(&plain) {
        assert!(case.model.as_ref().unwrap().effects.is_empty());
        assert_eq!(c.commands, p.commands);
        assert_eq!(c.final_true_gap_m, p.final_true_gap_m);
    }
}

/// Keeps each cycle's deployment.
#[derive(Default)]
struct Deployments(Vec<Deployment>);

impl CycleObserver for Deployments {
    fn on_cycle(&mut self, _: &CycleResult, d: &Deployment, _: &Case) {
        self.0.push(d.clone());
    }
}

/// The self-diagnosis's log of consecutive cycles (`cycles_log`) takes a
/// model along the path the truth took, fold-backs included: the truth's
/// own model replays cycles 2 and 3 of the default truth, as one log
/// from cycle 2's fold, to its noise (cycle 3's RMS z within the noise
/// limit of its readings), as it replays cycle 3's log alone from the
/// design (to 1e-6 σ: a 40 cm fold-back wipes the friction history
/// out, so the shorter log loses nothing here).
#[test]
fn a_log_of_consecutive_cycles_replays_the_truth_along_its_path() {
    use tensegrity_deploy::measure::compare::{compare, noise_rms_limit};
    use tensegrity_deploy::measure::settings::NoiseSettings;
    use tensegrity_deploy::studies::deployment_log::{cycles_log, deployment_log};
    let (structure, _, sensors) = bridge();
    let truth = default_truth(structure);
    let policy = read_policy(&repo_path("policies/qp.toml")).unwrap();
    let mut kept = Deployments::default();
    let mut memory = CaseMemory::default();
    run_on_bridge(&policy, 3, &truth, &mut memory, None, 1, &mut kept);
    let d = &kept.0;
    let name = &truth.structure.name;
    let two = compare(&truth, &cycles_log(&[&d[1], &d[2]], name, sensors.clone())).unwrap();
    let alone = compare(&truth, &deployment_log(&d[2], name, sensors.clone())).unwrap();
    let rms_of_cycle = |c: &tensegrity_deploy::measure::compare::Comparison, cycle: usize| {
        let z: Vec<f64> = c
            .residuals
            .iter()
            .filter(|r| r.cycle == cycle)
            .map(|r| r.z)
            .collect();
        (
            (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt(),
            z.len(),
        )
    };
    let (along, n) = rms_of_cycle(&two, 1);
    let (from_design, _) = rms_of_cycle(&alone, 0);
    let limit = noise_rms_limit(n, &NoiseSettings::default());
    assert!(along <= limit, "{along} > {limit}");
    assert!(
        (from_design - along).abs() < 1e-6,
        "{from_design} vs {along}"
    );
}

/// Issue 24's test "a truth with an out-of-library fault leaves the model
/// unchanged and says why": the default truth with motor A_cc1's drum
/// zeroed 15 mm off. The library's effects fitted to its logs leave a
/// structured residual (joints heavier and cables softer stand in for the
/// slack cable), so nothing is learnt, and the update says why.
#[test]
fn an_out_of_library_fault_leaves_the_learnt_model_unchanged_and_says_why() {
    use tensegrity_deploy::model::faults::DrumZeroError;
    let structure = reference_structure();
    let mut truth = default_truth(structure.clone());
    let cable = structure
        .continuous_cables
        .iter()
        .position(|c| c.id == "A_cc1")
        .unwrap();
    truth.effects.faults.drum_zero_error = Some(DrumZeroError {
        cable,
        offset_m: 0.015,
    });
    let (r, cases) = learning_cycles(2, truth);
    for (c, case) in r.iter().zip(&cases) {
        let u = c.model_update.as_ref().unwrap();
        assert_eq!(u.outcome(), "nothing_learnt", "cycle {}: {u:?}", c.cycle);
        let note = u.note.as_deref().unwrap_or_default();
        assert!(
            note.contains("structured residual"),
            "cycle {}: {u:?}",
            c.cycle
        );
        assert!(case.model.as_ref().unwrap().effects.is_empty());
    }
}

/// A memory keeps the model learnt: a later run with the same memory
/// (`tdeploy cycles --memory FILE`) starts from the latest model stored,
/// so its first cycle is planned on it and read at the noise, where a
/// fresh memory's first cycle reads the frictionless model at about 2 σ.
/// On the command line the self-diagnosis's columns are written.
#[test]
fn a_later_run_starts_from_the_model_its_memory_learnt() {
    let tmp = tempfile::tempdir().unwrap();
    let memory = tmp.path().join("memory.tdm");
    let run = |out: &str| {
        let out = tmp.path().join(out);
        let run = tdeploy(
            &[
                "cycles",
                "--cycles",
                "1",
                "--policy",
                "policies/memory-model.toml",
                "--memory",
                memory.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
            repo_root(),
        );
        succeeded(&run);
        let table = std::fs::read_to_string(out.join("cycles.csv")).unwrap();
        let mut lines = table.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let row: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let column = |name: &str| row[header.iter().position(|h| *h == name).unwrap()].clone();
        (
            column("planning_model_rms").parse::<f64>().unwrap(),
            column("model_update"),
        )
    };
    let (first, update) = run("first");
    assert!(first > 1.5, "{first}");
    assert_eq!(update, "accepted");
    let stored = read_memory(&memory).unwrap();
    assert!(stored.cases[0].model.as_ref().unwrap().accepted);
    let (second, _) = run("second");
    assert!(second < 1.2, "{second}");
}

/// `evaluate` does not learn models between cycles: a policy asking for
/// it is refused, naming the file and the setting, rather than run
/// without it under its name.
#[test]
fn evaluate_refuses_a_policy_that_learns_its_model() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("e");
    let run = tdeploy(
        &[
            "evaluate",
            "--policy",
            "policies/memory-model.toml",
            "--scenarios",
            "1",
            "-o",
            out.to_str().unwrap(),
        ],
        repo_root(),
    );
    let e = common::cli::failed_with(&run, 2);
    assert!(
        e.contains("policies/memory-model.toml") && e.contains("model_learning_enable"),
        "{e}"
    );
}

/// Keeps the note a run starts with.
#[derive(Default)]
struct StartNote(Option<String>);

impl CycleObserver for StartNote {
    fn on_start(&mut self, note: &str) {
        self.0 = Some(note.to_string());
    }
    fn on_cycle(&mut self, _: &CycleResult, _: &Deployment, _: &Case) {}
}

/// A memory whose newest model was learnt beyond one model file is not
/// carried onto another: the run starts from its own model file and says
/// so (the first cycle reads the frictionless model at about 2 σ again).
#[test]
fn a_model_learnt_beyond_another_model_file_is_not_carried_onto_this_one() {
    let structure = reference_structure();
    let policy = model_learning_policy();
    let truth = default_truth(structure.clone());
    let nominal = EffectModel::for_measurement(structure.clone(), Default::default());
    let mut memory = CaseMemory::default();
    run_on_bridge(&policy, 1, &truth, &mut memory, Some(&nominal), 1, &mut ());
    assert!(!memory.cases[0].model.as_ref().unwrap().effects.is_empty());
    // The same bridge, described by another model file (its cables 2 %
    // softer): another base.
    let other = EffectModel::for_measurement(
        structure,
        tensegrity_deploy::model::Effects::default().with_parameters(
            tensegrity_deploy::model::EffectKind::StiffnessError,
            &[1.0, 0.98, 1.0],
        ),
    );
    let mut note = StartNote::default();
    let r = run_on_bridge(&policy, 1, &truth, &mut memory, Some(&other), 1, &mut note);
    let note = note.0.expect("a note on the model not carried");
    assert!(note.contains("another model file"), "{note}");
    assert!(r[0].planning_model_rms.unwrap() > 1.5);
}
