//! The episode: an environment-style wrapper around one scenario world.
//! Start it from (scenario, tier, seed), read the public observation, step
//! it with an action every turn, read the outcome. Baselines, `validate`,
//! `serve` and the LLM loop all drive this same code.

use crate::action::Action;
use crate::grading::{self, Diagnostics, Grades};
pub use crate::grading::{Choice, Outcome};
use crate::observation::{EgoView, Observation};
use crate::rng::{EpisodeRng, Stream};
use crate::scenario::world::{EgoApproach, PlanPoint, World};
use crate::scenario::{Disposition, ScenarioConfig, ScenarioKind, Tier, episode_key};
use crate::sim::{Body, DECISION_INTERVAL, DT, EGO_MAX_ACCEL, EGO_MAX_BRAKE};
use serde::{Deserialize, Serialize};

/// What identifies an episode: the same spec and the same actions give the
/// same episode on any machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct EpisodeSpec {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
}

/// The disposition drawn 50/50 from the episode's own stream.
pub fn draw_disposition(spec: EpisodeSpec) -> Disposition {
    let key = episode_key(spec.scenario, spec.tier, spec.seed);
    let [a, b] = spec.scenario.dispositions();
    if EpisodeRng::new(&key, Stream::Disposition).coin() { b } else { a }
}

/// Seed for a policy's own randomness in this episode: from its own stream,
/// so it reveals nothing about the disposition.
pub fn policy_seed(spec: EpisodeSpec) -> u64 {
    EpisodeRng::new(&episode_key(spec.scenario, spec.tier, spec.seed), Stream::Policy).next_u64()
}

/// One decision as the graders see it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DecisionRecord {
    pub turn: u32,
    pub time_s: f64,
    pub action: Action,
    /// Whether the go / give-way question was already settled when this
    /// decision was taken.
    pub after_resolution: bool,
    /// Privileged: the ideal observer's belief that the other road user
    /// lets the ego pass first, given the observation this decision saw
    /// (see `belief`).
    #[serde(default = "half")]
    pub ideal_belief: f64,
}

fn half() -> f64 {
    0.5
}

/// Who entered the conflict first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Party {
    Ego,
    Other,
}

/// When the information arrived and when the ego committed
/// (docs/graders.md). Turns are 1-based decision indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct EvidenceTiming {
    /// The first turn whose observation differs from a replay of the same
    /// seed and actions under the other disposition (None: never, within
    /// the episode).
    pub evidence_turn: Option<u32>,
    /// The decision that settled who passes the conflict first: the one in
    /// force when the ego passed its point of no return (a go), or when the
    /// other entered the conflict while the ego could still stop (a give
    /// way). None when the episode ended with neither.
    pub commitment_turn: Option<u32>,
    pub choice: Option<Choice>,
    /// Who entered the conflict first (None: nobody did).
    pub first_in: Option<Party>,
}

impl EvidenceTiming {
    /// A commitment before the evidence turn (or with no evidence at all):
    /// whatever the outcome, the ego could not have known.
    pub fn guessed(&self) -> Option<bool> {
        let c = self.commitment_turn?;
        Some(self.evidence_turn.is_none_or(|e| c < e))
    }

    /// Turns from the evidence to the commitment (None for a guess or no
    /// commitment).
    pub fn lag(&self) -> Option<u32> {
        let (c, e) = (self.commitment_turn?, self.evidence_turn?);
        c.checked_sub(e)
    }
}

/// Privileged: where the forecast probe's road users are at one decision,
/// in the true world and in the other disposition's, both driven by the
/// same ego (the references the forecasts are scored against).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForecastTruth {
    pub time_s: f64,
    /// The ego's travel along its path so far (m): where positions are
    /// measured from the ego, a forecast made at one decision is scored in
    /// that decision's frame.
    pub ego_travel_m: f64,
    /// [`World::true_positions`] under the hidden disposition ...
    pub actual: Vec<f64>,
    /// ... and under the other one.
    pub other: Vec<f64>,
    /// Whether either world's road user had begun to move as its
    /// disposition makes it ([`World::revealed`]): until then the two
    /// must be byte-identical.
    pub revealed: bool,
}

