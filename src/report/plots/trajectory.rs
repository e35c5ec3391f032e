//! Trajectory views of chosen episodes (see [`crate::report::pick`]): a
//! plan view (top-down paths), the road users' positions along their paths
//! (a road user that crosses the ego's road, the pedestrian, in its own
//! panel in the scene text's lateral frame), their speeds over time, and the
//! ego's maneuver timeline. Road users are named by their scenario role.

use super::{GRID, INK, Plot, PlotInput, Svg, n};
use crate::episode::{Outcome, TrajectoryPoint};
use crate::report::drill::Loaded;
use crate::rundir::record::RolloutRecord;
use crate::scenario::{LateralFrame, PlanAxes, ScenarioKind};

const EGO: &str = "#6a3d9a";
const OTHER: &str = "#c0704a";
const FOLLOWER: &str = "#7f7f7f";

pub(crate) fn maneuver_color(name: &str) -> &'static str {
    match name {
        "proceed" => "#2e7d32",
        "nudge_forward" => "#f9a825",
        "yield" => "#ef6c00",
        _ => "#c62828",
    }
}

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    let series = input.series();
    input
        .trajectories
        .iter()
        .map(|l| {
            let label = &input.data.models[l.model].label;
            let shown = series.iter().find(|s| &s.label == label).map_or(label.as_str(), |s| s.name.as_str());
            plot(label, shown, l, input.style)
        })
        .collect()
}

/// Along-path coordinates (ego, others) at one trajectory point.
fn along(scenario: ScenarioKind, agents: &[crate::scenario::world::PlanPoint]) -> (f64, Vec<f64>) {
    let axes = scenario.plan_axes();
    let ego = agents.first().map_or(0.0, |a| axes.along(a, true));
    (ego, agents.iter().skip(1).map(|a| axes.along(a, false)).collect())
}

/// A linear map from values `lo..hi` to pixels `p0..p1`.
pub(crate) struct Scale {
    pub lo: f64,
    pub hi: f64,
    pub p0: f64,
    pub p1: f64,
}

impl Scale {
    pub(crate) fn new(lo: f64, hi: f64, p0: f64, p1: f64) -> Scale {
        let (lo, hi) = if hi - lo < 1e-9 { (lo - 1.0, hi + 1.0) } else { (lo, hi) };
        Scale { lo, hi, p0, p1 }
    }
    pub(crate) fn at(&self, v: f64) -> f64 {
        self.p0 + (v - self.lo) / (self.hi - self.lo) * (self.p1 - self.p0)
    }
}

fn nice_step(span: f64) -> f64 {
    let raw = span / 4.0;
    let mag = 10f64.powf(raw.abs().max(1e-9).log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|k| k * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag)
}

/// Horizontal grid lines with labels on the left.
fn y_ticks(svg: &mut Svg, s: &Scale, x0: f64, x1: f64) {
    let step = nice_step(s.hi - s.lo);
    let mut v = (s.lo / step).ceil() * step;
    while v <= s.hi + 1e-9 {
        let y = s.at(v);
        svg.line(x0, y, x1, y, GRID, 1.0, None);
        svg.text(x0 - 4.0, y + 3.5, &n(v), 9.5, "end", "");
        v += step;
    }
}

/// What every panel of one episode's figure reads.
struct Figure<'a> {
    record: &'a RolloutRecord,
    trajectory: &'a [TrajectoryPoint],
    /// Road users other than the ego (the most any point has).
    others: usize,
    axes: PlanAxes,
}

impl Figure<'_> {
    /// The figure's time span (s): the trajectory or the turns, at least 0.5.
    fn t_end(&self) -> f64 {
        self.trajectory.last().map_or(1.0, |p| p.time_s).max(self.record.turns.len() as f64 * 0.5).max(0.5)
    }

    /// The `k`-th other road user's lateral frame, if it crosses the ego's road.
    fn lateral(&self, k: usize) -> Option<LateralFrame> {
        self.axes.road_users.get(k).and_then(|u| u.lateral)
    }

    /// The other road users drawn on the ego's position axis.
    fn along_users(&self) -> Vec<usize> {
        (0..self.others).filter(|&k| self.lateral(k).is_none()).collect()
    }

    /// The other road users drawn in a lateral panel of their own.
    fn lateral_users(&self) -> Vec<(usize, LateralFrame)> {
        (0..self.others).filter_map(|k| self.lateral(k).map(|f| (k, f))).collect()
    }
}

