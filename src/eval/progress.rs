//! The reporters of a run's [`Event`]s: an indicatif bar on a terminal
//! ([`Bar`]), a plain line every few seconds otherwise (logs, CI;
//! [`Lines`]), nothing ([`Quiet`]), or one JSON object per event for other
//! tools ([`JsonLines`]). Everything goes to stderr; stdout carries only the
//! leaderboard.

use super::events::{Counters, Event, Reporter};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

fn human(n: u64) -> String {
    match n {
        0..=9_999 => n.to_string(),
        10_000..=999_999 => format!("{:.1}k", n as f64 / 1e3),
        _ => format!("{:.2}M", n as f64 / 1e6),
    }
}

fn status(c: &Counters) -> String {
    let done = c.done.load(Relaxed);
    let success = c.success.load(Relaxed);
    let rate = if done == 0 { "-".to_string() } else { format!("{:.2}", success as f64 / done as f64) };
    let mut line = format!(
        "success {rate} | infra errors {} | retries {} | tokens {} | cost {}",
        c.infra_errors.load(Relaxed),
        c.retries.load(Relaxed),
        human(c.tokens.load(Relaxed)),
        crate::rundir::usd_or_unknown(c.cost())
    );
    if let Some(e) = c.recent_error() {
        line.push_str(&format!(" | last error: {}", crate::llm::client::clip(&e, 100)));
    }
    line
}

/// The human-readable line of an event, if it has one (progress itself is
/// drawn from the counters).
fn human_line(event: &Event) -> Vec<String> {
    match event {
        Event::Resumed { torn_bytes, bad_lines, .. } => {
            let mut out = Vec::new();
            if *torn_bytes > 0 {
                out.push(format!("note: cut off a torn last line ({torn_bytes} bytes) left by an interrupted run"));
            }
            if *bad_lines > 0 {
                out.push(format!("warning: {bad_lines} unreadable line(s) in {} are ignored", crate::rundir::ROLLOUTS));
            }
            out
        }
        Event::Planned { run_dir, selected, finished, to_run } => vec![format!(
            "run directory {run_dir}: {selected} episodes selected, {finished} already finished, {to_run} to run"
        )],
        Event::Outage { streak, last_error } => vec![format!(
            "{streak} episodes in a row ran out of retries (last: {last_error}); starting no new episodes"
        )],
        Event::Finished { episodes, turns, retries, wall_s, .. } if *wall_s > 0.0 => vec![format!(
            "{episodes} episodes, {turns} decision turns in {wall_s:.1} s ({:.0} turns/s), {retries} retries",
            *turns as f64 / wall_s
        )],
        _ => Vec::new(),
    }
}

/// A thread that calls `tick` every `every` until stopped (synchronously,
/// so nothing redraws after [`Ticker::stop`] returns).
struct Ticker {
    stop: mpsc::Sender<()>,
    handle: JoinHandle<()>,
}

impl Ticker {
    fn start(every: Duration, mut tick: impl FnMut() + Send + 'static) -> Ticker {
        let (stop, stopped) = mpsc::channel::<()>();
        let handle = std::thread::spawn(move || {
            while let Err(mpsc::RecvTimeoutError::Timeout) = stopped.recv_timeout(every) {
                tick();
            }
        });
        Ticker { stop, handle }
    }

    fn stop(self) {
        let _ = self.stop.send(());
        let _ = self.handle.join();
    }
}

/// An indicatif bar redrawn five times a second; event lines are printed
/// above it.
#[derive(Default)]
pub struct Bar {
    live: Arc<Counters>,
    bar: Option<(ProgressBar, Ticker)>,
}

impl Bar {
    fn draw(bar: &ProgressBar, live: &Counters) {
        bar.set_position(live.done.load(Relaxed));
        bar.set_message(status(live));
    }
}

impl Reporter for Bar {
    fn attach(&mut self, live: Arc<Counters>) {
        self.live = live;
    }

