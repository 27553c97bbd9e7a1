//! Online sessions (`tdeploy session`, `tdeploy rig`): a session driven
//! one command at a time gives what `tdeploy deploy` gives on the same
//! truth and seed, survives `kill -9` anywhere, asks for approval, keeps
//! its interlocks, and refuses bad input without changing a byte.

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Duration;

use common::cli::{failed_with, stdout, succeeded, tdeploy, tdeploy_with, RunOptions};
use common::files::files;
use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_tdeploy");

/// `tdeploy rig --stdio` as a child: the simulated bridge.
struct Rig {
    child: Child,
    input: ChildStdin,
    output: BufReader<ChildStdout>,
    /// The start's measurements message.
    start: String,
}

impl Rig {
    fn new(seed: u64) -> Rig {
        let mut child = Command::new(BIN)
            .args(["rig", "--stdio", "--seed", &seed.to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let input = child.stdin.take().unwrap();
        let mut output = BufReader::new(child.stdout.take().unwrap());
        let hello = read_line(&mut output);
        assert!(hello.contains("\"role\":\"rig\""), "{hello}");
        let start = read_line(&mut output);
        Rig {
            child,
            input,
            output,
            start,
        }
    }

    /// Executes the command message `line`; returns the readings message.
    fn execute(&mut self, line: &str) -> String {
        writeln!(self.input, "{line}").unwrap();
        loop {
            let reply = read_line(&mut self.output);
            let m: Value = serde_json::from_str(&reply).unwrap();
            match m["type"].as_str() {
                Some("truth") => continue,
                Some("measurements") => return reply,
                _ => panic!("rig: {reply}"),
            }
        }
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `tdeploy session serve SESSION --stdio` started, its hello read: the
/// process, its input and its output.
fn serve(session: &Path) -> (Child, ChildStdin, BufReader<ChildStdout>) {
    let mut child = Command::new(BIN)
        .args(["session", "serve", &arg(session), "--stdio"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let input = child.stdin.take().unwrap();
    let mut output = BufReader::new(child.stdout.take().unwrap());
    let _hello = read_line(&mut output);
    (child, input, output)
}

fn read_line(r: &mut impl BufRead) -> String {
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    assert!(!line.is_empty(), "the peer closed its output");
    line.trim_end().to_string()
}

fn arg(p: &Path) -> String {
    p.display().to_string()
}

fn status_json(session: &Path) -> Value {
    let out = tdeploy(
        &["session", "status", &arg(session), "--json"],
        Path::new("."),
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", stdout(&out)))
}

/// Writes `line` (a measurements message) to a file and records it.
fn record_message(session: &Path, line: &str, options: RunOptions) -> std::process::Output {
    let file = session.with_extension("readings.json");
    std::fs::write(&file, line).unwrap();
    tdeploy_with(
        &[
            "session",
            "record",
            &arg(session),
            "--measurements",
            &arg(&file),
        ],
        Path::new("."),
        options,
    )
}

/// `tdeploy deploy --seed seed` into `dir/deploy`: the reference.
fn deploy(dir: &Path, seed: u64) -> PathBuf {
    let out = dir.join("deploy");
    succeeded(&tdeploy(
        &["deploy", "--seed", &seed.to_string(), "-o", &arg(&out)],
        Path::new("."),
    ));
    out
}

fn new_session(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let s = dir.join(name);
    let mut args = vec!["session", "start", "-o"];
    let a = arg(&s);
    args.push(&a);
    args.extend_from_slice(extra);
    succeeded(&tdeploy(&args, Path::new(".")));
    s
}

/// Drives `session` with `next --json` and `record` against `rig` until
/// it ends; returns the number of commands.
fn drive(session: &Path, rig: &mut Rig, options: RunOptions) -> usize {
    succeeded(&record_message(session, &rig.start.clone(), options));
    let mut commands = 0;
    loop {
        let out = tdeploy_with(
            &["session", "next", &arg(session), "--json"],
            Path::new("."),
            options,
        );
        let line = stdout(&out).trim().to_string();
        let m: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line}"));
        match m["type"].as_str() {
            Some("command") => {
                let readings = rig.execute(&line);
                succeeded(&record_message(session, &readings, options));
                commands += 1;
            }
            Some("ended") => return commands,
            _ => panic!("{line}"),
        }
    }
}

#[test]
fn a_session_driven_by_next_and_record_gives_the_commands_gaps_and_verdict_of_deploy() {
    let dir = tempfile::tempdir().unwrap();
    let reference = deploy(dir.path(), 1);
    let session = new_session(dir.path(), "s", &[]);
    let mut rig = Rig::new(1);
    let commands = drive(&session, &mut rig, RunOptions::rayon_threads(2));
    // The log holds every command and reading exactly as deploy's.
    assert_eq!(files(&session.join("log")), files(&reference.join("log")));
    let summary = common::files::read_json(&reference.join("summary.json"));
    let status = status_json(&session);
    assert_eq!(status["phase"], "ended");
    assert_eq!(status["ended_status"], summary["status"]["status"]);
    assert_eq!(status["commands_executed"], commands);
    assert_eq!(summary["commands"], commands);
}

#[test]
fn the_rig_client_example_drives_a_session_through_pipes_as_deploy_does() {
    let dir = tempfile::tempdir().unwrap();
    let reference = deploy(dir.path(), 2);
    let session = new_session(dir.path(), "s", &[]);
    let out = Command::new("python3")
        .arg(common::repo_path("examples/rig_client.py"))
        .args([&arg(&session), "--tdeploy", BIN, "--", "--seed", "2"])
        .output()
        .expect("python3 runs examples/rig_client.py");
    assert!(
        out.status.success(),
        "{}{}",
        stdout(&out),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout(&out).contains("session: connected"),
        "{}",
        stdout(&out)
    );
    assert_eq!(files(&session.join("log")), files(&reference.join("log")));
}

/// Runs `tdeploy args`, killing it with SIGKILL after `delay`; returns
/// whether the kill hit a running process.
fn run_killed(args: &[&str], delay: Duration) -> bool {
    let mut child = Command::new(BIN)
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while start.elapsed() < delay && child.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(1));
    }
    let running = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    let _ = child.wait();
    running
}

/// A deterministic stream of delays, ms (a linear congruential generator:
/// the test needs no more randomness than this).
struct Delays(u64);

impl Delays {
    fn next_ms(&mut self, below: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % below
    }
}

#[test]
fn kill_9_of_next_record_and_serve_at_random_points_then_resume_gives_the_same_deployment() {
    let dir = tempfile::tempdir().unwrap();
    let reference = deploy(dir.path(), 3);
    let session = new_session(dir.path(), "s", &[]);
    let mut rig = Rig::new(3);
    let mut delays = Delays(42);
    // The rig's readings per executed step: a command the rig executed
    // before the controller's record was killed is not executed again.
    let mut executed: Vec<String> = vec![rig.start.clone()];
    let readings_file = dir.path().join("readings.json");
    let (mut kills, mut serve_kills) = (0, 0);
    let (mut last, mut attempts) = ((String::new(), None), 0);
    for round in 0..400 {
        let status = status_json(&session);
        let phase = status["phase"].as_str().unwrap().to_string();
        if phase == "ended" {
            break;
        }
        // Every third round, the protocol server is started and killed.
        if round % 3 == 2 && serve_kills < 10 {
            let mut child = Command::new(BIN)
                .args(["session", "serve", &arg(&session), "--stdio"])
                .env("RAYON_NUM_THREADS", "1")
                .stdin(Stdio::piped())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            // Killed while it starts, replays and (when ready) plans and
            // stores the next command: the input stays open, unread.
            let _input = child.stdin.take().unwrap();
            std::thread::sleep(Duration::from_millis(delays.next_ms(40)));
            if child.try_wait().unwrap().is_none() {
                serve_kills += 1;
                kills += 1;
            }
            let _ = child.kill();
            let _ = child.wait();
            continue;
        }
        let s = arg(&session);
        let args: Vec<String> = match phase.as_str() {
            "awaiting_start" => {
                std::fs::write(&readings_file, &executed[0]).unwrap();
                vec![
                    "record".into(),
                    s,
                    "--measurements".into(),
                    arg(&readings_file),
                ]
            }
            "ready" => vec!["next".into(), s, "--json".into()],
            "pending" => {
                let step = status["pending_step"].as_u64().unwrap() as usize;
                if executed.len() <= step {
                    let out = tdeploy(&["session", "next", &s, "--json"], Path::new("."));
                    executed.push(rig.execute(stdout(&out).trim()));
                }
                std::fs::write(&readings_file, &executed[step]).unwrap();
                vec![
                    "record".into(),
                    s,
                    "--measurements".into(),
                    arg(&readings_file),
                ]
            }
            other => panic!("phase {other}"),
        };
        let mut full = vec!["session".to_string()];
        full.extend(args);
        let full: Vec<&str> = full.iter().map(String::as_str).collect();
        // Each operation is killed within its first 25 ms twice
        // (operations take 10 to 50 ms), then let finish.
        let here = (phase.clone(), status["events"].as_u64());
        attempts = if last == here { attempts + 1 } else { 0 };
        last = here;
        let delay = if attempts >= 2 {
            60_000
        } else {
            delays.next_ms(25)
        };
        if run_killed(&full, Duration::from_millis(delay)) {
            kills += 1;
        }
        // The journal is whole or its torn tail is the only damage.
        let status = tdeploy(&["session", "status", &arg(&session)], Path::new("."));
        assert!(!String::from_utf8_lossy(&status.stderr).contains("panicked"));
    }
    assert!(
        kills >= 20,
        "only {kills} kills hit a running process ({serve_kills} of serve)"
    );
    assert!(serve_kills >= 5, "only {serve_kills} kills hit serve");
    assert_eq!(status_json(&session)["phase"], "ended");
    // A kill between the journal's append and the views leaves the views
    // one change behind until the next command rewrites them.
    succeeded(&tdeploy(
        &["session", "next", &arg(&session)],
        Path::new("."),
    ));
    let log = files(&session.join("log"));
    let names: Vec<&String> = log.iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        [
            "commands.csv",
            "log.toml",
            "measurements.csv",
            "sensors.csv"
        ]
    );
    assert!(
        log == files(&reference.join("log")),
        "the session's log differs from deploy's"
    );
}

#[test]
fn a_command_awaits_approval_and_a_rejected_one_is_logged_and_planned_again_smaller() {
    let dir = tempfile::tempdir().unwrap();
    let session = new_session(dir.path(), "s", &["--approve"]);
    let mut rig = Rig::new(1);
    succeeded(&record_message(
        &session,
        &rig.start.clone(),
        RunOptions::default(),
    ));
    let next = || -> Value {
        let out = tdeploy(
            &["session", "next", &arg(&session), "--json"],
            Path::new("."),
        );
        succeeded(&out);
        serde_json::from_str(stdout(&out).trim()).unwrap()
    };
    let first = next();
    assert_eq!(
        (first["step"].as_u64(), &first["cleared"]),
        (Some(1), &Value::Bool(false))
    );
    // Not approved: its readings are refused and the session unchanged.
    let before = files(&session);
    let readings = rig.execute(&serde_json::to_string(&serde_json::json!({
        "type": "command", "step": 1, "payout_change_m": first["payout_change_m"], "cleared": true
    })).unwrap());
    let e = failed_with(
        &record_message(&session, &readings, RunOptions::default()),
        2,
    );
    assert!(e.contains("not been approved"), "{e}");
    assert_eq!(files(&session), before);
    // Rejected: logged with its reason; the next plan is smaller.
    succeeded(&tdeploy(
        &[
            "session",
            "reject",
            &arg(&session),
            "--step",
            "1",
            "--reason",
            "too far at once",
        ],
        Path::new("."),
    ));
    let journal = std::fs::read_to_string(session.join("events.tdj")).unwrap();
    assert!(journal.contains("\"event\":\"rejected\"") && journal.contains("too far at once"));
    let again = next();
    let largest = |m: &Value| {
        m["payout_change_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap().abs())
            .fold(0.0, f64::max)
    };
    assert_eq!(again["step"].as_u64(), Some(1));
    assert!(
        largest(&again) < largest(&first),
        "{} then {}",
        largest(&first),
        largest(&again)
    );
    succeeded(&tdeploy(
        &["session", "approve", &arg(&session), "--step", "1"],
        Path::new("."),
    ));
    assert_eq!(next()["cleared"], true);
}

/// A readings message of the rig's start with `sensor` replaced by `value`.
fn with_reading(line: &str, sensor: &str, value: f64) -> String {
    let mut m: Value = serde_json::from_str(line).unwrap();
    m["readings"][sensor] = serde_json::json!(value);
    m.to_string()
}

#[test]
fn each_interlock_stops_the_session_until_an_operator_resumes_it() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let cases = [
        ("load_A_cc0", 1.0e5, "load_A_cc0 reads"),
        ("load_A_cc1", -500.0, "below the plausible"),
        ("A4_2_z", 40.0, "from where the model puts node"),
        ("temperature", 95.0, "outside the plausible"),
    ];
    for (k, (sensor, value, words)) in cases.into_iter().enumerate() {
        let session = new_session(dir.path(), &format!("s{k}"), &[]);
        let line = with_reading(&rig.start, sensor, value);
        if !rig.start.contains(&format!("\"{sensor}\"")) {
            panic!("no sensor {sensor} in {}", rig.start);
        }
        let e = failed_with(&record_message(&session, &line, RunOptions::default()), 1);
        assert!(e.contains("stopped") && e.contains(words), "{sensor}: {e}");
        let e = failed_with(
            &tdeploy(&["session", "next", &arg(&session)], Path::new(".")),
            1,
        );
        assert!(e.contains("is stopped"), "{e}");
        succeeded(&tdeploy(
            &[
                "session",
                "resume",
                &arg(&session),
                "--note",
                "checked the sensor",
            ],
            Path::new("."),
        ));
        // Resumed, it plans with what it learnt from the readings: a
        // command, or an end that says why (never a refusal).
        let out = tdeploy(
            &["session", "next", &arg(&session), "--json"],
            Path::new("."),
        );
        let m: Value = serde_json::from_str(stdout(&out).trim()).unwrap();
        match m["type"].as_str() {
            Some("command") => succeeded(&out),
            Some("ended") => assert!(m["words"].as_str().unwrap().len() > 10, "{m}"),
            _ => panic!("{sensor}: {m}"),
        }
    }
    // No command while the last one's readings are missing: asking again
    // gives the same pending command and changes nothing.
    let session = new_session(dir.path(), "pending", &[]);
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    let first = stdout(&tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    ));
    let before = files(&session);
    let again = stdout(&tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    ));
    assert_eq!(first, again);
    assert_eq!(files(&session), before);
}

#[test]
fn malformed_readings_are_refused_naming_file_line_and_field_and_leave_the_session_byte_identical()
{
    let dir = tempfile::tempdir().unwrap();
    let session = new_session(dir.path(), "s", &[]);
    let mut rig = Rig::new(1);
    succeeded(&record_message(
        &session,
        &rig.start.clone(),
        RunOptions::default(),
    ));
    let command = stdout(&tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    ));
    let good = rig.execute(command.trim());
    let before = files(&session);
    let bad_csv = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let cases: Vec<(PathBuf, &str)> = vec![
        (
            bad_csv("unknown.csv", "step,sensor,value\n1,load_Z9,12\n"),
            "line 2, field `sensor`",
        ),
        (
            bad_csv("nan.csv", "step,sensor,value\n1,load_A_cc0,NaN\n"),
            "line 2, field `value`",
        ),
        (
            bad_csv(
                "steps.csv",
                "step,sensor,value\n1,load_A_cc0,10\n2,load_A_cc1,10\n",
            ),
            "line 3, field `step`",
        ),
        (
            bad_csv("header.csv", "cycle,step,sensor,value\n1,1,load_A_cc0,10\n"),
            "header",
        ),
        (
            bad_csv("future.csv", "step,sensor,value\n5,load_A_cc0,10\n"),
            "readings for step 5",
        ),
        (
            bad_csv("again.csv", "step,sensor,value\n0,load_A_cc0,10\n"),
            "readings for step 0",
        ),
        (
            bad_csv("field.json", &good.replace("\"step\"", "\"stepp\"")),
            "stepp",
        ),
        (
            bad_csv("sensor.json", &good.replace("load_A_cc0", "load_A_ccX")),
            "readings.load_A_ccX",
        ),
    ];
    for (file, words) in cases {
        let out = tdeploy(
            &[
                "session",
                "record",
                &arg(&session),
                "--measurements",
                &arg(&file),
            ],
            Path::new("."),
        );
        let e = failed_with(&out, 2);
        assert!(e.contains(words), "{}: {e}", file.display());
        assert_eq!(files(&session), before, "{}", file.display());
    }
    // The protocol refuses the same with an error message, unchanged.
    let (mut child, mut input, mut output) = serve(&session);
    let pending = read_line(&mut output);
    assert!(pending.contains("\"type\":\"command\""), "{pending}");
    for (message, field) in [
        ("not json", "message"),
        (
            "{\"type\":\"measurements\",\"step\":1,\"readings\":{\"nope\":1}}",
            "readings.nope",
        ),
        (
            "{\"type\":\"measurements\",\"step\":3,\"readings\":{}}",
            "step",
        ),
        ("{\"type\":\"launch\"}", "type"),
        ("{\"type\":\"approve\",\"step\":1,\"extra\":true}", "extra"),
    ] {
        writeln!(input, "{message}").unwrap();
        let reply: Value = serde_json::from_str(&read_line(&mut output)).unwrap();
        assert_eq!(
            (reply["type"].as_str(), reply["field"].as_str()),
            (Some("error"), Some(field)),
            "{message}: {reply}"
        );
    }
    drop(input);
    let _ = child.wait();
    assert_eq!(files(&session), before);
}

