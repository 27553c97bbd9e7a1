//! `tdeploy session start|next|record|approve|reject|resume|status|serve|repair`:
//! an online deployment of a real bridge (or a rig), one command at a
//! time ([`tensegrity_deploy::control::session`]; the folder's files in
//! [`tensegrity_deploy::io::session_files`], the protocol of `serve` in
//! [`tensegrity_deploy::io::session_protocol`] and `docs/session.md`).
//!
//! - `start [--problem F] [--policy P] [--model M] [--sensors F]
//!   [--memory FILE [--temperature °C]] [--approve] -o SESSION`: creates
//!   the session folder (refused if it exists); with `--memory`, the
//!   case memory's guidance (the nearest case's learnt approach, adapted
//!   to this fold) is fixed in the session;
//! - `next SESSION`: the pending command, or plans and issues the next
//!   one, or says how the session ended; with approval required it asks
//!   on a terminal for approval (elsewhere, `approve`/`reject` answer);
//! - `record SESSION --measurements F`: the readings of the folded start
//!   (step 0) or of the pending command, executed;
//! - `approve SESSION --step K`, `reject SESSION --step K --reason R`,
//!   `resume SESSION --note N [--discard]`: the operator's answers;
//! - `status SESSION [--json]`: where it stands (reads only);
//! - `serve SESSION --stdio`: the protocol on standard input and output;
//! - `repair SESSION`: removes the torn last line a crash left in the
//!   journal (every mutating command does so itself, saying so).
//!
//! Exit codes: 0 done (a command issued or pending, readings recorded,
//! connected); 1 the session ended without connecting or is stopped by
//! an interlock; 2 bad input or an operation the session refuses (it is
//! left unchanged).

use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::control::{
    gap_reading_sd_m, Guidance, Interlocks, Session, SessionEvent, SessionPhase, SessionRefusal,
    SessionSetup,
};
use tensegrity_deploy::io::journal::Tail;
use tensegrity_deploy::io::json_text;
use tensegrity_deploy::io::log::read_sensors;
use tensegrity_deploy::io::memory_file::read_memory_or_empty;
use tensegrity_deploy::io::model_file::ModelFile;
use tensegrity_deploy::io::model_file::REFERENCE_TEMPERATURE_RANGE_C;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::problem_file::read_problem_for;
use tensegrity_deploy::io::session_files::{
    append_events, create_session, phase_words, read_events, read_events_tolerant,
    read_folded_start, read_guidance, read_meta, read_readings, read_session_sensors,
    repair_events, write_views, NewSession, SessionMeta, SESSION_FORMAT,
};
use tensegrity_deploy::io::session_protocol::{
    parse_in_message, InMessage, OutMessage, SessionStatus, PROTOCOL,
};
use tensegrity_deploy::learn::{adapt, Advice, CaseConditions, EndStateCache, FeatureScales};
use tensegrity_deploy::model::{DeploymentState, ForwardModel};
use tensegrity_deploy::plan::{DeploymentProblem, PlanContext, Policy};
use tensegrity_deploy::sim::{standard_sensors, Sensor};

use super::inputs::{
    absolute, controller_model_file, planning_model, policy_or_default, problem_or_default,
};
use super::words::mm;
use super::{value, Outcome};

fn session_arg() -> Arg {
    Arg::new("session")
        .required(true)
        .value_parser(value_parser!(PathBuf))
        .help("Session folder (made by `tdeploy session start`)")
}

fn step_arg() -> Arg {
    Arg::new("step")
        .long("step")
        .required(true)
        .value_parser(value_parser!(usize))
        .help("The pending command's number (as `next` printed it)")
}

