//! Trajectory views of chosen episodes: a plan view (top-down paths), the
//! road users' positions along their paths and their speeds over time, and
//! the ego's maneuver timeline. One episode per (model, scenario) in scope:
//! the first collision by seed, else the first timeout, else the first
//! success, among the episodes whose transcripts were read.

use super::{GRID, INK, Plot, PlotInput, Svg, n};
use crate::episode::{Outcome, TrajectoryPoint};
use crate::report::drill::Loaded;
use crate::rundir::record::RolloutRecord;
use crate::scenario::ScenarioKind;
use crate::scenario::pedestrian_feint::{PATH_FAR, PATH_NEAR};

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

fn outcome_rank(o: Outcome) -> u8 {
    match o {
        Outcome::Collision => 0,
        Outcome::Timeout => 1,
        Outcome::Success => 2,
    }
}

/// The episodes drawn: one per (model, scenario) in the leaderboard scope.
pub(crate) fn chosen_episodes<'a>(input: &PlotInput<'a>) -> Vec<&'a Loaded> {
    let lb = input.leaderboard;
    let mut out = Vec::new();
    for label in input.models() {
        let Some(m) = input.data.models.iter().position(|d| d.label == label) else { continue };
        for &s in &lb.scenarios {
            let best = input
                .transcripts
                .iter()
                .filter(|l| {
                    l.model == m
                        && l.record.scenario == s
                        && lb.tiers.contains(&l.record.tier)
                        && l.record.trajectory.as_ref().is_some_and(|t| !t.is_empty())
                })
                .min_by_key(|l| (outcome_rank(l.record.outcome), l.record.tier, l.record.seed, l.record.rollout));
            out.extend(best);
        }
    }
    out
}

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    let series = input.series();
    chosen_episodes(input)
        .into_iter()
        .map(|l| {
            let label = &input.data.models[l.model].label;
            let shown = series.iter().find(|s| &s.label == label).map_or(label.as_str(), |s| s.name.as_str());
            plot(label, shown, l)
        })
        .collect()
}

/// Along-path coordinates (ego, others) at one trajectory point.
fn along(scenario: ScenarioKind, agents: &[crate::scenario::world::PlanPoint]) -> (f64, Vec<f64>) {
    let axes = scenario.plan_axes();
    let ego = agents.first().map_or(0.0, |a| axes.along(a, true));
    (ego, agents.iter().skip(1).map(|a| axes.along(a, false)).collect())
}

struct Scale {
    lo: f64,
    hi: f64,
    p0: f64,
    p1: f64,
}

impl Scale {
    fn new(lo: f64, hi: f64, p0: f64, p1: f64) -> Scale {
        let (lo, hi) = if hi - lo < 1e-9 { (lo - 1.0, hi + 1.0) } else { (lo, hi) };
        Scale { lo, hi, p0, p1 }
    }
    fn at(&self, v: f64) -> f64 {
        self.p0 + (v - self.lo) / (self.hi - self.lo) * (self.p1 - self.p0)
    }
}

fn nice_step(span: f64) -> f64 {
    let raw = span / 4.0;
    let mag = 10f64.powf(raw.abs().max(1e-9).log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|k| k * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag)
}

/// Horizontal grid lines with labels on the left (`right`: on the right).
fn y_ticks(svg: &mut Svg, s: &Scale, x0: f64, x1: f64, right: bool) {
    let step = nice_step(s.hi - s.lo);
    let mut v = (s.lo / step).ceil() * step;
    while v <= s.hi + 1e-9 {
        let y = s.at(v);
        if !right {
            svg.line(x0, y, x1, y, GRID, 1.0, None);
            svg.text(x0 - 4.0, y + 3.5, &n(v), 9.5, "end", "");
        } else {
            svg.text(x1 + 4.0, y + 3.5, &n(v), 9.5, "start", &format!(" fill=\"{OTHER}\""));
        }
        v += step;
    }
}

/// What every panel of one episode's figure reads.
struct Figure<'a> {
    record: &'a RolloutRecord,
    trajectory: &'a [TrajectoryPoint],
    /// Road users other than the ego (the most any point has).
    others: usize,
    /// The first other road user's name.
    other_name: &'static str,
}

impl Figure<'_> {
    /// The figure's time span (s): the trajectory or the turns, at least 0.5.
    fn t_end(&self) -> f64 {
        self.trajectory.last().map_or(1.0, |p| p.time_s).max(self.record.turns.len() as f64 * 0.5).max(0.5)
    }
}

fn other_name(scenario: ScenarioKind) -> &'static str {
    scenario.plan_axes().other_name
}

/// What position 0 along the paths is.
fn zero_label(scenario: ScenarioKind) -> &'static str {
    scenario.plan_axes().zero_label
}

fn agent_color(k: usize) -> &'static str {
    if k == 0 { OTHER } else { FOLLOWER }
}