#[test]
fn a_torn_journal_line_is_named_by_status_and_dropped_by_the_next_change() {
    let dir = tempfile::tempdir().unwrap();
    let session = new_session(dir.path(), "s", &[]);
    let rig = Rig::new(1);
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    let journal = session.join("events.tdj");
    let whole = std::fs::read(&journal).unwrap();
    let mut torn = whole.clone();
    torn.extend_from_slice(b"fnv1a:0123 {\"event\":\"iss");
    std::fs::write(&journal, &torn).unwrap();
    let e = failed_with(
        &tdeploy(&["session", "status", &arg(&session)], Path::new(".")),
        2,
    );
    assert!(e.contains("line 3") && e.contains("interrupted"), "{e}");
    let out = tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    );
    succeeded(&out);
    assert!(String::from_utf8_lossy(&out.stderr).contains("torn last line"));
    let now = std::fs::read(&journal).unwrap();
    assert!(now.starts_with(&whole) && now.len() > whole.len());
}

#[test]
fn inputs_edited_after_the_start_are_refused_naming_the_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    for (file, edit) in [
        ("folded_start.json", "0.4"),
        ("policy.toml", "max_commands = 40"),
        ("session.toml", "limit_sigmas = 3.0"),
    ] {
        let session = new_session(dir.path(), file, &[]);
        let path = session.join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains(edit), "{file}");
        std::fs::write(&path, text.replacen(edit, &format!("{edit}1"), 1)).unwrap();
        let e = failed_with(
            &tdeploy(&["session", "status", &arg(&session)], Path::new(".")),
            2,
        );
        assert!(
            e.contains("session.toml") && e.contains("inputs_fingerprint"),
            "{file}: {e}"
        );
    }
}