/// Plan-view positions at one decision (ego first).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryPoint {
    pub time_s: f64,
    pub agents: Vec<PlanPoint>,
}

/// Everything the graders need, accumulated step by step.
#[derive(Debug, Clone, Default)]
struct Tracker {
    min_gap_m: f64,
    min_ttc_s: Option<f64>,
    hard_brakes: u32,
    braking_hard: bool,
    row_violations: u32,
    cutting_off: bool,
    peak_accel: f64,
    peak_decel: f64,
    peak_jerk: f64,
    comfortable_steps: u32,
    accel_steps: u32,
    interval_accel_sum: f64,
    last_interval_accel: Option<f64>,
    jerk_ok_intervals: u32,
    intervals: u32,
    time_to_goal_s: Option<f64>,
    /// The world's count of turns taken by road users that had waited for
    /// the ego, as last seen, and how many of them began while the ego
    /// could no longer stop comfortably.
    turns_taken: u32,
    unstoppable_turns_taken: u32,
}

pub struct Episode {
    spec: EpisodeSpec,
    disposition: Disposition,
    world: Box<dyn World + Send>,
    /// The same seed under the other disposition, driven by the same ego,
    /// until its observation first differs (the evidence turn); on a world
    /// observed through noise, until the episode ends (the ideal observer
    /// weighs every reading against it).
    twin: Option<Box<dyn World + Send>>,
    timing: EvidenceTiming,
    /// The turn the ego passed its point of no return, where that alone
    /// does not settle the order (see [`World::order_settles_choice`]).
    no_return_turn: Option<u32>,
    /// The ideal observer: the log-likelihood ratio of the true disposition
    /// against the other from the noisy readings so far, and whether the
    /// other disposition has been ruled out.
    llr: f64,
    certain: bool,
    noisy: bool,
    ego: Body,
    start_s: f64,
    goal_s: f64,
    speed_limit: f64,
    turn_budget: u32,
    turn: u32,
    step: u32,
    held: Option<Action>,
    outcome: Option<Outcome>,
    observation: Observation,
    decisions: Vec<DecisionRecord>,
    trajectory: Option<Vec<TrajectoryPoint>>,
    /// The other disposition's world for the whole episode (the evidence
    /// twin above stops at the evidence), and where both worlds' road users
    /// were at every decision: kept only for the forecast probe.
    forecast_twin: Option<Box<dyn World + Send>>,
    forecast_truth: Vec<ForecastTruth>,
    tracker: Tracker,
}

impl Episode {
    /// Start an episode; the hidden disposition is drawn from the seed.
    pub fn new(config: &ScenarioConfig, tier: Tier, seed: u64) -> Episode {
        let spec = EpisodeSpec { scenario: config.kind(), tier, seed };
        Self::with_disposition(config, tier, seed, draw_disposition(spec))
    }

