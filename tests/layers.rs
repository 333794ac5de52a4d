//! The structure ARCHITECTURE.md states holds in the code:
//! - every top-level module of `core/src` imports only from modules on floors below its own (the
//!   floors are ARCHITECTURE.md's table under "Core's floors");
//! - no import loop between the modules of one folder, at any depth of `core/src`, `src`,
//!   `studio/src`, `robot/src` and `msgs/src` (files and folders beside each other as the nodes);
//! - no source file (tests apart) over 600 lines.
//!
//! Imports are read as text: `crate::a::…` and `super::a::…` paths in code (comments, doc text,
//! `#[cfg(doc)]` items and test code are left out), resolved to the sibling they name.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The code lines of a source file: no comments, no test code (from `#[cfg(test)]` at the
/// start of a line to the end of the file, where this codebase keeps it), no `#[cfg(doc)]` item.
fn code_lines(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut out = Vec::new();
    let mut skip_next = false;
    for line in text.lines() {
        let t = line.trim_start();
        if line.starts_with("#[cfg(test)]") {
            break;
        }
        if t.starts_with("#[cfg(doc)]") {
            skip_next = true;
            continue;
        }
        if skip_next {
            skip_next = !t.ends_with(';') && !t.ends_with('}');
            continue;
        }
        if t.starts_with("//") {
            continue;
        }
        out.push(line.split("//").next().unwrap_or("").to_string());
    }
    out
}

/// Identifiers that follow `prefix` in `line` (`crate::sim::…` → `sim`), and those listed in a
/// brace group right after it (`crate::{a, b::c}` → `a`, `b`).
fn names_after(line: &str, prefix: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find(prefix) {
        let before = rest[..at].chars().last();
        rest = &rest[at + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String = item.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                if !name.is_empty() {
                    out.push(name);
                }
            }
        } else {
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if !name.is_empty() {
                out.push(name);
            }
        }
    }
    out
}