#[test]
fn a_session_started_with_a_case_memory_sends_the_learnt_approach_first() {
    let dir = tempfile::tempdir().unwrap();
    let cycles = dir.path().join("cycles");
    succeeded(&tdeploy(
        &["cycles", "--cycles", "1", "-o", &arg(&cycles)],
        Path::new("."),
    ));
    let memory = arg(&cycles.join("memory.tdm"));
    let policy = common::repo_arg("policies/memory.toml");
    // The memory needs a policy that learns.
    let out = tdeploy(
        &[
            "session",
            "start",
            "-o",
            &arg(&dir.path().join("no")),
            "--memory",
            &memory,
        ],
        Path::new("."),
    );
    assert!(failed_with(&out, 2).contains("[memory] section"));
    let session = new_session(dir.path(), "s", &["--memory", &memory, "--policy", &policy]);
    let guidance = common::files::read_json(&session.join("guidance.json"));
    let learnt = guidance["feedforward_m"].as_array().unwrap();
    assert!(!learnt.is_empty());
    let rig = Rig::new(4);
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    let out = tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    );
    let command: Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(&command["payout_change_m"], &learnt[0]);
}

/// Review finding: the overload check used a bias estimate that had
/// already absorbed the overloaded reading, so one cell at 20 kN passed
/// for a 18 kN bias in a layout with one load cell.
#[test]
fn an_overloaded_cell_trips_the_interlock_even_alone_and_is_the_one_named() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    // The standard layout with one load cell.
    let layout =
        std::fs::read_to_string(new_session(dir.path(), "probe", &[]).join("sensors.csv")).unwrap();
    let one: String = layout
        .lines()
        .filter(|l| {
            !l.starts_with("load_A_cc1")
                && !l.starts_with("load_A_cc2")
                && !l.starts_with("load_A_cc3")
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let sensors = dir.path().join("one-cell.csv");
    std::fs::write(&sensors, one).unwrap();
    let session = new_session(dir.path(), "one", &["--sensors", &arg(&sensors)]);
    let mut m: Value = serde_json::from_str(&rig.start).unwrap();
    let readings = m["readings"].as_object_mut().unwrap();
    readings.retain(|k, _| !["load_A_cc1", "load_A_cc2", "load_A_cc3"].contains(&k.as_str()));
    readings.insert("load_A_cc0".into(), serde_json::json!(20_000.0));
    let e = failed_with(
        &record_message(&session, &m.to_string(), RunOptions::default()),
        1,
    );
    assert!(
        e.contains("load_A_cc0 reads 20000.0 N") && e.contains("above"),
        "{e}"
    );
    // With four cells, the overloaded one is named, not the others.
    let session = new_session(dir.path(), "four", &[]);
    let e = failed_with(
        &record_message(
            &session,
            &with_reading(&rig.start, "load_A_cc0", 3500.0),
            RunOptions::default(),
        ),
        1,
    );
    assert!(e.contains("load_A_cc0 reads 3500.0 N"), "{e}");
    assert!(!e.contains("load_A_cc1 reads"), "{e}");
}

/// Review finding: a load cell on a strut reads compression, which the
/// "a cable cannot push" check took for a fault.
#[test]
fn a_load_cell_on_a_strut_reading_its_compression_is_no_fault() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let probe = new_session(dir.path(), "probe", &[]);
    let mut layout = std::fs::read_to_string(probe.join("sensors.csv")).unwrap();
    // A strut of the reference bridge, by id, from the structure command.
    let out = tdeploy(
        &["structure", "-o", &arg(&dir.path().join("s.json"))],
        Path::new("."),
    );
    succeeded(&out);
    let structure = common::files::read_json(&dir.path().join("s.json"));
    let id = structure["struts"][0]["id"].as_str().unwrap();
    layout.push_str(&format!("strut_cell,tension,{id},7\n"));
    let sensors = dir.path().join("strut.csv");
    std::fs::write(&sensors, layout).unwrap();
    let session = new_session(dir.path(), "s", &["--sensors", &arg(&sensors)]);
    let mut m: Value = serde_json::from_str(&rig.start).unwrap();
    m["readings"]["strut_cell"] = serde_json::json!(-300.0);
    let out = record_message(&session, &m.to_string(), RunOptions::default());
    succeeded(&out);
    assert_eq!(status_json(&session)["phase"], "ready");
}

