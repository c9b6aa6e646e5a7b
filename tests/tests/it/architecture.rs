//! The shape of the workspace, as ARCHITECTURE.md states it, checked from the
//! sources themselves: which crate may depend on which, that the core crates
//! touch no ports, clocks or command lines, that no module's imports form a
//! cycle, and that every crate opens with a doc saying what it is for.
//!
//! These read `Cargo.toml` and `src/**/*.rs` as text: a `use` the compiler
//! accepts is what they check, not a build.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Each library crate and the workspace crates it may depend on (normal
/// dependencies). Data flows one way: nothing points back up the pipeline.
const ALLOWED: &[(&str, &[&str])] = &[
    ("hiddenline", &[]),
    ("strokes", &[]),
    ("scene", &["hiddenline", "strokes"]),
    ("plotcode", &["strokes"]),
    ("plotsim", &["strokes"]),
    ("plotd", &["scene", "strokes", "plotcode", "plotsim"]),
];

/// Crates of the outside world that the core must not use: no runtime,
/// serial port, terminal, process or command line in the geometry and the
/// device language.
const OUTSIDE_WORLD: &[&str] = &["tokio", "serialport", "tokio-serial", "mio-serial", "nix", "libc", "clap", "indicatif", "sd-notify"];
const CORE: &[&str] = &["hiddenline", "strokes", "scene", "plotcode"];

fn root() -> PathBuf {
    plotd_e2e::repo_root()
}

/// The names in a `[dependencies]`-like table of a manifest (not dev- or
/// build-dependencies).
fn dependencies(manifest: &str) -> BTreeSet<String> {
    let table: toml::Table = manifest.parse().expect("Cargo.toml parses");
    let mut names = BTreeSet::new();
    if let Some(deps) = table.get("dependencies").and_then(|d| d.as_table()) {
        names.extend(deps.keys().cloned());
    }
    if let Some(targets) = table.get("target").and_then(|t| t.as_table()) {
        for target in targets.values() {
            if let Some(deps) = target.get("dependencies").and_then(|d| d.as_table()) {
                names.extend(deps.keys().cloned());
            }
        }
    }
    names
}

#[test]
fn crates_depend_only_down_the_pipeline() {
    let workspace: BTreeSet<&str> = ALLOWED.iter().map(|(c, _)| *c).collect();
    for (krate, allowed) in ALLOWED {
        let manifest = fs::read_to_string(root().join("crates").join(krate).join("Cargo.toml")).unwrap();
        let deps = dependencies(&manifest);
        for dep in &deps {
            if workspace.contains(dep.as_str()) {
                assert!(allowed.contains(&dep.as_str()), "{krate} depends on {dep}, which ARCHITECTURE.md does not allow");
            }
            if CORE.contains(krate) {
                assert!(!OUTSIDE_WORLD.contains(&dep.as_str()), "{krate} is core (no I/O, no clocks) but depends on {dep}");
            }
        }
    }
}

/// A module's path inside its crate (`["map", "outline"]`), from its file.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    if matches!(parts.last().map(String::as_str), Some("lib" | "main" | "mod")) {
        parts.pop();
    }
    parts
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a file that the crate itself runs: comments and the unit-test
/// module at the end dropped (tests may reach anywhere).
fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// Every path that starts with `crate::`, `super::` or `self::` in `code`,
/// grouped imports (`crate::{a::X, b}`) expanded one level, as the segments
/// after the keyword, with the keyword.
fn relative_paths(code: &str) -> Vec<(&'static str, Vec<String>)> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    for keyword in ["crate", "super", "self"] {
        let pattern = format!("{keyword}::");
        let mut from = 0;
        while let Some(at) = code[from..].find(&pattern) {
            let start = from + at;
            from = start + pattern.len();
            let word_before =
                start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_' || bytes[start - 1] == b':');
            if word_before {
                continue;
            }
            let rest = &code[from..];
            let keyword: &'static str = match keyword {
                "crate" => "crate",
                "super" => "super",
                _ => "self",
            };
            if let Some(group) = rest.strip_prefix('{') {
                // Top-level items of the group, up to its closing brace.
                let (mut depth, mut item, mut items) = (0, String::new(), Vec::new());
                for c in group.chars() {
                    match c {
                        '{' => depth += 1,
                        '}' if depth == 0 => break,
                        '}' => depth -= 1,
                        ',' if depth == 0 => items.push(std::mem::take(&mut item)),
                        _ => {}
                    }
                    item.push(c);
                }
                items.push(item);
                for item in items {
                    out.push((keyword, segments(item.trim_start_matches(',').trim())));
                }
            } else {
                out.push((keyword, segments(rest)));
            }
        }
    }
    out
}

