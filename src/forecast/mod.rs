//! The forecast probe: where a policy expects the other road user to be
//! 1 s and 2 s from now, under each of the two intents, scored against the
//! simulator (the episode itself under the hidden disposition, and its twin
//! under the other, driven by the same ego), never against the noisy
//! readings or anything a policy wrote.
//!
//! - [`Forecast`]: one answer's forecast, per road user the probe asks
//!   about ([`forecast_tracks`]), on the scene's own axis and in its units;
//!   where the scene measures positions from the ego (the merge), from
//!   where the ego is at the decision.
//! - [`Forecaster`]: what forecasts from the public observation; the
//!   references [`ForecasterKind`] (constant velocity, the standard floor
//!   of trajectory prediction, and rules that know each scenario's
//!   road-user model but not the seed's hidden draws).
//! - [`metrics`]: one episode's scores and a cell's.
//!
//! "If it lets you go first" is always the class of dispositions under
//! which the ego should go ([`crate::scenario::Disposition::ego_should_go`]),
//! as the belief probe's "belief" is.

pub mod metrics;
pub(crate) mod rules;

use crate::observation::Observation;
use crate::scenario::ScenarioKind;
use serde::{Deserialize, Serialize};

pub use metrics::{ForecastMetrics, ForecastSummary, ForecastTurn};

/// The forecast horizons (s): each a whole number of decisions ahead.
pub const HORIZONS_S: [f64; 2] = [1.0, 2.0];

/// Where one road user will be at each of [`HORIZONS_S`].
pub type AtHorizons = [f64; 2];

/// One forecast: per road user the probe asks about (the scene's order),
/// where it will be at each horizon under each intent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Forecast {
    /// If it lets the ego go first.
    pub lets_you_go: Vec<AtHorizons>,
    /// If it does not.
    pub does_not: Vec<AtHorizons>,
}

impl Forecast {
    /// The same future under both intents.
    pub fn same(future: Vec<AtHorizons>) -> Forecast {
        Forecast { lets_you_go: future.clone(), does_not: future }
    }

    /// The forecast under one intent.
    pub fn under(&self, lets_you_go: bool) -> &[AtHorizons] {
        if lets_you_go { &self.lets_you_go } else { &self.does_not }
    }

    /// Whether it has the scenario's road users, every figure finite.
    pub fn fits(&self, kind: ScenarioKind) -> bool {
        let n = forecast_tracks(kind);
        let finite = |v: &[AtHorizons]| v.iter().flatten().all(|x| x.is_finite());
        self.lets_you_go.len() == n && self.does_not.len() == n && finite(&self.lets_you_go) && finite(&self.does_not)
    }
}

/// Keys of the forecast's two intents in an answer.
pub const LETS_YOU_GO_KEY: &str = "if_it_lets_you_go_first";
pub const DOES_NOT_KEY: &str = "if_it_does_not";

/// The paragraph the probe appends to the system prompt of a scenario:
/// one neutral sentence of what to forecast, and the answer's shape.
pub fn prompt_paragraph(kind: ScenarioKind) -> String {
    let n = forecast_tracks(kind);
    let pairs = |a: &str, b: &str| -> String {
        let one = |i: usize| if n == 1 { format!("[{a}, {b}]") } else { format!("[{a}{i}, {b}{i}]") };
        format!("[{}]", (1..=n).map(one).collect::<Vec<_>>().join(", "))
    };
    let per = if n == 1 { "as a pair [in 1 s, in 2 s]" } else { "one pair [in 1 s, in 2 s] per car, in that order" };
    format!(
        "\n\nAlso add the field \"forecast\" to every answer: where {} 1 s and 2 s from now, once if it lets you go \
         first and once if it does not (each as if it had been so all along, your own moves the same), {per}. For example: {{\"reasoning\": \"...\", \"maneuver\": \"yield\", \
         \"acceleration\": 0.3, \"steering\": 0.0, \"forecast\": {{\"{LETS_YOU_GO_KEY}\": {}, \"{DOES_NOT_KEY}\": {}}}}}, \
         with numbers in place of the letters. The forecast is only recorded: it does not change how your car is driven.",
        kind.def().forecast_subject,
        pairs("A", "B"),
        pairs("C", "D"),
    )
}

