//! One environment session: the episode a client is playing, driven through
//! the same [`Episode`] that `eval` and `baselines` drive, and every value
//! the client can see. No I/O here: the HTTP and WebSocket front ends in
//! `envserver` only move these values in and out.
//!
//! What a client can see before `done` is built from the public
//! observation rounded to the precision the scene text prints (the same
//! information the model gets in `eval`), the turn counters, the
//! parser's verdict on the client's own action, and (when the reset asked
//! for a teacher) a built-in policy's move on that rounded observation. The disposition, the
//! evidence turn and the grades appear only in the terminal step's
//! metadata (and in the state once the episode is over).

use crate::action::{Action, ActionParseError, Maneuver, ParsedAction, parse_action};
use crate::episode::{Episode, policy_seed};
use crate::features::{features, nearest_discrete_action};
use crate::forecast::{ForecastMetrics, ForecastTurn};
#[cfg(test)]
use crate::instructions::SYSTEM_PROMPT;
use crate::observation::{Observation, render_scene};
use crate::policy::{Policy, PolicyKind};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use schemars::JsonSchema;
use serde::Serialize;
use serde_json::{Map, Value, json};

use super::request::{FieldError, FieldErrors};

/// The scenario a reset without `scenario` plays: the benchmark's first.
pub(crate) const DEFAULT_SCENARIO: ScenarioKind = ScenarioKind::ALL[0];
/// The tier a reset without `tier` plays.
pub(crate) const DEFAULT_TIER: Tier = Tier::T1;
/// Seeds the server draws for a reset without one stay below 2^53, so that
/// a client reading JSON numbers as doubles (JavaScript, some Python
/// tooling) keeps them exact. A client may pass any seed up to 2^64 - 1.
pub(crate) const DRAWN_SEED_LIMIT: u64 = 1 << 53;
/// Longest `episode_id` a client may choose (OpenEnv's own limit).
pub(crate) const MAX_EPISODE_ID_LEN: usize = 255;
/// Longest reply read from an action, as `eval --max-reply-bytes`'s
/// default: a longer one is a parse error (a firm stop), as in `eval`.
pub(crate) const MAX_REPLY_BYTES: usize = crate::llm::DEFAULT_MAX_REPLY_BYTES;

/// Why a session refused a message. The session itself is unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum SessionError {
    #[error("invalid message: {}", summary(.0))]
    Invalid(Vec<FieldError>),
    #[error("no episode yet: send reset first")]
    NotReset,
    #[error("episode {0} is over (done): send reset to start another")]
    EpisodeOver(String),
}

fn summary(errors: &[FieldError]) -> String {
    errors.iter().map(|e| format!("{}: {}", e.loc.join("."), e.msg)).collect::<Vec<_>>().join("; ")
}

/// Which forms of the observation a session's observations carry. Every
/// form holds the same information; a client takes the one it reads (an
/// LLM harness that forwards the whole observation to the model wants
/// `text` alone, a vision-language harness `image`; a network wants
/// `features`), and the messages shrink.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum View {
    /// `instructions`, `scene`, `public` and `features`.
    Full,
    /// `instructions` and `scene`.
    Text,
    /// `public`.
    Public,
    /// `features`.
    Features,
    /// `instructions`, `image` (the scene's picture) and `scene` as the one
    /// line sent with it (`eval --observation image`).
    Image,
    /// `instructions`, `image` and `scene` (`eval --observation both`).
    Both,
}

impl View {
    pub const NAMES: [&str; 6] = ["full", "text", "public", "features", "image", "both"];

    fn parse(s: &str) -> Option<View> {
        Some(match s {
            "full" => View::Full,
            "text" => View::Text,
            "public" => View::Public,
            "features" => View::Features,
            "image" => View::Image,
            "both" => View::Both,
            _ => return None,
        })
    }

    fn text(self) -> bool {
        matches!(self, View::Full | View::Text | View::Image | View::Both)
    }

    fn public(self) -> bool {
        matches!(self, View::Full | View::Public)
    }

    fn features(self) -> bool {
        matches!(self, View::Full | View::Features)
    }

    /// What a model is shown each turn, as `eval --observation` names it.
    fn observation(self) -> crate::rundir::ObservationMode {
        match self {
            View::Image => crate::rundir::ObservationMode::Image,
            View::Both => crate::rundir::ObservationMode::Both,
            _ => crate::rundir::ObservationMode::Text,
        }
    }
}

/// The fields a reset takes, all optional.
pub(crate) const RESET_FIELDS: [&str; 7] = ["scenario", "tier", "seed", "view", "episode_id", "teacher", "probe"];

/// What a reset asks for, validated.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ResetRequest {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub view: View,
    /// None: the server draws one (and returns it).
    pub seed: Option<u64>,
    pub episode_id: Option<String>,
    /// A built-in policy whose move on each observation the observations
    /// carry (`teacher`), for a learner that imitates it.
    pub teacher: Option<PolicyKind>,
    /// `"forecast"`: every step's reply may carry a forecast (as for `eval
    /// --probe forecast`), scored in the terminal step's grades.
    pub forecast: bool,
}

