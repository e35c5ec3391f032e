//! Scenarios: their identities, tiers, hidden dispositions, and the TOML
//! parameter files that are compiled into the binary and can be overridden.

pub mod contested_merge;
pub mod pedestrian_feint;
mod scene;
pub mod world;
pub mod yield_standoff;

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

pub use contested_merge::MergeParams;
pub use pedestrian_feint::PedestrianParams;
pub use scene::Scene;
pub use yield_standoff::YieldParams;

/// The three validated negotiation scenarios.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScenarioKind {
    YieldStandoff,
    PedestrianFeint,
    ContestedMerge,
}

impl ScenarioKind {
    pub const ALL: [ScenarioKind; 3] =
        [ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint, ScenarioKind::ContestedMerge];

    pub fn name(self) -> &'static str {
        match self {
            ScenarioKind::YieldStandoff => "yield_standoff",
            ScenarioKind::PedestrianFeint => "pedestrian_feint",
            ScenarioKind::ContestedMerge => "contested_merge",
        }
    }

    /// The neutral name of the scene's geometry, as the scene text prints
    /// it: it names the place, never a behaviour to expect.
    pub fn scene_name(self) -> &'static str {
        match self {
            ScenarioKind::YieldStandoff => "intersection",
            ScenarioKind::PedestrianFeint => "crosswalk",
            ScenarioKind::ContestedMerge => "on-ramp",
        }
    }

    /// How the plan view of this scenario is read (for trajectory plots):
    /// which coordinate is each road user's progress along its path, what
    /// the other road user is called, and where position 0 is.
    pub fn plan_axes(self) -> PlanAxes {
        match self {
            ScenarioKind::YieldStandoff => PlanAxes {
                ego_along_y: true,
                others_along_y: false,
                other_name: "other car",
                zero_label: "crossing centre",
                shared_axis: true,
            },
            ScenarioKind::PedestrianFeint => PlanAxes {
                ego_along_y: false,
                others_along_y: true,
                other_name: "pedestrian",
                zero_label: "crosswalk",
                shared_axis: false,
            },
            ScenarioKind::ContestedMerge => PlanAxes {
                ego_along_y: false,
                others_along_y: false,
                other_name: "lane car",
                zero_label: "taper start",
                shared_axis: true,
            },
        }
    }

    pub fn from_scene_name(name: &str) -> Option<ScenarioKind> {
        ScenarioKind::ALL.into_iter().find(|k| k.scene_name() == name)
    }

    /// Small stable id mixed into RNG keys (never reorder).
    fn rng_id(self) -> u64 {
        match self {
            ScenarioKind::YieldStandoff => 1,
            ScenarioKind::PedestrianFeint => 2,
            ScenarioKind::ContestedMerge => 3,
        }
    }

    /// The two hidden dispositions of this scenario, the one that requires
    /// the ego to go first listed second.
    pub fn dispositions(self) -> [Disposition; 2] {
        match self {
            ScenarioKind::YieldStandoff => [Disposition::Committed, Disposition::Yielder],
            ScenarioKind::PedestrianFeint => [Disposition::Crosser, Disposition::Feinter],
            ScenarioKind::ContestedMerge => [Disposition::Committed, Disposition::MakesRoom],
        }
    }
}

impl fmt::Display for ScenarioKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The plan-view reading of a scenario (see [`ScenarioKind::plan_axes`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlanAxes {
    /// The ego progresses along y (else x).
    pub ego_along_y: bool,
    /// The other road users progress along y (else x).
    pub others_along_y: bool,
    pub other_name: &'static str,
    /// What position 0 along the paths is.
    pub zero_label: &'static str,
    /// Whether the ego's and the others' progress share one axis (the
    /// pedestrian's lateral position does not).
    pub shared_axis: bool,
}

impl PlanAxes {
    /// Progress of the ego (`ego`) or another road user along its path.
    pub fn along(&self, p: &world::PlanPoint, ego: bool) -> f64 {
        let along_y = if ego { self.ego_along_y } else { self.others_along_y };
        if along_y { p.y } else { p.x }
    }
}

#[derive(Debug, thiserror::Error)]
#[error("unknown scenario '{0}' (expected yield_standoff, pedestrian_feint or contested_merge)")]
pub struct UnknownScenario(String);

impl FromStr for ScenarioKind {
    type Err = UnknownScenario;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ScenarioKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| UnknownScenario(s.to_string()))
    }
}

