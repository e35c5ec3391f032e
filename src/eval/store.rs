//! The run directory: `run.json` (config, versions, totals),
//! `rollouts.jsonl` (one line per finished episode), `errors.jsonl`
//! (infrastructure failures, for the record; those episodes are re-run),
//! `summary.json` / `summary.md` (the leaderboard of the last invocation).
//!
//! Durability: every line is written with one `write_all` of the complete
//! line and its newline by a single writer thread, so a killed process
//! leaves at worst one torn last line, which the next invocation cuts off
//! before appending. Lines reach the operating system as each episode
//! finishes (a `kill -9` loses nothing written); the file is fsynced when the
//! run ends.

use crate::rundir::lines::read_rollouts;
use crate::rundir::record::{EpisodeKey, EpisodeScalars};
use crate::rundir::{ERRORS, ROLLOUTS, RunConfig, RunDirError, RunInfo};
use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error(
        "refusing to reuse {dir}: it holds a run with a different configuration ({changes}); \
         restore the original flags to resume it, or choose another --run-name / --output for a new run"
    )]
    ConfigChanged { dir: String, changes: String },
    #[error("{path}: unreadable run.json ({message}); move it away to start over")]
    BadRunJson { path: String, message: String },
}

impl From<RunDirError> for StoreError {
    fn from(e: RunDirError) -> Self {
        match e {
            RunDirError::Io { path, source } => StoreError::Io { path, source },
            RunDirError::BadRunJson { path, message } => StoreError::BadRunJson { path, message },
        }
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io { path: path.display().to_string(), source }
}

/// What a resume found in `rollouts.jsonl`.
#[derive(Debug, Default)]
pub struct Loaded {
    pub finished: HashMap<EpisodeKey, EpisodeScalars>,
    /// Bytes of a torn last line that were cut off.
    pub torn_bytes: u64,
    /// Complete lines that could not be read (kept in the file, ignored).
    pub bad_lines: usize,
    /// Config hash of the first readable line, if any.
    pub first_hash: Option<String>,
}

/// Read `rollouts.jsonl`, cutting off a torn last line (no newline, or
/// unreadable without one) so the next append starts on a fresh line. If a
/// key appears twice (two processes on one directory), the first line
/// counts.
pub fn load_rollouts(path: &Path) -> Result<Loaded, StoreError> {
    let mut finished: HashMap<EpisodeKey, EpisodeScalars> = HashMap::new();
    let read = read_rollouts(path, |s, _| {
        finished.entry(s.key()).or_insert(s);
    })
    .map_err(io(path))?;
    if let Some(torn) = read.torn {
        let f = OpenOptions::new().write(true).open(path).map_err(io(path))?;
        f.set_len(torn.offset).map_err(io(path))?;
        f.sync_all().map_err(io(path))?;
    }
    Ok(Loaded {
        finished,
        torn_bytes: read.torn.map_or(0, |t| u64::from(t.len)),
        bad_lines: read.bad_lines.len(),
        first_hash: read.config_hash,
    })
}

/// Refuse a directory whose run was started with another configuration.
pub fn check_config(
    dir: &Path,
    previous: Option<&RunInfo>,
    loaded: &Loaded,
    config: &RunConfig,
) -> Result<(), StoreError> {
    let changes = match previous {
        Some(info) if info.config != *config => info.config.diff(config).join("; "),
        Some(_) => return Ok(()),
        // No run.json (lost, or a copied rollouts file): the lines' hash decides.
        None => match &loaded.first_hash {
            Some(h) if *h != config.hash() => format!("config hash {h} -> {}", config.hash()),
            _ => return Ok(()),
        },
    };
    Err(StoreError::ConfigChanged { dir: dir.display().to_string(), changes })
}

pub enum WriteMsg {
    Rollout(String),
    InfraError(String),
}

/// The single writer: a thread that appends complete lines as they come.
pub struct Writer {
    pub tx: tokio::sync::mpsc::UnboundedSender<WriteMsg>,
    handle: std::thread::JoinHandle<Result<(), StoreError>>,
}

impl Writer {
    pub fn start(dir: &Path) -> Result<Writer, StoreError> {
        let rollouts_path = dir.join(ROLLOUTS);
        let errors_path = dir.join(ERRORS);
        let open = |p: &PathBuf| OpenOptions::new().create(true).append(true).open(p).map_err(io(p));
        let mut rollouts = open(&rollouts_path)?;
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<WriteMsg>();
        let handle = std::thread::Builder::new()
            .name("rollout-writer".into())
            .spawn(move || {
                let mut errors: Option<File> = None;
                while let Some(msg) = rx.blocking_recv() {
                    let (file, path, mut line) = match msg {
                        WriteMsg::Rollout(line) => (&mut rollouts, &rollouts_path, line),
                        WriteMsg::InfraError(line) => {
                            if errors.is_none() {
                                errors = Some(open(&errors_path)?);
                            }
                            (errors.as_mut().expect("just opened"), &errors_path, line)
                        }
                    };
                    // The choke point for both files: raw replies and error
                    // bodies come from the endpoint and may echo the key.
                    if let std::borrow::Cow::Owned(clean) = crate::redact::scrub(&line) {
                        line = clean;
                    }
                    line.push('\n');
                    // One write of the whole line; File is unbuffered, so the
                    // line is with the OS when this returns.
                    file.write_all(line.as_bytes()).map_err(io(path))?;
                }
                rollouts.sync_all().map_err(io(&rollouts_path))?;
                if let Some(e) = errors {
                    e.sync_all().map_err(io(&errors_path))?;
                }
                Ok(())
            })
            .map_err(io(dir))?;
        Ok(Writer { tx, handle })
    }

