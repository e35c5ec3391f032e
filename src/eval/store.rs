//! The run directory: `run.json` (config, versions, totals),
//! `rollouts.jsonl` (one line per finished episode), `errors.jsonl`
//! (infrastructure failures, for the record; those episodes are re-run),
//! `summary.json` / `summary.md` (the leaderboard of the last invocation).
//!
//! Durability: every line is written with one `write_all` of the complete
//! line and its newline by a single writer thread, so a killed process
//! leaves at worst one torn last line, which the next invocation cuts off
//! before appending. Lines reach the operating system as each episode
//! finishes (a `kill -9` loses nothing written); the file is fsynced at most
//! [`SYNC_INTERVAL`] after a line was written, and when the run ends.

use crate::rundir::lines::read_rollouts;
use crate::rundir::record::{EpisodeKey, EpisodeScalars};
use crate::rundir::{ERRORS, ROLLOUTS, RunConfig, RunDirError, RunInfo};
use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The lock file: an exclusive OS lock on it marks the directory as in use.
pub const LOCK: &str = ".lock";
/// Longest time a finished episode's line stays in the OS cache before it
/// is fsynced: a power cut loses at most this window (and leaves at worst a
/// torn last line, cut off by the next invocation).
pub const SYNC_INTERVAL: std::time::Duration = std::time::Duration::from_secs(1);

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error(
        "refusing to reuse {dir}: it holds a run with a different configuration ({changes}); \
         restore the original flags to resume it, or choose another --run-name / --output for a new run"
    )]
    ConfigChanged { dir: String, changes: String },
    #[error(
        "another eval is running in {dir} (it holds {dir}/{LOCK}); wait for it to finish, or choose another --run-name / --output"
    )]
    Locked { dir: String },
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