impl ResetRequest {
    /// Read a WebSocket reset's `data`: null (or absent) for every default,
    /// else an object of reset fields.
    pub fn from_data(data: &Value) -> Result<ResetRequest, SessionError> {
        if data.is_null() {
            return ResetRequest::from_fields(&Map::new());
        }
        let fields =
            super::request::object(data, "an object of reset fields").map_err(|e| SessionError::Invalid(vec![e]))?;
        ResetRequest::from_fields(fields)
    }

    /// Read a reset's `data`. Unknown fields are refused (a misspelt
    /// `senario` would otherwise silently play the default).
    pub fn from_fields(data: &Map<String, Value>) -> Result<ResetRequest, SessionError> {
        let mut errors = FieldErrors::default();
        let mut request = ResetRequest {
            scenario: DEFAULT_SCENARIO,
            tier: DEFAULT_TIER,
            view: View::Full,
            seed: None,
            episode_id: None,
            teacher: None,
            forecast: false,
        };
        for (key, value) in data {
            if value.is_null() {
                continue;
            }
            match key.as_str() {
                "scenario" => match value.as_str().map(str::parse::<ScenarioKind>) {
                    Some(Ok(k)) => request.scenario = k,
                    _ => errors.push(|| {
                        FieldError::new(
                            "enum",
                            key,
                            format!("expected one of {}, got {value}", scenario_names().join(", ")),
                        )
                    }),
                },
                "tier" => match tier_of(value) {
                    Some(t) => request.tier = t,
                    None => errors.push(|| FieldError::new("enum", key, format!("expected 1, 2 or 3, got {value}"))),
                },
                "seed" => match value.as_u64() {
                    Some(s) => request.seed = Some(s),
                    None => errors.push(|| {
                        FieldError::new(
                            "int_type",
                            key,
                            format!("expected a whole number from 0 to {}, got {value}", u64::MAX),
                        )
                    }),
                },
                "view" => match value.as_str().and_then(View::parse) {
                    Some(v) => request.view = v,
                    None => errors.push(|| {
                        FieldError::new("enum", key, format!("expected one of {}, got {value}", View::NAMES.join(", ")))
                    }),
                },
                "episode_id" => match value.as_str() {
                    Some(id) if !id.is_empty() && id.len() <= MAX_EPISODE_ID_LEN => {
                        request.episode_id = Some(id.to_string())
                    }
                    _ => errors.push(|| {
                        FieldError::new(
                            "string_type",
                            key,
                            format!("expected a string of 1 to {MAX_EPISODE_ID_LEN} bytes"),
                        )
                    }),
                },
                "teacher" => match value.as_str().map(str::parse::<PolicyKind>) {
                    Some(Ok(k)) => request.teacher = Some(k),
                    _ => errors.push(|| {
                        let names = PolicyKind::ALL.map(PolicyKind::name);
                        FieldError::new("enum", key, format!("expected one of {}, got {value}", names.join(", ")))
                    }),
                },
                "probe" => match value.as_str().map(str::parse::<crate::probe::Probe>) {
                    Some(Ok(p)) if !p.belief => request.forecast = p.forecast,
                    _ => {
                        errors.push(|| FieldError::new("enum", key, format!("expected forecast or none, got {value}")))
                    }
                },
                _ => errors.push(|| FieldError::unknown(key, &RESET_FIELDS)),
            }
        }
        errors.or(request).map_err(SessionError::Invalid)
    }
}

fn scenario_names() -> Vec<&'static str> {
    ScenarioKind::ALL.iter().map(|k| k.name()).collect()
}

/// A tier as a number (1) or a string ("1", "t1").
fn tier_of(value: &Value) -> Option<Tier> {
    match value {
        Value::Number(n) => n.as_u64().and_then(|t| t.to_string().parse().ok()),
        Value::String(s) => s.trim().trim_start_matches(['t', 'T']).parse().ok(),
        _ => None,
    }
}

/// Read a step's action: `{"reply": "<the model's whole reply>"}`, or the
/// benchmark's action object itself (`maneuver`, `acceleration`,
/// `steering`, `reasoning`). Either way the protective parser `eval` uses
/// reads it, so a malformed answer is a parse error and a firm stop, as in
/// `eval`. `metadata` (OpenEnv's) is ignored. Only a payload of the wrong
/// shape is refused (the session then stays where it was).
#[cfg(test)]
pub(crate) fn read_action(data: &Value) -> Result<ParsedAction, SessionError> {
    Ok(parse_reply(&read_reply(data)?))
}

