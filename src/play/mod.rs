//! `negotiator play`: a person drives the benchmark's episodes in the
//! terminal and lands in a run directory like a model's.
//!
//! How: `eval` runs unchanged against an in-process chat endpoint
//! ([`endpoint`]) whose answers come from the person, one episode at a
//! time, with the model name `human:NAME`. The run directory, resume (an
//! interrupted episode is replayed from its start), run.json, the summary
//! and `report` are `eval`'s; the episode is the same `Episode`. This
//! module only owns the person's side: the screen ([`screen`], ratatui on
//! crossterm) and its loop ([`terminal`]), the line mode for a standard
//! input that is not a terminal, and the keys ([`input`]).
//!
//! Nothing hidden is shown: each turn's screen is the scene text the model
//! receives (the instructions once, on the help screen), and an episode's
//! end says "episode over" only. `--feedback` shows the outcome and the
//! other road user's intent after each episode, `--view plan` adds a
//! drawing, `--turn-seconds` makes turns real-time: each is recorded in the
//! run's configuration ([`crate::rundir::HumanSettings`]) and makes its own
//! leaderboard row. `--practice` plays seeds outside the benchmark's range
//! with feedback, into a temporary directory that is removed afterwards.

mod endpoint;
mod input;
mod screen;
mod terminal;

use crate::episode::{EpisodeSpec, Outcome, draw_disposition};
use crate::eval::events::{Event, Reporter};
use crate::eval::{EvalOptions, RunOutcome};
use crate::rundir::Selection;
use crate::rundir::record::EpisodeKey;
use endpoint::{EndpointState, Prompt, ToScreen};
use input::Draft;
use std::io::{BufRead, Write};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};

/// Seeds at or above this are never benchmark seeds (benchmark runs use
/// small seeds from 0): `--practice` draws from above it.
pub const PRACTICE_SEED_BASE: u64 = 1 << 40;

/// A validated `play` invocation.
#[derive(Debug)]
pub struct PlayOptions {
    /// `eval`'s options (model `human:NAME`, the human settings in the
    /// config), except the endpoint, which `run` starts.
    pub eval: EvalOptions,
    pub name: String,
    pub feedback: bool,
    pub plan_view: bool,
    /// `--view picture`: the file each turn's picture is written to.
    pub picture_file: Option<std::path::PathBuf>,
    pub turn_seconds: Option<f64>,
    /// Standard input is not a terminal: read one action per line.
    pub line_mode: bool,
    /// A practice run: its directory is removed at the end.
    pub practice: bool,
}

/// Forwards the run's events to the screen.
struct ToScreenReporter(Sender<ToScreen>);

impl Reporter for ToScreenReporter {
    fn event(&mut self, event: &Event) {
        let message = match event {
            Event::Planned { selected, finished, .. } => ToScreen::Planned { selected: *selected, finished: *finished },
            Event::EpisodeFinished { key, outcome, reward, .. } => {
                ToScreen::EpisodeOver { key: *key, outcome: *outcome, reward: *reward }
            }
            Event::Finished { .. } => ToScreen::RunOver,
            _ => return,
        };
        let _ = self.0.send(message);
    }
}

/// What the other road user intended, in words (for feedback and the
/// final summary).
fn intent(key: &EpisodeKey) -> String {
    let d = draw_disposition(EpisodeSpec { scenario: key.scenario, tier: key.tier, seed: key.seed });
    let meant = if d.ego_should_go() { "would have let you go first" } else { "was going first" };
    format!("the other road user was a {} ({meant})", d.name())
}

fn episode_over(key: &EpisodeKey, outcome: Outcome, reward: f64, feedback: bool) -> String {
    if feedback {
        format!("Episode over: {} (reward {reward:.2}); {}.", outcome.name(), intent(key))
    } else {
        "Episode over.".to_string()
    }
}

/// Play the run: start the endpoint and `eval` on a runtime in the
/// background, and the person's side on this thread. Returns `eval`'s
/// outcome (the run directory is saved whatever happens).
pub fn run(options: PlayOptions) -> anyhow::Result<RunOutcome> {
    let (to_screen, from_run) = channel();
    let interrupt = Arc::new(tokio::sync::Notify::new());
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    let listener = runtime.block_on(tokio::net::TcpListener::bind(("127.0.0.1", 0)))?;
    let port = listener.local_addr()?.port();
    let state = Arc::new(EndpointState {
        screen: to_screen.clone(),
        turn_seconds: options.turn_seconds,
        picture_file: options.picture_file.clone(),
    });
    runtime.spawn(async move {
        let _ = axum::serve(listener, endpoint::router(state)).await;
    });
    let PlayOptions { mut eval, name, feedback, plan_view, turn_seconds, line_mode, practice, picture_file } = options;
    eval.client.base_url = format!("http://127.0.0.1:{port}/v1");
    eval.interrupt = Some(interrupt.clone());
    let run_dir = eval.run_dir.clone();
    let handle = {
        let to_screen = to_screen.clone();
        std::thread::spawn(move || {
            let mut reporter = ToScreenReporter(to_screen.clone());
            let outcome = runtime.block_on(crate::eval::run(eval, &mut reporter));
            let _ = to_screen.send(ToScreen::RunOver);
            outcome
        })
    };
    drop(to_screen);
    let side = Side { from_run, interrupt, feedback: feedback || practice, plan_view, turn_seconds, name };
    let played = if line_mode { side.lines() } else { terminal::run(&side) };
    let outcome = handle.join().map_err(|_| anyhow::anyhow!("the run's thread panicked"))?;
    // The picture file is the screen's, not the record's (the run keeps
    // the scene texts the pictures are drawn from).
    if let Some(file) = &picture_file {
        let _ = std::fs::remove_file(file);
    }
    played?;
    let outcome = outcome?;
    if practice {
        let _ = std::fs::remove_dir_all(&run_dir);
    }
    Ok(outcome)
}