/// The `session` subcommand's arguments.
pub fn command() -> Command {
    Command::new("session")
        .about("Drive a real bridge (or a rig) one command at a time: a crash-safe session on disk, with interlocks and operator approval")
        .subcommand_required(true)
        .subcommand(
            Command::new("start")
                .about("Create a session folder: the model, problem, policy and sensors it runs with, and an empty journal")
                .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file the controller plans on. Default: the reference bridge without friction"))
                .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file (default: policies/qp.toml's settings, built in)"))
                .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (default: fold 0.40 m, 30 mm connection, documented limits)"))
                .arg(Arg::new("sensors").long("sensors").value_parser(value_parser!(PathBuf)).help("Sensor layout (sensors.csv of the log format). Default: the standard layout (load cells on A_cc0–A_cc3, midspan node positions, thermometer)"))
                .arg(Arg::new("memory").long("memory").value_parser(value_parser!(PathBuf)).help("Case memory (a memory file of `tdeploy cycles`) to take the learnt approach from: the nearest case adapted to this fold and temperature when the session is created (needs a policy with a [memory] section, e.g. policies/memory.toml)"))
                .arg(Arg::new("temperature").long("temperature").value_parser(value_parser!(f64)).help("Air temperature at the bridge, °C: with --memory, the case is retrieved for it"))
                .arg(Arg::new("interlock-sigmas").long("interlock-sigmas").value_parser(value_parser!(f64)).help("Standard deviations (of a load cell's noise and the bias estimate) beyond its member's limit at which a reading stops the session, in (0, 10]. Default 3"))
                .arg(Arg::new("interlock-position-offset").long("interlock-position-offset").value_parser(value_parser!(f64)).help("Largest distance of a position reading from where the model puts its node before the session stops, m, in (0, 10]. Default 0.5"))
                .arg(Arg::new("interlock-temperature-range").long("interlock-temperature-range").value_name("LOW,HIGH").allow_hyphen_values(true).value_delimiter(',').num_args(1).value_parser(value_parser!(f64)).help("Plausible air temperature, °C, as LOW,HIGH: a thermometer reading outside it stops the session (the thermometer, not the weather, is at fault). Default -40,60"))
                .arg(Arg::new("approve").long("approve").action(ArgAction::SetTrue).help("Every command needs an operator's approval before it may be executed"))
                .arg(Arg::new("out").long("out").short('o').required(true).value_parser(value_parser!(PathBuf)).help("The new session folder (refused if it exists)")),
        )
        .subcommand(
            Command::new("next")
                .about("Print the pending command, or plan and issue the next one, or say how the session ended")
                .arg(session_arg())
                .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).help("Print the protocol's message (a command, stopped or ended) instead of words; never prompts")),
        )
        .subcommand(
            Command::new("record")
                .about("Record the readings taken after the pending command was executed (or of the folded start, step 0)")
                .arg(session_arg())
                .arg(Arg::new("measurements").long("measurements").required(true).value_parser(value_parser!(PathBuf)).help("Readings file: CSV `step,sensor,value`, or one JSON measurements message")),
        )
        .subcommand(Command::new("approve").about("Approve the pending command").arg(session_arg()).arg(step_arg()))
        .subcommand(
            Command::new("reject")
                .about("Reject the pending command: it is logged with the reason and the controller plans again")
                .arg(session_arg())
                .arg(step_arg())
                .arg(Arg::new("reason").long("reason").required(true).help("Why, in words (logged)")),
        )
        .subcommand(
            Command::new("resume")
                .about("Resume a session an interlock stopped")
                .arg(session_arg())
                .arg(Arg::new("note").long("note").required(true).help("The operator's note (logged): what was checked"))
                .arg(Arg::new("discard").long("discard").action(ArgAction::SetTrue).help("Discard the readings that tripped the interlock (a sensor fault, fixed): the same step's readings are recorded again. Without it the controller takes them as they are")),
        )
        .subcommand(
            Command::new("status")
                .about("Where the session stands (reads only)")
                .arg(session_arg())
                .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).help("Print status.json's content")),
        )
        .subcommand(
            Command::new("serve")
                .about("Speak the session protocol (JSON lines) on standard input and output")
                .arg(session_arg())
                .arg(Arg::new("stdio").long("stdio").action(ArgAction::SetTrue).help("Use standard input and output (the one transport; required)")),
        )
        .subcommand(
            Command::new("repair")
                .about("Remove the torn last line a crash left in the journal")
                .arg(session_arg()),
        )
}

