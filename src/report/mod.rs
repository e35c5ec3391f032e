//! `negotiator report`: run directories in, the tables and figures a
//! benchmark paper needs out — Markdown, CSV and JSON tables, SVG plots and
//! one offline `report.html` with a per-episode drill-down.
//!
//! Layout: [`load`] reads and merges run directories; [`tables`] builds the
//! leaderboard, per-tier, outcome and cost tables; [`paired`] the pairwise
//! comparisons; [`passk`] pass^k; [`timing`] guess rate and evidence lag; [`reference`](mod@reference) the expert ceiling and
//! `always_proceed` floor; [`boot`] the report's bootstraps; [`drill`] the
//! drill-down data; [`pick`] the episodes the trajectory figures and
//! maneuver timelines draw; [`plots`] one file per kind of figure; [`html`] the page.
//! Tables are [`crate::export`] tables.

pub mod boot;
pub mod drill;
pub mod forecast;
pub mod html;
pub mod load;
pub mod observations;
pub mod paired;
pub mod passk;
pub mod pdf;
pub mod pick;
pub mod plots;
pub mod probe_rows;
pub mod reference;
pub mod tables;
pub mod timing;

use crate::export::{Cell, Column, CsvExporter, Exporter, Field, Format, INCOMPLETE_MARK, MarkdownExporter, Table};
use crate::scenario::Tier;
use load::{Dataset, ModelData, RunSource};
use paired::PairRow;
use passk::PassKRow;
use plots::Plot;
use reference::References;
use serde::Serialize;
use std::path::{Path, PathBuf};
use tables::{CostRow, Leaderboard, OutcomeRow, TierRow, tiers_label};

/// The least number of bootstrap resamples accepted (docs/report.md,
/// "Statistics"): eval's summary's own, so that a report at the default
/// gives a cell the interval summary.json has.
pub(crate) const MIN_RESAMPLES: usize = crate::metrics::RESAMPLES;

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{0}: no such directory")]
    MissingDir(String),
    #[error("{0}: not a run directory (no run.json or rollouts.jsonl in it or in its subdirectories)")]
    NotARunDir(String),
    #[error("{0}: run directory given twice")]
    GivenTwice(String),
    #[error("{path}: unreadable run.json ({message})")]
    BadRunJson { path: String, message: String },
    #[error(
        "duplicate episode ({key}) of model '{model}': {first} and {second}; an episode may appear once \
         (shards of one run must not overlap, and a run directory must not be copied into another)"
    )]
    DuplicateEpisode { key: String, model: String, first: String, second: String },
    #[error("baseline table {path}: {message}")]
    Baselines { path: String, message: String },
    #[error("nothing to report: {0}")]
    Empty(String),
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error(transparent)]
    Pick(#[from] pick::BadPick),
    #[error("{path}: {source}")]
    Pdf { path: String, source: pdf::PdfError },
    #[error("{at}: an episode of {what} '{name}', which the benchmark's scenarios do not declare")]
    Undeclared { at: String, what: &'static str, name: String },
}

#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Run directories, or directories holding run directories.
    pub dirs: Vec<PathBuf>,
    /// Directory with `baselines.csv`.
    pub baselines: PathBuf,
    /// `baselines` was given explicitly (its absence is then an error).
    pub baselines_explicit: bool,
    /// Leaderboard scope; `None`: tier 1 if any run has it, else every tier.
    pub tiers: Option<Vec<Tier>>,
    pub resamples: usize,
    /// Shifts every bootstrap seed (0: the documented seeds).
    pub seed: u64,
    /// Transcripts embedded in report.html per (model, scenario, tier).
    pub transcripts_per_cell: usize,
    /// Rank incomplete models too (they are still marked).
    pub include_incomplete: bool,
    /// `--episode`: the episodes of the trajectory figures (empty: the
    /// default choice, see [`pick`]).
    pub episodes: Vec<pick::EpisodePick>,
    /// How the figures are drawn; paper also writes a PDF of each.
    pub style: plots::Style,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            dirs: Vec::new(),
            baselines: PathBuf::from("results/baselines"),
            baselines_explicit: false,
            tiers: None,
            resamples: MIN_RESAMPLES,
            seed: 0,
            transcripts_per_cell: 3,
            include_incomplete: false,
            episodes: Vec::new(),
            style: plots::Style::Default,
        }
    }
}

