//! The way people hedge: a driver who does not yet know slows from the
//! first decision (gently, whatever the scene shows) until the evidence
//! could have come, reads the scene then, often a decision late, and often
//! shows its go by first holding speed before it speeds up. After the
//! hedge it drives by the expert's own rules, so its score against the
//! expert's is what that way of driving costs.
//!
//! The defensive readers are the same family with no hedge: the expert's
//! rules, watching every road user as the expert does, and confirming with
//! one more reading that a walker has stopped before passing it.

use super::{ExpertLate, GENTLE_YIELD, gentler, watched_move};
use crate::action::{Action, Maneuver};
use crate::observation::Observation;
use crate::policy::Policy;

/// The built-in hedging readers' braking level (m/s^2) and how long they
/// brake (s): about 1.5 m/s^2 until the latest delayed reveal could have
/// shown (a crosser that steps out late is moving by 2.5 s).
pub const HEDGE_BRAKE_MPS2: f64 = 1.5;
pub const HEDGE_SECONDS: f64 = 2.5;

/// A careful driver, described by what it does while it does not know and
/// how it reads once it may.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hedging {
    /// Brake at least this gently (m/s^2) from the first decision ...
    pub brake_mps2: f64,
    /// ... for this long (s), whatever the scene shows (0: no hedge).
    pub hedge_s: f64,
    /// Then read the other road users this many decisions late ...
    pub lag: usize,
    /// ... and show the first go by holding speed for one decision.
    pub soft_first_go: bool,
    /// After the hedge, brake gently whenever the rules would not yet go
    /// (as `expert_cautious` does).
    pub cautious: bool,
    /// Count a walker that is not the tier's question as stopped only once
    /// a second reading shows it still (the defensive readers).
    pub defensive: bool,
}

impl Hedging {
    /// Braking from the first decision, then the expert's rules on time.
    pub const fn on_time(brake_mps2: f64, hedge_s: f64) -> Hedging {
        Hedging { brake_mps2, hedge_s, lag: 0, soft_first_go: false, cautious: false, defensive: false }
    }

    /// The same, then the rules a decision late.
    pub const fn late(brake_mps2: f64, hedge_s: f64) -> Hedging {
        Hedging { lag: 1, ..Hedging::on_time(brake_mps2, hedge_s) }
    }

    /// The same, a decision late, the first go only holding speed.
    pub const fn late_soft(brake_mps2: f64, hedge_s: f64) -> Hedging {
        Hedging { soft_first_go: true, ..Hedging::late(brake_mps2, hedge_s) }
    }

    /// `expert_cautious` a decision late, its first go holding speed.
    pub const fn cautious_late_soft() -> Hedging {
        Hedging { brake_mps2: 0.0, hedge_s: 0.0, lag: 1, soft_first_go: true, cautious: true, defensive: false }
    }

    /// A defensive reader: no hedge, the rules `lag` decisions late (0 or
    /// more), confirming every walker's stop, its first go holding speed
    /// if `soft_first_go`.
    pub const fn defensive(lag: usize, soft_first_go: bool) -> Hedging {
        Hedging { brake_mps2: 0.0, hedge_s: 0.0, lag, soft_first_go, cautious: false, defensive: true }
    }

    /// The defensive readers `validate` holds to the bar: on time, a
    /// decision late, and a decision late with a first go that holds.
    pub const DEFENSIVE: [Hedging; 3] =
        [Hedging::defensive(0, false), Hedging::defensive(1, false), Hedging::defensive(1, true)];

    /// The `yield` that brakes at `brake_mps2` (yield spans 0.5-4.0 m/s^2).
    fn brake(&self) -> Action {
        Action::new(Maneuver::Yield, ((self.brake_mps2 - 0.5) / 3.5).clamp(0.0, 1.0))
    }

    pub fn build(self) -> HedgingReader {
        HedgingReader { how: self, late: ExpertLate::new(self.lag), went: false }
    }
}

/// A [`Hedging`] driver.
pub struct HedgingReader {
    how: Hedging,
    late: ExpertLate,
    /// Whether it has gone yet this episode (its first go may only hold).
    went: bool,
}

impl Policy for HedgingReader {
    fn reset(&mut self, policy_seed: u64) {
        self.late.reset(policy_seed);
        self.went = false;
    }

    fn remembers(&self) -> bool {
        true
    }

    fn act(&mut self, obs: &Observation) -> Action {
        if obs.turn <= 1 {
            self.went = false;
        }
        let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
        let m = watched_move(&self.late.late_view(obs), self.how.defensive);
        if obs.time_s + 1e-9 < self.how.hedge_s {
            // Nothing is known yet: slow, whatever the scene shows (and
            // brake harder where the rules do).
            return gentler(v, v_max, m.action, self.how.brake());
        }
        if m.go {
            let first = !self.went;
            self.went = true;
            return if first && self.how.soft_first_go {
                gentler(v, v_max, m.action, Action::hold())
            } else {
                m.action
            };
        }
        if self.how.cautious {
            gentler(v, v_max, m.action, Action::new(Maneuver::Yield, GENTLE_YIELD))
        } else {
            m.action
        }
    }
}

