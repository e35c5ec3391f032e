use negotiator::baselines::*;
use negotiator::policy::PolicyKind;
use negotiator::scenario::*;
fn main() {
    let n: usize = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(200);
    let set = ScenarioSet::default();
    let spec = GridSpec { scenarios: ScenarioKind::ALL.to_vec(), tiers: Tier::ALL.to_vec(), policies: PolicyKind::ALL.to_vec(), episodes: n, seed_base: 0 };
    let t = std::time::Instant::now();
    let cells = run_grid(&set, &spec, &|_, _| {});
    eprintln!("{:?}", t.elapsed());
    for c in cells {
        println!("{:17} {} {:15} succ {:.2} coll {:.2} tout {:.2} rew {:+.2} dc {:.2}", c.cell.scenario.name(), c.cell.tier, c.cell.policy.name(), c.success.estimate, c.collision.estimate, c.timeout.estimate, c.reward.estimate, c.decision_correctness.estimate);
    }
}
