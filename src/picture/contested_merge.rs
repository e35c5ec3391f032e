//! The merge's picture, in the ego's frame as the scene measures it: the
//! ego on the ramp on the right, the through lane on its left, the lane
//! cars placed by their position relative to the ego (centre to centre),
//! the merge point (where the ego's body starts to overlap the lane) and
//! the ramp's end at the scene's distances ahead.

use super::{Canvas, Drawing, Heading, MARKING, ROAD, View, ZONE};
use crate::observation::Observation;

/// A lane's width (m); the through lane is centred on 0.
const LANE: f64 = 3.5;

pub(super) const DRAWING: Drawing = Drawing { view: View { centre_m: (1.75, 12.0), px_per_m: 6.0 }, draw };

fn draw(obs: &Observation, c: &mut Canvas) {
    let place = obs.scene.place();
    let (to_merge, ramp_left) = (place[0], place[1]);
    let (lane_right, ramp_right) = (0.5 * LANE, 1.5 * LANE);
    c.rect((-0.5 * LANE, -100.0), (lane_right, 100.0), ROAD);
    // The ramp at full width up to the merge point, then narrowing to its
    // end.
    c.rect((lane_right, -100.0), (ramp_right, to_merge), ROAD);
    if ramp_left > to_merge {
        let (a, b) = (c.view.to_px((lane_right, to_merge)), c.view.to_px((ramp_right, to_merge)));
        let tip = c.view.to_px((lane_right, ramp_left));
        c.polygon(&[a, b, tip], ROAD);
    }
    c.line((lane_right, -100.0), (lane_right, to_merge), MARKING, 2.0, None);
    c.line((lane_right - 0.3, to_merge), (ramp_right, to_merge), ZONE, 3.0, None);
    c.line((lane_right, ramp_left), (ramp_right, ramp_left), "#b03020", 3.0, None);
    c.ego((LANE, 0.0), Heading::Up, obs.ego.speed_mps);
    let labels = obs.scenario().track_labels();
    for (k, (track, label)) in obs.scene.tracks().iter().zip(labels).enumerate() {
        c.road_user(k, label.now, track, Some(Heading::Up), |rel| (0.0, rel), (0.0, 1.0));
    }
}
