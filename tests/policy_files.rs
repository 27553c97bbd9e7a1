//! Policy files of the old flat format 1: refused with one line naming
//! `tdeploy policy migrate`, which writes the same policy in the current
//! format. `tests/data/policy-1/` holds the four shipped policies as they
//! were written in format 1; each migrates to exactly the policy of its
//! format-2 file in `policies/`.

mod common;

use common::cli::{failed_with, stderr, tdeploy};
use common::repo_path;
use tensegrity_deploy::io::policy_file::{migrate_policy, read_policy};

const SHIPPED: [&str; 4] = ["qp", "memory", "nominal", "greedy-tree"];

#[test]
fn the_shipped_format_1_policies_migrate_to_the_shipped_format_2_ones() {
    for name in SHIPPED {
        let old = repo_path(&format!("tests/data/policy-1/{name}.toml"));
        let text = std::fs::read_to_string(&old).unwrap();
        let (migrated, notes) = migrate_policy(&text, &old).unwrap_or_else(|e| panic!("{e}"));
        let current = read_policy(&repo_path(&format!("policies/{name}.toml"))).unwrap();
        assert_eq!(migrated, current, "{name}");
        assert!(notes.is_empty(), "{name}: {notes:?}");
    }
}

#[test]
fn an_old_policy_is_refused_naming_the_migration_which_writes_the_new_form() {
    let dir = tempfile::tempdir().unwrap();
    let old = repo_path("tests/data/policy-1/greedy-tree.toml");
    std::fs::copy(&old, dir.path().join("old.toml")).unwrap();
    let out = tdeploy(&["plan", "--policy", "old.toml", "-o", "o"], dir.path());
    let e = failed_with(&out, 2);
    assert!(
        e.contains("old.toml: line 5, field `format`")
            && e.contains("tdeploy policy migrate old.toml -o NEW"),
        "{e}"
    );
    assert!(!dir.path().join("o").exists());
    let out = tdeploy(
        &["policy", "migrate", "old.toml", "-o", "new.toml"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let migrated = read_policy(&dir.path().join("new.toml")).unwrap();
    assert_eq!(
        migrated,
        read_policy(&repo_path("policies/greedy-tree.toml")).unwrap()
    );
    // A second run writes the same bytes; other contents need --force.
    let again = tdeploy(
        &["policy", "migrate", "old.toml", "-o", "new.toml"],
        dir.path(),
    );
    assert_eq!(again.status.code(), Some(0), "{again:?}");
    std::fs::write(dir.path().join("mine.toml"), "mine").unwrap();
    let refused = tdeploy(
        &["policy", "migrate", "old.toml", "-o", "mine.toml"],
        dir.path(),
    );
    assert_eq!(refused.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("mine.toml")).unwrap(),
        "mine"
    );
    // A file already in the current format is not format 1.
    let out = tdeploy(
        &["policy", "migrate", "new.toml", "-o", "newer.toml"],
        dir.path(),
    );
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(
        e.contains("new.toml") && e.contains("tensegrity-deploy/policy/1"),
        "{e}"
    );
}
