//! The shape of the workspace, as ARCHITECTURE.md states it, checked from the
//! sources themselves: which crate may depend on which, that the core crates
//! touch no ports, clocks or command lines, that no module's imports form a
//! cycle, that plotd's modules import only down its layers, and that every
//! crate opens with a doc saying what it is for.
//!
//! The sources are read as the compiler reads them (`syn`): the modules a
//! crate declares, from its root down; in each, every `use` (a re-export is
//! an import like any other) and every path in its code, macro calls
//! included, resolved to the module whose item it names, through any
//! re-exports on the way. Code under `#[cfg(test)]` is left out, the item it
//! is on and nothing else: tests may reach anywhere.

use proc_macro2::{Spacing, TokenStream, TokenTree};
use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use syn::visit::Visit;

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

/// plotd's layers (DESIGN.md), top first, by top-level module: a module
/// imports only modules of the layers below its own, never one of its own
/// layer or above. Every other module (`config`, `spool`, `protocol`,
/// `worker`, `text`, ...) is the floor every layer stands on, and imports
/// no module of any layer.
const PLOTD_LAYERS: &[&[&str]] = &[
    // The command line, and what each subcommand does.
    &["cli"],
    &["commands"],
    // The whole path on a virtual plotter: a daemon and its client.
    &["demo"],
    &["client", "render", "daemon"],
    // The job's life as a state machine, then the device's handshakes.
    &["job"],
    &["stream"],
];
/// Modules the layers name that are not written yet; every other one named
/// must exist, so that a rename cannot quietly switch a rule off.
const PLOTD_PLANNED: &[&str] = &[];

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

/// A module's path inside its crate (`["map", "outline"]`; the root is `[]`).
type ModPath = Vec<String>;

/// One `use` leaf: the name it brings into scope (`None` for a glob) and
/// the path as written.
#[derive(Debug)]
struct Import {
    name: Option<String>,
    path: Vec<String>,
}

/// What one module says, as far as dependencies go.
#[derive(Debug, Default)]
struct Module {
    /// Its `use` leaves, re-exports and private imports alike.
    imports: Vec<Import>,
    /// Every other path in its code (types, expressions, patterns, macro
    /// arguments), with two segments or more.
    paths: Vec<Vec<String>>,
}

/// A crate's modules, as declared from its root.
struct Crate {
    modules: BTreeMap<ModPath, Module>,
}

/// Whether `attrs` put the item under `#[cfg(test)]`.
fn is_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| match &a.meta {
        syn::Meta::List(list) => list.path.is_ident("cfg") && list.tokens.to_string() == "test",
        _ => false,
    })
}

/// The `use` leaves of `tree` under the path `prefix`.
fn imports(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<Import>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            imports(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) if n.ident == "self" => {
            out.push(Import { name: prefix.last().cloned(), path: prefix.clone() });
        }
        syn::UseTree::Name(n) => {
            let mut path = prefix.clone();
            path.push(n.ident.to_string());
            out.push(Import { name: Some(n.ident.to_string()), path });
        }
        syn::UseTree::Rename(r) => {
            let mut path = prefix.clone();
            if r.ident != "self" {
                path.push(r.ident.to_string());
            }
            out.push(Import { name: Some(r.rename.to_string()), path });
        }
        syn::UseTree::Glob(_) => out.push(Import { name: None, path: prefix.clone() }),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                imports(t, prefix, out);
            }
        }
    }
}

/// Paths written inside a macro call's tokens: `a::b::c` runs of
/// identifiers (`$crate` taken for `crate`).
fn token_paths(tokens: TokenStream, out: &mut Vec<Vec<String>>) {
    let mut run: Vec<String> = Vec::new();
    // Colons seen since the last identifier of the run: 2 joins the next.
    let mut colons = 0;
    for tt in tokens {
        match tt {
            TokenTree::Ident(i) => {
                if colons != 2 && run.len() > 1 {
                    out.push(std::mem::take(&mut run));
                }
                if colons != 2 {
                    run.clear();
                }
                run.push(i.to_string());
                colons = 0;
            }
            TokenTree::Punct(p) if p.as_char() == ':' && (colons == 0 && p.spacing() == Spacing::Joint || colons == 1) => colons += 1,
            TokenTree::Punct(p) if p.as_char() == '$' && colons == 0 => {}
            other => {
                if run.len() > 1 {
                    out.push(std::mem::take(&mut run));
                }
                run.clear();
                colons = 0;
                if let TokenTree::Group(g) = other {
                    token_paths(g.stream(), out);
                }
            }
        }
    }
    if run.len() > 1 {
        out.push(run);
    }
}

