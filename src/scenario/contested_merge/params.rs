//! The merge's parameters, as `scenarios/contested_merge.toml` sets them:
//! their fields, their ranges and the world they build.

use super::*;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeParams {
    pub episode: Common,
    pub ego: MergeEgo,
    pub road: MergeRoad,
    pub lane: MergeLane,
    pub idm: Idm,
    pub tier2: MergeTier2,
    pub tier3: MergeTier3,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeEgo {
    /// Ego centre to the merge point at t = 0 (m).
    pub start_distance_m: Range,
    pub start_speed_mps: Range,
    /// Goal: this far past the end of the ramp (m).
    pub goal_past_ramp_end_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeRoad {
    /// Length over which the ramp tapers into the lane (m).
    pub taper_length_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeLane {
    /// The through lane's own speed limit (m/s), which the scene states:
    /// the lane cars keep to it, and it is the ego's once the ego is in the
    /// lane (on the ramp the ego keeps the episode's limit).
    pub speed_limit_mps: f64,
    pub cruise_speed_mps: Range,
    /// Lane car's centre relative to the ego's at t = 0 (m): it starts alongside.
    pub alongside_offset_m: Range,
    /// Follower's centre behind the lane car's centre at t = 0 (m).
    pub follower_gap_m: Range,
    /// The follower's desired time headway (s) and standstill gap (m): it
    /// closes up behind a lane car that slows down.
    pub follower_headway_s: f64,
    pub follower_min_gap_m: f64,
    /// How much faster than its cruise a car holding the lane drives to
    /// keep an ego that is alongside from cutting in ahead of it (m/s).
    pub deny_extra_mps: f64,
    /// ... and how hard it accelerates to do so (m/s^2).
    pub deny_accel_mps2: f64,
    /// Bumper gap a car making room opens ahead of itself (m).
    pub open_gap_m: f64,
    /// Deceleration with which a car opens a gap for the ego (m/s^2).
    pub open_decel_mps2: f64,
    /// A car making room keeps it open while the ego keeps pace (drives on
    /// and is due at the merge point within this of the lane car's own
    /// arrival at cruise speed) (s).
    pub pace_tolerance_s: f64,
    /// Once the ego has hung back this long in all, a car making room
    /// gives up and takes its turn (s), drawn per episode ...
    pub patience_s: Range,
    /// ... counted only from this long after its easing off was on show
    /// (s, drawn per episode): it judges what the ego does once it could
    /// have seen the gap and answered, not what it did before.
    pub look_s: Range,
    /// An ego braking harder than this (m/s^2) ...
    pub late_brake_mps2: f64,
    /// ... this close to the merge point (m) hangs back at once.
    pub late_brake_within_m: f64,
    /// A car taking its turn passes an ego on the ramp this much faster
    /// than the ego goes (m/s) ...
    pub pass_margin_mps: f64,
    /// ... and no slower than this (m/s).
    pub pass_speed_mps: f64,
    /// Once past, it pulls back up to its cruise speed this gently (m/s^2).
    pub resume_accel_mps2: f64,
    /// While an ego on the ramp is beside the gap between the lane car and
    /// its follower, the follower closes up to this bumper gap (m).
    pub door_gap_m: f64,
    /// ... accelerating at most this hard to do so (m/s^2).
    pub door_accel_mps2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeTier2 {
    /// Standard deviation of the noise on observed lane-car positions (m).
    pub position_noise_m: f64,
    /// Standard deviation of the noise on observed lane-car speeds (m/s).
    pub speed_noise_mps: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeTier3 {
    /// Both dispositions open the gap like a car making room, down to this
    /// fraction of the cruise speed; only a car making room slows further.
    pub floor_fraction: f64,
    /// A bluffer holds the floor this long, then takes its turn (s).
    pub hold_s: f64,
    /// The ego takes the bait when it drives on while due at the merge
    /// point within this (s): the bluffer closes the gap.
    pub commit_horizon_s: f64,
    /// The bluffer closes the gap this hard (m/s^2).
    pub close_accel_mps2: f64,
    /// Both dispositions open the gap this gently (m/s^2).
    pub open_decel_mps2: f64,
}

impl crate::scenario::ScenarioParams for MergeParams {
    fn common(&self) -> &Common {
        &self.episode
    }

    fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        noise: EpisodeRng,
    ) -> Box<dyn World + Send> {
        Box::new(MergeWorld::new(self, tier, disposition, geometry, noise))
    }

    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.0, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_ramp_end_m", self.ego.goal_past_ramp_end_m, 0.0, 200.0)?;
        c.within("road.taper_length_m", self.road.taper_length_m, 5.0, 100.0)?;
        let lane = &self.lane;
        c.within("lane.speed_limit_mps", lane.speed_limit_mps, self.episode.speed_limit_mps, 30.0)?;
        c.range_within("lane.cruise_speed_mps", lane.cruise_speed_mps, 1.0, lane.speed_limit_mps)?;
        c.range_within("lane.alongside_offset_m", lane.alongside_offset_m, -20.0, 20.0)?;
        c.range_within("lane.follower_gap_m", lane.follower_gap_m, CAR_LENGTH + 1.0, 200.0)?;
        c.within("lane.follower_headway_s", lane.follower_headway_s, 0.1, 5.0)?;
        c.within("lane.follower_min_gap_m", lane.follower_min_gap_m, 0.0, 20.0)?;
        c.within("lane.deny_extra_mps", lane.deny_extra_mps, 0.0, 10.0)?;
        c.within("lane.deny_accel_mps2", lane.deny_accel_mps2, 0.3, 6.0)?;
        c.within("lane.open_gap_m", lane.open_gap_m, 0.0, 50.0)?;
        c.within("lane.open_decel_mps2", lane.open_decel_mps2, 0.3, 6.0)?;
        c.within("lane.pace_tolerance_s", lane.pace_tolerance_s, 0.0, 10.0)?;
        c.range_within("lane.patience_s", lane.patience_s, 0.0, 30.0)?;
        c.range_within("lane.look_s", lane.look_s, 0.0, 10.0)?;
        c.within("lane.late_brake_mps2", lane.late_brake_mps2, 0.5, 8.0)?;
        c.within("lane.late_brake_within_m", lane.late_brake_within_m, 0.0, 100.0)?;
        c.within("lane.pass_margin_mps", lane.pass_margin_mps, 0.1, 10.0)?;
        c.within("lane.pass_speed_mps", lane.pass_speed_mps, 0.5, 15.0)?;
        c.within("lane.resume_accel_mps2", lane.resume_accel_mps2, 0.3, 5.0)?;
        c.within("lane.door_gap_m", lane.door_gap_m, 0.0, 50.0)?;
        c.within("lane.door_accel_mps2", lane.door_accel_mps2, 0.3, 6.0)?;
        c.within("idm.accel", self.idm.accel, 0.3, 5.0)?;
        c.within("idm.brake", self.idm.brake, 0.5, 8.0)?;
        c.within("idm.headway", self.idm.headway, 0.1, 5.0)?;
        c.within("idm.min_gap", self.idm.min_gap, 0.0, 20.0)?;
        c.within("idm.max_brake", self.idm.max_brake, self.idm.brake, 12.0)?;
        c.within("tier2.position_noise_m", self.tier2.position_noise_m, 0.0, 10.0)?;
        c.within("tier2.speed_noise_mps", self.tier2.speed_noise_mps, 0.0, 5.0)?;
        c.within("tier3.floor_fraction", self.tier3.floor_fraction, 0.0, 1.0)?;
        c.within("tier3.hold_s", self.tier3.hold_s, 0.0, 60.0)?;
        c.within("tier3.commit_horizon_s", self.tier3.commit_horizon_s, 0.1, 5.0)?;
        c.within("tier3.close_accel_mps2", self.tier3.close_accel_mps2, 0.5, 6.0)?;
        c.within("tier3.open_decel_mps2", self.tier3.open_decel_mps2, 0.3, 6.0)
    }
}

impl MergeParams {
    /// Ego centre x at which its body starts to overlap the lane.
    pub fn merge_point(&self) -> f64 {
        self.road.taper_length_m * (1.0 - CAR_WIDTH / LANE_OFFSET)
    }
}

/// The typical figures of the merge's lane cars, as the public rules read
/// them (the scenario file in the binary).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Typical {
    /// A car making room slows at most this hard (m/s^2) to this bumper
    /// gap behind the ego (m), and picks up speed at lane traffic's
    /// comfortable rate (m/s^2).
    pub open_decel_mps2: f64,
    pub open_gap_m: f64,
    pub pick_up_mps2: f64,
    /// A car covering an ego that hangs back brakes up to this (m/s^2).
    pub max_brake_mps2: f64,
    /// A car holding the lane draws level with a faster ego at this rate
    /// (m/s^2), at most this much above its speed (m/s).
    pub deny_accel_mps2: f64,
    pub deny_extra_mps: f64,
    /// The noisy tier's speed noise (m/s, one standard deviation).
    pub speed_noise_mps: f64,
}

impl Typical {
    pub fn of(p: &MergeParams) -> Typical {
        Typical {
            open_decel_mps2: p.lane.open_decel_mps2,
            open_gap_m: p.lane.open_gap_m,
            pick_up_mps2: p.idm.accel,
            max_brake_mps2: p.idm.max_brake,
            deny_accel_mps2: p.lane.deny_accel_mps2,
            deny_extra_mps: p.lane.deny_extra_mps,
            speed_noise_mps: p.tier2.speed_noise_mps,
        }
    }
}

/// The built-in file's [`Typical`] figures.
pub fn typical() -> &'static Typical {
    static TYPICAL: std::sync::LazyLock<Typical> =
        std::sync::LazyLock::new(|| Typical::of(&crate::scenario::def::builtin_params::<MergeParams>(&DEF)));
    &TYPICAL
}
