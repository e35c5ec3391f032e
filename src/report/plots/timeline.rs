//! Maneuver timelines across models (the paper's caution-failure figure):
//! for one (scenario, tier, seed), each model's maneuver strip, one row per
//! model in leaderboard order on one time axis, the outcome marked at the
//! end of each row. One figure per (scenario, tier, seed) the trajectory
//! figures draw (see [`crate::report::pick`]).

use super::trajectory::{Scale, maneuver_legend, maneuver_strip, time_axis};
use super::{COLLISION_COLOR, INK, Plot, PlotInput, SUCCESS_COLOR, Svg, TIMEOUT_COLOR};
use crate::episode::Outcome;
use crate::report::pick::Timeline;

/// Rows: first top, height, pitch (px).
const ROW_TOP: f64 = 50.0;
const ROW_H: f64 = 20.0;
const ROW_PITCH: f64 = 30.0;
/// The strips' time axis (x) at the least: model names left of it,
/// outcomes right; it starts later and ends earlier when the names and
/// outcomes need the room at the style's text size.
const STRIP_X: (f64, f64) = (214.0, 780.0);
const WIDTH: f64 = 940.0;

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    input.timelines.iter().map(|t| plot(input, t)).collect()
}

pub(crate) fn outcome_color(o: Outcome) -> &'static str {
    match o {
        Outcome::Success => SUCCESS_COLOR,
        Outcome::Collision => COLLISION_COLOR,
        Outcome::Timeout => TIMEOUT_COLOR,
    }
}

fn plot(input: &PlotInput, tl: &Timeline) -> Plot {
    let series = input.series();
    let rows = tl.rows.len().max(1) as f64;
    let bottom = ROW_TOP + rows * ROW_PITCH - (ROW_PITCH - ROW_H);
    let height = bottom + 76.0;
    let mut svg = Svg::new(WIDTH, height, input.style);
    let rollout = if tl.rollout > 0 { format!(" rollout {}", tl.rollout) } else { String::new() };
    let title = format!("Maneuvers per model · {} tier {} seed {}{rollout}", tl.scenario, tl.tier, tl.seed);
    svg.title(10.0, 20.0, &title, 13.0, 24.0);
    let t_end = tl
        .rows
        .iter()
        .flatten()
        .map(|l| {
            let traj_end = l.record.trajectory.as_deref().and_then(|t| t.last()).map_or(0.0, |p| p.time_s);
            traj_end.max(l.record.turns.len() as f64 * 0.5)
        })
        .fold(0.5, f64::max);
    let style = svg.style();
    let widest_name = series.iter().map(|s| style.text_width(&s.name, 11.0)).fold(0.0, f64::max);
    let widest_mark = style.text_width("collision (rollout 10)", 10.0);
    let st =
        Scale::new(0.0, t_end, STRIP_X.0.max(26.0 + widest_name + 12.0), STRIP_X.1.min(WIDTH - 26.0 - widest_mark));
    time_axis(&mut svg, &st, ROW_TOP - 6.0, bottom + 4.0);
    for (m, row) in tl.rows.iter().enumerate() {
        let y0 = ROW_TOP + m as f64 * ROW_PITCH;
        let label = &input.data.models[m].label;
        let drawn = series.iter().find(|s| &s.label == label);
        let (shown, color, shape) = drawn.map_or((label.as_str(), INK, 0), |s| (s.name.as_str(), s.color, s.shape));
        svg.marker(shape, 16.0, y0 + ROW_H / 2.0, 4.5, color, INK, Some(label));
        svg.text_tip(26.0, y0 + ROW_H / 2.0 + 4.0, shown, 11.0, "start", label);
        let Some(l) = row else {
            svg.text(st.p0 + 4.0, y0 + ROW_H / 2.0 + 4.0, "no episode of this seed", 10.0, "start", " fill=\"#777\"");
            continue;
        };
        let r = &l.record;
        let end = maneuver_strip(&mut svg, r, &st, (y0, y0 + ROW_H), &format!("{label}: "));
        let other = if r.rollout != tl.rollout { format!(" (rollout {})", r.rollout) } else { String::new() };
        let mark = format!("{}{other}", r.outcome.name());
        let tip = format!("{label}: {} after {} turns, reward {:.2}", r.outcome.name(), r.turns.len(), r.reward);
        svg.circle(end + 10.0, y0 + ROW_H / 2.0, 6.0, outcome_color(r.outcome), INK, Some(&tip));
        svg.text(end + 20.0, y0 + ROW_H / 2.0 + 4.0, &mark, 10.0, "start", "");
    }
    let ly = height - 14.0;
    let mut lx = maneuver_legend(&mut svg, 10.0, ly);
    // Outcomes are circles, apart from the maneuvers' squares (success and proceed are both green).
    for o in [Outcome::Success, Outcome::Collision, Outcome::Timeout] {
        svg.circle(lx + 6.0, ly - 4.0, 6.0, outcome_color(o), INK, None);
        svg.text(lx + 16.0, ly, o.name(), 11.0, "start", "");
        lx += 16.0 + svg.style().text_width(o.name(), 11.0) + 14.0;
    }
    let disposition = tl.rows.iter().flatten().next().map_or(String::new(), |l| l.record.disposition.to_string());
    let caption = format!(
        "Each model's maneuver at every turn of {} tier {} seed {} (hidden disposition: {disposition}), one row per \
         model in leaderboard order, on one time axis (s); the circle and label at the end of a row are \
         the episode's outcome. Rollout {} where a model has it, else its lowest (named). Black bar: a parse error \
         (conservative stop).",
        tl.scenario, tl.tier, tl.seed, tl.rollout
    );
    let name = format!("timeline_{}_t{}_s{}_r{}", tl.scenario, tl.tier, tl.seed, tl.rollout);
    Plot { name, title: title.clone(), caption, svg: svg.finish(&title) }
}
