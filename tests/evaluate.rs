//! `tdeploy evaluate` and `tdeploy merge`: the same bytes at 1 and 2
//! threads; the shards of a sweep merged give the sweep's files byte for
//! byte; merge refuses shards that do not make one sweep; a bad
//! distribution file exits 2 naming file, line and field.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::cli::{failed_with, stderr, tdeploy};
use common::fixtures::{dir_with, REFERENCE_MODEL};
use common::repo_root;

/// Runs `tdeploy args` in the repository (the policies are named relative
/// to it).
fn tdeploy_in_repo(args: &[&str]) -> Output {
    tdeploy(args, repo_root())
}

/// Ran to its end: exit 0, or 1 where a run broke a truth limit (the
/// nominal policy does; the files are written either way).
fn ok(out: &Output) {
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "exit {:?}: {}",
        out.status.code(),
        stderr(out)
    );
}

/// The files that must be identical (timing.csv holds wall-clock times).
const SAME: [&str; 6] = [
    "evaluation.toml",
    "runs.csv",
    "summary.csv",
    "paired.csv",
    "by_fold.csv",
    "evaluation.svg",
];

fn assert_same(a: &Path, b: &Path) {
    for f in SAME {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(
            x == y,
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

const POLICIES: [&str; 4] = [
    "--policy",
    "policies/qp.toml",
    "--policy",
    "policies/nominal.toml",
];

fn evaluate(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["evaluate", "--scenarios", "4", "--seed", "5"];
    args.extend(POLICIES);
    args.extend(extra);
    args.extend(["-o", dir.to_str().unwrap()]);
    tdeploy_in_repo(&args)
}

#[test]
fn shards_merge_into_the_sweep_byte_for_byte_at_any_thread_count() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = |name: &str| -> PathBuf { tmp.path().join(name) };
    ok(&evaluate(&dir("whole"), &["--threads", "1"]));
    ok(&evaluate(&dir("whole2"), &["--threads", "2"]));
    assert_same(&dir("whole"), &dir("whole2"));
    // The runs name every scenario's seed and draws.
    let runs = std::fs::read_to_string(dir("whole").join("runs.csv")).unwrap();
    assert!(runs.starts_with("scenario,seed,joint_friction.mu,motor.slip_fraction"));
    assert_eq!(runs.lines().count(), 1 + 4 * 2);
    for k in 1..=3 {
        let shard = format!("{k}/3");
        ok(&evaluate(&dir(&format!("s{k}")), &["--shard", &shard]));
    }
    let merged = dir("merged");
    ok(&tdeploy_in_repo(&[
        "merge",
        dir("s3").to_str().unwrap(),
        dir("s1").to_str().unwrap(),
        dir("s2").to_str().unwrap(),
        "-o",
        merged.to_str().unwrap(),
    ]));
    assert_same(&dir("whole"), &merged);

    // A missing shard, a repeated one, and a shard of another sweep are
    // refused, naming what is wrong.
    let refuse = |args: &[&str], says: &str| {
        let err = failed_with(&tdeploy_in_repo(args), 2);
        assert!(err.contains(says), "{err}");
    };
    let o = dir("refused");
    let (s1, s2, s3) = (dir("s1"), dir("s2"), dir("s3"));
    let (s1, s2, s3) = (
        s1.to_str().unwrap(),
        s2.to_str().unwrap(),
        s3.to_str().unwrap(),
    );
    refuse(
        &["merge", s1, s2, "-o", o.to_str().unwrap()],
        "shards 3 of 3 are missing",
    );
    refuse(
        &["merge", s1, s1, s2, "-o", o.to_str().unwrap()],
        "given twice",
    );
    ok(&tdeploy_in_repo(&[
        "evaluate",
        "--scenarios",
        "4",
        "--seed",
        "6",
        "--policy",
        "policies/qp.toml",
        "--policy",
        "policies/nominal.toml",
        "--shard",
        "3/3",
        "-o",
        dir("other").to_str().unwrap(),
    ]));
    let other = dir("other");
    refuse(
        &[
            "merge",
            s1,
            s2,
            other.to_str().unwrap(),
            "-o",
            o.to_str().unwrap(),
        ],
        "not shards of the same sweep: their evaluation.toml differ in seed",
    );

    // Issue 25: shard rows were merged unchecked. Each of these edits of
    // shard 1's runs.csv is refused, naming the file, the line and the
    // column, and nothing is written.
    let runs = std::fs::read_to_string(Path::new(s1).join("runs.csv")).unwrap();
    let header: Vec<&str> = runs.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for (name, value) in [
        ("load_cell_noise_n", "-1e308"),
        ("motor.slip_fraction", "0.5"),
        ("status", "bogus"),
        ("corrective_commands", "18446744073709551615"),
        ("cable_travel_m", "-5"),
        ("final_true_gap_m", "inf"),
        ("binds", " x"),
        ("largest_force_breach_n", "1"),
    ] {
        let bad = dir(&format!("bad-{name}"));
        std::fs::create_dir(&bad).unwrap();
        for f in ["evaluation.toml", "summary.json"] {
            let from = Path::new(s1).join(f);
            if from.exists() {
                std::fs::copy(&from, bad.join(f)).unwrap();
            }
        }
        let mut lines: Vec<String> = runs.lines().map(str::to_string).collect();
        let mut cells: Vec<&str> = lines[1].split(',').collect();
        cells[column(name)] = value;
        lines[1] = cells.join(",");
        std::fs::write(bad.join("runs.csv"), lines.join("\n") + "\n").unwrap();
        let e = failed_with(
            &tdeploy_in_repo(&[
                "merge",
                bad.to_str().unwrap(),
                s2,
                s3,
                "-o",
                o.to_str().unwrap(),
            ]),
            2,
        );
        assert!(
            e.contains("runs.csv") && e.contains("line 2") && e.contains(&format!("`{name}`")),
            "{name} = {value}: {e}"
        );
        assert!(!o.exists(), "{name}: nothing written");
    }
}

/// Issue 25: `--slip-event-substeps` splits each truth's increments at
/// its joints' slip events. It changes what the runs are judged on, so
/// `evaluation.toml` records it (only when set: earlier records read as
/// without it) and a shard judged on split truths does not merge with
/// shards judged on plain ones.
#[test]
fn truths_split_at_slip_events_are_recorded_and_do_not_merge_with_plain_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = |name: &str| -> PathBuf { tmp.path().join(name) };
    let plain = |k: &str| evaluate(&dir(&format!("plain{k}")), &["--shard", &format!("{k}/2")]);
    ok(&plain("1"));
    ok(&evaluate(
        &dir("split2"),
        &["--shard", "2/2", "--slip-event-substeps"],
    ));
    let record = |d: &str| std::fs::read_to_string(dir(d).join("evaluation.toml")).unwrap();
    assert!(
        record("split2").contains("truth_slip_event_substeps = true"),
        "{}",
        record("split2")
    );
    assert!(!record("plain1").contains("truth_slip_event_substeps"));
    let o = dir("merged");
    let err = failed_with(
        &tdeploy_in_repo(&[
            "merge",
            dir("plain1").to_str().unwrap(),
            dir("split2").to_str().unwrap(),
            "-o",
            o.to_str().unwrap(),
        ]),
        2,
    );
    assert!(err.contains("truth_slip_event_substeps"), "{err}");
    assert!(!o.exists());
}

/// Shards run on model files of one name are one sweep only if the files
/// say the same: a comment changes nothing, a `[solver]` table (or any
/// effect) does, and `merge` names the field. Before the record carried
/// the model's fingerprint, only its path was compared.
#[test]
fn shards_on_model_files_of_one_name_but_other_contents_do_not_merge() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = |name: &str| -> PathBuf { tmp.path().join(name) };
    let model = tmp.path().join("m.toml");
    let run = |text: &str, out: &str, shard: &str| {
        std::fs::write(&model, text).unwrap();
        ok(&tdeploy_in_repo(&[
            "evaluate",
            "--scenarios",
            "2",
            "--seed",
            "5",
            "--model",
            model.to_str().unwrap(),
            "--shard",
            shard,
            "-o",
            dir(out).to_str().unwrap(),
        ]));
    };
    run(REFERENCE_MODEL, "a1", "1/2");
    run(&format!("# the same model\n{REFERENCE_MODEL}"), "a2", "2/2");
    run(
        &format!("{REFERENCE_MODEL}[solver]\nslip_event_substeps = true\n"),
        "b2",
        "2/2",
    );
    let merge = |second: &str, out: &str| {
        tdeploy_in_repo(&[
            "merge",
            dir("a1").to_str().unwrap(),
            dir(second).to_str().unwrap(),
            "-o",
            dir(out).to_str().unwrap(),
        ])
    };
    ok(&merge("a2", "merged"));
    let err = failed_with(&merge("b2", "refused"), 2);
    assert!(err.contains("model_fingerprint"), "{err}");
    assert!(!dir("refused").exists());
}

