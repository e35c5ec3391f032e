//! The truncation stop rule: a model that thinks inside its completion
//! limit and runs out of it writes no JSON answer; `eval` would execute that
//! turn as a firm stop, and a strong model would be ranked as a bad driver
//! because of the harness's limit. So when more than 2% of the turns of the
//! first 50 episodes end with `finish_reason: "length"`, the run stops and
//! names `--max-tokens` (unless `--allow-truncation`).

/// Episodes the rule watches (the first ones of the run; on a resume, the
/// episodes already stored count first).
pub const WINDOW_EPISODES: u64 = 50;
/// The share of truncated turns that stops a run.
pub const MAX_SHARE: f64 = 0.02;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Keep going (still watching, or the window passed the check).
    Continue,
    /// Too many turns were cut off.
    Stop { truncated: u64, turns: u64 },
}

/// Counts over the window.
#[derive(Debug, Clone)]
pub struct TruncationGuard {
    /// Episodes the window needs before its share is final: 50, or the
    /// whole selection when it is smaller.
    window: u64,
    /// The most truncated turns the window may hold under the rule, at its
    /// longest possible length (every episode using the whole turn budget).
    /// More than this already decides the rule before the window fills.
    ceiling: u64,
    episodes: u64,
    turns: u64,
    truncated: u64,
    decided: bool,
}

impl TruncationGuard {
    /// `selection`: episodes selected; `max_turns`: the longest turn budget.
    pub fn new(selection: u64, max_turns: u32) -> TruncationGuard {
        let window = WINDOW_EPISODES.min(selection).max(1);
        let ceiling = (MAX_SHARE * (window * u64::from(max_turns)) as f64).floor() as u64;
        TruncationGuard { window, ceiling, episodes: 0, turns: 0, truncated: 0, decided: false }
    }

    /// Count one finished episode; returns what to do.
    pub fn observe(&mut self, turns: u32, truncated: u32) -> Verdict {
        if self.decided {
            return Verdict::Continue;
        }
        self.episodes += 1;
        self.turns += u64::from(turns);
        self.truncated += u64::from(truncated);
        let over = self.truncated as f64 > MAX_SHARE * self.turns as f64;
        if self.truncated > self.ceiling || (self.episodes >= self.window && over) {
            self.decided = true;
            return Verdict::Stop { truncated: self.truncated, turns: self.turns };
        }
        if self.episodes >= self.window {
            self.decided = true;
        }
        Verdict::Continue
    }
}

/// The line that stops a run.
pub fn stop_message(truncated: u64, turns: u64, limit: Option<(&str, u64)>) -> String {
    let limit = match limit {
        Some((field, n)) => format!("{field} = {n}"),
        None => "the server's default".to_string(),
    };
    format!(
        "{truncated} of {turns} turns ({:.1}%) were cut off by the completion-token limit ({limit}) before the answer \
         (finish_reason \"length\"), more than {:.0}% of the first episodes: the model likely thinks inside the limit. \
         Raise it with --max-tokens N (reasoning models: 25000; see \"Models that think\" in docs/eval.md), \
         or pass --allow-truncation to score cut-off turns as they are",
        100.0 * truncated as f64 / turns.max(1) as f64,
        100.0 * MAX_SHARE
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_that_always_truncates_is_stopped_once_it_is_certain() {
        let mut g = TruncationGuard::new(1000, 40);
        // 2% of 50 episodes x 40 turns = 40 turns: the first 40 cannot decide.
        assert_eq!(g.observe(40, 40), Verdict::Continue);
        assert_eq!(g.observe(1, 1), Verdict::Stop { truncated: 41, turns: 41 });
        // Decided: no second stop.
        assert_eq!(g.observe(40, 40), Verdict::Continue);
    }

    #[test]
    fn the_share_is_judged_over_the_first_50_episodes() {
        let mut g = TruncationGuard::new(1000, 40);
        // 49 clean episodes of 20 turns, then one with 25 truncated turns:
        // 25 / 1000 = 2.5% > 2%.
        for _ in 0..49 {
            assert_eq!(g.observe(20, 0), Verdict::Continue);
        }
        assert_eq!(g.observe(20, 25), Verdict::Stop { truncated: 25, turns: 1000 });

        // 20 truncated of 1000 = 2.0% exactly is not more than 2%.
        let mut g = TruncationGuard::new(1000, 40);
        for _ in 0..49 {
            g.observe(20, 0);
        }
        assert_eq!(g.observe(20, 20), Verdict::Continue);
        // After the window, later truncation is counted but never stops.
        assert_eq!(g.observe(40, 40), Verdict::Continue);
    }

    #[test]
    fn a_small_selection_is_judged_at_its_end() {
        let mut g = TruncationGuard::new(3, 40);
        assert_eq!(g.observe(10, 1), Verdict::Continue);
        assert_eq!(g.observe(10, 0), Verdict::Continue);
        assert_eq!(g.observe(10, 0), Verdict::Stop { truncated: 1, turns: 30 });
    }

    #[test]
    fn the_message_names_the_flag_and_the_limit() {
        let m = stop_message(45, 90, Some(("max_completion_tokens", 500)));
        assert!(
            m.starts_with(
                "45 of 90 turns (50.0%) were cut off by the completion-token limit (max_completion_tokens = 500)"
            ),
            "{m}"
        );
        assert!(m.contains("--max-tokens N") && m.contains("--allow-truncation"), "{m}");
    }
}
