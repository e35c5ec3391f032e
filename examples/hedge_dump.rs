//! Development aid: every way of driving the hedging line tries that falls
//! below a caution bar, per cell.
//! `cargo run --release --example hedge_dump -- [scenario|all]`;
//! `SCENARIO_OVERRIDE=file.toml` plays an edited scenario file, `SEED0=n`
//! plays seeds n..n+200 instead of `validate`'s 0..200.
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let set = match std::env::var("SCENARIO_OVERRIDE") {
        Ok(p) => ScenarioSet::with_overrides(&[p.into()]).unwrap(),
        Err(_) => ScenarioSet::default(),
    };
    let scen: Vec<ScenarioKind> = match args.get(1).map(String::as_str) {
        Some("all") | None => ScenarioKind::ALL.to_vec(),
        Some(s) => vec![s.parse().expect("scenario")],
    };
    let start: u64 = std::env::var("SEED0").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
    let cells = negotiator::validate::hedging_readers(&set, &scen, &Tier::ALL, start..start + 200);
    for c in &cells {
        if c.success < negotiator::validate::CAUTIOUS_SUCCESS || c.collision > negotiator::validate::CAUTIOUS_COLLISION
        {
            println!("{:?}/{:?} {:.2}/{:.2} {}", c.scenario, c.tier, c.success, c.collision, c.driver);
        }
    }
}