#[test]
fn cycles_out_of_range_exit_2_naming_the_flag() {
    let tmp = tempfile::tempdir().unwrap();
    for bad in ["0", "101"] {
        let out = evaluate(&tmp.path().join("c"), &["--cycles", bad]);
        assert_eq!(out.status.code(), Some(2));
        let err = stderr(&out);
        assert!(err.contains("--cycles"), "{err}");
    }
}

#[test]
fn a_bad_distribution_file_exits_2_naming_file_line_and_field() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("d.toml");
    std::fs::write(
        &file,
        "format = \"tensegrity-deploy/scenarios/1\"\n[effects.motor]\nslip_fraction = [0.1, -0.1]\nbacklash_m = [0.0, 0.005]\n",
    )
    .unwrap();
    let out = tdeploy_in_repo(&[
        "evaluate",
        "--distribution",
        file.to_str().unwrap(),
        "-o",
        tmp.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains("d.toml")
            && err.contains("line 3")
            && err.contains("effects.motor.slip_fraction"),
        "{err}"
    );
}

/// Known limitation 20: a model with flexible supports appends bearings
/// and ground nodes to the bridge's own, and was refused as another
/// bridge (exit 2, "nodes"). It is the truths' bridge (they are drawn on
/// the bridge the model file names): every run starts on it.
#[test]
fn a_model_with_flexible_supports_plans_on_the_truths_bridge() {
    let supports =
        format!("{REFERENCE_MODEL}[effects.support_flexibility]\ncompliance_m_per_n = 3e-5\n");
    let tmp = dir_with(&[("supports.toml", &supports)]);
    let file = tmp.path().join("supports.toml");
    let o = tmp.path().join("o");
    let out = evaluate(&o, &["--model", file.to_str().unwrap()]);
    ok(&out);
    let runs = std::fs::read_to_string(o.join("runs.csv")).unwrap();
    assert!(!runs.contains("not_started"), "{runs}");
    assert!(runs.contains("connected"), "{runs}");
}