/// The leading `a::b::c` of `text`, as segments.
fn segments(text: &str) -> Vec<String> {
    let end = text.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':')).unwrap_or(text.len());
    text[..end].split("::").filter(|s| !s.is_empty()).map(str::to_owned).collect()
}

/// Module -> modules it refers to. A reference names the deepest module on
/// its path (`crate::map::outline::parse` -> `map::outline`); references
/// between a module and its own ancestors count too, since a child using its
/// parent's items while the parent uses the child's is a cycle as well.
fn module_graph(src: &Path) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeMap<Vec<String>, PathBuf> = files.iter().map(|f| (module_of(src, f), f.clone())).collect();
    let mut graph: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (module, file) in &modules {
        let code = code_of(&fs::read_to_string(file).unwrap());
        let edges = graph.entry(module.clone()).or_default();
        for (keyword, path) in relative_paths(&code) {
            let mut target = match keyword {
                "crate" => Vec::new(),
                "self" => module.clone(),
                _ => module[..module.len().saturating_sub(1)].to_vec(),
            };
            for segment in path {
                let mut deeper = target.clone();
                deeper.push(segment);
                if modules.contains_key(&deeper) {
                    target = deeper;
                } else {
                    break;
                }
            }
            // The crate root only declares and re-exports; a path through it
            // to an item is not a dependency on the root.
            if &target != module && !target.is_empty() {
                edges.insert(target);
            }
        }
    }
    graph
}

/// The strongly connected components of more than one module.
fn cycles(graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<String>> {
    // Kosaraju: finish order on the graph, then components on its reverse.
    fn finish(
        v: &Vec<String>,
        g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        seen: &mut BTreeSet<Vec<String>>,
        order: &mut Vec<Vec<String>>,
    ) {
        if !seen.insert(v.clone()) {
            return;
        }
        for w in g.get(v).into_iter().flatten() {
            finish(w, g, seen, order);
        }
        order.push(v.clone());
    }
    let mut seen = BTreeSet::new();
    let mut order = Vec::new();
    for v in graph.keys() {
        finish(v, graph, &mut seen, &mut order);
    }
    let mut reverse: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (v, ws) in graph {
        for w in ws {
            reverse.entry(w.clone()).or_default().insert(v.clone());
        }
    }
    let mut assigned = BTreeSet::new();
    let mut out = Vec::new();
    for v in order.iter().rev() {
        let mut component = Vec::new();
        finish(v, &reverse, &mut assigned, &mut component);
        if component.len() > 1 {
            let mut names: Vec<String> = component.iter().map(|m| if m.is_empty() { "<root>".into() } else { m.join("::") }).collect();
            names.sort();
            out.push(names);
        }
    }
    out
}

#[test]
fn no_module_imports_form_a_cycle() {
    let mut found = Vec::new();
    for entry in fs::read_dir(root().join("crates")).unwrap() {
        let src = entry.unwrap().path().join("src");
        for cycle in cycles(&module_graph(&src)) {
            found.push(format!("{}: {}", src.display(), cycle.join(" <-> ")));
        }
    }
    assert!(found.is_empty(), "module import cycles:\n{}", found.join("\n"));
}

#[test]
fn the_cycle_check_finds_cycles() {
    // The check itself, on a graph with one cycle through a parent and its
    // child and one chain without.
    let m = |s: &str| s.split("::").filter(|p| !p.is_empty()).map(str::to_owned).collect::<Vec<_>>();
    let mut g = BTreeMap::new();
    g.insert(m("emit"), BTreeSet::from([m("hpgl::emit")]));
    g.insert(m("hpgl::emit"), BTreeSet::from([m("emit"), m("placement")]));
    g.insert(m("placement"), BTreeSet::new());
    assert_eq!(cycles(&g), vec![vec!["emit".to_owned(), "hpgl::emit".to_owned()]]);
    let paths = relative_paths("use crate::{emit::Emitted, hpgl::{self, emit}};\nlet x = super::placement::fit(y);");
    let paths: Vec<_> = paths.into_iter().map(|(k, p)| format!("{k}::{}", p.join("::"))).collect();
    assert_eq!(paths, ["crate::emit::Emitted", "crate::hpgl", "super::placement::fit"]);
}

#[test]
fn every_library_says_what_it_is_for() {
    for entry in fs::read_dir(root().join("crates")).unwrap() {
        let lib = entry.unwrap().path().join("src/lib.rs");
        let text = fs::read_to_string(&lib).unwrap();
        assert!(text.starts_with("//! "), "{} does not open with a crate doc (`//!`)", lib.display());
        assert!(text.contains("#![deny(missing_docs)]"), "{} does not deny missing docs", lib.display());
    }
}
