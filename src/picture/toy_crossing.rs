//! The toy crossing's picture (the scenario the unit tests add through the
//! registry alone): the ego comes up, the crossing car from the left.

use super::{Canvas, Drawing, Heading, ROAD, View, ZONE};
use crate::observation::Observation;
use crate::scenario::toy_crossing::HALF_ZONE;

pub(super) const DRAWING: Drawing = Drawing { view: View { centre_m: (0.0, -10.0), px_per_m: 7.0 }, draw };

fn draw(obs: &Observation, c: &mut Canvas) {
    c.rect((-3.5, -100.0), (3.5, 100.0), ROAD);
    c.rect((-100.0, -3.5), (100.0, 3.5), ROAD);
    c.rect((-HALF_ZONE, -HALF_ZONE), (HALF_ZONE, HALF_ZONE), ZONE);
    c.ego((0.0, -HALF_ZONE - obs.scene.ego_to_conflict_m()), Heading::Up, obs.ego.speed_mps);
    let label = obs.scenario().track_labels()[0].now;
    c.road_user(0, label, &obs.scene.tracks()[0], Some(Heading::Right), |p| (-HALF_ZONE - p, 0.0), (1.0, 0.0));
}