/// One model as reported.
#[derive(Debug, Clone, Serialize)]
pub struct ModelInfo {
    pub label: String,
    pub model: String,
    pub config_hash: String,
    pub run_dirs: Vec<String>,
    pub episodes: usize,
    pub rollouts_per_seed: u32,
    /// Why the model is incomplete in the leaderboard scope; `None`: complete.
    pub incomplete: Option<String>,
}

/// Everything `report.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub negotiator_version: &'static str,
    pub resamples: usize,
    pub bootstrap_seed: u64,
    pub interval: &'static str,
    /// Leaderboard scope.
    pub tiers: Vec<Tier>,
    pub runs: Vec<RunSource>,
    pub models: Vec<ModelInfo>,
    pub leaderboard: Leaderboard,
    pub tier_rows: Vec<TierRow>,
    pub outcomes: Vec<OutcomeRow>,
    pub costs: Vec<CostRow>,
    pub paired: Vec<PairRow>,
    /// Text against picture: one model id under two observations, paired
    /// per cell on the shared seeds.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub observations: Vec<observations::ObservationRow>,
    pub pass_k: Vec<PassKRow>,
    /// Belief-probe runs: one row per (model, scenario, tier).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub belief: Vec<probe_rows::ProbeRow<crate::metrics::BeliefProbe>>,
    /// Forecast-probe runs: one row per (model, scenario, tier), then the
    /// reference forecasters' rows on the same cells.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub forecast: Vec<forecast::ForecastRow>,
    /// Evidence timing: one row per (model, scenario) in the leaderboard
    /// scope (none for runs written before evidence timing was recorded).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub timing: Vec<timing::TimingRow>,
    pub references: References,
    pub plots: Vec<Plot>,
    pub warnings: Vec<String>,
}

/// The report and the drill-down data of report.html.
pub struct Built {
    pub report: Report,
    pub drill: drill::DrillData,
    /// The figures' style (paper: a PDF beside each SVG).
    pub style: plots::Style,
}

const INTERVAL: &str = "95% percentile bootstrap: type-7 (linear interpolation) quantiles at 0.025 and 0.975 of the \
                        sorted resample statistics";

/// Term and definition, shown in report.md and report.html.
/// Stands for the leaderboard's DC column in [`DEFINITIONS`] (filled in, or
/// left out without the column, by [`definitions`]).
const DC_TERM: &str = "{dc}";

/// The report's glossary, with the leaderboard's DC column as the scenario
/// that asks for one names it.
pub(crate) fn definitions() -> Vec<(String, String)> {
    let dc = tables::DcColumn::get();
    DEFINITIONS
        .iter()
        .filter_map(|&(term, text)| match (term, dc) {
            (DC_TERM, None) => None,
            (DC_TERM, Some(c)) => Some((c.term(), text.replace("{scenario}", c.scenario.name()))),
            _ => Some((term.to_string(), text.to_string())),
        })
        .collect()
}

