//! Scenarios: their identities, tiers, hidden dispositions, and the TOML
//! parameter files that are compiled into the binary and can be overridden.

pub mod contested_merge;
mod def;
pub mod pedestrian_feint;
mod scene;
mod track;
pub mod world;
pub mod yield_standoff;

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

pub use contested_merge::MergeParams;
pub(crate) use def::{ScenarioDef, ScenarioParams, TrackLabel, load};
pub use pedestrian_feint::PedestrianParams;
pub use scene::Scene;
pub use track::{HISTORY_LEN, HISTORY_SPACING_S, ReadingNoise, Sample, Track};
pub use yield_standoff::YieldParams;

/// A scenario: a handle on its one definition (`ScenarioDef`, in the
/// scenario's own file). Two handles are the same scenario when they name
/// the same one; records and the command line spell it by name.
#[derive(Clone, Copy)]
pub struct ScenarioKind(&'static ScenarioDef);

#[allow(non_upper_case_globals)] // named as the scenarios were when this was an enum
impl ScenarioKind {
    pub const YieldStandoff: ScenarioKind = ScenarioKind(&yield_standoff::DEF);
    pub const PedestrianFeint: ScenarioKind = ScenarioKind(&pedestrian_feint::DEF);
    pub const ContestedMerge: ScenarioKind = ScenarioKind(&contested_merge::DEF);

    /// The benchmark's scenarios, in the order of every table. The only
    /// list of them: a name is looked up here.
    pub const ALL: [ScenarioKind; 3] =
        [ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint, ScenarioKind::ContestedMerge];

    /// The scenario's definition: the one place its facts are read from.
    pub(crate) fn def(self) -> &'static ScenarioDef {
        self.0
    }

    pub fn name(self) -> &'static str {
        self.def().name
    }

    /// The neutral name of the scene's geometry, as the scene text prints
    /// it: it names the place, never a behaviour to expect.
    pub fn scene_name(self) -> &'static str {
        self.def().scene_name
    }

    /// How the plan view of this scenario is read (for trajectory plots
    /// and the drill-down): which coordinate is each road user's progress
    /// along its path, where position 0 is, and the other road users'
    /// roles and frames.
    pub fn plan_axes(self) -> PlanAxes {
        self.def().plan_axes
    }

    pub fn from_scene_name(name: &str) -> Option<ScenarioKind> {
        ScenarioKind::ALL.into_iter().find(|k| k.scene_name() == name)
    }

    /// Small stable id mixed into RNG keys (never change one).
    pub(crate) fn rng_id(self) -> u64 {
        self.def().rng_id
    }

    /// The two hidden dispositions of this scenario, the one that requires
    /// the ego to go first listed second.
    pub fn dispositions(self) -> [Disposition; 2] {
        self.def().dispositions
    }

    /// The scene text's "Situation:" paragraph.
    pub(crate) fn situation(self) -> &'static str {
        self.def().situation
    }

    /// The road users' labels in the scene text, in the scene's order.
    pub(crate) fn track_labels(self) -> &'static [TrackLabel] {
        self.def().track_labels
    }

    /// How many numbers the ego's place takes on the "You:" line.
    pub(crate) fn place_numbers(self) -> usize {
        self.def().place_fields.len()
    }

    /// The current sample of a road user, e.g. "21.0 m to the conflict
    /// zone, speed 9.4 m/s", from its formatted position and velocity.
    pub(crate) fn track_now(self, position: &str, velocity: &str) -> String {
        (self.def().track_now)(position, velocity)
    }
}

impl PartialEq for ScenarioKind {
    fn eq(&self, other: &ScenarioKind) -> bool {
        self.name() == other.name()
    }
}

impl Eq for ScenarioKind {}

impl std::hash::Hash for ScenarioKind {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.name().hash(state);
    }
}

impl Ord for ScenarioKind {
    /// The order of [`ScenarioKind::ALL`] (by RNG id, which follows it).
    fn cmp(&self, other: &ScenarioKind) -> std::cmp::Ordering {
        (self.def().rng_id, self.name()).cmp(&(other.def().rng_id, other.name()))
    }
}

