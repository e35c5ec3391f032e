//! A toy scenario the crate's unit tests add through the registry alone
//! (`scenario::with_test_scenarios`): this file, its TOML
//! (`tests/fixtures/toy_crossing.toml`), its expert's rules
//! (`policy/expert/toy_crossing.rs`), its rules forecaster
//! (`forecast/rules/toy_crossing.rs`) and its picture
//! (`picture/toy_crossing.rs`). One car on a crossing road either
//! drives through (`committed`) or stops at its line and waits for the ego
//! (`yielder`).
//! It shows that the episode loop, the scene text, the scene's JSON, the
//! graders, the policies, `baselines`, `eval`'s dry run and `report` take a
//! scenario from its files and its registry line alone. It is in
//! `ScenarioKind::ALL` in the unit tests only, never in the binary.

use super::world::{Contact, History, PlanPoint, ROW_MARGIN_S, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, PlanAxes, Range, RoadUser, Sample, ScenarioError, Tier};
use super::{ScenarioConfig, ScenarioDef, ScenarioKind, Scene, TrackLabel};
use crate::rng::EpisodeRng;
use crate::sim::{Body, CAR_LENGTH, CAR_WIDTH, EGO_MAX_ACCEL, travel_time};
use serde::{Deserialize, Serialize};

const TOML: &str = include_str!("../../tests/fixtures/toy_crossing.toml");

pub(crate) const DEF: ScenarioDef = ScenarioDef {
    name: "toy_crossing",
    scene_name: "toy crossing",
    rng_id: 99,
    dispositions: [super::yield_standoff::COMMITTED, super::yield_standoff::YIELDER],
    plan_axes: PlanAxes {
        ego_along_y: true,
        others_along_y: false,
        zero_label: "crossing centre",
        road_users: &[RoadUser { role: "crossing car", lateral: None }],
    },
    situation: "A toy crossing: one car approaches on the crossing road.",
    scene_doc: "`ego_to_zone_m`: the ego's front bumper to the zone. `car.position_m`: the car's front bumper to it.",
    place_fields: &["ego_to_zone_m"],
    place_text: |n| format!("{} m to the zone", n[0]),
    track_labels: &[TrackLabel { now: "Crossing car", history: "Crossing car before", field: "car" }],
    tracks_relative_to_ego: false,
    position_per_velocity: -1.0,
    forecast_tracks: 1,
    track_now: |position, velocity| format!("{position} m to the zone, speed {velocity} m/s"),
    belief_question: "the crossing car will let you through first",
    forecast_subject: "the crossing car will be, as its distance in metres to the conflict zone,",
    tier_mechanics: ["the same", "the same"],
    leaderboard_dc: None,
    builtin_file: ("tests/fixtures/toy_crossing.toml", TOML),
    load: super::load::<ToyParams>,
};

/// Centre distance from the crossing centre at which the boxes overlap.
pub const HALF_ZONE: f64 = 0.5 * (CAR_LENGTH + CAR_WIDTH);

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToyParams {
    episode: Common,
    ego: ToyEgo,
    car: ToyCar,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToyEgo {
    start_distance_m: Range,
    start_speed_mps: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToyCar {
    approach_speed_mps: Range,
    stop_line_m: f64,
}

impl super::ScenarioParams for ToyParams {
    fn common(&self) -> &Common {
        &self.episode
    }

    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 5.0, 60.0)?;
        c.range_within("car.approach_speed_mps", self.car.approach_speed_mps, 1.0, 15.0)?;
        c.within("car.stop_line_m", self.car.stop_line_m, 0.0, 5.0)
    }

    fn build_world(
        &self,
        _tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        _noise: EpisodeRng,
    ) -> Box<dyn World + Send> {
        let d = self.ego.start_distance_m.sample(geometry);
        let v = self.ego.start_speed_mps.sample(geometry);
        let car_v = self.car.approach_speed_mps.sample(geometry);
        // A committed car reaches the zone as a racing ego does.
        let race = travel_time(d, v, self.episode.speed_limit_mps, EGO_MAX_ACCEL);
        let car = Body::new(-HALF_ZONE - car_v * race, car_v);
        let now = Sample { position_m: -HALF_ZONE - car.s, velocity_mps: car_v };
        Box::new(ToyWorld {
            ego: Body::new(-HALF_ZONE - d, v),
            car,
            stop_at: -HALF_ZONE - self.car.stop_line_m,
            yields: disposition == super::yield_standoff::YIELDER,
            approach_speed: car_v,
            history: History::steady(now, -car_v),
        })
    }
}