fn agent_color(k: usize) -> &'static str {
    if k == 0 { OTHER } else { FOLLOWER }
}

/// Vertical extents (top, bottom) of the right-hand panels.
struct Layout {
    positions: (f64, f64),
    /// One per road user in a lateral frame.
    lateral: Vec<(f64, f64)>,
    speeds: (f64, f64),
    maneuvers: (f64, f64),
    height: f64,
}

impl Layout {
    fn new(lateral_panels: usize) -> Layout {
        let positions = (44.0, 164.0);
        let mut y = positions.1 + 22.0;
        let mut lateral = Vec::new();
        for _ in 0..lateral_panels {
            lateral.push((y, y + 110.0));
            y += 132.0;
        }
        let speeds = (y - 2.0, y + 108.0);
        let maneuvers = (speeds.1 + 18.0, speeds.1 + 40.0);
        Layout { positions, lateral, speeds, maneuvers, height: maneuvers.1 + 86.0 }
    }
}

/// Left end and rightmost right end of the time axis; end-of-line labels
/// go right of it (it ends earlier when they need the room).
const TIME_X: (f64, f64) = (370.0, 850.0);

/// The figure of one episode: title, plan view on the left; positions
/// (and each crossing road user's lateral panel), speeds and maneuvers
/// over a shared time axis on the right; legend.
fn plot(model: &str, shown: &str, l: &Loaded, style: super::Style) -> Plot {
    let r = &l.record;
    let trajectory = r.trajectory.as_deref().unwrap_or(&[]);
    let fig = Figure {
        record: r,
        trajectory,
        others: trajectory.iter().map(|p| p.agents.len().saturating_sub(1)).max().unwrap_or(0),
        axes: r.scenario.plan_axes(),
    };
    let layout = Layout::new(fig.lateral_users().len());
    let w = 940.0;
    let mut svg = Svg::new(w, layout.height, style);
    let title = format!(
        "{shown} · {} tier {} seed {}{}: {} {}, {}",
        r.scenario,
        r.tier,
        r.seed,
        if r.rollout > 0 { format!(" rollout {}", r.rollout) } else { String::new() },
        r.disposition,
        fig.axes.role(0),
        r.outcome.name()
    );
    svg.title(10.0, 20.0, &title, 13.0, 24.0);
    plan_view(&mut svg, &fig);
    // Room on the right for the end-of-line labels (roles, the frame's lines, "ego") at the style's size.
    let labels = fig.lateral_users().into_iter().flat_map(|(_, f)| f.marks.map(|m| m.1));
    let labels = labels.chain((0..fig.others).map(|k| fig.axes.road_users.get(k).map_or("road user 10", |u| u.role)));
    let widest = labels.chain(["ego"]).map(|l| svg.style().text_width(l, 9.5)).fold(0.0, f64::max);
    let st = Scale::new(0.0, fig.t_end(), TIME_X.0, TIME_X.1.min(w - 10.0 - widest));
    positions(&mut svg, &fig, &st, layout.positions);
    for ((k, frame), &extent) in fig.lateral_users().into_iter().zip(&layout.lateral) {
        lateral_panel(&mut svg, &fig, &st, k, &frame, extent);
    }
    speeds(&mut svg, &fig, &st, layout.speeds);
    maneuvers(&mut svg, &fig, &st, layout.maneuvers);
    time_axis(&mut svg, &st, layout.positions.0, layout.maneuvers.1);
    legend(&mut svg, &fig, layout.height - 14.0);
    let name = format!(
        "trajectory_{}_{}_t{}_s{}_r{}",
        crate::rundir::sanitize_name(model),
        r.scenario,
        r.tier,
        r.seed,
        r.rollout
    );
    Plot { name, title: title.clone(), caption: caption(model, &fig), svg: svg.finish(&title) }
}

/// Labels placed so that none overlaps an earlier one: each moves by a
/// line (down for end-of-line labels of close curves, up for labels above
/// a path's start, off the path) until it is clear.
struct Labels {
    placed: Vec<(f64, f64, f64)>, // x0, x1, baseline y
    /// +1: move down; -1: move up.
    direction: f64,
}

