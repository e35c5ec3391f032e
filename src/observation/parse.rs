//! Reads scene text back into an observation. Used by `negotiator serve`,
//! whose scripted model sees nothing but the text, and by the round-trip
//! invariant.

use super::{EgoView, HISTORY_LEN, Observation, ReadingNoise, Sample, Scene, Track};
use crate::action::{Action, Maneuver};
use crate::scenario::ScenarioKind;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SceneParseError {
    #[error("scene text has no '{0}' line")]
    MissingLine(&'static str),
    #[error("scene line '{line}' should hold {expected} numbers")]
    BadNumbers { line: &'static str, expected: usize },
    #[error("unknown scene '{0}' in scene text")]
    UnknownScenario(String),
    #[error("unreadable last action '{0}'")]
    BadLastAction(String),
}

/// Numbers standing as their own words in `s` ("12.3", "-4", "(33");
/// digits glued to other text such as the 2 in "m/s^2" are skipped.
fn numbers(s: &str) -> Vec<f64> {
    s.split(|c: char| c.is_whitespace() || matches!(c, ',' | ';' | '(' | ')'))
        .filter_map(|w| {
            let first = w.chars().next()?;
            if first.is_ascii_digit() || (first == '-' && w.len() > 1) { w.parse::<f64>().ok() } else { None }
        })
        .collect()
}

fn line<'a>(text: &'a str, key: &'static str) -> Result<&'a str, SceneParseError> {
    let prefix_len = key.len() + 1;
    text.lines()
        .map(str::trim)
        .find(|l| l.len() > prefix_len && l.starts_with(key) && l.as_bytes()[key.len()] == b':')
        .map(|l| &l[prefix_len..])
        .ok_or(SceneParseError::MissingLine(key))
}

fn numbers_of(text: &str, key: &'static str, expected: usize) -> Result<Vec<f64>, SceneParseError> {
    let xs = numbers(line(text, key)?);
    if xs.len() == expected { Ok(xs) } else { Err(SceneParseError::BadNumbers { line: key, expected }) }
}

fn track(text: &str, label: &'static str, history_key: &'static str) -> Result<Track, SceneParseError> {
    let now = numbers_of(text, label, 2)?;
    let hist = numbers_of(text, history_key, 2 * HISTORY_LEN)?;
    let mut past = [Sample { position_m: 0.0, velocity_mps: 0.0 }; HISTORY_LEN];
    for (i, p) in past.iter_mut().enumerate() {
        *p = Sample { position_m: hist[2 * i], velocity_mps: hist[2 * i + 1] };
    }
    Ok(Track { now: Sample { position_m: now[0], velocity_mps: now[1] }, past })
}

/// Parse the text produced by `render_scene`. The scenario line decides the
/// layout; extra lines (for instance a prompt around the scene) are ignored.
pub fn parse_scene(text: &str) -> Result<Observation, SceneParseError> {
    let name = line(text, "Scene")?.trim();
    let scenario =
        ScenarioKind::from_scene_name(name).ok_or_else(|| SceneParseError::UnknownScenario(name.to_string()))?;
    let time_s = numbers_of(text, "Time", 1)?[0];
    let turn = numbers_of(text, "Turn", 4)?;
    let place_len = scenario.place_numbers();
    let ego_expected = place_len + 4;
    // The limit of the road the ego is to join, when the line shows one, is its last number.
    let mut ego = numbers(line(text, "You")?);
    let speed_limit_ahead_mps = match ego.len() {
        n if n == ego_expected + 1 => ego.pop(),
        n if n == ego_expected => None,
        _ => return Err(SceneParseError::BadNumbers { line: "You", expected: ego_expected }),
    };
    let (speed_mps, accel_mps2) = (ego[0], ego[1]);
    let (to_goal_m, speed_limit_mps) = (ego[ego_expected - 2], ego[ego_expected - 1]);
    let tracks = scenario
        .track_labels()
        .iter()
        .map(|label| track(text, label.now, label.history))
        .collect::<Result<Vec<Track>, SceneParseError>>()?;
    let scene = Scene::new(scenario, &ego[2..2 + place_len], &tracks)
        .expect("the place and track counts follow the scenario's own layout");
    let last = line(text, "Your last action")?.trim();
    let last_action = if last.starts_with("none") {
        None
    } else {
        let (name, rest) = last.split_once(',').ok_or_else(|| SceneParseError::BadLastAction(last.to_string()))?;
        let maneuver = Maneuver::from_loose(name).ok_or_else(|| SceneParseError::BadLastAction(last.to_string()))?;
        let acc = numbers(rest);
        if acc.len() != 1 {
            return Err(SceneParseError::BadLastAction(last.to_string()));
        }
        Some(Action { maneuver, acceleration: acc[0], steering: 0.0 })
    };
    let reading_noise = match line(text, "Readings") {
        Ok(l) => match numbers(l)[..] {
            [position_sd_m, speed_sd_mps] => Some(ReadingNoise { position_sd_m, speed_sd_mps }),
            _ => return Err(SceneParseError::BadNumbers { line: "Readings", expected: 2 }),
        },
        Err(_) => None,
    };
    Ok(Observation {
        time_s,
        turn: turn[0] as u32,
        turn_budget: turn[1] as u32,
        ego: EgoView { speed_mps, accel_mps2, to_goal_m, speed_limit_mps, speed_limit_ahead_mps },
        scene,
        last_action,
        reading_noise,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_skip_glued_digits() {
        assert_eq!(numbers("speed 7.2 m/s, acceleration -1.5 m/s^2, (33 left"), vec![7.2, -1.5, 33.0]);
        assert_eq!(numbers("- 3 x-4"), vec![3.0]);
    }

    #[test]
    fn missing_line_is_named() {
        assert_eq!(parse_scene("Scene: intersection\n"), Err(SceneParseError::MissingLine("Time")));
        assert_eq!(parse_scene("hello"), Err(SceneParseError::MissingLine("Scene")));
    }
}