struct ToyWorld {
    ego: Body,
    car: Body,
    /// Where a yielder's front bumper comes to rest.
    stop_at: f64,
    yields: bool,
    /// The speed it approached at (m/s).
    approach_speed: f64,
    history: History,
}

impl World for ToyWorld {
    fn ego_start(&self) -> Body {
        self.ego
    }

    fn goal_s(&self) -> f64 {
        2.0 * HALF_ZONE
    }

    fn advance(&mut self, ego: &Body, _t: f64, dt: f64) {
        let accel = if !self.yields {
            0.0
        } else if ego.s > HALF_ZONE {
            2.0 // the ego is through: its turn
        } else {
            // Brake to rest at the line (no faster than 6 m/s^2).
            let left = (self.stop_at - self.car.s).max(0.01);
            -(self.car.v * self.car.v / (2.0 * left)).min(6.0)
        };
        self.car.advance(accel, dt);
    }

    fn contact(&self, ego: &Body) -> Contact {
        let (e, o) = (car_box(0.0, ego.s, false), car_box(self.car.s, 0.0, true));
        let ttc = crossing_ttc(
            -HALF_ZONE - ego.s,
            HALF_ZONE - ego.s,
            ego.v,
            -HALF_ZONE - self.car.s,
            HALF_ZONE - self.car.s,
            self.car.v,
        );
        Contact { gap_m: e.gap(&o), ttc_s: ttc, collision: e.overlaps(&o) }
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let now = Sample { position_m: -HALF_ZONE - self.car.s, velocity_mps: self.car.v };
        Scene::new(ScenarioKind(&DEF), &[-HALF_ZONE - ego.s], &[self.history.track(now)]).expect("the toy's layout")
    }

    fn true_positions(&self, _ego: &Body) -> Vec<f64> {
        vec![-HALF_ZONE - self.car.s]
    }

    fn revealed(&self) -> bool {
        self.yields && self.car.v < 0.8 * self.approach_speed
    }

    fn ego_to_conflict(&self, ego: &Body) -> f64 {
        -HALF_ZONE - ego.s
    }

    fn other_entered(&self) -> bool {
        self.car.s > -HALF_ZONE
    }

    fn cuts_off(&self, ego: &Body) -> bool {
        let inside = ego.s > -HALF_ZONE && ego.s < HALF_ZONE;
        let o = -HALF_ZONE - self.car.s;
        let due = o > 0.0 && self.car.v > 0.1 && o / self.car.v < ROW_MARGIN_S;
        inside && ((o <= 0.0 && o > -2.0 * HALF_ZONE) || due)
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![PlanPoint { x: 0.0, y: ego.s, v: ego.v }, PlanPoint { x: self.car.s, y: 0.0, v: self.car.v }]
    }
}

/// The toy's parameters, from its TOML.
fn config() -> ScenarioConfig {
    let (path, text) = DEF.builtin_file;
    ScenarioConfig::for_scenario(ScenarioKind(&DEF), path, text).expect("the toy's TOML is valid")
}