impl Labels {
    fn new(direction: f64) -> Labels {
        Labels { placed: Vec::new(), direction }
    }

    fn put(&mut self, svg: &mut Svg, x: f64, y: f64, text: &str, color: &str) {
        const SIZE: f64 = 9.5;
        let x1 = x + svg.style().text_width(text, SIZE);
        let drawn = svg.style().font(SIZE);
        let mut y = y;
        while self.placed.iter().any(|&(a0, a1, ay)| a0 < x1 && x < a1 && (ay - y).abs() < drawn + 1.0) {
            y += self.direction * (drawn + 1.0);
        }
        self.placed.push((x, x1, y));
        svg.text(x, y, text, SIZE, "start", &format!(" fill=\"{color}\""));
    }
}

/// Top-down paths at equal aspect: the others dashed, the ego solid, an
/// open circle at each start (labelled with the role), an X at a
/// collision, and the lines of any lateral frame (the kerbs).
fn plan_view(svg: &mut Svg, fig: &Figure) {
    let traj = fig.trajectory;
    let (px0, py0, pw, ph) = (40.0, 44.0, 250.0, 250.0);
    let pts = traj.iter().flat_map(|p| p.agents.iter());
    let (mut xlo, mut xhi, mut ylo, mut yhi) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for a in pts {
        xlo = xlo.min(a.x);
        xhi = xhi.max(a.x);
        ylo = ylo.min(a.y);
        yhi = yhi.max(a.y);
    }
    if !xlo.is_finite() {
        (xlo, xhi, ylo, yhi) = (-1.0, 1.0, -1.0, 1.0);
    }
    let span = (xhi - xlo).max(yhi - ylo).max(10.0) + 8.0;
    let (cx, cy) = ((xlo + xhi) / 2.0, (ylo + yhi) / 2.0);
    let sx = Scale::new(cx - span / 2.0, cx + span / 2.0, px0, px0 + pw);
    let sy = Scale::new(cy - span / 2.0, cy + span / 2.0, py0 + ph, py0);
    svg.rect(px0, py0, pw, ph, "#fafafa", &format!(" stroke=\"{GRID}\""));
    svg.text(px0 + pw / 2.0, py0 + ph + 16.0, "plan view (m); dots every 0.5 s", 10.0, "middle", "");
    if sx.lo < 0.0 && sx.hi > 0.0 {
        svg.line(sx.at(0.0), py0, sx.at(0.0), py0 + ph, GRID, 1.0, Some("2 3"));
    }
    if sy.lo < 0.0 && sy.hi > 0.0 {
        svg.line(px0, sy.at(0.0), px0 + pw, sy.at(0.0), GRID, 1.0, Some("2 3"));
    }
    // A lateral frame's lines (the kerbs) across the plan view, at plan y = value - offset.
    // The lower line's label goes below it, the other's above: the road (and the ego's path) lies between.
    for (_, frame) in fig.lateral_users() {
        let lowest = frame.marks.iter().map(|m| m.0).fold(f64::INFINITY, f64::min);
        for (value, label) in frame.marks {
            let y = value - frame.plan_offset;
            if y > sy.lo && y < sy.hi {
                svg.line(px0, sy.at(y), px0 + pw, sy.at(y), "#9e9e9e", 1.0, Some("5 2"));
                let dy = if value == lowest { 11.0 } else { -3.0 };
                svg.text(px0 + 4.0, sy.at(y) + dy, label, 9.0, "start", " fill=\"#555\"");
            }
        }
    }
    let mut labels = Labels::new(-1.0);
    for k in 0..fig.others {
        let path: Vec<(f64, f64)> =
            traj.iter().filter_map(|p| p.agents.get(k + 1)).map(|a| (sx.at(a.x), sy.at(a.y))).collect();
        svg.polyline(&path, agent_color(k), 2.0, Some("6 3"));
        for &(x, y) in &path {
            svg.circle(x, y, 1.6, agent_color(k), "none", None);
        }
        if let Some(&(x, y)) = path.first() {
            svg.circle(x, y, 4.0, "#fff", agent_color(k), None);
            let role = fig.axes.role(k);
            // Inside the plan view: right of the start, or left of it near the right edge.
            let role_w = svg.style().text_width(&role, 9.5);
            let lx = if x + 7.0 + role_w > px0 + pw { x - 7.0 - role_w } else { x + 7.0 };
            labels.put(svg, lx, (y - 6.0).max(py0 + 10.0), &role, agent_color(k));
        }
    }
    let ego_path: Vec<(f64, f64)> =
        traj.iter().filter_map(|p| p.agents.first()).map(|a| (sx.at(a.x), sy.at(a.y))).collect();
    svg.polyline(&ego_path, EGO, 2.5, None);
    for &(x, y) in &ego_path {
        svg.circle(x, y, 1.8, EGO, "none", None);
    }
    if let Some(&(x, y)) = ego_path.first() {
        svg.circle(x, y, 4.0, "#fff", EGO, None);
    }
    if let Some(&(x, y)) = ego_path.last() {
        if fig.record.outcome == Outcome::Collision {
            svg.line(x - 6.0, y - 6.0, x + 6.0, y + 6.0, "#c62828", 3.0, None);
            svg.line(x - 6.0, y + 6.0, x + 6.0, y - 6.0, "#c62828", 3.0, None);
        } else {
            svg.circle(x, y, 3.5, EGO, INK, None);
        }
    }
}