/// Options of `tdeploy session`.
#[derive(Debug, Clone)]
pub enum Options {
    /// `start`.
    Start(StartInputs),
    /// `next`.
    Next {
        /// The session folder.
        dir: PathBuf,
        /// Print the protocol message.
        json: bool,
    },
    /// `record`.
    Record {
        /// The session folder.
        dir: PathBuf,
        /// The readings file.
        measurements: PathBuf,
    },
    /// `approve`.
    Approve {
        /// The session folder.
        dir: PathBuf,
        /// The command.
        step: usize,
    },
    /// `reject`.
    Reject {
        /// The session folder.
        dir: PathBuf,
        /// The command.
        step: usize,
        /// Why.
        reason: String,
    },
    /// `resume`.
    Resume {
        /// The session folder.
        dir: PathBuf,
        /// The operator's note.
        note: String,
        /// Discard the readings that tripped the interlock.
        discard: bool,
    },
    /// `status`.
    Status {
        /// The session folder.
        dir: PathBuf,
        /// Print JSON.
        json: bool,
    },
    /// `serve --stdio`.
    Serve {
        /// The session folder.
        dir: PathBuf,
    },
    /// `repair`.
    Repair {
        /// The session folder.
        dir: PathBuf,
    },
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let dir = |a: &ArgMatches| value::<PathBuf>(a, "session");
        Ok(match m.subcommand() {
            Some(("start", a)) => Options::Start(StartInputs {
                model: a.get_one::<PathBuf>("model").cloned(),
                policy: a.get_one::<PathBuf>("policy").cloned(),
                problem: a.get_one::<PathBuf>("problem").cloned(),
                sensors: a.get_one::<PathBuf>("sensors").cloned(),
                memory: a.get_one::<PathBuf>("memory").cloned(),
                temperature_c: a.get_one::<f64>("temperature").copied(),
                approve: a.get_flag("approve"),
                interlocks: {
                    let mut i = Interlocks::default();
                    if let Some(k) = a.get_one::<f64>("interlock-sigmas") {
                        i.limit_sigmas = *k;
                    }
                    if let Some(d) = a.get_one::<f64>("interlock-position-offset") {
                        i.max_position_offset_m = *d;
                    }
                    if let Some(range) = a.get_many::<f64>("interlock-temperature-range") {
                        let range: Vec<f64> = range.copied().collect();
                        let [low, high] = range[..] else {
                            bail!(
                                "--interlock-temperature-range: give LOW,HIGH (two numbers, °C), got {} number(s)",
                                range.len()
                            );
                        };
                        i.temperature_range_c = (low, high);
                    }
                    if let Err((field, why)) = i.validate() {
                        let flag = match field {
                            "limit_sigmas" => "--interlock-sigmas",
                            "temperature_range_c" => "--interlock-temperature-range",
                            _ => "--interlock-position-offset",
                        };
                        bail!("{flag}: {why}");
                    }
                    // The session's own temperature is a reading too.
                    if let Some(t) = a.get_one::<f64>("temperature") {
                        let (low, high) = i.temperature_range_c;
                        if !(low..=high).contains(t) {
                            bail!("--temperature: {t} °C is outside the plausible range {low} to {high} °C (--interlock-temperature-range)");
                        }
                    }
                    i
                },
                out: value(a, "out")?,
            }),
            Some(("next", a)) => Options::Next {
                dir: dir(a)?,
                json: a.get_flag("json"),
            },
            Some(("record", a)) => Options::Record {
                dir: dir(a)?,
                measurements: value(a, "measurements")?,
            },
            Some(("approve", a)) => Options::Approve {
                dir: dir(a)?,
                step: value(a, "step")?,
            },
            Some(("reject", a)) => Options::Reject {
                dir: dir(a)?,
                step: value(a, "step")?,
                reason: value(a, "reason")?,
            },
            Some(("resume", a)) => Options::Resume {
                dir: dir(a)?,
                note: value(a, "note")?,
                discard: a.get_flag("discard"),
            },
            Some(("status", a)) => Options::Status {
                dir: dir(a)?,
                json: a.get_flag("json"),
            },
            Some(("serve", a)) => {
                if !a.get_flag("stdio") {
                    bail!("session serve: --stdio is required (standard input and output are the one transport)");
                }
                Options::Serve { dir: dir(a)? }
            }
            Some(("repair", a)) => Options::Repair { dir: dir(a)? },
            Some((other, _)) => bail!("session: unknown action `{other}`"),
            None => bail!("session: an action is required (start, next, record, approve, reject, resume, status, serve, repair)"),
        })
    }
}

/// What a session runs with, loaded from its folder.
struct Inputs {
    meta: SessionMeta,
    model: ForwardModel,
    problem: DeploymentProblem,
    policy: Policy,
    sensors: Vec<Sensor>,
    guidance: Guidance,
    folded_start: Option<DeploymentState>,
    /// What ends the journal after its last complete line, as read:
    /// repaired before the next append, never on a refusal.
    tail: std::cell::Cell<Tail>,
    /// The session's lock, held while a command may write (`None`: a
    /// command that only reads).
    _lock: Option<std::fs::File>,
}

/// How long a command waits for another process to release the session
/// before it gives up: longer than any one command takes (50 ms), far
/// shorter than a person waits.
const LOCK_WAIT: std::time::Duration = std::time::Duration::from_secs(3);

/// Takes the session's exclusive lock (`session.lock`, released when the
/// process ends, however it ends): one process writes a session at a
/// time, and `serve` holds it for its whole life.
fn lock_session(dir: &Path) -> Result<std::fs::File> {
    let path = dir.join("session.lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    let clock = std::time::Instant::now();
    loop {
        match file.try_lock() {
            Ok(()) => return Ok(file),
            Err(std::fs::TryLockError::WouldBlock) if clock.elapsed() < LOCK_WAIT => {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            Err(std::fs::TryLockError::WouldBlock) => bail!(
                "{}: in use by another tdeploy process (a `session serve`?); the session is unchanged",
                dir.display()
            ),
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("{}: cannot lock", path.display()))
            }
        }
    }
}

