//! The firmware core's layers (drawn in the crate docs): every `crate::`/`super::` path in `plotter-fw/src` is read,
//! resolved to the module it names, and checked against the layer table — a module may use its own layer or a
//! lower one, never a higher one, and the modules' imports must not form a cycle.
//!
//! The checker is a small pure function (source files → import edges → violations) with the layer table as data,
//! so it can serve other crates too. Unit tests (`#[cfg(test)] mod tests` at the bottom of a file) are not part of
//! the layered build and are not read.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::Path;

/// The firmware's layers: a folder of `src/` (or a module at its root) and its layer, lowest first.
/// A name ending in `/` is a folder grouping modules of one layer; without, a module (with its submodules).
const FIRMWARE_LAYERS: &[(&str, u8)] = &[("types/", 0), ("logic/", 1), ("drivers/", 2), ("machine", 3), ("sim", 4)];

/// A use of one module by another.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
struct Edge {
    /// The using module, e.g. `thermal::pid`.
    from: String,
    /// The used module.
    to: String,
}

/// The module a source file defines, from its path under `src/` (`None` for the crate root and a layer folder's
/// own `mod.rs`). A layer folder (a table entry ending in `/`) is left out, since its modules are public at the
/// crate root: `logic/thermal/pid.rs` → `thermal::pid`, `machine/link.rs` → `machine::link`.
fn module_of(path: &str, layers: &[(&str, u8)]) -> Option<String> {
    let path = path.strip_suffix(".rs")?;
    let mut parts: Vec<&str> = path.split('/').collect();
    if parts.last() == Some(&"mod") {
        parts.pop();
    }
    if parts.first().is_some_and(|f| is_folder(f, layers)) {
        parts.remove(0);
    }
    if parts.is_empty() || parts.as_slice() == ["lib"] {
        return None;
    }
    Some(parts.join("::"))
}

/// Whether `name` is a layer folder (its modules sit at the crate root) rather than a module.
fn is_folder(name: &str, layers: &[(&str, u8)]) -> bool {
    layers.iter().any(|(f, _)| f.strip_suffix('/') == Some(name))
}

/// The layer of a file, from its folder (or its own module at the root).
fn layer_of_file(path: &str, layers: &[(&str, u8)]) -> Option<u8> {
    let first = path.split('/').next()?.trim_end_matches(".rs");
    layers.iter().find(|(f, _)| f.trim_end_matches('/') == first).map(|(_, l)| *l)
}

/// Code without comments, up to the unit tests.
fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("//") {
            rest = r.find('\n').map_or("", |i| &r[i..]);
        } else if let Some(r) = rest.strip_prefix("/*") {
            rest = r.find("*/").map_or("", |i| &r[i + 2..]);
        } else if rest.starts_with('"') {
            // A string literal: skipped, escapes included.
            let mut end = 1;
            let b = rest.as_bytes();
            while end < b.len() && b[end] != b'"' {
                end += if b[end] == b'\\' { 2 } else { 1 };
            }
            rest = &rest[(end + 1).min(rest.len())..];
            out.push_str("\"\"");
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            out.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    out
}

fn ident_len(s: &str) -> usize {
    s.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(s.len())
}

/// The paths after each `prefix` in `code` (`crate::a::b::C` → `a::b::C`), groups expanded
/// (`crate::{a::X, b::{Y, Z}}` → `a::X`, `b`).
fn paths_after(code: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    let mut from = 0;
    while let Some(i) = code[from..].find(prefix) {
        let start = from + i;
        from = start + prefix.len();
        // Part of a longer name (`my_crate::`)?
        if code[..start].chars().next_back().is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue;
        }
        collect_path(&code[from..], Vec::new(), &mut paths);
    }
    paths
}

