//! Progress display: an indicatif bar on a terminal, a plain line every few
//! seconds otherwise (logs, CI), nothing with `--quiet`. Everything goes to
//! stderr; stdout carries only the leaderboard.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

/// Counters shared by the episode tasks and the display.
#[derive(Debug, Default)]
pub struct Counters {
    pub done: AtomicU64,
    pub success: AtomicU64,
    pub infra_errors: AtomicU64,
    pub retries: AtomicU64,
    pub tokens: AtomicU64,
    pub turns: AtomicU64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Bar,
    Lines,
    Quiet,
}

impl Mode {
    pub fn detect(quiet: bool) -> Mode {
        if quiet {
            Mode::Quiet
        } else if std::io::stderr().is_terminal() {
            Mode::Bar
        } else {
            Mode::Lines
        }
    }
}

pub struct Progress {
    stop: tokio::sync::watch::Sender<bool>,
    task: Option<tokio::task::JoinHandle<()>>,
    bar: Option<ProgressBar>,
}

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
    format!(
        "success {rate} | infra errors {} | retries {} | tokens {}",
        c.infra_errors.load(Relaxed),
        c.retries.load(Relaxed),
        human(c.tokens.load(Relaxed))
    )
}

impl Progress {
    /// Start displaying progress towards `total` episodes.
    pub fn start(mode: Mode, total: u64, counters: Arc<Counters>, interval: Duration) -> Progress {
        let (stop, mut stopped) = tokio::sync::watch::channel(false);
        let bar = (mode == Mode::Bar).then(|| {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} episodes | {msg} | ETA {eta}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar
        });
        let task = match mode {
            Mode::Quiet => None,
            Mode::Bar => {
                let bar = bar.clone().expect("bar mode has a bar");
                Some(tokio::spawn(async move {
                    let mut tick = tokio::time::interval(Duration::from_millis(200));
                    loop {
                        bar.set_position(counters.done.load(Relaxed));
                        bar.set_message(status(&counters));
                        tokio::select! {
                            _ = tick.tick() => {}
                            _ = stopped.changed() => break,
                        }
                    }
                    bar.set_position(counters.done.load(Relaxed));
                    bar.set_message(status(&counters));
                }))
            }
            Mode::Lines => Some(tokio::spawn(async move {
                let started = Instant::now();
                let mut tick = tokio::time::interval(interval);
                tick.tick().await;
                loop {
                    tokio::select! {
                        _ = tick.tick() => {}
                        _ = stopped.changed() => break,
                    }
                    let done = counters.done.load(Relaxed);
                    let elapsed = started.elapsed().as_secs_f64();
                    let eta = if done == 0 {
                        "-".to_string()
                    } else {
                        format!("{:.0}s", elapsed / done as f64 * total.saturating_sub(done) as f64)
                    };
                    eprintln!("[{elapsed:.0}s] {done}/{total} episodes | {} | ETA {eta}", status(&counters));
                }
            })),
        };
        Progress { stop, task, bar }
    }

    /// Stop the display (the bar is cleared; the summary follows).
    pub async fn finish(mut self) {
        let _ = self.stop.send(true);
        if let Some(t) = self.task.take() {
            let _ = t.await;
        }
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}