/// Collects one file's (or inline module's) imports and paths, leaving out
/// everything under `#[cfg(test)]`; notes the modules it declares.
struct Reader<'m, 'ast> {
    module: &'m mut Module,
    /// Child modules declared: their names, and their items when inline
    /// (read as modules of their own).
    children: Vec<(String, Option<&'ast [syn::Item]>)>,
}

impl<'ast> Visit<'ast> for Reader<'_, 'ast> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs = match item {
            syn::Item::Const(i) => &i.attrs,
            syn::Item::Enum(i) => &i.attrs,
            syn::Item::ExternCrate(i) => &i.attrs,
            syn::Item::Fn(i) => &i.attrs,
            syn::Item::ForeignMod(i) => &i.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Macro(i) => &i.attrs,
            syn::Item::Mod(i) => &i.attrs,
            syn::Item::Static(i) => &i.attrs,
            syn::Item::Struct(i) => &i.attrs,
            syn::Item::Trait(i) => &i.attrs,
            syn::Item::TraitAlias(i) => &i.attrs,
            syn::Item::Type(i) => &i.attrs,
            syn::Item::Union(i) => &i.attrs,
            syn::Item::Use(i) => &i.attrs,
            _ => return syn::visit::visit_item(self, item),
        };
        if is_test(attrs) {
            return;
        }
        match item {
            syn::Item::Mod(m) => {
                self.children.push((m.ident.to_string(), m.content.as_ref().map(|(_, items)| items.as_slice())));
            }
            syn::Item::Use(u) if u.leading_colon.is_none() => imports(&u.tree, &mut Vec::new(), &mut self.module.imports),
            syn::Item::Use(_) => {}
            _ => syn::visit::visit_item(self, item),
        }
    }
    fn visit_impl_item(&mut self, item: &'ast syn::ImplItem) {
        let attrs = match item {
            syn::ImplItem::Const(i) => &i.attrs,
            syn::ImplItem::Fn(i) => &i.attrs,
            syn::ImplItem::Type(i) => &i.attrs,
            syn::ImplItem::Macro(i) => &i.attrs,
            _ => return syn::visit::visit_impl_item(self, item),
        };
        if !is_test(attrs) {
            syn::visit::visit_impl_item(self, item);
        }
    }
    fn visit_trait_item(&mut self, item: &'ast syn::TraitItem) {
        let attrs = match item {
            syn::TraitItem::Const(i) => &i.attrs,
            syn::TraitItem::Fn(i) => &i.attrs,
            syn::TraitItem::Type(i) => &i.attrs,
            syn::TraitItem::Macro(i) => &i.attrs,
            _ => return syn::visit::visit_trait_item(self, item),
        };
        if !is_test(attrs) {
            syn::visit::visit_trait_item(self, item);
        }
    }
    fn visit_field(&mut self, f: &'ast syn::Field) {
        if !is_test(&f.attrs) {
            syn::visit::visit_field(self, f);
        }
    }
    fn visit_variant(&mut self, v: &'ast syn::Variant) {
        if !is_test(&v.attrs) {
            syn::visit::visit_variant(self, v);
        }
    }
    fn visit_arm(&mut self, a: &'ast syn::Arm) {
        if !is_test(&a.attrs) {
            syn::visit::visit_arm(self, a);
        }
    }
    fn visit_local(&mut self, l: &'ast syn::Local) {
        if !is_test(&l.attrs) {
            syn::visit::visit_local(self, l);
        }
    }
    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.leading_colon.is_none() && p.segments.len() > 1 {
            self.module.paths.push(p.segments.iter().map(|s| s.ident.to_string()).collect());
        }
        syn::visit::visit_path(self, p);
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        token_paths(m.tokens.clone(), &mut self.module.paths);
        syn::visit::visit_macro(self, m);
    }
    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {
        // Attributes name derives and tools, not the crate's modules.
    }
}

impl Crate {
    /// The crate whose root file is `root_file`; `read` gives a file's text
    /// (`None`: no such file).
    fn read(root_file: &Path, read: &dyn Fn(&Path) -> Option<String>) -> Crate {
        let mut modules = BTreeMap::new();
        let dir = root_file.parent().unwrap().to_owned();
        let text = read(root_file).unwrap_or_else(|| panic!("{} is missing", root_file.display()));
        let file = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", root_file.display()));
        Crate::add(&mut modules, Vec::new(), &file.items, &dir, read);
        Crate { modules }
    }