#[test]
fn readings_with_no_values_a_key_given_twice_or_a_repeated_answer_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let session = new_session(dir.path(), "s", &[]);
    let before = files(&session);
    let e = failed_with(
        &record_message(
            &session,
            r#"{"type":"measurements","step":0,"readings":{}}"#,
            RunOptions::default(),
        ),
        2,
    );
    assert!(e.contains("no reading"), "{e}");
    let twice = rig
        .start
        .replacen("{\"A4_0_x\"", "{\"load_A_cc0\":1.0,\"A4_0_x\"", 1);
    assert_ne!(twice, rig.start);
    let e = failed_with(&record_message(&session, &twice, RunOptions::default()), 2);
    assert!(e.contains("load_A_cc0") && e.contains("duplicate"), "{e}");
    assert_eq!(files(&session), before);
    // A cleared command may be running: no approval, no rejection.
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    succeeded(&tdeploy(
        &["session", "next", &arg(&session)],
        Path::new("."),
    ));
    let before = files(&session);
    let e = failed_with(
        &tdeploy(
            &["session", "approve", &arg(&session), "--step", "1"],
            Path::new("."),
        ),
        2,
    );
    assert!(e.contains("already cleared"), "{e}");
    let e = failed_with(
        &tdeploy(
            &[
                "session",
                "reject",
                &arg(&session),
                "--step",
                "1",
                "--reason",
                "late",
            ],
            Path::new("."),
        ),
        2,
    );
    assert!(e.contains("already cleared"), "{e}");
    assert_eq!(files(&session), before);
}

