//! The import graph of the crate's top-level modules has no circles: each
//! module's non-test code names other modules through `crate::` paths, and
//! no two modules reach each other (docs/architecture.md draws the layers).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level modules each module's code (comments and `#[cfg(test)]`
/// items left out) refers to through `crate::` paths.
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
        let code = text.split("#[cfg(test)]").next().unwrap();
        let uses = graph.entry(module.clone()).or_default();
        for line in code.lines().map(str::trim).filter(|l| !l.starts_with("//")) {
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