    /// Start an episode with a chosen disposition (same geometry as the
    /// seed's). Used by the invariant checks that compare dispositions.
    pub fn with_disposition(config: &ScenarioConfig, tier: Tier, seed: u64, disposition: Disposition) -> Episode {
        let spec = EpisodeSpec { scenario: config.kind(), tier, seed };
        let key = episode_key(spec.scenario, tier, seed);
        let [a, b] = spec.scenario.dispositions();
        let other = if disposition == a { b } else { a };
        let mut world = config.build_world(tier, disposition, &key);
        let mut twin = config.build_world(tier, other, &key);
        let ego = world.ego_start();
        let common = config.common();
        let goal_s = world.goal_s();
        let view = EgoView {
            speed_mps: ego.v,
            accel_mps2: ego.a,
            to_goal_m: goal_s - ego.s,
            speed_limit_mps: common.speed_limit_mps,
            speed_limit_ahead_mps: world.speed_limit_ahead(&ego),
        };
        let observation = Observation {
            time_s: 0.0,
            turn: 1,
            turn_budget: common.turn_budget.get(tier),
            ego: view,
            scene: world.observe(&ego),
            last_action: None,
            reading_noise: world.reading_noise(),
        };
        // The twin's first observation is taken too, so that its history
        // advances in step with the real world's.
        let twin_scene = twin.observe(&ego);
        let noisy = !world.noisy_readings().is_empty();
        let mut episode = Episode {
            spec,
            disposition,
            world,
            twin: Some(twin),
            timing: EvidenceTiming::default(),
            no_return_turn: None,
            llr: 0.0,
            certain: false,
            noisy,
            ego,
            start_s: ego.s,
            goal_s,
            speed_limit: common.speed_limit_mps,
            turn_budget: common.turn_budget.get(tier),
            turn: 0,
            step: 0,
            held: None,
            outcome: None,
            observation,
            decisions: Vec::with_capacity(common.turn_budget.get(tier) as usize),
            trajectory: None,
            forecast_twin: None,
            forecast_truth: Vec::new(),
            tracker: Tracker { min_gap_m: f64::INFINITY, ..Tracker::default() },
        };
        episode.compare_twin(twin_scene);
        episode
    }

    /// Keep plan-view positions at every decision (for trajectory plots).
    pub fn record_trajectory(&mut self) {
        if self.trajectory.is_none() {
            self.trajectory = Some(vec![self.trajectory_point()]);
        }
    }

    /// Keep, at every decision, where the forecast probe's road users are
    /// under both dispositions, the other one's world driven by the same
    /// ego ([`Episode::forecast_truth`]). Only before the first step (the
    /// other world must start with this one); returns whether it is kept.
    pub fn record_forecast_truth(&mut self, config: &ScenarioConfig) -> bool {
        if self.turn > 0 {
            return self.forecast_twin.is_some();
        }
        if self.forecast_twin.is_none() {
            let [a, b] = self.spec.scenario.dispositions();
            let other = if self.disposition == a { b } else { a };
            let key = episode_key(self.spec.scenario, self.spec.tier, self.spec.seed);
            let mut twin = config.build_world(self.spec.tier, other, &key);
            // Observed as the real world is, so that its state advances in
            // step (a world's history and noise move at each observation).
            twin.observe(&self.ego);
            self.forecast_twin = Some(twin);
            self.push_forecast_truth();
        }
        true
    }

    /// Privileged: where the forecast probe's road users were at every
    /// decision so far (empty unless [`Episode::record_forecast_truth`]).
    pub fn forecast_truth(&self) -> &[ForecastTruth] {
        &self.forecast_truth
    }

    fn push_forecast_truth(&mut self) {
        let Some(twin) = self.forecast_twin.as_ref() else { return };
        self.forecast_truth.push(ForecastTruth {
            time_s: self.time(),
            ego_travel_m: self.ego.s - self.start_s,
            actual: self.world.true_positions(&self.ego),
            other: twin.true_positions(&self.ego),
            revealed: self.world.revealed() || twin.revealed(),
        });
    }

    pub fn spec(&self) -> EpisodeSpec {
        self.spec
    }

    /// The public observation for the next decision.
    pub fn observation(&self) -> &Observation {
        &self.observation
    }

    pub fn outcome(&self) -> Option<Outcome> {
        self.outcome
    }

    pub fn is_done(&self) -> bool {
        self.outcome.is_some()
    }

    /// Privileged: the hidden disposition. Policies never get an episode,
    /// only its observation.
    pub fn disposition(&self) -> Disposition {
        self.disposition
    }

    /// Privileged: whether the other agent's motion has started to depend on
    /// its disposition.
    pub fn revealed(&self) -> bool {
        self.world.revealed()
    }