/// Difficulty tier: 1 is the plain task; 2 and 3 change the information
/// structure (see the README's scenario table).
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
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "scenario", rename_all = "snake_case")]
pub enum ScenarioConfig {
    YieldStandoff(YieldParams),
    PedestrianFeint(PedestrianParams),
    ContestedMerge(MergeParams),
}

const BUILTIN: [(&str, &str); 3] = [
    ("scenarios/yield_standoff.toml", include_str!("../../scenarios/yield_standoff.toml")),
    ("scenarios/pedestrian_feint.toml", include_str!("../../scenarios/pedestrian_feint.toml")),
    ("scenarios/contested_merge.toml", include_str!("../../scenarios/contested_merge.toml")),
];

impl ScenarioConfig {
    pub fn kind(&self) -> ScenarioKind {
        match self {
            ScenarioConfig::YieldStandoff(_) => ScenarioKind::YieldStandoff,
            ScenarioConfig::PedestrianFeint(_) => ScenarioKind::PedestrianFeint,
            ScenarioConfig::ContestedMerge(_) => ScenarioKind::ContestedMerge,
        }
    }

    pub fn common(&self) -> &Common {
        match self {
            ScenarioConfig::YieldStandoff(p) => &p.episode,
            ScenarioConfig::PedestrianFeint(p) => &p.episode,
            ScenarioConfig::ContestedMerge(p) => &p.episode,
        }
    }

    /// Build the world of one episode: its geometry from the episode key's
    /// geometry stream, its observation noise from the noise stream. The
    /// only place that maps a scenario to its world type.
    pub(crate) fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        key: &[u64; 3],
    ) -> Box<dyn world::World + Send> {
        use crate::rng::{EpisodeRng, Stream};
        let mut geometry = EpisodeRng::new(key, Stream::Geometry);
        let noise = EpisodeRng::new(key, Stream::ObservationNoise);
        match self {
            ScenarioConfig::YieldStandoff(p) => {
                Box::new(yield_standoff::YieldWorld::new(p, tier, disposition, &mut geometry))
            }
            ScenarioConfig::PedestrianFeint(p) => {
                Box::new(pedestrian_feint::PedestrianWorld::new(p, tier, disposition, &mut geometry))
            }
            ScenarioConfig::ContestedMerge(p) => {
                Box::new(contested_merge::MergeWorld::new(p, tier, disposition, &mut geometry, noise))
            }
        }
    }

    /// The compiled-in parameters of a scenario.
    pub fn builtin(kind: ScenarioKind) -> ScenarioConfig {
        let (path, text) = BUILTIN[kind as usize];
        // The built-in files are checked by a unit test, so this cannot fail
        // in a released binary.
        Self::from_toml(path, text).expect("built-in scenario file is valid")
    }

    /// Parse and check a scenario file's text. `path` is only used in
    /// error messages.
    pub fn from_toml(path: &str, text: &str) -> Result<ScenarioConfig, ScenarioError> {
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| ScenarioError::Parse { path: path.into(), message: one_line(&e.to_string()) })?;
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
                    message: "missing (yield_standoff, pedestrian_feint or contested_merge)".into(),
                });
            }
        };
        let kind: ScenarioKind = name.parse().map_err(|e: UnknownScenario| ScenarioError::Field {
            path: path.into(),
            field: "scenario".into(),
            message: e.to_string(),
        })?;
        let mut body = table;
        body.remove("scenario");
        let parse_err =
            |e: toml::de::Error| ScenarioError::Parse { path: path.into(), message: one_line(&e.to_string()) };
        let body_text =
            toml::to_string(&body).map_err(|e| ScenarioError::Parse { path: path.into(), message: e.to_string() })?;
        let check = FieldCheck { path };
        let config = match kind {
            ScenarioKind::YieldStandoff => {
                let p: YieldParams = toml::from_str(&body_text).map_err(parse_err)?;
                p.validate(&check)?;
                ScenarioConfig::YieldStandoff(p)
            }
            ScenarioKind::PedestrianFeint => {
                let p: PedestrianParams = toml::from_str(&body_text).map_err(parse_err)?;
                p.validate(&check)?;
                ScenarioConfig::PedestrianFeint(p)
            }
            ScenarioKind::ContestedMerge => {
                let p: MergeParams = toml::from_str(&body_text).map_err(parse_err)?;
                p.validate(&check)?;
                ScenarioConfig::ContestedMerge(p)
            }
        };
        Ok(config)
    }

    pub fn from_file(path: &Path) -> Result<ScenarioConfig, ScenarioError> {
        let shown = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|source| ScenarioError::Read { path: shown.clone(), source })?;
        Self::from_toml(&shown, &text)
    }
}

