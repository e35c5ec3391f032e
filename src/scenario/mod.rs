//! Scenarios: their identities, tiers, hidden dispositions, and the TOML
//! parameter files that are compiled into the binary and can be overridden.

mod config;
mod def;
mod layout;
mod scene;
mod track;
pub mod world;

/// The benchmark's scenarios, in the order of every table: the one list of
/// them. Each name is a scenario's own files: its world
/// (`src/scenario/<name>.rs`, with its parameter file
/// `scenarios/<name>.toml`), its expert's rules
/// (`src/policy/expert/<name>.rs`), its rules forecaster
/// (`src/forecast/rules/<name>.rs`) and its picture
/// (`src/picture/<name>.rs`). Each of those modules expands this
/// list into its own part (`registry!(a_macro_of_its_own)`), so that a
/// scenario without one of its parts does not compile, and the parts
/// pair up by name.
macro_rules! registry {
    ($part:ident) => {
        crate::scenario::with_test_scenarios! { $part, yield_standoff, pedestrian_feint, contested_merge }
    };
}
pub(crate) use registry;

/// The registry as built: the benchmark's scenarios and, in the crate's
/// own unit tests only, `toy_crossing`, a scenario a test adds through the
/// registry alone (its files: `toy_crossing.rs`, its TOML in
/// `tests/fixtures/`, its expert's rules, its rules forecaster, its
/// picture).
#[cfg(not(test))]
macro_rules! with_test_scenarios {
    ($part:ident, $($name:ident),+) => {
        $part! { $($name),+ }
    };
}
#[cfg(test)]
macro_rules! with_test_scenarios {
    ($part:ident, $($name:ident),+) => {
        $part! { $($name),+, toy_crossing }
    };
}
pub(crate) use with_test_scenarios;

/// The worlds' part of the registry: a module per scenario and
/// [`ScenarioKind::ALL`].
macro_rules! worlds {
    ($($name:ident),+) => {
        $(pub mod $name;)+

        impl ScenarioKind {
            /// The benchmark's scenarios, in the order of every table (the
            /// registry's). A name is looked up here.
            pub const ALL: [ScenarioKind; [$(stringify!($name)),+].len()] = [$(ScenarioKind(&$name::DEF)),+];
        }
    };
}
registry!(worlds);

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

pub use config::{Common, Range, ScenarioConfig, ScenarioError, ScenarioSet, TurnBudget};
pub(crate) use config::{FieldCheck, one_line};
pub use contested_merge::MergeParams;
pub(crate) use def::{ScenarioDef, ScenarioParams, TrackLabel, load};
pub use layout::{LateralFrame, PlanAxes, RoadUser};
pub use pedestrian_feint::PedestrianParams;
pub(crate) use scene::MAX_TRACKS;
pub use scene::Scene;
pub use track::{HISTORY_LEN, HISTORY_SPACING_S, ReadingNoise, Sample, Track};
pub use yield_standoff::YieldParams;