/// Read an answer's forecast for a scene of `kind` (a missing or
/// malformed one is a probe parse error; the action is read apart).
pub fn parse_answer(text: &str, kind: ScenarioKind) -> Result<Forecast, crate::action::ForecastParseError> {
    let [lets_you_go, does_not] =
        crate::action::parse_forecast(text, forecast_tracks(kind), LETS_YOU_GO_KEY, DOES_NOT_KEY)?;
    Ok(Forecast { lets_you_go, does_not })
}

/// How many of the scene's road users the probe asks about.
pub fn forecast_tracks(kind: ScenarioKind) -> usize {
    kind.def().forecast_tracks
}

/// What forecasts from the public observation (a reference, or a policy's
/// own forecast).
pub trait Forecaster: Send {
    fn forecast(&mut self, obs: &Observation) -> Forecast;
}

/// The reference forecasters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForecasterKind {
    /// Every road user keeps its current velocity, under both intents: the
    /// standard floor in trajectory prediction.
    ConstantVelocity,
    /// Each scenario's road-user model under each intent, from the public
    /// scene, with the model's typical figures in place of the seed's
    /// hidden draws.
    Rules,
}

impl ForecasterKind {
    pub const ALL: [ForecasterKind; 2] = [ForecasterKind::ConstantVelocity, ForecasterKind::Rules];

    pub fn name(self) -> &'static str {
        match self {
            ForecasterKind::ConstantVelocity => "constant_velocity",
            ForecasterKind::Rules => "rules",
        }
    }

    pub fn build(self) -> Box<dyn Forecaster> {
        match self {
            ForecasterKind::ConstantVelocity => Box::new(ConstantVelocity),
            ForecasterKind::Rules => Box::new(rules::RulesForecaster),
        }
    }
}

impl std::fmt::Display for ForecasterKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A reference row of the forecast tables: a public forecaster, or the
/// privileged one that knows the episode's future and gives it under both
/// intents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reference {
    Forecaster(ForecasterKind),
    /// The episode's own future (its true positions) under both intents:
    /// no error under the true intent, and under the other as much as the
    /// worlds part after the evidence. A model that forecasts one future
    /// whatever the intent can do no better on the two together.
    SameFuture,
}

impl Reference {
    pub const ALL: [Reference; 3] = [
        Reference::Forecaster(ForecasterKind::ConstantVelocity),
        Reference::Forecaster(ForecasterKind::Rules),
        Reference::SameFuture,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Reference::Forecaster(k) => k.name(),
            Reference::SameFuture => "same_future",
        }
    }
}

impl std::fmt::Display for Reference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Play one episode with `policy` driving while every reference forecasts
/// at each decision; the record, and each reference's scores in
/// [`Reference::ALL`]'s order.
pub fn play_with_references(
    config: &crate::scenario::ScenarioConfig,
    tier: crate::scenario::Tier,
    seed: u64,
    policy: &mut dyn crate::policy::Policy,
) -> (crate::episode::EpisodeRecord, Vec<ForecastMetrics>) {
    let (record, scores, _) = play_with_references_and_truth(config, tier, seed, policy);
    (record, scores)
}

/// [`play_with_references`], and the positions the forecasts were scored
/// against.
pub fn play_with_references_and_truth(
    config: &crate::scenario::ScenarioConfig,
    tier: crate::scenario::Tier,
    seed: u64,
    policy: &mut dyn crate::policy::Policy,
) -> (crate::episode::EpisodeRecord, Vec<ForecastMetrics>, Vec<crate::episode::ForecastTruth>) {
    let mut episode = crate::episode::Episode::new(config, tier, seed);
    episode.record_forecast_truth(config);
    policy.reset(crate::episode::policy_seed(episode.spec()));
    let mut forecasters: Vec<Box<dyn Forecaster>> = ForecasterKind::ALL.iter().map(|k| k.build()).collect();
    let mut turns: Vec<Vec<ForecastTurn>> = vec![Vec::new(); forecasters.len()];
    while !episode.is_done() {
        let obs = episode.observation();
        let cv = constant_velocity(obs);
        for (f, t) in forecasters.iter_mut().zip(turns.iter_mut()) {
            t.push(ForecastTurn {
                turn: obs.turn,
                time_s: obs.time_s,
                forecast: Some(f.forecast(obs)),
                constant_velocity: cv.clone(),
            });
        }
        let action = policy.act(obs);
        episode.step(action);
    }
    let kind = episode.spec().scenario;
    let truths = episode.forecast_truth().to_vec();
    let same_future = same_future_turns(kind, &turns[0], &truths);
    let record = episode.finish();
    let lets_you_go = record.disposition.ego_should_go();
    let evidence = record.timing.evidence_turn;
    let score = |t: &[ForecastTurn]| ForecastMetrics::compute(kind, t, &truths, lets_you_go, evidence);
    let mut scores: Vec<ForecastMetrics> = turns.iter().map(|t| score(t)).collect();
    scores.push(score(&same_future));
    (record, scores, truths)
}

