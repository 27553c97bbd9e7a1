//! Running the `tdeploy` binary and checking how it ended: exit code 0
//! (done), 1 (ran, goal not reached) or 2 (bad input or I/O), with one
//! error line and never a panic.

use std::io::Read;
use std::path::Path;
use std::process::{Command, ExitStatus, Output, Stdio};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Hang guard for the runs of inputs that once hung the binary
/// (`tests/hardening.rs`): a run still going after this long is killed and
/// fails its test. It only tells a hang from an answer; it is not a speed
/// check (speed lives in `benches/`). The slowest guarded run, `diagnose
/// --rounds 1` on a small lab log, takes about 2 s, the others well under
/// one, so the guard is 60× the longest normal run; the hangs it catches
/// ran for ever (the were stopped after 60 s).
pub const HANG_GUARD: Duration = Duration::from_secs(120);

/// How to run the binary beyond its arguments and folder.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// `RAYON_NUM_THREADS` for the run; inherited from the test when `None`.
    pub rayon_threads: Option<usize>,
    /// Kill the run and fail the test past this time ([`HANG_GUARD`]); no
    /// limit when `None`.
    pub hang_guard: Option<Duration>,
}

impl RunOptions {
    /// Runs with the [`HANG_GUARD`].
    pub const fn hang_guarded() -> Self {
        RunOptions {
            rayon_threads: None,
            hang_guard: Some(HANG_GUARD),
        }
    }

    /// Runs with `RAYON_NUM_THREADS=threads`.
    pub const fn rayon_threads(threads: usize) -> Self {
        RunOptions {
            rayon_threads: Some(threads),
            hang_guard: None,
        }
    }
}

/// Runs `tdeploy args` in `dir`.
pub fn tdeploy(args: &[&str], dir: &Path) -> Output {
    tdeploy_with(args, dir, RunOptions::default())
}

/// Runs `tdeploy args` in `dir` with `options`.
pub fn tdeploy_with(args: &[&str], dir: &Path, options: RunOptions) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_tdeploy"));
    command.args(args).current_dir(dir);
    if let Some(threads) = options.rayon_threads {
        command.env("RAYON_NUM_THREADS", threads.to_string());
    }
    match options.hang_guard {
        None => command.output().expect("tdeploy runs"),
        Some(deadline) => output_within(command, deadline, args),
    }
}

/// The output of `command`, killing it (and failing) past `deadline`. The
/// pipes are drained while it runs, so that a run that writes much cannot
/// block on a full pipe and pass for a hang.
fn output_within(mut command: Command, deadline: Duration, args: &[&str]) -> Output {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tdeploy starts");
    let stdout = drain(child.stdout.take().expect("piped stdout"));
    let stderr = drain(child.stderr.take().expect("piped stderr"));
    let start = Instant::now();
    let status: ExitStatus = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("tdeploy {args:?} still running after {deadline:?}: a hang");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
    }
}

/// Reads `pipe` to its end on a thread of its own.
fn drain(mut pipe: impl Read + Send + 'static) -> JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        pipe.read_to_end(&mut bytes).unwrap();
        bytes
    })
}

/// What the run printed on stderr.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).to_string()
}

/// What the run printed on stdout.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// Checks that the run succeeded (exit 0), showing its stderr otherwise.
pub fn succeeded(out: &Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// Checks that the run ended with `code`, exactly one line on stderr and
/// no panic; returns that line (without its line break).
pub fn failed_with(out: &Output, code: i32) -> String {
    let e = stderr(out);
    assert_eq!(out.status.code(), Some(code), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
    e.trim_end().to_string()
}