/// Take the run directory for this process: an exclusive OS lock on
/// `DIR/.lock`, held as long as the returned file is open. The operating
/// system releases it when the process ends, by a crash or `kill -9` too, so
/// a stale lock never needs cleaning up.
pub fn lock_dir(dir: &Path) -> Result<File, StoreError> {
    let path = dir.join(LOCK);
    let file = OpenOptions::new().create(true).truncate(false).write(true).open(&path).map_err(io(&path))?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(StoreError::Locked { dir: dir.display().to_string() }),
        Err(std::fs::TryLockError::Error(e)) => Err(io(&path)(e)),
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

pub enum WriteMsg {
    Rollout(String),
    InfraError(String),
}

/// The single writer: a thread that appends complete lines as they come,
/// and fsyncs `rollouts.jsonl` no later than `sync_interval` after a line
/// was written (and once more at the end).
pub struct Writer {
    pub tx: std::sync::mpsc::Sender<WriteMsg>,
    /// fsyncs of `rollouts.jsonl` done so far (the tests time them).
    #[cfg(test)]
    pub syncs: std::sync::Arc<std::sync::atomic::AtomicU64>,
    handle: std::thread::JoinHandle<Result<(), StoreError>>,
}

impl Writer {
    pub fn start(dir: &Path) -> Result<Writer, StoreError> {
        Writer::start_with(dir, SYNC_INTERVAL)
    }

    pub fn start_with(dir: &Path, sync_interval: std::time::Duration) -> Result<Writer, StoreError> {
        use std::sync::atomic::Ordering::Relaxed;
        use std::sync::mpsc::RecvTimeoutError;
        use std::time::Instant;
        let rollouts_path = dir.join(ROLLOUTS);
        let errors_path = dir.join(ERRORS);
        let open = |p: &PathBuf| OpenOptions::new().create(true).append(true).open(p).map_err(io(p));
        let mut rollouts = open(&rollouts_path)?;
        let (tx, rx) = std::sync::mpsc::channel::<WriteMsg>();
        let syncs = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
        let sync_count = syncs.clone();
        let handle = std::thread::Builder::new()
            .name("rollout-writer".into())
            .spawn(move || {
                let mut errors: Option<File> = None;
                // When the oldest unsynced rollout line was written.
                let mut dirty_since: Option<Instant> = None;
                loop {
                    let wait = dirty_since
                        .map_or(std::time::Duration::from_secs(3600), |t| sync_interval.saturating_sub(t.elapsed()));
                    match rx.recv_timeout(wait) {
                        Ok(msg) => {
                            let is_rollout = matches!(msg, WriteMsg::Rollout(_));
                            let (file, path, mut line) = match msg {
                                WriteMsg::Rollout(line) => (&mut rollouts, &rollouts_path, line),
                                WriteMsg::InfraError(line) => {
                                    if errors.is_none() {
                                        errors = Some(open(&errors_path)?);
                                    }
                                    (errors.as_mut().expect("just opened"), &errors_path, line)
                                }
                            };
                            // The choke point for both files: raw replies and
                            // error bodies come from the endpoint and may echo
                            // the key.
                            if let std::borrow::Cow::Owned(clean) = crate::redact::scrub(&line) {
                                line = clean;
                            }
                            line.push('\n');
                            // One write of the whole line; File is unbuffered,
                            // so the line is with the OS when this returns.
                            file.write_all(line.as_bytes()).map_err(io(path))?;
                            if is_rollout && dirty_since.is_none() {
                                dirty_since = Some(Instant::now());
                            }
                        }
                        Err(RecvTimeoutError::Timeout) => {}
                        Err(RecvTimeoutError::Disconnected) => break,
                    }
                    if dirty_since.is_some_and(|t| t.elapsed() >= sync_interval) {
                        rollouts.sync_data().map_err(io(&rollouts_path))?;
                        sync_count.fetch_add(1, Relaxed);
                        dirty_since = None;
                    }
                }
                rollouts.sync_all().map_err(io(&rollouts_path))?;
                sync_count.fetch_add(1, Relaxed);
                if let Some(e) = errors {
                    e.sync_all().map_err(io(&errors_path))?;
                }
                Ok(())
            })
            .map_err(io(dir))?;
        Ok(Writer {
            tx,
            #[cfg(test)]
            syncs,
            handle,
        })
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
    use crate::scenario::{ScenarioKind, Tier};

    fn line(seed: u64, rollout: u32) -> String {
        let s = EpisodeScalars {
            schema_version: crate::rundir::SCHEMA_VERSION,
            scenario: ScenarioKind::YieldStandoff,
            tier: Tier::T1,
            seed,
            rollout,
            disposition: crate::scenario::yield_standoff::COMMITTED,
            outcome: Outcome::Success,
            reward: 0.9,
            decision_correctness: 1.0,
            timing: Default::default(),
            belief: None,
            forecast: None,
            turns_taken: 10,
            parse_error_turns: 0,
            tokens: 100,
            prompt_tokens: 90,
            completion_tokens: 10,
            truncated_turns: 0,
            reasoning_tokens: 0,
            cached_tokens: 0,
            cost_usd: Some(0.001),
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
    fn rollout_lines_are_fsynced_within_the_interval_not_only_at_the_end() {
        let dir = tempdir("sync");
        let w = Writer::start_with(&dir, std::time::Duration::ZERO).unwrap();
        for seed in 0..3 {
            w.tx.send(WriteMsg::Rollout(line(seed, 0).trim_end().to_string())).unwrap();
        }
        // Wait (bounded) for the writer to take all three: with a zero
        // interval each line is synced as it is written.
        for _ in 0..500 {
            if w.syncs.load(std::sync::atomic::Ordering::Relaxed) >= 3 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        assert!(w.syncs.load(std::sync::atomic::Ordering::Relaxed) >= 3, "synced only at the end");
        w.finish().unwrap();
        // A long interval syncs once, at the end.
        let w = Writer::start_with(&dir, std::time::Duration::from_secs(3600)).unwrap();
        w.tx.send(WriteMsg::Rollout(line(3, 0).trim_end().to_string())).unwrap();
        let syncs = w.syncs.clone();
        w.finish().unwrap();
        assert_eq!(syncs.load(std::sync::atomic::Ordering::Relaxed), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_locked_directory_is_refused_until_the_holder_lets_go() {
        let dir = tempdir("lock");
        let held = lock_dir(&dir).unwrap();
        let err = lock_dir(&dir).unwrap_err().to_string();
        assert!(err.starts_with("another eval is running in"), "{err}");
        drop(held);
        assert!(lock_dir(&dir).is_ok());
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
            endpoint: String::new(),
            probe: Default::default(),
            human: None,
            pictures: None,
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
                cost_usd: None,
                wall_s: 0.0,
            },
            totals: Totals::default(),
            pricing: None,
            imported_from: None,
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
