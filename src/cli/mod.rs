//! Command-line interface: one file per subcommand. Each turns its clap
//! arguments into a validated options value, runs, and returns an exit code.

mod baselines;
mod env_server;
mod eval;
mod import_inspect;
mod play;
mod report;
mod serve;
mod validate;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Documented exit codes.
pub mod exit {
    /// Everything ran and passed.
    pub const SUCCESS: u8 = 0;
    /// The command ran but its result is a failure: an invariant failed, or
    /// an eval run finished with rollouts still missing (infrastructure
    /// errors; re-run the same command to resume them).
    pub const FAILURE: u8 = 1;
    /// Bad input: an unknown scenario or policy, a malformed flag or config.
    pub const USAGE: u8 = 2;
    /// The endpoint refused the run (authentication, unknown model).
    pub const REFUSED: u8 = 3;
    /// Anything else went wrong (I/O, an internal error).
    pub const ERROR: u8 = 4;
}

/// A usage error: reported as one line, exit code 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    UsageError(msg.into()).into()
}

#[derive(Debug, Parser)]
#[command(
    name = "negotiator",
    version,
    about = "Can a model read another road user's hidden intent from its motion, and drive accordingly?"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Play episodes with a language model behind an OpenAI-compatible endpoint.
    Eval(Box<eval::EvalArgs>),
    /// Run the non-LLM baseline policies on every scenario and tier.
    Baselines(baselines::BaselinesArgs),
    /// Check the benchmark's invariants; non-zero exit if any fails.
    Validate(validate::ValidateArgs),
    /// Serve a scripted policy as an OpenAI-compatible chat endpoint.
    Serve(serve::ServeArgs),
    /// Serve the benchmark as an OpenEnv environment (HTTP and WebSocket) for trainers and other harnesses.
    EnvServer(env_server::EnvServerArgs),
    /// Drive the benchmark's episodes yourself in the terminal (a human baseline row).
    Play(play::PlayArgs),
    /// Leaderboards, paired comparisons, plots and an offline report.html from run directories.
    Report(report::ReportArgs),
    /// Turn an Inspect AI eval log of the negotiator task into a run directory for `report`.
    ImportInspect(import_inspect::ImportInspectArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Eval(args) => args.run(),
        Command::Baselines(args) => args.run(),
        Command::Validate(args) => args.run(),
        Command::Serve(args) => args.run(),
        Command::EnvServer(args) => args.run(),
        Command::Play(args) => args.run(),
        Command::Report(args) => args.run(),
        Command::ImportInspect(args) => args.run(),
    }
}

/// Exit code for an error that reached `main`. The one place that decides
/// which errors are the user's input (exit 2) or the endpoint's refusal (3):
/// the first error of the chain with a verdict decides; anything else is 4.
pub fn exit_code_for(e: &anyhow::Error) -> u8 {
    e.chain().find_map(verdict).unwrap_or(exit::ERROR)
}

