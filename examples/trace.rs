//! Development aid: one episode, turn by turn.
//! `cargo run --release --example trace -- <scenario> <tier> <policy|schedule> <seed> [disposition]`,
//! a schedule written `maneuver:strength:turns,...` (the last entry repeats);
//! `SCENARIO_OVERRIDE=file.toml` plays an edited scenario file; `LAG=n` plays
//! the expert reading the other road users n decisions late; `HEDGE=brake,seconds,lag,soft[,cautious[,defensive]]`
//! a hedging reader (`HEDGE=0,0,1,1,0,1`: the defensive reader a decision late, first go holding).
use negotiator::episode::*;
use negotiator::policy::PolicyKind;
use negotiator::scenario::*;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let kind: ScenarioKind = a[1].parse().unwrap();
    let tier: Tier = a[2].parse().unwrap();
    // A policy name, or a blind schedule "proceed:0.5:3,yield:0:2,stop:1" (the last repeats).
    let schedule: Option<Vec<negotiator::action::Action>> = a[3].contains(':').then(|| {
        a[3].split(',')
            .flat_map(|part| {
                let f: Vec<&str> = part.split(':').collect();
                let m = negotiator::action::Maneuver::from_loose(f[0]).unwrap();
                let n: usize = f.get(2).map_or(1, |x| x.parse().unwrap());
                std::iter::repeat_n(negotiator::action::Action::new(m, f[1].parse().unwrap()), n)
            })
            .collect()
    });
    let policy: PolicyKind = if schedule.is_some() { PolicyKind::Expert } else { a[3].parse().unwrap() };
    let seed: u64 = a[4].parse().unwrap();
    let set = match std::env::var("SCENARIO_OVERRIDE") {
        Ok(p) => ScenarioSet::with_overrides(&[p.into()]).unwrap(),
        Err(_) => ScenarioSet::default(),
    };
    let mut ep = match a.get(5) {
        Some(d) => {
            Episode::with_disposition(set.get(kind), tier, seed, serde_json::from_str(&format!("\"{d}\"")).unwrap())
        }
        None => Episode::new(set.get(kind), tier, seed),
    };
    let mut p: Box<dyn negotiator::policy::Policy> = match (std::env::var("LAG"), std::env::var("HEDGE")) {
        (Ok(l), _) => Box::new(negotiator::policy::ExpertLate::new(l.parse().unwrap())),
        // HEDGE=brake,seconds,lag,soft[,cautious[,defensive]]: a `Hedging` reader, fields in that order.
        (_, Ok(h)) => {
            let f: Vec<f64> = h.split(',').map(|x| x.parse().unwrap()).collect();
            let mut how = negotiator::policy::Hedging::on_time(f[0], f[1]);
            how.lag = f[2] as usize;
            how.soft_first_go = f[3] > 0.0;
            how.cautious = f.get(4).is_some_and(|c| *c > 0.0);
            how.defensive = f.get(5).is_some_and(|c| *c > 0.0);
            Box::new(how.build())
        }
        _ => policy.build(),
    };
    p.reset(policy_seed(ep.spec()));
    println!("disposition {}", ep.disposition());
    while !ep.is_done() {
        let o = *ep.observation();
        let act = match &schedule {
            Some(s) => s[(o.turn as usize - 1).min(s.len() - 1)],
            None => p.act(&o),
        };
        let ed = o.ego_to_conflict_m();
        let others: Vec<String> =
            o.scene.tracks().iter().map(|t| format!("{:6.2} {:5.2}", t.now.position_m, t.now.velocity_mps)).collect();
        let others = others.join(" | ");
        println!(
            "t {:4.1} ego d {:6.1} v {:5.1} | {} | {} {:+.2} rev {}",
            o.time_s,
            ed,
            o.ego.speed_mps,
            others,
            act.maneuver,
            act.acceleration,
            ep.revealed()
        );
        ep.step(act);
    }
    let r = ep.finish();
    println!("{:?} reward {:.2} dc {:.2} {:?}", r.outcome, r.grades.reward, r.grades.decision_correctness, r.timing);
}