    /// Reads module `path`'s `items`; its children's files are in `dir`.
    fn add(
        modules: &mut BTreeMap<ModPath, Module>,
        path: ModPath,
        items: &[syn::Item],
        dir: &Path,
        read: &dyn Fn(&Path) -> Option<String>,
    ) {
        let mut module = Module::default();
        let mut reader = Reader { module: &mut module, children: Vec::new() };
        for item in items {
            reader.visit_item(item);
        }
        let children = reader.children;
        modules.insert(path.clone(), module);
        for (name, inline) in children {
            let mut child = path.clone();
            child.push(name.clone());
            match inline {
                Some(items) => Crate::add(modules, child, items, &dir.join(&name), read),
                None => {
                    let (file, sub) =
                        [(dir.join(format!("{name}.rs")), dir.join(&name)), (dir.join(&name).join("mod.rs"), dir.join(&name))]
                            .into_iter()
                            .find(|(f, _)| read(f).is_some())
                            .unwrap_or_else(|| panic!("module {} has no file in {}", child.join("::"), dir.display()));
                    let text = read(&file).unwrap();
                    let parsed = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
                    Crate::add(modules, child, &parsed.items, &sub, read);
                }
            }
        }
    }

    /// The crate at `src` (`lib.rs`; a binary's `main.rs` is a crate of its own).
    fn at(src: &Path) -> Crate {
        let root_file = if src.join("lib.rs").exists() { src.join("lib.rs") } else { src.join("main.rs") };
        Crate::read(&root_file, &|p| fs::read_to_string(p).ok())
    }

    fn has(&self, m: &[String]) -> bool {
        self.modules.contains_key(m)
    }

    /// Where `path`, written in module `from`, leads: the module whose item
    /// it names (`Ok`), or a module itself (`Err`); `None` outside the
    /// crate (another crate, `std`, a local name).
    fn resolve(&self, from: &[String], path: &[String], depth: usize) -> Option<Result<ModPath, ModPath>> {
        if depth > 32 {
            return None;
        }
        let (first, rest) = path.split_first()?;
        let mut at: ModPath = match first.as_str() {
            "crate" => Vec::new(),
            "self" => from.to_vec(),
            "super" => from[..from.len().checked_sub(1)?].to_vec(),
            name => {
                let mut child = from.to_vec();
                child.push(name.to_owned());
                if self.has(&child) {
                    child
                } else {
                    let import = self.modules.get(from)?.imports.iter().find(|i| i.name.as_deref() == Some(name))?;
                    match self.resolve(from, &import.path, depth + 1)? {
                        Ok(owner) => return Some(Ok(owner)),
                        Err(module) => module,
                    }
                }
            }
        };
        let mut rest = rest;
        while let Some((segment, after)) = rest.split_first() {
            if segment == "super" && !at.is_empty() {
                at.pop();
                rest = after;
                continue;
            }
            let mut child = at.clone();
            child.push(segment.clone());
            if self.has(&child) {
                at = child;
                rest = after;
                continue;
            }
            // An import of `at` (a re-export, when another module names it):
            // the item is where that import leads.
            let imports = &self.modules.get(&at)?.imports;
            let named = imports.iter().find(|i| i.name.as_deref() == Some(segment.as_str()));
            let found = match named {
                Some(import) => self.resolve(&at, &import.path, depth + 1),
                // Through a glob import, when there is one.
                None => imports.iter().find(|i| i.name.is_none()).and_then(|glob| {
                    let mut through = glob.path.clone();
                    through.push(segment.clone());
                    self.resolve(&at, &through, depth + 1)
                }),
            };
            return match found {
                Some(Err(module)) if !after.is_empty() => self.resolve(&module, &[&["self".to_owned()], after].concat(), depth + 1),
                Some(found) => Some(found),
                // An item of `at` itself.
                None => Some(Ok(at)),
            };
        }
        Some(Err(at))
    }