/// The action of a reply's text (an oversized one is a parse error and a
/// firm stop, as `eval --max-reply-bytes` makes it).
fn parse_reply(text: &str) -> ParsedAction {
    if text.len() > MAX_REPLY_BYTES {
        return ParsedAction {
            action: Action::CONSERVATIVE,
            reasoning: None,
            errors: vec![ActionParseError::Oversized { limit: MAX_REPLY_BYTES }],
        };
    }
    parse_action(text)
}

/// A step's payload as the reply text a model would send: `reply` itself,
/// or the action's own fields written out as JSON.
fn read_reply(data: &Value) -> Result<String, SessionError> {
    let Some(fields) = data.as_object() else {
        return Err(SessionError::Invalid(vec![FieldError::whole(
            "dict_type",
            "expected an object: {\"reply\": text} or the action's fields",
        )]));
    };
    let text = match fields.get("reply") {
        Some(Value::String(reply)) => {
            if let Some(extra) = fields.keys().find(|k| !matches!(k.as_str(), "reply" | "metadata")) {
                return Err(SessionError::Invalid(vec![FieldError::new(
                    "extra_forbidden",
                    extra,
                    "send either reply or the action's own fields, not both",
                )]));
            }
            reply.clone()
        }
        Some(other) => {
            return Err(SessionError::Invalid(vec![FieldError::new(
                "string_type",
                "reply",
                format!("expected the reply as a string, got {other}"),
            )]));
        }
        // The action's own fields, as the reply text a model would send
        // (OpenEnv's `metadata` left out).
        None if fields.contains_key("metadata") => {
            let mut rest = fields.clone();
            rest.remove("metadata");
            Value::Object(rest).to_string()
        }
        None => data.to_string(),
    };
    Ok(text)
}

/// The observation a client receives. Its JSON schema is part of `/schema`.
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub(crate) struct EnvObservation {
    /// The benchmark's instructions: the system prompt `eval` sends, on
    /// the first observation only (absent afterwards). A harness that adds
    /// no system prompt of its own forwards it with the first scene.
    /// Views `full` and `text`.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "super::wire::text")]
    pub instructions: Option<String>,
    /// This turn's scene text, exactly the user message `eval` sends (the
    /// prompt `eval` renders is `instructions` as the system message, then
    /// one scene per turn). Views `full` and `text`.
    /// Under view `image`, the one line `eval --observation image` sends
    /// with the picture instead.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "super::wire::text")]
    pub scene: Option<String>,
    /// This turn's bird's-eye picture of the scene, a 512 x 512 PNG in
    /// base64: exactly the picture `eval --observation image|both` sends
    /// (docs/vision.md). Views `image` and `both`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// The public observation as structured values, rounded to the
    /// precision the scene text prints (the same information). Views
    /// `full` and `public`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub public: Option<Observation>,
    /// A fixed-length numeric vector of the same information, in SI units
    /// (layout: `feature_names` in `/metadata`). Views `full` and
    /// `features`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub features: Option<Vec<f64>>,
    /// The move the built-in policy the reset named as `teacher` makes on
    /// this observation; absent without one and once the episode is over.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub teacher: Option<TeacherMove>,
    /// 1-based index of the decision this observation asks for.
    pub turn: u32,
    pub turn_budget: u32,
    /// Decisions left, this one included (0 once the episode is over).
    pub turns_left: u32,
    pub scenario: String,
    pub tier: u8,
    pub seed: u64,
    pub episode_id: String,
    /// What the protective parser found wrong in the last action (each
    /// problem made it a firm stop, as in `eval`); empty when it was clean
    /// or on reset.
    pub parse_errors: Vec<String>,
    /// With the forecast probe (`probe` at reset): why the last reply's
    /// forecast could not be read, a probe parse error counted apart (the
    /// action is unaffected); absent when it was read.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probe_errors: Vec<String>,
    /// Empty until the episode is over; then the grades (see the step
    /// response's `metadata`).
    pub metadata: Map<String, Value>,
}

/// A teacher's move. A built-in policy sees only the public observation,
/// and the teacher is shown the rounded one the client reads, so its move
/// tells the client nothing the observation does not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
pub(crate) struct TeacherMove {
    pub maneuver: Maneuver,
    pub acceleration: f64,
    /// The index in `/metadata`'s `discrete_actions` of the action nearest
    /// this move: of those that go when it goes, the one commanding the
    /// nearest acceleration at the ego's current speed.
    pub discrete_action: usize,
}

/// One reply to a reset or a step, in OpenEnv's shape.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct StepReply {
    pub observation: EnvObservation,
    /// Null on reset; 0 on every step but the last; the episode reward on
    /// the step that ends the episode.
    pub reward: Option<f64>,
    pub done: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub metadata: Option<Map<String, Value>>,
}