// The whole module is test-only; marking the tests too keeps their imports
// (episode, policy) out of the layer check.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::Action;
    use crate::episode::Episode;
    use crate::grading::Outcome;
    use crate::observation::{Observation, render_scene};
    use crate::policy::{Expert, Policy, PolicyKind, go, hedge};

    /// Play one episode of the toy with `policy`.
    fn play(tier: Tier, seed: u64, disposition: Disposition, policy: &mut dyn Policy) -> Episode {
        let mut episode = Episode::with_disposition(&config(), tier, seed, disposition);
        while !episode.is_done() {
            let action = policy.act(episode.observation());
            episode.step(action);
        }
        episode
    }

    /// Reads the car from the public scene: go once it has stopped or gone
    /// through, give way before the zone until then.
    struct WaitForTheCar;
    impl Policy for WaitForTheCar {
        fn act(&mut self, obs: &Observation) -> Action {
            let car = obs.scene.tracks()[0].now;
            let d = obs.ego_to_conflict_m();
            if d < 0.5 || car.velocity_mps < 0.05 || car.position_m < -2.0 * HALF_ZONE - 0.5 {
                go()
            } else {
                hedge(obs.ego.speed_mps, d - 2.0)
            }
        }
    }

    #[test]
    fn its_file_is_read_checked_and_named_in_errors() {
        let config = config();
        assert_eq!(config.kind().name(), "toy_crossing");
        assert_eq!(config.common().turn_budget.get(Tier::T1), 30);
        let bad = TOML.replace("stop_line_m = 1.0", "stop_line_m = 9.0");
        let e = ScenarioConfig::for_scenario(ScenarioKind(&DEF), "toy.toml", &bad).unwrap_err().to_string();
        assert!(e.starts_with("toy.toml: car.stop_line_m: must lie in [0, 5]"), "{e}");
        // In the unit tests' registry: found by name, its file read as any.
        assert_eq!("toy_crossing".parse::<ScenarioKind>().unwrap(), ScenarioKind(&DEF));
        assert_eq!(ScenarioConfig::from_toml("toy.toml", TOML).unwrap(), config);
    }

    #[test]
    fn the_scene_text_and_json_are_the_toys_and_hide_the_disposition() {
        for seed in 0..20 {
            let [committed, yielder] = DEF.dispositions;
            let first = |d| *Episode::with_disposition(&config(), Tier::T1, seed, d).observation();
            let (a, b) = (first(committed), first(yielder));
            assert_eq!(render_scene(&a), render_scene(&b), "seed {seed}");
            assert_eq!(serde_json::to_string(&a).unwrap(), serde_json::to_string(&b).unwrap());
        }
        let obs = *Episode::new(&config(), Tier::T1, 3).observation();
        let text = render_scene(&obs);
        for expected in
            ["Scene: toy crossing", DEF.situation, "m to the zone", "Crossing car: ", "Crossing car before: "]
        {
            assert!(text.contains(expected), "{expected:?} not in:\n{text}");
        }
        let json = serde_json::to_value(obs.scene).unwrap();
        let keys: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
        assert_eq!(keys, ["car", "ego_to_zone_m", "scenario"]);
        assert_eq!(json["scenario"], "toy_crossing");
    }

    #[test]
    fn episodes_play_grade_and_reproduce_from_its_definition_alone() {
        let [committed, yielder] = DEF.dispositions;
        let (mut collisions, mut reader_wins, mut expert_collisions) = (0, 0, 0);
        for seed in 0..20 {
            let racer = play(Tier::T1, seed, committed, PolicyKind::AlwaysProceed.build().as_mut());
            collisions += usize::from(racer.outcome() == Some(Outcome::Collision));
            for d in [committed, yielder] {
                let reader = play(Tier::T2, seed, d, &mut WaitForTheCar).finish();
                reader_wins += usize::from(reader.outcome == Outcome::Success);
                let again = play(Tier::T2, seed, d, &mut WaitForTheCar).finish();
                assert_eq!(serde_json::to_string(&reader).unwrap(), serde_json::to_string(&again).unwrap());
                // The expert reads the car by its own rules for the toy.
                let expert = play(Tier::T1, seed, d, &mut Expert);
                expert_collisions += usize::from(expert.outcome() != Some(Outcome::Success));
            }
        }
        assert_eq!(collisions, 20, "racing meets the committed car");
        assert_eq!(reader_wins, 40, "reading the car wins against both");
        assert_eq!(expert_collisions, 0);
    }

    /// `validate`'s blind search runs on any scenario, and it catches this
    /// toy's flaw: its yielder waits for the ego for ever, so hanging back
    /// until a committed car would be through, then going, wins without
    /// looking. A benchmark scenario needs a yielder whose patience runs out.
    #[test]
    fn the_blind_search_finds_that_the_toy_is_won_without_looking() {
        use crate::adversary::{SearchSpec, TRAIN_SEED_BASE, evaluate, search};
        let config = config();
        let spec = SearchSpec { budget: 4_000, train_seed_base: TRAIN_SEED_BASE, search_seed: 1 };
        let found = search(&config, Tier::T1, spec);
        let held_out = evaluate(&config, Tier::T1, &found.best, &(0..200).collect::<Vec<u64>>());
        assert!(held_out.success >= 0.95, "{}: {held_out:?}", found.best);
    }
}
