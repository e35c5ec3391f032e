//! The intersection's picture: the ego comes up the stem of the T, the two
//! cars come from the left on the crossing road. The conflict zone is the
//! square both cars' bodies share: 1.9 m (a car's width) each way, its
//! near edges where the scene's distances end.

use super::{Canvas, Drawing, Heading, MARKING, ROAD, View, ZONE};
use crate::observation::Observation;
use crate::sim::{CAR_LENGTH, CAR_WIDTH};

/// The crossing lane's centre line (m): the zone is y in [0, CAR_WIDTH].
const CROSSING_Y: f64 = 0.5 * CAR_WIDTH;
/// A lane's width (m).
const LANE: f64 = 3.5;

pub(super) const DRAWING: Drawing = Drawing { view: View { centre_m: (0.0, -14.0), px_per_m: 6.0 }, draw };

fn draw(obs: &Observation, c: &mut Canvas) {
    let (near, far) = (CROSSING_Y - 0.5 * LANE, CROSSING_Y + 1.5 * LANE);
    // The stem (the ego's lane, the oncoming one to its left) and the
    // crossing road.
    c.rect((-1.5 * LANE, near), (0.5 * LANE, -100.0), ROAD);
    c.rect((-100.0, near), (100.0, far), ROAD);
    c.line((-0.5 * LANE, near), (-0.5 * LANE, -100.0), MARKING, 2.0, Some((10.0, 8.0)));
    c.line((-100.0, CROSSING_Y + 0.5 * LANE), (100.0, CROSSING_Y + 0.5 * LANE), MARKING, 2.0, Some((10.0, 8.0)));
    c.rect((-0.5 * CAR_WIDTH, 0.0), (0.5 * CAR_WIDTH, CAR_WIDTH), ZONE);
    // The ego: its front bumper the scene's distance below the zone.
    let d = obs.scene.ego_to_conflict_m();
    c.ego((0.0, -d - 0.5 * CAR_LENGTH), Heading::Up, obs.ego.speed_mps);
    // The cars on the crossing road: each front bumper its distance left
    // of the ego's lane, moving right.
    let labels = obs.scenario().track_labels();
    for (k, (track, label)) in obs.scene.tracks().iter().zip(labels).enumerate() {
        let at = |p: f64| (-0.5 * CAR_WIDTH - p - 0.5 * CAR_LENGTH, CROSSING_Y);
        c.road_user(k, label.now, track, Some(Heading::Right), at, (1.0, 0.0));
    }
}