impl std::fmt::Display for Hedging {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let reads = match (self.lag, self.soft_first_go) {
            (0, _) => "on time".to_string(),
            (1, false) => "a decision late".to_string(),
            (1, true) => "a decision late, first go holding".to_string(),
            (n, soft) => format!("{n} decisions late{}", if soft { ", first go holding" } else { "" }),
        };
        if self.defensive {
            write!(f, "defensive, ")?;
        }
        if self.hedge_s > 0.0 {
            write!(f, "braking {:.1} m/s^2 for {:.1} s, then {reads}", self.brake_mps2, self.hedge_s)?;
        } else {
            write!(f, "reading {reads}")?;
        }
        if self.cautious { write!(f, ", braking gently while unsure") } else { Ok(()) }
    }
}

#[cfg(test)]
mod tests {
    use super::super::expert_move;
    use super::*;
    use crate::episode::{Episode, run_episode};
    use crate::scenario::{ScenarioKind, ScenarioSet, Tier};

    /// With no hedge, on time and no soft go, the hedging reader is the
    /// expert; with no hedge, a decision late, it is `expert_late`.
    #[test]
    fn without_a_hedge_it_is_the_expert_on_time_or_late() {
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..20 {
                    let config = set.get(kind);
                    let plain = run_episode(config, tier, seed, &mut Hedging::on_time(1.5, 0.0).build());
                    let expert = run_episode(config, tier, seed, &mut super::super::Expert);
                    assert_eq!(plain.decisions, expert.decisions, "{kind}/t{tier} seed {seed}");
                    let late = run_episode(config, tier, seed, &mut Hedging::late(1.5, 0.0).build());
                    let expert_late = run_episode(config, tier, seed, &mut ExpertLate::new(1));
                    assert_eq!(late.decisions, expert_late.decisions, "{kind}/t{tier} seed {seed}");
                }
            }
        }
    }

    /// Until the hedge ends it brakes at least at its level, whatever the
    /// scene shows; its first go only holds speed when it says so; and it
    /// plays a reused episode as a fresh one.
    #[test]
    fn it_brakes_until_the_hedge_ends_and_its_first_go_holds() {
        let set = ScenarioSet::default();
        let accel = |a: Action, v: f64, v_max: f64| a.control().acceleration(v, v_max, crate::sim::DT);
        let mut soft_goes = 0;
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..20 {
                    let how = Hedging::late_soft(1.2, 2.0);
                    let mut reader = how.build();
                    let mut episode = Episode::new(set.get(kind), tier, seed);
                    // The rules' move a decision late, as the reader sees it.
                    let mut rules = ExpertLate::new(1);
                    let mut first_go = true;
                    while !episode.is_done() {
                        let obs = *episode.observation();
                        let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
                        let go = expert_move(&rules.late_view(&obs)).go;
                        let action = reader.act(&obs);
                        if obs.time_s < how.hedge_s - 1e-9 {
                            if v > 1.5 {
                                assert!(accel(action, v, v_max) <= -1.2 + 1e-9, "{kind}/t{tier} seed {seed}");
                            }
                        } else if go && first_go {
                            first_go = false;
                            soft_goes += 1;
                            assert!(accel(action, v, v_max) <= 1e-9, "{kind}/t{tier} seed {seed}: {action:?}");
                        }
                        episode.step(action);
                    }
                    let reused = run_episode(set.get(kind), tier, seed, &mut reader);
                    let fresh = run_episode(set.get(kind), tier, seed, &mut how.build());
                    assert_eq!(reused.decisions, fresh.decisions, "{kind}/t{tier} seed {seed}");
                }
            }
        }
        assert!(soft_goes > 100, "{soft_goes} first goes");
    }

    /// Confirming a stop is about walkers: where no walker is watched (the
    /// intersection, the merge) the defensive readers are the expert and
    /// `expert_late` (at the crosswalk, `tests/it/core.rs` plants walkers
    /// that come on late).
    #[test]
    fn the_defensive_readers_confirm_only_walkers() {
        let set = ScenarioSet::default();
        for kind in [ScenarioKind::YieldStandoff, ScenarioKind::ContestedMerge] {
            for tier in Tier::ALL {
                for seed in 0..20 {
                    let config = set.get(kind);
                    let defensive = run_episode(config, tier, seed, &mut Hedging::defensive(0, false).build());
                    let expert = run_episode(config, tier, seed, &mut super::super::Expert);
                    assert_eq!(defensive.decisions, expert.decisions, "{kind}/t{tier} seed {seed}");
                    let late = run_episode(config, tier, seed, &mut Hedging::defensive(1, false).build());
                    let expert_late = run_episode(config, tier, seed, &mut ExpertLate::new(1));
                    assert_eq!(late.decisions, expert_late.decisions, "{kind}/t{tier} seed {seed}");
                }
            }
        }
    }
}