impl Inputs {
    /// The session's inputs; with `lock`, the session locked for writing
    /// first.
    fn load(dir: &Path, lock: bool) -> Result<Inputs> {
        if !dir.join("session.toml").is_file() {
            bail!(
                "{}: not a session folder (no session.toml; `tdeploy session start -o {}` makes one)",
                dir.display(),
                dir.display()
            );
        }
        let lock = if lock { Some(lock_session(dir)?) } else { None };
        let meta = read_meta(dir)?;
        let model_path = dir.join("model.toml");
        let model = planning_model(Some(&model_path), Default::default())?;
        if model.structure().name != meta.structure {
            bail!(
                "{}: structure: the session is on \"{}\", its model.toml on \"{}\"",
                dir.join("session.toml").display(),
                meta.structure,
                model.structure().name
            );
        }
        let motors = model.structure().continuous_cables.len();
        let problem = read_problem_for(&dir.join("problem.toml"), motors)?;
        let policy = read_policy(&dir.join("policy.toml"))?;
        let sensors = read_session_sensors(dir, model.structure())?;
        let start_payout_m = problem.motor_limits(motors)?.start_payout_m;
        let folded_start = read_folded_start(
            dir,
            model.structure(),
            &start_payout_m,
            model.cable_seat_radius_m().is_some(),
        )?;
        let guidance = read_guidance(dir, motors)?;
        Ok(Inputs {
            meta,
            model,
            problem,
            policy,
            sensors,
            guidance,
            folded_start,
            tail: std::cell::Cell::new(Tail::Whole),
            _lock: lock,
        })
    }

    fn setup(&self) -> SessionSetup<'_> {
        SessionSetup {
            model: &self.model,
            problem: &self.problem,
            policy: &self.policy,
            sensors: &self.sensors,
            guidance: &self.guidance,
            folded_start: self.folded_start.as_ref(),
            approval_required: self.meta.approval_required,
            interlocks: self.meta.interlocks,
        }
    }

    fn start_payout_m(&self) -> Result<Vec<f64>> {
        Ok(self
            .problem
            .motor_limits(self.model.structure().continuous_cables.len())?
            .start_payout_m)
    }
}

/// The session rebuilt from its journal. With `tolerant`, as a repair
/// would leave the journal (a torn last line, an append a crash
/// interrupted and never reported, left out; the file is repaired only
/// before the next append, so that a refused input changes nothing);
/// without, a torn line is an error naming it.
fn open<'a>(dir: &Path, inputs: &'a Inputs, tolerant: bool) -> Result<Session<'a>> {
    let events = if tolerant {
        let (events, tail) = read_events_tolerant(dir)?;
        inputs.tail.set(tail);
        events
    } else {
        read_events(dir)?
    };
    Session::replay(inputs.setup(), &events)
        .with_context(|| format!("{}: the journal", dir.join("events.tdj").display()))
}

/// Repairs the journal's tail if the read found one to repair, saying so.
fn repair_tail(dir: &Path, inputs: &Inputs) -> Result<()> {
    if inputs.tail.get() == Tail::Whole {
        return Ok(());
    }
    let (tail, _) = repair_events(dir)?;
    let path = dir.join("events.tdj");
    match tail {
        Tail::Torn(n) => eprintln!(
            "note: {}: removed the torn last line ({n} bytes) an interrupted append left; it was never reported",
            path.display()
        ),
        Tail::MissingNewline => eprintln!(
            "note: {}: the last event lacked its line break; added",
            path.display()
        ),
        Tail::Whole => {}
    }
    inputs.tail.set(Tail::Whole);
    Ok(())
}

/// The pending command's predicted gaps (the controller's own decision,
/// held since it was issued or re-planned on replay).
fn predicted_gaps(session: &mut Session) -> Option<Vec<f64>> {
    if !matches!(session.phase(), SessionPhase::Pending { .. }) {
        return None;
    }
    session.pending_proposal().map(|p| p.predicted_gaps_m)
}

/// Stores `events` (one append) and rewrites the views.
fn store(
    dir: &Path,
    inputs: &Inputs,
    session: &mut Session,
    events: &[SessionEvent],
) -> Result<SessionStatus> {
    if !events.is_empty() {
        repair_tail(dir, inputs)?;
    }
    append_events(dir, events)?;
    views(dir, inputs, session)
}