    fn event(&mut self, event: &Event) {
        if let Event::Finished { .. } = event
            && let Some((bar, ticker)) = self.bar.take()
        {
            // Cleared before the run's last line and the summary.
            ticker.stop();
            Bar::draw(&bar, &self.live);
            bar.finish_and_clear();
        }
        for line in human_line(event) {
            match &self.bar {
                Some((bar, _)) => bar.suspend(|| crate::redact::eline!("{line}")),
                None => crate::redact::eline!("{line}"),
            }
        }
        if let Event::Planned { to_run, .. } = event {
            let bar = ProgressBar::with_draw_target(Some(*to_run as u64), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:30}] {pos}/{len} episodes | {msg} | ETA {eta_or_dash}",
                )
                .expect("valid template")
                .with_key("eta_or_dash", |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&eta_text(s.pos(), s.len().unwrap_or(0), s.eta()));
                })
                .progress_chars("=> "),
            );
            Bar::draw(&bar, &self.live);
            let (b, live) = (bar.clone(), self.live.clone());
            let ticker = Ticker::start(Duration::from_millis(200), move || Bar::draw(&b, &live));
            self.bar = Some((bar, ticker));
        }
    }
}

/// The ETA shown: "-" before the first episode finishes (nothing to
/// extrapolate from; "0s" at 0/N would read as "done"), else whole seconds.
pub(crate) fn eta_text(done: u64, total: u64, eta: Duration) -> String {
    if done == 0 && total > 0 { "-".to_string() } else { format!("{}s", eta.as_secs_f64().round() as u64) }
}

/// A plain progress line every `interval` (for logs and CI), and the event
/// lines.
pub struct Lines {
    interval: Duration,
    live: Arc<Counters>,
    ticker: Option<Ticker>,
}

impl Lines {
    pub fn new(interval: Duration) -> Lines {
        Lines { interval, live: Arc::default(), ticker: None }
    }
}

impl Reporter for Lines {
    fn attach(&mut self, live: Arc<Counters>) {
        self.live = live;
    }

    fn event(&mut self, event: &Event) {
        if let Event::Finished { .. } = event
            && let Some(t) = self.ticker.take()
        {
            t.stop();
        }
        for line in human_line(event) {
            crate::redact::eline!("{line}");
        }
        if let Event::Planned { to_run, .. } = event {
            let (live, total, started) = (self.live.clone(), *to_run as u64, Instant::now());
            self.ticker = Some(Ticker::start(self.interval, move || {
                let done = live.done.load(Relaxed);
                let elapsed = started.elapsed().as_secs_f64();
                let eta = eta_text(
                    done,
                    total,
                    Duration::from_secs_f64(if done == 0 {
                        0.0
                    } else {
                        elapsed / done as f64 * (total - done.min(total)) as f64
                    }),
                );
                crate::redact::eline!("[{elapsed:.0}s] {done}/{total} episodes | {} | ETA {eta}", status(&live));
            }));
        }
    }
}

/// No output at all.
pub struct Quiet;

impl Reporter for Quiet {
    fn event(&mut self, _: &Event) {}
}

/// One JSON object per event on stderr (`--events json`), for other tools.
pub struct JsonLines<W: Write = std::io::Stderr> {
    out: W,
}

impl JsonLines {
    pub fn stderr() -> JsonLines {
        JsonLines { out: std::io::stderr() }
    }
}

#[cfg(test)]
impl<W: Write> JsonLines<W> {
    pub fn new(out: W) -> JsonLines<W> {
        JsonLines { out }
    }

    pub fn into_inner(self) -> W {
        self.out
    }
}

