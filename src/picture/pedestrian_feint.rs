//! The crosswalk's picture: the ego drives up its lane toward the
//! crosswalk; the pedestrians stand or walk across it, placed by the
//! scene's lateral position (0 at the near kerb, on the ego's right; 7.0
//! at the far kerb). The band the ego's bumper measures to is the conflict
//! zone; the companions are drawn a little behind the pedestrian along the
//! crosswalk so that three discs at one kerb stay apart.

use super::{Canvas, Drawing, MARKING, ROAD, View, ZONE};
use crate::observation::Observation;
use crate::scenario::pedestrian_feint::FAR_KERB;
use crate::sim::{CAR_LENGTH, PEDESTRIAN_SIZE};

/// The near kerb's x (m): the ego's lane is centred on 0.
const NEAR_KERB_X: f64 = 1.75;
const SIDEWALK: &str = "#dcdcd4";

pub(super) const DRAWING: Drawing = Drawing { view: View { centre_m: (-1.75, -20.0), px_per_m: 6.5 }, draw };

fn draw(obs: &Observation, c: &mut Canvas) {
    let far_x = NEAR_KERB_X - FAR_KERB;
    c.rect((NEAR_KERB_X, -100.0), (NEAR_KERB_X + 3.0, 100.0), SIDEWALK);
    c.rect((far_x - 3.0, -100.0), (far_x, 100.0), SIDEWALK);
    c.rect((far_x, -100.0), (NEAR_KERB_X, 100.0), ROAD);
    let middle = 0.5 * (far_x + NEAR_KERB_X);
    c.line((middle, -100.0), (middle, 100.0), MARKING, 2.0, Some((10.0, 8.0)));
    // The zebra, and the band a bumper on the crosswalk covers.
    let mut x = far_x + 0.25;
    while x < NEAR_KERB_X {
        c.rect((x, -1.2), ((x + 0.5).min(NEAR_KERB_X), 1.8), MARKING);
        x += 1.0;
    }
    c.rect((far_x, 0.0), (NEAR_KERB_X, PEDESTRIAN_SIZE), ZONE);
    let d = obs.scene.ego_to_conflict_m();
    c.ego((0.0, -d - 0.5 * CAR_LENGTH), super::Heading::Up, obs.ego.speed_mps);
    let labels = obs.scenario().track_labels();
    for (k, (track, label)) in obs.scene.tracks().iter().zip(labels).enumerate() {
        let y = 0.5 * PEDESTRIAN_SIZE + 0.9 * k as f64;
        c.road_user(k, label.now, track, None, |lat| (NEAR_KERB_X - lat, y), (-1.0, 0.0));
    }
}
