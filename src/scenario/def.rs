//! One definition per scenario: every fact about a scenario that the rest
//! of the program reads (its names, its dispositions, how figures place its
//! road users, how the scene and its text are laid out, the belief
//! question, what its tiers do, its parameter file and the world those
//! parameters build) sits in its own file as a [`ScenarioDef`]. Everything
//! else reads it through a [`super::ScenarioKind`], a handle on that one
//! definition: nothing outside a scenario's file matches on which scenario
//! it is, so a scenario is added by its files (this definition and its
//! world, its TOML, its expert's rules, its rules forecaster) and its name
//! in the registry (`registry!` in `scenario/mod.rs`; docs/architecture.md
//! lists the steps; `toy.rs` is one a test adds outside it).

use super::world::World;
use super::{Common, Disposition, FieldCheck, PlanAxes, ScenarioError, Tier};
use crate::rng::EpisodeRng;
use std::sync::Arc;

/// A road user's lines in the scene text and its key in the scene's JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TrackLabel {
    /// The label of its current sample (the line key).
    pub now: &'static str,
    /// The key of its history line.
    pub history: &'static str,
    /// Its field in the scene's JSON ("other", "pedestrian").
    pub field: &'static str,
}

/// What the program knows of one scenario besides its world.
pub(crate) struct ScenarioDef {
    /// The scenario's name (CLI, records, file names).
    pub name: &'static str,
    /// The neutral name of the scene's geometry, as the scene text prints
    /// it: it names the place, never a behaviour to expect.
    pub scene_name: &'static str,
    /// Small stable id mixed into RNG keys (never change one).
    pub rng_id: u64,
    /// The two hidden dispositions, the one that requires the ego to go
    /// first listed second.
    pub dispositions: [Disposition; 2],
    /// How the plan view is read (trajectory plots, the drill-down).
    pub plan_axes: PlanAxes,
    /// The scene text's "Situation:" paragraph.
    pub situation: &'static str,
    /// What the scene's JSON fields measure (the scene schema's
    /// description of this scenario's layout).
    pub scene_doc: &'static str,
    /// The JSON fields of the ego's place, in the "You:" line's order: the
    /// first is the ego's distance to the conflict.
    pub place_fields: &'static [&'static str],
    /// The ego's place as the "You:" line phrases it, from its formatted
    /// numbers (one per place field).
    pub place_text: fn(&[String]) -> String,
    /// The road users' labels in the scene text, in the scene's order.
    pub track_labels: &'static [TrackLabel],
    /// The road users' positions are measured from the ego (they move with
    /// its travel), not from a fixed point of the road.
    pub tracks_relative_to_ego: bool,
    /// How a road user's position changes with its velocity as the scene
    /// states both: +1 where the velocity is along the position's axis,
    /// -1 where a position is a distance the road user closes (the
    /// intersection's distance to the conflict zone). The forecast probe's
    /// constant-velocity reference moves a position by this times
    /// velocity times the horizon.
    pub position_per_velocity: f64,
    /// How many of the scene's road users, in its order, the forecast probe
    /// asks about: the other road user (the merge: the lane car and the
    /// car behind it).
    pub forecast_tracks: usize,
    /// The current sample of a road user, e.g. "21.0 m to the conflict
    /// zone, speed 9.4 m/s", from its formatted position and velocity.
    pub track_now: fn(&str, &str) -> String,
    /// The belief probe's question: names the road user and the place as
    /// the scene text does, and says nothing about how it may behave.
    pub belief_question: &'static str,
    /// The forecast probe's subject: which road users it asks about and on
    /// what axis, worded as the scene text words them and saying nothing
    /// about how they may behave.
    pub forecast_subject: &'static str,
    /// What tiers 2 and 3 change, in a few words (figure captions).
    pub tier_mechanics: [&'static str; 2],
    /// The short label of the leaderboard column that shows this
    /// scenario's decision correctness, if the leaderboard shows it:
    /// "yield" makes the paper's "yield DC" column (the first scenario of
    /// `ScenarioKind::ALL` with one has it).
    pub leaderboard_dc: Option<&'static str>,
    /// The compiled-in parameter file: its path (for messages) and text.
    pub builtin_file: (&'static str, &'static str),
    /// Read and check the parameters of this scenario from a file's TOML
    /// (without its `scenario` key): [`load`] for the scenario's type.
    pub load: fn(&str, &FieldCheck) -> Loaded,
}

/// A scenario file's parameters, read and checked (see [`load`]).
pub(crate) type Loaded = Result<Arc<dyn ScenarioParams>, ScenarioError>;

/// One scenario's parameters, as its TOML file sets them: they build the
/// scenario's world.
pub(crate) trait ScenarioParams: ParamsJson + std::fmt::Debug + Send + Sync {
    /// The parameters every scenario file has.
    fn common(&self) -> &Common;
    /// Check every field's range; the error names the field.
    fn validate(&self, check: &FieldCheck) -> Result<(), ScenarioError>;
    /// The world of one episode: its geometry drawn from `geometry`, its
    /// observation noise (on a tier that has any) from `noise`.
    fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        noise: EpisodeRng,
    ) -> Box<dyn World + Send>;
}

/// Parameters as JSON (what the run's scenario hash covers): any
/// serialisable parameters have it.
pub(crate) trait ParamsJson {
    fn to_json(&self) -> serde_json::Value;
}

impl<P: serde::Serialize> ParamsJson for P {
    fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("scenario parameters serialise")
    }
}

/// Parse a scenario's parameters of type `P` from TOML text and check them.
pub(crate) fn load<P>(body: &str, check: &FieldCheck) -> Loaded
where
    P: ScenarioParams + serde::de::DeserializeOwned + 'static,
{
    let params: P = toml::from_str(body)
        .map_err(|e| ScenarioError::Parse { path: check.path.into(), message: super::one_line(&e.to_string()) })?;
    params.validate(check)?;
    Ok(Arc::new(params))
}

/// A scenario's built-in parameters, typed: where its public rules (the
/// expert's, the rules forecaster's) read the typical figures of its road
/// users, so that the scenario file states each figure once.
pub(crate) fn builtin_params<P: serde::de::DeserializeOwned>(def: &ScenarioDef) -> P {
    let mut table: toml::Table = def.builtin_file.1.parse().expect("built-in scenario file is valid TOML");
    table.remove("scenario");
    // The built-in files are checked by a unit test.
    toml::Value::Table(table).try_into().expect("built-in scenario file is valid")
}
