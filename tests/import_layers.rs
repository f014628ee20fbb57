//! The import layers of the workspace's crates, read from their source.
//!
//! A crate's module tree is followed from its root file (`mod x;` → `x.rs` or `x/mod.rs`; test modules, i.e. items
//! under `#[cfg(test)]`, are left out), and every path into the crate itself is collected: `use` trees and paths in
//! code and macro bodies that start with `crate::`, `super::`, `self::` or the name of a child module. Each path is
//! resolved to the module that defines what it names, following `use` items (re-exports) (so `crate::Drawing` counts as
//! an import of the module that defines `Drawing`, not of the crate root). That gives module → module edges, which
//! are checked two ways:
//!
//! * **cycles** — within every folder (the crate root included), its direct children (a file with everything below
//!   it) must not import each other in a circle; each circle is reported once, with one import per step;
//! * **layers** — given a table of layers (earliest first, each a list of module paths), a module may import only
//!   from its own layer or an earlier one. A module the table does not place is reported too, so a new folder
//!   cannot slip past the table. The crate root (`lib.rs`, re-exports only) belongs to no layer.
//!
//! The checker is pure: it reads files through a function, so its own tests below run it on small made-up crates.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::ext::IdentExt;
use syn::visit::Visit;

/// A module's path below its crate root (`[]` is the root itself).
type ModPath = Vec<String>;

/// A layer table: the layers in order, earliest first; each a name and the module paths (`"a::b"`) it holds. A
/// module belongs to the layer of the longest entry that is a prefix of its path.
type Layers<'a> = &'a [(&'a str, &'a [&'a str])];

/// A path to something in the crate, as written, with where it was written.
struct RawPath {
    /// The module the path was written in.
    module: ModPath,
    /// Its segments (`crate`, `super`, `self` or names).
    segments: Vec<String>,
    /// `file:line` of the path.
    at: String,
}

/// One import: `from` uses something `to` defines.
#[derive(Debug, Clone)]
struct Edge {
    from: ModPath,
    to: ModPath,
    /// `file:line` and the path as written.
    at: String,
}

/// What the checker read of one crate.
#[derive(Default)]
struct CrateSource {
    /// Every (non-test) module.
    modules: BTreeSet<ModPath>,
    /// Every path into the crate.
    paths: Vec<RawPath>,
    /// `use` items, public or not (a child module may name them through `super::`): (module, name it binds) → the
    /// path it names, as written in that module.
    reexports: BTreeMap<(ModPath, String), Vec<String>>,
    /// Files that could not be read or parsed, and modules whose file is missing.
    problems: Vec<String>,
}

fn show(m: &[String]) -> String {
    if m.is_empty() { "crate".to_string() } else { m.join("::") }
}

/// Is this attribute list marked test-only (`#[cfg(test)]`, `#[cfg(all(test, ..))]`)?
fn is_test_only(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && matches!(&a.meta, syn::Meta::List(l) if {
                let t = l.tokens.to_string();
                t.split(|c: char| !c.is_alphanumeric() && c != '_').any(|w| w == "test") && !t.contains("not")
            })
    })
}

/// The attributes of an item, for the variants that can carry `#[cfg(test)]`.
fn item_attrs(item: &syn::Item) -> &[syn::Attribute] {
    use syn::Item as I;
    match item {
        I::Const(i) => &i.attrs,
        I::Enum(i) => &i.attrs,
        I::ExternCrate(i) => &i.attrs,
        I::Fn(i) => &i.attrs,
        I::ForeignMod(i) => &i.attrs,
        I::Impl(i) => &i.attrs,
        I::Macro(i) => &i.attrs,
        I::Mod(i) => &i.attrs,
        I::Static(i) => &i.attrs,
        I::Struct(i) => &i.attrs,
        I::Trait(i) => &i.attrs,
        I::TraitAlias(i) => &i.attrs,
        I::Type(i) => &i.attrs,
        I::Union(i) => &i.attrs,
        I::Use(i) => &i.attrs,
        _ => &[],
    }
}

/// Flatten a use tree into (path segments, the name it binds; `None` for a glob).
fn flatten_use(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, Option<String>)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.unraw().to_string());
            flatten_use(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) if n.ident == "self" => {
            out.push((prefix.clone(), prefix.last().cloned()));
        }
        syn::UseTree::Name(n) => {
            let mut p = prefix.clone();
            p.push(n.ident.unraw().to_string());
            out.push((p, Some(n.ident.unraw().to_string())));
        }
        syn::UseTree::Rename(r) => {
            let mut p = prefix.clone();
            if r.ident != "self" {
                p.push(r.ident.unraw().to_string());
            }
            out.push((p, Some(r.rename.to_string())));
        }
        syn::UseTree::Glob(_) => out.push((prefix.clone(), None)),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                flatten_use(t, prefix, out);
            }
        }
    }
}