const DEFINITIONS: [(&str, &str); 8] = [
    (
        "Success",
        "Share of episodes ending with the ego at its goal without a collision. Per scenario, the unit is a seed \
         (scenario, tier, seed): its value is its success rate over its rollouts (0 or 1 with one rollout), so \
         rollouts of one seed are never counted as independent.",
    ),
    (
        "95% CI",
        "Percentile bootstrap with at least 10,000 seeded resamples: resample the units with replacement, compute the \
         statistic, and take the type-7 quantiles (Hyndman-Fan type 7, linear interpolation between order statistics: \
         h = (B - 1) q, Q = x[floor h] + (h - floor h)(x[floor h + 1] - x[floor h]), the default of R and numpy) at \
         q = 0.025 and 0.975. Seeds are fixed per statistic, so the report is reproducible; a (scenario, tier) cell \
         uses the seed of eval's summary and gives the same interval. When every seed is 0, or every seed is 1, the \
         bootstrap collapses to a point; the interval is then the Wilson score interval over the seeds.",
    ),
    (
        "Average",
        "Mean of the per-scenario successes. Its CI is a clustered bootstrap: each resample draws seeds with \
         replacement, jointly across scenarios (and tiers), keeping every value of a drawn seed, and recomputes the \
         mean of the scenario means.",
    ),
    (
        DC_TERM,
        "Decision correctness on {scenario}: the share of the agent's last 2 decisions before the go / give-way \
         question was settled that match what the hidden disposition requires.",
    ),
    (
        "Expert ceiling, always_proceed floor",
        "The reference policies' success from the baseline table (separate runs of 200 seeds, normal-approximation \
         intervals), as reference levels rather than paired comparisons.",
    ),
    (
        "Paired comparison",
        "On the (scenario, tier, seed) keys both models have: the mean of the per-key success differences with a \
         paired percentile bootstrap CI over the keys, and an exact two-sided McNemar test on the discordant pairs \
         (binomial, p = 1/2; with several rollouts, each key's lowest shared rollout). A model is better only when \
         the CI excludes 0 and McNemar p < 0.05 agree; fewer than 20 discordant pairs are flagged. Seeds for 80% \
         power (pairs without a significant difference): seeds per (scenario, tier) for a paired McNemar test at \
         0.05 to detect the observed difference, n = (1.96 sqrt(psi) + 0.84 sqrt(psi - delta^2))^2 / delta^2 keys \
         (Connor 1987; psi the discordant share, delta the difference) over the cells.",
    ),
    (
        "pass^k",
        "With r rollouts per seed: mean over seeds of C(c, k) / C(r, k) (c successes), the chance that k rollouts of \
         a seed all succeed; only seeds with all r rollouts count, the excluded ones are counted.",
    ),
    (
        "Errored, missing, incomplete",
        "Errored: rollouts whose requests failed after every retry (errors.jsonl); missing: episodes of the run's \
         selection (run.json) never started. Both are excluded from all scores and counted. A model with an errored \
         or missing episode in the leaderboard scope, or without a scenario other models have, is incomplete: marked \
         \u{2020} in every table and figure and not ranked unless --include-incomplete, because a partial sample is \
         biased (short episodes finish first). Parse errors are bad driving and are scored.",
    ),
];

/// The leaderboard scope: the requested tiers, else tier 1 if any run has
/// it, else every tier present.
fn scope(data: &Dataset, requested: Option<&[Tier]>) -> Vec<Tier> {
    if let Some(t) = requested {
        return t.to_vec();
    }
    let present: Vec<Tier> =
        Tier::ALL.into_iter().filter(|t| data.models.iter().any(|m| m.episodes.iter().any(|e| e.tier == *t))).collect();
    if present.contains(&Tier::T1) { vec![Tier::T1] } else { present }
}

/// Read the runs and compute every table and figure.
pub fn build(opts: &ReportOptions) -> Result<Built, ReportError> {
    let dirs = load::resolve_dirs(&opts.dirs)?;
    let data = load::load(&dirs)?;
    let refs = reference::load(&opts.baselines, opts.baselines_explicit)?;
    build_from(data, refs, opts)
}