/// A scenario: a handle on its one definition (`ScenarioDef`, in the
/// scenario's own file). Two handles are the same scenario when they name
/// the same one; records and the command line spell it by name.
#[derive(Clone, Copy)]
pub struct ScenarioKind(&'static ScenarioDef);

// Handles on the first three scenarios by name, for their own files and
// the tests (named as they were when this was an enum). A scenario added
// later needs none: the registry is the list.
#[allow(non_upper_case_globals)]
impl ScenarioKind {
    pub const YieldStandoff: ScenarioKind = ScenarioKind(&yield_standoff::DEF);
    pub const PedestrianFeint: ScenarioKind = ScenarioKind(&pedestrian_feint::DEF);
    pub const ContestedMerge: ScenarioKind = ScenarioKind(&contested_merge::DEF);
}

impl ScenarioKind {
    /// Where the scenario stands in [`ScenarioKind::ALL`] (and so in every
    /// part of the registry); `None` for one outside the benchmark (a
    /// test's scenario).
    pub(crate) fn index(self) -> Option<usize> {
        ScenarioKind::ALL.iter().position(|k| *k == self)
    }

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

    /// Whether the scene measures the road users' positions from the ego
    /// (they move with its travel), not from a fixed point of the road.
    pub fn positions_relative_to_ego(self) -> bool {
        self.def().tracks_relative_to_ego
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

#[derive(Debug, thiserror::Error)]
#[error("unknown scenario '{0}' (expected {list})", list = scenario_names())]
pub struct UnknownScenario(String);

/// The benchmark's scenario names as a message lists them: "a, b or c".
pub(super) fn scenario_names() -> String {
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

/// The other road user's hidden intent, as its scenario declares it (each
/// scenario's definition lists its two): a name, and whether it requires
/// the ego to go first. Privileged: only the simulator and the graders
/// read it. Records spell it by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Disposition {
    name: &'static str,
    ego_should_go: bool,
}

impl Disposition {
    /// A disposition called `name` (snake_case, as records and the
    /// drill-down spell it) that requires the ego to go first or not.
    pub const fn new(name: &'static str, ego_should_go: bool) -> Disposition {
        Disposition { name, ego_should_go }
    }

    /// Whether this disposition requires the ego to go first (otherwise it
    /// must give way).
    pub fn ego_should_go(self) -> bool {
        self.ego_should_go
    }

    pub fn name(self) -> &'static str {
        self.name
    }

    /// Every disposition the benchmark's scenarios declare, each name once,
    /// in the order of [`ScenarioKind::ALL`] (a scenario's that must give
    /// way first).
    pub fn all() -> Vec<Disposition> {
        let mut all: Vec<Disposition> = Vec::new();
        for d in ScenarioKind::ALL.iter().flat_map(|k| k.dispositions()) {
            if !all.iter().any(|a| a.name == d.name) {
                all.push(d);
            }
        }
        all
    }
}

impl fmt::Display for Disposition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Disposition {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Disposition {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = std::borrow::Cow::<str>::deserialize(deserializer)?;
        Disposition::all().into_iter().find(|d| d.name == name).ok_or_else(|| {
            let known: Vec<&str> = Disposition::all().iter().map(|d| d.name).collect();
            serde::de::Error::custom(format_args!(
                "unknown disposition '{name}' (expected one of {})",
                known.join(", ")
            ))
        })
    }
}

/// Key from which every random stream of an episode is derived.
pub(crate) fn episode_key(kind: ScenarioKind, tier: Tier, seed: u64) -> [u64; 3] {
    [kind.rng_id(), tier.number() as u64, seed]
}

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
            // A name means one disposition wherever it is declared: records spell it by name.
            for d in def.dispositions {
                let named: Vec<Disposition> =
                    defs.iter().flat_map(|(_, o)| o.dispositions).filter(|o| o.name() == d.name()).collect();
                assert!(named.iter().all(|o| *o == d), "{kind}: '{d}' declared twice, differently");
                assert_eq!(serde_json::from_value::<Disposition>(serde_json::json!(d.name())).unwrap(), d);
            }
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
        let text =
            ScenarioKind::YieldStandoff.def().builtin_file.1.replace("turn_budget = [26, 26, 24]", "turn_budget = 400");
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
                    // The pedestrian, then its companions.
                    for (k, track) in world.observe(&ego).tracks().iter().enumerate() {
                        let seen = track.now.position_m;
                        assert!((frame.of(&plan[1 + k]) - seen).abs() < 1e-9, "{tier:?} {disposition} {k}: {seen}");
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 3 * 480);
        // The situation paragraph prints the same kerbs, and the band of a pedestrian's centre in
        // which its body overlaps the car's path (its bounds excluded), as the frame draws them.
        let stated = format!(
            "{} = kerb, {:.1} = far kerb; a centre between {:.1} and {:.1} overlaps your path",
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