impl PartialOrd for ScenarioKind {
    fn partial_cmp(&self, other: &ScenarioKind) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl fmt::Debug for ScenarioKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for ScenarioKind {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for ScenarioKind {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = std::borrow::Cow::<str>::deserialize(deserializer)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

impl fmt::Display for ScenarioKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The plan-view reading of a scenario (see [`ScenarioKind::plan_axes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanAxes {
    /// The ego progresses along y (else x).
    pub ego_along_y: bool,
    /// The other road users progress along y (else x).
    pub others_along_y: bool,
    /// What position 0 along the paths is.
    pub zero_label: &'static str,
    /// The road users other than the ego, in the order of the plan-view
    /// points after the ego's (and of the scene text's tracks).
    pub road_users: &'static [RoadUser],
}

impl PlanAxes {
    /// Progress of the ego (`ego`) or another road user along its path.
    pub fn along(&self, p: &world::PlanPoint, ego: bool) -> f64 {
        let along_y = if ego { self.ego_along_y } else { self.others_along_y };
        if along_y { p.y } else { p.x }
    }

    /// The role of the `k`-th road user other than the ego ("road user
    /// k+1" beyond the scenario's list, which a well-formed record never
    /// reaches).
    pub fn role(&self, k: usize) -> std::borrow::Cow<'static, str> {
        match self.road_users.get(k) {
            Some(u) => u.role.into(),
            None => format!("road user {}", k + 1).into(),
        }
    }
}

/// A road user other than the ego, as figures and the drill-down name and
/// place it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadUser {
    /// Its role in the scenario ("lane car", "follower").
    pub role: &'static str,
    /// For a road user that crosses the ego's road: the scene text's
    /// lateral frame of its position. `None`: it travels along a path whose
    /// progress shares the ego's axis.
    pub lateral: Option<LateralFrame>,
}

/// A lateral frame across the ego's road, the one the scene text states
/// (the pedestrian's position "from the near kerb"), so that figures and
/// the drill-down show the numbers the model read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateralFrame {
    /// What the value measures, for an axis title ("from the near kerb").
    pub measured: &'static str,
    /// The frame's value is the plan view's y plus this (m).
    pub plan_offset: f64,
    /// Lines of the road in the frame: (value, label).
    pub marks: [(f64, &'static str); 2],
    /// Where the road user is in the ego's path, in the frame: [lo, hi].
    pub in_path: (f64, f64),
}

impl LateralFrame {
    /// A plan-view point's value in this frame.
    pub fn of(&self, p: &world::PlanPoint) -> f64 {
        p.y + self.plan_offset
    }
}

#[derive(Debug, thiserror::Error)]
#[error("unknown scenario '{0}' (expected {list})", list = scenario_names())]
pub struct UnknownScenario(String);

/// The benchmark's scenario names as a message lists them: "a, b or c".
fn scenario_names() -> String {
    let names: Vec<&str> = ScenarioKind::ALL.iter().map(|k| k.name()).collect();
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => names.join(""),
    }
}

impl FromStr for ScenarioKind {
    type Err = UnknownScenario;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ScenarioKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| UnknownScenario(s.to_string()))
    }
}

/// Difficulty tier: 1 is the plain task; 2 and 3 change the information
/// structure (see docs/scenarios.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub enum Tier {
    T1,
    T2,
    T3,
}

impl Tier {
    pub const ALL: [Tier; 3] = [Tier::T1, Tier::T2, Tier::T3];
    pub fn number(self) -> u8 {
        match self {
            Tier::T1 => 1,
            Tier::T2 => 2,
            Tier::T3 => 3,
        }
    }
}

impl From<Tier> for u8 {
    fn from(t: Tier) -> u8 {
        t.number()
    }
}

#[derive(Debug, thiserror::Error)]
#[error("unknown tier '{0}' (expected 1, 2 or 3)")]
pub struct UnknownTier(String);

impl TryFrom<u8> for Tier {
    type Error = UnknownTier;
    fn try_from(n: u8) -> Result<Self, Self::Error> {
        match n {
            1 => Ok(Tier::T1),
            2 => Ok(Tier::T2),
            3 => Ok(Tier::T3),
            _ => Err(UnknownTier(n.to_string())),
        }
    }
}

impl FromStr for Tier {
    type Err = UnknownTier;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "1" => Ok(Tier::T1),
            "2" => Ok(Tier::T2),
            "3" => Ok(Tier::T3),
            other => Err(UnknownTier(other.to_string())),
        }
    }
}

impl fmt::Display for Tier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// The other road user's hidden intent. Privileged: only the simulator and
/// the graders read it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Disposition {
    /// Drives through / holds the gap: the ego must give way.
    Committed,
    /// Brakes and waits for the ego: the ego should go.
    Yielder,
    /// Steps in and crosses: the ego must give way.
    Crosser,
    /// Lurches and stops short: the ego should go.
    Feinter,
    /// Opens a gap ahead of itself: the ego should merge ahead.
    MakesRoom,
}

impl Disposition {
    /// Whether this disposition requires the ego to go first (otherwise it
    /// must give way).
    pub fn ego_should_go(self) -> bool {
        matches!(self, Disposition::Yielder | Disposition::Feinter | Disposition::MakesRoom)
    }

    pub fn name(self) -> &'static str {
        match self {
            Disposition::Committed => "committed",
            Disposition::Yielder => "yielder",
            Disposition::Crosser => "crosser",
            Disposition::Feinter => "feinter",
            Disposition::MakesRoom => "makes_room",
        }
    }
}

impl fmt::Display for Disposition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A uniform range written `[lo, hi]` in TOML.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "[f64; 2]", into = "[f64; 2]")]
pub struct Range {
    pub lo: f64,
    pub hi: f64,
}

impl TryFrom<[f64; 2]> for Range {
    type Error = String;
    fn try_from([lo, hi]: [f64; 2]) -> Result<Self, Self::Error> {
        if !lo.is_finite() || !hi.is_finite() {
            return Err("range bounds must be finite numbers".into());
        }
        if lo > hi {
            return Err(format!("range [{lo}, {hi}] has its lower bound above its upper bound"));
        }
        Ok(Range { lo, hi })
    }
}

impl From<Range> for [f64; 2] {
    fn from(r: Range) -> [f64; 2] {
        [r.lo, r.hi]
    }
}

impl Range {
    pub fn sample(&self, rng: &mut crate::rng::EpisodeRng) -> f64 {
        self.lo + (self.hi - self.lo) * rng.unit()
    }
}

/// Errors loading or checking a scenario file. The message names the file
/// and the field.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("{path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    #[error("{path}: {field}: {message}")]
    Field { path: String, field: String, message: String },
}

/// Check helpers used by each scenario's `validate`.
pub(crate) struct FieldCheck<'a> {
    pub path: &'a str,
}

impl FieldCheck<'_> {
    pub fn within(&self, field: &str, x: f64, lo: f64, hi: f64) -> Result<(), ScenarioError> {
        if x.is_finite() && x >= lo && x <= hi {
            Ok(())
        } else {
            Err(self.err(field, format!("must lie in [{lo}, {hi}], got {x}")))
        }
    }
    pub fn range_within(&self, field: &str, r: Range, lo: f64, hi: f64) -> Result<(), ScenarioError> {
        if r.lo >= lo && r.hi <= hi {
            Ok(())
        } else {
            Err(self.err(field, format!("[{}, {}] must lie within [{lo}, {hi}]", r.lo, r.hi)))
        }
    }
    pub fn err(&self, field: &str, message: String) -> ScenarioError {
        ScenarioError::Field { path: self.path.to_string(), field: field.to_string(), message }
    }
}

/// Decisions before an episode ends as a timeout: one number for every
/// tier, or `[tier 1, tier 2, tier 3]`. It is printed in the scene text, so
/// it may depend on the tier (the information structure, which is public)
/// but never on the hidden disposition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum TurnBudget {
    All(u32),
    PerTier([u32; 3]),
}

impl TurnBudget {
    pub fn get(self, tier: Tier) -> u32 {
        match self {
            TurnBudget::All(n) => n,
            TurnBudget::PerTier(ns) => ns[tier.number() as usize - 1],
        }
    }
}

/// Parameters shared by every scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Common {
    /// Decisions before the episode ends as a timeout (at most 40).
    pub turn_budget: TurnBudget,
    /// Ego speed limit (m/s).
    pub speed_limit_mps: f64,
}

impl Common {
    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        for tier in Tier::ALL {
            let n = self.turn_budget.get(tier);
            if n == 0 || n > crate::sim::MAX_TURNS {
                return Err(c.err("turn_budget", format!("must be 1..={}, got {n}", crate::sim::MAX_TURNS)));
            }
        }
        c.within("speed_limit_mps", self.speed_limit_mps, 3.0, 20.0)
    }
}

/// One scenario's parameters, as read from its TOML file.
#[derive(Debug, Clone)]
pub struct ScenarioConfig {
    kind: ScenarioKind,
    params: std::sync::Arc<dyn ScenarioParams>,
}

impl PartialEq for ScenarioConfig {
    fn eq(&self, other: &ScenarioConfig) -> bool {
        self.kind == other.kind && self.params.to_json() == other.params.to_json()
    }
}

impl Serialize for ScenarioConfig {
    /// The parameters' fields with the scenario's name under `scenario`, as
    /// the file has them.
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut fields = match self.params.to_json() {
            serde_json::Value::Object(fields) => fields,
            _ => serde_json::Map::new(),
        };
        fields.insert("scenario".into(), self.kind.name().into());
        fields.serialize(serializer)
    }
}

impl ScenarioConfig {
    pub fn kind(&self) -> ScenarioKind {
        self.kind
    }

    pub fn common(&self) -> &Common {
        self.params.common()
    }

    /// Build the world of one episode: its geometry from the episode key's
    /// geometry stream, its observation noise from the noise stream.
    pub(crate) fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        key: &[u64; 3],
    ) -> Box<dyn world::World + Send> {
        use crate::rng::{EpisodeRng, Stream};
        let mut geometry = EpisodeRng::new(key, Stream::Geometry);
        let noise = EpisodeRng::new(key, Stream::ObservationNoise);
        self.params.build_world(tier, disposition, &mut geometry, noise)
    }

    /// The compiled-in parameters of a scenario.
    pub fn builtin(kind: ScenarioKind) -> ScenarioConfig {
        let (path, text) = kind.def().builtin_file;
        // The built-in files are checked by a unit test, so this cannot fail
        // in a released binary.
        Self::for_scenario(kind, path, text).expect("built-in scenario file is valid")
    }

    /// Parse and check a scenario file's text. `path` is only used in
    /// error messages.
    pub fn from_toml(path: &str, text: &str) -> Result<ScenarioConfig, ScenarioError> {
        let table = parse_table(path, text)?;
        let name = match table.get("scenario") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => {
                return Err(ScenarioError::Field {
                    path: path.into(),
                    field: "scenario".into(),
                    message: "must be a string".into(),
                });
            }
            None => {
                return Err(ScenarioError::Field {
                    path: path.into(),
                    field: "scenario".into(),
                    message: format!("missing ({})", scenario_names()),
                });
            }
        };
        let kind: ScenarioKind = name.parse().map_err(|e: UnknownScenario| ScenarioError::Field {
            path: path.into(),
            field: "scenario".into(),
            message: e.to_string(),
        })?;
        Self::for_scenario(kind, path, text)
    }

    /// Parse and check the text of a file of `kind`'s parameters (its
    /// `scenario` key, if any, must name `kind`).
    pub(crate) fn for_scenario(kind: ScenarioKind, path: &str, text: &str) -> Result<ScenarioConfig, ScenarioError> {
        let mut body = parse_table(path, text)?;
        if let Some(named) = body.remove("scenario").filter(|v| v.as_str() != Some(kind.name())) {
            return Err(ScenarioError::Field {
                path: path.into(),
                field: "scenario".into(),
                message: format!("names {named}, not {kind}"),
            });
        }
        let body_text =
            toml::to_string(&body).map_err(|e| ScenarioError::Parse { path: path.into(), message: e.to_string() })?;
        let params = (kind.def().load)(&body_text, &FieldCheck { path })?;
        Ok(ScenarioConfig { kind, params })
    }

    pub fn from_file(path: &Path) -> Result<ScenarioConfig, ScenarioError> {
        let shown = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|source| ScenarioError::Read { path: shown.clone(), source })?;
        Self::from_toml(&shown, &text)
    }
}

fn parse_table(path: &str, text: &str) -> Result<toml::Table, ScenarioError> {
    toml::from_str(text).map_err(|e| ScenarioError::Parse { path: path.into(), message: one_line(&e.to_string()) })
}

/// Collapse a multi-line parser message (toml prints a source excerpt) into
/// one line.
pub(crate) fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('|') && !l.chars().all(|c| c == '^' || c == ' '))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The scenario parameters in force for a run: the built-ins, with any
/// files given on the command line replacing the scenario they declare.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioSet {
    configs: Vec<ScenarioConfig>,
}

impl Default for ScenarioSet {
    fn default() -> Self {
        ScenarioSet { configs: ScenarioKind::ALL.iter().map(|k| ScenarioConfig::builtin(*k)).collect() }
    }
}

impl ScenarioSet {
    /// Hash of the scenario parameters in force (built-ins or overrides):
    /// part of a run's identity (run.json `config.scenarios_hash`).
    pub fn config_hash(&self) -> String {
        let configs: Vec<serde_json::Value> = ScenarioKind::ALL
            .iter()
            .map(|k| serde_json::to_value(self.get(*k)).expect("scenario config serialises"))
            .collect();
        crate::hash::fnv1a64_hex(&serde_json::Value::Array(configs).to_string())
    }

    pub fn with_overrides(files: &[std::path::PathBuf]) -> Result<ScenarioSet, ScenarioError> {
        let mut set = ScenarioSet::default();
        for f in files {
            set.replace(ScenarioConfig::from_file(f)?);
        }
        Ok(set)
    }

    /// Put `config` in force for its scenario (added if the set had none).
    pub fn replace(&mut self, config: ScenarioConfig) {
        match self.configs.iter_mut().find(|c| c.kind() == config.kind()) {
            Some(slot) => *slot = config,
            None => self.configs.push(config),
        }
    }

    /// The parameters in force for `kind`. A set holds every scenario of
    /// [`ScenarioKind::ALL`] and any other put in with
    /// [`ScenarioSet::replace`], and a scenario outside `ALL` is only made
    /// inside the scenario module (a test's toy), so a miss is a bug.
    pub fn get(&self, kind: ScenarioKind) -> &ScenarioConfig {
        self.configs.iter().find(|c| c.kind() == kind).expect("a scenario set holds every scenario it is asked for")
    }
}

/// Key from which every random stream of an episode is derived.
pub(crate) fn episode_key(kind: ScenarioKind, tier: Tier, seed: u64) -> [u64; 3] {
    [kind.rng_id(), tier.number() as u64, seed]
}

// A scenario added by a test.
#[cfg(test)]
mod toy;

#[cfg(test)]
mod tests {
    use super::*;

    /// Each scenario's one definition: names that parse back to it, ids and
    /// scene names no two share, a label per road user the figures place.
    #[test]
    fn every_definition_is_whole_and_its_own() {
        let defs: Vec<_> = ScenarioKind::ALL.iter().map(|k| (*k, k.def())).collect();
        assert!(ScenarioKind::ALL.is_sorted(), "ALL is in the order scenarios sort in (their RNG ids)");
        for (kind, def) in &defs {
            assert_eq!(def.name.parse::<ScenarioKind>().unwrap(), *kind);
            assert_eq!(ScenarioKind::from_scene_name(def.scene_name), Some(*kind));
            assert_eq!(def.track_labels.len(), def.plan_axes.road_users.len(), "{kind}");
            // The scene's layout fits a Scene (else Scene::new refuses every scene of it).
            assert!((1..=scene::MAX_PLACE).contains(&def.place_fields.len()), "{kind}");
            assert!(def.track_labels.len() <= scene::MAX_TRACKS, "{kind}");
            assert_ne!(def.dispositions[0], def.dispositions[1], "{kind}");
            assert!(def.dispositions[1].ego_should_go() && !def.dispositions[0].ego_should_go(), "{kind}");
            assert!(def.tier_mechanics.iter().all(|m| !m.is_empty()) && !def.situation.is_empty(), "{kind}");
            for (other, o) in &defs {
                if other != kind {
                    assert_ne!(def.rng_id, o.rng_id);
                    assert_ne!(def.scene_name, o.scene_name);
                }
            }
        }
    }

    #[test]
    fn builtin_files_parse_and_validate() {
        for kind in ScenarioKind::ALL {
            let c = ScenarioConfig::builtin(kind);
            assert_eq!(c.kind(), kind);
        }
    }

    #[test]
    fn unknown_field_is_named() {
        let text = ScenarioKind::YieldStandoff.def().builtin_file.1.replace("turn_budget", "turn_budgte");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.contains("turn_budgte"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn out_of_range_field_is_named() {
        let text = ScenarioKind::YieldStandoff.def().builtin_file.1.replace("turn_budget = 24", "turn_budget = 400");
        assert_ne!(text, ScenarioKind::YieldStandoff.def().builtin_file.1, "the planted value did not apply");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.starts_with("x.toml: turn_budget: must be 1..=40"), "{e}");
    }

    #[test]
    fn every_magnitude_has_an_upper_bound() {
        let text = ScenarioKind::ContestedMerge
            .def()
            .builtin_file
            .1
            .replace("position_noise_m = 1.5", "position_noise_m = 1e30");
        assert_ne!(text, ScenarioKind::ContestedMerge.def().builtin_file.1, "the planted value did not apply");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.starts_with("x.toml: tier2.position_noise_m: must lie in [0, 10]"), "{e}");
    }

    #[test]
    fn the_pedestrian_frame_is_the_scene_texts() {
        let axes = ScenarioKind::PedestrianFeint.plan_axes();
        let frame = axes.road_users[0].lateral.expect("the pedestrian has a lateral frame");
        assert_eq!(frame.plan_offset, 1.75, "lat = y + 1.75, as the module doc states");
        // Every sample the model reads is the plan point's value in the frame.
        let config = ScenarioConfig::builtin(ScenarioKind::PedestrianFeint);
        let mut checked = 0;
        for tier in Tier::ALL {
            for disposition in ScenarioKind::PedestrianFeint.dispositions() {
                let key = episode_key(ScenarioKind::PedestrianFeint, tier, 7);
                let mut world = config.build_world(tier, disposition, &key);
                let mut ego = world.ego_start();
                ego.v = 0.0; // the pedestrian acts on its own while the ego waits
                for step in 0..80 {
                    world.advance(&ego, f64::from(step) * crate::sim::DT, crate::sim::DT);
                    let plan = world.plan(&ego);
                    let seen = world.observe(&ego).tracks()[0].now.position_m;
                    assert!((frame.of(&plan[1]) - seen).abs() < 1e-9, "{tier:?} {disposition}: {seen}");
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 480);
        // The situation paragraph prints the same kerbs, and the band of the pedestrian's centre in
        // which its body overlaps the car's path (its bounds excluded), as the frame draws them.
        let stated = format!(
            "{} = kerb, {:.1} = far kerb; with its centre between {:.1} and {:.1} its body overlaps your car's path",
            frame.marks[0].0, frame.marks[1].0, frame.in_path.0, frame.in_path.1
        );
        assert!(ScenarioKind::PedestrianFeint.situation().contains(&stated), "{stated}");
    }

    #[test]
    fn every_plan_point_has_a_role() {
        // The built-in worlds' plan points: the ego, then one per road user of plan_axes.
        for kind in ScenarioKind::ALL {
            let key = episode_key(kind, Tier::T1, 1);
            let world = ScenarioConfig::builtin(kind).build_world(Tier::T1, kind.dispositions()[0], &key);
            let axes = kind.plan_axes();
            assert_eq!(world.plan(&world.ego_start()).len(), axes.road_users.len() + 1, "{kind}");
            assert_eq!(axes.road_users.len(), kind.track_labels().len(), "{kind}");
        }
        let merge = ScenarioKind::ContestedMerge.plan_axes();
        assert_eq!((merge.role(0), merge.role(1)), ("lane car".into(), "follower".into()));
    }

    #[test]
    fn unknown_scenario_name_is_refused() {
        let e = ScenarioConfig::from_toml("x.toml", "scenario = \"four_way\"").unwrap_err().to_string();
        assert!(e.contains("unknown scenario 'four_way'"), "{e}");
    }
}