/// Positions along the paths over time: the ego and the road users whose
/// progress shares its axis (labelled by role at the end of each line).
fn positions(svg: &mut Svg, fig: &Figure, st: &Scale, (ay0, ay1): (f64, f64)) {
    let r = fig.record;
    let (tx0, tx1) = (st.p0, st.p1);
    let along_users = fig.along_users();
    let series: Vec<(f64, f64, Vec<f64>)> = fig
        .trajectory
        .iter()
        .map(|p| {
            let (e, o) = along(r.scenario, &p.agents);
            (p.time_s, e, o)
        })
        .collect();
    let mut lo = series.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let mut hi = series.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
    for s in &series {
        for &k in &along_users {
            if let Some(&v) = s.2.get(k) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if !lo.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    let sa = Scale::new(lo.min(0.0), hi.max(0.0), ay1, ay0);
    svg.rect(tx0, ay0, tx1 - tx0, ay1 - ay0, "#fafafa", "");
    y_ticks(svg, &sa, tx0, tx1);
    svg.line(tx0, sa.at(0.0), tx1, sa.at(0.0), INK, 1.0, Some("4 3"));
    svg.text(tx0 + 4.0, sa.at(0.0) - 3.0, fig.axes.zero_label, 9.0, "start", " fill=\"#555\"");
    let title = if along_users.is_empty() { "ego position (m)" } else { "position (m)" };
    svg.text_up(tx0 - 36.0, (ay0 + ay1) / 2.0, title, 10.0);
    let mut labels = Labels::new(1.0);
    let ego_pos: Vec<(f64, f64)> = series.iter().map(|s| (st.at(s.0), sa.at(s.1))).collect();
    svg.polyline(&ego_pos, EGO, 2.2, None);
    if let Some(&(_, y)) = ego_pos.last() {
        labels.put(svg, tx1 + 4.0, y + 3.5, "ego", EGO);
    }
    for k in along_users {
        let pts: Vec<(f64, f64)> = series.iter().filter_map(|s| s.2.get(k).map(|&v| (st.at(s.0), sa.at(v)))).collect();
        svg.polyline(&pts, agent_color(k), 2.0, Some("6 3"));
        if let Some(&(_, y)) = pts.last() {
            labels.put(svg, tx1 + 4.0, y + 3.5, &fig.axes.role(k), agent_color(k));
        }
    }
}

/// The `k`-th road user's position in its lateral frame (the pedestrian
/// from the near kerb, the numbers the scene text gave the model), with the
/// frame's lines (near and far kerb) and the band where it is in the ego's
/// path.
fn lateral_panel(svg: &mut Svg, fig: &Figure, st: &Scale, k: usize, frame: &LateralFrame, (ly0, ly1): (f64, f64)) {
    let (tx0, tx1) = (st.p0, st.p1);
    let pts: Vec<(f64, f64)> =
        fig.trajectory.iter().filter_map(|p| p.agents.get(k + 1).map(|a| (p.time_s, frame.of(a)))).collect();
    let (m0, m1) = (frame.marks[0].0.min(frame.marks[1].0), frame.marks[0].0.max(frame.marks[1].0));
    let lo = pts.iter().map(|p| p.1).fold(m0 - 1.0, f64::min);
    let hi = pts.iter().map(|p| p.1).fold(m1 + 0.5, f64::max);
    let sl = Scale::new(lo, hi, ly1, ly0);
    let role = fig.axes.role(k);
    svg.rect(tx0, ly0, tx1 - tx0, ly1 - ly0, "#fafafa", "");
    y_ticks(svg, &sl, tx0, tx1);
    let (b0, b1) = (sl.at(frame.in_path.1), sl.at(frame.in_path.0));
    svg.rect(tx0, b0, tx1 - tx0, b1 - b0, agent_color(k), " fill-opacity=\"0.12\"");
    svg.text(
        tx0 + 4.0,
        b0 + 10.0,
        &format!("{role} in the ego's path ({:.1}–{:.1} m)", frame.in_path.0, frame.in_path.1),
        9.0,
        "start",
        &format!(" fill=\"{}\"", agent_color(k)),
    );
    let mut labels = Labels::new(1.0);
    for (value, label) in frame.marks {
        svg.line(tx0, sl.at(value), tx1, sl.at(value), INK, 1.0, Some("4 3"));
        labels.put(svg, tx1 + 4.0, sl.at(value) + 3.5, label, "#555");
    }
    let line: Vec<(f64, f64)> = pts.iter().map(|&(t, v)| (st.at(t), sl.at(v))).collect();
    svg.polyline(&line, agent_color(k), 2.0, Some("6 3"));
    if let Some(&(_, y)) = line.last() {
        labels.put(svg, tx1 + 4.0, y + 3.5, &role, agent_color(k));
    }
    svg.text(tx0, ly0 - 5.0, &format!("{role}, {} (m), as the scene text gives it", frame.measured), 10.0, "start", "");
    svg.text_up(tx0 - 36.0, (ly0 + ly1) / 2.0, "lateral (m)", 10.0);
}

/// Every road user's speed over time.
fn speeds(svg: &mut Svg, fig: &Figure, st: &Scale, (vy0, vy1): (f64, f64)) {
    let traj = fig.trajectory;
    let (tx0, tx1) = (st.p0, st.p1);
    let vmax = traj.iter().flat_map(|p| p.agents.iter().map(|a| a.v)).fold(1.0, f64::max);
    let sv = Scale::new(0.0, vmax * 1.05, vy1, vy0);
    svg.rect(tx0, vy0, tx1 - tx0, vy1 - vy0, "#fafafa", "");
    y_ticks(svg, &sv, tx0, tx1);
    svg.text_up(tx0 - 36.0, (vy0 + vy1) / 2.0, "speed (m/s)", 10.0);
    for k in 0..=fig.others {
        let pts: Vec<(f64, f64)> =
            traj.iter().filter_map(|p| p.agents.get(k).map(|a| (st.at(p.time_s), sv.at(a.v)))).collect();
        if k == 0 {
            svg.polyline(&pts, EGO, 2.2, None);
        } else {
            svg.polyline(&pts, agent_color(k - 1), 2.0, Some("6 3"));
        }
    }
}

/// The ego's maneuver each turn, coloured; parse errors marked above.
fn maneuvers(svg: &mut Svg, fig: &Figure, st: &Scale, (my0, my1): (f64, f64)) {
    svg.text(st.p0 - 6.0, my1 - 6.0, "maneuver", 10.0, "end", "");
    maneuver_strip(svg, fig.record, st, (my0, my1), "");
}

/// One episode's maneuvers as coloured cells over the time scale (turn
/// `i` at its trajectory time, else `i` × 0.5 s), each with a tooltip
/// (`who` first, when given); a parse error is a bar above its cell.
/// Returns the x where the strip ends.
pub(crate) fn maneuver_strip(svg: &mut Svg, r: &RolloutRecord, st: &Scale, (my0, my1): (f64, f64), who: &str) -> f64 {
    let traj = r.trajectory.as_deref().unwrap_or(&[]);
    let mut end = st.p0;
    for (i, t) in r.turns.iter().enumerate() {
        let t0 = traj.get(i).map_or(i as f64 * 0.5, |p| p.time_s);
        let (x0, x1) = (st.at(t0), st.at((t0 + 0.5).min(st.hi.max(t0 + 0.5))));
        let name = t.action.maneuver.name();
        let tip = format!(
            "{who}turn {} ({} s): {} {:.2}{}",
            t.turn,
            n(t0),
            name,
            t.action.acceleration,
            if t.parse_errors.is_empty() { String::new() } else { " — parse error, conservative stop".into() }
        );
        svg.rect_tip(x0, my0, (x1 - x0 - 0.6).max(0.5), my1 - my0, maneuver_color(name), &tip);
        if !t.parse_errors.is_empty() {
            svg.line(x0, my0 - 3.0, x1, my0 - 3.0, INK, 2.5, None);
        }
        end = end.max(x1);
    }
    end
}

/// Vertical grid lines through every right-hand panel, labelled below.
pub(crate) fn time_axis(svg: &mut Svg, st: &Scale, top: f64, bottom: f64) {
    let t_end = st.hi;
    // About six ticks (the value axes' four are too few across a wide time axis).
    let step = nice_step(t_end / 1.5);
    let mut tv = 0.0;
    while tv <= t_end + 1e-9 {
        let x = st.at(tv);
        svg.line(x, top, x, bottom, GRID, 0.6, None);
        svg.text(x, bottom + svg.style().space(14.0), &n(tv), 9.5, "middle", "");
        tv += step;
    }
    let below = svg.style().space(28.0);
    svg.text((st.p0 + st.p1) / 2.0, bottom + below, "time (s)", 10.0, "middle", "");
}

fn legend(svg: &mut Svg, fig: &Figure, ly: f64) {
    let mut lx = 40.0;
    svg.line(lx, ly - 4.0, lx + 20.0, ly - 4.0, EGO, 2.5, None);
    svg.text(lx + 24.0, ly, "ego", 11.0, "start", "");
    lx += 60.0;
    for k in 0..fig.others {
        lx += svg.legend_item(lx, ly, agent_color(k), &fig.axes.role(k), true);
    }
    maneuver_legend(svg, lx, ly);
}

/// The maneuver colours and the parse-error mark, from `lx`; returns the
/// x after the last item.
pub(crate) fn maneuver_legend(svg: &mut Svg, mut lx: f64, ly: f64) -> f64 {
    for m in ["proceed", "nudge_forward", "yield", "stop"] {
        lx += svg.legend_item(lx, ly, maneuver_color(m), m, false);
    }
    svg.line(lx, ly - 4.0, lx + 16.0, ly - 4.0, INK, 2.5, None);
    svg.text(lx + 20.0, ly, "parse error", 11.0, "start", "");
    lx + 20.0 + svg.style().text_width("parse error", 11.0) + 14.0
}

fn caption(model: &str, fig: &Figure) -> String {
    let r = fig.record;
    let roles: Vec<String> = (0..fig.others).map(|k| fig.axes.role(k).into_owned()).collect();
    let lateral: Vec<String> = fig
        .lateral_users()
        .into_iter()
        .map(|(k, f)| {
            format!(
                " The {} has its own panel in the scene text's frame, {} (the numbers the model read), with the {} \
                 and {} and the band where it is in the ego's path.",
                fig.axes.role(k),
                f.measured,
                f.marks[0].1,
                f.marks[1].1
            )
        })
        .collect();
    format!(
        "{model} on {} tier {} seed {} (hidden disposition: {}; outcome: {}; reward {:.2}; decision correctness \
         {:.2}). Left: top-down paths (ego solid, {} dashed; open circle = start{}). Right: positions along the \
         paths and speeds over time, and the ego's maneuver each turn.{}",
        r.scenario,
        r.tier,
        r.seed,
        r.disposition,
        r.outcome.name(),
        r.reward,
        r.decision_correctness,
        if roles.is_empty() { "no other road user".to_string() } else { roles.join(" and ") },
        if r.outcome == Outcome::Collision { ", X = collision" } else { "" },
        lateral.concat()
    )
}
