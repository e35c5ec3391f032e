//! Development aid: careful drivers beyond the hedging line's sweep on the
//! intersection (braking 0.6-2.5 m/s^2 for 1-5 s, then reading on time, one
//! or two decisions late, softly or not), seeds 90,000-90,199; prints each
//! that falls below a caution bar, marked `in` (inside the line's ranges:
//! up to 1.6 m/s^2, the evidence plus a decision, one decision late), `two`
//! (the same, two decisions late) or `out`.
//! `cargo run --release --example hedge_probe`
use negotiator::episode::{Outcome, run_episode};
use negotiator::policy::Hedging;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use negotiator::validate::{CAUTIOUS_COLLISION, CAUTIOUS_SUCCESS};

fn main() {
    let set = ScenarioSet::default();
    let config = set.get(ScenarioKind::YieldStandoff);
    let ways = [(0, false, false), (1, false, false), (1, true, false), (2, false, false), (2, true, false)];
    for tier in Tier::ALL {
        // The line's longest hedge: the tier's evidence time plus a decision.
        let longest = if tier == Tier::T2 { 4.0 } else { 3.5 };
        for brake_mps2 in [0.6, 0.8, 1.0, 1.3, 1.6, 2.0, 2.5] {
            for hedge_s in [1.0, 2.0, 3.0, 3.5, 4.0, 4.5, 5.0] {
                for (lag, soft_first_go, cautious) in ways {
                    let how = Hedging { brake_mps2, hedge_s, lag, soft_first_go, cautious, defensive: false };
                    let (mut success, mut collision) = (0u32, 0u32);
                    for seed in 90_000..90_200 {
                        match run_episode(config, tier, seed, &mut how.build()).outcome {
                            Outcome::Success => success += 1,
                            Outcome::Collision => collision += 1,
                            Outcome::Timeout => {}
                        }
                    }
                    let (success, collision) = (f64::from(success) / 200.0, f64::from(collision) / 200.0);
                    let inside = brake_mps2 <= 1.6 && hedge_s <= longest;
                    let class = match (inside, lag) {
                        (true, 0 | 1) => "in",
                        (true, _) => "two",
                        _ => "out",
                    };
                    if success < CAUTIOUS_SUCCESS || collision > CAUTIOUS_COLLISION {
                        println!("{class} {tier:?} {how}: {success:.2}/{collision:.2}");
                    }
                }
            }
        }
    }
}
