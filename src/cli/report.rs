//! `negotiator report`: leaderboards with bootstrap CIs, paired
//! comparisons, pass^k, SVG plots and one offline report.html from run
//! directories. Every output goes to `--out` (default `results/report`);
//! the main tables are printed on stdout in `--format`.

use super::{parse_list, usage};
use crate::export::Format;
use crate::report::pick::BadPick;
use crate::report::plots::Style;
use crate::report::{self, MIN_RESAMPLES, ReportOptions};
use crate::scenario::Tier;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Run directories (from `eval`), directories holding run directories,
    /// or Inspect AI eval logs of the negotiator task (`.eval`, `.json`).
    /// Runs of one configuration (shards) are joined.
    #[arg(value_name = "RUN_DIR|LOG", required = true)]
    pub runs: Vec<PathBuf>,
    /// Directory holding the reference tables (expert ceiling,
    /// always_proceed floor): each scenario's <scenario>.csv, or a whole
    /// grid's baselines.csv. A scenario without one, or every scenario
    /// without the flag and without the default directory, is computed
    /// in-process.
    #[arg(long, value_name = "DIR")]
    pub baselines: Option<PathBuf>,
    /// Output directory for report.html, report.md, report.json, the CSV
    /// tables and plots/*.svg.
    #[arg(long, value_name = "DIR", default_value = "results/report")]
    pub out: PathBuf,
    /// Format of the tables printed on stdout: the same tables in each (csv:
    /// one header line per table, a blank line between; json: one object
    /// keyed by table name). The whole report is report.json in --out.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
    /// Tiers of the leaderboard, outcome, paired and pass^k tables: 1, 2,
    /// 3, a comma-separated list, or all (default: 1 if the runs have tier-1
    /// episodes, else every tier). The per-tier table always has every tier.
    #[arg(long)]
    pub tiers: Option<String>,
    /// Bootstrap resamples per interval (at least 10000).
    #[arg(long, default_value_t = MIN_RESAMPLES)]
    pub resamples: usize,
    /// Shift every bootstrap seed (0 reproduces the documented figures).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Transcripts embedded in report.html per (model, scenario, tier).
    #[arg(long, default_value_t = 3)]
    pub transcripts: usize,
    /// Rank incomplete models (errored or missing episodes, or a scenario
    /// missing) on the leaderboard too; they stay marked.
    #[arg(long)]
    pub include_incomplete: bool,
    /// An episode to draw as a trajectory figure, with a maneuver timeline
    /// of every model on its scenario, tier and seed; repeatable. MODEL is
    /// the report's model label; ROLLOUT defaults to the model's lowest.
    /// Without it, one episode per model and scenario is chosen.
    #[arg(long = "episode", value_name = "MODEL:SCENARIO:TIER:SEED[:ROLLOUT]")]
    pub episodes: Vec<String>,
    /// How the figures are drawn: default (for the screen and report.html)
    /// or paper (text at least 8 pt at the declared print width of 3.3 in
    /// or 7 in, no titles, and a PDF beside each SVG).
    #[arg(long, value_name = "STYLE", default_value = "default", value_parser = style_parser())]
    pub style: Style,
    /// Print nothing but errors.
    #[arg(long, short = 'q')]
    pub quiet: bool,
}

/// A private directory under the system's temporary directory, removed
/// when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Scratch {
        let nonce: u64 = rand::random();
        Scratch(std::env::temp_dir().join(format!("negotiator-report-{}-{nonce:016x}", std::process::id())))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `--style`: clap lists the styles in `--help` and refuses any other.
fn style_parser() -> impl clap::builder::TypedValueParser<Value = Style> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(["default", "paper"])
        .map(|name| name.parse::<Style>().expect("a listed style parses"))
}

impl ReportArgs {
    pub fn options(&self) -> anyhow::Result<ReportOptions> {
        if self.resamples < MIN_RESAMPLES {
            return Err(usage(format!("--resamples: at least {MIN_RESAMPLES}, got {}", self.resamples)));
        }
        if self.resamples > 10_000_000 {
            return Err(usage(format!("--resamples: at most 10000000, got {}", self.resamples)));
        }
        let tiers = match &self.tiers {
            Some(t) => Some(parse_list(t, &Tier::ALL, "--tiers")?),
            None => None,
        };
        let episodes = self
            .episodes
            .iter()
            .map(|e| e.parse().map_err(|e: BadPick| usage(e.to_string())))
            .collect::<Result<_, _>>()?;
        let style = self.style;
        Ok(ReportOptions {
            dirs: self.runs.clone(),
            baselines: self.baselines.clone().unwrap_or_else(|| PathBuf::from("results/baselines")),
            baselines_explicit: self.baselines.is_some(),
            tiers,
            resamples: self.resamples,
            seed: self.seed,
            transcripts_per_cell: self.transcripts,
            include_incomplete: self.include_incomplete,
            episodes,
            style,
        })
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        let started = Instant::now();
        let mut opts = self.options()?;
        // Inspect logs are read as the run directories they import to, in a
        // scratch directory that lives as long as the report is built.
        let scratch = Scratch::new();
        opts.dirs = crate::inspect_log::import_inputs(&opts.dirs, &scratch.0)?;
        let built = report::build(&opts)?;
        let written = report::write(&built, &self.out)?;
        if !self.quiet {
            let r = &built.report;
            // Every format renders the same tables through the one table model.
            let out = self.format.exporter().render_all(&r.tables());
            crate::redact::term::write_out(&out)?;
            for w in &r.warnings {
                crate::redact::eline!("warning: {w}");
            }
            let html = written.iter().find(|p| p.ends_with("report.html"));
            let size = html.and_then(|p| std::fs::metadata(p).ok()).map_or(0, |m| m.len());
            crate::redact::eline!(
                "wrote {} files to {} (report.html {:.1} MB, {} transcripts) in {:.2} s",
                written.len(),
                self.out.display(),
                size as f64 / 1e6,
                built.drill.transcripts(),
                started.elapsed().as_secs_f64()
            );
        }
        Ok(ExitCode::SUCCESS)
    }
}
