//! The import graph of the crate's top-level modules has no circles: each
//! module's non-test code names other modules through `crate::` paths, and
//! no two modules reach each other (docs/architecture.md draws the layers).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level modules each module's code (line comments and
/// `#[cfg(test)]` items left out) refers to through `crate::` paths.
fn import_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut files = vec![src.to_path_buf()];
    while let Some(path) = files.pop() {
        if path.is_dir() {
            files.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
            continue;
        }
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let rel = path.strip_prefix(src).unwrap();
        let first = rel.components().next().unwrap().as_os_str().to_string_lossy().to_string();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "main" || module == "lib" {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let code: Vec<&str> = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect();
        let code = without_test_items(&code.join("\n"));
        let uses = graph.entry(module.clone()).or_default();
        for line in code.lines().map(str::trim) {
            // `crate::name` and `use crate::{a::..., b, ...}`.
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let names: Vec<&str> = match rest.strip_prefix('{') {
                    Some(group) => group.split(',').map(|n| n.trim().trim_end_matches('}')).collect(),
                    None => vec![rest],
                };
                for name in names {
                    let head: String = name.chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                    if !head.is_empty() && head != module {
                        uses.insert(head);
                    }
                }
            }
        }
    }
    graph
}

/// The text with every `#[cfg(test)]` item left out: the attribute up to
/// the end of the item it marks (its `;`, or the brace closing its body).
fn without_test_items(text: &str) -> String {
    const MARK: &str = "#[cfg(test)]";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(MARK) {
        out.push_str(&rest[..at]);
        let item = &rest[at + MARK.len()..];
        let end = match (item.find(';'), item.find('{')) {
            (Some(semi), Some(open)) if semi < open => semi + 1,
            (_, Some(open)) => {
                let mut depth = 0usize;
                let close = item[open..].char_indices().find_map(|(i, c)| {
                    match c {
                        '{' => depth += 1,
                        '}' => depth -= 1,
                        _ => {}
                    }
                    (depth == 0).then_some(open + i + 1)
                });
                close.unwrap_or(item.len())
            }
            (Some(semi), None) => semi + 1,
            (None, None) => item.len(),
        };
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// Whether `to` is reachable from `from`.
fn reaches(graph: &BTreeMap<String, BTreeSet<String>>, from: &str, to: &str) -> bool {
    let mut seen = BTreeSet::new();
    let mut stack = vec![from.to_string()];
    while let Some(m) = stack.pop() {
        for next in graph.get(&m).into_iter().flatten() {
            if next == to {
                return true;
            }
            if seen.insert(next.clone()) {
                stack.push(next.clone());
            }
        }
    }
    false
}

#[test]
fn no_two_top_level_modules_import_each_other() {
    let graph = import_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(graph.contains_key("scenario") && graph["observation"].contains("scenario"), "{graph:?}");
    let circles: Vec<String> = graph
        .iter()
        .flat_map(|(m, uses)| uses.iter().filter(|u| reaches(&graph, u, m)).map(move |u| format!("{m} -> {u}")))
        .collect();
    assert!(circles.is_empty(), "import circles: {circles:?}");
}

#[test]
fn only_the_test_items_are_left_out() {
    let text = "use crate::a;\n#[cfg(test)]\nmod t;\nuse crate::b;\n#[cfg(test)]\nmod tests {\n    fn f() { let _ = crate::c; }\n}\nuse crate::d;\n";
    let code = without_test_items(text);
    assert!(["crate::a", "crate::b", "crate::d"].iter().all(|n| code.contains(n)), "{code}");
    assert!(!code.contains("crate::c") && !code.contains("mod t"), "{code}");
}

/// Every module says what it owns in a module doc (`//!` first), and the
/// architecture page places every top-level module.
#[test]
fn every_module_has_a_doc_and_a_place_on_the_architecture_page() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let page = std::fs::read_to_string(src.join("../docs/architecture.md")).unwrap();
    let mut files = vec![src.clone()];
    let mut undocumented = Vec::new();
    while let Some(path) = files.pop() {
        if path.is_dir() {
            files.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
        } else if path.extension().is_some_and(|e| e == "rs")
            && !std::fs::read_to_string(&path).unwrap().starts_with("//!")
        {
            undocumented.push(path.strip_prefix(&src).unwrap().display().to_string());
        }
    }
    assert!(undocumented.is_empty(), "no module doc: {undocumented:?}");
    let unplaced: Vec<String> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().trim_end_matches(".rs").to_string())
        .filter(|m| m != "lib" && m != "main" && !page.contains(&format!("src/{m}")))
        .collect();
    assert!(unplaced.is_empty(), "not on docs/architecture.md: {unplaced:?}");
}