/// Rewrites the views; returns the status.
fn views(dir: &Path, inputs: &Inputs, session: &mut Session) -> Result<SessionStatus> {
    let gaps = predicted_gaps(session);
    let status = SessionStatus::of(session, gaps);
    write_views(dir, session, &status, &inputs.start_payout_m()?)?;
    Ok(status)
}

/// A refusal as the command's outcome: a stopped or ended session is
/// the goal missed (exit 1); anything else is input refused (exit 2).
fn refused(e: SessionRefusal, dir: &Path) -> Result<Outcome> {
    match e {
        SessionRefusal::Stopped { .. } | SessionRefusal::Ended { .. } => {
            Ok(Outcome::GoalMissed(format!("{}: {e}", dir.display())))
        }
        e => bail!("{}: {e}; the session is unchanged", dir.display()),
    }
}

/// Runs `tdeploy session`.
pub fn run(o: &Options) -> Result<Outcome> {
    match o {
        Options::Start(inputs) => start(inputs),
        Options::Next { dir, json } => next(dir, *json),
        Options::Record { dir, measurements } => record(dir, measurements),
        Options::Approve { dir, step } => answer(dir, |s| s.approve(*step)),
        Options::Reject { dir, step, reason } => answer(dir, |s| s.reject(*step, reason)),
        Options::Resume { dir, note, discard } => answer(dir, |s| s.resume(note, *discard)),
        Options::Status { dir, json } => status(dir, *json),
        Options::Serve { dir } => serve(dir),
        Options::Repair { dir } => {
            let _lock = lock_session(dir)?;
            let (tail, events) = repair_events(dir)?;
            let n = events.len();
            match tail {
                Tail::Whole => say!("{}: whole, nothing to repair ({n} events)", dir.display()),
                Tail::MissingNewline => say!(
                    "{}: the last event lacked its line break; added ({n} events)",
                    dir.display()
                ),
                Tail::Torn(bytes) => say!(
                    "{}: dropped the torn last line ({bytes} bytes); {n} complete events kept",
                    dir.display()
                ),
            }
            Ok(Outcome::GoalReached)
        }
    }
}

/// What `session start` is given: the files, conditions and settings of
/// the new session.
#[derive(Debug, Clone)]
pub struct StartInputs {
    model: Option<PathBuf>,
    policy: Option<PathBuf>,
    problem: Option<PathBuf>,
    sensors: Option<PathBuf>,
    memory: Option<PathBuf>,
    temperature_c: Option<f64>,
    approve: bool,
    interlocks: Interlocks,
    out: PathBuf,
}

/// The guidance the case memory at `path` gives a session of `setup`
/// from its `folded` start, with the case it came from in words.
fn memory_guidance(
    path: &Path,
    setup: &SessionSetup,
    folded: &DeploymentState,
    temperature_c: Option<f64>,
) -> Result<(Guidance, String)> {
    let Some(settings) = &setup.policy.memory else {
        bail!("--memory: the policy has no [memory] section (policies/memory.toml has one)");
    };
    if !path.is_file() {
        bail!("--memory: {}: no such memory file", path.display());
    }
    let s = setup.model.structure();
    let memory = read_memory_or_empty(path, s.continuous_cables.len(), s.midspan_pairs.len())?;
    let context = PlanContext::new(setup.model, setup.problem, setup.policy, folded)?;
    let conditions = CaseConditions {
        temperature_c,
        fold_m: folded.payout_m.clone(),
        start_gap_m: None,
        payout_scale: Vec::new(),
    };
    let advice = adapt(
        &memory,
        &conditions,
        &context,
        folded,
        settings,
        &FeatureScales::default(),
        gap_reading_sd_m(s, setup.sensors),
        &mut EndStateCache::default(),
    )
    .with_context(|| format!("--memory {}", path.display()))?;
    Ok(match advice {
        Advice::Empty => (
            Guidance::default(),
            format!("memory {}: empty, no guidance", path.display()),
        ),
        Advice::Declined(why) => (
            Guidance::default(),
            format!("memory {}: no guidance: {why}", path.display()),
        ),
        Advice::Guided(a) => {
            let words = format!(
                "memory {}: case {} (line {} of the file; distance {:.2}), {} feedforward commands",
                path.display(),
                a.case_index,
                a.case_index + 2,
                a.distance,
                a.guidance.feedforward_m.len()
            );
            (a.guidance, words)
        }
    })
}

