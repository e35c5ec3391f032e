//! One definition per scenario: every fact about a scenario that the rest
//! of the program reads (its names, its dispositions, how figures place its
//! road users, how the scene text phrases it, the belief question, what its
//! tiers do) sits in its own file as a [`ScenarioDef`], and everything else
//! reads it through the one accessor, [`super::ScenarioKind::def`].

use super::{Disposition, PlanAxes};

/// A road user's lines in the scene text: its label (the line key) and the
/// key of its history line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TrackLabel {
    pub now: &'static str,
    pub history: &'static str,
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
    /// The road users' labels in the scene text, in the scene's order.
    pub track_labels: &'static [TrackLabel],
    /// How many numbers the ego's place takes on the "You:" line.
    pub place_numbers: usize,
    /// The current sample of a road user, e.g. "21.0 m to the conflict
    /// zone, speed 9.4 m/s", from its formatted position and velocity.
    pub track_now: fn(&str, &str) -> String,
    /// The belief probe's question: names the road user and the place as
    /// the scene text does, and says nothing about how it may behave.
    pub belief_question: &'static str,
    /// What tiers 2 and 3 change, in a few words (figure captions).
    pub tier_mechanics: [&'static str; 2],
}