/// The code speaks of the project alone: no comment points at a
/// specification outside the repository (its sections, by number); the
/// contract a user needs is in docs/, and the code points there.
#[test]
fn no_file_cites_a_specification_outside_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut stack: Vec<std::path::PathBuf> =
        ["src", "tests", "examples", "benches", "scripts", "python/src", "python/tests", "docs"]
            .iter()
            .map(|d| root.join(d))
            .collect();
    stack.push(root.join("README.md"));
    // Built from parts, so that this file does not match itself.
    let needles = [["SPEC", " section"].concat(), ["SPEC", ".md"].concat()];
    let mut cited = Vec::new();
    while let Some(path) = stack.pop() {
        if path.is_dir() {
            stack.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
            continue;
        }
        let Ok(text) = std::fs::read_to_string(&path) else { continue };
        for (i, line) in text.lines().enumerate() {
            if needles.iter().any(|n| line.contains(n.as_str())) {
                cited.push(format!("{}:{}", path.strip_prefix(root).unwrap().display(), i + 1));
            }
        }
    }
    assert!(cited.is_empty(), "cites a specification the repository does not hold: {cited:?}");
}

/// `eval`'s files import each name where it is used: no glob import of a
/// sibling or parent outside the test modules, so that one namespace does
/// not silently span the front end's files.
#[test]
fn eval_imports_each_name_where_it_is_used() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/eval");
    let mut globs = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let code = without_test_items(&std::fs::read_to_string(&path).unwrap());
        for line in code.lines().map(str::trim) {
            if line.starts_with("use ") && line.ends_with("::*;") {
                globs.push(format!("{}: {line}", path.file_name().unwrap().to_string_lossy()));
            }
        }
    }
    assert!(globs.is_empty(), "glob imports in eval: {globs:?}");
}

/// The front ends, and which other front ends each may import: none,
/// except `play`, which is `eval` with a person as the endpoint.
const FRONT_ENDS: [(&str, &[&str]); 5] =
    [("eval", &[]), ("serve", &[]), ("envserver", &[]), ("report", &[]), ("play", &["eval"])];

/// Every import of one front end by another that the rule above forbids.
fn front_end_crossings(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut crossings = Vec::new();
    for (front_end, allowed) in FRONT_ENDS {
        for (other, _) in FRONT_ENDS {
            let uses = graph.get(front_end).is_some_and(|u| u.contains(other));
            if other != front_end && uses && !allowed.contains(&other) {
                crossings.push(format!("{front_end} -> {other}"));
            }
        }
    }
    crossings
}

/// Front ends never reach into each other: what two of them share (the
/// system prompt, a scripted reply, the shutdown signal, run naming, the
/// prices' display, the evidence-timing metrics) lives in a layer below
/// both.
#[test]
fn front_ends_do_not_import_each_other() {
    let graph = import_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(FRONT_ENDS.iter().all(|(m, _)| graph.contains_key(*m)), "{graph:?}");
    assert!(graph["play"].contains("eval"), "play runs eval");
    let crossings = front_end_crossings(&graph);
    assert!(crossings.is_empty(), "front ends importing each other: {crossings:?}");
    // A planted import is caught.
    let mut planted = graph.clone();
    planted.get_mut("envserver").unwrap().insert("eval".to_string());
    planted.get_mut("play").unwrap().insert("serve".to_string());
    assert_eq!(front_end_crossings(&planted), ["envserver -> eval", "play -> serve"]);
}

/// The functions of `text` (rustfmt's layout: a body closes with `}` at the
/// indentation of its `fn` line) longer than `limit` lines, as (name, first
/// line, lines).
fn long_functions(text: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let indent = |l: &str| l.len() - l.trim_start().len();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let head = line.trim_start();
        let head = head.strip_prefix("pub ").or_else(|| head.strip_prefix("pub(crate) ")).unwrap_or(head);
        let head = head.strip_prefix("pub(super) ").unwrap_or(head);
        let head = head.strip_prefix("async ").unwrap_or(head);
        let head = head.strip_prefix("const ").unwrap_or(head);
        let Some(rest) = head.strip_prefix("fn ") else { continue };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let at = indent(line);
        let end = lines[i + 1..]
            .iter()
            .position(|l| !l.trim().is_empty() && indent(l) <= at)
            .map_or(lines.len(), |k| i + 1 + k);
        // A declaration without a body (`fn f();` in a trait) ends on its line.
        let length = if line.trim_end().ends_with(';') { 1 } else { end - i + 1 };
        if length > limit {
            out.push((name, i + 1, length));
        }
    }
    out
}

/// No function in the crate is longer than 120 lines: a longer one does
/// several things, and each gets a name.
#[test]
fn no_function_is_longer_than_120_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = vec![src.clone()];
    let mut long = Vec::new();
    while let Some(path) = files.pop() {
        if path.is_dir() {
            files.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
        } else if path.extension().is_some_and(|e| e == "rs") {
            for (name, line, length) in long_functions(&std::fs::read_to_string(&path).unwrap(), 120) {
                long.push(format!("{}:{line} {name} ({length} lines)", path.strip_prefix(&src).unwrap().display()));
            }
        }
    }
    assert!(long.is_empty(), "functions over 120 lines: {long:?}");
    // A planted long function is caught, a short one and a bodiless one are not.
    let body = "    let x = 1;\n".repeat(121);
    let planted = format!("fn short() {{\n}}\n\nfn f();\n\npub(crate) fn long() {{\n{body}}}\n");
    assert_eq!(long_functions(&planted, 120), [("long".to_string(), 6, 123)]);
}