    /// Close the channel and wait for every line to be written.
    pub fn finish(self) -> Result<(), StoreError> {
        drop(self.tx);
        match self.handle.join() {
            Ok(r) => r,
            Err(_) => Err(StoreError::Io {
                path: ROLLOUTS.into(),
                source: std::io::Error::other("the writer thread panicked"),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Outcome;
    use crate::rundir::{Invocation, RunStatus, Selection, Shard, Totals, read_run_info, write_run_info};
    use crate::scenario::{Disposition, ScenarioKind, Tier};

    fn line(seed: u64, rollout: u32) -> String {
        let s = EpisodeScalars {
            schema_version: crate::rundir::SCHEMA_VERSION,
            scenario: ScenarioKind::YieldStandoff,
            tier: Tier::T1,
            seed,
            rollout,
            disposition: Disposition::Committed,
            outcome: Outcome::Success,
            reward: 0.9,
            decision_correctness: 1.0,
            turns_taken: 10,
            parse_error_turns: 0,
            tokens: 100,
            prompt_tokens: 90,
            completion_tokens: 10,
            latency_ms: 5,
            retries: 0,
        };
        let mut v = serde_json::to_value(s).unwrap();
        v["config_hash"] = "abc".into();
        v["turns"] = serde_json::json!([{"scene": "long"}]);
        format!("{v}\n")
    }

    fn tempdir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("negotiator-store-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn torn_last_line_is_cut_off_and_appends_start_clean() {
        let dir = tempdir("torn");
        let path = dir.join(ROLLOUTS);
        let complete = format!("{}{}", line(0, 0), line(1, 0));
        let torn = &line(2, 0)[..40];
        std::fs::write(&path, format!("{complete}{torn}")).unwrap();
        let loaded = load_rollouts(&path).unwrap();
        assert_eq!(loaded.finished.len(), 2);
        assert_eq!(loaded.torn_bytes, 40);
        assert_eq!(loaded.first_hash.as_deref(), Some("abc"));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), complete);
        // Appending after the cut gives well-formed lines only.
        let w = Writer::start(&dir).unwrap();
        w.tx.send(WriteMsg::Rollout(line(2, 0).trim_end().to_string())).unwrap();
        w.finish().unwrap();
        let loaded = load_rollouts(&path).unwrap();
        assert_eq!((loaded.finished.len(), loaded.torn_bytes, loaded.bad_lines), (3, 0, 0));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_and_duplicate_lines_are_counted_not_fatal() {
        let dir = tempdir("bad");
        let path = dir.join(ROLLOUTS);
        std::fs::write(&path, format!("{}garbage\n\n{}", line(0, 0), line(0, 0))).unwrap();
        let loaded = load_rollouts(&path).unwrap();
        assert_eq!((loaded.finished.len(), loaded.bad_lines, loaded.torn_bytes), (1, 1, 0));
        assert!(load_rollouts(&dir.join("absent.jsonl")).unwrap().finished.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_changed_config_is_refused_with_its_changes() {
        use crate::rundir::HistoryWindow;
        let dir = tempdir("config");
        let config = RunConfig {
            model: "m".into(),
            request_params: Default::default(),
            history: HistoryWindow::Full,
            prompt_hash: "p".into(),
            scenarios_hash: "s".into(),
        };
        let info = RunInfo {
            schema_version: crate::rundir::SCHEMA_VERSION,
            run_name: "r".into(),
            config: config.clone(),
            config_hash: config.hash(),
            crate_version: "0".into(),
            git_revision: "unknown".into(),
            started_at: "t".into(),
            ended_at: None,
            invocations: 1,
            last_invocation: Invocation {
                started_at: "t".into(),
                ended_at: None,
                status: RunStatus::Running,
                selection: Selection {
                    base_seed: 0,
                    rollouts: 1,
                    scenarios: vec![ScenarioKind::YieldStandoff],
                    seeds: 2,
                    shard: Shard::WHOLE,
                    tiers: vec![Tier::T1],
                },
                endpoint: Default::default(),
                settings: Default::default(),
                episodes: 0,
                infra_errors: 0,
                retries: 0,
                tokens: 0,
                turns: 0,
                wall_s: 0.0,
            },
            totals: Totals::default(),
        };
        write_run_info(&dir, &info).unwrap();
        let read = read_run_info(&dir).unwrap().unwrap();
        assert_eq!(read, info);
        let empty = Loaded::default();
        assert!(check_config(&dir, Some(&read), &empty, &config).is_ok());
        let mut changed = config.clone();
        changed.model = "other".into();
        changed.history = HistoryWindow::Last(2);
        let msg = check_config(&dir, Some(&read), &empty, &changed).unwrap_err().to_string();
        assert!(msg.contains("model: \"m\" -> \"other\""), "{msg}");
        assert!(msg.contains("history"), "{msg}");
        // Without run.json, the lines' hash decides.
        let loaded = Loaded { first_hash: Some("abc".into()), ..Loaded::default() };
        assert!(check_config(&dir, None, &loaded, &config).is_err());
        assert!(check_config(&dir, None, &Loaded::default(), &config).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