/// Review finding: two writers at once left a journal no command could
/// read, and a `reject` typed while `serve` ran was lost.
#[test]
fn one_process_writes_a_session_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let session = new_session(dir.path(), "s", &[]);
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    for _ in 0..5 {
        let spawn = || {
            Command::new(BIN)
                .args(["session", "next", &arg(&session), "--json"])
                .stdout(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn(), spawn());
        let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
        assert!(a.status.success() && b.status.success());
        assert_eq!(a.stdout, b.stdout, "both see the one pending command");
    }
    assert_eq!(status_json(&session)["pending_step"], 1);
    let (mut serve, _input, mut output) = serve(&session);
    let _command = read_line(&mut output);
    let e = failed_with(
        &tdeploy(
            &["session", "resume", &arg(&session), "--note", "x"],
            Path::new("."),
        ),
        2,
    );
    assert!(e.contains("in use by another tdeploy process"), "{e}");
    let _ = serve.kill();
    let _ = serve.wait();
}

/// Review findings: a refused input repaired the journal's torn tail
/// before it was refused; a complete last event without its line break
/// was dropped as torn.
#[test]
fn a_refusal_leaves_a_torn_journal_as_it_was_and_a_missing_line_break_loses_no_event() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let session = new_session(dir.path(), "s", &[]);
    succeeded(&record_message(&session, &rig.start, RunOptions::default()));
    let journal = session.join("events.tdj");
    let whole = std::fs::read(&journal).unwrap();
    let mut torn = whole.clone();
    torn.extend_from_slice(b"fnv1a:0123 {\"event\":\"iss");
    std::fs::write(&journal, &torn).unwrap();
    let before = files(&session);
    let e = failed_with(
        &record_message(&session, &rig.start, RunOptions::default()),
        2,
    );
    assert!(e.contains("readings for step 0"), "{e}");
    assert_eq!(files(&session), before);
    // Second review's finding: a new session's journal (the header alone)
    // without its line break could not be read at all.
    let fresh = new_session(dir.path(), "fresh", &[]);
    let header = std::fs::read(fresh.join("events.tdj")).unwrap();
    std::fs::write(fresh.join("events.tdj"), &header[..header.len() - 1]).unwrap();
    succeeded(&record_message(&fresh, &rig.start, RunOptions::default()));
    // The last event complete but for its line break: kept.
    std::fs::write(&journal, &whole[..whole.len() - 1]).unwrap();
    let out = tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    );
    succeeded(&out);
    assert!(stdout(&out).contains("\"step\":1"), "{}", stdout(&out));
    let now = std::fs::read(&journal).unwrap();
    assert!(now.starts_with(&whole), "the start's readings are kept");
}