/// Compute every table and figure from loaded runs.
pub fn build_from(mut data: Dataset, refs: References, opts: &ReportOptions) -> Result<Built, ReportError> {
    if data.models.iter().all(|m| m.episodes.is_empty()) {
        return Err(ReportError::Empty("the run directories hold no finished episode".into()));
    }
    let tiers = scope(&data, opts.tiers.as_deref());
    let mut warnings = data.warnings.clone();
    let leaderboard =
        tables::leaderboard(&data.models, &refs, &tiers, opts.resamples, opts.seed, opts.include_incomplete);
    if leaderboard.scenarios.is_empty() {
        warnings.push(format!("no episode in the leaderboard scope ({}); see the per-tier table", tiers_label(&tiers)));
    }
    for r in &leaderboard.rows {
        if let Some(why) = &r.incomplete {
            let ranked = if r.rank.is_some() { "ranked anyway" } else { "not ranked (--include-incomplete ranks it)" };
            warnings.push(format!("{} is incomplete ({why}); marked {INCOMPLETE_MARK}, {ranked}", r.model));
        }
    }
    // Every other table, the plots and the drill-down follow the leaderboard order.
    data.models.sort_by_key(|m| leaderboard.rows.iter().position(|r| r.model == m.label).unwrap_or(usize::MAX));
    let ordered: Vec<&ModelData> = data.models.iter().collect();
    let tier_rows = tables::tier_rows(&ordered, &refs, opts.resamples, opts.seed);
    let outcomes = tables::outcome_rows(&ordered, &tiers);
    let costs = tables::cost_rows(&ordered);
    let paired = paired::all_pairs(&ordered, &tiers, opts.resamples, opts.seed);
    let observation_rows = observations::rows(&ordered, &tiers);
    let pass_k = passk::pass_k_rows(&ordered, &tiers);
    let belief = probe_rows::rows::<crate::metrics::BeliefProbe>(&ordered);
    let forecast = forecast::rows(&ordered);
    let timing = timing::rows(&ordered, &refs, &tiers);
    // Named episodes first, so the drill-down carries their transcripts too.
    let picked = pick::resolve(&opts.episodes, &data)?;
    let mut chosen = drill::choose(&data, opts.transcripts_per_cell);
    chosen.retain(|c| !picked.contains(c));
    chosen.splice(0..0, picked.iter().copied());
    let transcripts = drill::load(&data, &chosen)?;
    if transcripts.len() < chosen.len() {
        warnings.push(format!("{} transcript line(s) could not be read in full", chosen.len() - transcripts.len()));
    }
    let (trajectories, timeline_sources) = if picked.is_empty() {
        let trajectories = pick::default_trajectories(&leaderboard, &data, &transcripts);
        let sources = pick::default_timeline_sources(&leaderboard, &data, &transcripts, &trajectories);
        (trajectories, sources)
    } else {
        let named: Vec<drill::Loaded> =
            picked.iter().filter_map(|&p| transcripts.iter().find(|l| (l.model, l.episode) == p).cloned()).collect();
        (named.clone(), named)
    };
    let timelines = pick::timelines(&data, &timeline_sources, &transcripts)?;
    let plots = plots::all(&plots::PlotInput {
        leaderboard: &leaderboard,
        tiers: &tier_rows,
        outcomes: &outcomes,
        timing: &timing,
        forecast: &forecast,
        observations: &observation_rows,
        refs: &refs,
        data: &data,
        transcripts: &transcripts,
        trajectories: &trajectories,
        timelines: &timelines,
        style: opts.style,
    });
    let drill = drill::build(&data, &transcripts, opts.transcripts_per_cell)?;
    let models = ordered
        .iter()
        .map(|m| ModelInfo {
            label: m.label.clone(),
            model: m.model.clone(),
            config_hash: m.config_hash.clone(),
            run_dirs: m.runs.iter().map(|&i| data.runs[i].dir.display().to_string()).collect(),
            episodes: m.episodes.len(),
            rollouts_per_seed: m.rollouts,
            incomplete: leaderboard.rows.iter().find(|r| r.model == m.label).and_then(|r| r.incomplete.clone()),
        })
        .collect();
    let report = Report {
        negotiator_version: env!("CARGO_PKG_VERSION"),
        resamples: opts.resamples,
        bootstrap_seed: opts.seed,
        interval: INTERVAL,
        tiers,
        runs: data.runs,
        models,
        leaderboard,
        tier_rows,
        outcomes,
        costs,
        paired,
        observations: observation_rows,
        pass_k,
        belief,
        forecast,
        timing,
        references: refs,
        plots,
        warnings,
    };
    Ok(Built { report, drill, style: opts.style })
}

impl Report {
    /// The tables in report order; each is written as `{name}.csv` too.
    pub(crate) fn tables(&self) -> Vec<Table> {
        let mut t = vec![
            self.leaderboard.table(self.resamples),
            tables::tier_table(&self.tier_rows),
            tables::outcome_table(&self.outcomes, &self.tiers),
            tables::cost_table(&self.costs),
        ];
        // One model: no pairs, no (empty) paired table.
        if !self.paired.is_empty() {
            t.push(paired::paired_table(&self.paired, &self.tiers, self.resamples));
        }
        if !self.observations.is_empty() {
            t.push(observations::table(&self.observations));
        }
        if !self.pass_k.is_empty() {
            t.push(passk::pass_k_table(&self.pass_k, &self.tiers));
        }
        if !self.timing.is_empty() {
            t.push(timing::table(&self.timing, &self.tiers));
        }
        if !self.belief.is_empty() {
            t.push(probe_rows::table(&self.belief, None));
        }
        if !self.forecast.is_empty() {
            t.push(forecast::table(&self.forecast));
        }
        for table in &mut t {
            self.mark_incomplete(table);
        }
        t
    }