    /// Module -> the modules whose items it uses. A reference names the
    /// module that owns the item, through re-exports (`crate::stream::Span`
    /// -> `stream::plan` when `stream` re-exports it from there); a path in
    /// code that ends on a module's name names an item beside it (a value
    /// and a module may share a name). References between a module and its
    /// own ancestors count too: a child using its parent's items while the
    /// parent uses the child's (a re-export is a use) is a cycle as well.
    /// Except the crate root's items: the root declares the modules and
    /// holds the crate's entry point and the small types it takes (strokes'
    /// `optimize` and `StrokeOptions`, fuzz's `check` and `Input`), which
    /// the modules it calls share; an import of one is no edge.
    fn graph(&self) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
        let mut graph: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
        for (name, module) in &self.modules {
            let edges = graph.entry(name.clone()).or_default();
            let imported = module.imports.iter().map(|i| (&i.path, false));
            for (path, in_code) in imported.chain(module.paths.iter().map(|p| (p, true))) {
                let owner = match self.resolve(name, path, 0) {
                    Some(Ok(owner)) => owner,
                    Some(Err(mut module)) if in_code && !module.is_empty() => {
                        module.pop();
                        module
                    }
                    _ => continue,
                };
                if &owner != name && !owner.is_empty() {
                    edges.insert(owner);
                }
            }
        }
        graph
    }
}

/// The strongly connected components of more than one module.
fn cycles(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<String>> {
    // Kosaraju: finish order on the graph, then components on its reverse.
    fn finish(v: &ModPath, g: &BTreeMap<ModPath, BTreeSet<ModPath>>, seen: &mut BTreeSet<ModPath>, order: &mut Vec<ModPath>) {
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
    let mut reverse: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
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
            let mut names: Vec<String> = component.iter().map(|m| shown(m)).collect();
            names.sort();
            out.push(names);
        }
    }
    out
}

fn shown(m: &[String]) -> String {
    if m.is_empty() {
        "<root>".into()
    } else {
        m.join("::")
    }
}

/// Each edge of a cycle, as `a -> b`, for the message.
fn cycle_edges(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>, cycle: &[String]) -> String {
    let mut lines = Vec::new();
    for (v, ws) in graph {
        for w in ws {
            if cycle.contains(&shown(v)) && cycle.contains(&shown(w)) {
                lines.push(format!("  {} -> {}", shown(v), shown(w)));
            }
        }
    }
    lines.join("\n")
}

#[test]
fn no_module_imports_form_a_cycle() {
    let mut found = Vec::new();
    for entry in fs::read_dir(root().join("crates")).unwrap() {
        let src = entry.unwrap().path().join("src");
        let graph = Crate::at(&src).graph();
        for cycle in cycles(&graph) {
            found.push(format!("{}: {}\n{}", src.display(), cycle.join(" <-> "), cycle_edges(&graph, &cycle)));
        }
    }
    assert!(found.is_empty(), "module import cycles:\n{}", found.join("\n"));
}

/// Where a top-level module of plotd stands: its layer, or `None` for the floor.
fn layer(module: &str) -> Option<usize> {
    PLOTD_LAYERS.iter().position(|layer| layer.contains(&module))
}

