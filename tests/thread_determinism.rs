//! The same inputs give the same bytes at 1, 2 and 4 threads: `lab`,
//! `compare`, `diagnose` and `simulate` (issue "harden": what held and
//! must keep holding). `deploy` and `evaluate` have their own tests.

mod common;

use common::cli::{stderr, stdout, tdeploy_with, RunOptions};
use common::files::files;
use common::repo_arg;

#[test]
fn lab_compare_diagnose_and_simulate_give_the_same_bytes_at_1_2_and_4_threads() {
    let (truth, baseline) = (
        repo_arg("experiments/lab/truth-friction.toml"),
        repo_arg("experiments/lab/baseline.toml"),
    );
    let run = |threads: usize| -> (Vec<(String, Vec<u8>)>, Vec<u8>) {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let steps: [&[&str]; 4] = [
            &[
                "lab",
                &truth,
                "-o",
                "log",
                "--amplitudes",
                "0.01,0.05",
                "--steps",
                "2",
                "--seed",
                "3",
            ],
            &["compare", &baseline, "log", "-o", "compare"],
            &[
                "diagnose",
                &baseline,
                "log",
                "--rounds",
                "1",
                "--json",
                "diagnose.json",
            ],
            &["simulate", "--mu", "0.2", "--quiet", "-o", "simulate"],
        ];
        let mut printed = Vec::new();
        for args in steps {
            let out = tdeploy_with(args, dir, RunOptions::rayon_threads(threads));
            assert!(
                matches!(out.status.code(), Some(0 | 1)),
                "{args:?}: {}",
                stderr(&out)
            );
            // diagnose prints its own wall time and thread count.
            let text = stdout(&out);
            for line in text.lines().filter(|l| !l.contains(" s on ")) {
                printed.extend_from_slice(line.as_bytes());
                printed.push(b'\n');
            }
        }
        (files(dir), printed)
    };
    let one = run(1);
    assert!(one.0.len() > 10, "{} files", one.0.len());
    for threads in [2, 4] {
        let other = run(threads);
        assert_eq!(
            one.0.iter().map(|f| &f.0).collect::<Vec<_>>(),
            other.0.iter().map(|f| &f.0).collect::<Vec<_>>()
        );
        for (a, b) in one.0.iter().zip(&other.0) {
            assert!(a.1 == b.1, "{} differs at {threads} threads", a.0);
        }
        assert!(
            one.1 == other.1,
            "printed output differs at {threads} threads"
        );
    }
}