/// Collects the paths of one file (and its inline modules); `mod x;` declarations are returned for loading.
struct FileVisitor<'a> {
    file: &'a str,
    /// Current module (inline `mod x { }` pushes).
    module: ModPath,
    /// Folder the current module's `mod x;` files live in.
    dir: PathBuf,
    /// `mod x;` found: (module path, folder of its files).
    children: Vec<(ModPath, PathBuf)>,
    out: &'a mut CrateSource,
}

impl FileVisitor<'_> {
    fn record(&mut self, segments: Vec<String>, line: usize) {
        let at = format!("{}:{} `{}`", self.file, line, segments.join("::"));
        self.out.paths.push(RawPath { module: self.module.clone(), segments, at });
    }
}

impl<'ast> Visit<'ast> for FileVisitor<'_> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        if !is_test_only(item_attrs(item)) {
            syn::visit::visit_item(self, item);
        }
    }

    fn visit_impl_item(&mut self, item: &'ast syn::ImplItem) {
        let attrs: &[syn::Attribute] = match item {
            syn::ImplItem::Const(i) => &i.attrs,
            syn::ImplItem::Fn(i) => &i.attrs,
            syn::ImplItem::Type(i) => &i.attrs,
            _ => &[],
        };
        if !is_test_only(attrs) {
            syn::visit::visit_impl_item(self, item);
        }
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        let mut path = self.module.clone();
        path.push(m.ident.unraw().to_string());
        let dir = self.dir.join(m.ident.unraw().to_string());
        match &m.content {
            None => self.children.push((path, dir)),
            Some((_, items)) => {
                self.out.modules.insert(path.clone());
                let (module, parent_dir) =
                    (std::mem::replace(&mut self.module, path), std::mem::replace(&mut self.dir, dir));
                for item in items {
                    self.visit_item(item);
                }
                self.module = module;
                self.dir = parent_dir;
            }
        }
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        let mut flat = Vec::new();
        flatten_use(&u.tree, &mut Vec::new(), &mut flat);
        let line = u.use_token.span.start().line;
        for (segments, name) in flat {
            if let Some(name) = name {
                self.out.reexports.insert((self.module.clone(), name), segments.clone());
            }
            self.record(segments, line);
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.leading_colon.is_none() && p.segments.len() > 1 {
            let segments = p.segments.iter().map(|s| s.ident.unraw().to_string()).collect();
            let line = p.segments[0].ident.span().start().line;
            self.record(segments, line);
        }
        syn::visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        // Macro bodies are tokens, not syntax: pick out `crate :: a :: b` chains.
        fn walk(tokens: proc_macro2::TokenStream, found: &mut Vec<(Vec<String>, usize)>) {
            let toks: Vec<_> = tokens.into_iter().collect();
            let mut i = 0;
            while i < toks.len() {
                match &toks[i] {
                    proc_macro2::TokenTree::Group(g) => walk(g.stream(), found),
                    proc_macro2::TokenTree::Ident(id) if id == "crate" => {
                        let mut segs = vec!["crate".to_string()];
                        let mut j = i + 1;
                        while let (
                            Some(proc_macro2::TokenTree::Punct(a)),
                            Some(proc_macro2::TokenTree::Punct(b)),
                            Some(proc_macro2::TokenTree::Ident(n)),
                        ) = (toks.get(j), toks.get(j + 1), toks.get(j + 2))
                        {
                            if a.as_char() != ':' || b.as_char() != ':' {
                                break;
                            }
                            segs.push(n.to_string());
                            j += 3;
                        }
                        if segs.len() > 1 {
                            found.push((segs, id.span().start().line));
                        }
                        i = j;
                        continue;
                    }
                    _ => {}
                }
                i += 1;
            }
        }
        let mut found = Vec::new();
        walk(m.tokens.clone(), &mut found);
        for (segments, line) in found {
            self.record(segments, line);
        }
        syn::visit::visit_macro(self, m);
    }
}

