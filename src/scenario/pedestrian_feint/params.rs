//! The crosswalk's parameters, as `scenarios/pedestrian_feint.toml` sets
//! them: their fields, their ranges and the world they build.

use super::*;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedestrianParams {
    pub episode: Common,
    pub ego: PedEgo,
    pub pedestrian: PedBehaviour,
    pub tier1: PedTier1,
    pub tier2: PedTier2,
    pub tier3: PedTier3,
    pub companions: PedCompanions,
}

/// The two companions: pedestrians who walk up the sidewalk to the same
/// kerb, the same in both worlds, and cross only with one they saw take
/// its turn (people at a kerb follow a neighbour who starts to cross, and
/// a group walks abreast at one pace).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedCompanions {
    /// Their walking pace up the sidewalk (m/s).
    pub walk_speed_mps: Range,
    /// The first comes to rest at the kerb this long (s) after the start,
    /// slowing from its walk at `pedestrian.stop_decel_mps2` before ...
    pub arrive_s: Range,
    /// ... and the second this much later (s).
    pub spacing_s: Range,
    /// Each sets out this long (s) after the pedestrian it follows, and
    /// walks beside it at its pace ...
    pub follow_delay_s: Range,
    /// ... if it reached the kerb no later than this (s) after the
    /// pedestrian took its turn, and only while the car can still stop.
    pub joined_within_s: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedEgo {
    /// Front bumper to the crossing line at t = 0 (m).
    pub start_distance_m: Range,
    pub start_speed_mps: Range,
    /// Goal: the ego's centre this far past the crossing line (m).
    pub goal_past_crosswalk_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedBehaviour {
    /// Walking speed of both dispositions until the reveal (m/s).
    pub walk_speed_mps: Range,
    /// Where the pedestrian stands when it waits at the kerb (lateral, m).
    pub kerb_stop_m: f64,
    /// A feinter taking its turn pulls away from rest this gently (m/s^2).
    pub give_up_accel_mps2: f64,
    /// Every walker slows to a stop at most this sharply (m/s^2): people
    /// end their walk over a step or more, never within a tenth of a second.
    pub stop_decel_mps2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier1 {
    /// A waiting pedestrian's critical gap (s), drawn per seed: a car due
    /// later than this at its current motion leaves it a gap to take.
    pub critical_gap_s: Range,
    /// A feinter stands at the kerb at least this long (s), from the moment
    /// it decides, before it steps in ...
    pub look_s: Range,
    /// ... and then walks across at this pace (m/s), its group beside it.
    pub give_up_speed_mps: Range,
    /// The pedestrian reaches the kerb this long (s) before a full-throttle
    /// ego would reach the crossing line.
    pub kerb_lead_s: Range,
    /// A gap must stay open this long (s, without a break) before a
    /// waiting feinter takes it.
    pub patience_s: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier2 {
    /// Both wait at the kerb; the crosser steps out this long (s) after the
    /// start, whatever the car does (it is not watching the car).
    pub step_at_s: Range,
    pub step_out_speed_mps: Range,
    /// A waiting pedestrian's critical gap (s), drawn per seed: a car due
    /// later than this at its current motion leaves it a gap to take.
    pub critical_gap_s: Range,
    /// A feinter stands at the kerb at least this long (s), from the moment
    /// it decides (when a crosser would step out), before it steps in ...
    pub look_s: Range,
    /// ... and then walks across at this pace (m/s), its group beside it.
    pub give_up_speed_mps: Range,
    /// A gap must stay open this long (s, without a break) before a
    /// waiting feinter takes it.
    pub patience_s: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier3 {
    /// A waiting pedestrian's critical gap (s), drawn per seed: a car due
    /// later than this at its current motion leaves it a gap to take.
    pub critical_gap_s: Range,
    /// A feinter stands at the kerb at least this long (s), from the moment
    /// it decides, before it steps in ...
    pub look_s: Range,
    /// ... and then walks across at this pace (m/s), its group beside it.
    pub give_up_speed_mps: Range,
    /// Both reach the feinter's stop this long (s) before a full-throttle
    /// arrival; the feinter stops there, the crosser walks on to ...
    pub kerb_lead_s: Range,
    /// ... the kerb's edge, where it stops too (lateral, m): a step nearer
    /// the road than a pedestrian who waits for cars.
    pub crosser_stop_m: f64,
    /// The crosser darts after lingering this long (s) at the kerb ...
    pub linger_s: Range,
    /// ... or as soon as a moving, not-stopping ego is due at the crossing
    /// line within this (s), after a reaction time.
    pub dart_horizon_s: Range,
    pub dart_reaction_s: f64,
    pub dart_speed_mps: f64,
    /// Invited, it walks across at this pace (m/s).
    pub invited_speed_mps: f64,
    /// A crosser at the edge takes its turn once the car, still short of
    /// the line, has left it a gap (as a waiting pedestrian judges it) for
    /// this long (s): a car that slows for it invites it.
    pub invite_s: Range,
    /// A gap must stay open this long (s, without a break) before a
    /// waiting feinter takes it.
    pub patience_s: Range,
}

impl crate::scenario::ScenarioParams for PedestrianParams {
    fn common(&self) -> &Common {
        &self.episode
    }

    fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        _noise: EpisodeRng,
    ) -> Box<dyn World + Send> {
        Box::new(PedestrianWorld::new(self, tier, disposition, geometry))
    }

    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.5, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_crosswalk_m", self.ego.goal_past_crosswalk_m, X_HALF, 200.0)?;
        let b = &self.pedestrian;
        c.range_within("pedestrian.walk_speed_mps", b.walk_speed_mps, 0.3, 3.0)?;
        c.within("pedestrian.kerb_stop_m", b.kerb_stop_m, -2.0, 0.0)?;
        c.within("pedestrian.give_up_accel_mps2", b.give_up_accel_mps2, 0.1, PED_ACCEL)?;
        c.within("pedestrian.stop_decel_mps2", b.stop_decel_mps2, 0.3, 20.0)?;
        c.range_within("tier1.kerb_lead_s", self.tier1.kerb_lead_s, 0.0, 10.0)?;
        for (tier, look, give_up) in [
            ("tier1", self.tier1.look_s, self.tier1.give_up_speed_mps),
            ("tier2", self.tier2.look_s, self.tier2.give_up_speed_mps),
            ("tier3", self.tier3.look_s, self.tier3.give_up_speed_mps),
        ] {
            c.range_within(&format!("{tier}.look_s"), look, 0.0, 10.0)?;
            c.range_within(&format!("{tier}.give_up_speed_mps"), give_up, 0.3, 3.0)?;
        }
        c.range_within("tier1.critical_gap_s", self.tier1.critical_gap_s, 0.5, 10.0)?;
        c.range_within("tier2.critical_gap_s", self.tier2.critical_gap_s, 0.5, 10.0)?;
        c.range_within("tier3.critical_gap_s", self.tier3.critical_gap_s, 0.5, 10.0)?;
        c.range_within("tier1.patience_s", self.tier1.patience_s, 0.0, 20.0)?;
        c.range_within("tier2.step_at_s", self.tier2.step_at_s, 0.0, 20.0)?;
        c.range_within("tier2.step_out_speed_mps", self.tier2.step_out_speed_mps, 0.3, 4.0)?;
        c.range_within("tier2.patience_s", self.tier2.patience_s, 0.0, 20.0)?;
        c.range_within("tier3.kerb_lead_s", self.tier3.kerb_lead_s, 0.0, 10.0)?;
        c.within("tier3.crosser_stop_m", self.tier3.crosser_stop_m, b.kerb_stop_m, 0.0)?;
        c.range_within("tier3.invite_s", self.tier3.invite_s, 0.0, 5.0)?;
        c.range_within("tier3.linger_s", self.tier3.linger_s, 0.0, 30.0)?;
        c.range_within("tier3.dart_horizon_s", self.tier3.dart_horizon_s, 0.0, 5.0)?;
        c.within("tier3.dart_reaction_s", self.tier3.dart_reaction_s, 0.0, 2.0)?;
        c.within("tier3.dart_speed_mps", self.tier3.dart_speed_mps, 0.5, 5.0)?;
        c.within("tier3.invited_speed_mps", self.tier3.invited_speed_mps, 0.5, 5.0)?;
        c.range_within("tier3.patience_s", self.tier3.patience_s, 0.0, 20.0)?;
        let k = &self.companions;
        c.range_within("companions.walk_speed_mps", k.walk_speed_mps, 0.3, 3.0)?;
        c.range_within("companions.arrive_s", k.arrive_s, 0.0, 20.0)?;
        c.range_within("companions.spacing_s", k.spacing_s, 0.0, 10.0)?;
        c.range_within("companions.follow_delay_s", k.follow_delay_s, 0.0, 10.0)?;
        c.within("companions.joined_within_s", k.joined_within_s, 0.0, 20.0)
    }
}

/// The typical figures of the crosswalk's pedestrian, as the public rules
/// read them (the scenario file in the binary, middles of ranges).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Typical {
    /// Where a pedestrian waiting for cars stands (lateral from the near
    /// kerb, m).
    pub kerb_stop_m: f64,
    /// A crosser at the kerb on tier 2 steps out at this time (s), at this
    /// pace (m/s).
    pub step_out_at_s: f64,
    pub step_out_speed_mps: f64,
    /// A crosser at the edge darts at this pace (m/s), once the car at its
    /// current speed is due at the line within this (s).
    pub dart_speed_mps: f64,
    pub dart_horizon_s: f64,
}

impl Typical {
    pub fn of(p: &PedestrianParams) -> Typical {
        Typical {
            kerb_stop_m: p.pedestrian.kerb_stop_m,
            step_out_at_s: p.tier2.step_at_s.mid(),
            step_out_speed_mps: p.tier2.step_out_speed_mps.mid(),
            dart_speed_mps: p.tier3.dart_speed_mps,
            dart_horizon_s: p.tier3.dart_horizon_s.mid(),
        }
    }
}

/// The built-in file's [`Typical`] figures.
pub fn typical() -> &'static Typical {
    static TYPICAL: std::sync::LazyLock<Typical> =
        std::sync::LazyLock::new(|| Typical::of(&crate::scenario::def::builtin_params::<PedestrianParams>(&DEF)));
    &TYPICAL
}
