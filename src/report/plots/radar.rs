//! A radar per model over the scenarios (small multiples): the model's
//! success on each axis, with the expert ceiling and the `always_proceed`
//! floor polygons. With fewer than three scenarios in scope the axes are
//! the (scenario, tier) cells instead; with fewer than three of those there
//! is no radar.

use super::{CEILING_COLOR, FLOOR_COLOR, GRID, INK, Plot, PlotInput, Style, Svg};
use crate::export::f2;
use crate::report::reference::{CEILING, FLOOR};
use crate::scenario::{ScenarioKind, Tier};

struct Axis {
    label: String,
    scenario: ScenarioKind,
    tiers: Vec<Tier>,
}

/// The radar's axes: the leaderboard's scenarios, else the (scenario, tier)
/// cells of the per-tier table.
fn axes(input: &PlotInput) -> Vec<Axis> {
    let lb = input.leaderboard;
    let mut axes: Vec<Axis> =
        lb.scenarios.iter().map(|&s| Axis { label: s.to_string(), scenario: s, tiers: lb.tiers.clone() }).collect();
    if axes.len() < 3 {
        axes = ScenarioKind::ALL
            .into_iter()
            .flat_map(|s| Tier::ALL.into_iter().map(move |t| (s, t)))
            .filter(|(s, t)| input.tiers.iter().any(|r| r.scenario == *s && r.tier == *t))
            .map(|(s, t)| Axis { label: format!("{s} t{t}"), scenario: s, tiers: vec![t] })
            .collect();
    }
    axes
}

/// A model's success on one axis.
fn value_of(input: &PlotInput, model: &str, a: &Axis) -> Option<f64> {
    let lb = input.leaderboard;
    if a.tiers == lb.tiers {
        let r = lb.rows.iter().find(|r| r.model == model)?;
        let i = lb.scenarios.iter().position(|&s| s == a.scenario)?;
        r.scenarios[i].as_ref().map(|c| c.success.estimate)
    } else {
        input
            .tiers
            .iter()
            .find(|r| r.model == model && r.scenario == a.scenario && r.tier == a.tiers[0])
            .map(|r| r.metrics.success.estimate)
    }
}

pub(crate) fn plot(input: &PlotInput) -> Option<Plot> {
    let st = input.style;
    let axes = axes(input);
    if axes.len() < 3 {
        return None;
    }
    let models = input.series();
    // A paper's larger axis labels need wider cells: two columns, and
    // labels broken into words (below).
    let paper = st == Style::Paper;
    let sp = |x: f64| st.space(x);
    let (cell_w, cell_h, cols) = if paper { (420.0, 250.0, 2usize) } else { (300.0, 250.0, 3usize) };
    let rows = models.len().div_ceil(cols).max(1);
    let width = cell_w * cols.min(models.len().max(1)) as f64;
    let top = sp(58.0);
    let mut svg = Svg::new(width.max(sp(420.0)), top + rows as f64 * cell_h, st);
    let title = "Success radar per model";
    svg.title(10.0, 20.0, title, 14.0, sp(24.0));
    let mut lx = 10.0;
    lx += svg.legend_item(lx, sp(42.0), CEILING_COLOR, "expert ceiling (reference)", true);
    svg.legend_item(lx, sp(42.0), FLOOR_COLOR, "always_proceed floor (reference)", true);
    let k = axes.len();
    let line_h = st.font(9.5) * 1.1;
    for (i, m) in models.iter().enumerate() {
        let cx = (i % cols) as f64 * cell_w + cell_w / 2.0;
        let cy = top + (i / cols) as f64 * cell_h + cell_h / 2.0 + sp(14.0);
        let radius = 82.0;
        let point = |j: usize, v: f64| {
            let angle = -std::f64::consts::FRAC_PI_2 + j as f64 * std::f64::consts::TAU / k as f64;
            (cx + radius * v.clamp(0.0, 1.0) * angle.cos(), cy + radius * v.clamp(0.0, 1.0) * angle.sin())
        };
        for ring in [0.25, 0.5, 0.75, 1.0] {
            let pts: Vec<(f64, f64)> = (0..k).map(|j| point(j, ring)).collect();
            svg.polygon(&pts, "none", 0.0, GRID, None);
        }
        for (j, a) in axes.iter().enumerate() {
            let (ex, ey) = point(j, 1.0);
            svg.line(cx, cy, ex, ey, GRID, 1.0, None);
            let (lx, ly) = point(j, 1.1);
            let (anchor, dx, dy) = if (lx - cx).abs() < 8.0 {
                ("middle", 0.0, if ly < cy { -4.0 } else { 12.0 })
            } else if lx > cx {
                ("start", 4.0, 4.0)
            } else {
                ("end", -4.0, 4.0)
            };
            if paper {
                // One word a line, the block centred on the axis end.
                let words: Vec<&str> = a.label.split(['_', ' ']).collect();
                let block = line_h * (words.len() as f64 - 1.0);
                let first = match (anchor, dy < 0.0) {
                    ("middle", true) => ly + dy - block,
                    ("middle", false) => ly + sp(dy),
                    _ => ly + dy - block / 2.0,
                };
                for (w, word) in words.iter().enumerate() {
                    svg.text(lx + dx, first + w as f64 * line_h, word, 9.5, anchor, "");
                }
                continue;
            }
            let label = if st.text_width(&a.label, 9.5) > 120.0 { a.label.replace('_', " ") } else { a.label.clone() };
            svg.text(lx + dx, ly + dy, &label, 9.5, anchor, "");
        }
        for (policy, color) in [(CEILING, CEILING_COLOR), (FLOOR, FLOOR_COLOR)] {
            let vals: Option<Vec<f64>> =
                axes.iter().map(|a| input.refs.success(policy, a.scenario, &a.tiers)).collect();
            if let Some(vals) = vals {
                let pts: Vec<(f64, f64)> = vals.iter().enumerate().map(|(j, &v)| point(j, v)).collect();
                svg.polygon(&pts, "none", 0.0, color, Some("5 3"));
            }
        }
        let vals: Vec<Option<f64>> = axes.iter().map(|a| value_of(input, &m.label, a)).collect();
        let pts: Vec<(f64, f64)> = vals.iter().enumerate().map(|(j, v)| point(j, v.unwrap_or(0.0))).collect();
        svg.polygon(&pts, m.color, 0.25, m.color, None);
        for (j, v) in vals.iter().enumerate() {
            if let Some(v) = v {
                let (px, py) = pts[j];
                let tip = format!("{}, {}: {}", m.label, axes[j].label, f2(*v));
                svg.marker(m.shape, px, py, 3.0, m.color, INK, Some(&tip));
            }
        }
        // Names are shortened to fit the cell, so panel titles never overlap.
        // Above the top axis's label (several lines in a paper).
        let above = if paper { line_h * (axes[0].label.split(['_', ' ']).count() as f64 - 1.0) } else { 0.0 };
        svg.text_tip(cx, cy - radius - sp(26.0) - above, &m.name, 12.0, "middle", &m.label);
    }
    Some(Plot {
        name: "radar".into(),
        title: title.into(),
        caption: "Each model's success on every scenario (rings at 0.25, 0.5, 0.75, 1). Skill is scenario-specific: \
                  shapes that cross the floor polygon on one axis and reach the ceiling on another carry a temperament, \
                  not a calibrated policy."
            .into(),
        svg: svg.finish(title),
    })
}