/// The state a client can read at any time. Nothing hidden before `done`.
#[derive(Debug, Clone, Default, Serialize, JsonSchema)]
pub(crate) struct EnvState {
    /// The current episode's id (null before the first reset).
    pub episode_id: Option<String>,
    /// Steps taken in the current episode.
    pub step_count: u32,
    pub scenario: Option<String>,
    pub tier: Option<u8>,
    pub seed: Option<u64>,
    /// 1-based index of the next decision.
    pub turn: Option<u32>,
    pub turn_budget: Option<u32>,
    pub done: bool,
    /// Steps whose action the protective parser could not read (each was
    /// a firm stop).
    pub parse_errors: u32,
    /// success, collision or timeout once the episode is over.
    pub outcome: Option<String>,
    /// The other road user's hidden disposition, once the episode is over.
    pub disposition: Option<String>,
}

struct Live {
    episode: Episode,
    view: View,
    episode_id: String,
    steps: u32,
    parse_errors: u32,
    /// The grades, once the episode is over.
    graded: Option<Map<String, Value>>,
    teacher: Option<(PolicyKind, Box<dyn Policy>)>,
    /// The teacher's move on the current observation.
    advice: Option<TeacherMove>,
    /// With the forecast probe: each step's forecast so far.
    forecasts: Option<Vec<ForecastTurn>>,
}

impl Live {
    /// Ask the teacher (if any) for its move on the current observation;
    /// called once per observation, as a policy is in `baselines`.
    fn advise(&mut self) {
        self.advice = match (&mut self.teacher, self.graded.is_some()) {
            (Some((_, teacher)), false) => {
                let o = self.episode.observation().rounded();
                let a = teacher.act(&o);
                let discrete_action = nearest_discrete_action(a, o.ego.speed_mps, o.ego.speed_limit_mps);
                Some(TeacherMove { maneuver: a.maneuver, acceleration: a.acceleration, discrete_action })
            }
            _ => None,
        };
    }
}

/// A session: at most one episode at a time.
#[derive(Default)]
pub(crate) struct Session {
    live: Option<Live>,
}

impl Session {
    /// Start the episode `request` names (replacing any current one).
    /// `draw` supplies a seed when the request has none; `new_id` an
    /// episode id.
    pub fn reset(
        &mut self,
        scenarios: &ScenarioSet,
        request: ResetRequest,
        draw: impl FnOnce() -> u64,
        new_id: impl FnOnce() -> String,
    ) -> StepReply {
        let seed = request.seed.unwrap_or_else(draw);
        let config = scenarios.get(request.scenario);
        let mut episode = Episode::new(config, request.tier, seed);
        if request.forecast {
            episode.record_forecast_truth(config);
        }
        let id = request.episode_id.unwrap_or_else(new_id);
        self.start(episode, request.view, id, request.teacher, request.forecast)
    }

    fn start(
        &mut self,
        episode: Episode,
        view: View,
        episode_id: String,
        teacher: Option<PolicyKind>,
        forecast: bool,
    ) -> StepReply {
        let teacher = teacher.map(|kind| {
            let mut policy = kind.build();
            policy.reset(policy_seed(episode.spec()));
            (kind, policy)
        });
        let forecasts = forecast.then(Vec::new);
        let mut live = Live {
            episode,
            view,
            episode_id,
            steps: 0,
            parse_errors: 0,
            graded: None,
            teacher,
            advice: None,
            forecasts,
        };
        live.advise();
        let reply =
            StepReply { observation: observe(&live, true, Vec::new()), reward: None, done: false, metadata: None };
        self.live = Some(live);
        reply
    }

    /// Apply one action payload.
    pub fn step(&mut self, data: &Value) -> Result<StepReply, SessionError> {
        let live = self.live.as_mut().ok_or(SessionError::NotReset)?;
        if live.graded.is_some() {
            return Err(SessionError::EpisodeOver(live.episode_id.clone()));
        }
        let text = read_reply(data)?;
        let parsed = parse_reply(&text);
        if !parsed.is_clean() {
            live.parse_errors += 1;
        }
        let errors: Vec<String> = parsed.errors.iter().map(ToString::to_string).collect();
        let mut probe_errors = Vec::new();
        if let Some(forecasts) = live.forecasts.as_mut() {
            let turn = read_forecast(&live.episode, &text);
            if let Err(e) = turn.forecast.as_ref() {
                probe_errors.push(format!("forecast: {e}"));
            }
            forecasts.push(turn.stated());
        }
        live.steps += 1;
        let done = live.episode.step(parsed.action).is_some();
        let mut reward = Some(0.0);
        if done {
            let teacher = live.teacher.as_ref().map(|(kind, _)| *kind);
            let mut graded = grades(&live.episode, live.parse_errors, teacher);
            if let Some(forecasts) = &live.forecasts {
                graded.insert("forecast".to_string(), forecast_grades(&live.episode, forecasts));
            }
            reward = graded.get("reward").and_then(Value::as_f64);
            live.graded = Some(graded);
        }
        live.advise();
        let mut observation = observe(live, false, errors);
        observation.probe_errors = probe_errors;
        Ok(StepReply { observation, reward, done, metadata: live.graded.clone() })
    }