/// What one error says of the exit code: bad input, a refusal, or nothing
/// (an I/O failure or an internal error, or an error that wraps the one
/// that decides).
fn verdict(e: &(dyn std::error::Error + 'static)) -> Option<u8> {
    use crate::eval::{EvalError, store::StoreError};
    use crate::inspect_log::InspectLogError;
    use crate::report::ReportError;
    if e.is::<UsageError>() || e.is::<crate::scenario::ScenarioError>() {
        return Some(exit::USAGE);
    }
    if let Some(r) = e.downcast_ref::<ReportError>() {
        return (!matches!(r, ReportError::Io { .. } | ReportError::Pdf { .. })).then_some(exit::USAGE);
    }
    if let Some(i) = e.downcast_ref::<InspectLogError>() {
        return (!matches!(i, InspectLogError::Io { .. } | InspectLogError::RunDir(_))).then_some(exit::USAGE);
    }
    match e.downcast_ref::<EvalError>()? {
        EvalError::Refused(_) => Some(exit::REFUSED),
        EvalError::BadParameter(_) | EvalError::Store(StoreError::ConfigChanged { .. }) => Some(exit::USAGE),
        _ => None,
    }
}

/// Writing to a closed pipe (`negotiator baselines | head`) is not an error.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

/// `all` or a comma-separated list, for --scenario / --tier. An item
/// listed twice is refused: it would play (and count) every episode twice.
pub fn parse_list<T>(value: &str, all: &[T], flag: &str) -> anyhow::Result<Vec<T>>
where
    T: Clone + PartialEq + std::str::FromStr,
    T::Err: std::fmt::Display,
{
    if value.trim() == "all" {
        return Ok(all.to_vec());
    }
    let mut items: Vec<T> = Vec::new();
    for v in value.split(',') {
        let item = v.trim().parse::<T>().map_err(|e| usage(format!("{flag}: {e}")))?;
        if items.contains(&item) {
            return Err(usage(format!("{flag}: '{}' is listed twice", v.trim())));
        }
        items.push(item);
    }
    Ok(items)
}

/// Most episodes one `eval` invocation or one `baselines` cell may select.
/// Far above any real benchmark run (the paper's protocol is 600), and low
/// enough that the selection, its bookkeeping and the summary fit in memory
/// on any machine: a larger -n is a typo, refused before anything is
/// allocated.
pub const MAX_EPISODES: u64 = 1_000_000;

/// How both servers (`serve`, `env-server`) start: a multi-threaded
/// runtime, the address bound and announced, then `serve` on the listener
/// until it returns (at shutdown). An error names the address.
fn serve_on<T, F>(
    host: &str,
    port: u16,
    path: &str,
    serve: impl FnOnce(tokio::net::TcpListener) -> F,
) -> anyhow::Result<T>
where
    F: std::future::Future<Output = std::io::Result<T>>,
{
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    runtime
        .block_on(async { serve(bind_and_announce(host, port, path).await?).await })
        .map_err(|e| anyhow::anyhow!("serving on {host}:{port}: {e}"))
}

/// Bind a server's address and print `listening on http://HOST:PORT{path}`
/// on stdout (the line scripts and tests read the port from; port 0 picks
/// a free one).
async fn bind_and_announce(host: &str, port: u16, path: &str) -> std::io::Result<tokio::net::TcpListener> {
    let listener = tokio::net::TcpListener::bind((host, port)).await?;
    let addr = listener.local_addr()?;
    let host = if addr.is_ipv6() { format!("[{}]", addr.ip()) } else { addr.ip().to_string() };
    crate::redact::term::out(&format!("listening on http://{host}:{}{path}\n", addr.port()));
    Ok(listener)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::EvalError;
    use crate::eval::store::StoreError;
    use crate::inspect_log::InspectLogError;
    use crate::report::ReportError;

    fn io() -> std::io::Error {
        std::io::Error::other("disk on fire")
    }

    /// One decision for every command: bad input is 2, a refusal 3, any
    /// other failure 4, whichever module's error it is and however wrapped.
    #[test]
    fn the_exit_code_is_decided_once_for_every_kind_of_error() {
        let cases: Vec<(anyhow::Error, u8)> = vec![
            (usage("--tier: '4' is not a tier"), exit::USAGE),
            (ReportError::MissingDir("x".into()).into(), exit::USAGE),
            (ReportError::Io { path: "x".into(), source: io() }.into(), exit::ERROR),
            (InspectLogError::OutputTaken { dir: "x".into() }.into(), exit::USAGE),
            (InspectLogError::Io { path: "x".into(), source: io() }.into(), exit::ERROR),
            (EvalError::Refused("401".into()).into(), exit::REFUSED),
            (EvalError::BadParameter("top_k".into()).into(), exit::USAGE),
            (EvalError::Store(StoreError::ConfigChanged { dir: "d".into(), changes: "c".into() }).into(), exit::USAGE),
            (EvalError::Store(StoreError::Locked { dir: "d".into() }).into(), exit::ERROR),
            (EvalError::Task("panicked".into()).into(), exit::ERROR),
            (anyhow::Error::new(io()), exit::ERROR),
        ];
        for (e, code) in cases {
            assert_eq!(exit_code_for(&e), code, "{e:#}");
            let wrapped = e.context("while doing something");
            assert_eq!(exit_code_for(&wrapped), code, "{wrapped:#}");
        }
    }
}

/// A scenario added through the registry alone (the unit tests' registry
/// adds `toy_crossing`: its own files and nothing else) runs through the
/// commands a user would run on it, by name: `baselines`, `eval --dry-run`,
/// `eval` against the served expert, and `report`.
#[cfg(test)]
mod a_scenario_added_through_the_registry {
    use super::{Cli, run};
    use clap::Parser;
    use std::path::Path;

    fn negotiator(args: &[&str]) {
        let cli = Cli::try_parse_from(std::iter::once("negotiator").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        let code = run(cli).unwrap_or_else(|e| panic!("{args:?}: {e:#}"));
        assert_eq!(format!("{code:?}"), format!("{:?}", std::process::ExitCode::SUCCESS), "{args:?}");
    }

    /// `serve --policy expert` on a free port, in this process.
    fn serve_expert() -> String {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        listener.set_nonblocking(true).unwrap();
        let port = listener.local_addr().unwrap().port();
        let config = crate::serve::ServeConfig {
            policy: crate::policy::PolicyKind::Expert,
            seed: 0,
            latency: std::time::Duration::ZERO,
            fail_rate: 0.0,
            rate_limit: None,
            drop_rate: 0.0,
            garbage_rate: 0.0,
            belief: None,
            forecast: None,
            probe_seeds: 0..10,
        };
        std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
            runtime.block_on(async {
                let listener = tokio::net::TcpListener::from_std(listener).unwrap();
                crate::serve::serve(listener, config).await
            })
        });
        format!("http://127.0.0.1:{port}/v1")
    }

    #[test]
    fn baselines_eval_and_the_report_take_it_by_name() {
        let root = std::env::temp_dir().join(format!("negotiator-toy-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (out, report) = (root.join("runs"), root.join("report"));
        let path = |p: &Path| p.to_str().unwrap().to_string();
        let toy = "toy_crossing";
        let expert = crate::baselines::run_grid(
            &crate::scenario::ScenarioSet::default(),
            &crate::baselines::GridSpec {
                scenarios: vec![toy.parse().unwrap()],
                tiers: crate::scenario::Tier::ALL.to_vec(),
                policies: vec![crate::policy::PolicyKind::Expert],
                episodes: 20,
                seed_base: 0,
            },
            &|_, _| {},
        );
        assert_eq!(expert.len(), 3);
        assert!(expert.iter().all(|c| c.success.estimate == 1.0), "{expert:?}");
        negotiator(&["baselines", "--scenario", toy, "-n", "5", "--format", "csv"]);
        let base_url = serve_expert();
        let eval =
            ["eval", "--base-url", &base_url, "--model", "expert", "--scenario", toy, "--tier", "all", "-n", "3"];
        negotiator(&[&eval[..], &["--dry-run"]].concat());
        negotiator(&[&eval[..], &["--output", &path(&out), "--run-name", "toy", "--quiet"]].concat());
        negotiator(&["report", "--quiet", "--format", "md", "--out", &path(&report), &path(&out.join("toy"))]);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap()).unwrap();
        assert_eq!(json["leaderboard"]["scenarios"], serde_json::json!([toy]), "{}", json["leaderboard"]);
        let md = std::fs::read_to_string(report.join("report.md")).unwrap();
        assert!(md.contains(toy), "{md}");
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("toy/summary.json")).unwrap()).unwrap();
        let cells = summary["cells"].as_array().unwrap();
        assert_eq!(cells.len(), 3);
        assert!(cells.iter().all(|c| c["scenario"] == toy && c["success"]["estimate"] == 1.0), "{summary}");
        // Beside the benchmark's three: four scenarios' panels, and a
        // paper's figures still print every text at 8 pt or more.
        let all =
            ["eval", "--base-url", &base_url, "--model", "expert", "--scenario", "all", "--tier", "all", "-n", "2"];
        negotiator(&[&all[..], &["--output", &path(&out), "--run-name", "all", "--quiet"]].concat());
        let paper = root.join("paper");
        negotiator(&["report", "--quiet", "--style", "paper", "--out", &path(&paper), &path(&out.join("all"))]);
        let mut figures = 0;
        for entry in std::fs::read_dir(paper.join("plots")).unwrap() {
            let file = entry.unwrap().path();
            if file.extension().is_none_or(|e| e != "svg") {
                continue;
            }
            let svg = std::fs::read_to_string(&file).unwrap();
            let attr = |name: &str| {
                let at = svg.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
                svg[at..at + svg[at..].find('"').unwrap()].to_string()
            };
            let inches: f64 = attr("width").trim_end_matches("in").parse().unwrap();
            let view_w: f64 = attr("viewBox").split(' ').nth(2).unwrap().parse().unwrap();
            let smallest = svg
                .split(" font-size=\"")
                .skip(1)
                .map(|s| s[..s.find('"').unwrap()].parse::<f64>().unwrap())
                .fold(f64::INFINITY, f64::min);
            let pt = smallest * inches * 72.0 / view_w;
            assert!(pt >= crate::report::plots::style::MIN_PRINT_PT - 1e-9, "{}: {pt:.2} pt", file.display());
            figures += 1;
        }
        assert!(figures >= 8, "{figures} figures");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