fn start(inputs: &StartInputs) -> Result<Outcome> {
    let StartInputs {
        model,
        policy,
        problem,
        sensors,
        memory,
        temperature_c,
        approve,
        interlocks,
        out,
    } = inputs;
    let (model, policy, problem) = (model.as_deref(), policy.as_deref(), problem.as_deref());
    let (approve, interlocks, temperature_c) = (*approve, *interlocks, *temperature_c);
    if let Some(t) = temperature_c {
        if let Err(m) = REFERENCE_TEMPERATURE_RANGE_C.check(t) {
            bail!("--temperature: {m}");
        }
    }
    if out.exists() {
        bail!(
            "{}: already exists; a session folder is never overwritten (choose a new one)",
            out.display()
        );
    }
    let (model_file, model_words) = controller_model_file(model)?;
    let model_file: ModelFile = absolute(model_file)?;
    let forward = planning_model(model, Default::default())?;
    let structure = forward.structure();
    let policy = policy_or_default(policy)?;
    let problem = problem_or_default(problem, structure.continuous_cables.len())?;
    let sensors = match sensors {
        Some(p) => read_sensors(p, structure)?,
        None => standard_sensors(structure),
    };
    let guidance = Guidance::default();
    let setup = SessionSetup {
        model: &forward,
        problem: &problem,
        policy: &policy,
        sensors: &sensors,
        guidance: &guidance,
        folded_start: None,
        approval_required: approve,
        interlocks,
    };
    let folded_start = Session::check_setup(&setup)?;
    let guidance = match memory {
        Some(path) => Some(memory_guidance(path, &setup, &folded_start, temperature_c)?),
        None => None,
    };
    let meta = SessionMeta {
        format: SESSION_FORMAT.into(),
        structure: structure.name.clone(),
        approval_required: approve,
        created_by: format!("tdeploy {}", env!("CARGO_PKG_VERSION")),
        inputs_fingerprint: String::new(),
        interlocks,
    };
    create_session(
        out,
        &NewSession {
            meta,
            model_file: &model_file,
            problem: &problem,
            policy: &policy,
            sensors: &sensors,
            structure,
            folded_start: &folded_start,
            guidance: guidance.as_ref().map(|(g, _)| g),
        },
    )?;
    say!(
        "session {}: policy {} ({}), controller's model {model_words}, {} sensors{}",
        out.display(),
        policy.name,
        policy.planner.as_str(),
        sensors.len(),
        if approve {
            ", every command needs approval"
        } else {
            ""
        }
    );
    if let Some((_, words)) = &guidance {
        say!("{words}");
    }
    say!(
        "next: fold the bridge to the start ({} m of payout), then `tdeploy session record {} --measurements F` with its readings as step 0",
        problem
            .motor_limits(structure.continuous_cables.len())?
            .start_payout_m
            .iter()
            .map(|p| format!("{p}"))
            .collect::<Vec<_>>()
            .join(", "),
        out.display()
    );
    Ok(Outcome::GoalReached)
}

/// The words for a phase after `next`, and its outcome.
fn phase_outcome(phase: &SessionPhase) -> Outcome {
    match phase {
        SessionPhase::Ended { status, words } if status != "connected" => {
            Outcome::GoalMissed(format!("the session ended: {words}"))
        }
        SessionPhase::Stopped { reason, .. } => {
            Outcome::GoalMissed(format!("the session is stopped: {reason}"))
        }
        _ => Outcome::GoalReached,
    }
}

fn next(dir: &Path, json: bool) -> Result<Outcome> {
    let inputs = Inputs::load(dir, true)?;
    let mut session = open(dir, &inputs, true)?;
    if let SessionPhase::Ended { .. } | SessionPhase::Stopped { .. } = session.phase() {
        // Not a refusal: the question has an answer. The views are
        // rewritten, in case a crash left them behind the journal.
        let status = views(dir, &inputs, &mut session)?;
        if json {
            say!("{}", phase_message(session.phase(), &[], &status).line());
        } else {
            say!("{}", phase_words(session.phase()));
        }
        return Ok(phase_outcome(session.phase()));
    }
    let events = match session.next_command() {
        Ok(events) => events,
        Err(e) if json => {
            let text = e.to_string();
            say!(
                "{}",
                OutMessage::Error {
                    field: "phase",
                    message: &text
                }
                .line()
            );
            return refused(e, dir);
        }
        Err(e) => return refused(e, dir),
    };
    let status = store(dir, &inputs, &mut session, &events)?;
    let motors: Vec<&str> = inputs
        .model
        .structure()
        .continuous_cables
        .iter()
        .map(|c| c.id.as_str())
        .collect();
    if json {
        say!(
            "{}",
            phase_message(session.phase(), &motors, &status).line()
        );
        return Ok(phase_outcome(session.phase()));
    }
    match session.phase().clone() {
        SessionPhase::Pending {
            step,
            command_m,
            cleared,
        } => {
            say!("command {step} (payout change per motor, mm; + pays out):");
            for (id, u) in motors.iter().zip(&command_m) {
                say!("  {id:<8} {:+.2}", 1e3 * u);
            }
            if let Some(g) = &status.pending_predicted_gaps_m {
                say!(
                    "predicted largest gap after it: {} mm",
                    mm(g.iter().copied().reduce(f64::max))
                );
            }
            say!(
                "also in {} and {}",
                dir.join("pending.csv").display(),
                dir.join("pending.json").display()
            );
            if !cleared {
                return approval_prompt(dir, &inputs, &mut session, step);
            }
            say!(
                "execute it, then `tdeploy session record {} --measurements F` with the readings of step {step}",
                dir.display()
            );
        }
        phase => say!("{}", phase_words(&phase)),
    }
    Ok(phase_outcome(session.phase()))
}