/// Issue 22: a run that does not connect names what binds. Folds of
/// 58–60 cm stop at the start (known limitations, item 18): `runs.csv`'s
/// `binds` names the segment the controller would not slacken further,
/// and the printed summary counts it.
#[test]
fn a_run_that_stops_names_what_binds() {
    let distribution = common::repo_text("scenarios/default.toml")
        .lines()
        .map(|l| {
            if l.starts_with("fold_m") {
                "fold_m = [0.58, 0.60]"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let tmp = dir_with(&[("big.toml", &distribution)]);
    let out = tdeploy(
        &[
            "evaluate",
            "--distribution",
            "big.toml",
            "--scenarios",
            "3",
            "--seed",
            "5",
            "-o",
            "o",
        ],
        tmp.path(),
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let (header, rows) = common::files::read_csv(&tmp.path().join("o/runs.csv"));
    let (status, binds) = (
        common::files::column(&header, "status"),
        common::files::column(&header, "binds"),
    );
    let stopped: Vec<&Vec<String>> = rows.iter().filter(|r| r[status] != "connected").collect();
    assert!(!stopped.is_empty(), "the big folds stop");
    for r in stopped {
        assert!(
            r[binds].starts_with("segment A_cc") && r[binds].ends_with(" min"),
            "{} names {:?}",
            r[status],
            r[binds]
        );
    }
    let printed = common::cli::stdout(&out);
    assert!(
        printed.contains("what binds in the 3 runs that did not connect"),
        "{printed}"
    );
}

#[test]
fn by_fold_counts_every_run_once_per_half_in_the_band_of_its_fold() {
    // Folds of 15–55 cm, half B up to 15 cm deeper or shallower: the
    // runs spread over several bands, and the halves' bands differ.
    let distribution = common::repo_text("scenarios/default.toml")
        .lines()
        .map(|l| {
            if l.starts_with("fold_m") {
                "fold_m = [0.15, 0.55]\nfold_difference_m = [-0.15, 0.15]"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let tmp = dir_with(&[("spread.toml", &distribution)]);
    let out = tdeploy(
        &[
            "evaluate",
            "--distribution",
            "spread.toml",
            "--scenarios",
            "8",
            "--seed",
            "12",
            "-o",
            "o",
        ],
        tmp.path(),
    );
    ok(&out);
    let (header, rows) = common::files::read_csv(&tmp.path().join("o/runs.csv"));
    let col = |name: &str| common::files::column(&header, name);
    let (succeeded, violations) = (col("succeeded"), col("truth_violations"));
    // The bands recounted here from runs.csv: band k is (k·10 cm,
    // (k+1)·10 cm], k counted up while the fold lies above its top.
    type Counts = std::collections::BTreeMap<(String, i64), [usize; 4]>;
    let mut expected = Counts::new();
    for (half, column) in [("A", col("fold_m")), ("B", col("fold_b_m"))] {
        for r in &rows {
            let fold: f64 = r[column].parse().unwrap();
            let mut k = 0;
            while fold > (k + 1) as f64 / 10.0 + 1e-12 {
                k += 1;
            }
            let e = expected.entry((half.to_string(), k)).or_default();
            e[0] += 1;
            if r[succeeded] == "true" {
                e[1] += 1;
            } else if r[violations] != "0" {
                e[2] += 1;
            } else {
                e[3] += 1;
            }
        }
    }
    let bands_of = |half: &str| expected.keys().filter(|(h, _)| h == half).count();
    assert!(
        bands_of("A") >= 2
            && expected
                .keys()
                .any(|(h, k)| h == "B" && !expected.contains_key(&("A".into(), *k))),
        "the folds span bands and the halves differ: {expected:?}"
    );
    let (bh, bands) = common::files::read_csv(&tmp.path().join("o/by_fold.csv"));
    assert_eq!(
        bh,
        [
            "policy",
            "half",
            "fold_from_m",
            "fold_to_m",
            "runs",
            "succeeded",
            "broke_limits",
            "other_failures"
        ]
    );
    let found: Counts = bands
        .iter()
        .map(|b| {
            assert_eq!(b[0], "qp");
            let from: f64 = b[2].parse().unwrap();
            let to: f64 = b[3].parse().unwrap();
            assert!((to - from - 0.1).abs() < 1e-9, "{b:?}");
            let n: Vec<usize> = b[4..].iter().map(|x| x.parse().unwrap()).collect();
            (
                (b[1].clone(), (from * 10.0).round() as i64),
                [n[0], n[1], n[2], n[3]],
            )
        })
        .collect();
    assert_eq!(found, expected);
}

/// Issue 24 ("never worse"): the case memory replayed the first cycle's
/// closed loop, lateral corrections and all, on a truth whose `B_cc1`
/// material creeps from cycle to cycle, and from cycle 3 the same
/// commands slackened that whole cable (scenario 61 of wide seed 7502:
/// 293 truth-limit violations over 5 cycles with `learnt_path =
/// "replayed"`; the memoryless controller none). The straight path to the
/// learnt end keeps it.
#[test]
fn a_learnt_approach_does_not_slacken_a_cable_that_crept_between_cycles() {
    let tmp = tempfile::tempdir().unwrap();
    let memory = common::repo_text("policies/memory.toml");
    assert!(memory.contains("learnt_path = \"paced\""));
    let replayed = tmp.path().join("replayed.toml");
    std::fs::write(
        &replayed,
        memory
            .replace("learnt_path = \"paced\"", "learnt_path = \"replayed\"")
            .replace("name = \"memory\"", "name = \"replayed\""),
    )
    .unwrap();
    let (header, rows) = wide_scenario_rows(
        &["policies/memory.toml", replayed.to_str().unwrap()],
        7502,
        61,
        5,
    );
    let col = |name: &str| common::files::column(&header, name);
    assert_eq!(rows.len(), 2);
    let [paced, replayed] = [&rows[0], &rows[1]];
    assert_eq!(paced[col("scenario")], "61");
    assert_eq!(paced[col("policy")], "memory");
    assert_eq!(paced[col("truth_violations")], "0", "{paced:?}");
    assert_eq!(paced[col("status")], "connected", "{paced:?}");
    // The scenario still exercises the flaw: replayed, the cable goes.
    assert_eq!(replayed[col("policy")], "replayed");
    assert_ne!(replayed[col("truth_violations")], "0", "{replayed:?}");
}

/// The `runs.csv` header and rows (one per policy, in order) of
/// `policies` on scenario `scenario` of `scenarios/wide.toml` drawn with
/// `seed`, over `cycles` cycles (the scenario alone: shard `scenario + 1`
/// of `scenario + 1`).
fn wide_scenario_rows(
    policies: &[&str],
    seed: u64,
    scenario: usize,
    cycles: usize,
) -> (Vec<String>, Vec<Vec<String>>) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    let count = (scenario + 1).to_string();
    let shard = format!("{count}/{count}");
    let (seed, cycles) = (seed.to_string(), cycles.to_string());
    let mut args = vec!["evaluate", "--distribution", "scenarios/wide.toml"];
    for p in policies {
        args.extend(["--policy", p]);
    }
    args.extend([
        "--scenarios",
        &count,
        "--shard",
        &shard,
        "--seed",
        &seed,
        "--cycles",
        &cycles,
        "-o",
        out.to_str().unwrap(),
    ]);
    ok(&tdeploy_in_repo(&args));
    let (header, rows) = common::files::read_csv(&out.join("runs.csv"));
    assert_eq!(rows.len(), policies.len());
    let col = common::files::column(&header, "scenario");
    assert!(rows.iter().all(|r| r[col] == scenario.to_string()));
    (header, rows)
}

/// The `runs.csv` header and row of `policies/memory.toml` alone
/// ([`wide_scenario_rows`]).
fn memory_on_wide_scenario(
    seed: u64,
    scenario: usize,
    cycles: usize,
) -> (Vec<String>, Vec<String>) {
    let (header, mut rows) = wide_scenario_rows(&["policies/memory.toml"], seed, scenario, cycles);
    (header, rows.remove(0))
}

/// Issue 24 ("never worse"): a learnt approach carries the take-up of the
/// cycle it was learnt from (the planner's first command reels in a
/// cable the fold left slack, `plan::take_up`), and the paced path spread
/// it over every motor: the others reeled in while that cable was still
/// slack, and its segments, already below their minimum at the start,
/// fell 0.1 N further (scenario 20 of wide seed 7502: 6 truth-limit
/// violations in every learnt cycle, none without the memory). The
/// controller now takes the slack up first and the learnt approach goes
/// on from there to the same end.
#[test]
fn a_learnt_approach_takes_up_a_slack_cable_before_reeling_in_the_others() {
    let (header, row) = memory_on_wide_scenario(7502, 20, 2);
    let col = |name: &str| common::files::column(&header, name);
    assert_eq!(row[col("truth_violations")], "0", "{row:?}");
    assert_eq!(row[col("status")], "connected", "{row:?}");
}

/// Issue 24 ("never worse"), after the take-up above: the case learnt
/// from began with its own take-up, which the paced path made a 2 mm step
/// of every motor. Sent after this cycle's take-up, that step reeled the
/// other cables in while the far segments of `A_cc0`, folded below their
/// minimum, stuck at its joints, and took them 0.1–0.3 N further below
/// (scenario 87 of wide seed 7501, cycle 4: 9 violations; the memoryless
/// controller's next command is 25 mm and breaks none). The case now
/// records which of its commands were take-ups (memory format 4), and
/// the paced path gives their motion to the learnt commands without a
/// step of their own (the twenty-first session merged the first two
/// learnt commands instead, a stand-in for this record).
#[test]
fn a_learnt_approach_after_a_take_up_does_not_begin_with_a_small_step() {
    // Cycles 2 and 3 stop "not reachable" at this 48 cm fold, as the
    // memoryless controller's do; what is tested is that no limit breaks.
    let (header, row) = memory_on_wide_scenario(7501, 87, 4);
    assert_eq!(
        row[common::files::column(&header, "truth_violations")],
        "0",
        "{row:?}"
    );
}