/// The figure of one episode: title, plan view on the left; positions,
/// speeds and maneuvers over a shared time axis on the right; legend.
fn plot(model: &str, shown: &str, l: &Loaded) -> Plot {
    let r = &l.record;
    let trajectory = r.trajectory.as_deref().unwrap_or(&[]);
    let fig = Figure {
        record: r,
        trajectory,
        others: trajectory.iter().map(|p| p.agents.len().saturating_sub(1)).max().unwrap_or(0),
        other_name: other_name(r.scenario),
    };
    let (w, h) = (940.0, 420.0);
    let mut svg = Svg::new(w, h);
    let title = format!(
        "{shown} · {} tier {} seed {}{}: {} {}, {}",
        r.scenario,
        r.tier,
        r.seed,
        if r.rollout > 0 { format!(" rollout {}", r.rollout) } else { String::new() },
        r.disposition,
        fig.other_name,
        r.outcome.name()
    );
    svg.text(10.0, 20.0, &title, 13.0, "start", " font-weight=\"bold\"");
    plan_view(&mut svg, &fig);
    let (tx0, tx1) = (370.0, 890.0);
    let t_end = fig.t_end();
    let st = Scale::new(0.0, t_end, tx0, tx1);
    positions(&mut svg, &fig, &st);
    speeds(&mut svg, &fig, &st);
    maneuvers(&mut svg, &fig, &st);
    time_axis(&mut svg, &st);
    legend(&mut svg, &fig, h - 14.0);
    let name = format!(
        "trajectory_{}_{}_t{}_s{}_r{}",
        crate::eval::config::sanitize_name(model),
        r.scenario,
        r.tier,
        r.seed,
        r.rollout
    );
    Plot { name, title: title.clone(), caption: caption(model, &fig), svg: svg.finish(&title) }
}

