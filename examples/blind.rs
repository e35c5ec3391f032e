//! Development aid: the blind-policy search and the expert on chosen cells.
//! `cargo run --release --example blind -- [scenario] [tier] [budget]`
//! `SCENARIO_OVERRIDE=file.toml` plays an edited scenario file instead of the
//! built-in one; `FULL=1` prints the plans found in full; `SEARCH_SEED=n`
//! reseeds the search (default 1); `BREAKDOWN=1` prints the best plan's
//! held-out success under each disposition.
use negotiator::adversary::{SearchSpec, TRAIN_SEED_BASE, evaluate, search};
use negotiator::baselines::Cell;
use negotiator::baselines::run_cell;
use negotiator::episode::Outcome;
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let set = match std::env::var("SCENARIO_OVERRIDE") {
        Ok(p) => ScenarioSet::with_overrides(&[p.into()]).unwrap(),
        Err(_) => ScenarioSet::default(),
    };
    let scenarios: Vec<ScenarioKind> = match args.first().map(String::as_str) {
        Some("all") | None => ScenarioKind::ALL.to_vec(),
        Some(s) => vec![s.parse().unwrap()],
    };
    let tiers: Vec<Tier> = match args.get(1).map(String::as_str) {
        Some("all") | None => Tier::ALL.to_vec(),
        Some(t) => vec![t.parse().unwrap()],
    };
    let budget: usize = args.get(2).map_or(negotiator::adversary::DEFAULT_BUDGET, |b| b.parse().unwrap());
    let held: Vec<u64> = (0..400).collect();
    let search_seed: u64 = std::env::var("SEARCH_SEED").map_or(1, |s| s.parse().unwrap());
    for &s in &scenarios {
        for &t in &tiers {
            let config = set.get(s);
            let start = std::time::Instant::now();
            let f = search(config, t, SearchSpec { budget, train_seed_base: TRAIN_SEED_BASE, search_seed });
            let held_score = evaluate(config, t, &f.best, &held);
            let held_c = evaluate(config, t, &f.best_correctness, &held);
            if std::env::var("BREAKDOWN").is_ok() {
                // The best plan's success under each disposition.
                let mut by: std::collections::BTreeMap<String, (usize, usize)> = Default::default();
                for &seed in &held {
                    let d = negotiator::episode::draw_disposition(negotiator::episode::EpisodeSpec {
                        scenario: s,
                        tier: t,
                        seed,
                    });
                    let e = by.entry(format!("{d:?}")).or_default();
                    e.0 += (evaluate(config, t, &f.best, &[seed]).success > 0.5) as usize;
                    e.1 += 1;
                }
                eprintln!("    best by disposition: {by:?}");
            }
            let stats = |p: PolicyKind| {
                let recs = run_cell(&set, Cell { scenario: s, tier: t, policy: p }, 400, 0);
                let n = recs.len() as f64;
                let succ = recs.iter().filter(|r| r.outcome == Outcome::Success).count() as f64 / n;
                let dc = recs.iter().map(|r| r.grades.decision_correctness).sum::<f64>() / n;
                let rw = recs.iter().map(|r| r.grades.reward).sum::<f64>() / n;
                let guess = recs.iter().filter(|r| r.timing.guessed() == Some(true)).count() as f64 / n;
                let mut turns: Vec<u32> =
                    recs.iter().filter(|r| r.outcome == Outcome::Success).map(|r| r.decisions.len() as u32).collect();
                turns.sort();
                let q = |f: f64| turns.get(((turns.len() as f64 - 1.0) * f) as usize).copied().unwrap_or(0);
                eprintln!("    {p}: success turns p50 {} p95 {} p99 {} max {}", q(0.5), q(0.95), q(0.99), q(1.0));
                (succ, dc, rw, guess)
            };
            let e = stats(PolicyKind::Expert);
            let c = stats(PolicyKind::CueFollower);
            println!(
                "{s}/t{t} (budget {} turns): expert succ {:.3} dc {:.3} rw {:.3} guess {:.3} | cue {:.3} | blind held succ {:.3} rw {:.3} (train {:.3}) margin {:+.3} | best-dc {:.3} | {} eps {:.1}s\n    best: {}\n    best-dc: {}",
                config.common().turn_budget.get(t),
                e.0,
                e.1,
                e.2,
                e.3,
                c.0,
                held_score.success,
                held_score.reward,
                f.train.success,
                e.0 - held_score.success,
                held_c.correctness,
                f.episodes,
                start.elapsed().as_secs_f64(),
                short(&f.best.to_string()),
                short(&f.best_correctness.to_string())
            );
        }
    }
}

fn short(s: &str) -> String {
    if s.len() > 200 && std::env::var("FULL").is_err() { format!("{}...", &s[..200]) } else { s.to_string() }
}