/// Read a crate from its root file (`lib.rs` or `main.rs`), through `read` (path → contents).
fn read_crate(root: &Path, read: &dyn Fn(&Path) -> Option<String>) -> CrateSource {
    let mut src = CrateSource::default();
    let root_dir = root.parent().unwrap_or(Path::new("")).to_path_buf();
    // (module, its file, folder of its children)
    let mut todo: Vec<(ModPath, PathBuf, PathBuf)> = vec![(Vec::new(), root.to_path_buf(), root_dir)];
    while let Some((module, file, dir)) = todo.pop() {
        let shown = file.display().to_string();
        let Some(text) = read(&file) else {
            src.problems.push(format!("{shown}: cannot be read"));
            continue;
        };
        let parsed = match syn::parse_file(&text) {
            Ok(f) => f,
            Err(e) => {
                src.problems.push(format!("{shown}:{}: does not parse: {e}", e.span().start().line));
                continue;
            }
        };
        src.modules.insert(module.clone());
        let mut v = FileVisitor { file: &shown, module, dir, children: Vec::new(), out: &mut src };
        for item in &parsed.items {
            v.visit_item(item);
        }
        for (child, child_dir) in std::mem::take(&mut v.children) {
            let name = child.last().cloned().unwrap_or_default();
            let parent_dir = child_dir.parent().unwrap_or(Path::new("")).to_path_buf();
            let flat = parent_dir.join(format!("{name}.rs"));
            let nested = child_dir.join("mod.rs");
            if read(&flat).is_some() {
                todo.push((child, flat, child_dir));
            } else if read(&nested).is_some() {
                todo.push((child, nested, child_dir));
            } else {
                v.out.problems.push(format!(
                    "{shown}: module {} has neither {} nor {}",
                    show(&child),
                    flat.display(),
                    nested.display()
                ));
            }
        }
    }
    src
}

impl CrateSource {
    /// A path written in `module` as a path from the crate root; `None` when it leads outside the crate.
    fn absolute(&self, module: &[String], segments: &[String]) -> Option<Vec<String>> {
        let first = segments.first()?;
        match first.as_str() {
            "crate" => Some(segments[1..].to_vec()),
            "self" => Some(module.iter().chain(&segments[1..]).cloned().collect()),
            "super" => {
                let mut base = module.to_vec();
                let mut rest = segments;
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop()?;
                    rest = &rest[1..];
                }
                Some(base.into_iter().chain(rest.iter().cloned()).collect())
            }
            name => {
                let mut child = module.to_vec();
                child.push(name.to_string());
                self.modules.contains(&child).then(|| module.iter().chain(segments).cloned().collect())
            }
        }
    }

    /// The module that defines what an absolute path names, through `use` items (re-exports).
    fn defining_module(&self, path: &[String], depth: usize) -> ModPath {
        let mut module: ModPath = Vec::new();
        for (i, seg) in path.iter().enumerate() {
            let mut next = module.clone();
            next.push(seg.clone());
            if self.modules.contains(&next) {
                module = next;
                continue;
            }
            if depth < 16
                && let Some(target) = self.reexports.get(&(module.clone(), seg.clone()))
                && let Some(abs) = self.absolute(&module, target)
            {
                let full: Vec<String> = abs.into_iter().chain(path[i + 1..].iter().cloned()).collect();
                return self.defining_module(&full, depth + 1);
            }
            break;
        }
        module
    }

    /// Every import between two different modules.
    fn edges(&self) -> Vec<Edge> {
        let mut edges = Vec::new();
        for p in &self.paths {
            let Some(abs) = self.absolute(&p.module, &p.segments) else { continue };
            let to = self.defining_module(&abs, 0);
            if to != p.module {
                edges.push(Edge { from: p.module.clone(), to, at: p.at.clone() });
            }
        }
        edges
    }
}