impl<W: Write> Reporter for JsonLines<W> {
    fn event(&mut self, event: &Event) {
        // Events carry endpoint messages, which may echo the key.
        let mut line = crate::redact::scrub(&serde_json::to_string(event).expect("events serialise")).into_owned();
        line.push('\n');
        // One write per line, so lines never interleave; a closed stderr
        // must not stop the run.
        let _ = self.out.write_all(line.as_bytes());
        let _ = self.out.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Outcome;

    #[test]
    fn no_eta_before_the_first_episode() {
        assert_eq!(eta_text(0, 120, Duration::ZERO), "-");
        assert_eq!(eta_text(3, 120, Duration::from_secs_f64(41.6)), "42s");
        assert_eq!(eta_text(120, 120, Duration::ZERO), "0s");
        // The bar's own template uses it.
        let bar = ProgressBar::hidden();
        bar.set_length(10);
        let style = ProgressStyle::with_template("{eta_or_dash}").unwrap().with_key(
            "eta_or_dash",
            |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(&eta_text(s.pos(), s.len().unwrap_or(0), s.eta()));
            },
        );
        bar.set_style(style);
        assert_eq!(eta_text(bar.position(), bar.length().unwrap(), bar.eta()), "-");
    }
    use crate::eval::events::StopReason;
    use crate::rundir::RunStatus;
    use crate::rundir::record::EpisodeKey;
    use crate::scenario::{ScenarioKind, Tier};

    #[test]
    fn json_lines_schema() {
        let key = EpisodeKey { scenario: ScenarioKind::ContestedMerge, tier: Tier::T2, seed: 7, rollout: 1 };
        let mut r = JsonLines::new(Vec::new());
        for e in [
            Event::EpisodeFinished {
                key,
                outcome: Outcome::Collision,
                reward: -1.0,
                turns: 12,
                tokens: 900,
                retries: 2,
            },
            Event::InfraError { key, turn: 3, error: "HTTP 503".into() },
            Event::Stopped { reason: StopReason::Outage { streak: 8 } },
            Event::Finished {
                status: RunStatus::Incomplete,
                stop: Some(StopReason::TokenBudget),
                episodes: 4,
                infra_errors: 1,
                turns: 40,
                retries: 2,
                tokens: 5000,
                cost_usd: Some(0.25),
                wall_s: 1.5,
                missing: 3,
            },
        ] {
            r.event(&e);
        }
        let text = String::from_utf8(r.into_inner()).unwrap();
        insta::assert_snapshot!(text, @r#"
        {"event":"episode_finished","scenario":"contested_merge","tier":2,"seed":7,"rollout":1,"outcome":"collision","reward":-1.0,"turns":12,"tokens":900,"retries":2}
        {"event":"infra_error","scenario":"contested_merge","tier":2,"seed":7,"rollout":1,"turn":3,"error":"HTTP 503"}
        {"event":"stopped","reason":"outage","streak":8}
        {"event":"finished","status":"incomplete","stop":{"reason":"token_budget"},"episodes":4,"infra_errors":1,"turns":40,"retries":2,"tokens":5000,"cost_usd":0.25,"wall_s":1.5,"missing":3}
        "#);
    }

    #[test]
    fn the_progress_line_shows_the_spend_or_that_it_is_unknown() {
        let c = Counters::default();
        c.tokens.store(12_345, Relaxed);
        assert!(status(&c).ends_with("tokens 12.3k | cost unknown"), "{}", status(&c));
        c.priced.store(true, Relaxed);
        c.add_cost(0.0125);
        c.add_cost(0.0125);
        assert!(status(&c).ends_with("tokens 12.3k | cost $0.0250"), "{}", status(&c));
    }

    #[test]
    fn stop_reasons_keep_the_most_serious() {
        let outage = StopReason::Outage { streak: 8 };
        assert!(StopReason::TokenBudget.outranks(None));
        assert!(!StopReason::CostBudget.outranks(Some(StopReason::TokenBudget)), "the first budget reached stays");
        assert!(outage.outranks(Some(StopReason::CostBudget)));
        assert!(outage.outranks(Some(StopReason::TokenBudget)));
        assert!(!StopReason::TokenBudget.outranks(Some(outage)));
        assert!(!outage.outranks(Some(outage)));
        assert!(StopReason::Interrupted.outranks(Some(outage)));
        assert!(StopReason::Failed.outranks(Some(StopReason::Refused)));
    }
}