    /// Stop tracking the other disposition's twin: the evidence turn stays
    /// unknown, and stepping costs half as much (for searches that only need
    /// outcomes).
    pub fn skip_evidence(&mut self) {
        self.twin = None;
    }

    /// Privileged: how the road users have moved so far (`validate`'s
    /// "road users move as people" line).
    pub fn road_user_motion(&self) -> crate::scenario::world::Motion {
        self.world.motion()
    }

    /// The speed limit that binds the ego where it is now: the world's
    /// (the merge's through lane) or the episode's.
    fn ego_speed_limit(&self) -> f64 {
        self.world.ego_speed_limit(&self.ego).unwrap_or(self.speed_limit)
    }

    /// Privileged: evidence and commitment so far.
    pub fn timing(&self) -> EvidenceTiming {
        self.timing
    }

    fn observe(&mut self) {
        let scene = self.world.observe(&self.ego);
        self.observation = Observation {
            time_s: self.time(),
            turn: self.turn + 1,
            turn_budget: self.turn_budget,
            ego: EgoView {
                speed_mps: self.ego.v,
                accel_mps2: self.ego.a,
                to_goal_m: self.goal_s - self.ego.s,
                speed_limit_mps: self.ego_speed_limit(),
                speed_limit_ahead_mps: self.world.speed_limit_ahead(&self.ego),
            },
            scene,
            last_action: self.held,
            reading_noise: self.world.reading_noise(),
        };
        if let Some(twin) = self.twin.as_mut() {
            let twin_scene = twin.observe(&self.ego);
            self.compare_twin(twin_scene);
        }
    }

    /// Compare the observation about to be shown with the twin's: the
    /// first difference at printed precision is the evidence turn, and the
    /// noisy readings update the ideal observer.
    fn compare_twin(&mut self, twin_scene: crate::observation::Scene) {
        let Some(twin) = self.twin.as_ref() else { return };
        self.llr += crate::noise::readings_llr(self.world.noisy_readings(), twin.noisy_readings());
        let twin_obs = Observation { scene: twin_scene, ..self.observation };
        if twin_obs.rounded() != self.observation.rounded() {
            self.reveal_now();
        }
        if self.llr == f64::INFINITY {
            self.rule_out_twin();
        }
    }

    /// The observation about to be shown differs from the other
    /// disposition's: this turn is the evidence turn. Without noise the
    /// difference rules the other disposition out; with noise only the
    /// readings' likelihoods weigh it.
    fn reveal_now(&mut self) {
        if self.timing.evidence_turn.is_none() {
            self.timing.evidence_turn = Some(self.turn + 1);
        }
        if !self.noisy {
            self.rule_out_twin();
        }
    }

    fn rule_out_twin(&mut self) {
        self.certain = true;
        self.twin = None;
    }

    /// Privileged: the ideal observer's belief, for the observation about
    /// to be shown, that the other road user lets the ego pass first.
    pub fn ideal_belief(&self) -> f64 {
        let p_true = if self.certain { 1.0 } else { crate::noise::posterior_true(self.llr) };
        if self.disposition.ego_should_go() { p_true } else { 1.0 - p_true }
    }

    fn time(&self) -> f64 {
        self.step as f64 * DT
    }

    fn trajectory_point(&self) -> TrajectoryPoint {
        TrajectoryPoint { time_s: self.time(), agents: self.world.plan(&self.ego) }
    }

