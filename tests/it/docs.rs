//! The README and docs/ stay true:
//! - a block between `<!-- generated: COMMAND -->` (or `<!-- generated
//!   (text): COMMAND -->`, fenced as text) and `<!-- end generated -->` is
//!   exactly what `negotiator COMMAND` prints now; with
//!   `NEGOTIATOR_REGEN_DOCS=1` (`scripts/regen_docs.sh`) the blocks are
//!   rewritten instead;
//! - every relative link points at a file that exists;
//! - the README's ```` ```sh runnable ```` block runs, against `serve`.

use super::support::{Server, negotiator, scratch};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

const END: &str = "<!-- end generated -->";

/// `negotiator ARGS`' standard output.
fn output_of(command: &str) -> String {
    let args: Vec<&str> = command.split_whitespace().skip(1).collect();
    let out = negotiator().args(&args).output().unwrap();
    assert!(out.status.success(), "{command}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The page with every generated block as the code produces it now, and
/// the commands whose blocks differ.
fn regenerate(text: &str) -> (String, Vec<String>) {
    let mut out = Vec::new();
    let mut stale = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        out.push(line.to_string());
        let Some(rest) = line.strip_prefix("<!-- generated") else { continue };
        let (fenced, command) = match rest.trim_end_matches("-->").trim().strip_prefix("(text):") {
            Some(c) => (true, c.trim()),
            None => (false, rest.trim_end_matches("-->").trim().trim_start_matches(':').trim()),
        };
        let mut old = Vec::new();
        for l in lines.by_ref() {
            if l == END {
                break;
            }
            old.push(l);
        }
        let produced = output_of(command);
        let new =
            if fenced { format!("```text\n{}\n```", produced.trim_end()) } else { produced.trim_end().to_string() };
        if old.join("\n") != new {
            stale.push(command.to_string());
        }
        out.push(new);
        out.push(END.to_string());
    }
    let mut joined = out.join("\n");
    if text.ends_with('\n') {
        joined.push('\n');
    }
    (joined, stale)
}

#[test]
fn generated_blocks_are_what_the_code_produces_now() {
    let rewrite = std::env::var_os("NEGOTIATOR_REGEN_DOCS").is_some();
    let mut stale = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let (fresh, changed) = regenerate(&text);
        if rewrite && fresh != text {
            std::fs::write(&page, fresh).unwrap();
        } else {
            stale.extend(changed.into_iter().map(|c| format!("{}: {c}", page.display())));
        }
    }
    assert!(stale.is_empty(), "stale generated blocks (run scripts/regen_docs.sh):\n{}", stale.join("\n"));
}

/// The committed reference tables, one per scenario in
/// `results/baselines/` (what `report` reads), are what `baselines` prints
/// now; with `NEGOTIATOR_REGEN_DOCS=1` they are rewritten instead.
#[test]
fn generated_reference_tables_are_what_baselines_prints_now() {
    let rewrite = std::env::var_os("NEGOTIATOR_REGEN_DOCS").is_some();
    let dir = root().join("results/baselines");
    let mut stale = Vec::new();
    for kind in negotiator::scenario::ScenarioKind::ALL {
        for format in ["csv", "md"] {
            let path = dir.join(format!("{kind}.{format}"));
            let fresh = output_of(&format!("negotiator baselines --scenario {kind} --format {format}"));
            if std::fs::read_to_string(&path).ok().as_deref() == Some(fresh.as_str()) {
                continue;
            }
            if rewrite {
                std::fs::create_dir_all(&dir).unwrap();
                std::fs::write(&path, fresh).unwrap();
            } else {
                stale.push(path.display().to_string());
            }
        }
    }
    assert!(stale.is_empty(), "stale reference tables (run scripts/regen_docs.sh):\n{}", stale.join("\n"));
}

#[test]
fn relative_links_point_at_files_that_exist() {
    let mut broken = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for (i, _) in text.match_indices("](") {
            let target: String = text[i + 2..].chars().take_while(|&c| c != ')').collect();
            if target.starts_with("http") || target.starts_with('#') || target.starts_with("mailto:") {
                continue;
            }
            let path = target.split('#').next().unwrap_or("");
            if !path.is_empty() && !dir.join(path).exists() {
                broken.push(format!("{}: {target}", page.display()));
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The README's runnable block, each line run as written (`cargo run
/// --release --` is the built binary; the `serve` line is started here on a
/// free port, which replaces 8765).
#[test]
fn the_readmes_runnable_block_runs() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let block: Vec<&str> = readme
        .split("```sh runnable\n")
        .nth(1)
        .and_then(|rest| rest.split("\n```").next())
        .expect("a runnable block in the README")
        .lines()
        .collect();
    let dir = scratch("docs-runnable");
    let mut server = None;
    for line in block {
        let command = line.trim().trim_end_matches('&').trim();
        let args: Vec<String> = command
            .strip_prefix("cargo run --release -- ")
            .unwrap_or_else(|| panic!("runnable lines start with `cargo run --release --`: {line}"))
            .split_whitespace()
            .map(String::from)
            .collect();
        if args.first().is_some_and(|a| a == "serve") {
            let rest: Vec<&str> =
                args[1..].iter().map(String::as_str).filter(|a| *a != "--port" && *a != "8765").collect();
            server = Some(Server::start(&rest));
            continue;
        }
        let port = server.as_ref().map(|s| s.port.to_string()).unwrap_or_default();
        let args: Vec<String> = args.iter().map(|a| a.replace("8765", &port)).collect();
        // Shell globs (`results/expert-*`) expand against the working directory.
        let args: Vec<String> = args.into_iter().flat_map(|a| expand(&dir, &a)).collect();
        let out = negotiator().args(&args).current_dir(&dir).output().unwrap();
        assert!(out.status.success(), "{line}: {}", String::from_utf8_lossy(&out.stderr));
    }
    assert!(dir.join("results").is_dir());
}

/// A trailing-`*` glob, as the shell would expand it (or the word itself).
fn expand(dir: &Path, word: &str) -> Vec<String> {
    let Some(prefix) = word.strip_suffix('*') else { return vec![word.to_string()] };
    let (parent, stem) = prefix.rsplit_once('/').unwrap_or((".", prefix));
    let mut found: Vec<String> = std::fs::read_dir(dir.join(parent))
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with(stem))
                .map(|e| format!("{parent}/{}", e.file_name().to_string_lossy()))
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    if found.is_empty() { vec![word.to_string()] } else { found }
}