/// The imports of `graph` that break plotd's layering, as messages.
fn layering_breaches(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<String> {
    let mut breaches = BTreeSet::new();
    for (from, tos) in graph {
        let Some(a) = from.first() else { continue };
        for to in tos {
            let Some(b) = to.first() else { continue };
            if a == b {
                continue;
            }
            let allowed = match (layer(a), layer(b)) {
                (_, None) => true,
                (Some(x), Some(y)) => x < y,
                (None, Some(_)) => false,
            };
            if !allowed {
                breaches.insert(format!("{} imports {}", shown(from), shown(to)));
            }
        }
    }
    breaches.into_iter().collect()
}

#[test]
fn plotd_modules_import_only_down_its_layers() {
    let plotd = Crate::at(&root().join("crates/plotd/src"));
    for name in PLOTD_LAYERS.iter().flat_map(|l| l.iter()) {
        assert!(
            plotd.has(&[(*name).to_owned()]) || PLOTD_PLANNED.contains(name),
            "plotd has no module `{name}`: update PLOTD_LAYERS (DESIGN.md's layers)"
        );
    }
    let breaches = layering_breaches(&plotd.graph());
    assert!(
        breaches.is_empty(),
        "imports against plotd's layers ({PLOTD_LAYERS:?}; other modules are the floor):\n{}",
        breaches.join("\n")
    );
}

/// A crate given as (file, text) pairs under `src/`.
fn crate_of(files: &[(&str, &str)]) -> Crate {
    let files: BTreeMap<PathBuf, String> = files.iter().map(|(f, t)| (Path::new("src").join(f), (*t).to_owned())).collect();
    Crate::read(Path::new("src/lib.rs"), &|p| files.get(p).cloned())
}

fn m(s: &str) -> ModPath {
    s.split("::").filter(|p| !p.is_empty()).map(str::to_owned).collect()
}

#[test]
fn the_cycle_check_finds_cycles() {
    // The check itself, on a graph with one cycle through a parent and its
    // child and one chain without.
    let mut g = BTreeMap::new();
    g.insert(m("emit"), BTreeSet::from([m("hpgl::emit")]));
    g.insert(m("hpgl::emit"), BTreeSet::from([m("emit"), m("placement")]));
    g.insert(m("placement"), BTreeSet::new());
    assert_eq!(cycles(&g), vec![vec!["emit".to_owned(), "hpgl::emit".to_owned()]]);
}

/// The cycle plotd had (issue 35): `spool` used `stream::Written`, defined
/// in `stream/mod.rs`, which re-exported `streamer`, which used `config`,
/// which used `worker`, which used `spool`. Each link is of a kind the
/// text-reading check missed: a re-export, and imports after an item
/// under `#[cfg(test)]`.
#[test]
fn reexports_and_code_after_a_test_item_are_read() {
    let c = crate_of(&[
        ("lib.rs", "pub mod config; pub mod spool; pub mod stream; pub mod worker;"),
        ("spool.rs", "use crate::stream::Written;\npub fn save(_: Written) {}"),
        ("stream/mod.rs", "mod streamer;\npub use streamer::Streamer;\npub enum Written { Into(usize) }"),
        ("stream/streamer.rs", "#[cfg(test)]\nfn helper() {}\nuse crate::config::Handshake;\npub struct Streamer(Handshake);"),
        (
            "config.rs",
            "#[cfg(test)]\nmod tests { use crate::spool; }\npub enum Handshake { A }\nfn budget() -> f64 { crate::worker::DEFAULT }",
        ),
        ("worker.rs", "pub const DEFAULT: f64 = 1.0;\nfn kind() { let _ = crate::spool::save; }"),
    ]);
    let g = c.graph();
    assert_eq!(g[&m("stream")], BTreeSet::from([m("stream::streamer")]), "a re-export is an import");
    assert!(g[&m("stream::streamer")].contains(&m("config")), "read past a #[cfg(test)] item");
    assert!(g[&m("config")].contains(&m("worker")), "read past a #[cfg(test)] module");
    assert!(!g[&m("config")].contains(&m("spool")), "the test module is left out");
    assert!(g[&m("worker")].contains(&m("spool")), "a path in code, not only in a `use`");
    assert_eq!(cycles(&g), vec![vec!["config", "spool", "stream", "stream::streamer", "worker"]]);
}

/// A path through a re-export is an import of the module that owns the
/// item, not of the one re-exporting it; a macro's arguments are code.
#[test]
fn paths_resolve_through_reexports_and_macros() {
    let c = crate_of(&[
        ("lib.rs", "pub mod stream; pub mod spool;"),
        ("stream/mod.rs", "mod error; mod written;\npub use error::StreamError;\npub use written::Written;"),
        ("stream/error.rs", "pub enum StreamError { A }\nfn f(w: super::Written) {}"),
        ("stream/written.rs", "pub enum Written { Into(usize) }"),
        ("spool.rs", "fn f() -> bool { matches!(x(), crate::stream::StreamError::A) }"),
    ]);
    let g = c.graph();
    assert_eq!(g[&m("stream::error")], BTreeSet::from([m("stream::written")]));
    assert_eq!(g[&m("spool")], BTreeSet::from([m("stream::error")]));
    assert!(cycles(&g).is_empty());
}

#[test]
fn the_layering_rule_finds_imports_up_and_across() {
    let c = crate_of(&[
        ("lib.rs", "pub mod cli; pub mod client; pub mod daemon; pub mod stream; pub mod config;"),
        ("cli.rs", "fn f() { crate::client::run(); crate::daemon::serve(); }"),
        ("client.rs", "pub fn run() { crate::daemon::serve(); }"),
        ("daemon/mod.rs", "mod plotter;\npub fn serve() { plotter::go(); }"),
        ("daemon/plotter.rs", "pub fn go() { crate::stream::open(); }"),
        ("stream.rs", "pub fn open() { let _ = crate::config::Handshake::A; }"),
        ("config.rs", "pub enum Handshake { A }\nfn f() { crate::stream::open(); }"),
    ]);
    assert_eq!(layering_breaches(&c.graph()), ["client imports daemon", "config imports stream"]);
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