    /// Apply one decision: hold `action` for `DECISION_INTERVAL` physics
    /// steps (fewer if the episode ends), then observe. Returns the outcome
    /// once the episode is over; stepping a finished episode does nothing.
    pub fn step(&mut self, action: Action) -> Option<Outcome> {
        if self.outcome.is_some() {
            return self.outcome;
        }
        let action = sanitize(action);
        self.decisions.push(DecisionRecord {
            turn: self.turn + 1,
            time_s: self.time(),
            action,
            after_resolution: self.timing.first_in.is_some(),
            ideal_belief: self.ideal_belief(),
        });
        let control = action.control();
        let prev_interval_accel = self.tracker.last_interval_accel;
        self.tracker.interval_accel_sum = 0.0;
        let mut steps_this_turn = 0;
        let mut twin_collided = false;
        for _ in 0..DECISION_INTERVAL {
            let t = self.time();
            let a_cmd =
                control.acceleration(self.ego.v, self.ego_speed_limit(), DT).clamp(-EGO_MAX_BRAKE, EGO_MAX_ACCEL);
            self.ego.advance(a_cmd, DT);
            self.world.advance(&self.ego, t, DT);
            if let Some(twin) = self.twin.as_mut() {
                twin.advance(&self.ego, t, DT);
                twin_collided |= twin.contact(&self.ego).collision;
            }
            if let Some(twin) = self.forecast_twin.as_mut() {
                twin.advance(&self.ego, t, DT);
            }
            self.step += 1;
            steps_this_turn += 1;
            self.track_step();
            self.track_conflict();
            self.track_turns_taken();
            let contact = self.world.contact(&self.ego);
            self.tracker.min_gap_m = self.tracker.min_gap_m.min(contact.gap_m);
            if let Some(ttc) = contact.ttc_s {
                self.tracker.min_ttc_s = Some(self.tracker.min_ttc_s.map_or(ttc, |m| m.min(ttc)));
            }
            if contact.collision {
                self.outcome = Some(Outcome::Collision);
                break;
            }
            if self.ego.s >= self.goal_s {
                self.tracker.time_to_goal_s = Some(self.time());
                self.outcome = Some(Outcome::Success);
                break;
            }
        }
        // Jerk over decision intervals: change of mean acceleration.
        let mean_accel = self.tracker.interval_accel_sum / steps_this_turn as f64;
        if let Some(prev) = prev_interval_accel {
            let jerk = (mean_accel - prev) / (DT * DECISION_INTERVAL as f64);
            self.tracker.peak_jerk = self.tracker.peak_jerk.max(jerk.abs());
            self.tracker.intervals += 1;
            if jerk.abs() <= grading::COMFORT_MAX_JERK {
                self.tracker.jerk_ok_intervals += 1;
            }
        }
        self.tracker.last_interval_accel = Some(mean_accel);
        self.turn += 1;
        self.held = Some(action);
        if self.outcome.is_none() && self.turn >= self.turn_budget {
            self.outcome = Some(Outcome::Timeout);
        }
        if steps_this_turn == DECISION_INTERVAL {
            // A decision's full interval: its end is the next decision's
            // time, which a forecast made earlier may reach.
            if let Some(twin) = self.forecast_twin.as_mut() {
                twin.observe(&self.ego);
            }
            self.push_forecast_truth();
        }
        if self.outcome.is_none() {
            if twin_collided && self.twin.is_some() {
                // Under the other disposition the same actions ended in a
                // collision: what the ego sees next differs, certainly.
                self.reveal_now();
                self.rule_out_twin();
            }
            self.observe();
        }
        if let Some(traj) = self.trajectory.as_mut() {
            traj.push(TrajectoryPoint { time_s: self.step as f64 * DT, agents: self.world.plan(&self.ego) });
        }
        self.outcome
    }

    /// Who enters the conflict first, and the ego's point of no return.
    fn track_conflict(&mut self) {
        if self.timing.first_in.is_some() {
            return;
        }
        let turn = self.turn + 1;
        let approach = EgoApproach::new(self.world.ego_to_conflict(&self.ego), &self.ego);
        let (to_conflict, beyond_stopping) = (approach.to_conflict, approach.beyond_stopping());
        if self.world.order_settles_choice() {
            // Side by side: an ego past its point of no return can still
            // fall in behind, so the order of entry is the choice.
            if beyond_stopping && self.no_return_turn.is_none() {
                self.no_return_turn = Some(turn);
            }
            if self.world.other_entered() {
                self.timing.first_in = Some(Party::Other);
                self.timing.choice = Some(Choice::GiveWay);
                self.timing.commitment_turn = Some(turn);
            } else if to_conflict <= 0.0 {
                self.timing.first_in = Some(Party::Ego);
                self.timing.choice = Some(Choice::Go);
                self.timing.commitment_turn = Some(self.no_return_turn.unwrap_or(turn));
            }
            return;
        }
        if beyond_stopping && self.timing.choice.is_none() {
            self.timing.choice = Some(Choice::Go);
            self.timing.commitment_turn = Some(turn);
        }
        if self.world.other_entered() {
            self.timing.first_in = Some(Party::Other);
            if self.timing.choice.is_none() {
                self.timing.choice = Some(Choice::GiveWay);
                self.timing.commitment_turn = Some(turn);
            }
        } else if to_conflict <= 0.0 {
            self.timing.first_in = Some(Party::Ego);
        }
    }