/// Circles among the direct children of every folder: one line per circle (a strongly connected set of siblings),
/// naming the circle and one import for each of its steps.
fn cycles(modules: &BTreeSet<ModPath>, edges: &[Edge]) -> Vec<String> {
    let mut problems = Vec::new();
    for parent in modules {
        let depth = parent.len();
        // sibling → sibling → an example import
        let mut graph: BTreeMap<&str, BTreeMap<&str, &Edge>> = BTreeMap::new();
        for e in edges {
            if e.from.len() > depth && e.to.len() > depth && e.from.starts_with(parent) && e.to.starts_with(parent) {
                let (a, b) = (e.from[depth].as_str(), e.to[depth].as_str());
                if a != b {
                    graph.entry(a).or_default().entry(b).or_insert(e);
                }
            }
        }
        for scc in strongly_connected(&graph) {
            if scc.len() < 2 {
                continue;
            }
            // One circle through the whole set's first member, found by a walk inside the set.
            let start = scc[0];
            let inside: BTreeSet<&str> = scc.iter().copied().collect();
            let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
            let mut queue = std::collections::VecDeque::from([start]);
            let mut back = None;
            while let Some(n) = queue.pop_front() {
                for &m in graph.get(n).map(|m| m.keys().collect::<Vec<_>>()).unwrap_or_default() {
                    if m == start {
                        back = Some(n);
                        break;
                    }
                    if inside.contains(m) && !prev.contains_key(m) {
                        prev.insert(m, n);
                        queue.push_back(m);
                    }
                }
                if back.is_some() {
                    break;
                }
            }
            let mut circle = vec![start];
            let mut n = back.unwrap_or(start);
            while n != start {
                circle.insert(1, n);
                n = prev[n];
            }
            circle.push(start);
            let name = |s: &str| show(&parent.iter().cloned().chain([s.to_string()]).collect::<Vec<_>>());
            let steps: Vec<String> = circle
                .windows(2)
                .map(|w| format!("{} → {} ({})", name(w[0]), name(w[1]), graph[w[0]][w[1]].at))
                .collect();
            problems.push(format!(
                "import cycle in {} among {{{}}}: {}",
                show(parent),
                scc.iter().map(|s| name(s)).collect::<Vec<_>>().join(", "),
                steps.join("; ")
            ));
        }
    }
    problems
}

/// Tarjan's strongly connected components of a small graph.
fn strongly_connected<'a>(graph: &BTreeMap<&'a str, BTreeMap<&'a str, &Edge>>) -> Vec<Vec<&'a str>> {
    struct State<'a> {
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<&'a str>>,
    }
    fn visit<'a>(n: &'a str, graph: &BTreeMap<&'a str, BTreeMap<&'a str, &Edge>>, s: &mut State<'a>) {
        let i = s.index.len();
        s.index.insert(n, i);
        s.low.insert(n, i);
        s.stack.push(n);
        s.on_stack.insert(n);
        for &m in graph.get(n).map(|m| m.keys().collect::<Vec<_>>()).unwrap_or_default() {
            if !s.index.contains_key(m) {
                visit(m, graph, s);
                let l = s.low[n].min(s.low[m]);
                s.low.insert(n, l);
            } else if s.on_stack.contains(m) {
                let l = s.low[n].min(s.index[m]);
                s.low.insert(n, l);
            }
        }
        if s.low[n] == s.index[n] {
            let mut scc = Vec::new();
            while let Some(m) = s.stack.pop() {
                s.on_stack.remove(m);
                scc.push(m);
                if m == n {
                    break;
                }
            }
            scc.sort_unstable();
            s.out.push(scc);
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for &n in graph.keys() {
        if !s.index.contains_key(n) {
            visit(n, graph, &mut s);
        }
    }
    s.out
}

