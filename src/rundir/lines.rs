//! The one reader of the run directory's JSON-lines files, used by `eval`
//! (resume) and `report` (loading).
//!
//! A line is complete when it ends with a newline: the writer appends each
//! line with one write, so only the last line of a file can be torn (a
//! process killed mid-write), and it is reported apart, never parsed as an
//! episode. Blank lines are skipped but counted in line numbers.
//!
//! Speed: every line is read (the file is streamed through a 1 MiB
//! buffer), but only its head is parsed. Records put the scalars before the
//! transcript, so a rollout line is cut at its top-level `,"turns":` key and
//! the head (closed with `}`) is deserialized; a line that does not allow
//! this is parsed whole.

use super::record::{EpisodeKey, EpisodeScalars, InfraErrorRecord, RolloutRecord};
use serde::Deserialize;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Where a line is in its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineRef {
    /// 1-based line number.
    pub line: u32,
    /// Byte offset of the line's start.
    pub offset: u64,
    /// Length without the newline.
    pub len: u32,
}

/// Stream `path` line by line; `on_line` gets every non-blank complete line
/// (without its newline). A missing file has no lines. Returns the torn
/// last line, if any, with its position.
fn for_each_line(path: &Path, mut on_line: impl FnMut(LineRef, &[u8])) -> std::io::Result<Option<(LineRef, Vec<u8>)>> {
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut buf = Vec::with_capacity(1 << 16);
    let mut offset: u64 = 0;
    let mut number: u32 = 0;
    loop {
        buf.clear();
        let n = reader.read_until(b'\n', &mut buf)?;
        if n == 0 {
            return Ok(None);
        }
        number += 1;
        let start = offset;
        offset += n as u64;
        if buf.last() != Some(&b'\n') {
            // A line the writer never finished.
            return Ok(Some((LineRef { line: number, offset: start, len: n as u32 }, buf)));
        }
        let line = &buf[..n - 1];
        if !is_blank(line) {
            on_line(LineRef { line: number, offset: start, len: line.len() as u32 }, line);
        }
    }
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
}

/// Byte position of the top-level `,"turns":` key, if the line has one.
fn turns_key(line: &[u8]) -> Option<usize> {
    const KEY: &[u8] = b",\"turns\":";
    line.windows(KEY.len()).position(|w| w == KEY)
}

/// The scalars of one rollout line, `None` if it is not a rollout record.
pub fn parse_scalars(line: &[u8], scratch: &mut Vec<u8>) -> Option<EpisodeScalars> {
    // Fast path: the head before the transcript, closed. A cut inside a
    // nested value leaves unbalanced braces and fails, falling through.
    if let Some(cut) = turns_key(line) {
        scratch.clear();
        scratch.extend_from_slice(&line[..cut]);
        scratch.push(b'}');
        if let Ok(s) = serde_json::from_slice::<EpisodeScalars>(scratch) {
            return Some(s);
        }
    }
    serde_json::from_slice::<EpisodeScalars>(line).ok()
}

/// Whether a line holds two records glued together (a newline lost by a
/// crash or a careless copy): `}{` followed by a record's first key. Such a
/// line is unreadable as a whole, for eval and report alike: counting only
/// its first record would drop the second silently.
fn is_glued(line: &[u8]) -> bool {
    const MARKERS: [&[u8]; 2] = [b"}{\"schema_version\":", b"}{\"model\":"];
    MARKERS.iter().any(|m| line.windows(m.len()).any(|w| w == *m))
}

/// Which configuration a line belongs to.
#[derive(Debug, Deserialize)]
struct LineIdentity {
    model: Option<String>,
    config_hash: Option<String>,
}

/// What [`read_rollouts`] found besides the episodes.
#[derive(Debug, Default)]
pub struct RolloutsRead {
    /// Complete, non-blank lines that are not rollout records.
    pub bad_lines: Vec<u32>,
    /// A torn last line (no newline): never read as an episode.
    pub torn: Option<LineRef>,
    /// The first model and config hash named by a readable line.
    pub model: Option<String>,
    pub config_hash: Option<String>,
}

/// Stream `rollouts.jsonl`, handing every readable episode to `on_episode`
/// in file order (duplicates included: callers decide which counts).
pub fn read_rollouts(
    path: &Path,
    mut on_episode: impl FnMut(EpisodeScalars, LineRef),
) -> std::io::Result<RolloutsRead> {
    let mut read = RolloutsRead::default();
    let mut scratch = Vec::with_capacity(4096);
    let torn = for_each_line(path, |at, line| {
        match parse_scalars(line, &mut scratch).filter(|_| !is_glued(line)) {
            Some(s) => {
                if read.model.is_none() || read.config_hash.is_none() {
                    // Once per file in practice (every line names both): the whole line.
                    if let Ok(id) = serde_json::from_slice::<LineIdentity>(line) {
                        read.model = read.model.take().or(id.model);
                        read.config_hash = read.config_hash.take().or(id.config_hash);
                    }
                }
                on_episode(s, at);
            }
            None => read.bad_lines.push(at.line),
        }
    })?;
    read.torn = torn.map(|(at, _)| at);
    Ok(read)
}