    /// A road user that had been waiting for the ego started into its path
    /// this step: count it when the ego could no longer stop comfortably
    /// before the conflict (what no person at a kerb or a stop line does).
    fn track_turns_taken(&mut self) {
        let taken = self.world.turns_taken();
        if taken > self.tracker.turns_taken {
            let approach = EgoApproach::new(self.world.ego_to_conflict(&self.ego), &self.ego);
            if !approach.can_stop() {
                self.tracker.unstoppable_turns_taken += taken - self.tracker.turns_taken;
            }
            self.tracker.turns_taken = taken;
        }
    }

    fn track_step(&mut self) {
        let a = self.ego.a;
        let tr = &mut self.tracker;
        tr.accel_steps += 1;
        tr.interval_accel_sum += a;
        tr.peak_accel = tr.peak_accel.max(a);
        tr.peak_decel = tr.peak_decel.max(-a);
        if (grading::COMFORT_MIN_ACCEL..=grading::COMFORT_MAX_ACCEL).contains(&a) {
            tr.comfortable_steps += 1;
        }
        let hard = a < grading::HARD_BRAKE;
        if hard && !tr.braking_hard {
            tr.hard_brakes += 1;
        }
        tr.braking_hard = hard;
        let cutting = self.world.cuts_off(&self.ego);
        if cutting && !tr.cutting_off {
            tr.row_violations += 1;
        }
        tr.cutting_off = cutting;
    }

    /// Grade the finished (or abandoned) episode. An episode stopped before
    /// its end is graded as a timeout at the current state.
    pub fn finish(self) -> EpisodeRecord {
        let (outcome, grades) = self.grades();
        EpisodeRecord {
            spec: self.spec,
            disposition: self.disposition,
            outcome,
            grades,
            timing: self.timing,
            decisions: self.decisions,
            trajectory: self.trajectory,
            stated_beliefs: Vec::new(),
        }
    }

    /// The outcome and grades [`Episode::finish`] records, without giving
    /// the episode up (for a front end that keeps serving it, such as
    /// `env-server`).
    pub fn grades(&self) -> (Outcome, Grades) {
        let outcome = self.outcome.unwrap_or(Outcome::Timeout);
        let tr = &self.tracker;
        let span = self.goal_s - self.start_s;
        let progress = ((self.ego.s - self.start_s) / span).clamp(0.0, 1.0);
        let free_flow_time_s = span / self.speed_limit;
        let efficiency = tr.time_to_goal_s.map_or(0.0, |t| (free_flow_time_s / t).min(1.0));
        let comfort = if tr.accel_steps == 0 {
            1.0
        } else {
            let accel_ok = tr.comfortable_steps as f64 / tr.accel_steps as f64;
            let jerk_ok = if tr.intervals == 0 { 1.0 } else { tr.jerk_ok_intervals as f64 / tr.intervals as f64 };
            0.5 * (accel_ok + jerk_ok)
        };
        let diagnostics = Diagnostics {
            min_ttc_s: tr.min_ttc_s,
            min_gap_m: tr.min_gap_m,
            hard_brakes: tr.hard_brakes,
            right_of_way_violations: tr.row_violations,
            time_to_goal_s: tr.time_to_goal_s,
            free_flow_time_s,
            efficiency,
            progress,
            peak_accel_mps2: tr.peak_accel,
            peak_decel_mps2: tr.peak_decel,
            peak_jerk_mps3: tr.peak_jerk,
            comfort,
            decisions: self.turn,
            duration_s: self.time(),
            unstoppable_turns_taken: tr.unstoppable_turns_taken,
        };
        let grades = Grades {
            reward: grading::compute_episode_reward(outcome, &diagnostics),
            decision_correctness: grading::decision_correctness(self.disposition, outcome, self.timing.choice),
            diagnostics,
        };
        (outcome, grades)
    }
}