fn collect_path(s: &str, mut segs: Vec<String>, out: &mut Vec<Vec<String>>) {
    let mut s = s.trim_start();
    loop {
        if let Some(group) = s.strip_prefix('{') {
            // Split the group's items at top-level commas.
            let mut depth = 0;
            let mut item_start = 0;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        collect_path(&group[item_start..i], segs.clone(), out);
                        return;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        collect_path(&group[item_start..i], segs.clone(), out);
                        item_start = i + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let n = ident_len(s);
        if n == 0 {
            break;
        }
        segs.push(s[..n].to_string());
        s = &s[n..];
        match s.strip_prefix("::") {
            Some(r) => s = r.trim_start(),
            None => break,
        }
    }
    if !segs.is_empty() && segs[0] != "self" {
        out.push(segs);
    }
}

/// The module a path names: its longest prefix that is a known module (a layer folder in it is skipped).
fn resolve(segs: &[String], modules: &BTreeSet<String>, layers: &[(&str, u8)]) -> Option<String> {
    let segs = if segs.first().is_some_and(|f| is_folder(f, layers)) { &segs[1..] } else { segs };
    (1..=segs.len()).rev().map(|n| segs[..n].join("::")).find(|m| modules.contains(m))
}

/// Every use of one module by another in `files` (path under `src/`, text), and the paths that name no module.
fn edges(files: &[(&str, &str)], layers: &[(&str, u8)]) -> (Vec<Edge>, Vec<String>) {
    let modules: BTreeSet<String> = files.iter().filter_map(|(p, _)| module_of(p, layers)).collect();
    let mut edges = BTreeSet::new();
    let mut unknown = Vec::new();
    for (path, text) in files {
        let Some(from) = module_of(path, layers) else { continue };
        let code = code_of(text);
        let parent = from.rsplit_once("::").map_or("", |(p, _)| p).to_string();
        let mut targets: Vec<(Vec<String>, String)> = Vec::new();
        for p in paths_after(&code, "crate::") {
            targets.push((p, String::new()));
        }
        for p in paths_after(&code, "super::") {
            targets.push((p, parent.clone()));
        }
        // `use child::...` of a module declared in this file (`mod child;`).
        for line in code.lines() {
            let line = line.trim();
            if let Some(child) = line.strip_prefix("mod ").or_else(|| line.strip_prefix("pub mod ")) {
                let child = child.trim_end_matches(';');
                for p in paths_after(&code, &format!("use {child}::")) {
                    let mut segs = vec![child.to_string()];
                    segs.extend(p);
                    targets.push((segs, from.clone()));
                }
            }
        }
        for (segs, base) in targets {
            let full: Vec<String> = base.split("::").filter(|s| !s.is_empty()).map(String::from).chain(segs).collect();
            match resolve(&full, &modules, layers) {
                Some(to) if to != from => {
                    edges.insert(Edge { from: from.clone(), to });
                }
                Some(_) => {}
                None => unknown.push(format!("{path}: `{}` names no module of the crate", full.join("::"))),
            }
        }
    }
    (edges.into_iter().collect(), unknown)
}

/// The layer rules broken by `edges`: an import from a higher layer, or a cycle of imports.
fn violations(edges: &[Edge], layer: &BTreeMap<String, u8>) -> Vec<String> {
    let mut out = Vec::new();
    let top = |m: &str| m.split("::").next().unwrap_or(m).to_string();
    for e in edges {
        let (Some(&from), Some(&to)) = (layer.get(&top(&e.from)), layer.get(&top(&e.to))) else {
            out.push(format!("{} -> {}: module without a layer", e.from, e.to));
            continue;
        };
        if to > from {
            out.push(format!("{} (layer {from}) imports {} (layer {to}), a higher layer", e.from, e.to));
        }
    }
    // Cycles: a depth-first search that reports each back edge's loop.
    let mut next: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for e in edges {
        next.entry(&e.from).or_default().push(&e.to);
    }
    let mut state: BTreeMap<&str, u8> = BTreeMap::new(); // 1 on the stack, 2 done
    let mut stack: Vec<&str> = Vec::new();
    fn visit<'a>(
        m: &'a str,
        next: &BTreeMap<&'a str, Vec<&'a str>>,
        state: &mut BTreeMap<&'a str, u8>,
        stack: &mut Vec<&'a str>,
        out: &mut Vec<String>,
    ) {
        state.insert(m, 1);
        stack.push(m);
        for &n in next.get(m).map(Vec::as_slice).unwrap_or(&[]) {
            match state.get(n) {
                Some(1) => {
                    let at = stack.iter().position(|s| *s == n).unwrap_or(0);
                    out.push(format!("import cycle: {} -> {n}", stack[at..].join(" -> ")));
                }
                Some(_) => {}
                None => visit(n, next, state, stack, out),
            }
        }
        stack.pop();
        state.insert(m, 2);
    }
    let starts: Vec<&str> = next.keys().copied().collect();
    for m in starts {
        if !state.contains_key(m) {
            visit(m, &next, &mut state, &mut stack, &mut out);
        }
    }
    out
}

/// Check `files` (path under `src/`, text) against `layers`: every violation, described.
fn check(files: &[(&str, &str)], layers: &[(&str, u8)]) -> Vec<String> {
    let (edges, mut out) = edges(files, layers);
    let mut layer = BTreeMap::new();
    for (path, _) in files {
        if let (Some(m), Some(l)) = (module_of(path, layers), layer_of_file(path, layers)) {
            layer.insert(m.split("::").next().unwrap_or(&m).to_string(), l);
        }
    }
    out.extend(violations(&edges, &layer));
    out
}