    pub fn state(&self) -> EnvState {
        let Some(live) = self.live.as_ref() else { return EnvState::default() };
        let spec = live.episode.spec();
        let o = live.episode.observation();
        let over = live.graded.is_some();
        EnvState {
            episode_id: Some(live.episode_id.clone()),
            step_count: live.steps,
            scenario: Some(spec.scenario.name().to_string()),
            tier: Some(spec.tier.number()),
            seed: Some(spec.seed),
            turn: Some(if over { live.steps } else { o.turn }),
            turn_budget: Some(o.turn_budget),
            done: over,
            parse_errors: live.parse_errors,
            outcome: live.episode.outcome().map(|x| x.name().to_string()),
            disposition: over.then(|| live.episode.disposition().name().to_string()),
        }
    }
}

/// The picture of `o` as base64 PNG (empty if it cannot be drawn, which a
/// registered scenario never is).
fn picture_base64(o: &Observation) -> String {
    use base64::Engine;
    crate::picture::png(o).map(|png| base64::engine::general_purpose::STANDARD.encode(png)).unwrap_or_default()
}

/// What the client sees of the episode now.
fn observe(live: &Live, first: bool, parse_errors: Vec<String>) -> EnvObservation {
    let o = live.episode.observation();
    let spec = live.episode.spec();
    let over = live.graded.is_some();
    let view = live.view;
    let public = (view.public() || view.features()).then(|| o.rounded());
    EnvObservation {
        instructions: (first && view.text()).then(|| {
            let probe = crate::probe::Probe { forecast: live.forecasts.is_some(), ..Default::default() };
            crate::instructions::system_prompt(probe, spec.scenario, view.observation())
        }),
        scene: view.text().then(|| match view {
            View::Image => crate::picture::user_line(o),
            _ => render_scene(o),
        }),
        image: matches!(view, View::Image | View::Both).then(|| picture_base64(o)),
        features: public.as_ref().filter(|_| view.features()).map(|p| features(p, spec.tier)),
        teacher: live.advice,
        public: public.filter(|_| view.public()),
        turn: o.turn,
        turn_budget: o.turn_budget,
        turns_left: if over { 0 } else { o.turns_left() },
        scenario: spec.scenario.name().to_string(),
        tier: spec.tier.number(),
        seed: spec.seed,
        episode_id: live.episode_id.clone(),
        parse_errors,
        probe_errors: Vec::new(),
        metadata: live.graded.clone().unwrap_or_default(),
    }
}

/// One step's forecast as read from its reply, with the constant-velocity
/// forecast of the observation it answered.
struct ReadForecast {
    turn: u32,
    time_s: f64,
    forecast: Result<crate::forecast::Forecast, crate::action::ForecastParseError>,
    constant_velocity: Vec<crate::forecast::AtHorizons>,
}

impl ReadForecast {
    fn stated(self) -> ForecastTurn {
        ForecastTurn {
            turn: self.turn,
            time_s: self.time_s,
            forecast: self.forecast.ok(),
            constant_velocity: self.constant_velocity,
        }
    }
}

fn read_forecast(episode: &Episode, reply: &str) -> ReadForecast {
    let o = episode.observation();
    let forecast = if reply.len() > MAX_REPLY_BYTES {
        Err(crate::action::ForecastParseError::NoAnswer)
    } else {
        crate::forecast::parse_answer(reply, episode.spec().scenario)
    };
    ReadForecast { turn: o.turn, time_s: o.time_s, forecast, constant_velocity: crate::forecast::constant_velocity(o) }
}

/// The forecast probe's scores of a finished episode (`forecast` in the
/// terminal grades): the episode's sums, and its means and skill.
fn forecast_grades(episode: &Episode, forecasts: &[ForecastTurn]) -> Value {
    let spec = episode.spec();
    let lets_you_go = episode.disposition().ego_should_go();
    let evidence = episode.timing().evidence_turn;
    let m = ForecastMetrics::compute(spec.scenario, forecasts, episode.forecast_truth(), lets_you_go, evidence);
    json!({ "episode": m, "summary": crate::forecast::ForecastSummary::of(std::iter::once(&m)) })
}