/// The layer (index, name) of a module: the longest table entry that is a prefix of its path.
fn layer_of<'a>(layers: Layers<'a>, module: &[String]) -> Option<(usize, &'a str)> {
    let mut best: Option<(usize, usize, &str)> = None;
    for (i, (name, entries)) in layers.iter().enumerate() {
        for entry in *entries {
            let e: Vec<&str> = entry.split("::").collect();
            if module.len() >= e.len()
                && module.iter().zip(&e).all(|(a, b)| a == b)
                && best.is_none_or(|(len, _, _)| e.len() > len)
            {
                best = Some((e.len(), i, name));
            }
        }
    }
    best.map(|(_, i, name)| (i, name))
}

/// Imports from a later layer into an earlier one, and modules the table does not place.
fn layer_violations(layers: Layers<'_>, modules: &BTreeSet<ModPath>, edges: &[Edge]) -> Vec<String> {
    let mut problems = Vec::new();
    for m in modules.iter().filter(|m| !m.is_empty()) {
        if layer_of(layers, m).is_none() {
            problems.push(format!("module {} is in no layer of the table", show(m)));
        }
    }
    for e in edges.iter().filter(|e| !e.from.is_empty() && !e.to.is_empty()) {
        if let (Some((fi, fname)), Some((ti, tname))) = (layer_of(layers, &e.from), layer_of(layers, &e.to))
            && ti > fi
        {
            problems.push(format!(
                "{} (layer {fname}) imports {} (layer {tname}, a later one): {}",
                show(&e.from),
                show(&e.to),
                e.at
            ));
        }
    }
    problems
}

/// Every problem of one crate: unreadable files, cycles, and layer violations against `layers`.
fn check_crate(root: &Path, layers: Layers<'_>, read: &dyn Fn(&Path) -> Option<String>) -> Vec<String> {
    let src = read_crate(root, read);
    let edges = src.edges();
    let mut problems = src.problems.clone();
    problems.extend(cycles(&src.modules, &edges));
    problems.extend(layer_violations(layers, &src.modules, &edges));
    problems
}

/// Reads a file of the workspace (path relative to its root).
fn read_disk(path: &Path) -> Option<String> {
    std::fs::read_to_string(workspace().join(path)).ok()
}

/// The workspace's root folder.
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ has a parent").to_path_buf()
}

/// plotter-path's stages, as DESIGN §1 draws them: a stage imports only from earlier stages and the shared
/// configuration. `geometry` (the `Drawing` model every input builds, flattening, regions, layout) comes before
/// `input` in import order although layout runs after the import in the data flow.
const PLOTTER_PATH: Layers<'static> = &[
    ("config", &["config"]),
    ("geometry", &["geometry"]),
    ("input", &["input"]),
    ("optimize", &["optimize"]),
    ("motion", &["motion"]),
    ("output", &["output"]),
];

#[test]
fn plotter_path_stages_import_only_downstream() {
    let problems = check_crate(Path::new("plotter-path/src/lib.rs"), PLOTTER_PATH, &read_disk);
    assert!(problems.is_empty(), "plotter-path imports:\n{}", problems.join("\n"));
}

/// plotter-cli's library (`plotter_host`), lowest first: the stop flag every wait reads; the error every part
/// returns; the option groups; the input loader; the link to the machine (transports, sessions, dialects,
/// connecting, jogging); the user's state directory, where the link's journals are kept; the plot job, which
/// drives the link.
const PLOTTER_CLI_LIB: Layers<'static> = &[
    ("stop", &["stop"]),
    ("error", &["error"]),
    ("options", &["options"]),
    ("input", &["input"]),
    ("link", &["link"]),
    ("state", &["state_dir"]),
    ("job", &["job"]),
    ("studio", &["studio"]),
];

