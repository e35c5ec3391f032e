//! A scenario's parameters as its TOML file gives them: the value types
//! (`Range`, `TurnBudget`, the `Common` episode table), their checks
//! (`FieldCheck`, `ScenarioError`), one scenario's parsed configuration
//! (`ScenarioConfig`) and the set in force (`ScenarioSet`: the built-ins,
//! or an override file in place of one).

use super::def::ScenarioParams;
use super::{Disposition, ScenarioKind, Tier, UnknownScenario, scenario_names, world};
use serde::{Deserialize, Serialize};
use std::path::Path;

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
    /// The middle of the range: a typical draw.
    pub fn mid(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }

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
    pub(super) fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
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