/// The terminal metadata: the outcome, the grades, the evidence timing,
/// now the disposition, and the teacher the episode was played with (null
/// for none), so that no graded episode hides the help it had.
fn grades(episode: &Episode, parse_errors: u32, teacher: Option<PolicyKind>) -> Map<String, Value> {
    let (outcome, g) = episode.grades();
    let t = episode.timing();
    let value = json!({
        "outcome": outcome.name(),
        "reward": g.reward,
        "decision_correctness": g.decision_correctness,
        "disposition": episode.disposition().name(),
        "evidence_turn": t.evidence_turn,
        "commitment_turn": t.commitment_turn,
        "choice": t.choice,
        "first_in": t.first_in,
        "guessed": t.guessed(),
        "decisions": g.diagnostics.decisions,
        "parse_errors": parse_errors,
        "teacher": teacher.map(PolicyKind::name),
        "efficiency": g.diagnostics.efficiency,
        "comfort": g.diagnostics.comfort,
        "min_gap_m": g.diagnostics.min_gap_m,
        "hard_brakes": g.diagnostics.hard_brakes,
        "right_of_way_violations": g.diagnostics.right_of_way_violations,
    });
    match value {
        Value::Object(map) => map,
        _ => unreachable!("a json! object literal is an object"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::Maneuver;

    fn data(v: Value) -> Map<String, Value> {
        v.as_object().cloned().unwrap()
    }

    #[test]
    fn reset_fields_have_defaults_and_refuse_unknown_ones() {
        let r = ResetRequest::from_fields(&Map::new()).unwrap();
        assert_eq!((r.scenario, r.tier, r.seed, r.episode_id), (DEFAULT_SCENARIO, DEFAULT_TIER, None, None));
        let r = ResetRequest::from_fields(&data(
            json!({"scenario": "contested_merge", "tier": "t3", "seed": 7, "view": "features"}),
        ))
        .unwrap();
        assert_eq!(
            (r.scenario, r.tier, r.seed, r.view),
            (ScenarioKind::ContestedMerge, Tier::T3, Some(7), View::Features)
        );
        let Err(SessionError::Invalid(errors)) =
            ResetRequest::from_fields(&data(json!({"senario": "x", "tier": 4, "seed": -1, "episode_id": ""})))
        else {
            panic!("refused")
        };
        let fields: Vec<&str> = errors.iter().map(|e| e.loc[0].as_str()).collect();
        assert_eq!(fields, ["episode_id", "seed", "senario", "tier"]);
        let r = ResetRequest::from_fields(&data(json!({"teacher": "expert_hedge"}))).unwrap();
        assert_eq!(r.teacher, Some(crate::policy::PolicyKind::ExpertHedge));
        for bad in [
            json!({"seed": 1.5}),
            json!({"seed": "3"}),
            json!({"scenario": 3}),
            json!({"view": "all"}),
            json!({"teacher": "oracle"}),
        ] {
            assert!(ResetRequest::from_fields(&data(bad)).is_err());
        }
    }

    #[test]
    fn actions_are_read_by_evals_parser_whatever_their_form() {
        let direct = read_action(&json!({"maneuver": "yield", "acceleration": 0.4, "metadata": {"k": 1}})).unwrap();
        assert_eq!(direct.action, Action::new(Maneuver::Yield, 0.4));
        assert!(direct.is_clean());
        let reply = "I will wait.\n```json\n{\"maneuver\": \"yield\", \"acceleration\": 0.4}\n```";
        assert_eq!(read_action(&json!({ "reply": reply })).unwrap(), parse_action(reply));
        let bad = read_action(&json!({"maneuver": "fly", "acceleration": 0.4})).unwrap();
        assert_eq!(bad.action, Action::CONSERVATIVE);
        assert!(!bad.is_clean());
        let huge = read_action(&json!({ "reply": "x".repeat(MAX_REPLY_BYTES + 1) })).unwrap();
        assert_eq!(huge.errors, [ActionParseError::Oversized { limit: MAX_REPLY_BYTES }]);
        for wrong in [json!("proceed"), json!({"reply": 3}), json!({"reply": "{}", "maneuver": "stop"})] {
            assert!(matches!(read_action(&wrong), Err(SessionError::Invalid(_))), "{wrong}");
        }
    }

    #[test]
    fn a_session_plays_the_episode_eval_plays_and_grades_it_at_the_end() {
        let set = ScenarioSet::default();
        let mut session = Session::default();
        assert_eq!(session.step(&json!({"reply": "{}"})).unwrap_err(), SessionError::NotReset);
        let request = ResetRequest {
            scenario: ScenarioKind::PedestrianFeint,
            tier: Tier::T2,
            view: View::Full,
            seed: Some(11),
            episode_id: None,
            teacher: None,
            forecast: false,
        };
        let first = session.reset(&set, request, || unreachable!(), || "ep".to_string());
        let mut episode = Episode::new(set.get(ScenarioKind::PedestrianFeint), Tier::T2, 11);
        assert_eq!(first.observation.scene, Some(render_scene(episode.observation())));
        assert_eq!(first.observation.instructions.as_deref(), Some(SYSTEM_PROMPT));
        assert_eq!(first.reward, None);
        let mut last = first;
        let mut steps = 0;
        while !last.done {
            let action = Action::new(Maneuver::Proceed, 1.0);
            episode.step(action);
            last = session.step(&serde_json::to_value(action).unwrap()).unwrap();
            steps += 1;
            if !last.done {
                assert_eq!(last.reward, Some(0.0));
                assert_eq!(last.observation.scene, Some(render_scene(episode.observation())));
                assert!(last.observation.instructions.is_none() && last.observation.metadata.is_empty());
                assert_eq!(session.state().disposition, None);
            }
        }
        let record = episode.finish();
        assert_eq!(last.reward, Some(record.grades.reward));
        let meta = last.metadata.unwrap();
        assert_eq!(meta["outcome"], record.outcome.name());
        assert_eq!(meta["disposition"], record.disposition.name());
        assert_eq!(meta["teacher"], Value::Null);
        assert_eq!(session.state().step_count, steps);
        assert_eq!(session.state().disposition.as_deref(), Some(record.disposition.name()));
        assert_eq!(session.step(&json!({"reply": "{}"})).unwrap_err(), SessionError::EpisodeOver("ep".to_string()));
    }

    /// The teacher's move is the one its policy makes on the observation
    /// the client reads, with the nearest discrete action; following that
    /// action plays the expert to its success; the move is gone at the end.
    #[test]
    fn a_teacher_moves_on_the_observation_the_client_reads() {
        use crate::features::DISCRETE_ACTIONS;
        use crate::policy::PolicyKind;
        let set = ScenarioSet::default();
        let mut won = 0;
        for seed in 0..20u64 {
            let mut session = Session::default();
            let request = ResetRequest {
                scenario: ScenarioKind::ContestedMerge,
                tier: Tier::T1,
                view: View::Public,
                seed: Some(seed),
                episode_id: None,
                teacher: Some(PolicyKind::Expert),
                forecast: false,
            };
            let mut reply = session.reset(&set, request, || unreachable!(), || "ep".into());
            let mut expert = PolicyKind::Expert.build();
            while !reply.done {
                let advice = reply.observation.teacher.expect("a move on every observation");
                let own = expert.act(reply.observation.public.as_ref().unwrap());
                assert_eq!((advice.maneuver, advice.acceleration), (own.maneuver, own.acceleration));
                let chosen = DISCRETE_ACTIONS[advice.discrete_action];
                assert_eq!(chosen.maneuver.is_go(), own.maneuver.is_go());
                reply = session.step(&serde_json::to_value(chosen).unwrap()).unwrap();
            }
            assert!(reply.observation.teacher.is_none());
            let graded = reply.metadata.unwrap();
            assert_eq!(graded["teacher"], "expert");
            won += usize::from(graded["outcome"] == "success");
        }
        assert!(won >= 19, "{won} of 20");
    }

    /// The rules forecaster's forecast of a reply's public observation, as
    /// a reply's `forecast` field.
    fn rules_forecast(reply: &StepReply) -> Value {
        rules_forecast_of(reply.observation.public.as_ref().unwrap())
    }

    fn rules_forecast_of(o: &Observation) -> Value {
        use crate::forecast::{DOES_NOT_KEY, Forecaster, LETS_YOU_GO_KEY};
        let f = crate::forecast::rules::RulesForecaster.forecast(o);
        json!({ LETS_YOU_GO_KEY: f.lets_you_go, DOES_NOT_KEY: f.does_not })
    }

    #[test]
    fn a_forecast_probe_episode_reads_each_replys_forecast_apart_and_grades_it_at_the_end() {
        use crate::policy::PolicyKind;
        let set = ScenarioSet::default();
        let refused = ResetRequest::from_fields(&data(json!({"probe": "belief"})));
        assert!(matches!(refused, Err(SessionError::Invalid(_))), "{refused:?}");
        let request =
            ResetRequest::from_fields(&data(json!({"scenario": "yield_standoff", "seed": 3, "probe": "forecast"})))
                .unwrap();
        let mut session = Session::default();
        let mut reply = session.reset(&set, request, || 0, || "ep".into());
        let instructions = reply.observation.instructions.clone().unwrap();
        assert!(instructions.starts_with(SYSTEM_PROMPT) && instructions.contains(crate::forecast::LETS_YOU_GO_KEY));
        let mut expert = PolicyKind::Expert.build();
        let mut turn = 0;
        while !reply.done {
            let mut payload = serde_json::to_value(expert.act(reply.observation.public.as_ref().unwrap())).unwrap();
            // Every fifth reply without its forecast: a probe error only.
            if turn % 5 != 4 {
                payload["forecast"] = rules_forecast(&reply);
            }
            reply = session.step(&payload).unwrap();
            assert!(reply.observation.parse_errors.is_empty(), "{:?}", reply.observation.parse_errors);
            assert_eq!(reply.observation.probe_errors.len(), usize::from(turn % 5 == 4), "turn {turn}");
            turn += 1;
        }
        let forecast = &reply.metadata.as_ref().unwrap()["forecast"];
        let missing = forecast["episode"]["probe_errors"].as_u64().unwrap();
        assert_eq!(missing, (turn / 5) as u64, "{forecast}");
        // The rules forecaster, from the rounded observation, is within
        // centimetres of where the car was (here, a car driving through).
        let error = forecast["summary"]["error_true_m"][1].as_f64().unwrap();
        assert!(error < 0.2, "{forecast}");
        // A run without the probe grades no forecast.
        let plain = ResetRequest::from_fields(&data(json!({"seed": 3}))).unwrap();
        let mut session = Session::default();
        let mut reply = session.reset(&set, plain, || 0, || "ep".into());
        while !reply.done {
            reply = session.step(&json!({"maneuver": "proceed", "acceleration": 0.5})).unwrap();
        }
        assert!(reply.metadata.unwrap().get("forecast").is_none());
    }

    /// Everything a client can read (the reset and step replies, the
    /// state, the scene's picture under views `image` and `both`) is
    /// byte-identical under both dispositions of a seed until the evidence
    /// turn, for every scenario and tier, driven by the expert (which reads
    /// what the client reads) and by a blind schedule.
    #[test]
    fn nothing_a_client_sees_depends_on_the_disposition_before_the_evidence() {
        use crate::policy::{Policy, PolicyKind};
        let set = ScenarioSet::default();
        let mut compared = 0;
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..25u64 {
                    for expert in [true, false] {
                        let [a, b] = kind.dispositions();
                        // Half the episodes with the forecast probe: its
                        // instructions and probe errors are on the screen too.
                        let forecast = seed % 2 == 0;
                        let mut sessions = [a, b].map(|d| {
                            let mut s = Session::default();
                            // Every teacher in turn: its move is on the screen too.
                            let teacher = PolicyKind::ALL[seed as usize % PolicyKind::ALL.len()];
                            let mut episode = Episode::with_disposition(set.get(kind), tier, seed, d);
                            if forecast {
                                episode.record_forecast_truth(set.get(kind));
                            }
                            // Some sessions see the scene's picture instead of its values.
                            let view = match seed % 5 {
                                1 => View::Image,
                                3 => View::Both,
                                _ => View::Full,
                            };
                            let first = s.start(episode, view, "ep".into(), Some(teacher), forecast);
                            (s, first)
                        });
                        // The evidence turn of the first disposition's play.
                        let mut policy: Box<dyn Policy> = PolicyKind::Expert.build();
                        let mut turn = 1;
                        loop {
                            let [(sa, ra), (sb, rb)] = &sessions;
                            let evidence = sa.live.as_ref().unwrap().episode.timing().evidence_turn;
                            if ra.done || rb.done || evidence.is_some_and(|e| turn >= e) {
                                break;
                            }
                            let text = |r: &StepReply| serde_json::to_string(r).unwrap();
                            assert_eq!(text(ra), text(rb), "{kind} t{tier} seed {seed} turn {turn}");
                            let state = |s: &Session| serde_json::to_string(&s.state()).unwrap();
                            assert_eq!(state(sa), state(sb));
                            compared += 1;
                            let seen = sa.live.as_ref().unwrap().episode.observation().rounded();
                            let seen = ra.observation.public.as_ref().unwrap_or(&seen);
                            let action = if expert {
                                policy.act(seen)
                            } else {
                                Action::new(crate::action::Maneuver::Proceed, if turn % 3 == 0 { 0.0 } else { 0.7 })
                            };
                            let mut payload = serde_json::to_value(action).unwrap();
                            if forecast && turn % 2 == 0 {
                                payload["forecast"] = rules_forecast_of(seen);
                            }
                            for (s, r) in sessions.iter_mut() {
                                *r = s.step(&payload).unwrap();
                            }
                            turn += 1;
                        }
                    }
                }
            }
        }
        assert!(compared > 1500, "{compared}");
    }

    /// View `image` carries the instructions for pictures, the one line and
    /// the picture `eval --observation image` sends; `both` the scene text
    /// beside the picture.
    #[test]
    fn the_image_view_carries_what_eval_sends_with_a_picture() {
        use base64::Engine;
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            for (view, mode) in [
                (View::Image, crate::rundir::ObservationMode::Image),
                (View::Both, crate::rundir::ObservationMode::Both),
            ] {
                let mut s = Session::default();
                let episode = Episode::new(set.get(kind), Tier::T2, 5);
                let obs = *episode.observation();
                let first = s.start(episode, view, "ep".into(), None, false);
                let o = &first.observation;
                let png = base64::engine::general_purpose::STANDARD.decode(o.image.as_deref().unwrap()).unwrap();
                assert_eq!(png, crate::picture::png(&obs).unwrap(), "{kind}");
                let line = if view == View::Image { crate::picture::user_line(&obs) } else { render_scene(&obs) };
                assert_eq!(o.scene.as_deref(), Some(line.as_str()));
                let prompt = crate::instructions::system_prompt(crate::probe::Probe::NONE, kind, mode);
                assert_eq!(o.instructions.as_deref(), Some(prompt.as_str()));
                assert!(o.public.is_none() && o.features.is_none());
                let next = s.step(&json!({"maneuver": "yield", "acceleration": 0.5})).unwrap();
                assert!(next.observation.instructions.is_none() && next.observation.image.is_some());
            }
        }
    }
}
