//! No import cycle between the files of `src/` (issue "Control apart from
//! planning"): a reader who follows the `use` lines from any file never
//! comes back to it. `tests/layers.rs` keeps the folders in order; this
//! keeps the files inside a folder in order too.
//!
//! Every path a file names (`crate::…`, `super::…`, `self::…`, in `use`
//! lines and in code, outside comments and `#[cfg(test)]` code) is
//! resolved to the file that defines the item: a name a `mod.rs`
//! re-exports (`pub use child::Name`) resolves to the child that defines
//! it, so importing through the facade is no edge to the facade. The
//! `pub mod` / `pub use` lines of a `mod.rs` are declarations, not
//! dependencies.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use common::repo_path;

/// The library's files, keyed by module path (`["plan", "policy"]`; a
/// `mod.rs` by its folder's path; `lib.rs` by `[]`).
fn modules(src: &Path) -> BTreeMap<Vec<String>, PathBuf> {
    fn walk(dir: &Path, prefix: &[String], out: &mut BTreeMap<Vec<String>, PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            let mut module = prefix.to_vec();
            if path.is_dir() {
                module.push(name);
                walk(&path, &module, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                if name != "mod" && name != "lib" && name != "main" {
                    module.push(name.clone());
                }
                if name != "main" {
                    out.insert(module, path);
                }
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, &[], &mut out);
    out
}

/// The code of a file: comments removed, everything from the first
/// `#[cfg(test)]` on dropped.
fn code_lines(text: &str) -> Vec<String> {
    let mut lines = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        lines.push(line.split("//").next().unwrap_or("").to_string());
    }
    lines
}

/// A path as written: `crate`/`super`/`self` root and its segments,
/// with `{a, b::c}` groups expanded.
fn expand_use_tree(tree: &str) -> Vec<String> {
    // `Name as Alias`: the alias names nothing new.
    let mut tokens = Vec::new();
    let mut words = tree.split_whitespace();
    while let Some(w) = words.next() {
        if w == "as" {
            let alias = words.next().unwrap_or("");
            // Keep the group's punctuation that followed the alias.
            tokens.push(alias.trim_start_matches(|c: char| c.is_alphanumeric() || c == '_'));
        } else {
            tokens.push(w);
        }
    }
    let tree: String = tokens.concat();
    fn expand(prefix: &str, rest: &str, out: &mut Vec<String>) {
        if let Some(open) = rest.find('{') {
            let close = rest.rfind('}').unwrap_or(rest.len());
            let head = &rest[..open];
            let inner = &rest[open + 1..close];
            // Split the group's items at top-level commas.
            let (mut depth, mut start) = (0, 0);
            let mut items = Vec::new();
            for (i, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        items.push(&inner[start..i]);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            items.push(&inner[start..]);
            for item in items.into_iter().filter(|i| !i.is_empty()) {
                expand(&format!("{prefix}{head}"), item, out);
            }
        } else {
            out.push(format!("{prefix}{rest}"));
        }
    }
    let mut out = Vec::new();
    expand("", &tree, &mut out);
    out
}

/// Every path a file names: whole `use` trees, and `crate::a::b`,
/// `super::a::b` paths in code. Each as its segments, `self` dropped,
/// `as` aliases cut.
fn named_paths(code: &[String], is_facade: bool) -> Vec<Vec<String>> {
    let text = code.join("\n");
    let mut paths = Vec::new();
    let mut rest = text.as_str();
    // `use` items (possibly over several lines, up to `;`).
    let mut outside_use = String::new();
    while let Some(i) = rest.find("use ") {
        let before = &rest[..i];
        let at_word_start = before
            .chars()
            .last()
            .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        let Some(end) = rest[i..].find(';') else {
            break;
        };
        let item = &rest[i + 4..i + end];
        let declaration = before.trim_end().ends_with("pub") && is_facade;
        outside_use.push_str(before);
        if at_word_start && !declaration {
            paths.extend(expand_use_tree(item));
        }
        rest = &rest[i + end + 1..];
    }
    outside_use.push_str(rest);
    // Paths in code.
    for root in ["crate::", "super::"] {
        let mut s = outside_use.as_str();
        while let Some(i) = s.find(root) {
            let tail: String = s[i..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            paths.push(tail.trim_end_matches(':').to_string());
            s = &s[i + root.len()..];
        }
    }
    paths
        .into_iter()
        .filter(|p| p.starts_with("crate") || p.starts_with("super") || p.starts_with("self"))
        .map(|p| p.split("::").map(str::to_string).collect())
        .collect()
}

/// `pub use child::{A, B}` lines of a facade: exported name → the path
/// it re-exports, relative to the facade's module.
fn reexports(code: &[String]) -> BTreeMap<String, Vec<String>> {
    let text = code.join("\n");
    let mut out = BTreeMap::new();
    let mut rest = text.as_str();
    while let Some(i) = rest.find("pub use ") {
        let Some(end) = rest[i..].find(';') else {
            break;
        };
        for p in expand_use_tree(&rest[i + 8..i + end]) {
            let segments: Vec<String> = p.split("::").map(str::to_string).collect();
            if let Some(name) = segments.last() {
                out.insert(name.clone(), segments);
            }
        }
        rest = &rest[i + end + 1..];
    }
    out
}

struct Crate {
    modules: BTreeMap<Vec<String>, PathBuf>,
    facades: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
}

impl Crate {
    /// The file that defines what `path` (absolute module segments, then
    /// an item) names; `None` outside the crate (a macro, a primitive).
    fn resolve(&self, path: &[String], depth: usize) -> Option<Vec<String>> {
        if depth > 8 {
            return None;
        }
        let mut module: Vec<String> = Vec::new();
        for (k, segment) in path.iter().enumerate() {
            let mut next = module.clone();
            next.push(segment.clone());
            if self.modules.contains_key(&next) {
                module = next;
                continue;
            }
            // `segment` is an item of `module`: re-exported or its own.
            if let Some(target) = self.facades.get(&module).and_then(|f| f.get(segment)) {
                let absolute = self.absolute(&module, target)?;
                let mut full = absolute;
                full.extend(path[k + 1..].iter().cloned());
                return self.resolve(&full, depth + 1);
            }
            return Some(module);
        }
        Some(module)
    }

    /// A path written in `module` made absolute.
    fn absolute(&self, module: &[String], path: &[String]) -> Option<Vec<String>> {
        let mut base = module.to_vec();
        let mut rest = path;
        match path.first().map(String::as_str) {
            Some("crate") => {
                base.clear();
                rest = &path[1..];
            }
            Some(_) => {}
            None => return None,
        }
        let mut out = base;
        for (k, s) in rest.iter().enumerate() {
            match s.as_str() {
                "super" if k == 0 || rest[..k].iter().all(|p| p == "super") => {
                    out.pop()?;
                }
                "self" => {}
                _ => out.push(s.clone()),
            }
        }
        Some(out)
    }
}

/// Strongly connected components of more than one file (Tarjan).
fn cycles(edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<Vec<String>>> {
    struct Tarjan<'a> {
        edges: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: BTreeMap<Vec<String>, usize>,
        low: BTreeMap<Vec<String>, usize>,
        stack: Vec<Vec<String>>,
        on_stack: BTreeSet<Vec<String>>,
        next: usize,
        out: Vec<Vec<Vec<String>>>,
    }
    impl Tarjan<'_> {
        fn visit(&mut self, v: &Vec<String>) {
            self.index.insert(v.clone(), self.next);
            self.low.insert(v.clone(), self.next);
            self.next += 1;
            self.stack.push(v.clone());
            self.on_stack.insert(v.clone());
            for w in self.edges.get(v).cloned().unwrap_or_default() {
                if !self.index.contains_key(&w) {
                    self.visit(&w);
                    let l = self.low[v].min(self.low[&w]);
                    self.low.insert(v.clone(), l);
                } else if self.on_stack.contains(&w) {
                    let l = self.low[v].min(self.index[&w]);
                    self.low.insert(v.clone(), l);
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on_stack.remove(&w);
                    let done = &w == v;
                    component.push(w);
                    if done {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.out.push(component);
                }
            }
        }
    }
    let mut t = Tarjan {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    t.out
}

/// Each file's edges to the files it names.
fn file_graph(src: &Path) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let modules = modules(src);
    let mut code = BTreeMap::new();
    let mut facades = BTreeMap::new();
    for (module, path) in &modules {
        let lines = code_lines(&std::fs::read_to_string(path).unwrap());
        let is_facade = path
            .file_name()
            .is_some_and(|n| n == "mod.rs" || n == "lib.rs");
        if is_facade {
            facades.insert(module.clone(), reexports(&lines));
        }
        code.insert(module.clone(), (lines, is_facade));
    }
    let krate = Crate {
        modules: modules.clone(),
        facades,
    };
    let mut edges = BTreeMap::new();
    for (module, (lines, is_facade)) in &code {
        let mut to = BTreeSet::new();
        for path in named_paths(lines, *is_facade) {
            // `super` in a file's code is its parent module; in a facade
            // it is the facade's own parent too.
            let Some(absolute) = krate.absolute(module, &path) else {
                continue;
            };
            if let Some(target) = krate.resolve(&absolute, 0) {
                if &target != module && !target.is_empty() {
                    to.insert(target);
                }
            }
        }
        edges.insert(module.clone(), to);
    }
    edges
}

#[test]
fn no_file_of_src_imports_itself_through_others() {
    let src = repo_path("src");
    let edges = file_graph(&src);
    let total: usize = edges.values().map(BTreeSet::len).sum();
    assert!(
        total > 300,
        "the scan found only {total} edges between files"
    );
    let found = cycles(&edges);
    let text: Vec<String> = found
        .iter()
        .map(|c| {
            c.iter()
                .map(|m| m.join("/"))
                .collect::<Vec<_>>()
                .join(" ↔ ")
        })
        .collect();
    assert!(found.is_empty(), "import cycles:\n{}", text.join("\n"));
}

#[test]
fn the_scan_resolves_facades_and_finds_a_planted_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod a;\n").unwrap();
    std::fs::write(
        src.join("a/mod.rs"),
        "pub mod x;\npub mod y;\npub use x::{X, helper};\n",
    )
    .unwrap();
    // x names y in code, y imports x's item through the facade.
    std::fs::write(
        src.join("a/x.rs"),
        "pub struct X;\npub fn helper() { super::y::f(); }\n",
    )
    .unwrap();
    std::fs::write(
        src.join("a/y.rs"),
        "use crate::a::X; // crate::b in a comment\npub fn f() {}\n\
         #[cfg(test)]\nmod tests { use super::super::x::X; }\n",
    )
    .unwrap();
    let edges = file_graph(src);
    let a = |s: &str| vec!["a".to_string(), s.to_string()];
    assert_eq!(edges[&a("y")], BTreeSet::from([a("x")]));
    assert_eq!(edges[&a("x")], BTreeSet::from([a("y")]));
    assert_eq!(cycles(&edges), vec![vec![a("x"), a("y")]]);
    // Without x's call into y, no cycle.
    std::fs::write(src.join("a/x.rs"), "pub struct X;\npub fn helper() {}\n").unwrap();
    assert!(cycles(&file_graph(src)).is_empty());
}
