//! The schedule argument the reference examples share:
//! `maneuver:strength:turns,...` (turns default 1; the last entry repeats).
use negotiator::action::{Action, Maneuver};

/// The actions of a schedule, one per turn; `None` if it does not parse.
pub fn parse(text: &str) -> Option<Vec<Action>> {
    let mut actions = Vec::new();
    for part in text.split(',') {
        let f: Vec<&str> = part.split(':').collect();
        let maneuver = Maneuver::from_loose(f.first()?)?;
        let strength: f64 = f.get(1)?.parse().ok()?;
        let turns: usize = f.get(2).map_or(Some(1), |t| t.parse().ok())?;
        actions.extend(std::iter::repeat_n(Action::new(maneuver, strength), turns));
    }
    (!actions.is_empty()).then_some(actions)
}