    /// Mark incomplete models' names in the model columns (`model`, and
    /// `a` / `b` of the paired table): "name †" on display, the name alone
    /// in CSV and JSON.
    pub(crate) fn mark_incomplete(&self, table: &mut Table) {
        let marked: Vec<&str> =
            self.models.iter().filter(|m| m.incomplete.is_some()).map(|m| m.label.as_str()).collect();
        if marked.is_empty() {
            return;
        }
        let columns: Vec<usize> = (table.columns.iter().enumerate())
            .filter(|(_, c)| matches!(c.key.as_deref(), Some("model" | "a" | "b")))
            .map(|(i, _)| i)
            .collect();
        let mut any = false;
        for row in &mut table.rows {
            for &i in &columns {
                if let Cell::Text(name) = &row[i]
                    && marked.contains(&name.as_str())
                {
                    row[i] = Cell::Marked(name.clone());
                    any = true;
                }
            }
        }
        if any && table.name != "leaderboard" {
            table.note(format!(
                "{INCOMPLETE_MARK}: incomplete model (errored or missing episodes); see the leaderboard."
            ));
        }
    }

    /// The table named `name` (a CSV file stem: `leaderboard`, `tiers`,
    /// `outcomes`, `errors_cost`, `paired`, `pass_k`, `runs`) in `format`.
    pub fn render_table(&self, name: &str, format: Format) -> Option<String> {
        let table = self.tables().into_iter().chain([self.runs_table()]).find(|t| t.name == name)?;
        Some(format.exporter().render(&table))
    }

    pub(crate) fn runs_table(&self) -> Table {
        type R = RunSource;
        let label = |r: &R| {
            self.models
                .iter()
                .find(|m| m.config_hash == r.config_hash && m.model == r.model)
                .map_or(r.model.clone(), |m| m.label.clone())
        };
        let fields: [Field<R>; 7] = [
            Field::new(Column::new("model", "model"), move |r: &R| Cell::Text(label(r))),
            Field::new(Column::new("directory", "directory"), |r: &R| Cell::text(r.dir.display().to_string())),
            Field::new(Column::new("config", "config"), |r: &R| Cell::Text(r.config_hash.chars().take(8).collect())),
            Field::new(Column::new("shard", "shard"), |r: &R| r.shard.clone().map_or(Cell::Missing, Cell::Text)),
            Field::new(Column::new("episodes", "episodes"), |r: &R| Cell::Int(r.episodes as u64)),
            Field::new(Column::new("errors.jsonl lines", "infra_error_lines"), |r: &R| {
                Cell::Int(r.infra_error_lines as u64)
            }),
            Field::new(Column::new("unreadable lines", "bad_lines"), |r: &R| Cell::Int(r.bad_lines as u64)),
        ];
        let mut t = Table::of("runs", "Run directories", &fields, &self.runs);
        self.mark_incomplete(&mut t);
        t
    }

    /// `report.md`: every table, the figures (linked), warnings, definitions.
    pub(crate) fn markdown(&self) -> String {
        let mut s = String::from("# negotiator report\n\n");
        s.push_str(&format!(
            "{} model(s), {} run director{}, {} episodes; leaderboard scope: {}; {} bootstrap resamples.\n\n",
            self.models.len(),
            self.runs.len(),
            if self.runs.len() == 1 { "y" } else { "ies" },
            self.runs.iter().map(|r| r.episodes).sum::<usize>(),
            tiers_label(&self.tiers),
            self.resamples
        ));
        for w in &self.warnings {
            s.push_str(&format!("> warning: {w}\n\n"));
        }
        let md = MarkdownExporter { heading_level: 2 };
        let tables = self.tables();
        s.push_str(&md.render(&tables[0]));
        s.push_str("\n## Figures\n\n");
        for p in &self.plots {
            s.push_str(&format!("![{}](plots/{}.svg)\n\n*{}*\n\n", p.title.replace(['[', ']'], ""), p.name, p.caption));
        }
        for t in &tables[1..] {
            s.push('\n');
            s.push_str(&md.render(t));
        }
        s.push('\n');
        s.push_str(&md.render(&self.runs_table()));
        s.push_str("\n## Definitions\n\n");
        for (term, def) in definitions() {
            s.push_str(&format!("- **{term}.** {def}\n"));
        }
        s
    }
}