/// Asks on a terminal for approval of command `step`; elsewhere says how
/// to answer.
fn approval_prompt(
    dir: &Path,
    inputs: &Inputs,
    session: &mut Session,
    step: usize,
) -> Result<Outcome> {
    if !std::io::stdin().is_terminal() {
        say!(
            "command {step} needs approval: `tdeploy session approve {d} --step {step}` or `tdeploy session reject {d} --step {step} --reason R`",
            d = dir.display()
        );
        return Ok(Outcome::GoalReached);
    }
    print!(
        "approve command {step}? [y = approve, anything else = reject; the text is the reason] "
    );
    std::io::stdout().flush().ok();
    let mut answer = String::new();
    std::io::stdin()
        .read_line(&mut answer)
        .context("reading the answer")?;
    let answer = answer.trim();
    let events = if answer.eq_ignore_ascii_case("y") || answer.eq_ignore_ascii_case("yes") {
        session.approve(step)
    } else {
        let reason = if answer.is_empty() {
            "rejected at the prompt"
        } else {
            answer
        };
        session.reject(step, reason)
    };
    let events = match events {
        Ok(e) => e,
        Err(e) => return refused(e, dir),
    };
    store(dir, inputs, session, &events)?;
    say!("{}", phase_words(session.phase()));
    Ok(Outcome::GoalReached)
}

fn record(dir: &Path, measurements: &Path) -> Result<Outcome> {
    let inputs = Inputs::load(dir, true)?;
    let mut session = open(dir, &inputs, true)?;
    let readings = read_readings(measurements, &inputs.sensors)?;
    let events = match session.record(readings.step, readings.values) {
        Ok(e) => e,
        Err(e) => return refused(e, dir),
    };
    let status = store(dir, &inputs, &mut session, &events)?;
    say!(
        "step {} recorded; largest measured gap {} mm",
        readings.step,
        mm(status.last_largest_measured_gap_m)
    );
    say!("{}", phase_words(session.phase()));
    Ok(phase_outcome(session.phase()))
}

fn answer(
    dir: &Path,
    op: impl FnOnce(&mut Session) -> Result<Vec<SessionEvent>, SessionRefusal>,
) -> Result<Outcome> {
    let inputs = Inputs::load(dir, true)?;
    let mut session = open(dir, &inputs, true)?;
    let events = match op(&mut session) {
        Ok(e) => e,
        Err(e) => return refused(e, dir),
    };
    store(dir, &inputs, &mut session, &events)?;
    say!("{}", phase_words(session.phase()));
    Ok(Outcome::GoalReached)
}

fn status(dir: &Path, json: bool) -> Result<Outcome> {
    let inputs = Inputs::load(dir, false)?;
    let mut session = open(dir, &inputs, false)?;
    let gaps = predicted_gaps(&mut session);
    let status = SessionStatus::of(&session, gaps);
    if json {
        say!("{}", json_text(&status)?.trim_end());
    } else {
        say!(
            "session {}: {}",
            dir.display(),
            phase_words(session.phase())
        );
        say!(
            "{} commands executed; largest measured gap at the last step {} mm",
            status.commands_executed,
            mm(status.last_largest_measured_gap_m)
        );
        if !status.estimated_payout_scale.is_empty() {
            let s: Vec<String> = status
                .estimated_payout_scale
                .iter()
                .map(|s| format!("{:+.1} %", 100.0 * s))
                .collect();
            say!("estimated payout scale per half: {}", s.join(", "));
        }
        if let Some((b, sd)) = status.estimated_load_cell_bias_n {
            say!("estimated load cells' common bias: {b:.1} ± {sd:.1} N");
        }
        if !status.diverged_commands.is_empty() {
            say!(
                "commands this version would not have issued (the journal was written by another): {:?}",
                status.diverged_commands
            );
        }
    }
    Ok(phase_outcome(session.phase()))
}