/// The whole records at `places` of a `rollouts.jsonl` (found earlier by
/// [`read_rollouts`]), in the order given: one open, reads in file order. A
/// place that no longer holds a readable record gives `None`.
pub fn read_records_at(path: &Path, places: &[LineRef]) -> std::io::Result<Vec<Option<RolloutRecord>>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = File::open(path)?;
    let mut order: Vec<usize> = (0..places.len()).collect();
    order.sort_by_key(|&k| places[k].offset);
    let mut out: Vec<Option<RolloutRecord>> = (0..places.len()).map(|_| None).collect();
    let mut buf = Vec::new();
    for k in order {
        let at = places[k];
        buf.resize(at.len as usize, 0);
        file.seek(SeekFrom::Start(at.offset))?;
        file.read_exact(&mut buf)?;
        out[k] = serde_json::from_slice::<RolloutRecord>(&buf).ok();
    }
    Ok(out)
}

/// `errors.jsonl`: its number of non-blank lines (a torn last one included)
/// and the keys of the readable ones.
pub fn read_infra_errors(path: &Path) -> std::io::Result<(usize, Vec<EpisodeKey>)> {
    let mut lines = 0;
    let mut keys = Vec::new();
    let mut take = |line: &[u8]| {
        lines += 1;
        if let Ok(r) = serde_json::from_slice::<InfraErrorRecord>(line) {
            keys.push(r.key());
        }
    };
    let torn = for_each_line(path, |_, line| take(line))?;
    if let Some((_, torn)) = torn.filter(|(_, t)| !is_blank(t)) {
        take(&torn);
    }
    Ok((lines, keys))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Outcome;
    use crate::scenario::Tier;

    #[test]
    fn glued_lines_are_unreadable_not_half_counted() {
        let a =
            r#"{"schema_version":1,"model":"m","scenario":"yield_standoff","tier":1,"seed":0,"rollout":0,"turns":[]}"#;
        let b = a.replace("\"seed\":0", "\"seed\":1");
        assert!(!is_glued(a.as_bytes()));
        assert!(is_glued(format!("{a}{b}").as_bytes()));
        assert!(is_glued(format!("{a}{}", r#"{"model":"m"}"#).as_bytes()));
    }

    #[test]
    fn fast_path_and_fallback_agree() {
        let head = r#"{"model":"m","config_hash":"h","scenario":"yield_standoff","tier":2,"seed":7,"rollout":1,"disposition":"committed","outcome":"timeout","reward":-0.2,"decision_correctness":0.5,"diagnostics":{"a":{"b":[1,2]}},"turns_taken":40,"parse_error_turns":3,"tokens":99"#;
        let mut scratch = Vec::new();
        // Transcript after the scalars: fast path.
        let line = format!(r#"{head},"turns":[{{"scene":"x,\"turns\":[","turns":1}}],"trajectory":null}}"#);
        let a = parse_scalars(line.as_bytes(), &mut scratch).unwrap();
        assert_eq!((a.seed, a.rollout, a.parse_error_turns, a.tier, a.schema_version), (7, 1, 3, Tier::T2, 0));
        // Transcript first: the cut head lacks fields, so the whole line is parsed.
        let reordered = format!(r#"{{"turns":[],{}}}"#, &head[1..]);
        let b = parse_scalars(reordered.as_bytes(), &mut scratch).unwrap();
        assert_eq!((b.seed, b.outcome), (7, Outcome::Timeout));
        // A nested "turns" key before the scalars' end cannot fool the cut.
        let nested = head.replace(r#""diagnostics":{"a":{"b":[1,2]}}"#, r#""diagnostics":{"x":1,"turns":[]}"#) + "}";
        let c = parse_scalars(nested.as_bytes(), &mut scratch).unwrap();
        assert_eq!(c.tokens, 99);
        // A versioned line reads its version.
        let versioned = head.replacen('{', r#"{"schema_version":1,"#, 1) + "}";
        assert_eq!(parse_scalars(versioned.as_bytes(), &mut scratch).unwrap().schema_version, 1);
        assert!(parse_scalars(b"{\"seed\":1}", &mut scratch).is_none());
    }
}