/// Collapse a multi-line parser message (toml prints a source excerpt) into
/// one line.
fn one_line(s: &str) -> String {
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
    configs: [ScenarioConfig; 3],
}

impl Default for ScenarioSet {
    fn default() -> Self {
        ScenarioSet { configs: ScenarioKind::ALL.map(ScenarioConfig::builtin) }
    }
}

impl ScenarioSet {
    pub fn with_overrides(files: &[std::path::PathBuf]) -> Result<ScenarioSet, ScenarioError> {
        let mut set = ScenarioSet::default();
        for f in files {
            set.replace(ScenarioConfig::from_file(f)?);
        }
        Ok(set)
    }

    pub fn replace(&mut self, config: ScenarioConfig) {
        let i = config.kind() as usize;
        self.configs[i] = config;
    }

    pub fn get(&self, kind: ScenarioKind) -> &ScenarioConfig {
        &self.configs[kind as usize]
    }
}

/// Key from which every random stream of an episode is derived.
pub(crate) fn episode_key(kind: ScenarioKind, tier: Tier, seed: u64) -> [u64; 3] {
    [kind.rng_id(), tier.number() as u64, seed]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_files_parse_and_validate() {
        for kind in ScenarioKind::ALL {
            let c = ScenarioConfig::builtin(kind);
            assert_eq!(c.kind(), kind);
        }
    }

    #[test]
    fn unknown_field_is_named() {
        let text = BUILTIN[0].1.replace("turn_budget", "turn_budgte");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.contains("turn_budgte"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn out_of_range_field_is_named() {
        let text = BUILTIN[0].1.replace("turn_budget = 22", "turn_budget = 400");
        assert_ne!(text, BUILTIN[0].1, "the planted value did not apply");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.starts_with("x.toml: turn_budget: must be 1..=40"), "{e}");
    }

    #[test]
    fn every_magnitude_has_an_upper_bound() {
        let text = BUILTIN[2].1.replace("position_noise_m = 1.5", "position_noise_m = 1e30");
        assert_ne!(text, BUILTIN[2].1, "the planted value did not apply");
        let e = ScenarioConfig::from_toml("x.toml", &text).unwrap_err().to_string();
        assert!(e.starts_with("x.toml: tier2.position_noise_m: must lie in [0, 10]"), "{e}");
    }

    #[test]
    fn unknown_scenario_name_is_refused() {
        let e = ScenarioConfig::from_toml("x.toml", "scenario = \"four_way\"").unwrap_err().to_string();
        assert!(e.contains("unknown scenario 'four_way'"), "{e}");
    }
}
