//! The layers of the library point one way (`src/lib.rs`, "Layout"): a
//! lower layer never names a higher one. This scans every `crate::LAYER`
//! path in the library's code, outside comments and outside `#[cfg(test)]`
//! code (unit tests may build their fixtures with any layer, e.g. a model
//! test on the reference bridge from `design`). The table of layers is
//! the folders of `src/`, no more and no fewer.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use common::repo_path;

/// Each layer (a folder of `src/`) and the layers it may use.
fn allowed() -> BTreeMap<&'static str, Vec<&'static str>> {
    let below = |layers: &[&'static str]| layers.to_vec();
    let mut m = BTreeMap::new();
    m.insert("numerics", below(&[]));
    m.insert("model", below(&["numerics"]));
    m.insert("design", below(&["numerics", "model"]));
    m.insert("sim", below(&["numerics", "model"]));
    m.insert("measure", below(&["numerics", "model", "sim"]));
    m.insert("plan", below(&["numerics", "model", "sim"]));
    m.insert("control", below(&["numerics", "model", "sim", "plan"]));
    m.insert(
        "learn",
        below(&["numerics", "model", "sim", "plan", "control"]),
    );
    let lower = [
        "numerics", "model", "design", "sim", "measure", "plan", "control", "learn",
    ];
    m.insert("studies", below(&lower));
    let mut with_studies = lower.to_vec();
    with_studies.push("studies");
    m.insert("io", with_studies.clone());
    with_studies.push("io");
    m.insert("report", with_studies.clone());
    // The binary's front end (`src/main.rs` holds it) may use everything.
    let mut every = with_studies;
    every.push("report");
    m.insert("cli", every);
    m
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The layers named as `crate::LAYER` in the code lines of `text` before
/// its first `#[cfg(test)]`, with their 1-based line numbers.
fn named_layers(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let code = line.split("//").next().unwrap_or("");
        for part in code.split("crate::").skip(1) {
            let layer: String = part
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            found.push((i + 1, layer));
        }
    }
    found
}

#[test]
fn no_layer_imports_a_higher_one() {
    let root = repo_path("src");
    let allowed = allowed();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let mut violations = Vec::new();
    let mut checked = 0;
    for file in files {
        let relative = file.strip_prefix(&root).unwrap();
        let layer = relative
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        // The crate roots may use everything.
        let Some(may_use) = allowed.get(layer.as_str()) else {
            assert!(
                ["lib", "main"].contains(&layer.as_str()),
                "{}: a folder the layer table does not know",
                relative.display()
            );
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, named) in named_layers(&text) {
            checked += 1;
            if named != layer && !may_use.contains(&named.as_str()) {
                violations.push(format!(
                    "src/{}:{line}: `{layer}` uses `{named}`",
                    relative.display()
                ));
            }
        }
    }
    assert!(checked > 50, "the scan found only {checked} crate paths");
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_scan_sees_a_violation_and_skips_tests_and_comments() {
    let text = "use crate::plan::Policy;\n// crate::cli in a comment\nfn f() {}\n\
                #[cfg(test)]\nmod tests { use crate::design::x; }\n";
    assert_eq!(named_layers(text), vec![(1, "plan".to_string())]);
}

/// The table knows every folder of `src/` and names no layer that is not
/// one; the library declares each layer below the binary's front end.
#[test]
fn the_layer_table_is_the_folders_of_src() {
    let root = repo_path("src");
    let folders: BTreeSet<String> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let table = allowed();
    let layers: BTreeSet<String> = table.keys().map(|l| l.to_string()).collect();
    assert_eq!(
        layers, folders,
        "the layer table against the folders of src/"
    );
    for (layer, may_use) in &table {
        for used in may_use {
            assert!(
                table.contains_key(used) && used != layer,
                "`{layer}` may use `{used}`, which is not another layer"
            );
        }
    }
    let lib = std::fs::read_to_string(root.join("lib.rs")).unwrap();
    let modules: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("pub mod ")?.strip_suffix(';'))
        .map(String::from)
        .collect();
    let library: BTreeSet<String> = layers.into_iter().filter(|l| l != "cli").collect();
    assert_eq!(
        modules, library,
        "the modules of src/lib.rs against the layers"
    );
}