/// Every `.rs` file under `dir`, test files (`tests.rs`, `*_tests.rs`, a `tests/` folder) left out.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if name != "tests" {
                    stack.push(p);
                }
            } else if name.ends_with(".rs") && name != "tests.rs" && !name.ends_with("_tests.rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The child of `dir` a file belongs to (`dir/a.rs` and `dir/a/…` → `a`).
fn child_of(dir: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(dir).ok()?;
    let first = rel.components().next()?.as_os_str().to_string_lossy().to_string();
    Some(first.trim_end_matches(".rs").to_string())
}

/// Import edges between the children of `dir` (a folder of modules), for a crate rooted at
/// `crate_root`: from the files of each child to the siblings they name.
fn sibling_edges(crate_root: &Path, dir: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let children: BTreeSet<String> =
        sources(dir).iter().filter_map(|f| child_of(dir, f)).filter(|c| c != "mod" && c != "lib" && c != "main").collect();
    // The module path of `dir` inside the crate: `crate::a::b` for crate_root/a/b.
    let module: Vec<String> =
        dir.strip_prefix(crate_root).unwrap().components().map(|c| c.as_os_str().to_string_lossy().to_string()).collect();
    let crate_prefix = if module.is_empty() { "crate::".to_string() } else { format!("crate::{}::", module.join("::")) };
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in sources(dir) {
        let Some(child) = child_of(dir, &file).filter(|c| children.contains(c)) else { continue };
        // `super::` of a file directly in `dir` is `dir`'s module; one folder deeper, `super::super::`.
        let depth = file.strip_prefix(dir).unwrap().components().count();
        let is_mod = file.file_name().is_some_and(|n| n == "mod.rs");
        let supers = if is_mod { depth - 1 } else { depth };
        let super_prefix = "super::".repeat(supers);
        for line in code_lines(&file) {
            let mut named = names_after(&line, &crate_prefix);
            if supers > 0 {
                named.extend(names_after(&line, &super_prefix));
            }
            for n in named {
                if n != child && children.contains(&n) {
                    edges.entry(child.clone()).or_default().insert(n);
                }
            }
        }
    }
    edges
}

/// A loop in `edges`, if any (as the list of nodes around it).
fn find_loop(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            match state.get(m.as_str()) {
                Some(1) => {
                    let at = stack.iter().position(|s| s == m).unwrap();
                    return Some(stack[at..].to_vec());
                }
                Some(_) => {}
                None => {
                    if let Some(l) = visit(m, edges, state, stack) {
                        return Some(l);
                    }
                }
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in edges.keys() {
        if !state.contains_key(n.as_str())
            && let Some(l) = visit(n, edges, &mut state, &mut Vec::new())
        {
            return Some(l);
        }
    }
    None
}

/// Every folder of modules under `src` (itself included).
fn module_dirs(src: &Path) -> Vec<PathBuf> {
    let mut out = vec![src.to_path_buf()];
    let mut stack = vec![src.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() && p.file_name().is_some_and(|n| n != "tests") {
                out.push(p.clone());
                stack.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The source folders of the workspace's crates (each must exist: a renamed crate is not
/// silently skipped).
fn crate_sources() -> Vec<PathBuf> {
    ["core/src", "src", "studio/src", "robot/src", "msgs/src"]
        .iter()
        .map(|krate| {
            let dir = root().join(krate);
            assert!(dir.is_dir(), "{krate} is not a folder");
            dir
        })
        .collect()
}

#[test]
fn no_import_loop_between_the_modules_of_a_folder() {
    let mut loops = Vec::new();
    for src in crate_sources() {
        for dir in module_dirs(&src) {
            if let Some(l) = find_loop(&sibling_edges(&src, &dir)) {
                loops.push(format!("{}: {}", dir.strip_prefix(root()).unwrap().display(), l.join(" → ")));
            }
        }
    }
    assert!(loops.is_empty(), "import loops:\n{}", loops.join("\n"));
}

/// ARCHITECTURE.md's floors of core: `| N | `a`, `b` |` rows after the "Core's floors" line.
fn floors() -> BTreeMap<String, u32> {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let start = text.find("Core's floors").expect("ARCHITECTURE.md names core's floors");
    let mut out = BTreeMap::new();
    for line in text[start..].lines().skip(1).skip_while(|l| !l.starts_with('|')).take_while(|l| l.starts_with('|')) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Ok(floor) = cells[1].parse::<u32>() else { continue };
        for m in cells[2].split(',') {
            out.insert(m.trim().trim_matches('`').to_string(), floor);
        }
    }
    out
}

#[test]
fn every_core_module_imports_only_from_floors_below_its_own() {
    let floors = floors();
    let src = root().join("core/src");
    let edges = sibling_edges(&src, &src);
    let modules: BTreeSet<String> = sources(&src).iter().filter_map(|f| child_of(&src, f)).filter(|c| c != "lib").collect();
    for m in &modules {
        assert!(floors.contains_key(m), "core module `{m}` is on no floor of ARCHITECTURE.md");
    }
    let mut up = Vec::new();
    for (from, tos) in &edges {
        for to in tos {
            if floors[to] >= floors[from] {
                up.push(format!("{from} (floor {}) imports {to} (floor {})", floors[from], floors[to]));
            }
        }
    }
    assert!(up.is_empty(), "imports that do not go down:\n{}", up.join("\n"));
}

/// Most lines a source file (tests apart) may have: a file holds one concept.
const MAX_FILE_LINES: usize = 600;

#[test]
fn no_source_file_is_longer_than_a_concept() {
    let mut long = Vec::new();
    for dir in crate_sources() {
        for file in sources(&dir) {
            let lines = std::fs::read_to_string(&file).unwrap().lines().count();
            if lines > MAX_FILE_LINES {
                long.push(format!("{}: {lines} lines", file.strip_prefix(root()).unwrap().display()));
            }
        }
    }
    assert!(long.is_empty(), "files over {MAX_FILE_LINES} lines:\n{}", long.join("\n"));
}