/// The `plotter` binary, above the library (which it reaches only as the external crate `plotter_host`): helpers,
/// the web app, and the subcommands — of which `plotter serve` starts the web app; the web app never imports a
/// subcommand.
const PLOTTER_CLI_BIN: Layers<'static> =
    &[("helpers", &["time_parts", "sim_qemu"]), ("web app", &["serve"]), ("commands", &["cmd"])];

#[test]
fn plotter_cli_library_imports_only_downstream() {
    let problems = check_crate(Path::new("plotter-cli/src/lib.rs"), PLOTTER_CLI_LIB, &read_disk);
    assert!(problems.is_empty(), "plotter-cli library imports:\n{}", problems.join("\n"));
}

#[test]
fn plotter_cli_front_ends_import_only_the_library() {
    let root = Path::new("plotter-cli/src/bin/plotter/main.rs");
    let problems = check_crate(root, PLOTTER_CLI_BIN, &read_disk);
    assert!(problems.is_empty(), "plotter binary imports:\n{}", problems.join("\n"));
    // Not vacuous: both front ends and the subcommand that starts the web app are read.
    let src = read_crate(root, &read_disk);
    let has = |m: &str| src.modules.contains(&m.split("::").map(String::from).collect::<Vec<_>>());
    assert!(has("cmd::plot") && has("cmd::serve") && has("serve::worker") && has("serve::command"));
    let edges = src.edges();
    assert!(edges.iter().any(|e| e.from == ["cmd", "serve"] && e.to.first().is_some_and(|t| t == "serve")));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A made-up crate: (file under `src/`, contents).
    fn check(files: &[(&str, &str)], layers: Layers<'_>) -> Vec<String> {
        let map: BTreeMap<PathBuf, String> =
            files.iter().map(|(p, c)| (Path::new("src").join(p), c.to_string())).collect();
        check_crate(Path::new("src/lib.rs"), layers, &|p| map.get(p).cloned())
    }

    const ABC: Layers<'static> = &[("a", &["a"]), ("b", &["b"]), ("c", &["c"])];

    #[test]
    fn a_clean_crate_passes() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c; pub use a::Thing;"),
            ("a.rs", "pub struct Thing;"),
            ("b/mod.rs", "pub mod inner; use crate::Thing; pub fn f(_: Thing) { inner::g() }"),
            ("b/inner.rs", "use super::super::a::Thing; pub fn g() { let _ = crate::a::Thing; }"),
            ("c.rs", "use crate::b::{self, inner::g}; fn h() { b::f(crate::Thing); g() }"),
        ];
        assert_eq!(check(&files, ABC), Vec::<String>::new());
    }

    #[test]
    fn an_upward_import_is_found_through_a_reexport() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c; pub use c::Late;"),
            ("a.rs", "fn f() -> crate::Late { todo!() }"),
            ("b.rs", ""),
            ("c.rs", "pub struct Late;"),
        ];
        let problems = check(&files, ABC);
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].starts_with("a (layer a) imports c (layer c, a later one): src/a.rs:1 `crate::Late`"),
            "{problems:?}"
        );
    }

    #[test]
    fn an_upward_import_in_a_macro_or_a_nested_use_is_found() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c;"),
            ("a.rs", "pub mod deep;"),
            ("a/deep.rs", "fn f() {\n    let v = vec![crate::b::X];\n    { use crate::c::Y as Z; }\n}"),
            ("b.rs", "pub const X: u8 = 0;"),
            ("c.rs", "pub struct Y;"),
        ];
        let problems = check(&files, ABC);
        assert_eq!(
            problems,
            [
                "a::deep (layer a) imports b (layer b, a later one): src/a/deep.rs:2 `crate::b::X`",
                "a::deep (layer a) imports c (layer c, a later one): src/a/deep.rs:3 `crate::c::Y`",
            ]
        );
    }

    #[test]
    fn test_modules_are_left_out() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c;"),
            ("a.rs", "#[cfg(test)]\nmod tests { use crate::c::Y; }\n#[cfg(test)]\nmod more;"),
            ("b.rs", ""),
            ("c.rs", "pub struct Y;"),
        ];
        // `a/more.rs` does not even exist: a test module is not followed.
        assert_eq!(check(&files, ABC), Vec::<String>::new());
    }

    #[test]
    fn a_cycle_between_siblings_is_found_with_its_steps() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c;"),
            ("a.rs", "pub mod x; pub mod y; pub mod z;"),
            ("a/x.rs", "use super::y::Y; pub struct X;"),
            ("a/y.rs", "pub struct Y; fn f() { let _ = super::z::Z; }"),
            ("a/z.rs", "pub struct Z; use crate::a::x::X;"),
            ("b.rs", ""),
            ("c.rs", ""),
        ];
        let problems = check(&files, ABC);
        assert_eq!(
            problems,
            ["import cycle in a among {a::x, a::y, a::z}: a::x → a::y (src/a/x.rs:1 `super::y::Y`); \
              a::y → a::z (src/a/y.rs:1 `super::z::Z`); a::z → a::x (src/a/z.rs:1 `crate::a::x::X`)"]
        );
    }

    #[test]
    fn a_cycle_between_folders_counts_their_files() {
        // b's child imports c, c's child imports b: the folders b and c form a circle, and b imports c which is a
        // later layer.
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c;"),
            ("a.rs", ""),
            ("b/mod.rs", "pub mod p;"),
            ("b/p.rs", "pub fn p() { crate::c::q::q() }"),
            ("c/mod.rs", "pub mod q;"),
            ("c/q.rs", "pub fn q() { crate::b::p::p() }"),
        ];
        let problems = check(&files, ABC);
        assert_eq!(problems.len(), 2, "{problems:?}");
        assert!(problems[0].starts_with("import cycle in crate among {b, c}: b → c (src/b/p.rs:1"), "{problems:?}");
        assert!(problems[1].starts_with("b::p (layer b) imports c::q (layer c"), "{problems:?}");
    }

    #[test]
    fn a_module_outside_the_table_and_a_missing_file_are_reported() {
        let files = [
            ("lib.rs", "pub mod a; pub mod b; pub mod c; pub mod extra; mod gone;"),
            ("a.rs", ""),
            ("b.rs", ""),
            ("c.rs", ""),
            ("extra.rs", ""),
        ];
        let problems = check(&files, ABC);
        assert_eq!(problems.len(), 2, "{problems:?}");
        assert!(problems[0].contains("module gone has neither src/gone.rs nor src/gone/mod.rs"), "{problems:?}");
        assert_eq!(problems[1], "module extra is in no layer of the table");
    }

    #[test]
    fn the_real_plotter_path_tree_is_read() {
        // Not vacuous on the real tree: its modules and the imports between its stages are seen.
        let src = read_crate(Path::new("plotter-path/src/lib.rs"), &read_disk);
        assert!(src.problems.is_empty(), "{:?}", src.problems);
        let has = |m: &str| src.modules.contains(&m.split("::").map(String::from).collect::<Vec<_>>());
        assert!(
            has("input::svg::walk::pattern")
                && has("input::gen::spiral")
                && has("optimize::kdtree")
                && has("output::stats")
        );
        assert!(!has("input::svg::tests") && !has("input::fuzz"), "test modules are left out");
        let edges = src.edges();
        let stage_edge = |from: &str, to: &str| {
            edges.iter().any(|e| e.from.first().is_some_and(|f| f == from) && e.to.first().is_some_and(|t| t == to))
        };
        assert!(stage_edge("input", "geometry") && stage_edge("output", "motion") && stage_edge("motion", "geometry"));
    }
}
