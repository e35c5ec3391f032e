//! The instructions every front end gives a player: the system prompt
//! `eval` sends a model, env-server's first observation carries, `play`
//! shows a person on its help screen and the probes and pictures extend
//! ([`system_prompt`]). One text, one home, below the front ends.
//!
//! It explains the task, the answer format and the controller mapping of
//! [`crate::action::Action::control`]. It says nothing about the other road
//! user's possible intentions or how they show: inferring them is the task.

pub const SYSTEM_PROMPT: &str = "\
You are the driver of an automated car (the ego vehicle) in a short traffic situation. \
Each turn you receive a description of the scene: your own speed, acceleration and distances, \
and the recent positions and speeds of the other road users. You cannot see what the others \
intend; you can only judge from how they move. Your goal is to reach your goal position without \
a collision, and without waiting needlessly: the episode ends when you reach the goal, when you \
collide, or when the turns run out. Running out of turns is a failure (scored only by how far you \
got, always below any success); a collision is the worst outcome. A collision is any overlap of \
your car's body with another road user's body (cars are 4.8 m long and 1.9 m wide, a pedestrian \
0.6 m across), checked every 0.1 s. At a crosswalk, the rule of the road (the US Uniform Vehicle \
Code, section 11-502) is that a driver gives way to a pedestrian on the crossing; a pedestrian \
waiting at the kerb has not taken it yet, and must not step in front of a car too close to stop.

Every turn, answer with exactly one JSON object and nothing else:
{\"reasoning\": \"<one or two short sentences>\", \"maneuver\": \"<proceed | yield | stop | nudge_forward>\", \"acceleration\": <number from -1 to 1>, \"steering\": 0.0}

The maneuver selects how your car is controlled; the magnitude |acceleration| (0 to 1) sets \
how strongly, linearly inside that maneuver's band (a = |acceleration|):
- proceed: go on toward the speed limit, accelerating at 3.0 x a m/s^2: 0 holds your current speed, 1 accelerates at 3.0 m/s^2.
- nudge_forward: creep toward 2.0 m/s, accelerating at 0.5 + 1.0 x a m/s^2, or braking at 2.0 + 2.0 x a m/s^2 if faster.
- yield: slow down toward a stop, braking at 0.5 + 3.5 x a m/s^2.
- stop: brake to a stop, at 4.0 + 4.0 x a m/s^2.
The sign of acceleration does not matter, and steering is ignored (you stay on your path). \
Each answer is held for 0.5 s, then you get the next scene. An answer that cannot be read as \
this JSON object is executed as a firm stop.";

/// The system prompt of one episode: [`SYSTEM_PROMPT`], plus each probe's
/// paragraph for its scenario (the belief question, then the forecast's),
/// then, for a scene shown as a picture, what the picture shows (the one
/// composition every front end uses).
pub fn system_prompt(
    probe: crate::probe::Probe,
    kind: crate::scenario::ScenarioKind,
    observation: crate::rundir::ObservationMode,
) -> String {
    use crate::rundir::ObservationMode;
    let mut prompt = SYSTEM_PROMPT.to_string();
    if probe.belief {
        prompt.push_str(&crate::belief::prompt_paragraph(kind));
    }
    if probe.forecast {
        prompt.push_str(&crate::forecast::prompt_paragraph(kind));
    }
    match observation {
        ObservationMode::Text => {}
        ObservationMode::Image => prompt.push_str(&crate::picture::prompt_paragraph(kind, false)),
        ObservationMode::Both => prompt.push_str(&crate::picture::prompt_paragraph(kind, true)),
    }
    prompt
}

/// The hash of every system prompt a run may send (part of the run's
/// identity): the plain prompt's alone for a text run without a probe, so
/// runs made before probes existed keep their hash.
pub fn prompt_hash(probe: crate::probe::Probe, observation: crate::rundir::ObservationMode) -> String {
    if probe.is_none() && observation == crate::rundir::ObservationMode::Text {
        return crate::hash::fnv1a64_hex(SYSTEM_PROMPT);
    }
    let all: Vec<String> =
        crate::scenario::ScenarioKind::ALL.iter().map(|&k| system_prompt(probe, k, observation)).collect();
    crate::hash::fnv1a64_hex(&all.join("\u{0}"))
}