/// The privileged same-future reference's turns: at each decision, where
/// the road users really were at each horizon (in the decision's frame),
/// given under both intents. A horizon the episode did not reach keeps
/// the constant-velocity figure (it is not scored).
pub(crate) fn same_future_turns(
    kind: ScenarioKind,
    turns: &[ForecastTurn],
    truths: &[crate::episode::ForecastTruth],
) -> Vec<ForecastTurn> {
    let relative = kind.def().tracks_relative_to_ego;
    let at = |time_s: f64| truths.iter().find(|t| (t.time_s - time_s).abs() < 1e-6);
    turns
        .iter()
        .map(|turn| {
            let mut future = turn.constant_velocity.clone();
            if let Some(now) = at(turn.time_s) {
                for (k, h) in HORIZONS_S.iter().enumerate() {
                    let Some(then) = at(turn.time_s + h) else { continue };
                    let shift = if relative { then.ego_travel_m - now.ego_travel_m } else { 0.0 };
                    for (r, at_h) in future.iter_mut().enumerate() {
                        if let Some(x) = then.actual.get(r) {
                            at_h[k] = x + shift;
                        }
                    }
                }
            }
            ForecastTurn { forecast: Some(Forecast::same(future)), ..turn.clone() }
        })
        .collect()
}

/// Every road user keeps its current (observed) velocity.
pub struct ConstantVelocity;

impl Forecaster for ConstantVelocity {
    fn forecast(&mut self, obs: &Observation) -> Forecast {
        Forecast::same(constant_velocity(obs))
    }
}

/// The constant-velocity future of the probe's road users: the position
/// moved by the velocity times the horizon, along the scene's axis, from
/// the figures as the scene text prints them (one decimal). A model that
/// forecasts constant velocity from what it reads matches this reference
/// exactly (skill 0), rather than paying for digits it was never shown.
pub fn constant_velocity(obs: &Observation) -> Vec<AtHorizons> {
    let kind = obs.scene.kind();
    let sign = kind.def().position_per_velocity;
    // As `Observation::rounded` rounds a track, without cloning the scene.
    let printed = |x: f64| crate::observation::round_to(x, 1);
    obs.scene
        .tracks()
        .iter()
        .take(forecast_tracks(kind))
        .map(|t| {
            let (position, velocity) = (printed(t.now.position_m), printed(t.now.velocity_mps));
            HORIZONS_S.map(|h| position + sign * velocity * h)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Episode;
    use crate::scenario::{ScenarioSet, Tier};

    #[test]
    fn every_forecast_prompt_is_neutral_and_shows_the_answers_shape() {
        for kind in ScenarioKind::ALL {
            let paragraph = prompt_paragraph(kind);
            let prompt = format!("{}{paragraph}", crate::instructions::SYSTEM_PROMPT);
            assert_eq!(crate::belief::check_neutral(&prompt), Ok(()), "{kind}");
            assert!(paragraph.contains(LETS_YOU_GO_KEY) && paragraph.contains(DOES_NOT_KEY), "{kind}");
            assert_eq!(paragraph.matches("[A").count(), forecast_tracks(kind), "{kind}: {paragraph}");
        }
    }

    #[test]
    fn constant_velocity_moves_along_each_scenes_axis() {
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            let episode = Episode::new(set.get(kind), Tier::T1, 7);
            let obs = episode.observation();
            let f = ConstantVelocity.forecast(obs);
            assert!(f.fits(kind), "{kind}");
            assert_eq!(f.lets_you_go, f.does_not);
            // From the scene as printed: the parsed-back text gives the
            // same forecast to the bit.
            let read = crate::observation::parse_scene(&crate::observation::render_scene(obs)).unwrap();
            let t = read.scene.tracks()[0].now;
            let moved = f.lets_you_go[0][1] - t.position_m;
            assert!((moved.abs() - 2.0 * t.velocity_mps.abs()).abs() < 1e-9, "{kind}");
            assert_eq!(constant_velocity(&read), f.lets_you_go, "{kind}");
        }
    }
}
