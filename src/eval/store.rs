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

use super::config::RunConfig;
use super::record::{EpisodeKey, RolloutScalars};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

pub const ROLLOUTS: &str = "rollouts.jsonl";
pub const ERRORS: &str = "errors.jsonl";
pub const RUN_JSON: &str = "run.json";

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

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io { path: path.display().to_string(), source }
}

/// Per-invocation facts kept in run.json (the last invocation's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Invocation {
    pub started_at: String,
    pub ended_at: Option<String>,
    /// `running`, `finished`, `incomplete` (episodes missing),
    /// `interrupted`, `refused` or `failed`.
    pub status: String,
    pub selection: serde_json::Value,
    pub endpoint: serde_json::Value,
    pub settings: serde_json::Value,
    pub episodes: u64,
    pub infra_errors: u64,
    pub retries: u64,
    pub tokens: u64,
    /// Decision turns answered (requests that succeeded).
    #[serde(default)]
    pub turns: u64,
    pub wall_s: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    /// Finished episodes in rollouts.jsonl.
    pub episodes: u64,
    /// Rollouts given up as infrastructure errors, over all invocations
    /// (each is re-run by the next invocation).
    pub infra_errors: u64,
    /// Episodes of the last selection still missing.
    pub missing: u64,
    /// Retried requests, over all invocations.
    pub retries: u64,
    /// Tokens of the finished episodes.
    pub tokens: u64,
    /// Wall time, over all invocations (s).
    pub wall_s: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    pub run_name: String,
    pub config: RunConfig,
    pub config_hash: String,
    pub crate_version: String,
    pub git_revision: String,
    /// First invocation's start.
    pub started_at: String,
    /// Last invocation's end.
    pub ended_at: Option<String>,
    pub invocations: u32,
    pub last_invocation: Invocation,
    pub totals: Totals,
}

/// What a resume found in `rollouts.jsonl`.
#[derive(Debug, Default)]
pub struct Loaded {
    pub finished: HashMap<EpisodeKey, RolloutScalars>,
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
    let mut loaded = Loaded::default();
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(loaded),
        Err(e) => return Err(io(path)(e)),
    };
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut buf = Vec::new();
    let mut good_end: u64 = 0;
    let mut offset: u64 = 0;
    loop {
        buf.clear();
        let n = reader.read_until(b'\n', &mut buf).map_err(io(path))?;
        if n == 0 {
            break;
        }
        offset += n as u64;
        if buf.last() != Some(&b'\n') {
            // A line the writer never finished.
            loaded.torn_bytes = n as u64;
            break;
        }
        good_end = offset;
        #[derive(Deserialize)]
        struct HashOnly {
            config_hash: Option<String>,
        }
        match serde_json::from_slice::<RolloutScalars>(&buf) {
            Ok(s) => {
                if loaded.first_hash.is_none() {
                    loaded.first_hash = serde_json::from_slice::<HashOnly>(&buf).ok().and_then(|h| h.config_hash);
                }
                loaded.finished.entry(s.key()).or_insert(s);
            }
            Err(_) if buf.iter().all(u8::is_ascii_whitespace) => {}
            Err(_) => loaded.bad_lines += 1,
        }
    }
    if loaded.torn_bytes > 0 {
        let f = OpenOptions::new().write(true).open(path).map_err(io(path))?;
        f.set_len(good_end).map_err(io(path))?;
        f.sync_all().map_err(io(path))?;
    }
    Ok(loaded)
}

pub fn read_run_info(dir: &Path) -> Result<Option<RunInfo>, StoreError> {
    let path = dir.join(RUN_JSON);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| StoreError::BadRunJson { path: path.display().to_string(), message: e.to_string() }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io(&path)(e)),
    }
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

/// Write `run.json` atomically (temporary file, then rename), so a kill
/// never leaves half a file.
pub fn write_run_info(dir: &Path, info: &RunInfo) -> Result<(), StoreError> {
    write_atomic(&dir.join(RUN_JSON), &serde_json::to_vec_pretty(info).expect("run info serialises"))
}

pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(io(&tmp))?;
    std::fs::rename(&tmp, path).map_err(io(path))
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
    use crate::scenario::{ScenarioKind, Tier};

    fn line(seed: u64, rollout: u32) -> String {
        let s = RolloutScalars {
            scenario: ScenarioKind::YieldStandoff,
            tier: Tier::T1,
            seed,
            rollout,
            outcome: Outcome::Success,
            reward: 0.9,
            decision_correctness: 1.0,
            turns_taken: 10,
            parse_error_turns: 0,
            tokens: 100,
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
        use super::super::config::HistoryWindow;
        let dir = tempdir("config");
        let config = RunConfig {
            model: "m".into(),
            request_params: Default::default(),
            history: HistoryWindow::Full,
            prompt_hash: "p".into(),
            scenarios_hash: "s".into(),
        };
        let info = RunInfo {
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
                status: "running".into(),
                selection: Default::default(),
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
