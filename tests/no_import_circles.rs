//! The house has no import circles: within each crate, no two sibling modules reach each
//! other through `super::x` or `crate::a::x` paths, directly or round a longer loop (issue
//! 56). Drawn from the code outside `#[cfg(test)]`, comments and string literals; a path
//! into a sibling's submodule counts as a path into the sibling.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

/// Every module of the crate rooted at `src`, by its path, with its file.
fn modules(src: &Path) -> BTreeMap<Module, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut parts: Module = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if matches!(
                    parts.last().map(String::as_str),
                    Some("mod" | "lib" | "main")
                ) {
                    parts.pop();
                }
                out.insert(parts, path);
            }
        }
    }
    out
}

/// The code of a file that builds outside tests: before its first `#[cfg(test)]`, without
/// comment lines and with string literals emptied.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = String::new();
    for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
        let mut in_string = false;
        let mut escaped = false;
        for c in line.chars() {
            if in_string {
                if escaped {
                    escaped = false;
                } else if c == '\\' {
                    escaped = true;
                } else if c == '"' {
                    in_string = false;
                    out.push('"');
                }
                continue;
            }
            if c == '"' {
                in_string = true;
            }
            out.push(c);
        }
        out.push('\n');
    }
    out
}

/// The module paths `text` names after `prefix` (`super::` or `crate::`), each as its
/// segments.
fn paths_after(text: &str, prefix: &str) -> Vec<Module> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find(prefix) {
        let before = rest[..at].chars().last();
        rest = &rest[at + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let mut segments = Vec::new();
        let mut tail = rest;
        loop {
            let end = tail
                .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
                .unwrap_or(tail.len());
            if end == 0 {
                break;
            }
            segments.push(tail[..end].to_string());
            if !tail[end..].starts_with("::") {
                break;
            }
            tail = &tail[end + 2..];
        }
        if !segments.is_empty() {
            out.push(segments);
        }
    }
    out
}

/// Sibling edges: `from` reaches `to`, both children of the same module.
fn sibling_edges(mods: &BTreeMap<Module, PathBuf>) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    let mut add = |from: &Module, to: &Module| {
        let common = from.iter().zip(to).take_while(|(a, b)| a == b).count();
        if common < from.len() && common < to.len() {
            edges
                .entry(from[..=common].to_vec())
                .or_default()
                .insert(to[..=common].to_vec());
        }
    };
    for (module, file) in mods {
        let text = code(&std::fs::read_to_string(file).unwrap());
        let parent = &module[..module.len().saturating_sub(1)];
        for segs in paths_after(&text, "super::") {
            let mut target = parent.to_vec();
            target.push(segs[0].clone());
            if mods.contains_key(&target) && &target != module {
                add(module, &target);
            }
        }
        for segs in paths_after(&text, "crate::") {
            if let Some(k) = (1..=segs.len())
                .rev()
                .find(|&k| mods.contains_key(&segs[..k].to_vec()))
            {
                add(module, &segs[..k].to_vec());
            }
        }
    }
    edges
}

/// The strongly connected components of more than one module (Tarjan).
fn circles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'a> {
        edges: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<Module, usize>,
        low: BTreeMap<Module, usize>,
        stack: Vec<Module>,
        on: BTreeSet<Module>,
        found: Vec<Vec<Module>>,
    }
    fn visit(s: &mut State, v: &Module) {
        let i = s.index.len();
        s.index.insert(v.clone(), i);
        s.low.insert(v.clone(), i);
        s.stack.push(v.clone());
        s.on.insert(v.clone());
        for w in s.edges.get(v).cloned().unwrap_or_default() {
            if !s.index.contains_key(&w) {
                visit(s, &w);
                let lw = s.low[&w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.on.contains(&w) {
                let iw = s.index[&w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on.remove(&w);
                let done = &w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                s.found.push(component);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.found
}

#[test]
fn no_crate_of_the_workspace_has_an_import_circle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for src in ["src", "sim/src", "hal/src", "learn/src"] {
        let mods = modules(&root.join(src));
        assert!(mods.len() > 5, "{src}: {} modules", mods.len());
        let found = circles(&sibling_edges(&mods));
        let shown: Vec<Vec<String>> = found
            .iter()
            .map(|c| c.iter().map(|m| m.join("::")).collect())
            .collect();
        assert!(shown.is_empty(), "{src}: import circles {shown:?}");
    }
}

#[test]
fn the_check_sees_a_circle_of_two_and_one_of_three() {
    let m = |s: &str| -> Module { s.split("::").map(String::from).collect() };
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    edges.entry(m("a::x")).or_default().insert(m("a::y"));
    edges.entry(m("a::y")).or_default().insert(m("a::x"));
    edges.entry(m("b")).or_default().insert(m("c"));
    edges.entry(m("c")).or_default().insert(m("d"));
    edges.entry(m("d")).or_default().insert(m("b"));
    edges.entry(m("e")).or_default().insert(m("b"));
    let mut sizes: Vec<usize> = circles(&edges).iter().map(Vec::len).collect();
    sizes.sort_unstable();
    assert_eq!(sizes, [2, 3]);
    // paths are read from code, not from comments or strings
    let text = code("use super::a::b;\n// super::c\nlet s = \"super::d\";\nx(crate::e::f);\n");
    assert_eq!(paths_after(&text, "super::"), [m("a::b")]);
    assert_eq!(paths_after(&text, "crate::"), [m("e::f")]);
}