/// Review finding: a glitch that tripped an interlock stayed in the
/// controller's estimates for good. Discarded, the same step is read
/// again and the glitch is nowhere: the session continues as if it had
/// never happened.
#[test]
fn readings_that_tripped_an_interlock_can_be_discarded_and_read_again() {
    let dir = tempfile::tempdir().unwrap();
    let reference = deploy(dir.path(), 1);
    let session = new_session(dir.path(), "s", &[]);
    let mut rig = Rig::new(1);
    // A glitch at the start, discarded; then the real readings.
    let glitch = with_reading(&rig.start, "load_A_cc2", 1.0e5);
    failed_with(&record_message(&session, &glitch, RunOptions::default()), 1);
    succeeded(&tdeploy(
        &[
            "session",
            "resume",
            &arg(&session),
            "--note",
            "cell A_cc2 reseated",
            "--discard",
        ],
        Path::new("."),
    ));
    assert_eq!(status_json(&session)["phase"], "remeasure");
    succeeded(&record_message(
        &session,
        &rig.start.clone(),
        RunOptions::default(),
    ));
    // A glitch after command 1, discarded; then its real readings.
    let command = stdout(&tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    ));
    let readings = rig.execute(command.trim());
    let glitch = with_reading(&readings, "A4_1_y", 3.0);
    failed_with(&record_message(&session, &glitch, RunOptions::default()), 1);
    succeeded(&tdeploy(
        &[
            "session",
            "resume",
            &arg(&session),
            "--note",
            "target cleaned",
            "--discard",
        ],
        Path::new("."),
    ));
    // Second review's finding: the discarded step's command was issued
    // again (a glue program would have run it twice). The session asks
    // for the sensors to be read again, nothing else.
    assert_eq!(status_json(&session)["phase"], "remeasure");
    let out = tdeploy(
        &["session", "next", &arg(&session), "--json"],
        Path::new("."),
    );
    let m: Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(
        (m["type"].as_str(), m["step"].as_u64()),
        (Some("read_again"), Some(1)),
        "{m}"
    );
    succeeded(&record_message(&session, &readings, RunOptions::default()));
    // From here as deploy: the discarded readings left no trace.
    loop {
        let out = tdeploy(
            &["session", "next", &arg(&session), "--json"],
            Path::new("."),
        );
        let line = stdout(&out).trim().to_string();
        let m: Value = serde_json::from_str(&line).unwrap();
        if m["type"] != "command" {
            break;
        }
        let readings = rig.execute(&line);
        succeeded(&record_message(&session, &readings, RunOptions::default()));
    }
    assert!(files(&session.join("log")) == files(&reference.join("log")));
}