/// The protocol message for where the session stands after a change.
fn phase_message<'a>(
    phase: &'a SessionPhase,
    motors: &[&'a str],
    status: &'a SessionStatus,
) -> OutMessage<'a> {
    match phase {
        SessionPhase::Pending {
            step,
            command_m,
            cleared,
        } => OutMessage::Command {
            step: *step,
            payout_change_m: command_m,
            motors: motors.to_vec(),
            cleared: *cleared,
            predicted_gaps_m: status.pending_predicted_gaps_m.as_deref(),
        },
        SessionPhase::Stopped { step, reason } => OutMessage::Stopped {
            step: *step,
            reason,
        },
        SessionPhase::Ended { status, words } => OutMessage::Ended { status, words },
        SessionPhase::Remeasure { step } => OutMessage::ReadAgain {
            step: *step,
            reason: "the readings sent were discarded by an operator; no command is repeated",
        },
        _ => OutMessage::Status { status },
    }
}

/// `serve --stdio`: the protocol (see the module notes of
/// `io::session_protocol`). The session is kept in memory between
/// messages; every change is stored before it is answered.
fn serve(dir: &Path) -> Result<Outcome> {
    let inputs = Inputs::load(dir, true)?;
    let mut session = open(dir, &inputs, true)?;
    let structure = inputs.model.structure();
    let motors: Vec<&str> = structure
        .continuous_cables
        .iter()
        .map(|c| c.id.as_str())
        .collect();
    let sensors: Vec<&str> = inputs.sensors.iter().map(|s| s.id.as_str()).collect();
    let out = send;
    out(OutMessage::Hello {
        protocol: PROTOCOL,
        role: "session",
        phase: Some(session.phase().label()),
        motors: motors.clone(),
        sensors,
    })?;
    // Where it stands: plan if ready, say what is pending or how it ended.
    let advance = |session: &mut Session, mut events: Vec<SessionEvent>| -> Result<bool> {
        if matches!(session.phase(), SessionPhase::Ready { .. }) {
            match session.next_command() {
                Ok(more) => events.extend(more),
                Err(e) => bail!("{e}"),
            }
        }
        let status = store(dir, &inputs, session, &events)?;
        match session.phase() {
            SessionPhase::AwaitingStart => {}
            phase => out(phase_message(phase, &motors, &status))?,
        }
        Ok(matches!(session.phase(), SessionPhase::Ended { .. }))
    };
    if advance(&mut session, Vec::new())? {
        return Ok(phase_outcome(session.phase()));
    }
    for line in std::io::stdin().lock().lines() {
        let line = line.context("standard input")?;
        if line.trim().is_empty() {
            continue;
        }
        let message = match parse_in_message(&line, &inputs.sensors) {
            Ok(m) => m,
            Err(e) => {
                out(OutMessage::Error {
                    field: &e.field,
                    message: &e.message,
                })?;
                continue;
            }
        };
        let result = match message {
            InMessage::Measurements(r) => session.record(r.step, r.values),
            InMessage::Approve { step } => session.approve(step),
            InMessage::Reject { step, reason } => session.reject(step, &reason),
            InMessage::Resume { note, discard } => session.resume(&note, discard),
            InMessage::Status => {
                let gaps = predicted_gaps(&mut session);
                let status = SessionStatus::of(&session, gaps);
                out(OutMessage::Status { status: &status })?;
                continue;
            }
            InMessage::Command { .. } | InMessage::ReadAgain { .. } => {
                out(OutMessage::Error {
                    field: "type",
                    message: "commands and requests to read again are the controller's to send, not to receive",
                })?;
                continue;
            }
        };
        match result {
            Ok(events) => {
                if advance(&mut session, events)? {
                    break;
                }
            }
            Err(e) => {
                let text = format!("{e}; the session is unchanged");
                out(OutMessage::Error {
                    field: refusal_field(&e),
                    message: &text,
                })?;
            }
        }
    }
    Ok(phase_outcome(session.phase()))
}

/// Sends one protocol message on standard output, flushed (a rig program
/// waits for it): `serve`'s and `rig`'s one way to speak.
pub(super) fn send(m: OutMessage) -> Result<()> {
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{}", m.line())
        .and_then(|()| stdout.flush())
        .context("standard output")
}

/// The message field a refusal is about.
fn refusal_field(e: &SessionRefusal) -> &'static str {
    match e {
        SessionRefusal::WrongStep { .. }
        | SessionRefusal::NotApproved { .. }
        | SessionRefusal::NoSuchPending { .. } => "step",
        SessionRefusal::BadReading { .. }
        | SessionRefusal::WrongReadingCount { .. }
        | SessionRefusal::NoReadings => "readings",
        _ => "type",
    }
}