/// The person's side of the run.
struct Side {
    from_run: Receiver<ToScreen>,
    interrupt: Arc<tokio::sync::Notify>,
    feedback: bool,
    plan_view: bool,
    turn_seconds: Option<f64>,
    name: String,
}

impl Side {
    /// The plain line mode: each scene on standard output, one action per
    /// line from standard input; end of input saves and quits.
    fn lines(self) -> anyhow::Result<()> {
        let stdin = std::io::stdin();
        let mut input = stdin.lock().lines();
        let mut out = std::io::stdout();
        let mut draft = Draft::default();
        let mut closed = false;
        // An unanswered turn stays open after quitting: the run is stopped
        // as interrupted, not failed by a dropped answer.
        let mut unanswered = Vec::new();
        for message in &self.from_run {
            match message {
                ToScreen::Prompt(Prompt { scene, answer, shown }) => {
                    if closed {
                        unanswered.push(answer);
                        continue;
                    }
                    if let Some(shown) = shown {
                        let _ = shown.send(());
                    }
                    writeln!(out, "\n{scene}")?;
                    loop {
                        write!(out, "> ")?;
                        out.flush()?;
                        let line = input.next().transpose()?;
                        // End of input, or q: save and quit.
                        let Some(line) = line.filter(|l| l.trim() != "q") else {
                            closed = true;
                            self.interrupt.notify_one();
                            unanswered.push(answer);
                            break;
                        };
                        match input::read_line(&line, &mut draft) {
                            Some(reply) => {
                                let _ = answer.send(reply);
                                break;
                            }
                            None => writeln!(
                                out,
                                "not an answer: {:?} (p/n/y/s and a digit 0-9, or a JSON action)",
                                line.trim()
                            )?,
                        }
                    }
                }
                ToScreen::TimedOut { .. } | ToScreen::Planned { .. } => {}
                ToScreen::EpisodeOver { key, outcome, reward } => {
                    writeln!(out, "{}", episode_over(&key, outcome, reward, self.feedback))?;
                }
                ToScreen::RunOver => break,
            }
        }
        Ok(())
    }
}

const HELP_KEYS: &str = "p proceed, n nudge forward, y yield, s stop; 0-9 set the strength (0 = 0, 9 = 1), \
arrow keys step it by 0.1; Enter sends the answer shown at the bottom. Type { to write a JSON action \
instead (Enter sends it, Esc drops it). PgUp/PgDn scroll. ? shows or hides this help. q (or Ctrl-C) \
saves and quits: the same command goes on with the next unplayed episode.";

/// The end-of-run summary: each episode of the run directory this person
/// played, its outcome and what the other road user intended.
pub fn summary_lines(run_dir: &std::path::Path) -> Vec<String> {
    let mut episodes = Vec::new();
    let path = run_dir.join(crate::rundir::ROLLOUTS);
    if crate::rundir::lines::read_rollouts(&path, |e, _| episodes.push(e)).is_err() || episodes.is_empty() {
        return Vec::new();
    }
    let mut out = vec![format!(
        "{:<18} {:>4} {:>6}  {:<9} {:>6}  the other road user",
        "scenario", "tier", "seed", "outcome", "reward"
    )];
    for e in episodes {
        out.push(format!(
            "{:<18} {:>4} {:>6}  {:<9} {:>6.2}  {}",
            e.scenario.name(),
            e.tier.number(),
            e.seed,
            e.outcome.name(),
            e.reward,
            e.disposition.name()
        ));
    }
    out
}

/// The share of the run directory's episodes that succeeded (0 when none).
pub fn mean_success(run_dir: &std::path::Path) -> f64 {
    let (mut n, mut ok) = (0u32, 0u32);
    let path = run_dir.join(crate::rundir::ROLLOUTS);
    let _ = crate::rundir::lines::read_rollouts(&path, |e, _| {
        n += 1;
        ok += u32::from(e.success());
    });
    if n == 0 { 0.0 } else { f64::from(ok) / f64::from(n) }
}

/// The selection of a practice run: `n` seeds per cell drawn above
/// [`PRACTICE_SEED_BASE`].
pub fn practice_selection(mut selection: Selection) -> Selection {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64);
    selection.base_seed = PRACTICE_SEED_BASE + crate::hash::splitmix64(nanos) % (1 << 30);
    selection
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{ScenarioKind, Tier};

    /// Without --feedback the end of an episode says the same under every
    /// disposition and outcome: nothing a model is not told.
    #[test]
    fn an_episode_ends_without_outcome_or_intent_unless_feedback_is_asked() {
        let mut seen = std::collections::HashSet::new();
        for seed in 0..20 {
            let key = EpisodeKey { scenario: ScenarioKind::YieldStandoff, tier: Tier::T2, seed, rollout: 0 };
            for outcome in [Outcome::Success, Outcome::Collision, Outcome::Timeout] {
                seen.insert(episode_over(&key, outcome, 0.5, false));
                let told = episode_over(&key, outcome, 0.5, true);
                assert!(told.contains(outcome.name()) && told.contains(&intent(&key)));
            }
        }
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), ["Episode over."]);
    }
}