#[test]
fn a_session_keeps_the_interlock_thresholds_it_was_started_with() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let start: Value = serde_json::from_str(&rig.start).unwrap();
    let z = start["readings"]["A4_2_z"].as_f64().unwrap();
    // 10 cm off where the model puts the node: within the default 0.5 m.
    let off = with_reading(&rig.start, "A4_2_z", z + 0.1);
    let default = new_session(dir.path(), "default", &[]);
    succeeded(&record_message(&default, &off, RunOptions::default()));
    let strict = new_session(
        dir.path(),
        "strict",
        &["--interlock-position-offset", "0.05"],
    );
    let e = failed_with(&record_message(&strict, &off, RunOptions::default()), 1);
    assert!(
        e.contains("A4_2_z") && e.contains("plausible within 0.05 m"),
        "{e}"
    );
    let e = failed_with(
        &tdeploy(
            &[
                "session",
                "start",
                "-o",
                &arg(&dir.path().join("bad")),
                "--interlock-sigmas=-1",
            ],
            Path::new("."),
        ),
        2,
    );
    assert!(e.contains("--interlock-sigmas"), "{e}");
    // The thermometer's plausible range: 20 °C is outside −30 to 10 °C
    // (a cold store), inside the default.
    let warm = with_reading(&rig.start, "temperature", 20.0);
    let cold_store = new_session(
        dir.path(),
        "cold",
        &["--interlock-temperature-range", "-30,10"],
    );
    let e = failed_with(
        &record_message(&cold_store, &warm, RunOptions::default()),
        1,
    );
    assert!(
        e.contains("stopped") && e.contains("outside the plausible"),
        "{e}"
    );
    let toml = std::fs::read_to_string(cold_store.join("session.toml")).unwrap();
    assert!(toml.contains("temperature_range_c"), "{toml}");
    let e = failed_with(
        &tdeploy(
            &[
                "session",
                "start",
                "-o",
                &arg(&dir.path().join("bad3")),
                "--temperature",
                "20",
                "--interlock-temperature-range=-30,10",
            ],
            Path::new("."),
        ),
        2,
    );
    assert!(e.contains("--temperature"), "{e}");
    for bad in ["10,-30", "5"] {
        let e = failed_with(
            &tdeploy(
                &[
                    "session",
                    "start",
                    "-o",
                    &arg(&dir.path().join("bad2")),
                    &format!("--interlock-temperature-range={bad}"),
                ],
                Path::new("."),
            ),
            2,
        );
        assert!(e.contains("--interlock-temperature-range"), "{bad}: {e}");
    }
}

/// Second review's finding: `serve` gave no answer to a `resume` that
/// discarded the start's readings.
#[test]
fn serve_answers_a_discarding_resume_with_a_request_to_read_again() {
    let dir = tempfile::tempdir().unwrap();
    let rig = Rig::new(1);
    let session = new_session(dir.path(), "s", &[]);
    let (mut child, mut input, mut output) = serve(&session);
    writeln!(input, "{}", with_reading(&rig.start, "temperature", 95.0)).unwrap();
    let stopped: Value = serde_json::from_str(&read_line(&mut output)).unwrap();
    assert_eq!(stopped["type"], "stopped", "{stopped}");
    writeln!(
        input,
        r#"{{"type":"resume","note":"thermometer replaced","discard":true}}"#
    )
    .unwrap();
    let again: Value = serde_json::from_str(&read_line(&mut output)).unwrap();
    assert_eq!(
        (again["type"].as_str(), again["step"].as_u64()),
        (Some("read_again"), Some(0)),
        "{again}"
    );
    writeln!(input, "{}", rig.start).unwrap();
    let command: Value = serde_json::from_str(&read_line(&mut output)).unwrap();
    assert_eq!(command["type"], "command", "{command}");
    drop(input);
    let _ = child.wait();
}