/// Write every output into `out`; returns the files written. In paper
/// style a PDF of each figure is written beside its SVG (same stem), made
/// from the scrubbed SVG.
///
/// All or nothing, as far as a file system allows: every file is first
/// written whole to a temporary name beside its target (scrubbed of
/// secrets) and fsynced; only when all of them are written are they renamed
/// into place, and only then are stale `plots/*.svg` and `*.pdf` from an earlier report
/// removed. A full disk or a kill while writing leaves the previous report
/// untouched and no temporary file behind; the error names the file that
/// could not be written.
pub fn write(built: &Built, out: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let io = |path: &Path| {
        let path = path.display().to_string();
        move |source| ReportError::Io { path, source }
    };
    let plots_dir = out.join("plots");
    std::fs::create_dir_all(&plots_dir).map_err(io(&plots_dir))?;
    let r = &built.report;
    let json = serde_json::to_string_pretty(r).map_err(|e| ReportError::Io {
        path: out.join("report.json").display().to_string(),
        source: std::io::Error::other(e),
    })?;
    let mut files: Vec<(PathBuf, String)> = vec![
        (out.join("report.html"), html::render(r, &built.drill)),
        (out.join("report.md"), r.markdown()),
        (out.join("report.json"), format!("{json}\n")),
    ];
    files.extend(r.tables().into_iter().map(|t| (out.join(format!("{}.csv", t.name)), CsvExporter.render(&t))));
    files.extend(r.plots.iter().map(|p| (plots_dir.join(format!("{}.svg", p.name)), p.file_text())));
    let mut staged = Vec::with_capacity(files.len());
    for (path, text) in &files {
        let bytes = crate::redact::scrub_bytes(text.as_bytes());
        staged.push(crate::atomic::stage(path, &bytes).map_err(io(path))?);
        if built.style.pdf() && path.extension().is_some_and(|e| e == "svg") {
            let pdf_path = path.with_extension("pdf");
            let svg = String::from_utf8_lossy(&bytes);
            let pdf = pdf::from_svg(&svg)
                .map_err(|source| ReportError::Pdf { path: pdf_path.display().to_string(), source })?;
            staged.push(crate::atomic::stage(&pdf_path, &pdf).map_err(io(&pdf_path))?);
        }
    }
    // The drill-down's pictures, drawn again from each turn's scene text
    // (the picture is a function of it), in parallel.
    let pictures = crate::par::par_map(&built.drill.pictures, |p| {
        let obs = crate::observation::parse_scene(&p.scene).map_err(|e| e.to_string())?;
        crate::picture::png(&obs).map_err(|e| e.to_string())
    });
    for (p, png) in built.drill.pictures.iter().zip(pictures) {
        let path = out.join(&p.path);
        let png =
            png.map_err(|e| ReportError::Io { path: path.display().to_string(), source: std::io::Error::other(e) })?;
        std::fs::create_dir_all(out.join("pictures")).map_err(io(&out.join("pictures")))?;
        staged.push(crate::atomic::stage(&path, &png).map_err(io(&path))?);
    }
    let mut written = Vec::with_capacity(staged.len());
    for s in staged {
        let target = s.target.clone();
        s.commit().map_err(io(&target))?;
        written.push(target);
    }
    for entry in std::fs::read_dir(&plots_dir).map_err(io(&plots_dir))?.flatten() {
        let p = entry.path();
        if p.extension().is_some_and(|e| e == "svg" || e == "pdf") && !written.contains(&p) {
            std::fs::remove_file(&p).map_err(io(&p))?;
        }
    }
    let pictures_dir = out.join("pictures");
    for entry in std::fs::read_dir(&pictures_dir).into_iter().flatten().flatten() {
        let p = entry.path();
        if p.extension().is_some_and(|e| e == "png") && !written.contains(&p) {
            std::fs::remove_file(&p).map_err(io(&p))?;
        }
    }
    Ok(written)
}
