//! Success against decision correctness, one point per (model, scenario),
//! with the diagonal "decisions convert to outcomes". Points below it are
//! right calls that did not become successes. Overplotted points are
//! translucent, jittered by a few pixels and counted ("×n").

use super::{CEILING_COLOR, FLOOR_COLOR, GRID, INK, Plot, PlotInput, Series, Svg, rate_axis_y};
use crate::export::f2;
use crate::report::reference::{CEILING, FLOOR};
use crate::report::tables::tiers_label;

pub(crate) fn plot(input: &PlotInput) -> Plot {
    let st = input.style;
    let lb = input.leaderboard;
    let models = input.series();
    // Lengths that hold text grow with it (paper style).
    let v = |x: f64| st.space(x);
    let (left, top, size) = (v(56.0), v(40.0), 340.0);
    let legend_w = models.iter().map(|m| st.text_width(&m.name, 11.0)).fold(v(140.0), f64::max) + v(40.0);
    let mut svg = Svg::new(left + size + 30.0 + legend_w, top + size + v(60.0), st);
    let title = format!("Success vs decision correctness ({})", tiers_label(&lb.tiers));
    svg.title(10.0, 20.0, &title, 14.0, 24.0);
    frame(&mut svg, left, top, size);
    points(&mut svg, input, &models, left, top, size);
    legend(&mut svg, input, &models, left + size + 24.0, top + 6.0);
    Plot {
        name: "success_vs_correctness".into(),
        title: title.clone(),
        caption: "Each point is a model on a scenario: x its decision correctness, y its success. On the diagonal, right \
                  calls become successes; below it, the model made the right call but failed the episode (typically \
                  by stalling into a timeout); above it, it succeeded despite wrong calls (luck or a forgiving opponent)."
            .into(),
        svg: svg.finish(&title),
    }
}

/// Both rate axes, their labels and the diagonal.
fn frame(svg: &mut Svg, left: f64, top: f64, size: f64) {
    let st = svg.style();
    let v = |x: f64| st.space(x);
    rate_axis_y(svg, top, size, left, left + size);
    for k in 0..=4 {
        let v = f64::from(k) / 4.0;
        let x = left + v * size;
        svg.line(x, top, x, top + size, GRID, 1.0, None);
        svg.text(x, top + size + st.space(14.0), &format!("{v}"), 10.0, "middle", "");
    }
    svg.line(left, top + size, left + size, top, INK, 1.2, Some("6 4"));
    // The diagonal's label sits above the plot area, at the diagonal's end,
    // where no point can be.
    svg.text(left + size - 14.0, top - v(8.0), "dashed: success = correctness", 10.0, "end", " fill=\"#555\"");
    svg.text(left + size / 2.0, top + size + v(32.0), "decision correctness", 11.0, "middle", "");
    svg.text_up(v(14.0), top + size / 2.0, "success", 11.0);
}

/// Marker shapes tell scenarios apart while the colours tell the models
/// apart (up to 7); beyond that the shapes are the models'.
fn shape_is_scenario(models: &[Series]) -> bool {
    models.iter().all(|m| m.shape == 0)
}

/// The reference policies (hollow), then every model on every scenario
/// (colour: model, shape: scenario).
fn points(svg: &mut Svg, input: &PlotInput, models: &[Series], left: f64, top: f64, size: f64) {
    let lb = input.leaderboard;
    let at = |dc: f64, s: f64| (left + dc.clamp(0.0, 1.0) * size, top + size - s.clamp(0.0, 1.0) * size);
    // Reference policies, hollow.
    for (policy, color) in [(CEILING, CEILING_COLOR), (FLOOR, FLOOR_COLOR)] {
        for (k, s) in lb.scenarios.iter().enumerate() {
            if let (Some(sr), Some(dc)) =
                (input.refs.success(policy, *s, &lb.tiers), input.refs.correctness(policy, *s, &lb.tiers))
            {
                let (x, y) = at(dc, sr);
                let tip = format!("{policy} on {s}: success {}, correctness {}", f2(sr), f2(dc));
                svg.marker(k, x, y, 5.0, "none", color, Some(&tip));
            }
        }
    }
    let by_scenario = shape_is_scenario(models);
    // Overplotted points stay visible: translucent, jittered a little
    // (deterministically), and each group of overlapping points counted.
    let mut placed = Vec::new();
    svg.open_group("fill-opacity=\"0.7\"");
    for (i, r) in lb.rows.iter().enumerate() {
        for (k, c) in r.scenarios.iter().enumerate() {
            let Some(c) = c else { continue };
            if !c.decision_correctness.is_finite() || !c.success.estimate.is_finite() {
                continue;
            }
            let (x, y) = at(c.decision_correctness, c.success.estimate);
            let tip = format!(
                "{} on {}: success {}, correctness {}",
                r.model,
                c.scenario,
                f2(c.success.estimate),
                f2(c.decision_correctness)
            );
            let shape = if by_scenario { k } else { models[i].shape };
            let (jx, jy) = super::jitter(&format!("{}/{}", r.model, c.scenario), JITTER);
            svg.marker(shape, x + jx, y + jy, 5.0, models[i].color, INK, Some(&tip));
            placed.push((x, y));
        }
    }
    svg.close_group();
    for ((x, y), count) in super::overlaps(&placed, OVERLAP_RADIUS) {
        if count > 1 {
            svg.text(x + 9.0, y - 7.0, &format!("\u{d7}{count}"), 9.5, "start", " font-weight=\"bold\"");
        }
    }
}

/// Jitter of a model's point, in pixels, each way.
const JITTER: f64 = 3.0;
/// Points closer than this (pixels, before jitter) overplot: about a marker.
const OVERLAP_RADIUS: f64 = 6.0;

/// Models (colour), scenarios (shape), references (hollow), from (lx, y).
fn legend(svg: &mut Svg, input: &PlotInput, models: &[Series], lx: f64, mut y: f64) {
    let st = svg.style();
    let v = |x: f64| st.space(x);
    let by_scenario = shape_is_scenario(models);
    for m in models {
        svg.marker(if by_scenario { 1 } else { m.shape }, lx + 6.0, y - v(4.0), 5.0, m.color, INK, None);
        svg.text_tip(lx + 17.0, y, &m.name, 11.0, "start", &m.label);
        y += v(16.0);
    }
    y += v(8.0);
    for (k, s) in input.leaderboard.scenarios.iter().enumerate().filter(|_| by_scenario) {
        svg.marker(k, lx + 6.0, y - v(4.0), 5.0, "#777", INK, None);
        svg.text(lx + 17.0, y, &s.to_string(), 11.0, "start", "");
        y += v(16.0);
    }
    y += v(8.0);
    svg.text(lx, y, "\u{d7}n: n points overlap", 11.0, "start", "");
    y += v(20.0);
    for (label, color) in [("expert (hollow)", CEILING_COLOR), ("always_proceed (hollow)", FLOOR_COLOR)] {
        svg.circle(lx + 6.0, y - v(4.0), 5.0, "none", color, None);
        svg.text(lx + 17.0, y, label, 11.0, "start", "");
        y += v(16.0);
    }
}