/// Non-finite numbers from a policy become the conservative action; the
/// magnitude is clamped to its documented range.
fn sanitize(a: Action) -> Action {
    if !a.acceleration.is_finite() {
        return Action::CONSERVATIVE;
    }
    Action {
        acceleration: a.acceleration.clamp(-1.0, 1.0),
        steering: if a.steering.is_finite() { a.steering } else { 0.0 },
        ..a
    }
}

/// A graded episode with its privileged facts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    pub spec: EpisodeSpec,
    pub disposition: Disposition,
    pub outcome: Outcome,
    pub grades: Grades,
    pub timing: EvidenceTiming,
    pub decisions: Vec<DecisionRecord>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub trajectory: Option<Vec<TrajectoryPoint>>,
    /// The beliefs an in-process policy stated, one per decision (empty
    /// when the episode was not played by [`run_episode`]).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub stated_beliefs: Vec<f64>,
}

impl EpisodeRecord {
    /// The belief metrics of the stated beliefs (None when none were
    /// stated).
    pub fn belief_metrics(&self) -> Option<crate::belief::BeliefMetrics> {
        if self.stated_beliefs.is_empty() {
            return None;
        }
        let turns: Vec<crate::belief::BeliefTurn> = self
            .decisions
            .iter()
            .zip(&self.stated_beliefs)
            .map(|(d, &b)| crate::belief::BeliefTurn {
                turn: d.turn,
                stated: Some(b),
                ideal: d.ideal_belief,
                maneuver: Some(d.action.maneuver),
                open: !d.after_resolution,
            })
            .collect();
        Some(crate::belief::BeliefMetrics::compute(&turns, self.disposition.ego_should_go(), self.timing.evidence_turn))
    }
}

/// The evidence-timing metrics have one home, here beside
/// [`EvidenceTiming`]: `eval`'s summary and `report` both call them.
/// Share of the episodes with a commitment that committed before the
/// evidence turn (NaN when none committed).
pub fn guess_rate(timings: impl Iterator<Item = EvidenceTiming>) -> f64 {
    let guesses: Vec<f64> = timings.filter_map(|t| t.guessed()).map(|g| f64::from(u8::from(g))).collect();
    crate::stats::mean(&guesses)
}

/// Mean turns from the evidence to the commitment over the episodes that
/// committed at or after it (NaN when none did).
pub fn evidence_lag(timings: impl Iterator<Item = EvidenceTiming>) -> f64 {
    let lags: Vec<f64> = timings.filter_map(|t| t.lag()).map(f64::from).collect();
    crate::stats::mean(&lags)
}

/// Play one whole episode with an in-process policy.
pub fn run_episode(
    config: &ScenarioConfig,
    tier: Tier,
    seed: u64,
    policy: &mut dyn crate::policy::Policy,
) -> EpisodeRecord {
    let mut episode = Episode::new(config, tier, seed);
    policy.reset(policy_seed(episode.spec()));
    let mut beliefs = Vec::new();
    while !episode.is_done() {
        let action = policy.act(episode.observation());
        beliefs.push(policy.belief(episode.observation(), &action, episode.ideal_belief()));
        episode.step(action);
    }
    let mut record = episode.finish();
    record.stated_beliefs = beliefs;
    record
}