/// Top-down paths at equal aspect: the others dashed, the ego solid, an
/// open circle at each start, an X at a collision.
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
    for k in 0..fig.others {
        let path: Vec<(f64, f64)> =
            traj.iter().filter_map(|p| p.agents.get(k + 1)).map(|a| (sx.at(a.x), sy.at(a.y))).collect();
        svg.polyline(&path, agent_color(k), 2.0, Some("6 3"));
        for &(x, y) in &path {
            svg.circle(x, y, 1.6, agent_color(k), "none", None);
        }
        if let Some(&(x, y)) = path.first() {
            svg.circle(x, y, 4.0, "#fff", agent_color(k), None);
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

/// Positions along the paths over time. The pedestrian's lateral offset
/// has its own axis on the right; other scenarios share one axis.
fn positions(svg: &mut Svg, fig: &Figure, st: &Scale) {
    let r = fig.record;
    let (tx0, tx1) = (st.p0, st.p1);
    let (ay0, ay1) = (44.0, 164.0);
    let series: Vec<(f64, f64, Vec<f64>)> = fig
        .trajectory
        .iter()
        .map(|p| {
            let (e, o) = along(r.scenario, &p.agents);
            (p.time_s, e, o)
        })
        .collect();
    let shared_axis = r.scenario.plan_axes().shared_axis;
    let mut lo = series.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let mut hi = series.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
    if shared_axis {
        for s in &series {
            for &v in &s.2 {
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
    y_ticks(svg, &sa, tx0, tx1, false);
    svg.line(tx0, sa.at(0.0), tx1, sa.at(0.0), INK, 1.0, Some("4 3"));
    svg.text(tx0 + 4.0, sa.at(0.0) - 3.0, zero_label(r.scenario), 9.0, "start", " fill=\"#555\"");
    axis_label(svg, tx0 - 36.0, (ay0 + ay1) / 2.0, "position (m)");
    let ego_pos: Vec<(f64, f64)> = series.iter().map(|s| (st.at(s.0), sa.at(s.1))).collect();
    svg.polyline(&ego_pos, EGO, 2.2, None);
    if fig.others == 0 {
        return;
    }
    let so = if shared_axis {
        Scale::new(sa.lo, sa.hi, ay1, ay0)
    } else {
        let vals: Vec<f64> = series.iter().flat_map(|s| s.2.iter().copied()).collect();
        pedestrian_axis(svg, &vals, tx0, tx1, (ay0, ay1))
    };
    for k in 0..fig.others {
        let pts: Vec<(f64, f64)> = series.iter().filter_map(|s| s.2.get(k).map(|&v| (st.at(s.0), so.at(v)))).collect();
        svg.polyline(&pts, agent_color(k), 2.0, Some("6 3"));
    }
}

/// A vertical axis title, rotated, centred at (x, y).
fn axis_label(svg: &mut Svg, x: f64, y: f64, label: &str) {
    svg.text(x, y, label, 10.0, "middle", &format!(" transform=\"rotate(-90 {} {})\"", n(x), n(y)));
}

/// The pedestrian's own axis (lateral offset from the ego's lane centre,
/// on the right) with the band where it is in the ego's path.
fn pedestrian_axis(svg: &mut Svg, vals: &[f64], tx0: f64, tx1: f64, (ay0, ay1): (f64, f64)) -> Scale {
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min).min(-2.0);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max).max(2.0);
    let so = Scale::new(lo, hi, ay1, ay0);
    y_ticks(svg, &so, tx0, tx1, true);
    // In the ego's path: within half a car and half a pedestrian of the lane centre.
    let half = 0.5 * (PATH_FAR - PATH_NEAR);
    let band = (so.at(half.min(so.hi)), so.at((-half).max(so.lo)));
    svg.rect(tx0, band.0, tx1 - tx0, band.1 - band.0, OTHER, " fill-opacity=\"0.08\"");
    svg.text(tx1 - 4.0, band.0 + 11.0, "pedestrian in the ego's path", 9.0, "end", &format!(" fill=\"{OTHER}\""));
    svg.text(
        tx1 + 34.0,
        (ay0 + ay1) / 2.0,
        "pedestrian from lane centre (m)",
        10.0,
        "middle",
        &format!(" fill=\"{OTHER}\" transform=\"rotate(90 {} {})\"", n(tx1 + 34.0), n((ay0 + ay1) / 2.0)),
    );
    so
}

/// Every road user's speed over time.
fn speeds(svg: &mut Svg, fig: &Figure, st: &Scale) {
    let traj = fig.trajectory;
    let (tx0, tx1) = (st.p0, st.p1);
    let (vy0, vy1) = (184.0, 294.0);
    let vmax = traj.iter().flat_map(|p| p.agents.iter().map(|a| a.v)).fold(1.0, f64::max);
    let sv = Scale::new(0.0, vmax * 1.05, vy1, vy0);
    svg.rect(tx0, vy0, tx1 - tx0, vy1 - vy0, "#fafafa", "");
    y_ticks(svg, &sv, tx0, tx1, false);
    axis_label(svg, tx0 - 36.0, (vy0 + vy1) / 2.0, "speed (m/s)");
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

/// Top of the maneuver strip, bottom of the maneuver strip (y).
const MANEUVER_Y: (f64, f64) = (312.0, 334.0);

/// The ego's maneuver each turn, coloured; parse errors marked above.
fn maneuvers(svg: &mut Svg, fig: &Figure, st: &Scale) {
    let (my0, my1) = MANEUVER_Y;
    let t_end = fig.t_end();
    svg.text(st.p0 - 6.0, my1 - 6.0, "maneuver", 10.0, "end", "");
    for (i, t) in fig.record.turns.iter().enumerate() {
        let t0 = fig.trajectory.get(i).map_or(i as f64 * 0.5, |p| p.time_s);
        let (x0, x1) = (st.at(t0), st.at((t0 + 0.5).min(t_end.max(t0 + 0.5))));
        let name = t.action.maneuver.name();
        let tip = format!(
            "turn {} ({} s): {} {:.2}{}",
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
    }
}

/// Vertical grid lines through every right-hand panel, labelled below.
fn time_axis(svg: &mut Svg, st: &Scale) {
    let (ay0, my1) = (44.0, MANEUVER_Y.1);
    let t_end = st.hi;
    let step = nice_step(t_end);
    let mut tv = 0.0;
    while tv <= t_end + 1e-9 {
        let x = st.at(tv);
        svg.line(x, ay0, x, my1, GRID, 0.6, None);
        svg.text(x, my1 + 14.0, &n(tv), 9.5, "middle", "");
        tv += step;
    }
    svg.text((st.p0 + st.p1) / 2.0, my1 + 28.0, "time (s)", 10.0, "middle", "");
}

fn legend(svg: &mut Svg, fig: &Figure, ly: f64) {
    let mut lx = 40.0;
    svg.line(lx, ly - 4.0, lx + 20.0, ly - 4.0, EGO, 2.5, None);
    svg.text(lx + 24.0, ly, "ego", 11.0, "start", "");
    lx += 60.0;
    for k in 0..fig.others {
        lx += svg.legend_item(lx, ly, agent_color(k), if k == 0 { fig.other_name } else { "following car" }, true);
    }
    for m in ["proceed", "nudge_forward", "yield", "stop"] {
        lx += svg.legend_item(lx, ly, maneuver_color(m), m, false);
    }
    svg.line(lx, ly - 4.0, lx + 16.0, ly - 4.0, INK, 2.5, None);
    svg.text(lx + 20.0, ly, "parse error", 11.0, "start", "");
}

fn caption(model: &str, fig: &Figure) -> String {
    let r = fig.record;
    format!(
        "{model} on {} tier {} seed {} (hidden disposition: {}; outcome: {}; reward {:.2}; decision correctness \
         {:.2}). Left: top-down paths (ego solid, {} dashed; open circle = start{}). Right: positions along the \
         paths and speeds over time, and the ego's maneuver each turn.",
        r.scenario,
        r.tier,
        r.seed,
        r.disposition,
        r.outcome.name(),
        r.reward,
        r.decision_correctness,
        fig.other_name,
        if r.outcome == Outcome::Collision { ", X = collision" } else { "" }
    )
}