fn read_tree(dir: &Path, root: &Path, out: &mut Vec<(String, String)>) {
    let mut entries: Vec<_> = fs::read_dir(dir).expect("read src").map(|e| e.expect("entry").path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            read_tree(&p, root, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            let rel = p.strip_prefix(root).expect("under src").to_string_lossy().replace('\\', "/");
            out.push((rel, fs::read_to_string(&p).expect("read file")));
        }
    }
}

#[test]
fn firmware_imports_follow_the_layers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    read_tree(&root, &root, &mut files);
    let files: Vec<(&str, &str)> = files.iter().map(|(p, t)| (p.as_str(), t.as_str())).collect();
    assert!(files.len() > 30, "read {} files", files.len());
    let (edges, _) = edges(&files, FIRMWARE_LAYERS);
    // The checker sees the imports that exist (a checker that reads nothing passes everything).
    for (from, to) in
        [("planner", "step_block"), ("machine", "planner"), ("machine::link", "protocol"), ("stepper", "hal")]
    {
        assert!(edges.contains(&Edge { from: from.into(), to: to.into() }), "{from} -> {to} not seen");
    }
    let bad = check(&files, FIRMWARE_LAYERS);
    assert!(bad.is_empty(), "layer violations:\n{}", bad.join("\n"));
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAYERS: &[(&str, u8)] = &[("base/", 0), ("algo/", 1), ("top/", 2)];

    fn run(files: &[(&str, &str)]) -> Vec<String> {
        check(files, LAYERS)
    }

    #[test]
    fn paths_are_read_from_code_only() {
        let code =
            code_of("use crate::a::{b::C, d};\n// crate::x\nlet s = \"crate::y\"; /* crate::z */ crate::e::f();\n");
        let paths = paths_after(&code, "crate::");
        let want: Vec<Vec<String>> = [vec!["a", "b", "C"], vec!["a", "d"], vec!["e", "f"]]
            .iter()
            .map(|p| p.iter().map(|s| s.to_string()).collect())
            .collect();
        assert_eq!(paths, want);
        assert!(paths_after("my_crate::a", "crate::").is_empty());
        assert_eq!(module_of("algo/thermal/mod.rs", LAYERS).as_deref(), Some("thermal"));
        assert_eq!(module_of("algo/thermal/pid.rs", LAYERS).as_deref(), Some("thermal::pid"));
        assert_eq!(module_of("lib.rs", LAYERS), None);
    }

    #[test]
    fn a_clean_table_passes() {
        let files = [
            ("base/axis.rs", "pub struct Axis;"),
            ("algo/plan.rs", "use crate::axis::Axis;\nuse crate::{axis, gcode::Words};"),
            ("algo/gcode.rs", "use crate::axis::Axis; pub struct Words;"),
            (
                "top/run.rs",
                "use crate::plan; fn f() { crate::axis::Axis; }\n#[cfg(test)]\nmod tests { use crate::nothing; }",
            ),
        ];
        assert_eq!(run(&files), Vec::<String>::new());
        let (edges, _) = edges(&files, LAYERS);
        assert_eq!(edges.len(), 5, "{edges:?}");
    }

    #[test]
    fn an_upward_import_fails() {
        let files = [("base/axis.rs", "use crate::plan::Block;"), ("algo/plan.rs", "pub struct Block;")];
        assert_eq!(run(&files), ["axis (layer 0) imports plan (layer 1), a higher layer"]);
        // Also inside an expression and a group.
        let files = [("base/axis.rs", "fn f() { let _ = crate::{plan::B}; }"), ("algo/plan.rs", "")];
        assert_eq!(run(&files).len(), 1);
    }

    #[test]
    fn a_cycle_fails_even_within_a_layer() {
        let files =
            [("algo/a.rs", "use crate::b::X;"), ("algo/b.rs", "use crate::c::Y;"), ("algo/c.rs", "use crate::a::Z;")];
        assert_eq!(run(&files), ["import cycle: a -> b -> c -> a"]);
        // A child module importing its parent closes a cycle with the parent's `use child::...`.
        let files =
            [("algo/m/mod.rs", "mod k;\nuse k::Part;\npub struct Whole;"), ("algo/m/k.rs", "use super::Whole;")];
        assert_eq!(run(&files), ["import cycle: m -> m::k -> m"]);
    }

    #[test]
    fn a_path_to_no_module_is_reported() {
        let files = [("base/axis.rs", "use crate::nowhere::X;")];
        assert_eq!(run(&files), ["base/axis.rs: `nowhere::X` names no module of the crate"]);
    }
}
